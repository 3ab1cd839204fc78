/* SPDX-License-Identifier: MIT */
/*
 * drsim adapter: the EtherNet/IP target logic, without sockets or clocks.
 *
 * The event loop (sim/main.c) owns the sockets and the timer; it hands
 * complete encapsulation frames and UDP datagrams to the functions below,
 * together with the monotonic time in nanoseconds, and sends what they
 * return. Keeping the protocol here, deterministic and I/O-free, lets the
 * unit tests (tests/unit/test_sim_*.c) drive every request and every timer.
 *
 * All framing goes through lib/cip.c; all assembly data through the codec.
 */
#ifndef DRSIM_ADAPTER_H
#define DRSIM_ADAPTER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "cip_internal.h"
#include "drgate/codec.h"
#include "drgate/layout.h"
#include "robot.h"

#define DRSIM_MAX_CONNS 64u
/* Heartbeat connection points for input-only (198) and listen-only (199)
 * connections: no O->T data, only the sequence count (+ run/idle). */
#define DRSIM_HB_INPUT_ONLY 198u
#define DRSIM_HB_LISTEN_ONLY 199u
/* RPIs drsim accepts, microseconds (1 ms .. 10 s). */
#define DRSIM_RPI_MIN_US 1000u
#define DRSIM_RPI_MAX_US 10000000u
/* Grace period for the first O->T packet after a Forward Open. */
#define DRSIM_FIRST_PACKET_NS 10000000000ull
/* The robot model runs every 10 ms. */
#define DRSIM_MODEL_PERIOD_NS 10000000ull

/* Identity object (class 1, instance 1). */
#define DRSIM_VENDOR_ID 0xFFFFu   /* no ODVA vendor: a simulator */
#define DRSIM_DEVICE_TYPE 0x0Cu   /* communications adapter */
#define DRSIM_PRODUCT_CODE 1u
#define DRSIM_PRODUCT_NAME "drsim Doosan robot simulator"

typedef struct {
    uint16_t instance[DR_ASM_COUNT]; /* assembly instance per dr_asm_t
                                        (layout per_assembly) */
    /* How the assemblies are offered (--layout): one instance each, or
     * the combined points of layout.input and layout.output. */
    dr_layout_t layout;
    bool echo;                 /* GPR inputs echo to outputs */
    unsigned max_conns;        /* Class 1 connections, 1..DRSIM_MAX_CONNS */
    uint16_t refuse_fo;        /* refuse every Forward Open with 0x01/this; 0 no */
    bool no_large_fo;          /* answer Large Forward Open (0x5B) with 0x08,
                                  like targets that only know 0x54 */
    bool no_get_assembly;      /* Get on an assembly instance: 0x08 (its
                                  data only through I/O connections) */
    bool refuse_identity;      /* Get_Attributes_All on the Identity: 0x08
                                  (--refuse-identity; its single
                                  attributes are still served) */
    uint16_t vendor_id;        /* the Identity's vendor ID (--vendor-id);
                                  DRSIM_VENDOR_ID by default */
    unsigned lose_fo_replies;  /* the first N successful Forward Opens
                                  open their connection, but their reply
                                  is not sent (lost on the way back) */
    uint64_t stop_producing_ns; /* stop T->O this long after an open; 0 never */
    unsigned drop_pct;         /* drop this share (0..100) of I/O packets */
    /* What real adapters do, legal or harmless (docs/interop.md,
     * "Adapter behaviours we accept"): */
    bool seq_on_change;        /* CIP sequence count moves only when the
                                  produced data changed (the encapsulation
                                  sequence number moves every packet) */
    uint32_t tick_us;          /* produce at a coarser tick: the API is the
                                  RPI rounded up to a multiple; 0: the RPI */
    bool api_requested;        /* the Forward Open reply states the
                                  requested RPIs, not the APIs produced at */
    bool trailing_item;        /* Forward Open replies carry one CPF item
                                  more than they declare (an echo of the
                                  0x8001 item) */
    bool still;                /* the robot stands still: no motion, no
                                  noise, so its data stays the same */
    uint64_t owner_hold_ns;    /* an exclusive owner whose O->T stopped is
                                  held this long (only its originator may
                                  take it over); 0: until drsim stops */
    bool drop_t2o;             /* produce, but send no T->O packet: a
                                  firewall that drops UDP towards the
                                  originator (--drop-t2o) */
    bool t2o_to_peer;          /* T->O goes to the TCP peer's address and
                                  only the port of the 0x8001 item, as
                                  OpENer does (--t2o-to-peer) */
    int32_t clock_ppm;         /* drsim's production clock runs this many
                                  parts per million fast (negative: slow),
                                  as a real adapter's crystal does: T->O
                                  packets every API x 1e6 / (1e6 + ppm) */
    uint64_t seed;             /* noise, drops, serial number, IDs */
    uint32_t address;          /* our IPv4 (host order); 0: any */
    uint16_t tcp_port;         /* encapsulation port, for ListIdentity */
    uint16_t udp_port;         /* Class 1 port, announced in 0x8000 items */
    /* Connection points the EDS of a real controller decides: */
    uint16_t config_instance;  /* the only configuration instance accepted
                                  (others: 0x01/0x0129); 0: any */
    uint16_t hb_input_only;    /* input-only heartbeat point (198); 0: none */
    uint16_t hb_listen_only;   /* listen-only heartbeat point (199); 0: none */
} drsim_config_t;

/* Defaults: instances 101..110, echo on, 16 connections, ports 44818/2222,
 * any configuration instance, heartbeats 198 (input-only) and 199
 * (listen-only). */
void drsim_config_default(drsim_config_t *cfg);

/* One TCP peer as the event loop knows it. */
typedef struct {
    uint32_t addr;       /* peer IPv4, host order */
    uint16_t port;
    uint32_t local_addr; /* our address on this TCP connection */
    uint32_t session;    /* registered session handle; 0: none yet */
} drsim_peer_t;

/* One instance of the Assembly object drsim offers: a "point" carrying
 * one assembly (layout per_assembly) or several back to back. */
#define DRSIM_MAX_POINTS DR_ASM_COUNT
typedef struct {
    dr_dir_t dir;
    dr_point_t p; /* instance, size, the assemblies in wire order */
} drsim_point_t;

/* One Class 1 connection. */
typedef struct {
    bool used;
    uint32_t o2t_cid, t2o_cid;
    uint16_t conn_serial, vendor;
    uint32_t orig_serial;
    int o2t_asm;               /* the O->T point (drsim_t.pt: in layout
                                  per_assembly the dr_asm_t), or -1 for a
                                  heartbeat point */
    int t2o_asm;               /* the T->O point, likewise */
    uint16_t o2t_point, t2o_point, config_inst;
    bool o2t_run_idle;         /* O->T carries the 32-bit run/idle header */
    bool listen_only;          /* opened on the listen-only heartbeat point */
    size_t o2t_data_len;       /* O->T data bytes after the headers */
    uint32_t o2t_api_us, t2o_api_us;
    uint64_t timeout_ns;       /* O->T silence that closes the connection */
    uint64_t opened_ns, last_rx_ns, next_produce_ns;
    dr_sockaddr_t t2o_dest;    /* where T->O goes */
    bool o2t_seen;             /* a valid O->T packet has arrived */
    bool run;                  /* last run/idle bit (true if no header) */
    uint32_t o2t_encap_seq;
    uint16_t o2t_cip_seq;
    uint32_t t2o_encap_seq;
    uint16_t t2o_cip_seq;
    bool stopped;              /* --stop-producing-after has struck */
    bool held;                 /* an owner that timed out, kept for its
                                  originator (vendor + orig_serial) */
    uint64_t held_ns;          /* since when */
    uint8_t last_t2o[DR_POINT_MAX_SIZE]; /* last data produced (seq_on_change) */
    /* counters */
    uint64_t produced, produce_dropped, consumed, applied, stale, rx_dropped;
    /* O->T timing as consumed, by arrival time (what a strict adapter
     * checks against the O->T API): first arrival, shortest gap between
     * two, and how many gaps were shorter than 3/4 of the API */
    uint64_t o2t_first_ns, o2t_min_gap_ns, o2t_short;
} drsim_conn_t;

typedef struct {
    drsim_config_t cfg;
    drsim_images_t img;
    drsim_robot_t robot;
    drsim_conn_t conn[DRSIM_MAX_CONNS];
    drsim_point_t pt[DRSIM_MAX_POINTS]; /* the Assembly instances offered */
    unsigned npt;
    dr_identity_t identity;
    uint64_t rng;              /* drop decisions */
    uint32_t next_session;
    uint32_t next_cid;
    unsigned lost_fo_replies;  /* replies --lose-forward-open-reply kept */
    uint64_t start_ns;         /* epoch of the production grid */
    uint64_t next_model_ns;
} drsim_t;

/* Start the adapter at monotonic time `now_ns`. */
void drsim_init(drsim_t *s, const drsim_config_t *cfg, uint64_t now_ns);

/* Which point (index into s->pt) instance `inst` is; -1 if none. In
 * layout per_assembly the index is the dr_asm_t. */
int drsim_asm_of_instance(const drsim_t *s, uint16_t inst);

/* What the event loop does with a frame's result. */
typedef enum {
    DRSIM_REPLY = 0, /* send out[0..*out_len) */
    DRSIM_SILENT,    /* nothing to send */
    DRSIM_CLOSE      /* close the TCP connection (after sending nothing) */
} drsim_action_t;

/* One complete encapsulation frame received on TCP from `peer` (whose
 * session field this updates on RegisterSession). The reply goes to
 * out[cap], at least DR_ENCAP_MAX_LEN bytes. */
drsim_action_t drsim_encap(drsim_t *s, drsim_peer_t *peer, uint64_t now_ns,
                           const uint8_t *frame, size_t len, uint8_t *out,
                           size_t cap, size_t *out_len);

/* One datagram received on UDP 44818: ListIdentity / ListServices are
 * answered, everything else is ignored (DRSIM_SILENT). */
drsim_action_t drsim_encap_udp(drsim_t *s, const drsim_peer_t *peer,
                               const uint8_t *frame, size_t len, uint8_t *out,
                               size_t cap, size_t *out_len);

/* One Message Router request (service, path, data), as carried in a 0x00B2
 * item; writes the reply into out[cap] and returns its length (0 if it did
 * not fit). `t2o_sa` is the request's 0x8001 item or NULL; *o2t_sa_out, if
 * not NULL, is set true when a Forward Open succeeded and the reply CPF
 * must carry our 0x8000 item. */
size_t drsim_cip(drsim_t *s, const drsim_peer_t *peer, uint64_t now_ns,
                 const uint8_t *req, size_t len, const dr_sockaddr_t *t2o_sa,
                 uint8_t *out, size_t cap, bool *o2t_sa_out);

/* Sends one UDP datagram for the adapter. */
typedef void (*drsim_send_fn)(void *ctx, const dr_sockaddr_t *to,
                              const uint8_t *buf, size_t len);

/* One datagram received on the Class 1 UDP port from `from`, at `now_ns`
 * (its arrival: the event loop passes the kernel's receive time). */
void drsim_io_receive(drsim_t *s, uint64_t now_ns, const dr_sockaddr_t *from,
                      const uint8_t *buf, size_t len);

/* Everything due by `now_ns`: the model tick, T->O packets (through
 * `send`), connection timeouts. */
void drsim_run(drsim_t *s, uint64_t now_ns, drsim_send_fn send, void *ctx);

/* Earliest time drsim_run has something to do. */
uint64_t drsim_next_deadline(const drsim_t *s);

/* The connection whose O->T connection ID is `cid`; NULL if none. */
drsim_conn_t *drsim_conn_by_o2t(drsim_t *s, uint32_t cid);
/* Number of open Class 1 connections. */
unsigned drsim_conn_count(const drsim_t *s);

/* Identity status word (attribute 5), from the connections' state. */
uint16_t drsim_identity_status(const drsim_t *s);

#endif /* DRSIM_ADAPTER_H */
