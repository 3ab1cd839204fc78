/* SPDX-License-Identifier: MIT */
/*
 * The key tables of docs/configuration.md, printed from the sides' tables
 * (`drgatewayd --help-config SECTION`; mk/gen-config-doc.sh keeps the
 * document equal to them).
 */
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
