/* SPDX-License-Identifier: MIT */
/*
 * The BSD-socket half of a transport, written once for every stack that
 * has BSD sockets under some prefix: the POSIX transport
 * (lib/transport_posix.c: socket, connect, ...) and the lwIP one
 * (port/lwip/dr_transport_lwip.c: lwip_socket, lwip_connect, ...). Not a
 * normal header: each transport includes it once, after defining how its
 * stack spells things, and gets static functions (bsd_*) for its
 * dr_transport_ops_t. What differs between the stacks in more than a
 * name (name resolution, the clock, the wait, timers, batched datagrams)
 * stays in the transport.
 *
 * The includer defines, before including:
 *   BSD_connect, BSD_bind, BSD_send, BSD_recv, BSD_sendto,
 *   BSD_recvfrom, BSD_setsockopt, BSD_getsockopt, BSD_getsockname,
 *   BSD_close, BSD_htons,
 *   BSD_htonl, BSD_ntohs, BSD_ntohl   the stack's calls, as macros
 *   BSD_SEND_FLAGS        flags of a TCP send (MSG_NOSIGNAL where SIGPIPE
 *                         exists)
 *   BSD_RECV_TRUNC        flags of a datagram receive that make it report
 *                         a datagram's full length (MSG_TRUNC), or 0
 *   BSD_TRUNCATED(n, cap) whether a datagram received as n bytes into cap
 *                         was longer than cap (then dropped)
 *   BSD_CONNECT_EINVAL_UNREACH  1 where connect's EINVAL on a valid
 *                         address means a blackhole route (Linux), else 0
 *   BSD_HAVE_LINGER       1 where SO_LINGER 0 resets a connection, else 0
 * and the static functions
 *   int bsd_socket_nb(int type)  a non-blocking IPv4 socket, -1 on error
 *   int bsd_connected(int h)     1: connected, 0: not yet, -1: error
 */
#ifndef DRGATE_TRANSPORT_BSD_H
#define DRGATE_TRANSPORT_BSD_H

#include <string.h>

#include "drgate/transport.h"

/* Each cause a user can act on has its own status: a refused connection
 * (nothing listens), no route (wrong address or network), TCP's own
 * timeout (nobody answers), an address in use or not on this host. */
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
#ifdef EHOSTDOWN
    case EHOSTDOWN: return DR_EHOSTUNREACH;
#endif
    case ENETUNREACH:
#ifdef ENETDOWN
    case ENETDOWN:
#endif
        return DR_ENETUNREACH;
    case EADDRINUSE: return DR_EADDRINUSE;
    case EADDRNOTAVAIL: return DR_EADDRNOTAVAIL;
    case EACCES:
    case EPERM: return DR_EACCES;
    case EPIPE:
    case ENOTCONN:
    case ECONNABORTED:
    case ECONNRESET: return DR_ECLOSED;
    default: return DR_EIO;
    }
}

/* A failure of a call that never "would block": EAGAIN there is an error. */
static dr_status_t fail_status(int e)
{
    dr_status_t st = errno_status(e);
    return st == DR_EAGAIN ? DR_EIO : st;
}

static struct sockaddr_in to_sin(dr_sockaddr_t a)
{
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = BSD_htons(a.port);
    sin.sin_addr.s_addr = BSD_htonl(a.addr);
    return sin;
}

static dr_sockaddr_t from_sin(const struct sockaddr_in *sin)
{
    dr_sockaddr_t a = {BSD_ntohl(sin->sin_addr.s_addr), BSD_ntohs(sin->sin_port)};
    return a;
}

static dr_status_t bsd_tcp_connect_from(void *ctx, dr_sockaddr_t from, dr_sockaddr_t to,
                                        int *h)
{
    (void)ctx;
    int s = bsd_socket_nb(SOCK_STREAM);
    if (s < 0)
        return DR_EIO;
    int one = 1;
    /* Requests and replies are small: send them at once. */
    (void)BSD_setsockopt(s, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    if (from.addr != 0 || from.port != 0) {
        struct sockaddr_in lsin = to_sin(from);
        if (BSD_bind(s, (struct sockaddr *)&lsin, sizeof lsin) < 0) {
            dr_status_t st = fail_status(errno); /* DR_EADDRNOTAVAIL, ... */
            BSD_close(s);
            return st;
        }
    }
    struct sockaddr_in sin = to_sin(to);
    if (BSD_connect(s, (struct sockaddr *)&sin, sizeof sin) < 0 && errno != EINPROGRESS) {
#if BSD_CONNECT_EINVAL_UNREACH
        /* EINVAL for a valid IPv4 address: a blackhole route to it */
        dr_status_t st = errno == EINVAL ? DR_ENETUNREACH : fail_status(errno);
#else
        dr_status_t st = fail_status(errno);
#endif
        BSD_close(s);
        return st;
    }
    *h = s;
    return DR_OK;
}

static dr_status_t bsd_tcp_connect(void *ctx, dr_sockaddr_t to, int *h)
{
    dr_sockaddr_t any = {0, 0};
    return bsd_tcp_connect_from(ctx, any, to, h);
}

static dr_status_t bsd_tcp_local(void *ctx, int h, dr_sockaddr_t *local)
{
    (void)ctx;
    struct sockaddr_in sin;
    socklen_t len = sizeof sin;
    memset(&sin, 0, sizeof sin);
    if (BSD_getsockname(h, (struct sockaddr *)&sin, &len) < 0)
        return DR_EIO;
    *local = from_sin(&sin);
    return DR_OK;
}

/* Connected once the stack says so; an error is in SO_ERROR. */
static dr_status_t bsd_tcp_finish(void *ctx, int h)
{
    (void)ctx;
    int connected = bsd_connected(h);
    if (connected < 0)
        return DR_EIO;
    int err = 0;
    socklen_t len = sizeof err;
    if (BSD_getsockopt(h, SOL_SOCKET, SO_ERROR, &err, &len) < 0)
        return DR_EIO;
    if (err != 0)
        return fail_status(err);
    return connected ? DR_OK : DR_EAGAIN;
}

static dr_status_t bsd_tcp_send(void *ctx, int h, const uint8_t *buf, size_t len,
                                size_t *sent)
{
    (void)ctx;
    ssize_t n = BSD_send(h, buf, len, BSD_SEND_FLAGS);
    if (n < 0)
        return errno_status(errno);
    *sent = (size_t)n;
    return DR_OK;
}

static dr_status_t bsd_tcp_recv(void *ctx, int h, uint8_t *buf, size_t cap,
                                size_t *got)
{
    (void)ctx;
    ssize_t n = BSD_recv(h, buf, cap, 0);
    if (n < 0)
        return errno_status(errno);
    if (n == 0)
        return DR_ECLOSED;
    *got = (size_t)n;
    return DR_OK;
}

static dr_status_t bsd_udp_open(void *ctx, dr_sockaddr_t local, int *h)
{
    (void)ctx;
    int s = bsd_socket_nb(SOCK_DGRAM);
    if (s < 0)
        return DR_EIO;
    int one = 1;
    (void)BSD_setsockopt(s, SOL_SOCKET, SO_BROADCAST, &one, sizeof one);
    struct sockaddr_in sin = to_sin(local);
    if (BSD_bind(s, (struct sockaddr *)&sin, sizeof sin) < 0) {
        dr_status_t st = fail_status(errno); /* DR_EADDRINUSE, DR_EADDRNOTAVAIL */
        BSD_close(s);
        return st;
    }
    *h = s;
    return DR_OK;
}

static dr_status_t bsd_udp_send(void *ctx, int h, const uint8_t *buf, size_t len,
                                dr_sockaddr_t to)
{
    (void)ctx;
    struct sockaddr_in sin = to_sin(to);
    ssize_t n = BSD_sendto(h, buf, len, 0, (struct sockaddr *)&sin, sizeof sin);
    if (n < 0)
        return errno_status(errno);
    return (size_t)n == len ? DR_OK : DR_EIO;
}

static dr_status_t bsd_udp_recv(void *ctx, int h, uint8_t *buf, size_t cap,
                                size_t *got, dr_sockaddr_t *from)
{
    (void)ctx;
    struct sockaddr_in sin;
    socklen_t len = sizeof sin;
    /* zeroed: clang's analyzer does not see recvfrom or getsockname fill
     * a sockaddr passed through glibc's transparent union (_GNU_SOURCE) */
    memset(&sin, 0, sizeof sin);
    ssize_t n = BSD_recvfrom(h, buf, cap, BSD_RECV_TRUNC, (struct sockaddr *)&sin, &len);
    if (n < 0)
        return errno_status(errno);
    if (BSD_TRUNCATED(n, cap))
        return DR_ELONG; /* truncated datagram: drop it */
    *got = (size_t)n;
    if (from != NULL)
        *from = from_sin(&sin);
    return DR_OK;
}

static void bsd_close(void *ctx, int h)
{
    (void)ctx;
    if (h >= 0)
        BSD_close(h);
}

#if BSD_HAVE_LINGER
/* Linger 0: close() drops the unsent data and resets the connection,
 * instead of going on sending it in the background. */
static void bsd_tcp_abort(void *ctx, int h)
{
    struct linger lg = {1, 0};
    if (h >= 0)
        (void)BSD_setsockopt(h, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
    bsd_close(ctx, h);
}
#endif

#endif /* DRGATE_TRANSPORT_BSD_H */
