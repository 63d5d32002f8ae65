/* Output sinks for the JSON-lines stream (`parlight estimate --out SPEC`, docs/OUTPUT.md
 * "Streaming"). One line = one JSON object followed by '\n'.
 *
 * Specs (parsed strictly; anything else is PL_E_ARG with a message naming the spec):
 *   stdout, -             standard output (the default)
 *   udp://HOST:PORT       one datagram per line sent to HOST:PORT (PORT 1..65535)
 *   tcp://HOST:PORT       a TCP server listening on HOST:PORT for any number of readers
 *                         (PORT 0..65535; 0 = a free port, see pl_sink_address)
 *   unix:PATH             a Unix stream-socket server at PATH (< 108 bytes)
 *   ws://HOST:PORT[/PATH] a WebSocket server (libwebsockets) on HOST:PORT for browsers; PATH
 *                         (default "/") is the only resource it upgrades; PORT 0..65535
 *   mqtt://HOST:PORT/TOPIC publishes each line to TOPIC on an MQTT broker (libmosquitto);
 *                         TOPIC: no '+' or '#', no control characters; PORT 1..65535
 * ws and mqtt are optional features of the build (`build/features`: ws, mqtt); without the
 * library, opening one is PL_E_UNSUPPORTED naming the package to install.
 * HOST is an IPv4 address (127.0.0.1), an IPv6 address in brackets ([::1]), or a host name
 * (letters, digits, '-', '.', '_'; resolved once at open, the first usable address is taken).
 * An empty HOST (tcp://:9000, udp://:5000) means 127.0.0.1: a server listens on loopback unless a
 * non-loopback address (0.0.0.0, [::], an interface's address) is written out.
 * Open failures: unresolvable host, address in use, bind/listen errors: PL_E_DEVICE naming the
 * spec and the system's reason. unix:PATH refuses to replace a file that is not a socket
 * (PL_E_IO); an existing socket is replaced only if nothing accepts on it (a stale one left by a
 * crash), else "address in use". The socket file is unlinked on close (if it is still ours).
 *
 * Writing never blocks the caller (except stdout, see below) and never raises SIGPIPE:
 *   - stream servers (tcp, unix) have no thread: each pl_sink_write first accepts pending
 *     clients (non-blocking listening socket, at most max_clients at once; an extra one is sent
 *     one line {"error":"refused","reason":"..."}, closed and counted), reads and discards what
 *     clients send (with a token: see pl_sink_options), then queues the
 *     line for every client and sends what each socket takes (MSG_DONTWAIT | MSG_NOSIGNAL).
 *     Each client has a queue of PL_SINK_QUEUE_BYTES (64 KiB) beyond the kernel's socket buffer
 *     (SO_SNDBUF set to PL_SINK_SOCKET_BUF); a client whose queue would overflow is dropped, as is
 *     one whose connection failed (reset, closed). So a client that connects and never reads is
 *     dropped after about PL_SINK_QUEUE_BYTES + 2 * PL_SINK_SOCKET_BUF + its receive buffer of
 *     backlog, while the others keep receiving every line. A client is accepted at the next
 *     write after it connects and receives whole lines from then on; a client that is dropped
 *     may read the start of one more line (what the kernel had already taken) before EOF, so a
 *     reader discards an unterminated last line.
 *   - ws: the same model as tcp, with libwebsockets doing the protocol on sockets this sink
 *     accepts itself (lws_service with a negative timeout: one poll that does not wait). Each
 *     line goes to every admitted client as one text message, without its '\n'. Per-client queue
 *     of PL_SINK_QUEUE_BYTES, slow clients dropped, max_clients and token as for tcp: the token
 *     is the client's first message (text or binary, a trailing "\n" or "\r\n" ignored). A
 *     refused client receives the refusal JSON as a text message, then a close frame with code
 *     1008 and the reason. At most max_clients + PL_SINK_WS_HANDSHAKES connections may be open
 *     at once counting those still in their HTTP handshake or being refused; one more is closed
 *     at accept. What clients send after the token is read and discarded (frames delivered in
 *     chunks of at most PL_SINK_WS_RX bytes; pings are answered by libwebsockets).
 *     Opening a ws sink makes the process ignore SIGPIPE (libwebsockets does this).
 *   - mqtt: libmosquitto without its thread: each write runs mosquitto_loop with a zero timeout.
 *     The connection is made in the background (mosquitto_connect_async) and made again after a
 *     loss, with a backoff from PL_SINK_MQTT_RETRY_MIN_MS doubling to PL_SINK_MQTT_RETRY_MAX_MS.
 *     Lines written while not connected (or when PL_SINK_MQTT_INFLIGHT messages are still
 *     unsent or unacknowledged) are dropped and counted in lines_dropped. Each line is one
 *     retained message (payload without the '\n'), QoS 0 or 1. HOST is resolved once at open
 *     (like udp); with TLS the host name itself is given to libmosquitto for the certificate
 *     check, so a name is resolved again at each connection.
 *   - udp: a non-blocking connected socket; a line that the socket cannot take right now
 *     (EAGAIN) or that nobody receives (ICMP refused) is dropped and counted; a line longer than
 *     PL_SINK_UDP_MAX bytes is an error for that line (counted; the sink stays usable).
 *   - stdout: blocking writes (a file or pipe chosen by the user, where losing lines would be
 *     wrong); a reader that went away gives PL_E_IO (EPIPE), not a SIGPIPE death (SIGPIPE is
 *     blocked in the calling thread around the write and a pending one is consumed).
 * Events (client connected, dropped as slow, disconnected, refused) are counted in
 * pl_sink_stats and queued as messages naming the sink for the caller to log
 * (pl_sink_next_event); the library prints nothing.
 *
 * A sink is used by one thread at a time. */
#ifndef PL_PORT_SINK_H
#define PL_PORT_SINK_H

#include <stddef.h>
#include <stdint.h>

#define PL_SINK_MAX_CLIENTS 16     /* readers at once per stream server by default */
#define PL_SINK_CLIENTS_LIMIT 1024 /* the most max_clients may be */
#define PL_SINK_TOKEN_MAX 256      /* longest token, bytes */
#define PL_SINK_TOKEN_MS 2000      /* how long a new client has to send the token */
#define PL_SINK_QUEUE_BYTES (64 * 1024)
#define PL_SINK_SOCKET_BUF (64 * 1024)
#define PL_SINK_UDP_MAX 65507 /* the largest UDP payload over IPv4 */
#define PL_SINK_SPEC_MAX 255  /* longest spec accepted */
#define PL_SINK_CLOSE_MS 250  /* how long pl_sink_close may spend flushing clients */
#define PL_SINK_EVENT_MAX 256 /* longest event message, with its NUL */
#define PL_SINK_WS_HANDSHAKES 16      /* ws connections beyond max_clients (handshake, refusal) */
#define PL_SINK_WS_RX 512             /* ws receive chunk, bytes */
#define PL_SINK_WS_FILE_CHUNK (64 * 1024) /* www_dir files: bytes sent per service call */
#define PL_SINK_MQTT_INFLIGHT 32      /* mqtt messages handed to libmosquitto, not yet sent/acked */
#define PL_SINK_MQTT_RETRY_MIN_MS 250 /* first wait before connecting again to the broker */
#define PL_SINK_MQTT_RETRY_MAX_MS 8000 /* longest wait between attempts */
#define PL_SINK_MQTT_KEEPALIVE_S 10    /* MQTT keepalive: a dead broker is noticed in ~1.5x */

typedef struct pl_sink pl_sink;

typedef struct pl_sink_stats {
    uint64_t lines;         /* lines accepted by pl_sink_write */
    uint64_t lines_failed;  /* lines rejected: too long for a datagram or the queue, or a
                               write error on stdout / udp */
    uint64_t lines_dropped; /* udp: lines the socket could not take or nobody received;
                               mqtt: lines while not connected or with too many in flight */
    uint64_t bytes;         /* bytes handed to the kernel (all clients) */
    int clients;            /* clients connected now (tcp, unix) */
    uint64_t accepted;      /* clients accepted since open */
    uint64_t dropped_slow;  /* clients dropped because their queue would overflow */
    uint64_t disconnected;  /* clients gone (closed, reset) */
    uint64_t refused;       /* connections closed at once: max_clients reached */
    uint64_t unauthorized;  /* clients closed for a wrong, missing or late token */
    uint64_t connects;      /* mqtt: connections to the broker accepted (CONNACK), first included */
} pl_sink_stats;

/* How stream servers (tcp, unix, ws) admit readers and how mqtt connects; each sink ignores what
 * is not its own. Zeroed = the defaults.
 *   max_clients  readers at once, 1..PL_SINK_CLIENTS_LIMIT (0: PL_SINK_MAX_CLIENTS). A client
 *                that finds every slot taken reads {"error":"refused","reason":"N clients
 *                already connected (--max-clients)"} and EOF. A client waiting for its token holds
 * a slot. unix_mode    permission bits of a unix: socket file, created with them (umask set around
 *                bind, so there is no moment with wider ones): 0 means 0600, owner only.
 *                Connecting needs write permission: 0660 lets the file's group read the stream.
 *   token        NULL or "": none. Else every new client must first send this token and '\n'
 *                (a trailing '\r' is ignored) within token_ms (0: PL_SINK_TOKEN_MS); until then
 *                it receives nothing. Wrong, too long or late: a refusal line and EOF.
 *                1..PL_SINK_TOKEN_MAX bytes, no control characters. The token crosses the
 *                network in clear: it keeps out whoever can reach the port but cannot read the
 *                traffic (docs/OUTPUT.md, "Who can read the stream").
 *   www_dir      ws only; NULL or "": none. A directory whose files the ws server also serves
 *                over plain HTTP GET on the same port (the live viewer, app/viewer): any path
 *                but the WebSocket's is a file under it ("/" is its index.html). Only files
 *                under the directory (libwebsockets refuses ".." and serves no listing), only
 *                known types (.html .js .css .png .jpg .json .svg ...: others 415), missing 404;
 *                symbolic links inside it are followed.
 *                Files go out a chunk per service call, so a page loads while the caller
 *                services the sink (pl_sink_service between frames, --wait-clients). Must be an
 *                existing directory at open (PL_E_ARG naming it otherwise). */
typedef struct pl_sink_options {
    int max_clients;
    unsigned unix_mode;
    const char *token;
    int token_ms;
    const char *www_dir;
    /* mqtt: strings are copied at open; NULL or "" = not set.
     *   mqtt_qos        0 (default) or 1
     *   mqtt_client_id  1..64 of [0-9A-Za-z_.-]; default "parlight-<pid>" (two clients with
     *                   one id take turns: the broker drops the older connection)
     *   mqtt_username   with mqtt_password (may be NULL): the broker's password login
     *   mqtt_ca_file    turns on TLS: the CA certificate(s) the broker's certificate must chain
     *                   to, and whose host name it must carry (mosquitto_tls_set)
     *   mqtt_cert_file, mqtt_key_file  a client certificate and its key (both or neither; TLS) */
    int mqtt_qos;
    const char *mqtt_client_id;
    const char *mqtt_username;
    const char *mqtt_password;
    const char *mqtt_ca_file;
    const char *mqtt_cert_file;
    const char *mqtt_key_file;
} pl_sink_options;

/* Opens the sink described by spec (see above) with the default options. *out owned by the
 * caller (pl_sink_close). */
int pl_sink_open(const char *spec, pl_sink **out);

/* The same with options (NULL: the defaults); bad options are PL_E_ARG naming the option. */
int pl_sink_open_opts(const char *spec, const pl_sink_options *opts, pl_sink **out);

/* Sends one line: len bytes, ending with '\n' and holding no other '\n' (PL_E_ARG otherwise).
 * Returns 0 when the line was accepted (even if some client was dropped, or no client is
 * connected), or a negative status for this line only (message names the sink); the sink stays
 * usable either way. */
int pl_sink_write(pl_sink *sink, const char *line, size_t len);

/* Accepts pending readers and reads what they sent (tokens), without writing a line: for a
 * caller waiting for readers before its first line. Returns the readers admitted now (connected
 * and past the token, if any); 0 for stdout and udp; mqtt: runs the client's network loop
 * (connects, keepalive) and returns 0. */
int pl_sink_service(pl_sink *sink);

/* Copies the oldest pending event message into msg (cap bytes, truncated, NUL-terminated) and
 * returns 1, or returns 0 when there is none. At most 32 are kept; older ones are lost and one
 * message says how many. */
int pl_sink_next_event(pl_sink *sink, char *msg, size_t cap);

void pl_sink_get_stats(const pl_sink *sink, pl_sink_stats *stats);

/* The spec as given at open. */
const char *pl_sink_spec(const pl_sink *sink);

/* Where the sink listens or sends: "127.0.0.1:40123", "[::1]:9000", the Unix path, "stdout".
 * Useful with port 0. */
const char *pl_sink_address(const pl_sink *sink);

/* Sends what is still queued to clients for at most PL_SINK_CLOSE_MS, closes every socket,
 * unlinks a Unix socket file, frees the sink. NULL is fine. */
void pl_sink_close(pl_sink *sink);

/* ---- several sinks (several --out) -------------------------------------------------------- */

#define PL_SINKS_MAX 8

typedef struct pl_sinks pl_sinks;

/* Opens every spec (n in 0..PL_SINKS_MAX; n == 0 means one "stdout" sink) with the same options
 * (NULL: the defaults), all or none: on a failure the ones already open are closed and the error
 * names the failing spec. The same spec twice is PL_E_ARG. */
int pl_sinks_open(const char *const *specs, int n, const pl_sink_options *opts, pl_sinks **out);

/* Writes the line to every sink. Returns 0, or the first sink's negative status (message names
 * it) after still writing to all the others. */
int pl_sinks_write(pl_sinks *sinks, const char *line, size_t len);

/* pl_sink_service on every sink: the readers admitted now, summed. */
int pl_sinks_service(pl_sinks *sinks);

/* Pending event of any sink, as pl_sink_next_event. */
int pl_sinks_next_event(pl_sinks *sinks, char *msg, size_t cap);

int pl_sinks_count(const pl_sinks *sinks);
/* The i-th sink (0-based, in spec order), or NULL. */
pl_sink *pl_sinks_get(pl_sinks *sinks, int i);

void pl_sinks_close(pl_sinks *sinks);

#endif
