/* SPDX-License-Identifier: MIT */
/*
 * The client on a real lwIP stack: Debian's lwIP 2.1.3 with its Linux
 * user-space port (tcpip thread, TAP driver), our client on it through
 * port/lwip's transport, drsim on the Linux kernel's stack at the other
 * end of the TAP device. tests/firmware/lwip.sh sets up the network
 * namespace and the device (PRECONFIGURED_TAPIF names it for tapif).
 *
 * The client's task is the firmware kind: its loop wakes every 1 ms tick
 * or at dr_client_next_deadline(), whichever is first, and calls
 * dr_client_process(); the client lives in static storage.
 *
 * usage: test_lwip LWIP_ADDR NETMASK DRSIM_ADDR SECONDS
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "lwip/init.h"
#include "lwip/ip4_addr.h"
#include "lwip/netif.h"
#include "lwip/sys.h"
#include "lwip/tcpip.h"
#include "netif/tapif.h"

#include "dr_transport_lwip.h"
#include "drive.h"

static struct netif nif;
static ip4_addr_t ip, mask, gw;

/* Runs in lwIP's tcpip thread: the interface is added there. */
static void on_tcpip_up(void *arg)
{
    sys_sem_t *up = arg;
    netif_add(&nif, &ip, &mask, &gw, NULL, tapif_init, tcpip_input);
    netif_set_default(&nif);
    netif_set_up(&nif);
    netif_set_link_up(&nif);
    sys_sem_signal(up);
}

/* The test's microsecond clock (firmware: a hardware timer). */
static uint64_t mono_us(void *user)
{
    struct timespec ts;
    (void)user;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}

/* The RTOS's task delay. */
static void task_sleep_us(uint32_t us)
{
    struct timespec ts = {(time_t)(us / 1000000u), (long)(us % 1000000u) * 1000L};
    nanosleep(&ts, NULL);
}

int main(int argc, char **argv)
{
    if (argc != 5 || !ip4addr_aton(argv[1], &ip) || !ip4addr_aton(argv[2], &mask)) {
        fprintf(stderr, "usage: %s LWIP_ADDR NETMASK DRSIM_ADDR SECONDS\n", argv[0]);
        return 2;
    }
    ip4_addr_set_zero(&gw);
    sys_sem_t up;
    if (sys_sem_new(&up, 0) != ERR_OK)
        return 1;
    tcpip_init(on_tcpip_up, &up);
    sys_sem_wait(&up);
    printf("lwip: lwIP %s up on %s, %s\n", LWIP_VERSION_STRING, getenv("PRECONFIGURED_TAPIF"),
           argv[1]);

    static dr_lwip_t lw = {mono_us, NULL};
    dr_transport_t tp = dr_transport_lwip(&lw);
    /* The transport's sockets must not block: a receive with nothing
     * there answers at once. */
    int h;
    dr_sockaddr_t any = {0, 0};
    uint8_t buf[16];
    size_t got;
    dr_sockaddr_t from;
    if (tp.ops->udp_open(tp.ctx, any, &h) != DR_OK ||
        tp.ops->udp_recv(tp.ctx, h, buf, sizeof buf, &got, &from) != DR_EAGAIN) {
        printf("lwip: FAIL the transport's UDP socket is not non-blocking\n");
        return 1;
    }
    tp.ops->close(tp.ctx, h);

    drive_opts_t o;
    memset(&o, 0, sizeof o);
    o.name = "lwip";
    o.tp = tp;
    o.host = argv[3];
    o.conns = 6;
    o.rpi_us = 10000;
    o.seconds = (unsigned)strtoul(argv[4], NULL, 10);
    o.sleep_us = task_sleep_us;
    o.tick_us = 1000;
    int rc = drive_run(&o);
    /* lwIP's threads do not stop; the process ends here. */
    (void)fflush(stdout);
    return rc;
}
