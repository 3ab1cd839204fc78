/* SPDX-License-Identifier: MIT */
/*
 * The side list: the one place that names every northbound side of
 * drgatewayd (docs/gateway.md "Adding a side"). Nothing in gateway/core/
 * names a side; the core expands this list where it needs every side:
 *
 *   core/config.h   gw_sides_config_t: one member per side, `NAME`, of the
 *                   side's type gw_NAME_side_config_t (its config_NAME.h)
 *   core/config.c   gw_side_cfgs[]: what the side is to the configuration,
 *                   gw_side_cfg_NAME (its config_NAME.c: its sections and
 *                   what it says to the write path; core/config.h)
 *   core/north.c    gw_north_sides[]: the side's operations gw_north_NAME
 *                   (its north_NAME.c; core/north.h)
 *
 * and counts them (GW_NORTH_SIDES). A side is a folder NAME/ with those
 * three names, one #include below and one X(NAME) in GW_SIDES.
 *
 * The order is the daemon's: every loop hook, a reload's prepare and
 * commit, and the status summary's lines go down the list, shutdown's
 * safe() up it. A side whose prepare() cannot be undone (GPIO: lines
 * released and requested again) comes last. Where a section comes in
 * messages and docs is its own (gw_cfg_side_t.rank), not the list's.
 */
#ifndef DRGATE_GW_SIDES_H
#define DRGATE_GW_SIDES_H

#include "modbus/config_modbus.h"
#include "mqtt/config_mqtt.h"
#include "http/config_http.h"
#include "opcua/config_opcua.h"
#include "gpio/config_gpio.h"

#define GW_SIDES(X) \
    X(modbus)       \
    X(mqtt)         \
    X(http)         \
    X(opcua)        \
    X(gpio) /* last: its reload cannot be undone */

/* How many sides the list has. */
#define GW_SIDE_ONE(name) +1u
#define GW_SIDE_COUNT (0u GW_SIDES(GW_SIDE_ONE))

#endif /* DRGATE_GW_SIDES_H */
