/* pl_model_load_memory (include/parlight.h): the shipped int8 model loaded from a buffer gives
 * the same lights as from its file, bit for bit, and the caller's buffer may be freed at once;
 * a NULL, empty, truncated, bit-flipped or foreign buffer is refused with a message that says
 * so, never a crash (the same checks as a file: model/plm.c). Skips (77) without the model. */
#include <stdlib.h>
#include <string.h>

#include "check.h"
#include "parlight.h"

static uint8_t *read_all(const char *path, size_t *n)
{
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    long len = ftell(f);
    fseek(f, 0, SEEK_SET);
    uint8_t *buf = len > 0 ? malloc((size_t)len) : NULL;
    if (buf && fread(buf, 1, (size_t)len, f) != (size_t)len) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *n = buf ? (size_t)len : 0;
    return buf;
}

/* Loads n bytes of data from memory and expects status `want` and `msg` in the message. */
static void expect_refused(const void *data, size_t n, int want, const char *msg, const char *what)
{
    pl_model *m = (pl_model *)&m; /* must come back NULL */
    int rc = pl_model_load_memory(data, n, &m);
    CHECK(rc == want, "%s: status %s, expected %s (%s)", what, pl_status_name(rc),
          pl_status_name(want), pl_last_error());
    CHECK(m == NULL, "%s: *out not NULL after a failure", what);
    CHECK(strstr(pl_last_error(), msg) != NULL, "%s: message '%s' lacks '%s'", what,
          pl_last_error(), msg);
    if (rc == PL_OK) pl_model_free(m);
}

static void frame(uint8_t *rgb, int w, int h)
{
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            for (int c = 0; c < 3; c++)
                rgb[((size_t)y * w + x) * 3 + c] =
                    (uint8_t)(x < w / 3 && y < h / 4 ? 250 : 60 + c * 20 + (x * 7 + y * 3) % 40);
}

int main(int argc, char **argv)
{
    const char *path = argc > 1 ? argv[1] : "models/parlight-n3-int8.plm";
    size_t n;
    uint8_t *bytes = read_all(path, &n);
    if (!bytes) {
        printf("skip: cannot read %s\n", path);
        return 77;
    }
    const int w = 160, h = 120;
    uint8_t *rgb = malloc((size_t)w * h * 3);
    frame(rgb, w, h);

    pl_model *mf = NULL, *mm = NULL;
    CHECK(pl_model_load(path, &mf) == PL_OK, "file: %s", pl_last_error());
    uint8_t *copy = malloc(n);
    memcpy(copy, bytes, n);
    CHECK(pl_model_load_memory(copy, n, &mm) == PL_OK, "memory: %s", pl_last_error());
    memset(copy, 0xA5, n); /* the model owns its own copy: this must not matter */
    free(copy);
    if (mf && mm) {
        pl_model_info fi, mi;
        pl_model_get_info(mf, &fi);
        pl_model_get_info(mm, &mi);
        CHECK(fi.file_size == mi.file_size && fi.n_lights == mi.n_lights &&
                  fi.n_params == mi.n_params && !strcmp(fi.precision, mi.precision),
              "info differs between file and memory loads");
        pl_lighting a, b;
        CHECK(pl_estimate_rgb8(mf, rgb, w, h, (size_t)w * 3, &a, NULL) == PL_OK, "%s",
              pl_last_error());
        CHECK(pl_estimate_rgb8(mm, rgb, w, h, (size_t)w * 3, &b, NULL) == PL_OK, "%s",
              pl_last_error());
        CHECK(memcmp(&a, &b, sizeof a) == 0, "memory-loaded model estimates differently");
    }
    pl_model_free(mf);
    pl_model_free(mm);

    expect_refused(NULL, n, PL_E_ARG, "NULL", "NULL buffer");
    expect_refused(bytes, 0, PL_E_ARG, "empty", "empty buffer");
    expect_refused(bytes, 40, PL_E_FORMAT, "too short for a .plm header", "40 bytes");
    expect_refused(bytes, n / 2, PL_E_FORMAT, "truncated", "half the model");
    expect_refused(bytes, n - 1, PL_E_FORMAT, "truncated", "one byte short");
    uint8_t *bad = malloc(n);
    memcpy(bad, bytes, n);
    bad[n / 2] ^= 0x10;
    expect_refused(bad, n, PL_E_FORMAT, "checksum mismatch", "one bit flipped");
    memcpy(bad, bytes, n);
    memcpy(bad, "JPEGFILE", 8);
    expect_refused(bad, n, PL_E_FORMAT, "not a parlight model", "bad magic");
    free(bad);
    expect_refused("\xff\xd8\xff\xe0 a JPEG, not a model .......................................",
                   64, PL_E_FORMAT, "<memory>", "a JPEG's first bytes");
    CHECK(pl_model_load_memory(bytes, n, NULL) == PL_E_ARG, "NULL out accepted");

    free(bytes);
    free(rgb);
    printf(failures ? "%d failure(s)\n" : "api memory: all passed\n", failures);
    return failures ? 1 : 0;
}
