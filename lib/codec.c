/* SPDX-License-Identifier: MIT */
/*
 * Decode, encode and per-field access of the assemblies. Whole-assembly
 * decode and encode are expanded per assembly from the field lists of
 * fields_internal.h; per-field access walks the field table. No offset is
 * written down in this file.
 */
#include <float.h>
#include <stddef.h>
#include <string.h>

#include "drgate/codec.h"
#include "fields_internal.h"

/* ---- wire helpers ----------------------------------------------------- */

/* HOST_IS_LE: wire order is host order, so runs of bytes can be copied. */
#if defined(__BYTE_ORDER__) && defined(__ORDER_LITTLE_ENDIAN__) && \
    __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
#define HOST_IS_LE 1
#else
#define HOST_IS_LE 0
#endif

/* Little-endian load/store of n (1..8) bytes as one integer. */
static uint64_t load_le(const uint8_t *p, unsigned n)
{
    uint64_t v = 0;
    if (HOST_IS_LE) {
        memcpy(&v, p, n);
        return v;
    }
    for (unsigned i = 0; i < n; i++)
        v |= (uint64_t)p[i] << (8u * i);
    return v;
}

static void store_le(uint8_t *p, unsigned n, uint64_t v)
{
    if (HOST_IS_LE) {
        memcpy(p, &v, n);
        return;
    }
    for (unsigned i = 0; i < n; i++)
        p[i] = (uint8_t)(v >> (8u * i));
}

static uint64_t low_mask(unsigned count)
{
    return count < 64u ? (UINT64_C(1) << count) - 1u : ~UINT64_C(0);
}

/* `count` bits starting at bit `bit` of the little-endian row at `row`.
 * The table guarantees bit + count <= 64. */
static uint64_t load_bits(const uint8_t *row, unsigned bit, unsigned count)
{
    return (load_le(row, (bit + count + 7u) / 8u) >> bit) & low_mask(count);
}

/* Write `count` bits of `v` at bit `bit` of `row`, leaving other bits:
 * one read-modify-write of the bytes the field touches. */
static void store_bits(uint8_t *row, unsigned bit, unsigned count, uint64_t v)
{
    unsigned n = (bit + count + 7u) / 8u;
    uint64_t mask = low_mask(count) << bit;
    store_le(row, n, (load_le(row, n) & ~mask) | ((v << bit) & mask));
}

/* Runs of 32-bit values (REAL, DINT) are most of the data. Their bit
 * patterns move unchanged between wire and struct (int32_t is two's
 * complement, float is binary32 with the integers' byte order), so on a
 * little-endian host a run is one memcpy; elsewhere, byte by byte. */
static void words_from_wire(uint8_t *dst, const uint8_t *src, unsigned n)
{
    if (HOST_IS_LE) {
        memcpy(dst, src, 4u * n);
        return;
    }
    for (unsigned i = 0; i < n; i++) {
        uint32_t v = dr_get_le32(src + 4u * i);
        memcpy(dst + 4u * i, &v, 4);
    }
}

static void words_to_wire(uint8_t *dst, const uint8_t *src, unsigned n)
{
    if (HOST_IS_LE) {
        memcpy(dst, src, 4u * n);
        return;
    }
    for (unsigned i = 0; i < n; i++) {
        uint32_t v;
        memcpy(&v, src + 4u * i, 4);
        dr_put_le32(dst + 4u * i, v);
    }
}

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

/* ---- whole assemblies ----------------------------------------------------
 * One decode and one encode function per assembly, expanded from its field
 * list (fields_internal.h): every offset, bit and count is a constant, so
 * each field compiles to a few loads and stores. */

/* decode one field into struct member m from the wire bytes at p (the
 * aliases are function-like: cppcheck's preprocessor does not rescan an
 * object-like alias of a function-like macro). A bit field is read from
 * the byte holding its first bit, as wide as it needs (tool_do, six bits at
 * bit 16 of its row: one byte, not three): a 3-byte load went through a
 * stack temporary, which cost a store-forwarding stall and a stack
 * protector. */
#define DEC_BIT(m, p, bit, n) (m) = ((p)[(bit) / 8u] >> ((bit) % 8u)) & 1u;
#define DEC_BITS(m, p, bit, n) (m) = load_bits((p) + (bit) / 8u, (bit) % 8u, n);
#define DEC_USINT(m, p, bit, n) memcpy(&(m), p, n);
#define DEC_ENUM(m, p, bit, n) DEC_USINT(m, p, bit, n)
#define DEC_DINT(m, p, bit, n) words_from_wire((uint8_t *)&(m), p, n);
#define DEC_REAL(m, p, bit, n) DEC_DINT(m, p, bit, n)
#define DEC_FIELD(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)       \
    DEC_##K(o->M, buf + (OFF), BIT, N)

/* encode one field onto zeroed wire bytes at p */
#define ENC_BIT(m, p, bit, n) (p)[(bit) / 8u] |= (uint8_t)((m) ? 1u << ((bit) % 8u) : 0u);
#define ENC_BITS(m, p, bit, n) or_bits((p) + (bit) / 8u, (bit) % 8u, n, (uint64_t)(m));
#define ENC_USINT(m, p, bit, n) memcpy(p, &(m), n);
#define ENC_ENUM(m, p, bit, n) ENC_USINT(m, p, bit, n)
#define ENC_DINT(m, p, bit, n) words_to_wire(p, (const uint8_t *)&(m), n);
#define ENC_REAL(m, p, bit, n) ENC_DINT(m, p, bit, n)
#define ENC_FIELD(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)       \
    ENC_##K(o->M, buf + (OFF), BIT, N)

/* check one member before anything is written */
#define CHK_BIT(m, n, o2t) DR_OK
#define CHK_BITS(m, n, o2t) (mask_fits((uint64_t)(m), n) ? DR_OK : DR_ERANGE)
#define CHK_USINT(m, n, o2t) DR_OK
#define CHK_ENUM(m, n, o2t) CHK_USINT(m, n, o2t)
#define CHK_DINT(m, n, o2t) CHK_USINT(m, n, o2t)
#define CHK_REAL(m, n, o2t) ((o2t) ? reals_finite((const uint8_t *)&(m), n) : DR_OK)
#define CHK_FIELD(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)       \
    if ((st = CHK_##K(o->M, N, o2t)) != DR_OK)                                 \
        return st;

/* Encoding writes onto a zeroed image, and masks were checked to fit
 * their bits: OR-ing the value in is enough. */
static void or_bits(uint8_t *row, unsigned bit, unsigned count, uint64_t v)
{
    unsigned n = (bit + count + 7u) / 8u;
    store_le(row, n, load_le(row, n) | (v << bit));
}

static bool mask_fits(uint64_t v, unsigned count)
{
    return count >= 64u || (v >> count) == 0;
}

/* NaN and infinities have all exponent bits set. No early exit: the loop
 * vectorizes, and the values are almost always fine. */
static dr_status_t reals_finite(const uint8_t *p, unsigned n)
{
    unsigned bad = 0;
    for (unsigned i = 0; i < n; i++) {
        uint32_t u;
        memcpy(&u, p + 4u * i, 4);
        bad |= (u & 0x7F800000u) == 0x7F800000u;
    }
    return bad ? DR_ENONFINITE : DR_OK;
}

/* Bytes of struct members and bits on the wire, summed over the fields:
 * a struct with no padding need not be cleared before decoding, a wire
 * image with no reserved bits need not be cleared before encoding. */
#define MEMBER_BYTES(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)    \
    +sizeof(((T *)0)->M)
#define WIRE_BITS_BIT(n) 1u
#define WIRE_BITS_BITS(n) (n)
#define WIRE_BITS_USINT(n) (8u * (n))
#define WIRE_BITS_ENUM(n) WIRE_BITS_USINT(n)
#define WIRE_BITS_DINT(n) (32u * (n))
#define WIRE_BITS_REAL(n) WIRE_BITS_DINT(n)
#define WIRE_BITS(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)       \
    +WIRE_BITS_##K(N)
#define BIT_FIELD(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)       \
    +(DR_KIND_##K == DR_KIND_BIT || DR_KIND_##K == DR_KIND_BITS)

/* An assembly is "flat" when its struct is its wire image on a
 * little-endian host: nothing but REAL/DINT runs, each member at its wire
 * offset, no padding and no reserved bytes (joint_state, task_state and
 * the int and float registers). Its fields then move as one memcpy of the
 * whole image instead of one per field; everywhere else (big-endian hosts,
 * assemblies with bits or bytes) the field-by-field code below runs. All
 * of it is a constant expression, so only one of the two is compiled. */
#define SAME_WORDS(A, T, M, K, OFF, BIT, N, FIRST, IDX, NAME, UNIT, HELP)      \
    &&(DR_KIND_##K == DR_KIND_DINT || DR_KIND_##K == DR_KIND_REAL) &&         \
        offsetof(T, M) == (OFF)
#define FLAT(T, FIELDS, SIZE)                                                 \
    (HOST_IS_LE && sizeof(T) == (SIZE) &&                                     \
     (0 FIELDS(MEMBER_BYTES, 0, T)) == (SIZE) FIELDS(SAME_WORDS, 0, T))

/* Wire bytes and struct never overlap (codec.h says so): `restrict` lets
 * the compiler keep a wire byte in a register across the stores of the
 * bits it holds, and merge neighbouring stores, instead of reloading it
 * after every store to a bool (char types may alias anything). */
#define DEFINE_CODEC(ID, name, T, FIELDS, O2T, SIZE)                                 \
    static dr_status_t decode_##name(const uint8_t *restrict buf,            \
                                     void *restrict out)                      \
    {                                                                         \
        T *restrict o = out;                                                  \
        if (FLAT(T, FIELDS, SIZE)) {                                          \
            memcpy(o, buf, SIZE);                                             \
            return DR_OK;                                                     \
        }                                                                     \
        if (sizeof *o != 0 FIELDS(MEMBER_BYTES, DR_ASM_##ID, T))              \
            memset(o, 0, sizeof *o); /* padding, so structs compare equal */  \
        FIELDS(DEC_FIELD, DR_ASM_##ID, T)                                     \
        return DR_OK;                                                         \
    }                                                                         \
    /* every value is checked before the first byte is written */           \
    static dr_status_t encode_##name(const void *restrict in,                \
                                     uint8_t *restrict buf)                   \
    {                                                                         \
        const T *restrict o = in;                                             \
        const bool o2t = O2T;                                                 \
        dr_status_t st = DR_OK;                                               \
        (void)o2t;                                                            \
        FIELDS(CHK_FIELD, DR_ASM_##ID, T)                                     \
        if (FLAT(T, FIELDS, SIZE)) {                                          \
            memcpy(buf, o, SIZE);                                             \
            return DR_OK;                                                     \
        }                                                                     \
        /* reserved bits are 0, and bit fields are OR-ed onto zeros */        \
        if ((0u FIELDS(WIRE_BITS, 0, T)) != 8u * (SIZE) ||                    \
            (0 FIELDS(BIT_FIELD, 0, T)) > 0)                                  \
            memset(buf, 0, SIZE);                                             \
        FIELDS(ENC_FIELD, DR_ASM_##ID, T)                                     \
        return st;                                                            \
    }
DR_ASSEMBLIES(DEFINE_CODEC)

/* The wire size sits next to the functions (the same SIZE as
 * dr_asm_info's), so a call is one bounds check, one length check and a
 * tail call, without asking fields.c first. */
typedef struct {
    dr_status_t (*decode)(const uint8_t *restrict buf, void *restrict out);
    dr_status_t (*encode)(const void *restrict in, uint8_t *restrict buf);
    size_t size;
} asm_codec_t;

#define CODEC_ENTRY(ID, name, T, FIELDS, O2T, SIZE)                            \
    {decode_##name, encode_##name, SIZE},
static const asm_codec_t codecs[DR_ASM_COUNT] = {DR_ASSEMBLIES(CODEC_ENTRY)};

dr_status_t dr_asm_decode(dr_asm_t a, const uint8_t *buf, size_t len, void *out)
{
    if ((unsigned)a >= DR_ASM_COUNT || buf == NULL || out == NULL)
        return DR_EINVAL;
    if (len != codecs[a].size)
        return DR_ELENGTH;
    return codecs[a].decode(buf, out);
}

dr_status_t dr_asm_encode(dr_asm_t a, const void *in, uint8_t *buf, size_t len)
{
    if ((unsigned)a >= DR_ASM_COUNT || buf == NULL || in == NULL)
        return DR_EINVAL;
    if (len != codecs[a].size)
        return DR_ELENGTH;
    return codecs[a].encode(in, buf);
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
