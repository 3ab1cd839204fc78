/* SPDX-License-Identifier: MIT */
/*
 * /api/v1/robots/NAME/map (asset.h): the robot's register map as the
 * robot page shows it, written by the side that has one (the Modbus
 * side's map_json op, reached through env->map: core/north.h), from the
 * slots that serve requests and that `drgatewayd --print-map` prints: the
 * addresses are never worked out twice, and the console names no other
 * side.
 */
#include "http/asset.h"

bool gw_http_api_map(gw_json_t *j, const gw_north_env_t *env, unsigned robot)
{
    return env->map != NULL && env->map(env->user, j, robot);
}
