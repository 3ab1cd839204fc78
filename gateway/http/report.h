/* SPDX-License-Identifier: MIT */
/*
 * What the console's report part (core/north.h report and metrics ops,
 * core/log.h's ring, http/metrics.c) gives the server: /metrics and
 * /api/v1/log. Until that part is in, report_stub.c stands in (both
 * answer 501).
 */
#ifndef GW_HTTP_REPORT_H
#define GW_HTTP_REPORT_H

#include <stdbool.h>

#include "core/json.h"
#include "core/north.h"

/* /metrics: the Prometheus text (format 0.0.4) into out. False: not
 * served (501). */
bool gw_http_report_metrics(const gw_north_env_t *env, gw_json_t *out);

/* /api/v1/log: [{"time", "level", "text"}, ...], the last 200 log events.
 * False: not served (501). */
bool gw_http_report_log(const gw_north_env_t *env, gw_json_t *out);
/* /api/v1/writes: the same of the write log (its own ring). */
bool gw_http_report_writes(const gw_north_env_t *env, gw_json_t *out);

/* The sides' own objects ("modbus": {...}, "mqtt": {...}) as members of
 * the status's "sides" object (nothing: none). */
void gw_http_report_sides(const gw_north_env_t *env, gw_json_t *out);

#endif
