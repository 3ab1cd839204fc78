/* SPDX-License-Identifier: MIT */
/*
 * The key tables of docs/configuration.md, printed from the sides' tables
 * (`drgatewayd --help-config SECTION`; mk/gen-config-doc.sh keeps the
 * document equal to them).
 */
#include <stdint.h>
#include <string.h>

#include "core/config_internal.h"

/* A cell's text: '|' would end the cell. */
static void cell(FILE *out, const char *text)
{
    fputs("| ", out);
    for (const char *p = text; *p; p++) {
        if (*p == '|')
            fputc('\\', out);
        fputc(*p, out);
    }
    fputc(' ', out);
}

/* "`a`, `b`, `c`" */
static void names_cell(FILE *out, const char *const *names)
{
    fputs("| ", out);
    for (size_t i = 0; names[i] != NULL; i++)
        fprintf(out, "%s`%s`", i ? ", " : "", names[i]);
    fputc(' ', out);
}

static void default_cell(FILE *out, const gw_cfg_key_t *k)
{
    char buf[96];
    const char *text = "(none)";
    if (k->doc_default != NULL)
        text = k->doc_default;
    else if (k->flags & GW_CFG_REQUIRED)
        text = "(required)";
    else if (k->type == GW_CFG_BOOL)
        text = k->def ? "`yes`" : "`no`";
    else if (k->type == GW_CFG_UINT)
        text = (snprintf(buf, sizeof buf, "`%lu`", k->def), buf);
    else if (k->type == GW_CFG_ENUM)
        text = (snprintf(buf, sizeof buf, "`%s`", k->names[k->def]), buf);
    else if (k->def_text != NULL)
        text = (snprintf(buf, sizeof buf, "`%s`", k->def_text), buf);
    cell(out, text);
}

static void allowed_cell(FILE *out, const gw_cfg_key_t *k)
{
    char buf[64];
    if (k->doc_allowed != NULL) {
        cell(out, k->doc_allowed);
    } else if (k->type == GW_CFG_BOOL) {
        cell(out, "`yes`, `no`");
    } else if (k->type == GW_CFG_ENUM || k->type == GW_CFG_WORD) {
        names_cell(out, k->names);
    } else if (k->allowed != NULL) {
        cell(out, k->allowed);
    } else {
        snprintf(buf, sizeof buf, "%lu..%lu", k->lo, k->hi);
        cell(out, buf);
    }
}

void gw_cfg_print_keys(FILE *out, const gw_cfg_side_t *s)
{
    fputs("| key | default | allowed | meaning |\n"
          "| --- | --- | --- | --- |\n",
          out);
    for (unsigned i = 0; i < s->nkeys; i++) {
        const gw_cfg_key_t *k = &s->keys[i];
        fprintf(out, "| `%s` ", k->name);
        default_cell(out, k);
        allowed_cell(out, k);
        cell(out, k->help != NULL ? k->help : "");
        fputs("|\n", out);
    }
}

/* ---- the configuration in effect (the console's /api/v1/config) ------------------- */

static bool secret_key(const char *name)
{
    static const char *const words[] = {"password", "secret", "token", "key", "auth"};
    for (size_t i = 0; i < GW_CFG_COUNT(words); i++)
        if (strstr(name, words[i]) != NULL)
            return true;
    return false;
}

/* An unsigned of 1, 2 or 4 bytes (the loader's sizes). */
static unsigned long value_at(const void *p, size_t size)
{
    if (size == 1) {
        uint8_t v;
        memcpy(&v, p, 1);
        return v;
    }
    if (size == 2) {
        uint16_t v;
        memcpy(&v, p, 2);
        return v;
    }
    uint32_t v = 0;
    memcpy(&v, p, size < 4 ? size : 4);
    return v;
}

static void key_line(FILE *out, const gw_cfg_key_t *k, const char *sec)
{
    const char *p = sec + k->off;
    if (k->type == GW_CFG_HOOK || k->type == GW_CFG_PREFIX || k->off == GW_CFG_NONE) {
        fprintf(out, "; %s: as in the file\n", k->name);
        return;
    }
    if (k->type == GW_CFG_BOOL || k->type == GW_CFG_UINT || k->type == GW_CFG_ENUM) {
        unsigned long v = value_at(p, k->size);
        if (k->type == GW_CFG_BOOL)
            fprintf(out, "%s = %s\n", k->name, v ? "yes" : "no");
        else if (k->type == GW_CFG_ENUM && k->names != NULL)
            fprintf(out, "%s = %s\n", k->name, k->names[v]);
        else
            fprintf(out, "%s = %lu\n", k->name, v);
        return;
    }
    size_t n = strnlen(p, k->size);
    if (secret_key(k->name))
        fprintf(out, "%s = %s\n", k->name, n > 0 ? "(set, hidden)" : "");
    else
        fprintf(out, "%s = %.*s\n", k->name, (int)n, p);
}

static void section_text(FILE *out, const gw_cfg_side_t *side, const char *sec, const char *name)
{
    unsigned line = 0;
    if (side->line_off != GW_CFG_NONE)
        memcpy(&line, sec + side->line_off, sizeof line);
    if (!side->named && side->begin != NULL && line == 0) {
        fprintf(out, "\n; [%s]: not in the file (off)\n", side->kw);
        return;
    }
    fprintf(out, "\n[%s%s%s]", side->kw, name != NULL ? " " : "", name != NULL ? name : "");
    if (line != 0)
        fprintf(out, " ; line %u", line);
    fputc('\n', out);
    for (unsigned i = 0; i < side->nkeys; i++)
        key_line(out, &side->keys[i], sec);
}

bool gw_config_effective(const gw_config_t *cfg, char *buf, size_t size)
{
    const gw_cfg_side_t *sides[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(sides);
    if (size < 2)
        return false;
    FILE *out = fmemopen(buf, size, "w");
    if (out == NULL)
        return false;
    fprintf(out, "; the configuration drgatewayd runs with: %s, every key with its value "
                 "(defaults included), secrets hidden\n", cfg->path);
    for (unsigned s = 0; s < n; s++) {
        const gw_cfg_side_t *side = sides[s];
        const char *base = (const char *)cfg + side->base;
        unsigned count = 1;
        if (side->named)
            memcpy(&count, (const char *)cfg + side->count_off, sizeof count);
        for (unsigned i = 0; i < count; i++) {
            const char *sec = base + (size_t)i * side->stride;
            section_text(out, side, sec, side->named && side->name_off != GW_CFG_NONE
                                             ? sec + side->name_off : NULL);
        }
    }
    long len = ftell(out);
    bool ok = !ferror(out) && len >= 0 && (size_t)len < size - 1;
    (void)fclose(out);
    if (!ok)
        buf[0] = '\0';
    return ok;
}
