/* JSON files: read whole, then parsed by the floors below (core/json.h, light/lights_json.h,
 * light/ridge.h), which do no file I/O. Messages name the path. */
#ifndef PL_PORT_JSON_FILE_H
#define PL_PORT_JSON_FILE_H

#include "core/json.h"
#include "light/ridge.h"
#include "parlight.h"

/* Reads a whole file (at most PL_JSON_MAX_BYTES) and parses it (pl_json_parse). */
int pl_json_read_file(const char *path, pl_json_doc *doc);
/* A lights JSON file (light/lights_json.h). */
int pl_lighting_read_json(const char *path, pl_lighting *out);
/* A ridge baseline model file (light/ridge.h, models/parlight-ridge.json). */
int pl_ridge_load(const char *path, pl_ridge **out);

#endif
