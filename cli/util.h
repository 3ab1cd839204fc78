/* SPDX-License-Identifier: MIT */
/*
 * drcli helpers every command may use: assembly names and value ranges in
 * words, JSON output, bytes in and out. Failures are reported through
 * cli_error (error.h).
 */
#ifndef DRCLI_UTIL_H
#define DRCLI_UTIL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <jansson.h>

#include "drgate/codec.h"
#include "drgate/layout.h"

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

/* The images of the assemblies a command reads. */
typedef struct {
    bool want[DR_ASM_COUNT];
    uint8_t img[DR_ASM_COUNT][DR_ASM_MAX_SIZE];
} cli_images_t;

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

/* Print a [robot] section for drgatewayd's configuration (drcli probe,
 * drcli eds): a comment line, the header, host (tcp_port when not 44818),
 * the layout; per_assembly: the instances of inst[] (NULL: all 101..110)
 * that are not the defaults; combined and gpr_only: the two points. */
void cli_print_robot_section(const char *host, uint16_t tcp_port, dr_layout_kind_t kind,
                             const uint16_t *inst, unsigned in_instance, int in_size,
                             unsigned out_instance, int out_size);

#endif /* DRCLI_UTIL_H */
