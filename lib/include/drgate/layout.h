/* SPDX-License-Identifier: MIT */
/*
 * drgate layouts: how the ten assemblies travel on the wire.
 *
 * The field table (codec.h) describes ten assemblies. Which instances a
 * controller offers for them is not published (docs/commissioning.md):
 *
 *   per_assembly  one instance per assembly (101..110 by default): one
 *                 Class 1 connection, or one Get/Set, per assembly.
 *   combined      one T->O image carrying the six T->O assemblies back to
 *                 back (36+144+96+8+96+96 = 476 bytes, Doosan's
 *                 "Monitoring&GPR (476bytes)"), and one O->T image carrying
 *                 the four O->T ones (12+8+96+96 = 212 bytes).
 *   gpr_only      the same with the register assemblies only: T->O bit_out,
 *                 int_out, float_out (200 bytes), O->T bit_in, int_in,
 *                 float_in (200 bytes).
 *
 * A combined image is a "point": an instance, its size and the assemblies
 * it carries, in wire order, each at the sum of the sizes before it. The
 * functions below slice such an image into the assemblies' own images and
 * put them back together, so that every consumer keeps working on the
 * per-assembly images (and so on the field table) whatever the layout.
 *
 * Portable C99, as the codec: no malloc, no stdio, no OS calls; every
 * length is checked before a byte is copied.
 */
#ifndef DRGATE_LAYOUT_H
#define DRGATE_LAYOUT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/codec.h"
#include "drgate/status.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum {
    DR_LAYOUT_PER_ASSEMBLY = 0,
    DR_LAYOUT_COMBINED,
    DR_LAYOUT_GPR_ONLY,
    DR_LAYOUT_COUNT
} dr_layout_kind_t;

/* Default instances of the two points of a combined layout: a convention
 * (as 101..110 are), overridable wherever a layout is configured. */
#define DR_LAYOUT_INPUT_INSTANCE 100u
#define DR_LAYOUT_OUTPUT_INSTANCE 150u
/* The assemblies one point may carry: at most every assembly of one
 * direction (6 T->O). */
#define DR_POINT_MAX_ASM 6u
/* The largest point: the six T->O assemblies, 476 bytes. */
#define DR_POINT_MAX_SIZE 476u

/* One connection point (assembly instance) carrying `count` assemblies. */
typedef struct {
    uint16_t instance;
    uint16_t size;  /* bytes on the wire; must equal dr_point_sum() */
    uint8_t count;  /* 0: the point is not used (e.g. no O->T image) */
    uint8_t asm_id[DR_POINT_MAX_ASM]; /* dr_asm_t, in wire order */
} dr_point_t;

typedef struct {
    dr_layout_kind_t kind;
    dr_point_t input;  /* T->O (combined, gpr_only) */
    dr_point_t output; /* O->T (combined, gpr_only); count 0: none */
} dr_layout_t;

/* "per_assembly", "combined", "gpr_only"; NULL for another value. */
const char *dr_layout_name(dr_layout_kind_t kind);

/* By name (exact). DR_OK or DR_ENOENT. */
dr_status_t dr_layout_lookup(const char *name, dr_layout_kind_t *out);

/* The layout `kind` with its default points: instances
 * DR_LAYOUT_INPUT_INSTANCE and DR_LAYOUT_OUTPUT_INSTANCE, the assemblies
 * named above, sizes their sums. per_assembly: both points empty. */
void dr_layout_default(dr_layout_t *l, dr_layout_kind_t kind);

/* Sum of the sizes of the point's assemblies (0 for an empty point, or
 * one that names no valid assembly). */
uint16_t dr_point_sum(const dr_point_t *p);

/* The point is usable for direction `dir`: 1..DR_POINT_MAX_ASM
 * assemblies, each of that direction, none twice, size = their sum.
 * DR_EINVAL (count, direction, repeat, NULL) or DR_ELENGTH (size). */
dr_status_t dr_point_check(const dr_point_t *p, dr_dir_t dir);

/* Byte offset of assembly `a` in the point's image; -1 if it does not
 * carry it. */
int dr_point_offset(const dr_point_t *p, dr_asm_t a);

/* True if the point carries assembly `a`. */
bool dr_point_has(const dr_point_t *p, dr_asm_t a);

/* Copy assembly `a` out of the point's image img[len] into
 * out[out_len] (out_len = the assembly's size). DR_EINVAL (a not
 * carried, NULL), DR_ELENGTH (len != p->size, or out_len wrong); on error
 * nothing is written. */
dr_status_t dr_point_slice(const dr_point_t *p, const uint8_t *img, size_t len,
                           dr_asm_t a, uint8_t *out, size_t out_len);

/* Copy assembly `a`'s image in[in_len] into its place in the point's
 * image img[len]. Errors as dr_point_slice; on error img is unchanged. */
dr_status_t dr_point_put(const dr_point_t *p, uint8_t *img, size_t len,
                         dr_asm_t a, const uint8_t *in, size_t in_len);

/* What a set of instance sizes looks like, for a probe: the caller gives
 * the size each assembly instance reported (0: the instance does not
 * exist) in per_asm[], and the sizes of the two combined points
 * (0: absent). Returns the layout they match and DR_OK, or DR_ENOENT when
 * they match none (the caller says so, with the sizes). per_assembly
 * matches when all ten have their specification's sizes; combined when
 * the input point is 476 and the output point 212 bytes; gpr_only when
 * they are 200 and 200 bytes. */
dr_status_t dr_layout_match(const uint16_t per_asm[DR_ASM_COUNT], uint16_t input_size,
                            uint16_t output_size, dr_layout_kind_t *out);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_LAYOUT_H */
