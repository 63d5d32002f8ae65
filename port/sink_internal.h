/* Shared by port/sink.c (specs, stdout, udp, several sinks), port/sink_server.c (the tcp and
 * unix stream servers, the access options), port/sink_ws.c (WebSocket server, libwebsockets),
 * port/sink_mqtt.c (MQTT publisher, libmosquitto) and port/sink_event.c (the event queue,
 * addresses). Not part of any public interface. */
#ifndef PL_PORT_SINK_INTERNAL_H
#define PL_PORT_SINK_INTERNAL_H

#include <netdb.h>
#include <poll.h>
#include <stdint.h>
#include <sys/socket.h>
#include <sys/types.h>
#include <sys/un.h>

#include "port/sink.h"

typedef enum sink_kind { SINK_STDOUT, SINK_UDP, SINK_TCP, SINK_UNIX, SINK_WS, SINK_MQTT } sink_kind;

#define SINK_EVENTS 32

/* One connected reader of a stream server. Its queue holds buf[off .. off + len). */
typedef struct sink_client {
    int fd;        /* -1: free slot */
    uint64_t id;   /* 1, 2, ... in accept order */
    char peer[64]; /* "127.0.0.1:51234", "[::1]:40000" or "unix" */
    char *buf;     /* PL_SINK_QUEUE_BYTES, allocated at accept */
    size_t off, len;
    int read_closed; /* the client shut its sending side: stop polling for input */
    int pending;     /* waiting for the token: receives nothing yet */
    int64_t token_deadline_ns;
    size_t tok_len; /* bytes of the token line received so far (in tok) */
    char tok[PL_SINK_TOKEN_MAX + 2];
} sink_client;

struct pl_sink {
    sink_kind kind;
    char spec[PL_SINK_SPEC_MAX + 1];
    char address[sizeof(((struct sockaddr_un *)0)->sun_path) + 8];
    int fd; /* udp socket or listening socket; -1 for stdout */
    pl_sink_stats stats;

    char events[SINK_EVENTS][PL_SINK_EVENT_MAX];
    int ev_head, ev_count;
    uint64_t ev_lost;

    /* stream servers */
    sink_client *clients; /* max_clients slots */
    struct pollfd *pf;    /* max_clients entries, scratch for poll */
    int *pf_idx;          /* client index of each pf entry */
    int max_clients;
    unsigned unix_mode;
    char token[PL_SINK_TOKEN_MAX + 1]; /* "" = none */
    int token_ms;
    uint64_t next_client_id;
    int last_accept_errno;
    char unix_path[sizeof(((struct sockaddr_un *)0)->sun_path)];
    int unix_owned; /* we created unix_path: unlink it on close if still ours */
    dev_t unix_dev;
    ino_t unix_ino;

    void *impl; /* ws (struct sink_ws) or mqtt (struct sink_mqtt) state */
};

/* A parsed spec. host is "" only for stdout/unix; an empty HOST in the spec becomes 127.0.0.1. */
typedef struct sink_spec {
    sink_kind kind;
    char host[256];
    int port;
    int host_numeric; /* an IPv4 or IPv6 literal: resolve without DNS */
    char path[sizeof(((struct sockaddr_un *)0)->sun_path)];
    char resource[PL_SINK_SPEC_MAX + 1]; /* ws: the path ("/" if none); mqtt: the topic */
} sink_spec;

/* Queues "<spec>: <message>" for pl_sink_next_event (port/sink_event.c). */
void sink_event(pl_sink *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Takes the access options (max_clients, unix_mode, token) into s (PL_E_ARG naming the option). */
int sink_access_init(pl_sink *s, const pl_sink_options *opts);
/* Equal in time independent of where the first difference is (token compare, at most
 * PL_SINK_TOKEN_MAX bytes looked at). */
int sink_same_secret(const char *a, size_t na, const char *b, size_t nb);
/* {"error":"refused","reason":"<reason>"} with '\n' into out; returns its length without the
 * '\n' (the reason is parlight's own text, without quotes). */
size_t sink_refusal_json(char *out, size_t cap, const char *reason);

/* sink_access_init, then allocates the client slots (PL_E_ARG / PL_E_NOMEM). */
int sink_server_init(pl_sink *s, const pl_sink_options *opts);
/* getaddrinfo of the spec's HOST:PORT for `socktype`; PL_E_DEVICE naming the spec (port/sink.c).
 * *res is the caller's (freeaddrinfo). */
int sink_resolve(const char *spec, const sink_spec *sp, int socktype, struct addrinfo **res);
/* The next pending connection on the listening socket (non-blocking, close-on-exec, its
 * address in *ss), or -1 when there is none now or accept failed (reported once per errno as an
 * event). Shared by the tcp/unix servers and the ws sink (port/sink_server.c). */
int sink_accept(pl_sink *s, struct sockaddr_storage *ss);
int sink_server_open_tcp(pl_sink *s, const sink_spec *sp);
int sink_server_open_unix(pl_sink *s, const sink_spec *sp);
int sink_server_write(pl_sink *s, const char *line, size_t len);
/* Accepts and services clients; returns the admitted ones (pl_sink_service). */
int sink_server_service(pl_sink *s);
/* Flushes, closes every socket, unlinks an owned Unix socket, frees the slots. Safe on a sink
 * whose open failed part way. */
void sink_server_close(pl_sink *s);

/* ws:// (port/sink_ws.c). Without libwebsockets, open is PL_E_UNSUPPORTED saying so. The listening
 * socket is sink_server_open_tcp's (same HOST rules); ws_close is safe after a failed open. */
int sink_ws_open(pl_sink *s, const sink_spec *sp, const pl_sink_options *opts);
int sink_ws_write(pl_sink *s, const char *line, size_t len);
int sink_ws_service(pl_sink *s);
void sink_ws_close(pl_sink *s);

/* mqtt:// (port/sink_mqtt.c). Without libmosquitto, open is PL_E_UNSUPPORTED saying so. */
int sink_mqtt_open(pl_sink *s, const sink_spec *sp, const pl_sink_options *opts);
int sink_mqtt_write(pl_sink *s, const char *line, size_t len);
int sink_mqtt_service(pl_sink *s);
void sink_mqtt_close(pl_sink *s);

/* "1.2.3.4:5" / "[::1]:5" for an IPv4/IPv6 socket address (port/sink_event.c). */
void sink_format_addr(const void *sockaddr, char *out, size_t cap);

#endif
