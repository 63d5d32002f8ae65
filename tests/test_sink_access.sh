#!/usr/bin/env bash
# Who may read parlight estimate's stream (docs/OUTPUT.md, "Who can read the stream"), end to end:
# --max-clients (a reader over the cap is told why, then EOF), --token-file (a reader must send
# the token first; a wrong one is told so), --unix-mode (the socket file's bits, 600 by default),
# a connect storm that prints a few lines and a count instead of one line per connection, and
# the replay flags that serve readers: --loop and --wait-clients.
# Bad values of the three flags are usage errors naming the problem; a FIFO as --token-file is
# refused, not waited on.
# needs: opencv (tests/run.sh skips this test in a build without it)
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/sink_access
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/frames"
. "$(dirname "$0")/cli_helpers.sh"
frame=$(ls tests/data/frames/*.jpg | head -n 1)
# 400 frames (links to one file): the servers below run until they are stopped
for i in $(seq -w 1 400); do ln -s "$PWD/$frame" "$T/frames/f$i.jpg"; done
printf 'correct-horse-battery\n' >"$T/token"
chmod 600 "$T/token"
run=("$P" estimate --model "$M" --input "$frame")

# --- bad values ---
expect 2 "max-clients" -- "${run[@]}" --max-clients 0
expect 2 "max-clients" -- "${run[@]}" --max-clients 5000
expect 2 "unix-mode '999'" -- "${run[@]}" --unix-mode 999
expect 2 "owner's write bit" -- "${run[@]}" --unix-mode 400
expect 2 "token-file $T/missing: cannot open token file: No such file" -- "${run[@]}" --token-file "$T/missing"
expect 2 "frames: is a directory, expected a regular file" -- "${run[@]}" --token-file "$T/frames"
mkfifo "$T/fifo"
EXPECT_TIMEOUT=10 expect 2 "fifo: is a FIFO, expected a regular file" -- "${run[@]}" --token-file "$T/fifo"
cp "$T/token" "$T/open-token" && chmod 644 "$T/open-token"
expect 2 "readable by every user" -- "${run[@]}" --token-file "$T/open-token"
: >"$T/empty-token" && chmod 600 "$T/empty-token"
expect 2 "first line is empty" -- "${run[@]}" --token-file "$T/empty-token"

# --- unix: owner-only by default, --unix-mode 660 on request ---
for mode in default 660; do
    flags=()
    [ $mode = default ] || flags=(--unix-mode $mode)
    rm -f "$T/s.sock"
    "$P" estimate --model "$M" --input "$T/frames" --fps-cap 4 --out "unix:$T/s.sock" "${flags[@]}" \
        2>"$T/unix.err" &
    pid=$!
    for _ in $(seq 300); do [ -S "$T/s.sock" ] && break; sleep 0.1; done
    got=$(stat -c %a "$T/s.sock" 2>/dev/null)
    kill -TERM $pid
    wait $pid
    want=$([ $mode = default ] && echo 600 || echo 660)
    [ "$got" = "$want" ] && ok "unix socket mode $got ($mode)" || fail "unix socket mode $got, expected $want ($mode)"
done

# --- tcp: token and --max-clients 2 ---
"$P" estimate --model "$M" --input "$T/frames" --fps-cap 4 --out tcp://127.0.0.1:0 \
    --token-file "$T/token" --max-clients 2 >/dev/null 2>"$T/tcp.err" &
pid=$!
$PY - "$T/tcp.err" <<'PYEOF' || fail "the tcp checks (above)"
import json, re, socket, sys, time

def wait_port(path):
    for _ in range(600):
        m = re.search(r"listening on 127\.0\.0\.1:(\d+) \(readers send the token first\)", open(path).read())
        if m:
            return int(m.group(1))
        time.sleep(0.1)
    sys.exit(f"no 'listening on' line in {path}")

def line(s):
    buf = b""
    s.settimeout(60)
    while not buf.endswith(b"\n"):
        b = s.recv(1)
        if not b:
            break
        buf += b
    return buf.decode()

port = wait_port(sys.argv[1])
a = socket.create_connection(("127.0.0.1", port))
a.sendall(b"correct-horse-battery\n")
first = line(a)
assert first.startswith('{"frame":'), f"the reader with the token got {first!r}"
print("ok   a reader with the token receives JSON lines")
b = socket.create_connection(("127.0.0.1", port))
b.sendall(b"correct-horse-batterY\n")
got = line(b)
assert json.loads(got) == {"error": "refused", "reason": "wrong token"}, got
assert line(b) == "", "EOF after the refusal"
print("ok   a wrong token is told so, then EOF")
c = socket.create_connection(("127.0.0.1", port))  # holds the second slot, waiting for its token
time.sleep(0.5)
d = socket.create_connection(("127.0.0.1", port))
got = line(d)
assert json.loads(got) == {"error": "refused", "reason": "2 clients already connected (--max-clients)"}, got
print("ok   a reader over --max-clients 2 is told why")
assert line(a).startswith('{"frame":'), "the admitted reader still receives lines"
PYEOF
kill -TERM $pid
wait $pid
grep -q "client [0-9]* (127.0.0.1:[0-9]*) refused: wrong token" "$T/tcp.err" ||
    fail "no log line for the wrong token: $(cat "$T/tcp.err")"

# --- --loop: numbering goes on, the same file gives the same lights each pass ---
mkdir -p "$T/five" "$T/junk"
ls tests/data/frames/*.jpg | head -n 5 | while read -r f; do ln -s "$PWD/$f" "$T/five/"; done
echo "not an image" >"$T/junk/a.jpg"
expect 0 "" -- "$P" estimate --model "$M" --input "$T/five" --loop --n-frames 12
$PY - "$T/out" <<'PYEOF' && ok "--loop: 12 frames over 3 passes of 5, numbered 0..11" || fail "--loop output"
import json, sys
f = [json.loads(l) for l in open(sys.argv[1])]
assert [x["frame"] for x in f] == list(range(12)), [x["frame"] for x in f]
for k in range(7):
    assert f[k]["lights"] == f[k + 5]["lights"] and f[k]["source"] == f[k + 5]["source"], k
PYEOF
expect 1 "no usable frame in a whole pass" -- "$P" estimate --model "$M" --input "$T/junk" --loop
expect 2 "loop replays files" -- "$P" estimate --model "$M" --camera v4l2:/dev/video0 --loop
expect 2 "wait-clients needs a server" -- "${run[@]}" --wait-clients 1
expect 2 "wait-clients" -- "${run[@]}" --wait-clients 0 --out tcp://127.0.0.1:0

# --- --wait-clients 1: nothing is estimated before the reader, which then gets frame 0 on ---
"$P" estimate --model "$M" --input "$T/five" --out tcp://127.0.0.1:0 --wait-clients 1 \
    >/dev/null 2>"$T/wait.err" &
pid=$!
$PY - "$T/wait.err" <<'PYEOF' || fail "--wait-clients (above)"
import json, re, socket, sys, time
for _ in range(600):
    m = re.search(r"listening on 127\.0\.0\.1:(\d+)", open(sys.argv[1]).read())
    if m:
        break
    time.sleep(0.1)
else:
    sys.exit("no 'listening on' line")
time.sleep(1.5)
assert "waiting for 1 reader" in open(sys.argv[1]).read()
s = socket.create_connection(("127.0.0.1", int(m.group(1))))
frames = [json.loads(l)["frame"] for l in s.makefile("r")]
assert frames == [0, 1, 2, 3, 4], frames
print("ok   --wait-clients 1: the reader that came 1.5 s late got frames 0..4")
PYEOF
wait $pid || fail "--wait-clients run exited $?"
"$P" estimate --model "$M" --input "$T/five" --out tcp://127.0.0.1:0 --wait-clients 1 \
    >/dev/null 2>"$T/wait2.err" &
pid=$!
for _ in $(seq 300); do grep -q "waiting for 1 reader" "$T/wait2.err" && break; sleep 0.1; done
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 0 ] && grep -q "stopped by a signal after 0 frames" "$T/wait2.err" &&
    ok "SIGTERM while waiting for readers: exit 0" || fail "SIGTERM while waiting: exit $rc, $(cat "$T/wait2.err")"

# --- a connect storm: a few log lines and a count, not one line per connection ---
"$P" estimate --model "$M" --input "$T/frames" --fps-cap 10 --out tcp://127.0.0.1:0 \
    --max-clients 1 >/dev/null 2>"$T/storm.err" &
pid=$!
$PY - "$T/storm.err" <<'PYEOF' || fail "the connect storm"
import re, socket, sys, time
for _ in range(600):
    m = re.search(r"listening on 127\.0\.0\.1:(\d+)", open(sys.argv[1]).read())
    if m:
        break
    time.sleep(0.1)
else:
    sys.exit("no 'listening on' line")
port = int(m.group(1))
for _ in range(300):
    s = socket.create_connection(("127.0.0.1", port))
    s.close()
    time.sleep(0.005)
time.sleep(1)
PYEOF
kill -TERM $pid
wait $pid
n=$(grep -c "parlight estimate: tcp://127.0.0.1:0: " "$T/storm.err")
[ "$n" -le 30 ] && grep -q "more .*not shown" "$T/storm.err" &&
    ok "300 connections: $n event lines and a count ($(grep -m1 'not shown' "$T/storm.err"))" ||
    fail "connect storm: $n event lines: $(head -c 600 "$T/storm.err")"
finish
