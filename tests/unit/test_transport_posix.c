/* SPDX-License-Identifier: MIT */
/*
 * The POSIX transport (lib/transport_posix.c) on its own, on loopback:
 * name resolution, a TCP connection seen from both ends, UDP datagrams
 * too large for the buffer, batches larger than one system call takes,
 * the timer's edge cases (a deadline in the past, disarming) and waits.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "drgate/transport.h"

static dr_transport_t T;

#define OPS T.ops
#define CTX T.ctx

static int setup(void **state)
{
    (void)state;
    T = dr_transport_posix();
    return 0;
}

static bool readable(int fd, int timeout_ms)
{
    struct pollfd p = {fd, POLLIN, 0};
    return poll(&p, 1, timeout_ms) == 1 && (p.revents & POLLIN);
}

static void test_resolve(void **state)
{
    (void)state;
    uint32_t a = 0;
    assert_int_equal(OPS->resolve(CTX, "127.0.0.9", &a), DR_OK);
    assert_int_equal(a, 0x7F000009u);
    /* a name: from /etc/hosts, IPv4 only */
    assert_int_equal(OPS->resolve(CTX, "localhost", &a), DR_OK);
    assert_int_equal(a >> 24, 127u);
    assert_int_equal(OPS->resolve(CTX, "", &a), DR_ENOTFOUND);
}

static void test_tcp_both_ends(void **state)
{
    (void)state;
    int ls = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sin;
    socklen_t sl = sizeof sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_addr.s_addr = htonl(0x7F000001u);
    assert_int_equal(bind(ls, (struct sockaddr *)&sin, sizeof sin), 0);
    assert_int_equal(listen(ls, 1), 0);
    assert_int_equal(getsockname(ls, (struct sockaddr *)&sin, &sl), 0);
    uint16_t port = ntohs(sin.sin_port);

    int h = -1;
    dr_sockaddr_t to = {0x7F000001u, port};
    assert_int_equal(OPS->tcp_connect(CTX, to, &h), DR_OK);
    assert_true(h >= 0);
    assert_int_equal(OPS->fd(CTX, h), h);
    dr_status_t st = DR_EAGAIN;
    uint64_t deadline = OPS->now_us(CTX) + 2000000u;
    while ((st = OPS->tcp_finish(CTX, h)) == DR_EAGAIN && OPS->now_us(CTX) < deadline) {
        bool out = true;
        OPS->wait(CTX, &h, &out, 1, OPS->now_us(CTX) + 10000u);
    }
    assert_int_equal(st, DR_OK);
    int peer = accept(ls, NULL, NULL);
    assert_true(peer >= 0);

    /* nothing to read yet; then the peer's bytes; then its close */
    uint8_t buf[16];
    size_t got = 0, sent = 0;
    assert_int_equal(OPS->tcp_recv(CTX, h, buf, sizeof buf, &got), DR_EAGAIN);
    assert_int_equal(OPS->tcp_send(CTX, h, (const uint8_t *)"ping", 4, &sent), DR_OK);
    assert_int_equal(sent, 4);
    assert_int_equal(read(peer, buf, sizeof buf), 4);
    assert_int_equal(write(peer, "pong", 4), 4);
    assert_true(readable(h, 2000));
    assert_int_equal(OPS->tcp_recv(CTX, h, buf, sizeof buf, &got), DR_OK);
    assert_int_equal(got, 4);
    assert_memory_equal(buf, "pong", 4);
    /* the peer resets the connection (SO_LINGER 0): sends fail as closed */
    struct linger lg = {1, 0};
    assert_int_equal(setsockopt(peer, SOL_SOCKET, SO_LINGER, &lg, sizeof lg), 0);
    close(peer);
    assert_true(readable(h, 2000));
    st = OPS->tcp_recv(CTX, h, buf, sizeof buf, &got);
    assert_true(st == DR_ECLOSED);
    st = OPS->tcp_send(CTX, h, (const uint8_t *)"late", 4, &sent);
    assert_true(st == DR_ECLOSED || st == DR_EIO);
    OPS->close(CTX, h);
    OPS->close(CTX, -1); /* a handle that never was: nothing happens */

    /* a refused connection is reported by tcp_finish */
    close(ls);
    assert_int_equal(OPS->tcp_connect(CTX, to, &h), DR_OK);
    deadline = OPS->now_us(CTX) + 2000000u;
    while ((st = OPS->tcp_finish(CTX, h)) == DR_EAGAIN && OPS->now_us(CTX) < deadline) {
        bool out = true;
        OPS->wait(CTX, &h, &out, 1, OPS->now_us(CTX) + 10000u);
    }
    assert_int_equal(st, DR_ECONNREFUSED);
    OPS->close(CTX, h);
}

static void test_udp(void **state)
{
    (void)state;
    int a = -1, b = -1, c = -1;
    dr_sockaddr_t any = {0x7F000001u, 0};
    assert_int_equal(OPS->udp_open(CTX, any, &a), DR_OK);
    assert_int_equal(OPS->udp_open(CTX, any, &b), DR_OK);
    struct sockaddr_in sin;
    socklen_t sl = sizeof sin;
    assert_int_equal(getsockname(b, (struct sockaddr *)&sin, &sl), 0);
    dr_sockaddr_t to = {0x7F000001u, ntohs(sin.sin_port)};
    /* the same port twice cannot be had, and says so (drgatewayd tells
     * the user to change local_address or local_udp_port) */
    assert_int_equal(OPS->udp_open(CTX, to, &c), DR_EADDRINUSE);
    /* an address that is not this host's (class E: never assigned) */
    dr_sockaddr_t foreign = {0xF0000001u, 0};
    assert_int_equal(OPS->udp_open(CTX, foreign, &c), DR_EADDRNOTAVAIL);

    uint8_t big[100], buf[50];
    memset(big, 7, sizeof big);
    size_t got = 0;
    dr_sockaddr_t from;
    assert_int_equal(OPS->udp_recv(CTX, b, buf, sizeof buf, &got, &from), DR_EAGAIN);
    assert_int_equal(OPS->udp_send(CTX, a, big, sizeof big, to), DR_OK);
    assert_true(readable(b, 2000));
    /* larger than the buffer: dropped, not cut */
    assert_int_equal(OPS->udp_recv(CTX, b, buf, sizeof buf, &got, &from), DR_ELONG);
    assert_int_equal(OPS->udp_send(CTX, a, big, 10, to), DR_OK);
    assert_true(readable(b, 2000));
    assert_int_equal(OPS->udp_recv(CTX, b, buf, sizeof buf, &got, NULL), DR_OK);
    assert_int_equal(got, 10);

    /* batches: at most 64 datagrams per call, either way; a cut one is
     * marked with length 0 */
    dr_udp_msg_t m[70];
    uint8_t bufs[70][64];
    for (int i = 0; i < 70; i++) {
        m[i].buf = bufs[i];
        m[i].len = i == 3 ? 60 : 8;
        m[i].cap = 32;
        m[i].addr = to;
        memset(bufs[i], i, sizeof bufs[i]);
    }
    unsigned done = 0;
    assert_int_equal(OPS->udp_send_batch(CTX, a, m, 70, &done), DR_OK);
    assert_int_equal(done, 64);
    assert_true(readable(b, 2000));
    struct timespec pause = {0, 20000000L}; /* all 64 in the receive queue */
    nanosleep(&pause, NULL);
    for (int i = 0; i < 70; i++)
        m[i].len = 99;
    assert_int_equal(OPS->udp_recv_batch(CTX, b, m, 70, &done), DR_OK);
    assert_int_equal(done, 64);
    assert_int_equal(m[0].len, 8);
    assert_int_equal(m[3].len, 0);
    assert_int_equal(m[63].buf[0], 63);
    assert_int_equal(m[63].addr.addr, 0x7F000001u);
    assert_int_equal(OPS->udp_recv_batch(CTX, b, m, 70, &done), DR_EAGAIN);
    /* sending to a closed socket's descriptor */
    OPS->close(CTX, a);
    assert_int_equal(OPS->udp_send(CTX, a, big, 10, to), DR_EIO);
    assert_int_equal(OPS->udp_send_batch(CTX, a, m, 2, &done), DR_EIO);
    OPS->close(CTX, b);
}

static void test_timer_and_wait(void **state)
{
    (void)state;
    int t = -1;
    assert_int_equal(OPS->timer_open(CTX, &t), DR_OK);
    /* a deadline in the past (even 0) fires at once */
    assert_int_equal(OPS->timer_arm(CTX, t, 0), DR_OK);
    assert_true(readable(t, 1000));
    /* re-arming clears the expiry; UINT64_MAX disarms */
    assert_int_equal(OPS->timer_arm(CTX, t, OPS->now_us(CTX) + 20000u), DR_OK);
    assert_false(readable(t, 0));
    assert_true(readable(t, 1000));
    assert_int_equal(OPS->timer_arm(CTX, t, UINT64_MAX), DR_OK);
    assert_false(readable(t, 50));
    /* wait: returns at the deadline; more than eight handles are cut to
     * eight; a bad descriptor is an error */
    int hs[9];
    bool outs[9] = {false};
    for (int i = 0; i < 9; i++)
        hs[i] = t;
    uint64_t t0 = OPS->now_us(CTX);
    assert_int_equal(OPS->wait(CTX, hs, outs, 9, t0 + 30000u), DR_OK);
    assert_true(OPS->now_us(CTX) - t0 >= 29000u);
    t0 = OPS->now_us(CTX);
    assert_int_equal(OPS->wait(CTX, hs, outs, 1, t0 - 1u), DR_OK); /* past: at once */
    assert_true(OPS->now_us(CTX) - t0 < 1000000u);
    OPS->close(CTX, t);
    assert_int_equal(OPS->timer_arm(CTX, t, 1), DR_EIO);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_resolve, setup),
        cmocka_unit_test_setup(test_tcp_both_ends, setup),
        cmocka_unit_test_setup(test_udp, setup),
        cmocka_unit_test_setup(test_timer_and_wait, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
