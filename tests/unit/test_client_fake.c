/* SPDX-License-Identifier: MIT */
/*
 * The client's failure paths, on a scripted transport: a fake network and
 * a virtual clock (dr_transport_t is the client's only way to the OS), and
 * a peer that answers each request the way a test tells it to. What a real
 * adapter rarely does on demand is done here exactly: a reply of the
 * wrong size, an encapsulation error, a late or mismatched reply, a send
 * that fails half way, a handle that cannot be opened, a pool that is full.
 * The happy paths against a real peer are in test_client_sim.c.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "cip_internal.h"
#include "drgate/client.h"

#define TCP_H 10
#define UDP_H 20
#define TIMER_H 30
#define FD_OF(h) ((h) + 100)
#define PEER_ADDR 0x7F000002u
#define MAX_UDP_IN 16

typedef struct fake fake_t;

/* Answers one CIP request: fills rsp (a whole Message Router reply) and
 * returns true, or returns false for no answer at all. */
typedef bool (*cip_fn)(fake_t *f, const dr_cip_req_t *req, uint8_t *rsp, size_t *rsp_len);

struct fake {
    uint64_t now;
    dr_status_t resolve_st, connect_st, finish_st, timer_st, udp_open_st, udp_send_st;
    dr_sockaddr_t tcp_from;   /* tcp_connect_from's local address ({0, 0}: tcp_connect) */
    unsigned connects_from;   /* tcp_connect_from calls */
    dr_status_t send_st;      /* tcp_send's result (DR_OK: take the bytes) */
    unsigned send_fail_after; /* >0: SendRRData number N makes tcp_send fail */
    size_t send_max;          /* >0: at most this many bytes per tcp_send */
    dr_status_t eof_st;       /* tcp_recv with nothing queued: DR_EAGAIN or DR_ECLOSED */
    uint8_t out[4096];        /* bytes from the client, not yet a whole frame */
    size_t out_len;
    uint8_t in[8192];         /* bytes for the client to read */
    size_t in_len;
    /* the peer */
    uint32_t session, reg_status;
    bool reg_silent;
    uint32_t next_status;     /* one-shot encapsulation status of the next reply */
    uint16_t next_cmd;        /* one-shot command of the next reply (0: the request's) */
    bool next_unknown_ctx;    /* one-shot: the next reply carries a context nobody sent */
    bool next_no_b2;          /* one-shot: the next SendRRData reply has no 0xB2 item */
    uint8_t next_rsp_service; /* one-shot: the next CIP reply's service byte (0: the right one) */
    cip_fn cip;
    size_t get_len;           /* Get_Attribute_Single data bytes */
    bool trailing_item;       /* SendRRData replies carry an undeclared 0x8001 item */
    bool fo_own_t2o;          /* the Forward Open reply sets a T->O ID of the peer's */
    uint8_t fo_general;       /* Forward Open refused with this general status */
    uint16_t fo_ext;
    unsigned rr, fwd_open, fwd_close, unregister, list_identity, closes, aborts;
    /* Connection Manager requests in the order the peer got them: the
     * service and the connection serial (cleared by the test) */
    struct {
        uint8_t service;
        uint16_t serial;
        uint32_t orig;
    } cm[32];
    unsigned ncm;
    /* replies held back (hold_replies), released by release_replies: a
     * reply that comes late */
    bool hold_replies;
    uint8_t held[2048];
    size_t held_len;
    uint32_t t2o_cid, o2t_cid;
    /* UDP */
    struct {
        uint8_t buf[600];
        size_t len;
        uint32_t from; /* source address; 0: the peer's */
    } udp_in[MAX_UDP_IN];
    uint32_t push_from; /* the source of the datagrams pushed next; 0: the peer */
    unsigned udp_in_n;
    uint8_t udp_last[600];
    size_t udp_last_len;
    dr_sockaddr_t udp_last_to;
    unsigned udp_sent, udp_batches;
    uint64_t armed;
};

/* ---- the scripted peer ------------------------------------------------------- */

static void queue_encap(fake_t *f, uint16_t cmd, uint32_t session, uint32_t status,
                        const uint8_t *ctx, const uint8_t *body, size_t len)
{
    uint8_t *buf = f->hold_replies ? f->held : f->in;
    size_t *blen = f->hold_replies ? &f->held_len : &f->in_len;
    size_t cap = f->hold_replies ? sizeof f->held : sizeof f->in;
    uint8_t *p = buf + *blen;
    assert_true(*blen + 24 + len <= cap);
    memset(p, 0, 24);
    dr_put_le16(p, cmd);
    dr_put_le16(p + 2, (uint16_t)len);
    dr_put_le32(p + 4, session);
    dr_put_le32(p + 8, status);
    memcpy(p + 12, ctx, 8);
    if (len > 0)
        memcpy(p + 24, body, len);
    *blen += 24 + len;
}

/* The replies held back so far arrive now. */
static void release_replies(fake_t *f)
{
    assert_true(f->in_len + f->held_len <= sizeof f->in);
    memcpy(f->in + f->in_len, f->held, f->held_len);
    f->in_len += f->held_len;
    f->held_len = 0;
    f->hold_replies = false;
}

/* Note a Connection Manager request (Forward Open or Close) in f->cm. */
static void note_cm(fake_t *f, const dr_cip_req_t *req)
{
    uint16_t serial = 0;
    uint32_t orig = 0;
    dr_fwd_open_t fo;
    dr_fwd_close_t fc;
    if (req->service == DR_CIP_SVC_FORWARD_CLOSE &&
        dr_fwd_close_parse(req->data, req->data_len, &fc) == DR_OK) {
        serial = fc.conn_serial;
        orig = fc.orig_serial;
    } else if ((req->service == DR_CIP_SVC_FORWARD_OPEN ||
                req->service == DR_CIP_SVC_LARGE_FORWARD_OPEN) &&
               dr_fwd_open_parse(req->data, req->data_len,
                                 req->service == DR_CIP_SVC_LARGE_FORWARD_OPEN, &fo) == DR_OK) {
        serial = fo.conn_serial;
        orig = fo.orig_serial;
    } else {
        return;
    }
    if (f->ncm < sizeof f->cm / sizeof f->cm[0]) {
        f->cm[f->ncm].service = req->service;
        f->cm[f->ncm].serial = serial;
        f->cm[f->ncm++].orig = orig;
    }
}

static bool cip_default(fake_t *f, const dr_cip_req_t *req, uint8_t *rsp, size_t *rsp_len)
{
    dr_wr_t w;
    uint8_t data[512];
    dr_wr_init(&w, rsp, 560);
    switch (req->service) {
    case DR_CIP_SVC_GET_ATTRIBUTE_SINGLE:
        memset(data, 0xA5, sizeof data);
        dr_cip_rsp_write(&w, req->service | DR_CIP_REPLY, 0, NULL, 0, data, f->get_len);
        break;
    case DR_CIP_SVC_SET_ATTRIBUTE_SINGLE:
        dr_cip_rsp_write(&w, req->service | DR_CIP_REPLY, 0, NULL, 0, NULL, 0);
        break;
    case DR_CIP_SVC_FORWARD_OPEN:
    case DR_CIP_SVC_LARGE_FORWARD_OPEN: {
        dr_fwd_open_t fo;
        assert_int_equal(dr_fwd_open_parse(req->data, req->data_len,
                                           req->service == DR_CIP_SVC_LARGE_FORWARD_OPEN, &fo),
                         DR_OK);
        f->fwd_open++;
        if (f->fo_general != 0) {
            dr_wr_t d;
            dr_wr_init(&d, data, sizeof data);
            dr_fwd_fail_write(&d, fo.conn_serial, fo.vendor, fo.orig_serial);
            dr_cip_rsp_write(&w, req->service | DR_CIP_REPLY, f->fo_general, &f->fo_ext, 1,
                             data, d.len);
            break;
        }
        if (f->fo_own_t2o) /* allowed for multicast: the target's choice */
            fo.t2o_cid = 0x7000u + f->fwd_open;
        f->t2o_cid = fo.t2o_cid;
        f->o2t_cid = 0x5000u + f->fwd_open;
        dr_fwd_open_reply_t rp = {f->o2t_cid, fo.t2o_cid, fo.conn_serial, fo.vendor,
                                  fo.orig_serial, fo.o2t_rpi_us, fo.t2o_rpi_us};
        dr_wr_t d;
        dr_wr_init(&d, data, sizeof data);
        dr_fwd_open_reply_write(&d, &rp);
        dr_cip_rsp_write(&w, req->service | DR_CIP_REPLY, 0, NULL, 0, data, d.len);
        break;
    }
    case DR_CIP_SVC_FORWARD_CLOSE:
        f->fwd_close++;
        dr_cip_rsp_write(&w, req->service | DR_CIP_REPLY, 0, NULL, 0, NULL, 0);
        break;
    default:
        dr_cip_rsp_write(&w, req->service | DR_CIP_REPLY, 0x08, NULL, 0, NULL, 0);
        break;
    }
    *rsp_len = w.len;
    return true;
}

/* A silent peer: no CIP request is ever answered. */
static bool cip_silent(fake_t *f, const dr_cip_req_t *req, uint8_t *rsp, size_t *rsp_len)
{
    (void)f, (void)req, (void)rsp, (void)rsp_len;
    return false;
}

static void peer_frame(fake_t *f, const uint8_t *frame, size_t len)
{
    dr_encap_t h;
    const uint8_t *body;
    assert_int_equal(dr_encap_parse(frame, len, &h, &body), DR_OK);
    uint8_t ctx[8];
    memcpy(ctx, h.context, 8);
    if (f->next_unknown_ctx) {
        f->next_unknown_ctx = false;
        memset(ctx, 0xEE, 8);
    }
    uint32_t status = f->next_status;
    f->next_status = 0;
    uint16_t cmd = f->next_cmd != 0 ? f->next_cmd : h.command;
    f->next_cmd = 0;
    switch (h.command) {
    case DR_ENCAP_REGISTER_SESSION: {
        if (f->reg_silent)
            return;
        static const uint8_t reg[4] = {1, 0, 0, 0};
        queue_encap(f, cmd, f->reg_status != 0 ? 0 : f->session, f->reg_status, ctx, reg, 4);
        return;
    }
    case DR_ENCAP_UNREGISTER_SESSION:
        f->unregister++;
        f->eof_st = DR_ECLOSED; /* and the peer closes */
        return;
    case DR_ENCAP_LIST_IDENTITY: {
        f->list_identity++;
        dr_identity_t id;
        memset(&id, 0, sizeof id);
        id.vendor = 0x0A0B;
        id.serial = 0x01020304;
        strcpy(id.product_name, "fake adapter");
        uint8_t b[128];
        dr_wr_t w;
        dr_wr_init(&w, b, sizeof b);
        dr_list_identity_write(&w, &id);
        queue_encap(f, cmd, f->session, status, ctx, b, w.len);
        return;
    }
    case DR_ENCAP_SEND_RR_DATA:
        break;
    default:
        fail_msg("unexpected encapsulation command 0x%04X", h.command);
    }
    f->rr++;
    uint32_t iface;
    uint16_t tmo;
    dr_cpf_t cpf;
    assert_int_equal(dr_rr_parse(body, h.length, &iface, &tmo, &cpf), DR_OK);
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_UNCONNECTED_DATA);
    assert_non_null(it);
    dr_cip_req_t req;
    assert_int_equal(dr_cip_req_parse(it->data, it->length, &req), DR_OK);
    note_cm(f, &req);
    uint8_t rsp[560];
    size_t rsp_len = 0;
    if (!(f->cip != NULL ? f->cip : cip_default)(f, &req, rsp, &rsp_len))
        return;
    if (f->next_rsp_service != 0 && rsp_len > 0) {
        rsp[0] = f->next_rsp_service;
        f->next_rsp_service = 0;
    }
    uint8_t b[600];
    dr_wr_t w;
    dr_wr_init(&w, b, sizeof b);
    dr_rr_begin(&w, 0);
    if (f->next_no_b2) {
        f->next_no_b2 = false;
        dr_cpf_begin(&w, 1);
        size_t m = dr_cpf_item_begin(&w, DR_CPF_NULL);
        dr_cpf_item_end(&w, m);
    } else {
        dr_cpf_begin(&w, 2);
        size_t m = dr_cpf_item_begin(&w, DR_CPF_NULL);
        dr_cpf_item_end(&w, m);
        m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
        dr_wr_bytes(&w, rsp, rsp_len);
        dr_cpf_item_end(&w, m);
        if (f->trailing_item) /* like the adapter of issue 10: not counted */
            dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O,
                                  (dr_sockaddr_t){0xC0A8010Au, DR_ENIP_UDP_PORT});
    }
    assert_false(w.overflow);
    queue_encap(f, cmd, f->session, status, ctx, b, w.len);
}

/* ---- the transport ------------------------------------------------------------ */

static dr_status_t f_resolve(void *ctx, const char *host, uint32_t *addr)
{
    fake_t *f = ctx;
    (void)host;
    if (f->resolve_st != DR_OK)
        return f->resolve_st;
    *addr = PEER_ADDR;
    return DR_OK;
}

static dr_status_t f_tcp_connect(void *ctx, dr_sockaddr_t to, int *h)
{
    fake_t *f = ctx;
    assert_int_equal(to.addr, PEER_ADDR);
    if (f->connect_st != DR_OK)
        return f->connect_st;
    f->out_len = f->in_len = 0;
    f->eof_st = DR_EAGAIN;
    *h = TCP_H;
    return DR_OK;
}

static dr_status_t f_tcp_connect_from(void *ctx, dr_sockaddr_t from, dr_sockaddr_t to, int *h)
{
    fake_t *f = ctx;
    f->tcp_from = from;
    f->connects_from++;
    return f_tcp_connect(ctx, to, h);
}

/* The TCP session leaves from where it was bound, else from 10.0.0.7. */
static dr_status_t f_tcp_local(void *ctx, int h, dr_sockaddr_t *local)
{
    fake_t *f = ctx;
    assert_int_equal(h, TCP_H);
    local->addr = f->tcp_from.addr != 0 ? f->tcp_from.addr : 0x0A000007u;
    local->port = 40000;
    return DR_OK;
}

static dr_status_t f_tcp_finish(void *ctx, int h)
{
    fake_t *f = ctx;
    assert_int_equal(h, TCP_H);
    return f->finish_st;
}

static dr_status_t f_tcp_send(void *ctx, int h, const uint8_t *buf, size_t len, size_t *sent)
{
    fake_t *f = ctx;
    assert_int_equal(h, TCP_H);
    if (f->send_st != DR_OK)
        return f->send_st;
    size_t n = f->send_max != 0 && len > f->send_max ? f->send_max : len;
    /* A whole SendRRData frame at the front: fail on the Nth one. */
    if (f->send_fail_after != 0 && f->out_len == 0 && len >= 24 &&
        dr_get_le16(buf) == DR_ENCAP_SEND_RR_DATA && f->rr + 1 == f->send_fail_after) {
        f->send_fail_after = 0;
        return DR_ECLOSED;
    }
    assert_true(f->out_len + n <= sizeof f->out);
    memcpy(f->out + f->out_len, buf, n);
    f->out_len += n;
    size_t total;
    while (dr_encap_frame_len(f->out, f->out_len, &total) == DR_OK && total <= f->out_len) {
        peer_frame(f, f->out, total);
        memmove(f->out, f->out + total, f->out_len - total);
        f->out_len -= total;
    }
    *sent = n;
    return DR_OK;
}

static dr_status_t f_tcp_recv(void *ctx, int h, uint8_t *buf, size_t cap, size_t *got)
{
    fake_t *f = ctx;
    assert_int_equal(h, TCP_H);
    if (f->in_len == 0)
        return f->eof_st;
    size_t n = f->in_len < cap ? f->in_len : cap;
    memcpy(buf, f->in, n);
    memmove(f->in, f->in + n, f->in_len - n);
    f->in_len -= n;
    *got = n;
    return DR_OK;
}

static dr_status_t f_udp_open(void *ctx, dr_sockaddr_t local, int *h)
{
    fake_t *f = ctx;
    (void)local;
    if (f->udp_open_st != DR_OK)
        return f->udp_open_st;
    *h = UDP_H;
    return DR_OK;
}

static dr_status_t f_udp_send(void *ctx, int h, const uint8_t *buf, size_t len, dr_sockaddr_t to)
{
    fake_t *f = ctx;
    assert_int_equal(h, UDP_H);
    if (f->udp_send_st != DR_OK)
        return f->udp_send_st;
    assert_true(len <= sizeof f->udp_last);
    memcpy(f->udp_last, buf, len);
    f->udp_last_len = len;
    f->udp_last_to = to;
    f->udp_sent++;
    return DR_OK;
}

static dr_status_t f_udp_recv(void *ctx, int h, uint8_t *buf, size_t cap, size_t *got,
                              dr_sockaddr_t *from)
{
    fake_t *f = ctx;
    assert_int_equal(h, UDP_H);
    if (f->udp_in_n == 0)
        return DR_EAGAIN;
    size_t n = f->udp_in[0].len;
    uint32_t src = f->udp_in[0].from != 0 ? f->udp_in[0].from : PEER_ADDR;
    assert_true(n <= cap);
    memcpy(buf, f->udp_in[0].buf, n);
    memmove(&f->udp_in[0], &f->udp_in[1], sizeof f->udp_in[0] * (f->udp_in_n - 1));
    f->udp_in_n--;
    *got = n;
    *from = (dr_sockaddr_t){src, DR_ENIP_UDP_PORT};
    return DR_OK;
}

static dr_status_t f_udp_send_batch(void *ctx, int h, const dr_udp_msg_t *m, unsigned n,
                                    unsigned *done)
{
    fake_t *f = ctx;
    f->udp_batches++;
    for (unsigned i = 0; i < n; i++) {
        dr_status_t st = f_udp_send(ctx, h, m[i].buf, m[i].len, m[i].addr);
        if (st != DR_OK)
            return st;
    }
    *done = n;
    return DR_OK;
}

static dr_status_t f_udp_recv_batch(void *ctx, int h, dr_udp_msg_t *m, unsigned n,
                                    unsigned *done)
{
    unsigned k = 0;
    while (k < n) {
        dr_status_t st = f_udp_recv(ctx, h, m[k].buf, m[k].cap, &m[k].len, &m[k].addr);
        if (st == DR_EAGAIN)
            break;
        k++;
    }
    *done = k;
    return k == 0 ? DR_EAGAIN : DR_OK;
}

static dr_status_t f_timer_open(void *ctx, int *h)
{
    fake_t *f = ctx;
    if (f->timer_st != DR_OK)
        return f->timer_st;
    *h = TIMER_H;
    return DR_OK;
}

static dr_status_t f_timer_arm(void *ctx, int h, uint64_t deadline_us)
{
    fake_t *f = ctx;
    assert_int_equal(h, TIMER_H);
    f->armed = deadline_us;
    return DR_OK;
}

static void f_close(void *ctx, int h)
{
    fake_t *f = ctx;
    f->closes++;
    if (h == TCP_H)
        f->in_len = f->out_len = f->held_len = 0;
}

static void f_tcp_abort(void *ctx, int h)
{
    fake_t *f = ctx;
    assert_int_equal(h, TCP_H);
    f->aborts++;
    f_close(ctx, h);
}

static uint64_t f_now(void *ctx)
{
    return ((fake_t *)ctx)->now;
}

static int f_fd(void *ctx, int h)
{
    (void)ctx;
    return FD_OF(h);
}

/* Nothing to read: the virtual clock moves on, at most 1 ms at a time. */
static dr_status_t f_wait(void *ctx, const int *h, const bool *want_out, int n,
                          uint64_t deadline_us)
{
    fake_t *f = ctx;
    (void)want_out;
    for (int i = 0; i < n; i++) {
        if (h[i] == TCP_H && (f->in_len > 0 || f->eof_st != DR_EAGAIN))
            return DR_OK;
        if (h[i] == UDP_H && f->udp_in_n > 0)
            return DR_OK;
    }
    uint64_t next = f->now + 1000u;
    f->now = deadline_us > f->now && deadline_us < next ? deadline_us : next;
    return DR_OK;
}

static const dr_transport_ops_t fake_ops = {
    f_resolve,  f_tcp_connect, f_tcp_finish, f_tcp_send,   f_tcp_recv,
    f_udp_open, f_udp_send,    f_udp_recv,   f_timer_open, f_timer_arm, f_close,
    f_now,      f_fd,          f_wait,       NULL,         NULL,       f_tcp_abort,
    NULL,       f_tcp_connect_from, f_tcp_local};

static const dr_transport_ops_t fake_batch_ops = {
    f_resolve,  f_tcp_connect, f_tcp_finish, f_tcp_send,   f_tcp_recv,
    f_udp_open, f_udp_send,    f_udp_recv,   f_timer_open, f_timer_arm, f_close,
    f_now,      f_fd,          f_wait,       f_udp_send_batch, f_udp_recv_batch, f_tcp_abort,
    NULL,       f_tcp_connect_from, f_tcp_local};

/* ---- fixtures ------------------------------------------------------------------ */

static fake_t F;

static dr_client_config_t config(const dr_transport_ops_t *ops)
{
    dr_client_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.host = "robot";
    cfg.timeout_ms = 100;
    cfg.backoff_min_ms = 10;
    cfg.backoff_max_ms = 40;
    cfg.transport.ops = ops;
    cfg.transport.ctx = &F;
    return cfg;
}

/* A shared UDP port on the fake transport, and *cfg a client configuration
 * that uses it (as drgatewayd's robots share one port). */
static dr_udp_port_t *shared_port(const dr_transport_ops_t *ops, dr_client_config_t *cfg)
{
    dr_transport_t tp = {ops, &F};
    dr_udp_port_t *p = dr_udp_port_new(NULL, 0, tp, NULL);
    assert_non_null(p);
    *cfg = config(ops);
    cfg->shared_udp = p;
    return p;
}

static int setup(void **state)
{
    (void)state;
    memset(&F, 0, sizeof F);
    F.now = 1000000u;
    F.session = 0x11223344u;
    F.eof_st = DR_EAGAIN;
    F.get_len = 36;
    return 0;
}

static dr_client_t *new_client(void)
{
    dr_client_config_t cfg = config(&fake_ops);
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    return c;
}

static dr_client_t *connected(void)
{
    dr_client_t *c = new_client();
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    assert_true(dr_client_ready(c));
    return c;
}

/* Run the client's loop for `ms` of virtual time. */
static void run_for(dr_client_t *c, unsigned ms)
{
    uint64_t end = F.now + (uint64_t)ms * 1000u;
    while (F.now < end)
        dr_client_run_once(c, 1);
}

/* ---- lifecycle ------------------------------------------------------------------- */

static void test_state_names(void **state)
{
    (void)state;
    assert_string_equal(dr_conn_state_name(DR_CONN_IDLE), "idle");
    assert_string_equal(dr_conn_state_name(DR_CONN_OPENING), "opening");
    assert_string_equal(dr_conn_state_name(DR_CONN_ESTABLISHED), "connected");
    assert_string_equal(dr_conn_state_name(DR_CONN_TIMED_OUT), "timed out");
    assert_string_equal(dr_conn_state_name(DR_CONN_RECONNECTING), "reconnecting");
    assert_string_equal(dr_conn_state_name(DR_CONN_CLOSED), "closed");
    assert_string_equal(dr_conn_state_name((dr_conn_state_t)42), "?");
}

static void test_new_refuses(void **state)
{
    (void)state;
    char host[300];
    dr_client_config_t cfg = config(&fake_ops);
    assert_null(dr_client_new(NULL, NULL));
    cfg.host = NULL;
    assert_null(dr_client_new(&cfg, NULL));
    memset(host, 'a', sizeof host - 1);
    host[sizeof host - 1] = '\0';
    cfg.host = host; /* 299 characters: more than a host name can be */
    assert_null(dr_client_new(&cfg, NULL));
    cfg.host = "robot";
    cfg.local_addr = "nowhere";
    F.resolve_st = DR_ENOTFOUND;
    assert_null(dr_client_new(&cfg, NULL));
    F.resolve_st = DR_OK;
    F.timer_st = DR_EIO;
    assert_null(dr_client_new(&cfg, NULL));
    F.timer_st = DR_OK;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_client_free(c);
    dr_client_free(NULL);
}

/* dr_client_new says why it refused: the configuration, or what the
 * transport said of the local address or the timer. */
static void test_new_says_why(void **state)
{
    (void)state;
    dr_status_t err = DR_OK;
    dr_client_config_t cfg = config(&fake_ops);
    assert_null(dr_client_new(NULL, &err));
    assert_int_equal(err, DR_EINVAL);
    cfg.host = NULL;
    err = DR_OK;
    assert_null(dr_client_new(&cfg, &err));
    assert_int_equal(err, DR_EINVAL);
    cfg.host = "robot";
    cfg.local_addr = "nowhere";
    F.resolve_st = DR_ENOTFOUND;
    assert_null(dr_client_new(&cfg, &err));
    assert_int_equal(err, DR_ENOTFOUND);
    F.resolve_st = DR_OK;
    F.timer_st = DR_EIO;
    assert_null(dr_client_new(&cfg, &err));
    assert_int_equal(err, DR_EIO);
    F.timer_st = DR_OK;
    dr_client_t *c = dr_client_new(&cfg, &err);
    assert_non_null(c);
    assert_int_equal(err, DR_OK);
    dr_client_free(c);
    /* The out-of-memory status has a text of its own. */
    assert_string_equal(dr_strerror(DR_ENOMEM), "out of memory");
}

static void test_shared_port_limits(void **state)
{
    (void)state;
    dr_status_t err = DR_OK;
    dr_transport_t tp = {&fake_ops, &F};
    F.resolve_st = DR_ENOTFOUND;
    assert_null(dr_udp_port_new("nowhere", 0, tp, &err));
    assert_int_equal(err, DR_ENOTFOUND);
    F.resolve_st = DR_OK;
    F.udp_open_st = DR_EIO;
    assert_null(dr_udp_port_new(NULL, 0, tp, &err));
    assert_int_equal(err, DR_EIO);
    F.udp_open_st = DR_OK;
    dr_udp_port_t *p = dr_udp_port_new("here", 0, tp, &err);
    assert_non_null(p);
    assert_int_equal(dr_udp_port_fd(p), FD_OF(UDP_H));
    /* DR_UDP_PORT_MAX_CLIENTS (32, as many as drgatewayd's robots) share
     * one port; one more is refused until one of them is freed */
    assert_int_equal(DR_UDP_PORT_MAX_CLIENTS, 32);
    dr_client_t *c[DR_UDP_PORT_MAX_CLIENTS];
    dr_client_config_t cfg = config(&fake_ops);
    cfg.shared_udp = p;
    for (int i = 0; i < DR_UDP_PORT_MAX_CLIENTS; i++) {
        c[i] = dr_client_new(&cfg, NULL);
        assert_non_null(c[i]);
    }
    unsigned closes = F.closes;
    assert_null(dr_client_new(&cfg, NULL));
    assert_int_equal(F.closes, closes + 1); /* its timer was closed again */
    dr_client_free(c[3]);
    c[3] = dr_client_new(&cfg, NULL);
    assert_non_null(c[3]);
    /* a shared port is the application's to poll: not in the clients' fds */
    dr_pollfd_t fds[DR_CLIENT_MAX_FDS];
    assert_int_equal(dr_client_pollfds(c[0], fds, DR_CLIENT_MAX_FDS), 1);
    assert_int_equal(fds[0].fd, FD_OF(TIMER_H));
    /* datagrams for nobody, or not even a Class 1 frame, are dropped */
    F.udp_in[0].len = 3;
    F.udp_in[1].len = 20;
    dr_put_le16(F.udp_in[1].buf, 2);
    F.udp_in_n = 2;
    dr_udp_port_process(p);
    assert_int_equal(F.udp_in_n, 0);
    for (int i = 0; i < DR_UDP_PORT_MAX_CLIENTS; i++)
        dr_client_free(c[i]);
    dr_udp_port_free(p);
    dr_udp_port_free(NULL);
}

/* ---- the session ------------------------------------------------------------------ */

static void test_connect_failures(void **state)
{
    (void)state;
    dr_client_t *c = new_client();
    F.resolve_st = DR_ENOTFOUND;
    assert_int_equal(dr_client_connect_sync(c), DR_ENOTFOUND);
    assert_string_equal(dr_client_last_step(c), "resolve");
    F.resolve_st = DR_OK;
    F.connect_st = DR_ECONNREFUSED;
    assert_int_equal(dr_client_connect_sync(c), DR_ECONNREFUSED);
    assert_string_equal(dr_client_last_step(c), "connect");
    F.connect_st = DR_OK;
    /* the connect itself fails after a while */
    F.finish_st = DR_ECONNREFUSED;
    assert_int_equal(dr_client_connect_sync(c), DR_ECONNREFUSED);
    /* or never finishes: no answer (TCP's, not a request timeout) */
    F.finish_st = DR_EAGAIN;
    uint64_t t0 = F.now;
    assert_int_equal(dr_client_connect_sync(c), DR_ENOANSWER);
    assert_true(F.now - t0 >= 100000u);
    assert_string_equal(dr_client_last_step(c), "connect");
    F.finish_st = DR_OK;
    /* connected, but RegisterSession is never answered */
    F.reg_silent = true;
    t0 = F.now;
    assert_int_equal(dr_client_connect_sync(c), DR_ENOREGISTER);
    assert_true(F.now - t0 >= 100000u);
    assert_string_equal(dr_client_last_step(c), "register session");
    F.reg_silent = false;
    /* RegisterSession refused, or answered with session handle 0 */
    F.reg_status = 0x0069;
    assert_int_equal(dr_client_connect_sync(c), DR_ENCAP(0x0069));
    assert_string_equal(dr_client_last_step(c), "register session");
    F.reg_status = 0;
    F.session = 0;
    assert_int_equal(dr_client_connect_sync(c), DR_EMALFORMED);
    F.session = 0x11223344u;
    /* sending the RegisterSession fails */
    F.send_st = DR_EIO;
    assert_int_equal(dr_client_connect_sync(c), DR_EIO);
    F.send_st = DR_OK;
    /* and at last it works; a second connect is a no-op */
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    unsigned rr = F.rr;
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    assert_int_equal(F.rr, rr);
    dr_client_free(c);
    assert_int_equal(F.unregister, 1);
}

/* What dr_session_cb reports to an event loop that lets the client
 * reconnect by itself: every failed attempt with its cause, the session
 * registered, the session ended by the peer; nothing while it closes. */
typedef struct {
    dr_status_t why[16];
    unsigned n;
} sess_log_t;

static sess_log_t S_LOG; /* file scope: the callback changes it behind the calls */

static void on_session_log(dr_client_t *c, dr_status_t why, void *user)
{
    sess_log_t *log = user;
    assert_true(dr_client_ready(c) == (why == DR_OK));
    if (log->n < 16)
        log->why[log->n] = why;
    log->n++;
}

static void test_session_callback(void **state)
{
    (void)state;
    memset(&S_LOG, 0, sizeof S_LOG);
    dr_client_config_t cfg = config(&fake_ops);
    cfg.on_session = on_session_log;
    cfg.session_user = &S_LOG;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    /* refused at once: told from the first attempt, and from each retry */
    F.connect_st = DR_ECONNREFUSED;
    dr_client_start(c);
    assert_int_equal(S_LOG.n, 1);
    assert_int_equal(S_LOG.why[0], DR_ECONNREFUSED);
    run_for(c, 25); /* backoff 10 ms, then 20 ms */
    assert_true(S_LOG.n >= 2);
    assert_int_equal(S_LOG.why[S_LOG.n - 1], DR_ECONNREFUSED);
    /* the TCP connect never completes: no answer at the 100 ms timeout */
    F.connect_st = DR_OK;
    F.finish_st = DR_EAGAIN;
    unsigned n = S_LOG.n;
    run_for(c, 200);
    assert_true(S_LOG.n > n);
    assert_int_equal(S_LOG.why[n], DR_ENOANSWER);
    /* connected, RegisterSession never answered */
    F.finish_st = DR_OK;
    F.reg_silent = true;
    n = S_LOG.n;
    run_for(c, 200);
    assert_true(S_LOG.n > n);
    assert_int_equal(S_LOG.why[S_LOG.n - 1], DR_ENOREGISTER);
    /* registered, then closed by the peer, then registered again */
    F.reg_silent = false;
    run_for(c, 300); /* the attempt under way times out, the next one works */
    assert_true(S_LOG.n < 16);
    assert_int_equal(S_LOG.why[S_LOG.n - 1], DR_OK);
    n = S_LOG.n - 1;
    F.eof_st = DR_ECLOSED;
    run_for(c, 100);
    assert_true(S_LOG.n >= n + 3);
    assert_int_equal(S_LOG.why[n + 1], DR_ECLOSED);
    assert_int_equal(S_LOG.why[n + 2], DR_OK);
    /* closing (the peer closes after UnRegisterSession): not told */
    n = S_LOG.n;
    dr_client_free(c);
    assert_int_equal(S_LOG.n, n);
}

/* A frame longer than any the protocol allows: the stream is given up. */
static void test_overlong_frame(void **state)
{
    (void)state;
    dr_client_t *c = connected();
    F.cip = cip_silent;
    uint8_t ctx[8] = {0};
    uint8_t big[700];
    memset(big, 0, sizeof big);
    queue_encap(&F, DR_ENCAP_SEND_RR_DATA, F.session, 0, ctx, big, sizeof big);
    uint8_t buf[36];
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, sizeof buf), DR_ELONG);
    assert_false(dr_client_ready(c));
    dr_client_free(c);
}

/* ---- explicit messaging ------------------------------------------------------------ */

static void test_reply_sizes(void **state)
{
    (void)state;
    dr_client_t *c = connected();
    uint8_t buf[96];
    uint16_t size;
    /* a reply of another size than the specification's is refused */
    F.get_len = 35;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ELENGTH);
    F.get_len = 36;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_OK);
    assert_int_equal(buf[0], 0xA5);
    /* the caller's length must be the assembly's; unknown assemblies */
    assert_int_equal(dr_client_read_asm_sync(c, (dr_asm_t)99, buf, 36), DR_EINVAL);
    assert_int_equal(dr_client_write_asm_sync(c, DR_ASM_INT_IN, buf, 95), DR_ELENGTH);
    assert_int_equal(dr_client_write_asm_sync(c, (dr_asm_t)99, buf, 96), DR_EINVAL);
    assert_int_equal(dr_client_write_asm_sync(c, DR_ASM_INT_IN, buf, 96), DR_OK);
    /* attribute 4 is two bytes, nothing else */
    F.get_len = 3;
    assert_int_equal(dr_client_read_asm_size_sync(c, 101, &size), DR_EMALFORMED);
    F.get_len = 2;
    assert_int_equal(dr_client_read_asm_size_sync(c, 101, &size), DR_OK);
    assert_int_equal(size, 0xA5A5);
    /* the identity needs the whole Get_Attributes_All reply (here: 0x08) */
    dr_identity_t id;
    assert_int_equal(dr_client_read_identity_sync(c, &id), DR_CIP(0x08, 0));
    /* a request too large for one message is refused before it is sent */
    uint8_t huge[700] = {0};
    unsigned rr = F.rr;
    assert_int_equal(dr_client_call_sync(c, 0x10, NULL, 0, huge, sizeof huge, NULL, 0, NULL),
                     DR_ENOSPACE);
    assert_int_equal(F.rr, rr);
    assert_int_equal(dr_client_instance(c, (dr_asm_t)99), 0);
    assert_int_equal(dr_client_instance(c, DR_ASM_INT_IN), 109);
    dr_client_free(c);
}

static void test_bad_replies(void **state)
{
    (void)state;
    dr_client_t *c = connected();
    uint8_t buf[36];
    /* an encapsulation error in the reply */
    F.next_status = 0x0003;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ENCAP(0x0003));
    assert_true(dr_client_ready(c));
    /* a reply with another command than the request's */
    F.next_cmd = DR_ENCAP_LIST_SERVICES;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EMISMATCH);
    /* a reply whose service is not the request's | 0x80 (issue 29): a
     * Set's reply (0x90) or a Forward Open's (0xD4) to a Get is not its
     * answer, whatever its data (a reply without the reply bit is not a
     * reply at all: malformed) */
    F.next_rsp_service = DR_CIP_SVC_SET_ATTRIBUTE_SINGLE | DR_CIP_REPLY;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EMISMATCH);
    F.next_rsp_service = DR_CIP_SVC_FORWARD_OPEN | DR_CIP_REPLY;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EMISMATCH);
    F.next_rsp_service = DR_CIP_SVC_GET_ATTRIBUTE_SINGLE;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EMALFORMED);
    assert_true(dr_client_ready(c));
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_OK);
    /* no 0xB2 item */
    F.next_no_b2 = true;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EMALFORMED);
    /* a reply to nobody's request is ignored: the request times out */
    F.next_unknown_ctx = true;
    uint64_t t0 = F.now;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ETIMEDOUT);
    assert_true(F.now - t0 >= 100000u);
    assert_true(dr_client_ready(c));
    /* "invalid session handle": the session is dropped */
    F.next_status = 0x0064;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ENCAP(0x0064));
    assert_false(dr_client_ready(c));
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ESESSION);
    dr_client_free(c);
}

static void test_partial_sends_and_close(void **state)
{
    (void)state;
    dr_client_t *c = new_client();
    F.send_max = 7; /* every frame goes out in pieces */
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    uint8_t buf[36];
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_OK);
    F.send_max = 0;
    /* the peer closes while a request is out */
    F.cip = cip_silent;
    F.eof_st = DR_ECLOSED;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ECLOSED);
    assert_false(dr_client_ready(c));
    /* and a send that fails */
    F.cip = NULL;
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    F.send_st = DR_EIO;
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EIO);
    assert_false(dr_client_ready(c));
    F.send_st = DR_OK;
    dr_client_free(c);
}

static void test_list_identity(void **state)
{
    (void)state;
    dr_client_t *c = new_client();
    dr_identity_t id;
    assert_int_equal(dr_client_list_identity_sync(c, &id), DR_ESESSION);
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    assert_int_equal(dr_client_list_identity_sync(c, &id), DR_OK);
    assert_string_equal(id.product_name, "fake adapter");
    assert_int_equal(id.serial, 0x01020304);
    F.next_status = 0x0001;
    assert_int_equal(dr_client_list_identity_sync(c, &id), DR_ENCAP(0x0001));
    F.send_st = DR_EIO;
    assert_int_equal(dr_client_list_identity_sync(c, &id), DR_EIO);
    F.send_st = DR_OK;
    dr_client_free(c);
}

/* ---- asynchronous requests ------------------------------------------------------- */

typedef struct {
    unsigned calls;
    dr_status_t st;
    size_t len;
} async_t;

static void on_async(dr_client_t *c, dr_status_t st, const uint8_t *data, size_t len, void *user)
{
    async_t *a = user;
    (void)c, (void)data;
    a->calls++;
    a->st = st;
    a->len = len;
}

static const uint8_t io_state_path[] = {0x20, 0x04, 0x24, 101, 0x30, 0x03};

static void test_async(void **state)
{
    (void)state;
    async_t a = {0, DR_OK, 0};
    dr_client_t *c = new_client();
    assert_int_equal(dr_client_call_async(c, 0x0E, io_state_path, sizeof io_state_path, NULL,
                                          0, on_async, &a),
                     DR_ESESSION);
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    assert_int_equal(dr_client_call_async(c, 0x0E, io_state_path, sizeof io_state_path, NULL,
                                          0, on_async, &a),
                     DR_OK);
    assert_int_equal(a.calls, 0); /* only from the loop */
    dr_client_process(c);
    assert_int_equal(a.calls, 1);
    assert_int_equal(a.st, DR_OK);
    assert_int_equal(a.len, 36);
    /* too large to send */
    uint8_t huge[700] = {0};
    assert_int_equal(dr_client_call_async(c, 0x10, io_state_path, sizeof io_state_path, huge,
                                          sizeof huge, on_async, &a),
                     DR_ENOSPACE);
    /* eight at most in flight */
    F.cip = cip_silent;
    for (int i = 0; i < 8; i++)
        assert_int_equal(dr_client_call_async(c, 0x0E, io_state_path, sizeof io_state_path,
                                              NULL, 0, on_async, &a),
                         DR_OK);
    assert_int_equal(dr_client_call_async(c, 0x0E, io_state_path, sizeof io_state_path, NULL,
                                          0, on_async, &a),
                     DR_EFULL);
    uint8_t buf[36];
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_EFULL);
    /* they time out, each called back once */
    run_for(c, 150);
    assert_int_equal(a.calls, 9);
    assert_int_equal(a.st, DR_ETIMEDOUT);
    dr_client_free(c);
}

/* The session fails while an asynchronous request is being sent (a peer
 * that has just closed): the request is refused with the error, and its
 * callback is not called from inside dr_client_call_async. drgatewayd's
 * explicit mode counts requests in flight by the calls that returned
 * DR_OK; a callback from inside the call left it counting one for ever,
 * and it never polled again after such a session drop. */
static void test_async_send_fails(void **state)
{
    (void)state;
    async_t a = {0, DR_OK, 0};
    dr_client_t *c = connected();
    F.send_fail_after = F.rr + 1;
    assert_int_equal(dr_client_call_async(c, 0x0E, io_state_path, sizeof io_state_path, NULL,
                                          0, on_async, &a),
                     DR_ECLOSED);
    assert_int_equal(a.calls, 0);
    assert_false(dr_client_ready(c));
    run_for(c, 10);
    assert_int_equal(a.calls, 0);
    /* requests still out when the session fails are called back, once */
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    F.cip = cip_silent;
    assert_int_equal(dr_client_call_async(c, 0x0E, io_state_path, sizeof io_state_path, NULL,
                                          0, on_async, &a),
                     DR_OK);
    F.eof_st = DR_ECLOSED;
    dr_client_process(c);
    assert_int_equal(a.calls, 1);
    assert_int_equal(a.st, DR_ECLOSED);
    dr_client_free(c);
}

/* ---- Class 1 ------------------------------------------------------------------------ */

typedef struct {
    unsigned data, states;
    dr_conn_state_t last;
    dr_status_t why;
    dr_client_t *ask; /* on_state asks it for its next deadline */
} conn_log_t;

static void on_data(dr_conn_t *cn, const uint8_t *data, size_t len, void *user)
{
    conn_log_t *l = user;
    (void)cn, (void)data, (void)len;
    l->data++;
}

static void on_state(dr_conn_t *cn, dr_conn_state_t s, dr_status_t why, void *user)
{
    conn_log_t *l = user;
    (void)cn;
    l->states++;
    l->last = s;
    l->why = why;
    if (l->ask != NULL) /* in the middle of a change: must not stick */
        (void)dr_client_next_deadline(l->ask);
}

static dr_conn_config_t conn_config(conn_log_t *log)
{
    dr_conn_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.o2t_asm = DR_ASM_INT_IN;
    cc.t2o_asm = DR_ASM_INT_OUT;
    cc.rpi_us = 10000;
    cc.timeout_mult = 0; /* x4: 40 ms */
    cc.on_data = on_data;
    cc.on_state = on_state;
    cc.user = log;
    return cc;
}

/* A T->O packet with its own encapsulation sequence number and CIP
 * sequence count, data bytes all `fill`. */
static void push_t2o_seq(uint32_t cid, uint32_t encap_seq, uint16_t cip_seq, uint8_t fill,
                         size_t len)
{
    uint8_t data[200];
    memset(data, fill, sizeof data);
    dr_io_frame_t fr;
    memset(&fr, 0, sizeof fr);
    fr.cid = cid;
    fr.encap_seq = encap_seq;
    fr.cip_seq = cip_seq;
    fr.data = data;
    fr.data_len = len;
    size_t n;
    assert_true(F.udp_in_n < MAX_UDP_IN);
    assert_int_equal(dr_io_frame_write(F.udp_in[F.udp_in_n].buf, 600, &fr, &n), DR_OK);
    F.udp_in[F.udp_in_n].from = F.push_from;
    F.udp_in[F.udp_in_n++].len = n;
}

static void push_t2o(uint32_t cid, uint16_t seq, size_t len)
{
    uint8_t data[200];
    memset(data, (int)seq, sizeof data);
    dr_io_frame_t fr;
    memset(&fr, 0, sizeof fr);
    fr.cid = cid;
    fr.encap_seq = seq;
    fr.cip_seq = seq;
    fr.data = data;
    fr.data_len = len;
    size_t n;
    assert_true(F.udp_in_n < MAX_UDP_IN);
    assert_int_equal(dr_io_frame_write(F.udp_in[F.udp_in_n].buf, 600, &fr, &n), DR_OK);
    F.udp_in[F.udp_in_n].from = F.push_from;
    F.udp_in[F.udp_in_n++].len = n;
}

static void test_conn_add_refuses(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_status_t err = DR_OK;
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    cc.t2o_asm = DR_ASM_INT_IN; /* not T->O */
    assert_null(dr_conn_add(c, &cc, &err));
    assert_int_equal(err, DR_EINVAL);
    cc = conn_config(&log);
    cc.o2t_asm = DR_ASM_INT_OUT; /* not O->T */
    assert_null(dr_conn_add(c, &cc, &err));
    cc = conn_config(&log);
    cc.rpi_us = 0;
    assert_null(dr_conn_add(c, &cc, &err));
    cc = conn_config(&log);
    cc.timeout_mult = 8;
    assert_null(dr_conn_add(c, &cc, &err));
    assert_null(dr_conn_add(c, NULL, NULL));
    cc = conn_config(&log);
    dr_conn_t *cn[DR_CLIENT_MAX_CONNS];
    for (int i = 0; i < DR_CLIENT_MAX_CONNS; i++)
        assert_non_null(cn[i] = dr_conn_add(c, &cc, &err));
    assert_null(dr_conn_add(c, &cc, &err));
    assert_int_equal(err, DR_EFULL);
    dr_conn_remove(cn[5]);
    dr_conn_remove(cn[5]); /* twice is harmless */
    dr_conn_remove(NULL);
    assert_non_null(dr_conn_add(c, &cc, &err));
    /* outputs: the assembly's size, and never for an input-only connection */
    uint8_t out[96] = {0};
    assert_int_equal(dr_conn_set_output(cn[0], out, 95), DR_ELENGTH);
    assert_int_equal(dr_conn_set_output(cn[0], NULL, 96), DR_EINVAL);
    assert_int_equal(dr_conn_set_output(NULL, out, 96), DR_EINVAL);
    cc.o2t_asm = -1;
    cc.t2o_asm = DR_ASM_JOINT_STATE;
    dr_conn_remove(cn[6]);
    dr_conn_t *in_only = dr_conn_add(c, &cc, &err);
    assert_non_null(in_only);
    assert_int_equal(dr_conn_set_output(in_only, out, 96), DR_EINVAL);
    dr_client_free(c);
}

static void test_class1_io(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    assert_ptr_equal(dr_conn_user(cn), &log);
    assert_null(dr_conn_input(cn, NULL));
    /* the event-loop API: descriptors, then process when they are ready */
    dr_client_start(c);
    dr_pollfd_t fds[DR_CLIENT_MAX_FDS];
    int n = dr_client_pollfds(c, fds, DR_CLIENT_MAX_FDS);
    assert_int_equal(n, 2); /* TCP (connecting: in and out) and the timer */
    assert_int_equal(fds[0].fd, FD_OF(TCP_H));
    assert_int_equal(fds[0].events, DR_POLL_IN | DR_POLL_OUT);
    for (int i = 0; i < 50 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++) {
        F.now += 1000u;
        n = dr_client_pollfds(c, fds, DR_CLIENT_MAX_FDS);
        for (int k = 0; k < n; k++)
            fds[k].revents = 1;
        dr_client_process_ready(c, fds, n);
    }
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(F.fwd_open, 1);
    /* the own UDP socket is in the descriptors now */
    n = dr_client_pollfds(c, fds, DR_CLIENT_MAX_FDS);
    assert_int_equal(n, 3);
    assert_int_equal(fds[1].fd, FD_OF(UDP_H));
    /* O->T: one datagram per RPI, one udp_send each (no batch op) */
    uint8_t out[96];
    memset(out, 0x3C, sizeof out);
    assert_int_equal(dr_conn_set_output(cn, out, sizeof out), DR_OK);
    unsigned sent = F.udp_sent;
    for (int i = 0; i < 5; i++) {
        F.now += 10000u;
        push_t2o(F.t2o_cid, (uint16_t)(i + 1), 96);
        dr_client_process(c);
    }
    assert_true(F.udp_sent >= sent + 4);
    /* item count, sequenced address item (4 + 8), data item header, CIP
     * sequence count, run/idle header, the assembly */
    assert_int_equal(F.udp_last_len, 2 + 12 + 4 + 2 + 4 + 96);
    assert_int_equal(F.udp_last[F.udp_last_len - 1], 0x3C);
    assert_int_equal(F.udp_last_to.addr, PEER_ADDR);
    assert_int_equal(F.udp_last[F.udp_last_len - 100], 1); /* run */
    dr_conn_set_run(cn, false);
    F.now += 10000u;
    dr_client_process(c);
    assert_int_equal(F.udp_last[F.udp_last_len - 100], 0); /* idle */
    /* T->O: in order, lost, duplicate, wrong size, someone else's */
    assert_int_equal(log.data, 5);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    push_t2o(F.t2o_cid, 8, 96);        /* 6 and 7 lost */
    push_t2o(F.t2o_cid, 8, 96);        /* duplicate */
    push_t2o(F.t2o_cid, 7, 96);        /* stale */
    push_t2o(F.t2o_cid, 9, 95);        /* wrong size */
    push_t2o(F.t2o_cid + 1, 10, 96);   /* another connection's ID */
    dr_client_process(c);
    assert_int_equal(log.data, 6);
    assert_int_equal(st->rx_packets, 6);
    assert_int_equal(st->rx_lost, 2);
    assert_int_equal(st->rx_dropped_seq, 2);
    assert_int_equal(st->rx_bad, 1);
    size_t len = 0;
    const uint8_t *in = dr_conn_input(cn, &len);
    assert_non_null(in);
    assert_int_equal(len, 96);
    assert_int_equal(in[0], 8);
    /* silence: the connection times out, closes and opens again */
    run_for(c, 200);
    assert_true(st->timeouts >= 1);
    assert_true(F.fwd_open >= 2);
    assert_true(F.fwd_close >= 1);
    /* removing an established one sends a Forward Close */
    for (int i = 0; i < 50 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++)
        run_for(c, 5);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    unsigned closes = F.fwd_close;
    dr_conn_remove(cn);
    assert_int_equal(log.last, DR_CONN_CLOSED);
    run_for(c, 5);
    assert_int_equal(F.fwd_close, closes + 1);
    dr_client_free(c);
}

/* Issue 30: a connection the adapter accepted that never gets its first
 * T->O packet times out with its own cause (DR_ENODATA), not "timed out";
 * one that had data and went silent is DR_ETIMEDOUT. The time the
 * connection was established is in its stats. dr_client_t2o_addr names
 * where T->O should have come: the TCP session's source address when no
 * local address is set. */
static void test_class1_no_first_packet(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    dr_client_start(c);
    for (int i = 0; i < 50 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++)
        run_for(c, 1);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    uint64_t opened = dr_conn_stats(cn)->opened_us;
    assert_true(opened > 0 && opened <= F.now);
    dr_sockaddr_t to = dr_client_t2o_addr(c);
    assert_int_equal(to.addr, 0x0A000007u);
    assert_int_equal(to.port, DR_ENIP_UDP_PORT);
    /* no packet: the grace (2 s) plus the timeout, then DR_ENODATA */
    for (int i = 0; i < 3000 && dr_conn_state(cn) == DR_CONN_ESTABLISHED; i++)
        run_for(c, 1);
    assert_int_equal(dr_conn_stats(cn)->timeouts, 1);
    assert_true(F.now - opened >= 2000000u); /* the grace was given */
    assert_int_equal(log.why, DR_ENODATA);
    assert_string_equal(dr_strerror(DR_ENODATA),
                        "the robot accepted the connection but sends no data");
    /* open again, with data this time, then silence: DR_ETIMEDOUT */
    for (int i = 0; i < 500 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++)
        run_for(c, 1);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    push_t2o(F.t2o_cid, 1, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 1);
    for (int i = 0; i < 100 && dr_conn_state(cn) == DR_CONN_ESTABLISHED; i++)
        run_for(c, 5);
    assert_int_equal(log.why, DR_ETIMEDOUT);
    dr_client_free(c);
}

/* Issue 30: a local address binds the TCP session too (the adapter sends
 * T->O to the address TCP comes from); a transport that cannot bind TCP
 * is refused with a local address, and works without one. */
static void test_local_addr_binds_tcp(void **state)
{
    (void)state;
    dr_client_config_t cfg = config(&fake_ops);
    cfg.local_addr = "10.0.0.9"; /* the fake resolves every name to PEER_ADDR */
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_client_start(c);
    run_for(c, 5);
    assert_int_equal(F.connects_from, 1);
    assert_int_equal(F.tcp_from.addr, PEER_ADDR);
    assert_int_equal(F.tcp_from.port, 0);
    assert_int_equal(dr_client_t2o_addr(c).addr, PEER_ADDR);
    dr_client_free(c);
    /* without a local address: plain tcp_connect */
    F.connects_from = 0;
    cfg.local_addr = NULL;
    c = dr_client_new(&cfg, NULL);
    dr_client_start(c);
    run_for(c, 5);
    assert_int_equal(F.connects_from, 0);
    dr_client_free(c);
    /* a transport without tcp_connect_from cannot honour one */
    dr_status_t err = DR_OK;
    dr_transport_ops_t unbound = fake_ops;
    unbound.tcp_connect_from = NULL;
    cfg = config(&unbound);
    cfg.local_addr = "10.0.0.9";
    assert_null(dr_client_new(&cfg, &err));
    assert_int_equal(err, DR_EUNSUPPORTED);
}

/* Forward Open refusals: retried after a backoff; O->T sent in batches. */
static void test_class1_refused_and_batch(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg = config(&fake_batch_ops);
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *a = dr_conn_add(c, &cc, NULL);
    cc.o2t_asm = DR_ASM_FLOAT_IN;
    cc.t2o_asm = DR_ASM_FLOAT_OUT;
    dr_conn_t *b = dr_conn_add(c, &cc, NULL);
    F.fo_general = 0x01;
    F.fo_ext = 0x0113; /* out of connections */
    dr_client_start(c);
    run_for(c, 30);
    assert_int_equal(dr_conn_state(a), DR_CONN_RECONNECTING);
    assert_int_equal(log.why, DR_CIP(0x01, 0x0113));
    unsigned opens = F.fwd_open;
    F.fo_general = 0;
    run_for(c, 100);
    assert_true(F.fwd_open > opens);
    assert_int_equal(dr_conn_state(a), DR_CONN_ESTABLISHED);
    assert_int_equal(dr_conn_state(b), DR_CONN_ESTABLISHED);
    /* both produce on one time grid: one batch carries both */
    unsigned batches = F.udp_batches, sent = F.udp_sent;
    F.now += 10000u;
    push_t2o(F.t2o_cid, 1, 96);
    dr_client_process(c);
    assert_int_equal(F.udp_batches, batches + 1);
    assert_int_equal(F.udp_sent, sent + 2);
    /* a UDP socket that cannot be opened: the open is retried later */
    dr_client_close_sync(c);
    assert_int_equal(dr_conn_state(a), DR_CONN_CLOSED);
    F.udp_open_st = DR_EIO;
    dr_client_start(c);
    run_for(c, 20);
    assert_int_equal(dr_conn_state(a), DR_CONN_RECONNECTING);
    assert_int_equal(log.why, DR_EIO);
    assert_string_equal(dr_client_last_step(c), "bind UDP");
    F.udp_open_st = DR_OK;
    run_for(c, 100);
    assert_int_equal(dr_conn_state(a), DR_CONN_ESTABLISHED);
    dr_client_free(c);
}

static void wait_established(dr_client_t *c, dr_conn_t *cn)
{
    for (int i = 0; i < 100 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++)
        run_for(c, 5);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
}

/* A connection of cc on c, started and established (the fake target
 * answers its Forward Open). */
static dr_conn_t *open_established(dr_client_t *c, const dr_conn_config_t *cc)
{
    dr_conn_t *cn = dr_conn_add(c, cc, NULL);
    assert_non_null(cn);
    dr_client_start(c);
    wait_established(c, cn);
    return cn;
}

/* The live producer's packet e, one RPI (10 ms) after the last: both
 * sequence numbers e, every data byte e's low byte. */
static void live_packet(dr_client_t *c, uint32_t e)
{
    F.now += 10000u;
    push_t2o_seq(F.t2o_cid, e, (uint16_t)e, (uint8_t)e, 96);
    dr_client_process(c);
}

/* T->O sequence handling (issue 10): a producer that keeps its CIP
 * sequence count while its data is unchanged stays alive by its
 * encapsulation sequence number; stale packets never keep it alive; both
 * numbers wrap; a count that goes back is a restart (new data, no gap). */
static void test_class1_seq_repeat(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log); /* RPI 10 ms, timeout 40 ms */
    dr_conn_t *cn = open_established(c, &cc);
    const dr_conn_stats_t *st = dr_conn_stats(cn);

    /* 30 RPIs of unchanged data: one count, the encapsulation number
     * moving; alive all along, one on_data, 29 repeats */
    uint32_t e = 1;
    for (int i = 0; i < 30; i++) {
        F.now += 10000u;
        push_t2o_seq(F.t2o_cid, e++, 7, 0x11, 96);
        dr_client_process(c);
        assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    }
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(log.data, 1);
    assert_int_equal(st->rx_packets, 30);
    assert_int_equal(st->rx_repeats, 29);
    assert_int_equal(st->rx_lost, 0);
    assert_int_equal(st->last_rx_us, F.now);
    /* a change of data arrives with the next packet */
    F.now += 10000u;
    push_t2o_seq(F.t2o_cid, e++, 8, 0x22, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 2);
    assert_int_equal(dr_conn_input(cn, NULL)[0], 0x22);
    /* a repeat after it does not bring the old data back */
    F.now += 10000u;
    push_t2o_seq(F.t2o_cid, e++, 8, 0x22, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 2);
    /* CIP count skips 8 -> 11: new data, two lost */
    push_t2o_seq(F.t2o_cid, e++, 11, 0x33, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 3);
    assert_int_equal(st->rx_lost, 2);
    /* CIP count back to 2 with a newer packet: the producer restarted its
     * count; new data, no gap */
    push_t2o_seq(F.t2o_cid, e++, 2, 0x44, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 4);
    assert_int_equal(st->rx_lost, 2);
    assert_int_equal(dr_conn_input(cn, NULL)[0], 0x44);

    /* stale (older encapsulation number, even with a newer CIP count):
     * dropped, no data, and no sign of life: 30 ms after the last packet
     * taken a stale one comes, 15 ms later the 40 ms timeout strikes */
    uint64_t taken = F.now;
    F.now = taken + 30000u;
    push_t2o_seq(F.t2o_cid, e - 3, 3, 0x55, 96);
    push_t2o_seq(F.t2o_cid, e - 1, 3, 0x55, 96); /* a duplicate of the last */
    dr_client_process(c);
    assert_int_equal(st->rx_dropped_seq, 2);
    assert_int_equal(log.data, 4);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    F.now = taken + 45000u;
    dr_client_process(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_RECONNECTING);
    assert_int_equal(st->timeouts, 1);

    /* a new connection: the first packet is taken whatever its numbers;
     * then both numbers wrap (0xFFFFFFFF -> 0, 0xFFFF -> 0) */
    wait_established(c, cn);
    unsigned data0 = log.data;
    uint64_t rx0 = st->rx_packets, rep0 = st->rx_repeats, drop0 = st->rx_dropped_seq;
    push_t2o_seq(F.t2o_cid, 0xFFFFFFFEu, 0xFFFF, 0x66, 96);
    push_t2o_seq(F.t2o_cid, 0xFFFFFFFFu, 0xFFFF, 0x66, 96); /* repeat */
    push_t2o_seq(F.t2o_cid, 0u, 0, 0x77, 96);               /* new, both wrapped */
    push_t2o_seq(F.t2o_cid, 1u, 0, 0x77, 96);               /* repeat */
    push_t2o_seq(F.t2o_cid, 0xFFFFFFFFu, 1, 0x88, 96);      /* stale across the wrap */
    dr_client_process(c);
    assert_int_equal(log.data, data0 + 2);
    assert_int_equal(st->rx_packets, rx0 + 4);
    assert_int_equal(st->rx_repeats, rep0 + 2);
    assert_int_equal(st->rx_dropped_seq, drop0 + 1);
    assert_int_equal(st->rx_lost, 2); /* 0xFFFF -> 0 is no gap */
    assert_int_equal(dr_conn_input(cn, NULL)[0], 0x77);
    /* and keeps the connection alive past its timeout */
    e = 2;
    for (int i = 0; i < 10; i++) {
        F.now += 10000u;
        push_t2o_seq(F.t2o_cid, e++, 0, 0x77, 96);
        dr_client_process(c);
    }
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(st->timeouts, 1);
    dr_client_free(c);
}

/* Issue 19: a corrupted encapsulation sequence number (a bit flipped high
 * in a datagram whose UDP checksum is zero) is not taken as "newer", so
 * the real packets after it are not taken as old; a jump within the window
 * is packet loss; three numbers in a row that agree with each other are a
 * producer that jumped, followed from the third. */
static void test_class1_seq_forged(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    cc.timeout_mult = 2; /* x16: 160 ms; window max(16 / 2, 8) = 8 */
    dr_conn_t *cn = open_established(c, &cc);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    uint32_t e;
    for (e = 1; e <= 5; e++)
        live_packet(c, e);
    assert_int_equal(log.data, 5);
    /* the next packet with bit 30 of its number flipped: dropped */
    F.now += 10000u;
    push_t2o_seq(F.t2o_cid, 6u ^ 0x40000000u, 6, 0xEE, 96);
    dr_client_process(c);
    assert_int_equal(st->rx_dropped_seq, 1);
    assert_int_equal(log.data, 5);
    /* the real ones after it are taken, 25 RPIs, longer than the timeout */
    for (e = 6; e <= 30; e++)
        live_packet(c, e);
    assert_int_equal(log.data, 30);
    assert_int_equal(st->rx_dropped_seq, 1);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(dr_conn_input(cn, NULL)[0], 30);
    /* 7 packets lost: a jump of 8, within the window, taken */
    push_t2o_seq(F.t2o_cid, 38, 38, 38, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 31);
    assert_int_equal(st->rx_lost, 7);
    /* one too far ahead between real ones never moves the window */
    push_t2o_seq(F.t2o_cid, 5000, 39, 0xEE, 96);
    push_t2o_seq(F.t2o_cid, 39, 39, 39, 96);
    push_t2o_seq(F.t2o_cid, 5001, 40, 0xEE, 96);
    push_t2o_seq(F.t2o_cid, 40, 40, 40, 96);
    push_t2o_seq(F.t2o_cid, 5002, 41, 0xEE, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 33);
    assert_int_equal(st->rx_dropped_seq, 4);
    assert_int_equal(st->rx_resyncs, 0);
    assert_int_equal(dr_conn_input(cn, NULL)[0], 40);
    /* a producer that jumped: its numbers agree with each other, but are
     * believed only once the sequence taken before has been silent for
     * half the timeout (80 ms): 1000-1006 dropped, 1007 (80 ms after the
     * last packet taken) followed, before the 160 ms timeout strikes */
    for (e = 1000; e <= 1007; e++) {
        F.now += 10000u;
        push_t2o_seq(F.t2o_cid, e, (uint16_t)(e - 959), (uint8_t)(e - 959), 96);
        dr_client_process(c);
    }
    assert_int_equal(st->rx_dropped_seq, 11);
    assert_int_equal(st->rx_resyncs, 1);
    assert_int_equal(log.data, 34);
    assert_int_equal(dr_conn_input(cn, NULL)[0], 1007 - 959);
    F.now += 10000u;
    push_t2o_seq(F.t2o_cid, 1008, 1008 - 959, 1008 - 959, 96);
    dr_client_process(c);
    assert_int_equal(log.data, 35);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    dr_client_free(c);
}

/* Issue 29: packets far ahead of a live sequence, from the target's own
 * address (a forger that can spoof it), agree with each other as much as
 * they like: while the real sequence keeps coming they are never
 * believed. Each costs only itself; the real packets keep flowing, the
 * connection never times out, rx_lost does not jump. (Before: the third
 * agreeing one was followed, and every real packet after it dropped as
 * old until the connection timed out.) */
static void test_class1_seq_forged_live(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    cc.timeout_mult = 2; /* x16: 160 ms; window 8 */
    dr_conn_t *cn = open_established(c, &cc);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    uint32_t e;
    for (e = 1; e <= 5; e++)
        live_packet(c, e);
    /* for 50 RPIs (three timeouts), three forged packets 30000 ahead,
     * agreeing, beside each real one */
    uint32_t forged = 30000;
    for (int i = 0; i < 50; i++, e++) {
        F.now += 10000u;
        for (int k = 0; k < 3; k++, forged++)
            push_t2o_seq(F.t2o_cid, forged, (uint16_t)forged, 0xEE, 96);
        push_t2o_seq(F.t2o_cid, e, (uint16_t)e, (uint8_t)e, 96);
        dr_client_process(c);
        assert_int_equal(dr_conn_input(cn, NULL)[0], (uint8_t)e);
    }
    assert_int_equal(st->rx_resyncs, 0);
    assert_int_equal(st->rx_dropped_seq, 150);
    assert_int_equal(st->rx_packets, 55);
    assert_int_equal(st->rx_lost, 0);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(log.data, 55);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    dr_client_free(c);
}

/* Issue 29: a T->O packet with a live connection's ID from any address
 * but the target's is dropped and counted, whatever its sequence numbers,
 * and keeps nothing alive; the real packets are taken as before. Both
 * receive paths (one datagram per call, and batches). */
static void test_class1_forged_source(void **state)
{
    (void)state;
    const dr_transport_ops_t *ops[2] = {&fake_ops, &fake_batch_ops};
    for (unsigned o = 0; o < 2; o++) {
        setup(NULL);
        conn_log_t log;
        memset(&log, 0, sizeof log);
        dr_client_config_t cfg = config(ops[o]);
        dr_client_t *c = dr_client_new(&cfg, NULL);
        assert_non_null(c);
        dr_conn_config_t cc = conn_config(&log); /* RPI 10 ms, timeout 40 ms */
        dr_conn_t *cn = open_established(c, &cc);
        const dr_conn_stats_t *st = dr_conn_stats(cn);
        uint32_t e;
        for (e = 1; e <= 3; e++)
            live_packet(c, e);
        /* another host: the next numbers, and numbers far ahead */
        F.push_from = PEER_ADDR + 1u;
        push_t2o_seq(F.t2o_cid, 4, 4, 0xEE, 96);
        for (uint32_t k = 0; k < 3; k++)
            push_t2o_seq(F.t2o_cid, 30000 + k, (uint16_t)(30000 + k), 0xEE, 96);
        F.push_from = 0;
        push_t2o_seq(F.t2o_cid, 4, 4, 4, 96); /* the real one: not a duplicate */
        dr_client_process(c);
        assert_int_equal(st->rx_dropped_addr, 4);
        assert_int_equal(st->rx_dropped_seq, 0);
        assert_int_equal(st->rx_packets, 4);
        assert_int_equal(st->rx_lost, 0);
        assert_int_equal(log.data, 4);
        assert_int_equal(dr_conn_input(cn, NULL)[0], 4);
        /* forged packets alone keep nothing alive: the timeout strikes */
        uint64_t taken = F.now;
        F.push_from = PEER_ADDR + 1u;
        for (e = 5; F.now < taken + 40000u; e++) {
            F.now += 10000u;
            push_t2o_seq(F.t2o_cid, e, (uint16_t)e, 0xEE, 96);
            dr_client_process(c);
        }
        F.push_from = 0;
        assert_int_equal(st->rx_dropped_addr, 8);
        assert_int_equal(st->timeouts, 1);
        assert_int_equal(log.data, 4);
        dr_client_free(c);
    }
}

/* An adapter that rounds a 5 ms RPI to its 10 ms tick without saying so
 * (the reply's APIs are the RPIs): the timeout, 8 x 5 ms, covers the
 * tick, in virtual time (test_client_sim runs it against drsim with room
 * for a busy machine). */
static void test_class1_coarse_tick_unreported(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    cc.rpi_us = 5000;
    cc.timeout_mult = 1; /* x8: 40 ms */
    dr_conn_t *cn = open_established(c, &cc);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    assert_int_equal(st->t2o_api_us, 5000);
    assert_true(st->timeout_us64 == 40000u);
    for (uint32_t e = 1; e <= 150; e++) /* 1.5 s, a packet every 10 ms */
        live_packet(c, e);
    assert_int_equal(st->rx_packets, 150);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(log.data, 150);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    dr_client_free(c);
}

/* Issue 29, item 8: the timeout of a connection at RPI 9 s with multiplier
 * 7 (x512) is 4608 s, past 2^32 us; computed in 32 bits it was 313 s, and
 * the connection timed out 4295 s early. */
static void test_class1_timeout_64bit(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    cc.rpi_us = 9000000u;
    cc.timeout_mult = 7;
    dr_conn_t *cn = open_established(c, &cc);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    assert_int_equal(st->t2o_api_us, 9000000u);
    assert_true(st->timeout_us64 == 4608000000ull);
    assert_int_equal(st->timeout_us, UINT32_MAX); /* saturated, not wrapped */
    push_t2o_seq(F.t2o_cid, 1, 1, 1, 96);
    dr_client_process(c);
    uint64_t taken = F.now;
    /* 400 s of silence (more than the 313 s of the overflow): alive */
    F.now = taken + 400000000ull;
    dr_client_process(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_true(dr_client_next_deadline(c) <= taken + 4608000000ull);
    F.now = taken + 4607000000ull;
    dr_client_process(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    F.now = taken + 4608000000ull;
    dr_client_process(c);
    assert_int_equal(st->timeouts, 1);
    assert_int_not_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    dr_client_free(c);
}

/* Issue 29, item 8: a Forward Open answered with another service's reply
 * (here a Forward Close's, 0xCE) is not a success, whatever its data: the
 * connection is not established on it (DR_EMISMATCH), and, as after an
 * open that got no answer, its triad is closed before the next open. */
static void test_class1_open_wrong_service(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = connected();
    dr_conn_config_t cc = conn_config(&log);
    F.next_rsp_service = DR_CIP_SVC_FORWARD_CLOSE | DR_CIP_REPLY;
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    dr_client_start(c);
    for (int i = 0; i < 100 && F.fwd_open == 0; i++)
        run_for(c, 1);
    run_for(c, 1);
    assert_int_equal(F.fwd_open, 1);
    assert_int_not_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(log.why, DR_EMISMATCH);
    wait_established(c, cn);
    assert_int_equal(F.fwd_open, 2);
    assert_int_equal(F.fwd_close, 1); /* the first open's triad */
    dr_client_free(c);
}

/* Issue 19: a Forward Open that goes unanswered (the path to the adapter
 * is down) resets the session by tcp_abort, so that nothing queued behind
 * it reaches the adapter later; the next session closes that open's triad
 * before the connection opens again, in case the adapter did open it; once
 * that close is answered it is not sent again. */
static void test_class1_open_timeout_resets(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client(); /* request timeout 100 ms */
    dr_conn_config_t cc = conn_config(&log); /* T->O timeout 40 ms */
    dr_conn_t *cn = open_established(c, &cc);
    push_t2o(F.t2o_cid, 1, 96);
    dr_client_process(c);
    /* the path goes: no T->O, no reply to anything */
    F.cip = cip_silent;
    F.ncm = 0;
    for (int i = 0; i < 1000 && F.aborts == 0; i++)
        run_for(c, 1);
    assert_int_equal(F.aborts, 1);
    assert_int_equal(F.closes, 1); /* the abort, no other close */
    /* what went out: the close of the timed-out connection, one open */
    assert_int_equal(F.ncm, 2);
    assert_int_equal(F.cm[0].service, DR_CIP_SVC_FORWARD_CLOSE);
    assert_int_equal(F.cm[1].service, DR_CIP_SVC_FORWARD_OPEN);
    uint16_t lost = F.cm[1].serial;
    assert_int_equal(dr_conn_state(cn), DR_CONN_RECONNECTING);
    /* the path returns: the new session closes the lost open first */
    F.cip = NULL;
    F.ncm = 0;
    wait_established(c, cn);
    assert_int_equal(F.ncm, 2);
    assert_int_equal(F.cm[0].service, DR_CIP_SVC_FORWARD_CLOSE);
    assert_int_equal(F.cm[0].serial, lost);
    assert_int_equal(F.cm[1].service, DR_CIP_SVC_FORWARD_OPEN);
    assert_int_not_equal(F.cm[1].serial, lost);
    /* answered: the next reopen (after a timeout) does not close it again */
    F.ncm = 0;
    run_for(c, 2100); /* no T->O: the first-packet grace, then reopened */
    assert_true(dr_conn_stats(cn)->timeouts >= 1);
    assert_true(F.ncm >= 2);
    for (unsigned i = 0; i < F.ncm; i++)
        assert_int_not_equal(F.cm[i].serial, lost);
    assert_int_equal(F.aborts, 1);
    dr_client_free(c);
}

/* Issue 19: a Forward Open answered after its connection was removed, or
 * while the client closes, opened a connection nobody produces for: it is
 * closed at once by the triad of the reply, and a close waits for it. */
static void test_class1_late_open_closed(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = connected();
    dr_conn_config_t cc = conn_config(&log);
    F.hold_replies = true; /* the adapter is slow */
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    dr_client_start(c);
    run_for(c, 2);
    assert_int_equal(dr_conn_state(cn), DR_CONN_OPENING);
    assert_int_equal(F.ncm, 1);
    uint16_t s = F.cm[0].serial;
    dr_conn_remove(cn); /* a reload took it away */
    release_replies(&F); /* and the reply comes: success */
    run_for(c, 5);
    assert_int_equal(F.fwd_close, 1);
    assert_int_equal(F.ncm, 2);
    assert_int_equal(F.cm[1].service, DR_CIP_SVC_FORWARD_CLOSE);
    assert_int_equal(F.cm[1].serial, s);
    /* the client closes while an open is out: the close waits for its
     * reply, closes that connection, and only then unregisters */
    F.hold_replies = true;
    F.ncm = 0;
    cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    run_for(c, 2);
    assert_int_equal(F.ncm, 1);
    s = F.cm[0].serial;
    dr_client_close_start(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_CLOSED);
    run_for(c, 5);
    assert_int_equal(F.unregister, 0);
    release_replies(&F);
    for (int i = 0; i < 200 && !dr_client_closed(c); i++)
        run_for(c, 1);
    assert_true(dr_client_closed(c));
    assert_int_equal(F.ncm, 2);
    assert_int_equal(F.cm[1].service, DR_CIP_SVC_FORWARD_CLOSE);
    assert_int_equal(F.cm[1].serial, s);
    assert_int_equal(F.unregister, 1);
    dr_client_free(c);
}

/* Issue 19: the originator serial, FNV-1a over the host's identity, a 0
 * byte and the name (docs/configuration.md); a configured serial is the
 * one in every Forward Open and Forward Close. */
static void test_originator_serial(void **state)
{
    (void)state;
    assert_int_equal(dr_originator_serial("", ""), 0x050C5D1Fu);
    assert_int_equal(dr_originator_serial("abc", "r0"), 0x4074118Bu);
    assert_int_equal(dr_originator_serial("0123456789abcdef0123456789abcdef", "arm1"),
                     0xA7B349AAu);
    assert_int_equal(dr_originator_serial(NULL, NULL), dr_originator_serial("", ""));
    assert_int_not_equal(dr_originator_serial("ab", "cr0"), dr_originator_serial("abc", "r0"));
    assert_int_equal(dr_originator_serial_local("r0"), dr_originator_serial_local("r0"));
    assert_int_not_equal(dr_originator_serial_local("r0"), dr_originator_serial_local("r1"));
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg = config(&fake_ops);
    cfg.serial = 0xC0FFEE01u;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    dr_client_start(c);
    wait_established(c, cn);
    dr_conn_remove(cn);
    run_for(c, 5);
    assert_int_equal(F.ncm, 2);
    assert_int_equal(F.cm[0].orig, 0xC0FFEE01u);
    assert_int_equal(F.cm[1].service, DR_CIP_SVC_FORWARD_CLOSE);
    assert_int_equal(F.cm[1].orig, 0xC0FFEE01u);
    dr_client_free(c);
}

/* A reply with an item after its declared ones (an adapter echoing our
 * 0x8001 item): the refusal's CIP status still surfaces, and a success
 * still opens the connection; the extra bytes are counted. */
static void test_class1_trailing_item(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_t *c = new_client();
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    F.trailing_item = true;
    F.fo_general = 0x01;
    F.fo_ext = 0x0106; /* ownership conflict */
    dr_client_start(c);
    run_for(c, 5);
    assert_int_equal(dr_conn_state(cn), DR_CONN_RECONNECTING);
    assert_int_equal(log.why, DR_CIP(0x01, 0x0106));
    assert_true(dr_client_stats(c)->replies_trailing >= 1);
    F.fo_general = 0;
    wait_established(c, cn);
    assert_int_equal(dr_conn_stats(cn)->o2t_cid, F.o2t_cid);
    /* explicit replies too */
    uint64_t before = dr_client_stats(c)->replies_trailing;
    uint8_t buf[36];
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, sizeof buf), DR_OK);
    assert_int_equal(dr_client_stats(c)->replies_trailing, before + 1);
    dr_client_free(c);
}

/* o2t_follow_us: an O->T packet due within the window goes out with the
 * arriving T->O packet (one wake-up for both), on the shared port the
 * gateway uses; arrivals outside the window move the O->T schedule after
 * three in a row, later, without sending, by half a window a period at
 * most; with no window, arrivals never send. */
static void test_class1_follow(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg;
    dr_udp_port_t *p = shared_port(&fake_batch_ops, &cfg);
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_conn_config_t cc = conn_config(&log); /* RPI 10 ms */
    cc.o2t_follow_us = 2500;
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    dr_client_start(c);
    dr_pollfd_t fds[DR_CLIENT_MAX_FDS];
    (void)dr_client_pollfds(c, fds, DR_CLIENT_MAX_FDS); /* the timer is polled */
    for (int i = 0; i < 50 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++) {
        F.now += 1000u;
        dr_client_process(c);
    }
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    uint16_t seq = 1;

    /* due in 1 ms: sent on arrival, the deadline keeps its grid */
    uint64_t d = dr_client_next_deadline(c);
    assert_int_equal(F.armed, d);
    unsigned sent = F.udp_sent;
    F.now = d - 1000u;
    push_t2o(F.t2o_cid, seq++, 96);
    dr_udp_port_process(p);
    assert_int_equal(F.udp_sent, sent + 1);
    assert_int_equal(dr_client_next_deadline(c), d + 10000u);
    assert_int_equal(F.armed, d + 10000u); /* the timer moved past it */
    d += 10000u;

    /* due in 6 ms, outside the window: not sent; the timer sends at the
     * deadline. The third such arrival in a row moves the schedule. */
    for (int miss = 1; miss <= 2; miss++) {
        sent = F.udp_sent;
        F.now = d - 6000u;
        push_t2o(F.t2o_cid, seq++, 96);
        dr_udp_port_process(p);
        assert_int_equal(F.udp_sent, sent);
        assert_int_equal(dr_client_next_deadline(c), d);
        F.now = d;
        dr_client_process_ready(c, NULL, 0);
        assert_int_equal(F.udp_sent, sent + 1);
        d += 10000u;
    }
    /* The third: nothing goes now (the last packet left only 4 ms ago),
     * and the deadline moves later, towards half a window after the next
     * arrival (t + 11.25 ms), but by half a window at most: to d + 1.25 ms,
     * an interval of 11.25 ms. The packet due then is not left out (it
     * was, when the move went in one step: an interval of 15.25 ms). */
    sent = F.udp_sent;
    uint64_t t = d - 6000u;
    F.now = t;
    push_t2o(F.t2o_cid, seq++, 96);
    dr_udp_port_process(p);
    assert_int_equal(F.udp_sent, sent);
    assert_int_equal(dr_client_next_deadline(c), d + 1250u);
    /* each further miss moves it again, half a window a period: the timer
     * sends at d + 1.25, + 12.5 and + 23.75 ms (intervals of 11.25 ms),
     * the arrivals at d + 4, + 14 and + 24 ms each move the next one */
    static const uint32_t timer_at[3] = {1250u, 12500u, 23750u};
    static const uint32_t moved_to[3] = {12500u, 23750u, 35000u};
    for (int i = 0; i < 3; i++) {
        sent = F.udp_sent;
        F.now = d + timer_at[i];
        dr_client_process_ready(c, NULL, 0);
        assert_int_equal(F.udp_sent, sent + 1);
        F.now = t + (uint64_t)(i + 1) * 10000u;
        push_t2o(F.t2o_cid, seq++, 96);
        dr_udp_port_process(p);
        assert_int_equal(F.udp_sent, sent + 1);
        assert_int_equal(dr_client_next_deadline(c), d + moved_to[i]);
    }
    /* from now on each arrival sends, 1 ms before the deadline (inside
     * the window), and the deadline keeps its grid */
    for (int i = 4; i <= 6; i++) {
        sent = F.udp_sent;
        F.now = t + (uint64_t)i * 10000u;
        push_t2o(F.t2o_cid, seq++, 96);
        dr_udp_port_process(p);
        assert_int_equal(F.udp_sent, sent + 1);
        assert_int_equal(dr_client_next_deadline(c), t + (uint64_t)(i + 1) * 10000u + 1000u);
    }
    assert_int_equal(log.data, seq - 1);

    /* no window: an arrival just before the deadline sends nothing */
    dr_conn_remove(cn);
    cc.o2t_follow_us = 0;
    cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    for (int i = 0; i < 50 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++) {
        F.now += 1000u;
        dr_client_process(c);
    }
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    for (int i = 0; i < 4; i++) {
        d = dr_client_next_deadline(c);
        sent = F.udp_sent;
        F.now = d - 100u;
        push_t2o(F.t2o_cid, (uint16_t)(i + 1), 96);
        dr_udp_port_process(p);
        assert_int_equal(F.udp_sent, sent);
        F.now = d;
        dr_client_process_ready(c, NULL, 0);
        assert_int_equal(F.udp_sent, sent + 1);
    }
    dr_client_free(c);
    dr_udp_port_free(p);
}

/* ---- firmware: static storage, no descriptors, non-blocking close ------------------ */

/* dr_client_init / dr_udp_port_init in caller storage: the storage and the
 * transport are checked, the client lives in the storage given. */
static void test_init_static(void **state)
{
    (void)state;
    static dr_client_storage_t st;
    static dr_udp_port_storage_t pst;
    dr_status_t err = DR_OK;
    dr_client_config_t cfg = config(&fake_ops);
    assert_true(dr_client_size() <= sizeof st);
    assert_true(dr_udp_port_size() <= sizeof pst);
    assert_null(dr_client_init(&st, dr_client_size() - 1, &cfg, &err));
    assert_int_equal(err, DR_EINVAL);
    assert_null(dr_client_init(st.bytes + 1, sizeof st - 1, &cfg, &err)); /* misaligned */
    assert_int_equal(err, DR_EINVAL);
    assert_null(dr_client_init(NULL, sizeof st, &cfg, &err));
    cfg.transport.ops = NULL; /* only dr_client_new defaults to POSIX */
    assert_null(dr_client_init(&st, sizeof st, &cfg, &err));
    assert_int_equal(err, DR_EINVAL);
    dr_transport_ops_t ops = fake_ops;
    ops.tcp_send = NULL; /* a required call missing */
    cfg.transport.ops = &ops;
    assert_null(dr_client_init(&st, sizeof st, &cfg, &err));
    ops = fake_ops;
    ops.timer_arm = NULL; /* a timer that cannot be armed */
    assert_null(dr_client_init(&st, sizeof st, &cfg, &err));
    assert_int_equal(err, DR_EINVAL);
    cfg.transport.ops = &fake_ops;
    F.timer_st = DR_EIO;
    assert_null(dr_client_init(&st, sizeof st, &cfg, &err));
    assert_int_equal(err, DR_EIO);
    F.timer_st = DR_OK;
    dr_client_t *c = dr_client_init(&st, sizeof st, &cfg, &err);
    assert_ptr_equal(c, (void *)&st);
    assert_int_equal(err, DR_OK);
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    dr_client_deinit(c);
    assert_int_equal(F.unregister, 1);

    dr_transport_t tp = {NULL, NULL};
    assert_null(dr_udp_port_init(&pst, sizeof pst, NULL, 0, tp, &err));
    assert_int_equal(err, DR_EINVAL);
    tp.ops = &fake_ops;
    tp.ctx = &F;
    assert_null(dr_udp_port_init(&pst, dr_udp_port_size() - 1, NULL, 0, tp, &err));
    assert_int_equal(err, DR_EINVAL);
    dr_udp_port_t *p = dr_udp_port_init(&pst, sizeof pst, NULL, 0, tp, &err);
    assert_ptr_equal(p, (void *)&pst);
    cfg.shared_udp = p;
    c = dr_client_init(&st, sizeof st, &cfg, &err);
    assert_non_null(c);
    dr_client_deinit(c);
    dr_udp_port_deinit(p);
}

/* The fake's transport as firmware may have it: no fd, no wait, no timer. */
static const dr_transport_ops_t fake_bare_ops = {
    f_resolve,  f_tcp_connect, f_tcp_finish, f_tcp_send,   f_tcp_recv,
    f_udp_open, f_udp_send,    f_udp_recv,   NULL,         NULL,       f_close,
    f_now,      NULL,          NULL,         NULL,         NULL,       NULL,
    NULL,       NULL,       NULL};

typedef struct {
    unsigned calls;
    dr_status_t st;
    size_t len;
} call_log_t;

static void on_call(dr_client_t *c, dr_status_t st, const uint8_t *data, size_t len,
                    void *user)
{
    call_log_t *l = user;
    (void)c, (void)data;
    l->calls++;
    l->st = st;
    l->len = len;
}

/* The application's loop: the clock jumps to the client's next deadline
 * (at most 1 ms on: sockets may have data sooner), then process. */
static void drive(dr_client_t *c, unsigned ms)
{
    uint64_t end = F.now + (uint64_t)ms * 1000u;
    while (F.now < end) {
        uint64_t d = dr_client_next_deadline(c);
        F.now = d > F.now && d < F.now + 1000u ? d : F.now + 1000u;
        dr_client_process(c);
    }
}

/* Driven by dr_client_next_deadline + dr_client_process only: the blocking
 * calls refuse, the async ones, Class 1 and the close work. */
static void test_no_descriptors(void **state)
{
    (void)state;
    static dr_client_storage_t st;
    conn_log_t log;
    call_log_t call;
    memset(&log, 0, sizeof log);
    memset(&call, 0, sizeof call);
    dr_client_config_t cfg = config(&fake_bare_ops);
    dr_client_t *c = dr_client_init(&st, sizeof st, &cfg, NULL);
    assert_non_null(c);
    dr_pollfd_t fds[DR_CLIENT_MAX_FDS];
    assert_int_equal(dr_client_pollfds(c, fds, DR_CLIENT_MAX_FDS), 0);
    assert_int_equal(dr_client_connect_sync(c), DR_EINVAL);
    assert_int_equal(dr_client_run_once(c, 1), DR_EINVAL);
    dr_transport_t tp = {&fake_bare_ops, &F};
    assert_int_equal(dr_discover("robot", 0, 10, tp, NULL, NULL, NULL), DR_EINVAL);
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    dr_client_start(c);
    drive(c, 5);
    assert_true(dr_client_ready(c));
    uint8_t buf[64];
    assert_int_equal(dr_client_get_attr_sync(c, 4, 101, 3, buf, sizeof buf, NULL), DR_EINVAL);
    uint8_t path[12];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, DR_CIP_CLASS_ASSEMBLY, 101, DR_CIP_ASM_ATTR_DATA);
    assert_int_equal(dr_client_call_async(c, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, w.len,
                                          NULL, 0, on_call, &call), DR_OK);
    drive(c, 2);
    assert_int_equal(call.calls, 1);
    assert_int_equal(call.st, DR_OK);
    assert_int_equal(call.len, 36);
    /* Class 1: open, data in, O->T out on the deadlines */
    drive(c, 5);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    unsigned sent = F.udp_sent;
    push_t2o(F.t2o_cid, 1, 96);
    drive(c, 30);
    assert_int_equal(log.data, 1);
    assert_true(F.udp_sent >= sent + 2);
    assert_int_equal(dr_conn_stats(cn)->timeouts, 0);
    /* the close goes through the loop, phase by phase */
    dr_client_close_start(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_CLOSED);
    assert_int_equal(F.fwd_close, 1);
    assert_false(dr_client_closed(c));
    assert_int_equal(dr_client_call_async(c, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, w.len,
                                          NULL, 0, on_call, &call), DR_ESESSION);
    drive(c, 1); /* the Forward Close reply: UnRegisterSession goes */
    assert_int_equal(F.unregister, 1);
    drive(c, 2); /* the peer closes */
    assert_true(dr_client_closed(c));
    dr_client_deinit(c);
    assert_int_equal(F.unregister, 1);
}

/* A peer that never answers the Forward Close: the close still ends, at
 * the request timeout and then the 500 ms bound for the peer's close, and
 * its deadline is the client's next deadline meanwhile. */
static void test_close_start_silent_peer(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg = config(&fake_bare_ops);
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    dr_client_start(c);
    drive(c, 10);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    F.cip = cip_silent;
    uint64_t t0 = F.now;
    dr_client_close_start(c);
    assert_true(dr_client_next_deadline(c) <= t0 + 100000u);
    drive(c, 90);
    assert_false(dr_client_closed(c));
    assert_int_equal(F.unregister, 0);
    drive(c, 20); /* the 100 ms request timeout passed: UnRegisterSession */
    assert_int_equal(F.unregister, 1);
    assert_true(dr_client_closed(c)); /* and the fake peer closed at once */
    dr_client_free(c);
}

/* T->O packets on a shared port find their connection by the ID alone
 * (lib/client_internal.h, struct dr_udp_port): every one reaches its own among many
 * clients and connections, a closed connection's ID matches nothing, a
 * freed client's slot is taken again by a new client, IDs nobody owns are
 * dropped, and a target that chose its own T->O ID is still served. */
#define CID_CLIENTS 20
#define CID_CONNS 3
static void establish_on(dr_client_t *c, dr_conn_t **cn, unsigned n, conn_log_t *log)
{
    dr_conn_config_t cc = conn_config(log);
    for (unsigned i = 0; i < n; i++)
        assert_non_null(cn[i] = dr_conn_add(c, &cc, NULL));
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    dr_client_start(c);
    for (unsigned i = 0; i < n; i++)
        wait_established(c, cn[i]);
}

static void test_cid_lookup(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg;
    dr_udp_port_t *p = shared_port(&fake_batch_ops, &cfg);
    dr_client_t *c[CID_CLIENTS];
    dr_conn_t *cn[CID_CLIENTS][CID_CONNS];
    for (unsigned k = 0; k < CID_CLIENTS; k++) {
        assert_non_null(c[k] = dr_client_new(&cfg, NULL));
        establish_on(c[k], cn[k], CID_CONNS, &log);
    }
    /* every connection has its own ID; a packet for each, in an order
     * unlike the clients', reaches exactly that connection */
    for (unsigned k = 0; k < CID_CLIENTS; k++)
        for (unsigned i = 0; i < CID_CONNS; i++)
            for (unsigned k2 = 0; k2 < CID_CLIENTS; k2++)
                for (unsigned i2 = 0; i2 < CID_CONNS; i2++)
                    if (k2 != k || i2 != i)
                        assert_int_not_equal(dr_conn_stats(cn[k][i])->t2o_cid,
                                             dr_conn_stats(cn[k2][i2])->t2o_cid);
    for (unsigned j = 0; j < CID_CLIENTS * CID_CONNS; j++) {
        unsigned k = CID_CLIENTS - 1u - j % CID_CLIENTS, i = j / CID_CLIENTS;
        push_t2o(dr_conn_stats(cn[k][i])->t2o_cid, (uint16_t)(100 + k), 96);
        if (F.udp_in_n == MAX_UDP_IN || j + 1 == CID_CLIENTS * CID_CONNS)
            dr_udp_port_process(p);
    }
    for (unsigned k = 0; k < CID_CLIENTS; k++)
        for (unsigned i = 0; i < CID_CONNS; i++) {
            size_t len = 0;
            assert_int_equal(dr_conn_stats(cn[k][i])->rx_packets, 1);
            assert_int_equal(dr_conn_input(cn[k][i], &len)[0], (uint8_t)(100 + k));
        }
    /* IDs nobody owns: near ours (the next slot, the next generation) or
     * anything; dropped, counted by no connection */
    uint32_t mine = dr_conn_stats(cn[4][1])->t2o_cid;
    push_t2o(mine + 1u, 200, 96);
    push_t2o(mine + 20000u, 200, 96);
    push_t2o(0xFFFFFFFFu, 200, 96);
    push_t2o(0, 200, 96);
    dr_udp_port_process(p);
    assert_int_equal(F.udp_in_n, 0);
    for (unsigned k = 0; k < CID_CLIENTS; k++)
        for (unsigned i = 0; i < CID_CONNS; i++) {
            assert_int_equal(dr_conn_stats(cn[k][i])->rx_packets, 1);
            assert_int_equal(dr_conn_stats(cn[k][i])->rx_bad, 0);
        }
    /* a removed connection's ID matches nothing, also when its slot is
     * used again: the new connection has a new ID */
    uint32_t gone = dr_conn_stats(cn[7][2])->t2o_cid;
    dr_conn_remove(cn[7][2]);
    push_t2o(gone, 300, 96);
    dr_udp_port_process(p);
    dr_conn_config_t cc = conn_config(&log);
    dr_conn_t *again = dr_conn_add(c[7], &cc, NULL);
    assert_ptr_equal(again, cn[7][2]); /* the same slot */
    wait_established(c[7], again);
    assert_int_not_equal(dr_conn_stats(again)->t2o_cid, gone);
    push_t2o(gone, 301, 96);
    dr_udp_port_process(p);
    assert_int_equal(dr_conn_stats(again)->rx_packets, 0);
    push_t2o(dr_conn_stats(again)->t2o_cid, 302, 96);
    dr_udp_port_process(p);
    assert_int_equal(dr_conn_stats(again)->rx_packets, 1);
    /* a freed client's slot goes to the next client; the old IDs of that
     * slot reach nobody, the new ones their connections */
    uint32_t old[CID_CONNS];
    for (unsigned i = 0; i < CID_CONNS; i++)
        old[i] = dr_conn_stats(cn[3][i])->t2o_cid;
    dr_client_free(c[3]);
    assert_non_null(c[3] = dr_client_new(&cfg, NULL));
    establish_on(c[3], cn[3], CID_CONNS, &log);
    for (unsigned i = 0; i < CID_CONNS; i++) {
        assert_int_equal(dr_conn_stats(cn[3][i])->t2o_cid % (DR_UDP_PORT_MAX_CLIENTS * DR_CLIENT_MAX_CONNS),
                         old[i] % (DR_UDP_PORT_MAX_CLIENTS * DR_CLIENT_MAX_CONNS));
        assert_int_not_equal(dr_conn_stats(cn[3][i])->t2o_cid, old[i]);
        push_t2o(old[i], 400, 96);
        push_t2o(dr_conn_stats(cn[3][i])->t2o_cid, 401, 96);
    }
    dr_udp_port_process(p);
    for (unsigned i = 0; i < CID_CONNS; i++) {
        size_t len = 0;
        assert_int_equal(dr_conn_stats(cn[3][i])->rx_packets, 1);
        assert_int_equal(dr_conn_input(cn[3][i], &len)[0], (uint8_t)401);
    }
    /* a target that answers with a T->O ID of its own choosing */
    F.fo_own_t2o = true;
    dr_client_free(c[9]);
    assert_non_null(c[9] = dr_client_new(&cfg, NULL));
    establish_on(c[9], cn[9], 1, &log);
    uint32_t theirs = dr_conn_stats(cn[9][0])->t2o_cid;
    assert_int_equal(theirs & 0xF000u, 0x7000u);
    push_t2o(theirs, 500, 96);
    dr_udp_port_process(p);
    assert_int_equal(dr_conn_stats(cn[9][0])->rx_packets, 1);
    /* once it is closed, its ID reaches nobody */
    dr_conn_remove(cn[9][0]);
    push_t2o(theirs, 501, 96);
    dr_udp_port_process(p);
    assert_int_equal(dr_conn_stats(cn[9][0])->rx_packets, 1);
    for (unsigned k = 0; k < CID_CLIENTS; k++)
        dr_client_free(c[k]);
    dr_udp_port_free(p);
}

/* follow_case: T->O arrivals every `period` us (an adapter whose clock
 * runs slow or fast against ours), each moved by a jitter of up to
 * `jitter` us, the first `phase` us after our first O->T deadline. */
typedef struct {
    const char *what;
    uint32_t period, jitter;
    int32_t phase;
} follow_case_t;

/* One connection at RPI 10 ms with a 2.5 ms follow window against the
 * arrivals of fc for 20 s of virtual time: the O->T packets, as sent. */
static void follow_run(const follow_case_t *fc)
{
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg;
    dr_udp_port_t *p = shared_port(&fake_batch_ops, &cfg);
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_conn_config_t cc = conn_config(&log);
    cc.o2t_follow_us = 2500;
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    dr_client_start(c);
    for (int i = 0; i < 50 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++) {
        F.now += 1000u;
        dr_client_process(c);
    }
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    uint64_t start = dr_client_next_deadline(c), end = start + 20000000u;
    uint64_t nominal = (uint64_t)((int64_t)start + fc->phase), arrival = nominal;
    uint64_t rng = 0x9E3779B97F4A7C15ull, first = 0, last = 0, min_gap = UINT64_MAX, max_gap = 0;
    unsigned n = 0, on_arrival = 0, arrivals = 0;
    uint16_t seq = 1;
    while (F.now < end) {
        uint64_t d = dr_client_next_deadline(c);
        unsigned before = F.udp_sent;
        bool arrived = arrival <= d;
        if (arrived) {
            F.now = arrival > F.now ? arrival : F.now;
            push_t2o(F.t2o_cid, seq++, 96);
            dr_udp_port_process(p);
            arrivals++;
            /* the next one: nominal time, jittered by up to +-jitter */
            nominal += fc->period;
            rng = rng * 6364136223846793005ull + 1442695040888963407ull;
            arrival = nominal + (rng >> 33) % (2u * fc->jitter + 1u) - fc->jitter;
        } else {
            F.now = d;
            dr_client_process_ready(c, NULL, 0);
        }
        for (unsigned k = before; k < F.udp_sent; k++, n++) {
            if (n > 0 && F.now - last < min_gap)
                min_gap = F.now - last;
            if (n > 0 && F.now - last > max_gap)
                max_gap = F.now - last;
            if (n == 0)
                first = F.now;
            last = F.now;
            on_arrival += arrived;
        }
    }
    print_message("%s: %u O->T packets in %.3f s (%u on arrival), shortest gap %.3f ms, "
                  "longest %.3f ms\n", fc->what, n, (double)(last - first) / 1e6, on_arrival,
                  (double)min_gap / 1e3, (double)max_gap / 1e3);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED); /* never timed out */
    /* never closer than API - window (10 ms - 2.5 ms) */
    assert_true(min_gap >= 7500u);
    /* never further apart than API + window (10 ms + 2.5 ms): one packet
     * sent a window early, the next on its deadline; the schedule moves
     * later by at most half a window per period (issue 30) */
    assert_true(max_gap <= 12500u);
    /* never more than one per API: n - 1 intervals fit in the span, give
     * or take the window the first one may leave early */
    assert_true((uint64_t)(n - 1u) * 10000u <= last - first + 2500u);
    /* and it still follows: most packets leave with an arrival */
    assert_true(on_arrival * 2u >= n);
    assert_true(n * 10u >= arrivals * 9u && arrivals > 1900u);
    dr_client_free(c);
    dr_udp_port_free(p);
}

/* o2t_follow_us keeps the promises of docs/configuration.md whatever the
 * adapter's clock: an adapter 1.1 % slow (98.9 packets/s, as measured on a
 * real one: the old code then sent 104.7/s, with a timer packet and an
 * arrival's packet 0.02 ms apart), 1.1 % fast, and one on our clock whose
 * packets arrive just after our deadlines, jittered to either side. */
static void test_class1_follow_spacing(void **state)
{
    (void)state;
    static const follow_case_t cases[] = {
        {"adapter 1.1 % slow", 10111u, 0u, 100},
        {"adapter 1.1 % fast", 9891u, 0u, 100},
        {"same clock, jitter", 10000u, 150u, 100},
        {"adapter 1.1 % fast, jitter", 9891u, 1000u, 100},
        {"same clock, just early", 10000u, 0u, -100},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        unsigned fo = F.fwd_open;
        follow_run(&cases[i]);
        assert_int_equal(F.fwd_open, fo + 1u);
    }
}

/* dr_client_next_deadline is kept between calls (lib/client_loop.c): after each
 * event that moves it, it is the new one at once, also when a state
 * callback asked in the middle of the change. Shared port, O->T on
 * arrival (o2t_follow_us), RPI 10 ms, timeout 40 ms, backoff 10 ms,
 * request timeout 100 ms. */
static void test_deadline_cache(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg;
    dr_udp_port_t *p = shared_port(&fake_batch_ops, &cfg);
    uint64_t epoch = F.now;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    log.ask = c;
    assert_int_equal(dr_client_next_deadline(c), UINT64_MAX);
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    dr_client_start(c); /* and reconnect by itself */
    assert_int_equal(dr_client_next_deadline(c), UINT64_MAX);
    /* a connection added to a ready session is due at once */
    dr_conn_config_t cc = conn_config(&log);
    cc.o2t_follow_us = 2500;
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_int_equal(dr_client_next_deadline(c), 0);
    /* its Forward Open is out: the request's timeout */
    F.cip = cip_silent;
    dr_client_process(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_OPENING);
    assert_int_equal(dr_client_next_deadline(c), F.now + 100000u);
    /* unanswered: the session is reset (issue 19), and comes back after
     * its backoff, 10 ms after the timeout */
    F.now += 100000u;
    dr_client_process(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_RECONNECTING);
    assert_int_equal(F.aborts, 1);
    assert_int_equal(dr_client_next_deadline(c), F.now + 10000u);
    /* opened: the first O->T deadline on the client's grid */
    F.cip = NULL;
    F.now += 10000u;
    /* connect, register, the lost open's close and the open, answered */
    for (int i = 0; i < 10 && dr_conn_state(cn) != DR_CONN_ESTABLISHED; i++)
        dr_client_process(c);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    uint64_t grid = epoch + ((F.now - epoch) / 10000u + 1u) * 10000u;
    assert_int_equal(dr_client_next_deadline(c), grid);
    /* new outputs do not move it */
    uint8_t out[96] = {1};
    assert_int_equal(dr_conn_set_output(cn, out, sizeof out), DR_OK);
    assert_int_equal(dr_client_next_deadline(c), grid);
    /* a T->O packet 1 ms before it, read by the port alone: the O->T
     * packet goes with it and the deadline is the next grid point */
    F.now = grid - 1000u;
    unsigned sent = F.udp_sent;
    push_t2o(F.t2o_cid, 1, 96);
    dr_udp_port_process(p);
    assert_int_equal(F.udp_sent, sent + 1);
    assert_int_equal(dr_client_next_deadline(c), grid + 10000u);
    /* the deadline itself: one packet, the next grid point */
    F.now = grid + 10000u;
    dr_client_process(c);
    assert_int_equal(F.udp_sent, sent + 2);
    assert_int_equal(dr_client_next_deadline(c), grid + 20000u);
    /* silence until the timeout (40 ms after the packet): timed out, a
     * Forward Close out and a new open after the backoff */
    uint64_t rx = grid - 1000u;
    while (F.now < rx + 40000u) {
        F.now = dr_client_next_deadline(c);
        dr_client_process(c);
    }
    assert_int_equal(dr_conn_state(cn), DR_CONN_RECONNECTING);
    assert_int_equal(dr_client_next_deadline(c), F.now + 10000u);
    /* removed: nothing left but the Forward Close's reply wait */
    wait_established(c, cn);
    uint64_t t = F.now;
    dr_conn_remove(cn);
    assert_int_equal(dr_client_next_deadline(c), t + 100000u);
    dr_client_process(c); /* the reply */
    assert_int_equal(dr_client_next_deadline(c), UINT64_MAX);
    /* close: the Forward Close's timeout bounds the wait */
    assert_non_null(cn = dr_conn_add(c, &cc, NULL));
    wait_established(c, cn);
    F.cip = cip_silent;
    t = F.now;
    dr_client_close_start(c);
    assert_int_equal(dr_client_next_deadline(c), t + 100000u);
    dr_client_free(c);
    dr_udp_port_free(p);
}

/* drgatewayd's set-up (gateway/core/link.c): a shared port and a transport
 * with descriptors but no timer, the daemon's loop waking at
 * dr_client_next_deadline. The client still sends one O->T packet per RPI
 * on its own deadlines (strict timing), and still times out a connection
 * whose T->O packets stop, at exactly the timeout. */
static const dr_transport_ops_t fake_untimed_ops = {
    f_resolve,  f_tcp_connect, f_tcp_finish, f_tcp_send,   f_tcp_recv,
    f_udp_open, f_udp_send,    f_udp_recv,   NULL,         NULL,       f_close,
    f_now,      f_fd,          f_wait,       f_udp_send_batch, f_udp_recv_batch, f_tcp_abort,
    NULL,       NULL,       NULL};

static void test_loop_timer(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg;
    dr_udp_port_t *p = shared_port(&fake_untimed_ops, &cfg);
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    dr_conn_t *cn[1];
    establish_on(c, cn, 1, &log);
    /* only the TCP socket to poll: no timer, the shared port is the
     * application's */
    dr_pollfd_t fds[DR_CLIENT_MAX_FDS];
    assert_int_equal(dr_client_pollfds(c, fds, DR_CLIENT_MAX_FDS), 1);
    assert_int_equal(fds[0].fd, FD_OF(TCP_H));
    /* 100 RPIs: a T->O packet in the middle of each, the loop waking at
     * the deadline: exactly one O->T packet per RPI, each at its deadline */
    unsigned sent = F.udp_sent;
    uint64_t d = dr_client_next_deadline(c), first = d;
    for (unsigned i = 0; i < 100; i++) {
        F.now = d - 5000u;
        push_t2o(F.t2o_cid, (uint16_t)(i + 1), 96);
        dr_udp_port_process(p);
        assert_int_equal(dr_client_next_deadline(c), d); /* strict: unmoved */
        assert_int_equal(F.udp_sent, sent + i);
        F.now = d;
        dr_client_process_ready(c, NULL, 0); /* the timers only */
        assert_int_equal(F.udp_sent, sent + i + 1);
        d = dr_client_next_deadline(c);
        assert_int_equal(d, first + (i + 1u) * 10000u);
    }
    assert_int_equal(dr_conn_stats(cn[0])->rx_packets, 100);
    /* silence: O->T goes on at the RPI until the timeout, 40 ms after the
     * last packet, then the connection times out, at that instant */
    uint64_t last_rx = F.now - 5000u, out = F.udp_sent;
    while (dr_conn_state(cn[0]) == DR_CONN_ESTABLISHED) {
        F.now = dr_client_next_deadline(c);
        assert_true(F.now <= last_rx + 40000u);
        dr_client_process_ready(c, NULL, 0);
    }
    assert_int_equal(F.now, last_rx + 40000u);
    assert_int_equal(log.last, DR_CONN_RECONNECTING);
    assert_int_equal(dr_conn_stats(cn[0])->timeouts, 1);
    assert_int_equal(F.udp_sent - out, 3); /* at 15, 25 and 35 ms after it */
    dr_client_free(c);
    dr_udp_port_free(p);
}

/* Clients on one shared port produce on the port's time grid: robots
 * connected at different moments are due at the same instants, so the
 * application's loop wakes up once per RPI for all of them (strict
 * timing). A client with a port of its own keeps its own grid. */
static void test_shared_grid(void **state)
{
    (void)state;
    conn_log_t log;
    memset(&log, 0, sizeof log);
    dr_client_config_t cfg;
    dr_udp_port_t *p = shared_port(&fake_untimed_ops, &cfg);
    uint64_t epoch = F.now;
    dr_client_t *c[3];
    dr_conn_t *cn[3][1];
    for (unsigned k = 0; k < 3; k++) {
        F.now += 3333u * (k + 1u); /* not on any grid point */
        assert_non_null(c[k] = dr_client_new(&cfg, NULL));
        establish_on(c[k], cn[k], 1, &log);
    }
    uint64_t d = dr_client_next_deadline(c[2]);
    assert_int_equal((d - epoch) % 10000u, 0);
    for (unsigned k = 0; k < 2; k++) {
        uint64_t dk = dr_client_next_deadline(c[k]);
        assert_int_equal((dk - epoch) % 10000u, 0);
        assert_true(dk <= d);
    }
    /* at d, all three are due together */
    F.now = d;
    unsigned sent = F.udp_sent;
    for (unsigned k = 0; k < 3; k++) {
        F.now = d; /* each process call at the same instant */
        dr_client_process_ready(c[k], NULL, 0);
        assert_int_equal(dr_client_next_deadline(c[k]), d + 10000u);
    }
    assert_int_equal(F.udp_sent, sent + 3);
    /* held: the process calls queue, one flush sends all three in one
     * batch call, and nothing twice */
    dr_udp_port_hold(p, true);
    sent = F.udp_sent;
    unsigned batches = F.udp_batches;
    uint64_t tx[3];
    for (unsigned k = 0; k < 3; k++)
        tx[k] = dr_conn_stats(cn[k][0])->tx_packets;
    for (unsigned k = 0; k < 3; k++) {
        F.now = d + 10000u;
        dr_client_process_ready(c[k], NULL, 0);
    }
    assert_int_equal(F.udp_sent, sent);
    dr_udp_port_flush(p);
    assert_int_equal(F.udp_sent, sent + 3);
    assert_int_equal(F.udp_batches, batches + 1);
    dr_udp_port_flush(p);
    assert_int_equal(F.udp_sent, sent + 3);
    for (unsigned k = 0; k < 3; k++)
        assert_int_equal(dr_conn_stats(cn[k][0])->tx_packets, tx[k] + 1);
    /* a blocking call of a held client sends at once, and what the other
     * clients held with it */
    F.now = d + 20000u;
    dr_client_process_ready(c[0], NULL, 0);
    dr_client_process_ready(c[1], NULL, 0);
    assert_int_equal(F.udp_sent, sent + 3); /* held */
    uint8_t buf[64];
    size_t len = 0;
    assert_int_equal(dr_client_get_attr_sync(c[2], 4, 101, 3, buf, sizeof buf, &len), DR_OK);
    assert_true(F.udp_sent >= sent + 6); /* all three, without a flush */
    /* clearing hold flushes */
    F.now = d + 40000u;
    dr_client_process_ready(c[0], NULL, 0);
    unsigned before = F.udp_sent;
    dr_udp_port_hold(p, false);
    assert_int_equal(F.udp_sent, before + 1);
    for (unsigned k = 0; k < 3; k++)
        dr_client_free(c[k]);
    dr_udp_port_free(p);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_state_names, setup),
        cmocka_unit_test_setup(test_new_refuses, setup),
        cmocka_unit_test_setup(test_new_says_why, setup),
        cmocka_unit_test_setup(test_shared_port_limits, setup),
        cmocka_unit_test_setup(test_connect_failures, setup),
        cmocka_unit_test_setup(test_session_callback, setup),
        cmocka_unit_test_setup(test_overlong_frame, setup),
        cmocka_unit_test_setup(test_reply_sizes, setup),
        cmocka_unit_test_setup(test_bad_replies, setup),
        cmocka_unit_test_setup(test_partial_sends_and_close, setup),
        cmocka_unit_test_setup(test_list_identity, setup),
        cmocka_unit_test_setup(test_async, setup),
        cmocka_unit_test_setup(test_async_send_fails, setup),
        cmocka_unit_test_setup(test_conn_add_refuses, setup),
        cmocka_unit_test_setup(test_class1_io, setup),
        cmocka_unit_test_setup(test_class1_no_first_packet, setup),
        cmocka_unit_test_setup(test_local_addr_binds_tcp, setup),
        cmocka_unit_test_setup(test_class1_refused_and_batch, setup),
        cmocka_unit_test_setup(test_class1_follow, setup),
        cmocka_unit_test_setup(test_class1_follow_spacing, setup),
        cmocka_unit_test_setup(test_class1_seq_repeat, setup),
        cmocka_unit_test_setup(test_class1_seq_forged, setup),
        cmocka_unit_test_setup(test_class1_seq_forged_live, setup),
        cmocka_unit_test_setup(test_class1_forged_source, setup),
        cmocka_unit_test_setup(test_class1_coarse_tick_unreported, setup),
        cmocka_unit_test_setup(test_class1_timeout_64bit, setup),
        cmocka_unit_test_setup(test_class1_open_wrong_service, setup),
        cmocka_unit_test_setup(test_class1_open_timeout_resets, setup),
        cmocka_unit_test_setup(test_class1_late_open_closed, setup),
        cmocka_unit_test_setup(test_originator_serial, setup),
        cmocka_unit_test_setup(test_class1_trailing_item, setup),
        cmocka_unit_test_setup(test_init_static, setup),
        cmocka_unit_test_setup(test_no_descriptors, setup),
        cmocka_unit_test_setup(test_close_start_silent_peer, setup),
        cmocka_unit_test_setup(test_cid_lookup, setup),
        cmocka_unit_test_setup(test_deadline_cache, setup),
        cmocka_unit_test_setup(test_loop_timer, setup),
        cmocka_unit_test_setup(test_shared_grid, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
