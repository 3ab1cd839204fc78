/* SPDX-License-Identifier: MIT */
/*
 * Layouts: combined images sliced into the assemblies and put back
 * together (drgate/layout.h). Offsets come from the assemblies' sizes in
 * the field table; none is written down here.
 */
#include <string.h>

#include "drgate/layout.h"

static const char *const layout_names[DR_LAYOUT_COUNT] = {
    "per_assembly", "combined", "gpr_only",
};

const char *dr_layout_name(dr_layout_kind_t kind)
{
    return (unsigned)kind < DR_LAYOUT_COUNT ? layout_names[kind] : NULL;
}

dr_status_t dr_layout_lookup(const char *name, dr_layout_kind_t *out)
{
    if (name == NULL || out == NULL)
        return DR_EINVAL;
    for (unsigned k = 0; k < DR_LAYOUT_COUNT; k++)
        if (strcmp(name, layout_names[k]) == 0) {
            *out = (dr_layout_kind_t)k;
            return DR_OK;
        }
    return DR_ENOENT;
}

/* The point of direction `dir` carrying every assembly of that direction
 * that `gpr` allows (registers only, or all), in dr_asm_t order. */
static void default_point(dr_point_t *p, dr_dir_t dir, bool gpr, uint16_t instance)
{
    memset(p, 0, sizeof *p);
    p->instance = instance;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        /* the register assemblies: their one field has no name of its
         * own ("int_in[7]"), as the field table says */
        uint16_t n = 0;
        const dr_field_t *f = dr_asm_fields((dr_asm_t)a, &n);
        bool reg = f != NULL && n == 1 && f->name[0] == '\0';
        if (info->dir != dir || (gpr && !reg) || p->count >= DR_POINT_MAX_ASM)
            continue;
        p->asm_id[p->count++] = (uint8_t)a;
    }
    p->size = dr_point_sum(p);
}

void dr_layout_default(dr_layout_t *l, dr_layout_kind_t kind)
{
    memset(l, 0, sizeof *l);
    l->kind = kind;
    if (kind != DR_LAYOUT_COMBINED && kind != DR_LAYOUT_GPR_ONLY)
        return;
    bool gpr = kind == DR_LAYOUT_GPR_ONLY;
    default_point(&l->input, DR_DIR_T2O, gpr, DR_LAYOUT_INPUT_INSTANCE);
    default_point(&l->output, DR_DIR_O2T, gpr, DR_LAYOUT_OUTPUT_INSTANCE);
}

uint16_t dr_point_sum(const dr_point_t *p)
{
    if (p == NULL || p->count == 0 || p->count > DR_POINT_MAX_ASM)
        return 0;
    unsigned sum = 0;
    for (unsigned i = 0; i < p->count; i++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)p->asm_id[i]);
        if (info == NULL)
            return 0;
        sum += info->size;
    }
    return (uint16_t)sum;
}

dr_status_t dr_point_check(const dr_point_t *p, dr_dir_t dir)
{
    if (p == NULL || p->count == 0 || p->count > DR_POINT_MAX_ASM)
        return DR_EINVAL;
    unsigned seen = 0;
    for (unsigned i = 0; i < p->count; i++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)p->asm_id[i]);
        if (info == NULL || info->dir != dir || (seen & (1u << p->asm_id[i])))
            return DR_EINVAL;
        seen |= 1u << p->asm_id[i];
    }
    return p->size == dr_point_sum(p) ? DR_OK : DR_ELENGTH;
}

int dr_point_offset(const dr_point_t *p, dr_asm_t a)
{
    if (p == NULL || p->count > DR_POINT_MAX_ASM)
        return -1;
    unsigned off = 0;
    for (unsigned i = 0; i < p->count; i++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)p->asm_id[i]);
        if (info == NULL)
            return -1;
        if (p->asm_id[i] == (unsigned)a)
            return (int)off;
        off += info->size;
    }
    return -1;
}

bool dr_point_has(const dr_point_t *p, dr_asm_t a)
{
    return dr_point_offset(p, a) >= 0;
}

/* Where assembly a is in the point's image of len bytes: its offset, or
 * an error when the image or the assembly's buffer has the wrong size. */
static dr_status_t locate(const dr_point_t *p, size_t len, dr_asm_t a, size_t asm_len,
                          size_t *off)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    int o = dr_point_offset(p, a);
    if (info == NULL || o < 0)
        return DR_EINVAL;
    if (len != p->size || asm_len != info->size || p->size != dr_point_sum(p))
        return DR_ELENGTH;
    *off = (size_t)o; /* o + size <= sum = len: checked above */
    return DR_OK;
}

dr_status_t dr_point_slice(const dr_point_t *p, const uint8_t *img, size_t len,
                           dr_asm_t a, uint8_t *out, size_t out_len)
{
    size_t off;
    if (img == NULL || out == NULL)
        return DR_EINVAL;
    dr_status_t st = locate(p, len, a, out_len, &off);
    if (st == DR_OK)
        memcpy(out, img + off, out_len);
    return st;
}

dr_status_t dr_point_put(const dr_point_t *p, uint8_t *img, size_t len,
                         dr_asm_t a, const uint8_t *in, size_t in_len)
{
    size_t off;
    if (img == NULL || in == NULL)
        return DR_EINVAL;
    dr_status_t st = locate(p, len, a, in_len, &off);
    if (st == DR_OK)
        memcpy(img + off, in, in_len);
    return st;
}

dr_status_t dr_layout_match(const uint16_t per_asm[DR_ASM_COUNT], uint16_t input_size,
                            uint16_t output_size, dr_layout_kind_t *out)
{
    if (per_asm == NULL || out == NULL)
        return DR_EINVAL;
    bool all = true;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        all &= per_asm[a] == dr_asm_info((dr_asm_t)a)->size;
    if (all) {
        *out = DR_LAYOUT_PER_ASSEMBLY;
        return DR_OK;
    }
    for (unsigned k = DR_LAYOUT_COMBINED; k < DR_LAYOUT_COUNT; k++) {
        dr_layout_t l;
        dr_layout_default(&l, (dr_layout_kind_t)k);
        if (input_size == l.input.size && output_size == l.output.size) {
            *out = (dr_layout_kind_t)k;
            return DR_OK;
        }
    }
    return DR_ENOENT;
}
