/* SPDX-License-Identifier: MIT */
/*
 * The example firmware's one task: a client in static storage with one
 * Class 1 connection (int_in out, int_out back at RPI 10 ms), driven from
 * the main loop by dr_client_next_deadline() and dr_client_process()
 * (docs/firmware.md, "A minimal lwIP task", without an RTOS).
 */
#include <stddef.h>
#include <stdint.h>

#include "board.h"
#include "drgate/client.h"

static dr_client_storage_t storage;
static uint8_t outputs[96];    /* int_in, as the PLC side sets it */
static volatile int32_t seen;  /* int_out[0] as the robot last sent it */

static void on_data(dr_conn_t *cn, const uint8_t *data, size_t len, void *user)
{
    (void)cn;
    (void)user;
    if (len >= 4)
        seen = (int32_t)dr_get_le32(data);
}

int main(void)
{
    dr_client_config_t cfg = {0};
    cfg.host = "192.168.1.20";
    cfg.transport = board_transport();
    /* Stable across restarts (docs/firmware.md, "The originator serial"):
     * from something unique to the device, such as its MAC address. */
    cfg.serial = dr_originator_serial("00:1d:9c:c8:12:34", "robot1");
    dr_client_t *c = dr_client_init(&storage, sizeof storage, &cfg, NULL);
    if (c == NULL)
        return 1;

    dr_conn_config_t cc = {0};
    cc.o2t_asm = DR_ASM_INT_IN;
    cc.t2o_asm = DR_ASM_INT_OUT;
    cc.rpi_us = 10000;
    cc.timeout_mult = 2; /* x16: 160 ms */
    cc.on_data = on_data;
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    if (cn == NULL)
        return 1;
    dr_client_start(c); /* connects, opens, reconnects by itself */

    for (;;) {
        /* Every SysTick (1 ms) wakes the loop: reading the sockets then is
         * enough for RPIs of 10 ms; sleep longer when nothing is due. */
        if (dr_client_next_deadline(c) > board_now_us())
            board_idle();
        dr_conn_set_output(cn, outputs, sizeof outputs);
        dr_client_process(c);
    }
}
