// Still-image files through OpenCV 4.6, behind the C interface in port/image.h.
//
// The file is read into memory here (precise errno messages, one read), its header is checked
// against the size limits before anything is decoded (PNG, JPEG, BMP), truncation is detected
// for PNG (no IEND) and JPEG (no EOI after the first scan: libjpeg would otherwise hand back a
// grey-padded image), and only then cv::imdecode runs. No exception leaves this file.
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/core/utils/logger.hpp>

#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <mutex>
#include <cstdio>
#include <cstring>
#include <new>
#include <string>
#include <vector>

#include <sys/stat.h>
#include <unistd.h>

extern "C" {
#include "port/cv_log.h"
#include "port/image.h"
#include "port/util.h"
}

namespace
{
std::mutex quiet_mutex;
int quiet_depth;
cv::utils::logging::LogLevel quiet_saved;
} // namespace

extern "C" void pl_cv_log_quiet_enter(void)
{
    try {
        static const bool user_set = std::getenv("OPENCV_LOG_LEVEL") != nullptr;
        if (user_set) return;
        std::lock_guard<std::mutex> lock(quiet_mutex);
        if (quiet_depth++ == 0)
            quiet_saved = cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT);
    } catch (...) {
    }
}

extern "C" void pl_cv_log_quiet_leave(void)
{
    try {
        static const bool user_set = std::getenv("OPENCV_LOG_LEVEL") != nullptr;
        if (user_set) return;
        std::lock_guard<std::mutex> lock(quiet_mutex);
        if (quiet_depth > 0 && --quiet_depth == 0) cv::utils::logging::setLogLevel(quiet_saved);
    } catch (...) {
    }
}

namespace
{

// Compressed files larger than this are refused before reading (an uncompressed BMP of the
// largest accepted image is 768 MiB).
constexpr long long kMaxFileBytes = 1LL << 30;

enum class Kind { unknown, png, jpeg, bmp };

struct Header {
    Kind kind = Kind::unknown;
    long long width = -1, height = -1; // -1: not known from the header
    size_t jpeg_scan = 0;              // offset of the first SOS marker (JPEG)
};

uint32_t be32(const uint8_t *p)
{
    return (uint32_t)p[0] << 24 | (uint32_t)p[1] << 16 | (uint32_t)p[2] << 8 | p[3];
}
uint32_t be16(const uint8_t *p)
{
    return (uint32_t)p[0] << 8 | p[1];
}
uint32_t le16(const uint8_t *p)
{
    return (uint32_t)p[1] << 8 | p[0];
}
uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[3] << 24 | (uint32_t)p[2] << 16 | (uint32_t)p[1] << 8 | p[0];
}

// PNG: every chunk complete, its CRC right, IEND reached (trailing junk after IEND is allowed).
// Catches truncation and corruption before libpng, which would print its complaint to stderr.
int check_png_chunks(const char *path, const uint8_t *p, size_t n)
{
    static uint32_t table[256];
    static bool have_table = false;
    if (!have_table) { // benign race: every thread writes the same values
        for (uint32_t i = 0; i < 256; i++) {
            uint32_t c = i;
            for (int k = 0; k < 8; k++)
                c = c & 1 ? 0xedb88320u ^ (c >> 1) : c >> 1;
            table[i] = c;
        }
        have_table = true;
    }
    size_t pos = 8;
    while (pos + 12 <= n) {
        const uint32_t len = be32(p + pos);
        if (len > 0x7fffffffu || len > n - pos - 12)
            return pl_error(PL_E_FORMAT, "%s: truncated PNG (chunk at byte %zu runs past the end)",
                            path, pos);
        uint32_t c = 0xffffffffu;
        for (size_t i = pos + 4; i < pos + 8 + len; i++)
            c = table[(c ^ p[i]) & 0xff] ^ (c >> 8);
        if ((c ^ 0xffffffffu) != be32(p + pos + 8 + len)) {
            char type[5];
            for (int k = 0; k < 4; k++)
                type[k] = isalpha(p[pos + 4 + k]) ? (char)p[pos + 4 + k] : '?';
            type[4] = '\0';
            return pl_error(PL_E_FORMAT, "%s: corrupt PNG (CRC error in chunk '%s' at byte %zu)",
                            path, type, pos);
        }
        if (memcmp(p + pos + 4, "IEND", 4) == 0) return PL_OK;
        pos += 12 + (size_t)len;
    }
    return pl_error(PL_E_FORMAT, "%s: truncated PNG (no IEND chunk at the end)", path);
}

// Reads what the header declares. Returns PL_OK, or PL_E_FORMAT (with a message) for a header
// that is recognisably this format but broken or truncated.
int parse_header(const char *path, const std::vector<uint8_t> &buf, Header *h)
{
    const uint8_t *p = buf.data();
    const size_t n = buf.size();
    static const uint8_t png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (n >= 8 && memcmp(p, png_sig, 8) == 0) {
        h->kind = Kind::png;
        if (n < 33 || memcmp(p + 12, "IHDR", 4) != 0)
            return pl_error(PL_E_FORMAT, "%s: truncated PNG (no complete IHDR chunk)", path);
        h->width = be32(p + 16);
        h->height = be32(p + 20);
        int rc = pl_image_check_size(path, h->width, h->height); // a bomb's CRCs may be right
        if (rc < 0) return rc;
        return check_png_chunks(path, p, n);
    }
    if (n >= 3 && p[0] == 0xff && p[1] == 0xd8 && p[2] == 0xff) {
        h->kind = Kind::jpeg;
        size_t i = 2;
        for (int guard = 0; guard < 100000; guard++) {
            while (i < n && p[i] == 0xff && i + 1 < n && p[i + 1] == 0xff)
                i++; // fill bytes
            if (i + 4 > n) break;
            if (p[i] != 0xff)
                return pl_error(PL_E_FORMAT, "%s: corrupt JPEG (no marker at byte %zu)", path, i);
            const uint8_t m = p[i + 1];
            if (m == 0xd8 || m == 0x01 || (m >= 0xd0 && m <= 0xd7)) { // no length
                i += 2;
                continue;
            }
            if (m == 0xd9) break; // EOI before any scan
            const size_t len = be16(p + i + 2);
            if (len < 2)
                return pl_error(PL_E_FORMAT, "%s: corrupt JPEG (segment length %zu at byte %zu)",
                                path, len, i);
            if (m >= 0xc0 && m <= 0xcf && m != 0xc4 && m != 0xc8 && m != 0xcc) {
                if (i + 9 > n) break;
                h->height = be16(p + i + 5);
                h->width = be16(p + i + 7);
            }
            if (m == 0xda) {
                h->jpeg_scan = i;
                break;
            }
            i += 2 + len;
        }
        if (h->jpeg_scan == 0)
            return pl_error(PL_E_FORMAT, "%s: truncated or corrupt JPEG (no image scan found)",
                            path);
        // FF D9 cannot occur inside entropy-coded data (FF is stuffed as FF 00).
        bool eoi = false;
        for (size_t k = h->jpeg_scan; k + 1 < n; k++)
            if (p[k] == 0xff && p[k + 1] == 0xd9) {
                eoi = true;
                break;
            }
        if (!eoi) return pl_error(PL_E_FORMAT, "%s: truncated JPEG (no end-of-image marker)", path);
        if (h->width == 0 || h->height == 0)
            return pl_error(PL_E_FORMAT, "%s: JPEG declares a %lldx%lld image", path, h->width,
                            h->height);
        return PL_OK;
    }
    if (n >= 26 && p[0] == 'B' && p[1] == 'M') {
        const uint32_t dib = le32(p + 14);
        const uint32_t offset = le32(p + 10);
        uint32_t bpp = 0, compression = 0;
        if (dib == 12) {
            h->kind = Kind::bmp;
            h->width = le16(p + 18);
            h->height = le16(p + 20);
            bpp = le16(p + 24);
        } else if (dib >= 40) {
            if (n < 34) return pl_error(PL_E_FORMAT, "%s: truncated BMP header", path);
            h->kind = Kind::bmp;
            h->width = (int32_t)le32(p + 18);
            long long hh = (int32_t)le32(p + 22);
            h->height = hh < 0 ? -hh : hh; // negative: top-down rows
            bpp = le16(p + 28);
            compression = le32(p + 30);
            // 0 RGB, 1 RLE8, 2 RLE4, 3 BITFIELDS: what OpenCV decodes (it asserts on the rest).
            if (compression > 3)
                return pl_error(PL_E_UNSUPPORTED, "%s: BMP compression %u not supported", path,
                                compression);
        }
        // Uncompressed pixel data must all be there (OpenCV would throw, and print, on the way).
        if (h->kind == Kind::bmp && (compression == 0 || compression == 3) && h->width >= 1 &&
            h->height >= 1 && h->width <= PL_IMAGE_MAX_SIDE && h->height <= PL_IMAGE_MAX_SIDE &&
            (bpp == 1 || bpp == 4 || bpp == 8 || bpp == 16 || bpp == 24 || bpp == 32)) {
            const unsigned long long row = ((unsigned long long)h->width * bpp + 31) / 32 * 4;
            const unsigned long long need =
                (unsigned long long)offset + row * (unsigned long long)h->height;
            if (need > n)
                return pl_error(PL_E_FORMAT,
                                "%s: truncated BMP (pixel data needs %llu bytes, file has %zu)",
                                path, need, n);
        }
    }
    return PL_OK;
}

// Reads the whole regular file at `path` into buf, with a message for each way that can fail.
int read_file(const char *path, std::vector<uint8_t> &buf)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return pl_error(PL_E_IO, "%s: cannot open image: %s", path, strerror(errno));
    if (S_ISDIR(st.st_mode))
        return pl_error(PL_E_IO, "%s: is a directory, not an image file", path);
    if (!S_ISREG(st.st_mode)) return pl_error(PL_E_IO, "%s: not a regular file", path);
    if (st.st_size == 0)
        return pl_error(PL_E_FORMAT, "%s: empty file (0 bytes), not an image", path);
    if (st.st_size > kMaxFileBytes)
        return pl_error(PL_E_FORMAT,
                        "%s: file of %lld bytes is larger than the %lld accepted for an image",
                        path, (long long)st.st_size, kMaxFileBytes);
    FILE *f = fopen(path, "rb");
    if (!f) return pl_error(PL_E_IO, "%s: cannot open image: %s", path, strerror(errno));
    buf.resize((size_t)st.st_size);
    size_t got = fread(buf.data(), 1, buf.size(), f);
    int err = ferror(f) ? errno : 0;
    fclose(f);
    if (err) return pl_error(PL_E_IO, "%s: read error: %s", path, strerror(err));
    if (got == 0) return pl_error(PL_E_FORMAT, "%s: empty file (0 bytes), not an image", path);
    buf.resize(got); // the file may have shrunk since stat
    return PL_OK;
}

const char *depth_name(int depth)
{
    switch (depth) {
    case CV_8U:
        return "8-bit unsigned";
    case CV_8S:
        return "8-bit signed";
    case CV_16U:
        return "16-bit unsigned";
    case CV_16S:
        return "16-bit signed";
    case CV_32S:
        return "32-bit integer";
    case CV_32F:
        return "32-bit float";
    case CV_64F:
        return "64-bit float";
    default:
        return "16-bit float";
    }
}

// Converts a decoded 8/16-bit, 1/3/4-channel BGR(A) Mat into img (reusing its buffer).
int mat_to_rgb8(const char *path, const cv::Mat &m, pl_image_u8 *img, size_t *cap)
{
    if (m.dims != 2) return pl_error(PL_E_UNSUPPORTED, "%s: %d-dimensional image", path, m.dims);
    int rc = pl_image_check_size(path, m.cols, m.rows);
    if (rc < 0) return rc;
    const int cn = m.channels();
    if (cn != 1 && cn != 3 && cn != 4)
        return pl_error(PL_E_UNSUPPORTED, "%s: %d channels per pixel (expected 1, 3 or 4)", path,
                        cn);
    cv::Mat m8;
    if (m.depth() == CV_8U) {
        m8 = m;
    } else if (m.depth() == CV_16U) {
        m8.create(m.rows, m.cols, CV_MAKETYPE(CV_8U, cn));
        for (int y = 0; y < m.rows; y++) {
            const uint16_t *s = m.ptr<uint16_t>(y);
            uint8_t *d = m8.ptr<uint8_t>(y);
            for (int x = 0; x < m.cols * cn; x++)
                d[x] = (uint8_t)(((uint32_t)s[x] * 255u + 32767u) / 65535u);
        }
    } else if (m.depth() == CV_32F || m.depth() == CV_64F || m.depth() == CV_16F) {
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: %s pixels (an HDR image): not read as 8-bit RGB; use the HDR reader",
                        path, depth_name(m.depth()));
    } else {
        return pl_error(PL_E_UNSUPPORTED,
                        "%s: %s pixels are not supported (expected 8 or 16-bit unsigned)", path,
                        depth_name(m.depth()));
    }
    rc = pl_image_u8_reserve(img, cap, m.cols, m.rows);
    if (rc < 0) return pl_error_prefix(rc, "%s", path);
    cv::Mat out(img->height, img->width, CV_8UC3, img->data, img->stride);
    const int code = cn == 1   ? cv::COLOR_GRAY2RGB
                     : cn == 3 ? cv::COLOR_BGR2RGB
                               : cv::COLOR_BGRA2RGB;
    cv::cvtColor(m8, out, code);
    if (out.data != img->data)
        return pl_error(PL_E_INTERNAL, "%s: colour conversion reallocated", path);
    return PL_OK;
}

int read_rgb8(const char *path, pl_image_u8 *img, size_t *cap)
{
    std::vector<uint8_t> buf;
    int rc = read_file(path, buf);
    if (rc < 0) return rc;
    Header h;
    rc = parse_header(path, buf, &h);
    if (rc < 0) return rc;
    if (h.width >= 0 && h.height >= 0) {
        rc = pl_image_check_size(path, h.width, h.height);
        if (rc < 0) return rc;
    }
    // JPEG: IMREAD_COLOR, so that the EXIF orientation is applied (always 8-bit anyway).
    const int flags = h.kind == Kind::jpeg ? cv::IMREAD_COLOR : cv::IMREAD_UNCHANGED;
    cv::Mat raw(1, (int)buf.size(), CV_8U, buf.data());
    cv::Mat m = cv::imdecode(raw, flags);
    if (m.empty()) {
        if (h.kind != Kind::unknown || cv::haveImageReader(path))
            return pl_error(PL_E_FORMAT, "%s: corrupt or truncated image data (decoder failed)",
                            path);
        return pl_error(PL_E_FORMAT, "%s: not an image (content matches no format OpenCV decodes)",
                        path);
    }
    return mat_to_rgb8(path, m, img, cap);
}

} // namespace

extern "C" int pl_image_read_rgb8_reuse(const char *path, pl_image_u8 *img, size_t *capacity)
{
    if (!path || !img || !capacity) return pl_error(PL_E_ARG, "pl_image_read_rgb8: NULL argument");
    struct Quiet {
        Quiet()
        {
            pl_cv_log_quiet_enter();
        }
        ~Quiet()
        {
            pl_cv_log_quiet_leave();
        }
    } quiet;
    try {
        return read_rgb8(path, img, capacity);
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory while decoding", path);
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_FORMAT, "%s: OpenCV cannot decode it: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unexpected exception while decoding", path);
    }
}

extern "C" int pl_image_read_rgb8(const char *path, pl_image_u8 *out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_image_read_rgb8: out is NULL");
    pl_image_u8 img = {0, 0, 0, nullptr};
    size_t cap = 0;
    int rc = pl_image_read_rgb8_reuse(path, &img, &cap);
    if (rc < 0) {
        pl_image_u8_free(&img);
        memset(out, 0, sizeof *out);
        return rc;
    }
    *out = img;
    return PL_OK;
}

extern "C" int pl_image_write_rgb8(const char *path, const pl_image_u8 *img)
{
    if (!path || !img || !img->data)
        return pl_error(PL_E_ARG, "pl_image_write_rgb8: NULL argument");
    int rc = pl_image_check_size(path, img->width, img->height);
    if (rc < 0)
        return pl_error(PL_E_ARG, "%s: cannot write a %dx%d image", path, img->width, img->height);
    if (img->stride < (size_t)img->width * 3)
        return pl_error(PL_E_ARG, "%s: stride %zu < 3 * width %d", path, img->stride, img->width);
    struct Quiet {
        Quiet()
        {
            pl_cv_log_quiet_enter();
        }
        ~Quiet()
        {
            pl_cv_log_quiet_leave();
        }
    } quiet;
    try {
        if (!cv::haveImageWriter(path))
            return pl_error(PL_E_ARG,
                            "%s: unknown image extension (use .png, .jpg, .bmp, .tif, .ppm, ...)",
                            path);
        struct stat st;
        if (stat(path, &st) == 0 && !S_ISREG(st.st_mode))
            return pl_error(PL_E_IO, "%s: exists and is not a regular file", path);
        std::string dir(path);
        size_t slash = dir.find_last_of('/');
        dir = slash == std::string::npos ? "." : slash == 0 ? "/" : dir.substr(0, slash);
        if (access(dir.c_str(), W_OK | X_OK) != 0)
            return pl_error(PL_E_IO, "%s: cannot write into %s: %s", path, dir.c_str(),
                            strerror(errno));
        cv::Mat rgb(img->height, img->width, CV_8UC3, img->data, img->stride), bgr;
        cv::cvtColor(rgb, bgr, cv::COLOR_RGB2BGR);
        if (!cv::imwrite(path, bgr))
            return pl_error(PL_E_IO, "%s: OpenCV could not write the image", path);
        return PL_OK;
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory while encoding", path);
    } catch (const cv::Exception &e) {
        return pl_error(PL_E_IO, "%s: OpenCV cannot write it: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: unexpected exception while encoding", path);
    }
}
