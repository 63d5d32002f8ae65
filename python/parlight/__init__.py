"""parlight: indoor lighting from one camera frame, a ctypes binding of libparlight.so.

    import numpy as np, parlight
    with parlight.Model("models/parlight-n3-int8.plm") as m:
        f = m.estimate(rgb)                     # rgb: H x W x 3 uint8 (RGB, not BGR)
        print(f["primary"]["dir"], f["ambient"])

estimate() returns the JSON object `parlight estimate` prints for a frame (docs/OUTPUT.md), made
by the library's own pl_frame_format_json and parsed with json.loads: the same fields, and for
the same pixels the same numbers, as the CLI.

KeyFuser is the room's key light fused over the headings a camera has seen (pl_key_fuser_*):
m.estimate(rgb, pose=q, fuse=k) adds the line's "key_light" as `estimate --poses ... --fuse` does;
aim=3 turns the primary light to it from 3 headings on (`--aim 3`).

Finding the library, first hit wins: the `lib` argument (a path), $PARLIGHT_LIB (a path), the
build/ folder of the checkout this package sits in (python/../build/libparlight.so), then
ctypes.util.find_library("parlight") (an installed libparlight.so.0: make install).

Threads (include/parlight.h): a pl_model is used by one thread at a time. A Model holds a lock
around every call into its pl_model, so sharing one between Python threads is safe but runs their
estimates one after the other; for parallel estimates give each thread its own Model. ctypes
releases the GIL during a call, so estimates on different Models do run in parallel. Functions
without a model (version()) are reentrant.

Errors: a failing library call raises ParlightError (a RuntimeError) carrying the library's
message (pl_last_error) and status; arguments refused before the library sees them (wrong dtype,
shape, a pose that is not a unit quaternion) raise ValueError or TypeError.
"""
import ctypes
import ctypes.util
import json
import math
import os
import threading
import time

import numpy as np

__all__ = ["Model", "KeyFuser", "ParlightError", "version", "load_library"]

PL_MAX_LIGHTS = 16
PL_E_ARG = -1
_JSON_CAP = 16384  # parlight.h: "16384 suffice for 16 lights and a source of up to 4096 ..."
_MAX_SOURCE = 4096


class ParlightError(RuntimeError):
    """A libparlight call failed: .status is its pl_status (negative), .status_name its name
    ("PL_E_FORMAT"), str() the library's message naming the file, field or size."""

    def __init__(self, message, status=0, status_name=""):
        super().__init__(message)
        self.status = status
        self.status_name = status_name


class _Light(ctypes.Structure):
    _fields_ = [("dir", ctypes.c_float * 3), ("distance_m", ctypes.c_float),
                ("solid_angle_sr", ctypes.c_float), ("rgb", ctypes.c_float * 3)]


class _Lighting(ctypes.Structure):
    _fields_ = [("n_lights", ctypes.c_int), ("lights", _Light * PL_MAX_LIGHTS),
                ("ambient", ctypes.c_float * 3)]


class _Timing(ctypes.Structure):
    _fields_ = [("preprocess_ms", ctypes.c_double), ("infer_ms", ctypes.c_double)]


class _FrameMeta(ctypes.Structure):
    _fields_ = [("frame", ctypes.c_int64), ("t_ns", ctypes.c_int64),
                ("source", ctypes.c_char_p), ("orientation", ctypes.POINTER(ctypes.c_double)),
                ("timing", _Timing), ("total_ms", ctypes.c_double),
                ("latency_ms", ctypes.c_double), ("dropped", ctypes.c_int64)]


class _KeyLight(ctypes.Structure):
    _fields_ = [("dir", ctypes.c_float * 3), ("views", ctypes.c_int)]


class _ModelInfo(ctypes.Structure):
    _fields_ = [("arch", ctypes.c_char_p), ("precision", ctypes.c_char_p),
                ("provenance", ctypes.c_char_p), ("n_lights", ctypes.c_int),
                ("input_h", ctypes.c_int), ("input_w", ctypes.c_int),
                ("n_params", ctypes.c_int64), ("file_size", ctypes.c_int64),
                ("arena_bytes", ctypes.c_size_t), ("anchor", ctypes.c_double * 3)]


_P = ctypes.c_void_p
_SIGNATURES = {  # name: (restype, argtypes), as declared in include/parlight.h
    "pl_version": (ctypes.c_char_p, []),
    "pl_status_name": (ctypes.c_char_p, [ctypes.c_int]),
    "pl_last_error": (ctypes.c_char_p, []),
    "pl_model_load": (ctypes.c_int, [ctypes.c_char_p, ctypes.POINTER(_P)]),
    "pl_model_load_memory": (ctypes.c_int, [ctypes.c_char_p, ctypes.c_size_t,
                                            ctypes.POINTER(_P)]),
    "pl_model_free": (None, [_P]),
    "pl_model_get_info": (ctypes.c_int, [_P, ctypes.POINTER(_ModelInfo)]),
    "pl_model_set_threads": (ctypes.c_int, [_P, ctypes.c_int]),
    "pl_estimate_rgb8": (ctypes.c_int, [_P, _P, ctypes.c_int, ctypes.c_int, ctypes.c_size_t,
                                        ctypes.POINTER(_Lighting), ctypes.POINTER(_Timing)]),
    "pl_quat_to_rotation": (ctypes.c_int, [ctypes.POINTER(ctypes.c_double),
                                           ctypes.POINTER(ctypes.c_double)]),
    "pl_lighting_rotate": (None, [ctypes.POINTER(_Lighting), ctypes.POINTER(ctypes.c_double),
                                  ctypes.POINTER(_Lighting)]),
    "pl_lighting_at_point": (ctypes.c_int, [ctypes.POINTER(_Lighting),
                                            ctypes.POINTER(ctypes.c_float),
                                            ctypes.POINTER(_Lighting)]),
    "pl_frame_format_json": (ctypes.c_int, [ctypes.POINTER(_FrameMeta),
                                            ctypes.POINTER(_Lighting), ctypes.c_char_p,
                                            ctypes.c_size_t]),
    "pl_frame_format_json_key": (ctypes.c_int, [ctypes.POINTER(_FrameMeta),
                                                ctypes.POINTER(_Lighting),
                                                ctypes.POINTER(_KeyLight), ctypes.c_char_p,
                                                ctypes.c_size_t]),
    "pl_key_fuser_new": (ctypes.c_int, [ctypes.c_double, ctypes.POINTER(_P)]),
    "pl_key_fuser_free": (None, [_P]),
    "pl_key_fuser_reset": (None, [_P]),
    "pl_key_fuser_add": (ctypes.c_int, [_P, ctypes.POINTER(_Lighting),
                                        ctypes.POINTER(ctypes.c_double), ctypes.c_double]),
    "pl_key_fuser_get": (ctypes.c_int, [_P, ctypes.c_double, ctypes.POINTER(_KeyLight)]),
    "pl_lighting_aim_primary": (ctypes.c_int, [ctypes.POINTER(_Lighting),
                                               ctypes.POINTER(ctypes.c_float),
                                               ctypes.POINTER(_Lighting)]),
    "pl_key_fuser_add_exposed": (ctypes.c_int, [_P, ctypes.POINTER(_Lighting),
                                                ctypes.POINTER(ctypes.c_double), ctypes.c_double,
                                                ctypes.c_double]),
    "pl_key_fuser_level": (ctypes.c_int, [_P, ctypes.c_double, ctypes.POINTER(_Lighting),
                                          ctypes.c_double, ctypes.POINTER(_Lighting)]),
}

_libs = {}
_libs_lock = threading.Lock()


def _candidates(lib):
    if lib is not None:
        return [os.fspath(lib)]
    env = os.environ.get("PARLIGHT_LIB")
    if env:
        return [env]
    out = []
    here = os.path.dirname(os.path.abspath(__file__))
    built = os.path.join(here, "..", "..", "build", "libparlight.so")
    if os.path.exists(built):
        out.append(os.path.normpath(built))
    found = ctypes.util.find_library("parlight")
    if found:
        out.append(found)
    return out


def load_library(lib=None):
    """The ctypes handle of libparlight.so, loaded once per path (see the module's doc for the
    search order). Raises OSError naming the paths tried when none loads."""
    tried = []
    for path in _candidates(lib):
        with _libs_lock:
            if path in _libs:
                return _libs[path]
            try:
                handle = ctypes.CDLL(path)
            except OSError as e:
                tried.append(f"{path}: {e}")
                continue
            for name, (restype, argtypes) in _SIGNATURES.items():
                fn = getattr(handle, name)
                fn.restype = restype
                fn.argtypes = argtypes
            _libs[path] = handle
            return handle
    raise OSError("parlight: cannot load libparlight.so (" +
                  ("; ".join(tried) if tried else
                   "not given, $PARLIGHT_LIB unset, no build/libparlight.so beside this package, "
                   "none installed") + ")")


def _error(L, status):
    msg = L.pl_last_error().decode("utf-8", "replace")
    name = L.pl_status_name(status).decode("ascii", "replace")
    return ParlightError(msg or name, status, name)


def version(lib=None):
    """pl_version(): the version of the library that is loaded ("0.8.0")."""
    return load_library(lib).pl_version().decode("ascii")


def _as_rgb(rgb):
    if not isinstance(rgb, np.ndarray):
        raise TypeError(f"parlight: rgb must be a numpy array, not {type(rgb).__name__}")
    if rgb.dtype != np.uint8:
        raise ValueError(f"parlight: rgb must be uint8 (8 bits per channel), not {rgb.dtype}")
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"parlight: rgb must be H x W x 3 (RGB), not shape {rgb.shape}")
    h, w = rgb.shape[0], rgb.shape[1]
    if h < 8 or w < 8 or h > 2**31 - 1 or w > 2**31 - 1:
        raise ValueError(f"parlight: rgb is {w} x {h} pixels: at least 8 x 8 needed")
    return np.ascontiguousarray(rgb)


def _as_time(t):
    try:
        v = float(t)
    except (TypeError, ValueError):
        raise ValueError(f"parlight: a time must be a number of seconds, not {t!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"parlight: a time must be finite, not {t!r}")
    return v


def _check_headings(name, n):
    """aim= and level=: a number of headings, 1..24 (the fuser's bins)."""
    if isinstance(n, bool) or not isinstance(n, int) or not 1 <= n <= 24:
        raise ValueError(f"parlight: {name} must be an integer in 1..24 (headings), not {n!r}")


def _as_exposure(x):
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"parlight: exposure must be a number > 0, not {x!r}") from None
    if isinstance(x, bool) or not (v > 0 and math.isfinite(v)):
        raise ValueError(f"parlight: exposure must be a finite number > 0, not {x!r}")
    return v


def _lighting_from_dict(d):
    """A camera-space line's lights (estimate()'s dict, or a parsed `parlight estimate` line) as
    a pl_lighting; ValueError naming what is missing or wrong."""
    if not isinstance(d, dict):
        raise TypeError(f"parlight: a lighting must be a dict (a JSON line), not {type(d).__name__}")
    if d.get("space", "camera") != "camera":
        raise ValueError(f"parlight: the lights must be in camera space (the line's \"space\" is "
                         f"{d.get('space')!r}): add a frame estimated without a pose")
    lights = d.get("lights")
    if not isinstance(lights, list) or len(lights) > PL_MAX_LIGHTS:
        raise ValueError(f"parlight: \"lights\" must be a list of at most {PL_MAX_LIGHTS} lights")
    L = _Lighting()
    L.n_lights = len(lights)
    def three(v):
        out = [float(x) for x in v]
        if len(out) != 3:
            raise ValueError
        return out

    try:
        for i, l in enumerate(lights):
            L.lights[i].dir[:] = three(l["dir"])
            L.lights[i].distance_m = float(l["distance_m"])
            L.lights[i].solid_angle_sr = float(l["solid_angle_sr"])
            L.lights[i].rgb[:] = three(l["rgb"])
        L.ambient[:] = three(d.get("ambient", [0, 0, 0]))
    except (KeyError, TypeError, ValueError):
        raise ValueError("parlight: each light needs dir[3], distance_m, solid_angle_sr and "
                         "rgb[3] numbers, and ambient 3 numbers") from None
    return L


def _as_quat(pose):
    try:
        q = [float(v) for v in pose]
    except (TypeError, ValueError):
        raise ValueError(f"parlight: pose must be 4 numbers (w, x, y, z), not {pose!r}") from None
    if len(q) != 4:
        raise ValueError(f"parlight: pose must be 4 numbers (w, x, y, z), not {len(q)}")
    return (ctypes.c_double * 4)(*q)


class _Owned:
    """A library object behind a handle: the loaded library, a lock held around every call into
    it, and close() (also `with` and garbage collection) freeing it with the function named by
    _FREE. Subclasses set _WHAT (for "the ... is closed") and _FREE."""
    _WHAT = "object"
    _FREE = None

    def _own(self, lib):
        self._lib = load_library(lib)
        self._lock = threading.Lock()
        self._p = None

    def _handle(self):
        if self._p is None:
            raise ValueError(f"parlight: the {self._WHAT} is closed")
        return self._p

    def close(self):
        """Frees the object; later calls raise ValueError. Idempotent."""
        lock = getattr(self, "_lock", None)
        if lock is None:
            return
        with lock:
            p, self._p = self._p, None
            if p is not None:
                getattr(self._lib, self._FREE)(p)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def __del__(self):
        try:
            self.close()
        except Exception:  # interpreter shutdown: the library may be gone already
            pass


class Model(_Owned):
    """A loaded .plm model (pl_model_load). Close it with close() or a `with` block; it is also
    freed when garbage-collected."""

    _WHAT = "model"
    _FREE = "pl_model_free"

    def __init__(self, path, lib=None, threads=1):
        self._own(lib)
        m = _P()
        st = self._lib.pl_model_load(os.fsencode(path), ctypes.byref(m))
        if st < 0:
            raise _error(self._lib, st)
        self._p = m
        self._setup(threads)

    @classmethod
    def from_bytes(cls, data, lib=None, threads=1):
        """A model from the bytes of a .plm file (pl_model_load_memory: copied, validated as a
        file is; messages name it "<memory>")."""
        self = cls.__new__(cls)
        self._own(lib)
        buf = bytes(data)
        m = _P()
        st = self._lib.pl_model_load_memory(buf, len(buf), ctypes.byref(m))
        if st < 0:
            raise _error(self._lib, st)
        self._p = m
        self._setup(threads)
        return self

    def _setup(self, threads):
        if threads != 1:
            st = self._lib.pl_model_set_threads(self._p, int(threads))
            if st < 0:
                err = _error(self._lib, st)
                self.close()
                raise err

    @property
    def info(self):
        """pl_model_get_info as a dict: arch, precision, provenance, n_lights, input_h,
        input_w, n_params, file_size, arena_bytes, anchor."""
        info = _ModelInfo()
        with self._lock:
            st = self._lib.pl_model_get_info(self._handle(), ctypes.byref(info))
            if st < 0:
                raise _error(self._lib, st)
            out = {k: getattr(info, k) for k, _ in _ModelInfo._fields_}
        for k in ("arch", "precision", "provenance"):
            out[k] = (out[k] or b"").decode("utf-8", "replace")
        out["anchor"] = list(info.anchor)
        return out

    def estimate(self, rgb, pose=None, at=None, frame=0, t_ns=None, source="", fuse=None,
                 fuse_t=None, aim=None, level=None, exposure=None):
        """Lighting of one frame, as the dict of `parlight estimate`'s JSON line.

        rgb     H x W x 3 numpy uint8 array, RGB order, at least 8 x 8 (copied when not
                C-contiguous); centre-cropped to 4:3 and resized by the library
        pose    None (camera space, "space":"camera") or the camera-to-world unit quaternion
                (w, x, y, z): lights, primary, sh9 and engine in world space, as the CLI's
                --orientation; |q| may differ from 1 by 1e-3 (PL_QUAT_UNIT_TOL), more is a
                ValueError with the library's message
        at      None or (x, y, z) metres: the lighting seen from that point (the CLI's --at;
                world axes when a pose is given)
        frame, t_ns, source   the line's "frame", "t_ns" (default: time.time_ns()) and
                "source" fields; timing_ms.total is measured around the library calls
        fuse    None or a KeyFuser (needs pose): the frame's own lights join it at time fuse_t
                (seconds; default t_ns / 1e9) and the line gets its "key_light", as the CLI's
                --poses ... --fuse prints it
        aim     None or N in 1..24 (needs fuse): once the key light rests on N headings or more,
                the frame's primary light is turned to it, as the CLI's --aim N
        exposure  None or the frame's exposure (> 0: what the camera multiplied the scene's
                radiance by, in any unit the stream keeps): with fuse, the frame joins it with
                its level (KeyFuser.add's exposure), as a --poses line's "exposure"
        level   None or N in 1..24 (needs fuse and exposure): once the room's level rests on N
                headings or more, the frame's intensity is brought to it, as the CLI's --level N
        """
        if fuse is not None:
            if not isinstance(fuse, KeyFuser):
                raise TypeError(f"parlight: fuse must be a KeyFuser, not {type(fuse).__name__}")
            if pose is None:
                raise ValueError("parlight: fuse needs the camera's pose (pose=...): the key "
                                 "light is fused in world space")
        if aim is not None:
            if fuse is None:
                raise ValueError("parlight: aim turns the lights to the fused key light: it "
                                 "needs fuse=KeyFuser(...)")
            _check_headings("aim", aim)
        if exposure is not None:
            if fuse is None:
                raise ValueError("parlight: exposure is kept by the key fuser: it needs "
                                 "fuse=KeyFuser(...)")
            exposure = _as_exposure(exposure)
        if level is not None:
            if exposure is None:
                raise ValueError("parlight: level brings the lights to the room's level over "
                                 "views: it needs fuse=KeyFuser(...) and the frame's exposure=")
            _check_headings("level", level)
        a = _as_rgb(rgb)
        q = R = p = None
        if pose is not None:
            q = _as_quat(pose)
            R = (ctypes.c_double * 9)()
            if self._lib.pl_quat_to_rotation(q, R) < 0:
                raise ValueError("parlight: pose: " +
                                 self._lib.pl_last_error().decode("utf-8", "replace"))
        if at is not None:
            try:
                pt = [float(v) for v in at]
            except (TypeError, ValueError):
                raise ValueError(f"parlight: at must be 3 numbers (x, y, z), not {at!r}") from None
            if len(pt) != 3 or not all(math.isfinite(v) for v in pt):
                raise ValueError(f"parlight: at must be 3 finite numbers (x, y, z), not {at!r}")
            p = (ctypes.c_float * 3)(*pt)
        src = str(source).encode("utf-8")
        if len(src) > _MAX_SOURCE:
            raise ValueError(f"parlight: source is {len(src)} bytes, at most {_MAX_SOURCE}")
        if t_ns is None:
            t_ns = time.time_ns()
        if fuse is not None:
            fuse_t = t_ns / 1e9 if fuse_t is None else _as_time(fuse_t)
        L = _Lighting()
        tm = _Timing()
        h, w = a.shape[0], a.shape[1]
        with self._lock:
            m = self._handle()
            t0 = time.perf_counter_ns()
            st = self._lib.pl_estimate_rgb8(m, a.ctypes.data, w, h, w * 3, ctypes.byref(L),
                                            ctypes.byref(tm))
            if st < 0:
                raise _error(self._lib, st)
        key = None
        if fuse is not None:  # the frame's own lights, camera frame (the CLI's order)
            key = fuse._add_get(L, R, fuse_t, exposure)
        if R is not None:
            self._lib.pl_lighting_rotate(ctypes.byref(L), R, ctypes.byref(L))
        if aim is not None and key.views >= aim:  # world space: the key's dir as it is
            st = self._lib.pl_lighting_aim_primary(ctypes.byref(L), key.dir, ctypes.byref(L))
            if st < 0:
                raise _error(self._lib, st)
        if level is not None:
            fuse._level(L, fuse_t, exposure, level)
        if p is not None:
            st = self._lib.pl_lighting_at_point(ctypes.byref(L), p, ctypes.byref(L))
            if st < 0:
                raise _error(self._lib, st)
        meta = _FrameMeta(int(frame), int(t_ns), src,
                          ctypes.cast(q, ctypes.POINTER(ctypes.c_double)) if q else None,
                          tm, (time.perf_counter_ns() - t0) / 1e6, -1.0, 0)
        buf = ctypes.create_string_buffer(_JSON_CAP)
        if key is None:
            n = self._lib.pl_frame_format_json(ctypes.byref(meta), ctypes.byref(L), buf,
                                               _JSON_CAP)
        else:
            n = self._lib.pl_frame_format_json_key(ctypes.byref(meta), ctypes.byref(L),
                                                   ctypes.byref(key), buf, _JSON_CAP)
        if n < 0:
            raise _error(self._lib, n)
        return json.loads(buf.raw[:n].decode("utf-8"))


class KeyFuser(_Owned):
    """The room's key light fused over the headings a camera has seen (pl_key_fuser_*,
    docs/OUTPUT.md "Key light over views"): the CLI's `estimate --poses ... --fuse MAX_AGE`.

        k = parlight.KeyFuser(max_age=30)            # seconds; 0: views never expire
        f = m.estimate(rgb, pose=q, fuse=k)          # f["key_light"]: {"dir", "views"} or None
        k.add(camera_line, pose=q, t=12.5)           # or a camera-space line from elsewhere
        k.key(t=12.5)                                # {"dir": [x, y, z], "views": K} or None

    It keeps the latest frame of each heading (8 yaw sectors x 3 pitch bands), each weighed
    equally, and answers the world-space direction where their lights add up to the most. Like a
    Model it locks around its calls; close() or a `with` block frees it."""

    _WHAT = "key fuser"
    _FREE = "pl_key_fuser_free"

    def __init__(self, max_age=0.0, lib=None):
        self._own(lib)
        k = _P()
        st = self._lib.pl_key_fuser_new(_as_time(max_age), ctypes.byref(k))
        if st < 0:
            raise ValueError("parlight: max_age: " +
                             self._lib.pl_last_error().decode("utf-8", "replace"))
        self._p = k

    def _add_get(self, L, R, t, exposure=None):
        key = _KeyLight()
        with self._lock:
            k = self._handle()
            if exposure is None:
                st = self._lib.pl_key_fuser_add(k, ctypes.byref(L), R, t)
            else:
                st = self._lib.pl_key_fuser_add_exposed(k, ctypes.byref(L), R, t, exposure)
            if st >= 0:
                st = self._lib.pl_key_fuser_get(k, t, ctypes.byref(key))
            if st < 0:
                raise _error(self._lib, st)
        return key

    def _level(self, L, t, exposure, min_views):
        """L brought to the room's level in place once it rests on min_views kept frames."""
        out = _Lighting()
        with self._lock:
            n = self._lib.pl_key_fuser_level(self._handle(), t, ctypes.byref(L), exposure,
                                             ctypes.byref(out))
        if n < 0:
            raise _error(self._lib, n)
        if n >= min_views:
            ctypes.pointer(L)[0] = out
        return n

    def add(self, lighting, pose, t, exposure=None):
        """Adds a frame: lighting, a camera-space line (estimate() without a pose, or a parsed
        `parlight estimate` line); pose, that frame's camera-to-world quaternion (w, x, y, z);
        t, its time in seconds; exposure, None or the frame's exposure (> 0), which records its
        level for estimate(..., level=N). Returns the key light after it, as key() does."""
        L = _lighting_from_dict(lighting)
        R = (ctypes.c_double * 9)()
        if self._lib.pl_quat_to_rotation(_as_quat(pose), R) < 0:
            raise ValueError("parlight: pose: " +
                             self._lib.pl_last_error().decode("utf-8", "replace"))
        x = None if exposure is None else _as_exposure(exposure)
        return _key_dict(self._add_get(L, R, _as_time(t), x))

    def key(self, t):
        """The key light at time t (seconds): {"dir": [x, y, z], "views": K}, or None before any
        frame with light."""
        key = _KeyLight()
        with self._lock:
            st = self._lib.pl_key_fuser_get(self._handle(), _as_time(t), ctypes.byref(key))
        if st < 0:
            raise _error(self._lib, st)
        return _key_dict(key)

    def reset(self):
        """Forgets every frame (another room, another model)."""
        with self._lock:
            self._lib.pl_key_fuser_reset(self._handle())


def _key_dict(key):
    if key.views <= 0:
        return None
    return {"dir": [float(v) for v in key.dir], "views": int(key.views)}
