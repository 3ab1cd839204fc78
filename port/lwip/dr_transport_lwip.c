/* SPDX-License-Identifier: MIT */
/*
 * drgate's transport over lwIP sockets (see dr_transport_lwip.h).
 * Every socket is non-blocking; nothing here waits except lw_wait, which
 * the client calls only from its blocking *_sync calls.
 */
#include <string.h>

#include "lwip/opt.h"
#include "lwip/inet.h"
#include "lwip/ip4_addr.h"
#include "lwip/sockets.h"
#include "lwip/sys.h"

#include "dr_transport_lwip.h"

#if !LWIP_SOCKET
#error "the drgate lwIP transport needs LWIP_SOCKET 1"
#endif

static dr_status_t errno_status(int e)
{
    switch (e) {
    case EAGAIN:
#if EWOULDBLOCK != EAGAIN
    case EWOULDBLOCK:
#endif
    case EINPROGRESS:
    case EINTR:
        return DR_EAGAIN;
    case ECONNREFUSED: return DR_ECONNREFUSED;
    case ETIMEDOUT: return DR_ENOANSWER; /* TCP's: not a request timeout */
    case EHOSTUNREACH: return DR_EHOSTUNREACH; /* lwIP's ERR_RTE: no route */
    case EADDRINUSE: return DR_EADDRINUSE;
    case EPIPE:
    case ENOTCONN:
    case ECONNRESET:
    case ECONNABORTED: return DR_ECLOSED;
    default: return DR_EIO;
    }
}

static struct sockaddr_in to_sin(dr_sockaddr_t a)
{
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = lwip_htons(a.port);
    sin.sin_addr.s_addr = lwip_htonl(a.addr);
    return sin;
}

static int nonblocking_socket(int type)
{
    int s = lwip_socket(AF_INET, type, 0);
    if (s < 0)
        return -1;
    if (lwip_fcntl(s, F_SETFL, O_NONBLOCK) < 0) {
        lwip_close(s);
        return -1;
    }
    return s;
}

static dr_status_t lw_resolve(void *ctx, const char *host, uint32_t *addr)
{
    ip4_addr_t a;
    (void)ctx;
    if (!ip4addr_aton(host, &a))
        return DR_ENOTFOUND; /* dotted addresses only: no DNS here */
    *addr = lwip_ntohl(ip4_addr_get_u32(&a));
    return DR_OK;
}

static dr_status_t lw_tcp_connect(void *ctx, dr_sockaddr_t to, int *h)
{
    (void)ctx;
    int s = nonblocking_socket(SOCK_STREAM);
    if (s < 0)
        return DR_EIO;
    int one = 1;
    (void)lwip_setsockopt(s, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    struct sockaddr_in sin = to_sin(to);
    if (lwip_connect(s, (struct sockaddr *)&sin, sizeof sin) < 0 && errno != EINPROGRESS) {
        dr_status_t st = errno_status(errno);
        lwip_close(s);
        return st == DR_EAGAIN ? DR_EIO : st;
    }
    *h = s;
    return DR_OK;
}

/* Connected once writable; an error is in SO_ERROR. */
static dr_status_t lw_tcp_finish(void *ctx, int h)
{
    (void)ctx;
    struct pollfd p = {h, POLLOUT, 0};
    if (lwip_poll(&p, 1, 0) < 0)
        return DR_EIO;
    int err = 0;
    socklen_t len = sizeof err;
    if (lwip_getsockopt(h, SOL_SOCKET, SO_ERROR, &err, &len) < 0)
        return DR_EIO;
    if (err != 0) {
        dr_status_t st = errno_status(err);
        return st == DR_EAGAIN ? DR_EIO : st;
    }
    return (p.revents & POLLOUT) ? DR_OK : DR_EAGAIN;
}

static dr_status_t lw_tcp_send(void *ctx, int h, const uint8_t *buf, size_t len,
                               size_t *sent)
{
    (void)ctx;
    ssize_t n = lwip_send(h, buf, len, 0);
    if (n < 0)
        return errno_status(errno);
    *sent = (size_t)n;
    return DR_OK;
}

static dr_status_t lw_tcp_recv(void *ctx, int h, uint8_t *buf, size_t cap, size_t *got)
{
    (void)ctx;
    ssize_t n = lwip_recv(h, buf, cap, 0);
    if (n < 0)
        return errno_status(errno);
    if (n == 0)
        return DR_ECLOSED;
    *got = (size_t)n;
    return DR_OK;
}

static dr_status_t lw_udp_open(void *ctx, dr_sockaddr_t local, int *h)
{
    (void)ctx;
    int s = nonblocking_socket(SOCK_DGRAM);
    if (s < 0)
        return DR_EIO;
    int one = 1;
    (void)lwip_setsockopt(s, SOL_SOCKET, SO_BROADCAST, &one, sizeof one);
    struct sockaddr_in sin = to_sin(local);
    if (lwip_bind(s, (struct sockaddr *)&sin, sizeof sin) < 0) {
        dr_status_t st = errno_status(errno); /* DR_EADDRINUSE */
        lwip_close(s);
        return st == DR_EAGAIN ? DR_EIO : st;
    }
    *h = s;
    return DR_OK;
}

static dr_status_t lw_udp_send(void *ctx, int h, const uint8_t *buf, size_t len,
                               dr_sockaddr_t to)
{
    (void)ctx;
    struct sockaddr_in sin = to_sin(to);
    ssize_t n = lwip_sendto(h, buf, len, 0, (struct sockaddr *)&sin, sizeof sin);
    if (n < 0)
        return errno_status(errno);
    return (size_t)n == len ? DR_OK : DR_EIO;
}

static dr_status_t lw_udp_recv(void *ctx, int h, uint8_t *buf, size_t cap, size_t *got,
                               dr_sockaddr_t *from)
{
    (void)ctx;
    struct sockaddr_in sin;
    socklen_t len = sizeof sin;
    memset(&sin, 0, sizeof sin);
    /* lwIP cuts a datagram longer than cap (no MSG_TRUNC length): one that
     * fills the buffer exactly may have been longer, so it is dropped. */
    ssize_t n = lwip_recvfrom(h, buf, cap, 0, (struct sockaddr *)&sin, &len);
    if (n < 0)
        return errno_status(errno);
    if ((size_t)n >= cap)
        return DR_ELONG;
    *got = (size_t)n;
    if (from != NULL) {
        from->addr = lwip_ntohl(sin.sin_addr.s_addr);
        from->port = lwip_ntohs(sin.sin_port);
    }
    return DR_OK;
}

static void lw_close(void *ctx, int h)
{
    (void)ctx;
    if (h >= 0)
        lwip_close(h);
}

static uint64_t lw_now_us(void *ctx)
{
    dr_lwip_t *lw = ctx;
    if (lw->now_us != NULL)
        return lw->now_us(lw->user);
    return (uint64_t)sys_now() * 1000u;
}

#if LWIP_POLL
/* lwip_poll counts in milliseconds: round up, so a wake-up is never early
 * (which would make the caller spin until the deadline). */
static dr_status_t lw_wait(void *ctx, const int *h, const bool *want_out, int n,
                           uint64_t deadline_us)
{
    struct pollfd p[4];
    if (n > 4)
        n = 4;
    for (int i = 0; i < n; i++) {
        p[i].fd = h[i];
        p[i].events = (short)(POLLIN | (want_out[i] ? POLLOUT : 0));
        p[i].revents = 0;
    }
    uint64_t now = lw_now_us(ctx);
    uint64_t ms = deadline_us > now ? (deadline_us - now + 999u) / 1000u : 0;
    if (ms > 60000u)
        ms = 60000u; /* UINT64_MAX: no deadline; wake now and then anyway */
    if (lwip_poll(p, (nfds_t)n, (int)ms) < 0 && errno != EINTR)
        return DR_EIO;
    return DR_OK;
}
#define LW_WAIT lw_wait
#else
#define LW_WAIT NULL /* the application drives the client */
#endif

#if LWIP_SO_LINGER
/* Linger 0: lwIP aborts the connection (a reset) and drops unsent data. */
static void lw_tcp_abort(void *ctx, int h)
{
    struct linger lg = {1, 0};
    if (h >= 0)
        (void)lwip_setsockopt(h, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
    lw_close(ctx, h);
}
#define LW_TCP_ABORT lw_tcp_abort
#else
#define LW_TCP_ABORT NULL /* close: queued requests may still go out */
#endif

static const dr_transport_ops_t lwip_ops = {
    lw_resolve,  lw_tcp_connect, lw_tcp_finish, lw_tcp_send,
    lw_tcp_recv, lw_udp_open,    lw_udp_send,   lw_udp_recv,
    NULL,        NULL,           lw_close,      lw_now_us,
    NULL,        LW_WAIT,        NULL,          NULL,
    LW_TCP_ABORT,
};

dr_transport_t dr_transport_lwip(dr_lwip_t *lw)
{
    dr_transport_t t = {&lwip_ops, lw};
    return t;
}
