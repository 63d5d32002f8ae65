#!/usr/bin/env bash
# Makes the live viewer's screenshots in docs/ (docs/VIEWER.md, README.md) by running
# tests/test_viewer.sh, which keeps what headless Chromium showed: docs/viewer.png (the sample
# frame lab-lamps.jpg, full engine-ready lighting) and docs/viewer-direct.png (the same with the
# directional light alone, its shadow at full contrast), plus the test's measured figures.
set -euo pipefail
cd "$(dirname "$0")/.."
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
PL_VIEWER_SHOTS="$out" tests/test_viewer.sh
/usr/bin/python3 - "$out" <<'PY'
import sys
from PIL import Image
d = sys.argv[1]
for src, dst in (("viewer.png", "docs/viewer.png"), ("direct.png", "docs/viewer-direct.png")):
    Image.open(f"{d}/{src}").convert("RGB").save(dst, optimize=True)
    print(f"wrote {dst}")
PY
cat "$out/figures.txt"
