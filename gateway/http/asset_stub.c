/* SPDX-License-Identifier: MIT */
/*
 * Stand-ins for the console's pages part (asset.h) until it is in: one
 * plain page that lists the robots and the API, and no map. The pages
 * part replaces this file with its generated asset table.
 */
#include "http/asset.h"

#include <string.h>

static const char index_html[] =
    "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>drgatewayd</title></head>\n"
    "<body><h1>drgatewayd</h1>\n<p>The console's pages are not built into this gateway. "
    "Its JSON API:</p>\n<ul>\n<li><a href=\"/api/v1/status\">/api/v1/status</a></li>\n"
    "<li><a href=\"/api/v1/robots\">/api/v1/robots</a></li>\n"
    "<li><a href=\"/metrics\">/metrics</a></li>\n</ul>\n</body></html>\n";

static const gw_http_asset_t assets[] = {
    {"index.html", "text/html; charset=utf-8", (const unsigned char *)index_html,
     sizeof index_html - 1},
    {"robot.html", "text/html; charset=utf-8", (const unsigned char *)index_html,
     sizeof index_html - 1},
};

const gw_http_asset_t *gw_http_asset_find(const char *name)
{
    for (size_t i = 0; i < sizeof assets / sizeof assets[0]; i++)
        if (strcmp(assets[i].name, name) == 0)
            return &assets[i];
    return NULL;
}

bool gw_http_api_map(gw_json_t *j, const gw_config_t *cfg, unsigned robot)
{
    (void)j, (void)cfg, (void)robot;
    return false;
}
