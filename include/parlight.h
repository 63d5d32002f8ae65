/* parlight — indoor lighting estimation from one camera frame (Gardner et al., ICCV 2019).
 *
 * Public C API. Typical use (tests/test_api_example.c is this example, compiled and run by
 * `make test`; tests/test_header_example.sh checks the two still agree):
 *
 *     pl_model *m = NULL;
 *     if (pl_model_load(path, &m) < 0) {
 *         fprintf(stderr, "%s\n", pl_last_error());
 *         return 1;
 *     }
 *     pl_lighting L;
 *     pl_timing t;
 *     if (pl_estimate_rgb8(m, rgb, width, height, (size_t)width * 3, &L, &t) < 0) {
 *         fprintf(stderr, "%s\n", pl_last_error());
 *         pl_model_free(m);
 *         return 1;
 *     }
 *     for (int i = 0; i < L.n_lights; i++)
 *         printf("light %d: dir %.3f %.3f %.3f, %.3f sr\n", i, L.lights[i].dir[0],
 *                L.lights[i].dir[1], L.lights[i].dir[2], L.lights[i].solid_angle_sr);
 *     printf("ambient %.3f %.3f %.3f (%.1f ms)\n", L.ambient[0], L.ambient[1], L.ambient[2],
 *            t.preprocess_ms + t.infer_ms);
 *     pl_model_free(m);
 *
 * Errors: every function that can fail returns a negative pl_status and leaves a message naming
 * the problem (file, offset, field, expected vs found) in pl_last_error(), which is per thread.
 * The library never prints and never exits. Every input from outside (a file, a buffer, a frame,
 * a size) is checked where it enters: a bad one is an error, never a crash.
 *
 * Ownership: pointers passed in are borrowed for the call only; the library keeps none of them
 * (pl_model_load_memory copies its bytes). What the library allocates is freed with the matching
 * function: a pl_model with pl_model_free, a pl_key_fuser with pl_key_fuser_free, a
 * pl_image_load_rgb8 buffer with pl_free. Output arrays (SH, maps, JSON text) are the caller's,
 * sized as each function says.
 *
 * Threads: a pl_model is used by one thread at a time (estimates, pl_model_set_*): give each
 * thread that estimates its own model. Different models are independent. A model may run its
 * estimates on worker threads of its own (pl_model_set_threads); results do not depend on their
 * count. A pl_key_fuser, likewise, serves one thread at a time. The functions without a model
 * or fuser (lighting maths, JSON, version, image loading) are reentrant, and the plugins that
 * image loading may need are loaded once, under a lock.
 *
 * Linking: `pkg-config --cflags --libs parlight` links libparlight.so.0; a static link takes
 * libparlight.a and `pkg-config --static --libs parlight`'s other libraries (docs/LIBRARY.md).
 * The plugins (OpenCV: BMP/TIFF/... images; libcamera) are looked for in $PARLIGHT_PLUGIN_DIR,
 * beside the executable and in parlight/ beside libparlight.so (where make install puts them).
 *
 * Coordinates (camera frame, right-handed, OpenGL/WebXR): x right, y up, the camera looks along
 * -z. A light's direction points from the camera toward the light. Distances in metres, angular
 * sizes as solid angles in steradians, colours linear RGB on the training panoramas' scale.
 */
#ifndef PARLIGHT_H
#define PARLIGHT_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Marks the public API: libparlight.so is built with -fvisibility=hidden and exports only what
 * carries it (and only pl_* names; `nm -D --defined-only libparlight.so.0`). */
#if defined(__GNUC__) || defined(__clang__)
#define PL_API __attribute__((visibility("default")))
#else
#define PL_API
#endif

/* Version of this library: PARLIGHT_VERSION (a string) for what a program was compiled
 * against, pl_version() for what it runs with. The major number changes when the API or the ABI
 * does (libparlight.so.MAJOR). */
#define PARLIGHT_VERSION_MAJOR 0
#define PARLIGHT_VERSION_MINOR 8
#define PARLIGHT_VERSION_PATCH 0
#define PARLIGHT_VERSION "0.8.0"
PL_API const char *pl_version(void);

typedef enum pl_status {
    PL_OK = 0,
    PL_E_ARG = -1,         /* a caller's argument is invalid (NULL, out of range, bad flag) */
    PL_E_IO = -2,          /* a file or device cannot be opened, read or written */
    PL_E_FORMAT = -3,      /* a file's contents are malformed (model, image, JSON, HDR) */
    PL_E_MODEL = -4,       /* a well-formed model that does not match the architecture */
    PL_E_NOMEM = -5,       /* an allocation failed or a size overflowed */
    PL_E_UNSUPPORTED = -6, /* valid but not handled (pixel format, dtype, ISA) */
    PL_E_EOF = -7,         /* a source has no more frames */
    PL_E_DEVICE = -8,      /* a camera or socket failed */
    PL_E_INTERNAL = -9,    /* a bug: please report it */
} pl_status;

/* Short name of a status ("PL_E_FORMAT"). */
PL_API const char *pl_status_name(int status);
/* Message of the last failure on this thread ("" when none). Valid until the next failure. */
PL_API const char *pl_last_error(void);

/* Most lights a model or a lights file may carry. */
#define PL_MAX_LIGHTS 16

/* One parametric light (the paper's p_i = {l_i, d_i, s_i, c_i}). */
typedef struct pl_light {
    float dir[3];          /* unit vector, camera frame, from the camera toward the light */
    float distance_m;      /* distance from the camera, metres, > 0 */
    float solid_angle_sr;  /* s_i: angular size as a solid angle, steradians, > 0 */
    float rgb[3];          /* c_i: peak radiance of the lobe, linear RGB, >= 0 */
} pl_light;

/* N lights plus the ambient term: what the network predicts and AR apps consume.
 * The environment map it stands for is eq. (4): sum_i c_i exp((l_i.u - 1) / (s_i / 4pi)) + a. */
typedef struct pl_lighting {
    int n_lights;                   /* 0..PL_MAX_LIGHTS */
    pl_light lights[PL_MAX_LIGHTS];
    float ambient[3];               /* a: linear RGB, >= 0 */
} pl_lighting;

/* ---- model ------------------------------------------------------------------------------- */

typedef struct pl_model pl_model;

/* Loads and validates a .plm file (docs/FORMAT.md), reads it whole into memory the model owns
 * (the file can then be changed or removed without effect on the model), and plans the one
 * arena that every later pl_estimate_* call runs in. Nothing is allocated per frame afterwards.
 * A path that is not a regular file (a FIFO, a device, a directory) is refused without blocking. */
PL_API int pl_model_load(const char *path, pl_model **out);
/* The same from the bytes of a .plm file already in memory (an asset bundle, a download): they
 * are copied into memory the model owns, so the caller may free or reuse data as soon as this
 * returns. Validated exactly as a file is (same checks, same CRC-32); messages name the model
 * "<memory>". A NULL or empty buffer is PL_E_ARG; a truncated or corrupt one PL_E_FORMAT, a
 * well-formed model of another architecture PL_E_MODEL. */
PL_API int pl_model_load_memory(const void *data, size_t size, pl_model **out);
PL_API void pl_model_free(pl_model *model);

typedef struct pl_model_info {
    const char *arch;        /* "densenet121-parametric" */
    const char *precision;   /* "fp32" or "int8" */
    const char *provenance;  /* how the weights were made (free text from the file) */
    int n_lights;            /* N: 2, 3 or 5 */
    int input_h, input_w;    /* network input in pixels (192 x 256 by default) */
    int64_t n_params;        /* parameters in the file's tensors */
    int64_t file_size;       /* bytes */
    size_t arena_bytes;      /* the executor's planned working memory */
    double anchor[3];        /* intensity anchor w, b (stops), gamma; w = b = 0: off */
} pl_model_info;

/* Fills *info; the strings belong to the model. */
PL_API int pl_model_get_info(const pl_model *model, pl_model_info *info);

/* Worker threads for the next estimates (1 = the calling thread only). Results do not depend
 * on the count. */
PL_API int pl_model_set_threads(pl_model *model, int n_threads);

/* Intensity anchor (docs/LIGHTING.md): each estimate's light colours and ambient are scaled by
 * 2^(w ev + b), where ev = log2(the frame's mean linear luminance, pixels linearised as
 * (v/255)^gamma, over the lighting's mean luminance over the sphere). w = 0 keeps the network's
 * intensity, w = 1 takes the frame's; b shifts by stops. The file's `intensity_anchor` metadata
 * sets it at load (docs/FORMAT.md); w = b = 0 turns it off. w in 0..1, b in -8..8, gamma 1..3. */
PL_API int pl_model_set_anchor(pl_model *model, double w, double b, double gamma);

/* ---- estimation -------------------------------------------------------------------------- */

/* Time spent in the last estimate, milliseconds. */
typedef struct pl_timing {
    double preprocess_ms;  /* crop, resize, normalise */
    double infer_ms;       /* encoder + heads */
} pl_timing;

/* Estimates lighting from one RGB frame, 8 bits per channel, rows `stride` bytes apart, any
 * size of at least 8 x 8. The frame is centre-cropped to 4:3 (the model's aspect) and resized
 * to the model input with an area filter. Not reentrant for one model: use one model per thread
 * that calls it. */
PL_API int pl_estimate_rgb8(pl_model *model, const uint8_t *rgb, int width, int height,
                            size_t stride, pl_lighting *out, pl_timing *timing);

/* YCbCr encoding of a camera frame: the matrix (BT.601 or BT.709) and the range (limited 16..235
 * or full 0..255). V4L2's ycbcr_enc and quantization fields and libcamera's ColorSpace say which
 * a camera sends; most webcams send BT.601 limited. */
typedef enum pl_ycbcr {
    PL_YCBCR_BT601_LIMITED = 0,
    PL_YCBCR_BT601_FULL = 1,
    PL_YCBCR_BT709_LIMITED = 2,
    PL_YCBCR_BT709_FULL = 3,
} pl_ycbcr;

/* Estimates from a camera frame as it comes, converted to RGB by the conversion the V4L2 and
 * libcamera sources use (chroma nearest, no filter; exact to within 1 of the formula), then as
 * pl_estimate_rgb8. The model keeps one RGB buffer for it, grown when the frame size grows:
 * nothing is allocated per frame once sizes settle. The conversion counts as preprocess time.
 *  YUYV (V4L2_PIX_FMT_YUYV): rows of Y0 U Y1 V macropixels, `stride` >= 2 x width bytes apart;
 *       width even (a macropixel is two pixels), height any; both >= 8.
 *  NV12 (V4L2_PIX_FMT_NV12): a Y plane (rows y_stride >= width bytes apart) and an interleaved
 *       U V plane of height / 2 rows (uv_stride >= width); width and height even, >= 8.
 *       V4L2's single-planar NV12 has uv = y + y_stride * height and uv_stride = y_stride.
 * An odd size, a short stride or an unknown encoding is PL_E_ARG naming it. Not reentrant for
 * one model, as pl_estimate_rgb8. */
PL_API int pl_estimate_yuyv(pl_model *model, const uint8_t *yuyv, int width, int height,
                            size_t stride, pl_ycbcr encoding, pl_lighting *out, pl_timing *timing);
PL_API int pl_estimate_nv12(pl_model *model, const uint8_t *y, size_t y_stride, const uint8_t *uv,
                            size_t uv_stride, int width, int height, pl_ycbcr encoding,
                            pl_lighting *out, pl_timing *timing);

/* Reads an image file into 8-bit RGB, rows packed (stride 3 x width), in a new buffer the caller
 * frees with pl_free: the decoding `parlight estimate --input` does, so the same file gives the
 * same lights. JPEG and PNG by the codecs linked in (EXIF orientation applied); BMP, TIFF, WebP,
 * PNM, ... through the OpenCV plugin when this build has one (loaded on first use; a missing
 * plugin is PL_E_UNSUPPORTED naming it and the folders searched). Sizes are checked on the
 * header before decoding (at most 64 Mi pixels). Errors name the path: PL_E_IO (missing,
 * unreadable, not a regular file), PL_E_FORMAT (not an image, truncated, corrupt, too large),
 * PL_E_UNSUPPORTED (HDR and float images: not frames). On failure *rgb is NULL. */
PL_API int pl_image_load_rgb8(const char *path, uint8_t **rgb, int *width, int *height);
/* Frees a buffer the library allocated for the caller (pl_image_load_rgb8); NULL is fine. */
PL_API void pl_free(void *p);

/* ---- what AR apps use: primary light, SH, the engine form, relighting, poses ------------- */

/* The lights as seen from point p (metres, camera frame): direction d*l - p, distance |d*l - p|,
 * solid angle scaled by (d/|d*l - p|)^2; rgb (peak radiance) and ambient unchanged. PL_E_ARG if p
 * is within 1 mm of a light or not finite. p = 0 returns L unchanged. out may be L. */
PL_API int pl_lighting_at_point(const pl_lighting *L, const float p[3], pl_lighting *out);

/* Main light for AR: the light with the largest energy, luminance(rgb) * (its lobe's integral,
 * 2 pi sigma (1 - e^(-2 / sigma)), sigma = s / 4pi) with
 * luminance = 0.2126 r + 0.7152 g + 0.0722 b (the first one on ties). dir = its direction, rgb =
 * its peak radiance c_i. Returns the index of that light (>= 0); with no lights dir = (0, 1, 0),
 * rgb = (0, 0, 0) and it returns 0 as well (PL_E_ARG only for NULL outputs). */
PL_API int pl_lighting_primary(const pl_lighting *L, float dir[3], float rgb[3]);

/* L with its primary light (pl_lighting_primary's) turned to dir, a direction in L's own frame
 * (normalised here); its distance, size and colour, the other lights and the ambient unchanged.
 * For an app that fuses views (pl_key_fuser_get): the frame's lighting aimed at the key light,
 * which puts the same light where the room's light is (docs/OUTPUT.md, "Aiming at the key
 * light"; world-space lights take the key's dir as it is, camera-frame ones R^T dir). Returns the
 * primary light's index (0 with no lights: out = L). PL_E_ARG, out untouched, for NULL arguments
 * or a zero or non-finite dir. out may be L. */
PL_API int pl_lighting_aim_primary(const pl_lighting *L, const float dir[3], pl_lighting *out);

/* 27 L2 SH coefficients, WebXR order (9 coefficients x RGB interleaved: L00.r, L00.g, L00.b,
 * L1-1.r, ...), in the order L00, L1-1, L10, L11, L2-2, L2-1, L20, L21, L22, real orthonormal
 * basis. They project RADIANCE (not irradiance): sh[k] = integral L(u) Y_k(u) du. Basis
 * constants and the irradiance conversion are in docs/LIGHTING.md. SG lobes are projected in
 * closed form (zonal), so this is exact up to float rounding. */
PL_API void pl_sh9_from_lights(const pl_lighting *L, float sh[27]);

/* Lighting an engine applies as it is, without double counting (docs/LIGHTING.md, "Engine-ready
 * lighting"): a directional light for the primary light and an SH probe of everything else, so
 * that DirectionalLight(dir, intensity) + LightProbe(sh9) gives the diffuse irradiance of the
 * whole lighting (three.js, WebXR, ARCore and Unity all add the two).
 *   dir        toward the primary light (pl_lighting_primary's light, unit); (0, 1, 0) with none
 *   intensity  RGB irradiance the directional light delivers at normal incidence (three.js:
 *              its colour x intensity): the share of the primary lobe a directional light can
 *              carry, chosen to minimise the error left in SH bands >= 4. About the lobe's energy
 *              c * (its lobe's integral) for a lamp; for wide lobes less, the rest stays in sh9
 *   sh9        27 radiance SH coefficients (pl_sh9_from_lights' order and basis) of the
 *              lighting minus a delta light of that intensity in dir
 * Measured against brute-force irradiance (tests/test_engine.c, error / peak irradiance): 0.3% for
 * a 0.002 sr lamp, <= 2.1% for one lobe of 0.01..1 sr, 0.4% at 2.9 sr; sh9 alone 0.9..7%, sh9 +
 * a directional light of the primary 9..97%. */
typedef struct pl_engine_lighting {
    float dir[3];
    float intensity[3];
    float sh9[27];
} pl_engine_lighting;
PL_API void pl_lighting_engine(const pl_lighting *L, pl_engine_lighting *out);

/* Evaluates the radiance of 27 SH coefficients in unit direction u. */
PL_API void pl_sh9_eval(const float sh[27], const float u[3], float rgb[3]);

/* How far |q| may be from 1 before a quaternion is refused rather than normalised. */
#define PL_QUAT_UNIT_TOL 1e-3

/* Row-major 3x3 rotation of unit quaternion q (w, x, y, z). PL_E_ARG, naming the problem, when
 * a component is not finite or | |q| - 1 | > PL_QUAT_UNIT_TOL; otherwise q is normalised first. */
PL_API int pl_quat_to_rotation(const double q[4], double R[9]);

/* Every light direction turned by R (distances, sizes, colours and the ambient unchanged);
 * out may be L. */
PL_API void pl_lighting_rotate(const pl_lighting *L, const double R[9], pl_lighting *out);

/* Environment map of the lights + ambient (eq. 4 above), equirectangular, width x width / 2
 * pixels, each the radiance at its centre direction: pixel (x, y) looks along longitude
 * phi = 2 pi ((x + 0.5) / width - 0.5) and latitude theta = pi (0.5 - (y + 0.5) / (width / 2)),
 * u = (cos theta sin phi, sin theta, -cos theta cos phi): the image centre is the camera's view
 * (-z), the top row up (+y) (docs/LIGHTING.md). rgb holds width * width / 2 * 3 floats,
 * interleaved linear RGB, rows top to bottom (the caller's). width even, 2..32768; PL_E_ARG for
 * a bad width, a NULL pointer or an invalid lighting (NaN, n_lights out of range, ...). */
PL_API int pl_equirect_from_lights(const pl_lighting *L, int width, float *rgb);

/* HDR cube map of the lights + ambient: 6 faces in the order +X, -X, +Y, -Y, +Z, -Z, OpenGL
 * cube-map conventions (what WebXR's XRLightProbe and WebGL's TEXTURE_CUBE_MAP use; face
 * orientation in docs/LIGHTING.md), each face x face pixels, rows top to bottom, interleaved
 * linear RGB: rgb holds 6 * face * face * 3 floats (the caller's). face 1..4096; PL_E_ARG as
 * above. */
PL_API int pl_cubemap_from_lights(const pl_lighting *L, int face, float *rgb);

/* ---- the room's key light over views ------------------------------------------------------ */

/* One frame says little about where a room's main light is when that light is out of view; an
 * AR app that knows the camera's pose sees the room from several headings, and the frames'
 * lights, turned into world space, agree most where the light really is (measured on the
 * evaluation rooms: 42 degrees from the room's main light after a full turn, against 60 for
 * single frames; models/MODEL_CARD.md, "The key light over views"). A key fuser keeps the
 * latest frame of each heading (8 sectors of 45 degrees x 3 bands of pitch, split at +-30
 * degrees), weighs every kept frame equally (its lights divided by their total energy, so
 * exposure changes between frames do not matter), and returns the direction where the frames'
 * lobes add up to the most (docs/OUTPUT.md, "Key light over views"; what `parlight estimate
 * --fuse` prints). Allocated once (16 KB); nothing is allocated per frame. Each
 * pl_key_fuser_get costs up to 24 x N x 1024 exponentials (1.1 ms for 24 headings of 3 lights on
 * one AMD EPYC core). One fuser per camera stream, used by one thread at a time. */
typedef struct pl_key_fuser pl_key_fuser;

/* The fused key light: dir, unit, world space (the frame of the R given to pl_key_fuser_add),
 * from the viewer toward the light; views, how many kept frames it rests on. views 0: no frame
 * with light yet (dir is then (0, 1, 0)). */
typedef struct pl_key_light {
    float dir[3];
    int views;
} pl_key_light;

/* A new, empty fuser in *out. max_age_s: frames older than this (by the t_s given) stop
 * counting, so walking into another room lets the old room's frames go; 0: they never expire.
 * PL_E_ARG (max_age_s negative or not finite, out NULL), PL_E_NOMEM. */
PL_API int pl_key_fuser_new(double max_age_s, pl_key_fuser **out);
/* Frees a fuser; NULL is fine. */
PL_API void pl_key_fuser_free(pl_key_fuser *fuser);
/* Forgets every frame (another model, another room). */
PL_API void pl_key_fuser_reset(pl_key_fuser *fuser);
/* Adds a frame: its lighting as pl_estimate_* returned it (camera frame, before any
 * pl_lighting_rotate), the camera-to-world rotation R of that frame (row-major 3x3, e.g. from
 * pl_quat_to_rotation; orthonormal within 1e-3; from a column-major 4x4 camera pose M as ARKit,
 * ARCore and OpenGL store it, R[3 * i + j] = M[4 * j + i]; world y up, as WebXR's, for the
 * heading bins) and its time t_s in seconds (any finite clock, only compared with other frames'
 * times). It replaces the kept frame of its heading. PL_E_ARG, naming the problem, for an
 * invalid lighting, a matrix that is not a rotation or a time that is not finite; the fuser is
 * then unchanged. */
PL_API int pl_key_fuser_add(pl_key_fuser *fuser, const pl_lighting *cam, const double R[9],
                            double t_s);
/* The key light at time t_s (frames older than max_age_s before it left out). Returns 0, with
 * out->views 0 when no kept frame holds light; PL_E_ARG for a NULL argument or a time that is
 * not finite. */
PL_API int pl_key_fuser_get(const pl_key_fuser *fuser, double t_s, pl_key_light *out);

/* The room's intensity over views (models/MODEL_CARD.md, "Intensity over views"). Auto exposure
 * hides how bright a room is, and one frame's intensity misses by up to a stop and a half either
 * way; the camera's exposure, which an AR app knows (ARKit's exposure duration and offset,
 * ARCore's image metadata, V4L2's exposure and gain controls), gives it back. Measured on the
 * evaluation rooms over a full turn: RMSE 0.688 -> 0.351 (below the constant-ambient baseline's
 * 0.500) in every room. pl_key_fuser_add_exposed is pl_key_fuser_add with the frame's exposure:
 * what the camera multiplied the scene's radiance by (exposure time x analog x digital gain x
 * 2^exposure offset, in any unit that stays the same for the stream; > 0 and finite, PL_E_ARG
 * otherwise, the fuser then unchanged). Each kept frame records its level, log2 of its
 * lighting's total energy over its exposure; the room's level is their mean. */
PL_API int pl_key_fuser_add_exposed(pl_key_fuser *fuser, const pl_lighting *cam, const double R[9],
                                    double t_s, double exposure);
/* L (any frame: camera or world space, aimed or not) brought to the room's level at time t_s:
 * its lights' colours and its ambient times 2^level x exposure / (L's total energy), exposure
 * being L's frame's (as given to pl_key_fuser_add_exposed). Returns how many kept frames the
 * level rests on; with none, when L has no energy, or when the colours would leave float's range
 * (an exposure ~2^128 from the views'), *out = *L. out may be L. PL_E_ARG for a NULL argument, a
 * time that is not finite, an exposure that is not > 0 and finite, or an invalid L; out is then
 * untouched. */
PL_API int pl_key_fuser_level(const pl_key_fuser *fuser, double t_s, const pl_lighting *L,
                              double exposure, pl_lighting *out);

/* ---- the JSON line ------------------------------------------------------------------------ */

/* What the line says about a frame besides its lighting (docs/OUTPUT.md). */
typedef struct pl_frame_meta {
    int64_t frame;                 /* "frame" */
    int64_t t_ns;                  /* "t_ns" */
    const char *source;            /* "source" (escaped here; NULL = "") */
    const double *orientation;     /* camera-to-world (w, x, y, z) the lighting was turned by:
                                      "space":"world"; NULL: "space":"camera" */
    pl_timing timing;              /* "timing_ms" preprocess and infer */
    double total_ms;               /* "timing_ms" total */
    double latency_ms;             /* "timing_ms" latency; < 0: left out */
    int64_t dropped;               /* "dropped" */
} pl_frame_meta;

/* Writes the one-line JSON object `parlight estimate` prints for a frame, '\n' included, into
 * buf (cap bytes; 16384 suffice for 16 lights and a source of up to 4096 plain characters),
 * NUL-terminated.
 * Returns its length, or PL_E_ARG when it does not fit or an argument is NULL. Apps that emit
 * this stream themselves produce the same bytes as the CLI. */
PL_API int pl_frame_format_json(const pl_frame_meta *meta, const pl_lighting *lighting, char *buf,
                                size_t cap);

/* The same line with a "key_light" member last: {"dir":[x,y,z],"views":K} from key, or null when
 * key->views is 0 (what `parlight estimate --fuse` prints). key NULL: PL_E_ARG; otherwise as
 * pl_frame_format_json (64 more bytes suffice). */
PL_API int pl_frame_format_json_key(const pl_frame_meta *meta, const pl_lighting *lighting,
                                    const pl_key_light *key, char *buf, size_t cap);

/* The latent z of the last estimate (3072 floats for the default model: 1024 channels x 3
 * bands, channel-major), for tests and tools. */
PL_API int pl_model_last_latent(const pl_model *model, const float **z, int *n);

#ifdef __cplusplus
}
#endif
#endif
