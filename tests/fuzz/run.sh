#!/usr/bin/env bash
# Runs libFuzzer targets built by `make fuzz` (build/fuzz/fuzz_<target>), each FUZZ_SECONDS
# (default 60) from its seeds, FUZZ_JOBS of them at once (default: the number of cores; each
# libFuzzer process uses one), and prints one line per target, in the order given: executions,
# seconds, crashes, peak RSS. Usage: tests/fuzz/run.sh [TARGET...] (default: every
# tests/fuzz/fuzz_*.c).
#   seeds and regression inputs: tests/fuzz/corpus/<target>/   (read only: nothing is written
#                                                               into the tree)
#   inputs found while fuzzing:  build/fuzz/corpus/<target>/   (kept between runs)
#   crashes, leaks, timeouts:    build/fuzz/artifacts/<target>/  (crash-<sha1>, leak-..., ...)
#   libFuzzer's log:             build/fuzz/logs/<target>.log
# Limits per input: 10 s (-timeout), 2048 MB RSS (-rss_limit_mb). Exit 1 when any target found
# a crash (its log's tail is printed and the input is named: docs/TESTING.md says how to turn it
# into a regression input), 2 when a target is not built or FUZZ_JOBS is not a positive number.
set -u
cd "$(dirname "$0")/../.."
FUZZ_BUILD=${FUZZ_BUILD:-build/fuzz}
SECONDS_EACH=${FUZZ_SECONDS:-60}
JOBS=${FUZZ_JOBS:-$(nproc 2>/dev/null || echo 1)}
[[ $JOBS =~ ^[1-9][0-9]*$ ]] || { echo "fuzz: FUZZ_JOBS must be a positive integer, not '$JOBS'" >&2; exit 2; }
targets=("$@")
if [ ${#targets[@]} -eq 0 ]; then
    for f in tests/fuzz/fuzz_*.c; do t=${f#tests/fuzz/fuzz_}; targets+=("${t%.c}"); done
fi
for t in "${targets[@]}"; do
    [ -x "$FUZZ_BUILD/fuzz_$t" ] || { echo "fuzz: $FUZZ_BUILD/fuzz_$t not built (make fuzz builds it)" >&2; exit 2; }
done

# One target: its libFuzzer run, then its table row (and, when it failed, the log's tail and the
# inputs it left) into logs/<target>.row; the exit status says whether it failed.
run_one() {
    local t=$1 bin=$FUZZ_BUILD/fuzz_$1 seeds=tests/fuzz/corpus/$1 work=$FUZZ_BUILD/corpus/$1
    local art=$FUZZ_BUILD/artifacts/$1 log=$FUZZ_BUILD/logs/$1.log before start rc ms new
    local crashes execs rss
    before=$(ls "$art")
    start=$(date +%s%N)
    "$bin" -max_total_time="$SECONDS_EACH" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
        -artifact_prefix="$art/" "$work" "$seeds" >"$log" 2>&1
    rc=$?
    ms=$(( ($(date +%s%N) - start) / 1000000 ))
    new=$(comm -13 <(echo "$before") <(ls "$art") | grep . | sed "s|^|$art/|")
    crashes=$(grep -c . <<<"$new")
    [ $rc -ne 0 ] && [ "$crashes" -eq 0 ] && crashes=1 # died without writing an input
    execs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
    rss=$(sed -n 's/^stat::peak_rss_mb: *//p' "$log" | tail -n 1)
    {
        printf '%-12s %12s %9s %8s %7s MB %8s\n' "$t" "${execs:-?}" \
            "$((ms / 1000)).$(( (ms % 1000) / 100 ))" "$crashes" "${rss:-?}" "$(find "$work" -type f | wc -l)"
        if [ $rc -ne 0 ]; then
            sed 's/^/      /' "$log" | grep -v '^      #[0-9]' | tail -n 40
            echo "      input(s): ${new:-none written} (log: $log)"
        fi
    } >"$FUZZ_BUILD/logs/$t.row"
    return $((rc != 0))
}

declare -A pid_of
for t in "${targets[@]}"; do
    mkdir -p "$FUZZ_BUILD/corpus/$t" "$FUZZ_BUILD/artifacts/$t" "$FUZZ_BUILD/logs"
    rm -f "$FUZZ_BUILD/logs/$t.row"
    while [ "$(jobs -rp | wc -l)" -ge "$JOBS" ]; do wait -n; done
    run_one "$t" &
    pid_of[$t]=$!
done

printf '%-12s %12s %9s %8s %10s %8s\n' target executions seconds crashes 'peak RSS' corpus
failed=()
for t in "${targets[@]}"; do
    wait "${pid_of[$t]}" || failed+=("$t")
    cat "$FUZZ_BUILD/logs/$t.row" 2>/dev/null || { echo "$t: no result (the run died)"; failed+=("$t"); }
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "fuzz: crashes in ${failed[*]}: inputs under $FUZZ_BUILD/artifacts/ (docs/TESTING.md)"
    exit 1
fi
