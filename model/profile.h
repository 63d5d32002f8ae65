/* Where a frame's time goes: wall time per stage of the network, summed over frames, for
 * `parlight bench --layers` (docs/PERFORMANCE.md "Where the time goes"). Private to the app and
 * model/: both executors (model/net_f32.c fp32, model/net_s8.c int8) add to it when one is set.
 *
 * A stage's time runs from the end of the previous stage to the end of its own last kernel call,
 * so the stages add up to the frame's time (the preprocessing is PL_PROF_PRE). Reading the
 * clock costs ~20 ns a stage; with no profile set nothing is read. */
#ifndef PL_MODEL_PROFILE_H
#define PL_MODEL_PROFILE_H

#include <stdint.h>

#include "parlight.h"

enum pl_prof_stage {
    PL_PROF_PRE,     /* crop, resize, normalise / convert to the first layer's input */
    PL_PROF_STEM,    /* conv0 7x7/2 (+ its input packing) */
    PL_PROF_MAXPOOL, /* max pool 3x3/2 into block 1 */
    PL_PROF_DENSE1,  /* block b's 1x1 bottlenecks (clamp + pack + conv): PL_PROF_DENSE1 + 2b */
    PL_PROF_DENSE3 = PL_PROF_DENSE1 + 1, /* block b's 3x3 128->32: PL_PROF_DENSE3 + 2b */
    PL_PROF_TRANS = PL_PROF_DENSE1 + 8,  /* transition t (clamp, pool, 1x1): PL_PROF_TRANS + t */
    PL_PROF_NORM5 = PL_PROF_TRANS + 3,   /* norm5 clamp and band pooling */
    PL_PROF_HEADS,                       /* FC and the heads */
    PL_PROF_N
};

typedef struct pl_profile {
    int64_t ns[PL_PROF_N];
    int64_t frames;
    int thread_cpu; /* 1: stages in the calling thread's CPU time (CLOCK_THREAD_CPUTIME_ID), which
                       a loaded machine disturbs less than wall time; meaningful at 1 thread */
} pl_profile;

/* "dense 1x1 b2" etc.; NULL outside 0..PL_PROF_N-1. */
const char *pl_prof_stage_name(int stage);

/* Stages of every later estimate add to *p (not cleared here); NULL stops. */
int pl_model_set_profile(pl_model *m, pl_profile *p);

/* The profile's clock in ns (0 when p is NULL). */
int64_t pl_prof_now(const pl_profile *p);
/* Adds now - *t to p->ns[stage] and sets *t to now; nothing when p is NULL. */
void pl_prof_mark(pl_profile *p, int stage, int64_t *t);

#endif
