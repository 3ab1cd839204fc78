/* SPDX-License-Identifier: MIT */
/*
 * drcli: the command-line tool of drgate. This file holds main(), the
 * table of commands, option parsing and messages; each command is in its
 * own file (list.c, decode.c, encode.c offline; get.c (get, dump), set.c,
 * watch.c, identity.c (identity, probe) over the network through net.c).
 */
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "drcli.h"

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

void cli_print_help(const cli_cmd_t *cmd)
{
    /* CLI_NET_HELP in a command's help stands for the network options. */
    const char *mark = strstr(cmd->help, CLI_NET_HELP);
    if (mark == NULL) {
        fputs(cmd->help, stdout);
        return;
    }
    fwrite(cmd->help, 1, (size_t)(mark - cmd->help), stdout);
    fputs(cli_net_help, stdout);
    fputs(mark + strlen(CLI_NET_HELP), stdout);
}

int cli_error(int code, const char *cmd, const char *fmt, ...)
{
    va_list ap;
    fprintf(stderr, "drcli%s%s: ", cmd != NULL ? " " : "", cmd != NULL ? cmd : "");
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    return code;
}

/* ---- options ---------------------------------------------------------- */

static const cli_opt_t *find_long(const cli_opt_t *opts, size_t n,
                                  const char *name, size_t len)
{
    for (size_t i = 0; i < n; i++)
        if (strlen(opts[i].long_name) == len &&
            memcmp(opts[i].long_name, name, len) == 0)
            return &opts[i];
    return NULL;
}

static const cli_opt_t *find_short(const cli_opt_t *opts, size_t n, char c)
{
    for (size_t i = 0; i < n; i++)
        if (opts[i].short_name != 0 && opts[i].short_name == c)
            return &opts[i];
    return NULL;
}

/* Apply one option; `inline_arg` is the text after '=' (long options) or
 * NULL. May take the next argv element as the option's argument. */
static bool apply_opt(const char *cmd, const cli_opt_t *o,
                      const char *spelled, const char *inline_arg, int *i,
                      int argc, char **argv)
{
    if (o->value == NULL && o->multi == NULL) {
        if (inline_arg != NULL) {
            cli_error(CLI_EXIT_USAGE, cmd, "option %s takes no value", spelled);
            return false;
        }
        *o->flag = true;
        return true;
    }
    if (inline_arg == NULL) {
        if (*i + 1 >= argc) {
            cli_error(CLI_EXIT_USAGE, cmd, "option %s needs a value", spelled);
            return false;
        }
        inline_arg = argv[++*i];
    }
    if (o->multi == NULL) {
        *o->value = inline_arg;
        return true;
    }
    if (o->multi->n >= CLI_MULTI_MAX) {
        cli_error(CLI_EXIT_USAGE, cmd, "option %s given more than %d times",
                  spelled, CLI_MULTI_MAX);
        return false;
    }
    o->multi->v[o->multi->n++] = inline_arg;
    return true;
}

/* Report an unknown option, and where the help of its command is. */
static void unknown_option(const char *cmd, const char *a, size_t len)
{
    cli_error(CLI_EXIT_USAGE, cmd, "unknown option '%.*s' (see drcli%s%s --help)",
              (int)len, a, cmd != NULL ? " " : "", cmd != NULL ? cmd : "");
}

/* Apply the option argv[*i] (not "-", "--", "-h" or "--help"). */
static bool parse_one(const char *cmd, const cli_opt_t *opts, size_t nopts,
                      int *i, int argc, char **argv)
{
    const char *a = argv[*i];
    if (a[1] == '-') {
        const char *eq = strchr(a + 2, '=');
        size_t len = eq != NULL ? (size_t)(eq - (a + 2)) : strlen(a + 2);
        const cli_opt_t *o = find_long(opts, nopts, a + 2, len);
        if (o == NULL) {
            unknown_option(cmd, a, len + 2);
            return false;
        }
        return apply_opt(cmd, o, a, eq != NULL ? eq + 1 : NULL, i, argc, argv);
    }
    /* "-x" only: no bundling, to keep messages unambiguous. */
    const cli_opt_t *o = a[2] == '\0' ? find_short(opts, nopts, a[1]) : NULL;
    if (o == NULL) {
        unknown_option(cmd, a, strlen(a));
        return false;
    }
    return apply_opt(cmd, o, a, NULL, i, argc, argv);
}

int cli_parse_opts(const cli_cmd_t *cmd, int argc, char **argv,
                   const cli_opt_t *opts, size_t nopts, bool *help)
{
    int npos = 0;
    bool options_done = false;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (options_done || a[0] != '-' || strcmp(a, "-") == 0) {
            argv[npos++] = argv[i]; /* npos < i: nothing unread is lost */
        } else if (strcmp(a, "--") == 0) {
            options_done = true;
        } else if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            *help = true;
        } else if (!parse_one(cmd->name, opts, nopts, &i, argc, argv)) {
            return -1;
        }
    }
    return npos;
}

bool cli_parse_leading(int argc, char **argv, int *i, const cli_opt_t *opts,
                       size_t nopts)
{
    for (; *i < argc; ++*i) {
        const char *a = argv[*i];
        if (a[0] != '-' || a[1] == '\0' || strcmp(a, "--") == 0 ||
            strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0 ||
            strcmp(a, "-V") == 0 || strcmp(a, "--version") == 0)
            return true;
        if (!parse_one(NULL, opts, nopts, i, argc, argv))
            return false;
    }
    return true;
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
