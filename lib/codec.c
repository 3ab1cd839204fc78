/* SPDX-License-Identifier: MIT */
/*
 * Table-driven decode, encode and per-field access of the assemblies.
 * Everything here walks dr_field_table; no offset is known to this file.
 */
#include <float.h>
#include <string.h>

#include "drgate/codec.h"

/* ---- wire helpers ----------------------------------------------------- */

/* `count` bits starting at bit `bit` of the little-endian row at `row`.
 * The table guarantees bit + count <= 64. */
static uint64_t load_bits(const uint8_t *row, unsigned bit, unsigned count)
{
    unsigned nbytes = (bit + count + 7u) / 8u;
    uint64_t v = 0;
    for (unsigned i = 0; i < nbytes; i++)
        v |= (uint64_t)row[i] << (8u * i);
    v >>= bit;
    return count < 64u ? v & ((UINT64_C(1) << count) - 1u) : v;
}

/* Write `count` bits of `v` at bit `bit` of `row`, leaving other bits. */
static void store_bits(uint8_t *row, unsigned bit, unsigned count, uint64_t v)
{
    for (unsigned i = 0; i < count; i++) {
        unsigned pos = bit + i;
        uint8_t mask = (uint8_t)(1u << (pos % 8u));
        if ((v >> i) & 1u)
            row[pos / 8u] |= mask;
        else
            row[pos / 8u] &= (uint8_t)~mask;
    }
}

/* Two's complement without implementation-defined conversions. */
static int32_t int32_from_wire(uint32_t u)
{
    return u <= (uint32_t)INT32_MAX ? (int32_t)u : -(int32_t)(~u) - 1;
}

static float real_from_wire(uint32_t u)
{
    float f;
    memcpy(&f, &u, sizeof f);
    return f;
}

static uint32_t real_to_wire(float f)
{
    uint32_t u;
    memcpy(&u, &f, sizeof u);
    return u;
}

/* The smallest double that rounds to binary32 infinity: 2^128 - 2^103. */
#define REAL_TO_INF 0x1.ffffffp127

typedef char assert_float_is_binary32[(sizeof(float) == 4 && FLT_MANT_DIG == 24) ? 1 : -1];

/* ---- typed structs: store and load one member -------------------------- */

static void put_member_uint(uint8_t *dst, unsigned size, uint64_t v)
{
    switch (size) {
    case 1: { uint8_t x = (uint8_t)v; memcpy(dst, &x, 1); break; }
    case 2: { uint16_t x = (uint16_t)v; memcpy(dst, &x, 2); break; }
    case 4: { uint32_t x = (uint32_t)v; memcpy(dst, &x, 4); break; }
    default: memcpy(dst, &v, 8); break;
    }
}

static uint64_t get_member_uint(const uint8_t *src, unsigned size)
{
    switch (size) {
    case 1: { uint8_t x; memcpy(&x, src, 1); return x; }
    case 2: { uint16_t x; memcpy(&x, src, 2); return x; }
    case 4: { uint32_t x; memcpy(&x, src, 4); return x; }
    default: { uint64_t x; memcpy(&x, src, 8); return x; }
    }
}

static void decode_field(const dr_field_t *f, const uint8_t *buf, uint8_t *obj)
{
    const uint8_t *src = buf + f->offset;
    uint8_t *dst = obj + f->member_offset;

    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT: {
        bool b = (src[f->bit / 8u] >> (f->bit % 8u)) & 1u;
        memcpy(dst, &b, sizeof b);
        break;
    }
    case DR_KIND_BITS:
        put_member_uint(dst, f->member_size, load_bits(src, f->bit, f->count));
        break;
    case DR_KIND_USINT:
    case DR_KIND_ENUM:
        memcpy(dst, src, f->count);
        break;
    case DR_KIND_DINT:
        for (unsigned i = 0; i < f->count; i++) {
            int32_t v = int32_from_wire(dr_get_le32(src + 4u * i));
            memcpy(dst + 4u * i, &v, 4);
        }
        break;
    case DR_KIND_REAL:
        for (unsigned i = 0; i < f->count; i++) {
            float v = real_from_wire(dr_get_le32(src + 4u * i));
            memcpy(dst + 4u * i, &v, 4);
        }
        break;
    }
}

/* Check a typed member before encoding: masks within their bits, O->T REALs
 * finite. */
static dr_status_t check_member(const dr_field_t *f, const uint8_t *obj)
{
    const uint8_t *src = obj + f->member_offset;

    if (f->kind == DR_KIND_BITS && f->count < 64u &&
        (get_member_uint(src, f->member_size) >> f->count) != 0)
        return DR_ERANGE;
    if (f->kind == DR_KIND_REAL &&
        dr_asm_info((dr_asm_t)f->assembly)->dir == DR_DIR_O2T) {
        for (unsigned i = 0; i < f->count; i++) {
            float v;
            memcpy(&v, src + 4u * i, 4);
            if (v != v || v > FLT_MAX || v < -FLT_MAX)
                return DR_ENONFINITE;
        }
    }
    return DR_OK;
}

static void encode_field(const dr_field_t *f, const uint8_t *obj, uint8_t *buf)
{
    const uint8_t *src = obj + f->member_offset;
    uint8_t *dst = buf + f->offset;

    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT: {
        bool b;
        memcpy(&b, src, sizeof b);
        store_bits(dst, f->bit, 1, b ? 1u : 0u);
        break;
    }
    case DR_KIND_BITS:
        store_bits(dst, f->bit, f->count, get_member_uint(src, f->member_size));
        break;
    case DR_KIND_USINT:
    case DR_KIND_ENUM:
        memcpy(dst, src, f->count);
        break;
    case DR_KIND_DINT:
    case DR_KIND_REAL:
        /* int32_t and float are both copied as their 32-bit pattern. */
        for (unsigned i = 0; i < f->count; i++) {
            uint32_t v;
            memcpy(&v, src + 4u * i, 4);
            dr_put_le32(dst + 4u * i, v);
        }
        break;
    }
}

/* ---- whole assemblies --------------------------------------------------- */

dr_status_t dr_asm_decode(dr_asm_t a, const uint8_t *buf, size_t len, void *out)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL || buf == NULL || out == NULL)
        return DR_EINVAL;
    if (len != info->size)
        return DR_ELENGTH;
    memset(out, 0, info->struct_size);
    const dr_field_t *f = &dr_field_table[info->first_field];
    for (unsigned i = 0; i < info->field_count; i++)
        decode_field(&f[i], buf, out);
    return DR_OK;
}

dr_status_t dr_asm_encode(dr_asm_t a, const void *in, uint8_t *buf, size_t len)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL || buf == NULL || in == NULL)
        return DR_EINVAL;
    if (len != info->size)
        return DR_ELENGTH;
    const dr_field_t *f = &dr_field_table[info->first_field];
    for (unsigned i = 0; i < info->field_count; i++) {
        dr_status_t st = check_member(&f[i], in);
        if (st != DR_OK)
            return st;
    }
    memset(buf, 0, len);
    for (unsigned i = 0; i < info->field_count; i++)
        encode_field(&f[i], in, buf);
    return DR_OK;
}

#define TYPED(name, A, T)                                                     \
    dr_status_t dr_##name##_decode(const uint8_t *buf, size_t len, T *out)    \
    {                                                                         \
        return dr_asm_decode(A, buf, len, out);                               \
    }                                                                         \
    dr_status_t dr_##name##_encode(const T *in, uint8_t *buf, size_t len)     \
    {                                                                         \
        return dr_asm_encode(A, in, buf, len);                                \
    }
TYPED(io_state, DR_ASM_IO_STATE, dr_io_state_t)
TYPED(joint_state, DR_ASM_JOINT_STATE, dr_joint_state_t)
TYPED(task_state, DR_ASM_TASK_STATE, dr_task_state_t)
TYPED(io_control, DR_ASM_IO_CONTROL, dr_io_control_t)

/* ---- values ------------------------------------------------------------- */

dr_value_t dr_value_real(double f)
{
    dr_value_t v = {DR_VAL_REAL, 0, 0, f};
    return v;
}

dr_value_t dr_value_int(int64_t i)
{
    dr_value_t v = {DR_VAL_INT, 0, i, 0.0};
    return v;
}

dr_value_t dr_value_uint(uint64_t u)
{
    dr_value_t v = {DR_VAL_UINT, u, 0, 0.0};
    return v;
}

double dr_value_as_double(const dr_value_t *v)
{
    switch (v->type) {
    case DR_VAL_BOOL:
    case DR_VAL_UINT: return (double)v->u;
    case DR_VAL_INT: return (double)v->i;
    default: return v->f;
    }
}

dr_val_type_t dr_ref_type(dr_ref_t ref)
{
    switch ((dr_kind_t)ref.field->kind) {
    case DR_KIND_BIT: return DR_VAL_BOOL;
    case DR_KIND_BITS: return ref.elem < 0 ? DR_VAL_UINT : DR_VAL_BOOL;
    case DR_KIND_USINT:
    case DR_KIND_ENUM: return DR_VAL_UINT;
    case DR_KIND_DINT: return DR_VAL_INT;
    default: return DR_VAL_REAL;
    }
}

/* The value as an exact integer in [lo, hi]; REALs must be whole numbers.
 * Compares in the value's own type first, so no conversion is out of range. */
static dr_status_t value_to_int(const dr_value_t *v, int64_t lo, uint64_t hi,
                                int64_t *out)
{
    switch (v->type) {
    case DR_VAL_BOOL:
    case DR_VAL_UINT:
        if (v->u > hi)
            return DR_ERANGE;
        *out = (int64_t)v->u;
        return DR_OK;
    case DR_VAL_INT:
        if (v->i < lo || (v->i > 0 && (uint64_t)v->i > hi))
            return DR_ERANGE;
        *out = v->i;
        return DR_OK;
    case DR_VAL_REAL:
        /* hi and lo here are at most 2^32 in magnitude: exact in a double. */
        if (!(v->f >= (double)lo && v->f <= (double)hi))
            return DR_ERANGE; /* also NaN */
        *out = (int64_t)v->f;
        return (double)*out == v->f ? DR_OK : DR_ERANGE;
    }
    return DR_EINVAL;
}

static dr_status_t check_ref(size_t len, dr_ref_t ref)
{
    if (ref.field == NULL)
        return DR_EINVAL;
    const dr_asm_info_t *info = dr_asm_info((dr_asm_t)ref.field->assembly);
    if (info == NULL)
        return DR_EINVAL;
    if (len != info->size)
        return DR_ELENGTH;
    if (ref.elem >= (int)ref.field->count ||
        (ref.elem < 0 && ref.field->kind != DR_KIND_BITS &&
         ref.field->count != 1) ||
        ref.elem < -1)
        return DR_EINDEX;
    return DR_OK;
}

/* Element index for scalar fields named without an index. */
static unsigned elem_of(dr_ref_t ref)
{
    return ref.elem < 0 ? 0u : (unsigned)ref.elem;
}

dr_status_t dr_field_get(const uint8_t *buf, size_t len, dr_ref_t ref,
                         dr_value_t *out)
{
    dr_status_t st = check_ref(len, ref);
    if (st != DR_OK)
        return st;
    if (buf == NULL || out == NULL)
        return DR_EINVAL;
    const dr_field_t *f = ref.field;
    const uint8_t *src = buf + f->offset;
    unsigned e = elem_of(ref);

    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT:
        *out = dr_value_uint(load_bits(src, f->bit, 1));
        out->type = DR_VAL_BOOL;
        break;
    case DR_KIND_BITS:
        if (ref.elem < 0) {
            *out = dr_value_uint(load_bits(src, f->bit, f->count));
        } else {
            *out = dr_value_uint(load_bits(src, f->bit + e, 1));
            out->type = DR_VAL_BOOL;
        }
        break;
    case DR_KIND_USINT:
    case DR_KIND_ENUM:
        *out = dr_value_uint(src[e]);
        break;
    case DR_KIND_DINT:
        *out = dr_value_int(int32_from_wire(dr_get_le32(src + 4u * e)));
        break;
    case DR_KIND_REAL:
        *out = dr_value_real(real_from_wire(dr_get_le32(src + 4u * e)));
        break;
    }
    return DR_OK;
}

dr_status_t dr_value_check(dr_ref_t ref, const dr_value_t *v, unsigned flags)
{
    int64_t n;
    if (ref.field == NULL || v == NULL)
        return DR_EINVAL;
    dr_status_t st = check_ref(dr_asm_info((dr_asm_t)ref.field->assembly)->size, ref);
    if (st != DR_OK)
        return st;
    const dr_asm_info_t *info = dr_asm_info((dr_asm_t)ref.field->assembly);
    if ((flags & DR_SET_O2T_ONLY) && info->dir != DR_DIR_O2T)
        return DR_EREADONLY;

    switch ((dr_kind_t)ref.field->kind) {
    case DR_KIND_BIT:
        return value_to_int(v, 0, 1, &n);
    case DR_KIND_BITS:
        if (ref.elem >= 0)
            return value_to_int(v, 0, 1, &n);
        if (ref.field->count == 64) {
            /* A whole 64-bit mask only comes exactly as an unsigned integer. */
            if (v->type == DR_VAL_UINT || v->type == DR_VAL_BOOL)
                return DR_OK;
            return value_to_int(v, 0, UINT32_MAX, &n);
        }
        return value_to_int(v, 0, (UINT64_C(1) << ref.field->count) - 1u, &n);
    case DR_KIND_USINT:
    case DR_KIND_ENUM:
        return value_to_int(v, 0, UINT8_MAX, &n);
    case DR_KIND_DINT:
        return value_to_int(v, INT32_MIN, INT32_MAX, &n);
    case DR_KIND_REAL: {
        double f = dr_value_as_double(v);
        if (f != f || f > DBL_MAX || f < -DBL_MAX)
            return info->dir == DR_DIR_O2T ? DR_ENONFINITE : DR_OK;
        /* Beyond FLT_MAX only what rounds to infinity is out of range:
         * 3.4028235e38, the shortest text of FLT_MAX, is a little above it
         * and must read back. The limit is FLT_MAX + half an ulp. */
        return (f >= REAL_TO_INF || f <= -REAL_TO_INF) ? DR_ERANGE : DR_OK;
    }
    }
    return DR_EINVAL;
}

dr_status_t dr_field_set(uint8_t *buf, size_t len, dr_ref_t ref,
                         const dr_value_t *v, unsigned flags)
{
    dr_status_t st = check_ref(len, ref);
    if (st == DR_OK)
        st = dr_value_check(ref, v, flags);
    if (st != DR_OK)
        return st;
    if (buf == NULL)
        return DR_EINVAL;

    const dr_field_t *f = ref.field;
    uint8_t *dst = buf + f->offset;
    unsigned e = elem_of(ref);
    int64_t n = 0;

    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT:
        (void)value_to_int(v, 0, 1, &n);
        store_bits(dst, f->bit, 1, (uint64_t)n);
        break;
    case DR_KIND_BITS:
        if (ref.elem >= 0) {
            (void)value_to_int(v, 0, 1, &n);
            store_bits(dst, f->bit + e, 1, (uint64_t)n);
        } else if (v->type == DR_VAL_UINT || v->type == DR_VAL_BOOL) {
            store_bits(dst, f->bit, f->count, v->u);
        } else {
            (void)value_to_int(v, 0, UINT32_MAX, &n);
            store_bits(dst, f->bit, f->count, (uint64_t)n);
        }
        break;
    case DR_KIND_USINT:
    case DR_KIND_ENUM:
        (void)value_to_int(v, 0, UINT8_MAX, &n);
        dst[e] = (uint8_t)n;
        break;
    case DR_KIND_DINT:
        (void)value_to_int(v, INT32_MIN, INT32_MAX, &n);
        dr_put_le32(dst + 4u * e, (uint32_t)n);
        break;
    case DR_KIND_REAL:
        dr_put_le32(dst + 4u * e, real_to_wire((float)dr_value_as_double(v)));
        break;
    }
    return DR_OK;
}

/* ---- kinds -------------------------------------------------------------- */

unsigned dr_kind_wire_size(dr_kind_t kind)
{
    switch (kind) {
    case DR_KIND_USINT:
    case DR_KIND_ENUM: return 1;
    case DR_KIND_DINT:
    case DR_KIND_REAL: return 4;
    default: return 0;
    }
}

const char *dr_kind_name(dr_kind_t kind)
{
    switch (kind) {
    case DR_KIND_BIT: return "BOOL";
    case DR_KIND_BITS: return "BOOL";
    case DR_KIND_USINT: return "USINT";
    case DR_KIND_ENUM: return "USINT enum";
    case DR_KIND_DINT: return "DINT";
    case DR_KIND_REAL: return "REAL";
    }
    return "?";
}
