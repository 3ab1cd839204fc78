/* SPDX-License-Identifier: MIT */
/*
 * make bench: explicit Get_Attribute_Single round trips per second of our
 * client against drsim (bench/bench_enip.py compares them with a bare TCP
 * ping-pong and with pycomm3 in the same run). One session, one request
 * in flight, dr_client_read_asm_sync in a loop for SECONDS.
 *
 * usage: enip_gets HOST TCP_PORT ASSEMBLY SECONDS
 * prints: sizes REQ_BYTES REP_BYTES   (the encapsulated frames on the wire)
 *         gets ROUND_TRIPS SECONDS RATE_PER_S
 * SECONDS 0: read durations from stdin, one per line, and measure one
 * slice per line in the same session, until end of input.
 */
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cip_internal.h"
#include "drgate/client.h"

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: enip_gets HOST TCP_PORT ASSEMBLY SECONDS\n");
        return 2;
    }
    dr_asm_t a;
    double secs = strtod(argv[4], NULL);
    if (dr_asm_lookup(argv[3], &a) != DR_OK || !(secs >= 0.0)) {
        fprintf(stderr, "enip_gets: bad assembly or duration\n");
        return 2;
    }
    dr_client_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.host = argv[1];
    cfg.tcp_port = (uint16_t)strtoul(argv[2], NULL, 10);
    cfg.timeout_ms = 2000;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    if (c == NULL || dr_client_connect_sync(c) != DR_OK) {
        fprintf(stderr, "enip_gets: cannot register a session\n");
        dr_client_free(c);
        return 1;
    }
    /* The frames on the wire, for a ping-pong of the same sizes:
     * encapsulation header, interface handle and timeout, CPF count, null
     * address item, data item header; then the request (service, path
     * size, path) or the reply (service, reserved, status, extended
     * status size, data). */
    uint8_t path[8];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, DR_CIP_CLASS_ASSEMBLY, dr_client_instance(c, a), DR_CIP_ASM_ATTR_DATA);
    size_t frame = DR_ENCAP_HEADER_LEN + 6u + 2u + 4u + 4u;
    printf("sizes %zu %zu\n", frame + 2u + w.len, frame + 4u + dr_asm_info(a)->size);
    fflush(stdout);
    uint8_t buf[DR_ASM_MAX_SIZE];
    int status = 0;
    char line[64];
    bool once = secs > 0.0;
    while (status == 0) {
        if (!once) {
            if (fgets(line, sizeof line, stdin) == NULL)
                break;
            secs = strtod(line, NULL);
            if (!(secs > 0.0))
                break;
        }
        unsigned long n = 0;
        double t0 = now_s(), t = t0;
        while (t - t0 < secs) {
            dr_status_t st = dr_client_read_asm_sync(c, a, buf, dr_asm_info(a)->size);
            if (st != DR_OK) {
                fprintf(stderr, "enip_gets: %s\n", dr_strerror(st));
                status = 1;
                break;
            }
            n++;
            if ((n & 63u) == 0)
                t = now_s();
        }
        t = now_s() - t0;
        printf("gets %lu %.3f %.1f\n", n, t, (double)n / t);
        fflush(stdout);
        if (once)
            break;
    }
    dr_client_free(c);
    return status;
}
