/* SPDX-License-Identifier: MIT */
/*
 * Modbus requests without sockets or serial ports: one handler on bare
 * PDUs (function code and data in, reply PDU out) that checks a request
 * and applies it to a unit's images through the register map (regmap.h),
 * and the MBAP framing of Modbus TCP. The framers (mbserver.c for TCP,
 * mbrtu.c for RTU) cut requests out of their byte streams, hand the PDU
 * here and send back what it answers: a request is parsed once, here.
 * fuzz/fuzz_modbus.c hands it anything.
 *
 * Order of the checks, each answered with the first exception that
 * applies: no unit with the unit ID (0x0A), a function code other than
 * 01-06, 0F, 10, 17, 2B (0x01), a write from a client that may not write
 * or is not the single writer (0x01), a malformed request or count
 * (0x03), a write other than the fault reset to a unit whose write fault
 * is latched (0x04), then the register map's own answer (0x02, 0x03,
 * 0x0B). The write rules (the client's right, the single writer, the
 * latch, direction, plan, GPIO bits, ranges) are the one write path's
 * (core/write.h): the handler asks it (gw_write_allowed) in this order
 * and the register map hands it the decoded fields. A write that fails any
 * check changes nothing; FC 23 (read/write multiple registers) checks its
 * read part before it applies its write part, so a refused FC 23 changes
 * nothing either. FC 43 / MEI 14 (read device identification) answers
 * from the unit's robot (its name and io_state's version, gw_robot_t)
 * and the gateway's version (gw_mb_env_t).
 */
#ifndef DRGATE_GW_MBPROTO_H
#define DRGATE_GW_MBPROTO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "modbus/regmap.h"

/* Quantities per request, MODBUS Application Protocol Specification
 * V1.1b3, 6.1-6.4, 6.11, 6.12, 6.17 (the values of libmodbus's
 * GW_MB_MAX_*, which fuzz/fuzz_modbus.c checks; the daemon does not need
 * libmodbus for them). */
#define GW_MB_MAX_READ_BITS 2000u          /* FC 01, 02 */
#define GW_MB_MAX_WRITE_BITS 1968u         /* FC 0F */
#define GW_MB_MAX_READ_REGISTERS 125u      /* FC 03, 04 */
#define GW_MB_MAX_WRITE_REGISTERS 123u     /* FC 10 */
#define GW_MB_MAX_WR_READ_REGISTERS 125u   /* FC 17, its read part */
#define GW_MB_MAX_WR_WRITE_REGISTERS 121u  /* FC 17, its write part */

#define GW_MBAP_LEN 7u  /* transaction ID, protocol ID, length, unit ID */
#define GW_ADU_MAX 260u /* MBAP + the largest PDU (253 bytes) */
#define GW_PDU_MAX 253u /* function code + data */

typedef enum {
    GW_MBAP_MORE = 0, /* not a whole ADU yet: wait for more bytes */
    GW_MBAP_FRAME,    /* *total bytes form one ADU */
    GW_MBAP_BAD       /* protocol ID not 0, or a length outside 2..254 */
} gw_mbap_t;

/* The first ADU of the stream buf[0..len). */
gw_mbap_t gw_mbap_frame(const uint8_t *buf, size_t len, size_t *total);

/* What a request may reach: the units (robots) by unit ID, and who
 * writes. may_write (the client's right: [modbus] allow rw, [modbus_rtu]
 * read_only = no) and owner (single-writer mode: the client owns the
 * outputs, or nobody does; NULL: yes) describe the client to the one
 * write path (core/write.h), which holds the rules; they change nothing.
 * wrote is told after a write was accepted and applied (in single-writer
 * mode that makes the client the owner if there is none: a refused write
 * never does). side, who and log: the write path's origin (who: the write
 * log's name for the client, log: its limiter; NULL: not logged). */
typedef struct {
    gw_unit_t *(*unit_for)(void *units, uint8_t unit_id); /* NULL: none */
    void *units;
    bool (*may_write)(void *client);
    void (*wrote)(void *client);
    void *client;
    const char *version; /* the gateway's, for FC 43 (MajorMinorRevision) */
    gw_origin_side_t side; /* GW_ORIGIN_MODBUS_TCP or _RTU */
    const char *who;
    gw_log_limit_t *log;
    bool (*owner)(void *client);
} gw_mb_env_t;

/* What gw_mbs_decide found. */
typedef struct {
    uint8_t unit_id, fc;
    /* The unit unit_id named (env->unit_for's answer), NULL: none. The
     * framers hand an accepted write's dirty images on with it: nothing
     * looks the unit ID up a second time. */
    gw_unit_t *unit;
    bool write;        /* fc is a write function (05, 06, 0F, 10, 17) */
    gw_area_t area;    /* valid once the function code is known */
    uint16_t addr, count;
    unsigned dirty;    /* accepted write: O->T images written (bit per assembly) */
    gw_write_result_t wr; /* write: the write path's answer (wr.status: why refused) */
    bool reset;        /* accepted write: it cleared the unit's latched write fault */
    /* Accepted read: the registers or bits (0/1) to answer with; write:
     * the values decoded from the request. */
    uint16_t values[GW_MB_MAX_READ_BITS];
    /* FC 23: its read part (values: its write part), read after the write. */
    uint16_t raddr, rcount;
    uint16_t rvalues[GW_MB_MAX_WR_READ_REGISTERS];
    /* The reply PDU: the data, an echo, or function code | 0x80 and the
     * exception code. */
    uint8_t pdu[GW_PDU_MAX];
    size_t pdu_len;
} gw_mb_result_t;

/* One request PDU (pdu[0..pdu_len): function code and data) for unit
 * `unit_id`: checked and applied (read into r->values, or written to the
 * unit), and answered in r->pdu (never empty). Returns 0 (the reply
 * carries the data) or the Modbus exception code the reply carries; -1 if
 * pdu_len is 0 or over GW_PDU_MAX (nothing is looked at). */
int gw_mb_handle(uint8_t unit_id, const uint8_t *pdu, size_t pdu_len, const gw_mb_env_t *env,
                 gw_mb_result_t *r);

/* Modbus TCP: gw_mb_handle on one whole ADU (adu[0..len), as
 * gw_mbap_frame found it). -1 if adu is not a frame gw_mbap_frame
 * accepts. */
int gw_mbs_decide(const uint8_t *adu, size_t len, const gw_mb_env_t *env,
                  gw_mb_result_t *r);

/* The reply ADU of request `adu` (its MBAP header with the new length,
 * then r's reply PDU) into out[GW_ADU_MAX]; returns its length. */
size_t gw_mbap_reply(const uint8_t *adu, const gw_mb_result_t *r, uint8_t *out);

/* ---- Modbus RTU framing (no I/O: mbrtu.c reads and writes the port) ---- */

#define GW_RTU_MIN 4u   /* address, function code, CRC */
#define GW_RTU_MAX 256u /* address + the largest PDU + CRC */

/* CRC-16/MODBUS of p[0..n) (sent low byte first). */
uint16_t gw_rtu_crc(const uint8_t *p, size_t n);
/* frame[0..n) is at least GW_RTU_MIN bytes and ends with its CRC. */
bool gw_rtu_crc_ok(const uint8_t *frame, size_t n);
/* The length of the request that starts buf[0..len), if its function
 * code tells it and enough of it is there; 0: not known (yet). */
size_t gw_rtu_request_len(const uint8_t *buf, size_t len);

/* Bytes received on a line, cut into frames. */
typedef struct {
    uint8_t buf[GW_RTU_MAX];
    size_t len;
    bool overflow; /* more than a frame's worth: garbage until the silence */
} gw_rtu_rx_t;

typedef enum {
    GW_RTU_NONE = 0, /* nothing whole yet */
    GW_RTU_FRAME,    /* frame[0..*n): one request with a good CRC */
    GW_RTU_BAD       /* *n bytes dropped: a bad CRC, short or too long */
} gw_rtu_ev_t;

void gw_rtu_rx_add(gw_rtu_rx_t *rx, const uint8_t *p, size_t n);
/* The next frame in rx into frame[GW_RTU_MAX]. A request whose function
 * code gives its length and whose CRC checks is whole at once; anything
 * else is whole only once the line has been silent for t3.5 (`silence`:
 * the caller's clock says so). Call again until GW_RTU_NONE. */
gw_rtu_ev_t gw_rtu_rx_next(gw_rtu_rx_t *rx, bool silence, uint8_t *frame, size_t *n);

/* The reply frame (address, r's reply PDU, CRC) into out[GW_RTU_MAX];
 * returns its length. */
size_t gw_rtu_reply(uint8_t addr, const gw_mb_result_t *r, uint8_t *out);

#endif /* DRGATE_GW_MBPROTO_H */
