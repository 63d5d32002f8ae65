/* port/sink.c and port/sink_server.c, on loopback only: UDP round trip, TCP with two readers, a
 * reader that never reads (dropped; pl_sink_write stays fast, the other reader gets every line),
 * a reader that disconnects mid-stream (no SIGPIPE death), stdout into a closed pipe, Unix socket
 * round trip, stale and live socket files, several sinks at once, the client limit, a bounded
 * close, and every malformed spec. Every wait has a timeout and alarm() guards the whole run. */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "core/util.h"
#include "port/sink.h"
#include "tests/check.h"

static char tmpdir[512];

static double now_s(void)
{
    return (double)pl_now_ns() * 1e-9;
}

/* Port of "127.0.0.1:40123" / "[::1]:40123". */
static int addr_port(const char *address)
{
    const char *c = strrchr(address, ':');
    return c ? atoi(c + 1) : -1;
}

static int connect_tcp(int port, int rcvbuf)
{
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd < 0) return -1;
    if (rcvbuf > 0) setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_port = htons((uint16_t)port);
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd, (struct sockaddr *)&sa, sizeof sa) < 0) {
        close(fd);
        return -1;
    }
    return fd;
}

static int connect_unix(const char *path)
{
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    struct sockaddr_un sa;
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", path);
    if (fd < 0 || connect(fd, (struct sockaddr *)&sa, sizeof sa) < 0) {
        if (fd >= 0) close(fd);
        return -1;
    }
    return fd;
}

/* Reads one line (up to and with '\n', NUL-terminated) within timeout_ms, a byte at a time so
 * nothing after it is consumed. Returns its length, 0 on EOF/timeout before a newline. */
static size_t read_line(int fd, char *buf, size_t cap, int timeout_ms)
{
    size_t n = 0;
    double end = now_s() + timeout_ms / 1000.0;
    buf[0] = '\0';
    while (n + 1 < cap) {
        int left = (int)((end - now_s()) * 1000);
        if (left <= 0) return 0;
        struct pollfd pf = {fd, POLLIN, 0};
        if (poll(&pf, 1, left) <= 0) continue;
        ssize_t r = recv(fd, buf + n, 1, 0);
        if (r <= 0) return 0;
        buf[++n] = '\0';
        if (buf[n - 1] == '\n') return n;
    }
    return 0;
}

/* Reads exactly n bytes within timeout_ms (poll between reads). Returns bytes read. */
static size_t read_bytes(int fd, char *buf, size_t n, int timeout_ms)
{
    size_t got = 0;
    double end = now_s() + timeout_ms / 1000.0;
    while (got < n) {
        int left = (int)((end - now_s()) * 1000);
        if (left <= 0) break;
        struct pollfd pf = {fd, POLLIN, 0};
        if (poll(&pf, 1, left) <= 0) continue;
        ssize_t r = recv(fd, buf + got, n - got, 0);
        if (r <= 0) break;
        got += (size_t)r;
    }
    return got;
}

static size_t make_line(char *buf, size_t cap, int i, int pad)
{
    int n = snprintf(buf, cap, "{\"frame\":%d,\"pad\":\"%0*d\"}\n", i, pad, 0);
    return (size_t)n;
}

static void drain_events(pl_sink *s, int *slow, int *gone, int *connected)
{
    char msg[PL_SINK_EVENT_MAX];
    while (pl_sink_next_event(s, msg, sizeof msg)) {
        if (strstr(msg, "slow")) (*slow)++;
        if (strstr(msg, "disconnected")) (*gone)++;
        if (strstr(msg, "connected (")) (*connected)++;
        CHECK(strncmp(msg, pl_sink_spec(s), strlen(pl_sink_spec(s))) == 0,
              "event does not name the sink: %s", msg);
    }
}

/* ---- specs ---------------------------------------------------------------------------- */

static void test_malformed_specs(void)
{
    char long_path[300], long_spec[400];
    memset(long_path, 'a', sizeof long_path);
    memcpy(long_path, "unix:/tmp/", 10);
    long_path[150] = '\0';
    memset(long_spec, 'x', sizeof long_spec);
    memcpy(long_spec, "tcp://", 6);
    long_spec[sizeof long_spec - 1] = '\0';
    const char *bad[] = {
        "",
        "tcp",
        "tcp:",
        "tcp://",
        "tcp://127.0.0.1",
        "tcp://127.0.0.1:",
        "tcp://:",
        "tcp://127.0.0.1:65536",
        "tcp://127.0.0.1:-1",
        "tcp://127.0.0.1:9x",
        "tcp://127.0.0.1:900000",
        "tcp://127.0.0.1:000009000",
        "tcp://::1:9000",
        "tcp://[::1:9000",
        "tcp://[::1]9000",
        "tcp://[::1]:",
        "tcp://[zz]:9000",
        "tcp://[]:9000",
        "tcp://999.1.1.1:9000",
        "tcp://1.2.3:9000",
        "tcp://host name:1",
        "tcp://a/b:1",
        "tcp://127.0.0.1:9000/path",
        "tcp://127.0.0.1:9000 ",
        "tcp:// 127.0.0.1:9000",
        "tcp://-x:1",
        "tcp://127.0.0.1:+80",
        "TCP://127.0.0.1:9000",
        "udp://127.0.0.1:0",
        "udp://:",
        "udp://",
        "udp:/127.0.0.1:5000",
        "unix:",
        "unix://tmp/x.sock",
        long_path,
        "http://localhost:80",
        "file:/tmp/x",
        "stdout:",
        "--",
        "-tcp",
        "stdin",
        long_spec,
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        pl_sink *s = (pl_sink *)&s;
        int rc = pl_sink_open(bad[i], &s);
        CHECK(rc == PL_E_ARG, "spec '%s': rc %d (%s)", bad[i], rc, pl_last_error());
        CHECK(s == NULL, "spec '%s': *out not cleared", bad[i]);
        if (bad[i][0] && strlen(bad[i]) < 200)
            CHECK(strstr(pl_last_error(), bad[i]) != NULL,
                  "spec '%s': message does not name it: %s", bad[i], pl_last_error());
        if (s && s != (pl_sink *)&s) pl_sink_close(s);
    }
    pl_sink *s;
    CHECK(pl_sink_open(NULL, &s) == PL_E_ARG, "NULL spec");
    CHECK(pl_sink_open("stdout", NULL) == PL_E_ARG, "NULL out");

    /* Names that cannot be resolved: an error naming the spec, quickly (RFC 6761 .invalid). */
    double t0 = now_s();
    int rc = pl_sink_open("udp://no-such-host.invalid:5000", &s);
    CHECK(rc == PL_E_DEVICE && strstr(pl_last_error(), "udp://no-such-host.invalid:5000"),
          "unresolvable udp host: rc %d (%s)", rc, pl_last_error());
    rc = pl_sink_open("tcp://no-such-host.invalid:0", &s);
    CHECK(rc == PL_E_DEVICE && strstr(pl_last_error(), "no-such-host"),
          "unresolvable tcp host: rc %d (%s)", rc, pl_last_error());
    printf("unresolvable hosts rejected in %.3f s\n", now_s() - t0);
}

/* ---- udp ------------------------------------------------------------------------------ */

static void test_udp(void)
{
    int rx = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t sl = sizeof sa;
    CHECK(rx >= 0 && bind(rx, (struct sockaddr *)&sa, sizeof sa) == 0 &&
              getsockname(rx, (struct sockaddr *)&sa, &sl) == 0,
          "udp receiver: %s", strerror(errno));
    int port = ntohs(sa.sin_port);
    char spec[64];
    snprintf(spec, sizeof spec, "udp://127.0.0.1:%d", port);
    pl_sink *s = NULL;
    CHECK(pl_sink_open(spec, &s) == 0, "open %s: %s", spec, pl_last_error());
    if (!s) return;
    char want[64];
    snprintf(want, sizeof want, "127.0.0.1:%d", port);
    CHECK(strcmp(pl_sink_address(s), want) == 0, "address %s", pl_sink_address(s));
    char line[2048], got[70000];
    for (int i = 0; i < 5; i++) {
        size_t n = make_line(line, sizeof line, i, 100 * i);
        CHECK(pl_sink_write(s, line, n) == 0, "udp write: %s", pl_last_error());
        struct pollfd pf = {rx, POLLIN, 0};
        ssize_t r = poll(&pf, 1, 2000) == 1 ? recv(rx, got, sizeof got, 0) : -1;
        CHECK(r == (ssize_t)n && memcmp(got, line, n) == 0, "datagram %d: %zd bytes, want %zu", i,
              r, n);
    }
    /* a line too long for a datagram: an error for that line only */
    char *big = malloc(70001);
    memset(big, 'x', 70000);
    big[69999] = '\n';
    CHECK(pl_sink_write(s, big, 70000) == PL_E_ARG && strstr(pl_last_error(), spec),
          "oversized datagram: %s", pl_last_error());
    free(big);
    size_t n = make_line(line, sizeof line, 99, 10);
    CHECK(pl_sink_write(s, line, n) == 0, "write after an oversized line");
    struct pollfd pf = {rx, POLLIN, 0};
    ssize_t r = poll(&pf, 1, 2000) == 1 ? recv(rx, got, sizeof got, 0) : -1;
    CHECK(r == (ssize_t)n, "datagram after an oversized line: %zd", r);
    /* malformed lines */
    CHECK(pl_sink_write(s, "{}", 2) == PL_E_ARG, "line without a newline");
    CHECK(pl_sink_write(s, "{}\n{}\n", 6) == PL_E_ARG, "two lines in one");
    CHECK(pl_sink_write(s, "", 0) == PL_E_ARG, "empty line");
    pl_sink_stats st;
    pl_sink_get_stats(s, &st);
    CHECK(st.lines == 6 && st.lines_failed == 4, "udp stats: lines %llu failed %llu",
          (unsigned long long)st.lines, (unsigned long long)st.lines_failed);
    pl_sink_close(s);

    /* nobody listening: lines are dropped quietly, never an error or a signal */
    close(rx);
    CHECK(pl_sink_open(spec, &s) == 0, "reopen %s", spec);
    for (int i = 0; i < 20; i++) {
        n = make_line(line, sizeof line, i, 10);
        CHECK(pl_sink_write(s, line, n) == 0, "write with no receiver: %s", pl_last_error());
    }
    pl_sink_get_stats(s, &st);
    printf("udp with no receiver: %llu of 20 lines reported dropped\n",
           (unsigned long long)st.lines_dropped);
    pl_sink_close(s);

    /* a host name */
    CHECK(pl_sink_open("udp://localhost:5999", &s) == 0, "udp://localhost: %s", pl_last_error());
    if (s) {
        CHECK(!strcmp(pl_sink_address(s), "127.0.0.1:5999") ||
                  !strcmp(pl_sink_address(s), "[::1]:5999"),
              "localhost resolved to %s", pl_sink_address(s));
        pl_sink_close(s);
    }
}

/* ---- tcp ------------------------------------------------------------------------------ */

static pl_sink *open_tcp(int *port)
{
    pl_sink *s = NULL;
    int rc = pl_sink_open("tcp://127.0.0.1:0", &s);
    CHECK(rc == 0, "open tcp://127.0.0.1:0: %s", pl_last_error());
    *port = s ? addr_port(pl_sink_address(s)) : -1;
    CHECK(!s || (*port > 0 && !strncmp(pl_sink_address(s), "127.0.0.1:", 10)), "address %s",
          s ? pl_sink_address(s) : "");
    return s;
}

static void test_tcp_two_clients(void)
{
    int port;
    pl_sink *s = open_tcp(&port);
    if (!s) return;
    int a = connect_tcp(port, 0), b = connect_tcp(port, 0);
    CHECK(a >= 0 && b >= 0, "connect: %s", strerror(errno));
    char line[256], expect[100 * 64], got[100 * 64];
    size_t total = 0;
    for (int i = 0; i < 100; i++) {
        size_t n = make_line(line, sizeof line, i, 20);
        memcpy(expect + total, line, n);
        total += n;
        CHECK(pl_sink_write(s, line, n) == 0, "write: %s", pl_last_error());
    }
    int slow = 0, gone = 0, conn = 0;
    drain_events(s, &slow, &gone, &conn);
    CHECK(conn == 2 && slow == 0 && gone == 0, "events: %d connected, %d slow, %d gone", conn, slow,
          gone);
    for (int k = 0; k < 2; k++) {
        int fd = k ? b : a;
        size_t r = read_bytes(fd, got, total, 3000);
        CHECK(r == total && memcmp(got, expect, total) == 0, "client %d got %zu of %zu bytes", k, r,
              total);
    }
    pl_sink_stats st;
    pl_sink_get_stats(s, &st);
    CHECK(st.clients == 2 && st.accepted == 2 && st.lines == 100, "stats: %d clients, %llu lines",
          st.clients, (unsigned long long)st.lines);

    /* the same address again: in use */
    char spec[64];
    snprintf(spec, sizeof spec, "tcp://127.0.0.1:%d", port);
    pl_sink *s2 = NULL;
    int rc = pl_sink_open(spec, &s2);
    CHECK(rc == PL_E_DEVICE && strstr(pl_last_error(), spec) && strstr(pl_last_error(), "in use"),
          "address in use: rc %d (%s)", rc, pl_last_error());
    if (s2) pl_sink_close(s2);

    /* close: both clients see the end of the stream */
    pl_sink_close(s);
    char c;
    CHECK(read_bytes(a, &c, 1, 2000) == 0 && read_bytes(b, &c, 1, 2000) == 0, "EOF after close");
    close(a);
    close(b);
}

typedef struct reader {
    int fd;
    int n_lines;    /* expected */
    atomic_int got; /* complete, correct lines so far */
    atomic_int bad;
} reader;

static void *reader_main(void *arg)
{
    reader *r = arg;
    static char buf[1 << 16];
    char acc[4096];
    size_t acc_len = 0;
    double end = now_s() + 30;
    while (atomic_load(&r->got) < r->n_lines && now_s() < end) {
        struct pollfd pf = {r->fd, POLLIN, 0};
        if (poll(&pf, 1, 200) <= 0) continue;
        ssize_t n = recv(r->fd, buf, sizeof buf, 0);
        if (n <= 0) break;
        for (ssize_t i = 0; i < n; i++) {
            if (acc_len < sizeof acc) acc[acc_len++] = buf[i];
            if (buf[i] != '\n') continue;
            int frame = -1;
            char expect[2048];
            int want = atomic_load(&r->got);
            size_t el = make_line(expect, sizeof expect, want, 1000);
            if (sscanf(acc, "{\"frame\":%d", &frame) != 1 || frame != want || acc_len != el ||
                memcmp(acc, expect, el) != 0)
                atomic_fetch_add(&r->bad, 1);
            atomic_fetch_add(&r->got, 1);
            acc_len = 0;
        }
    }
    return NULL;
}

/* One client reads everything, one never reads: the second is dropped once its queue would
 * overflow, the first receives all 10k lines in order, and no write takes long. */
static void test_tcp_slow_client(void)
{
    int port;
    pl_sink *s = open_tcp(&port);
    if (!s) return;
    reader r = {.fd = connect_tcp(port, 0), .n_lines = 10000};
    int idle = connect_tcp(port, 4096);
    CHECK(r.fd >= 0 && idle >= 0, "connect");
    pthread_t th;
    CHECK(pthread_create(&th, NULL, reader_main, &r) == 0, "reader thread");
    char line[2048];
    double write_total = 0, write_max = 0;
    int slow = 0, gone = 0, conn = 0;
    for (int i = 0; i < r.n_lines; i++) {
        size_t n = make_line(line, sizeof line, i, 1000);
        double t0 = now_s();
        int rc = pl_sink_write(s, line, n);
        double dt = now_s() - t0;
        write_total += dt;
        if (dt > write_max) write_max = dt;
        CHECK(rc == 0, "write %d: %s", i, pl_last_error());
        drain_events(s, &slow, &gone, &conn);
        /* Pace the writer to the reader thread (not timed): on a busy machine the reader may not
         * be scheduled for a while, and this test is about the idle client. */
        if (i % 32 == 31) {
            double end = now_s() + 10;
            while (atomic_load(&r.got) < i - 40 && now_s() < end)
                usleep(200);
        }
    }
    pthread_join(th, NULL);
    pl_sink_stats st;
    pl_sink_get_stats(s, &st);
    CHECK(atomic_load(&r.got) == r.n_lines && atomic_load(&r.bad) == 0,
          "reading client got %d of %d lines, %d bad", atomic_load(&r.got), r.n_lines,
          atomic_load(&r.bad));
    CHECK(st.dropped_slow == 1 && slow == 1 && st.clients == 1,
          "idle client: dropped_slow %llu, %d slow events, %d clients",
          (unsigned long long)st.dropped_slow, slow, st.clients);
    CHECK(write_total < 2.0 && write_max < 0.25, "10k writes took %.3f s (max %.2f ms)",
          write_total, write_max * 1e3);
    printf(
        "tcp: 10000 writes of %zu bytes in %.1f ms (max %.3f ms per write), idle client dropped\n",
        make_line(line, sizeof line, 0, 1000), write_total * 1e3, write_max * 1e3);
    /* the idle client got the beginning of the stream, then EOF (dropped), not garbage */
    double t0 = now_s();
    pl_sink_close(s);
    double tc = now_s() - t0;
    CHECK(tc < 1.0, "close took %.3f s", tc);
    /* the idle client got a prefix of the stream, then EOF: whole lines then maybe the start
     * of one (what the kernel had taken when it was dropped), never garbage */
    static char idle_buf[1 << 20];
    size_t got = read_bytes(idle, idle_buf, sizeof idle_buf, 3000), pos = 0;
    int ok = got > 0;
    for (int i = 0; ok && pos < got; i++) {
        size_t n = make_line(line, sizeof line, i, 1000), m = got - pos < n ? got - pos : n;
        ok = memcmp(idle_buf + pos, line, m) == 0;
        pos += m;
    }
    CHECK(ok, "idle client: %zu bytes, not a prefix of the stream", got);
    close(idle);
    close(r.fd);
}

/* A client that vanishes mid-stream (closed, or reset) costs no signal, the stream goes on. */
static void test_tcp_disconnect(void)
{
    signal(SIGPIPE, SIG_DFL); /* a SIGPIPE would kill the test */
    int port;
    pl_sink *s = open_tcp(&port);
    if (!s) return;
    int a = connect_tcp(port, 0), b = connect_tcp(port, 0), keep = connect_tcp(port, 0);
    char line[256], got[8192];
    int slow = 0, gone = 0, conn = 0;
    for (int i = 0; i < 400; i++) {
        size_t n = make_line(line, sizeof line, i, 50);
        CHECK(pl_sink_write(s, line, n) == 0, "write %d: %s", i, pl_last_error());
        if (i == 10) {
            read_bytes(a, got, 100, 1000);
            close(a); /* FIN, then RST at our next send */
        }
        if (i == 20) {
            struct linger lg = {1, 0};
            setsockopt(b, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
            close(b); /* RST now */
        }
        if (i % 50 == 0) read_bytes(keep, got, sizeof got, 1); /* keep it drained */
        drain_events(s, &slow, &gone, &conn);
        usleep(100);
    }
    pl_sink_stats st;
    pl_sink_get_stats(s, &st);
    CHECK(st.disconnected == 2 && gone == 2 && st.clients == 1 && st.dropped_slow == 0,
          "disconnects: %llu (%d events), %d clients left, %llu slow",
          (unsigned long long)st.disconnected, gone, st.clients,
          (unsigned long long)st.dropped_slow);
    pl_sink_close(s);
    close(keep);
}

/* pl_sink_close with data still queued for a reader that does not read: bounded in time. */
static void test_close_bounded(void)
{
    int port;
    pl_sink *s = open_tcp(&port);
    if (!s) return;
    int idle = connect_tcp(port, 4096);
    char line[2048];
    pl_sink_stats st;
    uint64_t queued = 0;
    for (int i = 0; i < 2000 && queued < 32768; i++) {
        size_t n = make_line(line, sizeof line, i, 1000);
        CHECK(pl_sink_write(s, line, n) == 0, "write");
        pl_sink_get_stats(s, &st);
        queued = st.lines * n - st.bytes;
    }
    pl_sink_get_stats(s, &st);
    CHECK(queued >= 32768 && st.clients == 1,
          "no queued data (%llu) or the client was dropped (%d)", (unsigned long long)queued,
          st.clients);
    double t0 = now_s();
    pl_sink_close(s);
    double dt = now_s() - t0;
    CHECK(dt >= PL_SINK_CLOSE_MS * 0.9e-3 && dt < 1.0, "close with %llu bytes queued took %.3f s",
          (unsigned long long)queued, dt);
    printf("close with %llu bytes queued for an idle reader: %.0f ms\n", (unsigned long long)queued,
           dt * 1e3);
    close(idle);
}

/* More than PL_SINK_MAX_CLIENTS: the extra ones are closed at once and counted. */
static void test_client_limit(void)
{
    int port;
    pl_sink *s = open_tcp(&port);
    if (!s) return;
    /* in two rounds: the listen backlog (16) would make a 17th blocking connect wait */
    int fds[PL_SINK_MAX_CLIENTS + 2];
    for (int i = 0; i < PL_SINK_MAX_CLIENTS; i++)
        fds[i] = connect_tcp(port, 0);
    CHECK(pl_sink_write(s, "{}\n", 3) == 0, "write");
    for (int i = PL_SINK_MAX_CLIENTS; i < PL_SINK_MAX_CLIENTS + 2; i++)
        fds[i] = connect_tcp(port, 0);
    CHECK(pl_sink_write(s, "{}\n", 3) == 0, "write");
    pl_sink_stats st;
    pl_sink_get_stats(s, &st);
    CHECK(st.clients == PL_SINK_MAX_CLIENTS && st.refused == 2, "clients %d, refused %llu",
          st.clients, (unsigned long long)st.refused);
    /* a refused client is told why, then EOF */
    char got[256] = "";
    size_t n = read_line(fds[PL_SINK_MAX_CLIENTS], got, sizeof got, 3000);
    CHECK(n > 0 &&
              !strcmp(got, "{\"error\":\"refused\",\"reason\":\"16 clients already connected (--max-clients)\"}\n"),
          "refused client read '%s'", got);
    CHECK(read_bytes(fds[PL_SINK_MAX_CLIENTS], got, 1, 3000) == 0, "EOF after the refusal");
    pl_sink_close(s);
    for (int i = 0; i < PL_SINK_MAX_CLIENTS + 2; i++)
        if (fds[i] >= 0) close(fds[i]);
}

/* ---- options: --max-clients, --token-file, --unix-mode ----------------------------------- */

static pl_sink *open_tcp_opts(const pl_sink_options *o, int *port)
{
    pl_sink *s = NULL;
    int rc = pl_sink_open_opts("tcp://127.0.0.1:0", o, &s);
    CHECK(rc == 0, "open tcp with options: %s", pl_last_error());
    *port = s ? addr_port(pl_sink_address(s)) : -1;
    return s;
}

static void test_max_clients(void)
{
    pl_sink_options o = {.max_clients = 2};
    int port;
    pl_sink *s = open_tcp_opts(&o, &port);
    if (!s) return;
    int a = connect_tcp(port, 0), b = connect_tcp(port, 0), c = connect_tcp(port, 0);
    CHECK(pl_sink_write(s, "{\"n\":1}\n", 8) == 0, "write");
    char got[256] = "";
    CHECK(read_line(a, got, sizeof got, 3000) > 0 && !strcmp(got, "{\"n\":1}\n"), "a: '%s'", got);
    CHECK(read_line(b, got, sizeof got, 3000) > 0 && !strcmp(got, "{\"n\":1}\n"), "b: '%s'", got);
    CHECK(read_line(c, got, sizeof got, 3000) > 0 &&
              !strcmp(got, "{\"error\":\"refused\",\"reason\":\"2 clients already connected (--max-clients)\"}\n"),
          "c: '%s'", got);
    pl_sink_stats st;
    pl_sink_get_stats(s, &st);
    CHECK(st.clients == 2 && st.refused == 1, "clients %d, refused %llu", st.clients,
          (unsigned long long)st.refused);
    pl_sink_close(s);
    close(a);
    close(b);
    close(c);

    /* bad options are refused at open, naming the problem */
    pl_sink_options bad[] = {{.max_clients = -1},
                             {.max_clients = PL_SINK_CLIENTS_LIMIT + 1},
                             {.unix_mode = 01777},
                             {.token_ms = -5},
                             {.token = "a\tb"}};
    const char *what[] = {"max clients", "max clients", "socket mode", "token wait",
                          "control character"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        pl_sink *x = NULL;
        int rc = pl_sink_open_opts("tcp://127.0.0.1:0", &bad[i], &x);
        CHECK(rc == PL_E_ARG && x == NULL && strstr(pl_last_error(), what[i]),
              "bad option %zu: rc %d '%s'", i, rc, pl_last_error());
        pl_sink_close(x);
    }
    char long_token[PL_SINK_TOKEN_MAX + 2];
    memset(long_token, 'k', sizeof long_token - 1);
    long_token[sizeof long_token - 1] = '\0';
    pl_sink_options lt = {.token = long_token};
    pl_sink *x = NULL;
    CHECK(pl_sink_open_opts("tcp://127.0.0.1:0", &lt, &x) == PL_E_ARG && !x, "long token");
}

static void test_token(void)
{
    pl_sink_options o = {.token = "s3cret-Token", .token_ms = 500};
    int port;
    pl_sink *s = open_tcp_opts(&o, &port);
    if (!s) return;
    int good = connect_tcp(port, 0), crlf = connect_tcp(port, 0), wrong = connect_tcp(port, 0),
        silent = connect_tcp(port, 0), prefix = connect_tcp(port, 0);
    CHECK(pl_sink_write(s, "{\"n\":0}\n", 8) == 0, "write 0"); /* accepts all five */
    CHECK(send(good, "s3cret-Token\n", 13, 0) == 13, "send token");
    CHECK(send(crlf, "s3cret-Token\r\nextra", 20, 0) == 20, "send token CRLF");
    CHECK(send(wrong, "s3cret-Tokem\n", 13, 0) == 13, "send wrong token");
    CHECK(send(prefix, "s3cret\n", 7, 0) == 7, "send a prefix of the token");
    /* the server reads them at its next writes; poll until the two are admitted */
    pl_sink_stats st;
    for (int k = 0; k < 200; k++) {
        struct timespec ts = {0, 5000000};
        nanosleep(&ts, NULL);
        CHECK(pl_sink_write(s, "{\"n\":1}\n", 8) == 0, "write 1");
        pl_sink_get_stats(s, &st);
        if (st.unauthorized >= 2 && st.clients == 3) break;
    }
    char got[256] = "";
    /* admitted clients see lines written after their token, never the ones before */
    CHECK(read_line(good, got, sizeof got, 3000) > 0 && !strcmp(got, "{\"n\":1}\n"), "good: '%s'",
          got);
    CHECK(read_line(crlf, got, sizeof got, 3000) > 0 && !strcmp(got, "{\"n\":1}\n"), "crlf: '%s'",
          got);
    CHECK(read_line(wrong, got, sizeof got, 3000) > 0 &&
              !strcmp(got, "{\"error\":\"refused\",\"reason\":\"wrong token\"}\n"),
          "wrong: '%s'", got);
    CHECK(read_line(prefix, got, sizeof got, 3000) > 0 &&
              !strcmp(got, "{\"error\":\"refused\",\"reason\":\"wrong token\"}\n"),
          "prefix: '%s'", got);
    /* the silent one is turned away once its 500 ms are up, and got nothing before */
    struct timespec ts = {0, 600000000};
    nanosleep(&ts, NULL);
    CHECK(pl_sink_write(s, "{\"n\":2}\n", 8) == 0, "write 2");
    CHECK(read_line(silent, got, sizeof got, 3000) > 0 &&
              !strcmp(got, "{\"error\":\"refused\",\"reason\":\"no token within 500 ms\"}\n"),
          "silent: '%s'", got);
    pl_sink_get_stats(s, &st);
    CHECK(st.unauthorized == 3 && st.clients == 2, "unauthorized %llu, clients %d",
          (unsigned long long)st.unauthorized, st.clients);
    int connected = 0, slow = 0, gone = 0, refused = 0;
    char msg[PL_SINK_EVENT_MAX];
    while (pl_sink_next_event(s, msg, sizeof msg)) {
        if (strstr(msg, "waiting for its token")) connected++;
        if (strstr(msg, "refused: wrong token") || strstr(msg, "refused: no token")) refused++;
        if (strstr(msg, "slow")) slow++;
        if (strstr(msg, "disconnected")) gone++;
    }
    CHECK(connected == 5 && refused == 3 && slow == 0, "events: %d connected, %d refused, %d slow",
          connected, refused, slow);
    pl_sink_close(s);
    close(good);
    close(crlf);
    close(wrong);
    close(silent);
    close(prefix);
}

/* ---- stdout -------------------------------------------------------------------------- */

static void test_stdout_epipe(void)
{
    signal(SIGPIPE, SIG_DFL);
    fflush(stdout);
    int saved = dup(1), p[2];
    CHECK(saved >= 0 && pipe(p) == 0, "pipe");
    dup2(p[1], 1);
    close(p[1]);
    close(p[0]); /* nobody will read */
    pl_sink *s = NULL;
    int rc = pl_sink_open("-", &s), wrc = 0;
    if (s) wrc = pl_sink_write(s, "{\"frame\":0}\n", 12);
    char msg[512];
    snprintf(msg, sizeof msg, "%s", pl_last_error());
    if (s) pl_sink_close(s);
    fflush(stdout);
    clearerr(stdout);
    dup2(saved, 1);
    close(saved);
    CHECK(rc == 0, "open stdout");
    CHECK(wrc == PL_E_IO && strstr(msg, "EPIPE"), "stdout into a closed pipe: rc %d (%s)", wrc,
          msg);
    sigset_t pending;
    sigpending(&pending);
    CHECK(!sigismember(&pending, SIGPIPE), "a SIGPIPE was left pending");

    /* and into a working pipe */
    fflush(stdout);
    saved = dup(1);
    CHECK(pipe(p) == 0, "pipe");
    dup2(p[1], 1);
    close(p[1]);
    rc = pl_sink_open("stdout", &s);
    wrc = s ? pl_sink_write(s, "{\"frame\":1}\n", 12) : -1;
    if (s) pl_sink_close(s);
    dup2(saved, 1);
    close(saved);
    char got[64] = "";
    ssize_t n = read(p[0], got, sizeof got - 1);
    close(p[0]);
    CHECK(rc == 0 && wrc == 0 && n == 12 && !memcmp(got, "{\"frame\":1}\n", 12), "stdout line: %zd",
          n);
}

/* ---- unix ---------------------------------------------------------------------------- */

static int bind_unix(const char *path, int do_listen)
{
    int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    struct sockaddr_un sa;
    memset(&sa, 0, sizeof sa);
    sa.sun_family = AF_UNIX;
    snprintf(sa.sun_path, sizeof sa.sun_path, "%s", path);
    if (fd < 0 || bind(fd, (struct sockaddr *)&sa, sizeof sa) < 0) return -1;
    if (do_listen && listen(fd, 4) < 0) return -1;
    return fd;
}

static void test_unix(void)
{
    char path[600], spec[700];
    snprintf(path, sizeof path, "%s/s.sock", tmpdir);
    if (strlen(path) >= sizeof(((struct sockaddr_un *)0)->sun_path)) {
        printf("unix tests: scratch path too long, using /tmp\n");
        snprintf(path, sizeof path, "/tmp/pl-sink-%d.sock", (int)getpid());
    }
    snprintf(spec, sizeof spec, "unix:%s", path);
    unlink(path);

    pl_sink *s = NULL;
    CHECK(pl_sink_open(spec, &s) == 0, "open %s: %s", spec, pl_last_error());
    if (!s) return;
    struct stat st;
    CHECK(lstat(path, &st) == 0 && S_ISSOCK(st.st_mode), "no socket at %s", path);
    CHECK((st.st_mode & 0777) == 0600, "default socket mode %o, expected 600 (owner only)",
          (unsigned)(st.st_mode & 0777));
    int c = connect_unix(path);
    CHECK(c >= 0, "connect %s: %s", path, strerror(errno));
    char line[256], expect[4096], got[4096];
    size_t total = 0;
    for (int i = 0; i < 20; i++) {
        size_t n = make_line(line, sizeof line, i, 30);
        memcpy(expect + total, line, n);
        total += n;
        CHECK(pl_sink_write(s, line, n) == 0, "write: %s", pl_last_error());
    }
    CHECK(read_bytes(c, got, total, 3000) == total && !memcmp(got, expect, total),
          "unix round trip");
    /* a second server on the same live path: in use, and the file stays */
    pl_sink *s2 = NULL;
    int rc = pl_sink_open(spec, &s2);
    CHECK(rc == PL_E_DEVICE && strstr(pl_last_error(), "in use"), "live socket: rc %d (%s)", rc,
          pl_last_error());
    if (s2) pl_sink_close(s2);
    pl_sink_close(s);
    CHECK(lstat(path, &st) < 0 && errno == ENOENT, "socket file left after close");
    close(c);

    /* a stale socket (bound, closed, never unlinked) is replaced */
    int fd = bind_unix(path, 0);
    CHECK(fd >= 0, "stale socket");
    close(fd);
    CHECK(lstat(path, &st) == 0 && S_ISSOCK(st.st_mode), "stale socket file");
    rc = pl_sink_open(spec, &s);
    CHECK(rc == 0, "stale socket not replaced: %s", pl_last_error());
    if (s) {
        c = connect_unix(path);
        CHECK(c >= 0 && pl_sink_write(s, "{}\n", 3) == 0 && read_bytes(c, got, 3, 2000) == 3,
              "stream after replacing a stale socket");
        if (c >= 0) close(c);
        pl_sink_close(s);
    }

    /* another program's live socket is not touched */
    fd = bind_unix(path, 1);
    CHECK(fd >= 0, "live socket");
    rc = pl_sink_open(spec, &s);
    CHECK(rc == PL_E_DEVICE && strstr(pl_last_error(), "in use"), "live foreign socket: %d (%s)",
          rc, pl_last_error());
    CHECK(lstat(path, &st) == 0 && S_ISSOCK(st.st_mode), "live socket removed");
    close(fd);
    unlink(path);

    /* a regular file is never replaced */
    FILE *f = fopen(path, "w");
    if (f) {
        fputs("precious\n", f);
        fclose(f);
    }
    rc = pl_sink_open(spec, &s);
    CHECK(rc == PL_E_IO && strstr(pl_last_error(), "not a socket") && strstr(pl_last_error(), spec),
          "regular file: rc %d (%s)", rc, pl_last_error());
    CHECK(lstat(path, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 9, "regular file changed");
    unlink(path);

    /* --unix-mode: the file is created with the bits asked for, whatever the umask */
    mode_t old_mask = umask(0);
    pl_sink_options o = {.unix_mode = 0660};
    rc = pl_sink_open_opts(spec, &o, &s);
    CHECK(rc == 0 && lstat(path, &st) == 0 && (st.st_mode & 0777) == 0660,
          "unix_mode 0660 under umask 0: rc %d, mode %o", rc, (unsigned)(st.st_mode & 0777));
    umask(old_mask);
    mode_t cur = umask(0);
    umask(cur);
    CHECK(cur == old_mask, "the umask is restored after open (%o, was %o)", (unsigned)cur,
          (unsigned)old_mask);
    pl_sink_close(s);

    /* a directory that does not exist */
    rc = pl_sink_open("unix:/nonexistent-dir-parlight/x.sock", &s);
    CHECK(rc < 0 && strstr(pl_last_error(), "/nonexistent-dir-parlight/x.sock"),
          "missing directory: rc %d (%s)", rc, pl_last_error());
}

/* ---- several sinks ------------------------------------------------------------------------ */

static void test_sinks(void)
{
    int rx = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    socklen_t sl = sizeof sa;
    bind(rx, (struct sockaddr *)&sa, sizeof sa);
    getsockname(rx, (struct sockaddr *)&sa, &sl);
    char udp[64];
    snprintf(udp, sizeof udp, "udp://127.0.0.1:%d", ntohs(sa.sin_port));
    const char *specs[] = {udp, "tcp://:0"};
    pl_sinks *m = NULL;
    CHECK(pl_sinks_open(specs, 2, NULL, &m) == 0, "open 2 sinks: %s", pl_last_error());
    if (!m) return;
    CHECK(pl_sinks_count(m) == 2, "count");
    pl_sink *tcp = pl_sinks_get(m, 1);
    CHECK(tcp && !strncmp(pl_sink_address(tcp), "127.0.0.1:", 10),
          "tcp://:0 listens on loopback: %s", tcp ? pl_sink_address(tcp) : "");
    int c = tcp ? connect_tcp(addr_port(pl_sink_address(tcp)), 0) : -1;
    CHECK(pl_sinks_write(m, "{\"frame\":7}\n", 12) == 0, "write: %s", pl_last_error());
    char got[64];
    struct pollfd pf = {rx, POLLIN, 0};
    CHECK(poll(&pf, 1, 2000) == 1 && recv(rx, got, sizeof got, 0) == 12, "udp got the line");
    CHECK(read_bytes(c, got, 12, 2000) == 12 && !memcmp(got, "{\"frame\":7}\n", 12),
          "tcp got the line");
    char msg[PL_SINK_EVENT_MAX];
    int events = 0;
    while (pl_sinks_next_event(m, msg, sizeof msg))
        events++;
    CHECK(events == 1, "%d events (one client connected)", events);
    /* one sink rejects a line: the others still get it, the error names the failing one */
    CHECK(pl_sinks_write(m, "x", 1) == PL_E_ARG, "bad line");
    pl_sinks_close(m);
    if (c >= 0) close(c);
    close(rx);

    const char *dup2_specs[] = {"tcp://:0", "tcp://:0"};
    CHECK(pl_sinks_open(dup2_specs, 2, NULL, &m) == PL_E_ARG && strstr(pl_last_error(), "twice"),
          "duplicate spec: %s", pl_last_error());
    const char *bad_specs[] = {"tcp://:0", "udp://:bad"};
    CHECK(pl_sinks_open(bad_specs, 2, NULL, &m) == PL_E_ARG &&
              strstr(pl_last_error(), "udp://:bad") && !m,
          "second spec bad: %s", pl_last_error());
    CHECK(pl_sinks_open(NULL, 0, NULL, &m) == 0 && pl_sinks_count(m) == 1 &&
              !strcmp(pl_sink_spec(pl_sinks_get(m, 0)), "stdout"),
          "no spec: stdout");
    pl_sinks_close(m);
    CHECK(pl_sinks_open(specs, PL_SINKS_MAX + 1, NULL, &m) == PL_E_ARG, "too many sinks");
}

/* IPv6 loopback, where the machine has it. */
static void test_ipv6(void)
{
    pl_sink *s = NULL;
    int rc = pl_sink_open("tcp://[::1]:0", &s);
    if (rc < 0) {
        printf("no IPv6 loopback here (%s): skipping the [::1] case\n", pl_last_error());
        CHECK(rc == PL_E_DEVICE, "[::1]: rc %d", rc);
        return;
    }
    CHECK(!strncmp(pl_sink_address(s), "[::1]:", 6), "address %s", pl_sink_address(s));
    pl_sink_close(s);
}

#define RUN(f) (printf("-- %s\n", #f), fflush(stdout), f())

int main(void)
{
    alarm(120); /* whatever happens, never hang */
    const char *t = getenv("PL_TEST_TMP");
    snprintf(tmpdir, sizeof tmpdir, "%s", t && *t ? t : "/tmp");
    RUN(test_malformed_specs);
    RUN(test_udp);
    RUN(test_tcp_two_clients);
    RUN(test_tcp_slow_client);
    RUN(test_tcp_disconnect);
    RUN(test_close_bounded);
    RUN(test_client_limit);
    RUN(test_max_clients);
    RUN(test_token);
    RUN(test_stdout_epipe);
    RUN(test_unix);
    RUN(test_sinks);
    RUN(test_ipv6);
    if (failures) {
        printf("%d failure(s)\n", failures);
        return 1;
    }
    printf("sink: all passed\n");
    return 0;
}
