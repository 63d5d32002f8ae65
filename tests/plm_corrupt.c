/* plm_corrupt MODEL.plm — feeds the loader broken copies of a real model file (fp32 or int8).
 *
 * 1. truncations at every structural boundary and in between;
 * 2. a bit flipped in the header, the table and the data with the checksum left as it was;
 * 3. targeted corruptions with the checksum recomputed, so that the structural and architectural
 *    checks themselves are exercised (wrong version, dims, offsets, duplicate names, NaN and Inf
 *    in the first float tensor, wrong N or architecture in the metadata).
 * Every broken copy must be refused with a non-empty message (and, for targeted cases, a message
 * naming the problem); a crash fails the test by itself. Prints one line per failure and a
 * closing "N passed, M failed".
 * Deterministic cases only: random mutation is the job of the libFuzzer target
 * tests/fuzz/fuzz_plm.c (`make fuzz`), which fixes the checksum so that it reaches past it. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model/plm.h"
#include "parlight.h"

static uint8_t *orig;
static size_t orig_size;
static char tmp_path[4096];
static int passed, failed;

static uint32_t rd32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static void wr32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; i++)
        p[i] = (uint8_t)(v >> (8 * i));
}

static uint64_t rd64(const uint8_t *p)
{
    return (uint64_t)rd32(p) | (uint64_t)rd32(p + 4) << 32;
}

static void fix_crc(uint8_t *buf, size_t size)
{
    wr32(buf + 56, pl_crc32(pl_crc32(0, buf, 56), buf + 60, size - 60));
}

/* Writes buf to the scratch file and expects pl_model_load to refuse it (with `want` in the
 * message when given). */
static void expect_refused(const char *what, const uint8_t *buf, size_t size, const char *want)
{
    FILE *f = fopen(tmp_path, "wb");
    if (!f || (size && fwrite(buf, 1, size, f) != size) || fclose(f)) {
        printf("FAIL %s: cannot write %s\n", what, tmp_path);
        failed++;
        return;
    }
    pl_model *m = NULL;
    int rc = pl_model_load(tmp_path, &m);
    const char *msg = pl_last_error();
    if (rc >= 0) {
        printf("FAIL %s: loaded without error\n", what);
        pl_model_free(m);
        failed++;
    } else if (!msg[0] || (want && !strstr(msg, want))) {
        printf("FAIL %s: message '%s' does not name the problem ('%s')\n", what, msg,
               want ? want : "");
        failed++;
    } else {
        passed++;
    }
}

static uint8_t *copy(void)
{
    uint8_t *b = malloc(orig_size);
    if (!b) abort();
    memcpy(b, orig, orig_size);
    return b;
}

/* Replaces `from` by `to` (same length) in the metadata block, fixes the CRC, expects refusal. */
static void meta_case(const char *what, const char *from, const char *to, const char *want)
{
    uint8_t *b = copy();
    size_t meta_size = rd32(b + 32);
    char *meta = (char *)b + 64, *hit = NULL;
    for (size_t i = 0; i + strlen(from) <= meta_size; i++)
        if (!memcmp(meta + i, from, strlen(from))) {
            hit = meta + i;
            break;
        }
    if (!hit || strlen(from) != strlen(to)) {
        printf("FAIL %s: metadata '%s' not found in the model\n", what, from);
        failed++;
    } else {
        memcpy(hit, to, strlen(to));
        fix_crc(b, orig_size);
        expect_refused(what, b, orig_size, want);
    }
    free(b);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: plm_corrupt MODEL.plm\n");
        return 2;
    }
    FILE *f = fopen(argv[1], "rb");
    if (!f) {
        fprintf(stderr, "plm_corrupt: cannot open %s\n", argv[1]);
        return 2;
    }
    fseek(f, 0, SEEK_END);
    orig_size = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    orig = malloc(orig_size);
    if (!orig || fread(orig, 1, orig_size, f) != orig_size) return 2;
    fclose(f);
    const char *tmp = getenv("PL_TEST_TMP");
    snprintf(tmp_path, sizeof tmp_path, "%s/plm_corrupt.plm", tmp ? tmp : "/tmp");

    pl_model *m;
    if (pl_model_load(argv[1], &m) < 0) {
        printf("FAIL the intact model does not load: %s\n", pl_last_error());
        return 1;
    }
    pl_model_free(m);

    const uint64_t table = rd64(orig + 40), data = rd64(orig + 48);
    const uint32_t meta_size = rd32(orig + 32), n_tensors = rd32(orig + 36);

    /* 1. truncations */
    const size_t cuts[] = {0,
                           1,
                           7,
                           8,
                           63,
                           64,
                           64 + meta_size / 2,
                           64 + meta_size,
                           table + 1,
                           table + 128 * (n_tensors / 2),
                           data,
                           data + 1,
                           orig_size / 2,
                           orig_size - 4096,
                           orig_size - 1};
    for (size_t i = 0; i < sizeof cuts / sizeof cuts[0]; i++) {
        char what[64];
        snprintf(what, sizeof what, "truncated to %zu bytes", cuts[i]);
        expect_refused(what, orig, cuts[i], NULL);
    }

    /* 2. one bit flipped, checksum not fixed: the CRC must catch it wherever it lands */
    const size_t flip_at[] = {8, 64, table + 3, data, orig_size - 1};
    for (size_t i = 0; i < sizeof flip_at / sizeof flip_at[0]; i++) {
        uint8_t *b = copy();
        b[flip_at[i]] ^= 0x10;
        char what[64];
        snprintf(what, sizeof what, "bit 4 of byte %zu flipped", flip_at[i]);
        expect_refused(what, b, orig_size, flip_at[i] == 8 ? "version" : "checksum");
        free(b);
    }

    /* 3. targeted corruptions, checksum fixed up */
    uint8_t *b;
    b = copy();
    wr32(b + 8, 2);
    fix_crc(b, orig_size);
    expect_refused("version 2", b, orig_size, "version");
    free(b);

    b = copy();
    memcpy(b, "PLMODEX", 7);
    expect_refused("bad magic", b, orig_size, "magic");
    free(b);

    uint8_t *e0 = NULL;
    b = copy();
    e0 = b + table; /* first table entry */
    wr32(e0 + 72, rd32(e0 + 72) + 1);
    fix_crc(b, orig_size);
    expect_refused("dims changed", b, orig_size, "size");
    free(b);

    b = copy();
    e0 = b + table;
    uint64_t far = (orig_size + 4096) & ~(uint64_t)63;
    for (int k = 0; k < 8; k++)
        e0[88 + k] = (uint8_t)(far >> (8 * k));
    fix_crc(b, orig_size);
    expect_refused("offset past the end", b, orig_size, "past end");
    free(b);

    b = copy();
    e0 = b + table;
    e0[88] ^= 4; /* misaligned */
    fix_crc(b, orig_size);
    expect_refused("misaligned offset", b, orig_size, "aligned");
    free(b);

    b = copy();
    memcpy(b + table + 128, b + table, 64); /* second entry gets the first one's name */
    fix_crc(b, orig_size);
    expect_refused("duplicate tensor name", b, orig_size, "twice");
    free(b);

    b = copy();
    wr32(b + table + 64, 9);
    fix_crc(b, orig_size);
    expect_refused("unknown dtype", b, orig_size, "dtype");
    free(b);

    /* the first float tensor with at least 6 elements: an int8 model starts with s8 weights,
     * whose bytes are never NaN */
    const uint8_t *f32_entry = NULL;
    for (uint32_t i = 0; i < n_tensors && !f32_entry; i++) {
        const uint8_t *e = orig + table + (size_t)i * 128;
        if (rd32(e + 64) == PL_DT_F32 && rd64(e + 96) >= 6 * sizeof(float)) f32_entry = e;
    }
    if (!f32_entry) {
        printf("FAIL the model has no float tensor of 6 or more elements to corrupt\n");
        failed++;
    }
    const float bad_values[2] = {__builtin_nanf(""), __builtin_inff()};
    const char *bad_names[2] = {"NaN", "Inf"};
    for (int k = 0; k < 2 && f32_entry; k++) {
        b = copy();
        uint64_t off = rd64(f32_entry + 88);
        memcpy(b + off + 4 * 5, &bad_values[k], 4);
        fix_crc(b, orig_size);
        char what[32];
        snprintf(what, sizeof what, "%s weight", bad_names[k]);
        expect_refused(what, b, orig_size, bad_names[k]);
        free(b);
    }

    b = copy();
    uint64_t off0 = rd64(b + table + 88), off1 = rd64(b + table + 128 + 88);
    uint64_t other = off0 == off1 ? off0 : off1;
    for (int k = 0; k < 8; k++)
        b[table + 88 + k] = (uint8_t)(other >> (8 * k));
    fix_crc(b, orig_size);
    expect_refused("overlapping tensors", b, orig_size, NULL);
    free(b);

    meta_case("n_lights 4", "n_lights=", "n_lightz=", "n_lights");
    meta_case("wrong architecture", "arch=densenet121", "arch=densenet169", "architecture");
    meta_case("bad mean", "mean=0", "mean=x", "mean");

    b = copy();
    wr32(b + 36, n_tensors - 1); /* one tensor fewer in the table */
    fix_crc(b, orig_size);
    expect_refused("missing tensor", b, orig_size, "missing");
    free(b);

    expect_refused("a directory", NULL, 0, NULL);
    pl_model *dm = NULL;
    if (pl_model_load(tmp ? tmp : "/tmp", &dm) >= 0 || !strstr(pl_last_error(), "regular")) {
        printf("FAIL loading a directory: '%s'\n", pl_last_error());
        failed++;
        pl_model_free(dm);
    } else {
        passed++;
    }
    if (pl_model_load("/nonexistent/model.plm", &dm) >= 0 || !strstr(pl_last_error(), "open")) {
        printf("FAIL loading a missing file: '%s'\n", pl_last_error());
        failed++;
    } else {
        passed++;
    }

    remove(tmp_path);
    free(orig);
    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}
