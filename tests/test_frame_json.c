/* pl_frame_format_json: the line parses back (core/json.c) with every field of docs/OUTPUT.md,
 * the source is escaped, "space" follows the orientation, a buffer one byte short is refused
 * (never a cut line), and NULL arguments are errors. */
#include <string.h>

#include "core/json.h"
#include "core/util.h"
#include "light_test.h"
#include "parlight.h"

int main(void)
{
    pl_lighting L;
    memset(&L, 0, sizeof L);
    L.n_lights = 2;
    L.lights[0] = (pl_light){{0, 1, 0}, 2, 0.1f, {5, 4, 3}};
    L.lights[1] = (pl_light){{0.6f, 0, -0.8f}, 3, 1.5f, {0.5f, 0.5f, 0.5f}};
    L.ambient[0] = L.ambient[1] = L.ambient[2] = 0.2f;
    const double q[4] = {1, 0, 0, 0};
    pl_frame_meta m = {7, 123456789, "dir:a \"b\"\\c\n", NULL, {1.5, 20.25}, 22.0, -1, 3};
    char buf[16384];
    int n = pl_frame_format_json(&m, &L, buf, sizeof buf);
    CHECK(n > 0 && (size_t)n == strlen(buf) && buf[n - 1] == '\n', "length %d", n);
    pl_json_doc doc;
    CHECK(pl_json_parse(buf, (size_t)n, "line", &doc) == 0, "parses: %s", pl_last_error());
    const char *keys[] = {"frame", "t_ns",   "source", "space",     "lights",
                          "ambient", "primary", "sh9",  "engine", "timing_ms", "dropped"};
    for (size_t i = 0; i < sizeof keys / sizeof keys[0]; i++)
        CHECK(pl_json_get(&doc.root, keys[i]) != NULL, "no \"%s\"", keys[i]);
    const pl_json_value *src = pl_json_get(&doc.root, "source");
    CHECK(src && !strcmp(src->str, "dir:a \"b\"\\c\n"), "source round trip");
    const pl_json_value *sp = pl_json_get(&doc.root, "space");
    CHECK(sp && !strcmp(sp->str, "camera") && !pl_json_get(&doc.root, "orientation"),
          "camera space without orientation");
    CHECK(!pl_json_get(pl_json_get(&doc.root, "timing_ms"), "latency"), "no latency when < 0");
    pl_json_free(&doc);
    m.orientation = q;
    m.latency_ms = 4.5;
    n = pl_frame_format_json(&m, &L, buf, sizeof buf);
    CHECK(n > 0 && strstr(buf, "\"space\":\"world\",\"orientation\":[1,0,0,0]") &&
              strstr(buf, "\"latency\":4.500"),
          "world space and latency: %s", buf);
    /* exactly the length + NUL fits; one byte less is refused, nothing half written counts */
    char small[16384];
    CHECK(pl_frame_format_json(&m, &L, small, (size_t)n + 1) == n, "fits in n + 1");
    CHECK(pl_frame_format_json(&m, &L, small, (size_t)n) == PL_E_ARG &&
              strstr(pl_last_error(), "does not fit"),
          "n bytes refused");
    CHECK(pl_frame_format_json(NULL, &L, buf, sizeof buf) == PL_E_ARG, "NULL meta");
    CHECK(pl_frame_format_json(&m, NULL, buf, sizeof buf) == PL_E_ARG, "NULL lighting");
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("frame json: all passed\n");
    return 0;
}
