/* SPDX-License-Identifier: MIT */
/*
 * The client's session: the TCP connection and RegisterSession, explicit
 * requests (matched to replies by the 8-byte sender context) and what
 * comes back on the stream, the session's timers and the orderly close.
 */
#include <stdint.h>
#include <string.h>

#include "client_internal.h"

/* ---- TCP output ---------------------------------------------------------- */

void drc_flush_tx(dr_client_t *c)
{
    while (c->tx_len > 0 && c->tcp >= 0) {
        size_t sent = 0;
        dr_status_t st = c->tp.ops->tcp_send(c->tp.ctx, c->tcp, c->tx, c->tx_len, &sent);
        if (st == DR_EAGAIN)
            return;
        if (st != DR_OK) {
            drc_session_fail(c, st);
            return;
        }
        memmove(c->tx, c->tx + sent, c->tx_len - sent);
        c->tx_len -= sent;
    }
}

/* Queue one encapsulated message: header + body built by the caller in
 * body[0..body_len). */
dr_status_t drc_send_encap(dr_client_t *c, uint16_t cmd, uint64_t context,
                              const uint8_t *body, size_t body_len)
{
    if (c->tcp < 0)
        return DR_ESESSION;
    if (TX_BUF - c->tx_len < DR_ENCAP_HEADER_LEN + body_len)
        return DR_EFULL;
    dr_encap_t h;
    memset(&h, 0, sizeof h);
    h.command = cmd;
    h.session = c->session;
    for (unsigned i = 0; i < 8; i++)
        h.context[i] = (uint8_t)(context >> (8 * i));
    uint8_t *frame = c->tx + c->tx_len;
    dr_status_t st = dr_encap_write(frame, TX_BUF - c->tx_len, &h, body_len);
    if (st != DR_OK)
        return st;
    if (body_len > 0)
        memcpy(frame + DR_ENCAP_HEADER_LEN, body, body_len);
    c->tx_len += DR_ENCAP_HEADER_LEN + body_len;
    drc_flush_tx(c);
    return DR_OK;
}

/* ---- requests ------------------------------------------------------------ */

req_t *drc_req_alloc(dr_client_t *c, req_kind_t kind)
{
    for (unsigned i = 0; i < MAX_REQS; i++) {
        req_t *r = &c->reqs[i];
        if (!r->active) {
            memset(r, 0, sizeof *r);
            r->active = true;
            r->kind = kind;
            r->context = ++c->next_context;
            r->deadline = now_us(c) + (uint64_t)c->cfg.timeout_ms * 1000u;
            deadline_moved(c);
            return r;
        }
    }
    return NULL;
}

static req_t *req_find(dr_client_t *c, uint64_t context)
{
    for (unsigned i = 0; i < MAX_REQS; i++)
        if (c->reqs[i].active && !c->reqs[i].done && c->reqs[i].context == context)
            return &c->reqs[i];
    return NULL;
}

/* A request got its answer (or failed): user requests keep the result
 * until the waiting call collects it; connection requests act at once. */
static void req_finish(dr_client_t *c, req_t *r, dr_status_t st,
                       const dr_cip_rsp_t *rsp, const dr_cpf_t *cpf)
{
    r->status = st;
    r->done = true;
    if (r->kind == R_USER || r->kind == R_LIST_IDENTITY) {
        if (rsp != NULL && r->rsp != NULL) {
            if (rsp->data_len > r->cap) {
                r->status = st == DR_OK ? DR_ENOSPACE : st;
            } else {
                memcpy(r->rsp, rsp->data, rsp->data_len);
                r->rsp_len = rsp->data_len;
            }
        }
        return; /* collected by wait_req */
    }
    r->active = false;
    if (r->kind == R_ASYNC) {
        if (r->cb != NULL)
            r->cb(c, st, rsp ? rsp->data : NULL, rsp ? rsp->data_len : 0, r->cb_user);
        return;
    }
    if (r->conn != NULL)
        drc_conn_on_reply(r->conn, r, rsp, cpf);
    else if (r->kind == R_FWD_OPEN && rsp != NULL && st == DR_OK)
        drc_close_orphan(c, r, rsp); /* its connection was removed meanwhile */
}

static void complete_all(dr_client_t *c, dr_status_t st)
{
    for (unsigned i = 0; i < MAX_REQS; i++)
        if (c->reqs[i].active && !c->reqs[i].done) {
            c->reqs[i].status = st;
            req_finish(c, &c->reqs[i], st, NULL, NULL);
        }
}

/* SendRRData with a UCMM message (optionally wrapped in Unconnected Send)
 * and, for a Forward Open, our T->O socket address when not 2222. */
dr_status_t drc_send_rr(dr_client_t *c, req_t *r, const uint8_t *msg,
                           size_t msg_len, bool with_sockaddr)
{
    uint8_t body[DR_ENCAP_MAX_LEN];
    uint8_t wrapped[DR_ENCAP_MAX_LEN];
    dr_wr_t w;

    r->service = msg_len > 0 ? msg[0] : 0;
    if (c->cfg.route) {
        /* Unconnected Send to the Connection Manager, route: port 1, slot 0 */
        static const uint8_t cm_path[] = {0x20, 0x06, 0x24, 0x01};
        static const uint8_t route[] = {0x01, 0x00};
        uint8_t data[DR_ENCAP_MAX_LEN];
        dr_wr_t d;
        dr_wr_init(&d, data, sizeof data);
        dr_ucmm_send_write(&d, msg, msg_len, route, sizeof route);
        dr_wr_init(&w, wrapped, sizeof wrapped);
        dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, cm_path, sizeof cm_path,
                         data, d.len);
        if (d.overflow || w.overflow)
            return DR_ENOSPACE;
        msg = wrapped;
        msg_len = w.len;
    }
    dr_wr_init(&w, body, sizeof body);
    dr_wr_u32(&w, 0); /* interface handle: CIP */
    dr_wr_u16(&w, 0); /* timeout: the UCMM's own */
    dr_cpf_begin(&w, with_sockaddr ? 3 : 2);
    size_t m = dr_cpf_item_begin(&w, DR_CPF_NULL);
    dr_cpf_item_end(&w, m);
    m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_wr_bytes(&w, msg, msg_len);
    dr_cpf_item_end(&w, m);
    if (with_sockaddr) {
        dr_sockaddr_t sa = c->udp->local;
        dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, sa);
    }
    if (w.overflow)
        return DR_ENOSPACE;
    return drc_send_encap(c, DR_ENCAP_SEND_RR_DATA, r->context, body, w.len);
}

/* ---- session --------------------------------------------------------------- */

/* Tell the application about the session (dr_session_cb), except while
 * it closes the client itself. */
static void session_tell(dr_client_t *c, dr_status_t why)
{
    if (c->cfg.on_session != NULL && c->closing == CL_NONE)
        c->cfg.on_session(c, why, c->cfg.session_user);
}

void drc_session_fail(dr_client_t *c, dr_status_t st)
{
    drc_close_handle(c, &c->tcp);
    c->tx_len = 0;
    c->rx_len = 0;
    c->sess_error = st;
    sess_t was = c->state;
    c->state = S_IDLE;
    complete_all(c, st);
    /* Class 1 connections live on without the session (CIP Vol. 2:
     * closing TCP does not close Class 1 connections); only those still
     * opening need a new try. */
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++)
        if (c->conns[i].used && c->conns[i].state == DR_CONN_OPENING)
            drc_conn_schedule_retry(&c->conns[i], st);
    if (c->started) {
        c->state = S_BACKOFF;
        c->retry_at = now_us(c) + (uint64_t)c->backoff_ms * 1000u;
        c->backoff_ms = min_u32(c->backoff_ms * 2u, c->cfg.backoff_max_ms);
    }
    (void)was;
    deadline_moved(c);
    session_tell(c, st);
}

/* A Forward Open went unanswered: the path to the adapter may be down,
 * with more requests queued in TCP behind it (the retries of this and of
 * the other connections, Forward Closes). Kept, they would all reach the
 * adapter when the path returns, which would open a connection for each
 * Forward Open nobody waits for any more and hold it as an owner until
 * its grace for a first O->T packet ends (10 s and more), refusing the
 * fresh Forward Opens with 0x0106 meanwhile. So the session is aborted:
 * what TCP still holds is dropped (transport tcp_abort; a plain close
 * would go on sending it), and a new session starts after the backoff.
 * Requests the adapter did get are dealt with by conn->stale. */
static void session_reset(dr_client_t *c, dr_status_t st)
{
    if (c->tcp >= 0 && c->tp.ops->tcp_abort != NULL) {
        c->tp.ops->tcp_abort(c->tp.ctx, c->tcp);
        c->tcp = -1;
    }
    drc_session_fail(c, st);
}

dr_status_t drc_begin_session(dr_client_t *c)
{
    uint32_t addr;
    drc_close_handle(c, &c->tcp);
    c->tx_len = c->rx_len = 0;
    c->session = 0;
    c->step = "resolve";
    dr_status_t st = c->tp.ops->resolve(c->tp.ctx, c->host, &addr);
    if (st == DR_OK) {
        c->peer.addr = addr;
        c->peer.port = c->cfg.tcp_port;
        c->step = "connect";
        /* From the local address, if there is one: the adapter sends
         * T->O to the address TCP comes from (see local_addr). */
        dr_sockaddr_t from = {c->local_udp_addr, 0};
        st = c->local_udp_addr != 0
                 ? c->tp.ops->tcp_connect_from(c->tp.ctx, from, c->peer, &c->tcp)
                 : c->tp.ops->tcp_connect(c->tp.ctx, c->peer, &c->tcp);
    }
    if (st != DR_OK) {
        drc_session_fail(c, st);
        return st;
    }
    c->state = S_CONNECTING;
    c->sess_deadline = now_us(c) + (uint64_t)c->cfg.timeout_ms * 1000u;
    deadline_moved(c);
    return DR_OK;
}

static void send_register(dr_client_t *c)
{
    uint8_t body[4];
    dr_put_le16(body, 1); /* protocol version */
    dr_put_le16(body + 2, 0); /* options */
    c->step = "register session";
    c->state = S_REGISTERING;
    c->sess_deadline = now_us(c) + (uint64_t)c->cfg.timeout_ms * 1000u;
    dr_status_t st = drc_send_encap(c, DR_ENCAP_REGISTER_SESSION, 0, body, sizeof body);
    if (st != DR_OK)
        drc_session_fail(c, st);
}

void dr_client_start(dr_client_t *c)
{
    if (c->closing != CL_NONE)
        drc_close_finish(c); /* started again before the close ended */
    c->started = true;
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++)
        if (c->conns[i].used && c->conns[i].state == DR_CONN_CLOSED) {
            c->conns[i].state = DR_CONN_IDLE;
            c->conns[i].retry_us = 0;
        }
    if (c->state == S_IDLE || c->state == S_BACKOFF)
        (void)drc_begin_session(c); /* a failure is retried with backoff */
    deadline_moved(c);
}

/* ---- inbound ---------------------------------------------------------------- */

static uint64_t context_of(const dr_encap_t *h)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < 8; i++)
        v |= (uint64_t)h->context[i] << (8 * i);
    return v;
}

/* Whether a reply answers the service r asked for: its service is the
 * request's with the reply bit (CIP Vol 1, 2-4.2), or, for a routed
 * request, an Unconnected Send's own reply that says why it could not be
 * routed. Anything else (another request's reply, a reply to nothing) is
 * not believed: DR_EMISMATCH, never data. */
static bool reply_service_ok(const dr_client_t *c, const req_t *r, const dr_cip_rsp_t *rsp)
{
    if (rsp->service == (uint8_t)(r->service | DR_CIP_REPLY))
        return true;
    return c->cfg.route && rsp->general != 0 &&
           rsp->service == (uint8_t)(DR_CIP_SVC_UNCONNECTED_SEND | DR_CIP_REPLY);
}

/* A SendRRData reply: CPF with the UCMM reply in an 0x00B2 item. */
static void on_rr_reply(dr_client_t *c, req_t *r, const uint8_t *body, size_t len)
{
    dr_cpf_t cpf;
    dr_cip_rsp_t rsp;
    const dr_cpf_item_t *it;
    dr_status_t st = DR_EMALFORMED;
    size_t extra = 0;
    /* Lenient about what follows the declared items (an adapter seen in
     * the field appends an echo of our 0x8001 item to a refusal): dropping
     * the reply would lose its CIP status. */
    if (len >= 6 && dr_cpf_parse_reply(body + 6, len - 6, &cpf, &extra) == DR_OK &&
        (it = dr_cpf_find(&cpf, DR_CPF_UNCONNECTED_DATA)) != NULL &&
        dr_cip_rsp_parse(it->data, it->length, &rsp) == DR_OK) {
        if (!reply_service_ok(c, r, &rsp)) {
            req_finish(c, r, DR_EMISMATCH, NULL, NULL);
            return;
        }
        if (extra > 0)
            c->stats.replies_trailing++;
        req_finish(c, r, dr_cip_rsp_status(&rsp), &rsp, &cpf);
        return;
    }
    req_finish(c, r, st, NULL, NULL);
}

static void on_frame(dr_client_t *c, const uint8_t *frame, size_t len)
{
    dr_encap_t h;
    const uint8_t *body;
    if (dr_encap_parse(frame, len, &h, &body) != DR_OK) {
        drc_session_fail(c, DR_EMALFORMED);
        return;
    }
    if (h.command == DR_ENCAP_REGISTER_SESSION) {
        if (c->state != S_REGISTERING)
            return;
        if (h.status != 0 || h.session == 0) {
            drc_session_fail(c, h.status != 0 ? DR_ENCAP(h.status) : DR_EMALFORMED);
            return;
        }
        c->session = h.session;
        c->state = S_READY;
        c->backoff_ms = c->cfg.backoff_min_ms;
        c->sess_error = DR_OK;
        session_tell(c, DR_OK);
        return;
    }
    req_t *r = req_find(c, context_of(&h));
    if (r == NULL)
        return; /* a late reply to a request that timed out */
    if (h.status != 0) {
        req_finish(c, r, DR_ENCAP(h.status), NULL, NULL);
        if (h.status == 0x64) /* invalid session: register again */
            drc_session_fail(c, DR_ENCAP(h.status));
        return;
    }
    if (h.command == DR_ENCAP_LIST_IDENTITY && r->kind == R_LIST_IDENTITY) {
        dr_cip_rsp_t raw = {0, 0, 0, {0, 0}, body, h.length};
        req_finish(c, r, DR_OK, &raw, NULL);
    } else if (h.command == DR_ENCAP_SEND_RR_DATA) {
        on_rr_reply(c, r, body, h.length);
    } else {
        req_finish(c, r, DR_EMISMATCH, NULL, NULL);
    }
}

/* The caller's poll is level-triggered: a receive that did not fill the
 * buffer has taken what there was, and anything later wakes us again, so
 * there is no second receive only to hear "nothing more". */
void drc_read_tcp(dr_client_t *c)
{
    for (bool more = true; more && c->tcp >= 0;) {
        size_t got = 0, space = sizeof c->rx - c->rx_len;
        dr_status_t st = c->tp.ops->tcp_recv(c->tp.ctx, c->tcp, c->rx + c->rx_len,
                                             space, &got);
        more = got == space;
        if (st == DR_EAGAIN)
            return;
        if (st != DR_OK) {
            drc_session_fail(c, st);
            return;
        }
        c->rx_len += got;
        size_t total;
        while (c->tcp >= 0 && (st = dr_encap_frame_len(c->rx, c->rx_len, &total)) == DR_OK &&
               total <= c->rx_len) {
            on_frame(c, c->rx, total);
            if (c->tcp < 0)
                return;
            memmove(c->rx, c->rx + total, c->rx_len - total);
            c->rx_len -= total;
        }
        if (st == DR_ELONG) {
            drc_session_fail(c, DR_ELONG); /* the stream cannot be trusted */
            return;
        }
    }
}

void drc_session_timers(dr_client_t *c, uint64_t t)
{
    if (c->state == S_CONNECTING) {
        dr_status_t st = c->tp.ops->tcp_finish(c->tp.ctx, c->tcp);
        if (st == DR_OK && (c->tp.ops->tcp_local == NULL ||
                            c->tp.ops->tcp_local(c->tp.ctx, c->tcp, &c->tcp_local) != DR_OK))
            c->tcp_local.addr = c->local_udp_addr;
        if (st == DR_OK)
            send_register(c);
        else if (st != DR_EAGAIN)
            drc_session_fail(c, st);
        else if (t >= c->sess_deadline)
            drc_session_fail(c, DR_ENOANSWER); /* TCP's timeout, not a request's */
    } else if (c->state == S_REGISTERING && t >= c->sess_deadline) {
        drc_session_fail(c, DR_ENOREGISTER);
    } else if (c->state == S_BACKOFF && c->started && t >= c->retry_at) {
        (void)drc_begin_session(c);
    }
    bool fo_lost = false;
    for (unsigned i = 0; i < MAX_REQS; i++) {
        req_t *r = &c->reqs[i];
        if (r->active && !r->done && t >= r->deadline) {
            fo_lost |= r->kind == R_FWD_OPEN;
            req_finish(c, r, DR_ETIMEDOUT, NULL, NULL);
        }
    }
    if (fo_lost && c->tcp >= 0)
        session_reset(c, DR_ETIMEDOUT);
}

/* Build a Message Router request and send it as a request of `kind`.
 * A session that fails while it is being sent completes an async request
 * on the spot (with no callback yet); that is reported as the failure. */
dr_status_t drc_start_call(dr_client_t *c, req_kind_t kind, uint8_t service,
                              const uint8_t *path, size_t path_len,
                              const uint8_t *data, size_t data_len, req_t **out)
{
    if (c->state != S_READY || c->closing != CL_NONE)
        return DR_ESESSION;
    if (kind == R_USER && !drc_can_wait(c))
        return DR_EINVAL;
    uint8_t msg[DR_ENCAP_MAX_LEN];
    dr_wr_t w;
    dr_wr_init(&w, msg, sizeof msg);
    dr_cip_req_write(&w, service, path, path_len, data, data_len);
    if (w.overflow)
        return DR_ENOSPACE;
    req_t *r = drc_req_alloc(c, kind);
    if (r == NULL)
        return DR_EFULL;
    dr_status_t st = drc_send_rr(c, r, msg, w.len, false);
    if (st == DR_OK && !r->active)
        st = c->sess_error != DR_OK ? c->sess_error : DR_ECLOSED;
    deadline_moved(c);
    if (st != DR_OK) {
        r->active = false;
        return st;
    }
    *out = r;
    return DR_OK;
}

dr_status_t dr_client_call_async(dr_client_t *c, uint8_t service,
                                 const uint8_t *path, size_t path_len,
                                 const uint8_t *data, size_t data_len,
                                 dr_call_cb done, void *user)
{
    req_t *r;
    dr_status_t st = drc_start_call(c, R_ASYNC, service, path, path_len, data, data_len, &r);
    if (st != DR_OK)
        return st;
    /* The callback only now: the caller must first see the request taken. */
    r->cb = done;
    r->cb_user = user;
    return DR_OK;
}

/* ---- close -------------------------------------------------------------------- */

/* Forward Closes, and Forward Opens whose success would have to be
 * closed (close_orphan), still awaiting their replies. */
static bool fwd_close_pending(const dr_client_t *c)
{
    for (unsigned i = 0; i < MAX_REQS; i++)
        if (c->reqs[i].active && !c->reqs[i].done &&
            (c->reqs[i].kind == R_FWD_CLOSE || c->reqs[i].kind == R_FWD_OPEN))
            return true;
    return false;
}

/* The end of a close: whatever is still open goes, at once. */
void drc_close_finish(dr_client_t *c)
{
    complete_all(c, DR_ECLOSED);
    for (unsigned i = 0; i < MAX_REQS; i++)
        c->reqs[i].active = false;
    drc_close_handle(c, &c->tcp);
    if (!c->udp->shared)
        drc_close_handle(c, &c->udp->h);
    c->state = S_IDLE;
    c->closing = CL_NONE;
    c->tx_len = c->rx_len = 0;
    deadline_moved(c);
}

/* One step of a close, from the loop: every phase ends when its work is
 * done or at its deadline, so a silent peer cannot hold the close. */
void drc_close_step(dr_client_t *c, uint64_t t)
{
    if (c->closing == CL_FWD) {
        if (c->tcp >= 0 && fwd_close_pending(c) && t < c->close_deadline)
            return;
        if (c->state != S_READY) {
            drc_close_finish(c);
            return;
        }
        /* UnRegisterSession, then let the peer close the connection. */
        (void)drc_send_encap(c, DR_ENCAP_UNREGISTER_SESSION, 0, NULL, 0);
        uint64_t wait = (uint64_t)c->cfg.timeout_ms * 1000u;
        c->close_deadline = t + (wait < CLOSE_WAIT_US ? wait : CLOSE_WAIT_US);
        c->closing = CL_UNREG;
    }
    if (c->closing == CL_UNREG) {
        if (c->tcp >= 0 && c->tx_len > 0 && t < c->close_deadline)
            return;
        c->state = S_IDLE; /* a close by the peer is now expected */
        c->closing = CL_DRAIN;
    }
    /* CL_DRAIN: the peer's close (read_tcp sees it) or the deadline. */
    if (c->tcp < 0 || t >= c->close_deadline)
        drc_close_finish(c);
}

void dr_client_close_start(dr_client_t *c)
{
    if (c->closing != CL_NONE)
        return;
    c->started = false;
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++) {
        dr_conn_t *cn = &c->conns[i];
        if (!cn->used)
            continue;
        if (cn->state == DR_CONN_ESTABLISHED)
            drc_send_forward_close(cn);
        drc_conn_set_state(cn, DR_CONN_CLOSED, DR_OK); /* dr_client_start reopens */
    }
    c->closing = CL_FWD;
    c->close_deadline = now_us(c) + (uint64_t)c->cfg.timeout_ms * 1000u;
    drc_close_step(c, now_us(c));
    deadline_moved(c);
}

bool dr_client_closed(const dr_client_t *c)
{
    return c->closing == CL_NONE && c->tcp < 0 && !c->started;
}
