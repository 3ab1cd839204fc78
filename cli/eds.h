/* SPDX-License-Identifier: MIT */
/*
 * EDS files (ODVA Electronic Data Sheets) for drcli eds: the reader.
 *
 * cli_eds_parse() reads the text of an EDS from a buffer (not
 * NUL-terminated) into a plain struct the caller owns: the device's
 * identity, the assemblies ([Assembly], also spelled [Assem]), the
 * connections of [Connection Manager] and the numeric parameters
 * ([Params]) they refer to. No malloc, no stdio: every table has a bound
 * below, every string is cut to its buffer, every length is checked.
 *
 * The syntax (ODVA Vol. 1, chapter 7): sections `[Name]`; entries
 * `Keyword = field, field, ... ;` that may span lines; `$` starts a
 * comment to the end of the line (outside strings); strings in double
 * quotes, adjacent strings joined ("ab" "cd" is "abcd"), no string across
 * a line end; `{ ... }` groups a structured field.
 *
 * A malformed file is refused: cli_eds_parse returns false with the line
 * and what is wrong. What is well formed but not usable for a plan (a
 * Class 3 connection, a symbolic path, a table full) lands in the notes,
 * each with its line.
 */
#ifndef DRCLI_EDS_H
#define DRCLI_EDS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define CLI_EDS_MAX_ASSEM 64u
#define CLI_EDS_MAX_CONN 32u
#define CLI_EDS_MAX_PARAM 2048u
#define CLI_EDS_MAX_NOTES 16u
#define CLI_EDS_NAME 64u  /* names and strings kept, NUL included */
#define CLI_EDS_NOTE 160u

/* One [Assembly] entry: AssemN = name, path, size, descriptor, , ,
 * {member size in bits, member reference}...; */
typedef struct {
    uint32_t number;   /* N of AssemN */
    uint32_t instance; /* from the path (0x24/0x25 segment), else N */
    int32_t size;      /* bytes; -1: not given and no members */
    unsigned members;
    unsigned line;
    char name[CLI_EDS_NAME];
} cli_eds_assem_t;

/* A size, RPI or format field of a connection: a number, a reference
 * (ParamN, AssemN) or empty. */
typedef struct {
    char kind;       /* 0 empty, 'n' number, 'P' ParamN, 'A' AssemN */
    uint32_t value;  /* the number, or N */
} cli_eds_ref_t;

/* One [Connection Manager] entry (ConnectionN = trigger and transport,
 * connection parameters, O->T RPI, O->T size, O->T format, T->O RPI,
 * T->O size, T->O format, config #1 size, config #1 format, config #2
 * size, config #2 format, name, help, path;). */
typedef struct {
    uint32_t number;
    unsigned line;
    uint32_t trigger;       /* field 1 */
    uint32_t params;        /* field 2 */
    cli_eds_ref_t ot_rpi, ot_size, ot_format, to_rpi, to_size, to_format;
    cli_eds_ref_t cfg_size, cfg_format;
    char name[CLI_EDS_NAME];
    /* From the path (field 15): the instance (0x24/0x25) and the two
     * connection points (0x2C/0x2D, consumed O->T then produced T->O);
     * 0: not in the path. path_ok false: the path is not hex bytes (a
     * symbolic or parameterised path). */
    bool path_ok;
    uint32_t path_config, path_ot, path_to;
} cli_eds_conn_t;

/* Transport class and type bits of field 1 (trigger and transport). */
#define CLI_EDS_CLASS1 (1u << 1)
#define CLI_EDS_CYCLIC (1u << 16)
#define CLI_EDS_LISTEN_ONLY (1u << 24)
#define CLI_EDS_INPUT_ONLY (1u << 25)
#define CLI_EDS_EXCLUSIVE (1u << 26)
#define CLI_EDS_REDUNDANT (1u << 27)

/* One numeric parameter: ParamN's minimum, maximum and default
 * (fields 10, 11, 12) when they are integers. */
typedef struct {
    uint32_t number;
    unsigned line;
    bool has_min, has_max, has_def;
    uint32_t min, max, def;
    char units[16];
} cli_eds_param_t;

typedef struct {
    /* [Device] */
    uint32_t vendor, product_type, product_code, major_rev, minor_rev;
    char vendor_name[CLI_EDS_NAME], product_name[CLI_EDS_NAME], catalog[CLI_EDS_NAME];
    /* [Device Classification]: Class1 = EtherNetIP */
    bool ethernetip;
    cli_eds_assem_t assem[CLI_EDS_MAX_ASSEM];
    unsigned n_assem;
    cli_eds_conn_t conn[CLI_EDS_MAX_CONN];
    unsigned n_conn;
    cli_eds_param_t param[CLI_EDS_MAX_PARAM];
    unsigned n_param;
    char note[CLI_EDS_MAX_NOTES][CLI_EDS_NOTE]; /* what could not be used */
    unsigned note_line[CLI_EDS_MAX_NOTES];
    unsigned n_note;
    unsigned lost_notes; /* notes beyond CLI_EDS_MAX_NOTES */
    unsigned lines;      /* lines in the file */
} cli_eds_t;

/* Parse text[len] into *out (overwritten). Returns true for a well
 * formed EDS with [File] and [Device] (VendCode, ProdCode, MajRev, MinRev,
 * ProdName); every AssemN, ParamN a connection names must exist, and
 * an assembly's members must add up to its size. On false, *line is the
 * line (1-based) and err[errsize] says what is wrong (one line, always
 * terminated when errsize > 0); *out is then unspecified. */
bool cli_eds_parse(const char *text, size_t len, cli_eds_t *out, unsigned *line,
                   char *err, size_t errsize);

/* Add a note (what could not be used) at `line`; printf-like; counted in
 * lost_notes when the table is full. */
void cli_eds_note(cli_eds_t *eds, unsigned line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The assembly whose number is n (AssemN), or NULL. */
const cli_eds_assem_t *cli_eds_assem(const cli_eds_t *eds, uint32_t n);

/* The parameter whose number is n (ParamN), or NULL. */
const cli_eds_param_t *cli_eds_param(const cli_eds_t *eds, uint32_t n);

/* A connection's size field resolved to bytes: a number, the parameter's
 * default, or the size of the assembly its format names. -1: unknown. */
int32_t cli_eds_size(const cli_eds_t *eds, cli_eds_ref_t size, cli_eds_ref_t format);

/* The instance a connection's format names (its assembly's instance),
 * else `from_path`. 0: unknown. */
uint32_t cli_eds_instance(const cli_eds_t *eds, cli_eds_ref_t format, uint32_t from_path);

#endif /* DRCLI_EDS_H */
