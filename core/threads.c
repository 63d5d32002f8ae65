#include "core/threads.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdlib.h>

#include "core/util.h"

/* How long a thread waits actively before it sleeps on a condition variable: a frame runs ~130
 * loops back to back, and waking a sleeping thread costs tens of microseconds (a futex and an
 * inter-processor interrupt, more in a VM). The first SPIN_PAUSE_NS it spins with pause, then
 * it yields the core between checks (a thread it waits for may be queued on the same core when
 * the machine is busy), and after SPIN_NS it sleeps: between frames the workers are asleep. */
#define SPIN_PAUSE_NS 5000
#define SPIN_NS 100000

struct pl_pool {
    int n_threads;
    pthread_t workers[PL_MAX_THREADS];
    pthread_mutex_t mu;
    pthread_cond_t wake, done;
    pl_pool_fn fn; /* the current loop: written before `generation` is bumped */
    void *ctx;
    int n;
    int quit;
    _Alignas(64) atomic_ulong generation; /* bumped for every loop */
    _Alignas(64) atomic_int pending;      /* workers still running the current loop */
};

static void chunk(int n, int parts, int i, int *b, int *e)
{
    *b = (int)((long long)n * i / parts);
    *e = (int)((long long)n * (i + 1) / parts);
}

static inline void cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
    __asm__ __volatile__("yield");
#endif
}

/* One step of an active wait that began at t0 (i counts the steps): 1 while it should go on,
 * 0 when it is time to sleep. */
static int wait_step(int64_t t0, unsigned i)
{
    if (i & 15) {
        cpu_relax();
        return 1;
    }
    const int64_t dt = pl_now_ns() - t0;
    if (dt > SPIN_NS) return 0;
    if (dt > SPIN_PAUSE_NS)
        sched_yield();
    else
        cpu_relax();
    return 1;
}

/* Waits actively while *gen == seen (at most SPIN_NS); returns the last value read. */
static unsigned long spin_while_gen(atomic_ulong *gen, unsigned long seen)
{
    unsigned long g = atomic_load_explicit(gen, memory_order_acquire);
    if (g != seen) return g;
    const int64_t t0 = pl_now_ns();
    for (unsigned i = 1; wait_step(t0, i); i++) {
        g = atomic_load_explicit(gen, memory_order_acquire);
        if (g != seen) return g;
    }
    return g;
}

struct worker_arg {
    pl_pool *pool;
    int index;
};

static void *worker_main(void *arg)
{
    pl_pool *p = ((struct worker_arg *)arg)->pool;
    int index = ((struct worker_arg *)arg)->index;
    free(arg);
    unsigned long seen = 0;
    for (;;) {
        unsigned long g = spin_while_gen(&p->generation, seen);
        if (g == seen) {
            pthread_mutex_lock(&p->mu);
            while (!p->quit &&
                   (g = atomic_load_explicit(&p->generation, memory_order_acquire)) == seen)
                pthread_cond_wait(&p->wake, &p->mu);
            const int quit = p->quit;
            pthread_mutex_unlock(&p->mu);
            if (quit) break;
        }
        seen = g;
        int b, e;
        chunk(p->n, p->n_threads, index, &b, &e);
        if (b < e) p->fn(p->ctx, b, e);
        if (atomic_fetch_sub_explicit(&p->pending, 1, memory_order_acq_rel) == 1) {
            pthread_mutex_lock(&p->mu);
            pthread_cond_signal(&p->done);
            pthread_mutex_unlock(&p->mu);
        }
    }
    return NULL;
}

int pl_pool_create(int n_threads, pl_pool **out)
{
    *out = NULL;
    if (n_threads < 1 || n_threads > PL_MAX_THREADS)
        return pl_error(PL_E_ARG, "thread count %d not in 1..%d", n_threads, PL_MAX_THREADS);
    pl_pool *p = aligned_alloc(64, (sizeof *p + 63) & ~(size_t)63);
    if (!p) return pl_error(PL_E_NOMEM, "out of memory for the thread pool");
    p->n_threads = 1;
    p->fn = NULL;
    p->ctx = NULL;
    p->n = 0;
    p->quit = 0;
    atomic_init(&p->generation, 0);
    atomic_init(&p->pending, 0);
    pthread_mutex_init(&p->mu, NULL);
    pthread_cond_init(&p->wake, NULL);
    pthread_cond_init(&p->done, NULL);
    for (int i = 1; i < n_threads; i++) {
        struct worker_arg *a = malloc(sizeof *a);
        if (!a) break;
        a->pool = p;
        a->index = i;
        if (pthread_create(&p->workers[i], NULL, worker_main, a) != 0) {
            free(a);
            pl_pool_destroy(p);
            return pl_error(PL_E_NOMEM, "cannot start worker thread %d of %d", i, n_threads);
        }
        p->n_threads = i + 1;
    }
    if (p->n_threads != n_threads) {
        pl_pool_destroy(p);
        return pl_error(PL_E_NOMEM, "out of memory starting %d threads", n_threads);
    }
    *out = p;
    return PL_OK;
}

void pl_pool_destroy(pl_pool *p)
{
    if (!p) return;
    pthread_mutex_lock(&p->mu);
    p->quit = 1;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->mu);
    for (int i = 1; i < p->n_threads; i++) pthread_join(p->workers[i], NULL);
    pthread_mutex_destroy(&p->mu);
    pthread_cond_destroy(&p->wake);
    pthread_cond_destroy(&p->done);
    free(p);
}

int pl_pool_threads(const pl_pool *p)
{
    return p ? p->n_threads : 1;
}

void pl_pool_for(pl_pool *p, int n, pl_pool_fn fn, void *ctx)
{
    if (!p || p->n_threads == 1 || n < 2) {
        if (n > 0) fn(ctx, 0, n);
        return;
    }
    /* workers read fn, ctx and n only after they see the new generation (release/acquire) */
    p->fn = fn;
    p->ctx = ctx;
    p->n = n;
    atomic_store_explicit(&p->pending, p->n_threads - 1, memory_order_relaxed);
    pthread_mutex_lock(&p->mu); /* a worker between its check and its wait holds mu */
    atomic_fetch_add_explicit(&p->generation, 1, memory_order_release);
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->mu);
    int b, e;
    chunk(n, p->n_threads, 0, &b, &e);
    if (b < e) fn(ctx, b, e);
    if (atomic_load_explicit(&p->pending, memory_order_acquire) > 0) {
        const int64_t t0 = pl_now_ns();
        for (unsigned i = 1; atomic_load_explicit(&p->pending, memory_order_acquire) > 0; i++) {
            if (!wait_step(t0, i)) {
                pthread_mutex_lock(&p->mu);
                while (atomic_load_explicit(&p->pending, memory_order_acquire) > 0)
                    pthread_cond_wait(&p->done, &p->mu);
                pthread_mutex_unlock(&p->mu);
                break;
            }
        }
    }
}
