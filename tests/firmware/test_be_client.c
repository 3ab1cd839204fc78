/* SPDX-License-Identifier: MIT */
/*
 * The client's wire handling on a big-endian CPU: built for s390x and run
 * under qemu-user against a native drsim on loopback (mk/firmware.mk,
 * check-be-client). Explicit Get/Set with echo and one Class 1 connection.
 *
 * usage: test_be_client HOST TCP_PORT LOCAL_ADDR LOCAL_UDP_PORT
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drive.h"

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: %s HOST TCP_PORT LOCAL_ADDR LOCAL_UDP_PORT\n", argv[0]);
        return 2;
    }
    unsigned char probe[2] = {0x12, 0x34};
    uint16_t v;
    memcpy(&v, probe, sizeof v);
    printf("be-client: this CPU is %s-endian\n", v == 0x1234 ? "big" : "little");
    drive_opts_t o;
    memset(&o, 0, sizeof o);
    o.name = "be-client";
    o.tp = dr_transport_posix();
    o.host = argv[1];
    o.tcp_port = (uint16_t)strtoul(argv[2], NULL, 10);
    o.local_addr = argv[3];
    o.local_udp_port = (uint16_t)strtoul(argv[4], NULL, 10);
    o.conns = 1;
    o.rpi_us = 10000;
    o.seconds = 2;
    return drive_run(&o);
}
