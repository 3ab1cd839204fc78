/* SPDX-License-Identifier: MIT */
/*
 * What the console's pages part (gateway/http/www/, docs/http.md) gives
 * the server: the pages and assets embedded at build time, and the robot
 * page's map of fields. Until that part is in, asset_stub.c stands in
 * (a plain built-in page, no map).
 */
#ifndef GW_HTTP_ASSET_H
#define GW_HTTP_ASSET_H

#include <stdbool.h>
#include <stddef.h>

#include "core/json.h"
#include "core/north.h"

typedef struct {
    const char *name; /* "index.html", "robot.html", "console.js", ... */
    const char *type; /* Content-Type: "text/html; charset=utf-8", ... */
    const unsigned char *data;
    size_t size;
} gw_http_asset_t;

/* The asset called `name` (no leading '/'), NULL if none. */
const gw_http_asset_t *gw_http_asset_find(const char *name);

/* /api/v1/robots/NAME/map: every field of robot `robot` with its type,
 * unit, direction, enum names and Modbus addresses. False: not served
 * (404), or j is full. GW_HTTP_MAP_MAX bytes always hold it (a side's
 * map_json answer is at most GW_NORTH_MAP_MAX: the Modbus side checks its
 * largest user map's against it). */
#define GW_HTTP_MAP_MAX GW_NORTH_MAP_MAX
bool gw_http_api_map(gw_json_t *j, const gw_north_env_t *env, unsigned robot);

#endif
