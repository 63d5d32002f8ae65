/* A small, strict, bounded JSON parser (RFC 8259) into a read-only tree.
 *
 * Strict: exactly one value (surrounded by optional whitespace); no comments, trailing commas,
 * NaN/Infinity literals, leading zeros, single quotes or control characters in strings; strings
 * must be valid UTF-8 and escapes complete (\uXXXX with surrogate pairs checked); duplicate keys
 * in one object are an error. Numbers are parsed with strtod after the JSON grammar is checked;
 * a number whose magnitude overflows a double is an error (underflow gives 0 or a subnormal).
 * Bounded: input at most PL_JSON_MAX_BYTES, nesting at most PL_JSON_MAX_DEPTH, at most
 * PL_JSON_MAX_VALUES values. Every error is PL_E_FORMAT (PL_E_NOMEM when memory runs out) with a
 * message "<name>: byte <offset> (line L, column C): <what was expected>, found <what>". */
#ifndef PL_CORE_JSON_H
#define PL_CORE_JSON_H

#include <stddef.h>

#define PL_JSON_MAX_BYTES ((size_t)64 << 20)
#define PL_JSON_MAX_DEPTH 64
#define PL_JSON_MAX_VALUES ((size_t)4 << 20) /* each value takes 56 bytes of tree */

typedef enum pl_json_type {
    PL_JSON_NULL,
    PL_JSON_FALSE,
    PL_JSON_TRUE,
    PL_JSON_NUMBER,
    PL_JSON_STRING,
    PL_JSON_ARRAY,
    PL_JSON_OBJECT,
} pl_json_type;

typedef struct pl_json_value pl_json_value;
struct pl_json_value {
    pl_json_type type;
    size_t offset;        /* byte offset of the value's first character in the text */
    double number;        /* PL_JSON_NUMBER */
    char *str;            /* PL_JSON_STRING: decoded UTF-8, NUL-terminated (may hold \u0000) */
    size_t len;           /* string: bytes in str; array/object: number of items */
    pl_json_value *items; /* array elements or object member values, in document order */
    char **keys;          /* object: decoded member names (NUL-terminated), parallel to items */
};

/* A parsed document; owns every value and string. */
typedef struct pl_json_doc {
    pl_json_value root;
} pl_json_doc;

/* Parses len bytes of text (need not be NUL-terminated). `name` (a file name, or NULL for
 * "json") starts error messages. On failure *doc is empty and needs no free. */
int pl_json_parse(const char *text, size_t len, const char *name, pl_json_doc *doc);
void pl_json_free(pl_json_doc *doc);

/* The member `key` of an object, or NULL (also when v is not an object). */
const pl_json_value *pl_json_get(const pl_json_value *v, const char *key);
/* Name of a type ("number", "object", ...), for messages. */
const char *pl_json_type_name(pl_json_type t);

#endif
