# Sourced by the CLI tests (not a test itself: tests/run.sh runs test_*.sh only).
# The caller sets T (its scratch directory) before sourcing; EXPECT_TIMEOUT (seconds, default 120)
# bounds each command run by expect, so a hang fails the test instead of stalling the suite.
#   fail MSG...                    count a failure and go on
#   ok MSG...                      report a passing check
#   expect CODE PATTERN -- CMD...  run CMD: exit status CODE and stderr matching the extended
#                                  regex PATTERN ("" matches anything); stdout in $T/out,
#                                  stderr in $T/err
#   finish                         exit 0 if nothing failed, else 1 with the count
fails=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }
ok() { echo "ok   $*"; }
expect() {
    local code=$1 pat=$2
    shift 3
    timeout "${EXPECT_TIMEOUT:-120}" "$@" >"$T/out" 2>"$T/err"
    local rc=$?
    if [ $rc -ne "$code" ]; then
        fail "$* -> exit $rc, expected $code ($(head -c 600 "$T/err"))"
    elif [ -n "$pat" ] && ! grep -qE -- "$pat" "$T/err"; then
        fail "$* -> stderr '$(head -c 400 "$T/err")' lacks /$pat/"
    else
        ok "exit $rc: $*  $(tail -n 1 "$T/err" | head -c 160)"
    fi
}
finish() {
    [ "$fails" -eq 0 ] && { echo "all passed"; exit 0; }
    echo "$fails failure(s)"
    exit 1
}
