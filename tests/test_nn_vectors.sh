#!/usr/bin/env bash
# The int8 reference kernels against golden vectors, bit-exactly (build/tests/nn_vectors):
#  - always: our own cases in tests/data/nn-vectors (tools/make_nn_vectors.py: left shifts,
#    dilation with stride, odd channels, extremes), so the core suite exercises the runner;
#  - then the CMSIS-NN vectors in $PL_SHARED/data/cmsis-nn-vectors; exit 77 (skip) with a reason
#    when they are absent (after the local cases passed).
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
bin="$BUILD/tests/nn_vectors"
if [ ! -x "$bin" ]; then
    echo "$bin is not built (make BUILD=$BUILD tests)"
    exit 1
fi

echo "== tests/data/nn-vectors"
"$bin" tests/data/nn-vectors || exit 1

shared="${PL_SHARED:-$(cd .. && pwd)/shared}/data/cmsis-nn-vectors"
if [ ! -d "$shared" ]; then
    echo "local vectors passed; CMSIS-NN vectors not found at $shared (set PL_SHARED): skipped"
    exit 77
fi
echo "== $shared"
"$bin" "$shared" || exit 1
