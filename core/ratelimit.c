/* Rate limiting of repeated log messages (core/ratelimit.h). */
#include "core/ratelimit.h"

void pl_ratelimit_init(pl_ratelimit *r, int burst, int64_t window_ns)
{
    r->window_ns = window_ns > 0 ? window_ns : 1;
    r->burst = burst >= 1 ? burst : 1;
    r->start_ns = 0;
    r->used = 0;
    r->held = 0;
    r->started = 0;
}

int pl_ratelimit_allow(pl_ratelimit *r, int64_t now_ns, long long *held_out)
{
    *held_out = 0;
    if (!r->started || now_ns - r->start_ns >= r->window_ns || now_ns < r->start_ns) {
        r->started = 1;
        r->start_ns = now_ns;
        r->used = 0;
        *held_out = r->held;
        r->held = 0;
    }
    if (r->used < r->burst) {
        r->used++;
        return 1;
    }
    r->held++;
    return 0;
}

long long pl_ratelimit_take_held(pl_ratelimit *r)
{
    long long n = r->held;
    r->held = 0;
    return n;
}
