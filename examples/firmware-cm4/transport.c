/* SPDX-License-Identifier: MIT */
/*
 * The board's network as drgate's transport (drgate/transport.h): the ten
 * calls the client requires, every one non-blocking, and none of the
 * optional ones. This board has no network driver yet: TCP connections
 * stay pending, datagrams go nowhere and none arrive, so the client keeps
 * retrying with its backoff, which is what it does on a real board while
 * the cable is out. Replace the bodies marked "driver" with your MAC/PHY
 * driver's or TCP/IP stack's calls (with lwIP, take port/lwip/ instead of
 * this file); docs/firmware.md, "The transport", says what each must do.
 */
#include <stddef.h>
#include <stdint.h>

#include "board.h"

enum { H_TCP = 0, H_UDP = 1 };

/* Dotted IPv4 ("192.168.1.20"); this board has no DNS. */
static dr_status_t nn_resolve(void *ctx, const char *host, uint32_t *addr)
{
    (void)ctx;
    uint32_t a = 0;
    unsigned part = 0, digits = 0, dots = 0;
    for (const char *p = host;; p++) {
        if (*p >= '0' && *p <= '9' && digits < 3) {
            part = part * 10u + (unsigned)(*p - '0');
            digits++;
        } else if ((*p == '.' || *p == '\0') && digits > 0 && part <= 255u) {
            a = a << 8 | part;
            part = digits = 0;
            if (*p == '\0')
                break;
            if (++dots > 3)
                return DR_ENOTFOUND;
        } else {
            return DR_ENOTFOUND;
        }
    }
    if (dots != 3)
        return DR_ENOTFOUND;
    *addr = a;
    return DR_OK;
}

static dr_status_t nn_tcp_connect(void *ctx, dr_sockaddr_t to, int *h)
{
    (void)ctx;
    (void)to; /* driver: start the connection to `to` */
    *h = H_TCP;
    return DR_OK;
}

static dr_status_t nn_tcp_finish(void *ctx, int h)
{
    (void)ctx;
    (void)h;
    return DR_EAGAIN; /* driver: DR_OK once connected */
}

static dr_status_t nn_tcp_send(void *ctx, int h, const uint8_t *buf, size_t len, size_t *sent)
{
    (void)ctx;
    (void)h;
    (void)buf;
    (void)len;
    *sent = 0; /* driver: queue what fits */
    return DR_EAGAIN;
}

static dr_status_t nn_tcp_recv(void *ctx, int h, uint8_t *buf, size_t cap, size_t *got)
{
    (void)ctx;
    (void)h;
    (void)buf;
    (void)cap;
    *got = 0; /* driver: copy what has arrived */
    return DR_EAGAIN;
}

static dr_status_t nn_udp_open(void *ctx, dr_sockaddr_t local, int *h)
{
    (void)ctx;
    (void)local; /* driver: bind UDP local.port (2222) */
    *h = H_UDP;
    return DR_OK;
}

static dr_status_t nn_udp_send(void *ctx, int h, const uint8_t *buf, size_t len, dr_sockaddr_t to)
{
    (void)ctx;
    (void)h;
    (void)buf;
    (void)len;
    (void)to; /* driver: send one datagram */
    return DR_OK;
}

static dr_status_t nn_udp_recv(void *ctx, int h, uint8_t *buf, size_t cap, size_t *got,
                               dr_sockaddr_t *from)
{
    (void)ctx;
    (void)h;
    (void)buf;
    (void)cap;
    (void)from;
    *got = 0; /* driver: one datagram and its sender */
    return DR_EAGAIN;
}

static void nn_close(void *ctx, int h)
{
    (void)ctx;
    (void)h; /* driver: close the connection or socket */
}

static uint64_t nn_now_us(void *ctx)
{
    (void)ctx;
    return board_now_us();
}

static const dr_transport_ops_t board_ops = {
    .resolve = nn_resolve,
    .tcp_connect = nn_tcp_connect,
    .tcp_finish = nn_tcp_finish,
    .tcp_send = nn_tcp_send,
    .tcp_recv = nn_tcp_recv,
    .udp_open = nn_udp_open,
    .udp_send = nn_udp_send,
    .udp_recv = nn_udp_recv,
    .close = nn_close,
    .now_us = nn_now_us,
};

dr_transport_t board_transport(void)
{
    dr_transport_t t = {&board_ops, NULL};
    return t;
}
