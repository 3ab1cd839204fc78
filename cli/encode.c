/* SPDX-License-Identifier: MIT */
/*
 * drcli encode: build an assembly image from FIELD=VALUE assignments,
 * starting from all zeros. Every assignment is checked before anything is
 * written, so a mistake never leaves a half-built image on stdout.
 */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "cmd.h"
#include "error.h"
#include "opt.h"
#include "util.h"
#include "drgate/text.h"

static const char encode_help[] =
    "usage: drcli encode [--hex] ASSEMBLY [FIELD=VALUE...]\n"
    "\n"
    "Builds one image of ASSEMBLY (name or alias), all zeros except for the\n"
    "fields given, and writes it to standard output as raw bytes (refused on a\n"
    "terminal) or, with --hex, as hex text that `drcli decode --hex` reads.\n"
    "Assignments apply from left to right.\n"
    "\n"
    "FIELD is a path relative to the assembly (cb_do[3], ao[0], position[1],\n"
    "[7] for a register) or a full path (io_control.cb_do[3], dr7.ao[0]);\n"
    "a mask without index sets all its bits (cb_do=0x00ff).\n"
    "VALUE: bits 0/1/true/false, integers in decimal or 0x hex, robot_state as\n"
    "a name (OPERATING) or number, REALs in decimal (2.5, -1e-3).\n"
    "\n"
    "options:\n"
    "  --hex       write hex text, 16 bytes per line\n"
    "  -h, --help  this text\n"
    "\n"
    "example: drcli encode --hex io_control cb_do[3]=1 ao[0]=2.5\n";

/* Does s[0..n) name an assembly (name or alias)? */
static bool names_assembly(const char *s, size_t n)
{
    char tmp[16];
    dr_asm_t a;
    if (n == 0 || n >= sizeof tmp)
        return false;
    memcpy(tmp, s, n);
    tmp[n] = '\0';
    return dr_asm_lookup(tmp, &a) == DR_OK;
}

/* " (indexes 1..16)" for a path such as "io_control.cb_do[17]" whose field
 * exists and takes an index; "" otherwise. */
static void index_hint(const char *path, char *out, size_t size)
{
    size_t head = strcspn(path, ".["), stem = strcspn(path, "[");
    char asm_name[16];
    dr_asm_t a;
    out[0] = '\0';
    if (head >= sizeof asm_name)
        return;
    memcpy(asm_name, path, head);
    asm_name[head] = '\0';
    if (dr_asm_lookup(asm_name, &a) != DR_OK)
        return;
    const char *field = head < stem ? path + head + 1 : path + stem;
    size_t field_len = (size_t)(path + stem - field);
    uint16_t count;
    const dr_field_t *f = dr_asm_fields(a, &count);
    for (uint16_t i = 0; i < count; i++)
        if (f[i].indexed && strlen(f[i].name) == field_len &&
            memcmp(f[i].name, field, field_len) == 0)
            snprintf(out, size, " (indexes %u..%u)", (unsigned)f[i].first_index,
                     (unsigned)f[i].first_index + f[i].count - 1u);
}

/* Resolve FIELD (name[0..name_len)) for assembly `a`. A name whose first
 * part (up to '.' or '[') is an assembly name or alias is a full path;
 * anything else is relative to `a` (field names and assembly names never
 * coincide). Prints the error and returns false on failure. */
static bool resolve(const char *cmd, int argno, const char *arg, dr_asm_t a,
                    const char *name, size_t name_len, dr_ref_t *out)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    size_t head = strcspn(name, ".[");
    bool full = names_assembly(name, head < name_len ? head : name_len);
    char path[128];
    int n;
    if (full)
        n = snprintf(path, sizeof path, "%.*s", (int)name_len, name);
    else
        n = snprintf(path, sizeof path, "%s%s%.*s", info->name,
                     name[0] == '[' ? "" : ".", (int)name_len, name);
    if (n < 0 || (size_t)n >= sizeof path) {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': field name too long",
                  argno, arg);
        return false;
    }

    dr_status_t st = dr_path_parse(path, out);
    if (st == DR_ENOENT) {
        char best[64];
        dr_path_closest(path, best, sizeof best);
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': no field %s; closest known field: %s",
                  argno, arg, path, best);
        return false;
    }
    if (st == DR_EINDEX || st == DR_ESYNTAX) {
        char hint[48];
        index_hint(path, hint, sizeof hint);
        const char *what = st == DR_ESYNTAX           ? "malformed index in"
                           : strchr(path, '[') == NULL ? "no index given for"
                                                       : "index out of range in";
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': %s %s%s", argno, arg,
                  what, path, hint);
        return false;
    }
    if (st != DR_OK) {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': %s", argno, arg,
                  dr_strerror(st));
        return false;
    }
    if (out->field->assembly != a) {
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': %s is a field of %s, not of %s", argno, arg,
                  path, dr_asm_info((dr_asm_t)out->field->assembly)->name,
                  info->name);
        return false;
    }
    return true;
}

/* Apply one "FIELD=VALUE" to the image. Prints the error and returns false
 * on failure; the image is then unchanged. */
static bool assign(const char *cmd, int argno, const char *arg, dr_asm_t a,
                   uint8_t *img, size_t len)
{
    const char *eq = strchr(arg, '=');
    if (eq == NULL || eq == arg) {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': expected FIELD=VALUE",
                  argno, arg);
        return false;
    }
    dr_ref_t ref;
    if (!resolve(cmd, argno, arg, a, arg, (size_t)(eq - arg), &ref))
        return false;

    char path[64], range[96];
    dr_ref_path(ref, path, sizeof path);
    const char *text = eq + 1;
    dr_value_t v;
    dr_status_t st = dr_text_parse(ref, text, 0, &v);
    if (st == DR_OK)
        st = dr_field_set(img, len, ref, &v, 0);
    if (st == DR_OK)
        return true;

    cli_describe_range(ref, range, sizeof range);
    const char *type = cli_type_name(ref);
    switch (st) {
    case DR_ESYNTAX:
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': malformed value '%s' for %s (%s); expected %s",
                  argno, arg, text, path, type, range);
        break;
    case DR_ERANGE:
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': value %s out of range for %s (%s); expected %s",
                  argno, arg, text, path, type, range);
        break;
    case DR_ENONFINITE:
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': non-finite value %s for %s (%s), which the "
                  "robot consumes; expected %s", argno, arg, text, path, type, range);
        break;
    default:
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': %s: %s", argno, arg,
                  path, dr_strerror(st));
        break;
    }
    return false;
}

static int run_encode(const char *cmd, int argc, char **argv,
                      const cli_net_opts_t *lead)
{
    (void)lead; /* offline: main refuses network options */
    bool help = false, hex = false;
    const cli_opt_t opts[] = {
        {"hex", 0, &hex, NULL, NULL},
    };
    int npos = cli_parse_opts(cli_cmd_encode.name, argc, argv, opts,
                              sizeof opts / sizeof opts[0], &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(&cli_cmd_encode);
        return CLI_EXIT_OK;
    }
    if (npos < 1)
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "expected ASSEMBLY [FIELD=VALUE...] (see drcli encode --help)");

    dr_asm_t a;
    if (!cli_lookup_asm(cmd, argv[0], &a))
        return CLI_EXIT_USAGE;
    const dr_asm_info_t *info = dr_asm_info(a);
    uint8_t img[DR_ASM_MAX_SIZE] = {0};
    for (int i = 1; i < npos; i++)
        if (!assign(cmd, i + 1, argv[i], a, img, info->size))
            return CLI_EXIT_USAGE;

    if (hex) {
        cli_print_hex(img, info->size);
        return CLI_EXIT_OK;
    }
    if (isatty(STDOUT_FILENO))
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "refusing to write binary to a terminal; redirect it or use --hex");
    if (fwrite(img, 1, info->size, stdout) != info->size)
        return cli_error(CLI_EXIT_FAIL, cmd, "writing to standard output failed");
    return CLI_EXIT_OK;
}

const cli_cmd_t cli_cmd_encode = {
    "encode", "build an assembly image from FIELD=VALUE assignments",
    encode_help, run_encode, false,
};
