/* SPDX-License-Identifier: MIT */
/*
 * The connection plan an EDS gives (common/eds.h): its Class 1
 * connections resolved to instances, sizes and RPI ranges, the layout
 * their sizes match (drgate/layout.h), and the points and RPI of the
 * connection drgatewayd would open. drcli eds prints it; drgatewayd's
 * `eds` key of [robot] takes it as the robot's defaults.
 */
#include <string.h>

#include "common/eds.h"

/* The RPI range of a connection (microseconds, from a number or a
 * parameter); false when it gives none. */
static bool rpi_range(const eds_t *e, eds_ref_t r, uint32_t *min, uint32_t *max,
                      uint32_t *def)
{
    *min = 0;
    *max = 0;
    *def = 0;
    if (r.kind == 'n') {
        *min = *max = *def = r.value;
        return true;
    }
    const eds_param_t *p = r.kind == 'P' ? eds_param(e, r.value) : NULL;
    if (p == NULL || !p->has_min || !p->has_max)
        return false;
    *min = p->min;
    *max = p->max;
    *def = p->has_def ? p->def : 0;
    return true;
}

static void conn_plan(const eds_t *e, const eds_conn_t *c, eds_conn_plan_t *p)
{
    memset(p, 0, sizeof *p);
    p->c = c;
    p->ot_inst = eds_instance(e, c->ot_format, c->path_ot);
    p->to_inst = eds_instance(e, c->to_format, c->path_to);
    p->ot_size = eds_size(e, c->ot_size, c->ot_format);
    p->to_size = eds_size(e, c->to_size, c->to_format);
    uint32_t a, b, d, a2, b2, d2;
    bool ot = rpi_range(e, c->ot_rpi, &a, &b, &d), to = rpi_range(e, c->to_rpi, &a2, &b2, &d2);
    if (ot && to) { /* both directions: what both take */
        a = a > a2 ? a : a2;
        b = b < b2 ? b : b2;
        d = d != 0 ? d : d2;
    } else if (to) {
        a = a2, b = b2, d = d2;
    }
    p->has_rpi = (ot || to) && a <= b;
    p->rpi_min = a;
    p->rpi_max = b;
    p->rpi_def = d;
}

unsigned eds_pick_rpi_ms(const eds_conn_plan_t *p)
{
    if (!p->has_rpi)
        return 0;
    unsigned lo = (p->rpi_min + 999u) / 1000u, hi = p->rpi_max / 1000u;
    unsigned want = p->rpi_def != 0 ? (p->rpi_def + 999u) / 1000u : 10u;
    if (lo < 1)
        lo = 1;
    if (hi > 10000)
        hi = 10000;
    if (lo > hi)
        return 0;
    return want < lo ? lo : want > hi ? hi : want;
}

const char *eds_type_name(uint32_t trigger)
{
    if (trigger & EDS_EXCLUSIVE)
        return "exclusive owner";
    if (trigger & EDS_REDUNDANT)
        return "redundant owner";
    if (trigger & EDS_INPUT_ONLY)
        return "input only";
    if (trigger & EDS_LISTEN_ONLY)
        return "listen only";
    return "no type";
}

/* The Class 1 connections resolved, and which of them the plan takes. */
static void plan_conns(eds_t *e, eds_plan_t *p)
{
    for (unsigned i = 0; i < e->n_conn; i++) {
        const eds_conn_t *c = &e->conn[i];
        if (!(c->trigger & EDS_CLASS1)) {
            eds_note(e, c->line, "Connection%lu \"%s\": not Class 1 (0x%08lx)",
                     (unsigned long)c->number, c->name, (unsigned long)c->trigger);
            continue;
        }
        if (!c->path_ok)
            eds_note(e, c->line, "Connection%lu \"%s\": path not in hex bytes: "
                     "instances from [Assembly] only", (unsigned long)c->number, c->name);
        int k = (int)p->nconn;
        conn_plan(e, c, &p->conn[p->nconn++]);
        if ((c->trigger & EDS_EXCLUSIVE) && p->main_i < 0)
            p->main_i = k;
        if ((c->trigger & EDS_INPUT_ONLY) && p->in_only_i < 0)
            p->in_only_i = k;
        if ((c->trigger & EDS_LISTEN_ONLY) && p->listen_i < 0)
            p->listen_i = k;
    }
    p->plan_i = p->main_i >= 0 ? p->main_i : p->in_only_i;
}

void eds_plan(eds_t *e, eds_plan_t *p)
{
    memset(p, 0, sizeof *p);
    p->main_i = p->in_only_i = p->listen_i = p->plan_i = -1;
    plan_conns(e, p);
    /* per_assembly from the instances 101..110, combined and gpr_only
     * from the plan's connection's sizes */
    uint16_t per_asm[DR_ASM_COUNT];
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        per_asm[a] = 0;
        for (unsigned i = 0; i < e->n_assem; i++)
            if (e->assem[i].instance == DR_ASM_DEFAULT_INSTANCE(a) && e->assem[i].size > 0)
                per_asm[a] = (uint16_t)e->assem[i].size;
    }
    const eds_conn_plan_t *mp = p->plan_i >= 0 ? &p->conn[p->plan_i] : NULL;
    if (mp != NULL) {
        p->in_instance = mp->to_inst;
        p->in_size = mp->to_size > 0 && mp->to_size <= 0xFFFF ? (uint16_t)mp->to_size : 0;
        if (p->plan_i == p->main_i) {
            p->out_instance = mp->ot_inst;
            p->out_size = mp->ot_size > 0 && mp->ot_size <= 0xFFFF ? (uint16_t)mp->ot_size : 0;
        }
        p->plan_line = mp->c->line;
        p->config_instance = mp->c->path_config;
        int32_t cfg = eds_size(e, mp->c->cfg_size, mp->c->cfg_format);
        if (cfg > 0)
            eds_note(e, mp->c->line, "Connection%lu: %ld bytes of configuration data: "
                     "drgatewayd sends none", (unsigned long)mp->c->number, (long)cfg);
    }
    p->matched = dr_layout_match(per_asm, p->in_size, p->out_size, &p->kind) == DR_OK;
    if (p->matched && p->kind != DR_LAYOUT_PER_ASSEMBLY) {
        for (unsigned i = 0; i < p->nconn; i++)
            if ((int)i != p->plan_i && (int)i != p->in_only_i && (int)i != p->listen_i)
                eds_note(e, p->conn[i].c->line, "Connection%lu \"%s\": %s, beside "
                         "Connection%lu of the plan", (unsigned long)p->conn[i].c->number,
                         p->conn[i].c->name, eds_type_name(p->conn[i].c->trigger),
                         (unsigned long)mp->c->number);
    }
    const eds_conn_plan_t *rp = mp != NULL ? mp : p->nconn > 0 ? &p->conn[0] : NULL;
    if (rp != NULL) {
        p->rpi_ms = eds_pick_rpi_ms(rp);
        p->has_rpi = rp->has_rpi;
        p->rpi_min_us = rp->rpi_min;
        p->rpi_max_us = rp->rpi_max;
        p->rpi_conn = rp->c->number;
        p->rpi_line = rp->c->line;
        if (p->config_instance == 0)
            p->config_instance = rp->c->path_config;
    }
    if (p->in_only_i >= 0 && p->conn[p->in_only_i].ot_inst != 0 &&
        p->conn[p->in_only_i].ot_inst != EDS_HB_INPUT_ONLY)
        p->input_only_hb = p->conn[p->in_only_i].ot_inst;
    if (p->listen_i >= 0 && p->conn[p->listen_i].ot_inst != 0 &&
        p->conn[p->listen_i].ot_inst != EDS_HB_LISTEN_ONLY)
        p->listen_only_hb = p->conn[p->listen_i].ot_inst;
}
