/* SPDX-License-Identifier: MIT */
/*
 * drcli list: every leaf field of the assemblies, from the codec's field
 * table, as an aligned table, a Markdown table (docs/assemblies.md is made
 * of it) or JSON.
 */
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "error.h"
#include "opt.h"
#include "util.h"

static const char list_help[] =
    "usage: drcli list [--markdown | --json] [ASSEMBLY...]\n"
    "\n"
    "Lists every field of the given assemblies (all ten by default): its\n"
    "canonical path, direction, byte offset, bit, type, unit and meaning.\n"
    "ASSEMBLY is a name (io_state) or an alias (dr1).\n"
    "\n"
    "Offsets of bits are those of their 32-bit row: bit n of the row at byte B\n"
    "is bit n%8 of byte B + n/8.\n"
    "\n"
    "options:\n"
    "  --markdown  one Markdown table per assembly, one row per field with its\n"
    "              index range (position[1..6]), as in docs/assemblies.md\n"
    "  --json      {\"assemblies\": [...], \"fields\": [...]}, one field per leaf\n"
    "  -h, --help  this text\n";

/* ---- one leaf --------------------------------------------------------- */

typedef struct {
    char path[64];
    char offset[12];
    char bit[12];
    const char *asm_name, *dir, *type, *unit, *help;
    unsigned offset_n;
    int bit_n; /* -1 if not a bit */
} leaf_row_t;

static void fill_row(dr_ref_t leaf, leaf_row_t *r)
{
    const dr_field_t *f = leaf.field;
    const dr_asm_info_t *info = dr_asm_info((dr_asm_t)f->assembly);
    unsigned e = leaf.elem < 0 ? 0u : (unsigned)leaf.elem;

    dr_ref_path(leaf, r->path, sizeof r->path);
    r->asm_name = info->name;
    r->dir = cli_dir_name(info->dir);
    r->type = dr_kind_name((dr_kind_t)f->kind);
    r->unit = f->unit;
    r->help = f->help;
    if (f->kind == DR_KIND_BIT || f->kind == DR_KIND_BITS) {
        r->offset_n = f->offset;
        r->bit_n = (int)(f->bit + (f->kind == DR_KIND_BITS ? e : 0u));
    } else {
        r->offset_n = f->offset + dr_kind_wire_size((dr_kind_t)f->kind) * e;
        r->bit_n = -1;
    }
    snprintf(r->offset, sizeof r->offset, "%u", r->offset_n);
    if (r->bit_n >= 0)
        snprintf(r->bit, sizeof r->bit, "%d", r->bit_n);
    else
        snprintf(r->bit, sizeof r->bit, "-");
}

/* Leaves of the selected assemblies, in table order; at most `max`. */
static size_t collect(const bool *selected, leaf_row_t *rows, size_t max)
{
    size_t n = 0;
    for (uint16_t i = 0; i < dr_leaf_count() && n < max; i++) {
        dr_ref_t leaf;
        if (dr_leaf_at(i, &leaf) != DR_OK)
            break;
        if (selected[leaf.field->assembly])
            fill_row(leaf, &rows[n++]);
    }
    return n;
}

/* ---- aligned text ------------------------------------------------------- */

enum { NCOLS = 8 };

static const char *cell(const leaf_row_t *r, int c)
{
    switch (c) {
    case 0: return r->asm_name;
    case 1: return r->path;
    case 2: return r->dir;
    case 3: return r->offset;
    case 4: return r->bit;
    case 5: return r->type;
    case 6: return r->unit[0] != '\0' ? r->unit : "-";
    default: return r->help;
    }
}

static void print_line(const char *const *cells, const int *width)
{
    for (int c = 0; c < NCOLS; c++) {
        if (c == NCOLS - 1)
            printf("%s\n", cells[c]); /* last column: no trailing spaces */
        else if (c == 3 || c == 4)
            printf("%*s  ", width[c], cells[c]); /* numbers: right-aligned */
        else
            printf("%-*s  ", width[c], cells[c]);
    }
}

static void print_text(const leaf_row_t *rows, size_t n)
{
    static const char *const head[NCOLS] = {
        "ASSEMBLY", "FIELD", "DIR", "OFFSET", "BIT", "TYPE", "UNIT", "DESCRIPTION"};
    int width[NCOLS];
    for (int c = 0; c < NCOLS; c++)
        width[c] = (int)strlen(head[c]);
    for (size_t i = 0; i < n; i++)
        for (int c = 0; c < NCOLS; c++) {
            int w = (int)strlen(cell(&rows[i], c));
            if (w > width[c])
                width[c] = w;
        }
    print_line(head, width);
    for (size_t i = 0; i < n; i++) {
        const char *cells[NCOLS];
        for (int c = 0; c < NCOLS; c++)
            cells[c] = cell(&rows[i], c);
        print_line(cells, width);
    }
}

/* ---- Markdown ------------------------------------------------------------- */

/* "cb_do[1..16]", "position[1..6]", "bit_out[0..63]", "version.major" */
static void md_name(const dr_field_t *f, char *out, size_t size)
{
    const char *name = f->name[0] != '\0'
                           ? f->name
                           : dr_asm_info((dr_asm_t)f->assembly)->name;
    if (f->indexed)
        snprintf(out, size, "%s[%u..%u]", name, (unsigned)f->first_index,
                 (unsigned)f->first_index + f->count - 1u);
    else
        snprintf(out, size, "%s", name);
}

/* "bits 16-31", "bit 3", "REAL[6]", "USINT" */
static void md_type(const dr_field_t *f, char *out, size_t size)
{
    if (f->kind == DR_KIND_BIT)
        snprintf(out, size, "bit %u", (unsigned)f->bit);
    else if (f->kind == DR_KIND_BITS)
        snprintf(out, size, "bits %u-%u", (unsigned)f->bit,
                 (unsigned)f->bit + f->count - 1u);
    else if (f->indexed)
        snprintf(out, size, "%s[%u]", dr_kind_name((dr_kind_t)f->kind),
                 (unsigned)f->count);
    else
        snprintf(out, size, "%s", dr_kind_name((dr_kind_t)f->kind));
}

static void print_markdown_asm(dr_asm_t a)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    printf("### %s (%s): %s\n\n", info->name, info->alias, info->title);
    printf("%s, %u bytes, default instance %u.\n\n", cli_dir_name(info->dir),
           (unsigned)info->size, (unsigned)DR_ASM_DEFAULT_INSTANCE(a));
    printf("| field | offset | bits / type | unit | meaning |\n");
    printf("|---|---:|---|---|---|\n");
    uint16_t count;
    const dr_field_t *f = dr_asm_fields(a, &count);
    for (uint16_t i = 0; i < count; i++) {
        char name[48], type[24];
        md_name(&f[i], name, sizeof name);
        md_type(&f[i], type, sizeof type);
        printf("| `%s` | %u | %s | %s | %s |\n", name, (unsigned)f[i].offset,
               type, f[i].unit, f[i].help);
    }
}

static void print_markdown(const bool *selected)
{
    bool first = true;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (!selected[a])
            continue;
        if (!first)
            printf("\n");
        first = false;
        print_markdown_asm((dr_asm_t)a);
    }
}

/* ---- JSON --------------------------------------------------------------- */

static json_t *json_assembly(dr_asm_t a)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    return json_pack("{s:s, s:s, s:s, s:s, s:i, s:i}",
                     "name", info->name, "alias", info->alias,
                     "title", info->title, "direction", cli_dir_name(info->dir),
                     "size", (int)info->size,
                     "instance", (int)DR_ASM_DEFAULT_INSTANCE(a));
}

static json_t *json_leaf(const leaf_row_t *r)
{
    json_t *o = json_pack("{s:s, s:s, s:s, s:i, s:o, s:s, s:s, s:s}",
                          "path", r->path, "assembly", r->asm_name,
                          "direction", r->dir, "offset", (int)r->offset_n,
                          "bit", r->bit_n >= 0 ? json_integer(r->bit_n) : json_null(),
                          "type", r->type, "unit", r->unit, "description", r->help);
    /* An enum's names by value ("enum": {"0": "INITIALIZING", ...}), for
     * tools such as the Wireshark dissector (mk/gen-dissector.py). The
     * robot state is the codec's one enum. */
    if (o != NULL && strcmp(r->type, "USINT enum") == 0) {
        json_t *names = json_object();
        char key[8];
        for (unsigned v = 0; names != NULL && dr_robot_state_name(v) != NULL; v++) {
            snprintf(key, sizeof key, "%u", v);
            (void)json_object_set_new(names, key, json_string(dr_robot_state_name(v)));
        }
        if (names == NULL || json_object_set_new(o, "enum", names) != 0) {
            json_decref(o);
            return NULL;
        }
    }
    return o;
}

static int print_json(const char *cmd, const bool *selected,
                      const leaf_row_t *rows, size_t n)
{
    json_t *assemblies = json_array(), *fields = json_array();
    bool ok = assemblies != NULL && fields != NULL;
    for (unsigned a = 0; ok && a < DR_ASM_COUNT; a++)
        if (selected[a])
            ok = json_array_append_new(assemblies, json_assembly((dr_asm_t)a)) == 0;
    for (size_t i = 0; ok && i < n; i++)
        ok = json_array_append_new(fields, json_leaf(&rows[i])) == 0;
    if (!ok) {
        json_decref(assemblies);
        json_decref(fields);
        return cli_json_print(cmd, NULL);
    }
    return cli_json_print(cmd, json_pack("{s:o, s:o}", "assemblies", assemblies,
                                         "fields", fields));
}

/* ---- command ---------------------------------------------------------- */

static int run_list(const char *cmd, int argc, char **argv,
                    const cli_net_opts_t *lead)
{
    (void)lead; /* offline: main refuses network options */
    bool help = false, markdown = false, json = false;
    const cli_opt_t opts[] = {
        {"markdown", 0, &markdown, NULL, NULL},
        {"json", 0, &json, NULL, NULL},
    };
    int npos = cli_parse_opts(cli_cmd_list.name, argc, argv, opts,
                              sizeof opts / sizeof opts[0], &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(&cli_cmd_list);
        return CLI_EXIT_OK;
    }
    if (markdown && json)
        return cli_error(CLI_EXIT_USAGE, cmd, "--markdown and --json exclude each other");

    bool selected[DR_ASM_COUNT];
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        selected[a] = npos == 0;
    for (int i = 0; i < npos; i++) {
        dr_asm_t a;
        if (!cli_lookup_asm(cmd, argv[i], &a))
            return CLI_EXIT_USAGE;
        selected[a] = true;
    }

    if (markdown) {
        print_markdown(selected);
        return CLI_EXIT_OK;
    }
    static leaf_row_t rows[512]; /* 371 leaves in all */
    size_t n = collect(selected, rows, sizeof rows / sizeof rows[0]);
    if (json)
        return print_json(cmd, selected, rows, n);
    print_text(rows, n);
    return CLI_EXIT_OK;
}

const cli_cmd_t cli_cmd_list = {
    "list", "list the fields of the assemblies (offsets, types, units)",
    list_help, run_list, false,
};
