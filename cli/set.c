/* SPDX-License-Identifier: MIT */
/*
 * drcli set: write O->T fields. Every assignment is checked before anything
 * is sent; then, per assembly, the current image is read, all of that
 * assembly's assignments are applied to it, and it is written back with
 * one Set_Attribute_Single, so values given together land together.
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

static const char set_help[] =
    "usage: drcli [-H HOST] set [OPTION...] FIELD=VALUE...\n"
    "\n"
    "Writes fields the robot consumes (O->T: io_control, bit_in, int_in,\n"
    "float_in). Every assignment is checked first: a field the robot produces\n"
    "(T->O), an unknown field, an index or value out of range or a malformed\n"
    "value ends the command with status 2 and nothing is sent.\n"
    "\n"
    "Then, per assembly: read its current image (Get_Attribute_Single), apply\n"
    "all of its assignments from left to right, write it back once\n"
    "(Set_Attribute_Single). Fields given together in one command land in\n"
    "the same write; other fields keep the values read. This is not atomic\n"
    "against another writer between the read and the write. Assemblies are\n"
    "written in the order of `drcli list`; if one fails, the message says\n"
    "which were already written.\n"
    "\n"
    "FIELD is a full path (io_control.cb_do[3], dr7.ao[0], bit_in[5],\n"
    "io_control.cb_do=0x00ff for a whole mask). VALUE: bits 0/1/true/false,\n"
    "integers in decimal or 0x hex, REALs in decimal (2.5, -1e-3).\n"
    "\n"
    "options:\n"
    "  -n, --dry-run       read the current images and print the bytes that\n"
    "                      would be written; send no write\n"
    CLI_NET_HELP
    "  -h, --help          this text\n"
    "\n"
    "--raw prints the bytes written; --json does not apply. Prints nothing\n"
    "else on success.\n"
    "Exit status: 0, 2 usage (nothing sent), 3 network, 4 CIP error.\n"
    "\n"
    "example: drcli -H 192.168.137.100 set io_control.cb_do[1]=1 io_control.cb_do[2]=1\n";

typedef struct {
    dr_ref_t ref;
    dr_value_t value;
} assignment_t;

/* Explain why VALUE does not fit FIELD (dr_text_parse's status). */
static void value_error(const char *cmd, int argno, const char *arg,
                        dr_ref_t ref, const char *text, dr_status_t st)
{
    char path[64], range[96];
    dr_ref_path(ref, path, sizeof path);
    cli_describe_range(ref, range, sizeof range);
    const char *type = cli_type_name(ref);
    if (st == DR_ESYNTAX)
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': malformed value '%s' for %s (%s); expected %s",
                  argno, arg, text, path, type, range);
    else if (st == DR_ERANGE)
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': value %s out of range for %s (%s); expected %s",
                  argno, arg, text, path, type, range);
    else if (st == DR_ENONFINITE)
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': non-finite value %s for %s (%s), which the "
                  "robot consumes; expected %s", argno, arg, text, path, type, range);
    else
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': %s: %s", argno, arg,
                  path, dr_strerror(st));
}

bool cli_parse_assignment(const char *cmd, int argno, const char *arg,
                          dr_ref_t *ref, dr_value_t *value)
{
    const char *eq = strchr(arg, '=');
    if (eq == NULL || eq == arg) {
        cli_error(CLI_EXIT_USAGE, cmd, "argument %d '%s': expected FIELD=VALUE",
                  argno, arg);
        return false;
    }
    if (!cli_resolve_path(cmd, argno, arg, arg, (size_t)(eq - arg), ref))
        return false;
    const dr_asm_info_t *info = dr_asm_info((dr_asm_t)ref->field->assembly);
    if (info->dir != DR_DIR_O2T) {
        char path[64];
        dr_ref_path(*ref, path, sizeof path);
        cli_error(CLI_EXIT_USAGE, cmd,
                  "argument %d '%s': %s is produced by the robot (T->O, %s) and "
                  "cannot be set; writable assemblies: io_control, bit_in, int_in, "
                  "float_in", argno, arg, path, info->name);
        return false;
    }
    dr_status_t st = dr_text_parse(*ref, eq + 1, DR_SET_O2T_ONLY, value);
    if (st != DR_OK) {
        value_error(cmd, argno, arg, *ref, eq + 1, st);
        return false;
    }
    return true;
}

/* Read assembly `a`, apply its assignments, write it (or print it). */
static int write_asm(cli_net_t *net, dr_asm_t a, const assignment_t *as,
                     size_t n, bool dry_run, bool raw)
{
    const dr_asm_info_t *info = dr_asm_info(a);
    uint8_t img[DR_ASM_MAX_SIZE];
    char label[96];
    cli_net_asm_label(net, a, label, sizeof label);
    int rc = cli_net_read_asm(net, a, img);
    if (rc != CLI_EXIT_OK)
        return rc;
    for (size_t i = 0; i < n; i++)
        if (as[i].ref.field->assembly == a &&
            dr_field_set(img, info->size, as[i].ref, &as[i].value, DR_SET_O2T_ONLY) != DR_OK)
            return cli_error(CLI_EXIT_FAIL, net->cmd, "internal error applying "
                             "argument %zu", i + 1); /* checked before */
    if (!dry_run) {
        rc = cli_net_write_asm(net, a, img);
        if (rc != CLI_EXIT_OK)
            return rc;
    }
    if (dry_run || raw) {
        printf("%s: %u bytes%s\n", label, (unsigned)info->size,
               dry_run ? ", not sent (dry run)" : " written");
        cli_print_raw(img, info->size);
    }
    return CLI_EXIT_OK;
}

/* Write every assembly that has assignments, in table order. */
static int write_all(cli_net_t *net, const assignment_t *as, size_t n,
                     bool dry_run, bool raw)
{
    bool touched[DR_ASM_COUNT] = {false};
    char done[160] = "";
    for (size_t i = 0; i < n; i++)
        touched[as[i].ref.field->assembly] = true;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (!touched[a])
            continue;
        int rc = write_asm(net, (dr_asm_t)a, as, n, dry_run, raw);
        if (rc != CLI_EXIT_OK) {
            if (done[0] != '\0' && !dry_run)
                cli_error(rc, net->cmd, "already written before the failure:%s", done);
            return rc;
        }
        size_t len = strlen(done);
        snprintf(done + len, sizeof done - len, " %s", dr_asm_info((dr_asm_t)a)->name);
    }
    return CLI_EXIT_OK;
}

static int run_set(const char *cmd, int argc, char **argv,
                   const cli_net_opts_t *lead)
{
    cli_net_opts_t o = *lead;
    bool help = false, dry_run = false;
    cli_opt_t opts[CLI_NET_NOPTS + 1];
    size_t nopts = cli_net_optv(&o, opts);
    opts[nopts++] = (cli_opt_t){"dry-run", 'n', &dry_run, NULL, NULL};
    int npos = cli_parse_opts(cli_cmd_set.name, argc, argv, opts, nopts, &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(&cli_cmd_set);
        return CLI_EXIT_OK;
    }
    dr_client_config_t cfg;
    int rc = cli_net_refuse(cmd, &o, false, true);
    if (rc == CLI_EXIT_OK)
        rc = cli_net_config(cmd, &o, &cfg);
    if (rc != CLI_EXIT_OK)
        return rc;
    if (npos == 0)
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "expected FIELD=VALUE... (see drcli set --help)");

    static assignment_t as[CLI_ITEMS_MAX];
    if ((size_t)npos > sizeof as / sizeof as[0])
        return cli_error(CLI_EXIT_USAGE, cmd, "more than %zu assignments",
                         sizeof as / sizeof as[0]);
    for (int i = 0; i < npos; i++)
        if (!cli_parse_assignment(cmd, i + 1, argv[i], &as[i].ref, &as[i].value))
            return CLI_EXIT_USAGE;

    cli_net_t net;
    rc = cli_net_connect(cmd, &cfg, &net);
    if (rc != CLI_EXIT_OK)
        return rc;
    rc = write_all(&net, as, (size_t)npos, dry_run, o.raw);
    cli_net_close(&net);
    return rc;
}

const cli_cmd_t cli_cmd_set = {
    "set", "write O->T fields (read-modify-write, one write per assembly)",
    set_help, run_set, true,
};
