/* SPDX-License-Identifier: MIT */
/* The default transport: Linux sockets, timerfd and CLOCK_MONOTONIC. */
#define _GNU_SOURCE /* timerfd, SOCK_NONBLOCK, accept4 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include "drgate/transport.h"

static struct sockaddr_in to_sin(dr_sockaddr_t a)
{
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = htons(a.port);
    sin.sin_addr.s_addr = htonl(a.addr);
    return sin;
}

static dr_sockaddr_t from_sin(const struct sockaddr_in *sin)
{
    dr_sockaddr_t a = {ntohl(sin->sin_addr.s_addr), ntohs(sin->sin_port)};
    return a;
}

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
    case EINTR:
        return DR_EAGAIN;
    case ECONNREFUSED: return DR_ECONNREFUSED;
    case ETIMEDOUT: return DR_ENOANSWER;
    case EHOSTUNREACH:
    case EHOSTDOWN: return DR_EHOSTUNREACH;
    case ENETUNREACH:
    case ENETDOWN: return DR_ENETUNREACH;
    case EADDRINUSE: return DR_EADDRINUSE;
    case EADDRNOTAVAIL: return DR_EADDRNOTAVAIL;
    case EACCES:
    case EPERM: return DR_EACCES;
    case EPIPE:
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

static dr_status_t px_resolve(void *ctx, const char *host, uint32_t *addr)
{
    (void)ctx;
    struct in_addr in;
    if (inet_pton(AF_INET, host, &in) == 1) {
        *addr = ntohl(in.s_addr);
        return DR_OK;
    }
    struct addrinfo hints, *res = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_INET;
    if (getaddrinfo(host, NULL, &hints, &res) != 0 || res == NULL)
        return DR_ENOTFOUND;
    *addr = ntohl(((struct sockaddr_in *)(void *)res->ai_addr)->sin_addr.s_addr);
    freeaddrinfo(res);
    return DR_OK;
}

static dr_status_t px_tcp_connect(void *ctx, dr_sockaddr_t to, int *h)
{
    (void)ctx;
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return DR_EIO;
    int one = 1;
    /* Requests and replies are small: send them at once. */
    (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    struct sockaddr_in sin = to_sin(to);
    if (connect(fd, (struct sockaddr *)&sin, sizeof sin) < 0 && errno != EINPROGRESS) {
        /* EINVAL for a valid IPv4 address: a blackhole route to it */
        dr_status_t st = errno == EINVAL ? DR_ENETUNREACH : fail_status(errno);
        close(fd);
        return st;
    }
    *h = fd;
    return DR_OK;
}

static dr_status_t px_tcp_finish(void *ctx, int h)
{
    (void)ctx;
    int err = 0;
    socklen_t len = sizeof err;
    if (getsockopt(h, SOL_SOCKET, SO_ERROR, &err, &len) < 0)
        return DR_EIO;
    if (err != 0)
        return fail_status(err);
    struct sockaddr_in peer;
    len = sizeof peer;
    if (getpeername(h, (struct sockaddr *)&peer, &len) < 0)
        return errno == ENOTCONN ? DR_EAGAIN : DR_EIO;
    return DR_OK;
}

static dr_status_t px_tcp_send(void *ctx, int h, const uint8_t *buf, size_t len,
                               size_t *sent)
{
    (void)ctx;
    ssize_t n = send(h, buf, len, MSG_NOSIGNAL);
    if (n < 0)
        return errno_status(errno);
    *sent = (size_t)n;
    return DR_OK;
}

static dr_status_t px_tcp_recv(void *ctx, int h, uint8_t *buf, size_t cap,
                               size_t *got)
{
    (void)ctx;
    ssize_t n = recv(h, buf, cap, 0);
    if (n < 0)
        return errno_status(errno);
    if (n == 0)
        return DR_ECLOSED;
    *got = (size_t)n;
    return DR_OK;
}

static dr_status_t px_udp_open(void *ctx, dr_sockaddr_t local, int *h)
{
    (void)ctx;
    int fd = socket(AF_INET, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return DR_EIO;
    int one = 1;
    (void)setsockopt(fd, SOL_SOCKET, SO_BROADCAST, &one, sizeof one);
    struct sockaddr_in sin = to_sin(local);
    if (bind(fd, (struct sockaddr *)&sin, sizeof sin) < 0) {
        dr_status_t st = fail_status(errno); /* DR_EADDRINUSE, DR_EADDRNOTAVAIL */
        close(fd);
        return st;
    }
    *h = fd;
    return DR_OK;
}

static dr_status_t px_udp_send(void *ctx, int h, const uint8_t *buf, size_t len,
                               dr_sockaddr_t to)
{
    (void)ctx;
    struct sockaddr_in sin = to_sin(to);
    ssize_t n = sendto(h, buf, len, 0, (struct sockaddr *)&sin, sizeof sin);
    if (n < 0)
        return errno_status(errno);
    return (size_t)n == len ? DR_OK : DR_EIO;
}

static dr_status_t px_udp_recv(void *ctx, int h, uint8_t *buf, size_t cap,
                               size_t *got, dr_sockaddr_t *from)
{
    (void)ctx;
    struct sockaddr_in sin;
    socklen_t len = sizeof sin;
    /* zeroed: clang's analyzer does not see recvfrom or getsockname fill
     * a sockaddr passed through glibc's transparent union (_GNU_SOURCE) */
    memset(&sin, 0, sizeof sin);
    ssize_t n = recvfrom(h, buf, cap, MSG_TRUNC, (struct sockaddr *)&sin, &len);
    if (n < 0)
        return errno_status(errno);
    if ((size_t)n > cap)
        return DR_ELONG; /* truncated datagram: drop it */
    *got = (size_t)n;
    if (from != NULL)
        *from = from_sin(&sin);
    return DR_OK;
}

static dr_status_t px_timer_open(void *ctx, int *h)
{
    (void)ctx;
    int fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (fd < 0)
        return DR_EIO;
    *h = fd;
    return DR_OK;
}

static dr_status_t px_timer_arm(void *ctx, int h, uint64_t deadline_us)
{
    (void)ctx;
    struct itimerspec its;
    memset(&its, 0, sizeof its); /* all zero disarms */
    if (deadline_us != UINT64_MAX) {
        /* 0 would disarm: a deadline in the past must still fire. */
        if (deadline_us == 0)
            deadline_us = 1;
        its.it_value.tv_sec = (time_t)(deadline_us / 1000000u);
        its.it_value.tv_nsec = (long)(deadline_us % 1000000u) * 1000L;
    }
    /* Setting the timer also clears an expiry not yet read, so the fd
     * reports only the new deadline: no read() needed to drain it. */
    if (timerfd_settime(h, TFD_TIMER_ABSTIME, &its, NULL) < 0)
        return DR_EIO;
    return DR_OK;
}

static void px_close(void *ctx, int h)
{
    (void)ctx;
    if (h >= 0)
        close(h);
}

/* Linger 0: close() drops the unsent data and resets the connection,
 * instead of going on sending it in the background. */
static void px_tcp_abort(void *ctx, int h)
{
    struct linger lg = {1, 0};
    if (h >= 0)
        (void)setsockopt(h, SOL_SOCKET, SO_LINGER, &lg, sizeof lg);
    px_close(ctx, h);
}

static uint64_t px_now_us(void *ctx)
{
    (void)ctx;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

static int px_fd(void *ctx, int h)
{
    (void)ctx;
    return h;
}

static dr_status_t px_wait(void *ctx, const int *h, const bool *want_out,
                           int n, uint64_t deadline_us)
{
    struct pollfd pfd[8];
    if (n > 8)
        n = 8;
    for (int i = 0; i < n; i++) {
        pfd[i].fd = h[i];
        pfd[i].events = (short)(POLLIN | (want_out[i] ? POLLOUT : 0));
        pfd[i].revents = 0;
    }
    uint64_t now = px_now_us(ctx);
    uint64_t wait_us = deadline_us > now ? deadline_us - now : 0;
    struct timespec ts = {(time_t)(wait_us / 1000000u), (long)(wait_us % 1000000u) * 1000L};
    if (ppoll(pfd, (nfds_t)n, &ts, NULL) < 0 && errno != EINTR)
        return DR_EIO;
    return DR_OK;
}

#define BATCH_MAX 64 /* datagrams per sendmmsg / recvmmsg (6 KB of stack) */

static dr_status_t px_udp_send_batch(void *ctx, int h, const dr_udp_msg_t *m,
                                     unsigned n, unsigned *done)
{
    (void)ctx;
    struct mmsghdr mh[BATCH_MAX];
    struct iovec iov[BATCH_MAX];
    struct sockaddr_in sin[BATCH_MAX];
    if (n > BATCH_MAX)
        n = BATCH_MAX;
    memset(mh, 0, sizeof mh[0] * n);
    for (unsigned i = 0; i < n; i++) {
        sin[i] = to_sin(m[i].addr);
        iov[i].iov_base = m[i].buf;
        iov[i].iov_len = m[i].len;
        mh[i].msg_hdr.msg_name = &sin[i];
        mh[i].msg_hdr.msg_namelen = sizeof sin[i];
        mh[i].msg_hdr.msg_iov = &iov[i];
        mh[i].msg_hdr.msg_iovlen = 1;
    }
    int r = sendmmsg(h, mh, n, 0);
    if (r < 0)
        return errno_status(errno);
    *done = (unsigned)r;
    return DR_OK;
}

static dr_status_t px_udp_recv_batch(void *ctx, int h, dr_udp_msg_t *m,
                                     unsigned n, unsigned *done)
{
    (void)ctx;
    struct mmsghdr mh[BATCH_MAX];
    struct iovec iov[BATCH_MAX];
    struct sockaddr_in sin[BATCH_MAX];
    if (n > BATCH_MAX)
        n = BATCH_MAX;
    memset(mh, 0, sizeof mh[0] * n);
    for (unsigned i = 0; i < n; i++) {
        iov[i].iov_base = m[i].buf;
        iov[i].iov_len = m[i].cap;
        mh[i].msg_hdr.msg_name = &sin[i];
        mh[i].msg_hdr.msg_namelen = sizeof sin[i];
        mh[i].msg_hdr.msg_iov = &iov[i];
        mh[i].msg_hdr.msg_iovlen = 1;
    }
    int r = recvmmsg(h, mh, n, MSG_DONTWAIT, NULL);
    if (r < 0)
        return errno_status(errno);
    for (int i = 0; i < r; i++) {
        /* a datagram larger than the buffer was cut: mark it unusable */
        m[i].len = (mh[i].msg_hdr.msg_flags & MSG_TRUNC) ? 0 : mh[i].msg_len;
        m[i].addr = from_sin(&sin[i]);
    }
    *done = (unsigned)r;
    return DR_OK;
}

static const dr_transport_ops_t posix_ops = {
    px_resolve,  px_tcp_connect, px_tcp_finish, px_tcp_send,
    px_tcp_recv, px_udp_open,    px_udp_send,   px_udp_recv,
    px_timer_open, px_timer_arm, px_close,      px_now_us,
    px_fd,       px_wait,
    px_udp_send_batch, px_udp_recv_batch, px_tcp_abort,
};

dr_transport_t dr_transport_posix(void)
{
    dr_transport_t t = {&posix_ops, NULL};
    return t;
}
