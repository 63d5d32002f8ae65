#!/usr/bin/env bash
# Every fuzz target (tests/fuzz/fuzz_*.c) once on every input of its corpus,
# tests/fuzz/corpus/<target>/: the seeds and the regression inputs of crashes found by `make fuzz`
# (docs/TESTING.md). The targets are linked with tests/fuzz/replay.c instead of libFuzzer, so this
# runs with gcc in every build, and with ASan and UBSan under `make test SAN=1`. A target fails by
# crashing or aborting (a refusal without a message, an accepted input that breaks the reader's
# promises); a target without corpus fails too.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
fails=0 n=0
for src in tests/fuzz/fuzz_*.c; do
    t=$(basename "$src" .c)
    bin="$BUILD/tests/fuzz/$t" corpus="tests/fuzz/corpus/${t#fuzz_}"
    [ -x "$bin" ] || { echo "FAIL $t: $bin not built"; fails=$((fails + 1)); continue; }
    if out=$("$bin" "$corpus" 2>&1); then
        echo "ok   $t: $out"
        n=$((n + 1))
    else
        echo "FAIL $t (exit $?):"
        tail -n 30 <<<"$out" | sed 's/^/     /'
        fails=$((fails + 1))
    fi
done
[ $n -gt 0 ] || { echo "FAIL: no fuzz target found in tests/fuzz/"; exit 1; }
[ $fails -eq 0 ]
