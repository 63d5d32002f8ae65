/* A small fixed pool of worker threads for data-parallel loops.
 *
 * pl_pool_for(pool, n, fn, ctx) splits [0, n) into one contiguous chunk per thread (the caller
 * runs the first) and returns when all chunks are done. Chunk boundaries depend only on n and the
 * thread count, and kernels compute each item independently, so results never depend on the
 * number of threads. Between loops a waiting thread (worker or caller) spins for up to 100 us,
 * then sleeps on a condition variable: a frame's ~130 back-to-back loops never pay a wake-up,
 * and an idle pool burns no CPU. Nothing is allocated per call. */
#ifndef PL_CORE_THREADS_H
#define PL_CORE_THREADS_H

typedef struct pl_pool pl_pool;
typedef void (*pl_pool_fn)(void *ctx, int begin, int end);

#define PL_MAX_THREADS 64

/* n_threads in 1..PL_MAX_THREADS; 1 makes a pool with no workers (runs in the caller). */
int pl_pool_create(int n_threads, pl_pool **out);
void pl_pool_destroy(pl_pool *pool);
int pl_pool_threads(const pl_pool *pool);
void pl_pool_for(pl_pool *pool, int n, pl_pool_fn fn, void *ctx);

#endif
