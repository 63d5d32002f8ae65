#!/usr/bin/env bash
# The loader against broken copies of real model files (tests/plm_corrupt.c): the seeded fp32
# model that `make test` exports (build/models/seeded-n3.plm) and the shipped int8 one, whose
# first tensors are int8; and `parlight info` on the intact seeded model.
set -eu
model=build/models/seeded-n3.plm
[ -f "$model" ] || { echo "no $model: run 'make test' (it exports it)"; exit 1; }
"$BUILD"/tests/plm_corrupt "$model"
"$BUILD"/tests/plm_corrupt models/parlight-n3-int8.plm
out=$("$BUILD"/parlight info --model "$model")
echo "$out"
grep -q "lights (N)   3" <<<"$out"
grep -q "input        256 x 192" <<<"$out"
# a missing model and a non-model file: one clear line, exit 1
for bad in /nonexistent.plm tools/model.py; do
    set +e
    msg=$("$BUILD"/parlight info --model "$bad" 2>&1 >/dev/null)
    rc=$?
    set -e
    [ "$rc" -eq 1 ] || { echo "info --model $bad exited $rc"; exit 1; }
    [ "$(wc -l <<<"$msg")" -eq 1 ] || { echo "more than one line: $msg"; exit 1; }
    echo "refused $bad: $msg"
done
