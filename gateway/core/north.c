/* SPDX-License-Identifier: MIT */
/* The northbound sides the daemon runs: see north.h. */
#include "core/north.h"

/* From the side list (gateway/sides.h), in its order. */
#define GW_NORTH_ENTRY(name) &gw_north_##name,
const gw_north_ops_t *const gw_north_sides[GW_NORTH_SIDES] = {
    GW_SIDES(GW_NORTH_ENTRY)
};
#undef GW_NORTH_ENTRY
