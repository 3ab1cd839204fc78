/* SPDX-License-Identifier: MIT */
/*
 * A drcli command: each command file (list.c, decode.c, encode.c, get.c,
 * set.c, watch.c, identity.c) exports one cli_cmd_t, and drcli.c's main()
 * holds the table of them. The commands' shared parts live below this
 * header, each with its own: opt.h, error.h, util.h, fields.h, net.h.
 */
#ifndef DRCLI_CMD_H
#define DRCLI_CMD_H

#include <stdbool.h>

#include "net.h"

typedef struct {
    const char *name;
    const char *summary; /* one line for `drcli --help` */
    const char *help;    /* full text for `drcli NAME --help` */
    /* `lead`: the network options given before the command's name. */
    int (*run)(const char *name, int argc, char **argv,
               const cli_net_opts_t *lead);
    bool network;        /* takes the network options */
} cli_cmd_t;

extern const cli_cmd_t cli_cmd_list;
extern const cli_cmd_t cli_cmd_decode;
extern const cli_cmd_t cli_cmd_encode;
extern const cli_cmd_t cli_cmd_get;
extern const cli_cmd_t cli_cmd_dump;
extern const cli_cmd_t cli_cmd_set;
extern const cli_cmd_t cli_cmd_watch;
extern const cli_cmd_t cli_cmd_identity;
extern const cli_cmd_t cli_cmd_probe;
extern const cli_cmd_t cli_cmd_eds;

/* Print the full help of a command on stdout; the line CLI_NET_HELP in it
 * becomes the text of the network options. */
#define CLI_NET_HELP "@network-options@\n"
void cli_print_help(const cli_cmd_t *cmd);

#endif /* DRCLI_CMD_H */
