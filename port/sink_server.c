/* TCP and Unix stream-socket servers for the JSON-lines stream (port/sink.h): no thread; every
 * write accepts pending clients, discards what they send, queues the line per client and sends
 * what each socket takes, without blocking. */
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
    s->stats.clients--;
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

static void accept_pending(pl_sink *s)
{
    for (int k = 0; k < ACCEPTS_PER_WRITE; k++) {
        struct sockaddr_storage ss;
        socklen_t sl = sizeof ss;
        int fd = accept4(s->fd, (struct sockaddr *)&ss, &sl, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0) {
            int err = errno;
            if (err == EINTR || err == ECONNABORTED || err == EPROTO) continue;
            if (err == EAGAIN || err == EWOULDBLOCK) {
                s->last_accept_errno = 0;
                return;
            }
            if (err != s->last_accept_errno)
                sink_event(s, "cannot accept a client: %s", strerror(err));
            s->last_accept_errno = err;
            return;
        }
        s->last_accept_errno = 0;
        sink_client *c = NULL;
        for (int i = 0; i < PL_SINK_MAX_CLIENTS && !c; i++)
            if (s->clients[i].fd < 0) c = &s->clients[i];
        char peer[64];
        if (s->kind == SINK_TCP)
            sink_format_addr(&ss, peer, sizeof peer);
        else
            snprintf(peer, sizeof peer, "unix");
        if (!c) {
            close(fd);
            s->stats.refused++;
            sink_event(s, "refused a client (%s): %d clients already", peer, PL_SINK_MAX_CLIENTS);
            continue;
        }
        char *buf = malloc(PL_SINK_QUEUE_BYTES);
        if (!buf) {
            close(fd);
            s->stats.refused++;
            sink_event(s, "refused a client (%s): out of memory", peer);
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
        s->stats.clients++;
        s->stats.accepted++;
        sink_event(s, "client %llu connected (%s)", (unsigned long long)c->id, c->peer);
    }
}

/* Discards what clients sent (the stream is one-way) and notices closed connections. */
static void service_clients(pl_sink *s)
{
    struct pollfd pf[PL_SINK_MAX_CLIENTS];
    int idx[PL_SINK_MAX_CLIENTS], n = 0;
    for (int i = 0; i < PL_SINK_MAX_CLIENTS; i++) {
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
    for (int i = 0; i < PL_SINK_MAX_CLIENTS; i++) {
        sink_client *c = &s->clients[i];
        if (c->fd < 0 || client_flush(s, c) < 0) continue;
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

int sink_server_open_tcp(pl_sink *s, const sink_spec *sp)
{
    struct addrinfo hints, *res = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = SOCK_STREAM;
    hints.ai_flags = AI_NUMERICSERV | (sp->host_numeric ? AI_NUMERICHOST : 0);
    char port[8];
    snprintf(port, sizeof port, "%d", sp->port);
    int rc = getaddrinfo(sp->host, port, &hints, &res);
    if (rc != 0)
        return pl_error(PL_E_DEVICE, "sink '%s': cannot resolve '%s': %s", s->spec, sp->host,
                        rc == EAI_SYSTEM ? strerror(errno) : gai_strerror(rc));
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
    if (bind(fd, (struct sockaddr *)&sa, sizeof sa) < 0) {
        int err = errno;
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
        struct pollfd pf[PL_SINK_MAX_CLIENTS];
        int idx[PL_SINK_MAX_CLIENTS], n = 0;
        for (int i = 0; i < PL_SINK_MAX_CLIENTS; i++) {
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
    for (int i = 0; i < PL_SINK_MAX_CLIENTS; i++)
        if (s->clients[i].fd >= 0) client_drop(s, &s->clients[i]);
    if (s->fd >= 0) close(s->fd);
    s->fd = -1;
    struct stat st;
    if (s->unix_owned && lstat(s->unix_path, &st) == 0 && st.st_dev == s->unix_dev &&
        st.st_ino == s->unix_ino)
        unlink(s->unix_path);
}
