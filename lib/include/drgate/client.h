/* SPDX-License-Identifier: MIT */
/*
 * drgate client: an EtherNet/IP originator for the Doosan robot.
 *
 * One dr_client_t holds one encapsulation session (TCP 44818) with the
 * robot, explicit messaging over it, and any number (up to
 * DR_CLIENT_MAX_CONNS) of Class 1 connections sharing one UDP socket bound
 * to port 2222, demultiplexed by connection ID.
 *
 * Event-loop friendly and thread-free: put the descriptors from
 * dr_client_pollfds() into your poll/epoll (one of them is a timer that
 * fires at the next deadline, so RPIs hold without a fine poll timeout),
 * then call dr_client_process(). Nothing blocks. The explicit-messaging
 * calls named *_sync run that same loop internally until their reply or
 * their timeout, so Class 1 traffic keeps flowing meanwhile; they need the
 * transport's wait (DR_EINVAL without it).
 *
 * Without descriptors (firmware: a transport with no fd, wait or timer),
 * the application's own loop or RTOS task calls dr_client_process() when
 * its sockets may have data and no later than dr_client_next_deadline(),
 * and uses dr_client_call_async() and dr_client_close_start().
 * docs/firmware.md has an lwIP example.
 *
 * Memory: dr_client_init() works in storage the caller provides
 * (dr_client_storage_t, or DR_CLIENT_STORAGE_SIZE bytes with its
 * alignment), and nothing allocates afterwards; the bounds are the
 * compile-time options in drgate/config.h. dr_client_new() is the Linux
 * convenience that takes the storage from malloc and defaults to the POSIX
 * transport; it lives with that transport (lib/client_posix.c), which
 * firmware does not link.
 *
 * Threads: a client, its connections and a dr_udp_port_t shared by several
 * clients belong to one thread (or RTOS task): every call on them, and
 * every callback they make, happens in that thread. Different clients in
 * different threads are fine (they share nothing but the transport, which
 * must then be thread-safe, as sockets are). From a callback, call only
 * dr_conn_set_output, dr_conn_set_run and the dr_conn_state, _stats and
 * _input getters; dr_conn_remove also from the data callback.
 */
#ifndef DRGATE_CLIENT_H
#define DRGATE_CLIENT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/codec.h"
#include "drgate/config.h"
#include "drgate/enip.h"
#include "drgate/status.h"
#include "drgate/transport.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DR_CLIENT_MAX_FDS 3 /* TCP, UDP, timer */

typedef struct dr_client dr_client_t;
typedef struct dr_conn dr_conn_t;
typedef struct dr_udp_port dr_udp_port_t;

/* The session, for event loops (dr_client_start reconnects by itself and
 * says nothing otherwise): called with DR_OK when a session is registered,
 * and with the cause each time an attempt fails or a registered session
 * ends: DR_ENOTFOUND, DR_ECONNREFUSED, DR_EHOSTUNREACH, DR_ENETUNREACH,
 * DR_ENOANSWER (TCP connect not completed within the timeout),
 * DR_ENOREGISTER (connected, RegisterSession not answered), DR_ECLOSED
 * (closed by the peer), DR_ENCAP() (RegisterSession refused), ... The
 * step it failed in is dr_client_last_step(). Not called while the client
 * closes (dr_client_close_start). From the callback, call only the
 * getters (dr_client_ready, dr_client_last_step). */
typedef void (*dr_session_cb)(dr_client_t *c, dr_status_t why, void *user);

/* The configuration is copied by dr_client_init: `host` into the client
 * (at most DR_CLIENT_HOST_MAX - 1 characters), `local_addr` is resolved
 * there and not kept; neither needs to outlive the call. */
typedef struct {
    const char *host;         /* robot address or name */
    uint16_t tcp_port;        /* 0: 44818 */
    uint16_t udp_port;        /* robot's Class 1 port; 0: 2222 (a 0x8000
                                 item in the Forward Open reply wins) */
    const char *local_addr;   /* local address for UDP and TCP, NULL: any.
                                 The TCP session leaves from it too (an
                                 adapter sends T->O to the TCP peer's
                                 address, whatever the 0x8001 item says):
                                 a transport without tcp_connect_from is
                                 refused with DR_EUNSUPPORTED */
    uint16_t local_udp_port;  /* 0: 2222 */
    uint32_t timeout_ms;      /* explicit request timeout; 0: 2000 */
    uint16_t instance[DR_ASM_COUNT]; /* 0: default 101..110 */
    uint16_t vendor_id;       /* originator vendor ID (0: 0xFFFE) */
    uint32_t serial;          /* originator serial number; 0: from the
                                 clock, see "Originator serial" below */
    bool route;               /* wrap requests in Unconnected Send */
    uint32_t backoff_min_ms;  /* reconnect backoff: 0: 100 ms */
    uint32_t backoff_max_ms;  /* 0: 5000 ms */
    dr_transport_t transport; /* required by dr_client_init; dr_client_new
                                 takes ops NULL as dr_transport_posix() */
    dr_udp_port_t *shared_udp; /* NULL: the client opens its own UDP socket
                                  at local_addr:local_udp_port */
    dr_session_cb on_session; /* optional: the session's attempts and ends */
    void *session_user;       /* passed to on_session */
} dr_client_config_t;

/* ---- originator serial --------------------------------------------------- */

/* The vendor ID and originator serial number name the originator in every
 * Forward Open and Forward Close. An adapter keeps an exclusive-owner
 * connection whose originator went silent (a crash, a power cut, a cable)
 * in a timed-out state, and lets only the same vendor ID + originator
 * serial take it over; anyone else is refused with 0x01/0x0106 (ownership
 * conflict) for as long as the adapter holds it, which for some adapters
 * is until they restart. A restarted originator must therefore come back
 * with the serial it had, as a PLC does: pass a stable one in
 * dr_client_config_t.serial.
 *
 * Left 0, the library takes one from the clock, different at every start:
 * unique, but a restarted application is locked out of the connections of
 * its previous run. The library cannot do better by itself (in firmware
 * it knows nothing stable about its host); drgatewayd and drcli always
 * pass a stable serial (dr_originator_serial_local). Firmware should
 * derive one from something unique to the device, e.g. its MAC address:
 * dr_originator_serial(mac_text, robot_name). */

/* FNV-1a (32 bits) over the bytes of host_id, one 0 byte, and the bytes of
 * name; 1 if that is 0 (0 means "not set"). Pure: the same arguments give
 * the same serial on every machine and every run. */
uint32_t dr_originator_serial(const char *host_id, const char *name);

/* POSIX (lib/client_posix.c): dr_originator_serial(host_id, name), host_id
 * the first line of /etc/machine-id, or the host name (gethostname) when
 * that file is missing or empty, or "" when neither is known. Stable for
 * one installation of the machine and one name (drgatewayd: the robot's
 * section name; drcli: the robot's address as given). */
uint32_t dr_originator_serial_local(const char *name);

/* ---- a Class 1 UDP port shared by several clients --------------------- */

/* Storage for dr_client_init / dr_udp_port_init, as upper bounds computed
 * from drgate/config.h, with DR_STORAGE_RESERVE to spare for later
 * versions of the library (the library checks at build time that its
 * structures fit; dr_client_size() / dr_udp_port_size() give the exact
 * figure). The unions carry the strictest alignment the structures need
 * (C99 has no max_align_t): declare one of these, statically or on the
 * heap, or align raw storage like them. */
#define DR_UDP_PORT_STORAGE_SIZE                                              \
    (DR_CLIENT_RX_BATCH * DR_CLIENT_UDP_BUF +                                 \
     (DR_UDP_PORT_MAX_CLIENTS + 8) * sizeof(void *) + 64 + DR_STORAGE_RESERVE / 4)
#define DR_CLIENT_STORAGE_SIZE                                                \
    (DR_CLIENT_HOST_MAX + DR_ENCAP_MAX_LEN + DR_CLIENT_TX_BUF +               \
     DR_UDP_PORT_STORAGE_SIZE + DR_CLIENT_MAX_REQS * (64 + 4 * sizeof(void *)) + \
     DR_CLIENT_MAX_CONNS * (2 * DR_CLIENT_IO_MAX + DR_CLIENT_UDP_BUF + 272 +  \
                            8 * sizeof(void *)) +                             \
     256 + 16 * sizeof(void *) + DR_STORAGE_RESERVE)

typedef union {
    unsigned char bytes[DR_CLIENT_STORAGE_SIZE];
    uint64_t align_u64;
    void *align_ptr;
    void (*align_fn)(void);
    double align_double;
    long double align_ldouble;
} dr_client_storage_t;

typedef union {
    unsigned char bytes[DR_UDP_PORT_STORAGE_SIZE];
    uint64_t align_u64;
    void *align_ptr;
    void (*align_fn)(void);
    double align_double;
    long double align_ldouble;
} dr_udp_port_storage_t;

/* The exact sizes of the structures in this build of the library. */
size_t dr_client_size(void);
size_t dr_udp_port_size(void);

/* ---- a Class 1 UDP port shared by several clients --------------------- */

/* One process talking to several robots needs one UDP port 2222 for all of
 * them: open it here and pass it in each client's config. The application
 * polls dr_udp_port_fd() (-1 if the transport has no fd) and calls
 * dr_udp_port_process(), which hands each datagram to the client whose
 * connection it belongs to. Deinit the clients first.
 * dr_udp_port_init works in `size` bytes at `storage` (aligned like
 * dr_udp_port_storage_t) and needs a transport; NULL on error (*err:
 * DR_EINVAL for storage or transport, DR_ENOTFOUND, DR_EIO, ...).
 * dr_udp_port_new (POSIX only) allocates (DR_ENOMEM when it cannot);
 * transport ops NULL: POSIX. */
dr_udp_port_t *dr_udp_port_init(void *storage, size_t size, const char *local_addr,
                                uint16_t port, dr_transport_t transport,
                                dr_status_t *err);
void dr_udp_port_deinit(dr_udp_port_t *p);
dr_udp_port_t *dr_udp_port_new(const char *local_addr, uint16_t port,
                               dr_transport_t transport, dr_status_t *err);
void dr_udp_port_free(dr_udp_port_t *p);
int dr_udp_port_fd(const dr_udp_port_t *p);
void dr_udp_port_process(dr_udp_port_t *p);

/* The clients of one port produce their O->T packets at the same instants
 * (they share the port's time grid). With hold set, the packets a client's
 * dr_client_process / _process_ready produces wait in the client, and
 * dr_udp_port_flush() sends those of every client in one batch call:
 * call it at the end of every turn of the loop (dr_udp_port_process sends
 * them too). The blocking *_sync calls send at once. Clearing hold
 * flushes. Off by default. */
void dr_udp_port_hold(dr_udp_port_t *p, bool hold);
void dr_udp_port_flush(dr_udp_port_t *p);

/* Sets up a client in `size` bytes at `storage` (a dr_client_storage_t, or
 * at least dr_client_size() bytes aligned like it), which must stay in
 * place until dr_client_deinit. Nothing is sent yet. NULL with *err:
 * DR_EINVAL (no host, host too long, a transport without its required
 * calls, storage too small or misaligned), the transport's error for
 * local_addr or its timer, DR_EFULL (the shared UDP port is full),
 * DR_EUNSUPPORTED (local_addr with a transport that cannot bind TCP). */
dr_client_t *dr_client_init(void *storage, size_t size, const dr_client_config_t *cfg,
                            dr_status_t *err);
/* Closes everything (dr_client_close_sync) and lets go of the storage and
 * the shared UDP port. NULL is fine. */
void dr_client_deinit(dr_client_t *c);

/* Linux convenience (lib/client_posix.c, not in firmware builds): the
 * storage from malloc, and transport ops NULL meaning dr_transport_posix().
 * NULL with *err (when err is not NULL) saying why: DR_ENOMEM, or what
 * dr_client_init says (DR_EINVAL for no config, ...). dr_client_free
 * deinits and frees; NULL is fine. */
dr_client_t *dr_client_new(const dr_client_config_t *cfg, dr_status_t *err);
void dr_client_free(dr_client_t *c);

/* ---- session and explicit messaging -------------------------------- */

/* Connect and register a session, within the timeout.
 * Errors: DR_ENOTFOUND, DR_ECONNREFUSED, DR_EHOSTUNREACH, DR_ENETUNREACH,
 * DR_ENOANSWER (the TCP connection not made within the timeout),
 * DR_ENOREGISTER (made, but RegisterSession not answered), DR_ECLOSED,
 * DR_EIO, DR_ENCAP() (RegisterSession refused). */
dr_status_t dr_client_connect_sync(dr_client_t *c);

/* Start the session in the background (for event loops): the client
 * connects, registers, opens its connections and reconnects by itself.
 * Failures are retried with backoff and reported to on_session. */
void dr_client_start(dr_client_t *c);

/* Close without blocking: Forward Close every open connection (their
 * state callbacks report DR_CONN_CLOSED now), and stop reconnecting. The
 * loop (dr_client_process, by dr_client_next_deadline) then waits for the
 * Forward Close replies (at most the request timeout), sends
 * UnRegisterSession, waits for the peer to close (at most 500 ms) and
 * closes the sockets; dr_client_closed() then turns true. New requests are
 * refused meanwhile (DR_ESESSION). The client can be started again. */
void dr_client_close_start(dr_client_t *c);
/* No session, no close under way and not started: all is closed. */
bool dr_client_closed(const dr_client_t *c);

/* dr_client_close_start, then the loop until dr_client_closed (bounded as
 * said there). Without the transport's wait, what could be sent at once
 * was sent and the sockets close now. */
void dr_client_close_sync(dr_client_t *c);

/* Change the explicit request timeout (e.g. shorter for a quick shutdown). */
void dr_client_set_timeout(dr_client_t *c, uint32_t timeout_ms);

/* Is the session registered? */
bool dr_client_ready(const dr_client_t *c);

/* Any CIP service to any path: data in, reply data out.
 * Returns DR_OK, DR_CIP(general, extended) from the reply, DR_ENOSPACE if
 * the reply does not fit `cap`, or a network error. *rsp_len is set when
 * reply data was copied (also on CIP errors that carry data). */
dr_status_t dr_client_call_sync(dr_client_t *c, uint8_t service,
                                const uint8_t *path, size_t path_len,
                                const uint8_t *data, size_t data_len,
                                uint8_t *rsp, size_t cap, size_t *rsp_len);

dr_status_t dr_client_get_attr_sync(dr_client_t *c, uint16_t cls, uint16_t inst,
                                    uint16_t attr, uint8_t *buf, size_t cap,
                                    size_t *len);
dr_status_t dr_client_set_attr_sync(dr_client_t *c, uint16_t cls, uint16_t inst,
                                    uint16_t attr, const uint8_t *data,
                                    size_t len);

/* Assembly data (attribute 3) of assembly `a` at its configured instance.
 * A reply of another size than the specification's is DR_ELENGTH. */
dr_status_t dr_client_read_asm_sync(dr_client_t *c, dr_asm_t a, uint8_t *buf,
                                    size_t len);
dr_status_t dr_client_write_asm_sync(dr_client_t *c, dr_asm_t a,
                                     const uint8_t *buf, size_t len);
/* Attribute 4 (size in bytes) of an assembly instance. */
dr_status_t dr_client_read_asm_size_sync(dr_client_t *c, uint16_t instance,
                                         uint16_t *size);

/* Asynchronous form for event loops: `done` is called from
 * dr_client_process() with the status and the reply data (valid only
 * during the call), never from within dr_client_call_async itself: a
 * request that cannot be sent (no session, the session failing as it is
 * sent) is refused with the error instead, and `done` is not called.
 * DR_EFULL if too many requests are in flight. */
typedef void (*dr_call_cb)(dr_client_t *c, dr_status_t status,
                           const uint8_t *data, size_t len, void *user);
dr_status_t dr_client_call_async(dr_client_t *c, uint8_t service,
                                 const uint8_t *path, size_t path_len,
                                 const uint8_t *data, size_t data_len,
                                 dr_call_cb done, void *user);

/* Identity object (class 1, instance 1) and ListIdentity over TCP. */
dr_status_t dr_client_read_identity_sync(dr_client_t *c, dr_identity_t *id);
dr_status_t dr_client_list_identity_sync(dr_client_t *c, dr_identity_t *id);

/* Instance number in use for assembly a. */
uint16_t dr_client_instance(const dr_client_t *c, dr_asm_t a);

/* Where the last error happened: "connect", "register session", "get",
 * "set", "forward open", ... (static string). */
const char *dr_client_last_step(const dr_client_t *c);

/* Where the robot is to send T->O packets: the local address (or, with
 * none, the address the TCP session leaves from, 0 before it connected or
 * when the transport has no tcp_local) and the local UDP port. For
 * messages: "sends no data to 10.0.0.5:2222". */
dr_sockaddr_t dr_client_t2o_addr(const dr_client_t *c);

/* What the session saw that was accepted but not as it should be. */
typedef struct {
    uint64_t replies_trailing; /* SendRRData replies with bytes after their
                                  declared CPF items (ignored) */
} dr_client_stats_t;

const dr_client_stats_t *dr_client_stats(const dr_client_t *c);

/* ---- Class 1 implicit I/O -------------------------------------------- */

typedef enum {
    DR_CONN_IDLE = 0,     /* not opened yet (waiting for the session) */
    DR_CONN_OPENING,      /* Forward Open sent */
    DR_CONN_ESTABLISHED,  /* data flowing */
    DR_CONN_TIMED_OUT,    /* no T->O data within the timeout */
    DR_CONN_RECONNECTING, /* waiting out the backoff before a new open */
    DR_CONN_CLOSED        /* closed by the caller */
} dr_conn_state_t;

const char *dr_conn_state_name(dr_conn_state_t s);

/* New T->O data: `data` (the assembly's size) is the connection's input
 * buffer, valid until the callback returns; copy what you keep. */
typedef void (*dr_conn_data_cb)(dr_conn_t *conn, const uint8_t *data,
                                size_t len, void *user);
/* State changes with the reason (DR_OK for a normal transition, else the
 * error that caused it, e.g. DR_ETIMEDOUT or DR_CIP(0x01, 0x0113)). A
 * connection that times out before its first T->O packet (it gets
 * 2 s + its timeout for that one) says DR_ENODATA, not DR_ETIMEDOUT. */
typedef void (*dr_conn_state_cb)(dr_conn_t *conn, dr_conn_state_t state,
                                 dr_status_t reason, void *user);

typedef struct {
    int o2t_asm;              /* an O->T dr_asm_t, or -1: input only */
    dr_asm_t t2o_asm;         /* a T->O assembly */
    uint16_t config_instance; /* 0: 1 */
    uint16_t heartbeat_instance; /* input only; 0: 198 */
    uint32_t rpi_us;          /* requested packet interval, both ways */
    uint8_t timeout_mult;     /* code 0..7: timeout = API x (4 << code) */
    bool large;               /* use Large Forward Open (0x5B) first */
    bool t2o_run_idle;        /* T->O carries a run/idle header (no: modeless) */
    uint32_t o2t_follow_us;   /* 0: O->T strictly on its own timer. Else an
                                 O->T packet due within this window (at most
                                 half the API) is sent when the T->O packet
                                 arrives: one wake-up per period instead of
                                 two, packets up to the window early, never
                                 two closer than API - window, never more
                                 than one per API, never two further apart
                                 than API + window */
    dr_conn_data_cb on_data;
    dr_conn_state_cb on_state;
    void *user;
    /* Connection points that are not one assembly (drgate/layout.h: a
     * combined layout carries several assemblies in one image). 0: the
     * assembly's own instance and size. A T->O point of its own still
     * needs t2o_asm (a T->O assembly it carries), an O->T one o2t_asm >= 0
     * (an O->T assembly it carries); on_data then gets the point's whole
     * image, dr_conn_set_output takes one. Sizes up to DR_CLIENT_IO_MAX. */
    uint16_t t2o_instance, t2o_size;
    uint16_t o2t_instance, o2t_size;
} dr_conn_config_t;

/* Add a connection; it opens once the session is up, and reopens after a
 * failure with capped exponential backoff. NULL if the pool is full or the
 * config is invalid (DR_EINVAL in *err if err is not NULL).
 *
 * Forward Opens nobody waits for must never open a connection the adapter
 * then holds as an owner (refusing the next opens with 0x0106): a Forward
 * Open that gets no answer within the request timeout resets the session
 * (the transport's tcp_abort drops what TCP still holds, the session
 * comes back after its backoff); one that ended without an answer is
 * closed by its triad (Forward Close) just before that connection's next
 * open; and a success that comes for a connection removed or closed
 * meanwhile is closed at once. dr_client_close_start waits for the
 * answers of the opens still out, as for its Forward Closes. */
dr_conn_t *dr_conn_add(dr_client_t *c, const dr_conn_config_t *cfg, dr_status_t *err);

/* The pair of dr_conn_add: Forward Close (if open) and release the slot.
 * NULL is fine. */
void dr_conn_remove(dr_conn_t *conn);

/* Copy new O->T data (the assembly's size exactly); sent from the next
 * RPI on. DR_ELENGTH, DR_EINVAL for input-only connections. */
dr_status_t dr_conn_set_output(dr_conn_t *conn, const uint8_t *data, size_t len);

/* The run/idle bit sent in the O->T header (default run). */
void dr_conn_set_run(dr_conn_t *conn, bool run);

/* T->O sequence handling: a packet whose 32-bit encapsulation sequence
 * number is not newer (wrap-safe) than the last one taken is a duplicate
 * or late: dropped (rx_dropped_seq), and it does not keep the connection
 * alive. Every newer packet does (rx_packets, last_rx_us, the timeout),
 * as long as it is at most max(8, (4 << timeout_mult) / 2) ahead: a
 * number further ahead than a live producer can have gone is a corrupted
 * one (a bit flipped in a datagram without a UDP checksum) and is dropped
 * too, so that it cannot make the real packets after it look old. Such
 * numbers are believed only once the sequence taken so far has gone
 * silent, no packet taken for half the timeout, and then only the third
 * of a row of them that follow each other within that window: the
 * producer jumped, and is followed from there (rx_resyncs). While the
 * real sequence is alive, packets far ahead of it (forged, or corrupted)
 * cost nothing but themselves, however many agree with each other.
 * Whether it carries new data goes by the 16-bit CIP sequence count: the
 * same count as the last new data is a repeat (rx_repeats: no copy, no
 * on_data), as producers may send while their data is unchanged; any
 * other count is new data, and a newer one counts the counts skipped
 * (rx_lost). A count that goes back (a producer that started counting
 * again) is new data with no gap. New samples: rx_packets - rx_repeats.
 *
 * Who may send T->O data: only the target. A packet carrying the ID of an
 * established connection is taken only from the address the session's TCP
 * connection goes to, or from the address the Forward Open reply named for
 * O->T (its O->T sockaddr item: where the target's I/O lives); any other
 * source is dropped and counted (rx_dropped_addr), whatever its sequence
 * numbers. The source port is not checked (targets send from 2222, but
 * NAT and some stacks do not keep it). This keeps out every host that
 * cannot forge the robot's IP source address; one that can (on the same
 * segment, with raw sockets) is limited by the sequence rules above: a
 * few forged packets cost at most those packets, never the connection. */
typedef struct {
    uint64_t rx_packets;       /* T->O packets taken: new data and repeats */
    uint64_t rx_dropped_seq;   /* stale or duplicate (encapsulation sequence) */
    uint64_t rx_bad, tx_packets;
    uint64_t rx_lost;          /* gaps in the CIP sequence count of new data */
    uint64_t rx_repeats;       /* packets taken that repeat the CIP count */
    uint64_t last_rx_us;       /* monotonic time of the last packet taken */
    uint32_t o2t_api_us, t2o_api_us; /* from the Forward Open reply */
    uint32_t timeout_us;  /* T->O silence that times the connection out:
                             t2o_api_us x (4 << timeout_mult), at most
                             UINT32_MAX (see timeout_us64) */
    uint32_t o2t_cid, t2o_cid;
    uint32_t opens, timeouts;
    uint16_t size_wanted; /* from a 0x0109 refusal: the target's size */
    uint64_t rx_resyncs;  /* encapsulation sequence numbers followed after
                             a jump too far ahead (see above) */
    /* Added after 1.0.0 (appended: the fields above keep their places). */
    uint64_t rx_dropped_addr; /* T->O packets with this connection's ID from
                                 a source address other than the target's:
                                 dropped (see "Who may send T->O data") */
    uint64_t timeout_us64;    /* timeout_us, exact: timeout_us saturates at
                                 UINT32_MAX (RPI 9 s x 512 is 4608 s) */
    uint64_t opened_us;       /* monotonic time the connection was last
                             established (its Forward Open answered) */
} dr_conn_stats_t;

dr_conn_state_t dr_conn_state(const dr_conn_t *conn);
const dr_conn_stats_t *dr_conn_stats(const dr_conn_t *conn);
void *dr_conn_user(const dr_conn_t *conn);
/* Last T->O data (the assembly's size), NULL before the first packet.
 * The buffer belongs to the connection: it changes when the next packet
 * arrives (in dr_client_process / dr_udp_port_process) and goes with
 * dr_conn_remove or dr_client_deinit. */
const uint8_t *dr_conn_input(const dr_conn_t *conn, size_t *len);

/* ---- discovery ----------------------------------------------------------- */

typedef void (*dr_discover_cb)(const dr_identity_t *id, dr_sockaddr_t from,
                               void *user);

/* ListIdentity over UDP to `target` (a device, or a broadcast address such
 * as 192.168.1.255 to find every device on that subnet) at `port` (0:
 * 44818). Calls `found` for every valid answer until timeout_ms has passed
 * (for a unicast target, after the first answer). Returns DR_OK if anything
 * answered, DR_ETIMEDOUT if nothing did, or a network error. Blocking:
 * the transport must have wait (else DR_EINVAL). */
dr_status_t dr_discover(const char *target, uint16_t port, uint32_t timeout_ms,
                        dr_transport_t transport, dr_discover_cb found, void *user,
                        unsigned *count);

/* ---- event loop -------------------------------------------------------- */

typedef struct {
    int fd;
    short events;  /* DR_POLL_IN / DR_POLL_OUT: what to wait for */
    short revents; /* for dr_client_process_ready: non-zero if ready */
} dr_pollfd_t;

#define DR_POLL_IN 0x1
#define DR_POLL_OUT 0x4

/* The descriptors to watch now (at most DR_CLIENT_MAX_FDS). They change
 * when sockets are opened or closed: ask again after each process call.
 * None if the transport has no fd. */
int dr_client_pollfds(dr_client_t *c, dr_pollfd_t *fds, int max);

/* Monotonic microseconds (the transport's now_us) of the next timer
 * (UINT64_MAX if none): call dr_client_process() by then. Not const: the
 * client keeps the answer until something moves it, so that a loop may
 * ask at every turn for the cost of a compare. */
uint64_t dr_client_next_deadline(dr_client_t *c);

/* Do all that is due: read every socket until it would block, run timers
 * (O->T production, timeouts, reconnects, request timeouts). Never blocks.
 * Session problems are reported through the connections' state
 * callbacks, on_session and dr_client_ready(). */
void dr_client_process(dr_client_t *c);

/* The same, for callers that know which descriptors their poll reported
 * (revents set in fds[0..n) as returned by dr_client_pollfds): sockets
 * that were not ready are not read, which saves a system call each per
 * wake-up at short RPIs. */
void dr_client_process_ready(dr_client_t *c, const dr_pollfd_t *fds, int n);

/* Wait for the client's descriptors at most timeout_ms and process once.
 * For simple programs that have no loop of their own; needs the
 * transport's wait (else DR_EINVAL). */
dr_status_t dr_client_run_once(dr_client_t *c, int timeout_ms);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_CLIENT_H */
