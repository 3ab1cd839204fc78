/* SPDX-License-Identifier: MIT */
/* The northbound sides the daemon runs: see north.h. */
#include "core/north.h"

const gw_north_ops_t *const gw_north_sides[GW_NORTH_SIDES] = {
    &gw_north_modbus, /* TCP and RTU */
    &gw_north_mqtt,
    &gw_north_http,
    &gw_north_gpio, /* last: its reload cannot be undone */
};
