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
#include <sys/random.h>
#include <sys/socket.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include "drgate/transport.h"

/* The socket code shared with the lwIP transport (lib/transport_bsd.h),
 * with Linux's calls. */
#define BSD_connect connect
#define BSD_bind bind
#define BSD_send send
#define BSD_recv recv
#define BSD_sendto sendto
#define BSD_recvfrom recvfrom
#define BSD_setsockopt setsockopt
#define BSD_getsockopt getsockopt
#define BSD_getsockname getsockname
#define BSD_close close
#define BSD_htons htons
#define BSD_htonl htonl
#define BSD_ntohs ntohs
#define BSD_ntohl ntohl
#define BSD_SEND_FLAGS MSG_NOSIGNAL /* a peer gone is an error, not SIGPIPE */
/* MSG_TRUNC: recvfrom returns a datagram's real length, so one longer
 * than the buffer is known to be cut. */
#define BSD_RECV_TRUNC MSG_TRUNC
#define BSD_TRUNCATED(n, cap) ((size_t)(n) > (cap))
#define BSD_CONNECT_EINVAL_UNREACH 1
#define BSD_HAVE_LINGER 1

static int bsd_socket_nb(int type)
{
    return socket(AF_INET, type | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
}

/* A peer name once the connection is made (ENOTCONN until then). */
static int bsd_connected(int h)
{
    struct sockaddr_in peer;
    socklen_t len = sizeof peer;
    if (getpeername(h, (struct sockaddr *)&peer, &len) < 0)
        return errno == ENOTCONN ? 0 : -1;
    return 1;
}

#include "transport_bsd.h"

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

/* The kernel's random source (getrandom(2), urandom's pool): never blocks
 * once the pool is initialised at boot; before that, or on a kernel
 * without it, DR_EAGAIN / an error, and the client uses its own generator. */
static dr_status_t px_random(void *ctx, uint8_t *buf, size_t len)
{
    (void)ctx;
    size_t got = 0;
    while (got < len) {
        ssize_t n = getrandom(buf + got, len - got, GRND_NONBLOCK);
        if (n < 0 && errno == EINTR)
            continue;
        if (n <= 0)
            return n < 0 ? errno_status(errno) : DR_EAGAIN;
        got += (size_t)n;
    }
    return DR_OK;
}

static const dr_transport_ops_t posix_ops = {
    px_resolve,  bsd_tcp_connect, bsd_tcp_finish, bsd_tcp_send,
    bsd_tcp_recv, bsd_udp_open,   bsd_udp_send,   bsd_udp_recv,
    px_timer_open, px_timer_arm,  bsd_close,      px_now_us,
    px_fd,       px_wait,
    px_udp_send_batch, px_udp_recv_batch, bsd_tcp_abort,
    px_random, bsd_tcp_connect_from, bsd_tcp_local,
};

dr_transport_t dr_transport_posix(void)
{
    dr_transport_t t = {&posix_ops, NULL};
    return t;
}
