/* File sources: a still image, a video (through port/video_cv.cpp) or a directory of frames.
 * The rules (what is a video, directory order, timestamps) are in port/source.h. */
#include "port/source.h"

#include <dirent.h>
#include <errno.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "core/file.h"
#include "core/util.h"
#include "port/image.h"
#include "port/libcamera_src.h"
#include "port/v4l2.h"
#include "port/video_cv.h"

enum source_kind { SRC_FILE, SRC_VIDEO, SRC_DIR, SRC_CAMERA };

typedef struct dir_entry {
    char *name;
    int64_t mtime_ns;
} dir_entry;

struct pl_source {
    enum source_kind kind;
    char *path;
    char *desc;
    pl_image_u8 img; /* the frame buffer handed out, reused */
    size_t capacity;
    int64_t good, bad;
    bool eof;
    /* SRC_FILE: the image decoded at open; handed out once */
    int64_t mtime_ns;
    /* SRC_DIR */
    dir_entry *entries;
    size_t n_entries, next;
    char *file_path; /* path + '/' + longest name, rebuilt per read */
    /* SRC_VIDEO */
    pl_video *video;
    int64_t video_index;
    /* SRC_CAMERA (port/source_v4l2.c), or with libcam set port/source_libcamera.cpp */
    pl_v4l2 *camera;
    pl_libcam *libcam;
};

static const char *const video_exts[] = {"mp4",  "m4v", "mov",  "avi",  "mkv",  "webm", "mjpeg",
                                         "mjpg", "mpg", "mpeg", "ts",   "m2ts", "wmv",  "flv",
                                         "ogv",  "3gp", "y4m",  "h264", "264",  "hevc", "h265"};

static bool has_video_extension(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *dot = strrchr(slash ? slash + 1 : path, '.');
    if (!dot || dot[1] == '\0') return false;
    for (size_t i = 0; i < sizeof video_exts / sizeof video_exts[0]; i++)
        if (strcasecmp(dot + 1, video_exts[i]) == 0) return true;
    return false;
}

static int64_t mtime_ns(const struct stat *st)
{
    return (int64_t)st->st_mtim.tv_sec * 1000000000LL + st->st_mtim.tv_nsec;
}

static char *dup_str(const char *s)
{
    size_t n = strlen(s) + 1;
    char *p = malloc(n);
    if (p) memcpy(p, s, n);
    return p;
}

static int cmp_entry(const void *a, const void *b)
{
    return strcmp(((const dir_entry *)a)->name, ((const dir_entry *)b)->name);
}

static int open_dir(pl_source *s)
{
    DIR *d = opendir(s->path);
    if (!d) return pl_error(PL_E_IO, "%s: cannot open directory: %s", s->path, strerror(errno));
    size_t cap = 0, longest = 0, skipped = 0;
    const size_t plen = strlen(s->path);
    char *tmp = NULL;
    size_t tmp_cap = 0;
    int rc = PL_OK;
    for (;;) {
        errno = 0;
        struct dirent *e = readdir(d);
        if (!e) {
            if (errno)
                rc = pl_error(PL_E_IO, "%s: cannot list directory: %s", s->path, strerror(errno));
            break;
        }
        if (e->d_name[0] == '.') continue;
        const size_t nlen = strlen(e->d_name);
        size_t need;
        if (!pl_add_size(plen, nlen, &need) || !pl_add_size(need, 2, &need)) {
            rc = pl_error(PL_E_NOMEM, "%s: path too long", s->path);
            break;
        }
        if (need > tmp_cap) {
            char *p = realloc(tmp, need);
            if (!p) {
                rc = pl_error(PL_E_NOMEM, "%s: out of memory listing the directory", s->path);
                break;
            }
            tmp = p;
            tmp_cap = need;
        }
        snprintf(tmp, tmp_cap, "%s/%s", s->path, e->d_name);
        struct stat st;
        if (stat(tmp, &st) != 0 || !S_ISREG(st.st_mode)) {
            skipped++;
            continue; /* sub-directories, sockets, dangling links */
        }
        if (s->n_entries == cap) {
            size_t ncap = cap ? cap * 2 : 64, bytes;
            if (!pl_mul_size(ncap, sizeof(dir_entry), &bytes)) {
                rc = pl_error(PL_E_NOMEM, "%s: too many files", s->path);
                break;
            }
            dir_entry *p = realloc(s->entries, bytes);
            if (!p) {
                rc = pl_error(PL_E_NOMEM, "%s: out of memory listing the directory", s->path);
                break;
            }
            s->entries = p;
            cap = ncap;
        }
        char *name = dup_str(e->d_name);
        if (!name) {
            rc = pl_error(PL_E_NOMEM, "%s: out of memory listing the directory", s->path);
            break;
        }
        s->entries[s->n_entries].name = name;
        s->entries[s->n_entries].mtime_ns = mtime_ns(&st);
        s->n_entries++;
        if (nlen > longest) longest = nlen;
    }
    closedir(d);
    free(tmp);
    if (rc < 0) return rc;
    if (s->n_entries == 0)
        return pl_error(
            PL_E_FORMAT,
            "%s: directory has no frame files (hidden files and %zu other entries skipped)",
            s->path, skipped);
    qsort(s->entries, s->n_entries, sizeof *s->entries, cmp_entry);
    s->file_path = malloc(plen + longest + 2);
    if (!s->file_path) return pl_error(PL_E_NOMEM, "%s: out of memory", s->path);
    return PL_OK;
}

static int open_file(pl_source *s, const struct stat *st)
{
    char video_err[512] = "";
    if (has_video_extension(s->path)) {
        int rc = pl_video_open(s->path, &s->video);
        if (rc == PL_OK) {
            s->kind = SRC_VIDEO;
            return PL_OK;
        }
        if (rc == PL_E_NOMEM) return rc;
        snprintf(video_err, sizeof video_err, "%s", pl_last_error());
    }
    s->kind = SRC_FILE;
    s->mtime_ns = mtime_ns(st);
    int rc = pl_image_read_rgb8_reuse(s->path, &s->img, &s->capacity);
    if (rc < 0 && video_err[0]) return pl_error_prefix(rc, "%s; nor as an image", video_err);
    return rc;
}

int pl_source_open_path(const char *path, pl_source **out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_source_open_path: out is NULL");
    *out = NULL;
    if (!path || !path[0]) return pl_error(PL_E_ARG, "frame source: empty path");
    struct stat st;
    if (stat(path, &st) != 0)
        return pl_error(PL_E_IO, "%s: cannot open: %s", path, strerror(errno));
    if (!S_ISDIR(st.st_mode) && !S_ISREG(st.st_mode)) /* a FIFO would block OpenCV's open */
        return pl_error(PL_E_IO, "%s: %s, expected a regular file or a directory", path,
                        pl_file_not_regular(st.st_mode));

    pl_source *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", path);
    s->path = dup_str(path);
    /* A trailing '/' on a directory would double in joined paths. */
    size_t n = s->path ? strlen(s->path) : 0;
    while (n > 1 && s->path[n - 1] == '/')
        s->path[--n] = '\0';
    int rc = s->path ? PL_OK : pl_error(PL_E_NOMEM, "%s: out of memory", path);
    if (rc == PL_OK) {
        if (S_ISDIR(st.st_mode)) {
            s->kind = SRC_DIR;
            rc = open_dir(s);
        } else {
            rc = open_file(s, &st);
        }
    }
    if (rc == PL_OK) {
        const char *prefix = s->kind == SRC_DIR     ? "dir:"
                             : s->kind == SRC_VIDEO ? "video:"
                                                    : "file:";
        s->desc = malloc(strlen(prefix) + n + 1);
        if (s->desc)
            sprintf(s->desc, "%s%s", prefix, s->path);
        else
            rc = pl_error(PL_E_NOMEM, "%s: out of memory", path);
    }
    if (rc < 0) {
        pl_source_close(s);
        return rc;
    }
    *out = s;
    return PL_OK;
}

static int open_libcamera(const char *spec, pl_source **out)
{
    pl_source *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", spec);
    s->kind = SRC_CAMERA;
    int rc = pl_libcam_open(spec, &s->libcam);
    if (rc == PL_OK) {
        s->desc = dup_str(pl_libcam_describe(s->libcam));
        s->path = dup_str(s->desc);
        if (!s->desc || !s->path) rc = pl_error(PL_E_NOMEM, "%s: out of memory", spec);
    }
    if (rc < 0) {
        pl_source_close(s);
        return rc;
    }
    *out = s;
    return PL_OK;
}

int pl_source_open_camera(const char *spec, pl_source **out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_source_open_camera: out is NULL");
    *out = NULL;
    if (pl_libcam_is_spec(spec)) return open_libcamera(spec, out);
    pl_v4l2_spec vs;
    int rc = pl_v4l2_parse_spec(spec, &vs);
    if (rc < 0) return rc;
    pl_source *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "%s: out of memory", spec);
    s->kind = SRC_CAMERA;
    rc = pl_v4l2_open(&vs, &s->camera);
    if (rc == PL_OK) {
        s->desc = dup_str(pl_v4l2_describe(s->camera));
        s->path = dup_str(vs.path);
        if (!s->desc || !s->path) rc = pl_error(PL_E_NOMEM, "%s: out of memory", spec);
    }
    if (rc < 0) {
        pl_source_close(s);
        return rc;
    }
    *out = s;
    return PL_OK;
}

static int end_of_source(pl_source *s)
{
    s->eof = true;
    return pl_error(PL_E_EOF, "%s: end of frames (%lld good, %lld bad)", s->desc,
                    (long long)s->good, (long long)s->bad);
}

int pl_source_read(pl_source *s, pl_frame *frame)
{
    if (!s || !frame) return pl_error(PL_E_ARG, "pl_source_read: NULL argument");
    if (s->eof) return end_of_source(s);
    int rc;
    switch (s->kind) {
    case SRC_FILE:
        if (s->good > 0) return end_of_source(s);
        frame->t_ns = s->mtime_ns;
        frame->index = 0;
        frame->name = s->path;
        break;
    case SRC_VIDEO: {
        int64_t t = 0;
        rc = pl_video_read(s->video, &s->img, &s->capacity, &t);
        if (rc == PL_E_EOF) return end_of_source(s);
        if (rc < 0) {
            s->bad++;
            s->video_index++;
            return rc;
        }
        frame->t_ns = t;
        frame->index = s->video_index++;
        frame->name = s->path;
        break;
    }
    case SRC_CAMERA:
        rc = s->libcam
                 ? pl_libcam_read(s->libcam, &s->img, &s->capacity, &frame->t_ns, &frame->index)
                 : pl_v4l2_read(s->camera, &s->img, &s->capacity, &frame->t_ns, &frame->index);
        if (rc == PL_E_EOF) s->eof = true; /* keeps the camera's "gave up" message */
        if (rc < 0) {
            if (rc != PL_E_EOF) s->bad++;
            return rc;
        }
        frame->name = s->path;
        break;
    case SRC_DIR: {
        if (s->next >= s->n_entries) return end_of_source(s);
        const dir_entry *e = &s->entries[s->next];
        frame->index = (int64_t)s->next++;
        sprintf(s->file_path, "%s/%s", s->path, e->name);
        rc = pl_image_read_rgb8_reuse(s->file_path, &s->img, &s->capacity);
        if (rc < 0) {
            s->bad++;
            return rc;
        }
        frame->t_ns = e->mtime_ns;
        frame->name = e->name;
        break;
    }
    default:
        return pl_error(PL_E_INTERNAL, "frame source: bad kind %d", (int)s->kind);
    }
    frame->image = s->img;
    s->good++;
    return PL_OK;
}

const char *pl_source_describe(const pl_source *s)
{
    return s && s->desc ? s->desc : "(no source)";
}

int pl_source_fps(const pl_source *s, double *fps)
{
    if (!s || !fps) return pl_error(PL_E_ARG, "pl_source_fps: NULL argument");
    if (s->kind == SRC_CAMERA)
        return s->libcam ? pl_libcam_fps(s->libcam, fps) : pl_v4l2_fps(s->camera, fps);
    if (s->kind != SRC_VIDEO)
        return pl_error(PL_E_UNSUPPORTED, "%s: not a video: no frame rate", pl_source_describe(s));
    return pl_video_fps(s->video, fps);
}

void pl_source_counts(const pl_source *s, int64_t *good, int64_t *bad)
{
    if (good) *good = s ? s->good : 0;
    if (bad) *bad = s ? s->bad : 0;
}

void pl_source_close(pl_source *s)
{
    if (!s) return;
    pl_video_close(s->video);
    pl_v4l2_close(s->camera);
    pl_libcam_close(s->libcam);
    for (size_t i = 0; i < s->n_entries; i++)
        free(s->entries[i].name);
    free(s->entries);
    free(s->file_path);
    pl_image_u8_free(&s->img);
    free(s->desc);
    free(s->path);
    free(s);
}
