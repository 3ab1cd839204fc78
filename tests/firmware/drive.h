/* SPDX-License-Identifier: MIT */
/*
 * The firmware client test: one scenario run over any transport, against
 * drsim. tests/firmware/test_lwip.c runs it on lwIP (a TAP device in a
 * network namespace), test_be_client.c on a big-endian CPU (qemu-user
 * s390x, POSIX transport). The client lives in static storage
 * (dr_client_init) and is closed without blocking (dr_client_close_start).
 */
#ifndef DRGATE_TEST_DRIVE_H
#define DRGATE_TEST_DRIVE_H

#include <stdint.h>

#include "drgate/client.h"

typedef struct {
    const char *name;        /* for the report lines */
    dr_transport_t tp;
    const char *host;        /* drsim's address */
    uint16_t tcp_port;       /* 0: 44818 */
    const char *local_addr;  /* NULL: any */
    uint16_t local_udp_port; /* 0: 2222 */
    unsigned conns;          /* Class 1 connections, 0..6 */
    uint32_t rpi_us;
    unsigned seconds;        /* Class 1 traffic for this long */
    /* NULL: the loop waits in the transport (dr_client_run_once). Else
     * the loop of a firmware task: sleep until the next tick (tick_us) or
     * the client's deadline, then dr_client_process. */
    void (*sleep_us)(uint32_t us);
    uint32_t tick_us;
} drive_opts_t;

/* Runs ListIdentity (UDP and TCP), Get of all ten assemblies, a Set with
 * drsim's echo, the Class 1 connections, and the close. Prints one line
 * per step and the figures; returns 0 if all went as expected. */
int drive_run(const drive_opts_t *o);

#endif
