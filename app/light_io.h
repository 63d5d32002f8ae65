/* Helpers shared by the lighting commands (render, compare): output files by extension, the
 * --at point, and lighting-or-panorama inputs. They print nothing; errors go through pl_error. */
#ifndef PL_APP_LIGHT_IO_H
#define PL_APP_LIGHT_IO_H

#include "core/image.h"
#include "light/light.h"
#include "parlight.h"

/* Output kind from the extension of path: 1 = linear HDR (.exr, .hdr), 2 = tonemapped .png,
 * 0 = unknown. Case-insensitive. */
int pl_app_output_kind(const char *path);
/* Writes img to path: .exr/.hdr linear (pl_hdr_write), .png tonemapped (pl_tonemap_rgb8).
 * Refuses to replace an existing path unless force. */
int pl_app_write_image(const char *path, const pl_image_f32 *img, int force);
/* Parses "x,y,z" (metres, finite) into p; PL_E_ARG with the text on failure. */
int pl_app_parse_point(const char *text, float p[3]);
/* Input kind of a file for compare: 1 = lights JSON (.json), 2 = panorama (.exr, .hdr), 0 =
 * unknown. */
int pl_app_input_kind(const char *path);

/* Writes s as a JSON string literal (quotes, escapes) to f. */
#include <stdio.h>
void pl_app_put_json_string(FILE *f, const char *s);

#endif
