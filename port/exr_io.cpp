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
#include <openexr.h>
#pragma GCC diagnostic pop

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <new>
#include <string>
#include <vector>

#include <sys/stat.h>

extern "C" {
#include "core/util.h"
#include "port/hdr_io.h"
}

namespace
{

std::string &last_core_message()
{
    thread_local std::string msg;
    return msg;
}

// Sizes the C++ library itself accepts (Header::sanityCheck throws before allocating): no side or
// tile side over PL_IMAGE_MAX_SIDE. The read limit and the chunk table are checked by probe().
struct Limits {
    Limits()
    {
        Imf::Header::setMaxImageSize(PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_SIDE);
        Imf::Header::setMaxTileSize(PL_IMAGE_MAX_SIDE, PL_IMAGE_MAX_SIDE);
    }
};

// OpenEXRCore would print to stderr: keep its first message (the cause; later ones are
// consequences, "Unable to extract header byte") for ours instead.
void core_error(exr_const_context_t, exr_result_t, const char *msg)
{
    if (last_core_message().empty()) last_core_message() = msg ? msg : "?";
}

const char *core_message(exr_result_t r)
{
    return last_core_message().empty() ? exr_get_default_error_message(r)
                                       : last_core_message().c_str();
}

// Reads the header with OpenEXRCore before Imf::InputFile sees the file. The C++ reader sizes
// buffers from header fields it has not checked against the file (an attribute's declared length:
// 15 bytes of file reserve 1.77 GB; a tiled image's chunk table). OpenEXRCore checks attribute
// sizes against the file, takes maximum image and tile sizes per context, and gives the data
// window and chunk count without reading pixels: the size, the shape and the chunk table (8 bytes
// a chunk, all in the file) are checked here, before anything the size of the image exists.
int probe(const char *path, int panorama)
{
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = core_error;
    init.max_image_width = PL_IMAGE_MAX_SIDE;
    init.max_image_height = PL_IMAGE_MAX_SIDE;
    init.max_tile_width = PL_IMAGE_MAX_SIDE;
    init.max_tile_height = PL_IMAGE_MAX_SIDE;
    exr_context_t ctx = nullptr;
    last_core_message().clear();
    exr_result_t r = exr_start_read(&ctx, path, &init);
    if (r != EXR_ERR_SUCCESS) {
        int st = pl_error(r == EXR_ERR_OUT_OF_MEMORY ? PL_E_NOMEM : PL_E_FORMAT,
                          "%s: OpenEXR header: %s", path, core_message(r));
        exr_finish(&ctx);
        return st;
    }
    int st = PL_OK;
    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_attr_box2i_t dw;
    int32_t chunks = 0;
    struct stat sb;
    if ((r = exr_get_storage(ctx, 0, &storage)) != EXR_ERR_SUCCESS ||
        (r = exr_get_data_window(ctx, 0, &dw)) != EXR_ERR_SUCCESS ||
        (r = exr_get_chunk_count(ctx, 0, &chunks)) != EXR_ERR_SUCCESS) {
        st = pl_error(PL_E_FORMAT, "%s: OpenEXR header: %s", path, core_message(r));
    } else if (storage == EXR_STORAGE_DEEP_SCANLINE || storage == EXR_STORAGE_DEEP_TILED) {
        st = pl_error(PL_E_UNSUPPORTED, "%s: deep OpenEXR images are not supported", path);
    } else {
        const long long w = (long long)dw.max.x - dw.min.x + 1;
        const long long h = (long long)dw.max.y - dw.min.y + 1;
        st = pl_hdr_check_declared(path, w, h, panorama);
        if (st == PL_OK && stat(path, &sb) == 0 &&
            (unsigned long long)chunks * 8 > (unsigned long long)sb.st_size)
            st = pl_error(PL_E_FORMAT,
                          "%s: truncated: %lld x %lld in %d chunks needs a %llu-byte chunk table, "
                          "the file has %lld bytes",
                          path, w, h, (int)chunks, (unsigned long long)chunks * 8,
                          (long long)sb.st_size);
    }
    exr_finish(&ctx);
    return st;
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

} // namespace

extern "C" int pl_exr_read_file(const char *path, int panorama, pl_image_f32 *out)
{
    static Limits limits;
    (void)limits;
    pl_image_f32 img = {0, 0, nullptr};
    try {
        bool tiled = false, deep = false, multipart = false;
        if (!Imf::isOpenExrFile(path, tiled, deep, multipart))
            return pl_error(PL_E_FORMAT, "%s: not an OpenEXR file", path);
        if (deep)
            return pl_error(PL_E_UNSUPPORTED, "%s: deep OpenEXR images are not supported", path);
        int st = probe(path, panorama);
        if (st < 0) return st;
        Imf::InputFile in(path);
        const Imf::Header &hd = in.header();
        const Imath::Box2i dw = hd.dataWindow();
        long long w = (long long)dw.max.x - dw.min.x + 1, h = (long long)dw.max.y - dw.min.y + 1;
        st = pl_hdr_check_declared(path, w, h, panorama); // the C++ reader's view of the header
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

extern "C" int pl_exr_read_file(const char *path, int, pl_image_f32 *out)
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
