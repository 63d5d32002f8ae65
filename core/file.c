#include "core/file.h"

#include <errno.h>
#include <fcntl.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "core/util.h"

const char *pl_file_not_regular(unsigned mode)
{
    if (S_ISREG(mode)) return NULL;
    if (S_ISFIFO(mode)) return "is a FIFO";
    if (S_ISCHR(mode)) return "is a character device";
    if (S_ISBLK(mode)) return "is a block device";
    if (S_ISDIR(mode)) return "is a directory";
    if (S_ISSOCK(mode)) return "is a socket";
    return "is not a regular file";
}

static int open_failed(const char *path, const char *what, int err)
{
    return pl_error(PL_E_IO, "%s: cannot open%s%s: %s", path, what ? " " : "", what ? what : "",
                    strerror(err));
}

int pl_file_open_regular(const char *path, const char *what, int *fd, int64_t *size)
{
    *fd = -1;
    if (!path) return pl_error(PL_E_ARG, "%s path is NULL", what ? what : "file");
    struct stat st;
    const char *type;
    if (stat(path, &st) < 0) return open_failed(path, what, errno);
    if ((type = pl_file_not_regular(st.st_mode)))
        return pl_error(PL_E_IO, "%s: %s, expected a regular file", path, type);
    int f = open(path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (f < 0) return open_failed(path, what, errno);
    if (fstat(f, &st) < 0) {
        int err = errno;
        close(f);
        return pl_error(PL_E_IO, "%s: cannot stat: %s", path, strerror(err));
    }
    if ((type = pl_file_not_regular(st.st_mode))) { /* replaced between stat and open */
        close(f);
        return pl_error(PL_E_IO, "%s: %s, expected a regular file", path, type);
    }
    int flags = fcntl(f, F_GETFL);
    if (flags < 0 || fcntl(f, F_SETFL, flags & ~O_NONBLOCK) < 0) {
        int err = errno;
        close(f);
        return pl_error(PL_E_IO, "%s: cannot clear O_NONBLOCK: %s", path, strerror(err));
    }
    *fd = f;
    if (size) *size = (int64_t)st.st_size;
    return PL_OK;
}

int pl_file_fopen_regular(const char *path, const char *what, FILE **f)
{
    *f = NULL;
    int fd, rc = pl_file_open_regular(path, what, &fd, NULL);
    if (rc < 0) return rc;
    if (!(*f = fdopen(fd, "rb"))) {
        int err = errno;
        close(fd);
        return open_failed(path, what, err);
    }
    return PL_OK;
}
