/* SPDX-License-Identifier: MIT */
/* The fields named on drcli's command line (fields.c): get, dump, watch
 * and set. */
#ifndef DRCLI_FIELDS_H
#define DRCLI_FIELDS_H

#include <stdbool.h>
#include <stddef.h>

#include <jansson.h>

#include "drgate/codec.h"
#include "util.h"

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

#endif /* DRCLI_FIELDS_H */
