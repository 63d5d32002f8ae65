#!/usr/bin/env bash
# Builds the camera rig's guest: an ELF vmlinux and an initramfs holding busybox, the vivid module
# closure, parlight with its shared libraries, the model and /init (tools/camrig/init.sh).
#
#   tools/camrig/build.sh [--build DIR] [--model FILE] [--compress none|gzip] [--share none|9p]
#                         [--frames DIR]
#
# --frames DIR builds the UVC webcam guest instead (outputs in DIR/camrig-uvc/): no vivid but
# dummy_hcd, gadgetfs and uvcvideo, the userspace webcam tools/camrig/uvc-gadget (built here) with
# the frames of DIR, the frames as a reader will see them (uvc-gadget --expected) and
# tools/camrig/init-uvc.sh as /init.
# --share 9p keeps parlight, its libraries and the model out of the initramfs, in DIR/camrig/share,
# which run.sh --share 9p exports to the guest read-only over virtio-9p (the 9p modules are added).
# Debian's kernel and busybox-static are fetched with `apt-get download` into .deps/camrig/debs
# and unpacked there with dpkg -x: nothing is installed on the host. Outputs go to DIR/camrig/
# (DIR defaults to $BUILD or build): vmlinux, initramfs.cpio[.gz], sizes.txt. Prints the paths.
# Needs: apt-get, dpkg, depmod/modprobe (kmod), cpio, xz, ldd (tools/install-deps.sh installs them).
set -euo pipefail
cd "$(dirname "$0")/../.."

BUILD_DIR=${BUILD:-build}
MODEL=build/models/seeded-n3.plm
COMPRESS=none
SHARE=none
FRAMES_DIR=""
while [ $# -gt 0 ]; do
    case "$1" in
        --build) BUILD_DIR=$2; shift 2 ;;
        --model) MODEL=$2; shift 2 ;;
        --compress) COMPRESS=$2; shift 2 ;;
        --share) SHARE=$2; shift 2 ;;
        --frames) FRAMES_DIR=$2; shift 2 ;;
        -h|--help) sed -n '2,21p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "camrig build: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done
case "$COMPRESS" in none|gzip) ;; *) echo "camrig build: --compress none|gzip" >&2; exit 2 ;; esac
case "$SHARE" in none|9p) ;; *) echo "camrig build: --share none|9p" >&2; exit 2 ;; esac

die() { echo "camrig build: $*" >&2; exit 1; }
CACHE=.deps/camrig
OUT=$BUILD_DIR/camrig
PARLIGHT=$BUILD_DIR/parlight
HELPER=$BUILD_DIR/tests/vivid_ctl
if [ -n "$FRAMES_DIR" ]; then
    [ -d "$FRAMES_DIR" ] || die "--frames $FRAMES_DIR: not a directory"
    [ "$SHARE" = none ] || die "--frames works with --share none only"
    OUT=$BUILD_DIR/camrig-uvc
    HELPER=$BUILD_DIR/tools/uvc-gadget
    make -s BUILD="$BUILD_DIR" "$HELPER" >&2 || die "cannot build $HELPER"
fi
[ -x "$PARLIGHT" ] || die "$PARLIGHT not built (make BUILD=$BUILD_DIR all)"
[ -x "$HELPER" ] || die "$HELPER not built (make BUILD=$BUILD_DIR all)"
[ -f "$MODEL" ] || die "model $MODEL missing (make $MODEL)"
for tool in apt-get dpkg depmod modprobe cpio xz ldd; do
    command -v "$tool" >/dev/null 2>&1 || die "'$tool' not found (run tools/install-deps.sh)"
done

# ---- 1. kernel and busybox packages (downloaded once) --------------------------------------------
mkdir -p "$CACHE/debs"
# The cache is shared by every build directory: one builder at a time fills it.
exec 9>"$CACHE/.lock"
flock -w 600 9 || die "timed out waiting for $CACHE/.lock"
if ! ls "$CACHE"/debs/linux-image-*-amd64_*.deb >/dev/null 2>&1 ||
   ! ls "$CACHE"/debs/busybox-static_*.deb >/dev/null 2>&1; then
    kpkg=$(apt-cache depends linux-image-amd64 2>/dev/null | awk '/Depends: linux-image-[0-9]/ {print $2; exit}')
    [ -n "$kpkg" ] || die "cannot resolve linux-image-amd64 (apt-get update?)"
    echo "camrig build: downloading $kpkg busybox-static into $CACHE/debs" >&2
    (cd "$CACHE/debs" && apt-get download "$kpkg" busybox-static >/dev/null 2>&1) ||
        die "apt-get download $kpkg busybox-static failed"
fi
KDEB=$(ls "$CACHE"/debs/linux-image-*-amd64_*.deb | sort -V | tail -n 1)
BDEB=$(ls "$CACHE"/debs/busybox-static_*.deb | sort -V | tail -n 1)

# ---- 2. unpack, depmod, vmlinux ------------------------------------------------------------------
KROOT=$CACHE/kroot
if [ ! -f "$KROOT/.unpacked" ] || [ "$(cat "$KROOT/.unpacked")" != "$(basename "$KDEB")" ]; then
    rm -rf "$KROOT"
    mkdir -p "$KROOT"
    dpkg -x "$KDEB" "$KROOT"
    basename "$KDEB" >"$KROOT/.unpacked"
fi
KVER=$(ls "$KROOT/lib/modules" | head -n 1)
[ -n "$KVER" ] || die "no modules in $KDEB"
[ -f "$KROOT/lib/modules/$KVER/modules.dep" ] || depmod -b "$KROOT" "$KVER"

BBROOT=$CACHE/busybox
if [ ! -x "$BBROOT/bin/busybox" ]; then
    rm -rf "$BBROOT"
    mkdir -p "$BBROOT"
    dpkg -x "$BDEB" "$BBROOT"
fi

mkdir -p "$OUT"
# The guest decompressing its own bzImage costs ~2 s under TCG: hand QEMU the ELF inside instead
# (the kernel tree's scripts/extract-vmlinux, for the xz payload Debian uses).
VMLINUX=$OUT/vmlinux
BZ=$KROOT/boot/vmlinuz-$KVER
if [ ! -f "$VMLINUX" ] || [ "$BZ" -nt "$VMLINUX" ]; then
    ok=0
    for off in $(LC_ALL=C grep -obUaP '\xfd7zXZ\x00' "$BZ" | cut -d: -f1 | head -n 5); do
        tail -c +$((off + 1)) "$BZ" | xz -dc --single-stream >"$VMLINUX.tmp" 2>/dev/null || true
        if [ "$(head -c 4 "$VMLINUX.tmp" | od -An -tx1 | tr -d ' ')" = 7f454c46 ]; then
            mv "$VMLINUX.tmp" "$VMLINUX"
            ok=1
            break
        fi
    done
    rm -f "$VMLINUX.tmp"
    [ $ok = 1 ] || die "could not extract an ELF vmlinux from $BZ (not xz-compressed?)"
fi

flock -u 9

# ---- 3. initramfs --------------------------------------------------------------------------------
STAGE=$OUT/initramfs
rm -rf "$STAGE"
mkdir -p "$STAGE"/{bin,sbin,dev,proc,sys,tmp,run,lib/modules}
cp "$BBROOT/bin/busybox" "$STAGE/bin/busybox"
for applet in $("$STAGE/bin/busybox" --list); do
    [ -e "$STAGE/bin/$applet" ] || ln -s busybox "$STAGE/bin/$applet"
done

# vivid (and with --share 9p the 9p client over virtio-pci) and what they need, in load order, as
# insmod lines for /init.
MODS=vivid
[ "$SHARE" = 9p ] && MODS="virtio_pci 9pnet_virtio 9p vivid"
[ -n "$FRAMES_DIR" ] && MODS="dummy_hcd gadgetfs uvcvideo"
: >"$STAGE/modules.list"
for m in $MODS; do
    modprobe -d "$KROOT" -S "$KVER" --show-depends "$m" | while read -r kw path rest; do
        [ "$kw" = insmod ] || continue
        # the module's path in the guest (modprobe prints it absolute, whatever form -d had)
        rel=/lib/modules/${path#*/lib/modules/}
        mkdir -p "$STAGE$(dirname "$rel")"
        cp "$path" "$STAGE$rel"
        grep -qxF "$rel" "$STAGE/modules.list" || echo "$rel" >>"$STAGE/modules.list"
    done
done
[ -s "$STAGE/modules.list" ] || die "modprobe found no $MODS module in $KROOT"

# parlight, the rig's helper and every shared library they load (ldd), at their host paths, into
# the initramfs or the 9p share (PAYLOAD).
PAYLOAD=$STAGE
rm -rf "$OUT/share"
if [ "$SHARE" = 9p ]; then
    PAYLOAD=$OUT/share
    rm -rf "$PAYLOAD"
    echo 9p >"$STAGE/share.mode"
fi
mkdir -p "$PAYLOAD/opt/parlight"
cp "$PARLIGHT" "$PAYLOAD/opt/parlight/parlight"
# Plugins (libcamera, OpenCV: port/plugin.h) are loaded from beside the binary.
PLUGINS=()
for so in "$BUILD_DIR"/parlight-*.so; do [ -f "$so" ] && PLUGINS+=("$so"); done
[ ${#PLUGINS[@]} -eq 0 ] || cp "${PLUGINS[@]}" "$PAYLOAD/opt/parlight/"
if [ -n "$FRAMES_DIR" ]; then
    cp "$HELPER" "$PAYLOAD/opt/parlight/uvc-gadget"
    mkdir -p "$PAYLOAD/opt/parlight/frames" "$PAYLOAD/opt/parlight/expected"
    find "$FRAMES_DIR" -maxdepth 1 -type f ! -name '.*' -exec cp {} "$PAYLOAD/opt/parlight/frames/" \;
    "$HELPER" --expected "$PAYLOAD/opt/parlight/expected" "$PAYLOAD/opt/parlight/frames" ||
        die "uvc-gadget --expected failed on $FRAMES_DIR"
else
    cp "$HELPER" "$PAYLOAD/opt/parlight/vivid_ctl"
fi
for bin in "$PARLIGHT" "$HELPER" ${PLUGINS[@]+"${PLUGINS[@]}"}; do
    ldd "$bin" | awk '$2 == "=>" && $3 ~ /^\// {print $3} $1 ~ /^\// {print $1}'
done | sort -u | while read -r lib; do
    mkdir -p "$PAYLOAD$(dirname "$lib")"
    cp -L "$lib" "$PAYLOAD$lib"
    dirname "$lib" >>"$PAYLOAD/ldpath.tmp"
done
sort -u "$PAYLOAD/ldpath.tmp" | grep -v '^/lib64$' >"$PAYLOAD/ldpath"
rm -f "$PAYLOAD/ldpath.tmp"
[ -e "$PAYLOAD/lib64/ld-linux-x86-64.so.2" ] || die "dynamic loader not found by ldd"
cp "$MODEL" "$PAYLOAD/opt/parlight/model.plm"
if [ -n "$FRAMES_DIR" ]; then
    cp tools/camrig/init-uvc.sh "$STAGE/init"
else
    cp tools/camrig/init.sh "$STAGE/init"
fi
chmod 755 "$STAGE/init"

CPIO=$OUT/initramfs.cpio
rm -f "$CPIO" "$CPIO.gz"
(cd "$STAGE" && find . -print0 | LC_ALL=C sort -z | cpio -o -H newc -0 --quiet) >"$CPIO"
if [ "$COMPRESS" = gzip ]; then
    gzip -1 -n "$CPIO"
    CPIO=$CPIO.gz
fi
{
    echo "kernel $KVER"
    echo "vmlinux_bytes $(stat -c %s "$VMLINUX")"
    echo "initramfs_bytes $(stat -c %s "$CPIO") ($COMPRESS)"
    echo "staged_bytes $(du -sb "$STAGE" | cut -f1)"
    [ "$SHARE" = 9p ] && echo "share_bytes $(du -sb "$PAYLOAD" | cut -f1) (9p)"
    echo "libs $(find "$PAYLOAD/lib" "$PAYLOAD/usr" -name '*.so*' 2>/dev/null | wc -l)"
    echo "libs_bytes $(find "$PAYLOAD/lib" "$PAYLOAD/usr" -name '*.so*' -print0 2>/dev/null | du -cb --files0-from=- | tail -n 1 | cut -f1)"
    echo "model_bytes $(stat -c %s "$MODEL")"
} >"$OUT/sizes.txt"
rm -rf "$STAGE"
echo "$VMLINUX"
echo "$CPIO"
