/* `parlight estimate --poses FILE`: one camera orientation per frame, from a phone's AR session
 * or an IMU logger (docs/OUTPUT.md, "World space"). JSON lines, one object each:
 *     {"frame": 12, "q": [w, x, y, z]}        by the frame number in the output
 *     {"t_ns": 1712345678901234567, "q": [w, x, y, z]}   by the frame's timestamp
 * every line keyed the same way, keys strictly increasing, q a camera-to-world unit quaternion
 * (within PL_QUAT_UNIT_TOL). Other members are ignored (a logger may add its own); empty lines
 * are skipped. By frame, a frame must have its own line; by time, a frame between two lines gets
 * their slerp and one outside the file's span is an error: never a silent wrong orientation. */
#ifndef PL_APP_POSES_H
#define PL_APP_POSES_H

#include <stddef.h>
#include <stdint.h>

typedef struct cli_pose {
    int64_t key; /* frame number or t_ns */
    double q[4];
    double exposure; /* > 0; 0: the line has none */
} cli_pose;

typedef struct cli_poses {
    int by_time; /* keys are t_ns (else frame numbers) */
    size_t n;
    cli_pose *pose;
    char path[512];
} cli_poses;

/* Reads and checks the whole file; messages "PATH:LINE: problem". PL_E_FORMAT / PL_E_IO. */
int cli_poses_load(const char *path, cli_poses *p);

/* The orientation of a frame (its output number and timestamp) into q, and its exposure into
 * *exposure when not NULL (0 when the file has none for it). PL_E_ARG, naming the frame and the
 * file, when the file has no orientation for it. */
int cli_poses_lookup(const cli_poses *p, int64_t frame, int64_t t_ns, double q[4],
                     double *exposure);

void cli_poses_free(cli_poses *p);

#endif
