/* The event queue and the address formatting that port/sink.c and port/sink_server.c share
 * (port/sink_internal.h): a file of their own, so that neither of the two calls into the other's
 * helpers and sink.c -> sink_server.c is the only arrow between them. */
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdio.h>
#include <sys/socket.h>

#include "port/sink_internal.h"

void sink_event(pl_sink *s, const char *fmt, ...)
{
    if (s->ev_count == SINK_EVENTS) {
        s->ev_head = (s->ev_head + 1) % SINK_EVENTS;
        s->ev_count--;
        s->ev_lost++;
    }
    char *m = s->events[(s->ev_head + s->ev_count) % SINK_EVENTS];
    int n = snprintf(m, PL_SINK_EVENT_MAX, "%s: ", s->spec);
    if (n < 0 || n >= PL_SINK_EVENT_MAX) n = 0;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(m + n, PL_SINK_EVENT_MAX - (size_t)n, fmt, ap);
    va_end(ap);
    s->ev_count++;
}

void sink_format_addr(const void *sockaddr, char *out, size_t cap)
{
    const struct sockaddr *sa = sockaddr;
    char ip[INET6_ADDRSTRLEN] = "?";
    if (sa->sa_family == AF_INET) {
        const struct sockaddr_in *in = sockaddr;
        inet_ntop(AF_INET, &in->sin_addr, ip, sizeof ip);
        snprintf(out, cap, "%s:%u", ip, (unsigned)ntohs(in->sin_port));
    } else if (sa->sa_family == AF_INET6) {
        const struct sockaddr_in6 *in6 = sockaddr;
        inet_ntop(AF_INET6, &in6->sin6_addr, ip, sizeof ip);
        snprintf(out, cap, "[%s]:%u", ip, (unsigned)ntohs(in6->sin6_port));
    } else {
        snprintf(out, cap, "unix");
    }
}
