/* Opening a user-given path that must be a regular file: a model, a panorama, a lights JSON, an
 * image. open(2) of a FIFO blocks until a writer appears (forever, for a FIFO nobody writes), and
 * a FIFO, a device or a directory is never what the user meant, so every such path goes through
 * here: the type is checked with stat(2) before opening (a device is not even opened), the file
 * is opened O_RDONLY | O_NONBLOCK | O_CLOEXEC (O_NONBLOCK makes the open of a FIFO return at
 * once should one appear in between), checked again with fstat(2), and O_NONBLOCK is cleared so
 * reads block as usual. A refusal names the path and the type:
 *   "PATH: is a FIFO, expected a regular file"
 * Paths that may legitimately be something else (a camera device, `-` for stdin, a directory of
 * frames) are not opened through here. */
#ifndef PL_CORE_FILE_H
#define PL_CORE_FILE_H

#include <stdint.h>
#include <stdio.h>

/* Opens `path` for reading as above. `what` names the file in the message when it cannot be
 * opened ("PATH: cannot open model: No such file or directory"); NULL: "PATH: cannot open: ...".
 * On success *fd is the descriptor (the caller closes it) and *size, when not NULL, the file's
 * size in bytes. On failure returns PL_E_IO with pl_last_error() set and *fd = -1. */
int pl_file_open_regular(const char *path, const char *what, int *fd, int64_t *size);

/* The same, as a stdio stream opened "rb" (the caller fcloses it). */
int pl_file_fopen_regular(const char *path, const char *what, FILE **f);

/* "is a FIFO", "is a character device", "is a block device", "is a directory", "is a socket"
 * for a st_mode from stat(2); NULL for a regular file. */
const char *pl_file_not_regular(unsigned mode);

#endif
