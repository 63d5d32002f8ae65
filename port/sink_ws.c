/* The ws:// sink (port/sink.h): a WebSocket server for browsers, with libwebsockets doing the
 * protocol (handshake, framing, pings, close) and this file doing what the tcp server does:
 * accepting (its own non-blocking listening socket, sink_server_open_tcp), admitting (max_clients,
 * token), queuing per client and dropping slow ones. No thread: every write and service call
 * runs lws_service with a negative timeout, which polls once without waiting. With a www_dir,
 * plain HTTP GETs on the same port are served from it by libwebsockets' file mount (the
 * viewer page, app/viewer). */
#include <errno.h>
#include <limits.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "core/util.h"
#include "port/sink_internal.h"

#ifdef PL_HAVE_LWS
#include <libwebsockets.h>

#define ACCEPTS_PER_CALL 64

enum ws_state {
    WS_HANDSHAKE, /* adopted, HTTP upgrade not done yet */
    WS_PENDING,   /* upgraded, waiting for its token: receives nothing */
    WS_ADMITTED,  /* receives every line */
    WS_REFUSING,  /* gets the refusal message and a close frame at its next writable */
    WS_GONE       /* closed or dropped by us: waiting for libwebsockets to free the wsi */
};

/* One adopted connection, from accept to the wsi's destruction (LWS_CALLBACK_WSI_DESTROY). Its
 * queue holds whole lines, buf[off .. off + len), each with its '\n'. */
typedef struct ws_client {
    struct ws_client *next, *prev;
    struct lws *wsi;
    enum ws_state state;
    uint64_t id;
    char peer[64];
    char *buf;
    size_t off, len;
    int64_t token_deadline_ns;
    size_t tok_len;
    int tok_too_long;
    char tok[PL_SINK_TOKEN_MAX + 2];
    char why[112]; /* refusal reason (a close reason is at most 123 bytes) */
} ws_client;

typedef struct sink_ws {
    struct lws_context *ctx;
    struct lws_vhost *vh;
    struct lws_protocols protocols[2];
    char path[PL_SINK_SPEC_MAX + 1];
    ws_client *head;
    int conns;              /* adopted connections not yet destroyed, any state */
    unsigned char *scratch; /* LWS_PRE + PL_SINK_QUEUE_BYTES: one message with lws's headroom */
    int closing;            /* pl_sink_close: each client gets its queue, then a close frame */
    char www[PATH_MAX];     /* www_dir, resolved ("" = no HTTP files) */
    struct lws_http_mount mount;
} sink_ws;

static void client_unlink(sink_ws *w, ws_client *c)
{
    if (c->prev)
        c->prev->next = c->next;
    else
        w->head = c->next;
    if (c->next) c->next->prev = c->prev;
    c->next = c->prev = NULL;
}

/* Leaves the admitted/pending set (stats.clients) and frees the queue. */
static void client_release(pl_sink *s, ws_client *c)
{
    if (c->state == WS_PENDING || c->state == WS_ADMITTED) s->stats.clients--;
    free(c->buf);
    c->buf = NULL;
    c->off = c->len = 0;
    c->state = WS_GONE;
}

/* Turns the client away: the refusal JSON as a text message and a close frame (1008) with the
 * reason, at its next writable; libwebsockets kills it after 2 s if it never reads. */
static void client_refuse(pl_sink *s, ws_client *c, const char *why)
{
    client_release(s, c);
    c->state = WS_REFUSING;
    snprintf(c->why, sizeof c->why, "%s", why);
    lws_set_timeout(c->wsi, PENDING_TIMEOUT_USER_OK, 2);
    lws_callback_on_writable(c->wsi);
}

/* A path as the client sent it, safe to log: printable ASCII, at most 48 bytes. */
static void printable(const char *in, char *out, size_t cap)
{
    size_t n = 0;
    for (; *in && n + 4 < cap && n < 48; in++)
        out[n++] = (*in >= 0x20 && *in < 0x7f && *in != '\'') ? *in : '?';
    if (*in && n + 4 < cap) {
        memcpy(out + n, "...", 3);
        n += 3;
    }
    out[n] = '\0';
}

static void token_message(pl_sink *s, ws_client *c, struct lws *wsi, const char *in, size_t len)
{
    if (c->tok_len + len > sizeof c->tok)
        c->tok_too_long = 1;
    else {
        memcpy(c->tok + c->tok_len, in, len);
        c->tok_len += len;
    }
    if (!lws_is_final_fragment(wsi) || lws_remaining_packet_payload(wsi) > 0) return;
    size_t n = c->tok_len;
    if (n > 0 && c->tok[n - 1] == '\n') n--;
    if (n > 0 && c->tok[n - 1] == '\r') n--;
    const char *why = c->tok_too_long                                            ? "token too long"
                      : !sink_same_secret(c->tok, n, s->token, strlen(s->token)) ? "wrong token"
                                                                                 : NULL;
    if (why) {
        sink_event(s, "client %llu (%s) refused: %s", (unsigned long long)c->id, c->peer, why);
        s->stats.unauthorized++;
        client_refuse(s, c, why);
        return;
    }
    c->state = WS_ADMITTED;
    sink_event(s, "client %llu (%s) gave the token", (unsigned long long)c->id, c->peer);
}

/* Sends queued lines while the socket takes them; one message per line, without its '\n'.
 * Returns -1 to have libwebsockets close the connection. */
static int client_writable(pl_sink *s, sink_ws *w, ws_client *c, struct lws *wsi)
{
    if (c->state == WS_REFUSING) {
        char msg[192];
        size_t n = sink_refusal_json(msg, sizeof msg, c->why);
        memcpy(w->scratch + LWS_PRE, msg, n);
        (void)lws_write(wsi, w->scratch + LWS_PRE, n, LWS_WRITE_TEXT);
        lws_close_reason(wsi, LWS_CLOSE_STATUS_POLICY_VIOLATION, (unsigned char *)c->why,
                         strlen(c->why));
        c->state = WS_GONE;
        return -1;
    }
    if (c->state != WS_ADMITTED && c->state != WS_PENDING) return 0;
    while (c->state == WS_ADMITTED && c->len > 0 && !lws_send_pipe_choked(wsi)) {
        const char *line = c->buf + c->off;
        const char *nl = memchr(line, '\n', c->len);
        size_t n = (size_t)(nl - line); /* the queue holds whole lines only */
        memcpy(w->scratch + LWS_PRE, line, n);
        int put = lws_write(wsi, w->scratch + LWS_PRE, n, LWS_WRITE_TEXT);
        if (put < (int)n) {
            sink_event(s, "client %llu (%s) disconnected: write failed", (unsigned long long)c->id,
                       c->peer);
            s->stats.disconnected++;
            client_release(s, c);
            return -1;
        }
        s->stats.bytes += n;
        c->off += n + 1;
        c->len -= n + 1;
    }
    if (c->len > 0 || lws_partial_buffered(wsi)) {
        lws_callback_on_writable(wsi);
        return 0;
    }
    c->off = 0;
    if (!w->closing) return 0;
    /* the end of the stream: a close frame, so that a browser sees a clean close (1001) */
    static const char bye[] = "parlight stopped";
    lws_close_reason(wsi, LWS_CLOSE_STATUS_GOINGAWAY, (unsigned char *)bye, sizeof bye - 1);
    client_release(s, c);
    return -1;
}

static int ws_callback(struct lws *wsi, enum lws_callback_reasons reason, void *user, void *in,
                       size_t len)
{
    struct lws_context *ctx = lws_get_context(wsi);
    pl_sink *s = ctx ? lws_context_user(ctx) : NULL;
    ws_client *c = lws_get_opaque_user_data(wsi);
    if (!s || !c) return lws_callback_http_dummy(wsi, reason, user, in, len);
    sink_ws *w = s->impl;
    switch (reason) {
    case LWS_CALLBACK_FILTER_PROTOCOL_CONNECTION: {
        char uri[256] = "", shown[64];
        if (lws_hdr_copy(wsi, uri, sizeof uri, WSI_TOKEN_GET_URI) < 0 || strcmp(uri, w->path)) {
            printable(uri, shown, sizeof shown);
            sink_event(s, "refused a client (%s): path '%s', this server serves '%s'", c->peer,
                       shown, w->path);
            s->stats.refused++;
            c->state = WS_GONE;
            return -1;
        }
        return 0;
    }
    case LWS_CALLBACK_ESTABLISHED:
        if (s->stats.clients >= s->max_clients) {
            char why[96];
            snprintf(why, sizeof why, "%d client%s already connected (--max-clients)",
                     s->max_clients, s->max_clients == 1 ? "" : "s");
            sink_event(s, "refused a client (%s): %s", c->peer, why);
            s->stats.refused++;
            client_refuse(s, c, why);
            return 0;
        }
        c->buf = malloc(PL_SINK_QUEUE_BYTES);
        if (!c->buf) {
            sink_event(s, "refused a client (%s): out of memory", c->peer);
            s->stats.refused++;
            client_refuse(s, c, "out of memory");
            return 0;
        }
        c->state = s->token[0] ? WS_PENDING : WS_ADMITTED;
        c->token_deadline_ns = pl_now_ns() + (int64_t)s->token_ms * 1000000;
        s->stats.clients++;
        s->stats.accepted++;
        sink_event(s, "client %llu connected (%s)%s", (unsigned long long)c->id, c->peer,
                   c->state == WS_PENDING ? ", waiting for its token" : "");
        return 0;
    case LWS_CALLBACK_RECEIVE:
        if (c->state == WS_PENDING) token_message(s, c, wsi, in, len);
        return 0; /* anything else a client sends is read and dropped: the stream is one-way */
    case LWS_CALLBACK_SERVER_WRITEABLE:
        return client_writable(s, w, c, wsi);
    case LWS_CALLBACK_CLOSED:
        if (c->state == WS_PENDING || c->state == WS_ADMITTED) {
            sink_event(s, "client %llu (%s) disconnected: connection closed",
                       (unsigned long long)c->id, c->peer);
            s->stats.disconnected++;
            client_release(s, c);
        }
        c->state = WS_GONE;
        return 0;
    case LWS_CALLBACK_WSI_DESTROY:
        client_release(s, c);
        client_unlink(w, c);
        lws_set_opaque_user_data(wsi, NULL);
        free(c);
        w->conns--;
        return 0;
    default:
        return lws_callback_http_dummy(wsi, reason, user, in, len);
    }
}

static void ws_accept(pl_sink *s, sink_ws *w)
{
    for (int k = 0; k < ACCEPTS_PER_CALL; k++) {
        struct sockaddr_storage ss;
        int fd = sink_accept(s, &ss);
        if (fd < 0) return;
        char peer[64];
        sink_format_addr(&ss, peer, sizeof peer);
        ws_client *c = NULL;
        const char *why = NULL;
        if (w->conns >= s->max_clients + PL_SINK_WS_HANDSHAKES)
            why = "too many connections at once (--max-clients and handshakes)";
        else if (!(c = calloc(1, sizeof *c)))
            why = "out of memory";
        if (why) {
            close(fd);
            s->stats.refused++;
            sink_event(s, "refused a client (%s): %s", peer, why);
            continue;
        }
        int sndbuf = PL_SINK_SOCKET_BUF, one = 1;
        (void)setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof sndbuf);
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        struct lws *wsi = lws_adopt_socket_vhost(w->vh, fd); /* closes fd on failure */
        if (!wsi) {
            free(c);
            s->stats.refused++;
            sink_event(s, "refused a client (%s): libwebsockets cannot take the connection", peer);
            continue;
        }
        c->wsi = wsi;
        c->state = WS_HANDSHAKE;
        c->id = s->next_client_id++;
        snprintf(c->peer, sizeof c->peer, "%s", peer);
        c->next = w->head;
        if (w->head) w->head->prev = c;
        w->head = c;
        w->conns++;
        lws_set_opaque_user_data(wsi, c);
    }
}

/* Accepts, runs one non-blocking lws_service (handshakes, tokens, client input, sends), turns
 * away clients whose token is late. */
static void ws_service_once(pl_sink *s, sink_ws *w)
{
    ws_accept(s, w);
    (void)lws_service(w->ctx, -1);
    const int64_t now = pl_now_ns();
    for (ws_client *c = w->head; c; c = c->next)
        if (c->state == WS_PENDING && now > c->token_deadline_ns) {
            char why[64];
            snprintf(why, sizeof why, "no token within %d ms", s->token_ms);
            sink_event(s, "client %llu (%s) refused: %s", (unsigned long long)c->id, c->peer, why);
            s->stats.unauthorized++;
            client_refuse(s, c, why);
        }
}

/* www_dir: resolved to an absolute path (the mount's origin) and checked to be a directory. */
static int www_init(pl_sink *s, sink_ws *w, const char *dir)
{
    struct stat st;
    if (!realpath(dir, w->www) || stat(w->www, &st) < 0)
        return pl_error(PL_E_ARG, "sink '%s': web directory %s: %s", s->spec, dir, strerror(errno));
    if (!S_ISDIR(st.st_mode)) {
        w->www[0] = '\0';
        return pl_error(PL_E_ARG, "sink '%s': web directory %s: not a directory", s->spec, dir);
    }
    w->mount.mountpoint = "/";
    w->mount.mountpoint_len = 1;
    w->mount.origin = w->www;
    w->mount.def = "index.html";
    w->mount.origin_protocol = LWSMPRO_FILE;
    return 0;
}

int sink_ws_open(pl_sink *s, const sink_spec *sp, const pl_sink_options *opts)
{
    int rc = sink_access_init(s, opts);
    if (rc < 0) return rc;
    sink_ws *w = calloc(1, sizeof *w);
    if (!w) return pl_error(PL_E_NOMEM, "sink '%s': out of memory", s->spec);
    s->impl = w;
    snprintf(w->path, sizeof w->path, "%s", sp->resource);
    if (opts && opts->www_dir && opts->www_dir[0] && (rc = www_init(s, w, opts->www_dir)) < 0)
        return rc;
    w->scratch = malloc(LWS_PRE + PL_SINK_QUEUE_BYTES);
    if (!w->scratch) return pl_error(PL_E_NOMEM, "sink '%s': out of memory", s->spec);
    rc = sink_server_open_tcp(s, sp);
    if (rc < 0) return rc;

    w->protocols[0].name = "parlight";
    w->protocols[0].callback = ws_callback;
    w->protocols[0].rx_buffer_size = PL_SINK_WS_RX;
    /* 0 would mean rx_buffer_size: every line over 512 bytes would leave in pieces, one per
     * writable callback, and a reader of ~1.4 KB lines fell behind and was dropped */
    w->protocols[0].tx_packet_size = PL_SINK_QUEUE_BYTES;
    lws_set_log_level(0, NULL); /* the library prints nothing; events say what happened */
    struct lws_context_creation_info info;
    memset(&info, 0, sizeof info);
    info.options = LWS_SERVER_OPTION_EXPLICIT_VHOSTS;
    info.port = CONTEXT_PORT_NO_LISTEN_SERVER; /* sockets come from ws_accept */
    info.protocols = w->protocols;
    info.gid = -1;
    info.uid = -1;
    info.user = s;
    info.timeout_secs = 5; /* for the HTTP upgrade */
    info.fd_limit_per_thread = (unsigned)(s->max_clients + PL_SINK_WS_HANDSHAKES + 16);
    if (w->www[0]) {
        info.mounts = &w->mount;
        /* a file goes out one chunk of this size per writable (one per service call): 4 KiB,
         * the default, took a second of frames to load three.js */
        info.pt_serv_buf_size = PL_SINK_WS_FILE_CHUNK;
    }
    w->ctx = lws_create_context(&info);
    if (w->ctx) w->vh = lws_create_vhost(w->ctx, &info);
    if (!w->ctx || !w->vh)
        return pl_error(PL_E_DEVICE, "sink '%s': libwebsockets could not start (%s)", s->spec,
                        w->ctx ? "vhost" : "context");
    return 0;
}

int sink_ws_write(pl_sink *s, const char *line, size_t len)
{
    sink_ws *w = s->impl;
    if (len > PL_SINK_QUEUE_BYTES) {
        s->stats.lines_failed++;
        return pl_error(PL_E_ARG, "sink '%s': line of %zu bytes exceeds the client queue (%d)",
                        s->spec, len, PL_SINK_QUEUE_BYTES);
    }
    ws_service_once(s, w);
    ws_client *next;
    for (ws_client *c = w->head; c; c = next) {
        next = c->next;
        if (c->state != WS_ADMITTED) continue;
        if (c->len + len > PL_SINK_QUEUE_BYTES) {
            sink_event(s, "client %llu (%s) dropped: a slow reader (%zu bytes queued, limit %d)",
                       (unsigned long long)c->id, c->peer, c->len, PL_SINK_QUEUE_BYTES);
            s->stats.dropped_slow++;
            client_release(s, c);
            lws_set_timeout(c->wsi, PENDING_TIMEOUT_USER_OK, LWS_TO_KILL_ASYNC);
            continue;
        }
        if (c->off + c->len + len > PL_SINK_QUEUE_BYTES) {
            memmove(c->buf, c->buf + c->off, c->len);
            c->off = 0;
        }
        memcpy(c->buf + c->off + c->len, line, len);
        c->len += len;
        lws_callback_on_writable(c->wsi);
    }
    (void)lws_service(w->ctx, -1);
    s->stats.lines++;
    return 0;
}

int sink_ws_service(pl_sink *s)
{
    sink_ws *w = s->impl;
    ws_service_once(s, w);
    int n = 0;
    for (ws_client *c = w->head; c; c = c->next)
        n += c->state == WS_ADMITTED;
    return n;
}

void sink_ws_close(pl_sink *s)
{
    sink_ws *w = s->impl;
    if (w && w->ctx) {
        /* what is queued, then a close frame, each client's close reply: at most
         * PL_SINK_CLOSE_MS; clients still in their HTTP handshake are not waited for */
        const int64_t deadline = pl_now_ns() + (int64_t)PL_SINK_CLOSE_MS * 1000000;
        w->closing = 1;
        for (ws_client *c = w->head; c; c = c->next)
            if (c->state == WS_ADMITTED || c->state == WS_PENDING) lws_callback_on_writable(c->wsi);
        for (;;) {
            int open = 0;
            for (ws_client *c = w->head; c; c = c->next)
                open |= c->state != WS_HANDSHAKE;
            if (!open || pl_now_ns() >= deadline) break;
            (void)lws_service(w->ctx, -1);
            struct timespec ts = {0, 1000000};
            nanosleep(&ts, NULL);
        }
        lws_context_destroy(w->ctx); /* closes every connection; WSI_DESTROY frees each client */
    }
    if (w) {
        while (w->head) { /* none left normally: only if libwebsockets skipped a destroy */
            ws_client *c = w->head;
            client_unlink(w, c);
            free(c->buf);
            free(c);
        }
        free(w->scratch);
        free(w);
    }
    s->impl = NULL;
    if (s->fd >= 0) close(s->fd);
    s->fd = -1;
}

#else /* no libwebsockets */

int sink_ws_open(pl_sink *s, const sink_spec *sp, const pl_sink_options *opts)
{
    (void)sp;
    (void)opts;
    return pl_error(PL_E_UNSUPPORTED,
                    "sink '%s': ws:// needs libwebsockets, which this build does not have "
                    "(tools/install-deps.sh installs libwebsockets-dev; then rebuild)",
                    s->spec);
}

int sink_ws_write(pl_sink *s, const char *line, size_t len)
{
    (void)line;
    (void)len;
    return pl_error(PL_E_UNSUPPORTED, "sink '%s': no libwebsockets in this build", s->spec);
}

int sink_ws_service(pl_sink *s)
{
    (void)s;
    return 0;
}

void sink_ws_close(pl_sink *s)
{
    (void)s;
}

#endif
