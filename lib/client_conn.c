/* SPDX-License-Identifier: MIT */
/*
 * The client's Class 1 connections: Forward Open and Close, O->T
 * production on a time grid (and following the T->O arrivals), T->O
 * consumption with its sequence number checks, and the connections'
 * timers.
 */
#include <stdint.h>
#include <string.h>

#include "client_internal.h"

/* ---- Class 1 connections ------------------------------------------------- */

void drc_conn_set_state(dr_conn_t *cn, dr_conn_state_t s, dr_status_t why)
{
    if (cn->state == s)
        return;
    /* The port scans for target-chosen IDs only while one is in use. */
    if (cn->foreign_cid && (cn->state == DR_CONN_ESTABLISHED) != (s == DR_CONN_ESTABLISHED)) {
        if (s == DR_CONN_ESTABLISHED)
            cn->client->udp->foreign++;
        else
            cn->client->udp->foreign--;
    }
    cn->state = s;
    if (cn->cfg.on_state != NULL)
        cn->cfg.on_state(cn, s, why, cn->cfg.user);
}

const char *dr_conn_state_name(dr_conn_state_t s)
{
    switch (s) {
    case DR_CONN_IDLE: return "idle";
    case DR_CONN_OPENING: return "opening";
    case DR_CONN_ESTABLISHED: return "connected";
    case DR_CONN_TIMED_OUT: return "timed out";
    case DR_CONN_RECONNECTING: return "reconnecting";
    case DR_CONN_CLOSED: return "closed";
    }
    return "?";
}

static dr_status_t ensure_udp(dr_client_t *c)
{
    if (c->udp->h >= 0)
        return DR_OK;
    dr_sockaddr_t local = {c->local_udp_addr, c->cfg.local_udp_port};
    c->udp->local = local;
    return c->tp.ops->udp_open(c->tp.ctx, local, &c->udp->h);
}

static uint64_t conn_backoff_us(dr_conn_t *cn)
{
    dr_client_t *c = cn->client;
    uint64_t d = (uint64_t)cn->backoff_ms * 1000u;
    cn->backoff_ms = min_u32(cn->backoff_ms * 2u, c->cfg.backoff_max_ms);
    return d;
}

void drc_conn_schedule_retry(dr_conn_t *cn, dr_status_t why)
{
    cn->retry_us = now_us(cn->client) + conn_backoff_us(cn);
    drc_conn_set_state(cn, DR_CONN_RECONNECTING, why);
}

/* The instances of a connection's path: configuration, O->T point (an
 * assembly or a heartbeat), T->O point. */
static void conn_path_inst(const dr_conn_t *cn, uint16_t inst[3])
{
    const dr_client_t *c = cn->client;
    inst[0] = cn->cfg.config_instance;
    inst[1] = cn->cfg.o2t_asm < 0      ? cn->cfg.heartbeat_instance
              : cn->cfg.o2t_instance != 0 ? cn->cfg.o2t_instance
                                          : c->cfg.instance[cn->cfg.o2t_asm];
    inst[2] = cn->cfg.t2o_instance != 0 ? cn->cfg.t2o_instance : c->cfg.instance[cn->cfg.t2o_asm];
}

static size_t conn_path(const dr_conn_t *cn, uint8_t *buf, size_t cap)
{
    uint16_t inst[3];
    conn_path_inst(cn, inst);
    return dr_conn_path_write(buf, cap, inst[0], inst[1], inst[2]);
}

/* 32 bits from the transport's random source, or false. */
static bool random32(dr_client_t *c, uint32_t *v)
{
    uint8_t b[4];
    if (!drc_random(c, b, sizeof b))
        return false;
    *v = (uint32_t)b[0] | (uint32_t)b[1] << 8 | (uint32_t)b[2] << 16 | (uint32_t)b[3] << 24;
    return true;
}

/* A fresh T->O connection ID that says where the connection lives (see
 * struct dr_udp_port): generation * CID_SLOTS + slot, never 0, and never
 * wrapping past 2^32, so that cid % CID_SLOTS is the slot for any bounds.
 * The generation comes from the transport's random source when it has
 * one (an ID nobody off the path can guess), else from the client's
 * counter; never the one the slot had last, so that late packets of the
 * connection before are not taken for this one's. */
static uint32_t next_t2o_cid(const dr_conn_t *cn)
{
    dr_client_t *c = cn->client;
    uint32_t gens = UINT32_MAX / CID_SLOTS; /* generations that fit */
    uint32_t r, gen, slot = (uint32_t)c->port_slot * DR_CLIENT_MAX_CONNS + (uint32_t)(cn - c->conns);
    if (random32(c, &r))
        gen = 1u + r % (gens - 1u);
    else
        gen = 1u + c->cid_gen++ % (gens - 1u);
    if (gen * CID_SLOTS + slot == cn->stats.t2o_cid)
        gen = 1u + gen % (gens - 1u);
    return gen * CID_SLOTS + slot;
}

/* A connection serial for a new Forward Open of cn: random when the
 * transport has a source (so the triad a Forward Close needs cannot be
 * guessed off the path), else the client's counter; never one another
 * connection of the client holds or may hold (its current serial, its
 * unanswered opens), which would make the adapter refuse the open as a
 * duplicate or close the wrong connection. */
static uint16_t next_serial(dr_conn_t *cn)
{
    dr_client_t *c = cn->client;
    for (unsigned tries = 0;; tries++) {
        uint32_t r;
        uint16_t s = tries < 8 && random32(c, &r) ? (uint16_t)r : c->next_serial++;
        bool taken = false;
        for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS && !taken; i++) {
            const dr_conn_t *o = &c->conns[i];
            if (!o->used || o == cn)
                continue;
            taken = o->conn_serial == s;
            for (unsigned k = 0; k < o->nstale && !taken; k++)
                taken = o->stale[k] == s;
        }
        for (unsigned k = 0; k < cn->nstale && !taken; k++)
            taken = cn->stale[k] == s;
        if (!taken || tries >= 8 + DR_CLIENT_MAX_CONNS * (CONN_MAX_STALE + 1) + CONN_MAX_STALE)
            return s;
    }
}

static bool send_close_triad(dr_client_t *c, dr_conn_t *cn, uint16_t serial,
                             const uint16_t inst[3]);

static unsigned free_reqs(const dr_client_t *c)
{
    unsigned n = 0;
    for (unsigned i = 0; i < MAX_REQS; i++)
        n += !c->reqs[i].active;
    return n;
}

static void send_forward_open(dr_conn_t *cn)
{
    dr_client_t *c = cn->client;
    dr_status_t ust = ensure_udp(c);
    if (ust != DR_OK) {
        c->step = "bind UDP";
        drc_conn_schedule_retry(cn, ust);
        return;
    }
    /* The Forward Closes of its unanswered opens go first, in the same
     * stream: the adapter handles them before this open, which it would
     * otherwise refuse (0x0106) while one of those holds the O->T point. */
    if (free_reqs(c) < cn->nstale + 1u) {
        cn->retry_us = now_us(c) + 10000u; /* request slots busy: soon again */
        return;
    }
    uint16_t inst[3];
    conn_path_inst(cn, inst);
    for (unsigned i = 0; i < cn->nstale; i++)
        if (!send_close_triad(c, cn, cn->stale[i], inst) || c->state != S_READY) {
            cn->retry_us = now_us(c) + 10000u; /* no room, or no session */
            return;
        }
    req_t *r = drc_req_alloc(c, R_FWD_OPEN);
    r->conn = cn;
    uint8_t path[32];
    dr_fwd_open_t fo;
    memset(&fo, 0, sizeof fo);
    fo.large = cn->large_now;
    fo.priority_tick = 0x0A;
    fo.timeout_ticks = 0x05;
    fo.o2t_cid = 0; /* the target chooses for point-to-point */
    fo.t2o_cid = next_t2o_cid(cn);
    cn->foreign_cid = false; /* not established: no port count to move */
    cn->conn_serial = next_serial(cn); /* fresh on every attempt */
    fo.conn_serial = cn->conn_serial;
    r->conn_serial = cn->conn_serial;
    memcpy(r->path_inst, inst, sizeof inst);
    fo.vendor = c->cfg.vendor_id;
    fo.orig_serial = c->cfg.serial;
    fo.timeout_mult = cn->cfg.timeout_mult;
    fo.o2t_rpi_us = cn->cfg.rpi_us;
    fo.t2o_rpi_us = cn->cfg.rpi_us;
    fo.o2t.type = DR_CONN_TYPE_P2P;
    fo.o2t.priority = 2; /* scheduled */
    fo.o2t.size = (uint16_t)(cn->o2t_size + 2u + (cn->cfg.o2t_asm >= 0 ? 4u : 0u));
    fo.t2o.type = DR_CONN_TYPE_P2P;
    fo.t2o.priority = 2;
    fo.t2o.size = (uint16_t)(cn->t2o_size + 2u + (cn->cfg.t2o_run_idle ? 4u : 0u));
    fo.transport = 0x01; /* class 1, cyclic, client */
    fo.path = path;
    fo.path_len = conn_path(cn, path, sizeof path);

    uint8_t data[128], msg[160];
    dr_wr_t w;
    dr_wr_init(&w, data, sizeof data);
    dr_fwd_open_write(&w, &fo);
    static const uint8_t cm_path[] = {0x20, 0x06, 0x24, 0x01};
    dr_wr_t m;
    dr_wr_init(&m, msg, sizeof msg);
    dr_cip_req_write(&m, cn->large_now ? DR_CIP_SVC_LARGE_FORWARD_OPEN : DR_CIP_SVC_FORWARD_OPEN,
                     cm_path, sizeof cm_path, data, w.len);
    cn->stats.t2o_cid = fo.t2o_cid;
    cn->stats.opens++;
    c->step = "forward open";
    drc_conn_set_state(cn, DR_CONN_OPENING, DR_OK);
    /* Tell the target where T->O goes when it is not where it would
     * guess (the TCP connection's own address, port 2222). */
    bool sockaddr = c->udp->local.port != DR_ENIP_UDP_PORT || c->udp->local.addr != 0;
    dr_status_t st = drc_send_rr(c, r, msg, m.len, sockaddr);
    if (st != DR_OK) {
        r->active = false;
        drc_conn_schedule_retry(cn, st);
    }
}

/* Forward Close of the connection with our vendor ID and originator
 * serial and connection serial `serial`, path instances inst; its reply
 * goes to cn (NULL: nobody). False if it could not be sent. */
static bool send_close_triad(dr_client_t *c, dr_conn_t *cn, uint16_t serial,
                             const uint16_t inst[3])
{
    if (c->state != S_READY)
        return false; /* the target times the connection out by itself */
    req_t *r = drc_req_alloc(c, R_FWD_CLOSE);
    if (r == NULL)
        return false;
    r->conn = cn;
    r->conn_serial = serial;
    memcpy(r->path_inst, inst, sizeof r->path_inst);
    uint8_t path[32], data[64], msg[96];
    dr_fwd_close_t fc;
    fc.priority_tick = 0x0A;
    fc.timeout_ticks = 0x05;
    fc.conn_serial = serial;
    fc.vendor = c->cfg.vendor_id;
    fc.orig_serial = c->cfg.serial;
    fc.path = path;
    fc.path_len = dr_conn_path_write(path, sizeof path, inst[0], inst[1], inst[2]);
    dr_wr_t w, m;
    dr_wr_init(&w, data, sizeof data);
    dr_fwd_close_write(&w, &fc);
    static const uint8_t cm_path[] = {0x20, 0x06, 0x24, 0x01};
    dr_wr_init(&m, msg, sizeof msg);
    dr_cip_req_write(&m, DR_CIP_SVC_FORWARD_CLOSE, cm_path, sizeof cm_path, data, w.len);
    if (drc_send_rr(c, r, msg, m.len, false) != DR_OK) {
        r->active = false;
        return false;
    }
    return true;
}

void drc_send_forward_close(dr_conn_t *cn)
{
    uint16_t inst[3];
    conn_path_inst(cn, inst);
    /* No reply is awaited: a connection that is not closed times out. */
    (void)send_close_triad(cn->client, NULL, cn->conn_serial, inst);
}

/* A Forward Open succeeded for a connection that no longer wants it (it
 * was removed or closed while the request was under way): the adapter has
 * opened a connection nobody will produce for, and would hold it as an
 * owner. Closed at once, by the triad of the reply. */
void drc_close_orphan(dr_client_t *c, const req_t *r, const dr_cip_rsp_t *rsp)
{
    dr_fwd_open_reply_t rp;
    if (dr_fwd_open_reply_parse(rsp->data, rsp->data_len, &rp) == DR_OK)
        (void)send_close_triad(c, NULL, rp.conn_serial, r->path_inst);
}

/* Remember (or forget) a Forward Open that may have opened a connection
 * we know nothing of: see dr_conn stale. The oldest goes when full. */
static void stale_add(dr_conn_t *cn, uint16_t serial)
{
    if (cn->nstale == CONN_MAX_STALE) {
        memmove(cn->stale, cn->stale + 1, sizeof cn->stale[0] * (CONN_MAX_STALE - 1));
        cn->nstale--;
    }
    cn->stale[cn->nstale++] = serial;
}

static void stale_forget(dr_conn_t *cn, uint16_t serial)
{
    for (unsigned i = 0; i < cn->nstale; i++)
        if (cn->stale[i] == serial) {
            memmove(cn->stale + i, cn->stale + i + 1,
                    sizeof cn->stale[0] * (cn->nstale - i - 1));
            cn->nstale--;
            return;
        }
}

/* The first point of the grid epoch + k * api after t. Connections with
 * the same API then produce at the same instants: one wake-up sends all of
 * them, instead of one wake-up per connection. */
static uint64_t grid_after(const dr_client_t *c, uint64_t t, uint64_t api)
{
    if (api == 0 || t < c->epoch)
        return t;
    return c->epoch + ((t - c->epoch) / api + 1u) * api;
}

static void conn_established(dr_conn_t *cn, const dr_fwd_open_reply_t *rp,
                             const dr_cpf_t *cpf)
{
    dr_client_t *c = cn->client;
    uint64_t t = now_us(c);
    cn->stats.o2t_cid = rp->o2t_cid;
    cn->foreign_cid = rp->t2o_cid != cn->stats.t2o_cid; /* counted by conn_set_state */
    cn->stats.t2o_cid = rp->t2o_cid;
    cn->stats.o2t_api_us = rp->o2t_api_us ? rp->o2t_api_us : cn->cfg.rpi_us;
    cn->stats.t2o_api_us = rp->t2o_api_us ? rp->t2o_api_us : cn->cfg.rpi_us;
    /* Timers run from the APIs the target granted, not what we asked; in
     * 64 bits (an API of 9 s times 512 is 4608 s, past 2^32 us). */
    uint64_t timeout = (uint64_t)cn->stats.t2o_api_us * (4u << cn->cfg.timeout_mult);
    cn->stats.timeout_us64 = timeout;
    cn->stats.timeout_us = timeout > UINT32_MAX ? UINT32_MAX : (uint32_t)timeout;
    cn->o2t_to.addr = c->peer.addr;
    cn->o2t_to.port = c->cfg.udp_port;
    const dr_cpf_item_t *it = cpf ? dr_cpf_find(cpf, DR_CPF_SOCKADDR_O2T) : NULL;
    dr_sockaddr_t sa;
    if (it != NULL && dr_cpf_sockaddr_parse(it, &sa) == DR_OK) {
        if (sa.addr != 0)
            cn->o2t_to.addr = sa.addr;
        if (sa.port != 0)
            cn->o2t_to.port = sa.port;
    }
    cn->have_t2o_seq = false;
    cn->resync_n = 0;
    cn->next_tx_us = grid_after(c, t, cn->stats.o2t_api_us);
    cn->last_tx_us = 0;
    cn->follow_misses = 0;
    cn->rx_deadline_us = t + cn->stats.timeout_us64 + FIRST_PACKET_GRACE_US;
    cn->stats.opened_us = t;
    cn->backoff_ms = c->cfg.backoff_min_ms;
    cn->dup_retries = 0;
    drc_conn_set_state(cn, DR_CONN_ESTABLISHED, DR_OK);
}

void drc_conn_on_reply(dr_conn_t *cn, req_t *r, const dr_cip_rsp_t *rsp,
                          const dr_cpf_t *cpf)
{
    if (r->kind == R_FWD_CLOSE) {
        /* A close of an unanswered open: any CIP answer (success, or
         * 0x0107 when the open never arrived) settles it. */
        if (rsp != NULL)
            stale_forget(cn, r->conn_serial);
        return;
    }
    if (rsp == NULL) /* no reply at all: the adapter may have opened it */
        stale_add(cn, r->conn_serial);
    if (cn->state != DR_CONN_OPENING) {
        if (rsp != NULL && r->status == DR_OK) /* closed meanwhile */
            drc_close_orphan(cn->client, r, rsp);
        return;
    }
    dr_status_t st = r->status;
    if (rsp != NULL && st == DR_OK) {
        dr_fwd_open_reply_t rp;
        st = dr_fwd_open_reply_parse(rsp->data, rsp->data_len, &rp);
        if (st == DR_OK) {
            conn_established(cn, &rp, cpf);
            return;
        }
    }
    if (rsp != NULL && rsp->general == 0x01 && rsp->ext_count >= 2 &&
        rsp->ext[0] == 0x0109)
        cn->stats.size_wanted = rsp->ext[1];
    if (st == DR_CIP(0x01, 0x0100) && cn->dup_retries++ < 3) {
        send_forward_open(cn); /* a fresh serial is enough */
        return;
    }
    if (cn->large_now && (st == DR_CIP(0x08, 0) || st == DR_CIP(0x01, 0x0108) ||
                          st == DR_CIP(0x01, 0x0111))) {
        cn->large_now = false; /* the target may not know 0x5B */
        send_forward_open(cn);
        return;
    }
    drc_conn_schedule_retry(cn, st);
}

dr_conn_t *dr_conn_add(dr_client_t *c, const dr_conn_config_t *cfg,
                              dr_status_t *err)
{
    dr_status_t st = DR_EINVAL;
    dr_conn_t *cn = NULL;
    const dr_asm_info_t *t2o = cfg ? dr_asm_info(cfg->t2o_asm) : NULL;
    const dr_asm_info_t *o2t = cfg && cfg->o2t_asm >= 0 ? dr_asm_info((dr_asm_t)cfg->o2t_asm) : NULL;
    if (t2o == NULL || t2o->dir != DR_DIR_T2O || (cfg->o2t_asm >= 0 && (o2t == NULL || o2t->dir != DR_DIR_O2T)) ||
        cfg->rpi_us == 0 || cfg->timeout_mult > 7 || cfg->t2o_size > DR_CLIENT_IO_MAX ||
        cfg->o2t_size > DR_CLIENT_IO_MAX || (cfg->o2t_size != 0 && cfg->o2t_asm < 0))
        goto out;
    st = DR_EFULL;
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS && cn == NULL; i++)
        if (!c->conns[i].used)
            cn = &c->conns[i];
    if (cn == NULL)
        goto out;
    memset(cn, 0, sizeof *cn);
    cn->used = true;
    cn->client = c;
    cn->cfg = *cfg;
    if (cn->cfg.config_instance == 0) cn->cfg.config_instance = 1;
    if (cn->cfg.heartbeat_instance == 0) cn->cfg.heartbeat_instance = 198;
    cn->o2t_size = cfg->o2t_size != 0 ? cfg->o2t_size : o2t ? o2t->size : 0;
    cn->t2o_size = cfg->t2o_size != 0 ? cfg->t2o_size : t2o->size;
    cn->run = true;
    cn->backoff_ms = c->cfg.backoff_min_ms;
    cn->state = DR_CONN_IDLE;
    cn->retry_us = 0; /* open as soon as the session is up */
    deadline_moved(c);
    st = DR_OK;
out:
    if (err != NULL)
        *err = st;
    return st == DR_OK ? cn : NULL;
}

void dr_conn_remove(dr_conn_t *cn)
{
    if (cn == NULL || !cn->used)
        return;
    if (cn->state == DR_CONN_ESTABLISHED)
        drc_send_forward_close(cn);
    uint16_t inst[3];
    conn_path_inst(cn, inst);
    for (unsigned i = 0; i < cn->nstale; i++)
        (void)send_close_triad(cn->client, NULL, cn->stale[i], inst);
    drc_conn_set_state(cn, DR_CONN_CLOSED, DR_OK);
    /* Requests still in flight for it must not call back into the slot
     * (an open that succeeds after this is closed: close_orphan). */
    for (unsigned i = 0; i < MAX_REQS; i++)
        if (cn->client->reqs[i].conn == cn)
            cn->client->reqs[i].conn = NULL;
    cn->used = false;
    deadline_moved(cn->client);
}

dr_status_t dr_conn_set_output(dr_conn_t *cn, const uint8_t *data, size_t len)
{
    if (cn == NULL || cn->cfg.o2t_asm < 0 || data == NULL)
        return DR_EINVAL;
    if (len != cn->o2t_size)
        return DR_ELENGTH;
    memcpy(cn->out, data, len);
    return DR_OK;
}

void dr_conn_set_run(dr_conn_t *cn, bool run)
{
    cn->run = run;
}

dr_conn_state_t dr_conn_state(const dr_conn_t *cn)
{
    return cn->state;
}

const dr_conn_stats_t *dr_conn_stats(const dr_conn_t *cn)
{
    return &cn->stats;
}

void *dr_conn_user(const dr_conn_t *cn)
{
    return cn->cfg.user;
}

const uint8_t *dr_conn_input(const dr_conn_t *cn, size_t *len)
{
    if (!cn->have_in)
        return NULL;
    if (len != NULL)
        *len = cn->t2o_size;
    return cn->in;
}

/* cfg.o2t_follow_us as it applies to cn: the window (at most half the
 * API), or 0 when O->T goes by its own timer alone (no window asked for,
 * or APIs that differ both ways, when the arrivals do not mark our
 * periods). */
static uint64_t follow_window(const dr_conn_t *cn)
{
    uint64_t api = cn->stats.o2t_api_us, win = cn->cfg.o2t_follow_us;
    if (win == 0 || api != cn->stats.t2o_api_us)
        return 0;
    return win < api / 2u ? win : api / 2u;
}

static void conn_produce(dr_conn_t *cn, uint64_t t)
{
    dr_client_t *c = cn->client;
    size_t len;
    dr_io_frame_t f;
    cn->o2t_seq16++;
    cn->o2t_seq32++;
    f.cid = cn->stats.o2t_cid;
    f.encap_seq = cn->o2t_seq32;
    f.cip_seq = cn->o2t_seq16;
    f.has_run_idle = cn->cfg.o2t_asm >= 0;
    f.run_idle = cn->run ? 1u : 0u;
    f.data = cn->out;
    f.data_len = cn->o2t_size;
    if (c->tx_n == DR_CLIENT_MAX_CONNS)
        drc_flush_io(c); /* held (dr_udp_port_hold) and full: no frame is lost */
    if (dr_io_frame_write(c->tx_frames[c->tx_n], UDP_BUF, &f, &len) == DR_OK) {
        dr_udp_msg_t *m = &c->tx_batch[c->tx_n];
        m->buf = c->tx_frames[c->tx_n];
        m->len = len;
        m->addr = cn->o2t_to;
        c->tx_conn[c->tx_n++] = cn;
    }
    cn->last_tx_us = t;
    /* Absolute deadlines: the next packet is due one API after the last
     * deadline, not after now, so the rate does not drift. After a stall
     * of more than one period, start again from now instead of bursting. */
    uint64_t api = cn->stats.o2t_api_us;
    cn->next_tx_us += api;
    if (cn->next_tx_us <= t)
        cn->next_tx_us = grid_after(c, t, api);
    /* Following the arrivals, a packet may leave up to the window before
     * its deadline; one that left late (a busy loop) must not pull the
     * next one closer than API - window to it. */
    uint64_t win = follow_window(cn);
    if (win != 0 && cn->next_tx_us < t + api - win)
        cn->next_tx_us = t + api - win;
}

/* cfg.o2t_follow_us: an O->T packet due within the window is produced
 * when the connection's T->O packet arrives, so that one wake-up serves
 * both directions instead of one for the arrival and one for our own
 * deadline moments later. Two rules keep the adapter's view of our
 * packets what the Forward Open promised, whatever the arrivals do:
 *  - two packets are never closer than API - window: an arrival sends
 *    only that long after the last packet (an arrival moments after a
 *    packet the timer sent is not the next period's);
 *  - deadlines only ever move later, never closer than one API apart, so
 *    the rate never exceeds one packet per API.
 * When arrivals keep falling outside the window (FOLLOW_MISSES in a row:
 * the connection has just opened, or the two clocks drift apart, as real
 * adapters' do) the schedule moves later towards "due half a window after
 * the next expected arrival", by at most half a window per period: the
 * next deadline never goes past the last packet + API + window / 2. Each
 * further miss moves it again, until an arrival falls in the window.
 *
 * The longest O->T interval, in virtual time (the loop on time): API +
 * window, reached by a packet sent a whole window early with an arrival
 * and the next one on its deadline; a move adds at most window / 2 to an
 * interval that began on a deadline, so it stays within that. With the
 * gateway's window (RPI / 4, gateway/core/link.c) that is 1.25 RPI. The
 * move used to go in one step (to the arrival + API + window / 2), which
 * left out the packet then due: an interval of up to 2 API - window / 2
 * against an adapter whose clock runs fast (arrivals drift out of the
 * window's early end), 1.875 RPI with the gateway's window (1.9 RPI was
 * measured at RPI 50 ms, issue 30), and up to 2 API + window / 2 with
 * bunched arrivals. Against a fast adapter the schedule must move later by
 * nearly an API to catch its next arrival (ours may not run faster than
 * one packet per API); in steps of half a window that takes up to
 * 2 API / window - 1 periods (7 with the gateway's window), in which the
 * packets go on their timer. test_class1_follow_spacing asserts the bound.
 * Only for equal APIs both ways: otherwise the arrivals do not mark our
 * periods. */
#define FOLLOW_MISSES 3u

static void follow_t2o(dr_conn_t *cn, uint64_t t)
{
    uint64_t api = cn->stats.o2t_api_us, win = follow_window(cn);
    if (win == 0 || cn->state != DR_CONN_ESTABLISHED)
        return;
    bool spaced = cn->last_tx_us == 0 || t >= cn->last_tx_us + api - win;
    if (cn->next_tx_us <= t + win) {
        cn->follow_misses = 0;
        if (spaced)
            conn_produce(cn, t);
    } else if (++cn->follow_misses >= FOLLOW_MISSES) {
        cn->follow_misses = FOLLOW_MISSES; /* and again at the next miss */
        uint64_t to = t + api + win / 2u;
        if (cn->last_tx_us != 0 && to > cn->last_tx_us + api + win / 2u)
            to = cn->last_tx_us + api + win / 2u;
        if (cn->next_tx_us < to)
            cn->next_tx_us = to;
    }
}

void drc_conn_timers(dr_conn_t *cn, uint64_t t)
{
    dr_client_t *c = cn->client;
    switch (cn->state) {
    case DR_CONN_ESTABLISHED:
        if (t >= cn->rx_deadline_us) {
            /* Not one packet within the first packet's grace: the adapter
             * took the Forward Open and its data goes elsewhere (a
             * firewall, or another address than ours): its own cause. */
            dr_status_t why = cn->have_t2o_seq ? DR_ETIMEDOUT : DR_ENODATA;
            cn->stats.timeouts++;
            drc_conn_set_state(cn, DR_CONN_TIMED_OUT, why);
            drc_send_forward_close(cn); /* so the new open is not a duplicate */
            drc_conn_schedule_retry(cn, why);
            break;
        }
        if (t >= cn->next_tx_us)
            conn_produce(cn, t);
        break;
    case DR_CONN_IDLE:
    case DR_CONN_RECONNECTING:
    case DR_CONN_TIMED_OUT:
        if (c->state == S_READY && t >= cn->retry_us) {
            cn->large_now = cn->cfg.large;
            send_forward_open(cn);
        }
        break;
    default:
        break;
    }
}

uint64_t drc_conn_deadline(const dr_conn_t *cn)
{
    switch (cn->state) {
    case DR_CONN_ESTABLISHED:
        return cn->next_tx_us < cn->rx_deadline_us ? cn->next_tx_us : cn->rx_deadline_us;
    case DR_CONN_IDLE:
    case DR_CONN_RECONNECTING:
    case DR_CONN_TIMED_OUT:
        return cn->client->state == S_READY ? cn->retry_us : UINT64_MAX;
    default:
        return UINT64_MAX;
    }
}

/* How far ahead of the last packet taken a T->O encapsulation sequence
 * number may be: half the packets of a timeout (4 << multiplier), at
 * least 8. A live producer cannot have gone much further (the connection
 * would have timed out meanwhile), and a number that went further is a
 * corrupted one, e.g. a bit flipped high in a datagram whose UDP checksum
 * is zero (IPv4 allows it), or a forged one: taken, it would make every
 * real packet after it look old until the connection timed out. Within
 * the window, such a number costs at most the packets up to it, half a
 * timeout. */
#define SEQ_RESYNC 3u /* packets in a row that agree with each other */

static uint32_t seq_window(const dr_conn_t *cn)
{
    uint32_t w = (4u << cn->cfg.timeout_mult) / 2u;
    return w < 8u ? 8u : w;
}

/* Whether a T->O packet with encapsulation sequence number seq, arriving
 * at t, is newer than the last one taken. Too far ahead: dropped, unless
 * the sequence taken so far has gone silent (nothing taken for half the
 * timeout: a live producer is never that quiet)
 * and this is the SEQ_RESYNC-th in a row of such numbers, each within the
 * window after the one before: a producer that really jumped (it
 * restarted its count within the connection), followed from there
 * before the connection times out. While the real sequence keeps coming,
 * numbers far ahead of it are never believed however many agree (issue
 * 29: three forged packets used to take the connection over, and every
 * real one after them was dropped as old until the timeout). */
static bool t2o_seq_take(dr_conn_t *cn, uint32_t seq, uint64_t t)
{
    uint32_t win = seq_window(cn);
    uint32_t ahead = seq - cn->t2o_seq32;
    if (ahead != 0u && ahead <= win) {
        cn->resync_n = 0;
        return true;
    }
    if (!dr_seq32_newer(seq, cn->t2o_seq32))
        return false; /* a duplicate or an older packet */
    uint32_t step = seq - cn->resync_seq32;
    cn->resync_n = cn->resync_n > 0 && step != 0u && step <= win ? cn->resync_n + 1u : 1u;
    cn->resync_seq32 = seq;
    bool quiet = t >= cn->stats.last_rx_us &&
                 t - cn->stats.last_rx_us >= cn->stats.timeout_us64 / 2u;
    if (cn->resync_n < SEQ_RESYNC || !quiet)
        return false;
    cn->resync_n = 0;
    cn->stats.rx_resyncs++;
    return true;
}

/* A packet for connection cn (f: parsed without a run/idle header): check
 * it, take it, keep the connection alive. */
void drc_conn_datagram(dr_conn_t *cn, const uint8_t *buf, size_t len,
                          const dr_io_frame_t *fp, uint64_t t)
{
    dr_io_frame_t f = *fp;
    if (cn->cfg.t2o_run_idle && dr_io_frame_parse(buf, len, true, &f) != DR_OK) {
        cn->stats.rx_bad++;
        return;
    }
    if (f.data_len != cn->t2o_size) {
        cn->stats.rx_bad++;
        return;
    }
    /* Liveness goes by the 32-bit encapsulation sequence number, which the
     * producer advances with every packet: one that is not newer than the
     * last one taken (wrap-safe) is a duplicate or came late, one too far
     * ahead is corrupted (t2o_seq_take), and neither counts as a sign of
     * life. */
    if (cn->have_t2o_seq && !t2o_seq_take(cn, f.encap_seq, t)) {
        cn->stats.rx_dropped_seq++;
        return;
    }
    cn->t2o_seq32 = f.encap_seq;
    cn->stats.rx_packets++;
    cn->stats.last_rx_us = t;
    cn->rx_deadline_us = t + cn->stats.timeout_us64;
    /* The 16-bit CIP sequence count says whether the data is new: a
     * producer may keep it while its data is unchanged, and only the
     * encapsulation sequence number moves (seen on a real adapter). A
     * count that went back with a newer packet is a producer that started
     * counting again: new data, no gap. */
    if (cn->have_t2o_seq && f.cip_seq == cn->t2o_seq16) {
        cn->stats.rx_repeats++;
        follow_t2o(cn, t); /* it still marks the producer's period */
        return;
    }
    if (cn->have_t2o_seq && dr_seq16_newer(f.cip_seq, cn->t2o_seq16))
        cn->stats.rx_lost += (uint16_t)(f.cip_seq - cn->t2o_seq16 - 1u);
    cn->have_t2o_seq = true;
    cn->t2o_seq16 = f.cip_seq;
    memcpy(cn->in, f.data, f.data_len);
    cn->have_in = true;
    if (cn->cfg.on_data != NULL)
        cn->cfg.on_data(cn, cn->in, f.data_len, cn->cfg.user);
    if (cn->used) /* the callback may have removed it */
        follow_t2o(cn, t);
}
