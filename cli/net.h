/* SPDX-License-Identifier: MIT */
/*
 * What drcli's network commands (get, dump, set, watch, identity, probe)
 * share (net.c): their options, the client's configuration, the session,
 * reading assemblies and the one way failures are reported.
 */
#ifndef DRCLI_NET_H
#define DRCLI_NET_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/client.h"
#include "drgate/codec.h"
#include "drgate/layout.h"
#include "opt.h"
#include "util.h"

/* Options every network command takes, before or after the command's
 * name. Texts are checked by cli_net_config. */
typedef struct {
    const char *host;    /* -H, --host; else $DRCLI_HOST */
    const char *port;    /* --port */
    const char *timeout; /* --timeout MS */
    cli_multi_t instance; /* --instance ASSEMBLY=N (input=N, output=N) */
    const char *layout;  /* --layout per_assembly|combined|gpr_only */
    bool json, raw, route;
} cli_net_opts_t;

/* Number of entries cli_net_optv writes. */
#define CLI_NET_NOPTS 8

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
    const char *host;  /* as given */
    uint16_t tcp_port;
    uint32_t timeout_ms;
    /* --layout: per_assembly reads and writes each assembly's instance;
     * combined and gpr_only the input point (T->O) or the output point
     * (O->T) whole, and slice the assembly out of it. */
    dr_layout_t layout;
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

/* Read one assembly (Get_Attribute_Single of attribute 3): an image of
 * exactly the specification's size (in a combined layout, sliced out of
 * its point's image). Returns an exit code. */
int cli_net_read_asm(cli_net_t *net, dr_asm_t a, uint8_t *img);

/* Write one O->T assembly's image (Set_Attribute_Single of attribute 3;
 * in a combined layout: read the output point, put the image in its
 * place, write the point). Returns an exit code. */
int cli_net_write_asm(cli_net_t *net, dr_asm_t a, const uint8_t *img);

/* Read every wanted assembly, one request each. Returns an exit code. */
int cli_net_read(cli_net_t *net, cli_images_t *im);

/* "io_state (dr1, instance 101)" into out[size]. */
void cli_net_asm_label(const cli_net_t *net, dr_asm_t a, char *out, size_t size);

#endif /* DRCLI_NET_H */
