#!/usr/bin/env bash
# make install into a staging folder, then use it as a library user would (docs/LIBRARY.md):
#  - DESTDIR staging writes only under DESTDIR (PREFIX is a folder that must not appear), and
#    installs the CLI, libparlight.a, libparlight.so.0 (SONAME, symlinks), parlight.h,
#    parlight.pc, the plugins in LIBDIR/parlight, parlight.1 and parlight.3, the models and
#    LICENSE;
#  - the shared library exports only pl_* names, exactly the PL_API functions of the header;
#    the plugins need no pl_* symbol from whoever loads them;
#  - tests/install_app.c (public header only) builds with `pkg-config --cflags --libs parlight`
#    against libparlight.so and with `pkg-config --static ...` against libparlight.a; both load
#    the model from memory, estimate every sample frame and print JSON lines equal to the
#    installed `parlight estimate`'s (timing and time stamps aside), and estimate it as NV12;
#  - the installed OpenCV plugin is found and loaded by the shared app (beside libparlight.so),
#    by the static app through PARLIGHT_PLUGIN_DIR (and refused with a clear message without it)
#    and by the installed CLI (BINDIR/../lib/parlight): a BMP gives the same JSON everywhere.
# Host build only (BUILD=build): it runs `make install` on it.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
if [ "${PL_SAN:-0}" = 1 ] || [ -n "${PL_RUNNER:-}" ] || [ "$BUILD" != build ]; then
    echo "skip: installs and links the host build (build/) only, not $BUILD${PL_RUNNER:+ under $PL_RUNNER}"
    exit 77
fi
for tool in pkg-config nm readelf; do
    command -v $tool >/dev/null || { echo "skip: no $tool"; exit 77; }
done
T=$(mktemp -d "${PL_TEST_TMP:-/tmp}/install.XXXXXX")
trap 'rm -rf "$T"' EXIT
. tests/cli_helpers.sh
CC=${CC:-cc}
features=" $(cat "$BUILD/features" 2>/dev/null) "

# ---- install, staged ------------------------------------------------------------------------
prefix=/nonexistent-parlight-prefix-$$
stage=$T/stage
root=$stage$prefix
# make install builds what is out of date: with a build made in another configuration
# (WITH_OPENCV=0, ...) that would rebuild build/ behind the suite's back, so skip instead. The
# dry run shows the feature list a plain make would write to build/features.
plain=$(make --no-print-directory -n install DESTDIR="$stage" PREFIX="$prefix" |
        sed -n "s/^echo '\(.*\)' | cmp -s - .*features.*/\1/p" | head -n 1)
if [ "$plain" != "$(cat "$BUILD/features")" ]; then
    echo "skip: build/ has features '$(cat "$BUILD/features")', a plain make '$plain': run make first"
    exit 77
fi
expect 0 "" -- make --no-print-directory -s install DESTDIR="$stage" PREFIX="$prefix"
[ -e "$prefix" ] && fail "make install DESTDIR=... wrote to $prefix"
outside=$(find "$stage" -mindepth 1 -maxdepth 1 | grep -v "^$stage/nonexistent-parlight-prefix-$$\$")
[ -z "$outside" ] && ok "DESTDIR staging: everything under \$DESTDIR\$PREFIX" ||
    fail "staged outside \$DESTDIR\$PREFIX: $outside"
version=$(sed -n 's/^#define PARLIGHT_VERSION "\(.*\)"/\1/p' include/parlight.h)
major=${version%%.*}
want=(bin/parlight lib/libparlight.a "lib/libparlight.so.$version" "lib/libparlight.so.$major"
      lib/libparlight.so include/parlight.h lib/pkgconfig/parlight.pc share/man/man1/parlight.1
      share/man/man3/parlight.3 share/parlight/models/parlight-n3.plm
      share/parlight/models/parlight-n3-int8.plm share/parlight/models/MODEL_CARD.md
      share/doc/parlight/LICENSE)
[[ $features == *" opencv "* ]] && want+=(lib/parlight/parlight-opencv.so)
[[ $features == *" libcamera "* ]] && want+=(lib/parlight/parlight-libcamera.so)
missing=""
for f in "${want[@]}"; do [ -e "$root/$f" ] || missing+=" $f"; done
[ -z "$missing" ] && ok "installed: ${#want[@]} files" || fail "not installed:$missing"
[ "$(readlink "$root/lib/libparlight.so.$major")" = "libparlight.so.$version" ] &&
    [ "$(readlink "$root/lib/libparlight.so")" = "libparlight.so.$major" ] &&
    ok "symlinks libparlight.so -> .so.$major -> .so.$version" || fail "shared library symlinks"
grep -q "^prefix=$prefix\$" "$root/lib/pkgconfig/parlight.pc" &&
    ok "parlight.pc names PREFIX, not DESTDIR" || fail "parlight.pc: $(head -1 "$root/lib/pkgconfig/parlight.pc")"

# ---- what the shared library exports --------------------------------------------------------
so=$root/lib/libparlight.so.$major
readelf -d "$so" | grep -q "SONAME.*\[libparlight.so.$major\]" && ok "SONAME libparlight.so.$major" ||
    fail "SONAME: $(readelf -d "$so" | grep SONAME)"
nm -D --defined-only "$so" | awk '{print $NF}' | sort >"$T/exported"
sed -n 's/^PL_API [^(]*[ *]\(pl_[a-z0-9_]*\)(.*/\1/p' include/parlight.h | sort >"$T/api"
n=$(wc -l <"$T/exported")
if grep -qv '^pl_' "$T/exported"; then
    fail "exports non-pl_ symbols: $(grep -v '^pl_' "$T/exported" | head -5 | tr '\n' ' ')"
elif ! cmp -s "$T/exported" "$T/api"; then
    fail "exports differ from the header's PL_API functions: $(diff "$T/api" "$T/exported" | grep '^[<>]' | tr '\n' ' ')"
else
    ok "exports exactly the $n PL_API functions of parlight.h"
fi
for p in "$root"/lib/parlight/*.so; do
    [ -e "$p" ] || continue
    u=$(nm -uD "$p" | awk '$NF ~ /^pl_/ {print $NF}')
    [ -z "$u" ] && ok "$(basename "$p") needs no pl_* symbol from its host" ||
        fail "$(basename "$p") imports: $u"
done

# ---- the header alone, as C and C++ ---------------------------------------------------------
expect 0 "" -- "$CC" -std=c11 -Wall -Wextra -Wpedantic -Werror -fsyntax-only -I"$root/include" \
    -x c - <<<'#include <parlight.h>'
if command -v "${CXX:-c++}" >/dev/null; then
    expect 0 "" -- "${CXX:-c++}" -std=c++17 -Wall -Wextra -Werror -fsyntax-only -I"$root/include" \
        -x c++ - <<<'#include <parlight.h>'
fi

# ---- a program built with pkg-config, shared and static ------------------------------------
export PKG_CONFIG_PATH=$root/lib/pkgconfig PKG_CONFIG_SYSROOT_DIR=$stage
cflags=$(pkg-config --cflags parlight) libs=$(pkg-config --libs parlight)
slibs=$(pkg-config --static --libs parlight | sed 's/-lparlight\b/-l:libparlight.a/')
expect 0 "" -- "$CC" -std=c11 -Wall -Wextra -Werror tests/install_app.c $cflags $libs -lm \
    -o "$T/app_shared"
expect 0 "" -- "$CC" -std=c11 -Wall -Wextra -Werror tests/install_app.c $cflags $slibs -lm \
    -o "$T/app_static"
readelf -d "$T/app_shared" | grep -q "NEEDED.*libparlight.so.$major" && ok "app_shared needs libparlight.so.$major" ||
    fail "app_shared does not link libparlight.so.$major"
readelf -d "$T/app_static" | grep -q "NEEDED.*libparlight" && fail "app_static links libparlight.so" ||
    ok "app_static has libparlight.a inside"

norm() { sed -E 's/"t_ns":[0-9]+,//; s/"timing_ms":\{[^}]*\},//'; }
model=$root/share/parlight/models/parlight-n3-int8.plm
frames=(tests/data/frames/*.jpg)
expect 0 "" -- "$root/bin/parlight" estimate --model "$model" --input "${frames[0]}"
: >"$T/cli.jsonl"
for f in "${frames[@]}"; do
    "$root/bin/parlight" estimate --model "$model" --input "$f" | norm >>"$T/cli.jsonl"
done
for app in app_shared app_static; do
    LD_LIBRARY_PATH=$root/lib expect 0 "" -- "$T/$app" "$model" "${frames[@]}"
    norm <"$T/out" | sed -E 's/"frame":[0-9]+/"frame":0/' >"$T/$app.jsonl"
    if [ -s "$T/$app.jsonl" ] && cmp -s "$T/cli.jsonl" "$T/$app.jsonl"; then
        ok "$app: ${#frames[@]} JSON lines equal to parlight estimate's (model from memory, NV12 too)"
    else
        fail "$app: JSON differs from parlight estimate's: $(diff "$T/cli.jsonl" "$T/$app.jsonl" | head -c 400)"
    fi
done

# ---- the installed plugin, from the apps and the CLI ---------------------------------------
if [[ $features == *" opencv "* ]]; then
    python3 - "$T/frame.bmp" <<'PY'
import struct, sys
w, h = 96, 64
row = (w * 3 + 3) & ~3
px = bytearray()
for y in range(h):
    r = bytearray()
    for x in range(w):
        r += bytes([(x * 2) % 256, (y * 3) % 256, 230 if (x < 30 and y > 40) else 60])
    px += r + b"\0" * (row - w * 3)
hdr = b"BM" + struct.pack("<IHHI", 54 + len(px), 0, 0, 54)
hdr += struct.pack("<IiiHHIIiiII", 40, w, h, 1, 24, 0, len(px), 2835, 2835, 0, 0)
open(sys.argv[1], "wb").write(hdr + px)
PY
    env -u PARLIGHT_PLUGIN_DIR "$root/bin/parlight" estimate --model "$model" --input "$T/frame.bmp" \
        >"$T/cli_bmp" 2>"$T/err" && ok "installed CLI reads a BMP through lib/parlight/parlight-opencv.so" ||
        fail "installed CLI on a BMP: $(cat "$T/err")"
    norm <"$T/cli_bmp" >"$T/cli_bmp.n"
    LD_LIBRARY_PATH=$root/lib expect 0 "" -- env -u PARLIGHT_PLUGIN_DIR "$T/app_shared" "$model" "$T/frame.bmp"
    norm <"$T/out" >"$T/app_bmp.n"
    [ -s "$T/cli_bmp.n" ] && cmp -s "$T/app_bmp.n" "$T/cli_bmp.n" && ok "app_shared loads the installed plugin beside libparlight.so" ||
        fail "app_shared on a BMP: $(head -c 300 "$T/out") $(head -c 300 "$T/err")"
    expect 1 "cannot load the opencv plugin parlight-opencv.so" -- env -u PARLIGHT_PLUGIN_DIR \
        "$T/app_static" "$model" "$T/frame.bmp"
    PARLIGHT_PLUGIN_DIR=$root/lib/parlight expect 0 "" -- "$T/app_static" "$model" "$T/frame.bmp"
    norm <"$T/out" >"$T/app_bmp.n"
    [ -s "$T/cli_bmp.n" ] && cmp -s "$T/app_bmp.n" "$T/cli_bmp.n" && ok "app_static loads it through PARLIGHT_PLUGIN_DIR" ||
        fail "app_static on a BMP: $(head -c 300 "$T/out") $(head -c 300 "$T/err")"
else
    ok "(no OpenCV in this build: plugin checks skipped)"
fi
finish
