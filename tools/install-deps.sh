#!/usr/bin/env bash
# Installs what parlight needs and is missing: Debian packages with apt-get (through sudo when
# not root), the npm packages the tests and sample tools read, into .deps/npm, and the live
# viewer's (npm ci in app/viewer).
# Does nothing when everything is present. Run by `make demo` and `make test`.
# With a cross board (`tools/install-deps.sh rpi5`, or BOARD=rpi5 in the environment, as
# `make test BOARD=rpi5` passes it) it also installs that board's cross toolchain, qemu-user and
# the target's -dev libraries (Debian multiarch, e.g. libpng-dev:arm64); a host build stays lean.
set -euo pipefail
cd "$(dirname "$0")/.."
BOARD=${1:-${BOARD:-host}}
[ -f "boards/$BOARD.mk" ] || { echo "install-deps: no boards/$BOARD.mk" >&2; exit 1; }
# The board's Debian architecture, when it is a cross board (BOARD_DEB_ARCH in its .mk).
DEB_ARCH=$(sed -n 's/^BOARD_DEB_ARCH *:\?= *\([a-z0-9]*\).*/\1/p' "boards/$BOARD.mk")

PKGS=(
    build-essential pkg-config
    libjpeg-dev libpng-dev # JPEG and PNG files, MJPEG frames (port/jpeg_codec.c, port/png_codec.c)
    libopencv-dev          # other image formats and videos (port/image_io.cpp, port/video_cv.cpp)
    libopenexr-dev         # .exr panoramas and maps
    libcamera-dev          # libcamera camera source (port/source_libcamera.cpp)
    libwebsockets-dev      # --out ws:// (port/sink_ws.c)
    libmosquitto-dev       # --out mqtt:// (port/sink_mqtt.c)
    mosquitto mosquitto-clients  # tests/test_sink_mqtt.sh runs its own broker (own config, 127.0.0.1, a free
                           # port) and mosquitto_sub; a system broker the package may start is not used
    python3-websockets     # tests/test_sink_ws.sh: a browser-like WebSocket client
    chromium curl          # tests/test_viewer.sh: the live viewer in headless Chromium (driven by
                           # playwright-core from app/viewer/node_modules), its static files with curl
    python3-torch python3-torchvision python3-numpy python3-pil   # reference model, exporter, golden tests
    nodejs python3-onnx    # make bench: ONNX Runtime peer (npm onnxruntime-node under node) and its ONNX models (tools/bench)
    time                   # make bench: /usr/bin/time -v for the peak RSS of parlight estimate
    qemu-system-x86 kmod cpio xz-utils   # camera rig VM (tools/camrig; kernel + busybox are apt-get downloaded, not installed)
    clang libclang-rt-dev  # make fuzz: clang with libFuzzer and the sanitizer runtimes (docs/TESTING.md)
)

CROSS_ARCH=""
case "$DEB_ARCH" in
    "") ;;
    arm64)
        CROSS_ARCH=arm64
        PKGS+=(
            gcc-aarch64-linux-gnu g++-aarch64-linux-gnu libc6-dev-arm64-cross  # cross toolchain
            qemu-user                                     # runs the board's tests (qemu-aarch64)
            llvm-19                # make bench-arm: llvm-mca-19 (Neoverse N1 model for the A76/A78)
            libjpeg62-turbo-dev:arm64 libpng-dev:arm64 zlib1g-dev:arm64  # the target's codecs
            libmosquitto-dev:arm64 # the target's mqtt:// sink. Not libwebsockets-dev:arm64: Debian 12's
                                   # cannot sit beside the host's (their /usr/include/lws_config.h
                                   # differ), so board builds have no ws:// (docs/PORTING.md)
        ) ;;
    *) echo "install-deps: boards/$BOARD.mk: no cross packages known for '$DEB_ARCH'" >&2; exit 1 ;;
esac

missing=()
for p in "${PKGS[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
command -v npm >/dev/null 2>&1 || missing+=(npm)

if [ ${#missing[@]} -gt 0 ]; then
    echo "install-deps: installing ${missing[*]}" >&2
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then
        command -v sudo >/dev/null 2>&1 || { echo "install-deps: need root or sudo to install ${missing[*]}" >&2; exit 1; }
        SUDO=sudo
    fi
    export DEBIAN_FRONTEND=noninteractive
    if [ -n "$CROSS_ARCH" ] && ! dpkg --print-foreign-architectures | grep -qx "$CROSS_ARCH"; then
        echo "install-deps: adding the $CROSS_ARCH architecture for the $BOARD libraries" >&2
        $SUDO dpkg --add-architecture "$CROSS_ARCH"
    fi
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# npm: the live viewer's packages (three.js for the page, playwright-core for its browser test),
# exactly as pinned in app/viewer/package-lock.json; again when the lock file changes.
if [ ! -f app/viewer/node_modules/.package-lock.json ] ||
    [ app/viewer/package-lock.json -nt app/viewer/node_modules/.package-lock.json ]; then
    echo "install-deps: npm ci in app/viewer" >&2
    (cd app/viewer && npm ci --no-audit --no-fund --loglevel=error >/dev/null)
fi

# npm: CC0 HDR panoramas (@pmndrs/assets) for the sample-frame tool and the lighting tests.
NPM_DIR=.deps/npm
if [ ! -f "$NPM_DIR/node_modules/@pmndrs/assets/package.json" ]; then
    echo "install-deps: installing @pmndrs/assets into $NPM_DIR" >&2
    mkdir -p "$NPM_DIR"
    npm install --prefix "$NPM_DIR" --no-audit --no-fund --loglevel=error @pmndrs/assets@1.7.0 >/dev/null
fi
