#include "port/threads.h"

#include <pthread.h>
#include <stdlib.h>

#include "port/util.h"

struct pl_pool {
    int n_threads;
    pthread_t workers[PL_MAX_THREADS];
    pthread_mutex_t mu;
    pthread_cond_t wake, done;
    unsigned long generation; /* bumped for every loop */
    int pending;              /* workers still running the current loop */
    int quit;
    pl_pool_fn fn;
    void *ctx;
    int n;
};

static void chunk(int n, int parts, int i, int *b, int *e)
{
    *b = (int)((long long)n * i / parts);
    *e = (int)((long long)n * (i + 1) / parts);
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
    pthread_mutex_lock(&p->mu);
    for (;;) {
        while (!p->quit && p->generation == seen) pthread_cond_wait(&p->wake, &p->mu);
        if (p->quit) break;
        seen = p->generation;
        pl_pool_fn fn = p->fn;
        void *ctx = p->ctx;
        int b, e;
        chunk(p->n, p->n_threads, index, &b, &e);
        pthread_mutex_unlock(&p->mu);
        if (b < e) fn(ctx, b, e);
        pthread_mutex_lock(&p->mu);
        if (--p->pending == 0) pthread_cond_signal(&p->done);
    }
    pthread_mutex_unlock(&p->mu);
    return NULL;
}

int pl_pool_create(int n_threads, pl_pool **out)
{
    *out = NULL;
    if (n_threads < 1 || n_threads > PL_MAX_THREADS)
        return pl_error(PL_E_ARG, "thread count %d not in 1..%d", n_threads, PL_MAX_THREADS);
    pl_pool *p = calloc(1, sizeof *p);
    if (!p) return pl_error(PL_E_NOMEM, "out of memory for the thread pool");
    p->n_threads = 1;
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
    pthread_mutex_lock(&p->mu);
    p->fn = fn;
    p->ctx = ctx;
    p->n = n;
    p->pending = p->n_threads - 1;
    p->generation++;
    pthread_cond_broadcast(&p->wake);
    pthread_mutex_unlock(&p->mu);
    int b, e;
    chunk(n, p->n_threads, 0, &b, &e);
    if (b < e) fn(ctx, b, e);
    pthread_mutex_lock(&p->mu);
    while (p->pending > 0) pthread_cond_wait(&p->done, &p->mu);
    pthread_mutex_unlock(&p->mu);
}
