/* SPDX-License-Identifier: MIT */
/*
 * The latency instrumentation of the benchmark's drgatewayd-lat
 * (mk/bench_gw.mk, bench/gw_bench.py), linked into that build only, never
 * into the installed daemon: for every T->O packet, the kernel's receive
 * timestamp of the datagram (SIOCGSTAMPNS on the Class 1 socket: when it
 * entered this host's network stack), the time the event loop last woke up
 * (its epoll wait returned: see gw_lat_hook.h) and the time its data is in
 * the robot's image that Modbus reads answer from, all CLOCK_REALTIME. Kept
 * in memory, written at exit to $GW_BENCH_LATENCY_FILE as lines
 * "ARRIVAL WAKE VISIBLE" (ns). Costs one ioctl and two clock reads a packet,
 * and the Class 1 port is read one datagram at a time (lat_transport),
 * which puts the figures on the safe side by about a microsecond for each
 * packet ahead in the same burst.
 *
 * It sees the links through their observer (gateway/core/link.h:
 * gw_link_observe), registered before main() runs, so the gateway's
 * sources have no code of the benchmark's.
 */
#include "gw_lat_hook.h" /* first, as -include puts it in every other source */

#include <linux/sockios.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <time.h>

#include "core/link.h"
#include "core/log.h"

#define LAT_MAX (1u << 20)

static struct lat_sample {
    int64_t at_ns, wake_ns, vis_ns;
} *lat_samples;
static size_t lat_count;
static int64_t lat_wake_ns;

static int64_t realtime_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

/* The loop's epoll_wait (renamed by the hook); epoll_pwait with no signal
 * mask is the same call. */
int gw_bench_epoll_wait(int epfd, struct epoll_event *events, int maxevents, int timeout)
{
    int n = epoll_pwait(epfd, events, maxevents, timeout, NULL);
    lat_wake_ns = realtime_ns();
    return n;
}

/* The loop woke up from epoll_pwait2 (a syscall(), which the hook cannot
 * rename: the loop calls this after it). */
void gw_bench_woke(void)
{
    lat_wake_ns = realtime_ns();
}

static void lat_dump(void)
{
    const char *path = getenv("GW_BENCH_LATENCY_FILE");
    FILE *f = path != NULL ? fopen(path, "w") : NULL;
    if (f == NULL)
        return;
    for (size_t i = 0; i < lat_count; i++)
        (void)fprintf(f, "%lld %lld %lld\n", (long long)lat_samples[i].at_ns,
                      (long long)lat_samples[i].wake_ns, (long long)lat_samples[i].vis_ns);
    if (fclose(f) != 0)
        gw_log(GW_LOG_ERROR, "bench: cannot write %s", path);
}

/* The link observer's on_t2o: the packet read on udp_fd is in the image. */
static void lat_record(void *user, unsigned robot, dr_asm_t a, int udp_fd)
{
    struct timespec arr;
    int64_t now = realtime_ns();
    (void)user, (void)robot, (void)a;
    if (udp_fd < 0 || ioctl(udp_fd, SIOCGSTAMPNS, &arr) < 0)
        return;
    if (lat_samples == NULL) {
        lat_samples = calloc(LAT_MAX, sizeof *lat_samples);
        if (lat_samples == NULL)
            return;
        if (atexit(lat_dump) != 0) {
            free(lat_samples);
            lat_samples = NULL;
            return;
        }
    }
    int64_t at = (int64_t)arr.tv_sec * 1000000000 + arr.tv_nsec;
    if (at > 0 && lat_count < LAT_MAX)
        lat_samples[lat_count++] = (struct lat_sample){at, lat_wake_ns, now};
}

/* The daemon reads the Class 1 port in batches (recvmmsg); the socket's
 * timestamp is that of the last datagram read, so this build reads them
 * one at a time. */
static dr_transport_ops_t lat_ops;
static gw_link_observer_t lat_observer = {lat_record, {NULL, NULL}, NULL};

/* Before main(): the links are made at start, and their shared ports take
 * the observer's transport when they open. (A GCC and Clang attribute, as
 * -include, which this build needs anyway, is their option.) */
static void lat_register(void) __attribute__((constructor));
static void lat_register(void)
{
    dr_transport_t t = dr_transport_posix();
    lat_ops = *t.ops;
    lat_ops.udp_recv_batch = NULL;
    t.ops = &lat_ops;
    lat_observer.port_transport = t;
    gw_link_observe(&lat_observer);
}
