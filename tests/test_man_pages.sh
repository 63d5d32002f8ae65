#!/usr/bin/env bash
# The man pages in docs/man/ (installed by make install):
#  - parlight.1 is what tools/gen-man.sh makes from this build's `parlight --help` and
#    `parlight COMMAND --help` (a changed help text needs `tools/gen-man.sh` and a commit);
#  - parlight.3 names every PL_API function of include/parlight.h and carries its version;
#  - both render with `man -l` without a troff warning.
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
T=$(mktemp -d "${PL_TEST_TMP:-/tmp}/man.XXXXXX")
trap 'rm -rf "$T"' EXIT
. tests/cli_helpers.sh

if [ -n "${PL_RUNNER:-}" ]; then
    ok "(under $PL_RUNNER: parlight.1 is compared by the host suite)"
elif tools/gen-man.sh "$BUILD" - >"$T/parlight.1" 2>"$T/err"; then
    cmp -s "$T/parlight.1" docs/man/parlight.1 && ok "docs/man/parlight.1 is the CLI's current help" ||
        fail "docs/man/parlight.1 is stale, run tools/gen-man.sh: $(diff docs/man/parlight.1 "$T/parlight.1" | head -c 600)"
else
    fail "tools/gen-man.sh: $(cat "$T/err")"
fi

version=$(sed -n 's/^#define PARLIGHT_VERSION "\(.*\)"/\1/p' include/parlight.h)
grep -q "^\.TH PARLIGHT 3 .*\"parlight $version\"" docs/man/parlight.3 &&
    ok "parlight.3 says parlight $version" || fail "parlight.3's .TH line does not say parlight $version"
missing=""
for f in $(sed -n 's/^PL_API [^(]*[ *]\(pl_[a-z0-9_]*\)(.*/\1/p' include/parlight.h); do
    grep -qw "$f" docs/man/parlight.3 || missing+=" $f"
done
[ -z "$missing" ] && ok "parlight.3 names every PL_API function" || fail "parlight.3 lacks:$missing"

if command -v man >/dev/null; then
    for p in docs/man/parlight.1 docs/man/parlight.3; do
        MANWIDTH=100 man --warnings -l "$p" >"$T/out" 2>"$T/err"
        if [ -s "$T/err" ] || ! grep -q "^NAME" "$T/out"; then
            fail "man -l $p: $(head -c 400 "$T/err")"
        else
            ok "man -l $p renders, $(wc -l <"$T/out") lines, no warning"
        fi
    done
else
    ok "(no man here: rendering not checked)"
fi
finish
