/* port/json.c and light/lights_json.c: the strict parser on valid documents (escapes, surrogate
 * pairs, numbers) and on malformed ones (truncated, deep nesting, huge numbers, NaN literal,
 * trailing commas, bad escapes, bad UTF-8, duplicate keys, trailing garbage), each with a clear
 * message and byte offset; the lights JSON on wrong types, missing fields and bad values (the
 * message names the field); and format -> parse round trips. */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/json.h"
#include "core/util.h"
#include "light/lights_json.h"
#include "port/json_file.h"
#include "light_test.h"

static int parse(const char *s, pl_json_doc *d)
{
    return pl_json_parse(s, strlen(s), "t.json", d);
}

/* Expects a parse failure whose message contains `want`. */
static void bad(const char *text, const char *want)
{
    pl_json_doc d;
    int rc = parse(text, &d);
    CHECK(rc == PL_E_FORMAT, "'%.40s' should fail (rc %d)", text, rc);
    CHECK(strstr(pl_last_error(), want) != NULL, "'%.40s': message '%s' lacks '%s'", text,
          pl_last_error(), want);
    CHECK(d.root.type == PL_JSON_NULL && d.root.items == NULL, "failed doc is empty");
}

static void test_valid(void)
{
    pl_json_doc d;
    const char *t = " {\"a\": [1, -2.5e3, 0, -0, 1E-2, true, false, null], \"s\": "
                    "\"x\\\"\\\\\\/\\b\\f\\n\\r\\t\\u00e9\\ud83d\\ude00\","
                    " \"o\": {}, \"e\": [] } \n";
    CHECK(parse(t, &d) == 0, "valid doc: %s", pl_last_error());
    const pl_json_value *a = pl_json_get(&d.root, "a"), *s = pl_json_get(&d.root, "s");
    CHECK(a && a->type == PL_JSON_ARRAY && a->len == 8, "array");
    if (a && a->len == 8) {
        CHECK(a->items[1].number == -2500 && a->items[4].number == 0.01, "numbers");
        CHECK(a->items[5].type == PL_JSON_TRUE && a->items[7].type == PL_JSON_NULL, "literals");
        CHECK(a->items[1].offset == 11, "offset of -2.5e3: %zu", a->items[1].offset);
    }
    CHECK(s && s->type == PL_JSON_STRING && s->len == 9 + 2 + 4 &&
              !memcmp(s->str, "x\"\\/\b\f\n\r\t\xc3\xa9\xf0\x9f\x98\x80", 15),
          "escapes decoded to UTF-8");
    CHECK(pl_json_get(&d.root, "o")->len == 0 && pl_json_get(&d.root, "missing") == NULL,
          "empty object, missing key");
    pl_json_free(&d);
    CHECK(parse("\"\\u0000\"", &d) == 0 && d.root.len == 1 && d.root.str[0] == 0,
          "\\u0000 in a value");
    pl_json_free(&d);
    CHECK(parse("1e-400", &d) == 0 && d.root.number == 0, "underflow is 0");
    pl_json_free(&d);
    /* nesting up to the limit is fine */
    char deep[2 * PL_JSON_MAX_DEPTH + 1];
    for (int i = 0; i < PL_JSON_MAX_DEPTH; i++)
        deep[i] = '[', deep[2 * PL_JSON_MAX_DEPTH - 1 - i] = ']';
    deep[2 * PL_JSON_MAX_DEPTH] = 0;
    CHECK(parse(deep, &d) == 0, "depth %d accepted: %s", PL_JSON_MAX_DEPTH, pl_last_error());
    pl_json_free(&d);
}

static void test_malformed(void)
{
    bad("", "byte 0");
    bad("   ", "expected a value");
    bad("{\"lights\": [1, 2", "expected ',' or ']'");
    bad("{\"lights\": [1, 2", "end of input");
    bad("{\"a\":", "expected a value");
    bad("{\"a\" 1}", "expected ':'");
    bad("{\"a\":1,}", "trailing comma");
    bad("[1,]", "trailing comma");
    bad("[1 2]", "expected ',' or ']'");
    bad("{a:1}", "member name");
    bad("\"abc", "unterminated string");
    bad("\"a\\x\"", "valid escape");
    bad("\"\\u12G4\"", "hex digit");
    bad("\"\\ud800\"", "low surrogate");
    bad("\"\\udc00\"", "high surrogate");
    bad("\"a\nb\"", "control characters");
    bad("\"\xff\"", "UTF-8");
    bad("\"\xc0\xaf\"", "UTF-8");
    bad("NaN", "expected a value");
    bad("[nan]", "expected a value");
    bad("Infinity", "expected a value");
    bad("-Infinity", "digit");
    bad("tru", "expected a value");
    bad("01", "leading zeros");
    bad("1.", "after the decimal point");
    bad("1e", "exponent");
    bad("+1", "expected a value");
    bad("1e999", "double range");
    bad("-1e400", "double range");
    bad("{\"a\":1,\"a\":2}", "duplicate member name \"a\"");
    bad("{} {}", "end of input after the value");
    bad("[1] x", "byte 4");
    bad("[1]\n  x", "line 2, column 3");
    bad("// c\n1", "expected a value");
    bad("'a'", "expected a value");
    /* one level too deep, and much too deep (no stack overflow) */
    char deep[2 * PL_JSON_MAX_DEPTH + 3];
    for (int i = 0; i <= PL_JSON_MAX_DEPTH; i++)
        deep[i] = '[', deep[2 * PL_JSON_MAX_DEPTH + 1 - i] = ']';
    deep[2 * PL_JSON_MAX_DEPTH + 2] = 0;
    bad(deep, "nesting depth");
    size_t n = 1000000;
    char *huge = malloc(n + 1);
    memset(huge, '[', n);
    huge[n] = 0;
    bad(huge, "nesting depth");
    /* a very long number is still parsed with strtod */
    memset(huge, '1', 400);
    huge[400] = 0;
    bad(huge, "double range");
    huge[300] = 0;
    pl_json_doc d;
    CHECK(parse(huge, &d) == 0 && d.root.number > 1e299, "300-digit number");
    pl_json_free(&d);
    free(huge);
    CHECK(pl_json_parse("[1]", 2, NULL, &d) == PL_E_FORMAT &&
              strstr(pl_last_error(), "json: ") == pl_last_error(),
          "len respected (no NUL needed), default name: %s", pl_last_error());
}

static const char *good_lights =
    "{\"frame\": 3, \"lights\": [{\"dir\": [0, 2, 0], \"distance_m\": 2.5, \"solid_angle_sr\": 0.1,"
    " \"rgb\": [1, 2, 3], \"extra\": \"ignored\"}, {\"dir\": [0.6, 0, -0.8], \"distance_m\": 3,"
    " \"solid_angle_sr\": 0.2, \"rgb\": [0, 0.5, 0]}], \"ambient\": [0.1, 0.2, 0.3], \"sh9\": []}";

static void bad_lights(const char *text, const char *want)
{
    pl_lighting L;
    int rc = pl_lighting_parse_json(text, strlen(text), &L);
    CHECK(rc == PL_E_FORMAT, "'%.60s' should fail (rc %d)", text, rc);
    CHECK(strstr(pl_last_error(), want) != NULL, "message '%s' lacks '%s'", pl_last_error(), want);
}

static void test_lights(void)
{
    pl_lighting L;
    CHECK(pl_lighting_parse_json(good_lights, strlen(good_lights), &L) == 0, "good lights: %s",
          pl_last_error());
    CHECK(L.n_lights == 2 && L.lights[0].dir[1] == 1 && L.lights[0].distance_m == 2.5f &&
              L.lights[1].rgb[1] == 0.5f && L.ambient[2] == 0.3f,
          "fields read, direction normalised");
    /* round trip through the formatter is exact */
    char buf[2048];
    strcpy(buf, "{");
    int n = pl_lighting_format_json(&L, buf + 1, sizeof buf - 2);
    CHECK(n > 0, "format");
    strcat(buf, "}");
    pl_lighting M;
    CHECK(pl_lighting_parse_json(buf, strlen(buf), &M) == 0 && !memcmp(&L, &M, sizeof L),
          "round trip: %s", buf);
    CHECK(pl_lighting_format_json(&L, buf, 20) == PL_E_ARG, "small buffer");
    memset(&M, 0, sizeof M);
    n = pl_lighting_format_json(&M, buf, sizeof buf);
    CHECK(n > 0 && !strcmp(buf, "\"lights\":[],\"ambient\":[0,0,0]"), "no lights: %s", buf);

    bad_lights("[1]", "expected a JSON object");
    bad_lights("{\"ambient\":[0,0,0]}", "missing field \"lights\"");
    bad_lights("{\"lights\":{},\"ambient\":[0,0,0]}", "lights: expected an array, found object");
    bad_lights("{\"lights\":[],\"ambient\":[0,0]}", "ambient: expected an array of 3 numbers");
    bad_lights("{\"lights\":[]}", "missing field ambient");
    bad_lights("{\"lights\":[],\"ambient\":[0,\"1\",0]}",
               "ambient[1]: expected a number, found string");
    bad_lights("{\"lights\":[],\"ambient\":[0,-1,0]}",
               "ambient[1]: expected a number >= 0, found -1");
    bad_lights("{\"lights\":[],\"ambient\":[0,1e300,0]}", "ambient[1]: expected a finite float");
    bad_lights("{\"lights\":[5],\"ambient\":[0,0,0]}",
               "lights[0]: expected an object, found number");
    bad_lights("{\"lights\":[{\"distance_m\":1,\"solid_angle_sr\":1,\"rgb\":[1,1,1]}],\"ambient\":["
               "0,0,0]}",
               "missing field lights[0].dir");
    bad_lights("{\"lights\":[{\"dir\":[0,0,0],\"distance_m\":1,\"solid_angle_sr\":1,\"rgb\":[1,1,1]"
               "}],\"ambient\":[0,0,0]}",
               "lights[0].dir: expected a non-zero direction");
    bad_lights("{\"lights\":[{\"dir\":[0,0,1],\"distance_m\":0,\"solid_angle_sr\":1,\"rgb\":[1,1,1]"
               "}],\"ambient\":[0,0,0]}",
               "lights[0].distance_m: expected a number > 0, found 0");
    bad_lights("{\"lights\":[{\"dir\":[0,0,1],\"distance_m\":1,\"solid_angle_sr\":null,\"rgb\":[1,"
               "1,1]}],\"ambient\":[0,0,0]}",
               "lights[0].solid_angle_sr: expected a number, found null");
    bad_lights("{\"lights\":[{\"dir\":[0,0,1],\"distance_m\":1,\"solid_angle_sr\":1}],\"ambient\":["
               "0,0,0]}",
               "missing field lights[0].rgb");
    bad_lights(
        "{\"lights\":[{\"dir\":[0,0,1],\"distance_m\":1,\"solid_angle_sr\":NaN,\"rgb\":[1,1,1]}]}",
        "byte 58");
    char many[4096] = "{\"lights\":[";
    for (int i = 0; i <= PL_MAX_LIGHTS; i++)
        strcat(many, i ? ",{}" : "{}");
    strcat(many, "],\"ambient\":[0,0,0]}");
    bad_lights(many, "expected at most 16");

    const char *tmp = getenv("PL_TEST_TMP");
    char path[4096];
    snprintf(path, sizeof path, "%s/missing-%d.json", tmp ? tmp : "/tmp", (int)getpid());
    CHECK(pl_lighting_read_json(path, &L) == PL_E_IO && strstr(pl_last_error(), path),
          "missing file named: %s", pl_last_error());
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("{\"lights\": [", f);
        fclose(f);
        CHECK(pl_lighting_read_json(path, &L) == PL_E_FORMAT && strstr(pl_last_error(), path) &&
                  strstr(pl_last_error(), "byte 12"),
              "truncated file: %s", pl_last_error());
        remove(path);
    }
}

/* Random mutations (insert, delete, replace, truncate) of valid documents: the parsers must
 * return (0 or an error with a message), never crash or read out of bounds — run under ASan to
 * see the latter. Each input is a malloc'ed copy without a terminating NUL. */
static void test_mutations(void)
{
    static const char alpha[] = "{}[]\",:\\u0123456789eE+-.tfn \xc3\xa9\xff\x01";
    char buf[512];
    long parsed = 0;
    for (long it = 0; it < 100000; it++) {
        const char *seed =
            it % 2 ? good_lights
                   : "[1,-2.5e3,true,false,null,\"a\\u00e9\\ud83d\\ude00\\n\",{\"k\":[[]]}]";
        size_t n = strlen(seed);
        if (n > 400) n = 400;
        memcpy(buf, seed, n);
        for (unsigned m = 0, muts = 1 + rnd() % 4; m < muts; m++) {
            size_t pos = rnd() % (n + 1);
            unsigned op = rnd() % 3;
            if (op == 0 && n < sizeof buf - 1) {
                memmove(buf + pos + 1, buf + pos, n - pos);
                buf[pos] = alpha[rnd() % (sizeof alpha - 1)];
                n++;
            } else if (op == 1 && pos < n) {
                memmove(buf + pos, buf + pos + 1, n - pos - 1);
                n--;
            } else if (pos < n) {
                buf[pos] = alpha[rnd() % (sizeof alpha - 1)];
            }
        }
        if (rnd() % 8 == 0) n = rnd() % (n + 1);
        char *heap = malloc(n ? n : 1);
        memcpy(heap, buf, n);
        pl_json_doc d;
        int rc = pl_json_parse(heap, n, "m", &d);
        if (rc == 0) {
            parsed++;
            pl_json_free(&d);
        } else {
            CHECK(rc == PL_E_FORMAT && strncmp(pl_last_error(), "m: ", 3) == 0,
                  "mutant: rc %d '%s'", rc, pl_last_error());
        }
        pl_lighting L;
        rc = pl_lighting_parse_json(heap, n, &L);
        CHECK(rc == 0 || rc == PL_E_FORMAT, "lights mutant: rc %d", rc);
        free(heap);
    }
    CHECK(parsed > 1000 && parsed < 100000, "mutants parsed: %ld of 100000", parsed);
}

int main(void)
{
    test_valid();
    test_malformed();
    test_lights();
    test_mutations();
    if (failures) {
        printf("%d failures\n", failures);
        return 1;
    }
    printf("ok\n");
    return 0;
}
