/* Output sinks: spec parsing, stdout, UDP, several sinks (port/sink.h). The TCP and Unix
 * stream servers are in port/sink_server.c, the WebSocket server in port/sink_ws.c, the MQTT
 * publisher in port/sink_mqtt.c, the event queue they use in port/sink_event.c. */
#include <arpa/inet.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <pthread.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "core/util.h"
#include "port/sink_internal.h"

#define SPEC_HELP                                                                                  \
    "expected stdout, -, udp://HOST:PORT, tcp://HOST:PORT, unix:PATH, ws://HOST:PORT[/PATH] or "   \
    "mqtt://HOST:PORT/TOPIC"

/* ---- spec parsing --------------------------------------------------------------------------- */

static int host_char_ok(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '-' ||
           c == '.' || c == '_';
}

/* HOST:PORT (after "udp://" or "tcp://") into sp->host, sp->port. */
static int parse_host_port(const char *spec, const char *rest, int min_port, sink_spec *sp)
{
    const char *colon;
    size_t hlen;
    if (rest[0] == '[') {
        const char *close = strchr(rest, ']');
        if (!close)
            return pl_error(PL_E_ARG, "sink '%s': '[' without ']' around an IPv6 address", spec);
        hlen = (size_t)(close - rest - 1);
        if (hlen == 0 || hlen >= sizeof sp->host)
            return pl_error(PL_E_ARG, "sink '%s': empty or too long IPv6 address", spec);
        memcpy(sp->host, rest + 1, hlen);
        sp->host[hlen] = '\0';
        struct in6_addr a6;
        if (inet_pton(AF_INET6, sp->host, &a6) != 1)
            return pl_error(PL_E_ARG, "sink '%s': '%s' is not an IPv6 address", spec, sp->host);
        sp->host_numeric = 1;
        colon = close + 1;
        if (*colon != ':') return pl_error(PL_E_ARG, "sink '%s': expected ':PORT' after ']'", spec);
    } else {
        colon = strchr(rest, ':');
        if (!colon) return pl_error(PL_E_ARG, "sink '%s': missing ':PORT'", spec);
        hlen = (size_t)(colon - rest);
        if (hlen >= sizeof sp->host)
            return pl_error(PL_E_ARG, "sink '%s': host name too long", spec);
        int digits_dots = 1;
        for (size_t i = 0; i < hlen; i++) {
            if (!host_char_ok(rest[i]))
                return pl_error(PL_E_ARG,
                                "sink '%s': character '%c' not allowed in a host name (IPv6 "
                                "addresses go in brackets: tcp://[::1]:9000)",
                                spec, rest[i]);
            if (!(rest[i] == '.' || (rest[i] >= '0' && rest[i] <= '9'))) digits_dots = 0;
        }
        if (hlen == 0) {
            strcpy(sp->host, "127.0.0.1");
            sp->host_numeric = 1;
        } else {
            memcpy(sp->host, rest, hlen);
            sp->host[hlen] = '\0';
            if (digits_dots) {
                struct in_addr a4;
                if (inet_pton(AF_INET, sp->host, &a4) != 1)
                    return pl_error(PL_E_ARG, "sink '%s': '%s' is not an IPv4 address", spec,
                                    sp->host);
                sp->host_numeric = 1;
            } else if (sp->host[0] == '-' || sp->host[0] == '.') {
                return pl_error(PL_E_ARG, "sink '%s': '%s' is not a host name", spec, sp->host);
            }
        }
    }
    const char *p = colon + 1;
    if (*p == '\0') return pl_error(PL_E_ARG, "sink '%s': missing port after ':'", spec);
    long port = 0;
    int nd = 0;
    for (; *p; p++, nd++) {
        if (*p < '0' || *p > '9' || nd >= 5)
            return pl_error(PL_E_ARG, "sink '%s': port '%s' is not a number in %d..65535", spec,
                            colon + 1, min_port);
        port = port * 10 + (*p - '0');
    }
    if (port < min_port || port > 65535)
        return pl_error(PL_E_ARG, "sink '%s': port %ld out of range %d..65535", spec, port,
                        min_port);
    sp->port = (int)port;
    return 0;
}

/* HOST:PORT/RESOURCE (ws, mqtt): the part before the first '/' as parse_host_port, the rest
 * (with its '/') into sp->resource, or "" when there is none. */
static int parse_host_port_resource(const char *spec, const char *rest, int min_port, sink_spec *sp)
{
    const char *slash = strchr(rest, '/');
    size_t n = slash ? (size_t)(slash - rest) : strlen(rest);
    char hp[PL_SINK_SPEC_MAX + 1];
    memcpy(hp, rest, n);
    hp[n] = '\0';
    int rc = parse_host_port(spec, hp, min_port, sp);
    if (rc < 0) return rc;
    snprintf(sp->resource, sizeof sp->resource, "%s", slash ? slash : "");
    for (const char *p = sp->resource; *p; p++)
        if ((unsigned char)*p <= 0x20 || *p == 0x7f)
            return pl_error(PL_E_ARG, "sink '%s': a space or control character after the port",
                            spec);
    return 0;
}

static int parse_spec(const char *spec, sink_spec *sp)
{
    memset(sp, 0, sizeof *sp);
    if (!spec) return pl_error(PL_E_ARG, "sink spec is NULL");
    size_t n = strnlen(spec, PL_SINK_SPEC_MAX + 1);
    if (n == 0) return pl_error(PL_E_ARG, "empty sink spec: " SPEC_HELP);
    if (n > PL_SINK_SPEC_MAX)
        return pl_error(PL_E_ARG, "sink spec longer than %d bytes", PL_SINK_SPEC_MAX);
    if (!strcmp(spec, "stdout") || !strcmp(spec, "-")) {
        sp->kind = SINK_STDOUT;
        return 0;
    }
    if (!strncmp(spec, "udp://", 6)) {
        sp->kind = SINK_UDP;
        return parse_host_port(spec, spec + 6, 1, sp);
    }
    if (!strncmp(spec, "tcp://", 6)) {
        sp->kind = SINK_TCP;
        return parse_host_port(spec, spec + 6, 0, sp);
    }
    if (!strncmp(spec, "ws://", 5)) {
        sp->kind = SINK_WS;
        int rc = parse_host_port_resource(spec, spec + 5, 0, sp);
        if (rc < 0) return rc;
        if (sp->resource[0] == '\0') strcpy(sp->resource, "/");
        if (strpbrk(sp->resource, "?#"))
            return pl_error(PL_E_ARG, "sink '%s': the path may not hold '?' or '#'", spec);
        return 0;
    }
    if (!strncmp(spec, "mqtt://", 7)) {
        sp->kind = SINK_MQTT;
        int rc = parse_host_port_resource(spec, spec + 7, 1, sp);
        if (rc < 0) return rc;
        if (sp->resource[0] != '/' || sp->resource[1] == '\0')
            return pl_error(PL_E_ARG, "sink '%s': missing the topic: mqtt://HOST:PORT/TOPIC", spec);
        memmove(sp->resource, sp->resource + 1, strlen(sp->resource));
        if (strpbrk(sp->resource, "+#"))
            return pl_error(PL_E_ARG,
                            "sink '%s': topic '%s' holds a wildcard ('+' or '#'): a message is "
                            "published to one topic",
                            spec, sp->resource);
        return 0;
    }
    if (!strncmp(spec, "unix:", 5)) {
        sp->kind = SINK_UNIX;
        const char *path = spec + 5;
        if (!strncmp(path, "//", 2))
            return pl_error(PL_E_ARG,
                            "sink '%s': write unix:PATH (unix:/tmp/parlight.sock), "
                            "not a URL",
                            spec);
        size_t pl = strlen(path);
        if (pl == 0) return pl_error(PL_E_ARG, "sink '%s': missing path after 'unix:'", spec);
        if (pl >= sizeof sp->path)
            return pl_error(PL_E_ARG, "sink '%s': socket path of %zu bytes, at most %zu", spec, pl,
                            sizeof sp->path - 1);
        memcpy(sp->path, path, pl + 1);
        return 0;
    }
    return pl_error(PL_E_ARG, "sink '%s': unknown kind, " SPEC_HELP, spec);
}

/* ---- stdout ------------------------------------------------------------------------------ */

/* Blocking write and flush with SIGPIPE blocked in this thread; a SIGPIPE raised by this write
 * (not one already pending) is consumed, so a closed reader is an EPIPE error, not a death. */
static int stdout_write(pl_sink *s, const char *line, size_t len)
{
    sigset_t pipe_set, old, pending;
    sigemptyset(&pipe_set);
    sigaddset(&pipe_set, SIGPIPE);
    pthread_sigmask(SIG_BLOCK, &pipe_set, &old);
    sigemptyset(&pending);
    sigpending(&pending);
    int was_pending = sigismember(&pending, SIGPIPE);
    errno = 0;
    size_t n = fwrite(line, 1, len, stdout);
    int ok = n == len && fflush(stdout) == 0;
    int err = errno;
    if (!ok && err == EPIPE && !was_pending) {
        struct timespec zero = {0, 0};
        while (sigtimedwait(&pipe_set, NULL, &zero) < 0 && errno == EINTR) {
        }
    }
    pthread_sigmask(SIG_SETMASK, &old, NULL);
    if (!ok) {
        clearerr(stdout);
        s->stats.lines_failed++;
        return pl_error(PL_E_IO, "sink '%s': write failed: %s", s->spec,
                        err == EPIPE ? "the reader closed the pipe (EPIPE)"
                        : err        ? strerror(err)
                                     : "short write");
    }
    s->stats.lines++;
    s->stats.bytes += len;
    return 0;
}

/* ---- udp --------------------------------------------------------------------------------- */

int sink_resolve(const char *spec, const sink_spec *sp, int socktype, struct addrinfo **res)
{
    struct addrinfo hints;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_UNSPEC;
    hints.ai_socktype = socktype;
    hints.ai_flags = AI_NUMERICSERV | (sp->host_numeric ? AI_NUMERICHOST : 0);
    char port[8];
    snprintf(port, sizeof port, "%d", sp->port);
    int rc = getaddrinfo(sp->host, port, &hints, res);
    if (rc != 0)
        return pl_error(PL_E_DEVICE, "sink '%s': cannot resolve '%s': %s", spec, sp->host,
                        rc == EAI_SYSTEM ? strerror(errno) : gai_strerror(rc));
    return 0;
}

static int udp_open(pl_sink *s, const sink_spec *sp)
{
    struct addrinfo *res = NULL;
    int rc = sink_resolve(s->spec, sp, SOCK_DGRAM, &res);
    if (rc < 0) return rc;
    int err = 0;
    for (struct addrinfo *ai = res; ai; ai = ai->ai_next) {
        int fd =
            socket(ai->ai_family, ai->ai_socktype | SOCK_NONBLOCK | SOCK_CLOEXEC, ai->ai_protocol);
        if (fd < 0) {
            err = errno;
            continue;
        }
        if (connect(fd, ai->ai_addr, ai->ai_addrlen) < 0) {
            err = errno;
            close(fd);
            continue;
        }
        s->fd = fd;
        sink_format_addr(ai->ai_addr, s->address, sizeof s->address);
        break;
    }
    freeaddrinfo(res);
    if (s->fd < 0)
        return pl_error(PL_E_DEVICE, "sink '%s': cannot send to %s:%d: %s", s->spec, sp->host,
                        sp->port, err ? strerror(err) : "no usable address");
    return 0;
}

static int udp_write(pl_sink *s, const char *line, size_t len)
{
    if (len > PL_SINK_UDP_MAX) {
        s->stats.lines_failed++;
        return pl_error(PL_E_ARG, "sink '%s': line of %zu bytes exceeds the datagram limit %d",
                        s->spec, len, PL_SINK_UDP_MAX);
    }
    for (int attempt = 0; attempt < 3; attempt++) {
        ssize_t n = send(s->fd, line, len, MSG_DONTWAIT | MSG_NOSIGNAL);
        if (n >= 0) {
            s->stats.lines++;
            s->stats.bytes += (uint64_t)n;
            return 0;
        }
        if (errno == EINTR) continue;
        /* ECONNREFUSED reports an earlier datagram that nobody received (ICMP port
         * unreachable) and consumes that error: send this one again, once. */
        if (errno == ECONNREFUSED && attempt == 0) {
            s->stats.lines_dropped++;
            continue;
        }
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS || errno == ECONNREFUSED) {
            s->stats.lines++;
            s->stats.lines_dropped++;
            return 0;
        }
        int err = errno;
        s->stats.lines_failed++;
        return pl_error(PL_E_DEVICE, "sink '%s': send failed: %s", s->spec, strerror(err));
    }
    s->stats.lines++;
    s->stats.lines_dropped++;
    return 0;
}

/* ---- one sink ------------------------------------------------------------------------------ */

int pl_sink_open(const char *spec, pl_sink **out)
{
    return pl_sink_open_opts(spec, NULL, out);
}

int pl_sink_open_opts(const char *spec, const pl_sink_options *opts, pl_sink **out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_sink_open: NULL output");
    *out = NULL;
    sink_spec sp;
    int rc = parse_spec(spec, &sp);
    if (rc < 0) return rc;
    pl_sink *s = calloc(1, sizeof *s);
    if (!s) return pl_error(PL_E_NOMEM, "sink '%s': out of memory", spec);
    s->kind = sp.kind;
    s->fd = -1;
    snprintf(s->spec, sizeof s->spec, "%s", spec);
    s->next_client_id = 1;
    switch (sp.kind) {
    case SINK_STDOUT:
        snprintf(s->address, sizeof s->address, "stdout");
        rc = 0;
        break;
    case SINK_UDP:
        rc = udp_open(s, &sp);
        break;
    case SINK_TCP:
        rc = sink_server_init(s, opts);
        if (rc == 0) rc = sink_server_open_tcp(s, &sp);
        break;
    case SINK_UNIX:
        rc = sink_server_init(s, opts);
        if (rc == 0) rc = sink_server_open_unix(s, &sp);
        break;
    case SINK_WS:
        rc = sink_ws_open(s, &sp, opts);
        break;
    case SINK_MQTT:
        rc = sink_mqtt_open(s, &sp, opts);
        break;
    }
    if (rc < 0) {
        if (s->kind == SINK_TCP || s->kind == SINK_UNIX) sink_server_close(s);
        if (s->kind == SINK_WS) sink_ws_close(s);
        if (s->kind == SINK_MQTT) sink_mqtt_close(s);
        free(s);
        return rc;
    }
    *out = s;
    return 0;
}

int pl_sink_write(pl_sink *s, const char *line, size_t len)
{
    if (!s || !line) return pl_error(PL_E_ARG, "pl_sink_write: NULL sink or line");
    if (len == 0 || line[len - 1] != '\n' || memchr(line, '\n', len - 1)) {
        s->stats.lines_failed++;
        return pl_error(PL_E_ARG, "sink '%s': a line must end with its only newline (%zu bytes)",
                        s->spec, len);
    }
    switch (s->kind) {
    case SINK_STDOUT:
        return stdout_write(s, line, len);
    case SINK_UDP:
        return udp_write(s, line, len);
    case SINK_TCP:
    case SINK_UNIX:
        return sink_server_write(s, line, len);
    case SINK_WS:
        return sink_ws_write(s, line, len);
    case SINK_MQTT:
        return sink_mqtt_write(s, line, len);
    }
    return pl_error(PL_E_INTERNAL, "sink '%s': bad kind", s->spec);
}

int pl_sink_service(pl_sink *s)
{
    if (!s) return 0;
    switch (s->kind) {
    case SINK_TCP:
    case SINK_UNIX:
        return sink_server_service(s);
    case SINK_WS:
        return sink_ws_service(s);
    case SINK_MQTT:
        return sink_mqtt_service(s);
    default:
        return 0;
    }
}

int pl_sink_next_event(pl_sink *s, char *msg, size_t cap)
{
    if (!s || !msg || cap == 0) return 0;
    if (s->ev_lost) {
        snprintf(msg, cap, "%s: %llu older event message(s) lost", s->spec,
                 (unsigned long long)s->ev_lost);
        s->ev_lost = 0;
        return 1;
    }
    if (s->ev_count == 0) return 0;
    snprintf(msg, cap, "%s", s->events[s->ev_head]);
    s->ev_head = (s->ev_head + 1) % SINK_EVENTS;
    s->ev_count--;
    return 1;
}

void pl_sink_get_stats(const pl_sink *s, pl_sink_stats *stats)
{
    if (!stats) return;
    if (!s) {
        memset(stats, 0, sizeof *stats);
        return;
    }
    *stats = s->stats;
}

const char *pl_sink_spec(const pl_sink *s)
{
    return s ? s->spec : "";
}

const char *pl_sink_address(const pl_sink *s)
{
    return s ? s->address : "";
}

void pl_sink_close(pl_sink *s)
{
    if (!s) return;
    switch (s->kind) {
    case SINK_STDOUT:
        fflush(stdout);
        break;
    case SINK_UDP:
        if (s->fd >= 0) close(s->fd);
        break;
    case SINK_TCP:
    case SINK_UNIX:
        sink_server_close(s);
        break;
    case SINK_WS:
        sink_ws_close(s);
        break;
    case SINK_MQTT:
        sink_mqtt_close(s);
        break;
    }
    free(s);
}

/* ---- several sinks ---------------------------------------------------------------------- */

struct pl_sinks {
    int n;
    pl_sink *sink[PL_SINKS_MAX];
    int next_event; /* round robin over the sinks' events */
};

int pl_sinks_open(const char *const *specs, int n, const pl_sink_options *opts, pl_sinks **out)
{
    if (!out) return pl_error(PL_E_ARG, "pl_sinks_open: NULL output");
    *out = NULL;
    if (n < 0 || n > PL_SINKS_MAX || (n > 0 && !specs))
        return pl_error(PL_E_ARG, "%d sinks (--out given %d times): at most %d", n, n,
                        PL_SINKS_MAX);
    for (int i = 0; i < n; i++)
        for (int j = 0; j < i; j++)
            if (specs[i] && specs[j] && !strcmp(specs[i], specs[j]))
                return pl_error(PL_E_ARG, "sink '%s' given twice", specs[i]);
    pl_sinks *m = calloc(1, sizeof *m);
    if (!m) return pl_error(PL_E_NOMEM, "sinks: out of memory");
    static const char *const default_spec[1] = {"stdout"};
    if (n == 0) {
        specs = default_spec;
        n = 1;
    }
    for (int i = 0; i < n; i++) {
        int rc = pl_sink_open_opts(specs[i], opts, &m->sink[i]);
        if (rc < 0) {
            pl_sinks_close(m);
            return rc;
        }
        m->n = i + 1;
    }
    *out = m;
    return 0;
}

int pl_sinks_write(pl_sinks *m, const char *line, size_t len)
{
    if (!m) return pl_error(PL_E_ARG, "pl_sinks_write: NULL sinks");
    int first = 0;
    char msg[512] = "";
    for (int i = 0; i < m->n; i++) {
        int rc = pl_sink_write(m->sink[i], line, len);
        if (rc < 0 && first == 0) {
            first = rc;
            snprintf(msg, sizeof msg, "%s", pl_last_error());
        }
    }
    if (first < 0) return pl_error(first, "%s", msg);
    return 0;
}

int pl_sinks_service(pl_sinks *m)
{
    int n = 0;
    for (int i = 0; m && i < m->n; i++)
        n += pl_sink_service(m->sink[i]);
    return n;
}

int pl_sinks_next_event(pl_sinks *m, char *msg, size_t cap)
{
    if (!m) return 0;
    for (int k = 0; k < m->n; k++) {
        int i = (m->next_event + k) % m->n;
        if (pl_sink_next_event(m->sink[i], msg, cap)) {
            m->next_event = (i + 1) % m->n;
            return 1;
        }
    }
    return 0;
}

int pl_sinks_count(const pl_sinks *m)
{
    return m ? m->n : 0;
}

pl_sink *pl_sinks_get(pl_sinks *m, int i)
{
    return m && i >= 0 && i < m->n ? m->sink[i] : NULL;
}

void pl_sinks_close(pl_sinks *m)
{
    if (!m) return;
    for (int i = 0; i < m->n; i++)
        pl_sink_close(m->sink[i]);
    free(m);
}
