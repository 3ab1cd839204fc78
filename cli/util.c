/* SPDX-License-Identifier: MIT */
/* drcli helpers: assembly names, value ranges, JSON numbers, byte I/O. */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "error.h"
#include "util.h"

#include "drgate/enip.h"
#include "drgate/text.h"

/* ---- assemblies ----------------------------------------------------------- */

bool cli_lookup_asm(const char *cmd, const char *name, dr_asm_t *out)
{
    if (dr_asm_lookup(name, out) == DR_OK)
        return true;
    const char *best = NULL;
    unsigned best_d = ~0u;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        const char *cand[2] = {info->name, info->alias};
        for (int k = 0; k < 2; k++) {
            unsigned d = dr_edit_distance(name, cand[k]);
            if (d < best_d) {
                best_d = d;
                best = cand[k];
            }
        }
    }
    cli_error(CLI_EXIT_USAGE, cmd,
              "unknown assembly '%s'; closest known assembly: %s "
              "(drcli list shows all)", name, best);
    return false;
}

const char *cli_dir_name(dr_dir_t dir)
{
    return dir == DR_DIR_T2O ? "T->O" : "O->T";
}

const char *cli_type_name(dr_ref_t ref)
{
    static const char *const masks[] = {"6-bit mask", "16-bit mask", "64-bit mask"};
    if (ref.field->kind != DR_KIND_BITS || ref.elem >= 0)
        return dr_kind_name((dr_kind_t)ref.field->kind);
    switch (ref.field->count) {
    case 6: return masks[0];
    case 16: return masks[1];
    case 64: return masks[2];
    default: return "bit mask";
    }
}

void cli_describe_range(dr_ref_t ref, char *out, size_t size)
{
    const dr_field_t *f = ref.field;
    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT:
        snprintf(out, size, "0 or 1 (or false/true)");
        return;
    case DR_KIND_BITS:
        if (ref.elem >= 0)
            snprintf(out, size, "0 or 1 (or false/true)");
        else if (f->count >= 64)
            snprintf(out, size, "0..%" PRIu64, UINT64_MAX);
        else
            snprintf(out, size, "0..%" PRIu64,
                     (UINT64_C(1) << f->count) - 1u);
        return;
    case DR_KIND_USINT:
        snprintf(out, size, "0..255");
        return;
    case DR_KIND_ENUM:
        snprintf(out, size, "0..255 or a state name (%s..%s)",
                 dr_robot_state_name(0), dr_robot_state_name(DR_ROBOT_SAFE_OFF2));
        return;
    case DR_KIND_DINT:
        snprintf(out, size, "a whole number in %" PRId32 "..%" PRId32,
                 INT32_MIN, INT32_MAX);
        return;
    case DR_KIND_REAL:
        snprintf(out, size, "a finite number of magnitude up to 3.4028235e38");
        return;
    }
    snprintf(out, size, "?");
}

/* ---- JSON ------------------------------------------------------------- */

/* jansson prints a real with "%.*g" at the precision given to the dump call
 * (17 by default), which shows 0.1f as 0.10000000149011612. So the number
 * is the library's JSON token for it (dr_text_json: the double nearest the
 * float's shortest text, at 9 digits, which the gateway's console prints
 * too), printed again with 9 digits (CLI_JSON_FLAGS): the same token, as
 * %.9g of a number read from a %.9g text gives that text back. Whole
 * numbers get ".0" from both. Non-finite values are dr_text_json's
 * strings. */
json_t *cli_json_real(float f)
{
    char text[32];
    dr_value_t v = {DR_VAL_REAL, 0, 0, (double)f};
    if (dr_text_json(&v, text, sizeof text) != DR_OK)
        return NULL; /* not reached: 32 bytes hold any binary32 */
    if (text[0] == '"') {
        text[strlen(text) - 1] = '\0';
        return json_string(text + 1);
    }
    return json_real(strtod(text, NULL));
}

json_t *cli_json_value(const dr_value_t *v)
{
    switch (v->type) {
    case DR_VAL_BOOL: return json_boolean(v->u != 0);
    case DR_VAL_UINT: return json_integer((json_int_t)v->u); /* leaves < 2^8 */
    case DR_VAL_INT: return json_integer((json_int_t)v->i);
    case DR_VAL_REAL: return cli_json_real((float)v->f);
    }
    return NULL;
}

/* One leaf under its canonical path. */
static bool add_leaf(json_t *obj, const uint8_t *img, size_t len, dr_ref_t leaf)
{
    char path[64];
    dr_value_t v;
    return dr_ref_path(leaf, path, sizeof path) == DR_OK &&
           dr_field_get(img, len, leaf, &v) == DR_OK &&
           json_object_set_new(obj, path, cli_json_value(&v)) == 0;
}

bool cli_json_add_ref(json_t *obj, const uint8_t *img, size_t len, dr_ref_t ref)
{
    if (ref.elem >= 0 || ref.field->kind != DR_KIND_BITS)
        return add_leaf(obj, img, len, ref);
    for (unsigned e = 0; e < ref.field->count; e++) {
        dr_ref_t leaf = {ref.field, (int16_t)e};
        if (!add_leaf(obj, img, len, leaf))
            return false;
    }
    return true;
}

int cli_json_print(const char *cmd, json_t *value)
{
    return cli_json_print_flags(cmd, value, CLI_JSON_FLAGS);
}

int cli_json_print_flags(const char *cmd, json_t *value, size_t flags)
{
    if (value == NULL)
        return cli_error(CLI_EXIT_FAIL, cmd, "out of memory building JSON");
    int st = json_dumpf(value, stdout, flags);
    json_decref(value);
    if (st != 0 || fputc('\n', stdout) == EOF)
        return cli_error(CLI_EXIT_FAIL, cmd, "writing JSON to standard output failed");
    return CLI_EXIT_OK;
}

/* ---- bytes in and out --------------------------------------------------- */

bool cli_read_input(const char *cmd, const char *path, uint8_t *buf,
                    size_t *len)
{
    bool is_stdin = strcmp(path, "-") == 0;
    const char *shown = is_stdin ? "standard input" : path;
    FILE *fp = is_stdin ? stdin : fopen(path, "rb");
    if (fp == NULL) {
        cli_error(CLI_EXIT_USAGE, cmd, "%s: cannot open: %s", path, strerror(errno));
        return false;
    }
    size_t n = fread(buf, 1, CLI_INPUT_MAX, fp);
    bool ok = !ferror(fp);
    int err = errno;
    /* One more byte tells "exactly the limit" from "too long". */
    uint8_t extra;
    bool too_long = ok && n == CLI_INPUT_MAX && fread(&extra, 1, 1, fp) == 1;
    if (!is_stdin)
        (void)fclose(fp); /* read only: nothing to lose */
    if (!ok) {
        cli_error(CLI_EXIT_USAGE, cmd, "%s: read error: %s", shown, strerror(err));
        return false;
    }
    if (too_long) {
        cli_error(CLI_EXIT_USAGE, cmd, "%s: more than %u bytes of input", shown,
                  CLI_INPUT_MAX);
        return false;
    }
    *len = n;
    return true;
}

static int hex_value(uint8_t c)
{
    if (c >= '0' && c <= '9')
        return c - '0';
    if (c >= 'a' && c <= 'f')
        return c - 'a' + 10;
    if (c >= 'A' && c <= 'F')
        return c - 'A' + 10;
    return -1;
}

static bool is_space(uint8_t c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\f' || c == '\v';
}

bool cli_parse_hex(const char *cmd, const char *path, uint8_t *buf,
                   size_t *len)
{
    const char *shown = strcmp(path, "-") == 0 ? "standard input" : path;
    size_t out = 0, line = 1, col = 0;
    int high = -1; /* first digit of a byte, while waiting for the second */
    for (size_t i = 0; i < *len; i++) {
        uint8_t c = buf[i];
        col++;
        if (is_space(c)) {
            if (high >= 0) {
                cli_error(CLI_EXIT_USAGE, cmd,
                          "%s: line %zu, column %zu: whitespace inside a hex byte "
                          "(write bytes as two digits)", shown, line, col);
                return false;
            }
            if (c == '\n') {
                line++;
                col = 0;
            }
            continue;
        }
        int v = hex_value(c);
        if (v < 0) {
            if (c >= 0x20 && c < 0x7f)
                cli_error(CLI_EXIT_USAGE, cmd,
                          "%s: line %zu, column %zu: '%c' is not a hex digit",
                          shown, line, col, c);
            else
                cli_error(CLI_EXIT_USAGE, cmd,
                          "%s: line %zu, column %zu: byte 0x%02x is not a hex digit",
                          shown, line, col, c);
            return false;
        }
        if (high < 0) {
            high = v;
        } else {
            buf[out++] = (uint8_t)(high << 4 | v); /* out < i: safe in place */
            high = -1;
        }
    }
    if (high >= 0) {
        cli_error(CLI_EXIT_USAGE, cmd,
                  "%s: odd number of hex digits (the last byte has one digit)", shown);
        return false;
    }
    *len = out;
    return true;
}

void cli_print_hex(const uint8_t *buf, size_t len)
{
    for (size_t i = 0; i < len; i++)
        printf("%02x%c", buf[i], (i % 16u == 15u || i + 1 == len) ? '\n' : ' ');
}

void cli_hex_string(const uint8_t *buf, size_t len, char *out, size_t size)
{
    size_t at = 0;
    out[0] = '\0';
    for (size_t i = 0; i < len && at + 4 <= size; i++)
        at += (size_t)snprintf(out + at, size - at, i > 0 ? " %02x" : "%02x",
                               buf[i]);
}

void cli_print_raw(const uint8_t *img, size_t len)
{
    for (size_t at = 0; at < len; at += 16) {
        char hex[64];
        size_t n = len - at < 16 ? len - at : 16;
        cli_hex_string(img + at, n, hex, sizeof hex);
        printf("  %4zu: %s\n", at, hex);
    }
}

void cli_print_robot_section(const char *host, uint16_t tcp_port, dr_layout_kind_t kind,
                             const uint16_t *inst, unsigned in_instance, int in_size,
                             unsigned out_instance, int out_size)
{
    printf("\n; for drgatewayd's configuration (docs/commissioning.md)\n[robot arm1]\n");
    printf("host = %s\n", host);
    if (tcp_port != DR_ENIP_TCP_PORT)
        printf("tcp_port = %u\n", (unsigned)tcp_port);
    printf("layout = %s\n", dr_layout_name(kind));
    if (kind == DR_LAYOUT_PER_ASSEMBLY) {
        for (unsigned a = 0; inst != NULL && a < DR_ASM_COUNT; a++)
            if (inst[a] != DR_ASM_DEFAULT_INSTANCE(a))
                printf("instance.%s = %u\n", dr_asm_info((dr_asm_t)a)->name,
                       (unsigned)inst[a]);
        return;
    }
    printf("input_instance = %u\ninput_size = %d\n", in_instance, in_size);
    printf("output_instance = %u\noutput_size = %d\n", out_instance, out_size);
}
