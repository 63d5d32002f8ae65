/* Helpers shared by the subcommands: strict parsing of flag values with clear messages. */
#ifndef PL_APP_CLI_H
#define PL_APP_CLI_H

/* Each returns 0 on success, or prints "parlight <cmd>: --flag: <problem>" and returns -1. */
int cli_int(const char *cmd, const char *flag, const char *s, long lo, long hi, int *out);
int cli_float3(const char *cmd, const char *flag, const char *s, float out[3]);

#endif
