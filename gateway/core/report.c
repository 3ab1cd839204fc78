/* SPDX-License-Identifier: MIT */
/* The core's part of /metrics: see report.h. */
#include "core/report.h"

#include <stdio.h>

#include "drgate/codec.h"

/* One gauge or counter per robot, label robot. */
typedef double (*robot_value_t)(const gw_robot_t *r);

static void per_robot(gw_prom_t *m, const gw_robot_t *robots, unsigned count, const char *name,
                      gw_prom_type_t type, const char *help, robot_value_t value)
{
    gw_prom_family(m, name, type, help);
    for (unsigned i = 0; i < count; i++) {
        gw_prom_label_t l = {"robot", robots[i].name};
        gw_prom_sample(m, name, &l, 1, value(&robots[i]));
    }
}

static double link_up(const gw_robot_t *r) { return r->link.link_state == 2 ? 1 : 0; }
static double link_state(const gw_robot_t *r) { return r->link.link_state; }
static double reconnects(const gw_robot_t *r) { return r->link.reconnects; }
static double timeouts(const gw_robot_t *r) { return r->link.timeouts; }
static double last_error(const gw_robot_t *r) { return r->link.last_error; }
static double age(const gw_robot_t *r) { return r->link.age_ms / 1000.0; }
static double fresh(const gw_robot_t *r) { return r->link.fresh ? 1 : 0; }
static double rpi(const gw_robot_t *r) { return r->link.rpi_ms / 1000.0; }

/* A per-connection counter of the link, by its T->O assembly. */
typedef enum { CONN_RX, CONN_LOST, CONN_RESYNCS } conn_counter_t;

static uint32_t conn_counter(const gw_robot_link_t *k, unsigned c, conn_counter_t which)
{
    switch (which) {
    case CONN_RX:
        return k->conn_rx[c];
    case CONN_LOST:
        return k->conn_lost[c];
    case CONN_RESYNCS:
        return k->conn_resyncs[c];
    }
    return 0;
}

/* A connection's labels after `robot`: its assembly (a combined layout's:
 * the first its input carries, as before) and, for a combined layout's
 * connection only, `connection` with its name (docs/http.md). Returns
 * how many of l[] it filled. */
static size_t conn_labels(const gw_robot_t *rb, unsigned c, gw_prom_label_t *l)
{
    const gw_robot_link_t *k = &rb->link;
    l[0] = (gw_prom_label_t){"robot", rb->name};
    l[1] = (gw_prom_label_t){"assembly", dr_asm_info((dr_asm_t)k->conn_t2o[c])->name};
    if (k->conn_name[0] == '\0')
        return 2;
    l[2] = (gw_prom_label_t){"connection", k->conn_name};
    return 3;
}

/* One family, a sample per connection of every robot. */
static void per_conn(gw_prom_t *m, const gw_robot_t *robots, unsigned count, const char *name,
                     const char *help, conn_counter_t which)
{
    gw_prom_family(m, name, GW_PROM_COUNTER, help);
    for (unsigned i = 0; i < count; i++) {
        const gw_robot_link_t *k = &robots[i].link;
        for (unsigned c = 0; c < GW_ROBOT_CONNS; c++) {
            if (k->conn_t2o[c] >= DR_ASM_COUNT)
                continue;
            gw_prom_label_t l[3];
            size_t n = conn_labels(&robots[i], c, l);
            gw_prom_sample(m, name, l, n, conn_counter(k, c, which));
        }
    }
}

/* Per connection: T->O packets dropped, by why (issue 29). */
static void per_conn_drops(gw_prom_t *m, const gw_robot_t *robots, unsigned count)
{
    const char *name = "drgate_link_packets_dropped_total";
    gw_prom_family(m, name, GW_PROM_COUNTER,
                   "T->O packets dropped per connection, by the assembly it carries and "
                   "why: sequence (stale, duplicate, or too far ahead of the live "
                   "sequence) or source_address (not from the robot's address)");
    for (unsigned i = 0; i < count; i++) {
        const gw_robot_link_t *k = &robots[i].link;
        for (unsigned c = 0; c < GW_ROBOT_CONNS; c++) {
            if (k->conn_t2o[c] >= DR_ASM_COUNT)
                continue;
            gw_prom_label_t l[4];
            size_t n = conn_labels(&robots[i], c, l);
            l[n] = (gw_prom_label_t){"reason", "sequence"};
            gw_prom_sample(m, name, l, n + 1, k->conn_dropped_seq[c]);
            l[n].value = "source_address";
            gw_prom_sample(m, name, l, n + 1, k->conn_dropped_addr[c]);
        }
    }
}

void gw_report_robot_metrics(gw_prom_t *m, const gw_robot_t *robots, unsigned count)
{
    per_robot(m, robots, count, "drgate_link_up", GW_PROM_GAUGE,
              "1 when every connection of the robot's link is established", link_up);
    per_robot(m, robots, count, "drgate_link_state", GW_PROM_GAUGE,
              "The robot's link: 0 down, 1 connecting, 2 up", link_state);
    per_robot(m, robots, count, "drgate_link_reconnects_total", GW_PROM_COUNTER,
              "Times the robot's link went down after being up", reconnects);
    per_robot(m, robots, count, "drgate_link_timeouts_total", GW_PROM_COUNTER,
              "Connections (explicit mode: polls) that timed out without robot data", timeouts);
    per_robot(m, robots, count, "drgate_link_last_error_code", GW_PROM_GAUGE,
              "Why the link last failed, as the status block's last_error (IR 12; "
              "drgatewayd --print-errors), 0: never", last_error);
    per_robot(m, robots, count, "drgate_link_data_age_seconds", GW_PROM_GAUGE,
              "Age of the oldest T->O data of the robot", age);
    per_robot(m, robots, count, "drgate_link_data_fresh", GW_PROM_GAUGE,
              "1 when the robot's data is younger than the connection timeout", fresh);
    per_robot(m, robots, count, "drgate_link_rpi_seconds", GW_PROM_GAUGE,
              "Packet interval in use (explicit mode: the poll period)", rpi);
    per_conn(m, robots, count, "drgate_link_packets_received_total",
             "T->O packets (explicit mode: poll replies) received per connection, by the "
             "assembly it carries",
             CONN_RX);
    per_conn(m, robots, count, "drgate_link_packets_lost_total",
             "T->O packets lost (CIP sequence gaps) per connection, by the assembly it carries",
             CONN_LOST);
    per_conn_drops(m, robots, count);
    per_conn(m, robots, count, "drgate_link_sequence_resyncs_total",
             "Jumps of the robot's T->O sequence followed per connection (after the "
             "sequence before had gone silent for half the timeout)",
             CONN_RESYNCS);
}

/* Upper bounds of the lag buckets, microseconds. */
static const uint64_t lag_le_us[GW_LAG_BUCKETS] = {50,    100,    250,    500,    1000,
                                                   2500,  5000,   10000,  100000, 1000000};

void gw_lag_observe(gw_lag_t *l, uint64_t late_us)
{
    unsigned b = 0;
    while (b < GW_LAG_BUCKETS && late_us > lag_le_us[b])
        b++;
    l->bucket[b]++;
    l->count++;
    l->sum_us += late_us;
    if (late_us > l->max_us)
        l->max_us = late_us;
}

void gw_lag_metrics(gw_prom_t *m, const gw_lag_t *l)
{
    gw_prom_family(m, "drgate_loop_lag_seconds", GW_PROM_HISTOGRAM,
                   "How late the daemon's loop woke up after the deadline it had set "
                   "(the next robot packet, timer or tick)");
    uint64_t cum = 0;
    for (unsigned b = 0; b <= GW_LAG_BUCKETS; b++) {
        char le[24];
        cum += l->bucket[b];
        if (b < GW_LAG_BUCKETS)
            snprintf(le, sizeof le, "%g", (double)lag_le_us[b] / 1e6);
        else
            snprintf(le, sizeof le, "+Inf");
        gw_prom_label_t lb = {"le", le};
        gw_prom_sample(m, "drgate_loop_lag_seconds_bucket", &lb, 1, (double)cum);
    }
    gw_prom_sample(m, "drgate_loop_lag_seconds_sum", NULL, 0, (double)l->sum_us / 1e6);
    gw_prom_sample(m, "drgate_loop_lag_seconds_count", NULL, 0, (double)l->count);
    gw_prom_one(m, "drgate_loop_lag_max_seconds", GW_PROM_GAUGE,
                "The largest lag of the loop since the daemon started", (double)l->max_us / 1e6);
}

/* ---- the summaries ------------------------------------------------------------- */

void gw_robot_state_text(const gw_robot_t *rb, char *out, size_t size)
{
    char why[200];
    gw_robot_cause(rb, why, sizeof why);
    if (rb->link.link_state == 2)
        snprintf(out, size, "linked");
    else
        snprintf(out, size, "%s%s%s", rb->link.link_state == 1 ? "connecting" : "down",
                 why[0] ? ": " : "", why);
}

void gw_report_notify(gw_json_t *j, const gw_robot_t *robots, unsigned count,
                      const gw_side_summary_t *sides, unsigned nsides)
{
    if (count == 0)
        gw_json_str(j, "no robot");
    for (unsigned r = 0; r < count; r++) {
        char st[240];
        gw_robot_state_text(&robots[r], st, sizeof st);
        if (r > 0)
            gw_json_str(j, ", ");
        gw_json_str(j, robots[r].name);
        gw_json_str(j, " ");
        gw_json_str(j, st);
    }
    for (unsigned i = 0; i < nsides; i++)
        if (sides[i].brief[0] != '\0') {
            gw_json_str(j, "; ");
            gw_json_str(j, sides[i].brief);
        }
}
