/* SPDX-License-Identifier: MIT */
/*
 * The Modbus side of the gateway as one northbound side (north.h): Modbus
 * TCP (mbserver.c) and the Modbus RTU lines (mbrtu.c), both answering
 * through the one request handler (mbproto.c) from the same units.
 *
 * A unit (regmap.h) is Modbus's per-robot state: the [modbus] rules
 * (word order, on_link_loss, unmapped reads),
 * the single writer's watchdog register and write fault latch, and
 * Modbus's part of the status block; it points at the robot (robot.h),
 * whose images and link facts are the daemon's. The units are kept here
 * by robot position and carried over a reload by the robot's serial, as
 * the daemon carries the robots (same name and link settings: same robot,
 * same unit state). The single writer's watchdog is here too: it spans
 * TCP and RTU (a write on either line moves the same register).
 */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "common/ev.h"
#include "core/log.h"
#include "core/report.h"
#include "modbus/mbrtu.h"
#include "modbus/mbserver.h"
#include "modbus/regmap.h"
#include "core/north.h"

typedef struct mb mb_t;

/* ---- unit lookup and writes, shared by TCP and RTU ------------------------------ */

typedef struct {
    mb_t *mb;
    void (*wrote)(void *side); /* a write reached a robot (single writer) */
    void *side;
    unsigned transport; /* MB_TCP, MB_RTU: which counters its requests go to */
} mb_ctx_t;

enum { MB_TCP = 0, MB_RTU = 1, MB_TRANSPORTS = 2 };
static const char *const transport_name[MB_TRANSPORTS] = {"tcp", "rtu"};

/* For /metrics: requests by function code, exceptions by code, accepted
 * writes, since the side started (TCP and RTU apart). */
typedef struct {
    uint64_t by_fc[MB_TRANSPORTS][128];
    uint64_t by_ex[MB_TRANSPORTS][256];
    uint64_t writes[MB_TRANSPORTS];
    gw_exstats_t ex_at; /* exceptions by place (reqlog.h) */
} mb_counts_t;

/* Modbus TCP */
typedef struct {
    mb_ctx_t ctx;
    gw_mbs_t *mbs;
    /* single writer */
    bool writer_seen;
    unsigned writer_claims; /* gw_mbs_writer_claims() when last looked */
    uint16_t last_watchdog[GW_MAX_ROBOTS];
    uint64_t watchdog_change_us;
} tcp_t;

/* The RTU lines, and during a reload the ones that will take over (a line
 * keeps its hooks, which point at ctx: the lines are reloaded in place). */
typedef struct {
    mb_ctx_t ctx;
    unsigned count, pending_count;
    gw_rtu_config_t cfg[GW_MAX_RTU], pending_cfg[GW_MAX_RTU];
    gw_rtu_t *line[GW_MAX_RTU], *pending[GW_MAX_RTU];
    bool handed[GW_MAX_RTU]; /* line[i] is in pending[] too */
} rtu_t;

struct mb {
    const gw_north_env_t *env;
    gw_unit_t unit[GW_MAX_ROBOTS];   /* by robot position */
    uint32_t serial[GW_MAX_ROBOTS];  /* whose unit it is (prepare: before the move) */
    gw_unit_t moving[GW_MAX_ROBOTS]; /* units_move's copy of the old ones */
    tcp_t tcp;
    rtu_t rtu;
    mb_counts_t n;
};

static void unit_refresh(mb_t *m, unsigned r);

static gw_unit_t *unit_for(void *user, uint8_t unit_id)
{
    const mb_ctx_t *c = user;
    const gw_config_t *cfg = c->mb->env->cfg;
    for (unsigned i = 0; i < cfg->robot_count; i++)
        if (cfg->robot[i].side.modbus.unit_id == unit_id || (unit_id == 0 && cfg->robot[i].side.modbus.alias0) ||
            (unit_id == 255 && cfg->robot[i].side.modbus.alias255)) {
            unit_refresh(c->mb, i);
            return &c->mb->unit[i];
        }
    return NULL;
}

/* A write reached unit u, which unit_for found for the request: its
 * robot is where the daemon keeps it (unit_policy points u->robot into
 * env->robots), and that position is the link's. */
static void on_write(void *user, gw_unit_t *u, unsigned dirty)
{
    const mb_ctx_t *c = user;
    const gw_north_env_t *env = c->mb->env;
    if (c->wrote != NULL)
        c->wrote(c->side);
    env->outputs_changed(env->user, (unsigned)(u->robot - env->robots), dirty);
}

/* Every request: counted (an accepted write that reached robot data was
 * made the robot's last write, and logged, by the write path). */
static void on_request(void *user, const gw_mb_result_t *r, int ex, const char *client,
                       gw_log_limit_t *log)
{
    const mb_ctx_t *c = user;
    mb_counts_t *n = &c->mb->n;
    n->by_fc[c->transport][r->fc & 0x7Fu]++;
    if (ex > 0) {
        n->by_ex[c->transport][ex & 0xFF]++;
        gw_exstats_add(&n->ex_at, c->transport, ev_now_us(), r, ex);
    }
    (void)client, (void)log;
    if (ex != 0 || !r->write || r->dirty == 0 || r->unit == NULL)
        return;
    n->writes[c->transport]++;
}

/* What [modbus] decides about unit r, and its robot (the bits [gpio]
 * inputs drive are the write path's: gw_robot_t.write_policy).
 * on_link_loss = zero is handed to the robot (robot.h: clear_while_down):
 * every side reads its images. */
static void unit_policy(mb_t *m, unsigned r)
{
    const gw_config_t *cfg = m->env->cfg;
    gw_unit_t *u = &m->unit[r];
    u->robot = &m->env->robots[r];
    u->umap = r < cfg->robot_count ? &cfg->robot[r].side.modbus.map : NULL;
    u->default_ro = r < cfg->robot_count && !cfg->robot[r].side.modbus.default_map_writes;
    u->order = cfg->side.modbus.word_order;
    u->on_loss = cfg->side.modbus.on_link_loss;
    u->unmapped = cfg->side.modbus.unmapped_read;
    u->robot->clear_while_down = cfg->side.modbus.on_link_loss == GW_LOSS_ZERO;
}

/* After a reload: each robot's unit from where the robot was (its serial,
 * recorded at prepare), a new robot's afresh. */
static void units_move(mb_t *m)
{
    gw_unit_t *old = m->moving;
    memcpy(old, m->unit, sizeof m->unit);
    memset(m->unit, 0, sizeof m->unit);
    const gw_north_env_t *env = m->env;
    for (unsigned r = 0; r < env->cfg->robot_count; r++)
        for (unsigned o = 0; o < GW_MAX_ROBOTS; o++)
            if (m->serial[o] != 0 && m->serial[o] == env->robots[r].serial)
                m->unit[r] = old[o];
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        unit_policy(m, r);
}

/* ---- Modbus TCP ---------------------------------------------------------------- */

/* A writer seen only between two ticks (it wrote and left within one
 * loop iteration) must still start the watchdog: only the owner's writes
 * get here in single-writer mode. */
static void writer_wrote(void *side)
{
    tcp_t *t = side;
    if (t->ctx.mb->env->cfg->side.modbus.single_writer && !t->writer_seen) {
        t->writer_seen = true;
        t->watchdog_change_us = ev_now_us();
    }
}

static gw_mbs_t *tcp_server(tcp_t *t, char *err, size_t errlen)
{
    gw_mbs_hooks_t mh = {unit_for, on_write, &t->ctx, t->ctx.mb->env->version, on_request};
    return gw_mbs_new(&t->ctx.mb->env->cfg->side.modbus, t->ctx.mb->env->epfd, &mh, err, errlen);
}

static bool tcp_create(mb_t *m, char *err, size_t errlen)
{
    tcp_t *t = &m->tcp;
    t->ctx = (mb_ctx_t){m, writer_wrote, t, MB_TCP};
    t->mbs = tcp_server(t, err, errlen);
    return t->mbs != NULL;
}

/* Reconfigured in place at commit: it cannot refuse. false: no listener
 * is left (logged). */
static bool tcp_commit(tcp_t *t)
{
    const gw_north_env_t *env = t->ctx.mb->env;
    /* Robots may have moved to other positions: the watchdog registers
     * are compared from their current values on, not from the old order. */
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        t->last_watchdog[r] = t->ctx.mb->unit[r].watchdog;
    if (gw_mbs_reconfigure(t->mbs, &env->cfg->side.modbus))
        return true;
    char err[512];
    gw_mbs_free(t->mbs);
    t->mbs = tcp_server(t, err, sizeof err);
    if (t->mbs == NULL) {
        gw_log(GW_LOG_ERROR, "reload: %s", err);
        return false;
    }
    return true;
}

/* The outputs of every robot to their fallback, the fault latched. */
static void writer_expired(tcp_t *t)
{
    const gw_north_env_t *env = t->ctx.mb->env;
    t->writer_seen = false;
    gw_mbs_release_writer(t->mbs);
    gw_log(GW_LOG_WARNING, "modbus: single writer's watchdog expired: outputs to fallback");
    for (unsigned r = 0; r < env->cfg->robot_count; r++) {
        gw_unit_t *u = &t->ctx.mb->unit[r];
        u->robot->fault = true; /* the write path refuses writes from now on */
        if (!env->cfg->robot[r].side.modbus.fallback_hold) {
            unsigned dirty = 0;
            for (unsigned a = 0; a < DR_ASM_COUNT; a++)
                if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_O2T) {
                    memset(u->robot->img[a], 0, DR_ASM_MAX_SIZE);
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
    const gw_north_env_t *env = t->ctx.mb->env;
    const gw_config_t *cfg = env->cfg;
    /* A reset counts in any mode: a fault latched before a reload turned
     * single-writer mode off must not hold the GPIO outputs for ever. */
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        gw_unit_t *u = &t->ctx.mb->unit[r];
        /* The write that reset the latch cleared write_fault at once
         * (mbproto.c: writes pipelined behind it are taken) and logged it. */
        if (u->fault_reset) {
            u->fault_reset = false;
            env->fault(env->user, r, false); /* outputs follow again */
        }
        /* Out of single-writer mode the register is just a register: a
         * value written then is no owner's sign of life later. */
        if (!cfg->side.modbus.single_writer)
            t->last_watchdog[r] = u->watchdog;
    }
    if (!cfg->side.modbus.single_writer) {
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
        const gw_unit_t *u = &t->ctx.mb->unit[r];
        if (u->watchdog != t->last_watchdog[r]) {
            t->last_watchdog[r] = u->watchdog;
            writer_wrote(t); /* only the owner can have written it */
            t->watchdog_change_us = now;
        }
    }
    uint64_t limit = (uint64_t)cfg->side.modbus.writer_watchdog_ms * 1000u;
    if (t->writer_seen && now - t->watchdog_change_us >= limit)
        writer_expired(t);
}

/* ---- Modbus RTU ---------------------------------------------------------------- */

static void rtu_free(rtu_t *t)
{
    for (unsigned i = 0; i < t->count; i++)
        gw_rtu_free(t->line[i]);
    t->count = 0;
}

static gw_rtu_t *rtu_open(rtu_t *t, const gw_rtu_config_t *cfg, const gw_robot_config_t *robots,
                          char *err, size_t errlen)
{
    gw_mbs_hooks_t h = {unit_for, on_write, &t->ctx, t->ctx.mb->env->version, on_request};
    return gw_rtu_new(cfg, robots, t->ctx.mb->env->epfd, &h, err, errlen);
}

static bool rtu_create(mb_t *m, char *err, size_t errlen)
{
    rtu_t *t = &m->rtu;
    const gw_north_env_t *env = m->env;
    t->ctx = (mb_ctx_t){m, NULL, NULL, MB_RTU};
    for (unsigned i = 0; i < env->cfg->side.modbus.rtu_count; i++) {
        t->cfg[i] = env->cfg->side.modbus.rtu[i];
        t->line[i] = rtu_open(t, &t->cfg[i], env->cfg->robot, err, errlen);
        if (t->line[i] == NULL)
            return false;
        t->count++;
    }
    return true;
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
            ra[a->slave_robot[s]].side.modbus.unit_id != rb[b->slave_robot[s]].side.modbus.unit_id)
            return false;
    return true;
}

static void rtu_abort(rtu_t *t)
{
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
static bool rtu_prepare(rtu_t *t, const gw_config_t *next, const gw_north_env_t *env,
                        char *err, size_t errlen)
{
    t->pending_count = 0;
    memset(t->handed, 0, sizeof t->handed);
    for (unsigned i = 0; i < next->side.modbus.rtu_count; i++) {
        t->pending_cfg[i] = next->side.modbus.rtu[i];
        t->pending[i] = NULL;
        for (unsigned o = 0; o < t->count && t->pending[i] == NULL; o++)
            if (!t->handed[o] && same_line(&t->cfg[o], env->cfg->robot, &next->side.modbus.rtu[i], next->robot)) {
                t->pending[i] = t->line[o];
                t->handed[o] = true;
            }
        if (t->pending[i] == NULL)
            t->pending[i] = rtu_open(t, &t->pending_cfg[i], next->robot, err, errlen);
        if (t->pending[i] == NULL) {
            rtu_abort(t);
            return false;
        }
        t->pending_count = i + 1;
    }
    return true;
}

static void rtu_commit(rtu_t *t)
{
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
}

static void rtu_tick(rtu_t *t, uint64_t now)
{
    for (unsigned i = 0; i < t->count; i++)
        gw_rtu_tick(t->line[i], now);
}

static uint64_t rtu_deadline(const rtu_t *t)
{
    uint64_t d = UINT64_MAX;
    for (unsigned i = 0; i < t->count; i++) {
        uint64_t x = gw_rtu_next_deadline(t->line[i]);
        if (x < d)
            d = x;
    }
    return d;
}

/* ---- the side ------------------------------------------------------------------ */

static void mb_free(void *self)
{
    mb_t *m = self;
    if (m == NULL)
        return;
    gw_mbs_free(m->tcp.mbs);
    rtu_free(&m->rtu);
    free(m);
}

static void *mb_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    mb_t *m = calloc(1, sizeof *m);
    if (m == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    m->env = env;
    gw_regmap_init();
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        unit_policy(m, r);
    if (!tcp_create(m, err, errlen) || !rtu_create(m, err, errlen)) {
        mb_free(m);
        return NULL;
    }
    return m;
}

/* TCP is reconfigured in place at commit and cannot refuse; RTU lines
 * that cannot be opened refuse the reload. The robots' serials are taken
 * now, while they are still where the units are. */
static gw_north_reload_t mb_prepare(void *self, const gw_config_t *next,
                                    const gw_north_env_t *env, void **out, char *err,
                                    size_t errlen)
{
    mb_t *m = self;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        m->serial[r] = r < env->cfg->robot_count ? env->robots[r].serial : 0;
    if (!rtu_prepare(&m->rtu, next, env, err, errlen))
        return GW_NORTH_REFUSED;
    *out = m;
    return GW_NORTH_OK;
}

static void mb_abort(void *self, void *out)
{
    mb_t *m = self;
    (void)out;
    rtu_abort(&m->rtu);
}

static void *mb_commit(void *self, void *out, const gw_north_env_t *env)
{
    mb_t *m = self;
    (void)out, (void)env;
    units_move(m);
    bool ok = tcp_commit(&m->tcp);
    rtu_commit(&m->rtu);
    if (!ok) {
        mb_free(m);
        return NULL;
    }
    return m;
}

static void mb_tick(void *self, uint64_t now)
{
    mb_t *m = self;
    gw_mbs_tick(m->tcp.mbs, now);
    writer_watchdog(&m->tcp, now);
    rtu_tick(&m->rtu, now);
}

static uint64_t mb_deadline(const void *self)
{
    const mb_t *m = self;
    uint64_t d = gw_mbs_next_deadline(m->tcp.mbs), x = rtu_deadline(&m->rtu);
    return x < d ? x : d;
}

static void mb_on_data(void *self, unsigned robot, dr_asm_t a)
{
    (void)self, (void)robot, (void)a; /* requests read the images as they are */
}

/* on_link_loss = zero is applied to the images by the robot (robot.h),
 * exception by the read path (regmap.c): nothing to do here. */
static void mb_on_link(void *self, unsigned robot, bool up)
{
    (void)self, (void)robot, (void)up;
}

static void mb_on_fault(void *self, unsigned robot, bool latched)
{
    (void)self, (void)robot, (void)latched; /* set it: gw_robot_t.fault */
}

/* Modbus's part of the status block: clients, exceptions (TCP and every
 * RTU line), the writer, and IR 40-43: the frames dropped and the frames
 * for other slaves of the lines this robot is on. unit_for also calls it
 * for the unit a request addresses, so that a client reading the block
 * finds itself counted: a 10 Hz snapshot would often have been taken
 * before it connected (or after its predecessor left). */
static void unit_refresh(mb_t *m, unsigned r)
{
    gw_status_t *st = &m->unit[r].status;
    uint8_t unit_id = m->env->cfg->robot[r].side.modbus.unit_id;
    st->clients = (uint16_t)gw_mbs_client_count(m->tcp.mbs);
    st->exceptions = gw_mbs_exceptions(m->tcp.mbs);
    st->writer_present = gw_mbs_writer_present(m->tcp.mbs);
    st->rtu_dropped = 0;
    st->rtu_other = 0;
    for (unsigned i = 0; i < m->rtu.count; i++) {
        const gw_rtu_counters_t *n = gw_rtu_counters(m->rtu.line[i]);
        st->exceptions += n->exceptions;
        if (!gw_rtu_serves(m->rtu.line[i], unit_id))
            continue;
        st->rtu_dropped += n->crc_errors;
        st->rtu_other += n->other;
    }
}

static void mb_refresh(void *self)
{
    mb_t *m = self;
    for (unsigned r = 0; r < m->env->cfg->robot_count; r++)
        unit_refresh(m, r);
}

static void mb_safe(void *self)
{
    (void)self;
}

/* ---- the console: report and metrics --------------------------------------------- */

static void json_fmt(gw_json_t *j, const char *fmt, ...) GW_PRINTF(2, 3);
static void json_fmt(gw_json_t *j, const char *fmt, ...)
{
    char t[256];
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(t, sizeof t, fmt, ap);
    va_end(ap);
    if (n < 0 || (size_t)n >= sizeof t)
        j->full = true; /* never cut a member in half */
    else
        gw_json_raw(j, t, (size_t)n);
}

static void json_name(gw_json_t *j, const char *key, const char *s)
{
    json_fmt(j, "\"%s\":", key);
    gw_json_quote(j, s, strlen(s));
}

typedef struct {
    gw_json_t *j;
    bool first;
} client_json_t;

static void client_report(void *user, const gw_mbs_client_info_t *c)
{
    client_json_t *cj = user;
    gw_json_str(cj->j, cj->first ? "{" : ",{");
    cj->first = false;
    json_name(cj->j, "address", c->address);
    json_fmt(cj->j, ",\"requests\":%lu,\"exceptions\":%lu,\"read_write\":%s,\"writer\":%s}",
             (unsigned long)c->requests, (unsigned long)c->exceptions,
             c->read_write ? "true" : "false", c->writer ? "true" : "false");
}

/* "modbus": {"listen", "requests", "exceptions", "clients": [...],
 * "writer_watchdog": {...}, "rtu": [...]} */
static void mb_report(const void *self, gw_json_t *j)
{
    const mb_t *m = self;
    const gw_config_t *cfg = m->env->cfg;
    const tcp_t *t = &m->tcp;
    uint32_t ex = gw_mbs_exceptions(t->mbs);
    json_fmt(j, "\"modbus\":{\"listen\":\"%s:%u\",\"requests\":%lu,\"exceptions\":%lu,"
             "\"clients\":[", cfg->side.modbus.listen, (unsigned)cfg->side.modbus.port,
             (unsigned long)gw_mbs_requests(t->mbs), (unsigned long)ex);
    client_json_t cj = {j, true};
    gw_mbs_each_client(t->mbs, client_report, &cj);
    /* The single writer's watchdog: on in single-writer mode; running once
     * a writer wrote; the robots whose write fault it latched. */
    uint64_t now = ev_now_us(), limit = (uint64_t)cfg->side.modbus.writer_watchdog_ms * 1000u;
    uint64_t left = t->writer_seen && now - t->watchdog_change_us < limit
                        ? (limit - (now - t->watchdog_change_us)) / 1000u
                        : 0;
    json_fmt(j, "],\"writer_watchdog\":{\"single_writer\":%s,\"timeout_ms\":%u,"
             "\"writer_present\":%s,\"running\":%s,\"remaining_ms\":%llu,\"faults\":[",
             cfg->side.modbus.single_writer ? "true" : "false", cfg->side.modbus.writer_watchdog_ms,
             gw_mbs_writer_present(t->mbs) ? "true" : "false",
             t->writer_seen && cfg->side.modbus.single_writer ? "true" : "false",
             (unsigned long long)left);
    bool first = true;
    for (unsigned r = 0; r < cfg->robot_count; r++)
        if (m->unit[r].robot->fault) {
            gw_json_str(j, first ? "" : ",");
            gw_json_quote(j, cfg->robot[r].name, strlen(cfg->robot[r].name));
            first = false;
        }
    gw_json_str(j, "]},\"rtu\":[");
    for (unsigned i = 0; i < m->rtu.count; i++) {
        const gw_rtu_counters_t *n = gw_rtu_counters(m->rtu.line[i]);
        gw_json_str(j, i > 0 ? ",{" : "{");
        json_name(j, "name", m->rtu.cfg[i].name);
        gw_json_str(j, ",");
        json_name(j, "device", m->rtu.cfg[i].device);
        json_fmt(j, ",\"baud\":%u,\"requests\":%lu,\"exceptions\":%lu,\"dropped\":%lu,"
                 "\"other\":%lu}", m->rtu.cfg[i].baud, (unsigned long)n->requests,
                 (unsigned long)n->exceptions, (unsigned long)n->crc_errors,
                 (unsigned long)n->other);
    }
    gw_json_str(j, "]}");
}

/* Requests by function code or exceptions by code (ex), per transport:
 * only the codes seen (a counter that appears later starts from 0). */
static void by_code(gw_prom_t *p, const mb_t *m, bool ex)
{
    const char *name = ex ? "drgate_modbus_exceptions_total" : "drgate_modbus_requests_total";
    gw_prom_family(p, name, GW_PROM_COUNTER,
                   ex ? "Modbus exception replies sent, by exception code"
                      : "Modbus requests answered, by function code");
    for (unsigned t = 0; t < MB_TRANSPORTS; t++)
        for (unsigned c = 0; c < (ex ? 256u : 128u); c++) {
            uint64_t v = ex ? m->n.by_ex[t][c] : m->n.by_fc[t][c];
            if (v == 0)
                continue;
            char code[12]; /* any unsigned: what gcc -O0 checks */
            snprintf(code, sizeof code, "%u", c);
            gw_prom_label_t l[2] = {{"transport", transport_name[t]},
                                    {ex ? "code" : "function_code", code}};
            gw_prom_sample(p, name, l, 2, (double)v);
        }
}

typedef double (*rtu_value_t)(const gw_rtu_counters_t *n);
static double rtu_requests(const gw_rtu_counters_t *n) { return n->requests; }
static double rtu_exceptions(const gw_rtu_counters_t *n) { return n->exceptions; }
static double rtu_dropped(const gw_rtu_counters_t *n) { return n->crc_errors; }
static double rtu_other(const gw_rtu_counters_t *n) { return n->other; }

static void per_line(gw_prom_t *p, const mb_t *m, const char *name, const char *help,
                     rtu_value_t value)
{
    gw_prom_family(p, name, GW_PROM_COUNTER, help);
    for (unsigned i = 0; i < m->rtu.count; i++) {
        gw_prom_label_t l[2] = {{"line", m->rtu.cfg[i].name}, {"device", m->rtu.cfg[i].device}};
        gw_prom_sample(p, name, l, 2, value(gw_rtu_counters(m->rtu.line[i])));
    }
}

static void mb_metrics(const void *self, gw_prom_t *p)
{
    const mb_t *m = self;
    const gw_config_t *cfg = m->env->cfg;
    gw_prom_one(p, "drgate_modbus_clients", GW_PROM_GAUGE, "Modbus TCP clients connected",
                gw_mbs_client_count(m->tcp.mbs));
    by_code(p, m, false);
    by_code(p, m, true);
    gw_prom_family(p, "drgate_modbus_writes_total", GW_PROM_COUNTER,
                   "Modbus writes accepted that changed robot data");
    for (unsigned t = 0; t < MB_TRANSPORTS; t++) {
        gw_prom_label_t l = {"transport", transport_name[t]};
        gw_prom_sample(p, "drgate_modbus_writes_total", &l, 1, (double)m->n.writes[t]);
    }
    gw_prom_one(p, "drgate_modbus_writer_present", GW_PROM_GAUGE,
                "1 while the single writer (single-writer mode) is connected",
                gw_mbs_writer_present(m->tcp.mbs) ? 1 : 0);
    gw_prom_family(p, "drgate_modbus_write_fault", GW_PROM_GAUGE,
                   "1 while the robot's write fault (single writer's watchdog) is latched");
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        gw_prom_label_t l = {"robot", cfg->robot[r].name};
        gw_prom_sample(p, "drgate_modbus_write_fault", &l, 1, m->unit[r].robot->fault);
    }
    if (m->rtu.count == 0)
        return;
    per_line(p, m, "drgate_modbus_rtu_requests_total",
             "Modbus RTU frames for this gateway with a good CRC (broadcasts included)",
             rtu_requests);
    per_line(p, m, "drgate_modbus_rtu_exceptions_total", "Modbus RTU exception replies sent",
             rtu_exceptions);
    per_line(p, m, "drgate_modbus_rtu_dropped_frames_total",
             "Modbus RTU frames dropped: bad CRC, too short or too long", rtu_dropped);
    per_line(p, m, "drgate_modbus_rtu_other_frames_total",
             "Modbus RTU frames for other slave addresses", rtu_other);
}

/* ---- /api/v1/modbus/requests -------------------------------------------------------- */

/* Room kept for one more client's log: a request log that would not fit
 * the console's answer (256 clients) is cut between clients, and says
 * so. */
#define LOG_ROOM (GW_REQLOG_N * 200u + 512u)

typedef struct {
    gw_json_t *j;
    uint64_t now;
    bool first, cut;
} log_json_t;

static void client_log(void *user, const gw_mbs_client_info_t *c)
{
    log_json_t *lj = user;
    if (lj->j->cap - lj->j->len < LOG_ROOM) {
        lj->cut = true;
        return;
    }
    gw_json_str(lj->j, lj->first ? "{" : ",{");
    lj->first = false;
    json_name(lj->j, "client", c->address);
    json_fmt(lj->j, ",\"transport\":\"tcp\",\"connected\":%s,\"read_write\":%s,"
             "\"writer\":%s,\"requests\":%lu,\"exceptions\":%lu,\"log\":[",
             c->connected ? "true" : "false", c->read_write ? "true" : "false",
             c->writer ? "true" : "false", (unsigned long)c->requests,
             (unsigned long)c->exceptions);
    gw_reqlog_json(lj->j, c->log, lj->now);
    gw_json_str(lj->j, "]}");
}

/* {"log_size", "clients": [{"client", "transport", "connected", ...,
 * "log": [...]}], "truncated", "exceptions": {...}}: every TCP client's
 * and RTU line's last requests, and the exceptions by code and place. */
static void requests_json(const mb_t *m, gw_json_t *j)
{
    uint64_t now = ev_now_us();
    json_fmt(j, "{\"log_size\":%u,\"clients\":[", GW_REQLOG_N);
    log_json_t lj = {j, now, true, false};
    if (m->tcp.mbs != NULL)
        gw_mbs_each_log(m->tcp.mbs, client_log, &lj);
    for (unsigned i = 0; i < m->rtu.count; i++) {
        const gw_rtu_counters_t *n = gw_rtu_counters(m->rtu.line[i]);
        gw_json_str(j, lj.first ? "{" : ",{");
        lj.first = false;
        json_name(j, "client", m->rtu.cfg[i].name);
        json_fmt(j, ",\"transport\":\"rtu\",\"connected\":true,\"requests\":%lu,"
                 "\"exceptions\":%lu,\"log\":[",
                 (unsigned long)n->requests, (unsigned long)n->exceptions);
        gw_reqlog_json(j, gw_rtu_reqlog(m->rtu.line[i]), now);
        gw_json_str(j, "]}");
    }
    json_fmt(j, "],\"truncated\":%s,\"exceptions\":", lj.cut ? "true" : "false");
    gw_exstats_json(j, &m->n.ex_at, &m->n.by_ex[0][0], MB_TRANSPORTS, now);
    gw_json_str(j, "}");
}

/* "modbus": {"unit_id", "unit_id_aliases"} of robot r: what a PLC names
 * it by. */
static void mb_robot_report(const void *self, unsigned r, gw_json_t *j)
{
    const mb_t *m = self;
    const gw_config_t *cfg = m->env->cfg;
    if (r >= cfg->robot_count)
        return;
    const gw_modbus_robot_config_t *rc = &cfg->robot[r].side.modbus;
    json_fmt(j, "\"modbus\":{\"unit_id\":%u,\"unit_id_aliases\":[%s%s%s]}",
             (unsigned)rc->unit_id, rc->alias0 ? "0" : "", rc->alias0 && rc->alias255 ? "," : "",
             rc->alias255 ? "255" : "");
}

/* "registers/NAME": robot NAME's registers as a PLC reads them now. */
static bool registers_json(const mb_t *m, const char *name, gw_json_t *j)
{
    const gw_config_t *cfg = m->env->cfg;
    for (unsigned r = 0; r < cfg->robot_count; r++)
        if (strcmp(cfg->robot[r].name, name) == 0) /* (its status block: refreshed ten times a second) */
            return gw_regmap_raw_json(j, &m->unit[r], cfg, r);
    return false;
}

static bool mb_api(const void *self, const char *path, gw_json_t *j)
{
    const mb_t *m = self;
    if (strncmp(path, "registers/", 10) == 0)
        return registers_json(m, path + 10, j);
    if (strcmp(path, "requests") != 0)
        return false;
    requests_json(m, j);
    return !j->full;
}

/* ---- the status summary ------------------------------------------------------------ */

/* The TCP clients: how many, and "address (writer), ..." (as long as the
 * text has room). */
typedef struct {
    char text[1024];
    size_t len;
    unsigned n;
} client_list_t;

static void client_summary(void *user, const gw_mbs_client_info_t *c)
{
    client_list_t *l = user;
    int k = snprintf(l->text + l->len, sizeof l->text - l->len, "%s%s%s", l->n > 0 ? ", " : "",
                     c->address, c->writer ? " (writer)" : "");
    if (k > 0 && (size_t)k < sizeof l->text - l->len)
        l->len += (size_t)k;
    l->n++;
}

/* "Modbus: 0.0.0.0:502, 2 clients: 10.0.0.7:50112 (writer), ..." */
static void mb_summary(const void *self, gw_side_summary_t *s)
{
    const mb_t *m = self;
    const gw_modbus_config_t *mc = &m->env->cfg->side.modbus;
    client_list_t l = {"", 0, 0};
    gw_mbs_each_client(m->tcp.mbs, client_summary, &l);
    snprintf(s->label, sizeof s->label, "Modbus");
    snprintf(s->line, sizeof s->line, "%s:%u, %u client%s%s%s", mc->listen, (unsigned)mc->port,
             l.n, l.n == 1 ? "" : "s", l.n > 0 ? ": " : "", l.text);
    snprintf(s->brief, sizeof s->brief, "%u Modbus client%s", l.n, l.n == 1 ? "" : "s");
}

/* ---- what the daemon asks of the configuration, and its commands --------------------- */

/* The register map: the only side that has one (regmap.c). */
typedef char mb_map_fits[GW_REGMAP_JSON_SIZE <= GW_NORTH_MAP_MAX ? 1 : -1]; // NOLINT(misc-redundant-expression)

static bool mb_map_json(const gw_config_t *cfg, unsigned robot, gw_json_t *j)
{
    return gw_regmap_json(j, cfg, robot);
}

static bool mb_map_csv(const gw_config_t *cfg, unsigned robot, gw_json_t *j)
{
    return gw_regmap_csv(j, cfg, robot);
}

const gw_north_ops_t gw_north_modbus = {
    .name = "modbus",
    .create = mb_create,
    .prepare = mb_prepare,
    .abort = mb_abort,
    .commit = mb_commit,
    .tick = mb_tick,
    .deadline = mb_deadline,
    .on_data = mb_on_data,
    .on_link = mb_on_link,
    .on_fault = mb_on_fault,
    .refresh = mb_refresh,
    .safe = mb_safe,
    .free = mb_free,
    .report = mb_report,
    .metrics = mb_metrics,
    .summary = mb_summary,
    .api = mb_api,
    .robot_report = mb_robot_report,
    .map_json = mb_map_json,
    .map_csv = mb_map_csv,
    .print_map = gw_regmap_print_all,
    .print_errors = gw_regmap_print_errors,
};
