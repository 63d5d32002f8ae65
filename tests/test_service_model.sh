#!/usr/bin/env bash
# parlight estimate as a service (issue 25): the model is read whole at load, so truncating,
# overwriting or copying over its file while estimate runs changes nothing; SIGHUP after a rename
# puts the new model's outputs on the stream, and a bad replacement (truncated, or a FIFO) keeps
# the old one; files that must be regular (model, --hdr, --lights, compare's arguments) are
# refused at once when they are a FIFO, a device or a directory; SIGTERM at any moment of
# start-up exits cleanly and the unix: socket is gone.
# Timing: every wait is for something observable (a line of output, a message, the socket file)
# with a generous deadline, so a loaded machine makes it slower, not flaky.
set -u
P="$BUILD/parlight"
A=models/parlight-n3.plm
B=build/models/seeded-n3.plm
T="$PL_TEST_TMP/service_model"
mkdir -p "$T"
fail() {
    echo "FAIL: $*"
    [ -n "${pid:-}" ] && kill -KILL "$pid" 2>/dev/null
    exit 1
}
[ -f "$B" ] || fail "no $B (make test exports it)"
frame=$(ls tests/data/frames/*.jpg | head -n 1)

# The reference lighting of each model on the frame (smoothing is off for --input).
for m in A B; do
    timeout 120 "$P" estimate --model "${!m}" --input "$frame" >"$T/ref$m.jsonl" 2>"$T/err"
    rc=$?
    if [ $rc -ne 0 ] && grep -q "cannot decode JPEG" "$T/err"; then
        echo "skip: this build cannot decode $frame"
        exit 77
    fi
    [ $rc -eq 0 ] || fail "reference run with ${!m}: $(cat "$T/err")"
done

# labels FILE: the lines of FILE as A (model A's lighting), B, or ? (anything else), run-length
# coded: "A*5 B*3".
labels() {
    /usr/bin/python3 - "$T/refA.jsonl" "$T/refB.jsonl" "$1" <<'PY'
import json, sys
key = lambda d: json.dumps([d["lights"], d["ambient"]])
ref = {key(json.loads(open(sys.argv[i]).readline())): n for i, n in ((1, "A"), (2, "B"))}
out = []
for line in open(sys.argv[3]):
    if not line.endswith("\n"):
        break
    lab = ref.get(key(json.loads(line)), "?")
    if out and out[-1][0] == lab:
        out[-1][1] += 1
    else:
        out.append([lab, 1])
print(" ".join(f"{l}*{n}" for l, n in out))
PY
}
# (0 for a file the background estimate has not created yet: its redirection may come later)
lines() { if [ -f "$1" ]; then wc -l <"$1"; else echo 0; fi; }
# wait_lines FILE N: until FILE has N complete lines (at most 180 s; the process must live).
wait_lines() {
    local deadline=$((SECONDS + 180))
    while [ "$(lines "$1")" -lt "$2" ]; do
        kill -0 "$pid" 2>/dev/null || fail "estimate died waiting for line $2: $(cat "$T/svc.err")"
        [ $SECONDS -lt $deadline ] || fail "no line $2 in $1 after 180 s"
        sleep 0.05
    done
}
# wait_grep PATTERN FILE: until FILE has a line matching PATTERN (at most 180 s).
wait_grep() {
    local deadline=$((SECONDS + 180))
    until grep -q -e "$1" "$2"; do
        kill -0 "$pid" 2>/dev/null || fail "estimate died waiting for '$1': $(cat "$T/svc.err")"
        [ $SECONDS -lt $deadline ] || fail "no '$1' in $2 after 180 s: $(cat "$2")"
        sleep 0.05
    done
}

# A long-running estimate: 2000 copies of one frame, paced, served on a Unix socket as well.
mkdir -p "$T/frames"
for i in $(seq -w 1 2000); do ln -s "$PWD/$frame" "$T/frames/f$i.jpg"; done
cp "$A" "$T/m.plm"
sock="$T/s.sock"
"$P" estimate --model "$T/m.plm" --input "$T/frames" --fps-cap 10 --out stdout --out "unix:$sock" \
    >"$T/svc.jsonl" 2>"$T/svc.err" &
pid=$!
wait_lines "$T/svc.jsonl" 1

# --- the file changes under the running model: nothing happens ---
truncate -s 1000 "$T/m.plm"
n=$(lines "$T/svc.jsonl"); wait_lines "$T/svc.jsonl" $((n + 2))
cp "$A" "$T/m.plm"
head -c 200000 /dev/urandom | dd of="$T/m.plm" bs=4096 seek=100 conv=notrunc status=none
n=$(lines "$T/svc.jsonl"); wait_lines "$T/svc.jsonl" $((n + 2))
cp "$B" "$T/m.plm" # in place: the same inode, other bytes
n=$(lines "$T/svc.jsonl"); wait_lines "$T/svc.jsonl" $((n + 2))
got=$(labels "$T/svc.jsonl")
[[ $got =~ ^A\*[0-9]+$ ]] || fail "the model changed under estimate: $got; $(cat "$T/svc.err")"
echo "ok  truncate, overwrite and copy over the model file: $got, no crash"

# --- rename + SIGHUP: the new model's lighting from the next frame on ---
cp "$B" "$T/.m.plm.tmp" && mv "$T/.m.plm.tmp" "$T/m.plm"
kill -HUP $pid
wait_grep "SIGHUP: model reloaded from $T/m.plm" "$T/svc.err"
n=$(lines "$T/svc.jsonl"); wait_lines "$T/svc.jsonl" $((n + 2))
got=$(labels "$T/svc.jsonl")
[[ $got =~ ^A\*[0-9]+\ B\*[0-9]+$ ]] || fail "after rename + SIGHUP: $got"
echo "ok  rename + SIGHUP: $got"

# --- a bad replacement keeps the current model, with one line saying why ---
head -c 5000 "$A" >"$T/.m.plm.tmp" && mv "$T/.m.plm.tmp" "$T/m.plm"
kill -HUP $pid
wait_grep "SIGHUP: keeping the current model: $T/m.plm: header says" "$T/svc.err"
rm "$T/m.plm" && mkfifo "$T/m.plm"
kill -HUP $pid
wait_grep "SIGHUP: keeping the current model: $T/m.plm: is a FIFO, expected a regular file" "$T/svc.err"
n=$(lines "$T/svc.jsonl"); wait_lines "$T/svc.jsonl" $((n + 2))
got=$(labels "$T/svc.jsonl")
[[ $got =~ ^A\*[0-9]+\ B\*[0-9]+$ ]] || fail "after bad replacements: $got"
[ "$(grep -c 'keeping the current model' "$T/svc.err")" -eq 2 ] || fail "$(cat "$T/svc.err")"
echo "ok  a truncated file and a FIFO renamed in: old model kept ($got)"

[ -S "$sock" ] || fail "no socket $sock while serving"
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "SIGTERM: exit $rc: $(cat "$T/svc.err")"
[ ! -e "$sock" ] || fail "socket $sock left behind"
pid=
echo "ok  SIGTERM: exit 0, socket removed"

# --- files that must be regular: a FIFO, a device or a directory is refused at once ---
mkfifo "$T/f.plm" "$T/f.hdr" "$T/f.exr" "$T/f.json"
gt=$(ls tests/data/frames-gt/*.json | head -n 1)
# refused RC WHAT CMD...: exits RC (not 124: timeout) with "WHAT: is a ..., expected a regular file"
refused() {
    local want=$1 what=$2
    shift 2
    timeout 5 "$@" >/dev/null 2>"$T/err"
    local rc=$?
    [ $rc -ne 124 ] || fail "'$*' hangs on $what"
    [ $rc -eq "$want" ] || fail "'$*' exited $rc, expected $want: $(cat "$T/err")"
    grep -qE "$what: is a (FIFO|character device|directory), expected a regular file" "$T/err" ||
        fail "'$*': $(cat "$T/err")"
}
refused 1 "$T/f.plm" "$P" info --model "$T/f.plm"
refused 1 "$T/f.plm" "$P" estimate --model "$T/f.plm" --input "$frame"
refused 1 "$T/f.hdr" "$P" extract --hdr "$T/f.hdr" --json
refused 1 "$T/f.hdr" "$P" crop --hdr "$T/f.hdr" --yaw 0 --pitch 0 --fov 60 --out "$T/c.png"
refused 1 "$T/f.json" "$P" render --lights "$T/f.json" --out "$T/r.png"
refused 1 "$T/f.json" "$P" compare "$T/f.json" "$gt"
refused 1 "$T/f.exr" "$P" compare "$gt" "$T/f.exr"
refused 1 /dev/null "$P" info --model /dev/null
refused 1 "$T" "$P" info --model "$T"
refused 1 /dev/null "$P" render --lights /dev/null --out "$T/r.png"
echo "ok  FIFO, device and directory refused by name (model, --hdr, --lights, compare)"

# --- SIGTERM during start-up: exit 0 (143 only if it lands before main, with nothing made) ---
for d in 0 0.01 0.05; do
    rm -f "$sock"
    # a signal that lands before the child has opened 2> leaves the file as it
    # was: empty it here, or an earlier check's message reads as this one's
    : >"$T/err"
    "$P" estimate --model "$A" --input "$T/frames" --out "unix:$sock" >/dev/null 2>"$T/err" &
    pid=$!
    sleep $d
    kill -TERM $pid
    wait $pid
    rc=$?
    [ $rc -eq 0 ] || { [ $rc -eq 143 ] && [ ! -s "$T/err" ]; } ||
        fail "SIGTERM after ${d}s: exit $rc: $(cat "$T/err")"
    [ ! -e "$sock" ] || fail "SIGTERM after ${d}s: socket left behind"
    echo "ok  SIGTERM ${d}s after start: exit $rc, no socket"
done
# the moment the socket appears the model is loading: the signal must still be clean
"$P" estimate --model "$A" --input "$T/frames" --out "unix:$sock" >/dev/null 2>"$T/err" &
pid=$!
deadline=$((SECONDS + 60))
until [ -S "$sock" ]; do
    [ $SECONDS -lt $deadline ] || fail "no socket after 60 s: $(cat "$T/err")"
    sleep 0.005
done
kill -TERM $pid
wait $pid
rc=$?
[ $rc -eq 0 ] || fail "SIGTERM once the socket exists: exit $rc: $(cat "$T/err")"
[ ! -e "$sock" ] || fail "SIGTERM once the socket exists: socket left behind"
grep -q "stopped by a signal" "$T/err" || fail "$(cat "$T/err")"
echo "ok  SIGTERM as the socket appears (model loading): $(cat "$T/err")"
# an error at start removes the socket too
pid=
timeout 60 "$P" estimate --model "$T/f.plm" --input "$frame" --out "unix:$sock" >/dev/null 2>&1
[ $? -eq 1 ] && [ ! -e "$sock" ] || fail "bad model: socket left behind or wrong status"
timeout 60 "$P" estimate --model "$A" --input "$T/none" --out "unix:$sock" >/dev/null 2>&1
[ $? -eq 1 ] && [ ! -e "$sock" ] || fail "bad input: socket left behind or wrong status"
echo "ok  start-up errors exit 1 and remove the socket"
