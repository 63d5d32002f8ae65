/* TCP and Unix stream-socket servers for the JSON-lines stream (port/sink.h): no thread; every
 * write accepts pending clients, reads their token or discards what they send, queues the line
 * per admitted client and sends what each socket takes, without blocking. */
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "core/util.h"
#include "port/sink_internal.h"

#define ACCEPTS_PER_WRITE 64
#define READ_CHUNKS_PER_WRITE 8

static void client_drop(pl_sink *s, sink_client *c)
{
    close(c->fd);
    c->fd = -1;
    free(c->buf);
    c->buf = NULL;
    c->off = c->len = 0;
    c->read_closed = 0;
    c->pending = 0;
    c->tok_len = 0;
    s->stats.clients--;
}

size_t sink_refusal_json(char *out, size_t cap, const char *reason)
{
    int n = snprintf(out, cap, "{\"error\":\"refused\",\"reason\":\"%s\"}\n", reason);
    if (n <= 0) {
        if (cap) out[0] = '\0';
        return 0;
    }
    size_t len = (size_t)n < cap ? (size_t)n : cap - 1;
    return len > 0 && out[len - 1] == '\n' ? len - 1 : len;
}

/* One JSON line telling a client why it is turned away, {"error":"refused","reason":"..."} (a
 * JSON-lines reader parses it like a frame), sent if the socket takes it now: it is closed right
 * after, so nothing waits for a slow reader. Reasons are parlight's own text, without quotes. */
static void tell_refused(int fd, const char *reason)
{
    char msg[160];
    size_t n = sink_refusal_json(msg, sizeof msg, reason);
    if (n > 0) (void)send(fd, msg, msg[n] == '\n' ? n + 1 : n, MSG_DONTWAIT | MSG_NOSIGNAL);
}

static void client_unauthorized(pl_sink *s, sink_client *c, const char *why)
{
    tell_refused(c->fd, why);
    sink_event(s, "client %llu (%s) refused: %s", (unsigned long long)c->id, c->peer, why);
    s->stats.unauthorized++;
    client_drop(s, c);
}

int sink_same_secret(const char *a, size_t na, const char *b, size_t nb)
{
    unsigned char d = (unsigned char)(na != nb);
    for (size_t i = 0; i < PL_SINK_TOKEN_MAX; i++) {
        unsigned char x = i < na ? (unsigned char)a[i] : 0, y = i < nb ? (unsigned char)b[i] : 0;
        d |= (unsigned char)(x ^ y);
    }
    return d == 0;
}

int sink_access_init(pl_sink *s, const pl_sink_options *o)
{
    static const pl_sink_options defaults = {0};
    if (!o) o = &defaults;
    s->max_clients = o->max_clients ? o->max_clients : PL_SINK_MAX_CLIENTS;
    if (s->max_clients < 1 || s->max_clients > PL_SINK_CLIENTS_LIMIT)
        return pl_error(PL_E_ARG, "sink '%s': max clients %d: expected 1..%d", s->spec,
                        o->max_clients, PL_SINK_CLIENTS_LIMIT);
    s->unix_mode = o->unix_mode ? o->unix_mode : 0600;
    if (s->unix_mode & ~0777u)
        return pl_error(PL_E_ARG, "sink '%s': socket mode %o: expected permission bits (0..0777)",
                        s->spec, s->unix_mode);
    s->token_ms = o->token_ms ? o->token_ms : PL_SINK_TOKEN_MS;
    if (s->token_ms < 1 || s->token_ms > 600000)
        return pl_error(PL_E_ARG, "sink '%s': token wait %d ms: expected 1..600000", s->spec,
                        o->token_ms);
    if (o->token && o->token[0]) {
        size_t n = strlen(o->token);
        if (n > PL_SINK_TOKEN_MAX)
            return pl_error(PL_E_ARG, "sink '%s': the token has %zu bytes, at most %d", s->spec, n,
                            PL_SINK_TOKEN_MAX);
        for (size_t i = 0; i < n; i++)
            if ((unsigned char)o->token[i] < 0x20 || o->token[i] == 0x7f)
                return pl_error(PL_E_ARG, "sink '%s': the token holds a control character",
                                s->spec);
        memcpy(s->token, o->token, n + 1);
    }
    return 0;
}

int sink_server_init(pl_sink *s, const pl_sink_options *o)
{
    int rc = sink_access_init(s, o);
    if (rc < 0) return rc;
    s->clients = calloc((size_t)s->max_clients, sizeof *s->clients);
    s->pf = calloc((size_t)s->max_clients, sizeof *s->pf);
    s->pf_idx = calloc((size_t)s->max_clients, sizeof *s->pf_idx);
    if (!s->clients || !s->pf || !s->pf_idx)
        return pl_error(PL_E_NOMEM, "sink '%s': out of memory for %d clients", s->spec,
                        s->max_clients);
    for (int i = 0; i < s->max_clients; i++)
        s->clients[i].fd = -1;
    return 0;
}

static void client_gone(pl_sink *s, sink_client *c, const char *why)
{
    sink_event(s, "client %llu (%s) disconnected: %s", (unsigned long long)c->id, c->peer, why);
    s->stats.disconnected++;
    client_drop(s, c);
}

/* Sends what the socket takes now; drops the client on a hard error. Returns 0 if it is still
 * connected. */
static int client_flush(pl_sink *s, sink_client *c)
{
    while (c->len > 0) {
        ssize_t n = send(c->fd, c->buf + c->off, c->len, MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n > 0) {
            c->off += (size_t)n;
            c->len -= (size_t)n;
            s->stats.bytes += (uint64_t)n;
            continue;
        }
        if (n < 0 && errno == EINTR) continue;
        if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK)) break;
        client_gone(s, c, n < 0 ? strerror(errno) : "send returned 0");
        return -1;
    }
    if (c->len == 0) c->off = 0;
    return 0;
}

int sink_accept(pl_sink *s, struct sockaddr_storage *ss)
{
    for (;;) {
        socklen_t sl = sizeof *ss;
        int fd = accept4(s->fd, (struct sockaddr *)ss, &sl, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd >= 0) {
            s->last_accept_errno = 0;
            return fd;
        }
        int err = errno;
        if (err == EINTR || err == ECONNABORTED || err == EPROTO) continue;
        if (err == EAGAIN || err == EWOULDBLOCK) {
            s->last_accept_errno = 0;
            return -1;
        }
        if (err != s->last_accept_errno) sink_event(s, "cannot accept a client: %s", strerror(err));
        s->last_accept_errno = err;
        return -1;
    }
}

static void accept_pending(pl_sink *s)
{
    for (int k = 0; k < ACCEPTS_PER_WRITE; k++) {
        struct sockaddr_storage ss;
        int fd = sink_accept(s, &ss);
        if (fd < 0) return;
        sink_client *c = NULL;
        for (int i = 0; i < s->max_clients && !c; i++)
            if (s->clients[i].fd < 0) c = &s->clients[i];
        char peer[64];
        if (s->kind == SINK_TCP)
            sink_format_addr(&ss, peer, sizeof peer);
        else
            snprintf(peer, sizeof peer, "unix");
        char *buf = c ? malloc(PL_SINK_QUEUE_BYTES) : NULL;
        if (!buf) {
            char why[96];
            if (c)
                snprintf(why, sizeof why, "out of memory");
            else
                snprintf(why, sizeof why, "%d client%s already connected (--max-clients)",
                         s->max_clients, s->max_clients == 1 ? "" : "s");
            tell_refused(fd, why);
            close(fd);
            s->stats.refused++;
            sink_event(s, "refused a client (%s): %s", peer, why);
            continue;
        }
        int sndbuf = PL_SINK_SOCKET_BUF, one = 1;
        (void)setsockopt(fd, SOL_SOCKET, SO_SNDBUF, &sndbuf, sizeof sndbuf);
        if (s->kind == SINK_TCP) (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        c->fd = fd;
        c->id = s->next_client_id++;
        snprintf(c->peer, sizeof c->peer, "%s", peer);
        c->buf = buf;
        c->off = c->len = 0;
        c->read_closed = 0;
        c->pending = s->token[0] != '\0';
        c->tok_len = 0;
        c->token_deadline_ns = pl_now_ns() + (int64_t)s->token_ms * 1000000;
        s->stats.clients++;
        s->stats.accepted++;
        sink_event(s, "client %llu connected (%s)%s", (unsigned long long)c->id, c->peer,
                   c->pending ? ", waiting for its token" : "");
    }
}

/* A waiting client's bytes: the token line, or a refusal. */
static void read_token(pl_sink *s, sink_client *c)
{
    const size_t cap = sizeof c->tok;
    ssize_t got = recv(c->fd, c->tok + c->tok_len, cap - c->tok_len, MSG_DONTWAIT);
    if (got < 0) {
        if (errno != EINTR && errno != EAGAIN && errno != EWOULDBLOCK)
            client_gone(s, c, strerror(errno));
        return;
    }
    if (got == 0) {
        client_gone(s, c, "closed before sending its token");
        return;
    }
    c->tok_len += (size_t)got;
    char *nl = memchr(c->tok, '\n', c->tok_len);
    if (!nl) {
        if (c->tok_len == cap) client_unauthorized(s, c, "token line too long");
        return;
    }
    size_t n = (size_t)(nl - c->tok);
    if (n > 0 && c->tok[n - 1] == '\r') n--;
    if (!sink_same_secret(c->tok, n, s->token, strlen(s->token))) {
        client_unauthorized(s, c, "wrong token");
        return;
    }
    c->pending = 0; /* what followed the token line is discarded like any client input */
    sink_event(s, "client %llu (%s) gave the token", (unsigned long long)c->id, c->peer);
}

/* Reads waiting clients' tokens, discards what admitted clients send (the stream is one-way),
 * notices closed connections and turns away clients whose token is late. */
static void service_clients(pl_sink *s)
{
    struct pollfd *pf = s->pf;
    int *idx = s->pf_idx, n = 0;
    const int64_t now = pl_now_ns();
    for (int i = 0; i < s->max_clients; i++) {
        sink_client *c = &s->clients[i];
        if (c->fd >= 0 && c->pending && now > c->token_deadline_ns) {
            char why[64];
            snprintf(why, sizeof why, "no token within %d ms", s->token_ms);
            client_unauthorized(s, c, why);
        }
    }
    for (int i = 0; i < s->max_clients; i++) {
        if (s->clients[i].fd < 0) continue;
        pf[n].fd = s->clients[i].fd;
        pf[n].events = s->clients[i].read_closed ? 0 : POLLIN;
        pf[n].revents = 0;
        idx[n++] = i;
    }
    if (n == 0) return;
    int r;
    do
        r = poll(pf, (nfds_t)n, 0);
    while (r < 0 && errno == EINTR);
    if (r <= 0) return;
    for (int k = 0; k < n; k++) {
        sink_client *c = &s->clients[idx[k]];
        short re = pf[k].revents;
        if (re & (POLLERR | POLLNVAL)) {
            int err = 0;
            socklen_t el = sizeof err;
            getsockopt(c->fd, SOL_SOCKET, SO_ERROR, &err, &el);
            client_gone(s, c, err ? strerror(err) : "socket error");
            continue;
        }
        if (re & POLLHUP) {
            client_gone(s, c, "connection closed");
            continue;
        }
        if (!(re & POLLIN)) continue;
        if (c->pending) {
            read_token(s, c);
            continue;
        }
        char scratch[4096];
        for (int j = 0; j < READ_CHUNKS_PER_WRITE; j++) {
            ssize_t got = recv(c->fd, scratch, sizeof scratch, MSG_DONTWAIT);
            if (got > 0) continue;
            if (got == 0) {
                c->read_closed = 1; /* half-closed: it may still read; send will tell */
                break;
            }
            if (errno == EINTR) continue;
            if (errno != EAGAIN && errno != EWOULDBLOCK) client_gone(s, c, strerror(errno));
            break;
        }
    }
}

int sink_server_write(pl_sink *s, const char *line, size_t len)
{
    if (len > PL_SINK_QUEUE_BYTES) {
        s->stats.lines_failed++;
        return pl_error(PL_E_ARG, "sink '%s': line of %zu bytes exceeds the client queue (%d)",
                        s->spec, len, PL_SINK_QUEUE_BYTES);
    }
    accept_pending(s);
    service_clients(s);
    for (int i = 0; i < s->max_clients; i++) {
        sink_client *c = &s->clients[i];
        if (c->fd < 0 || c->pending || client_flush(s, c) < 0) continue;
        if (c->len + len > PL_SINK_QUEUE_BYTES) {
            sink_event(s, "client %llu (%s) dropped: a slow reader (%zu bytes queued, limit %d)",
                       (unsigned long long)c->id, c->peer, c->len, PL_SINK_QUEUE_BYTES);
            s->stats.dropped_slow++;
            client_drop(s, c);
            continue;
        }
        if (c->off + c->len + len > PL_SINK_QUEUE_BYTES) {
            memmove(c->buf, c->buf + c->off, c->len);
            c->off = 0;
        }
        memcpy(c->buf + c->off + c->len, line, len);
        c->len += len;
        client_flush(s, c);
    }
    s->stats.lines++;
    return 0;
}

int sink_server_service(pl_sink *s)
{
    accept_pending(s);
    service_clients(s);
    int n = 0;
    for (int i = 0; i < s->max_clients; i++)
        n += s->clients[i].fd >= 0 && !s->clients[i].pending;
    return n;
}

int sink_server_open_tcp(pl_sink *s, const sink_spec *sp)
{
    struct addrinfo *res = NULL;
    int rc = sink_resolve(s->spec, sp, SOCK_STREAM, &res);
    if (rc < 0) return rc;
    int err = 0;
    char where[96] = "";
    for (struct addrinfo *ai = res; ai; ai = ai->ai_next) {
        sink_format_addr(ai->ai_addr, where, sizeof where);
        int fd =
            socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd < 0) {
            err = errno;
            continue;
        }
        int one = 1;
        (void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
        if (bind(fd, ai->ai_addr, ai->ai_addrlen) < 0 || listen(fd, 16) < 0) {
            err = errno;
            close(fd);
            continue;
        }
        struct sockaddr_storage ss;
        socklen_t sl = sizeof ss;
        if (getsockname(fd, (struct sockaddr *)&ss, &sl) == 0)
            sink_format_addr(&ss, s->address, sizeof s->address);
        else
            snprintf(s->address, sizeof s->address, "%s", where);
        s->fd = fd;
        break;
    }
    freeaddrinfo(res);
    if (s->fd < 0)
        return pl_error(PL_E_DEVICE, "sink '%s': cannot listen on %s: %s", s->spec, where,
                        err ? strerror(err) : "no usable address");
    return 0;
}

int sink_server_open_unix(pl_sink *s, const sink_spec *sp)
{
    struct sockaddr_un sa;
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    memcpy(sa.sun_path, sp->path, strlen(sp->path) + 1);

    struct stat st;
    if (lstat(sp->path, &st) == 0) {
        if (!S_ISSOCK(st.st_mode))
            return pl_error(PL_E_IO,
                            "sink '%s': %s exists and is not a socket: refusing to "
                            "replace it",
                            s->spec, sp->path);
        int probe = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC | SOCK_NONBLOCK, 0);
        if (probe < 0)
            return pl_error(PL_E_DEVICE, "sink '%s': socket: %s", s->spec, strerror(errno));
        int r = connect(probe, (struct sockaddr *)&sa, sizeof sa), err = errno;
        close(probe);
        if (r == 0 || err == EAGAIN || err == EINPROGRESS)
            return pl_error(PL_E_DEVICE, "sink '%s': address in use: a server accepts on %s",
                            s->spec, sp->path);
        if (err != ECONNREFUSED)
            return pl_error(PL_E_DEVICE, "sink '%s': cannot check the existing socket %s: %s",
                            s->spec, sp->path, strerror(err));
        if (unlink(sp->path) < 0 && errno != ENOENT)
            return pl_error(PL_E_IO, "sink '%s': cannot remove the stale socket %s: %s", s->spec,
                            sp->path, strerror(errno));
    } else if (errno != ENOENT) {
        return pl_error(PL_E_IO, "sink '%s': %s: %s", s->spec, sp->path, strerror(errno));
    }

    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0) return pl_error(PL_E_DEVICE, "sink '%s': socket: %s", s->spec, strerror(errno));
    /* the file is born with unix_mode: a chmod after bind would leave a window with the
     * umask's bits (the process's umask is restored at once; sinks open before any thread) */
    mode_t old_mask = umask((mode_t)(~s->unix_mode & 0777u));
    int b = bind(fd, (struct sockaddr *)&sa, sizeof sa);
    int bind_err = errno;
    umask(old_mask);
    if (b < 0) {
        int err = bind_err;
        close(fd);
        return pl_error(err == EADDRINUSE ? PL_E_DEVICE : PL_E_IO, "sink '%s': cannot bind %s: %s",
                        s->spec, sp->path, strerror(err));
    }
    if (lstat(sp->path, &st) == 0) {
        s->unix_owned = 1;
        s->unix_dev = st.st_dev;
        s->unix_ino = st.st_ino;
    }
    snprintf(s->unix_path, sizeof s->unix_path, "%s", sp->path);
    if (listen(fd, 16) < 0) {
        int err = errno;
        close(fd);
        if (s->unix_owned) unlink(sp->path);
        s->unix_owned = 0;
        return pl_error(PL_E_DEVICE, "sink '%s': cannot listen on %s: %s", s->spec, sp->path,
                        strerror(err));
    }
    s->fd = fd;
    snprintf(s->address, sizeof s->address, "%s", sp->path);
    return 0;
}

void sink_server_close(pl_sink *s)
{
    int64_t deadline = pl_now_ns() + (int64_t)PL_SINK_CLOSE_MS * 1000000;
    for (;;) {
        struct pollfd *pf = s->pf;
        int *idx = s->pf_idx, n = 0;
        for (int i = 0; i < s->max_clients && s->clients; i++) {
            if (s->clients[i].fd < 0 || s->clients[i].len == 0) continue;
            pf[n].fd = s->clients[i].fd;
            pf[n].events = POLLOUT;
            pf[n].revents = 0;
            idx[n++] = i;
        }
        int64_t left_ms = (deadline - pl_now_ns()) / 1000000;
        if (n == 0 || left_ms <= 0) break;
        int r = poll(pf, (nfds_t)n, (int)left_ms);
        if (r < 0 && errno != EINTR) break;
        for (int k = 0; k < n && r > 0; k++)
            if (pf[k].revents) client_flush(s, &s->clients[idx[k]]);
    }
    for (int i = 0; i < s->max_clients && s->clients; i++)
        if (s->clients[i].fd >= 0) client_drop(s, &s->clients[i]);
    free(s->clients);
    free(s->pf);
    free(s->pf_idx);
    s->clients = NULL;
    s->pf = NULL;
    s->pf_idx = NULL;
    if (s->fd >= 0) close(s->fd);
    s->fd = -1;
    struct stat st;
    if (s->unix_owned && lstat(s->unix_path, &st) == 0 && st.st_dev == s->unix_dev &&
        st.st_ino == s->unix_ino)
        unlink(s->unix_path);
}
