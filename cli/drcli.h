/* SPDX-License-Identifier: MIT */
/*
 * drcli internals shared by the command files under cli/.
 *
 * Each command lives in its own file and exports one cli_cmd_t; drcli.c
 * holds the table of commands, main() and the helpers below. A network
 * command (get, dump, set, watch, identity, probe) is added the same way:
 * a new cli/NAME.c with a cli_cmd_t, one line in the table in drcli.c.
 */
#ifndef DRCLI_H
#define DRCLI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "drgate/codec.h"

/* Exit codes, the same for every command (documented in drcli(1)). */
enum {
    CLI_EXIT_OK = 0,      /* success */
    CLI_EXIT_FAIL = 1,    /* anything else: writing output failed, no memory */
    CLI_EXIT_USAGE = 2,   /* bad command line or bad input data */
    CLI_EXIT_NETWORK = 3, /* network error or timeout (network commands) */
    CLI_EXIT_CIP = 4      /* the device answered with a CIP error */
};

typedef struct {
    const char *name;
    const char *summary; /* one line for `drcli --help` */
    const char *help;    /* full text for `drcli NAME --help` */
    int (*run)(const char *name, int argc, char **argv);
} cli_cmd_t;

extern const cli_cmd_t cli_cmd_list;
extern const cli_cmd_t cli_cmd_decode;
extern const cli_cmd_t cli_cmd_encode;

/* ---- command-line options -------------------------------------------- */

/* One option: a flag (`value` NULL) sets *flag; an option with an argument
 * (`value` non-NULL) stores it in *value ("--name=ARG", "--name ARG" or
 * "-x ARG"). */
typedef struct {
    const char *long_name; /* without the leading "--" */
    char short_name;       /* 0 if none */
    bool *flag;
    const char **value;
} cli_opt_t;

/* Split argv[1..argc) into options (anywhere; "--" ends them) and
 * positional arguments, which are moved to argv[0..n) in their order
 * (argv[0], the command's name, is overwritten). "-h" and "--help" set
 * *help. Returns n, or -1 after printing what was wrong. */
int cli_parse_opts(const cli_cmd_t *cmd, int argc, char **argv,
                   const cli_opt_t *opts, size_t nopts, bool *help);

/* ---- messages ----------------------------------------------------------- */

/* "drcli CMD: message" on stderr; always returns `code` for `return
 * cli_error(...)`. */
int cli_error(int code, const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Print the full help of a command on stdout. */
void cli_print_help(const cli_cmd_t *cmd);

/* ---- assemblies, values --------------------------------------------------- */

/* Look an assembly up by name or alias; on failure print what was given and
 * the closest known name, and return false. */
bool cli_lookup_asm(const char *cmd, const char *name, dr_asm_t *out);

/* "T->O" or "O->T". */
const char *cli_dir_name(dr_dir_t dir);

/* Type of what `ref` names: "BOOL", "16-bit mask", "REAL", ... */
const char *cli_type_name(dr_ref_t ref);

/* What values the field `ref` names accepts, for error messages:
 * "0..255", "0 or 1 (or true/false)", ... */
void cli_describe_range(dr_ref_t ref, char *out, size_t size);

/* ---- JSON ------------------------------------------------------------- */

/* Flags for json_dumpf everywhere, see cli_json_real. */
#define CLI_JSON_FLAGS (JSON_INDENT(2) | JSON_REAL_PRECISION(9))

/* A binary32 value as JSON: a number that prints (with CLI_JSON_FLAGS) as
 * the shortest decimal that reads back to the same float; "nan", "inf" or
 * "-inf" as strings, because JSON has no such numbers. NULL if out of
 * memory. */
json_t *cli_json_real(float f);

/* Print `value` (consumed) on stdout followed by a newline. Returns an exit
 * code. */
int cli_json_print(const char *cmd, json_t *value);

/* ---- bytes in and out --------------------------------------------------- */

#define CLI_INPUT_MAX 65536u /* bytes read from a file or stdin, at most */

/* Read all of `path` ("-" = stdin) into buf[CLI_INPUT_MAX]; sets *len.
 * Returns false after printing an error naming the file. */
bool cli_read_input(const char *cmd, const char *path, uint8_t *buf,
                    size_t *len);

/* Turn hex text in buf[0..*len) into bytes, in place. Whitespace may
 * separate bytes but not split one. Returns false after printing an error
 * with the line and column of the problem. */
bool cli_parse_hex(const char *cmd, const char *path, uint8_t *buf,
                   size_t *len);

/* Print bytes as hex, 16 per line, separated by spaces. */
void cli_print_hex(const uint8_t *buf, size_t len);

#endif /* DRCLI_H */
