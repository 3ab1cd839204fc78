/* SPDX-License-Identifier: MIT */
/*
 * drcli: the command-line tool of drgate. This file holds main() and the
 * table of commands, and sits on top: nothing includes it or calls into
 * it. Each command is in its own file (list.c, decode.c, encode.c
 * offline; get.c (get, dump), set.c, watch.c, identity.c (identity,
 * probe) over the network through net.c), and exports one cli_cmd_t
 * (cmd.h). Below them: the options (opt.c), the messages and exit codes
 * (error.c), the fields named on the command line (fields.c) and the
 * helpers for assemblies, JSON and bytes (util.c).
 */
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "error.h"
#include "net.h"
#include "opt.h"

#ifndef DRGATE_VERSION
#define DRGATE_VERSION "unknown"
#endif

/* Every command, in the order `drcli --help` shows them. */
static const cli_cmd_t *const commands[] = {
    &cli_cmd_list,
    &cli_cmd_decode,
    &cli_cmd_encode,
    &cli_cmd_get,
    &cli_cmd_dump,
    &cli_cmd_set,
    &cli_cmd_watch,
    &cli_cmd_identity,
    &cli_cmd_probe,
    &cli_cmd_eds,
};
#define NCOMMANDS (sizeof commands / sizeof commands[0])

static void print_usage(FILE *out)
{
    fprintf(out,
            "usage: drcli [-H HOST] [NETWORK-OPTION...] COMMAND [OPTION...] [ARG...]\n"
            "       drcli --help | --version\n"
            "\n"
            "Reads and writes the EtherNet/IP assemblies of a Doosan robot.\n"
            "\n"
            "commands:\n");
    for (size_t i = 0; i < NCOMMANDS; i++)
        fprintf(out, "  %-8s %s\n", commands[i]->name, commands[i]->summary);
    fprintf(out,
            "\n"
            "network options (before or after the command; get, dump, set, watch,\n"
            "identity, probe):\n"
            "%s"
            "\n"
            "`drcli COMMAND --help` describes one command.\n"
            "exit status: 0 success, 1 failure (output, memory), 2 bad usage or\n"
            "input (nothing was sent), 3 network error, timeout or unusable reply,\n"
            "4 CIP error from the device.\n", cli_net_help);
}

/* ---- main ----------------------------------------------------------------- */

static const cli_cmd_t *find_command(const char *name)
{
    for (size_t i = 0; i < NCOMMANDS; i++)
        if (strcmp(commands[i]->name, name) == 0)
            return commands[i];
    return NULL;
}

/* `drcli help [COMMAND]` */
static int run_help(int argc, char **argv)
{
    if (argc < 3) {
        print_usage(stdout);
        return CLI_EXIT_OK;
    }
    const cli_cmd_t *cmd = find_command(argv[2]);
    if (cmd == NULL)
        return cli_error(CLI_EXIT_USAGE, NULL,
                         "help: unknown command '%s' (see drcli --help)", argv[2]);
    cli_print_help(cmd);
    return CLI_EXIT_OK;
}

/* Output goes through stdio buffers: a full disk or a closed pipe shows
 * only when they are flushed, and must not end in exit status 0. */
static int finish_output(int rc)
{
    if (fflush(stdout) != 0 || ferror(stdout)) {
        cli_error(CLI_EXIT_FAIL, NULL, "writing to standard output failed");
        return rc != CLI_EXIT_OK ? rc : CLI_EXIT_FAIL;
    }
    return rc;
}

int main(int argc, char **argv)
{
    /* Network options may come before the command: drcli -H robot get ... */
    cli_net_opts_t lead = {0};
    cli_opt_t opts[CLI_NET_NOPTS];
    size_t nopts = cli_net_optv(&lead, opts);
    int first = 1;
    if (!cli_parse_leading(argc, argv, &first, opts, nopts))
        return CLI_EXIT_USAGE;
    if (first >= argc) {
        print_usage(stderr);
        return CLI_EXIT_USAGE;
    }
    const char *name = argv[first];
    if (strcmp(name, "-h") == 0 || strcmp(name, "--help") == 0) {
        print_usage(stdout);
        return finish_output(CLI_EXIT_OK);
    }
    if (strcmp(name, "--version") == 0 || strcmp(name, "-V") == 0) {
        printf("drcli %s\n", DRGATE_VERSION);
        return finish_output(CLI_EXIT_OK);
    }
    if (strcmp(name, "help") == 0)
        return finish_output(run_help(argc - (first - 1), argv + (first - 1)));

    const cli_cmd_t *cmd = find_command(name);
    if (cmd == NULL)
        return cli_error(CLI_EXIT_USAGE, NULL,
                         "unknown command '%s' (see drcli --help)", name);
    if (cli_net_any(&lead) && !cmd->network)
        return cli_error(CLI_EXIT_USAGE, NULL,
                         "network options given, but %s works offline", name);
    return finish_output(cmd->run(cmd->name, argc - first, argv + first, &lead));
}
