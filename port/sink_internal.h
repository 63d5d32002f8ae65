/* Shared by port/sink.c (specs, stdout, udp, several sinks), port/sink_server.c (the tcp and
 * unix stream servers) and port/sink_event.c (the event queue, addresses). Not part of any
 * public interface. */
#ifndef PL_PORT_SINK_INTERNAL_H
#define PL_PORT_SINK_INTERNAL_H

#include <poll.h>
#include <stdint.h>
#include <sys/types.h>
#include <sys/un.h>

#include "port/sink.h"

typedef enum sink_kind { SINK_STDOUT, SINK_UDP, SINK_TCP, SINK_UNIX } sink_kind;

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
};

/* A parsed spec. host is "" only for stdout/unix; an empty HOST in the spec becomes 127.0.0.1. */
typedef struct sink_spec {
    sink_kind kind;
    char host[256];
    int port;
    int host_numeric; /* an IPv4 or IPv6 literal: resolve without DNS */
    char path[sizeof(((struct sockaddr_un *)0)->sun_path)];
} sink_spec;

/* Queues "<spec>: <message>" for pl_sink_next_event (port/sink_event.c). */
void sink_event(pl_sink *s, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* Takes the options into s and allocates the client slots (PL_E_ARG / PL_E_NOMEM). */
int sink_server_init(pl_sink *s, const pl_sink_options *opts);
int sink_server_open_tcp(pl_sink *s, const sink_spec *sp);
int sink_server_open_unix(pl_sink *s, const sink_spec *sp);
int sink_server_write(pl_sink *s, const char *line, size_t len);
/* Accepts and services clients; returns the admitted ones (pl_sink_service). */
int sink_server_service(pl_sink *s);
/* Flushes, closes every socket, unlinks an owned Unix socket, frees the slots. Safe on a sink
 * whose open failed part way. */
void sink_server_close(pl_sink *s);

/* "1.2.3.4:5" / "[::1]:5" for an IPv4/IPv6 socket address (port/sink_event.c). */
void sink_format_addr(const void *sockaddr, char *out, size_t cap);

#endif
