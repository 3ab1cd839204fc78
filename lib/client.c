/* SPDX-License-Identifier: MIT */
/*
 * EtherNet/IP originator: session, explicit messaging, Class 1 I/O.
 * Portable: all OS access goes through dr_transport_t.
 *
 * Shape: one non-blocking state machine driven by dr_client_process().
 * The session (TCP) and each Class 1 connection have their own state;
 * explicit requests are matched to replies by the 8-byte sender context.
 */
#include <stdint.h>
#include <string.h>

#include "drgate/client.h"

/* The bounds, all from drgate/config.h. */
#define MAX_REQS DR_CLIENT_MAX_REQS
#define TX_BUF DR_CLIENT_TX_BUF
#define UDP_BUF DR_CLIENT_UDP_BUF
#define RX_BATCH DR_CLIENT_RX_BATCH /* datagrams per receive call */
#define FO_TIMEOUT_MULT_DEFAULT 2 /* x16 */
#define FIRST_PACKET_GRACE_US 2000000u /* first T->O may lag the open */
#define CONN_MAX_STALE 2 /* unanswered Forward Opens kept per connection */
#define CLOSE_WAIT_US 500000u

typedef enum { S_IDLE, S_CONNECTING, S_REGISTERING, S_READY, S_BACKOFF } sess_t;

/* A close in progress (dr_client_close_start): Forward Closes answered,
 * then UnRegisterSession sent, then the peer's close awaited. */
typedef enum { CL_NONE, CL_FWD, CL_UNREG, CL_DRAIN } close_t;

typedef enum { R_USER, R_ASYNC, R_FWD_OPEN, R_FWD_CLOSE, R_LIST_IDENTITY } req_kind_t;

typedef struct {
    bool active, done;
    req_kind_t kind;
    uint64_t context;
    uint64_t deadline;
    dr_conn_t *conn;
    /* Forward Open / Close: the connection serial and the path's instances
     * (configuration, O->T point, T->O point), so that a connection the
     * adapter opened for a request nobody waits for any more can be
     * closed by its triad (close_orphan) even after its slot went. */
    uint16_t conn_serial;
    uint16_t path_inst[3];
    dr_call_cb cb;
    void *cb_user;
    dr_status_t status;
    uint8_t *rsp;
    size_t cap;
    size_t rsp_len;
} req_t;

/* The Class 1 UDP socket. Every client has one of its own, unless the
 * application shares one between clients (several robots, one port 2222):
 * datagrams are then handed to the client whose connection ID they carry.
 *
 * Finding that connection costs no scan: the T->O connection IDs are ours
 * to choose (point-to-point), and each one says where its connection
 * lives, cid % CID_SLOTS = client slot on the port * MAX_CONNS + connection
 * slot, with a per-client counter above that, so that a reopened
 * connection gets a new ID. A client keeps its slot on the port for its
 * life. Only a target that answers with a T->O ID of its own (allowed for
 * multicast) makes the port scan, and only while such a connection is
 * established (`foreign`). */
#define UDP_PORT_MAX_CLIENTS DR_UDP_PORT_MAX_CLIENTS
#define CID_SLOTS ((uint32_t)UDP_PORT_MAX_CLIENTS * DR_CLIENT_MAX_CONNS)
struct dr_udp_port {
    dr_transport_t tp;
    int h;
    dr_sockaddr_t local;
    bool shared;
    dr_client_t *clients[UDP_PORT_MAX_CLIENTS]; /* by slot; NULL: free */
    unsigned nclients; /* slots in use */
    unsigned foreign;  /* established connections with a target-chosen T->O ID */
    uint64_t epoch;    /* the O->T time grid of every client on the port */
    bool hold;         /* dr_udp_port_hold: O->T frames wait for a flush */
    uint8_t rx[RX_BATCH][UDP_BUF]; /* receive buffers for one batch */
};

struct dr_conn {
    dr_client_t *client;
    bool used;
    bool foreign_cid; /* the target chose the T->O connection ID */
    dr_conn_config_t cfg;
    dr_conn_state_t state;
    dr_conn_stats_t stats;
    uint16_t o2t_size, t2o_size; /* assembly bytes */
    uint16_t conn_serial;
    bool large_now;
    dr_sockaddr_t o2t_to;
    uint16_t o2t_seq16;
    uint32_t o2t_seq32;
    uint16_t t2o_seq16;  /* CIP sequence count of the last new data */
    uint32_t t2o_seq32;  /* encapsulation sequence number of the last packet */
    bool have_t2o_seq;
    uint64_t next_tx_us, rx_deadline_us, retry_us;
    uint64_t last_tx_us; /* when the last O->T packet was produced; 0: none yet */
    uint32_t timeout_us;
    uint32_t backoff_ms;
    unsigned dup_retries;
    unsigned follow_misses; /* T->O arrivals in a row outside the window */
    /* Connection serials of Forward Opens that ended without a reply (a
     * timeout, the session lost): the adapter may have opened them. Each
     * is closed by its triad before the next Forward Open of this
     * connection, and forgotten when that Forward Close is answered. */
    uint16_t stale[CONN_MAX_STALE];
    unsigned nstale;
    /* T->O encapsulation sequence numbers too far ahead to believe: the
     * last one, and how many such came in a row, each a plausible step
     * after the one before (see t2o_seq_take). */
    uint32_t resync_seq32;
    unsigned resync_n;
    bool run, have_in;
    uint8_t out[DR_ASM_MAX_SIZE];
    uint8_t in[DR_ASM_MAX_SIZE];
};

struct dr_client {
    dr_client_config_t cfg;
    char host[DR_CLIENT_HOST_MAX];
    dr_transport_t tp;
    int tcp, timer;
    dr_udp_port_t own_udp;  /* used unless the config shares one */
    dr_udp_port_t *udp;     /* the port this client sends and receives on */
    sess_t state;
    bool started; /* reconnect by itself */
    close_t closing;
    uint64_t close_deadline;
    uint32_t session;
    dr_status_t sess_error;
    dr_sockaddr_t peer;
    uint32_t local_udp_addr;
    uint64_t sess_deadline, retry_at;
    uint32_t backoff_ms;
    uint8_t rx[DR_ENCAP_MAX_LEN];
    size_t rx_len;
    uint8_t tx[TX_BUF];
    size_t tx_len;
    req_t reqs[MAX_REQS];
    uint64_t next_context;
    uint16_t next_serial;
    uint32_t cid_gen;  /* the counter part of our T->O connection IDs */
    unsigned port_slot; /* this client's slot on its UDP port */
    /* dr_client_next_deadline, kept until something that can move it
     * happens (next_dl_stale): the daemon asks at every turn of its loop
     * for every robot, and the answer is a scan of every slot. */
    uint64_t next_dl;
    bool next_dl_stale;
    uint64_t armed;
    uint64_t epoch; /* O->T deadlines of equal APIs fall on one grid; on a
                       shared port, the port's: one wake-up of the
                       application's loop then serves every robot */
    bool timer_polled; /* the caller polls our timer fd: keep it armed */
    /* O->T frames due at one instant, sent together at the end of a
     * process call (one system call for all connections). */
    uint8_t tx_frames[DR_CLIENT_MAX_CONNS][UDP_BUF];
    dr_udp_msg_t tx_batch[DR_CLIENT_MAX_CONNS];
    dr_conn_t *tx_conn[DR_CLIENT_MAX_CONNS];
    unsigned tx_n;
    const char *step;
    dr_client_stats_t stats;
    dr_conn_t conns[DR_CLIENT_MAX_CONNS];
};

/* ---- helpers ----------------------------------------------------------- */

static uint64_t now_us(dr_client_t *c)
{
    return c->tp.ops->now_us(c->tp.ctx);
}

static uint32_t min_u32(uint32_t a, uint32_t b)
{
    return a < b ? a : b;
}

/* Something that can move dr_client_next_deadline happened: it is
 * computed again when next asked. Marked after the change (a callback in
 * the middle of it may already have asked). */
static void deadline_moved(dr_client_t *c)
{
    c->next_dl_stale = true;
}

static void conn_set_state(dr_conn_t *cn, dr_conn_state_t s, dr_status_t why)
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

/* ---- originator serial ----------------------------------------------------- */

static uint32_t fnv1a(uint32_t h, const char *s)
{
    for (; *s != '\0'; s++) {
        h ^= (uint8_t)*s;
        h *= 16777619u; /* the 32-bit FNV prime */
    }
    return h;
}

uint32_t dr_originator_serial(const char *host_id, const char *name)
{
    uint32_t h = fnv1a(2166136261u, host_id != NULL ? host_id : ""); /* offset basis */
    h *= 16777619u; /* the 0 byte between the two: h ^= 0, then the prime */
    h = fnv1a(h, name != NULL ? name : "");
    return h != 0 ? h : 1u;
}

/* ---- lifecycle ----------------------------------------------------------- */

static void close_handle(dr_client_t *c, int *h);

/* Storage handed to dr_client_init / dr_udp_port_init must hold the
 * structure and be aligned like the public storage unions (C99 has no
 * _Static_assert: a negative array size stops the build instead). */
typedef char client_fits_storage[sizeof(struct dr_client) <= DR_CLIENT_STORAGE_SIZE ? 1 : -1];
typedef char port_fits_storage[sizeof(struct dr_udp_port) <= DR_UDP_PORT_STORAGE_SIZE ? 1 : -1];
/* cppcheck-suppress unusedStructMember ; only offsetof reads them */
struct client_align { char c; dr_client_storage_t s; };
/* cppcheck-suppress unusedStructMember ; only offsetof reads them */
struct port_align { char c; dr_udp_port_storage_t s; };

static bool storage_ok(const void *storage, size_t size, size_t need, size_t align)
{
    return storage != NULL && size >= need && (uintptr_t)storage % align == 0;
}

size_t dr_client_size(void)
{
    return sizeof(struct dr_client);
}

size_t dr_udp_port_size(void)
{
    return sizeof(struct dr_udp_port);
}

/* The calls every transport must have; the others may be NULL. */
static bool transport_ok(dr_transport_t tp)
{
    const dr_transport_ops_t *o = tp.ops;
    return o != NULL && o->resolve != NULL && o->tcp_connect != NULL &&
           o->tcp_finish != NULL && o->tcp_send != NULL && o->tcp_recv != NULL &&
           o->udp_open != NULL && o->udp_send != NULL && o->udp_recv != NULL &&
           o->close != NULL && o->now_us != NULL &&
           (o->timer_open == NULL) == (o->timer_arm == NULL);
}

static dr_client_t *init_fail(dr_status_t *err, dr_status_t st)
{
    if (err != NULL)
        *err = st;
    return NULL;
}

dr_client_t *dr_client_init(void *storage, size_t size, const dr_client_config_t *cfg,
                            dr_status_t *err)
{
    if (cfg == NULL || cfg->host == NULL || strlen(cfg->host) >= DR_CLIENT_HOST_MAX ||
        !transport_ok(cfg->transport) ||
        !storage_ok(storage, size, sizeof(struct dr_client),
                    offsetof(struct client_align, s)))
        return init_fail(err, DR_EINVAL);
    dr_client_t *c = storage;
    memset(c, 0, sizeof *c);
    c->cfg = *cfg;
    memcpy(c->host, cfg->host, strlen(cfg->host) + 1);
    c->cfg.host = c->host;
    c->cfg.local_addr = NULL; /* resolved below, not kept */
    if (c->cfg.tcp_port == 0) c->cfg.tcp_port = DR_ENIP_TCP_PORT;
    if (c->cfg.udp_port == 0) c->cfg.udp_port = DR_ENIP_UDP_PORT;
    if (c->cfg.local_udp_port == 0) c->cfg.local_udp_port = DR_ENIP_UDP_PORT;
    if (c->cfg.timeout_ms == 0) c->cfg.timeout_ms = 2000;
    if (c->cfg.vendor_id == 0) c->cfg.vendor_id = 0xFFFE;
    if (c->cfg.backoff_min_ms == 0) c->cfg.backoff_min_ms = 100;
    if (c->cfg.backoff_max_ms == 0) c->cfg.backoff_max_ms = 5000;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (c->cfg.instance[a] == 0)
            c->cfg.instance[a] = DR_ASM_DEFAULT_INSTANCE(a);
    c->tp = c->cfg.transport;
    c->tcp = c->timer = -1;
    c->own_udp.h = -1;
    c->own_udp.tp = c->tp;
    c->own_udp.clients[0] = c;
    c->own_udp.nclients = 1;
    c->udp = &c->own_udp;
    c->next_dl_stale = true;
    uint64_t t = now_us(c);
    c->epoch = t;
    /* Unique but not stable: see "Originator serial" in client.h. */
    if (c->cfg.serial == 0)
        c->cfg.serial = (uint32_t)(t ^ (t >> 32)) | 1u;
    c->next_serial = (uint16_t)(t >> 4);
    /* Connection IDs differ between clients sharing a UDP port by their
     * slot (see struct dr_udp_port); the counter starts from the clock so
     * that a restarted originator does not reuse the last run's IDs. */
    c->cid_gen = (uint32_t)(t ^ (t >> 20));
    c->backoff_ms = c->cfg.backoff_min_ms;
    c->step = "";
    dr_status_t st;
    if (cfg->local_addr != NULL &&
        (st = c->tp.ops->resolve(c->tp.ctx, cfg->local_addr, &c->local_udp_addr)) != DR_OK)
        return init_fail(err, st);
    if (c->tp.ops->timer_open != NULL &&
        (st = c->tp.ops->timer_open(c->tp.ctx, &c->timer)) != DR_OK)
        return init_fail(err, st);
    if (cfg->shared_udp != NULL) {
        dr_udp_port_t *p = cfg->shared_udp;
        if (p->nclients == UDP_PORT_MAX_CLIENTS) {
            close_handle(c, &c->timer);
            return init_fail(err, DR_EFULL);
        }
        unsigned slot = 0;
        while (p->clients[slot] != NULL)
            slot++;
        p->clients[slot] = c;
        p->nclients++;
        c->port_slot = slot;
        c->udp = p;
        c->epoch = p->epoch;
    }
    if (err != NULL)
        *err = DR_OK;
    return c;
}

static void complete_all(dr_client_t *c, dr_status_t st);
static void session_fail(dr_client_t *c, dr_status_t st);

static void close_handle(dr_client_t *c, int *h)
{
    if (*h >= 0)
        c->tp.ops->close(c->tp.ctx, *h);
    *h = -1;
}

void dr_client_deinit(dr_client_t *c)
{
    if (c == NULL)
        return;
    dr_client_close(c);
    close_handle(c, &c->timer);
    if (c->udp != &c->own_udp) {
        c->udp->clients[c->port_slot] = NULL; /* the others keep their slots */
        c->udp->nclients--;
    }
}

uint16_t dr_client_instance(const dr_client_t *c, dr_asm_t a)
{
    return (unsigned)a < DR_ASM_COUNT ? c->cfg.instance[a] : 0;
}

const char *dr_client_last_step(const dr_client_t *c)
{
    return c->step;
}

const dr_client_stats_t *dr_client_stats(const dr_client_t *c)
{
    return &c->stats;
}

void dr_client_set_timeout(dr_client_t *c, uint32_t timeout_ms)
{
    c->cfg.timeout_ms = timeout_ms != 0 ? timeout_ms : 2000;
}

bool dr_client_ready(const dr_client_t *c)
{
    return c->state == S_READY;
}

/* ---- TCP output ---------------------------------------------------------- */

static void flush_tx(dr_client_t *c)
{
    while (c->tx_len > 0 && c->tcp >= 0) {
        size_t sent = 0;
        dr_status_t st = c->tp.ops->tcp_send(c->tp.ctx, c->tcp, c->tx, c->tx_len, &sent);
        if (st == DR_EAGAIN)
            return;
        if (st != DR_OK) {
            session_fail(c, st);
            return;
        }
        memmove(c->tx, c->tx + sent, c->tx_len - sent);
        c->tx_len -= sent;
    }
}

/* Queue one encapsulated message: header + body built by the caller in
 * body[0..body_len). */
static dr_status_t send_encap(dr_client_t *c, uint16_t cmd, uint64_t context,
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
    flush_tx(c);
    return DR_OK;
}

/* ---- requests ------------------------------------------------------------ */

static req_t *req_alloc(dr_client_t *c, req_kind_t kind)
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

static void conn_on_reply(dr_conn_t *cn, req_t *r, const dr_cip_rsp_t *rsp,
                          const dr_cpf_t *cpf);
static void close_orphan(dr_client_t *c, const req_t *r, const dr_cip_rsp_t *rsp);

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
        conn_on_reply(r->conn, r, rsp, cpf);
    else if (r->kind == R_FWD_OPEN && rsp != NULL && st == DR_OK)
        close_orphan(c, r, rsp); /* its connection was removed meanwhile */
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
static dr_status_t send_rr(dr_client_t *c, req_t *r, const uint8_t *msg,
                           size_t msg_len, bool with_sockaddr)
{
    uint8_t body[DR_ENCAP_MAX_LEN];
    uint8_t wrapped[DR_ENCAP_MAX_LEN];
    dr_wr_t w;

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
    return send_encap(c, DR_ENCAP_SEND_RR_DATA, r->context, body, w.len);
}

/* ---- session --------------------------------------------------------------- */

static void conn_schedule_retry(dr_conn_t *cn, dr_status_t why);

/* Tell the application about the session (dr_session_cb), except while
 * it closes the client itself. */
static void session_tell(dr_client_t *c, dr_status_t why)
{
    if (c->cfg.on_session != NULL && c->closing == CL_NONE)
        c->cfg.on_session(c, why, c->cfg.session_user);
}

static void session_fail(dr_client_t *c, dr_status_t st)
{
    close_handle(c, &c->tcp);
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
            conn_schedule_retry(&c->conns[i], st);
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
    session_fail(c, st);
}

static dr_status_t ensure_udp(dr_client_t *c)
{
    if (c->udp->h >= 0)
        return DR_OK;
    dr_sockaddr_t local = {c->local_udp_addr, c->cfg.local_udp_port};
    c->udp->local = local;
    return c->tp.ops->udp_open(c->tp.ctx, local, &c->udp->h);
}

static dr_status_t begin_session(dr_client_t *c)
{
    uint32_t addr;
    close_handle(c, &c->tcp);
    c->tx_len = c->rx_len = 0;
    c->session = 0;
    c->step = "resolve";
    dr_status_t st = c->tp.ops->resolve(c->tp.ctx, c->host, &addr);
    if (st == DR_OK) {
        c->peer.addr = addr;
        c->peer.port = c->cfg.tcp_port;
        c->step = "connect";
        st = c->tp.ops->tcp_connect(c->tp.ctx, c->peer, &c->tcp);
    }
    if (st != DR_OK) {
        session_fail(c, st);
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
    dr_status_t st = send_encap(c, DR_ENCAP_REGISTER_SESSION, 0, body, sizeof body);
    if (st != DR_OK)
        session_fail(c, st);
}

static void close_finish(dr_client_t *c);

dr_status_t dr_client_start(dr_client_t *c)
{
    if (c->closing != CL_NONE)
        close_finish(c); /* started again before the close ended */
    c->started = true;
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++)
        if (c->conns[i].used && c->conns[i].state == DR_CONN_CLOSED) {
            c->conns[i].state = DR_CONN_IDLE;
            c->conns[i].retry_us = 0;
        }
    if (c->state == S_IDLE || c->state == S_BACKOFF)
        (void)begin_session(c); /* a failure is retried with backoff */
    deadline_moved(c);
    return DR_OK;
}

/* ---- Class 1 connections ------------------------------------------------- */

static uint64_t conn_backoff_us(dr_conn_t *cn)
{
    dr_client_t *c = cn->client;
    uint64_t d = (uint64_t)cn->backoff_ms * 1000u;
    cn->backoff_ms = min_u32(cn->backoff_ms * 2u, c->cfg.backoff_max_ms);
    return d;
}

static void conn_schedule_retry(dr_conn_t *cn, dr_status_t why)
{
    cn->retry_us = now_us(cn->client) + conn_backoff_us(cn);
    conn_set_state(cn, DR_CONN_RECONNECTING, why);
}

/* The instances of a connection's path: configuration, O->T point (an
 * assembly or a heartbeat), T->O point. */
static void conn_path_inst(const dr_conn_t *cn, uint16_t inst[3])
{
    const dr_client_t *c = cn->client;
    inst[0] = cn->cfg.config_instance;
    inst[1] = cn->cfg.o2t_asm >= 0 ? c->cfg.instance[cn->cfg.o2t_asm]
                                   : cn->cfg.heartbeat_instance;
    inst[2] = c->cfg.instance[cn->cfg.t2o_asm];
}

static size_t conn_path(const dr_conn_t *cn, uint8_t *buf, size_t cap)
{
    uint16_t inst[3];
    conn_path_inst(cn, inst);
    return dr_conn_path_write(buf, cap, inst[0], inst[1], inst[2]);
}

/* A fresh T->O connection ID that says where the connection lives (see
 * struct dr_udp_port): generation * CID_SLOTS + slot, never 0, and never
 * wrapping past 2^32, so that cid % CID_SLOTS is the slot for any bounds. */
static uint32_t next_t2o_cid(const dr_conn_t *cn)
{
    dr_client_t *c = cn->client;
    uint32_t gens = UINT32_MAX / CID_SLOTS; /* generations that fit */
    uint32_t gen = 1u + c->cid_gen++ % (gens - 1u);
    uint32_t slot = (uint32_t)c->port_slot * DR_CLIENT_MAX_CONNS + (uint32_t)(cn - c->conns);
    return gen * CID_SLOTS + slot;
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
        conn_schedule_retry(cn, ust);
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
    req_t *r = req_alloc(c, R_FWD_OPEN);
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
    cn->conn_serial = c->next_serial++; /* fresh on every attempt */
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
    conn_set_state(cn, DR_CONN_OPENING, DR_OK);
    /* Tell the target where T->O goes when it is not where it would
     * guess (the TCP connection's own address, port 2222). */
    bool sockaddr = c->udp->local.port != DR_ENIP_UDP_PORT || c->udp->local.addr != 0;
    dr_status_t st = send_rr(c, r, msg, m.len, sockaddr);
    if (st != DR_OK) {
        r->active = false;
        conn_schedule_retry(cn, st);
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
    req_t *r = req_alloc(c, R_FWD_CLOSE);
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
    if (send_rr(c, r, msg, m.len, false) != DR_OK) {
        r->active = false;
        return false;
    }
    return true;
}

static void send_forward_close(dr_conn_t *cn)
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
static void close_orphan(dr_client_t *c, const req_t *r, const dr_cip_rsp_t *rsp)
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
    /* Timers run from the APIs the target granted, not what we asked. */
    cn->timeout_us = cn->stats.t2o_api_us * (4u << cn->cfg.timeout_mult);
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
    cn->rx_deadline_us = t + cn->timeout_us + FIRST_PACKET_GRACE_US;
    cn->backoff_ms = c->cfg.backoff_min_ms;
    cn->dup_retries = 0;
    conn_set_state(cn, DR_CONN_ESTABLISHED, DR_OK);
}

static void conn_on_reply(dr_conn_t *cn, req_t *r, const dr_cip_rsp_t *rsp,
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
            close_orphan(cn->client, r, rsp);
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
    conn_schedule_retry(cn, st);
}

dr_conn_t *dr_client_conn_add(dr_client_t *c, const dr_conn_config_t *cfg,
                              dr_status_t *err)
{
    dr_status_t st = DR_EINVAL;
    dr_conn_t *cn = NULL;
    const dr_asm_info_t *t2o = cfg ? dr_asm_info(cfg->t2o_asm) : NULL;
    const dr_asm_info_t *o2t = cfg && cfg->o2t_asm >= 0 ? dr_asm_info((dr_asm_t)cfg->o2t_asm) : NULL;
    if (t2o == NULL || t2o->dir != DR_DIR_T2O || (cfg->o2t_asm >= 0 && (o2t == NULL || o2t->dir != DR_DIR_O2T)) ||
        cfg->rpi_us == 0 || cfg->timeout_mult > 7)
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
    cn->o2t_size = o2t ? o2t->size : 0;
    cn->t2o_size = t2o->size;
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
        send_forward_close(cn);
    uint16_t inst[3];
    conn_path_inst(cn, inst);
    for (unsigned i = 0; i < cn->nstale; i++)
        (void)send_close_triad(cn->client, NULL, cn->stale[i], inst);
    conn_set_state(cn, DR_CONN_CLOSED, DR_OK);
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

static void flush_io(dr_client_t *c);

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
        flush_io(c); /* held (dr_udp_port_hold) and full: no frame is lost */
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

/* Send n O->T frames on port p (who[i]: whose frame m[i] is), in one
 * call if the transport can. */
static void send_frames(dr_udp_port_t *p, const dr_udp_msg_t *m, dr_conn_t *const *who,
                        unsigned n)
{
    unsigned sent = 0;
    if (p->h < 0)
        return;
    if (p->tp.ops->udp_send_batch != NULL) {
        while (sent < n) {
            unsigned k = 0;
            if (p->tp.ops->udp_send_batch(p->tp.ctx, p->h, &m[sent], n - sent, &k) != DR_OK ||
                k == 0)
                break; /* dropped, like a datagram the network loses */
            for (unsigned i = sent; i < sent + k; i++)
                who[i]->stats.tx_packets++;
            sent += k;
        }
    } else {
        for (unsigned i = 0; i < n; i++)
            if (p->tp.ops->udp_send(p->tp.ctx, p->h, m[i].buf, m[i].len, m[i].addr) == DR_OK)
                who[i]->stats.tx_packets++;
    }
}

/* Send the O->T frames queued by conn_produce. */
static void flush_io(dr_client_t *c)
{
    send_frames(c->udp, c->tx_batch, c->tx_conn, c->tx_n);
    c->tx_n = 0;
}

/* The frames every client of a shared port queued while the port was
 * read (o2t_follow_us), together: one batch call for all the robots whose
 * packets came in the same read, instead of one per robot. The frames
 * stay in their clients' buffers; only the descriptors are gathered. */
/* Frames per batch call: every frame of up to 10 robots of six connections
 * (the POSIX transport's sendmmsg takes 64), bounded by what the port can
 * hold at all, which keeps it small in firmware builds (stack). */
#define PORT_TX_BATCH (CID_SLOTS < 64u ? CID_SLOTS : 64u)
static void flush_port(dr_udp_port_t *p)
{
    dr_udp_msg_t m[PORT_TX_BATCH];
    dr_conn_t *who[PORT_TX_BATCH];
    unsigned n = 0;
    for (unsigned k = 0; k < UDP_PORT_MAX_CLIENTS; k++) {
        dr_client_t *c = p->clients[k];
        for (unsigned i = 0; c != NULL && i < c->tx_n; i++) {
            m[n] = c->tx_batch[i];
            who[n++] = c->tx_conn[i];
            if (n == PORT_TX_BATCH) {
                send_frames(p, m, who, n);
                n = 0;
            }
        }
    }
    send_frames(p, m, who, n);
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
 * When arrivals keep falling outside the window (the connection has just
 * opened, or the two clocks drift apart, as real adapters' do) the
 * schedule moves: the next packet is due half a window after the next
 * expected arrival, which makes one interval longer, never shorter. Only
 * for equal APIs both ways: otherwise the arrivals do not mark our
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
        cn->follow_misses = 0;
        if (cn->next_tx_us < t + api + win / 2u)
            cn->next_tx_us = t + api + win / 2u;
    }
}

static void conn_timers(dr_conn_t *cn, uint64_t t)
{
    dr_client_t *c = cn->client;
    switch (cn->state) {
    case DR_CONN_ESTABLISHED:
        if (t >= cn->rx_deadline_us) {
            cn->stats.timeouts++;
            conn_set_state(cn, DR_CONN_TIMED_OUT, DR_ETIMEDOUT);
            send_forward_close(cn); /* so the new open is not a duplicate */
            conn_schedule_retry(cn, DR_ETIMEDOUT);
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

static uint64_t conn_deadline(const dr_conn_t *cn)
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

/* ---- inbound ---------------------------------------------------------------- */

static uint64_t context_of(const dr_encap_t *h)
{
    uint64_t v = 0;
    for (unsigned i = 0; i < 8; i++)
        v |= (uint64_t)h->context[i] << (8 * i);
    return v;
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
        session_fail(c, DR_EMALFORMED);
        return;
    }
    if (h.command == DR_ENCAP_REGISTER_SESSION) {
        if (c->state != S_REGISTERING)
            return;
        if (h.status != 0 || h.session == 0) {
            session_fail(c, h.status != 0 ? DR_ENCAP(h.status) : DR_EMALFORMED);
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
            session_fail(c, DR_ENCAP(h.status));
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
static void read_tcp(dr_client_t *c)
{
    for (bool more = true; more && c->tcp >= 0;) {
        size_t got = 0, space = sizeof c->rx - c->rx_len;
        dr_status_t st = c->tp.ops->tcp_recv(c->tp.ctx, c->tcp, c->rx + c->rx_len,
                                             space, &got);
        more = got == space;
        if (st == DR_EAGAIN)
            return;
        if (st != DR_OK) {
            session_fail(c, st);
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
            session_fail(c, DR_ELONG); /* the stream cannot be trusted */
            return;
        }
    }
}

static bool conn_has_t2o_cid(const dr_conn_t *cn, uint32_t cid)
{
    return cn->used && cn->state == DR_CONN_ESTABLISHED && cn->stats.t2o_cid == cid;
}

/* The established connection a T->O packet belongs to: where its ID says
 * (see struct dr_udp_port), else, only while some target chose its own
 * ID, wherever it is. */
static dr_conn_t *conn_by_t2o_cid(dr_udp_port_t *p, uint32_t cid)
{
    uint32_t slot = cid % CID_SLOTS;
    dr_client_t *c = p->clients[slot / DR_CLIENT_MAX_CONNS];
    if (c != NULL && conn_has_t2o_cid(&c->conns[slot % DR_CLIENT_MAX_CONNS], cid))
        return &c->conns[slot % DR_CLIENT_MAX_CONNS];
    for (unsigned k = 0; p->foreign > 0 && k < UDP_PORT_MAX_CLIENTS; k++)
        for (unsigned i = 0; p->clients[k] != NULL && i < DR_CLIENT_MAX_CONNS; i++)
            if (conn_has_t2o_cid(&p->clients[k]->conns[i], cid))
                return &p->clients[k]->conns[i];
    return NULL;
}

static void conn_datagram(dr_conn_t *cn, const uint8_t *buf, size_t len,
                          const dr_io_frame_t *f, uint64_t t);

static void on_datagram(dr_udp_port_t *p, const uint8_t *buf, size_t len, uint64_t t)
{
    dr_io_frame_t f;
    if (dr_io_frame_parse(buf, len, false, &f) != DR_OK)
        return;
    dr_conn_t *cn = conn_by_t2o_cid(p, f.cid);
    if (cn == NULL)
        return;
    dr_client_t *c = cn->client;
    conn_datagram(cn, buf, len, &f, t);
    deadline_moved(c); /* its timeout, maybe its O->T deadline (follow) */
}

/* How far ahead of the last packet taken a T->O encapsulation sequence
 * number may be: half the packets of a timeout (4 << multiplier), at
 * least 8. A live producer cannot have gone much further (the connection
 * would have timed out meanwhile), and a number that went further is a
 * corrupted one, e.g. a bit flipped high in a datagram whose UDP checksum
 * is zero (IPv4 allows it): taken, it would make every real packet after
 * it look old until the connection timed out. Within the window, such a
 * number costs at most the packets up to it, half a timeout. */
#define SEQ_RESYNC 3u /* packets in a row that agree with each other */

static uint32_t seq_window(const dr_conn_t *cn)
{
    uint32_t w = (4u << cn->cfg.timeout_mult) / 2u;
    return w < 8u ? 8u : w;
}

/* Whether a T->O packet with encapsulation sequence number seq is newer
 * than the last one taken. Too far ahead: dropped, unless it is the
 * SEQ_RESYNC-th in a row of such numbers, each within the window after
 * the one before: a producer that really jumped (it restarted its count
 * within the connection), followed from there. */
static bool t2o_seq_take(dr_conn_t *cn, uint32_t seq)
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
    if (cn->resync_n < SEQ_RESYNC)
        return false;
    cn->resync_n = 0;
    cn->stats.rx_resyncs++;
    return true;
}

/* A packet for connection cn (f: parsed without a run/idle header): check
 * it, take it, keep the connection alive. */
static void conn_datagram(dr_conn_t *cn, const uint8_t *buf, size_t len,
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
    if (cn->have_t2o_seq && !t2o_seq_take(cn, f.encap_seq)) {
        cn->stats.rx_dropped_seq++;
        return;
    }
    cn->t2o_seq32 = f.encap_seq;
    cn->stats.rx_packets++;
    cn->stats.last_rx_us = t;
    cn->rx_deadline_us = t + cn->timeout_us;
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

/* Everything that is waiting, bounded so a flood cannot starve the loop. */
static void read_udp(dr_udp_port_t *p, uint64_t t)
{
    if (p->tp.ops->udp_recv_batch != NULL) {
        /* Until the socket is empty: a batch that came back full may have
         * left more behind. Bounded, so a flood cannot starve the loop. */
        dr_udp_msg_t m[RX_BATCH];
        for (unsigned round = 0; p->h >= 0 && round < 100; round++) {
            unsigned got = 0;
            for (unsigned i = 0; i < RX_BATCH; i++) {
                m[i].buf = p->rx[i];
                m[i].cap = UDP_BUF;
                m[i].len = 0;
            }
            if (p->tp.ops->udp_recv_batch(p->tp.ctx, p->h, m, RX_BATCH, &got) != DR_OK)
                return;
            for (unsigned i = 0; i < got; i++)
                if (m[i].len > 0)
                    on_datagram(p, m[i].buf, m[i].len, t);
            if (got < RX_BATCH)
                return;
        }
        return;
    }
    for (unsigned n = 0; p->h >= 0 && n < 1000; n++) {
        size_t got;
        dr_sockaddr_t from;
        dr_status_t st = p->tp.ops->udp_recv(p->tp.ctx, p->h, p->rx[0], UDP_BUF, &got, &from);
        if (st == DR_EAGAIN)
            return;
        if (st == DR_OK)
            on_datagram(p, p->rx[0], got, t);
    }
}

dr_udp_port_t *dr_udp_port_init(void *storage, size_t size, const char *local_addr,
                                uint16_t port, dr_transport_t tp, dr_status_t *err)
{
    dr_status_t st = DR_EINVAL;
    dr_udp_port_t *p = storage;
    if (!transport_ok(tp) ||
        !storage_ok(storage, size, sizeof *p, offsetof(struct port_align, s)))
        goto fail;
    memset(p, 0, sizeof *p);
    p->tp = tp;
    p->h = -1;
    p->shared = true;
    p->epoch = tp.ops->now_us(tp.ctx);
    p->local.port = port != 0 ? port : DR_ENIP_UDP_PORT;
    if (local_addr != NULL &&
        (st = p->tp.ops->resolve(p->tp.ctx, local_addr, &p->local.addr)) != DR_OK)
        goto fail;
    if ((st = p->tp.ops->udp_open(p->tp.ctx, p->local, &p->h)) != DR_OK)
        goto fail;
    if (err != NULL)
        *err = DR_OK;
    return p;
fail:
    if (err != NULL)
        *err = st;
    return NULL;
}

void dr_udp_port_deinit(dr_udp_port_t *p)
{
    if (p != NULL && p->h >= 0)
        p->tp.ops->close(p->tp.ctx, p->h);
    if (p != NULL)
        p->h = -1;
}

/* The descriptor of a handle, -1 when the transport has none. */
static int fd_of(dr_transport_t tp, int h)
{
    return h >= 0 && tp.ops->fd != NULL ? tp.ops->fd(tp.ctx, h) : -1;
}

int dr_udp_port_fd(const dr_udp_port_t *p)
{
    return fd_of(p->tp, p->h);
}

/* Re-arm only when the deadline moved; with none left, disarm, so an
 * expired timer does not keep the caller's poll awake. */
static void rearm(dr_client_t *c)
{
    uint64_t d = dr_client_next_deadline(c);
    if (c->timer_polled && c->timer >= 0 && d != c->armed) {
        c->tp.ops->timer_arm(c->tp.ctx, c->timer, d);
        c->armed = d;
    }
}

dr_status_t dr_udp_port_process(dr_udp_port_t *p)
{
    read_udp(p, p->tp.ops->now_us(p->tp.ctx));
    /* O->T produced on arrival (o2t_follow_us) goes now, and the timers
     * move past the deadlines it served; a client that produced nothing
     * has nothing to send and no deadline that moved earlier. */
    flush_port(p);
    for (unsigned k = 0; k < UDP_PORT_MAX_CLIENTS; k++) {
        dr_client_t *c = p->clients[k];
        if (c == NULL || c->tx_n == 0)
            continue;
        c->tx_n = 0;
        rearm(c);
    }
    return DR_OK;
}

void dr_udp_port_hold(dr_udp_port_t *p, bool hold)
{
    if (p->hold && !hold)
        dr_udp_port_flush(p);
    p->hold = hold;
}

void dr_udp_port_flush(dr_udp_port_t *p)
{
    flush_port(p);
    for (unsigned k = 0; k < UDP_PORT_MAX_CLIENTS; k++)
        if (p->clients[k] != NULL)
            p->clients[k]->tx_n = 0;
}

/* ---- the loop -------------------------------------------------------------- */

static void session_timers(dr_client_t *c, uint64_t t)
{
    if (c->state == S_CONNECTING) {
        dr_status_t st = c->tp.ops->tcp_finish(c->tp.ctx, c->tcp);
        if (st == DR_OK)
            send_register(c);
        else if (st != DR_EAGAIN)
            session_fail(c, st);
        else if (t >= c->sess_deadline)
            session_fail(c, DR_ENOANSWER); /* TCP's timeout, not a request's */
    } else if (c->state == S_REGISTERING && t >= c->sess_deadline) {
        session_fail(c, DR_ENOREGISTER);
    } else if (c->state == S_BACKOFF && c->started && t >= c->retry_at) {
        (void)begin_session(c);
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

/* Every deadline of the client: a scan of its request and connection
 * slots, which dr_client_next_deadline keeps until one may have moved. */
static uint64_t compute_deadline(const dr_client_t *c)
{
    uint64_t d = c->closing != CL_NONE ? c->close_deadline : UINT64_MAX;
    if (c->state == S_CONNECTING || c->state == S_REGISTERING)
        d = c->sess_deadline;
    else if (c->state == S_BACKOFF && c->started)
        d = c->retry_at;
    for (unsigned i = 0; i < MAX_REQS; i++)
        if (c->reqs[i].active && !c->reqs[i].done && c->reqs[i].deadline < d)
            d = c->reqs[i].deadline;
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++) {
        if (!c->conns[i].used)
            continue;
        uint64_t cd = conn_deadline(&c->conns[i]);
        if (cd < d)
            d = cd;
    }
    return d;
}

uint64_t dr_client_next_deadline(dr_client_t *c)
{
    if (c->next_dl_stale) {
        c->next_dl = compute_deadline(c);
        c->next_dl_stale = false;
    }
    return c->next_dl;
}

static void close_step(dr_client_t *c, uint64_t t);

/* may_hold: the O->T frames produced may wait for dr_udp_port_flush (a
 * held port, and the application's loop calling); the blocking calls
 * send them at once, as nobody flushes while they wait. */
static void process(dr_client_t *c, bool tcp_ready, bool udp_ready, bool may_hold)
{
    uint64_t t = now_us(c);
    if (c->tcp >= 0 && c->state != S_CONNECTING && tcp_ready) {
        flush_tx(c);
        read_tcp(c);
    }
    if (udp_ready)
        read_udp(c->udp, t);
    t = now_us(c);
    session_timers(c, t);
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++)
        if (c->conns[i].used)
            conn_timers(&c->conns[i], t);
    if (!may_hold || !c->udp->hold)
        flush_io(c);
    if (c->closing != CL_NONE)
        close_step(c, t);
    deadline_moved(c);
    rearm(c);
}

dr_status_t dr_client_process(dr_client_t *c)
{
    process(c, true, true, true);
    return DR_OK;
}

dr_status_t dr_client_process_ready(dr_client_t *c, const dr_pollfd_t *fds, int n)
{
    bool tcp = c->tcp >= 0 && c->tx_len > 0, udp = false;
    int tcp_fd = fd_of(c->tp, c->tcp), udp_fd = fd_of(c->tp, c->udp->h);
    for (int i = 0; i < n; i++) {
        if (fds[i].revents == 0 || fds[i].fd < 0)
            continue;
        if (fds[i].fd == tcp_fd)
            tcp = true;
        else if (fds[i].fd == udp_fd)
            udp = true;
    }
    process(c, tcp, udp, true);
    return DR_OK;
}

int dr_client_pollfds(dr_client_t *c, dr_pollfd_t *fds, int max)
{
    /* From now on the timer fd is in someone's poll set and must be armed;
     * the *_sync calls alone wait with a deadline and do not need it. */
    if (c->tp.ops->fd == NULL)
        return 0; /* the application drives us by dr_client_next_deadline */
    if (!c->timer_polled && c->timer >= 0) {
        c->timer_polled = true;
        c->tp.ops->timer_arm(c->tp.ctx, c->timer, dr_client_next_deadline(c));
        c->armed = dr_client_next_deadline(c);
    }
    int n = 0;
    if (c->tcp >= 0 && n < max) {
        fds[n].fd = c->tp.ops->fd(c->tp.ctx, c->tcp);
        fds[n].revents = 0;
        fds[n].events = (short)(DR_POLL_IN |
                                (c->state == S_CONNECTING || c->tx_len > 0 ? DR_POLL_OUT : 0));
        n++;
    }
    /* A shared port is polled by the application, once for all clients. */
    if (!c->udp->shared && c->udp->h >= 0 && n < max) {
        fds[n].fd = c->tp.ops->fd(c->tp.ctx, c->udp->h);
        fds[n].events = DR_POLL_IN;
        fds[n].revents = 0;
        n++;
    }
    if (c->timer >= 0 && n < max) {
        fds[n].fd = c->tp.ops->fd(c->tp.ctx, c->timer);
        fds[n].events = DR_POLL_IN;
        fds[n].revents = 0;
        n++;
    }
    return n;
}

/* The blocking calls need the transport's wait: without it, they would
 * spin on the clock. */
static bool can_wait(const dr_client_t *c)
{
    return c->tp.ops->wait != NULL;
}

/* Wait for any of our handles, at most until `deadline`, then process. */
static void wait_and_process(dr_client_t *c, uint64_t deadline)
{
    int h[3];
    bool out[3];
    int n = 0;
    if (c->tcp >= 0) {
        h[n] = c->tcp;
        out[n++] = c->state == S_CONNECTING || c->tx_len > 0;
    }
    if (c->udp->h >= 0) {
        h[n] = c->udp->h;
        out[n++] = false;
    }
    uint64_t d = dr_client_next_deadline(c);
    if (deadline < d)
        d = deadline;
    c->tp.ops->wait(c->tp.ctx, h, out, n, d);
    process(c, true, true, false);
    if (c->udp->hold)
        dr_udp_port_flush(c->udp); /* what other clients held meanwhile */
}

dr_status_t dr_client_run_once(dr_client_t *c, int timeout_ms)
{
    if (!can_wait(c))
        return DR_EINVAL;
    wait_and_process(c, now_us(c) + (uint64_t)(timeout_ms < 0 ? 0 : timeout_ms) * 1000u);
    return DR_OK;
}

/* ---- synchronous explicit messaging ----------------------------------------- */

dr_status_t dr_client_connect_sync(dr_client_t *c)
{
    if (c->state == S_READY)
        return DR_OK;
    if (!can_wait(c) || c->closing != CL_NONE)
        return c->closing != CL_NONE ? DR_ESESSION : DR_EINVAL;
    dr_status_t st = begin_session(c);
    if (st != DR_OK)
        return st;
    uint64_t deadline = now_us(c) + 2u * (uint64_t)c->cfg.timeout_ms * 1000u;
    while (c->state == S_CONNECTING || c->state == S_REGISTERING) {
        if (now_us(c) >= deadline) {
            session_fail(c, c->state == S_CONNECTING ? DR_ENOANSWER : DR_ENOREGISTER);
            break;
        }
        wait_and_process(c, deadline);
    }
    return c->state == S_READY ? DR_OK : c->sess_error;
}

/* Run the loop until request r is done; collect and free it. */
static dr_status_t wait_req(dr_client_t *c, req_t *r, size_t *rsp_len)
{
    while (!r->done)
        wait_and_process(c, r->deadline);
    dr_status_t st = r->status;
    if (rsp_len != NULL)
        *rsp_len = r->rsp_len;
    r->active = false;
    return st;
}

/* Build a Message Router request and send it as a request of `kind`.
 * A session that fails while it is being sent completes an async request
 * on the spot (with no callback yet); that is reported as the failure. */
static dr_status_t start_call(dr_client_t *c, req_kind_t kind, uint8_t service,
                              const uint8_t *path, size_t path_len,
                              const uint8_t *data, size_t data_len, req_t **out)
{
    if (c->state != S_READY || c->closing != CL_NONE)
        return DR_ESESSION;
    if (kind == R_USER && !can_wait(c))
        return DR_EINVAL;
    uint8_t msg[DR_ENCAP_MAX_LEN];
    dr_wr_t w;
    dr_wr_init(&w, msg, sizeof msg);
    dr_cip_req_write(&w, service, path, path_len, data, data_len);
    if (w.overflow)
        return DR_ENOSPACE;
    req_t *r = req_alloc(c, kind);
    if (r == NULL)
        return DR_EFULL;
    dr_status_t st = send_rr(c, r, msg, w.len, false);
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

dr_status_t dr_client_call_sync(dr_client_t *c, uint8_t service,
                                const uint8_t *path, size_t path_len,
                                const uint8_t *data, size_t data_len,
                                uint8_t *rsp, size_t cap, size_t *rsp_len)
{
    req_t *r;
    if (rsp_len != NULL)
        *rsp_len = 0;
    dr_status_t st = start_call(c, R_USER, service, path, path_len, data, data_len, &r);
    if (st != DR_OK)
        return st;
    r->rsp = rsp; /* replies are only read by wait_req, after this */
    r->cap = cap;
    return wait_req(c, r, rsp_len);
}

dr_status_t dr_client_call_async(dr_client_t *c, uint8_t service,
                                 const uint8_t *path, size_t path_len,
                                 const uint8_t *data, size_t data_len,
                                 dr_call_cb done, void *user)
{
    req_t *r;
    dr_status_t st = start_call(c, R_ASYNC, service, path, path_len, data, data_len, &r);
    if (st != DR_OK)
        return st;
    /* The callback only now: the caller must first see the request taken. */
    r->cb = done;
    r->cb_user = user;
    return DR_OK;
}

dr_status_t dr_client_get_attr_sync(dr_client_t *c, uint16_t cls, uint16_t inst,
                                    uint16_t attr, uint8_t *buf, size_t cap,
                                    size_t *len)
{
    uint8_t path[12];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, cls, inst, attr);
    c->step = "get";
    return dr_client_call_sync(c, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, w.len,
                               NULL, 0, buf, cap, len);
}

dr_status_t dr_client_set_attr_sync(dr_client_t *c, uint16_t cls, uint16_t inst,
                                    uint16_t attr, const uint8_t *data, size_t len)
{
    uint8_t path[12];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, cls, inst, attr);
    c->step = "set";
    return dr_client_call_sync(c, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, path, w.len,
                               data, len, NULL, 0, NULL);
}

dr_status_t dr_client_asm_read_sync(dr_client_t *c, dr_asm_t a, uint8_t *buf,
                                    size_t len)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL || len != info->size)
        return info == NULL ? DR_EINVAL : DR_ELENGTH;
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    size_t got = 0;
    dr_status_t st = dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, c->cfg.instance[a],
                                             DR_CIP_ASM_ATTR_DATA, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return st;
    if (got != info->size)
        return DR_ELENGTH; /* not what the specification says: refuse it */
    memcpy(buf, tmp, got);
    return DR_OK;
}

dr_status_t dr_client_asm_write_sync(dr_client_t *c, dr_asm_t a,
                                     const uint8_t *buf, size_t len)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL || len != info->size)
        return info == NULL ? DR_EINVAL : DR_ELENGTH;
    return dr_client_set_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, c->cfg.instance[a],
                                   DR_CIP_ASM_ATTR_DATA, buf, len);
}

dr_status_t dr_client_asm_size_sync(dr_client_t *c, uint16_t instance, uint16_t *size)
{
    uint8_t tmp[8];
    size_t got = 0;
    dr_status_t st = dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, instance,
                                             DR_CIP_ASM_ATTR_SIZE, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return st;
    if (got != 2)
        return DR_EMALFORMED;
    *size = dr_get_le16(tmp);
    return DR_OK;
}

dr_status_t dr_client_identity_sync(dr_client_t *c, dr_identity_t *id)
{
    uint8_t path[8], tmp[128];
    size_t got = 0;
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, DR_CIP_CLASS_IDENTITY, 1, -1);
    c->step = "identity";
    dr_status_t st = dr_client_call_sync(c, DR_CIP_SVC_GET_ATTRIBUTES_ALL, path, w.len,
                                         NULL, 0, tmp, sizeof tmp, &got);
    if (st != DR_OK)
        return st;
    return dr_identity_parse_all(tmp, got, id);
}

dr_status_t dr_client_list_identity_sync(dr_client_t *c, dr_identity_t *id)
{
    if (c->tcp < 0 || c->state == S_CONNECTING || c->closing != CL_NONE)
        return DR_ESESSION;
    if (!can_wait(c))
        return DR_EINVAL;
    req_t *r = req_alloc(c, R_LIST_IDENTITY);
    if (r == NULL)
        return DR_EFULL;
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    r->rsp = tmp;
    r->cap = sizeof tmp;
    c->step = "list identity";
    dr_status_t st = send_encap(c, DR_ENCAP_LIST_IDENTITY, r->context, NULL, 0);
    deadline_moved(c);
    if (st != DR_OK) {
        r->active = false;
        return st;
    }
    size_t got = 0;
    st = wait_req(c, r, &got);
    if (st != DR_OK)
        return st;
    return dr_list_identity_parse(tmp, got, id);
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
static void close_finish(dr_client_t *c)
{
    complete_all(c, DR_ECLOSED);
    for (unsigned i = 0; i < MAX_REQS; i++)
        c->reqs[i].active = false;
    close_handle(c, &c->tcp);
    if (!c->udp->shared)
        close_handle(c, &c->udp->h);
    c->state = S_IDLE;
    c->closing = CL_NONE;
    c->tx_len = c->rx_len = 0;
    deadline_moved(c);
}

/* One step of a close, from the loop: every phase ends when its work is
 * done or at its deadline, so a silent peer cannot hold the close. */
static void close_step(dr_client_t *c, uint64_t t)
{
    if (c->closing == CL_FWD) {
        if (c->tcp >= 0 && fwd_close_pending(c) && t < c->close_deadline)
            return;
        if (c->state != S_READY) {
            close_finish(c);
            return;
        }
        /* UnRegisterSession, then let the peer close the connection. */
        (void)send_encap(c, DR_ENCAP_UNREGISTER_SESSION, 0, NULL, 0);
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
        close_finish(c);
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
            send_forward_close(cn);
        conn_set_state(cn, DR_CONN_CLOSED, DR_OK); /* dr_client_start reopens */
    }
    c->closing = CL_FWD;
    c->close_deadline = now_us(c) + (uint64_t)c->cfg.timeout_ms * 1000u;
    close_step(c, now_us(c));
    deadline_moved(c);
}

bool dr_client_closed(const dr_client_t *c)
{
    return c->closing == CL_NONE && c->tcp < 0 && !c->started;
}

void dr_client_close(dr_client_t *c)
{
    dr_client_close_start(c);
    while (c->closing != CL_NONE && can_wait(c))
        wait_and_process(c, c->close_deadline);
    if (c->closing != CL_NONE)
        close_finish(c); /* no wait in the transport: what is sent is sent */
}
