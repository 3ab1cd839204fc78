/* SPDX-License-Identifier: MIT */
/*
 * EDS files (ODVA Electronic Data Sheets): the reader (eds.c) and the
 * connection plan an EDS gives (eds_plan.c), shared by drcli eds and
 * drgatewayd's `eds` key of [robot].
 *
 * eds_parse() reads the text of an EDS from a buffer (not
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
 * A malformed file is refused: eds_parse returns false with the line
 * and what is wrong. What is well formed but not usable for a plan (a
 * Class 3 connection, a symbolic path, a table full) lands in the notes,
 * each with its line.
 */
#ifndef DRGATE_COMMON_EDS_H
#define DRGATE_COMMON_EDS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "drgate/layout.h"

#define EDS_MAX_ASSEM 64u
#define EDS_MAX_CONN 32u
#define EDS_MAX_PARAM 2048u
#define EDS_MAX_NOTES 16u
#define EDS_NAME 64u  /* names and strings kept, NUL included */
#define EDS_NOTE 160u

/* One [Assembly] entry: AssemN = name, path, size, descriptor, , ,
 * {member size in bits, member reference}...; */
typedef struct {
    uint32_t number;   /* N of AssemN */
    uint32_t instance; /* from the path (0x24/0x25 segment), else N */
    int32_t size;      /* bytes; -1: not given and no members */
    unsigned members;
    unsigned line;
    char name[EDS_NAME];
} eds_assem_t;

/* A size, RPI or format field of a connection: a number, a reference
 * (ParamN, AssemN) or empty. */
typedef struct {
    char kind;       /* 0 empty, 'n' number, 'P' ParamN, 'A' AssemN */
    uint32_t value;  /* the number, or N */
} eds_ref_t;

/* One [Connection Manager] entry (ConnectionN = trigger and transport,
 * connection parameters, O->T RPI, O->T size, O->T format, T->O RPI,
 * T->O size, T->O format, config #1 size, config #1 format, config #2
 * size, config #2 format, name, help, path;). */
typedef struct {
    uint32_t number;
    unsigned line;
    uint32_t trigger;       /* field 1 */
    uint32_t params;        /* field 2 */
    eds_ref_t ot_rpi, ot_size, ot_format, to_rpi, to_size, to_format;
    eds_ref_t cfg_size, cfg_format;
    char name[EDS_NAME];
    /* From the path (field 15): the instance (0x24/0x25) and the two
     * connection points (0x2C/0x2D, consumed O->T then produced T->O);
     * 0: not in the path. path_ok false: the path is not hex bytes (a
     * symbolic or parameterised path). */
    bool path_ok;
    uint32_t path_config, path_ot, path_to;
} eds_conn_t;

/* Transport class and type bits of field 1 (trigger and transport). */
#define EDS_CLASS1 (1u << 1)
#define EDS_CYCLIC (1u << 16)
#define EDS_LISTEN_ONLY (1u << 24)
#define EDS_INPUT_ONLY (1u << 25)
#define EDS_EXCLUSIVE (1u << 26)
#define EDS_REDUNDANT (1u << 27)

/* One numeric parameter: ParamN's minimum, maximum and default
 * (fields 10, 11, 12) when they are integers. */
typedef struct {
    uint32_t number;
    unsigned line;
    bool has_min, has_max, has_def;
    uint32_t min, max, def;
    char units[16];
} eds_param_t;

typedef struct {
    /* [Device] */
    uint32_t vendor, product_type, product_code, major_rev, minor_rev;
    char vendor_name[EDS_NAME], product_name[EDS_NAME], catalog[EDS_NAME];
    /* [Device Classification]: Class1 = EtherNetIP */
    bool ethernetip;
    eds_assem_t assem[EDS_MAX_ASSEM];
    unsigned n_assem;
    eds_conn_t conn[EDS_MAX_CONN];
    unsigned n_conn;
    eds_param_t param[EDS_MAX_PARAM];
    unsigned n_param;
    char note[EDS_MAX_NOTES][EDS_NOTE]; /* what could not be used */
    unsigned note_line[EDS_MAX_NOTES];
    unsigned n_note;
    unsigned lost_notes; /* notes beyond EDS_MAX_NOTES */
    unsigned lines;      /* lines in the file */
} eds_t;

/* Parse text[len] into *out (overwritten). Returns true for a well
 * formed EDS with [File] and [Device] (VendCode, ProdCode, MajRev, MinRev,
 * ProdName); every AssemN, ParamN a connection names must exist, and
 * an assembly's members must add up to its size. On false, *line is the
 * line (1-based) and err[errsize] says what is wrong (one line, always
 * terminated when errsize > 0); *out is then unspecified. */
bool eds_parse(const char *text, size_t len, eds_t *out, unsigned *line,
                   char *err, size_t errsize);

/* Add a note (what could not be used) at `line`; printf-like; counted in
 * lost_notes when the table is full. */
void eds_note(eds_t *eds, unsigned line, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;

/* The assembly whose number is n (AssemN), or NULL. */
const eds_assem_t *eds_assem(const eds_t *eds, uint32_t n);

/* The parameter whose number is n (ParamN), or NULL. */
const eds_param_t *eds_param(const eds_t *eds, uint32_t n);

/* A connection's size field resolved to bytes: a number, the parameter's
 * default, or the size of the assembly its format names. -1: unknown. */
int32_t eds_size(const eds_t *eds, eds_ref_t size, eds_ref_t format);

/* The instance a connection's format names (its assembly's instance),
 * else `from_path`. 0: unknown. */
uint32_t eds_instance(const eds_t *eds, eds_ref_t format, uint32_t from_path);

/* ---- the plan (eds_plan.c) ------------------------------------------------ */

/* drgatewayd's default heartbeat connection points (configuration.md) */
#define EDS_HB_INPUT_ONLY 198u
#define EDS_HB_LISTEN_ONLY 199u

/* "exclusive owner", "redundant owner", "input only", "listen only" or
 * "no type", from a connection's trigger and transport field. */
const char *eds_type_name(uint32_t trigger);

/* One Class 1 connection resolved: instances, sizes, RPI range (us). */
typedef struct {
    const eds_conn_t *c;
    uint32_t ot_inst, to_inst;
    int32_t ot_size, to_size;
    bool has_rpi;
    uint32_t rpi_min, rpi_max, rpi_def;
} eds_conn_plan_t;

/* What an EDS says for drgatewayd's [robot]: the layout its sizes match,
 * the connection the plan takes (the first exclusive owner, else the
 * first input-only one), its points and RPI. */
typedef struct {
    eds_conn_plan_t conn[EDS_MAX_CONN]; /* the Class 1 connections */
    unsigned nconn;
    int main_i, in_only_i, listen_i; /* indexes into conn[]; -1: none */
    int plan_i;                      /* main_i, else in_only_i */
    bool matched;
    dr_layout_kind_t kind;
    uint32_t in_instance, out_instance; /* out 0: input-only, no output */
    uint16_t in_size, out_size;
    uint32_t config_instance;           /* 0: not named */
    uint32_t input_only_hb, listen_only_hb; /* 0: not named */
    unsigned rpi_ms;    /* the EDS's default (else 10) inside its range;
                           0: no range, or no whole ms fits */
    bool has_rpi;       /* the connection giving the RPI has a range: */
    uint32_t rpi_min_us, rpi_max_us;
    uint32_t rpi_conn;  /* N of its ConnectionN */
    unsigned rpi_line;  /* its line */
    unsigned plan_line; /* line of the plan's connection; 0: none */
} eds_plan_t;

/* The plan of a parsed EDS; what it cannot use goes into eds's notes
 * (Class 3 connections, symbolic paths, configuration data, connections
 * beside the plan's). conn[].c point into *eds (valid while it is); the
 * other members are copies, for use after it is gone. */
void eds_plan(eds_t *eds, eds_plan_t *out);

/* The rpi_ms drgatewayd would use for a connection: its default, else
 * 10, inside its range and 1..10000; 0 if no whole number of ms fits. */
unsigned eds_pick_rpi_ms(const eds_conn_plan_t *p);

#endif /* DRGATE_COMMON_EDS_H */
