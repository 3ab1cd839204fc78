/* SPDX-License-Identifier: MIT */
/*
 * Field paths: "assembly.field[index]" parsing, canonical names, listing of
 * leaves and the closest known name for a typo. No stdio, no malloc.
 */
#include <string.h>

#include "drgate/codec.h"
#include "fields_internal.h"

#define PATH_MAX_LEN 64u

static bool span_eq(const char *s, size_t n, const char *lit)
{
    return strlen(lit) == n && memcmp(s, lit, n) == 0;
}

static dr_status_t asm_lookup_n(const char *name, size_t n, dr_asm_t *out)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        if (span_eq(name, n, info->name) || span_eq(name, n, info->alias)) {
            *out = (dr_asm_t)a;
            return DR_OK;
        }
    }
    return DR_ENOENT;
}

dr_status_t dr_asm_lookup(const char *name, dr_asm_t *out)
{
    if (name == NULL || out == NULL)
        return DR_EINVAL;
    return asm_lookup_n(name, strlen(name), out);
}

const dr_field_t *dr_asm_fields(dr_asm_t a, uint16_t *count)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    if (info == NULL)
        return NULL;
    if (count != NULL)
        *count = info->field_count;
    return &dr_field_tab[info->first_field];
}

/* "[digits]" at the very end of s[0..n); at most 3 digits. */
static dr_status_t parse_index(const char *s, size_t n, unsigned *out)
{
    if (n < 3 || s[0] != '[' || s[n - 1] != ']' || n - 2 > 3)
        return DR_ESYNTAX;
    unsigned v = 0;
    for (size_t i = 1; i + 1 < n; i++) {
        if (s[i] < '0' || s[i] > '9')
            return DR_ESYNTAX;
        v = v * 10u + (unsigned)(s[i] - '0');
    }
    *out = v;
    return DR_OK;
}

dr_status_t dr_path_parse_n(const char *path, size_t n, dr_ref_t *out)
{
    if (path == NULL || out == NULL)
        return DR_EINVAL;

    /* assembly part: up to the first '.' or '[' */
    size_t a_end = 0;
    while (a_end < n && path[a_end] != '.' && path[a_end] != '[')
        a_end++;
    dr_asm_t a;
    if (asm_lookup_n(path, a_end, &a) != DR_OK)
        return DR_ENOENT;

    /* field part: after the '.', up to '[' */
    size_t f_start = a_end, f_end = a_end;
    if (f_start < n && path[f_start] == '.') {
        f_start++;
        f_end = f_start;
        while (f_end < n && path[f_end] != '[')
            f_end++;
        if (f_end == f_start)
            return DR_ENOENT;
    }

    uint16_t count = 0;
    const dr_field_t *fields = dr_asm_fields(a, &count);
    const dr_field_t *f = NULL;
    for (unsigned i = 0; i < count && f == NULL; i++)
        if (span_eq(path + f_start, f_end - f_start, fields[i].name))
            f = &fields[i];
    if (f == NULL)
        return DR_ENOENT;

    dr_ref_t ref = {f, -1};
    if (f_end < n) {
        unsigned idx;
        dr_status_t st = parse_index(path + f_end, n - f_end, &idx);
        if (st != DR_OK)
            return st;
        if (!f->indexed || idx < f->first_index ||
            idx >= (unsigned)f->first_index + f->count)
            return DR_EINDEX;
        ref.elem = (int16_t)(idx - f->first_index);
    } else if (!f->indexed) {
        ref.elem = 0;
    } else if (f->kind != DR_KIND_BITS) {
        return DR_EINDEX; /* an array of values needs an index */
    }
    *out = ref;
    return DR_OK;
}

dr_status_t dr_path_parse(const char *path, dr_ref_t *out)
{
    if (path == NULL)
        return DR_EINVAL;
    return dr_path_parse_n(path, strlen(path), out);
}

/* Appends to a bounded buffer; remembers overflow. */
typedef struct {
    char *p;
    size_t size, len;
    bool overflow;
} sbuf_t;

static void sb_puts(sbuf_t *sb, const char *s)
{
    for (; *s; s++) {
        if (sb->len + 1 < sb->size)
            sb->p[sb->len++] = *s;
        else
            sb->overflow = true;
    }
    if (sb->size > 0)
        sb->p[sb->len < sb->size ? sb->len : sb->size - 1] = '\0';
}

static void sb_putu(sbuf_t *sb, unsigned v)
{
    char tmp[12];
    size_t i = sizeof tmp;
    tmp[--i] = '\0';
    do {
        tmp[--i] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0);
    sb_puts(sb, &tmp[i]);
}

dr_status_t dr_ref_path(dr_ref_t ref, char *out, size_t size)
{
    if (ref.field == NULL || out == NULL || size == 0)
        return DR_EINVAL;
    const dr_field_t *f = ref.field;
    sbuf_t sb = {out, size, 0, false};
    sb_puts(&sb, dr_asm_info((dr_asm_t)f->assembly)->name);
    if (f->name[0] != '\0') {
        sb_puts(&sb, ".");
        sb_puts(&sb, f->name);
    }
    if (f->indexed && ref.elem >= 0) {
        sb_puts(&sb, "[");
        sb_putu(&sb, (unsigned)ref.elem + f->first_index);
        sb_puts(&sb, "]");
    }
    return sb.overflow ? DR_ENOSPACE : DR_OK;
}

static uint16_t leaves_of(const dr_field_t *f)
{
    return f->indexed ? f->count : 1u;
}

uint16_t dr_leaf_count(void)
{
    uint16_t n = 0;
    for (unsigned i = 0; i < DR_FF_END; i++)
        n = (uint16_t)(n + leaves_of(&dr_field_tab[i]));
    return n;
}

dr_status_t dr_leaf_at(uint16_t i, dr_ref_t *out)
{
    for (unsigned k = 0; k < DR_FF_END; k++) {
        const dr_field_t *f = &dr_field_tab[k];
        if (i < leaves_of(f)) {
            out->field = f;
            out->elem = (int16_t)i;
            return DR_OK;
        }
        i = (uint16_t)(i - leaves_of(f));
    }
    return DR_EINDEX;
}

/* Levenshtein distance, strings cut at PATH_MAX_LEN. */
unsigned dr_edit_distance(const char *a, const char *b)
{
    unsigned row[PATH_MAX_LEN + 1];
    size_t la = strlen(a), lb = strlen(b);
    if (la > PATH_MAX_LEN)
        la = PATH_MAX_LEN;
    if (lb > PATH_MAX_LEN)
        lb = PATH_MAX_LEN;
    for (size_t j = 0; j <= lb; j++)
        row[j] = (unsigned)j;
    for (size_t i = 1; i <= la; i++) {
        unsigned diag = row[0];
        row[0] = (unsigned)i;
        for (size_t j = 1; j <= lb; j++) {
            unsigned up = row[j];
            unsigned best = diag + (a[i - 1] != b[j - 1]);
            if (up + 1 < best)
                best = up + 1;
            if (row[j - 1] + 1 < best)
                best = row[j - 1] + 1;
            diag = up;
            row[j] = best;
        }
    }
    return row[lb];
}

/* Keep cand in best[] if it is closer to path than what is there. */
static void consider(const char *path, dr_ref_t ref, unsigned *best_d,
                     char best[PATH_MAX_LEN])
{
    char cand[PATH_MAX_LEN] = "";
    if (dr_ref_path(ref, cand, sizeof cand) != DR_OK)
        return;
    unsigned d = dr_edit_distance(path, cand);
    if (d < *best_d) {
        *best_d = d;
        memcpy(best, cand, sizeof cand);
    }
}

dr_status_t dr_path_closest(const char *path, char *out, size_t size)
{
    if (path == NULL || out == NULL || size == 0)
        return DR_EINVAL;
    unsigned best_d = ~0u;
    char best[PATH_MAX_LEN] = "";
    for (unsigned k = 0; k < DR_FF_END; k++) {
        const dr_field_t *f = &dr_field_tab[k];
        if (f->kind == DR_KIND_BITS) {
            dr_ref_t mask = {f, -1};
            consider(path, mask, &best_d, best);
        }
        for (unsigned e = 0; e < leaves_of(f); e++) {
            dr_ref_t ref = {f, (int16_t)e};
            consider(path, ref, &best_d, best);
        }
    }
    sbuf_t sb = {out, size, 0, false};
    out[0] = '\0';
    sb_puts(&sb, best);
    return sb.overflow ? DR_ENOSPACE : DR_OK;
}
