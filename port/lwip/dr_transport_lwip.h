/* SPDX-License-Identifier: MIT */
/*
 * drgate on lwIP: a dr_transport_t over lwIP's socket API (lwip_socket,
 * lwip_recvfrom, ... by their lwip_ names, so it builds with
 * LWIP_COMPAT_SOCKETS 0 as well as 1).
 *
 * Why the socket API rather than the raw API: the client is a loop that
 * asks "is there data?" and never blocks, which is what non-blocking
 * sockets answer, from any task; the raw API would call us back from the
 * tcpip thread with pbufs that must be queued and copied into the client's
 * task anyway. It needs LWIP_SOCKET (and NO_SYS 0, an RTOS); LWIP_POLL
 * gives the blocking wait of the client's *_sync calls.
 *
 * The transport has no fd and no timer: the application's task calls
 * dr_client_process() no later than dr_client_next_deadline() (and sooner
 * when it likes: an RTOS tick of 1 ms is fine). With LWIP_POLL, wait is
 * there too, so dr_client_connect_sync() and the other blocking calls
 * work, with Class 1 traffic flowing meanwhile.
 *
 * Handles are lwIP socket numbers. Addresses: dotted IPv4 only (no DNS).
 * One dr_lwip_t per transport; it is not shared between tasks.
 */
#ifndef DRGATE_TRANSPORT_LWIP_H
#define DRGATE_TRANSPORT_LWIP_H

#include <stdint.h>

#include "drgate/transport.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct {
    /* Monotonic microseconds, e.g. a hardware timer; NULL: lwIP's
     * sys_now() x 1000 (millisecond steps, fine for RPIs of 10 ms and up). */
    uint64_t (*now_us)(void *user);
    void *user;
} dr_lwip_t;

/* The transport over `lw` (which must outlive every client using it). */
dr_transport_t dr_transport_lwip(dr_lwip_t *lw);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_TRANSPORT_LWIP_H */
