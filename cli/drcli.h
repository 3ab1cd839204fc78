/* SPDX-License-Identifier: MIT */
/*
 * drcli internals shared by the command files under cli/.
 *
 * Each command lives in its own file and exports one cli_cmd_t; drcli.c
 * holds the table of commands, main() and the helpers below. The network
 * commands (get, dump, set, watch, identity, probe) share their options,
 * the connection and the error reporting through net.c (cli_net_*).
 */
#ifndef DRCLI_H
#define DRCLI_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "drgate/client.h"
#include "drgate/codec.h"

/* Exit codes, the same for every command (documented in drcli(1)). */
enum {
    CLI_EXIT_OK = 0,      /* success */
    CLI_EXIT_FAIL = 1,    /* anything else: writing output failed, no memory */
    CLI_EXIT_USAGE = 2,   /* bad command line or bad input data */
    CLI_EXIT_NETWORK = 3, /* network error or timeout (network commands) */
    CLI_EXIT_CIP = 4      /* the device answered with a CIP error */
};

/* ---- command-line options -------------------------------------------- */

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

/* Options every network command takes (net.c), before or after the
 * command's name. Texts are checked by cli_net_config. */
typedef struct {
    const char *host;    /* -H, --host; else $DRCLI_HOST */
    const char *port;    /* --port */
    const char *timeout; /* --timeout MS */
    cli_multi_t instance; /* --instance ASSEMBLY=N */
    bool json, raw, route;
} cli_net_opts_t;

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

/* Split argv[1..argc) into options (anywhere; "--" ends them) and
 * positional arguments, which are moved to argv[0..n) in their order
 * (argv[0], the command's name, is overwritten). "-h" and "--help" set
 * *help. Returns n, or -1 after printing what was wrong. */
int cli_parse_opts(const cli_cmd_t *cmd, int argc, char **argv,
                   const cli_opt_t *opts, size_t nopts, bool *help);

/* Parse options from argv[*i] on, up to the first argument that is not one
 * (the command's name): main's options before the command. `cmd` is NULL
 * for messages. Returns false after printing what was wrong. */
bool cli_parse_leading(int argc, char **argv, int *i, const cli_opt_t *opts,
                       size_t nopts);

/* ---- messages ----------------------------------------------------------- */

/* "drcli CMD: message" on stderr; always returns `code` for `return
 * cli_error(...)`. */
int cli_error(int code, const char *cmd, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* Print the full help of a command on stdout; the line CLI_NET_HELP in it
 * becomes the text of the network options. */
#define CLI_NET_HELP "@network-options@\n"
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

/* Same with other jansson flags (CLI_JSON_LINE: one object per line). */
#define CLI_JSON_LINE (JSON_COMPACT | JSON_REAL_PRECISION(9))
int cli_json_print_flags(const char *cmd, json_t *value, size_t flags);

/* The JSON value of one leaf: true/false, integer or cli_json_real. */
json_t *cli_json_value(const dr_value_t *v);

/* Add what `ref` names in the image img[0..len) to `obj` under canonical
 * leaf paths: one key for a leaf, one per bit for a whole mask. Returns
 * false if out of memory. */
bool cli_json_add_ref(json_t *obj, const uint8_t *img, size_t len, dr_ref_t ref);

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

/* Bytes as one string of hex digit pairs separated by spaces, in out[size]
 * (cut short if it does not fit). */
void cli_hex_string(const uint8_t *buf, size_t len, char *out, size_t size);

/* An image as hex, 16 bytes a line, each line led by the decimal offset of
 * its first byte (as `drcli list` gives offsets) and indented. */
void cli_print_raw(const uint8_t *img, size_t len);

/* ---- network commands (net.c) ------------------------------------------ */

/* Number of entries cli_net_optv writes. */
#define CLI_NET_NOPTS 7

/* Write the table of the network options, storing into *o, to out[]; returns
 * CLI_NET_NOPTS. A command appends its own options after them. */
size_t cli_net_optv(cli_net_opts_t *o, cli_opt_t *out);

/* A whole decimal number (digits only) in min..max. */
bool cli_parse_ulong(const char *text, unsigned long min, unsigned long max,
                     unsigned long *out);

/* Was any network option given? */
bool cli_net_any(const cli_net_opts_t *o);

/* The option text of the network options, for the commands' help. */
extern const char cli_net_help[];

/* Refuse --json or --raw where a command has no use for them. Returns an
 * exit code (CLI_EXIT_OK if none was refused). */
int cli_net_refuse(const char *cmd, const cli_net_opts_t *o, bool json_ok,
                   bool raw_ok);

/* Validate the network options into a client configuration (host, ports,
 * timeout, instances). Returns CLI_EXIT_OK or CLI_EXIT_USAGE after
 * printing what was wrong. Nothing is sent. */
int cli_net_config(const char *cmd, const cli_net_opts_t *o,
                   dr_client_config_t *cfg);

/* A connected client and what error messages need to name. */
typedef struct {
    const char *cmd;
    dr_client_t *client;
    char where[300]; /* "host:port" */
    uint32_t timeout_ms;
} cli_net_t;

/* Create the client and register a session. Returns an exit code; on
 * failure the message names host:port and the step. */
int cli_net_connect(const char *cmd, const dr_client_config_t *cfg,
                    cli_net_t *net);

/* Unregister and free (bounded by the client's timeout). */
void cli_net_close(cli_net_t *net);

/* Print "drcli CMD: host:port: step[ what]: message" for a failed call and
 * return its exit code: CLI_EXIT_CIP for CIP errors, CLI_EXIT_NETWORK for
 * everything else (network, timeouts, encapsulation, malformed replies). */
int cli_net_fail(cli_net_t *net, dr_status_t st, const char *what);

/* Exit code of a failed call's status (as cli_net_fail). */
int cli_net_exit_code(dr_status_t st);

/* The images of the assemblies a command reads. */
typedef struct {
    bool want[DR_ASM_COUNT];
    uint8_t img[DR_ASM_COUNT][DR_ASM_MAX_SIZE];
} cli_images_t;

/* Read one assembly (Get_Attribute_Single of attribute 3): an image of
 * exactly the specification's size. Returns an exit code. */
int cli_net_read_asm(cli_net_t *net, dr_asm_t a, uint8_t *img);

/* Read every wanted assembly, one request each. Returns an exit code. */
int cli_net_read(cli_net_t *net, cli_images_t *im);

/* "io_state (dr1, instance 101)" into out[size]. */
void cli_net_asm_label(const cli_net_t *net, dr_asm_t a, char *out, size_t size);

/* ---- fields named on the command line (fields.c) -------------------------- */

#define CLI_ITEMS_MAX 1024 /* refs one command prints; all ten assemblies: 388 */

typedef struct {
    dr_ref_t ref[CLI_ITEMS_MAX];
    size_t n;
} cli_items_t;

/* Append every field of assembly `a` as dump prints them: each mask before
 * its bits, then every leaf. False (nothing added) if they do not fit. */
bool cli_items_add_asm(cli_items_t *it, dr_asm_t a);

/* Append what argument `arg` names: a full field path (one leaf or a whole
 * mask) or, if `asm_ok`, an assembly name or alias (all its fields). On
 * failure prints why (the closest known field for an unknown one) and
 * returns false. */
bool cli_items_add_arg(const char *cmd, cli_items_t *it, int argno,
                       const char *arg, bool asm_ok);

/* Resolve the full field path path[0..len) of argument number `argno`
 * (`arg` as given, for messages): unknown fields name the closest known
 * one, index problems the valid range. Prints why and returns false on
 * failure. */
bool cli_resolve_path(const char *cmd, int argno, const char *arg,
                      const char *path, size_t len, dr_ref_t *out);

/* Check one "FIELD=VALUE" argument of drcli set (number `argno`): a full
 * path of an O->T field and a value that fits it, into *ref and *value.
 * Prints why and returns false if it is not one. */
bool cli_parse_assignment(const char *cmd, int argno, const char *arg,
                          dr_ref_t *ref, dr_value_t *value);

/* Mark the assemblies the items live in. */
void cli_items_want(const cli_items_t *it, cli_images_t *im);

/* Format the value `ref` names in the images, as dr_text_format does with
 * `flags`. */
void cli_format_ref(const cli_images_t *im, dr_ref_t ref, unsigned flags,
                    char *out, size_t size);

/* Add every item to a JSON object (leaf paths as keys; masks as their
 * bits). NULL if out of memory. */
json_t *cli_items_json(const cli_items_t *it, const cli_images_t *im);

#endif /* DRCLI_H */
