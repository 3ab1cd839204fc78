/* SPDX-License-Identifier: MIT */
/*
 * The Modbus request log (docs/http.md "Modbus requests"): the last
 * GW_REQLOG_N requests of each Modbus TCP client and of each RTU line,
 * kept where the request is answered (mbserver.c, mbrtu.c), in a ring of
 * fixed size inside the client's own slot: a request costs one entry
 * written (no allocation, no lookup, no formatting), and a client that
 * floods the gateway overwrites only its own past. The exceptions are
 * also counted by where they went (unit, function code, address and
 * code: gw_exstats_t) in a table of fixed size, so that "the PLC gets
 * 0x02" leads to the register it asked for. The console formats both
 * when asked (/api/v1/modbus/requests), never on the request path.
 */
#ifndef DRGATE_GW_REQLOG_H
#define DRGATE_GW_REQLOG_H

#include <stdint.h>

#include "core/json.h"
#include "modbus/mbproto.h"

#define GW_REQLOG_N 32u /* requests kept per client (a power of two) */

/* One request: when (the loop's monotonic clock), unit ID, function code
 * (as sent, without the 0x80 of an exception reply), the first address
 * and the count it named (0 for the function codes that name none), and
 * 0 or the exception code answered. */
typedef struct {
    uint64_t us;
    uint16_t addr, count;
    uint8_t unit, fc, ex;
} gw_reqlog_entry_t;

typedef struct {
    uint32_t total; /* requests logged so far; the newest is at (total - 1) % N */
    gw_reqlog_entry_t e[GW_REQLOG_N];
} gw_reqlog_t;

/* Request r (its result ex) answered at `us`: one entry, over the oldest. */
static inline void gw_reqlog_add(gw_reqlog_t *l, uint64_t us, const gw_mb_result_t *r, int ex)
{
    gw_reqlog_entry_t *e = &l->e[l->total++ % GW_REQLOG_N];
    e->us = us;
    e->unit = r->unit_id;
    e->fc = (uint8_t)(r->fc & 0x7Fu);
    e->addr = r->addr;
    e->count = r->count;
    e->ex = (uint8_t)ex;
}

/* Exceptions by where they went; at most GW_EXSTATS_MAX places, the
 * exceptions to places beyond them counted in `other`. */
#define GW_EXSTATS_MAX 64u
typedef struct {
    uint16_t addr;
    uint8_t unit, fc, ex;
    uint8_t transport; /* 0: TCP, 1: RTU */
    uint32_t count;
    uint64_t last_us;
} gw_exstat_t;

typedef struct {
    unsigned n;
    uint64_t other;
    gw_exstat_t s[GW_EXSTATS_MAX];
} gw_exstats_t;

/* An exception reply (ex != 0) to request r, at `us`. */
void gw_exstats_add(gw_exstats_t *x, unsigned transport, uint64_t us, const gw_mb_result_t *r,
                    int ex);

/* The names the Modbus specification gives: "Read Holding Registers",
 * "Illegal Data Address"; NULL for a code it does not name. */
const char *gw_mb_fc_name(unsigned fc);
const char *gw_mb_ex_name(unsigned ex);

/* The log's entries, oldest first, as JSON objects into j ({"age_ms",
 * "unit", "fc", "function", "addr", "count", "ex", "exception"}),
 * commas between; `now` is the loop's clock. */
void gw_reqlog_json(gw_json_t *j, const gw_reqlog_t *l, uint64_t now);
/* {"by_code": [{"code", "name", "count"}], "by_address": [{"transport",
 * "unit", "fc", "function", "addr", "code", "name", "count",
 * "last_age_ms"}], "other": N}: by_code summed from by_address and other
 * (ex_by_code: the side's exceptions by code, 256 counters per
 * transport, both summed). */
void gw_exstats_json(gw_json_t *j, const gw_exstats_t *x, const uint64_t *ex_by_code,
                     unsigned transports, uint64_t now);

#endif /* DRGATE_GW_REQLOG_H */
