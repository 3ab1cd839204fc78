/* SPDX-License-Identifier: MIT */
/*
 * What the core tells the console's /metrics (core/prom.h): each robot's
 * link (gw_robot_t link facts) and the daemon loop's lag. The sides write
 * their own (north.h: report, metrics); the daemon (main.c) puts them
 * together in env->metrics and env->report.
 */
#ifndef DRGATE_GW_REPORT_H
#define DRGATE_GW_REPORT_H

#include <stdint.h>

#include "core/json.h"
#include "core/log.h"
#include "core/north.h"
#include "core/prom.h"
#include "core/robot.h"

/* The robots' families: drgate_link_up, drgate_link_state,
 * drgate_link_reconnects_total, drgate_link_timeouts_total,
 * drgate_link_last_error_code, drgate_link_data_age_seconds,
 * drgate_link_rpi_seconds, drgate_link_packets_received_total,
 * drgate_link_packets_lost_total, drgate_link_packets_dropped_total (and
 * label reason) and drgate_link_sequence_resyncs_total (label assembly:
 * per connection). */
void gw_report_robot_metrics(gw_prom_t *m, const gw_robot_t *robots, unsigned count);

/* The loop's lag: how late the loop woke up after the deadline it had
 * set itself (the next robot packet, timer or tick), as a histogram. */
#define GW_LAG_BUCKETS 10
typedef struct {
    uint64_t bucket[GW_LAG_BUCKETS + 1]; /* by upper bound; the last: +Inf */
    uint64_t count, sum_us, max_us;
} gw_lag_t;
void gw_lag_observe(gw_lag_t *l, uint64_t late_us);
/* drgate_loop_lag_seconds (histogram) and drgate_loop_lag_max_seconds. */
void gw_lag_metrics(gw_prom_t *m, const gw_lag_t *l);

/* A robot's state in words, as the summaries say it: "linked",
 * "connecting", "down: connection refused". */
void gw_robot_state_text(const gw_robot_t *rb, char *out, size_t size);

/* One line for systemd's STATUS=: "arm1 linked, arm2 down: connection
 * refused; 2 Modbus clients; MQTT connected": the robots, then each
 * side's summary brief (north.h), in list order. */
void gw_report_notify(gw_json_t *j, const gw_robot_t *robots, unsigned count,
                      const gw_side_summary_t *sides, unsigned nsides);

/* Writes are logged by the one write path: gw_write_log (core/write.h). */

#endif /* DRGATE_GW_REPORT_H */
