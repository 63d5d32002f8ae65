#!/usr/bin/env bash
# The usage example in include/parlight.h is the body of tests/test_api_example.c (between its
# BEGIN/END markers), line for line after the comment prefix and indentation are stripped: so the
# header's example always compiles and runs (test_api_example does both).
set -u
cd "$(dirname "$0")/.."
norm() { sed -E 's/^[[:space:]]*\*?[[:space:]]*//; s/[[:space:]]+$//' | grep -v '^$'; }
hdr=$(sed -n '/Typical use/,/^ \* Errors:/p' include/parlight.h | sed '1,2d;$d' | norm)
ex=$(sed -n '/BEGIN header example/,/END header example/p' tests/test_api_example.c | sed '1d;$d' | norm)
[ -n "$hdr" ] || { echo "FAIL: no example found in include/parlight.h"; exit 1; }
if [ "$hdr" != "$ex" ]; then
    echo "FAIL: the example in include/parlight.h and tests/test_api_example.c differ:"
    diff <(echo "$hdr") <(echo "$ex")
    exit 1
fi
echo "ok  the header's example ($(echo "$hdr" | wc -l) lines) is tests/test_api_example.c's"
