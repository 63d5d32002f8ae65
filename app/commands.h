/* The parlight subcommands. Each lives in app/cmd_<name>.c as `int cmd_<name>(int argc, char **argv)`
 * (argv[0] is the command name), prints its own --help, and returns the process exit code:
 * 0 success, 1 failure (one line on stderr naming the problem), 2 bad usage. */
#ifndef PL_APP_COMMANDS_H
#define PL_APP_COMMANDS_H

/* X(name, summary) — one line per command, in the order `parlight --help` lists them. */
#define PL_COMMANDS(X)                                                                             \
    X(estimate, "estimate lights from image files, videos or directories (JSON lines)")            \
    X(cameras, "list V4L2 cameras with their formats, frame sizes and rates")                      \
    X(info, "print a model's architecture, N, input size, parameters and file size")              \
    X(render, "render lights (JSON) to an env map, cube map or sphere image (EXR/HDR/PNG)")        \
    X(compare, "RMSE and scale-invariant RMSE between two lightings (sphere renders)")        \
    X(extract, "ground-truth lights + ambient from an HDR panorama (JSON)")                    \
    X(crop, "perspective LDR crops of an HDR panorama with their ground-truth lights")          \
    X(eval, "score a model and baselines on crops of a folder of HDR panoramas")               \
    X(quantize, "float model -> int8 model calibrated on frames (minmax/percentile/entropy/mse)")  \
    X(qcheck, "int8 vs float: per-layer SQNR/cosine and end-to-end light errors")                \
    X(bench, "time estimates on one frame: median/min/max ms, ISA, GMAC/s, peak RSS")            \
    X(view, "live viewer: estimate to a browser page (three.js) over WebSocket, prints the URL")

#define PL_DECLARE(name, summary) int cmd_##name(int argc, char **argv);
PL_COMMANDS(PL_DECLARE)
#undef PL_DECLARE

#endif
