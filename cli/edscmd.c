/* SPDX-License-Identifier: MIT */
/*
 * drcli eds: read a vendor's EDS into a connection plan and a [robot]
 * section (the reader is eds.c), or write drsim's EDS from the field
 * table (--write).
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cmd.h"
#include "common/eds.h"
#include "error.h"
#include "opt.h"
#include "util.h"

#include "drgate/layout.h"

#define EDS_FILE_MAX (1u << 20) /* an EDS larger than 1 MiB is refused */
/* drsim's limits and identity (sim/adapter.h), written into its EDS */
#define EDS_SIM_RPI_MIN_US 1000u
#define EDS_SIM_RPI_MAX_US 10000000u
#define EDS_SIM_RPI_DEF_US 10000u
#define EDS_SIM_VENDOR 0xFFFFu
#define EDS_SIM_DEVICE_TYPE 0x0Cu
#define EDS_SIM_PRODUCT_CODE 1u
#define EDS_SIM_PRODUCT_NAME "drsim Doosan robot simulator"

static const char eds_help[] =
    "usage: drcli eds [-H HOST] FILE.eds\n"
    "       drcli eds --write [--layout NAME]\n"
    "\n"
    "Reads an EDS (Electronic Data Sheet, the ODVA format) and derives the\n"
    "connection plan: the device, its assemblies ([Assembly]: instances and\n"
    "sizes), its Class 1 connections ([Connection Manager]: type, input and\n"
    "output instances and sizes, configuration instance, RPI range), the\n"
    "layout they match (per_assembly: the ten at 101..110 with their sizes;\n"
    "combined: 476 and 212 bytes; gpr_only: 200 and 200) and a [robot]\n"
    "section for drgatewayd's configuration, host HOST (-H) or 192.0.2.1.\n"
    "Then, with FILE:LINE, what it could not use. A malformed EDS is\n"
    "refused with FILE:LINE and what is wrong.\n"
    "\n"
    "With --write: drsim's EDS on standard output, from the field table:\n"
    "every field a parameter with its unit, the assemblies of the layout\n"
    "NAME (per_assembly, the default; combined; gpr_only) with their\n"
    "members, and the Class 1 connections of drgatewayd's plan for it.\n"
    "\n"
    "options:\n"
    "  -H, --host HOST     the controller's address, for the [robot] section\n"
    "  -w, --write         write drsim's EDS instead of reading one\n"
    "  -l, --layout NAME   with --write: the layout (default per_assembly)\n"
    "  -h, --help          this text\n"
    "\n"
    "Exit status: 0 a layout matched (or written), 1 none matched, 2 usage\n"
    "or a malformed EDS.\n";

/* ---- reading ------------------------------------------------------------- */

static bool read_file(const char *cmd, const char *path, char *buf, size_t cap, size_t *len)
{
    FILE *fp = strcmp(path, "-") == 0 ? stdin : fopen(path, "rb");
    if (fp == NULL) {
        cli_error(CLI_EXIT_USAGE, cmd, "%s: cannot open: %s", path, strerror(errno));
        return false;
    }
    size_t n = fread(buf, 1, cap, fp);
    bool ok = !ferror(fp), big = n == cap && fgetc(fp) != EOF;
    if (fp != stdin)
        (void)fclose(fp);
    if (!ok)
        cli_error(CLI_EXIT_USAGE, cmd, "%s: cannot read", path);
    else if (big)
        cli_error(CLI_EXIT_USAGE, cmd, "%s: larger than %u bytes: not an EDS", path,
                  (unsigned)cap);
    *len = n;
    return ok && !big;
}

static void print_us(uint32_t us)
{
    if (us % 1000u == 0)
        printf("%lu", (unsigned long)(us / 1000u));
    else
        printf("%lu.%03lu", (unsigned long)(us / 1000u), (unsigned long)(us % 1000u));
}

static void print_conn(const eds_conn_plan_t *p)
{
    const eds_conn_t *c = p->c;
    printf("  Connection%lu \"%s\": %s%s; O->T ", (unsigned long)c->number, c->name,
           eds_type_name(c->trigger), c->trigger & EDS_CYCLIC ? ", cyclic" : "");
    if (p->ot_inst != 0)
        printf("instance %lu, ", (unsigned long)p->ot_inst);
    if (p->ot_size >= 0)
        printf("%ld bytes", (long)p->ot_size);
    else
        printf("size unknown");
    printf("; T->O ");
    if (p->to_inst != 0)
        printf("instance %lu, ", (unsigned long)p->to_inst);
    if (p->to_size >= 0)
        printf("%ld bytes", (long)p->to_size);
    else
        printf("size unknown");
    if (c->path_config != 0)
        printf("; configuration instance %lu", (unsigned long)c->path_config);
    if (p->has_rpi) {
        printf("; RPI ");
        print_us(p->rpi_min);
        printf("..");
        print_us(p->rpi_max);
        printf(" ms");
        if (p->rpi_def != 0) {
            printf(" (default ");
            print_us(p->rpi_def);
            printf(")");
        }
    }
    printf("\n");
}

static int run_read(const char *cmd, const char *path, const char *host)
{
    static char text[EDS_FILE_MAX];
    static eds_t eds;
    size_t len = 0;
    if (!read_file(cmd, path, text, sizeof text, &len))
        return CLI_EXIT_USAGE;
    char err[160];
    unsigned line = 0;
    if (!eds_parse(text, len, &eds, &line, err, sizeof err))
        return cli_error(CLI_EXIT_USAGE, cmd, "%s:%u: %s", path, line, err);
    const eds_t *e = &eds;

    printf("device: vendor %lu \"%s\", product type %lu, product code %lu, revision "
           "%lu.%lu, \"%s\"", (unsigned long)e->vendor, e->vendor_name,
           (unsigned long)e->product_type, (unsigned long)e->product_code,
           (unsigned long)e->major_rev, (unsigned long)e->minor_rev, e->product_name);
    if (e->catalog[0] != '\0')
        printf(" (catalog \"%s\")", e->catalog);
    printf("\n");
    if (!e->ethernetip)
        eds_note(&eds, 1, "[Device Classification] does not say EtherNetIP");
    printf("assemblies: %u\n", e->n_assem);
    for (unsigned i = 0; i < e->n_assem; i++) {
        const eds_assem_t *a = &e->assem[i];
        printf("  Assem%lu \"%s\": instance %lu, ", (unsigned long)a->number, a->name,
               (unsigned long)a->instance);
        if (a->size >= 0)
            printf("%ld bytes", (long)a->size);
        else
            printf("size unknown");
        printf(", %u members\n", a->members);
    }

    /* The Class 1 connections and the plan (common/eds_plan.c). */
    static eds_plan_t plan;
    eds_plan(&eds, &plan);
    const eds_plan_t *p = &plan;
    printf("Class 1 connections: %u\n", p->nconn);
    for (unsigned i = 0; i < p->nconn; i++)
        print_conn(&p->conn[i]);
    if (p->plan_i >= 0 && p->matched && p->kind != DR_LAYOUT_PER_ASSEMBLY) {
        printf("plan: input instance %lu (%u bytes), output instance %lu (%u bytes)",
               (unsigned long)p->in_instance, (unsigned)p->in_size,
               (unsigned long)p->conn[p->plan_i].ot_inst, (unsigned)p->out_size);
        if (p->conn[p->plan_i].c->path_config != 0)
            printf(", configuration instance %lu",
                   (unsigned long)p->conn[p->plan_i].c->path_config);
        printf("\n");
    }
    if (p->matched)
        printf("layout: %s\n", dr_layout_name(p->kind));
    else
        printf("layout: none matches (per_assembly wants the ten assemblies at 101..110 "
               "with their sizes, combined 476 and 212 bytes, gpr_only 200 and 200)\n");
    if (e->n_note > 0 || e->lost_notes > 0) {
        printf("not used:\n");
        for (unsigned i = 0; i < e->n_note; i++)
            printf("  %s:%u: %s\n", path, e->note_line[i], e->note[i]);
        if (e->lost_notes > 0)
            printf("  and %u more\n", e->lost_notes);
    }
    if (!p->matched)
        return CLI_EXIT_FAIL;

    if (p->kind == DR_LAYOUT_PER_ASSEMBLY)
        cli_print_robot_section(host, DR_ENIP_TCP_PORT, p->kind, NULL, 0, 0, 0, 0);
    else
        cli_print_robot_section(host, DR_ENIP_TCP_PORT, p->kind, NULL,
                                (unsigned)p->in_instance, p->in_size,
                                (unsigned)p->out_instance, p->out_size);
    if (p->kind != DR_LAYOUT_PER_ASSEMBLY && p->main_i < 0)
        printf("output_assemblies = none\n");
    if (p->rpi_ms != 0)
        printf("rpi_ms = %u\n", p->rpi_ms);
    if (p->config_instance != 0 && p->config_instance != 1)
        printf("config_instance = %lu\n", (unsigned long)p->config_instance);
    if (p->input_only_hb != 0)
        printf("input_only_heartbeat = %lu\n", (unsigned long)p->input_only_hb);
    if (p->listen_only_hb != 0)
        printf("listen_only_heartbeat = %lu\n", (unsigned long)p->listen_only_hb);
    return CLI_EXIT_OK;
}

/* ---- writing ------------------------------------------------------------- */

/* A string field: quotes, and \ before " and \. */
static void put_str(const char *s)
{
    putchar('"');
    for (; *s != '\0'; s++) {
        if (*s == '"' || *s == '\\')
            putchar('\\');
        putchar(*s);
    }
    putchar('"');
}

/* Where a leaf lies in its assembly, in bits, and how wide it is. */
static void leaf_bits(dr_ref_t r, unsigned *pos, unsigned *width)
{
    const dr_field_t *f = r.field;
    unsigned e = r.elem > 0 ? (unsigned)r.elem : 0;
    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT: *pos = f->offset * 8u + f->bit; *width = 1; return;
    case DR_KIND_BITS: *pos = f->offset * 8u + f->bit + e; *width = 1; return;
    case DR_KIND_USINT:
    case DR_KIND_ENUM: *pos = (f->offset + e) * 8u; *width = 8; return;
    case DR_KIND_DINT:
    case DR_KIND_REAL: *pos = (f->offset + 4u * e) * 8u; *width = 32; return;
    }
    *pos = 0;
    *width = 0;
}

/* CIP data type code and size of a leaf's parameter. */
static void leaf_type(dr_ref_t r, unsigned *code, unsigned *size, const char **range)
{
    switch ((dr_kind_t)r.field->kind) {
    case DR_KIND_BIT:
    case DR_KIND_BITS: *code = 0xC1; *size = 1; *range = "0, 1, 0"; return;
    case DR_KIND_USINT:
    case DR_KIND_ENUM: *code = 0xC6; *size = 1; *range = "0, 255, 0"; return;
    case DR_KIND_DINT: *code = 0xC4; *size = 4; *range = "-2147483648, 2147483647, 0"; return;
    case DR_KIND_REAL: *code = 0xCA; *size = 4; *range = "-3.4028235e38, 3.4028235e38, 0.0"; return;
    }
    *code = 0;
    *size = 0;
    *range = ", , ";
}

#define RPI_PARAM 1u
#define FIRST_FIELD_PARAM 2u
#define CONFIG_INSTANCE 1u

/* The members of assembly a, from bit `base` of an image: each leaf that
 * does not overlap the one before, padding between. */
static unsigned print_members(dr_asm_t a, const uint16_t *leaf_param)
{
    unsigned at = 0, n = 0, count = dr_leaf_count();
    /* leaves in bit order: the table's order is by field; take the next
     * smallest position each time (371 leaves: fine). */
    for (;;) {
        unsigned best = 0xFFFFFFFFu, best_i = 0, best_w = 0;
        for (unsigned i = 0; i < count; i++) {
            dr_ref_t r;
            unsigned pos, w;
            if (dr_leaf_at((uint16_t)i, &r) != DR_OK || r.field->assembly != (uint8_t)a)
                continue;
            leaf_bits(r, &pos, &w);
            if (pos >= at && pos < best) {
                best = pos;
                best_i = i;
                best_w = w;
            }
        }
        if (best == 0xFFFFFFFFu)
            break;
        if (best > at)
            printf(",\n    %u, ", best - at);
        printf(",\n    %u, Param%u", best_w, (unsigned)leaf_param[best_i]);
        at = best + best_w;
        n++;
    }
    unsigned end = dr_asm_info(a)->size * 8u;
    if (end > at)
        printf(",\n    %u, ", end - at);
    return n;
}

static void print_assem(unsigned number, const char *name, unsigned instance, unsigned size,
                        const dr_asm_t *asms, unsigned nasm, const uint16_t *leaf_param)
{
    printf("        Assem%u =\n    ", number);
    put_str(name);
    printf(",\n    \"20 04 24 %02X 30 03\",\n    %u,\n    0x0000,\n    ,\n    ", instance,
           size);
    for (unsigned i = 0; i < nasm; i++)
        print_members(asms[i], leaf_param);
    printf(";\n");
}

static void print_conn_entry(unsigned number, const char *trigger, const char *params,
                             unsigned ot_size, unsigned ot_assem, unsigned to_size,
                             unsigned to_assem, const char *name)
{
    printf("        Connection%u =\n    %s, %s,\n", number, trigger, params);
    printf("    Param%u, %u, Assem%u,\n", RPI_PARAM, ot_size, ot_assem);
    printf("    Param%u, %u, Assem%u,\n", RPI_PARAM, to_size, to_assem);
    printf("    ,, ,,\n    ");
    put_str(name);
    printf(",\n    \"\",\n    \"20 04 24 %02X 2C %02X 2C %02X\";\n", CONFIG_INSTANCE, ot_assem,
           to_assem);
}

/* Triggers: Class 1, cyclic, and exclusive owner / input only / listen
 * only; connection parameters: O->T and T->O fixed size, O->T with the
 * 32-bit run/idle header (owner) or the heartbeat format, T->O pure data,
 * point-to-point O->T, multicast or point-to-point T->O, scheduled. */
#define T_OWNER "0x04010002"
#define T_INPUT "0x02010002"
#define T_LISTEN "0x01010002"
#define P_OWNER "0x44640405"
#define P_HB "0x44640305"
#define P_LISTEN "0x44240305"

static int run_write(const char *cmd, const char *layout_name)
{
    dr_layout_kind_t kind = DR_LAYOUT_PER_ASSEMBLY;
    if (layout_name != NULL && dr_layout_lookup(layout_name, &kind) != DR_OK)
        return cli_error(CLI_EXIT_USAGE, cmd, "unknown layout '%s' (per_assembly, combined, "
                         "gpr_only)", layout_name);
    static uint16_t leaf_param[1024];
    unsigned count = dr_leaf_count();
    if (count > sizeof leaf_param / sizeof leaf_param[0])
        return cli_error(CLI_EXIT_FAIL, cmd, "%u leaves: more than this writer holds", count);

    printf("$ EDS of drsim, the simulated Doosan robot of drgate, layout %s.\n"
           "$ Generated by `drcli eds --write --layout %s` from the field table\n"
           "$ (docs/assemblies.md); do not edit. docs/commissioning.md says how.\n\n",
           dr_layout_name(kind), dr_layout_name(kind));
    printf("[File]\n        DescText = \"drsim, layout %s\";\n"
           "        CreateDate = 01-01-2025;\n        CreateTime = 00:00:00;\n"
           "        ModDate = 01-01-2025;\n        ModTime = 00:00:00;\n"
           "        Revision = 1.0;\n\n", dr_layout_name(kind));
    printf("[Device]\n        VendCode = %u;\n        VendName = \"drgate (no ODVA vendor "
           "ID: a simulator)\";\n        ProdType = %u;\n        ProdTypeStr = "
           "\"Communications Adapter\";\n        ProdCode = %u;\n        MajRev = 2;\n"
           "        MinRev = 0;\n        ProdName = \"%s\";\n        Catalog = \"drsim\";\n\n",
           EDS_SIM_VENDOR, EDS_SIM_DEVICE_TYPE, EDS_SIM_PRODUCT_CODE, EDS_SIM_PRODUCT_NAME);
    printf("[Device Classification]\n        Class1 = EtherNetIP;\n\n");

    /* Params: the RPI, then one per leaf. */
    printf("[Params]\n        Param%u =\n    0, , , 0x0000, 0xC8, 4,\n    \"RPI\", "
           "\"microsecond\", \"Requested packet interval\",\n    %u, %u, %u,\n"
           "    , , , , , , , , 0;\n", RPI_PARAM, EDS_SIM_RPI_MIN_US, EDS_SIM_RPI_MAX_US,
           EDS_SIM_RPI_DEF_US);
    for (unsigned i = 0; i < count; i++) {
        dr_ref_t r;
        char name[96];
        unsigned code, size;
        const char *range;
        if (dr_leaf_at((uint16_t)i, &r) != DR_OK || dr_ref_path(r, name, sizeof name) != DR_OK)
            return cli_error(CLI_EXIT_FAIL, cmd, "leaf %u: not in the field table", i);
        leaf_param[i] = (uint16_t)(FIRST_FIELD_PARAM + i);
        leaf_type(r, &code, &size, &range);
        const dr_asm_info_t *ai = dr_asm_info((dr_asm_t)r.field->assembly);
        printf("        Param%u =\n    0, , , 0x%04X, 0x%02X, %u,\n    ", leaf_param[i],
               ai->dir == DR_DIR_T2O ? 0x0030u : 0x0000u, code, size);
        put_str(name);
        printf(", ");
        put_str(r.field->unit);
        printf(", ");
        put_str(r.field->help);
        printf(",\n    %s,\n    1, 1, 0, 0, , , , , 0;\n", range);
    }

    /* Assemblies and connections. */
    printf("\n[Assembly]\n");
    dr_layout_t l;
    dr_layout_default(&l, kind);
    unsigned nconn = 0;
    if (kind == DR_LAYOUT_PER_ASSEMBLY) {
        for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
            dr_asm_t id = (dr_asm_t)a;
            print_assem(DR_ASM_DEFAULT_INSTANCE(a), dr_asm_info(id)->name,
                        DR_ASM_DEFAULT_INSTANCE(a), dr_asm_info(id)->size, &id, 1, leaf_param);
        }
    } else {
        dr_asm_t in[DR_POINT_MAX_ASM], out[DR_POINT_MAX_ASM];
        for (unsigned i = 0; i < l.input.count; i++)
            in[i] = (dr_asm_t)l.input.asm_id[i];
        for (unsigned i = 0; i < l.output.count; i++)
            out[i] = (dr_asm_t)l.output.asm_id[i];
        print_assem(l.input.instance, "Input", l.input.instance, l.input.size, in,
                    l.input.count, leaf_param);
        print_assem(l.output.instance, "Output", l.output.instance, l.output.size, out,
                    l.output.count, leaf_param);
    }
    print_assem(EDS_HB_INPUT_ONLY, "Input only heartbeat", EDS_HB_INPUT_ONLY, 0, NULL, 0,
                leaf_param);
    print_assem(EDS_HB_LISTEN_ONLY, "Listen only heartbeat", EDS_HB_LISTEN_ONLY, 0, NULL, 0,
                leaf_param);

    printf("\n[Connection Manager]\n");
    if (kind == DR_LAYOUT_PER_ASSEMBLY) {
        /* drgatewayd's default plan (configuration.md, Connection plan):
         * io_state, bit_out, int_out, float_out own their O->T
         * partners; joint_state and task_state are input only. */
        static const struct {
            dr_asm_t to, ot;
        } owner[] = {
            {DR_ASM_IO_STATE, DR_ASM_IO_CONTROL}, {DR_ASM_BIT_OUT, DR_ASM_BIT_IN},
            {DR_ASM_INT_OUT, DR_ASM_INT_IN}, {DR_ASM_FLOAT_OUT, DR_ASM_FLOAT_IN},
        };
        static const dr_asm_t input[] = {DR_ASM_JOINT_STATE, DR_ASM_TASK_STATE};
        char name[64];
        for (unsigned i = 0; i < sizeof owner / sizeof owner[0]; i++) {
            snprintf(name, sizeof name, "Exclusive Owner %s/%s", dr_asm_info(owner[i].to)->name,
                     dr_asm_info(owner[i].ot)->name);
            print_conn_entry(++nconn, T_OWNER, P_OWNER, dr_asm_info(owner[i].ot)->size,
                             DR_ASM_DEFAULT_INSTANCE(owner[i].ot), dr_asm_info(owner[i].to)->size,
                             DR_ASM_DEFAULT_INSTANCE(owner[i].to), name);
        }
        for (unsigned i = 0; i < sizeof input / sizeof input[0]; i++) {
            snprintf(name, sizeof name, "Input Only %s", dr_asm_info(input[i])->name);
            print_conn_entry(++nconn, T_INPUT, P_HB, 0, EDS_HB_INPUT_ONLY,
                             dr_asm_info(input[i])->size, DR_ASM_DEFAULT_INSTANCE(input[i]),
                             name);
        }
    } else {
        print_conn_entry(++nconn, T_OWNER, P_OWNER, l.output.size, l.output.instance,
                         l.input.size, l.input.instance, "Exclusive Owner");
        print_conn_entry(++nconn, T_INPUT, P_HB, 0, EDS_HB_INPUT_ONLY, l.input.size,
                         l.input.instance, "Input Only");
        print_conn_entry(++nconn, T_LISTEN, P_LISTEN, 0, EDS_HB_LISTEN_ONLY, l.input.size,
                         l.input.instance, "Listen Only");
    }
    if (fflush(stdout) != 0 || ferror(stdout))
        return cli_error(CLI_EXIT_FAIL, cmd, "writing the EDS: %s", strerror(errno));
    return CLI_EXIT_OK;
}

/* ---- command ------------------------------------------------------------- */

static int run_eds(const char *cmd, int argc, char **argv, const cli_net_opts_t *lead)
{
    (void)lead;
    bool help = false, write = false;
    const char *host = NULL, *layout = NULL;
    const cli_opt_t opts[] = {
        {"host", 'H', NULL, &host, NULL},
        {"write", 'w', &write, NULL, NULL},
        {"layout", 'l', NULL, &layout, NULL},
    };
    int npos = cli_parse_opts(cli_cmd_eds.name, argc, argv, opts, sizeof opts / sizeof opts[0],
                              &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(&cli_cmd_eds);
        return CLI_EXIT_OK;
    }
    if (write) {
        if (npos != 0 || host != NULL)
            return cli_error(CLI_EXIT_USAGE, cmd, "--write takes no file and no --host: "
                             "the EDS goes to standard output");
        return run_write(cmd, layout);
    }
    if (layout != NULL)
        return cli_error(CLI_EXIT_USAGE, cmd, "--layout goes with --write");
    if (npos != 1)
        return cli_error(CLI_EXIT_USAGE, cmd, "one EDS file expected (see drcli eds --help)");
    return run_read(cmd, argv[0], host != NULL ? host : "192.0.2.1");
}

const cli_cmd_t cli_cmd_eds = {
    "eds", "read a vendor's EDS into a plan, or write drsim's (offline)",
    eds_help, run_eds, false,
};
