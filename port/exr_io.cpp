// OpenEXR shim (port/hdr_io.h): the only file that sees the OpenEXR C++ API. Every exception is
// caught here and turned into a pl_status with a message naming the file.
// The OpenEXR headers are included with -I (not -isystem): keep their own warnings out.
// Without OpenEXR (PL_HAVE_OPENEXR unset: a cross build, WITH_OPENEXR=0) both functions return
// PL_E_UNSUPPORTED saying so; .hdr files (port/hdr_io.c) need no library.
#ifdef PL_HAVE_OPENEXR
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wunused-parameter" /* clang, in ImfAttribute.h */
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfRgbaFile.h>
#include <ImfTestFile.h>
#pragma GCC diagnostic pop

#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <vector>

extern "C" {
#include "core/util.h"
#include "port/hdr_io.h"
}

namespace
{

// Sizes the library itself accepts (its sanity check then throws before allocating).
struct Limits {
    Limits()
    {
        Imf::Header::setMaxImageSize(PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_SIDE);
    }
};

int check_size(const char *path, long long w, long long h)
{
    if (w <= 0 || h <= 0 || w > PL_IMAGE_MAX_SIDE || h > PL_IMAGE_MAX_SIDE ||
        (unsigned long long)w * (unsigned long long)h > PL_IMAGE_MAX_PIXELS)
        return pl_error(PL_E_FORMAT,
                        "%s: data window %lld x %lld outside 1..%d per side, %u pixels", path, w, h,
                        PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_PIXELS);
    return PL_OK;
}

int alloc_image(const char *path, int w, int h, pl_image_f32 *out)
{
    size_t n;
    if (!pl_mul_size((size_t)w * (size_t)h, 3 * sizeof(float), &n))
        return pl_error(PL_E_NOMEM, "%s: size %d x %d overflows", path, w, h);
    out->data = static_cast<float *>(std::calloc(1, n));
    if (!out->data) return pl_error(PL_E_NOMEM, "%s: cannot allocate %zu bytes", path, n);
    out->width = w;
    out->height = h;
    return PL_OK;
}

int read_rgb(const char *path, Imf::InputFile &in, int w, int h, int x0, int y0, bool grey,
             pl_image_f32 *out)
{
    int st = alloc_image(path, w, h, out);
    if (st < 0) return st;
    char *base = reinterpret_cast<char *>(out->data) -
                 ((ptrdiff_t)x0 + (ptrdiff_t)y0 * w) * (ptrdiff_t)(3 * sizeof(float));
    size_t xs = 3 * sizeof(float), ys = xs * (size_t)w;
    Imf::FrameBuffer fb;
    if (grey) {
        fb.insert("Y", Imf::Slice(Imf::FLOAT, base, xs, ys, 1, 1, 0.0));
    } else {
        fb.insert("R", Imf::Slice(Imf::FLOAT, base, xs, ys, 1, 1, 0.0));
        fb.insert("G", Imf::Slice(Imf::FLOAT, base + sizeof(float), xs, ys, 1, 1, 0.0));
        fb.insert("B", Imf::Slice(Imf::FLOAT, base + 2 * sizeof(float), xs, ys, 1, 1, 0.0));
    }
    in.setFrameBuffer(fb);
    in.readPixels(y0, y0 + h - 1);
    if (grey) {
        size_t n = (size_t)w * (size_t)h;
        for (size_t i = 0; i < n; i++)
            out->data[3 * i + 1] = out->data[3 * i + 2] = out->data[3 * i];
    }
    return PL_OK;
}

// Luminance/chroma files (Y + RY/BY, possibly subsampled): RgbaInputFile converts to RGB (half).
int read_yc(const char *path, int w, int h, pl_image_f32 *out)
{
    Imf::RgbaInputFile in(path);
    const Imath::Box2i dw = in.dataWindow();
    std::vector<Imf::Rgba> px((size_t)w * (size_t)h);
    in.setFrameBuffer(px.data() - dw.min.x - (ptrdiff_t)dw.min.y * w, 1, (size_t)w);
    in.readPixels(dw.min.y, dw.max.y);
    int st = alloc_image(path, w, h, out);
    if (st < 0) return st;
    for (size_t i = 0; i < px.size(); i++) {
        out->data[3 * i] = px[i].r;
        out->data[3 * i + 1] = px[i].g;
        out->data[3 * i + 2] = px[i].b;
    }
    return PL_OK;
}

// OpenEXR 3.1 allocates an attribute's declared size before reading it, so a 71-byte file that
// declares a 1.6 GB "channels" attribute costs 1.6 GB (found by tests/fuzz/fuzz_exr.c). Walks
// the header(s) first: every attribute's size must fit in what is left of the file.
int check_attribute_sizes(const char *path)
{
    FILE *f = std::fopen(path, "rb");
    if (!f) return pl_error(PL_E_IO, "%s: cannot open: %s", path, std::strerror(errno));
    int st = PL_OK;
    long long file_size = -1;
    unsigned char head[8];
    if (std::fseek(f, 0, SEEK_END) == 0) file_size = std::ftell(f);
    if (file_size < 8 || std::fseek(f, 0, SEEK_SET) != 0 || std::fread(head, 1, 8, f) != 8) {
        std::fclose(f);
        return pl_error(PL_E_FORMAT, "%s: truncated OpenEXR header", path);
    }
    const bool multipart = head[5] & 0x10;
    const int name_max = (head[5] & 0x04) ? 256 : 32; // long names: 255 bytes + NUL
    long long pos = 8;
    bool header_empty = true;
    for (;;) {
        char name[2][256];
        for (int k = 0; k < 2; k++) { // attribute name, then type name
            int n = 0, c;
            while ((c = std::fgetc(f)) > 0 && n < name_max - 1)
                name[k][n++] = (char)c;
            name[k][n] = '\0';
            pos += n + 1;
            if (c != 0) {
                st = pl_error(PL_E_FORMAT, "%s: OpenEXR header ends or a name is too long at %lld",
                              path, pos);
                goto out;
            }
            if (k == 0 && n == 0) break;
        }
        if (!name[0][0]) { // the end of a header
            if (!multipart || header_empty) break;
            header_empty = true;
            continue;
        }
        header_empty = false;
        unsigned char sz[4];
        if (std::fread(sz, 1, 4, f) != 4) {
            st = pl_error(PL_E_FORMAT, "%s: OpenEXR header truncated in attribute '%s'", path,
                          name[0]);
            goto out;
        }
        pos += 4;
        const long long size = (long long)(int32_t)((uint32_t)sz[0] | (uint32_t)sz[1] << 8 |
                                                    (uint32_t)sz[2] << 16 | (uint32_t)sz[3] << 24);
        if (size < 0 || size > file_size - pos) {
            st = pl_error(PL_E_FORMAT,
                          "%s: OpenEXR attribute '%s' (%s) declares %lld bytes, %lld left", path,
                          name[0], name[1], size, file_size - pos);
            goto out;
        }
        if (std::fseek(f, (long)size, SEEK_CUR) != 0) {
            st = pl_error(PL_E_IO, "%s: cannot seek: %s", path, std::strerror(errno));
            goto out;
        }
        pos += size;
    }
out:
    std::fclose(f);
    return st;
}

} // namespace

extern "C" int pl_exr_read_file(const char *path, pl_image_f32 *out)
{
    static Limits limits;
    (void)limits;
    pl_image_f32 img = {0, 0, nullptr};
    try {
        bool tiled = false, deep = false, multipart = false;
        int st0 = check_attribute_sizes(path);
        if (st0 < 0) return st0;
        if (!Imf::isOpenExrFile(path, tiled, deep, multipart))
            return pl_error(PL_E_FORMAT, "%s: not an OpenEXR file", path);
        if (deep)
            return pl_error(PL_E_UNSUPPORTED, "%s: deep OpenEXR images are not supported", path);
        Imf::InputFile in(path);
        const Imf::Header &hd = in.header();
        const Imath::Box2i dw = hd.dataWindow();
        long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
        int st = check_size(path, w, h);
        if (st < 0) return st;
        if (!in.isComplete())
            return pl_error(PL_E_FORMAT, "%s: truncated or incomplete (missing pixel chunks)",
                            path);
        const Imf::ChannelList &ch = hd.channels();
        bool rgb = ch.findChannel("R") || ch.findChannel("G") || ch.findChannel("B");
        bool y = ch.findChannel("Y") != nullptr;
        bool chroma = ch.findChannel("RY") || ch.findChannel("BY");
        if (rgb)
            st = read_rgb(path, in, (int)w, (int)h, dw.min.x, dw.min.y, false, &img);
        else if (y && !chroma)
            st = read_rgb(path, in, (int)w, (int)h, dw.min.x, dw.min.y, true, &img);
        else if (y)
            st = read_yc(path, (int)w, (int)h, &img);
        else {
            std::string names;
            for (Imf::ChannelList::ConstIterator it = ch.begin(); it != ch.end(); ++it) {
                if (!names.empty()) names += ",";
                names += it.name();
                if (names.size() > 120) break;
            }
            return pl_error(PL_E_UNSUPPORTED, "%s: no R/G/B or Y channel (channels: %s)", path,
                            names.c_str());
        }
        if (st < 0) {
            std::free(img.data);
            return st;
        }
        *out = img;
        return PL_OK;
    } catch (const std::bad_alloc &) {
        std::free(img.data);
        return pl_error(PL_E_NOMEM, "%s: out of memory while reading", path);
    } catch (const std::exception &e) {
        std::free(img.data);
        return pl_error(PL_E_FORMAT, "%s: OpenEXR: %s", path, e.what());
    } catch (...) {
        std::free(img.data);
        return pl_error(PL_E_INTERNAL, "%s: OpenEXR: unknown exception", path);
    }
}

extern "C" int pl_exr_write_file(const char *path, const pl_image_f32 *img, pl_exr_type type)
{
    try {
        const int w = img->width, h = img->height;
        const size_t n = (size_t)w * (size_t)h;
        Imf::Header hd(w, h);
        hd.compression() = Imf::ZIP_COMPRESSION;
        Imf::FrameBuffer fb;
        std::vector<float> f;
        std::vector<half> hf;
        const char *names[3] = {"R", "G", "B"};
        if (type == PL_EXR_HALF) {
            hf.resize(3 * n);
            for (size_t i = 0; i < 3 * n; i++) {
                float v = img->data[i];
                if (!(v > 0.0f) || std::isinf(v)) v = 0.0f;
                hf[i] = half(v > 65504.0f ? 65504.0f : v);
            }
            for (int c = 0; c < 3; c++) {
                hd.channels().insert(names[c], Imf::Channel(Imf::HALF));
                fb.insert(names[c], Imf::Slice(Imf::HALF, reinterpret_cast<char *>(hf.data() + c),
                                               3 * sizeof(half), 3 * sizeof(half) * (size_t)w));
            }
        } else {
            f.resize(3 * n);
            for (size_t i = 0; i < 3 * n; i++) {
                float v = img->data[i];
                f[i] = (!(v > 0.0f) || std::isinf(v)) ? 0.0f : v;
            }
            for (int c = 0; c < 3; c++) {
                hd.channels().insert(names[c], Imf::Channel(Imf::FLOAT));
                fb.insert(names[c], Imf::Slice(Imf::FLOAT, reinterpret_cast<char *>(f.data() + c),
                                               3 * sizeof(float), 3 * sizeof(float) * (size_t)w));
            }
        }
        Imf::OutputFile out(path, hd);
        out.setFrameBuffer(fb);
        out.writePixels(h);
        return PL_OK;
    } catch (const std::bad_alloc &) {
        return pl_error(PL_E_NOMEM, "%s: out of memory while writing", path);
    } catch (const std::exception &e) {
        return pl_error(PL_E_IO, "%s: OpenEXR: %s", path, e.what());
    } catch (...) {
        return pl_error(PL_E_INTERNAL, "%s: OpenEXR: unknown exception", path);
    }
}

#else // !PL_HAVE_OPENEXR

extern "C" {
#include "core/util.h"
#include "port/hdr_io.h"
}

extern "C" int pl_exr_read_file(const char *path, pl_image_f32 *out)
{
    if (out) *out = pl_image_f32{0, 0, nullptr};
    return pl_error(PL_E_UNSUPPORTED,
                    "%s: this build has no OpenEXR: cannot read .exr (.hdr works)",
                    path ? path : "EXR");
}

extern "C" int pl_exr_write_file(const char *path, const pl_image_f32 *, pl_exr_type)
{
    return pl_error(PL_E_UNSUPPORTED,
                    "%s: this build has no OpenEXR: cannot write .exr (.hdr works)",
                    path ? path : "EXR");
}

#endif
