/* SPDX-License-Identifier: MIT */
/* The Modbus request log and the exceptions by place: see reqlog.h. */
#include "modbus/reqlog.h"

#include <stdio.h>
#include <string.h>

void gw_exstats_add(gw_exstats_t *x, unsigned transport, uint64_t us, const gw_mb_result_t *r,
                    int ex)
{
    uint8_t fc = (uint8_t)(r->fc & 0x7Fu);
    for (unsigned i = 0; i < x->n; i++) {
        gw_exstat_t *s = &x->s[i];
        if (s->addr == r->addr && s->unit == r->unit_id && s->fc == fc && s->ex == (uint8_t)ex &&
            s->transport == transport) {
            s->count++;
            s->last_us = us;
            return;
        }
    }
    if (x->n == GW_EXSTATS_MAX) {
        x->other++;
        return;
    }
    x->s[x->n++] = (gw_exstat_t){r->addr, r->unit_id, fc, (uint8_t)ex, (uint8_t)transport, 1, us};
}

/* Modbus Application Protocol Specification V1.1b3, 6 and 7. */
const char *gw_mb_fc_name(unsigned fc)
{
    switch (fc) {
    case 0x01: return "Read Coils";
    case 0x02: return "Read Discrete Inputs";
    case 0x03: return "Read Holding Registers";
    case 0x04: return "Read Input Registers";
    case 0x05: return "Write Single Coil";
    case 0x06: return "Write Single Register";
    case 0x07: return "Read Exception Status";
    case 0x08: return "Diagnostics";
    case 0x0B: return "Get Comm Event Counter";
    case 0x0C: return "Get Comm Event Log";
    case 0x0F: return "Write Multiple Coils";
    case 0x10: return "Write Multiple Registers";
    case 0x11: return "Report Server ID";
    case 0x14: return "Read File Record";
    case 0x15: return "Write File Record";
    case 0x16: return "Mask Write Register";
    case 0x17: return "Read/Write Multiple Registers";
    case 0x18: return "Read FIFO Queue";
    case 0x2B: return "Read Device Identification";
    default: return NULL;
    }
}

const char *gw_mb_ex_name(unsigned ex)
{
    switch (ex) {
    case 0x01: return "Illegal Function";
    case 0x02: return "Illegal Data Address";
    case 0x03: return "Illegal Data Value";
    case 0x04: return "Server Device Failure";
    case 0x05: return "Acknowledge";
    case 0x06: return "Server Device Busy";
    case 0x08: return "Memory Parity Error";
    case 0x0A: return "Gateway Path Unavailable";
    case 0x0B: return "Gateway Target Device Failed to Respond";
    default: return NULL;
    }
}

static void num(gw_json_t *j, const char *key, unsigned long long v)
{
    char t[48];
    snprintf(t, sizeof t, ",\"%s\":%llu", key, v);
    gw_json_str(j, t);
}

static void name(gw_json_t *j, const char *key, const char *s)
{
    gw_json_str(j, ",\"");
    gw_json_str(j, key);
    gw_json_str(j, "\":");
    if (s != NULL)
        gw_json_quote(j, s, strlen(s));
    else
        gw_json_str(j, "null");
}

void gw_reqlog_json(gw_json_t *j, const gw_reqlog_t *l, uint64_t now)
{
    uint32_t first = l->total > GW_REQLOG_N ? l->total - GW_REQLOG_N : 0;
    for (uint32_t k = first; k != l->total; k++) {
        const gw_reqlog_entry_t *e = &l->e[k % GW_REQLOG_N];
        gw_json_str(j, k != first ? ",{" : "{");
        char t[48];
        snprintf(t, sizeof t, "\"age_ms\":%llu",
                 (unsigned long long)(now > e->us ? (now - e->us) / 1000u : 0));
        gw_json_str(j, t);
        num(j, "unit", e->unit);
        num(j, "fc", e->fc);
        name(j, "function", gw_mb_fc_name(e->fc));
        num(j, "addr", e->addr);
        num(j, "count", e->count);
        num(j, "ex", e->ex);
        name(j, "exception", e->ex != 0 ? gw_mb_ex_name(e->ex) : NULL);
        gw_json_str(j, "}");
    }
}

void gw_exstats_json(gw_json_t *j, const gw_exstats_t *x, const uint64_t *ex_by_code,
                     unsigned transports, uint64_t now)
{
    gw_json_str(j, "{\"by_code\":[");
    bool first = true;
    for (unsigned c = 1; c < 256u; c++) {
        uint64_t v = 0;
        for (unsigned t = 0; t < transports; t++)
            v += ex_by_code[t * 256u + c];
        if (v == 0)
            continue;
        char b[48];
        snprintf(b, sizeof b, "%s{\"code\":%u", first ? "" : ",", c);
        gw_json_str(j, b);
        first = false;
        name(j, "name", gw_mb_ex_name(c));
        num(j, "count", v);
        gw_json_str(j, "}");
    }
    gw_json_str(j, "],\"by_address\":[");
    for (unsigned i = 0; i < x->n; i++) {
        const gw_exstat_t *s = &x->s[i];
        gw_json_str(j, i > 0 ? ",{\"transport\":" : "{\"transport\":");
        gw_json_str(j, s->transport == 0 ? "\"tcp\"" : "\"rtu\"");
        num(j, "unit", s->unit);
        num(j, "fc", s->fc);
        name(j, "function", gw_mb_fc_name(s->fc));
        num(j, "addr", s->addr);
        num(j, "code", s->ex);
        name(j, "name", gw_mb_ex_name(s->ex));
        num(j, "count", s->count);
        num(j, "last_age_ms", now > s->last_us ? (now - s->last_us) / 1000u : 0);
        gw_json_str(j, "}");
    }
    char b[48];
    snprintf(b, sizeof b, "],\"other\":%llu}", (unsigned long long)x->other);
    gw_json_str(j, b);
}
