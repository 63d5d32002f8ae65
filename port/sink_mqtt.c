/* The mqtt:// sink (port/sink.h): every line is published, retained, to one topic on a broker,
 * with libmosquitto driven from the caller's thread: each write (and pl_sink_service) runs
 * mosquitto_loop with a zero timeout, the connection is opened with mosquitto_connect_async (a
 * non-blocking connect) and opened again after a loss with a doubling backoff. The pipeline
 * never waits for the broker: a line that finds no connection, or too many messages still in
 * flight, is dropped and counted. */
#include <errno.h>
#include <netdb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "core/util.h"
#include "port/sink_internal.h"

#ifdef PL_HAVE_MOSQUITTO
#include <mosquitto.h>

#define CLIENT_ID_MAX 64

typedef struct sink_mqtt {
    struct mosquitto *mosq;
    char topic[PL_SINK_SPEC_MAX + 1];
    char host[256]; /* what libmosquitto connects to: numeric, or the name with TLS */
    int port, qos;
    int started;   /* mosquitto_connect_async done once: later attempts reconnect */
    int attempt;   /* a socket exists (connecting or connected) */
    int connected; /* CONNACK accepted */
    int lost;      /* on_disconnect ran since the last step */
    int lost_rc;
    int lost_errno;
    int refused;  /* on_connect reported a refusal: the disconnection that follows is not news */
    int inflight; /* published, not yet written (QoS 0) or acknowledged (QoS 1) */
    int backoff_ms;
    int64_t next_try_ns;
    uint64_t dropped_since; /* lines dropped since the last connection */
    char last_fail[160];    /* the last failure reported, not repeated while it lasts */
    int lib_init;
} sink_mqtt;

static void on_connect(struct mosquitto *mosq, void *obj, int rc)
{
    (void)mosq;
    pl_sink *s = obj;
    sink_mqtt *m = s->impl;
    if (rc != 0) { /* refused (bad login, id): the broker closes, on_disconnect follows */
        char why[160];
        char reason[96];
        snprintf(reason, sizeof reason, "%s", mosquitto_connack_string(rc));
        size_t n = strlen(reason);
        if (n > 0 && reason[n - 1] == '.') reason[n - 1] = '\0';
        snprintf(why, sizeof why, "the broker refused the connection: %s", reason);
        if (strcmp(why, m->last_fail)) sink_event(s, "%s", why);
        snprintf(m->last_fail, sizeof m->last_fail, "%s", why);
        m->refused = 1;
        return;
    }
    m->connected = 1;
    m->backoff_ms = PL_SINK_MQTT_RETRY_MIN_MS;
    m->last_fail[0] = '\0';
    s->stats.connects++;
    if (s->stats.connects == 1)
        sink_event(s, "connected to the broker at %s", s->address);
    else
        sink_event(s, "connected again to the broker at %s (%llu line%s dropped meanwhile)",
                   s->address, (unsigned long long)m->dropped_since,
                   m->dropped_since == 1 ? "" : "s");
    m->dropped_since = 0;
}

static void on_disconnect(struct mosquitto *mosq, void *obj, int rc)
{
    (void)mosq;
    pl_sink *s = obj;
    sink_mqtt *m = s->impl;
    m->lost = 1;
    m->lost_rc = rc;
    m->lost_errno = errno;
}

static void on_publish(struct mosquitto *mosq, void *obj, int mid)
{
    (void)mosq;
    (void)mid;
    pl_sink *s = obj;
    sink_mqtt *m = s->impl;
    if (m->inflight > 0) m->inflight--;
}

/* libmosquitto's reason for rc, without its closing full stop (it goes inside our sentences). */
static const char *mosq_reason(int rc, int err, char *buf, size_t cap)
{
    snprintf(buf, cap, "%s", rc == MOSQ_ERR_ERRNO && err ? strerror(err) : mosquitto_strerror(rc));
    size_t n = strlen(buf);
    if (n > 0 && buf[n - 1] == '.') buf[n - 1] = '\0';
    return buf;
}

/* The connection (or the attempt) is over: try again after the backoff, say so once. */
static void connection_over(pl_sink *s, sink_mqtt *m, const char *why)
{
    char msg[200];
    if (m->connected)
        snprintf(msg, sizeof msg, "lost the broker at %s: %s; connecting again in %d ms",
                 s->address, why, m->backoff_ms);
    else
        snprintf(msg, sizeof msg, "cannot connect to the broker at %s: %s; trying again",
                 s->address, why);
    if (m->refused)
        m->refused = 0; /* on_connect said why */
    else {
        if (m->connected || strcmp(why, m->last_fail)) sink_event(s, "%s", msg);
        snprintf(m->last_fail, sizeof m->last_fail, "%s", why);
    }
    m->connected = 0;
    m->attempt = 0;
    m->lost = 0;
    if (m->qos == 0) m->inflight = 0; /* QoS 1 messages are sent again after reconnecting */
    m->next_try_ns = pl_now_ns() + (int64_t)m->backoff_ms * 1000000;
    m->backoff_ms = m->backoff_ms * 2 > PL_SINK_MQTT_RETRY_MAX_MS ? PL_SINK_MQTT_RETRY_MAX_MS
                                                                  : m->backoff_ms * 2;
}

/* Starts a connection when it is time, then runs the network loop once without waiting. */
static void mqtt_step(pl_sink *s, sink_mqtt *m)
{
    if (!m->attempt && pl_now_ns() >= m->next_try_ns) {
        errno = 0;
        int rc = m->started
                     ? mosquitto_reconnect_async(m->mosq)
                     : mosquitto_connect_async(m->mosq, m->host, m->port, PL_SINK_MQTT_KEEPALIVE_S);
        int err = errno;
        m->started = 1;
        if (rc != MOSQ_ERR_SUCCESS) {
            char why[128];
            connection_over(s, m, mosq_reason(rc, err, why, sizeof why));
            return;
        }
        m->attempt = 1;
        m->lost = 0;
    }
    if (!m->attempt) return;
    errno = 0;
    int rc = mosquitto_loop(m->mosq, 0, 1);
    int err = errno;
    if (m->lost || rc != MOSQ_ERR_SUCCESS || mosquitto_socket(m->mosq) < 0) {
        char why[160];
        if (m->lost && m->lost_rc)
            mosq_reason(m->lost_rc, m->lost_errno, why, sizeof why);
        else if (rc != MOSQ_ERR_SUCCESS)
            mosq_reason(rc, err, why, sizeof why);
        else
            snprintf(why, sizeof why, "the connection closed");
        connection_over(s, m, why);
    }
}

static int client_id_ok(const char *id)
{
    size_t n = strlen(id);
    if (n == 0 || n > CLIENT_ID_MAX) return 0;
    for (size_t i = 0; i < n; i++) {
        char c = id[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') ||
              c == '-' || c == '_' || c == '.'))
            return 0;
    }
    return 1;
}

static int file_readable(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    fclose(f);
    return 1;
}

int sink_mqtt_open(pl_sink *s, const sink_spec *sp, const pl_sink_options *opts)
{
    static const pl_sink_options defaults = {0};
    const pl_sink_options *o = opts ? opts : &defaults;
    sink_mqtt *m = calloc(1, sizeof *m);
    if (!m) return pl_error(PL_E_NOMEM, "sink '%s': out of memory", s->spec);
    s->impl = m;
    snprintf(m->topic, sizeof m->topic, "%s", sp->resource);
    m->port = sp->port;
    m->qos = o->mqtt_qos;
    m->backoff_ms = PL_SINK_MQTT_RETRY_MIN_MS;
    if (m->qos != 0 && m->qos != 1)
        return pl_error(PL_E_ARG, "sink '%s': QoS %d: expected 0 or 1 (--mqtt-qos)", s->spec,
                        m->qos);
    const int tls = o->mqtt_ca_file && o->mqtt_ca_file[0];
    const int cert = o->mqtt_cert_file && o->mqtt_cert_file[0];
    const int key = o->mqtt_key_file && o->mqtt_key_file[0];
    if (cert != key)
        return pl_error(PL_E_ARG,
                        "sink '%s': a client certificate needs both --mqtt-cert and "
                        "--mqtt-key",
                        s->spec);
    if (cert && !tls)
        return pl_error(PL_E_ARG, "sink '%s': --mqtt-cert and --mqtt-key need --mqtt-ca (TLS)",
                        s->spec);
    const char *files[3] = {o->mqtt_ca_file, o->mqtt_cert_file, o->mqtt_key_file};
    static const char *const flags[3] = {"--mqtt-ca", "--mqtt-cert", "--mqtt-key"};
    for (int i = 0; i < 3; i++)
        if (files[i] && files[i][0] && !file_readable(files[i]))
            return pl_error(PL_E_IO, "sink '%s': %s %s: %s", s->spec, flags[i], files[i],
                            strerror(errno));
    if (o->mqtt_password && o->mqtt_password[0] && !(o->mqtt_username && o->mqtt_username[0]))
        return pl_error(PL_E_ARG, "sink '%s': a password needs a user name (--mqtt-user)", s->spec);
    char id[CLIENT_ID_MAX + 1];
    if (o->mqtt_client_id && o->mqtt_client_id[0]) {
        if (!client_id_ok(o->mqtt_client_id))
            return pl_error(PL_E_ARG,
                            "sink '%s': client id '%.80s': expected 1..%d of letters, digits, "
                            "'-', '_', '.'",
                            s->spec, o->mqtt_client_id, CLIENT_ID_MAX);
        snprintf(id, sizeof id, "%s", o->mqtt_client_id);
    } else {
        snprintf(id, sizeof id, "parlight-%ld", (long)getpid());
    }

    /* resolved once here, like udp://, so that a wrong name fails at start and a reconnection
     * never waits for DNS; with TLS, libmosquitto needs the name to check the certificate */
    struct addrinfo *res = NULL;
    int rc = sink_resolve(s->spec, sp, SOCK_STREAM, &res);
    if (rc < 0) return rc;
    sink_format_addr(res->ai_addr, s->address, sizeof s->address);
    if (tls) {
        snprintf(m->host, sizeof m->host, "%s", sp->host);
    } else {
        char *colon = strrchr(s->address, ':'); /* "1.2.3.4:p" or "[::1]:p": the bare address */
        size_t n = colon ? (size_t)(colon - s->address) : 0;
        const char *a = s->address;
        if (n >= 2 && a[0] == '[') {
            a++;
            n -= 2;
        }
        snprintf(m->host, sizeof m->host, "%.*s", (int)n, a);
    }
    freeaddrinfo(res);

    mosquitto_lib_init();
    m->lib_init = 1;
    m->mosq = mosquitto_new(id, true, s);
    if (!m->mosq)
        return pl_error(PL_E_NOMEM, "sink '%s': cannot create the MQTT client: %s", s->spec,
                        strerror(errno));
    mosquitto_connect_callback_set(m->mosq, on_connect);
    mosquitto_disconnect_callback_set(m->mosq, on_disconnect);
    mosquitto_publish_callback_set(m->mosq, on_publish);
    (void)mosquitto_int_option(m->mosq, MOSQ_OPT_TCP_NODELAY, 1);
    if (o->mqtt_username && o->mqtt_username[0] &&
        (rc = mosquitto_username_pw_set(m->mosq, o->mqtt_username, o->mqtt_password)) != 0)
        return pl_error(PL_E_ARG, "sink '%s': user name or password: %s", s->spec,
                        mosquitto_strerror(rc));
    if (tls &&
        (rc = mosquitto_tls_set(m->mosq, o->mqtt_ca_file, NULL, cert ? o->mqtt_cert_file : NULL,
                                key ? o->mqtt_key_file : NULL, NULL)) != 0)
        return pl_error(PL_E_ARG, "sink '%s': TLS files (--mqtt-ca, --mqtt-cert, --mqtt-key): %s",
                        s->spec, mosquitto_strerror(rc));
    mqtt_step(s, m); /* the first attempt starts now; its result comes in later calls */
    return 0;
}

int sink_mqtt_write(pl_sink *s, const char *line, size_t len)
{
    sink_mqtt *m = s->impl;
    mqtt_step(s, m);
    s->stats.lines++;
    if (!m->connected || m->inflight >= PL_SINK_MQTT_INFLIGHT) {
        s->stats.lines_dropped++;
        m->dropped_since++;
        return 0;
    }
    m->inflight++; /* before: a QoS 0 message written at once calls on_publish inside */
    errno = 0;
    int rc = mosquitto_publish(m->mosq, NULL, m->topic, (int)(len - 1), line, m->qos, true);
    int err = errno;
    if (rc == MOSQ_ERR_SUCCESS) {
        s->stats.bytes += len - 1;
        return 0;
    }
    if (m->inflight > 0) m->inflight--;
    char why[128];
    mosq_reason(rc, err, why, sizeof why);
    if (rc == MOSQ_ERR_NO_CONN || rc == MOSQ_ERR_CONN_LOST || rc == MOSQ_ERR_ERRNO) {
        s->stats.lines_dropped++;
        m->dropped_since++;
        connection_over(s, m, why);
        return 0;
    }
    s->stats.lines--;
    s->stats.lines_failed++;
    return pl_error(PL_E_DEVICE, "sink '%s': publish failed: %s", s->spec, why);
}

int sink_mqtt_service(pl_sink *s)
{
    mqtt_step(s, s->impl);
    return 0;
}

void sink_mqtt_close(pl_sink *s)
{
    sink_mqtt *m = s->impl;
    if (!m) return;
    if (m->mosq) {
        /* what is still unsent or unacknowledged gets PL_SINK_CLOSE_MS, then a clean goodbye */
        const int64_t deadline = pl_now_ns() + (int64_t)PL_SINK_CLOSE_MS * 1000000;
        while (m->connected && m->inflight > 0 && pl_now_ns() < deadline) {
            mqtt_step(s, m);
            struct timespec ts = {0, 2000000};
            nanosleep(&ts, NULL);
        }
        if (m->connected) {
            mosquitto_disconnect(m->mosq);
            (void)mosquitto_loop(m->mosq, 0, 1);
        }
        mosquitto_destroy(m->mosq);
    }
    if (m->lib_init) mosquitto_lib_cleanup();
    free(m);
    s->impl = NULL;
}

#else /* no libmosquitto */

int sink_mqtt_open(pl_sink *s, const sink_spec *sp, const pl_sink_options *opts)
{
    (void)sp;
    (void)opts;
    return pl_error(PL_E_UNSUPPORTED,
                    "sink '%s': mqtt:// needs libmosquitto, which this build does not have "
                    "(tools/install-deps.sh installs libmosquitto-dev; then rebuild)",
                    s->spec);
}

int sink_mqtt_write(pl_sink *s, const char *line, size_t len)
{
    (void)line;
    (void)len;
    return pl_error(PL_E_UNSUPPORTED, "sink '%s': no libmosquitto in this build", s->spec);
}

int sink_mqtt_service(pl_sink *s)
{
    (void)s;
    return 0;
}

void sink_mqtt_close(pl_sink *s)
{
    (void)s;
}

#endif
