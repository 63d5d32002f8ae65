/* nn_vectors: runs int8 golden-vector cases (the CMSIS-NN vectors in
 * ../shared/data/cmsis-nn-vectors and our own in tests/data/nn-vectors, same JSON schema; see the
 * README beside the CMSIS-NN ones and docs/QUANT.md) through the reference int8 kernels and
 * compares bit-exactly.
 *
 *   nn_vectors [-v] PATH...    PATH: a directory (searched recursively for *.json) or a file
 *
 * Every field is validated first (sizes must match the dims; a malformed case is a failure line
 * naming the file and the field, never a crash). Each case runs in two ways: packed tensors over
 * the whole channel range, and tensors with wider pixel strides (output at a channel offset,
 * guard bytes checked) computed in three channel ranges in reverse order. conv2d cases with a 1x1
 * filter and no padding also run through nn_conv1x1_s8__ref. Prints one line per failure
 * ("FAIL file: ...": first mismatching index, expected vs got) and closes with
 * "N passed, M failed"; exits 1 on any failure or when no case ran, 2 on a usage error. */
#include <dirent.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "core/json.h"
#include "core/util.h"
#include "kernels/ref/nn_ref_s8.h"
#include "port/json_file.h"

#define MAX_DEPTH 16 /* directory nesting (also stops symlink loops) */

enum op { OP_CONV, OP_DEPTHWISE, OP_FC, OP_AVGPOOL, OP_MAXPOOL };

/* One validated case. For FC, in = {batches, 1, 1, depth} and out = {batches, 1, 1, out_c}. */
typedef struct vcase {
    const char *path;
    enum op op;
    nn_dims in, filter, out;
    nn_conv_s8_params conv;
    nn_fc_s8_params fc;
    nn_pool_s8_params pool;
    nn_per_channel_quant q;
    int8_t *input, *weights, *expected;
    int32_t *bias, *multiplier, *shift;
} vcase;

/* Runs one kernel on tensors with the given pixel strides, channels [c_begin, c_end). */
typedef void (*run_fn)(const vcase *c, const int8_t *in, int in_c_stride, int8_t *out,
                       int out_c_stride, int c_begin, int c_end);

static int n_passed, n_failed, verbose;

static void fail_line(const char *path, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
static void fail_line(const char *path, const char *fmt, ...)
{
    va_list ap;
    printf("FAIL %s: ", path);
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    printf("\n");
}

/* --- Field access: each returns PL_OK or a negative status with a message naming the field. --- */

static int get_int(const pl_json_value *root, const char *key, long long lo, long long hi,
                   long long *out)
{
    const pl_json_value *v = pl_json_get(root, key);
    if (!v) return pl_error(PL_E_FORMAT, "field '%s' missing", key);
    if (v->type != PL_JSON_NUMBER)
        return pl_error(PL_E_FORMAT, "field '%s': expected an integer, found %s", key,
                        pl_json_type_name(v->type));
    if (v->number != floor(v->number) || v->number < (double)lo || v->number > (double)hi)
        return pl_error(PL_E_FORMAT, "field '%s' %.17g: expected an integer in [%lld, %lld]", key,
                        v->number, lo, hi);
    *out = (long long)v->number;
    return PL_OK;
}

static int get_i(const pl_json_value *root, const char *key, long long lo, long long hi, int *out)
{
    long long v = 0;
    int rc = get_int(root, key, lo, hi, &v);
    if (rc == PL_OK) *out = (int)v;
    return rc;
}

static int get_i32(const pl_json_value *root, const char *key, long long lo, long long hi,
                   int32_t *out)
{
    long long v = 0;
    int rc = get_int(root, key, lo, hi, &v);
    if (rc == PL_OK) *out = (int32_t)v;
    return rc;
}

static int get_str(const pl_json_value *root, const char *key, const char **out)
{
    const pl_json_value *v = pl_json_get(root, key);
    if (!v) return pl_error(PL_E_FORMAT, "field '%s' missing", key);
    if (v->type != PL_JSON_STRING)
        return pl_error(PL_E_FORMAT, "field '%s': expected a string, found %s", key,
                        pl_json_type_name(v->type));
    *out = v->str;
    return PL_OK;
}

/* An integer array of exactly `count` values in [lo, hi] into a new buffer of `elem` bytes per
 * value (1: int8, 4: int32). `nullable`: null gives *out = NULL. `what` explains the count. */
static int get_array(const pl_json_value *root, const char *key, size_t count, const char *what,
                     long long lo, long long hi, size_t elem, int nullable, void **out)
{
    *out = NULL;
    const pl_json_value *v = pl_json_get(root, key);
    if (!v) return pl_error(PL_E_FORMAT, "field '%s' missing", key);
    if (nullable && v->type == PL_JSON_NULL) return PL_OK;
    if (v->type != PL_JSON_ARRAY)
        return pl_error(PL_E_FORMAT, "field '%s': expected an array%s, found %s", key,
                        nullable ? " or null" : "", pl_json_type_name(v->type));
    if (v->len != count)
        return pl_error(PL_E_FORMAT, "field '%s': expected %zu values (%s), found %zu", key, count,
                        what, v->len);
    void *buf = malloc(count * elem);
    if (!buf) return pl_error(PL_E_NOMEM, "field '%s': out of memory for %zu values", key, count);
    for (size_t i = 0; i < count; i++) {
        const pl_json_value *e = &v->items[i];
        if (e->type != PL_JSON_NUMBER || e->number != floor(e->number) || e->number < (double)lo ||
            e->number > (double)hi) {
            free(buf);
            if (e->type != PL_JSON_NUMBER)
                return pl_error(PL_E_FORMAT, "field '%s'[%zu]: expected an integer, found %s", key,
                                i, pl_json_type_name(e->type));
            return pl_error(PL_E_FORMAT,
                            "field '%s'[%zu] %.17g: expected an integer in [%lld, %lld]", key, i,
                            e->number, lo, hi);
        }
        if (elem == 1)
            ((int8_t *)buf)[i] = (int8_t)e->number;
        else
            ((int32_t *)buf)[i] = (int32_t)e->number;
    }
    *out = buf;
    return PL_OK;
}

#define I8_ARRAY(key, count, what, nullable, out)                                                  \
    get_array(root, key, count, what, INT8_MIN, INT8_MAX, 1, nullable, (void **)(out))
#define I32_ARRAY(key, count, what, nullable, out)                                                 \
    get_array(root, key, count, what, INT32_MIN, INT32_MAX, 4, nullable, (void **)(out))

static void free_case(vcase *c)
{
    free(c->input);
    free(c->weights);
    free(c->expected);
    free(c->bias);
    free(c->multiplier);
    free(c->shift);
}

/* Elements of a packed tensor (validated dims, so the product fits). */
static size_t packed(const nn_dims *d)
{
    return (size_t)d->n * (size_t)d->h * (size_t)d->w * (size_t)d->c;
}

/* Reads and validates everything a case needs; PL_OK or a message naming the field. */
static int load_case(const pl_json_value *root, vcase *c)
{
    int rc;
    const char *op = NULL;
    if (root->type != PL_JSON_OBJECT)
        return pl_error(PL_E_FORMAT, "expected a JSON object, found %s",
                        pl_json_type_name(root->type));
    if ((rc = get_str(root, "op", &op)) < 0) return rc;
    if (!strcmp(op, "conv2d"))
        c->op = OP_CONV;
    else if (!strcmp(op, "depthwise_conv2d"))
        c->op = OP_DEPTHWISE;
    else if (!strcmp(op, "fully_connected"))
        c->op = OP_FC;
    else if (!strcmp(op, "avgpool"))
        c->op = OP_AVGPOOL;
    else if (!strcmp(op, "maxpool"))
        c->op = OP_MAXPOOL;
    else
        return pl_error(PL_E_FORMAT,
                        "field 'op' \"%s\": expected conv2d, depthwise_conv2d, "
                        "fully_connected, avgpool or maxpool",
                        op);
    const pl_json_value *prov = pl_json_get(root, "provenance");
    if (!prov || prov->type != PL_JSON_OBJECT)
        return pl_error(PL_E_FORMAT,
                        "field 'provenance': expected an object saying how the case "
                        "was made, found %s",
                        prov ? pl_json_type_name(prov->type) : "nothing");

    const long long D = NN_S8_MAX_DIM;
    int batches = 0;
    if ((rc = get_i(root, "batches", 1, D, &batches)) < 0 ||
        (rc = get_i(root, "input_h", 1, D, &c->in.h)) < 0 ||
        (rc = get_i(root, "input_w", 1, D, &c->in.w)) < 0 ||
        (rc = get_i(root, "input_c", 1, NN_S8_MAX_CHANNELS, &c->in.c)) < 0 ||
        (rc = get_i(root, "output_c", 1, NN_S8_MAX_CHANNELS, &c->out.c)) < 0 ||
        (rc = get_i32(root, "act_min", -128, 127, &c->conv.act_min)) < 0 ||
        (rc = get_i32(root, "act_max", -128, 127, &c->conv.act_max)) < 0)
        return rc;
    c->in.n = c->out.n = batches;
    const int32_t act_min = c->conv.act_min, act_max = c->conv.act_max;
    size_t n_in = 0, n_out = 0;

    if (c->op == OP_FC) {
        int depth = 0;
        const char *gran = NULL;
        if ((rc = get_i(root, "accum_depth", 1, NN_S8_MAX_FC_DEPTH, &depth)) < 0) return rc;
        if ((long long)c->in.h * c->in.w * c->in.c != depth)
            return pl_error(PL_E_FORMAT,
                            "field 'accum_depth' %d: expected input_h*input_w*input_c "
                            "= %lld",
                            depth, (long long)c->in.h * c->in.w * c->in.c);
        c->in = (nn_dims){batches, 1, 1, depth};
        c->out.h = c->out.w = 1;
        c->fc.act_min = act_min;
        c->fc.act_max = act_max;
        if ((rc = get_i32(root, "input_offset", -127, 128, &c->fc.input_offset)) < 0 ||
            (rc = get_i32(root, "weights_offset", -127, 128, &c->fc.weights_offset)) < 0 ||
            (rc = get_i32(root, "output_offset", -128, 127, &c->fc.output_offset)) < 0 ||
            (rc = get_str(root, "quant_granularity", &gran)) < 0)
            return rc;
        if (!strcmp(gran, "per_channel"))
            c->fc.per_channel = 1;
        else if (!strcmp(gran, "per_tensor"))
            c->fc.per_channel = 0;
        else
            return pl_error(PL_E_FORMAT,
                            "field 'quant_granularity' \"%s\": expected per_channel "
                            "or per_tensor",
                            gran);
        if ((rc = nn_fc_s8_check(&c->fc, batches, depth, depth, c->out.c, c->out.c)) < 0) return rc;
        n_in = packed(&c->in);
        n_out = packed(&c->out);
        const size_t n_q = c->fc.per_channel ? (size_t)c->out.c : 1;
        const char *q_what = c->fc.per_channel ? "output_c, per_channel" : "per_tensor";
        if ((rc = I8_ARRAY("weights", (size_t)c->out.c * (size_t)depth, "output_c*accum_depth", 0,
                           &c->weights)) < 0 ||
            (rc = I32_ARRAY("bias", (size_t)c->out.c, "output_c", 1, &c->bias)) < 0 ||
            (rc = I32_ARRAY("multiplier", n_q, q_what, 0, &c->multiplier)) < 0 ||
            (rc = I32_ARRAY("shift", n_q, q_what, 0, &c->shift)) < 0)
            return rc;
        if ((rc = nn_quant_s8_check(c->multiplier, c->shift, (int)n_q)) < 0) return rc;
    } else {
        if ((rc = get_i(root, "output_h", 1, D, &c->out.h)) < 0 ||
            (rc = get_i(root, "output_w", 1, D, &c->out.w)) < 0 ||
            (rc = get_i(root, "kernel_h", 1, D, &c->filter.h)) < 0 ||
            (rc = get_i(root, "kernel_w", 1, D, &c->filter.w)) < 0)
            return rc;
        nn_conv_s8_params *p = &c->conv;
        if (c->op == OP_AVGPOOL || c->op == OP_MAXPOOL) {
            nn_pool_s8_params *pp = &c->pool;
            pp->kernel_h = c->filter.h;
            pp->kernel_w = c->filter.w;
            pp->act_min = act_min;
            pp->act_max = act_max;
            if ((rc = get_i(root, "stride_h", 1, D, &pp->stride_h)) < 0 ||
                (rc = get_i(root, "stride_w", 1, D, &pp->stride_w)) < 0 ||
                (rc = get_i(root, "pad_h", 0, D, &pp->pad_h)) < 0 ||
                (rc = get_i(root, "pad_w", 0, D, &pp->pad_w)) < 0 ||
                (rc = nn_pool2d_s8_check(pp, &c->in, c->in.c, &c->out, c->out.c)) < 0)
                return rc;
        } else {
            const char *gran = NULL;
            if ((rc = get_i(root, "stride_h", 1, D, &p->stride_h)) < 0 ||
                (rc = get_i(root, "stride_w", 1, D, &p->stride_w)) < 0 ||
                (rc = get_i(root, "pad_h", 0, D, &p->pad_h)) < 0 ||
                (rc = get_i(root, "pad_w", 0, D, &p->pad_w)) < 0 ||
                (rc = get_i(root, "dilation_h", 1, D, &p->dilation_h)) < 0 ||
                (rc = get_i(root, "dilation_w", 1, D, &p->dilation_w)) < 0 ||
                (rc = get_i32(root, "input_offset", -127, 128, &p->input_offset)) < 0 ||
                (rc = get_i32(root, "output_offset", -128, 127, &p->output_offset)) < 0 ||
                (rc = get_str(root, "quant_granularity", &gran)) < 0)
                return rc;
            if (strcmp(gran, "per_channel") != 0)
                return pl_error(PL_E_FORMAT,
                                "field 'quant_granularity' \"%s\": expected "
                                "per_channel for %s",
                                gran, op);
            if (c->op == OP_CONV) {
                c->filter.n = c->out.c;
                c->filter.c = c->in.c;
                rc = nn_conv2d_s8_check(p, &c->in, c->in.c, &c->filter, &c->out, c->out.c);
            } else {
                int mult = 0;
                if ((rc = get_i(root, "depth_multiplier", 1, NN_S8_MAX_CHANNELS, &mult)) < 0)
                    return rc;
                if ((long long)c->in.c * mult != c->out.c)
                    return pl_error(PL_E_FORMAT,
                                    "field 'output_c' %d: expected input_c*"
                                    "depth_multiplier = %lld",
                                    c->out.c, (long long)c->in.c * mult);
                c->filter.n = 1;
                c->filter.c = c->out.c;
                rc =
                    nn_depthwise_conv2d_s8_check(p, &c->in, c->in.c, &c->filter, &c->out, c->out.c);
            }
            if (rc < 0) return rc;
            const size_t n_w = packed(&c->filter);
            if ((rc = I8_ARRAY("weights", n_w,
                               c->op == OP_CONV ? "output_c*kernel_h*kernel_w*input_c"
                                                : "kernel_h*kernel_w*output_c",
                               0, &c->weights)) < 0 ||
                (rc = I32_ARRAY("bias", (size_t)c->out.c, "output_c", 1, &c->bias)) < 0 ||
                (rc = I32_ARRAY("multiplier", (size_t)c->out.c, "output_c", 0, &c->multiplier)) <
                    0 ||
                (rc = I32_ARRAY("shift", (size_t)c->out.c, "output_c", 0, &c->shift)) < 0)
                return rc;
            if ((rc = nn_quant_s8_check(c->multiplier, c->shift, c->out.c)) < 0) return rc;
        }
        n_in = packed(&c->in);
        n_out = packed(&c->out);
    }
    c->q.multiplier = c->multiplier;
    c->q.shift = c->shift;
    if ((rc = I8_ARRAY("input", n_in, "batches*input_h*input_w*input_c", 0, &c->input)) < 0)
        return rc;
    return I8_ARRAY("expected_output", n_out, "batches*output_h*output_w*output_c", 0,
                    &c->expected);
}

/* --- Kernel adapters ------------------------------------------------------------------------- */

static void run_conv2d(const vcase *c, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                       int e)
{
    nn_conv2d_s8__ref(&c->conv, &c->q, &c->in, in, in_s, &c->filter, c->weights, c->bias, &c->out,
                      out, out_s, b, e);
}
static void run_conv1x1(const vcase *c, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                        int e)
{
    nn_conv1x1_s8__ref(&c->conv, &c->q, &c->in, in, in_s, &c->filter, c->weights, c->bias, &c->out,
                       out, out_s, b, e);
}
static void run_depthwise(const vcase *c, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                          int e)
{
    nn_depthwise_conv2d_s8__ref(&c->conv, &c->q, &c->in, in, in_s, &c->filter, c->weights, c->bias,
                                &c->out, out, out_s, b, e);
}
static void run_fc(const vcase *c, const int8_t *in, int in_s, int8_t *out, int out_s, int b, int e)
{
    nn_fc_s8__ref(&c->fc, &c->q, c->in.n, c->in.c, in, in_s, c->weights, c->bias, c->out.c, out,
                  out_s, b, e);
}
static void run_maxpool(const vcase *c, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                        int e)
{
    nn_maxpool2d_s8__ref(&c->pool, &c->in, in, in_s, &c->out, out, out_s, b, e);
}
static void run_avgpool(const vcase *c, const int8_t *in, int in_s, int8_t *out, int out_s, int b,
                        int e)
{
    nn_avgpool2d_s8__ref(&c->pool, &c->in, in, in_s, &c->out, out, out_s, b, e);
}

/* --- Running and comparing ------------------------------------------------------------------- */

enum { IN_PAD = 3, OUT_OFF = 2, OUT_PAD = 5, GUARD = 0x5b, IN_FILL = 127 };

/* Compares output channels [0, out.c) of every pixel of `got` (pixel stride `stride`, starting at
 * channel `off`) with the packed expected output; also that bytes outside them kept GUARD.
 * 1 when equal, else prints the failure line and returns 0. */
static int compare(const vcase *c, const char *variant, const int8_t *got, int stride, int off)
{
    const size_t pixels = (size_t)c->out.n * c->out.h * c->out.w, oc = (size_t)c->out.c;
    size_t bad = 0, first = 0;
    int8_t want = 0, have = 0;
    for (size_t px = 0; px < pixels; px++)
        for (size_t ch = 0; ch < oc; ch++) {
            const int8_t g = got[px * (size_t)stride + (size_t)off + ch];
            if (g != c->expected[px * oc + ch] && bad++ == 0) {
                first = px * oc + ch;
                want = c->expected[first];
                have = g;
            }
        }
    if (bad) {
        const size_t px = first / oc;
        fail_line(c->path,
                  "%s: expected_output[%zu] (pixel %zu, channel %zu) expected %d, got %d "
                  "(%zu of %zu values differ)",
                  variant, first, px, first % oc, want, have, bad, pixels * oc);
        return 0;
    }
    for (size_t px = 0; px < pixels; px++)
        for (size_t ch = 0; ch < (size_t)stride; ch++) {
            if (ch >= (size_t)off && ch < (size_t)off + oc) continue;
            if (got[px * (size_t)stride + ch] != (int8_t)GUARD) {
                fail_line(c->path,
                          "%s: wrote outside its channels (pixel %zu, byte %zu of the "
                          "pixel stride %d)",
                          variant, px, ch, stride);
                return 0;
            }
        }
    return 1;
}

/* Packed whole-range run, then strided run in three channel ranges (last range first). */
static int run_variants(const vcase *c, run_fn fn, const char *kernel)
{
    const size_t in_pixels = (size_t)c->in.n * c->in.h * c->in.w;
    const size_t out_pixels = (size_t)c->out.n * c->out.h * c->out.w;
    const int in_s = c->in.c + IN_PAD, out_s = c->out.c + OUT_OFF + OUT_PAD;
    const int nc = c->out.c;
    char variant[192];
    int ok = 1;
    int8_t *out = malloc(out_pixels * (size_t)nc);
    int8_t *in2 = malloc(in_pixels * (size_t)in_s);
    int8_t *out2 = malloc(out_pixels * (size_t)out_s);
    if (!out || !in2 || !out2) {
        fail_line(c->path, "out of memory");
        ok = 0;
        goto done;
    }
    memset(out, GUARD, out_pixels * (size_t)nc);
    fn(c, c->input, c->in.c, out, nc, 0, nc);
    snprintf(variant, sizeof variant, "%s packed", kernel);
    if (!compare(c, variant, out, nc, 0)) {
        ok = 0;
        goto done;
    }

    memset(in2, IN_FILL, in_pixels * (size_t)in_s);
    for (size_t px = 0; px < in_pixels; px++)
        memcpy(in2 + px * (size_t)in_s, c->input + px * (size_t)c->in.c, (size_t)c->in.c);
    memset(out2, GUARD, out_pixels * (size_t)out_s);
    const int a = nc / 3, b = 2 * nc / 3;
    fn(c, in2, in_s, out2 + OUT_OFF, out_s, b, nc);
    fn(c, in2, in_s, out2 + OUT_OFF, out_s, a, b);
    fn(c, in2, in_s, out2 + OUT_OFF, out_s, 0, a);
    snprintf(variant, sizeof variant,
             "%s strided (in_c_stride %d, out_c_stride %d at +%d), "
             "split [0,%d) [%d,%d) [%d,%d)",
             kernel, in_s, out_s, OUT_OFF, a, a, b, b, nc);
    ok = compare(c, variant, out2, out_s, OUT_OFF);
done:
    free(out);
    free(in2);
    free(out2);
    return ok;
}

static void run_file(const char *path)
{
    pl_json_doc doc;
    vcase c;
    memset(&c, 0, sizeof c);
    c.path = path;
    if (pl_json_read_file(path, &doc) < 0) {
        /* the parser's message already starts with the path */
        const char *msg = pl_last_error();
        const size_t n = strlen(path);
        if (!strncmp(msg, path, n) && !strncmp(msg + n, ": ", 2)) msg += n + 2;
        fail_line(path, "%s", msg);
        n_failed++;
        return;
    }
    int ok = 0;
    if (load_case(&doc.root, &c) < 0) {
        fail_line(path, "%s", pl_last_error());
    } else {
        switch (c.op) {
        case OP_CONV:
            ok = run_variants(&c, run_conv2d, "nn_conv2d_s8__ref");
            if (ok && c.filter.h == 1 && c.filter.w == 1 && c.conv.pad_h == 0 && c.conv.pad_w == 0)
                ok = run_variants(&c, run_conv1x1, "nn_conv1x1_s8__ref");
            break;
        case OP_DEPTHWISE:
            ok = run_variants(&c, run_depthwise, "nn_depthwise_conv2d_s8__ref");
            break;
        case OP_FC:
            ok = run_variants(&c, run_fc, "nn_fc_s8__ref");
            break;
        case OP_AVGPOOL:
            ok = run_variants(&c, run_avgpool, "nn_avgpool2d_s8__ref");
            break;
        case OP_MAXPOOL:
            ok = run_variants(&c, run_maxpool, "nn_maxpool2d_s8__ref");
            break;
        }
    }
    if (ok) {
        n_passed++;
        if (verbose) printf("pass %s\n", path);
    } else {
        n_failed++;
    }
    free_case(&c);
    pl_json_free(&doc);
}

static int ends_with(const char *s, const char *suffix)
{
    const size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

/* A file is run when named directly or, inside a directory, when it ends in .json. */
static void walk(const char *path, int depth, int named)
{
    struct stat st;
    if (stat(path, &st) != 0) {
        fail_line(path, "cannot open: %s", strerror(errno));
        n_failed++;
        return;
    }
    if (!S_ISDIR(st.st_mode)) {
        if (named || (S_ISREG(st.st_mode) && ends_with(path, ".json"))) run_file(path);
        return;
    }
    if (depth >= MAX_DEPTH) {
        fail_line(path, "directories nested deeper than %d (a symlink loop?)", MAX_DEPTH);
        n_failed++;
        return;
    }
    struct dirent **names = NULL;
    const int n = scandir(path, &names, NULL, alphasort);
    if (n < 0) {
        fail_line(path, "cannot read directory: %s", strerror(errno));
        n_failed++;
        return;
    }
    for (int i = 0; i < n; i++) {
        const char *name = names[i]->d_name;
        if (name[0] != '.') {
            const size_t len = strlen(path) + strlen(name) + 2;
            char *child = malloc(len);
            if (child) {
                snprintf(child, len, "%s/%s", path, name);
                walk(child, depth + 1, 0);
                free(child);
            } else {
                fail_line(path, "out of memory");
                n_failed++;
            }
        }
        free(names[i]);
    }
    free(names);
}

static void usage(FILE *f)
{
    fprintf(f, "usage: nn_vectors [-v] PATH...\n"
               "Runs every int8 golden-vector case (*.json, directories searched recursively)\n"
               "through the reference int8 kernels and compares bit-exactly. Prints one line per\n"
               "failure and 'N passed, M failed'; exits 1 on any failure or when no case ran.\n"
               "  -v, --verbose   also print a line per passing case\n"
               "  -h, --help      this help\n");
}

int main(int argc, char **argv)
{
    static const struct option opts[] = {
        {"verbose", no_argument, NULL, 'v'}, {"help", no_argument, NULL, 'h'}, {NULL, 0, NULL, 0}};
    int ch;
    while ((ch = getopt_long(argc, argv, "vh", opts, NULL)) != -1) {
        switch (ch) {
        case 'v':
            verbose = 1;
            break;
        case 'h':
            usage(stdout);
            return 0;
        default:
            usage(stderr);
            return 2;
        }
    }
    if (optind >= argc) {
        usage(stderr);
        return 2;
    }
    for (int i = optind; i < argc; i++)
        walk(argv[i], 0, 1);
    printf("%d passed, %d failed\n", n_passed, n_failed);
    return n_failed == 0 && n_passed > 0 ? 0 : 1;
}
