/* SPDX-License-Identifier: MIT */
/*
 * The console's JSON API and its summaries (docs/http.md), written with
 * core/json.h into the caller's buffer (no allocation): what the daemon
 * knows of itself and its robots, as the routes of north_http.c serve it,
 * and the human summary that `drgatewayd status` prints and that the
 * daemon sends to systemd (STATUS=).
 */
#ifndef GW_HTTP_API_H
#define GW_HTTP_API_H

#include <stdbool.h>
#include <stdint.h>

#include "core/json.h"
#include "core/north.h"

/* What the API says of the daemon beside the robots. */
typedef struct {
    const gw_north_env_t *env;
    uint64_t uptime_s;
    unsigned generation; /* configuration reloads so far */
} gw_http_api_t;

/* The configuration file's path as an absolute one (-c with a relative
 * path: joined to the working directory of the start). */
const char *gw_http_api_config_path(const gw_config_t *cfg);

/* The robot named `name` (its index), -1 if none. */
int gw_http_api_find(const gw_http_api_t *a, const char *name);

/* ROBOT: {"name", "link", "state", "ever_linked", "host", "tcp_port",
 * "udp_port", "mode", "layout", "originator_serial", "sides", "reason",
 * "rpi_ms", "age_ms", "fresh", "robot_state", "servo_on", "values_stale",
 * "heartbeat", "connections", "rx_packets", "lost_packets", ...,
 * "last_error", "last_write"} (docs/http.md). */
void gw_http_api_robot(gw_json_t *j, const gw_http_api_t *a, unsigned r);
/* [ROBOT, ...] */
void gw_http_api_robots(gw_json_t *j, const gw_http_api_t *a);
/* {"version", "uptime_s", "config": {"file", "generation"}, "robots",
 * "sides"} */
void gw_http_api_status(gw_json_t *j, const gw_http_api_t *a);

/* {"path": value, ...}: every leaf of the robot's images, keyed and
 * valued as `drcli get --json` prints them (dr_text_json), in the
 * library's leaf order; `indent`: as drcli lays it out (two spaces per
 * line), else on one line. With `last` (dr_leaf_count() values' bits,
 * each byte GW_HTTP_API_UNSENT before the first), only the leaves whose
 * value differs from it, which is then updated. Returns how many leaves
 * were written. */
#define GW_HTTP_API_UNSENT 0xFF
/* Leaves whose path and last text api.c keeps (the field table has 371). */
#define GW_HTTP_API_LEAVES 512u
unsigned gw_http_api_values(gw_json_t *j, const gw_robot_t *rb, bool indent, uint64_t *last);

/* The link state in words: "up", "connecting", "down". */
const char *gw_http_api_link_name(const gw_robot_t *rb);
/* The same, "never linked" for a robot whose link was never up. */
const char *gw_http_api_state_name(const gw_robot_t *rb);

/* The human summary (`drgatewayd status`), lines of text: the daemon,
 * its robots, then each side's line (env->summaries). */
void gw_http_api_summary(gw_json_t *j, const gw_http_api_t *a);
/* Robots not linked. */
unsigned gw_http_api_down(const gw_http_api_t *a);
/* systemd's STATUS= line is the daemon's: gw_report_notify (core/report.h). */

#endif
