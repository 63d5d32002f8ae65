/* Helpers shared by `parlight extract` and `parlight crop`: strict number flags, the room flags
 * and the ground-truth JSON they write. Print only to the FILE given. */
#ifndef PL_APP_LIGHTDATA_H
#define PL_APP_LIGHTDATA_H

#include <stdio.h>

#include "light/extract.h"

/* Parses a finite number in [lo, hi]; on failure prints "parlight <cmd>: <flag> '<s>': ..." to
 * stderr and returns -1. */
int pl_app_double(const char *cmd, const char *flag, const char *s, double lo, double hi,
                  double *out);

/* Writes the lights + ambient and the extraction's provenance as JSON members (no braces, no
 * trailing comma): source, size, "lights", "ambient", "distance_assumed": true, the room, the
 * energy measure, per-light diagnostics and (when timing) timings. Returns 0 or a negative
 * pl_status. */
int pl_app_put_extract_json(FILE *f, const char *source, int width, int height,
                            const pl_lighting *L, const pl_extract_params *p,
                            const pl_extract_info *info, int timing);

#endif
