/* SPDX-License-Identifier: MIT */
/*
 * The user's register map (docs/register-map.md "Your own map"): the
 * `map` lines of [robot NAME] parsed and checked, without the loader's
 * context so that tests and the fuzz harness call them directly.
 *
 *   map = TABLE ADDRESS PATH[RANGE] [VIEW] [writable] [saturate] [scale=N] [lo|hi]
 *
 * TABLE hr, ir, co, di; ADDRESS 0..65535 (0-based, as on the wire); PATH
 * a canonical field path, RANGE [a..b] in the field's numbering; VIEW
 * real, dint, int16, uint16, bits (registers), bit (coils and discrete
 * inputs, the default there).
 */
#ifndef DRGATE_GW_USERMAP_H
#define DRGATE_GW_USERMAP_H

#include <stdbool.h>
#include <stddef.h>

#include "core/config.h"

/* One `map` value, written at `line`, into *e. False with the reason in
 * err[errlen] (no FILE:LINE: the caller adds it). */
bool gw_umap_parse(const char *value, unsigned line, gw_umap_entry_t *e, char *err,
                   size_t errlen);

/* Add e to m, kept sorted; refuses a block that overlaps another entry of
 * m or an address of the default map, or a full map. */
bool gw_umap_add(gw_umap_t *m, const gw_umap_entry_t *e, char *err, size_t errlen);

/* "hr", "ir", "co", "di"; the views' names. */
const char *gw_umap_table_name(unsigned table);
const char *gw_umap_view_name(unsigned view);

#endif /* DRGATE_GW_USERMAP_H */
