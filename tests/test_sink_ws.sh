#!/usr/bin/env bash
# parlight estimate --out ws://HOST:PORT/PATH with real WebSocket clients (python3-websockets,
# what a browser does: docs/OUTPUT.md, "WebSocket"): one text message per frame, no newline, in
# order; a wrong path is refused at the handshake; --token-file (the token is the first message;
# a wrong or late one gets the refusal message and close 1008 with the reason); --max-clients
# (one more is told why the same way); --wait-clients with a ws reader; and the abuse run: while
# a good reader counts frames, a junk client sends binary, 1 MiB and invalid frames and pings,
# a reader that never reads is dropped as slow, and a connect storm (half-open TCP connections,
# handshakes closed at once) runs; the good reader must miss no frame. Prints its frames/s alone
# and during the abuse. Every wait has a timeout.
# needs: ws libjpeg
set -u
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
P="$BUILD/parlight"
M=build/models/seeded-n3.plm
PY=/usr/bin/python3
T=${PL_TEST_TMP:-$(mktemp -d)}/sink_ws
[ -x "$P" ] || { echo "skip: $P not built"; exit 77; }
[ -f "$M" ] || { echo "skip: no $M (make build/models/seeded-n3.plm)"; exit 77; }
$PY -c 'import websockets' 2>/dev/null ||
    { echo "skip: no python3-websockets (tools/install-deps.sh installs it)"; exit 77; }
rm -rf "$T"
mkdir -p "$T/frames"
. "$(dirname "$0")/cli_helpers.sh"
frame=$(ls tests/data/frames/*.jpg | head -n 1)
for i in $(seq -w 1 400); do ln -s "$PWD/$frame" "$T/frames/f$i.jpg"; done
printf 'correct-horse-battery\n' >"$T/token"
chmod 600 "$T/token"
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done; }
trap cleanup EXIT
stop() { kill -TERM "$1" 2>/dev/null; wait "$1"; }

# The Python side: helpers, then the check named by argv[2].
cat >"$T/ws.py" <<'PYEOF'
import asyncio, json, re, socket, sys, time
import websockets

def port_of(err_path):
    for _ in range(1200):
        m = re.search(r"listening on 127\.0\.0\.1:(\d+)", open(err_path).read())
        if m:
            return int(m.group(1))
        time.sleep(0.1)
    sys.exit(f"no 'listening on' line in {err_path}")

ERR, CHECK = sys.argv[1], sys.argv[2]
PORT = port_of(ERR)
URL = f"ws://127.0.0.1:{PORT}/lights"

def connect(path="/lights"):
    return websockets.connect(f"ws://127.0.0.1:{PORT}{path}", open_timeout=30, close_timeout=5,
                              max_size=1 << 20, ping_interval=None)

async def refused(ws):
    """The refusal message and the close frame: (json, code, reason)."""
    msg = await asyncio.wait_for(ws.recv(), 30)
    try:
        await asyncio.wait_for(ws.recv(), 30)
        raise AssertionError("no close after the refusal")
    except websockets.ConnectionClosed as e:
        return json.loads(msg), e.code, e.reason

async def frames(ws, n):
    out = []
    for _ in range(n):
        m = await asyncio.wait_for(ws.recv(), 60)
        assert isinstance(m, str) and not m.endswith("\n"), repr(m[-20:])
        out.append(json.loads(m)["frame"])
    return out

def consecutive(f):
    return f == list(range(f[0], f[0] + len(f)))

async def basic():
    async with connect() as ws:
        f = await frames(ws, 10)
    assert consecutive(f), f
    print(f"ok   10 text messages, one JSON object each, no newline, frames in order {f[0]}..{f[-1]}")
    try:
        async with connect("/other"):
            raise AssertionError("a wrong path was upgraded")
    except (websockets.InvalidHandshake, websockets.InvalidMessage, OSError, EOFError):
        print("ok   a wrong path is refused at the handshake")

async def access():
    async with connect() as a:                       # the token first, then frames
        await a.send("correct-horse-battery\n")
        f = await frames(a, 3)
        print(f"ok   a reader with the token receives frames {f}")
        async with connect() as b:
            await b.send("correct-horse-batterY")
            r = await refused(b)
            assert r == ({"error": "refused", "reason": "wrong token"}, 1008, "wrong token"), r
            print(f"ok   a wrong token: {r}")
        async with connect() as c:                   # says nothing: turned away after 2 s
            t0 = time.monotonic()
            r = await refused(c)
            assert r == ({"error": "refused", "reason": "no token within 2000 ms"}, 1008,
                         "no token within 2000 ms"), r
            print(f"ok   no token: refused after {time.monotonic() - t0:.1f} s: {r[2]}")
        async with connect() as d:                   # holds the second slot
            await d.send(b"correct-horse-battery")   # binary works too
            await frames(d, 1)
            async with connect() as e:
                r = await refused(e)
                why = "2 clients already connected (--max-clients)"
                assert r == ({"error": "refused", "reason": why}, 1008, why), r
                print(f"ok   a third reader over --max-clients 2: {r[2]}")
        f = await frames(a, 3)
        print(f"ok   the first reader still receives frames {f}")

async def junk_client(stop):
    n = 0
    try:
        async with connect() as ws:  # reads nothing itself: in time it is dropped as slow too
            while not stop.is_set():
                await ws.send(b"\x00\xff" * 1000)          # binary
                await ws.send("x" * (1 << 20))             # a 1 MiB text frame
                await ws.send(b"\xc3\x28")                  # invalid UTF-8 as binary
                await ws.ping(str(n).encode())
                await ws.send(["frag", "ments"])            # a fragmented message
                n += 5
                await asyncio.sleep(0.01)
    except websockets.ConnectionClosed:
        pass
    return n

def never_reads():
    s = socket.socket()
    s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    s.connect(("127.0.0.1", PORT))
    s.sendall(b"GET /lights HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
              b"Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n")
    return s

async def storm(stop):
    n, held = 0, []
    while not stop.is_set():
        for _ in range(20):                           # connect and close at once
            try:
                socket.create_connection(("127.0.0.1", PORT), timeout=5).close()
                n += 1
            except OSError:
                pass
        if len(held) < 60:                            # half-open: never send a handshake
            try:
                held.append(socket.create_connection(("127.0.0.1", PORT), timeout=5))
            except OSError:
                pass
        try:                                          # handshakes closed at once
            async with connect():
                n += 1
        except Exception:
            pass
        await asyncio.sleep(0.05)
    for s in held:
        s.close()
    return n + len(held)

async def abuse():
    async with connect() as good:
        await frames(good, 2)
        t0 = time.monotonic()
        f = await frames(good, 40)
        alone = len(f) / (time.monotonic() - t0)
        assert consecutive(f), f
        print(f"ok   one reader alone: {alone:.1f} frames/s")
        stop = asyncio.Event()
        before = open(ERR).read().count(" connected (")
        slow = never_reads()                            # admitted before the storm starts
        f += await frames(good, 2)
        for _ in range(600):
            if open(ERR).read().count(" connected (") > before:
                break
            await asyncio.sleep(0.1)
        else:
            raise AssertionError("the reader that never reads was not admitted")
        jt = asyncio.create_task(junk_client(stop))
        st = asyncio.create_task(storm(stop))
        t0 = time.monotonic()
        got = await frames(good, 300)  # the never-reading one's ~200 KB fill up meanwhile
        busy = len(got) / (time.monotonic() - t0)
        stop.set()
        sent = await jt
        storms = await st
        assert consecutive(f + got), "the good reader missed frames"
        print(f"ok   during the abuse ({sent} junk messages and pings, {storms} storm connections): "
              f"{busy:.1f} frames/s, {len(got)} frames, none missed")
        # dropped: what the kernel holds, then EOF; a reader still served would get more and more
        slow.settimeout(30)
        total, eof, end = 0, False, time.monotonic() + 30
        while not eof and total < 4 << 20 and time.monotonic() < end:
            b = slow.recv(65536)
            eof = not b
            total += len(b)
        slow.close()
        assert eof, f"the reader that never read was not dropped ({total} bytes, no EOF)"
        print(f"ok   the reader that never read was dropped (it could still read {total} bytes, then EOF)")
        f = await frames(good, 5)
        assert consecutive(f), f
        print("ok   after the abuse the good reader still receives frames")

async def wait_clients():
    time.sleep(1.5)
    assert "waiting for 1 reader" in open(ERR).read()
    async with connect() as ws:
        f = await frames(ws, 5)
    assert f == [0, 1, 2, 3, 4], f
    print("ok   --wait-clients 1 with a ws reader: frames 0..4")

async def main():
    # the storm's clients leave futures whose errors nobody reads: not this test's business
    asyncio.get_running_loop().set_exception_handler(lambda loop, ctx: None)
    await globals()[CHECK]()

asyncio.run(main())
PYEOF

run_check() { # NAME CHECK ARGS...: a parlight server and one Python check against it
    local name=$1 check=$2
    shift 2
    "$P" estimate --model "$M" --input "$T/frames" --loop "$@" >/dev/null 2>"$T/$name.err" &
    local pid=$!
    pids+=($pid)
    timeout 400 $PY "$T/ws.py" "$T/$name.err" "$check" || fail "$name (above; stderr: $(tail -n 5 "$T/$name.err"))"
    stop $pid || fail "$name: parlight exited $?"
}

# --- bad specs and flags ---
run=("$P" estimate --model "$M" --input "$frame")
expect 2 "missing ':PORT'" -- "${run[@]}" --out ws://127.0.0.1
expect 2 "is not a number" -- "${run[@]}" --out ws://::1:9000/
expect 2 "may not hold '\?' or '#'" -- "${run[@]}" --out "ws://127.0.0.1:9000/a?b"
expect 2 "max-clients" -- "${run[@]}" --out ws://127.0.0.1:0 --max-clients 0

run_check basic basic --fps-cap 20 --out ws://127.0.0.1:0/lights
run_check access access --fps-cap 10 --out ws://127.0.0.1:0/lights --token-file "$T/token" --max-clients 2
t0=$SECONDS
run_check abuse abuse --out ws://127.0.0.1:0/lights --max-clients 8
secs=$((SECONDS - t0))
# the app shows at most 5 lines of each kind (connected, disconnected, refused, ...) per 10 s
n=$(grep -c "parlight estimate: ws://127.0.0.1:0/lights: " "$T/abuse.err")
[ "$n" -le $((20 * (secs / 10 + 1))) ] && ok "the abuse run logged $n event lines in $secs s, the rest counted" ||
    fail "the abuse run logged $n event lines in $secs s"
"$P" estimate --model "$M" --input "$T/frames" --n-frames 5 --out ws://127.0.0.1:0/lights \
    --wait-clients 1 >/dev/null 2>"$T/wait.err" &
pid=$!
pids+=($pid)
timeout 120 $PY "$T/ws.py" "$T/wait.err" wait_clients || fail "--wait-clients (above)"
wait $pid || fail "--wait-clients run exited $?"
finish
