/* SPDX-License-Identifier: MIT */
/*
 * drcli: fields named on the command line of the network commands (full
 * paths such as io_state.robot_state, or whole assemblies), and their
 * values in the images read from the robot, as text or JSON.
 */
#include <stdio.h>
#include <string.h>

#include "error.h"
#include "fields.h"
#include "util.h"
#include "drgate/text.h"

static void add(cli_items_t *it, dr_ref_t ref)
{
    if (it->n < CLI_ITEMS_MAX) /* callers check the room first */
        it->ref[it->n++] = ref;
}

/* Refs cli_items_add_asm appends for `a`. */
static size_t asm_items(dr_asm_t a)
{
    uint16_t count;
    size_t n = 0;
    const dr_field_t *f = dr_asm_fields(a, &count);
    for (uint16_t i = 0; i < count; i++)
        n += (f[i].kind == DR_KIND_BITS) + (f[i].indexed ? f[i].count : 1u);
    return n;
}

bool cli_items_add_asm(cli_items_t *it, dr_asm_t a)
{
    if (asm_items(a) > CLI_ITEMS_MAX - it->n)
        return false;
    uint16_t count;
    const dr_field_t *f = dr_asm_fields(a, &count);
    for (uint16_t i = 0; i < count; i++) {
        if (f[i].kind == DR_KIND_BITS) {
            dr_ref_t mask = {&f[i], -1};
            add(it, mask);
        }
        unsigned leaves = f[i].indexed ? f[i].count : 1u;
        for (unsigned e = 0; e < leaves; e++) {
            dr_ref_t leaf = {&f[i], (int16_t)e};
            add(it, leaf);
        }
    }
    return true;
}

/* " (indexes 1..16)" when `path` names an indexed field; "" otherwise. */
static void index_hint(const char *path, char *out, size_t size)
{
    char stem[128];
    size_t n = strcspn(path, "[");
    dr_ref_t ref;
    out[0] = '\0';
    if (n >= sizeof stem)
        return;
    /* "io_control.cb_do" parses as the whole mask; other indexed fields
     * answer DR_EINDEX without an index, so try element numbers too. */
    memcpy(stem, path, n);
    stem[n] = '\0';
    if (dr_path_parse(stem, &ref) != DR_OK) {
        snprintf(stem + n, sizeof stem - n, "[0]");
        if (dr_path_parse(stem, &ref) != DR_OK) {
            snprintf(stem + n, sizeof stem - n, "[1]");
            if (dr_path_parse(stem, &ref) != DR_OK)
                return;
        }
    }
    if (ref.field->indexed)
        snprintf(out, size, " (indexes %u..%u)", (unsigned)ref.field->first_index,
                 (unsigned)ref.field->first_index + ref.field->count - 1u);
}

bool cli_resolve_path(const char *cmd, int argno, const char *arg,
                      const char *path, size_t len, dr_ref_t *out)
{
    char text[128];
    if (len >= sizeof text) {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': field name too long",
                  argno, arg);
        return false;
    }
    memcpy(text, path, len);
    text[len] = '\0';
    dr_status_t st = dr_path_parse(text, out);
    if (st == DR_OK)
        return true;
    if (st == DR_ENOENT) {
        char best[64];
        dr_path_closest(text, best, sizeof best);
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': no field %s; closest known field: %s "
                  "(drcli list shows all)", argno, arg, text, best);
    } else if (st == DR_EINDEX || st == DR_ESYNTAX) {
        char hint[48];
        index_hint(text, hint, sizeof hint);
        const char *what = st == DR_ESYNTAX           ? "malformed index in"
                           : strchr(text, '[') == NULL ? "no index given for"
                                                       : "index out of range in";
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': %s %s%s", argno, arg,
                  what, text, hint);
    } else {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': %s", argno, arg,
                  dr_strerror(st));
    }
    return false;
}

bool cli_items_add_arg(const char *cmd, cli_items_t *it, int argno,
                       const char *arg, bool asm_ok)
{
    dr_asm_t a;
    dr_ref_t ref;
    bool whole = asm_ok && dr_asm_lookup(arg, &a) == DR_OK;
    if (!whole && !cli_resolve_path(cmd, argno, arg, arg, strlen(arg), &ref))
        return false;
    if (whole ? !cli_items_add_asm(it, a) : it->n >= CLI_ITEMS_MAX) {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': more than %d fields in all",
                  argno, arg, CLI_ITEMS_MAX);
        return false;
    }
    if (!whole)
        add(it, ref);
    return true;
}

void cli_items_want(const cli_items_t *it, cli_images_t *im)
{
    for (size_t i = 0; i < it->n; i++)
        im->want[it->ref[i].field->assembly] = true;
}

void cli_format_ref(const cli_images_t *im, dr_ref_t ref, unsigned flags,
                    char *out, size_t size)
{
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    dr_value_t v;
    if (dr_field_get(im->img[a], dr_asm_info(a)->size, ref, &v) != DR_OK ||
        dr_text_format(ref, &v, flags, out, size) != DR_OK)
        snprintf(out, size, "?"); /* not reached: sizes are the codec's */
}

json_t *cli_items_json(const cli_items_t *it, const cli_images_t *im)
{
    json_t *obj = json_object();
    for (size_t i = 0; obj != NULL && i < it->n; i++) {
        dr_asm_t a = (dr_asm_t)it->ref[i].field->assembly;
        if (!cli_json_add_ref(obj, im->img[a], dr_asm_info(a)->size, it->ref[i])) {
            json_decref(obj);
            obj = NULL;
        }
    }
    return obj;
}
