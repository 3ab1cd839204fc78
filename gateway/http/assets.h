/* SPDX-License-Identifier: MIT */
/*
 * The console's files (gateway/http/www/: its pages, script and style
 * sheet), built into the daemon: a plant network has no internet, so the
 * console loads nothing from outside, and an installed daemon needs no
 * folder of its own. mk/gen-assets.sh writes the table at build time
 * ($(B)/gateway/http/assets_gen.c) from the files as they are, with only
 * POSIX tools (od, awk).
 */
#ifndef DRGATE_GW_HTTP_ASSETS_H
#define DRGATE_GW_HTTP_ASSETS_H

#include <stddef.h>

typedef struct {
    const char *name;          /* file name in www/: "console.js" */
    const unsigned char *data; /* its bytes (not NUL-terminated) */
    size_t size;
    const char *type;          /* Content-Type: "text/javascript; charset=utf-8" */
    const char *etag;          /* strong validator, quoted: "\"1f2e3d4c-5120\"" */
} gw_http_asset_t;

/* The file `path` names: a file name of www/ as it follows /static/ in a
 * URL ("console.css"), or "index.html" (the overview, `/`) and
 * "robot.html" (`/robot/NAME`). A leading '/' is ignored; any other '/',
 * an empty name or an unknown one: NULL. */
const gw_http_asset_t *gw_http_asset_find(const char *path);

/* Every file, for listings and tests: i from 0 while not NULL. */
const gw_http_asset_t *gw_http_asset_at(size_t i);

#endif /* DRGATE_GW_HTTP_ASSETS_H */
