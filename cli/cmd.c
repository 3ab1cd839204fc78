/* SPDX-License-Identifier: MIT */
/* What every drcli command shares (cmd.h): its help text. */
#include <stdio.h>
#include <string.h>

#include "cmd.h"

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
