#!/usr/bin/env bash
# Decode bombs (issue 25): small files whose headers declare huge images, made at test time by
# tests/decode_bombs.py (a few KB each, never committed), run through the commands that read
# their format under an address-space cap (1 GiB, ulimit -v) and a time cap (20 s). Each must be
# refused with exit 1 and one message naming the file and the problem (the size, the limit and
# --max-pixels; not 2:1; the EXR header's fault) -- not "out of memory", which is what the
# readers said under the cap before they checked headers first. Legitimate files still work,
# --max-pixels lowers and raises the limit, and where /usr/bin/time exists a refusal's peak RSS
# stays under 200 MB (the model and OpenCV's libraries included; the bombs cost 1-3 GB before).
# needs: opencv openexr
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P=$BUILD/parlight
M=build/models/seeded-n3.plm
T=${PL_TEST_TMP:-/tmp}/decode_bombs
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: $M not built (make $M)"; exit 77; }
mkdir -p "$T"
/usr/bin/python3 tests/decode_bombs.py "$T" || { echo "FAIL: decode_bombs.py"; exit 1; }
CAP_KB=${PL_BOMB_CAP_KB:-1048576}
export MALLOC_ARENA_MAX=2 # glibc's per-thread arenas reserve 64 MB of address space each
TIME=
[ -x /usr/bin/time ] && TIME="/usr/bin/time -f %M -o $T/rss"
# make test SAN=1: ASan maps terabytes of shadow address space and keeps freed memory in
# quarantine, so neither the address-space cap nor the RSS bound means anything there; the
# refusals still run sanitized, and their exit statuses and messages are checked.
SAN=${PL_SAN:-0}
[ "$SAN" = 1 ] && TIME= && echo "SAN=1: no address-space cap, no RSS bound"
fail=0

# run CAP_KB WANT_EXIT "description" 'grep -E pattern for stderr' command...
run() {
    local cap=$1 want=$2 what=$3 pat=$4
    shift 4
    rm -f "$T/rss"
    [ "$SAN" = 1 ] && cap=unlimited
    (ulimit -v "$cap" && exec timeout 20 $TIME "$@") >"$T/out" 2>"$T/err"
    local rc=$? msg rss=""
    msg=$(grep -v '^Command exited' "$T/err" | head -c 300)
    [ -s "$T/rss" ] && rss=$(tail -n 1 "$T/rss")
    if [ $rc -ne "$want" ]; then
        echo "FAIL $what: exit $rc, expected $want: $msg"
        fail=1
    elif [ -n "$pat" ] && ! grep -qE -- "$pat" <<<"$msg"; then
        echo "FAIL $what: message does not match /$pat/: $msg"
        fail=1
    elif [ "$want" -ne 0 ] && [ -n "$rss" ] && [ "$rss" -gt 204800 ]; then
        echo "FAIL $what: refused, but peak RSS was $((rss / 1024)) MB"
        fail=1
    else
        echo "ok   $what (exit $rc${rss:+, peak RSS $((rss / 1024)) MB}) ${msg:0:160}"
    fi
}
LIMIT='over the limit of 67108864 pixels; --max-pixels N raises it'
NOT21='is not a 2:1 equirectangular panorama'

# Radiance RGBE: 98 KB 32768x8192 and 139 KB 23168x11584 (old-style runs, 12 bytes a row)
for cmd in "extract --hdr" "crop --batch 1 --out-dir $T/crops --hdr" "render --out $T/r.png --cubemap 8 --force --env"; do
    c=${cmd%% *}
    run $CAP_KB 1 "$c: RGBE 32768x8192 (not 2:1)" "rgbe_4to1.hdr: 32768 x 8192 $NOT21" $P $cmd "$T/rgbe_4to1.hdr"
    run $CAP_KB 1 "$c: RGBE 23168x11584" "rgbe_2to1.hdr: image size 23168x11584 .*$LIMIT" $P $cmd "$T/rgbe_2to1.hdr"
done
run $CAP_KB 1 "compare: RGBE 23168x11584" "rgbe_2to1.hdr: image size 23168x11584 .*$LIMIT" \
    $P compare "$T/rgbe_ok.hdr" "$T/rgbe_2to1.hdr"
run $CAP_KB 1 "estimate: an RGBE file as a frame" "rgbe_4to1.hdr: an HDR image .*not read as 8-bit" \
    $P estimate --model $M --input "$T/rgbe_4to1.hdr"

# OpenEXR: 15-byte headers, a huge data window, a 2:1 one over the limit
for cmd in "extract --hdr" "render --out $T/r.png --cubemap 8 --force --env"; do
    c=${cmd%% *}
    run $CAP_KB 1 "$c: EXR, 15 bytes, no channels" "exr_tiny.exr: OpenEXR header: 'channels' attribute not found" $P $cmd "$T/exr_tiny.exr"
    run $CAP_KB 1 "$c: EXR, 15 bytes, a 1.77 GB attribute" "exr_attr.exr: OpenEXR header: .*attribute 'a'" $P $cmd "$T/exr_attr.exr"
    run $CAP_KB 1 "$c: EXR 30000x15000" "exr_huge.exr: image size 30000x15000 has more than 268435456 pixels" $P $cmd "$T/exr_huge.exr"
    run $CAP_KB 1 "$c: EXR 16384x8192" "exr_2to1.exr: image size 16384x8192 .*$LIMIT" $P $cmd "$T/exr_2to1.exr"
done
run $CAP_KB 1 "extract --max-pixels 2^28: EXR 16384x8192 then refused for its chunk table" \
    "exr_2to1.exr: truncated: 16384 x 8192 in 8192 chunks needs a 65536-byte chunk table" \
    $P extract --max-pixels 268435456 --hdr "$T/exr_2to1.exr"

# TIFF through the OpenCV plugin: 9 KB 30000x30000, 4 KB 12000x12000
for cmd in "estimate --model $M --input" "bench --model $M --runs 1 --warmup 0 --input"; do
    c=${cmd%% *}
    run $CAP_KB 1 "$c: TIFF 30000x30000" "tiff_30k.tif: image size 30000x30000 has more than 268435456 pixels" $P $cmd "$T/tiff_30k.tif"
    run $CAP_KB 1 "$c: TIFF 12000x12000" "tiff_12k.tif: image size 12000x12000 .*$LIMIT" $P $cmd "$T/tiff_12k.tif"
done
run $CAP_KB 1 "estimate: Sun raster 9000x9000 (OpenCV's check, limit from ours)" \
    "ras_big.ras: the image's declared size is over the limit of 67108864 pixels" \
    $P estimate --model $M --input "$T/ras_big.ras"

# legitimate files, and the flag both ways
run $CAP_KB 0 "extract: a 2048x1024 RGBE panorama" "" $P extract --hdr "$T/rgbe_ok.hdr"
grep -q "1 light(s) kept" "$T/out" || { echo "FAIL extract of rgbe_ok.hdr: $(head -c 200 "$T/out")"; fail=1; }
run $CAP_KB 1 "extract --max-pixels 1000000: the same is refused" \
    "rgbe_ok.hdr: image size 2048x1024 \(2097152 pixels\) is over the limit of 1000000 pixels" \
    $P extract --max-pixels 1000000 --hdr "$T/rgbe_ok.hdr"
run $CAP_KB 0 "estimate: a 4096x3072 TIFF" "" $P estimate --model $M --input "$T/tiff_ok.tif"
run $CAP_KB 1 "estimate: a 9000x8000 TIFF over the default limit" "tiff_72m.tif: image size 9000x8000 .*$LIMIT" \
    $P estimate --model $M --input "$T/tiff_72m.tif"
run $((2 * CAP_KB)) 0 "estimate --max-pixels 72000000: the 9000x8000 TIFF is read" "" \
    $P estimate --max-pixels 72000000 --model $M --input "$T/tiff_72m.tif"
run $CAP_KB 2 "--max-pixels 0 is a usage error" "--max-pixels '0': expected an integer in 1..268435456" \
    $P extract --max-pixels 0 --hdr "$T/rgbe_ok.hdr"
exit $fail
