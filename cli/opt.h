/* SPDX-License-Identifier: MIT */
/*
 * drcli's command-line options: a command describes its options in a
 * table of cli_opt_t, and one parser applies them. It knows nothing of the
 * commands: `cmd` (a command's name, or NULL before the command) only
 * names them in messages.
 */
#ifndef DRCLI_OPT_H
#define DRCLI_OPT_H

#include <stdbool.h>
#include <stddef.h>

/* Values of an option that may be given more than once (--instance). */
#define CLI_MULTI_MAX 32
typedef struct {
    const char *v[CLI_MULTI_MAX];
    size_t n;
} cli_multi_t;

/* One option: a flag (`value` and `multi` NULL) sets *flag; an option with
 * an argument ("--name=ARG", "--name ARG" or "-x ARG") stores it in *value,
 * or appends it to *multi if the option is repeatable. */
typedef struct {
    const char *long_name; /* without the leading "--" */
    char short_name;       /* 0 if none */
    bool *flag;
    const char **value;
    cli_multi_t *multi;
} cli_opt_t;

/* Split argv[1..argc) of command `cmd` into options (anywhere; "--" ends
 * them) and positional arguments, which are moved to argv[0..n) in their
 * order (argv[0], the command's name, is overwritten). "-h" and "--help"
 * set *help. Returns n, or -1 after printing what was wrong. */
int cli_parse_opts(const char *cmd, int argc, char **argv, const cli_opt_t *opts,
                   size_t nopts, bool *help);

/* Parse options from argv[*i] on, up to the first argument that is not one
 * (the command's name): main's options before the command. Returns false
 * after printing what was wrong. */
bool cli_parse_leading(int argc, char **argv, int *i, const cli_opt_t *opts,
                       size_t nopts);

#endif /* DRCLI_OPT_H */
