/* SPDX-License-Identifier: MIT */
/*
 * The client's insides, shared by its parts and by nothing else: not
 * installed, not for applications (they see drgate/client.h).
 *
 *   client.c          lifecycle: init/deinit of clients and UDP ports,
 *                     configuration defaults, getters, originator serial
 *   client_session.c  TCP session, RegisterSession, explicit requests and
 *                     replies, session timers, the orderly close
 *   client_conn.c     Class 1 connections: Forward Open/Close, produce,
 *                     consume, follow, sequence numbers, their timers
 *   client_port.c     the UDP port: receive, demultiplex by connection
 *                     ID, O->T batches, hold and flush
 *   client_loop.c     dr_client_process, pollfds, next deadline, the
 *                     timer, the bounded wait, run_once
 *   client_sync.c     the blocking *_sync calls
 *
 * Functions shared between the parts carry the drc_ prefix (the library
 * is also linked statically: their names must not collide with an
 * application's); everything else stays static in its file.
 */
#ifndef DRGATE_CLIENT_INTERNAL_H
#define DRGATE_CLIENT_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "cip_internal.h"
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
    uint8_t service; /* the request's CIP service (inside an Unconnected
                        Send when routed): its reply must be service | 0x80 */
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
    uint16_t o2t_size, t2o_size; /* data bytes (an assembly's, or a point's) */
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
    uint8_t out[DR_CLIENT_IO_MAX];
    uint8_t in[DR_CLIENT_IO_MAX];
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
    dr_sockaddr_t tcp_local; /* where the TCP session leaves from (tcp_local) */
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

static inline uint64_t now_us(dr_client_t *c)
{
    return c->tp.ops->now_us(c->tp.ctx);
}

/* len bytes from the transport's random source; false when it has none
 * (or it failed): the caller falls back to its own generator. */
static inline bool drc_random(dr_client_t *c, void *buf, size_t len)
{
    return c->tp.ops->random != NULL &&
           c->tp.ops->random(c->tp.ctx, (uint8_t *)buf, len) == DR_OK;
}

static inline uint32_t min_u32(uint32_t a, uint32_t b)
{
    return a < b ? a : b;
}

/* Something that can move dr_client_next_deadline happened: it is
 * computed again when next asked. Marked after the change (a callback in
 * the middle of it may already have asked). */
static inline void deadline_moved(dr_client_t *c)
{
    c->next_dl_stale = true;
}

/* ---- shared between the parts -------------------------------------------- */

/* Hidden from the shared library's dynamic symbols, like cip_internal.h. */
#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility push(hidden)
#endif

/* client.c */
void drc_close_handle(dr_client_t *c, int *h);

/* client_session.c */
void drc_flush_tx(dr_client_t *c);
dr_status_t drc_send_encap(dr_client_t *c, uint16_t cmd, uint64_t context,
                           const uint8_t *body, size_t body_len);
req_t *drc_req_alloc(dr_client_t *c, req_kind_t kind);
dr_status_t drc_send_rr(dr_client_t *c, req_t *r, const uint8_t *msg,
                        size_t msg_len, bool with_sockaddr);
void drc_session_fail(dr_client_t *c, dr_status_t st);
dr_status_t drc_begin_session(dr_client_t *c);
void drc_read_tcp(dr_client_t *c);
void drc_session_timers(dr_client_t *c, uint64_t t);
dr_status_t drc_start_call(dr_client_t *c, req_kind_t kind, uint8_t service,
                           const uint8_t *path, size_t path_len,
                           const uint8_t *data, size_t data_len, req_t **out);
void drc_close_finish(dr_client_t *c);
void drc_close_step(dr_client_t *c, uint64_t t);

/* client_conn.c */
void drc_conn_set_state(dr_conn_t *cn, dr_conn_state_t s, dr_status_t why);
void drc_conn_schedule_retry(dr_conn_t *cn, dr_status_t why);
void drc_send_forward_close(dr_conn_t *cn);
void drc_close_orphan(dr_client_t *c, const req_t *r, const dr_cip_rsp_t *rsp);
void drc_conn_on_reply(dr_conn_t *cn, req_t *r, const dr_cip_rsp_t *rsp,
                       const dr_cpf_t *cpf);
void drc_conn_timers(dr_conn_t *cn, uint64_t t);
uint64_t drc_conn_deadline(const dr_conn_t *cn);
void drc_conn_datagram(dr_conn_t *cn, const uint8_t *buf, size_t len,
                       const dr_io_frame_t *f, uint64_t t);

/* client_port.c */
void drc_flush_io(dr_client_t *c);
void drc_read_udp(dr_udp_port_t *p, uint64_t t);
int drc_fd_of(dr_transport_t tp, int h);

/* client_loop.c */
void drc_rearm(dr_client_t *c);
bool drc_can_wait(const dr_client_t *c);
void drc_wait_and_process(dr_client_t *c, uint64_t deadline);

#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility pop
#endif

#endif /* DRGATE_CLIENT_INTERNAL_H */
