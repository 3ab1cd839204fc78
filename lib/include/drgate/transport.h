/* SPDX-License-Identifier: MIT */
/*
 * drgate transport: the network and clock seen by the EtherNet/IP client.
 *
 * The client never calls the OS itself; it goes through this table, which
 * the application passes in (dr_client_config_t.transport), so that
 * firmware can plug in lwIP (port/lwip/) or a test a fake, while Linux uses
 * the sockets transport, dr_transport_posix(), which lives in its own
 * object (lib/transport_posix.c) that firmware does not link. Handles are
 * small integers chosen by the transport. Every call is non-blocking:
 * DR_EAGAIN means "nothing now". Addresses are IPv4 in host order.
 *
 * Required: resolve, tcp_connect, tcp_finish, tcp_send, tcp_recv, udp_open,
 * udp_send, udp_recv, close, now_us. Optional (NULL):
 *   - fd: no descriptors to poll; dr_client_pollfds() reports none.
 *   - wait: no blocking wait; the *_sync calls, dr_client_run_once() and
 *     dr_discover() then refuse with DR_EINVAL, and the application drives
 *     the client from its own loop or RTOS task with
 *     dr_client_next_deadline() and dr_client_process().
 *   - timer_open / timer_arm: no timer handle (both or neither); the
 *     application sleeps until dr_client_next_deadline() itself.
 *   - udp_send_batch / udp_recv_batch: one datagram per call instead.
 *   - tcp_abort: close instead (requests queued in TCP may then still
 *     reach the peer after the client gave up on them).
 *   - random: the client's own generator (the clock and a counter), which
 *     an attacker who knows roughly when the client started can predict:
 *     a firmware port should give its hardware RNG here.
 *   - tcp_connect_from: none; a client given a local address
 *     (dr_client_config_t.local_addr) is then refused (DR_EUNSUPPORTED),
 *     since its TCP connection could leave from another address.
 *   - tcp_local: the client cannot name the address its TCP connection
 *     leaves from (dr_client_t2o_addr says 0.0.0.0).
 * Calls come only from the thread that drives the client (see client.h).
 */
#ifndef DRGATE_TRANSPORT_H
#define DRGATE_TRANSPORT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* An IPv4 socket address, both fields in host order. */
typedef struct {
    uint32_t addr;
    uint16_t port;
} dr_sockaddr_t;

/* One datagram of a batch: buf/len to send, or buf/cap to receive into
 * (len and addr are then set). */
typedef struct {
    uint8_t *buf;
    size_t len;
    size_t cap;
    dr_sockaddr_t addr;
} dr_udp_msg_t;

typedef struct {
    /* Resolve a host name or dotted address. DR_ENOTFOUND. */
    dr_status_t (*resolve)(void *ctx, const char *host, uint32_t *addr);
    /* Start a TCP connection; DR_OK with *h set (it may still be pending). */
    dr_status_t (*tcp_connect)(void *ctx, dr_sockaddr_t to, int *h);
    /* DR_OK once connected, DR_EAGAIN while pending, else the failure. */
    dr_status_t (*tcp_finish)(void *ctx, int h);
    /* Send what fits now: *sent may be less than len. */
    dr_status_t (*tcp_send)(void *ctx, int h, const uint8_t *buf, size_t len,
                            size_t *sent);
    /* DR_EAGAIN: no data; DR_ECLOSED: orderly close by the peer. */
    dr_status_t (*tcp_recv)(void *ctx, int h, uint8_t *buf, size_t cap,
                            size_t *got);
    /* A UDP socket bound to local (addr 0 = any, port 0 = any). */
    dr_status_t (*udp_open)(void *ctx, dr_sockaddr_t local, int *h);
    dr_status_t (*udp_send)(void *ctx, int h, const uint8_t *buf, size_t len,
                            dr_sockaddr_t to);
    dr_status_t (*udp_recv)(void *ctx, int h, uint8_t *buf, size_t cap,
                            size_t *got, dr_sockaddr_t *from);
    /* Optional. A timer that makes its fd readable at an absolute
     * deadline; UINT64_MAX disarms it. Arming clears an earlier expiry. */
    dr_status_t (*timer_open)(void *ctx, int *h);
    dr_status_t (*timer_arm)(void *ctx, int h, uint64_t deadline_us);
    void (*close)(void *ctx, int h);
    /* Monotonic clock in microseconds. */
    uint64_t (*now_us)(void *ctx);
    /* Optional. The file descriptor to poll for a handle, -1 if none. */
    int (*fd)(void *ctx, int h);
    /* Optional. Block until one of the handles is readable (or writable,
     * where want_out[i] is set) or the deadline passes. Used only by the
     * client's blocking calls; event loops poll the fds themselves. */
    dr_status_t (*wait)(void *ctx, const int *h, const bool *want_out, int n,
                        uint64_t deadline_us);
    /* Optional (NULL: one udp_send / udp_recv each): several datagrams in
     * one call, which matters at 1 ms RPIs. *done: how many went or came;
     * receiving, DR_EAGAIN when none was waiting. */
    dr_status_t (*udp_send_batch)(void *ctx, int h, const dr_udp_msg_t *m,
                                  unsigned n, unsigned *done);
    dr_status_t (*udp_recv_batch)(void *ctx, int h, dr_udp_msg_t *m,
                                  unsigned n, unsigned *done);
    /* Optional (NULL: close). Close a TCP connection at once, dropping
     * what it has not yet sent or had acknowledged (POSIX: SO_LINGER 0,
     * the peer gets a reset): the client resets a session whose Forward
     * Open went unanswered, and its queued requests must never reach the
     * adapter later (see session_reset in lib/client_session.c). */
    void (*tcp_abort)(void *ctx, int h);
    /* Optional (NULL, or anything but DR_OK: the client's own generator).
     * Fill buf with len bytes from an unpredictable source (POSIX:
     * getrandom). The client draws its connection serials and T->O
     * connection IDs from it, so that an off-path sender cannot guess the
     * ID of a live connection (see "Who may send T->O data" in client.h).
     * Added after 1.0.0, at the end: a table written for 1.0.0 must be
     * rebuilt against this header (docs/api-changes.md). */
    dr_status_t (*random)(void *ctx, uint8_t *buf, size_t len);
    /* Optional. tcp_connect from the local address `from` (port 0: any).
     * The client connects with it whenever it has a local address: an
     * adapter takes the T->O address from the TCP peer (OpENer takes only
     * the port from the 0x8001 item), so TCP must leave from the address
     * the Forward Open announces. DR_EADDRNOTAVAIL: not of this host. */
    dr_status_t (*tcp_connect_from)(void *ctx, dr_sockaddr_t from, dr_sockaddr_t to, int *h);
    /* Optional. The local address of a TCP connection (after tcp_finish
     * said DR_OK). */
    dr_status_t (*tcp_local)(void *ctx, int h, dr_sockaddr_t *local);
} dr_transport_ops_t;

typedef struct {
    const dr_transport_ops_t *ops;
    void *ctx;
} dr_transport_t;

/* The Linux/POSIX sockets transport (non-blocking sockets, timerfd,
 * CLOCK_MONOTONIC), in lib/transport_posix.c: not part of firmware builds.
 * Its handles are its file descriptors. */
dr_transport_t dr_transport_posix(void);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_TRANSPORT_H */
