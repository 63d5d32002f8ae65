#!/usr/bin/env bash
# Decodes the CC0 panoramas of the npm package @pmndrs/assets (installed by tools/install-deps.sh
# into .deps/npm) into plain .exr files:
#
#   tools/pmndrs-hdri.sh OUTDIR            all 18 panoramas -> OUTDIR/<name>.exr
#   tools/pmndrs-hdri.sh --indoor          print the names of the indoor ones (one a line)
#   tools/pmndrs-hdri.sh --indoor OUTDIR   decode only the indoor ones
#
# Each hdri/<name>.exr.js is `export default 'data:application/exr;base64,<data>'`; the prefix and
# the closing quote are stripped and the rest goes through `base64 -d`. Idempotent: a file that is
# already there with the right content is left alone (compared with cmp). Exit 77 when the npm
# package is missing (so tests can skip), 1 on a decode error.
set -euo pipefail
cd "$(dirname "$0")/.."
PKG=.deps/npm/node_modules/@pmndrs/assets
HDRI=$PKG/hdri

# Indoor panoramas, classified by looking at each one (tonemapped previews of all 18, made with
# pl_tonemap_rgb8; the names match Poly Haven scenes listed in $PL_SHARED/data/hdri/MANIFEST.tsv).
# All are 512x256 half-float EXR.
#   apartment  living room (Poly Haven "lebombo"): window + two wall lamps
#   esplanade  hotel/mall interior ("royal_esplanade"): ceiling spots, blue cove lighting
#   hall       ballroom ("dancing_hall"): rows of ceiling light fixtures, curtained windows
#   lab        library/lab ("vintage_measuring_lab"): tall windows + wall lamps
#   lobby      public interior ("st_fagans_interior"): ceiling strip lights, windows
#   studio     photo studio: one softbox umbrella + one round ceiling light, dark walls
#   warehouse  empty warehouse ("empty_warehouse_01"): ceiling tube lights, windows
#   workshop   industrial workshop: ceiling lamps + skylights, open door
# Not indoor: bridge (enclosed glass bridge at night, "indoor-semi" in the manifest; left out),
# city, dawn, forest, night, park, sky, sunrise, sunset, venice (outdoor).
INDOOR=(apartment esplanade hall lab lobby studio warehouse workshop)

indoor_only=0
if [ "${1:-}" = "--indoor" ]; then indoor_only=1; shift; fi
if [ $# -eq 0 ] && [ $indoor_only -eq 1 ]; then printf '%s\n' "${INDOOR[@]}"; exit 0; fi
if [ $# -ne 1 ] || [ "${1:-}" = "--help" ]; then
    sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'
    [ "${1:-}" = "--help" ] && exit 0 || exit 2
fi
OUT=$1
if [ ! -d "$HDRI" ]; then
    echo "pmndrs-hdri: $HDRI not found (run tools/install-deps.sh)" >&2
    exit 77
fi
mkdir -p "$OUT"
if [ $indoor_only -eq 1 ]; then
    names=("${INDOOR[@]}")
else
    names=()
    for f in "$HDRI"/*.exr.js; do names+=("$(basename "$f" .exr.js)"); done
fi
for name in "${names[@]}"; do
    src=$HDRI/$name.exr.js
    [ -f "$src" ] || { echo "pmndrs-hdri: missing $src" >&2; exit 1; }
    tmp=$(mktemp "$OUT/.$name.XXXXXX")
    prefix="export default 'data:application/exr;base64,"
    if ! head -c ${#prefix} "$src" | cmp -s - <(printf '%s' "$prefix"); then
        rm -f "$tmp"; echo "pmndrs-hdri: $src does not start with the expected data URL" >&2; exit 1
    fi
    if ! tail -c +$((${#prefix} + 1)) "$src" | tr -d "'\n; " | base64 -d >"$tmp" 2>/dev/null; then
        rm -f "$tmp"; echo "pmndrs-hdri: $src: base64 decode failed" >&2; exit 1
    fi
    if [ -f "$OUT/$name.exr" ] && cmp -s "$tmp" "$OUT/$name.exr"; then
        rm -f "$tmp"
    else
        chmod 644 "$tmp" && mv -f "$tmp" "$OUT/$name.exr"
    fi
done
