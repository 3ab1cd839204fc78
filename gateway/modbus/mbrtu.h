/* SPDX-License-Identifier: MIT */
/*
 * The Modbus RTU side of the gateway: one serial line (RS-232 or RS-485)
 * on which the gateway is a slave answering for some robots, each at its
 * own slave address.
 *
 * The port is non-blocking in the daemon's epoll loop. Frames are cut by
 * mbproto.c (gw_rtu_rx_*): a request whose function code gives its length
 * is taken as soon as it is whole and its CRC checks; anything else ends
 * at t3.5 of silence (3.5 character times; a fixed 1.75 ms above 19200
 * baud, as the Modbus serial line specification says). Each request's
 * PDU goes to the one request handler (gw_mb_handle). A frame with a bad
 * CRC, or for an address that is not ours, is dropped without a word (a
 * slave must not answer it) and counted; a write to address 0
 * (broadcast) is applied to every robot on the line and not answered.
 */
#ifndef DRGATE_GW_MBRTU_H
#define DRGATE_GW_MBRTU_H

#include <stdbool.h>
#include <stdint.h>

#include "core/config.h"
#include "modbus/mbserver.h"
#include "modbus/regmap.h"

typedef struct gw_rtu gw_rtu_t;

/* Counters of one line (wrap at 2^32). */
typedef struct {
    uint32_t requests;   /* frames for us with a good CRC (broadcast included) */
    uint32_t crc_errors; /* frames dropped: bad CRC, too short or too long */
    uint32_t other;      /* good frames for another slave address */
    uint32_t exceptions; /* exception replies sent */
} gw_rtu_counters_t;

/* Open and set up the port as `cfg` says and register in the epoll set.
 * hooks->unit_for is asked by unit ID: the line's slave addresses are
 * turned into the robots' unit IDs first (config: robots = NAME:ADDRESS),
 * using `robots` (the robot sections, for their unit IDs). NULL on error
 * with a message in err. An RS-485 request (TIOCSRS485) the port refuses
 * is logged as a warning, not an error: many USB adapters switch the
 * driver by themselves and have no such ioctl. */
gw_rtu_t *gw_rtu_new(const gw_rtu_config_t *cfg, const gw_robot_config_t *robots, int epfd,
                     const gw_mbs_hooks_t *hooks, char *err, size_t errlen);
void gw_rtu_free(gw_rtu_t *t);

/* Frames that end at the silence: call at least every gw_rtu_next_deadline(). */
void gw_rtu_tick(gw_rtu_t *t, uint64_t now_us);
uint64_t gw_rtu_next_deadline(const gw_rtu_t *t);

const gw_rtu_counters_t *gw_rtu_counters(const gw_rtu_t *t);
/* The master's last requests on this line (reqlog.h). */
const gw_reqlog_t *gw_rtu_reqlog(const gw_rtu_t *t);
/* Does the line serve this robot (by unit ID)? */
bool gw_rtu_serves(const gw_rtu_t *t, uint8_t unit_id);
/* t3.5 of a line at `baud` in microseconds (1.75 ms above 19200). */
uint64_t gw_rtu_t35_us(unsigned baud, unsigned bits_per_char);

#endif /* DRGATE_GW_MBRTU_H */
