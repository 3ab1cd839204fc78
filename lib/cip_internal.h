/* SPDX-License-Identifier: MIT */
/*
 * drgate cip: EtherNet/IP encapsulation, CPF and CIP messages on the wire.
 * Private to the library and its test peers (drsim, the fuzzers, the
 * tests, which include it from lib/ with -Ilib): not installed. What an
 * application needs of it (ports, services, classes, the Identity record,
 * paths) is public in drgate/enip.h.
 *
 * Builders and parsers only: no sockets, no clock, no malloc. Both ends use
 * them: the client (originator) and drsim (adapter). Every parser checks
 * every length before it reads and rejects a frame whose lengths disagree
 * (short, long or lying); parsed views point into the caller's buffer.
 *
 * References: CIP Vol. 1 (Message Router 2-4, Connection Manager 3-5),
 * Vol. 2 (encapsulation 2-3, CPF 2-6, Class 1 over UDP 3-3).
 */
#ifndef DRGATE_CIP_INTERNAL_H
#define DRGATE_CIP_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/enip.h"
#include "drgate/status.h"
#include "drgate/transport.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Not part of the shared library's interface: hidden from its dynamic
 * symbols (the programs that use them link the static library). */
#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility push(hidden)
#endif

/* ---- constants ------------------------------------------------------- */

enum {
    DR_ENCAP_NOP = 0x0000,
    DR_ENCAP_LIST_SERVICES = 0x0004,
    DR_ENCAP_LIST_IDENTITY = 0x0063,
    DR_ENCAP_LIST_INTERFACES = 0x0064,
    DR_ENCAP_REGISTER_SESSION = 0x0065,
    DR_ENCAP_UNREGISTER_SESSION = 0x0066,
    DR_ENCAP_SEND_RR_DATA = 0x006F,
    DR_ENCAP_SEND_UNIT_DATA = 0x0070
};

enum {
    DR_CPF_NULL = 0x0000,
    DR_CPF_LIST_IDENTITY = 0x000C,
    DR_CPF_CONNECTED_ADDRESS = 0x00A1,
    DR_CPF_CONNECTED_DATA = 0x00B1,
    DR_CPF_UNCONNECTED_DATA = 0x00B2,
    DR_CPF_SOCKADDR_O2T = 0x8000,
    DR_CPF_SOCKADDR_T2O = 0x8001,
    DR_CPF_SEQUENCED_ADDRESS = 0x8002
};

/* Services of the Connection Manager and the reply bit (the general ones
 * are in drgate/enip.h). */
enum {
    DR_CIP_SVC_FORWARD_CLOSE = 0x4E,
    DR_CIP_SVC_UNCONNECTED_SEND = 0x52,
    DR_CIP_SVC_FORWARD_OPEN = 0x54,
    DR_CIP_SVC_LARGE_FORWARD_OPEN = 0x5B,
    DR_CIP_REPLY = 0x80
};

#define DR_ENCAP_HEADER_LEN 24u

/* ---- encapsulation ------------------------------------------------------ */

typedef struct {
    uint16_t command;
    uint16_t length; /* bytes after the 24-byte header */
    uint32_t session;
    uint32_t status;
    uint8_t context[8];
    uint32_t options;
} dr_encap_t;

/* Bytes of the whole frame that starts in buf[0..len), once at least the
 * header is there: DR_OK and *total, or DR_EAGAIN (header incomplete), or
 * DR_ELONG (longer than DR_ENCAP_MAX_LEN, the stream cannot be trusted). */
dr_status_t dr_encap_frame_len(const uint8_t *buf, size_t len, size_t *total);

/* Parse one complete frame of exactly `len` bytes; *body points after the
 * header. DR_ESHORT / DR_ELONG when len disagrees with the header. */
dr_status_t dr_encap_parse(const uint8_t *buf, size_t len, dr_encap_t *hdr,
                           const uint8_t **body);

/* Write a header for a body of `body_len` bytes that the caller has already
 * put at buf + 24. Returns DR_OK or DR_ENOSPACE (cap < 24 + body_len). */
dr_status_t dr_encap_write(uint8_t *buf, size_t cap, const dr_encap_t *hdr,
                           size_t body_len);

/* ---- common packet format ------------------------------------------------ */

#define DR_CPF_MAX_ITEMS 4u

typedef struct {
    uint16_t type;
    uint16_t length;
    const uint8_t *data;
} dr_cpf_item_t;

typedef struct {
    uint16_t count;
    dr_cpf_item_t item[DR_CPF_MAX_ITEMS];
} dr_cpf_t;

/* Parse a CPF that fills buf[0..len) exactly. DR_EMALFORMED for more than
 * DR_CPF_MAX_ITEMS items; DR_ESHORT / DR_ELONG on disagreeing lengths. */
dr_status_t dr_cpf_parse(const uint8_t *buf, size_t len, dr_cpf_t *cpf);

/* The same for a reply that we only read: every declared item is still
 * length-checked, but bytes after them are not an error. They are left
 * out and counted in *extra (some adapters append an item they did not
 * count, e.g. an echo of the request's 0x8001 item; Wireshark ignores it
 * too). Requests, which we act on, go through dr_cpf_parse. */
dr_status_t dr_cpf_parse_reply(const uint8_t *buf, size_t len, dr_cpf_t *cpf,
                               size_t *extra);

/* First item of `type`, NULL if none. */
const dr_cpf_item_t *dr_cpf_find(const dr_cpf_t *cpf, uint16_t type);

/* Socket address item (0x8000/0x8001): big-endian family, port, address.
 * dr_sockaddr_t itself is in transport.h. */

dr_status_t dr_cpf_sockaddr_parse(const dr_cpf_item_t *item, dr_sockaddr_t *out);

/* ---- bounded writer, for building messages ----------------------------- */

typedef struct {
    uint8_t *buf;
    size_t cap;
    size_t len;
    bool overflow; /* set once anything did not fit; later puts are ignored */
} dr_wr_t;

void dr_wr_init(dr_wr_t *w, uint8_t *buf, size_t cap);
void dr_wr_u8(dr_wr_t *w, uint8_t v);
void dr_wr_u16(dr_wr_t *w, uint16_t v);
void dr_wr_u32(dr_wr_t *w, uint32_t v);
void dr_wr_u16_be(dr_wr_t *w, uint16_t v);
void dr_wr_u32_be(dr_wr_t *w, uint32_t v);
void dr_wr_bytes(dr_wr_t *w, const void *p, size_t n);
/* Reserve n bytes to fill in later; NULL on overflow. */
uint8_t *dr_wr_reserve(dr_wr_t *w, size_t n);

/* Items: start one, write its data, finish it (fills in its length). */
void dr_cpf_begin(dr_wr_t *w, uint16_t item_count);
size_t dr_cpf_item_begin(dr_wr_t *w, uint16_t type);
void dr_cpf_item_end(dr_wr_t *w, size_t mark);
void dr_cpf_sockaddr_write(dr_wr_t *w, uint16_t type, dr_sockaddr_t sa);

/* ---- encapsulation command bodies ---------------------------------------- */

/* RegisterSession body: protocol version (1) and options (0), 4 bytes.
 * Parse: DR_ESHORT / DR_ELONG unless exactly 4 bytes. */
dr_status_t dr_register_parse(const uint8_t *body, size_t len,
                              uint16_t *version, uint16_t *options);
void dr_register_write(dr_wr_t *w, uint16_t version, uint16_t options);

/* SendRRData / SendUnitData body: interface handle (u32, 0 for CIP),
 * timeout (u16), then a CPF filling the rest (parsed into *cpf). */
dr_status_t dr_rr_parse(const uint8_t *body, size_t len, uint32_t *iface,
                        uint16_t *timeout, dr_cpf_t *cpf);
/* Write interface handle 0 and the timeout; the caller then writes the CPF. */
void dr_rr_begin(dr_wr_t *w, uint16_t timeout);

/* ListServices reply body: a CPF with one 0x0100 "Communications" item
 * (version 1, capability flags: CIP over TCP, Class 0/1 over UDP). */
#define DR_CPF_LIST_SERVICES 0x0100u
#define DR_SVC_FLAG_CIP_TCP 0x0020u
#define DR_SVC_FLAG_CLASS01_UDP 0x0100u
void dr_list_services_write(dr_wr_t *w, uint16_t flags);

/* ---- CIP requests and replies (Message Router) ------------------------ */

/* A parsed EPATH of logical segments (class, instance, attribute,
 * connection points) with 8- or 16-bit values. */
typedef struct {
    uint16_t cls, inst, attr;
    uint16_t point[2]; /* connection points in order: O->T, T->O */
    uint8_t has_cls, has_inst, has_attr, points;
    uint8_t has_key; /* an electronic key segment was present (and skipped) */
    const uint8_t *data; /* simple data segment (0x80), e.g. config data */
    uint8_t data_words;
} dr_epath_t;

/* Parse `len` bytes of EPATH. DR_CIP(0x04, 0) for segments we do not know
 * (a path segment error is the right CIP answer to send back). */
dr_status_t dr_epath_parse(const uint8_t *buf, size_t len, dr_epath_t *out);

/* Append logical segments for class/instance[/attribute], 8 or 16-bit as
 * the value needs. attr < 0 leaves the attribute out. */
void dr_epath_write(dr_wr_t *w, uint16_t cls, uint16_t inst, int attr);

typedef struct {
    uint8_t service;
    const uint8_t *path; /* raw EPATH */
    size_t path_len;
    const uint8_t *data;
    size_t data_len;
} dr_cip_req_t;

dr_status_t dr_cip_req_parse(const uint8_t *buf, size_t len, dr_cip_req_t *req);

/* Write service + path (as given) + data. */
void dr_cip_req_write(dr_wr_t *w, uint8_t service, const uint8_t *path,
                      size_t path_len, const uint8_t *data, size_t data_len);

typedef struct {
    uint8_t service; /* with the 0x80 reply bit */
    uint8_t general;
    uint8_t ext_count; /* words of additional status */
    uint16_t ext[2];   /* first two words */
    const uint8_t *data;
    size_t data_len;
} dr_cip_rsp_t;

dr_status_t dr_cip_rsp_parse(const uint8_t *buf, size_t len, dr_cip_rsp_t *rsp);

/* Status of a reply as one code: DR_OK, or DR_CIP(general, first ext). */
dr_status_t dr_cip_rsp_status(const dr_cip_rsp_t *rsp);

void dr_cip_rsp_write(dr_wr_t *w, uint8_t service, uint8_t general,
                      const uint16_t *ext, uint8_t ext_count,
                      const uint8_t *data, size_t data_len);

/* Unconnected Send (0x52) to the Connection Manager: the embedded request
 * and the route path. */
typedef struct {
    uint8_t priority_tick, timeout_ticks;
    const uint8_t *message;
    size_t message_len;
    const uint8_t *route;
    size_t route_len;
} dr_ucmm_send_t;

dr_status_t dr_ucmm_send_parse(const uint8_t *data, size_t len, dr_ucmm_send_t *out);
void dr_ucmm_send_write(dr_wr_t *w, const uint8_t *message, size_t message_len,
                        const uint8_t *route, size_t route_len);

/* ---- Forward Open / Close (Connection Manager) ------------------------- */

typedef struct {
    uint16_t size;    /* bytes incl. sequence count and run/idle header */
    uint8_t type;     /* 0 null, 1 multicast, 2 point-to-point */
    uint8_t priority; /* 0 low, 1 high, 2 scheduled, 3 urgent */
    bool variable;
    bool redundant_owner;
} dr_netparams_t;

enum { DR_CONN_TYPE_NULL = 0, DR_CONN_TYPE_MULTICAST = 1, DR_CONN_TYPE_P2P = 2 };

typedef struct {
    bool large; /* 0x5B with 32-bit network parameters */
    uint8_t priority_tick, timeout_ticks;
    uint32_t o2t_cid, t2o_cid;
    uint16_t conn_serial;
    uint16_t vendor;
    uint32_t orig_serial;
    uint8_t timeout_mult; /* code 0..7: timeout = RPI * (4 << code) */
    uint32_t o2t_rpi_us, t2o_rpi_us;
    dr_netparams_t o2t, t2o;
    uint8_t transport; /* 0x01: class 1, cyclic, client */
    const uint8_t *path;
    size_t path_len;
} dr_fwd_open_t;

dr_status_t dr_fwd_open_parse(const uint8_t *data, size_t len, bool large,
                              dr_fwd_open_t *out);
/* Request data (after the MR header) for service 0x54 or 0x5B. */
void dr_fwd_open_write(dr_wr_t *w, const dr_fwd_open_t *fo);
/* Connection path 20 04 24 cfg 2C o2t 2C t2o (o2t == 0: no O->T point,
 * for a heartbeat/input-only connection the caller passes the heartbeat
 * instance instead). Returns bytes written. */
size_t dr_conn_path_write(uint8_t *buf, size_t cap, uint16_t config_inst,
                          uint16_t o2t_point, uint16_t t2o_point);

typedef struct {
    uint32_t o2t_cid, t2o_cid;
    uint16_t conn_serial, vendor;
    uint32_t orig_serial;
    uint32_t o2t_api_us, t2o_api_us;
} dr_fwd_open_reply_t;

dr_status_t dr_fwd_open_reply_parse(const uint8_t *data, size_t len,
                                    dr_fwd_open_reply_t *out);
void dr_fwd_open_reply_write(dr_wr_t *w, const dr_fwd_open_reply_t *r);

/* Failure data of a refused Forward Open/Close (serials, remaining path). */
void dr_fwd_fail_write(dr_wr_t *w, uint16_t conn_serial, uint16_t vendor,
                       uint32_t orig_serial);

typedef struct {
    uint8_t priority_tick, timeout_ticks;
    uint16_t conn_serial, vendor;
    uint32_t orig_serial;
    const uint8_t *path;
    size_t path_len;
} dr_fwd_close_t;

dr_status_t dr_fwd_close_parse(const uint8_t *data, size_t len, dr_fwd_close_t *out);
void dr_fwd_close_write(dr_wr_t *w, const dr_fwd_close_t *fc);
void dr_fwd_close_reply_write(dr_wr_t *w, uint16_t conn_serial, uint16_t vendor,
                              uint32_t orig_serial);

/* Network connection parameters, 16-bit (0x54) or 32-bit (0x5B) layout. */
uint32_t dr_netparams_encode(const dr_netparams_t *np, bool large);
dr_netparams_t dr_netparams_decode(uint32_t raw, bool large);

/* ---- Class 1 I/O frames (UDP) ------------------------------------------- */

typedef struct {
    uint32_t cid;
    uint32_t encap_seq;
    uint16_t cip_seq;
    const uint8_t *data; /* after the sequence count (and run/idle header) */
    size_t data_len;
    uint32_t run_idle;   /* valid when has_run_idle */
    bool has_run_idle;
} dr_io_frame_t;

/* Parse a Class 1 datagram. `run_idle` says whether this connection's
 * format carries the 32-bit run/idle header (O->T usually, T->O modeless).
 * The data length is not checked here: the connection knows its size. */
dr_status_t dr_io_frame_parse(const uint8_t *buf, size_t len, bool run_idle,
                              dr_io_frame_t *out);

/* Build a Class 1 datagram; returns DR_OK or DR_ENOSPACE; *out_len set. */
dr_status_t dr_io_frame_write(uint8_t *buf, size_t cap, const dr_io_frame_t *f,
                              size_t *out_len);

/* Wrap-safe sequence compares: a is newer than b. */
bool dr_seq16_newer(uint16_t a, uint16_t b);
bool dr_seq32_newer(uint32_t a, uint32_t b);

/* ---- Identity ----------------------------------------------------------- */

/* dr_identity_t is in drgate/enip.h. */

/* The Identity object's Get_Attributes_All reply data (attributes 1-7). */
dr_status_t dr_identity_parse_all(const uint8_t *data, size_t len, dr_identity_t *out);
void dr_identity_write_all(dr_wr_t *w, const dr_identity_t *id);

/* ListIdentity reply body (CPF with a 0x0C item), read leniently as
 * dr_cpf_parse_reply does: every declared item is length-checked, bytes
 * after them are ignored; the identity item must be exact. */
dr_status_t dr_list_identity_parse(const uint8_t *body, size_t len, dr_identity_t *out);
void dr_list_identity_write(dr_wr_t *w, const dr_identity_t *id);

#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility pop
#endif

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_CIP_INTERNAL_H */
