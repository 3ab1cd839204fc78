/* SPDX-License-Identifier: MIT */
/*
 * The Modbus sides of the gateway as northbound sides (north.h): Modbus
 * TCP (mbserver.c) with the [modbus] rules that are not per request (the
 * stale policy on link loss, the single writer's watchdog).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "log.h"
#include "loop.h"
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
