/* SPDX-License-Identifier: MIT */
/*
 * drgate codec: the Doosan robot's ten EtherNet/IP assemblies.
 *
 * One const field table (dr_field_at) describes every field: assembly,
 * name, byte offset, bit position, wire type, element count, unit and where
 * the value lives in the typed struct. Typed decode/encode, generic access
 * by path, listing and the generated docs all walk that table; no offset is
 * written down anywhere else.
 *
 * Wire rules (spec/README.md): little-endian, REAL = IEEE-754 binary32,
 * DINT = int32; "bit n" of the 32-bit row at byte B is bit n%8 of byte
 * B + n/8. Reserved bits are written as 0 by encode and left untouched by
 * dr_field_set.
 *
 * Portable C99: no malloc, no stdio, no OS calls; every wire access is
 * byte-wise, so alignment and host byte order do not matter.
 */
#ifndef DRGATE_CODEC_H
#define DRGATE_CODEC_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/status.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- Assemblies ------------------------------------------------------- */

typedef enum {
    DR_ASM_IO_STATE = 0, /* dr1, T->O, 36 bytes */
    DR_ASM_JOINT_STATE,  /* dr2, T->O, 144 bytes */
    DR_ASM_TASK_STATE,   /* dr3, T->O, 96 bytes */
    DR_ASM_BIT_OUT,      /* dr4, T->O, 8 bytes */
    DR_ASM_INT_OUT,      /* dr5, T->O, 96 bytes */
    DR_ASM_FLOAT_OUT,    /* dr6, T->O, 96 bytes */
    DR_ASM_IO_CONTROL,   /* dr7, O->T, 12 bytes */
    DR_ASM_BIT_IN,       /* dr8, O->T, 8 bytes */
    DR_ASM_INT_IN,       /* dr9, O->T, 96 bytes */
    DR_ASM_FLOAT_IN,     /* dr10, O->T, 96 bytes */
    DR_ASM_COUNT
} dr_asm_t;

typedef enum {
    DR_DIR_T2O = 0, /* produced by the robot, read by the PLC/gateway */
    DR_DIR_O2T = 1  /* written by the PLC/gateway, consumed by the robot */
} dr_dir_t;

#define DR_ASM_MAX_SIZE 144u     /* joint_state, the largest */
#define DR_ASM_TOTAL_SIZE 688u   /* all ten together */
#define DR_ASM_DEFAULT_INSTANCE(a) ((uint16_t)(101u + (unsigned)(a)))

typedef struct {
    const char *name;    /* canonical name, e.g. "joint_state" */
    const char *alias;   /* "dr2" */
    const char *title;   /* the specification's title */
    dr_dir_t dir;
    uint16_t size;       /* bytes on the wire */
    uint16_t first_field; /* index of its first field (dr_field_at) */
    uint16_t field_count;
    size_t struct_size;  /* sizeof the typed struct */
} dr_asm_info_t;

/* Information on assembly `a`; NULL if a >= DR_ASM_COUNT. */
const dr_asm_info_t *dr_asm_info(dr_asm_t a);

/* Look an assembly up by canonical name or drN alias (exact match).
 * Returns DR_OK, or DR_ENOENT. */
dr_status_t dr_asm_lookup(const char *name, dr_asm_t *out);

/* ---- Fields ----------------------------------------------------------- */

typedef enum {
    DR_KIND_BIT = 0, /* one bit, 0/1; typed member: bool */
    DR_KIND_BITS,    /* `count` consecutive bits; typed member: the narrowest
                        uint8/16/32/64_t mask, element i is bit i */
    DR_KIND_USINT,   /* uint8_t */
    DR_KIND_ENUM,    /* uint8_t with names (robot_state) */
    DR_KIND_DINT,    /* int32_t, little-endian */
    DR_KIND_REAL     /* float, IEEE-754 binary32, little-endian */
} dr_kind_t;

typedef struct {
    uint8_t assembly;     /* dr_asm_t */
    uint8_t kind;         /* dr_kind_t */
    uint8_t bit;          /* BIT/BITS: first bit, counted from `offset` */
    uint8_t count;        /* elements: 1 for a scalar */
    uint8_t first_index;  /* number of element 0 in paths (1 for cb_di[1]) */
    uint8_t indexed;      /* 1: path takes [index] */
    uint16_t offset;      /* byte offset of the 32-bit row (bits) or of
                             element 0 (REAL/DINT arrays use a 4-byte stride) */
    uint16_t member_offset; /* offsetof in the typed struct */
    uint16_t member_size;   /* sizeof that member */
    const char *name;     /* path below the assembly: "position",
                             "aio_type.ai0", "" for a GPR assembly */
    const char *unit;     /* "degree", "" if none */
    const char *help;     /* one line from the specification */
} dr_field_t;

/* The field table: every field of every assembly, in assembly order
 * (dr_asm_info()->first_field is an index into it). The table itself is
 * internal to the library (2.0.0: it was exported as data, dr_field_table,
 * whose size was then part of the ABI); these three reach it. */
#define DR_FIELD_NONE UINT16_MAX
/* Number of fields. */
uint16_t dr_field_count(void);
/* Field i, NULL if i >= dr_field_count(). The pointer is valid for the
 * life of the program and may be compared with the others it returns. */
const dr_field_t *dr_field_at(uint16_t i);
/* The index of a field this library returned (dr_field_at, dr_asm_fields,
 * dr_ref_t.field), DR_FIELD_NONE for any other pointer. */
uint16_t dr_field_index(const dr_field_t *f);

/* Reference to one leaf (or to a whole BITS mask): what a path names. */
typedef struct {
    const dr_field_t *field;
    int16_t elem; /* 0-based element; -1 = the whole BITS mask */
} dr_ref_t;

/* ---- Typed structs ---------------------------------------------------- */

typedef struct {
    uint16_t cb_di; /* bit i = ControlBox DI i+1 */
    uint16_t cb_do;
    struct {
        bool ai0, ai1, ao0, ao1; /* analog channel type bits */
    } aio_type;
    float ai[2];
    float ao[2];
    uint8_t tool_di; /* bit i = tool DI i+1 */
    uint8_t tool_do;
    struct {
        uint8_t major, minor, patch;
    } version;
    uint8_t robot_state; /* dr_robot_state_t, other values possible */
    bool servo_on;
    bool safety_stopped;
    bool emergency_stopped;
    bool direct_teach_pressed;
    bool power_button_pressed;
} dr_io_state_t;

typedef struct {
    float position[6];          /* degree, joint 1..6 */
    float velocity[6];          /* degree/s */
    float motor_current[6];     /* A */
    float motor_temperature[6]; /* degC */
    float torque[6];            /* Nm */
    float external_torque[6];   /* Nm */
} dr_joint_state_t;

typedef struct {
    float x, y, z;
} dr_xyz_t;

typedef struct {
    dr_xyz_t position;                 /* mm, base frame */
    struct { float a, b, c; } orientation; /* degree, Euler Z-Y-Z */
    dr_xyz_t velocity;                 /* mm/s */
    struct { float rx, ry, rz; } angular_velocity; /* degree/s */
    struct { float x, y, z, a, b, c; } tool_offset; /* mm / degree, tool frame */
    dr_xyz_t external_force;           /* N */
    dr_xyz_t external_moment;          /* Nm */
} dr_task_state_t;

typedef struct {
    uint64_t bits; /* bit r = register r */
} dr_bit_gpr_t;

typedef struct {
    int32_t reg[24];
} dr_int_gpr_t;

typedef struct {
    float reg[24];
} dr_float_gpr_t;

typedef struct {
    uint16_t cb_do; /* bit i = ControlBox DO i+1 */
    uint8_t tool_do;
    struct {
        bool ao0, ao1;
    } ao_type;
    float ao[2];
} dr_io_control_t;

typedef enum {
    DR_ROBOT_INITIALIZING = 0,
    DR_ROBOT_STANDBY = 1,
    DR_ROBOT_OPERATING = 2,
    DR_ROBOT_SAFE_OFF = 3,
    DR_ROBOT_TEACHING = 4,
    DR_ROBOT_SAFE_STOP = 5,
    DR_ROBOT_EMERGENCY_STOP = 6,
    DR_ROBOT_HOMING = 7,
    DR_ROBOT_RECOVERY = 8,
    DR_ROBOT_SAFE_STOP2 = 9,
    DR_ROBOT_SAFE_OFF2 = 10
} dr_robot_state_t;

/* Name of a robot_state value ("OPERATING"), NULL if not one of the above. */
const char *dr_robot_state_name(unsigned value);

/* ---- Whole-assembly decode and encode --------------------------------- */

/* Decode `len` bytes of assembly `a` into its typed struct (`out` must point
 * to the struct named in dr_asm_info(a)->struct_size: dr_io_state_t for
 * io_state, dr_bit_gpr_t for bit_out/bit_in, ...).
 * Errors: DR_EINVAL (bad assembly or NULL), DR_ELENGTH (len != size).
 * On error `out` is untouched. `buf` and `out` must not overlap (the
 * decoders are compiled on that assumption, as if `restrict`). */
dr_status_t dr_asm_decode(dr_asm_t a, const uint8_t *buf, size_t len,
                          void *out);

/* Encode a typed struct into `len` bytes; reserved bits and bytes are 0.
 * Every value is checked before any byte is written:
 * DR_ERANGE (a mask with bits beyond its count), DR_ENONFINITE (NaN or
 * infinity in an O->T REAL), DR_ELENGTH, DR_EINVAL. On error `buf` is
 * untouched. `in` and `buf` must not overlap. */
dr_status_t dr_asm_encode(dr_asm_t a, const void *in, uint8_t *buf,
                          size_t len);

/* Typed wrappers of the two functions above. */
dr_status_t dr_io_state_decode(const uint8_t *buf, size_t len, dr_io_state_t *out);
dr_status_t dr_io_state_encode(const dr_io_state_t *in, uint8_t *buf, size_t len);
dr_status_t dr_joint_state_decode(const uint8_t *buf, size_t len, dr_joint_state_t *out);
dr_status_t dr_joint_state_encode(const dr_joint_state_t *in, uint8_t *buf, size_t len);
dr_status_t dr_task_state_decode(const uint8_t *buf, size_t len, dr_task_state_t *out);
dr_status_t dr_task_state_encode(const dr_task_state_t *in, uint8_t *buf, size_t len);
dr_status_t dr_io_control_decode(const uint8_t *buf, size_t len, dr_io_control_t *out);
dr_status_t dr_io_control_encode(const dr_io_control_t *in, uint8_t *buf, size_t len);

/* ---- Generic access by field ------------------------------------------ */

typedef enum {
    DR_VAL_BOOL = 0, /* u = 0 or 1 */
    DR_VAL_UINT,     /* u: USINT, ENUM, BITS masks */
    DR_VAL_INT,      /* i: DINT */
    DR_VAL_REAL      /* f */
} dr_val_type_t;

typedef struct {
    dr_val_type_t type;
    uint64_t u;
    int64_t i;
    double f;
} dr_value_t;

/* Value type of what `ref` names. */
dr_val_type_t dr_ref_type(dr_ref_t ref);

/* Read the value `ref` names from an assembly image of `len` bytes.
 * Errors: DR_ELENGTH, DR_EINDEX, DR_EINVAL. */
dr_status_t dr_field_get(const uint8_t *buf, size_t len, dr_ref_t ref,
                         dr_value_t *out);

/* Flags for dr_field_set / dr_value_check. */
#define DR_SET_O2T_ONLY 0x1u /* refuse T->O fields (what a PLC may write) */

/* Check that `v` fits what `ref` names, without writing: DR_ERANGE (bit not
 * 0/1, USINT > 255, mask beyond its bits, DINT overflow, REAL beyond
 * binary32), DR_ENONFINITE (NaN/inf for an O->T REAL), DR_EREADONLY (T->O
 * field with DR_SET_O2T_ONLY), DR_EINDEX. Any numeric type is accepted if
 * the value is exact for the field (2.0 for a DINT, but not 2.5). */
dr_status_t dr_value_check(dr_ref_t ref, const dr_value_t *v, unsigned flags);

/* Check `v`, then write it into the image, touching only the field's bits.
 * On error the image is unchanged. */
dr_status_t dr_field_set(uint8_t *buf, size_t len, dr_ref_t ref,
                         const dr_value_t *v, unsigned flags);

/* Helpers to build values. */
dr_value_t dr_value_real(double f);
dr_value_t dr_value_int(int64_t i);
dr_value_t dr_value_uint(uint64_t u);
/* Any value as a double (exact for all but 64-bit masks above 2^53). */
double dr_value_as_double(const dr_value_t *v);

/* ---- Paths ------------------------------------------------------------ */

/* Parse a path such as "joint_state.position[3]", "dr2.position[3]",
 * "io_state.cb_di" (whole mask), "io_state.aio_type.ai0", "int_in[7]".
 * Parsing is exact (lower case, no spaces).
 * Errors: DR_ENOENT (no such field: see dr_path_closest), DR_EINDEX (index
 * outside the field's numbering), DR_ESYNTAX (malformed index). */
dr_status_t dr_path_parse(const char *path, dr_ref_t *out);

/* Same, for a path of `n` bytes that need not be NUL-terminated. */
dr_status_t dr_path_parse_n(const char *path, size_t n, dr_ref_t *out);

/* Write the canonical path of `ref` ("joint_state.position[3]",
 * "int_in[7]") into out[size]. Returns DR_OK or DR_ENOSPACE. */
dr_status_t dr_ref_path(dr_ref_t ref, char *out, size_t size);

/* The known path closest to `path` (edit distance over canonical leaf and
 * mask paths), written into out[size]. Returns DR_OK, or DR_ENOSPACE. */
dr_status_t dr_path_closest(const char *path, char *out, size_t size);

/* Levenshtein distance between two names, each cut to 64 characters:
 * what "closest known name" suggestions are ranked by (also used by the
 * tools for assembly names and configuration keys). */
unsigned dr_edit_distance(const char *a, const char *b);

/* Iterate over every leaf (one element of one field) in table order:
 * i from 0 to dr_leaf_count()-1. Returns DR_OK or DR_EINDEX. */
uint16_t dr_leaf_count(void);
dr_status_t dr_leaf_at(uint16_t i, dr_ref_t *out);

/* Fields of one assembly: pointer to the first and the count. */
const dr_field_t *dr_asm_fields(dr_asm_t a, uint16_t *count);

/* Wire size in bytes of one element of `kind` (1 or 4); 0 for bits. */
unsigned dr_kind_wire_size(dr_kind_t kind);
/* "BOOL", "BITS", "USINT", "USINT enum", "DINT", "REAL" */
const char *dr_kind_name(dr_kind_t kind);

/* Little-endian wire access, usable on any host. */
static inline uint16_t dr_get_le16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (uint16_t)p[1] << 8);
}
static inline uint32_t dr_get_le32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 |
           (uint32_t)p[3] << 24;
}
static inline void dr_put_le16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}
static inline void dr_put_le32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_CODEC_H */
