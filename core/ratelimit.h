/* Rate limiting of repeated log messages: at most `burst` messages of one kind per window, and
 * a count of the ones held back, so that a storm (a reader gone from stdout, thousands of
 * connections a second) prints a few lines and a total instead of one line per event. Pure
 * logic: the caller passes the time and does the printing. */
#ifndef PL_CORE_RATELIMIT_H
#define PL_CORE_RATELIMIT_H

#include <stdint.h>

typedef struct pl_ratelimit {
    int64_t window_ns; /* length of a window */
    int burst;         /* messages allowed per window */
    int64_t start_ns;  /* start of the current window */
    int used;          /* messages allowed in it so far */
    long long held;    /* messages held back since the last report */
    int started;
} pl_ratelimit;

/* A limiter allowing `burst` (>= 1) messages per `window_ns` (> 0). */
void pl_ratelimit_init(pl_ratelimit *r, int burst, int64_t window_ns);

/* One message at time now_ns: returns 1 if it may be printed, 0 if it is held back (counted).
 * When a new window begins and messages were held back in the ones before, *held_out receives
 * their count (print it before this message) and the count restarts; else *held_out is 0. */
int pl_ratelimit_allow(pl_ratelimit *r, int64_t now_ns, long long *held_out);

/* Messages held back and not yet reported (for a summary at exit); resets the count. */
long long pl_ratelimit_take_held(pl_ratelimit *r);

#endif
