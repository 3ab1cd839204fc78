/* SPDX-License-Identifier: MIT */
/* drcli's option parser (opt.h). */
#include <string.h>

#include "error.h"
#include "opt.h"

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

int cli_parse_opts(const char *cmd, int argc, char **argv, const cli_opt_t *opts,
                   size_t nopts, bool *help)
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
        } else if (!parse_one(cmd, opts, nopts, &i, argc, argv)) {
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
