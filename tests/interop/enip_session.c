/* SPDX-License-Identifier: MIT */
/*
 * One complete EtherNet/IP session of our client against drsim, for
 * test_tshark.py to capture and have Wireshark's dissectors decode:
 * RegisterSession, Get_Attribute_Single on every assembly (data and size),
 * Identity Get_Attributes_All, Set_Attribute_Single, ListIdentity, a
 * Forward Open (0x54) and a Large Forward Open (0x5B), Class 1 I/O both
 * ways for a while, Forward Close of both, UnRegisterSession.
 *
 * usage: enip_session HOST TCP_PORT LOCAL_ADDR LOCAL_UDP_PORT
 *
 * It prints what it sent, one fact per line, for the test to compare with
 * what Wireshark decoded:
 *   request SERVICE CLASS INSTANCE ATTRIBUTE   (hex; attribute - if none)
 *   conn N O2T_CID T2O_CID LARGE TX RX          (hex CIDs; packet counts)
 *   output N HEX                                (O->T data of connection N)
 *   done
 * Exit status 0 if every step worked. Every step has a timeout.
 */
#define _GNU_SOURCE
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cip_internal.h"
#include "drgate/client.h"

#define RPI_US 10000u

static uint64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

static int fail(const char *what, dr_status_t st)
{
    fprintf(stderr, "enip_session: %s: %s\n", what, dr_strerror(st));
    return 1;
}

static void print_request(uint8_t svc, unsigned cls, unsigned inst, int attr)
{
    if (attr < 0)
        printf("request %02x %x %x -\n", svc, cls, inst);
    else
        printf("request %02x %x %x %x\n", svc, cls, inst, (unsigned)attr);
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: enip_session HOST TCP_PORT LOCAL_ADDR LOCAL_UDP_PORT\n");
        return 2;
    }
    dr_client_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.host = argv[1];
    cfg.tcp_port = (uint16_t)strtoul(argv[2], NULL, 10);
    cfg.local_addr = argv[3];
    cfg.local_udp_port = (uint16_t)strtoul(argv[4], NULL, 10);
    cfg.timeout_ms = 2000;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    if (c == NULL)
        return fail("new", DR_EINVAL);
    dr_status_t st = dr_client_connect_sync(c);
    if (st != DR_OK)
        return fail("register session", st);

    uint8_t buf[DR_ASM_MAX_SIZE];
    for (int a = 0; a < DR_ASM_COUNT; a++) {
        uint16_t inst = dr_client_instance(c, (dr_asm_t)a), size = 0;
        print_request(DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, DR_CIP_CLASS_ASSEMBLY, inst, 3);
        st = dr_client_read_asm_sync(c, (dr_asm_t)a, buf, dr_asm_info((dr_asm_t)a)->size);
        if (st != DR_OK)
            return fail("get", st);
        print_request(DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, DR_CIP_CLASS_ASSEMBLY, inst, 4);
        st = dr_client_read_asm_size_sync(c, inst, &size);
        if (st != DR_OK)
            return fail("get size", st);
    }
    dr_identity_t id;
    print_request(DR_CIP_SVC_GET_ATTRIBUTES_ALL, DR_CIP_CLASS_IDENTITY, 1, -1);
    if ((st = dr_client_read_identity_sync(c, &id)) != DR_OK)
        return fail("identity", st);
    uint8_t ints[96];
    for (unsigned i = 0; i < sizeof ints; i++)
        ints[i] = (uint8_t)(i * 3u + 1u);
    print_request(DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, DR_CIP_CLASS_ASSEMBLY,
                  dr_client_instance(c, DR_ASM_INT_IN), 3);
    if ((st = dr_client_write_asm_sync(c, DR_ASM_INT_IN, ints, sizeof ints)) != DR_OK)
        return fail("set", st);
    if ((st = dr_client_list_identity_sync(c, &id)) != DR_OK)
        return fail("list identity", st);

    /* Two Class 1 connections: io_control -> io_state with a plain
     * Forward Open, input-only joint_state with a Large Forward Open. */
    dr_conn_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.o2t_asm = DR_ASM_IO_CONTROL;
    cc.t2o_asm = DR_ASM_IO_STATE;
    cc.rpi_us = RPI_US;
    cc.timeout_mult = 2;
    dr_conn_t *cn[2];
    cn[0] = dr_conn_add(c, &cc, &st);
    cc.o2t_asm = -1;
    cc.t2o_asm = DR_ASM_JOINT_STATE;
    cc.large = true;
    cn[1] = dr_conn_add(c, &cc, &st);
    if (cn[0] == NULL || cn[1] == NULL)
        return fail("conn add", st);
    static const uint8_t ctl[12] = {0x01, 0x80, 0x04, 0x00, 0, 0, 0x80, 0x3F};
    if ((st = dr_conn_set_output(cn[0], ctl, sizeof ctl)) != DR_OK)
        return fail("set output", st);
    dr_client_start(c);
    /* Open both (bounded), then run 0.5 s of I/O. */
    for (int i = 0; i < 500; i++) {
        if (dr_conn_state(cn[0]) == DR_CONN_ESTABLISHED &&
            dr_conn_state(cn[1]) == DR_CONN_ESTABLISHED)
            break;
        dr_client_run_once(c, 10);
    }
    for (int k = 0; k < 2; k++)
        if (dr_conn_state(cn[k]) != DR_CONN_ESTABLISHED)
            return fail("forward open", DR_ETIMEDOUT);
    print_request(DR_CIP_SVC_FORWARD_OPEN, DR_CIP_CLASS_CONNECTION_MANAGER, 1, -1);
    print_request(DR_CIP_SVC_LARGE_FORWARD_OPEN, DR_CIP_CLASS_CONNECTION_MANAGER, 1, -1);
    uint64_t until = now_ms() + 500;
    while (now_ms() < until)
        dr_client_run_once(c, 10);
    for (int k = 0; k < 2; k++) {
        const dr_conn_stats_t *s = dr_conn_stats(cn[k]);
        if (s->rx_packets == 0 || s->tx_packets == 0 || s->rx_bad != 0)
            return fail("I/O", DR_EIO);
        printf("conn %d %08x %08x %d %llu %llu\n", k, (unsigned)s->o2t_cid, (unsigned)s->t2o_cid,
               k == 1, (unsigned long long)s->tx_packets, (unsigned long long)s->rx_packets);
    }
    printf("output 0 ");
    for (unsigned i = 0; i < sizeof ctl; i++)
        printf("%02x", ctl[i]);
    printf("\n");
    print_request(DR_CIP_SVC_FORWARD_CLOSE, DR_CIP_CLASS_CONNECTION_MANAGER, 1, -1);
    print_request(DR_CIP_SVC_FORWARD_CLOSE, DR_CIP_CLASS_CONNECTION_MANAGER, 1, -1);
    dr_client_close_sync(c); /* Forward Close both, UnRegisterSession */
    dr_client_free(c);
    printf("done\n");
    return 0;
}
