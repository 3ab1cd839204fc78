/* SPDX-License-Identifier: MIT */
/*
 * The Modbus sides of the gateway as northbound sides (north.h): Modbus
 * TCP (mbserver.c) with the [modbus] rules that are not per request (the
 * stale policy on link loss, the single writer's watchdog), and the
 * Modbus RTU lines (mbrtu.c). Both answer through the one request
 * handler (mbproto.c) from the same units.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "log.h"
#include "loop.h"
#include "mbrtu.h"
#include "mbserver.h"
#include "north.h"

/* ---- unit lookup and writes, shared by TCP and RTU ------------------------------ */

typedef struct {
    const gw_north_env_t *env;
    void (*wrote)(void *side); /* a write reached a robot (single writer) */
    void *side;
} mb_ctx_t;

static gw_unit_t *unit_for(void *user, uint8_t unit_id)
{
    const mb_ctx_t *c = user;
    const gw_config_t *cfg = c->env->cfg;
    for (unsigned i = 0; i < cfg->robot_count; i++)
        if (cfg->robot[i].unit_id == unit_id)
            return &c->env->units[i];
    return NULL;
}

static void on_write(void *user, uint8_t unit_id, unsigned dirty)
{
    const mb_ctx_t *c = user;
    const gw_config_t *cfg = c->env->cfg;
    unsigned r = 0;
    for (unsigned i = 0; i < cfg->robot_count; i++)
        if (cfg->robot[i].unit_id == unit_id)
            r = i;
    if (c->wrote != NULL)
        c->wrote(c->side);
    c->env->outputs_changed(c->env->user, r, dirty);
}

/* ---- Modbus TCP ---------------------------------------------------------------- */

typedef struct {
    mb_ctx_t ctx;
    gw_mbs_t *mbs;
    /* single writer */
    bool writer_seen;
    unsigned writer_claims; /* gw_mbs_writer_claims() when last looked */
    uint16_t last_watchdog[GW_MAX_ROBOTS];
    uint64_t watchdog_change_us;
} tcp_t;

/* A writer seen only between two ticks (it wrote and left within one
 * loop iteration) must still start the watchdog: only the owner's writes
 * get here in single-writer mode. */
static void writer_wrote(void *side)
{
    tcp_t *t = side;
    if (t->ctx.env->cfg->modbus.single_writer && !t->writer_seen) {
        t->writer_seen = true;
        t->watchdog_change_us = gw_now_us();
    }
}

static gw_mbs_t *tcp_server(tcp_t *t, char *err, size_t errlen)
{
    gw_mbs_hooks_t mh = {unit_for, on_write, &t->ctx, t->ctx.env->version};
    return gw_mbs_new(&t->ctx.env->cfg->modbus, t->ctx.env->epfd, &mh, err, errlen);
}

static void *tcp_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    tcp_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    t->ctx = (mb_ctx_t){env, writer_wrote, t};
    t->mbs = tcp_server(t, err, errlen);
    if (t->mbs == NULL) {
        free(t);
        return NULL;
    }
    return t;
}

static gw_north_reload_t tcp_prepare(void *self, const gw_config_t *next,
                                     const gw_north_env_t *env, void **out, char *err,
                                     size_t errlen)
{
    (void)next, (void)env, (void)err, (void)errlen;
    *out = self; /* reconfigured in place at commit: it cannot refuse */
    return GW_NORTH_OK;
}

static void tcp_abort(void *self, void *out)
{
    (void)self, (void)out;
}

static void *tcp_commit(void *self, void *out, const gw_north_env_t *env)
{
    tcp_t *t = self;
    (void)out;
    /* Robots may have moved to other positions: the watchdog registers
     * are compared from their current values on, not from the old order. */
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        t->last_watchdog[r] = env->units[r].watchdog;
    if (gw_mbs_reconfigure(t->mbs, &env->cfg->modbus))
        return t;
    char err[512];
    gw_mbs_free(t->mbs);
    t->mbs = tcp_server(t, err, sizeof err);
    if (t->mbs == NULL) {
        gw_log(GW_LOG_ERROR, "reload: %s", err);
        free(t);
        return NULL;
    }
    return t;
}

/* The outputs of every robot to their fallback, the fault latched. */
static void writer_expired(tcp_t *t)
{
    const gw_north_env_t *env = t->ctx.env;
    t->writer_seen = false;
    gw_mbs_release_writer(t->mbs);
    gw_log(GW_LOG_WARNING, "modbus: single writer's watchdog expired: outputs to fallback");
    for (unsigned r = 0; r < env->cfg->robot_count; r++) {
        gw_unit_t *u = &env->units[r];
        u->status.write_fault = true;
        if (!env->cfg->robot[r].fallback_hold) {
            unsigned dirty = 0;
            for (unsigned a = 0; a < DR_ASM_COUNT; a++)
                if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_O2T) {
                    memset(u->img[a], 0, DR_ASM_MAX_SIZE);
                    dirty |= 1u << a;
                }
            env->outputs_changed(env->user, r, dirty);
        }
        /* GPIO outputs safe until the fault is reset (not until the link
         * happens to reconnect). */
        env->fault(env->user, r, true);
    }
}

/* EK9000-like write lock: the owner must keep changing the watchdog
 * register; when it stops, outputs go to their fallback and a fault
 * latches until a client writes the reset register. */
static void writer_watchdog(tcp_t *t, uint64_t now)
{
    const gw_north_env_t *env = t->ctx.env;
    const gw_config_t *cfg = env->cfg;
    /* A reset counts in any mode: a fault latched before a reload turned
     * single-writer mode off must not hold the GPIO outputs for ever. */
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        gw_unit_t *u = &env->units[r];
        /* The write that reset the latch cleared write_fault at once
         * (mbproto.c: writes pipelined behind it are taken) and logged it. */
        if (u->fault_reset) {
            u->fault_reset = false;
            env->fault(env->user, r, false); /* outputs follow again */
        }
        /* Out of single-writer mode the register is just a register: a
         * value written then is no owner's sign of life later. */
        if (!cfg->modbus.single_writer)
            t->last_watchdog[r] = u->watchdog;
    }
    if (!cfg->modbus.single_writer) {
        t->writer_seen = false; /* a reload into the mode starts afresh */
        return;
    }
    /* A new owner (the first, or one that took over from an owner that
     * left while its watchdog still ran): its watchdog starts now. */
    unsigned claims = gw_mbs_writer_claims(t->mbs);
    if (claims != t->writer_claims) {
        t->writer_claims = claims;
        t->watchdog_change_us = now;
    }
    t->writer_seen = t->writer_seen || gw_mbs_writer_present(t->mbs);
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        const gw_unit_t *u = &env->units[r];
        if (u->watchdog != t->last_watchdog[r]) {
            t->last_watchdog[r] = u->watchdog;
            writer_wrote(t); /* only the owner can have written it */
            t->watchdog_change_us = now;
        }
    }
    uint64_t limit = (uint64_t)cfg->modbus.writer_watchdog_ms * 1000u;
    if (t->writer_seen && now - t->watchdog_change_us >= limit)
        writer_expired(t);
}

static void tcp_tick(void *self, uint64_t now)
{
    tcp_t *t = self;
    gw_mbs_tick(t->mbs, now);
    writer_watchdog(t, now);
}

static uint64_t tcp_deadline(const void *self)
{
    const tcp_t *t = self;
    return gw_mbs_next_deadline(t->mbs);
}

static void tcp_on_data(void *self, unsigned robot, dr_asm_t a)
{
    (void)self, (void)robot, (void)a; /* requests read the images as they are */
}

/* [modbus] on_link_loss = zero: the robot's T->O data reads 0 while the
 * link is down (hold: as last received; exception: 0x0B, regmap.c). */
static void tcp_on_link(void *self, unsigned robot, bool up)
{
    const tcp_t *t = self;
    const gw_north_env_t *env = t->ctx.env;
    if (!up && env->cfg->modbus.on_link_loss == GW_LOSS_ZERO)
        for (unsigned a = 0; a < DR_ASM_COUNT; a++)
            if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O)
                memset(env->units[robot].img[a], 0, DR_ASM_MAX_SIZE);
}

static void tcp_on_fault(void *self, unsigned robot, bool latched)
{
    (void)self, (void)robot, (void)latched; /* its own: write_fault in the unit */
}

static void tcp_status(const void *self, unsigned robot, gw_status_t *st)
{
    const tcp_t *t = self;
    (void)robot;
    st->clients = (uint16_t)gw_mbs_client_count(t->mbs);
    st->exceptions += gw_mbs_exceptions(t->mbs);
    st->writer_present = gw_mbs_writer_present(t->mbs);
}

static void tcp_safe(void *self)
{
    (void)self;
}

static void tcp_free(void *self)
{
    tcp_t *t = self;
    if (t == NULL)
        return;
    gw_mbs_free(t->mbs);
    free(t);
}

const gw_north_ops_t gw_north_modbus_tcp = {
    "modbus",     tcp_create, tcp_prepare, tcp_abort,    tcp_commit, tcp_tick, tcp_deadline,
    tcp_on_data,  tcp_on_link, tcp_on_fault, tcp_status, tcp_safe,  tcp_free,
};

/* ---- Modbus RTU ---------------------------------------------------------------- */

/* The lines, and during a reload the ones that will take over (a line
 * keeps its hooks, which point at ctx: the side is reloaded in place). */
typedef struct {
    mb_ctx_t ctx;
    unsigned count, pending_count;
    gw_rtu_config_t cfg[GW_MAX_RTU], pending_cfg[GW_MAX_RTU];
    gw_rtu_t *line[GW_MAX_RTU], *pending[GW_MAX_RTU];
    bool handed[GW_MAX_RTU]; /* line[i] is in pending[] too */
} rtu_t;

static void rtu_free(void *self)
{
    rtu_t *t = self;
    if (t == NULL)
        return;
    for (unsigned i = 0; i < t->count; i++)
        gw_rtu_free(t->line[i]);
    free(t);
}

static gw_rtu_t *rtu_open(rtu_t *t, const gw_rtu_config_t *cfg, const gw_robot_config_t *robots,
                          char *err, size_t errlen)
{
    gw_mbs_hooks_t h = {unit_for, on_write, &t->ctx, t->ctx.env->version};
    return gw_rtu_new(cfg, robots, t->ctx.env->epfd, &h, err, errlen);
}

static void *rtu_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    rtu_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    t->ctx = (mb_ctx_t){env, NULL, NULL};
    for (unsigned i = 0; i < env->cfg->rtu_count; i++) {
        t->cfg[i] = env->cfg->rtu[i];
        t->line[i] = rtu_open(t, &t->cfg[i], env->cfg->robot, err, errlen);
        if (t->line[i] == NULL) {
            rtu_free(t);
            return NULL;
        }
        t->count++;
    }
    return t;
}

/* The same line, set up the same way, for the same robots at the same
 * addresses (by unit ID: a robot whose unit ID changed is another). */
static bool same_line(const gw_rtu_config_t *a, const gw_robot_config_t *ra,
                      const gw_rtu_config_t *b, const gw_robot_config_t *rb)
{
    if (strcmp(a->name, b->name) != 0 || strcmp(a->device, b->device) != 0 ||
        a->baud != b->baud || a->parity != b->parity || a->data_bits != b->data_bits ||
        a->stop_bits != b->stop_bits || a->rs485 != b->rs485 ||
        a->rts_on_send_low != b->rts_on_send_low || a->rts_before_ms != b->rts_before_ms ||
        a->rts_after_ms != b->rts_after_ms || a->read_only != b->read_only ||
        a->slave_count != b->slave_count)
        return false;
    for (unsigned s = 0; s < a->slave_count; s++)
        if (a->slave_addr[s] != b->slave_addr[s] ||
            ra[a->slave_robot[s]].unit_id != rb[b->slave_robot[s]].unit_id)
            return false;
    return true;
}

static void rtu_abort(void *self, void *out)
{
    rtu_t *t = self;
    (void)out;
    for (unsigned i = 0; i < t->pending_count; i++) {
        bool carried = false;
        for (unsigned o = 0; o < t->count; o++)
            carried = carried || (t->handed[o] && t->line[o] == t->pending[i]);
        if (!carried)
            gw_rtu_free(t->pending[i]);
    }
    memset(t->handed, 0, sizeof t->handed);
    t->pending_count = 0;
}

/* Unchanged lines carry over (their port stays open); new and changed
 * ones are opened now, while the old ones still serve. */
static gw_north_reload_t rtu_prepare(void *self, const gw_config_t *next,
                                     const gw_north_env_t *env, void **out, char *err,
                                     size_t errlen)
{
    rtu_t *t = self;
    t->pending_count = 0;
    memset(t->handed, 0, sizeof t->handed);
    for (unsigned i = 0; i < next->rtu_count; i++) {
        t->pending_cfg[i] = next->rtu[i];
        t->pending[i] = NULL;
        for (unsigned o = 0; o < t->count && t->pending[i] == NULL; o++)
            if (!t->handed[o] && same_line(&t->cfg[o], env->cfg->robot, &next->rtu[i], next->robot)) {
                t->pending[i] = t->line[o];
                t->handed[o] = true;
            }
        if (t->pending[i] == NULL)
            t->pending[i] = rtu_open(t, &t->pending_cfg[i], next->robot, err, errlen);
        if (t->pending[i] == NULL) {
            rtu_abort(t, NULL);
            return GW_NORTH_REFUSED;
        }
        t->pending_count = i + 1;
    }
    *out = t;
    return GW_NORTH_OK;
}

static void *rtu_commit(void *self, void *out, const gw_north_env_t *env)
{
    rtu_t *t = self;
    (void)out, (void)env;
    for (unsigned o = 0; o < t->count; o++)
        if (!t->handed[o]) {
            gw_log(GW_LOG_INFO, "reload: modbus_rtu %s changed or removed: closing %s",
                   t->cfg[o].name, t->cfg[o].device);
            gw_rtu_free(t->line[o]);
        }
    memcpy(t->line, t->pending, sizeof t->line);
    memcpy(t->cfg, t->pending_cfg, sizeof t->cfg);
    t->count = t->pending_count;
    t->pending_count = 0;
    memset(t->handed, 0, sizeof t->handed);
    return t;
}

static void rtu_tick(void *self, uint64_t now)
{
    rtu_t *t = self;
    for (unsigned i = 0; i < t->count; i++)
        gw_rtu_tick(t->line[i], now);
}

static uint64_t rtu_deadline(const void *self)
{
    const rtu_t *t = self;
    uint64_t d = UINT64_MAX;
    for (unsigned i = 0; i < t->count; i++) {
        uint64_t x = gw_rtu_next_deadline(t->line[i]);
        if (x < d)
            d = x;
    }
    return d;
}

static void rtu_on_link(void *self, unsigned robot, bool up)
{
    (void)self, (void)robot, (void)up; /* the stale policy is applied once, by TCP's side */
}

/* Status IR 40-43: the frames dropped and the frames for other slaves of
 * the lines this robot is on. */
static void rtu_status(const void *self, unsigned robot, gw_status_t *st)
{
    const rtu_t *t = self;
    uint8_t unit_id = t->ctx.env->cfg->robot[robot].unit_id;
    st->rtu_dropped = 0;
    st->rtu_other = 0;
    for (unsigned i = 0; i < t->count; i++) {
        const gw_rtu_counters_t *n = gw_rtu_counters(t->line[i]);
        st->exceptions += n->exceptions;
        if (!gw_rtu_serves(t->line[i], unit_id))
            continue;
        st->rtu_dropped += n->crc_errors;
        st->rtu_other += n->other;
    }
}

const gw_north_ops_t gw_north_modbus_rtu = {
    "modbus_rtu", rtu_create,   rtu_prepare,  rtu_abort,  rtu_commit, rtu_tick, rtu_deadline,
    tcp_on_data,  rtu_on_link,  tcp_on_fault, rtu_status, tcp_safe, rtu_free,
};
