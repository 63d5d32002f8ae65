#!/usr/bin/env bash
# Runs the whole suite: every compiled tests/test_*.c program and every tests/test_*.sh script.
# Exit status 0 = pass, 77 = skip (with a reason on its output), anything else = fail.
# Prints one line per test and closes with "N passed, M failed, K skipped"; exits 1 on any failure.
# Environment: BUILD (default build), PL_SHARED (default ../shared, beside the repo),
# TEST_FILTER (a grep pattern on test names).
set -u
cd "$(dirname "$0")/.."
export BUILD=${BUILD:-build}
export PL_SHARED=${PL_SHARED:-$(cd .. && pwd)/shared}
export PL_TEST_TMP=$(mktemp -d "${TMPDIR:-/tmp}/parlight-test.XXXXXX")
trap 'rm -rf "$PL_TEST_TMP"' EXIT

tests=()
for t in "$BUILD"/tests/test_*; do [ -x "$t" ] && tests+=("$t"); done
for t in tests/test_*.sh; do [ -f "$t" ] && tests+=("$t"); done

pass=0 fail=0 skip=0 failed=()
for t in "${tests[@]}"; do
    name=$(basename "$t")
    if [ -n "${TEST_FILTER:-}" ] && ! grep -qE "$TEST_FILTER" <<<"$name"; then continue; fi
    log="$PL_TEST_TMP/$name.log"
    start=$(date +%s%N)
    case "$t" in
        *.sh) timeout 900 bash "$t" >"$log" 2>&1 ;;
        *) timeout 900 "$t" >"$log" 2>&1 ;;
    esac
    rc=$?
    ms=$(( ($(date +%s%N) - start) / 1000000 ))
    secs="$((ms / 1000)).$(( (ms % 1000) / 100 ))"
    case $rc in
        0) pass=$((pass + 1)); echo "PASS  $name (${secs}s)" ;;
        77) skip=$((skip + 1)); echo "SKIP  $name: $(tail -n 1 "$log")" ;;
        *) fail=$((fail + 1)); failed+=("$name"); echo "FAIL  $name (exit $rc, ${secs}s)"
           sed 's/^/      /' "$log" | tail -n 40 ;;
    esac
done
echo
[ $fail -eq 0 ] || echo "failed: ${failed[*]}"
echo "$pass passed, $fail failed, $skip skipped"
[ $fail -eq 0 ] && [ $pass -gt 0 ]
