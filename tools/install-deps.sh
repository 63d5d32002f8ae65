#!/usr/bin/env bash
# Installs what parlight needs and is missing: Debian packages with apt-get (through sudo when
# not root) and the npm packages the tests and sample tools read, into .deps/npm.
# Does nothing when everything is present. Run by `make demo` and `make test`.
set -euo pipefail
cd "$(dirname "$0")/.."

PKGS=(
    build-essential pkg-config
    libopencv-dev          # image and video files (port/image_io.cpp)
    libopenexr-dev         # .exr panoramas and maps
    libcamera-dev          # libcamera camera source (port/source_libcamera.cpp)
    python3-torch python3-torchvision python3-numpy python3-pil   # reference model, exporter, golden tests
    qemu-system-x86 kmod cpio xz-utils   # camera rig VM (tools/camrig; kernel + busybox are apt-get downloaded, not installed)
)

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
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# npm: CC0 HDR panoramas (@pmndrs/assets) for the sample-frame tool and the lighting tests.
NPM_DIR=.deps/npm
if [ ! -f "$NPM_DIR/node_modules/@pmndrs/assets/package.json" ]; then
    echo "install-deps: installing @pmndrs/assets into $NPM_DIR" >&2
    mkdir -p "$NPM_DIR"
    npm install --prefix "$NPM_DIR" --no-audit --no-fund --loglevel=error @pmndrs/assets@1.7.0 >/dev/null
fi
