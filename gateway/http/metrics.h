/* SPDX-License-Identifier: MIT */
/*
 * What the console's HTTP side (north_http.c, api.c) serves from the
 * report part: GET /metrics (the Prometheus text of the core and of every
 * side, north.h env->metrics), GET /api/v1/log (the log ring, core/log.h)
 * and a robot's last write (robot.h last_write) for the ROBOT object.
 * Times are ISO 8601 in UTC with milliseconds ("2026-11-25T14:48:10.123Z").
 */
#ifndef DRGATE_GW_HTTP_METRICS_H
#define DRGATE_GW_HTTP_METRICS_H

#include <stddef.h>

#include "core/json.h"
#include "core/north.h"

/* The content type of GET /metrics. */
#define GW_HTTP_METRICS_TYPE "text/plain; version=0.0.4; charset=utf-8"

/* The whole /metrics text into buf[cap]: its length, or 0 if it did not
 * fit (nothing to send: answer 500, or retry with a larger buffer). */
size_t gw_http_metrics(const gw_north_env_t *env, char *buf, size_t cap);

/* [{"time": "...", "level": "info", "text": "..."}, ...]: the last 200 log
 * events (writes: the last 200 lines of the write log, their own ring:
 * core/log.h), the oldest first. */
void gw_http_log_json(gw_json_t *j, bool writes);

/* {"time": "...", "client": "192.0.2.7:50412", "fields": ["path", ...],
 * "more": N} or null when the robot was never written. ("more": fields
 * beyond those kept, 0 usually.) */
void gw_http_last_write_json(gw_json_t *j, const gw_robot_t *r);

/* "2026-11-25T14:48:10.123Z" of a wall-clock time (microseconds since
 * 1970), as a JSON string. */
void gw_http_time_json(gw_json_t *j, uint64_t time_us);

#endif /* DRGATE_GW_HTTP_METRICS_H */
