/* Lights JSON: reading and writing pl_lighting in the same field names as the estimate output
 * (docs/LIGHTING.md, DESIGN.md "Output"):
 *   {"lights":[{"dir":[x,y,z],"distance_m":d,"solid_angle_sr":s,"rgb":[r,g,b]}, ...],
 *    "ambient":[r,g,b]}
 * Extra fields anywhere are ignored (so a whole estimate line is a valid input). Missing fields,
 * wrong types, non-finite or out-of-range values (distance/solid angle <= 0, negative rgb or
 * ambient, zero direction, more than PL_MAX_LIGHTS lights) are rejected with PL_E_FORMAT and a
 * message naming the field ("lights[1].rgb[2]: expected a number >= 0, found -1").
 * Directions are normalised on reading. */
#ifndef PL_LIGHT_LIGHTS_JSON_H
#define PL_LIGHT_LIGHTS_JSON_H

#include <stddef.h>

#include "core/json.h"
#include "parlight.h"

/* Parses len bytes of text (need not be NUL-terminated). A file: pl_lighting_read_json
 * (port/json_file.h). */
int pl_lighting_parse_json(const char *text, size_t len, pl_lighting *out);
/* The lighting of a parsed document's root; messages start with `name`. */
int pl_lighting_from_json(const char *name, const pl_json_value *root, pl_lighting *out);
/* Appends `"lights":[...],"ambient":[r,g,b]` (no braces) to buf, NUL-terminated; returns bytes
 * written (excluding the NUL) or <0 (PL_E_ARG when cap is too small). Numbers with %.9g, so a
 * float round-trips exactly. */
int pl_lighting_format_json(const pl_lighting *L, char *buf, size_t cap);

#endif
