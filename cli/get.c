/* SPDX-License-Identifier: MIT */
/*
 * drcli get and dump: read assemblies from the robot (one
 * Get_Attribute_Single per assembly, however many of its fields are asked
 * for) and print fields as `path = value unit`, or as one JSON object.
 */
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "error.h"
#include "fields.h"
#include "net.h"
#include "opt.h"
#include "util.h"
#include "drgate/text.h"

static const char get_help[] =
    "usage: drcli [-H HOST] get [OPTION...] FIELD...\n"
    "\n"
    "Reads the assemblies that hold the FIELDs, one request per assembly, and\n"
    "prints `path = value unit` per FIELD in the order given: bits 0/1, masks\n"
    "as `5 (0x0005)`, robot_state by name (`OPERATING (2)`), REALs in the\n"
    "shortest form that reads back exactly.\n"
    "\n"
    "FIELD is a full path as `drcli list` prints it (io_state.robot_state,\n"
    "dr2.position[3], io_state.cb_di for a whole mask, int_out[7]) or an\n"
    "assembly name or alias for all its fields.\n"
    "\n"
    "options:\n"
    CLI_NET_HELP
    "  -h, --help          this text\n"
    "\n"
    "With --json: one object, canonical leaf paths as keys (a mask as its\n"
    "bits), bits true/false, integers and robot_state as numbers, REALs as\n"
    "numbers; --raw adds each assembly's bytes as a hex string under its name.\n"
    "Exit status: 0, 2 usage (nothing sent), 3 network, 4 CIP error.\n"
    "\n"
    "example: drcli -H 192.168.137.100 get io_state.robot_state dr2.position[1]\n";

static const char dump_help[] =
    "usage: drcli [-H HOST] dump [OPTION...] [ASSEMBLY...]\n"
    "\n"
    "Reads the ASSEMBLYs (names or aliases; all ten by default), one request\n"
    "each, and prints all their fields, aligned, grouped by assembly under a\n"
    "`# name (alias, instance N): size bytes, direction` line. Values are\n"
    "formatted as by `drcli get`.\n"
    "\n"
    "options:\n"
    CLI_NET_HELP
    "  -h, --help          this text\n"
    "\n"
    "With --json: one object with every leaf of the assemblies (as get --json).\n"
    "Exit status: 0, 2 usage (nothing sent), 3 network, 4 CIP error.\n";

/* ---- output ------------------------------------------------------------------ */

/* `path = value unit`, the path padded to `width`. */
static void print_item(const cli_images_t *im, dr_ref_t ref, int width)
{
    char path[64], text[64];
    dr_ref_path(ref, path, sizeof path);
    cli_format_ref(im, ref, DR_TEXT_UNIT, text, sizeof text);
    printf("%-*s = %s\n", width, path, text);
}

static int print_json(const char *cmd, const cli_items_t *it,
                      const cli_images_t *im, bool raw)
{
    json_t *obj = cli_items_json(it, im);
    for (unsigned a = 0; raw && obj != NULL && a < DR_ASM_COUNT; a++) {
        if (!im->want[a])
            continue;
        char hex[DR_ASM_MAX_SIZE * 3 + 1];
        cli_hex_string(im->img[a], dr_asm_info((dr_asm_t)a)->size, hex, sizeof hex);
        if (json_object_set_new(obj, dr_asm_info((dr_asm_t)a)->name,
                                json_string(hex)) != 0) {
            json_decref(obj);
            obj = NULL;
        }
    }
    return cli_json_print(cmd, obj);
}

static void print_get(const cli_net_t *net, const cli_items_t *it,
                      const cli_images_t *im, bool raw)
{
    for (size_t i = 0; i < it->n; i++)
        print_item(im, it->ref[i], 0);
    for (unsigned a = 0; raw && a < DR_ASM_COUNT; a++) {
        if (!im->want[a])
            continue;
        char label[64];
        cli_net_asm_label(net, (dr_asm_t)a, label, sizeof label);
        printf("%s: %u bytes\n", label, (unsigned)dr_asm_info((dr_asm_t)a)->size);
        cli_print_raw(im->img[a], dr_asm_info((dr_asm_t)a)->size);
    }
}

static void print_dump(const cli_net_t *net, const cli_images_t *im, bool raw)
{
    bool first = true;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (!im->want[a])
            continue;
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        static cli_items_t group;
        group.n = 0;
        (void)cli_items_add_asm(&group, (dr_asm_t)a); /* one always fits */
        int width = 0;
        for (size_t i = 0; i < group.n; i++) {
            char path[64];
            dr_ref_path(group.ref[i], path, sizeof path);
            if ((int)strlen(path) > width)
                width = (int)strlen(path);
        }
        char label[64];
        cli_net_asm_label(net, (dr_asm_t)a, label, sizeof label);
        printf("%s# %s: %u bytes, %s\n", first ? "" : "\n", label,
               (unsigned)info->size, cli_dir_name(info->dir));
        first = false;
        if (raw)
            cli_print_raw(im->img[a], info->size);
        for (size_t i = 0; i < group.n; i++)
            print_item(im, group.ref[i], width);
    }
}

/* ---- commands ------------------------------------------------------------ */

/* Options, then the arguments (fields for get, assemblies for dump), then
 * the network. */
static int run_read(const cli_cmd_t *self, int argc, char **argv,
                    const cli_net_opts_t *lead, bool dump)
{
    const char *cmd = self->name;
    cli_net_opts_t o = *lead;
    bool help = false;
    cli_opt_t opts[CLI_NET_NOPTS];
    size_t nopts = cli_net_optv(&o, opts);
    int npos = cli_parse_opts(self->name, argc, argv, opts, nopts, &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(self);
        return CLI_EXIT_OK;
    }
    dr_client_config_t cfg;
    int rc = cli_net_config(cmd, &o, &cfg);
    if (rc != CLI_EXIT_OK)
        return rc;

    static cli_items_t items;
    static cli_images_t im;
    items.n = 0;
    memset(im.want, 0, sizeof im.want);
    if (!dump && npos == 0)
        return cli_error(CLI_EXIT_USAGE, cmd, "expected FIELD... (see drcli get --help)");
    for (int i = 0; i < npos; i++) {
        dr_asm_t a;
        if (!dump) {
            if (!cli_items_add_arg(cmd, &items, i + 1, argv[i], true))
                return CLI_EXIT_USAGE;
        } else if (!cli_lookup_asm(cmd, argv[i], &a)) {
            return CLI_EXIT_USAGE;
        } else {
            im.want[a] = true;
        }
    }
    /* dump: each assembly once, in table order (all ten fit). */
    for (unsigned a = 0; dump && a < DR_ASM_COUNT; a++)
        if (npos == 0 || im.want[a])
            (void)cli_items_add_asm(&items, (dr_asm_t)a);
    cli_items_want(&items, &im);

    cli_net_t net;
    rc = cli_net_connect(cmd, &cfg, &net);
    if (rc == CLI_EXIT_OK)
        rc = cli_net_read(&net, &im);
    if (rc == CLI_EXIT_OK) {
        if (o.json)
            rc = print_json(cmd, &items, &im, o.raw);
        else if (dump)
            print_dump(&net, &im, o.raw);
        else
            print_get(&net, &items, &im, o.raw);
    }
    if (net.client != NULL)
        cli_net_close(&net);
    return rc;
}

static int run_get(const char *cmd, int argc, char **argv,
                   const cli_net_opts_t *lead)
{
    (void)cmd;
    return run_read(&cli_cmd_get, argc, argv, lead, false);
}

static int run_dump(const char *cmd, int argc, char **argv,
                    const cli_net_opts_t *lead)
{
    (void)cmd;
    return run_read(&cli_cmd_dump, argc, argv, lead, true);
}

const cli_cmd_t cli_cmd_get = {
    "get", "read fields from the robot (one request per assembly)",
    get_help, run_get, true,
};

const cli_cmd_t cli_cmd_dump = {
    "dump", "read whole assemblies from the robot, every field",
    dump_help, run_dump, true,
};
