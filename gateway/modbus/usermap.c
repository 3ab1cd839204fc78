/* SPDX-License-Identifier: MIT */
/*
 * Parsing and checking the user's register map (usermap.h). Everything a
 * block can get wrong is refused here, at load time, so that serving it
 * (regmap.c) never meets an entry it cannot read or write.
 */
#include "modbus/usermap.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "modbus/regmap.h"

static const char *const table_names[GW_UMAP_TABLES] = {"co", "di", "hr", "ir"};
static const char *const view_names[] = {"bit", "real", "dint", "int16", "uint16", "bits"};
#define VIEW_COUNT (sizeof view_names / sizeof view_names[0])
#define MAX_TOKENS 10

const char *gw_umap_table_name(unsigned table)
{
    return table < GW_UMAP_TABLES ? table_names[table] : "?";
}

const char *gw_umap_view_name(unsigned view)
{
    return view < VIEW_COUNT ? view_names[view] : "?";
}

/* Split s (modified) at blanks into at most max tokens. */
static unsigned split(char *s, char **tok, unsigned max, bool *too_many)
{
    unsigned n = 0;
    *too_many = false;
    char *p = s;
    for (;;) {
        while (*p == ' ' || *p == '\t')
            *p++ = '\0';
        if (*p == '\0')
            return n;
        if (n == max) {
            *too_many = true;
            return n;
        }
        tok[n++] = p;
        while (*p != '\0' && *p != ' ' && *p != '\t')
            p++;
    }
}

static bool parse_u(const char *s, unsigned long lo, unsigned long hi, unsigned long *out)
{
    if (s[0] < '0' || s[0] > '9' || strlen(s) > 6)
        return false;
    for (const char *p = s; *p != '\0'; p++)
        if (*p < '0' || *p > '9')
            return false;
    *out = strtoul(s, NULL, 10);
    return *out >= lo && *out <= hi;
}

/* The indexed field whose paths are stem[i], or NULL. */
static const dr_field_t *field_named(const char *stem)
{
    size_t n = strlen(stem);
    for (uint16_t i = 0; i < dr_field_count(); i++) {
        const dr_field_t *f = dr_field_at(i);
        dr_ref_t ref = {f, 0};
        char name[128];
        if (f->indexed && dr_ref_path(ref, name, sizeof name) == DR_OK &&
            strncmp(name, stem, n) == 0 && name[n] == '[')
            return f;
    }
    return NULL;
}

/* PATH or PATH[a..b]: the field and its elements. */
static bool parse_path(const char *path, gw_umap_entry_t *e, char *err, size_t errlen)
{
    char one[128];
    const char *dots = strstr(path, "..");
    dr_ref_t first, last;
    if (strlen(path) >= sizeof one - 8) {
        snprintf(err, errlen, "field path too long");
        return false;
    }
    if (dots == NULL) {
        dr_status_t st = dr_path_parse(path, &first);
        if (st != DR_OK) {
            char best[96] = "";
            if (st == DR_ENOENT && dr_path_closest(path, best, sizeof best) == DR_OK)
                snprintf(err, errlen, "unknown field '%s' (did you mean '%s'? "
                         "drgatewayd --print-map lists every field)", path, best);
            else
                snprintf(err, errlen, "field '%s' invalid: %s", path, dr_strerror(st));
            return false;
        }
        last = first;
    } else {
        const char *open = strrchr(path, '[');
        if (open == NULL || open > dots || path[strlen(path) - 1] != ']') {
            snprintf(err, errlen, "range in '%s' invalid (allowed: path[a..b])", path);
            return false;
        }
        /* path[a] and path[b], each through the library's own parser */
        size_t base = (size_t)(open - path);
        snprintf(one, sizeof one, "%.*s]", (int)(dots - path), path);
        dr_status_t st = dr_path_parse(one, &first);
        if (st == DR_OK) {
            snprintf(one, sizeof one, "%.*s[%s", (int)base, path, dots + 2);
            st = dr_path_parse(one, &last);
        }
        if (st != DR_OK) {
            char best[96] = "", stem[128];
            snprintf(stem, sizeof stem, "%.*s", (int)base, path);
            const dr_field_t *f = field_named(stem);
            if (f != NULL)
                snprintf(err, errlen, "range '%s' invalid: %s (allowed: %s[%u..%u])", path,
                         dr_strerror(st), stem, (unsigned)f->first_index,
                         (unsigned)(f->first_index + f->count - 1u));
            else if (dr_path_closest(stem, best, sizeof best) == DR_OK)
                snprintf(err, errlen, "unknown field '%s' (did you mean '%s'?)", stem, best);
            else
                snprintf(err, errlen, "range '%s' invalid: %s", path, dr_strerror(st));
            return false;
        }
        if (first.field != last.field || last.elem < first.elem) {
            snprintf(err, errlen, "range '%s' invalid: the first index must not be above the "
                     "last", path);
            return false;
        }
    }
    const dr_field_t *f = first.field;
    e->field = dr_field_index(f);
    if (first.elem < 0) { /* a whole BITS mask */
        e->elem = 0;
        e->count = f->count;
    } else {
        e->elem = (uint16_t)first.elem;
        e->count = (uint16_t)(last.elem - first.elem + 1);
    }
    return true;
}

/* The largest |value| a field can hold, for INT16's range check (0: no
 * bound, a DINT or a REAL). */
static double field_max(const dr_field_t *f)
{
    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT: case DR_KIND_BITS: return 1;
    case DR_KIND_USINT: case DR_KIND_ENUM: return 255;
    default: return 0;
    }
}

/* The view and the field fit; the addresses the block takes. */
static bool check_view(gw_umap_entry_t *e, bool half_given, bool scale_given, char *err,
                       size_t errlen)
{
    const dr_field_t *f = dr_field_at(e->field);
    dr_kind_t k = (dr_kind_t)f->kind;
    bool bits_table = e->table == GW_UMAP_CO || e->table == GW_UMAP_DI;
    const char *vn = view_names[e->view];
    if (bits_table != (e->view == GW_VIEW_BIT)) {
        snprintf(err, errlen, "view %s in table %s (allowed: bit in co and di; real, dint, "
                 "int16, uint16, bits in hr and ir)", vn, table_names[e->table]);
        return false;
    }
    bool ok = false;
    switch ((gw_view_t)e->view) {
    case GW_VIEW_BIT: case GW_VIEW_BITS: ok = k == DR_KIND_BIT || k == DR_KIND_BITS; break;
    case GW_VIEW_REAL: ok = k == DR_KIND_REAL; break;
    case GW_VIEW_DINT: ok = k == DR_KIND_DINT; break;
    case GW_VIEW_INT16: ok = k != DR_KIND_BITS; break;
    case GW_VIEW_UINT16: ok = k == DR_KIND_BIT || k == DR_KIND_USINT || k == DR_KIND_ENUM ||
                               (k == DR_KIND_DINT && half_given); break;
    }
    if (!ok) {
        snprintf(err, errlen, "view %s does not fit a %s field (allowed: %s)", vn,
                 dr_kind_name(k),
                 k == DR_KIND_REAL ? "real, int16 scale=N saturate" :
                 k == DR_KIND_DINT ? "dint, int16 saturate, uint16 lo, uint16 hi" :
                 k == DR_KIND_BITS || k == DR_KIND_BIT ? "bits, or bit in co/di; BIT also int16, uint16" :
                 "int16, uint16");
        return false;
    }
    if (half_given && !(e->view == GW_VIEW_UINT16 && k == DR_KIND_DINT)) {
        snprintf(err, errlen, "lo/hi is for uint16 of a DINT field");
        return false;
    }
    if (scale_given && e->view != GW_VIEW_INT16) {
        snprintf(err, errlen, "scale= is for the int16 view");
        return false;
    }
    if (e->view == GW_VIEW_INT16 && !e->saturate) {
        double max = field_max(f);
        if (max == 0 || max * e->scale > 32767.0) {
            snprintf(err, errlen, "int16 x %u cannot hold every value of a %s field (add "
                     "'saturate' to clamp to -32768..32767, or a smaller scale)",
                     (unsigned)e->scale, dr_kind_name(k));
            return false;
        }
    }
    switch ((gw_view_t)e->view) {
    case GW_VIEW_REAL: case GW_VIEW_DINT: e->size = 2u * e->count; break;
    case GW_VIEW_BITS: e->size = (e->count + 15u) / 16u; break;
    default: e->size = e->count; break;
    }
    return true;
}

static bool parse_option(const char *t, gw_umap_entry_t *e, bool *half, bool *scale,
                         bool *view_given, char *err, size_t errlen)
{
    for (unsigned v = 0; v < VIEW_COUNT; v++)
        if (strcmp(t, view_names[v]) == 0) {
            if (*view_given) {
                snprintf(err, errlen, "two views ('%s' after '%s')", t, view_names[e->view]);
                return false;
            }
            e->view = (uint8_t)v;
            *view_given = true;
            return true;
        }
    unsigned long n;
    if (strcmp(t, "writable") == 0)
        e->writable = true;
    else if (strcmp(t, "saturate") == 0)
        e->saturate = true;
    else if (strcmp(t, "lo") == 0 || strcmp(t, "hi") == 0) {
        e->half = t[0] == 'h';
        *half = true;
    } else if (strncmp(t, "scale=", 6) == 0 && parse_u(t + 6, 1, 10000, &n)) {
        e->scale = (uint16_t)n;
        *scale = true;
    } else {
        snprintf(err, errlen, "'%s' invalid (allowed: a view bit, real, dint, int16, uint16, "
                 "bits; writable, saturate, scale=1..10000, lo, hi)", t);
        return false;
    }
    return true;
}

bool gw_umap_parse(const char *value, unsigned line, gw_umap_entry_t *e, char *err,
                   size_t errlen)
{
    char buf[256], *tok[MAX_TOKENS];
    bool too_many;
    memset(e, 0, sizeof *e);
    e->line = line;
    e->scale = 1;
    if (strlen(value) >= sizeof buf) {
        snprintf(err, errlen, "map line too long");
        return false;
    }
    snprintf(buf, sizeof buf, "%s", value);
    unsigned n = split(buf, tok, MAX_TOKENS, &too_many);
    if (n < 3 || too_many) {
        snprintf(err, errlen, "map '%s' invalid (allowed: TABLE ADDRESS PATH[a..b] VIEW "
                 "[writable] [saturate] [scale=N] [lo|hi], e.g. hr 2000 "
                 "joint_state.position[1..6] real)", value);
        return false;
    }
    bool found = false;
    for (unsigned t = 0; t < GW_UMAP_TABLES; t++)
        if (strcmp(tok[0], table_names[t]) == 0) {
            e->table = (uint8_t)t;
            found = true;
        }
    if (!found) {
        snprintf(err, errlen, "table '%s' invalid (allowed: hr, ir, co, di)", tok[0]);
        return false;
    }
    unsigned long addr;
    if (!parse_u(tok[1], 0, 65535, &addr)) {
        snprintf(err, errlen, "address '%s' invalid (allowed: 0..65535, 0-based)", tok[1]);
        return false;
    }
    e->addr = (uint16_t)addr;
    if (!parse_path(tok[2], e, err, errlen))
        return false;
    bool half = false, scale = false, view_given = false;
    e->view = GW_VIEW_BIT;
    for (unsigned i = 3; i < n; i++)
        if (!parse_option(tok[i], e, &half, &scale, &view_given, err, errlen))
            return false;
    if (!view_given && e->table != GW_UMAP_CO && e->table != GW_UMAP_DI) {
        snprintf(err, errlen, "map '%s' has no view (allowed: real, dint, int16, uint16, bits)",
                 value);
        return false;
    }
    if (!check_view(e, half, scale, err, errlen))
        return false;
    const dr_field_t *f = dr_field_at(e->field);
    if (e->writable && dr_asm_info((dr_asm_t)f->assembly)->dir != DR_DIR_O2T) {
        snprintf(err, errlen, "'%s' is written by the robot (T->O %s): it cannot be "
                 "writable (only O->T fields: io_control, bit_in, int_in, float_in)", tok[2],
                 dr_asm_info((dr_asm_t)f->assembly)->name);
        return false;
    }
    if (e->writable && (e->table == GW_UMAP_IR || e->table == GW_UMAP_DI)) {
        snprintf(err, errlen, "writable in table %s, which Modbus cannot write (allowed: hr, co)",
                 table_names[e->table]);
        return false;
    }
    if ((uint32_t)e->addr + e->size > 65536u) {
        snprintf(err, errlen, "block %s %u takes %lu addresses: past the table's last, 65535",
                 table_names[e->table], (unsigned)e->addr, (unsigned long)e->size);
        return false;
    }
    return true;
}

bool gw_umap_add(gw_umap_t *m, const gw_umap_entry_t *e, char *err, size_t errlen)
{
    uint32_t end = (uint32_t)e->addr + e->size;
    if (m->count >= GW_MAX_MAP) {
        snprintf(err, errlen, "too many map lines (at most %u per robot)", GW_MAX_MAP);
        return false;
    }
    uint16_t at;
    if (gw_regmap_default_used((gw_area_t)e->table, e->addr, e->size, &at)) {
        char name[96];
        gw_regmap_slot_name((gw_area_t)e->table, at, name, sizeof name);
        snprintf(err, errlen, "%s %u is %s in the default map (place the block where "
                 "drgatewayd --print-map shows nothing, e.g. %s 2048 and up)",
                 table_names[e->table], (unsigned)at, name, table_names[e->table]);
        return false;
    }
    unsigned pos = m->count;
    for (unsigned i = 0; i < m->count; i++) {
        const gw_umap_entry_t *o = &m->entry[i];
        uint32_t oend = (uint32_t)o->addr + o->size;
        if (o->table == e->table && e->addr < oend && o->addr < end) {
            snprintf(err, errlen, "%s %u-%lu overlaps the block at %s %u-%lu (line %u)",
                     table_names[e->table], (unsigned)e->addr, (unsigned long)end - 1,
                     table_names[o->table], (unsigned)o->addr, (unsigned long)oend - 1,
                     o->line);
            return false;
        }
        if (pos == m->count &&
            (o->table > e->table || (o->table == e->table && o->addr > e->addr)))
            pos = i;
    }
    memmove(&m->entry[pos + 1], &m->entry[pos], (m->count - pos) * sizeof m->entry[0]);
    m->entry[pos] = *e;
    m->count++;
    return true;
}
