#!/usr/bin/env bash
# parlight estimate --out mqtt://HOST:PORT/TOPIC against a real broker (docs/OUTPUT.md, "MQTT"):
# the test runs its own mosquitto (own config, 127.0.0.1, a free port; a system broker is never
# used) and reads with mosquitto_sub. Covers: no broker at start (the estimate keeps running and
# connects when the broker appears), lines in order, the retained message a late subscriber gets
# at once, a broker restart mid-stream (reconnects, lines resume; the time it takes is printed),
# QoS 1 with a user name and a password file (a wrong password is reported, not fatal), TLS with
# openssl-made certificates, and the usage errors. Every wait has a timeout.
# needs: mqtt libjpeg
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/sink_mqtt
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
for b in mosquitto mosquitto_sub mosquitto_passwd; do
    command -v $b >/dev/null || [ -x /usr/sbin/$b ] ||
        { echo "skip: no $b (tools/install-deps.sh installs mosquitto, mosquitto-clients)"; exit 77; }
done
MOSQUITTO=$(command -v mosquitto || echo /usr/sbin/mosquitto)
rm -rf "$T"
mkdir -p "$T/frames"
. "$(dirname "$0")/cli_helpers.sh"
frame=$(ls tests/data/frames/*.jpg | head -n 1)
for i in $(seq -w 1 400); do ln -s "$PWD/$frame" "$T/frames/f$i.jpg"; done
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; }
trap cleanup EXIT

free_port() { $PY -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }
# wait_for FILE REGEX SECONDS: 0 once FILE holds a line matching REGEX
wait_for() {
    local end=$((SECONDS + $3))
    while [ $SECONDS -lt "$end" ]; do grep -qE -- "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
    return 1
}
# mosquitto started as root drops to the user "mosquitto", which cannot read this test's files
ME="user $(id -un)"
# start_broker NAME CONF: runs mosquitto with CONF, sets BROKER_PID, waits until it listens
start_broker() {
    "$MOSQUITTO" -c "$2" >"$T/$1.log" 2>&1 &
    BROKER_PID=$!
    pids+=($BROKER_PID)
    wait_for "$T/$1.log" "Opening ipv4 listen socket|Error" 30 &&
        ! grep -q Error "$T/$1.log" || { fail "broker $1 did not start: $(cat "$T/$1.log")"; return 1; }
}
stop() { kill -TERM "$1" 2>/dev/null; wait "$1" 2>/dev/null; }
lines() { wc -l <"$1" 2>/dev/null || echo 0; }
# frames FILE: the frame numbers of mosquitto_sub's payload lines, space-separated
frames() { $PY -c 'import json,sys; print(" ".join(str(json.loads(l)["frame"]) for l in open(sys.argv[1]) if l.strip()))' "$1"; }
consecutive() { $PY -c 'import sys; f=[int(x) for x in sys.argv[1:]]; sys.exit(not f or f != list(range(f[0], f[0]+len(f))))' $1; }

PORT=$(free_port)
cat >"$T/broker.conf" <<EOF
$ME
listener $PORT 127.0.0.1
allow_anonymous true
persistence false
EOF
SPEC="mqtt://127.0.0.1:$PORT/parlight/test"

# --- usage errors ---
run=("$P" estimate --model "$M" --input "$frame")
expect 2 "missing the topic" -- "${run[@]}" --out "mqtt://127.0.0.1:$PORT"
expect 2 "missing the topic" -- "${run[@]}" --out "mqtt://127.0.0.1:$PORT/"
expect 2 "wildcard" -- "${run[@]}" --out "mqtt://127.0.0.1:$PORT/a/#"
expect 2 "port 0 out of range" -- "${run[@]}" --out "mqtt://127.0.0.1:0/t"
expect 2 "mqtt-qos" -- "${run[@]}" --mqtt-qos 2 --out "$SPEC"
expect 2 "needs --mqtt-user" -- "${run[@]}" --mqtt-password-file "$T/none" --out "$SPEC"
expect 2 "client id" -- "${run[@]}" --mqtt-id 'bad id' --out "$SPEC"
expect 1 "--mqtt-ca $T/missing.crt: No such file" -- "${run[@]}" --mqtt-ca "$T/missing.crt" --out "$SPEC"
expect 2 "need --mqtt-ca" -- "${run[@]}" --mqtt-cert "$T/a" --mqtt-key "$T/b" --out "$SPEC"

# --- no broker at start: the estimate runs on, and connects when the broker comes ---
"$P" estimate --model "$M" --input "$T/frames" --loop --fps-cap 10 --out "$SPEC" --out stdout \
    >"$T/est.out" 2>"$T/est.err" &
est=$!
pids+=($est)
wait_for "$T/est.err" "cannot connect to the broker at 127.0.0.1:$PORT: Connection refused" 60 ||
    fail "no 'cannot connect' message: $(cat "$T/est.err")"
n0=$(lines "$T/est.out")
wait_for "$T/est.out" "\"frame\":$((n0 + 5))," 60 &&
    ok "no broker: estimating goes on ($(lines "$T/est.out") frames on stdout, the MQTT lines dropped)" ||
    fail "the estimate stalled without a broker"
start_broker b1 "$T/broker.conf" || finish
wait_for "$T/est.err" "connected to the broker at 127.0.0.1:$PORT" 60 &&
    ok "connected once the broker came: $(grep -m1 'connected to the broker' "$T/est.err")" ||
    fail "did not connect to the broker: $(cat "$T/est.err")"

# --- lines in order; a late subscriber gets the retained message at once ---
timeout 60 mosquitto_sub -h 127.0.0.1 -p "$PORT" -t parlight/test -C 20 -W 50 >"$T/sub1" 2>&1
f=$(frames "$T/sub1")
consecutive "$f" && ok "20 messages, frames in order: ${f:0:60}..." || fail "messages out of order or missing: $f"
timeout 20 mosquitto_sub -h 127.0.0.1 -p "$PORT" -t parlight/test -C 1 -W 10 -F '%r %p' >"$T/sub2" 2>&1
grep -q '^1 {"frame":' "$T/sub2" && ok "a late subscriber's first message is the retained one" ||
    fail "no retained message: $(head -c 200 "$T/sub2")"

# --- broker restart mid-stream: lines dropped while it is away, then they resume ---
last=$(frames "$T/sub1" | awk '{print $NF}')
stop $BROKER_PID
wait_for "$T/est.err" "lost the broker at 127.0.0.1:$PORT" 60 &&
    ok "broker stopped: $(grep -m1 'lost the broker' "$T/est.err")" || fail "the loss was not reported: $(cat "$T/est.err")"
n1=$(lines "$T/est.out")
wait_for "$T/est.out" "\"frame\":$((n1 + 5))," 60 && ok "broker away: estimating goes on" ||
    fail "the estimate stalled while the broker was away"
start_broker b2 "$T/broker.conf" || finish
t0=$(date +%s%N)
wait_for "$T/est.err" "connected again to the broker" 60 &&
    ok "reconnected $(( ($(date +%s%N) - t0) / 1000000 )) ms after the broker was back: $(grep -m1 'connected again' "$T/est.err")" ||
    fail "no reconnection: $(cat "$T/est.err")"
timeout 60 mosquitto_sub -h 127.0.0.1 -p "$PORT" -t parlight/test -C 5 -W 50 >"$T/sub3" 2>&1
f=$(frames "$T/sub3")
first=${f%% *}
[ -n "$first" ] && [ "$first" -gt "$last" ] && consecutive "$f" &&
    ok "lines resume after the restart: $f (before: up to $last)" || fail "after the restart: '$f' (before: $last)"
stop $est
grep -q "stopped by a signal" "$T/est.err" && ok "SIGTERM: a clean stop" || fail "stop: $(tail -n 3 "$T/est.err")"
timeout 20 mosquitto_sub -h 127.0.0.1 -p "$PORT" -t parlight/test -C 1 -W 10 -F '%r %p' >"$T/sub4" 2>&1
grep -q '^1 {"frame":' "$T/sub4" && ok "after parlight exits the last lighting stays retained" ||
    fail "no retained message after exit: $(head -c 200 "$T/sub4")"
stop $BROKER_PID

# --- QoS 1, a user name and a password file ---
printf 'secret-pass\n' >"$T/pass" && chmod 600 "$T/pass"
printf 'wrong-pass\n' >"$T/wrong" && chmod 600 "$T/wrong"
mosquitto_passwd -b -c "$T/passwd" parlight secret-pass >/dev/null 2>&1
chmod 600 "$T/passwd" 2>/dev/null
cat >"$T/auth.conf" <<EOF
$ME
listener $PORT 127.0.0.1
allow_anonymous false
password_file $T/passwd
persistence false
EOF
start_broker b3 "$T/auth.conf" || finish
EXPECT_TIMEOUT=60 expect 0 "the broker refused the connection: Connection Refused: not authori[sz]ed" -- \
    "$P" estimate --model "$M" --input "$T/frames" --n-frames 10 --fps-cap 10 --out "$SPEC" \
    --mqtt-user parlight --mqtt-password-file "$T/wrong"
"$P" estimate --model "$M" --input "$T/frames" --loop --fps-cap 10 --out "$SPEC" --mqtt-qos 1 \
    --mqtt-user parlight --mqtt-password-file "$T/pass" --mqtt-id parlight-test >/dev/null 2>"$T/q1.err" &
est=$!
pids+=($est)
timeout 60 mosquitto_sub -h 127.0.0.1 -p "$PORT" -u parlight -P secret-pass -t parlight/test -q 1 \
    -C 5 -W 50 -F '%q %p' >"$T/sub5" 2>&1
[ "$(grep -c '^1 {"frame":' "$T/sub5")" -eq 5 ] && ok "QoS 1 with a user name and a password file" ||
    fail "QoS 1 login: $(head -c 300 "$T/sub5") / $(cat "$T/q1.err")"
stop $est
stop $BROKER_PID

# --- TLS: a CA and a broker certificate for localhost made here with openssl ---
if command -v openssl >/dev/null; then
    (cd "$T" &&
        openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=parlight-test-ca \
            -keyout ca.key -out ca.crt &&
        openssl req -newkey rsa:2048 -nodes -subj /CN=localhost -keyout server.key -out server.csr &&
        printf 'subjectAltName=DNS:localhost\n' >san.ext &&
        openssl x509 -req -in server.csr -CA ca.crt -CAkey ca.key -CAcreateserial -days 2 \
            -extfile san.ext -out server.crt) >"$T/openssl.log" 2>&1 || fail "openssl: $(tail -n 3 "$T/openssl.log")"
    cat >"$T/tls.conf" <<EOF
$ME
listener $PORT 127.0.0.1
allow_anonymous true
persistence false
cafile $T/ca.crt
certfile $T/server.crt
keyfile $T/server.key
EOF
    start_broker b4 "$T/tls.conf" || finish
    "$P" estimate --model "$M" --input "$T/frames" --loop --fps-cap 10 \
        --out "mqtt://localhost:$PORT/parlight/test" --mqtt-ca "$T/ca.crt" >/dev/null 2>"$T/tls.err" &
    est=$!
    pids+=($est)
    timeout 60 mosquitto_sub -h localhost -p "$PORT" --cafile "$T/ca.crt" -t parlight/test -C 3 -W 50 \
        >"$T/sub6" 2>&1
    consecutive "$(frames "$T/sub6" 2>/dev/null)" && ok "TLS: 3 frames through a verified connection" ||
        fail "TLS: $(head -c 300 "$T/sub6") / $(cat "$T/tls.err")"
    stop $est
    # the same broker with a CA that did not sign it: refused, reported, the estimate goes on
    (cd "$T" && openssl req -x509 -newkey rsa:2048 -nodes -days 2 -subj /CN=other-ca \
        -keyout other.key -out other.crt) >/dev/null 2>&1
    EXPECT_TIMEOUT=60 expect 0 "cannot connect to the broker" -- "$P" estimate --model "$M" \
        --input "$T/frames" --n-frames 10 --fps-cap 10 --out "mqtt://localhost:$PORT/parlight/test" \
        --mqtt-ca "$T/other.crt"
    stop $BROKER_PID
fi
finish
