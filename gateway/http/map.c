/* SPDX-License-Identifier: MIT */
/*
 * /api/v1/robots/NAME/map (asset.h): the robot's register map as the
 * robot page shows it, written by the Modbus side's map itself
 * (gw_regmap_json), from the slots that serve requests and that
 * `drgatewayd --print-map` prints: the addresses are never worked out
 * twice.
 */
#include "http/asset.h"
#include "modbus/regmap.h"

/* The server's response buffer (GW_HTTP_MAP_MAX) holds any map: a
 * compile-time check, as C99 has no static assertion (the two are equal
 * today, which clang-tidy takes for a redundant comparison). */
typedef char gw_http_map_fits[GW_HTTP_MAP_MAX >= GW_REGMAP_JSON_SIZE ? 1 : -1]; // NOLINT(misc-redundant-expression)

bool gw_http_api_map(gw_json_t *j, const gw_config_t *cfg, unsigned robot)
{
    return gw_regmap_json(j, cfg, robot);
}
