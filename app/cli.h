/* Helpers shared by the subcommands: strict parsing of flag values with clear messages. */
#ifndef PL_APP_CLI_H
#define PL_APP_CLI_H

#include <stddef.h>

/* Each returns 0 on success, or prints "parlight <cmd>: --flag: <problem>" and returns -1. */
int cli_int(const char *cmd, const char *flag, const char *s, long lo, long hi, int *out);
int cli_float3(const char *cmd, const char *flag, const char *s, float out[3]);
/* --orientation W,X,Y,Z: four finite numbers (unit length is checked by pl_quat_to_rotation). */
int cli_quat(const char *cmd, const char *s, double q[4]);
/* A number in [lo, hi], or in (lo, hi] when lo_open. */
int cli_double(const char *cmd, const char *flag, const char *s, double lo, double hi, int lo_open,
               double *out);
/* --anchor: "off" (w = b = 0, gamma 2.2) or W,B or W,B,GAMMA (pl_model_set_anchor's ranges). */
int cli_anchor(const char *cmd, const char *s, double out[3]);

/* A shared secret from `path` (--token-file): its first line without the newline, 1..cap-1
 * bytes, no control characters. The file must be a regular file that not every user can read.
 * Prints "parlight <cmd>: --token-file PATH: <problem>" and returns -1 otherwise. */
int cli_read_token(const char *cmd, const char *path, char *out, size_t cap);

/* --max-pixels N, the same in every command that reads images or panoramas: the read limit
 * (core/image.h: pl_image_set_max_pixels), 1..PL_IMAGE_MAX_PIXELS. The getopt_long value is
 * CLI_OPT_MAX_PIXELS. Prints "parlight <cmd>: --max-pixels ..." and returns -1 when out of range.
 */
enum { CLI_OPT_MAX_PIXELS = 0x4d50 };
int cli_max_pixels(const char *cmd, const char *s);

/* For getopt_long's ':' (an option without its value; the optstring must start with ':') and
 * '?' (an unknown option, or a value given to one that takes none) results `c`: prints
 * "parlight <cmd>: ..." naming the option as the user wrote it and returns 2, the exit status
 * for a usage error. */
int cli_getopt_error(const char *cmd, int c, char *const argv[]);

#endif
