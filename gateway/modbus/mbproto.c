/* SPDX-License-Identifier: MIT */
/* Modbus TCP framing and request checks: see mbproto.h. */
#include "modbus/mbproto.h"

#include <stdio.h>
#include <string.h>

#define FC_READ_WRITE 0x17
#define FC_MEI 0x2B
#define MEI_DEVICE_ID 0x0E

static uint16_t be16(const uint8_t *p)
{
    return (uint16_t)(p[0] << 8 | p[1]);
}

gw_mbap_t gw_mbap_frame(const uint8_t *buf, size_t len, size_t *total)
{
    if (len < GW_MBAP_LEN)
        return GW_MBAP_MORE;
    uint16_t proto = be16(buf + 2), mlen = be16(buf + 4);
    /* length counts the unit ID and the PDU: 2..254 */
    if (proto != 0 || mlen < 2 || mlen > GW_ADU_MAX - 6)
        return GW_MBAP_BAD;
    *total = 6u + mlen;
    return len < *total ? GW_MBAP_MORE : GW_MBAP_FRAME;
}

/* Function code -> area and limits. */
typedef struct {
    gw_area_t area;
    bool write;
    uint16_t max;
} fc_info_t;

static bool fc_lookup(uint8_t fc, fc_info_t *fi)
{
    switch (fc) {
    case 0x01: *fi = (fc_info_t){GW_COILS, false, GW_MB_MAX_READ_BITS}; return true;
    case 0x02: *fi = (fc_info_t){GW_DISCRETE, false, GW_MB_MAX_READ_BITS}; return true;
    case 0x03: *fi = (fc_info_t){GW_HOLDING, false, GW_MB_MAX_READ_REGISTERS}; return true;
    case 0x04: *fi = (fc_info_t){GW_INPUT, false, GW_MB_MAX_READ_REGISTERS}; return true;
    case 0x05: *fi = (fc_info_t){GW_COILS, true, 1}; return true;
    case 0x06: *fi = (fc_info_t){GW_HOLDING, true, 1}; return true;
    case 0x0F: *fi = (fc_info_t){GW_COILS, true, GW_MB_MAX_WRITE_BITS}; return true;
    case 0x10: *fi = (fc_info_t){GW_HOLDING, true, GW_MB_MAX_WRITE_REGISTERS}; return true;
    default: return false;
    }
}

/* Decode the values of a write request into v[]; 0 or an exception. */
static int write_values(uint8_t fc, const uint8_t *pdu, size_t pdu_len, uint16_t *addr,
                        uint16_t *n, uint16_t *v)
{
    if (pdu_len < 5)
        return GW_EX_ILLEGAL_VALUE;
    *addr = be16(pdu + 1);
    if (fc == 0x05 || fc == 0x06) {
        if (pdu_len != 5)
            return GW_EX_ILLEGAL_VALUE;
        uint16_t x = be16(pdu + 3);
        if (fc == 0x05 && x != 0xFF00 && x != 0x0000)
            return GW_EX_ILLEGAL_VALUE;
        *n = 1;
        v[0] = fc == 0x05 ? (x == 0xFF00) : x;
        return 0;
    }
    *n = be16(pdu + 3);
    if (pdu_len < 6)
        return GW_EX_ILLEGAL_VALUE;
    size_t bytes = pdu[5];
    bool bits = fc == 0x0F;
    if (*n == 0 || *n > (bits ? GW_MB_MAX_WRITE_BITS : GW_MB_MAX_WRITE_REGISTERS) ||
        bytes != (bits ? (*n + 7u) / 8u : 2u * *n) || pdu_len != 6 + bytes)
        return GW_EX_ILLEGAL_VALUE;
    for (uint16_t i = 0; i < *n; i++)
        v[i] = bits ? (uint16_t)((pdu[6 + i / 8] >> (i % 8)) & 1u) : be16(pdu + 6 + 2 * i);
    return 0;
}

/* A write of 1 to the fault-reset register, with nothing but the control
 * registers around it: the one write a latched write fault lets through
 * (a PLC may write its watchdog and the reset in one FC 16). */
static bool is_fault_reset(gw_area_t area, uint16_t addr, uint16_t count, const uint16_t *v)
{
    return area == GW_HOLDING && addr <= GW_HR_FAULT_RESET &&
           (uint32_t)addr + count > GW_HR_FAULT_RESET &&
           (uint32_t)addr + count <= GW_HR_FAULT_RESET + 1u && v[GW_HR_FAULT_RESET - addr] == 1;
}

/* The write path's origin for this request (the reset: see above). */
static gw_write_origin_t origin(const gw_mb_env_t *env, const gw_mb_result_t *r)
{
    gw_write_origin_t o = {env->side, env->who, env->may_write(env->client),
                           env->owner == NULL || env->owner(env->client), false, env->log};
    o.reset = r->count > 0 && is_fault_reset(r->area, r->addr, r->count, r->values);
    return o;
}

/* The rules of the write path that come before a request is parsed: the
 * client's right and the single writer (0x01). */
static int rights_check(const gw_unit_t *u, const gw_mb_env_t *env, gw_mb_result_t *r)
{
    gw_write_origin_t o = origin(env, r);
    gw_write_status_t st = gw_write_allowed(u->robot, &o);
    if (st == GW_WRITE_RIGHTS || st == GW_WRITE_SINGLE) {
        r->wr.status = st;
        return GW_EX_ILLEGAL_FUNCTION;
    }
    return 0;
}

/* The latch, once the request is parsed: only the reset gets through
 * (0x04), before the register map's checks. */
static int latch_check(const gw_unit_t *u, const gw_mb_env_t *env, gw_mb_result_t *r)
{
    gw_write_origin_t o = origin(env, r);
    if (gw_write_allowed(u->robot, &o) == GW_WRITE_FAULT) {
        r->wr.status = GW_WRITE_FAULT;
        return GW_EX_DEVICE_FAILURE;
    }
    return 0;
}

/* Decode the write into the robot's fields and hand it to the write path
 * (gw_regmap_write), and tell the server it was applied. */
static int apply_write(gw_unit_t *u, const gw_mb_env_t *env, gw_mb_result_t *r)
{
    int ex = latch_check(u, env, r);
    if (ex != 0)
        return ex;
    gw_write_origin_t o = origin(env, r);
    ex = gw_regmap_write(u, r->area, r->addr, r->count, r->values, &o, &r->wr);
    if (ex != 0)
        return ex;
    r->dirty = r->wr.dirty;
    /* Cleared at once by the write path: a request pipelined behind the
     * reset is not refused; the daemon puts the GPIO outputs back at its
     * next turn (u->fault_reset). */
    r->reset = r->wr.reset;
    env->wrote(env->client);
    return 0;
}

/* ---- FC 23: read/write multiple registers ---------------------------------- */

/* Request: read address, read count, write address, write count, byte
 * count, values. The write is applied first, then the read made (as the
 * specification says), and nothing is applied unless both parts pass. */
static int decide_read_write(gw_unit_t *u, const gw_mb_env_t *env, const uint8_t *pdu,
                             size_t pdu_len, gw_mb_result_t *r)
{
    r->write = true;
    r->area = GW_HOLDING;
    if (rights_check(u, env, r) != 0)
        return GW_EX_ILLEGAL_FUNCTION;
    if (pdu_len < 10)
        return GW_EX_ILLEGAL_VALUE;
    r->raddr = be16(pdu + 1);
    r->rcount = be16(pdu + 3);
    r->addr = be16(pdu + 5);
    r->count = be16(pdu + 7);
    if (r->rcount == 0 || r->rcount > GW_MB_MAX_WR_READ_REGISTERS || r->count == 0 ||
        r->count > GW_MB_MAX_WR_WRITE_REGISTERS || pdu[9] != 2u * r->count ||
        pdu_len != 10u + pdu[9])
        return GW_EX_ILLEGAL_VALUE;
    for (uint16_t i = 0; i < r->count; i++)
        r->values[i] = be16(pdu + 10 + 2 * i);
    int ex = latch_check(u, env, r);
    /* The read part's answer depends only on its addresses: checked now,
     * before anything is written. */
    if (ex == 0)
        ex = gw_regmap_read(u, GW_HOLDING, r->raddr, r->rcount, r->rvalues);
    if (ex == 0)
        ex = apply_write(u, env, r);
    if (ex == 0)
        ex = gw_regmap_read(u, GW_HOLDING, r->raddr, r->rcount, r->rvalues);
    if (ex != 0)
        return ex; /* the second read cannot fail where the first passed */
    r->pdu[0] = FC_READ_WRITE;
    r->pdu[1] = (uint8_t)(2u * r->rcount);
    for (uint16_t i = 0; i < r->rcount; i++) {
        r->pdu[2 + 2 * i] = (uint8_t)(r->rvalues[i] >> 8);
        r->pdu[3 + 2 * i] = (uint8_t)r->rvalues[i];
    }
    r->pdu_len = 2u + 2u * r->rcount;
    return 0;
}

/* ---- FC 43 / MEI 14: read device identification ---------------------------- */

/* The objects, by id: basic 0x00-0x02, regular 0x04-0x06 (no VendorUrl,
 * 0x03: the gateway has none to give), extended 0x80-0x81 (the unit's
 * robot). Writes object `id` into out[n]; returns its length, or -1 if
 * there is no such object. */
static int devid_object(const gw_unit_t *u, const char *version, uint8_t id, char *out,
                        size_t n)
{
    switch (id) {
    case 0x00: return snprintf(out, n, "drgate");
    case 0x01: return snprintf(out, n, "drgatewayd");
    case 0x02: return snprintf(out, n, "%s", version != NULL ? version : "");
    case 0x04: return snprintf(out, n, "drgate Modbus TCP gateway for Doosan robots");
    case 0x05: return snprintf(out, n, "drgatewayd");
    case 0x06: /* UserApplicationName: the robot this unit serves */
    case 0x80: return snprintf(out, n, "%s", u->robot->name);
    case 0x81: { /* the controller's version, as io_state reports it */
        static const char *const part[3] = {"io_state.version.major", "io_state.version.minor",
                                            "io_state.version.patch"};
        uint64_t v[3] = {0, 0, 0};
        for (unsigned i = 0; i < 3; i++) {
            dr_ref_t ref;
            dr_value_t x;
            if (dr_path_parse(part[i], &ref) == DR_OK && gw_robot_get(u->robot, ref, &x) == DR_OK)
                v[i] = x.u;
        }
        return snprintf(out, n, "%u.%u.%u", (unsigned)v[0], (unsigned)v[1], (unsigned)v[2]);
    }
    default: return -1;
    }
}

/* The last object id of each read code's category (1 basic, 2 regular,
 * 3 extended). */
static const uint8_t devid_last[4] = {0, 0x02, 0x06, 0x81};

/* Request: MEI type 0x0E, read device id code (1-3 stream access by
 * category, 4 one object), object id. */
static int decide_device_id(const gw_unit_t *u, const gw_mb_env_t *env, const uint8_t *pdu,
                            size_t pdu_len, gw_mb_result_t *r)
{
    if (pdu_len >= 2 && pdu[1] != MEI_DEVICE_ID)
        return GW_EX_ILLEGAL_FUNCTION; /* another MEI type (0x0D CANopen) */
    if (pdu_len != 4 || pdu[2] < 1 || pdu[2] > 4)
        return GW_EX_ILLEGAL_VALUE;
    uint8_t code = pdu[2], first = pdu[3];
    char text[GW_ADU_MAX];
    if (code == 4 && devid_object(u, env->version, first, text, sizeof text) < 0)
        return GW_EX_ILLEGAL_ADDRESS;
    uint8_t last = code == 4 ? first : devid_last[code];
    /* Stream access from an object the category does not have starts
     * over at object 0 (the specification's rule). */
    if (code != 4 && (first > last || devid_object(u, env->version, first, text,
                                                   sizeof text) < 0))
        first = 0;
    uint8_t *p = r->pdu;
    p[0] = FC_MEI;
    p[1] = MEI_DEVICE_ID;
    p[2] = code;
    p[3] = 0x83; /* conformity: extended, stream and individual access */
    p[4] = 0x00; /* more follows */
    p[5] = 0x00; /* next object id */
    p[6] = 0;    /* number of objects */
    size_t n = 7;
    for (unsigned id = first; id <= last; id++) {
        int len = devid_object(u, env->version, (uint8_t)id, text, sizeof text);
        if (len < 0)
            continue;
        if ((size_t)len > sizeof r->pdu - 9u)
            len = (int)(sizeof r->pdu - 9u); /* one object alone always fits a reply */
        if (n + 2u + (size_t)len > sizeof r->pdu) {
            p[4] = 0xFF; /* the rest in the next request, from this one */
            p[5] = (uint8_t)id;
            break;
        }
        p[n] = (uint8_t)id;
        p[n + 1] = (uint8_t)len;
        memcpy(p + n + 2, text, (size_t)len);
        n += 2u + (size_t)len;
        p[6]++;
    }
    r->pdu_len = n;
    return 0;
}

/* The reply PDU of an accepted request that did not build its own
 * (FC 23 and 43 do): a read's data, a write's echo. The same bytes
 * libmodbus's modbus_reply sent for these codes (fuzz_modbus.c compares
 * them with it). */
static void reply_data(const uint8_t *pdu, gw_mb_result_t *r)
{
    uint8_t *p = r->pdu;
    p[0] = r->fc;
    if (r->fc == 0x05 || r->fc == 0x06) {
        memcpy(p, pdu, 5); /* an echo of the request */
        r->pdu_len = 5;
    } else if (r->write) { /* 0x0F, 0x10: address and count */
        p[1] = (uint8_t)(r->addr >> 8);
        p[2] = (uint8_t)r->addr;
        p[3] = (uint8_t)(r->count >> 8);
        p[4] = (uint8_t)r->count;
        r->pdu_len = 5;
    } else if (r->area == GW_COILS || r->area == GW_DISCRETE) {
        size_t bytes = (r->count + 7u) / 8u;
        p[1] = (uint8_t)bytes;
        memset(p + 2, 0, bytes);
        for (uint16_t i = 0; i < r->count; i++)
            p[2 + i / 8] = (uint8_t)(p[2 + i / 8] | (r->values[i] & 1u) << (i % 8));
        r->pdu_len = 2u + bytes;
    } else {
        p[1] = (uint8_t)(2u * r->count);
        for (uint16_t i = 0; i < r->count; i++) {
            p[2 + 2 * i] = (uint8_t)(r->values[i] >> 8);
            p[3 + 2 * i] = (uint8_t)r->values[i];
        }
        r->pdu_len = 2u + 2u * r->count;
    }
}

/* The address and count a request names, as far as it is there: what the
 * request log (reqlog.h) shows of a request refused before its data is
 * looked at (no robot for the unit ID, a read-only client). The checks
 * below read them again, where they check them. */
static void request_span(const uint8_t *pdu, size_t pdu_len, gw_mb_result_t *r)
{
    bool single = r->fc == 0x05 || r->fc == 0x06;
    if ((r->fc < 0x01 || r->fc > 0x06) && r->fc != 0x0F && r->fc != 0x10 &&
        r->fc != FC_READ_WRITE)
        return;
    if (pdu_len >= 3)
        r->addr = be16(pdu + 1);
    if (single)
        r->count = 1;
    else if (pdu_len >= 5)
        r->count = be16(pdu + 3);
}

/* Check and apply; 0 or the exception code. */
static int decide(uint8_t unit_id, const uint8_t *pdu, size_t pdu_len, const gw_mb_env_t *env,
                  gw_mb_result_t *r)
{
    fc_info_t fi;
    r->unit_id = unit_id;
    r->fc = pdu[0];
    r->write = false;
    r->area = GW_COILS;
    r->addr = r->count = 0;
    r->dirty = 0;
    r->reset = false;
    memset(&r->wr, 0, sizeof r->wr);
    r->raddr = r->rcount = 0;
    r->pdu_len = 0;
    request_span(pdu, pdu_len, r);

    gw_unit_t *u = env->unit_for(env->units, unit_id);
    r->unit = u;
    if (u == NULL)
        return 0x0A; /* gateway path unavailable: no robot with this unit ID */
    if (r->fc == FC_READ_WRITE)
        return decide_read_write(u, env, pdu, pdu_len, r);
    if (r->fc == FC_MEI)
        return decide_device_id(u, env, pdu, pdu_len, r);
    if (!fc_lookup(r->fc, &fi))
        return GW_EX_ILLEGAL_FUNCTION;
    r->write = fi.write;
    r->area = fi.area;
    if (fi.write && rights_check(u, env, r) != 0)
        return GW_EX_ILLEGAL_FUNCTION; /* read-only client, or not the writer */

    if (!fi.write) {
        if (pdu_len != 5)
            return GW_EX_ILLEGAL_VALUE;
        r->addr = be16(pdu + 1);
        r->count = be16(pdu + 3);
        if (r->count == 0 || r->count > fi.max)
            return GW_EX_ILLEGAL_VALUE;
        return gw_regmap_read(u, fi.area, r->addr, r->count, r->values);
    }
    int ex = write_values(r->fc, pdu, pdu_len, &r->addr, &r->count, r->values);
    return ex != 0 ? ex : apply_write(u, env, r);
}

int gw_mb_handle(uint8_t unit_id, const uint8_t *pdu, size_t pdu_len, const gw_mb_env_t *env,
                 gw_mb_result_t *r)
{
    if (pdu_len < 1 || pdu_len > GW_PDU_MAX)
        return -1;
    int ex = decide(unit_id, pdu, pdu_len, env, r);
    if (ex != 0) {
        /* A request's function code is 1..127: one with the high bit set
         * is answered with the code itself, which has the exception bit
         * ((code + 0x80) & 0xFF would not). */
        r->pdu[0] = (uint8_t)(pdu[0] | 0x80u);
        r->pdu[1] = (uint8_t)ex;
        r->pdu_len = 2;
    } else if (r->pdu_len == 0) {
        reply_data(pdu, r);
    }
    return ex;
}

int gw_mbs_decide(const uint8_t *adu, size_t len, const gw_mb_env_t *env,
                  gw_mb_result_t *r)
{
    size_t total;
    if (gw_mbap_frame(adu, len, &total) != GW_MBAP_FRAME || total != len)
        return -1;
    return gw_mb_handle(adu[6], adu + GW_MBAP_LEN, len - GW_MBAP_LEN, env, r);
}

size_t gw_mbap_reply(const uint8_t *adu, const gw_mb_result_t *r, uint8_t *out)
{
    memcpy(out, adu, 4); /* transaction and protocol identifiers */
    out[4] = (uint8_t)((r->pdu_len + 1u) >> 8);
    out[5] = (uint8_t)(r->pdu_len + 1u);
    out[6] = adu[6];
    memcpy(out + GW_MBAP_LEN, r->pdu, r->pdu_len);
    return GW_MBAP_LEN + r->pdu_len;
}

/* ---- Modbus RTU framing ---------------------------------------------------- */

uint16_t gw_rtu_crc(const uint8_t *p, size_t n)
{
    uint16_t crc = 0xFFFF;
    for (size_t i = 0; i < n; i++) {
        crc ^= p[i];
        for (unsigned b = 0; b < 8; b++)
            crc = (crc & 1u) ? (uint16_t)(crc >> 1 ^ 0xA001u) : (uint16_t)(crc >> 1);
    }
    return crc;
}

bool gw_rtu_crc_ok(const uint8_t *frame, size_t n)
{
    if (n < GW_RTU_MIN)
        return false;
    uint16_t crc = gw_rtu_crc(frame, n - 2);
    /* the CRC goes low byte first, unlike everything else in Modbus */
    return frame[n - 2] == (uint8_t)crc && frame[n - 1] == (uint8_t)(crc >> 8);
}

size_t gw_rtu_request_len(const uint8_t *buf, size_t len)
{
    if (len < 2)
        return 0;
    switch (buf[1]) {
    case 0x01: case 0x02: case 0x03: case 0x04: case 0x05: case 0x06:
        return 8; /* address, code, two 16-bit fields, CRC */
    case 0x0F: case 0x10:
        return len < 7 ? 0 : 9u + buf[6];
    case FC_READ_WRITE:
        return len < 11 ? 0 : 13u + buf[10];
    case FC_MEI:
        return 7; /* MEI type, read code, object id */
    default:
        return 0; /* unknown: the silence after it ends it */
    }
}

void gw_rtu_rx_add(gw_rtu_rx_t *rx, const uint8_t *p, size_t n)
{
    if (rx->len + n > sizeof rx->buf) {
        rx->overflow = true; /* not a frame: dropped at the silence */
        return;
    }
    memcpy(rx->buf + rx->len, p, n);
    rx->len += n;
}

gw_rtu_ev_t gw_rtu_rx_next(gw_rtu_rx_t *rx, bool silence, uint8_t *frame, size_t *n)
{
    if (rx->len == 0 && !rx->overflow)
        return GW_RTU_NONE;
    size_t want = rx->overflow ? 0 : gw_rtu_request_len(rx->buf, rx->len);
    /* A request whose length its code tells, with a good CRC: taken at
     * once (no waiting for the silence after it; the master waits for
     * our reply anyway). Anything else ends at the silence. */
    if (want != 0 && want <= rx->len && want <= GW_RTU_MAX && gw_rtu_crc_ok(rx->buf, want))
        *n = want;
    else if (silence)
        *n = rx->len;
    else
        return GW_RTU_NONE;
    bool bad = rx->overflow || !gw_rtu_crc_ok(rx->buf, *n);
    if (!bad)
        memcpy(frame, rx->buf, *n);
    memmove(rx->buf, rx->buf + *n, rx->len - *n);
    rx->len -= *n;
    if (bad) {
        rx->len = 0; /* the whole garbled frame */
        rx->overflow = false;
    }
    return bad ? GW_RTU_BAD : GW_RTU_FRAME;
}

size_t gw_rtu_reply(uint8_t addr, const gw_mb_result_t *r, uint8_t *out)
{
    out[0] = addr;
    memcpy(out + 1, r->pdu, r->pdu_len);
    uint16_t crc = gw_rtu_crc(out, 1u + r->pdu_len);
    out[1 + r->pdu_len] = (uint8_t)crc;
    out[2 + r->pdu_len] = (uint8_t)(crc >> 8);
    return 3u + r->pdu_len;
}
