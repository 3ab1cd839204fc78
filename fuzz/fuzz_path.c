/* SPDX-License-Identifier: MIT */
/*
 * Names and values typed by people (CLI arguments, config files, a web
 * form): dr_path_parse_n, dr_path_closest, dr_text_parse on each kind of
 * leaf, and dr_field_get / dr_field_set on an assembly image.
 *
 * Input layout (gen_corpus.c writes seeds in it):
 *   [flags][leaf lo][leaf hi] path '\0' value '\0' image...
 * flags bit 0: take the whole mask of a BITS field; bit 1: DR_SET_O2T_ONLY;
 * bit 2: DR_TEXT_UNIT; bit 3: call dr_path_closest (it measures the edit
 * distance to all ~370 leaves, ~2 ms instrumented: on every input it would
 * slow the rest of the harness tenfold); bits 4-7: its output size. The leaf
 * number picks the field when the path does not parse. Missing parts are
 * empty; the image is repeated to the assembly's size.
 */
#include <math.h>
#include <string.h>

#include "drgate/codec.h"
#include "drgate/text.h"
#include "fuzz.h"

#define TEXT_MAX 256u

/* A NUL-terminated copy of at most TEXT_MAX bytes. */
static void cstr(char *dst, const uint8_t *src, size_t n)
{
    if (n > TEXT_MAX)
        n = TEXT_MAX;
    memcpy(dst, src, n);
    dst[n] = '\0';
}

/* Next part up to a NUL (or the end); advances *p past the NUL. */
static size_t part(const uint8_t **p, const uint8_t *end)
{
    const uint8_t *s = *p;
    const uint8_t *z = memchr(s, 0, (size_t)(end - s));
    size_t n = (size_t)((z != NULL ? z : end) - s);
    *p = z != NULL ? z + 1 : end;
    return n;
}

static void check_ref(dr_ref_t ref)
{
    FUZZ_CHECK(dr_field_index(ref.field) != DR_FIELD_NONE);
    FUZZ_CHECK(ref.elem >= -1 && ref.elem < (int)ref.field->count);
    FUZZ_CHECK(ref.elem >= 0 || ref.field->kind == DR_KIND_BITS);
    /* The canonical name reads back to the same reference. */
    char canon[64];
    dr_ref_t again;
    FUZZ_CHECK(dr_ref_path(ref, canon, sizeof canon) == DR_OK);
    FUZZ_CHECK(dr_path_parse(canon, &again) == DR_OK);
    FUZZ_CHECK(again.field == ref.field && again.elem == ref.elem);
}

static int same_value(const dr_value_t *a, const dr_value_t *b)
{
    if (a->type != b->type)
        return 0;
    switch (a->type) {
    case DR_VAL_BOOL:
    case DR_VAL_UINT:
        return a->u == b->u;
    case DR_VAL_INT:
        return a->i == b->i;
    default: {
        /* Stored as binary32: compare what the wire holds. */
        float fa = (float)a->f, fb = (float)b->f;
        if (isnan(fa) || isnan(fb))
            return isnan(fa) && isnan(fb);
        /* bitwise on purpose: -0.0f and 0.0f differ on the wire */
        return memcmp(&fa, &fb, sizeof fa) == 0; // NOLINT(bugprone-suspicious-memory-comparison,cert-exp42-c,cert-flp37-c)
    }
    }
}

/* Every leaf of every other field of the assembly reads the same in both
 * images: a set touches only its own field's bits. */
static void check_others(const uint8_t *before, const uint8_t *after,
                         size_t len, const dr_field_t *f)
{
    uint16_t count;
    const dr_field_t *fields = dr_asm_fields((dr_asm_t)f->assembly, &count);
    for (unsigned k = 0; k < count; k++) {
        if (&fields[k] == f)
            continue;
        for (unsigned e = 0; e < fields[k].count; e++) {
            dr_ref_t r = {&fields[k], (int16_t)e};
            dr_value_t x, y;
            FUZZ_CHECK(dr_field_get(before, len, r, &x) == DR_OK);
            FUZZ_CHECK(dr_field_get(after, len, r, &y) == DR_OK);
            if (x.type == DR_VAL_REAL)
                FUZZ_CHECK(memcmp(before + fields[k].offset + 4u * e,
                                  after + fields[k].offset + 4u * e, 4) == 0);
            else
                FUZZ_CHECK(same_value(&x, &y));
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 3)
        return 0;
    unsigned flags = data[0];
    unsigned leaf = (unsigned)(data[1] | data[2] << 8);
    const uint8_t *p = data + 3, *end = data + size;
    const uint8_t *path = p;
    size_t path_n = part(&p, end);
    const uint8_t *value = p;
    size_t value_n = part(&p, end);
    const uint8_t *image_src = p;
    size_t image_n = (size_t)(end - p);

    /* dr_path_parse_n on bytes that are not NUL-terminated (the input is
     * an exact-size block: ASan sees a read past n). */
    dr_ref_t ref;
    int have = dr_path_parse_n((const char *)path, path_n, &ref) == DR_OK;
    if (have)
        check_ref(ref);

    char text[TEXT_MAX + 1];
    cstr(text, path, path_n);
    /* The output size from the flags, 1..61 bytes: cut or whole. */
    char closest[64];
    size_t csize = 1u + (flags >> 4) * 4u;
    dr_status_t st = (flags & 8u) ? dr_path_closest(text, closest, csize) : DR_EINVAL;
    if (st != DR_EINVAL) {
        FUZZ_CHECK(st == DR_OK || st == DR_ENOSPACE);
        FUZZ_CHECK(strnlen(closest, csize) < csize);
    }
    if (st != DR_EINVAL && csize >= 40) {
        dr_ref_t near;
        FUZZ_CHECK(st == DR_OK); /* canonical paths are at most 32 bytes */
        FUZZ_CHECK(dr_path_parse(closest, &near) == DR_OK);
    }
    if (have && st != DR_EINVAL && csize >= 40) {
        /* A canonical name is its own closest match (distance 0). Aliases
         * ("dr2") and zero-padded indexes are spelled unlike the canonical
         * names, so they may land anywhere. */
        char canon[64];
        FUZZ_CHECK(dr_ref_path(ref, canon, sizeof canon) == DR_OK);
        if (strcmp(canon, text) == 0)
            FUZZ_CHECK(strcmp(closest, text) == 0);
    }

    if (!have) {
        FUZZ_CHECK(dr_leaf_at((uint16_t)(leaf % dr_leaf_count()), &ref) == DR_OK);
        if ((flags & 1u) && ref.field->kind == DR_KIND_BITS)
            ref.elem = -1;
        check_ref(ref);
    }
    unsigned set_flags = (flags & 2u) ? DR_SET_O2T_ONLY : 0u;
    unsigned text_flags = (flags & 4u) ? DR_TEXT_UNIT : 0u;

    /* The image: the rest of the input, repeated to the assembly's size. */
    size_t len = dr_asm_info((dr_asm_t)ref.field->assembly)->size;
    uint8_t image[DR_ASM_MAX_SIZE] = {0}, before[DR_ASM_MAX_SIZE];
    for (size_t i = 0; i < len; i++)
        image[i] = image_n ? image_src[i % image_n] : 0;
    memcpy(before, image, len);

    /* Reading any image works; writing back what was read changes
     * nothing (NaN payloads aside: a set may quiet them). */
    dr_value_t got;
    FUZZ_CHECK(dr_field_get(image, len, ref, &got) == DR_OK);
    FUZZ_CHECK(got.type == dr_ref_type(ref));
    FUZZ_CHECK(dr_field_get(image, len + 1, ref, &got) == DR_ELENGTH);
    FUZZ_CHECK(dr_field_get(image, len, ref, &got) == DR_OK);
    st = dr_field_set(image, len, ref, &got, 0);
    if (got.type == DR_VAL_REAL && isnan(got.f)) {
        FUZZ_CHECK(st == DR_OK || st == DR_ENONFINITE);
    } else if (got.type == DR_VAL_REAL && isinf(got.f)) {
        FUZZ_CHECK(st == DR_OK || st == DR_ENONFINITE);
        if (st == DR_OK)
            FUZZ_CHECK(memcmp(image, before, len) == 0);
    } else {
        FUZZ_CHECK(st == DR_OK);
        FUZZ_CHECK(memcmp(image, before, len) == 0);
    }
    memcpy(image, before, len);

    /* Text for the field: parse, set, get back; format, parse back. */
    char vtext[TEXT_MAX + 1];
    cstr(vtext, value, value_n);
    dr_value_t v;
    memset(&v, 0, sizeof v);
    st = dr_text_parse(ref, vtext, set_flags, &v);
    if (st != DR_OK) {
        FUZZ_CHECK(st == DR_ESYNTAX || st == DR_ERANGE ||
                   st == DR_ENONFINITE || st == DR_EREADONLY);
        /* dr_field_set agrees with dr_text_parse's verdict on a refusal of
         * the field itself. */
        if (st == DR_EREADONLY)
            FUZZ_CHECK(dr_field_set(image, len, ref, &got, set_flags) == DR_EREADONLY);
        FUZZ_CHECK(memcmp(image, before, len) == 0);
        return 0;
    }
    FUZZ_CHECK(v.type == dr_ref_type(ref));
    FUZZ_CHECK(dr_value_check(ref, &v, set_flags) == DR_OK);
    FUZZ_CHECK(dr_field_set(image, len, ref, &v, set_flags) == DR_OK);
    dr_value_t back;
    FUZZ_CHECK(dr_field_get(image, len, ref, &back) == DR_OK);
    FUZZ_CHECK(same_value(&v, &back));
    check_others(before, image, len, ref.field);

    char fmt[128];
    FUZZ_CHECK(dr_text_format(ref, &back, text_flags, fmt, sizeof fmt) == DR_OK);
    FUZZ_CHECK(strlen(fmt) < sizeof fmt);
    dr_kind_t kind = (dr_kind_t)ref.field->kind;
    int plain = kind == DR_KIND_BIT || kind == DR_KIND_USINT ||
                kind == DR_KIND_DINT || kind == DR_KIND_REAL ||
                (kind == DR_KIND_BITS && ref.elem >= 0);
    if (plain && !(text_flags && ref.field->unit[0] != '\0')) {
        /* Plain numbers read back to the stored value. */
        dr_value_t again;
        FUZZ_CHECK(dr_text_parse(ref, fmt, 0, &again) == DR_OK);
        FUZZ_CHECK(same_value(&back, &again));
    }
    return 0;
}
