/* SPDX-License-Identifier: MIT */
/* Modbus TCP framing and request checks: see mbproto.h. */
#include "mbproto.h"

#include <string.h>

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
    case 0x01: *fi = (fc_info_t){GW_COILS, false, MODBUS_MAX_READ_BITS}; return true;
    case 0x02: *fi = (fc_info_t){GW_DISCRETE, false, MODBUS_MAX_READ_BITS}; return true;
    case 0x03: *fi = (fc_info_t){GW_HOLDING, false, MODBUS_MAX_READ_REGISTERS}; return true;
    case 0x04: *fi = (fc_info_t){GW_INPUT, false, MODBUS_MAX_READ_REGISTERS}; return true;
    case 0x05: *fi = (fc_info_t){GW_COILS, true, 1}; return true;
    case 0x06: *fi = (fc_info_t){GW_HOLDING, true, 1}; return true;
    case 0x0F: *fi = (fc_info_t){GW_COILS, true, MODBUS_MAX_WRITE_BITS}; return true;
    case 0x10: *fi = (fc_info_t){GW_HOLDING, true, MODBUS_MAX_WRITE_REGISTERS}; return true;
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
    if (*n == 0 || *n > (bits ? MODBUS_MAX_WRITE_BITS : MODBUS_MAX_WRITE_REGISTERS) ||
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

/* Check a decoded write against the fault latch, apply it, and tell the
 * server it was applied. */
static int apply_write(gw_unit_t *u, const gw_mb_env_t *env, gw_mb_result_t *r)
{
    bool reset = is_fault_reset(r->area, r->addr, r->count, r->values);
    if (u->status.write_fault && !reset)
        return GW_EX_DEVICE_FAILURE; /* latched: only the reset gets through */
    int ex = gw_regmap_write(u, r->area, r->addr, r->count, r->values, &r->dirty);
    if (ex != 0)
        return ex;
    if (reset && u->status.write_fault) {
        /* Cleared at once: a request pipelined behind the reset is not
         * refused; the daemon puts the GPIO outputs back at its next turn
         * (u->fault_reset). */
        u->status.write_fault = false;
        r->reset = true;
    }
    env->wrote(env->client);
    return 0;
}

int gw_mbs_decide(const uint8_t *adu, size_t len, const gw_mb_env_t *env,
                  gw_mb_result_t *r)
{
    size_t total;
    if (gw_mbap_frame(adu, len, &total) != GW_MBAP_FRAME || total != len)
        return -1;
    const uint8_t *pdu = adu + GW_MBAP_LEN;
    size_t pdu_len = len - GW_MBAP_LEN;
    fc_info_t fi;
    r->unit_id = adu[6];
    r->fc = pdu[0];
    r->write = false;
    r->area = GW_COILS;
    r->addr = r->count = 0;
    r->dirty = 0;
    r->reset = false;

    gw_unit_t *u = env->unit_for(env->units, r->unit_id);
    if (u == NULL)
        return 0x0A; /* gateway path unavailable: no robot with this unit ID */
    if (!fc_lookup(r->fc, &fi))
        return GW_EX_ILLEGAL_FUNCTION;
    r->write = fi.write;
    r->area = fi.area;
    if (fi.write && !env->may_write(env->client))
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

int gw_mbs_reply(modbus_t *ctx, modbus_mapping_t *map, const uint8_t *adu,
                 size_t len, int ex, const gw_mb_result_t *r)
{
    if (ex != 0 && (adu[GW_MBAP_LEN] & 0x80u) != 0) {
        /* A request's function code is 1..127: libmodbus would answer one
         * with the high bit set with (code + 0x80) & 0xFF, which has no
         * exception bit. Answer with the code itself, which has. */
        uint8_t copy[GW_ADU_MAX];
        if (len > sizeof copy)
            return -1;
        memcpy(copy, adu, len);
        copy[GW_MBAP_LEN] &= 0x7Fu;
        return modbus_reply_exception(ctx, copy, (unsigned)ex);
    }
    if (ex != 0)
        return modbus_reply_exception(ctx, adu, (unsigned)ex);
    if (!r->write) {
        for (uint16_t i = 0; i < r->count; i++) {
            unsigned a = (unsigned)r->addr + i;
            switch (r->area) {
            case GW_COILS: map->tab_bits[a] = (uint8_t)r->values[i]; break;
            case GW_DISCRETE: map->tab_input_bits[a] = (uint8_t)r->values[i]; break;
            case GW_HOLDING: map->tab_registers[a] = r->values[i]; break;
            default: map->tab_input_registers[a] = r->values[i]; break;
            }
        }
    }
    return modbus_reply(ctx, adu, (int)len, map);
}
