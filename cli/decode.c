/* SPDX-License-Identifier: MIT */
/*
 * drcli decode: an assembly image (raw bytes or hex text) as one line per
 * field, or as one JSON object.
 */
#include <stdio.h>

#include "cmd.h"
#include "error.h"
#include "opt.h"
#include "util.h"
#include "drgate/text.h"

static const char decode_help[] =
    "usage: drcli decode [--hex] [--json] ASSEMBLY [FILE|-]\n"
    "\n"
    "Decodes one image of ASSEMBLY (name or alias) read from FILE, or from\n"
    "standard input if FILE is - or missing. The input must be exactly as long\n"
    "as the assembly (drcli list shows the sizes).\n"
    "\n"
    "Prints `path = value unit` per field: bits 0/1, whole masks as\n"
    "`5 (0x0005)` before their bits, robot_state by name (`OPERATING (2)`,\n"
    "`UNKNOWN(13)`), REALs in the shortest form that reads back exactly.\n"
    "\n"
    "options:\n"
    "  --hex       the input is hex text: two digits per byte, bytes may be\n"
    "              separated by whitespace (as `drcli encode --hex` prints)\n"
    "  --json      one JSON object, canonical paths as keys, one per leaf\n"
    "              (no masks): bits true/false, integers and robot_state as\n"
    "              numbers, REALs as numbers (non-finite: \"nan\", \"inf\",\n"
    "              \"-inf\")\n"
    "  -h, --help  this text\n";

/* "path = value unit" for one leaf or mask. */
static void print_ref(const uint8_t *buf, size_t len, dr_ref_t ref)
{
    char path[64], text[64];
    dr_value_t v;
    dr_ref_path(ref, path, sizeof path);
    if (dr_field_get(buf, len, ref, &v) != DR_OK ||
        dr_text_format(ref, &v, DR_TEXT_UNIT, text, sizeof text) != DR_OK)
        snprintf(text, sizeof text, "?"); /* not reached: len was checked */
    printf("%s = %s\n", path, text);
}

static void print_text(dr_asm_t a, const uint8_t *buf, size_t len)
{
    uint16_t count;
    const dr_field_t *f = dr_asm_fields(a, &count);
    for (uint16_t i = 0; i < count; i++) {
        if (f[i].kind == DR_KIND_BITS) {
            dr_ref_t mask = {&f[i], -1};
            print_ref(buf, len, mask);
        }
        unsigned leaves = f[i].indexed ? f[i].count : 1u;
        for (unsigned e = 0; e < leaves; e++) {
            dr_ref_t leaf = {&f[i], (int16_t)e};
            print_ref(buf, len, leaf);
        }
    }
}

static int print_json(const char *cmd, dr_asm_t a, const uint8_t *buf,
                      size_t len)
{
    json_t *obj = json_object();
    uint16_t count;
    const dr_field_t *f = dr_asm_fields(a, &count);
    bool ok = obj != NULL;
    for (uint16_t i = 0; ok && i < count; i++) {
        unsigned leaves = f[i].indexed ? f[i].count : 1u;
        for (unsigned e = 0; ok && e < leaves; e++) {
            dr_ref_t leaf = {&f[i], (int16_t)e};
            ok = cli_json_add_ref(obj, buf, len, leaf);
        }
    }
    if (!ok) {
        json_decref(obj);
        obj = NULL;
    }
    return cli_json_print(cmd, obj);
}

static int run_decode(const char *cmd, int argc, char **argv,
                      const cli_net_opts_t *lead)
{
    (void)lead; /* offline: main refuses network options */
    bool help = false, hex = false, json = false;
    const cli_opt_t opts[] = {
        {"hex", 0, &hex, NULL, NULL},
        {"json", 0, &json, NULL, NULL},
    };
    int npos = cli_parse_opts(cli_cmd_decode.name, argc, argv, opts,
                              sizeof opts / sizeof opts[0], &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(&cli_cmd_decode);
        return CLI_EXIT_OK;
    }
    if (npos < 1 || npos > 2)
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "expected ASSEMBLY [FILE|-] (see drcli decode --help)");

    dr_asm_t a;
    if (!cli_lookup_asm(cmd, argv[0], &a))
        return CLI_EXIT_USAGE;
    const char *path = npos == 2 ? argv[1] : "-";
    static uint8_t buf[CLI_INPUT_MAX];
    size_t len;
    if (!cli_read_input(cmd, path, buf, &len))
        return CLI_EXIT_USAGE;
    if (hex && !cli_parse_hex(cmd, path, buf, &len))
        return CLI_EXIT_USAGE;

    const dr_asm_info_t *info = dr_asm_info(a);
    if (len != info->size)
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "%s: %s is %u bytes, the input has %zu%s",
                         path[0] == '-' && path[1] == '\0' ? "standard input" : path,
                         info->name, (unsigned)info->size, len,
                         hex ? " (after hex decoding)" : "");
    if (json)
        return print_json(cmd, a, buf, len);
    print_text(a, buf, len);
    return CLI_EXIT_OK;
}

const cli_cmd_t cli_cmd_decode = {
    "decode", "decode an assembly image (raw or hex) into named values",
    decode_help, run_decode, false,
};
