/* libFuzzer target: the JSON parser (core/json.c) and the lights reader on top of it
 * (light/lights_json.c), through pl_lighting_parse_json, from memory.
 *
 * A refused input must come with a message. An accepted one must survive the round trip the CLI
 * relies on (`compare`, `render` read what `estimate` writes): formatting it and parsing the
 * result gives the same lighting (directions are renormalised on reading, hence the 1e-6).
 * Seeds: tests/fuzz/corpus/lights_json (tools/fuzz-corpus.py). */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "light/lights_json.h"
#include "parlight.h"
#include "tests/fuzz/fuzz_input.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static int close_to(float a, float b)
{
    return fabsf(a - b) <= 1e-6f * fmaxf(1.0f, fmaxf(fabsf(a), fabsf(b)));
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    pl_lighting L, back;
    int rc = pl_lighting_parse_json((const char *)data, size, &L);
    fuzz_expect_message(rc, pl_last_error());
    if (rc < 0) return 0;
    if (L.n_lights < 0 || L.n_lights > PL_MAX_LIGHTS) abort();

    static char text[16384];
    text[0] = '{';
    int n = pl_lighting_format_json(&L, text + 1, sizeof text - 2);
    if (n < 0) {
        fprintf(stderr, "fuzz: cannot format an accepted lighting: %s\n", pl_last_error());
        abort();
    }
    text[1 + n] = '}';
    if (pl_lighting_parse_json(text, (size_t)n + 2, &back) < 0) {
        fprintf(stderr, "fuzz: own output refused: %s\n%s\n", pl_last_error(), text);
        abort();
    }
    int same = back.n_lights == L.n_lights;
    for (int i = 0; same && i < L.n_lights; i++)
        for (int c = 0; c < 3; c++)
            same = same && close_to(L.lights[i].dir[c], back.lights[i].dir[c]) &&
                   L.lights[i].rgb[c] == back.lights[i].rgb[c];
    for (int i = 0; same && i < L.n_lights; i++)
        same = L.lights[i].distance_m == back.lights[i].distance_m &&
               L.lights[i].solid_angle_sr == back.lights[i].solid_angle_sr;
    for (int c = 0; c < 3; c++)
        same = same && L.ambient[c] == back.ambient[c];
    if (!same) {
        fprintf(stderr, "fuzz: round trip changed the lighting:\n%s\n", text);
        abort();
    }
    return 0;
}
