/* The stage profile of model/profile.h: names and the clock. A file of its own, so that both
 * executors (model/net_f32.c, model/net_s8.c) use it without the int8 executor calling back into
 * the fp32 one's file. */
#include "model/profile.h"

#include <time.h>

#include "core/util.h"

const char *pl_prof_stage_name(int stage)
{
    static const char *const names[PL_PROF_N] = {
        "preprocess",   "stem 7x7",     "max pool",      "dense 1x1 b1",
        "dense 3x3 b1", "dense 1x1 b2", "dense 3x3 b2",  "dense 1x1 b3",
        "dense 3x3 b3", "dense 1x1 b4", "dense 3x3 b4",  "transition 1",
        "transition 2", "transition 3", "norm5 + bands", "fc + heads"};
    return stage >= 0 && stage < PL_PROF_N ? names[stage] : NULL;
}

int64_t pl_prof_now(const pl_profile *p)
{
    if (!p) return 0;
    if (!p->thread_cpu) return pl_now_ns();
    struct timespec ts;
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

void pl_prof_mark(pl_profile *p, int stage, int64_t *t)
{
    if (!p) return;
    const int64_t now = pl_prof_now(p);
    p->ns[stage] += now - *t;
    *t = now;
}
