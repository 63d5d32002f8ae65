#include "port/capture.h"

#include <errno.h>
#include <stdio.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "core/util.h"

/* One frame buffer: pixels plus the frame's metadata, owned by the capture. */
struct slot {
    pl_image_u8 image;
    int64_t t_ns, index;
    char name[1024];
};

struct pl_capture {
    pl_source *src;
    int realtime;
    int64_t interval_ns; /* > 0: frame k at start + k * interval_ns (pl_capture_start_paced) */
    pthread_t thread;
    pthread_mutex_t mu;
    pthread_cond_t cv;
    struct slot slots[3];
    int writing, mailbox, reading; /* indexes into slots; mailbox -1 when empty */
    int64_t dropped, bad;
    int stop, ended, status;        /* ended: the thread is done; status: PL_E_EOF or an error */
    char error[512];                /* why the source ended */
    char last_bad[512];             /* the last bad frame's message */
};

static int copy_frame(struct slot *s, const pl_frame *f)
{
    const pl_image_u8 *src = &f->image;
    if (s->image.width != src->width || s->image.height != src->height) {
        pl_image_u8_free(&s->image);
        int rc = pl_image_u8_alloc(&s->image, src->width, src->height);
        if (rc < 0) return rc;
    }
    for (int y = 0; y < src->height; y++)
        memcpy(s->image.data + (size_t)y * s->image.stride, src->data + (size_t)y * src->stride,
               (size_t)src->width * 3);
    s->t_ns = f->t_ns;
    s->index = f->index;
    snprintf(s->name, sizeof s->name, "%s", f->name ? f->name : "");
    return PL_OK;
}

static void sleep_until(int64_t deadline_ns, const struct pl_capture *c)
{
    for (;;) {
        int64_t left = deadline_ns - pl_now_ns();
        if (left <= 0 || c->stop) return;
        if (left > 50000000) left = 50000000; /* wake every 50 ms to notice a stop */
        struct timespec ts = {0, (long)left};
        nanosleep(&ts, NULL);
    }
}

static void *capture_main(void *arg)
{
    pl_capture *c = arg;
    int64_t start_ns = 0, first_t = 0, released = 0;
    int have_first = 0, status = PL_E_EOF;
    for (;;) {
        pthread_mutex_lock(&c->mu);
        int stop = c->stop;
        pthread_mutex_unlock(&c->mu);
        if (stop) break;
        pl_frame f;
        int rc = pl_source_read(c->src, &f);
        if (rc == PL_E_EOF) break;
        if (rc < 0) { /* one bad frame (a corrupt file, a broken camera buffer): skipped */
            pthread_mutex_lock(&c->mu);
            c->bad++;
            snprintf(c->last_bad, sizeof c->last_bad, "%s", pl_last_error());
            pthread_mutex_unlock(&c->mu);
            continue;
        }
        if (c->interval_ns > 0) {
            if (!have_first) {
                start_ns = pl_now_ns();
                have_first = 1;
            } else {
                sleep_until(start_ns + released * c->interval_ns, c);
            }
            released++;
        } else if (c->realtime) {
            if (!have_first) {
                start_ns = pl_now_ns();
                first_t = f.t_ns;
                have_first = 1;
            } else {
                sleep_until(start_ns + (f.t_ns - first_t), c);
            }
        }
        if (copy_frame(&c->slots[c->writing], &f) < 0) {
            status = PL_E_NOMEM;
            break;
        }
        pthread_mutex_lock(&c->mu);
        int old = c->mailbox;
        c->mailbox = c->writing;
        if (old >= 0) {
            c->dropped++; /* inference was busy: the unseen frame is replaced */
            c->writing = old;
        } else {
            c->writing = 3 - c->mailbox - c->reading;
        }
        pthread_cond_signal(&c->cv);
        pthread_mutex_unlock(&c->mu);
    }
    pthread_mutex_lock(&c->mu);
    c->ended = 1;
    c->status = status;
    snprintf(c->error, sizeof c->error, "%s", pl_last_error());
    pthread_cond_signal(&c->cv);
    pthread_mutex_unlock(&c->mu);
    return NULL;
}

static int capture_start(pl_source *src, int realtime, int64_t interval_ns, pl_capture **out)
{
    *out = NULL;
    if (!src) return pl_error(PL_E_ARG, "pl_capture_start: source is NULL");
    pl_capture *c = calloc(1, sizeof *c);
    if (!c) return pl_error(PL_E_NOMEM, "out of memory for the capture pipeline");
    c->src = src;
    c->realtime = realtime;
    c->interval_ns = interval_ns;
    c->writing = 0;
    c->mailbox = -1;
    c->reading = 2;
    pthread_mutex_init(&c->mu, NULL);
    pthread_cond_init(&c->cv, NULL);
    if (pthread_create(&c->thread, NULL, capture_main, c) != 0) {
        pthread_mutex_destroy(&c->mu);
        pthread_cond_destroy(&c->cv);
        free(c);
        return pl_error(PL_E_NOMEM, "cannot start the capture thread");
    }
    *out = c;
    return PL_OK;
}

int pl_capture_start(pl_source *src, int realtime, pl_capture **out)
{
    return capture_start(src, realtime, 0, out);
}

int pl_capture_start_paced(pl_source *src, int64_t interval_ns, pl_capture **out)
{
    if (interval_ns <= 0 || interval_ns > PL_CAPTURE_MAX_INTERVAL_NS) {
        *out = NULL;
        return pl_error(PL_E_ARG, "capture: frame interval %lld ns: expected 1..%lld",
                        (long long)interval_ns, (long long)PL_CAPTURE_MAX_INTERVAL_NS);
    }
    return capture_start(src, 1, interval_ns, out);
}

int pl_capture_take(pl_capture *c, pl_frame *frame, int64_t *dropped, int timeout_ms)
{
    struct timespec deadline;
    clock_gettime(CLOCK_REALTIME, &deadline);
    deadline.tv_sec += timeout_ms / 1000;
    deadline.tv_nsec += (long)(timeout_ms % 1000) * 1000000L;
    if (deadline.tv_nsec >= 1000000000L) {
        deadline.tv_sec++;
        deadline.tv_nsec -= 1000000000L;
    }
    pthread_mutex_lock(&c->mu);
    while (c->mailbox < 0 && !c->ended)
        if (pthread_cond_timedwait(&c->cv, &c->mu, &deadline) == ETIMEDOUT) break;
    if (c->mailbox < 0) {
        int rc = c->ended ? c->status : PL_CAPTURE_AGAIN;
        pthread_mutex_unlock(&c->mu);
        return rc < 0 ? pl_error(rc, "%s", c->error) : rc;
    }
    int took = c->mailbox;
    c->mailbox = -1;
    c->reading = took;
    /* the capture thread's next buffer is whichever of the three is neither read nor writing */
    *dropped = c->dropped;
    c->dropped = 0;
    pthread_mutex_unlock(&c->mu);
    struct slot *s = &c->slots[took];
    frame->image = s->image;
    frame->t_ns = s->t_ns;
    frame->index = s->index;
    frame->name = s->name;
    return PL_OK;
}

int64_t pl_capture_bad_frames(pl_capture *c, char *last_msg, size_t cap)
{
    pthread_mutex_lock(&c->mu);
    int64_t b = c->bad;
    if (last_msg && cap) snprintf(last_msg, cap, "%s", c->last_bad);
    pthread_mutex_unlock(&c->mu);
    return b;
}

void pl_capture_stop(pl_capture *c)
{
    if (!c) return;
    pthread_mutex_lock(&c->mu);
    c->stop = 1;
    pthread_mutex_unlock(&c->mu);
    pthread_join(c->thread, NULL);
    pthread_mutex_destroy(&c->mu);
    pthread_cond_destroy(&c->cv);
    for (int i = 0; i < 3; i++) pl_image_u8_free(&c->slots[i].image);
    free(c);
}
