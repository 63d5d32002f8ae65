#!/usr/bin/env bash
# Real indoor frames for int8 calibration and for the int8-vs-float check (docs/QUANT.md),
# as perspective LDR crops (`parlight crop --batch`) of indoor HDR panoramas:
#
#   tools/make-calib-frames.sh OUTDIR [PER_PANO]      (PER_PANO crops per panorama, default 4)
#
#   OUTDIR/calib/  from the CC0 pmndrs indoor panoramas (tools/pmndrs-hdri.sh) that are NOT in
#                  $PL_SHARED/data/hdri/eval (apartment = eval/lebombo and lobby =
#                  eval/st_fagans_interior are left out), plus every indoor panorama of
#                  $PL_SHARED/data/hdri/train when present (MANIFEST.tsv scene "indoor")
#   OUTDIR/check/  from $PL_SHARED/data/hdri/eval (indoor) when present, else from the two pmndrs
#                  panoramas left out above
# Calibration and check frames therefore come from different panoramas; eval/ is never used for
# calibration. Crops are 640x480 JPEG, N yaws 360/N apart at pitch 0, fov 60 (crop's batch
# mode), named <panorama>_yawNNN.jpg (pmndrs ones pmndrs-<name>_yawNNN.jpg); the ground-truth
# JSON files are not kept. Frames are not committed.
# Environment: BUILD (default build), PL_SHARED (default ../shared). Exit 77 when no panorama
# source exists at all.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
PL_SHARED=${PL_SHARED:-$(cd .. && pwd)/shared}
if [ $# -lt 1 ] || [ "${1:-}" = "--help" ]; then
    sed -n '2,20p' "$0" | sed 's/^# \{0,1\}//'
    [ "${1:-}" = "--help" ] && exit 0 || exit 2
fi
OUT=$1
PER=${2:-4}
P="$BUILD/parlight"
[ -x "$P" ] || { echo "make-calib-frames: $P not built (make BUILD=$BUILD)" >&2; exit 1; }
mkdir -p "$OUT/calib" "$OUT/check" "$OUT/.pano" "$OUT/.tmp"

# Frames written by this run: a second panorama whose crops would take the same names (pmndrs's
# "workshop" is train/workshop.hdr at half the size; a.hdr beside a.exr) must not silently replace
# the first one's, so the pmndrs frames carry a prefix and any remaining clash is an error.
declare -A made=()
crop() { # crop PANO DEST [PREFIX]: PER crops of PANO into DEST (images only)
    local pano=$1 dest=$2 prefix=${3:-} f name
    rm -rf "$OUT/.tmp"/*
    "$P" crop --hdr "$pano" --batch "$PER" --out-dir "$OUT/.tmp" --format jpg --force >/dev/null
    for f in "$OUT/.tmp"/*.jpg; do
        name=$prefix$(basename "$f")
        if [ -n "${made[$dest/$name]:-}" ]; then
            echo "make-calib-frames: $pano and ${made[$dest/$name]} both make $dest/$name" >&2
            exit 1
        fi
        made[$dest/$name]=$pano
        mv "$f" "$dest/$name"
    done
}

have_pm=0
if tools/pmndrs-hdri.sh --indoor "$OUT/.pano" 2>/dev/null; then have_pm=1; fi
have_shared=0
[ -d "$PL_SHARED/data/hdri/train" ] && [ -f "$PL_SHARED/data/hdri/MANIFEST.tsv" ] && have_shared=1
if [ $have_pm -eq 0 ] && [ $have_shared -eq 0 ]; then
    echo "make-calib-frames: neither the pmndrs panoramas nor $PL_SHARED/data/hdri exist" >&2
    exit 77
fi
n_cal=0 n_chk=0
if [ $have_pm -eq 1 ]; then
    for name in $(tools/pmndrs-hdri.sh --indoor); do
        case $name in
            apartment|lobby) # the same scenes as eval/lebombo and eval/st_fagans_interior
                [ $have_shared -eq 1 ] && continue
                crop "$OUT/.pano/$name.exr" "$OUT/check" pmndrs-; n_chk=$((n_chk + 1)) ;;
            *) crop "$OUT/.pano/$name.exr" "$OUT/calib" pmndrs-; n_cal=$((n_cal + 1)) ;;
        esac
    done
fi
if [ $have_shared -eq 1 ]; then
    while IFS=$'\t' read -r file scene _; do
        case $file in
            train/*) [ "$scene" = indoor ] || continue
                     crop "$PL_SHARED/data/hdri/$file" "$OUT/calib"; n_cal=$((n_cal + 1)) ;;
            eval/*) [ "$scene" = indoor ] || continue
                    crop "$PL_SHARED/data/hdri/$file" "$OUT/check"; n_chk=$((n_chk + 1)) ;;
        esac
    done < <(tail -n +2 "$PL_SHARED/data/hdri/MANIFEST.tsv")
fi
rm -rf "$OUT/.tmp" "$OUT/.pano"
echo "make-calib-frames: $OUT/calib: $(ls "$OUT/calib" | wc -l) frames from $n_cal panoramas;" \
     "$OUT/check: $(ls "$OUT/check" | wc -l) frames from $n_chk panoramas"
