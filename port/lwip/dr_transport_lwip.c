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

/* The socket code shared with the POSIX transport (lib/transport_bsd.h),
 * with lwIP's calls by their lwip_ names. */
#define BSD_connect lwip_connect
#define BSD_bind lwip_bind
#define BSD_send lwip_send
#define BSD_recv lwip_recv
#define BSD_sendto lwip_sendto
#define BSD_recvfrom lwip_recvfrom
#define BSD_setsockopt lwip_setsockopt
#define BSD_getsockopt lwip_getsockopt
#define BSD_getsockname lwip_getsockname
#define BSD_close lwip_close
#define BSD_htons lwip_htons
#define BSD_htonl lwip_htonl
#define BSD_ntohs lwip_ntohs
#define BSD_ntohl lwip_ntohl
#define BSD_SEND_FLAGS 0 /* no signals in lwIP */
/* lwIP cuts a datagram longer than cap (no MSG_TRUNC length): one that
 * fills the buffer exactly may have been longer, so it is dropped. */
#define BSD_RECV_TRUNC 0
#define BSD_TRUNCATED(n, cap) ((size_t)(n) >= (cap))
#define BSD_CONNECT_EINVAL_UNREACH 0
/* Linger 0: lwIP aborts the connection (a reset) and drops unsent data.
 * Without it, tcp_abort is left out: close, and queued requests may
 * still go out. */
#define BSD_HAVE_LINGER LWIP_SO_LINGER

static int bsd_socket_nb(int type)
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

/* Connected once writable (an error shows in SO_ERROR). */
static int bsd_connected(int h)
{
    struct pollfd p = {h, POLLOUT, 0};
    if (lwip_poll(&p, 1, 0) < 0)
        return -1;
    return (p.revents & POLLOUT) != 0;
}

#include "transport_bsd.h"

static dr_status_t lw_resolve(void *ctx, const char *host, uint32_t *addr)
{
    ip4_addr_t a;
    (void)ctx;
    if (!ip4addr_aton(host, &a))
        return DR_ENOTFOUND; /* dotted addresses only: no DNS here */
    *addr = lwip_ntohl(ip4_addr_get_u32(&a));
    return DR_OK;
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
#define LW_TCP_ABORT bsd_tcp_abort
#else
#define LW_TCP_ABORT NULL /* close: queued requests may still go out */
#endif

static const dr_transport_ops_t lwip_ops = {
    lw_resolve,  bsd_tcp_connect, bsd_tcp_finish, bsd_tcp_send,
    bsd_tcp_recv, bsd_udp_open,   bsd_udp_send,   bsd_udp_recv,
    NULL,        NULL,            bsd_close,      lw_now_us,
    NULL,        LW_WAIT,        NULL,          NULL,
    LW_TCP_ABORT,
    NULL, /* random: the board's RNG belongs here (docs/firmware.md) */
    bsd_tcp_connect_from, bsd_tcp_local,
};

dr_transport_t dr_transport_lwip(dr_lwip_t *lw)
{
    dr_transport_t t = {&lwip_ops, lw};
    return t;
}
