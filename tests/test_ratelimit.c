/* core/ratelimit: a burst per window, the held-back count reported when the next window opens
 * and at the end, and a clock that goes backwards (a new window, never a stuck limiter). */
#include "core/ratelimit.h"
#include "check.h"

#define S 1000000000LL

int main(void)
{
    pl_ratelimit r;
    long long held = -1;
    pl_ratelimit_init(&r, 3, 10 * S);
    int shown = 0;
    for (int i = 0; i < 100; i++) { /* 100 messages in the first second: 3 shown, 97 held */
        shown += pl_ratelimit_allow(&r, (long long)i * 10000000LL, &held);
        CHECK(held == 0, "message %d: no report inside the first window (%lld)", i, held);
    }
    CHECK(shown == 3, "first window: %d shown, expected 3", shown);
    CHECK(pl_ratelimit_allow(&r, 10 * S, &held) == 1 && held == 97,
          "next window: shown, with 97 held reported (got %lld)", held);
    CHECK(pl_ratelimit_allow(&r, 11 * S, &held) == 1 && held == 0, "second in the window");
    CHECK(pl_ratelimit_allow(&r, 12 * S, &held) == 1, "third in the window");
    CHECK(pl_ratelimit_allow(&r, 13 * S, &held) == 0 && held == 0, "fourth held");
    CHECK(pl_ratelimit_take_held(&r) == 1 && pl_ratelimit_take_held(&r) == 0,
          "take_held gives the count once");
    /* a clock that jumps back opens a window instead of holding everything for ever */
    CHECK(pl_ratelimit_allow(&r, 1 * S, &held) == 1, "clock backwards: a new window");
    /* degenerate settings are clamped, not undefined */
    pl_ratelimit_init(&r, 0, 0);
    CHECK(pl_ratelimit_allow(&r, 0, &held) == 1 && pl_ratelimit_allow(&r, 0, &held) == 0,
          "burst 0 means 1");
    CHECK(pl_ratelimit_allow(&r, 1, &held) == 1 && held == 1, "window 0 means 1 ns");
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("ratelimit: all passed\n");
    return 0;
}
