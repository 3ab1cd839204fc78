/* SPDX-License-Identifier: MIT */
/*
 * drcli identity and probe: who the device says it is (ListIdentity and
 * the Identity object), and which assembly instances it has, with their
 * sizes (attribute 4) against the specification's.
 */
#include <stdio.h>
#include <string.h>

#include "cmd.h"
#include "error.h"
#include "net.h"
#include "opt.h"
#include "util.h"

static const char identity_help[] =
    "usage: drcli [-H HOST] identity [OPTION...]\n"
    "\n"
    "Asks the device who it is, twice: ListIdentity (an encapsulation command,\n"
    "over the session's TCP connection) and the Identity object (class 1,\n"
    "instance 1, Get_Attributes_All). Prints vendor, device type, product\n"
    "code, revision, status, serial number and product name of each; the\n"
    "ListIdentity reply also has the device's state and socket address.\n"
    "\n"
    "options:\n"
    CLI_NET_HELP
    "  -h, --help          this text\n"
    "\n"
    "With --json: {\"list_identity\": {...}, \"identity\": {...}}, null for an\n"
    "answer that failed; --raw does not apply. Exit status: 0, 2 usage,\n"
    "3 network, 4 CIP error; what was answered is printed even if the other\n"
    "request failed.\n";

static const char probe_help[] =
    "usage: drcli [-H HOST] probe [OPTION...]\n"
    "\n"
    "Checks the device against the specification: for each of the ten\n"
    "assemblies, whether its instance (101..110, or as --instance says)\n"
    "exists and its size (attribute 4; where the device has no attribute 4,\n"
    "the length of its data, attribute 3) against the specified size. Then\n"
    "the Identity object (or ListIdentity) in one line.\n"
    "\n"
    "options:\n"
    CLI_NET_HELP
    "  -h, --help          this text\n"
    "\n"
    "With --json: {\"assemblies\": [...], \"identity\": {...}, \"ok\": BOOL};\n"
    "--raw does not apply.\n"
    "Exit status: 0 every assembly exists with the specified size, 4 some do\n"
    "not (the table says which), 2 usage, 3 network.\n";

/* ---- identity ------------------------------------------------------------ */

/* Extended device status, bits 4-7 of the Identity status word. */
static const char *ext_status_text(uint16_t status)
{
    static const char *const text[16] = {
        "self-testing or unknown", "firmware update in progress",
        "an I/O connection faulted", "no I/O connection established",
        "non-volatile configuration bad", "major fault",
        "an I/O connection in run mode", "I/O connections established, all idle",
    };
    const char *t = text[(status >> 4) & 0xFu];
    return t != NULL ? t : "reserved";
}

static const char *state_text(uint8_t state)
{
    static const char *const text[] = {
        "nonexistent", "self testing", "standby", "operational",
        "major recoverable fault", "major unrecoverable fault",
    };
    if (state < sizeof text / sizeof text[0])
        return text[state];
    return state == 0xFF ? "not given" : "reserved";
}

static void print_identity(const char *title, const dr_identity_t *id, bool listed)
{
    printf("# %s\n", title);
    printf("vendor       = %u (0x%04x)\n", (unsigned)id->vendor, (unsigned)id->vendor);
    printf("device_type  = %u (0x%04x)\n", (unsigned)id->device_type,
           (unsigned)id->device_type);
    printf("product_code = %u\n", (unsigned)id->product_code);
    printf("revision     = %u.%u\n", (unsigned)id->rev_major, (unsigned)id->rev_minor);
    printf("status       = 0x%04x (%s)\n", (unsigned)id->status,
           ext_status_text(id->status));
    printf("serial       = 0x%08lx\n", (unsigned long)id->serial);
    printf("product_name = \"%s\"\n", id->product_name);
    if (!listed)
        return;
    printf("state        = %u (%s)\n", (unsigned)id->state, state_text(id->state));
    printf("address      = %u.%u.%u.%u:%u\n", (unsigned)(id->sockaddr.addr >> 24),
           (unsigned)(id->sockaddr.addr >> 16 & 0xFFu),
           (unsigned)(id->sockaddr.addr >> 8 & 0xFFu),
           (unsigned)(id->sockaddr.addr & 0xFFu), (unsigned)id->sockaddr.port);
}

static json_t *identity_json(const dr_identity_t *id, bool listed)
{
    char rev[16], addr[24];
    snprintf(rev, sizeof rev, "%u.%u", (unsigned)id->rev_major, (unsigned)id->rev_minor);
    json_t *o = json_pack("{s:i, s:i, s:i, s:s, s:i, s:I, s:s}",
                          "vendor", (int)id->vendor, "device_type", (int)id->device_type,
                          "product_code", (int)id->product_code, "revision", rev,
                          "status", (int)id->status, "serial", (json_int_t)id->serial,
                          "product_name", id->product_name);
    if (o == NULL || !listed)
        return o;
    snprintf(addr, sizeof addr, "%u.%u.%u.%u", (unsigned)(id->sockaddr.addr >> 24),
             (unsigned)(id->sockaddr.addr >> 16 & 0xFFu),
             (unsigned)(id->sockaddr.addr >> 8 & 0xFFu),
             (unsigned)(id->sockaddr.addr & 0xFFu));
    if (json_object_set_new(o, "state", json_integer(id->state)) != 0 ||
        json_object_set_new(o, "address", json_string(addr)) != 0 ||
        json_object_set_new(o, "port", json_integer(id->sockaddr.port)) != 0) {
        json_decref(o);
        return NULL;
    }
    return o;
}

/* Parse the options of identity and probe; returns an exit code, or -1
 * after printing the help. */
static int parse_common(const cli_cmd_t *self, int argc, char **argv,
                        const cli_net_opts_t *lead, cli_net_opts_t *o,
                        dr_client_config_t *cfg)
{
    bool help = false;
    *o = *lead;
    cli_opt_t opts[CLI_NET_NOPTS];
    size_t nopts = cli_net_optv(o, opts);
    int npos = cli_parse_opts(self->name, argc, argv, opts, nopts, &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(self);
        return -1;
    }
    if (npos > 0)
        return cli_error(CLI_EXIT_USAGE, self->name,
                         "unexpected argument '%s' (see drcli %s --help)", argv[0],
                         self->name);
    int rc = cli_net_refuse(self->name, o, true, false);
    return rc != CLI_EXIT_OK ? rc : cli_net_config(self->name, o, cfg);
}

/* Parse, then connect: CLI_EXIT_OK with *net connected, -1 after printing
 * the help, or the exit code of what failed. */
static int open_common(const cli_cmd_t *self, const char *cmd, int argc, char **argv,
                       const cli_net_opts_t *lead, cli_net_opts_t *o, cli_net_t *net)
{
    dr_client_config_t cfg;
    int rc = parse_common(self, argc, argv, lead, o, &cfg);
    return rc != CLI_EXIT_OK ? rc : cli_net_connect(cmd, &cfg, net);
}

static int run_identity(const char *cmd, int argc, char **argv,
                        const cli_net_opts_t *lead)
{
    cli_net_opts_t o;
    cli_net_t net;
    int rc = open_common(&cli_cmd_identity, cmd, argc, argv, lead, &o, &net);
    if (rc != CLI_EXIT_OK)
        return rc < 0 ? CLI_EXIT_OK : rc;

    dr_identity_t listed, object;
    int rc_list = CLI_EXIT_OK, rc_obj = CLI_EXIT_OK;
    dr_status_t st = dr_client_list_identity_sync(net.client, &listed);
    if (st != DR_OK)
        rc_list = cli_net_fail(&net, st, NULL);
    st = dr_client_read_identity_sync(net.client, &object);
    if (st != DR_OK)
        rc_obj = cli_net_fail(&net, st, "(Identity object, Get_Attributes_All)");
    cli_net_close(&net);

    if (o.json) {
        json_t *l = rc_list == CLI_EXIT_OK ? identity_json(&listed, true) : json_null();
        json_t *i = rc_obj == CLI_EXIT_OK ? identity_json(&object, false) : json_null();
        rc = cli_json_print(cmd, json_pack("{s:o?, s:o?}", "list_identity", l,
                                           "identity", i));
    } else {
        if (rc_list == CLI_EXIT_OK)
            print_identity("ListIdentity (encapsulation command 0x0063)", &listed, true);
        if (rc_list == CLI_EXIT_OK && rc_obj == CLI_EXIT_OK)
            putchar('\n');
        if (rc_obj == CLI_EXIT_OK)
            print_identity("Identity object (class 0x01, instance 1)", &object, false);
    }
    if (rc_list != CLI_EXIT_OK)
        return rc_list;
    return rc_obj != CLI_EXIT_OK ? rc_obj : rc;
}

/* ---- probe --------------------------------------------------------------- */

typedef struct {
    uint16_t instance;
    int size;            /* -1: unknown */
    bool from_data;      /* size is the data's length: no attribute 4 */
    dr_status_t error;   /* DR_OK, or why the instance is unusable */
} probe_row_t;

/* Statuses that mean "this attribute or service is not there". */
static bool not_supported(dr_status_t st)
{
    return DR_IS_CIP(st) &&
           (DR_CIP_GENERAL(st) == 0x14 || DR_CIP_GENERAL(st) == 0x08);
}

/* Probe one instance. Returns an exit code for failures that end the
 * probe (network); CIP errors land in row->error. */
static int probe_asm(cli_net_t *net, dr_asm_t a, probe_row_t *row)
{
    uint16_t size = 0;
    memset(row, 0, sizeof *row);
    row->instance = dr_client_instance(net->client, a);
    row->size = -1;
    row->error = dr_client_read_asm_size_sync(net->client, row->instance, &size);
    if (row->error == DR_OK) {
        row->size = size;
    } else if (not_supported(row->error)) {
        uint8_t tmp[DR_ENCAP_MAX_LEN];
        size_t got = 0;
        row->error = dr_client_get_attr_sync(net->client, DR_CIP_CLASS_ASSEMBLY,
                                             row->instance, DR_CIP_ASM_ATTR_DATA,
                                             tmp, sizeof tmp, &got);
        row->from_data = true;
        if (row->error == DR_OK)
            row->size = (int)got;
    }
    if (row->error != DR_OK && !DR_IS_CIP(row->error) && row->error != DR_EMALFORMED) {
        char label[64];
        cli_net_asm_label(net, a, label, sizeof label);
        return cli_net_fail(net, row->error, label);
    }
    return CLI_EXIT_OK;
}

static bool row_ok(dr_asm_t a, const probe_row_t *row)
{
    return row->error == DR_OK && row->size == (int)dr_asm_info(a)->size;
}

static void row_result(dr_asm_t a, const probe_row_t *row, char *out, size_t size)
{
    if (row->error != DR_OK)
        snprintf(out, size, "missing: %s", dr_strerror(row->error));
    else if (!row_ok(a, row))
        snprintf(out, size, "size differs%s", row->from_data ? " (size from data)" : "");
    else
        snprintf(out, size, "ok%s", row->from_data ? " (size from data, no attribute 4)" : "");
}

static void print_probe(const probe_row_t *rows, const char *ident, unsigned good)
{
    printf("ASSEMBLY     ALIAS  DIR   INSTANCE  SIZE  SPEC  RESULT\n");
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        char size[16], result[96];
        if (rows[a].size >= 0)
            snprintf(size, sizeof size, "%d", rows[a].size);
        else
            snprintf(size, sizeof size, "-");
        row_result((dr_asm_t)a, &rows[a], result, sizeof result);
        printf("%-11s  %-5s  %-4s  %8u  %4s  %4u  %s\n", info->name, info->alias,
               cli_dir_name(info->dir), (unsigned)rows[a].instance, size,
               (unsigned)info->size, result);
    }
    printf("identity: %s\n", ident);
    printf("%u of %u assemblies as specified\n", good, (unsigned)DR_ASM_COUNT);
}

static json_t *probe_json(const probe_row_t *rows, const dr_identity_t *id,
                          bool have_id, unsigned good)
{
    json_t *arr = json_array();
    for (unsigned a = 0; arr != NULL && a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        const probe_row_t *r = &rows[a];
        const char *result = r->error != DR_OK ? "missing"
                             : row_ok((dr_asm_t)a, r) ? "ok" : "size differs";
        json_t *o = json_pack("{s:s, s:s, s:s, s:i, s:o, s:i, s:s?, s:s, s:s?}",
                              "name", info->name, "alias", info->alias,
                              "direction", cli_dir_name(info->dir),
                              "instance", (int)r->instance,
                              "size", r->size >= 0 ? json_integer(r->size) : json_null(),
                              "spec_size", (int)info->size,
                              "size_from", r->size < 0 ? NULL
                                           : r->from_data ? "data" : "attribute 4",
                              "result", result,
                              "error", r->error != DR_OK ? dr_strerror(r->error) : NULL);
        if (json_array_append_new(arr, o) != 0) {
            json_decref(arr);
            arr = NULL;
        }
    }
    json_t *ident = have_id ? identity_json(id, false) : json_null();
    return json_pack("{s:o?, s:o?, s:b}", "assemblies", arr, "identity", ident,
                     "ok", good == DR_ASM_COUNT);
}

/* The Identity object, else ListIdentity, in one line. Network failures
 * end the probe; CIP errors only say the identity is not available. */
static int probe_identity(cli_net_t *net, dr_identity_t *id, bool *have,
                          char *out, size_t size)
{
    dr_status_t st = dr_client_read_identity_sync(net->client, id);
    if (DR_IS_CIP(st) || st == DR_EMALFORMED)
        st = dr_client_list_identity_sync(net->client, id);
    *have = st == DR_OK;
    if (st == DR_OK)
        snprintf(out, size, "\"%s\", vendor %u, device type %u, product code %u, "
                 "revision %u.%u, serial 0x%08lx", id->product_name,
                 (unsigned)id->vendor, (unsigned)id->device_type,
                 (unsigned)id->product_code, (unsigned)id->rev_major,
                 (unsigned)id->rev_minor, (unsigned long)id->serial);
    else if (DR_IS_CIP(st) || st == DR_EMALFORMED)
        snprintf(out, size, "not available (%s)", dr_strerror(st));
    else
        return cli_net_fail(net, st, NULL);
    return CLI_EXIT_OK;
}

static int run_probe(const char *cmd, int argc, char **argv,
                     const cli_net_opts_t *lead)
{
    cli_net_opts_t o;
    cli_net_t net;
    int rc = open_common(&cli_cmd_probe, cmd, argc, argv, lead, &o, &net);
    if (rc != CLI_EXIT_OK)
        return rc < 0 ? CLI_EXIT_OK : rc;

    probe_row_t rows[DR_ASM_COUNT];
    unsigned good = 0;
    for (unsigned a = 0; rc == CLI_EXIT_OK && a < DR_ASM_COUNT; a++) {
        rc = probe_asm(&net, (dr_asm_t)a, &rows[a]);
        good += rc == CLI_EXIT_OK && row_ok((dr_asm_t)a, &rows[a]);
    }
    dr_identity_t id;
    bool have_id = false;
    char ident[160];
    if (rc == CLI_EXIT_OK)
        rc = probe_identity(&net, &id, &have_id, ident, sizeof ident);
    cli_net_close(&net);
    if (rc != CLI_EXIT_OK)
        return rc;
    if (o.json)
        rc = cli_json_print(cmd, probe_json(rows, &id, have_id, good));
    else
        print_probe(rows, ident, good);
    if (rc == CLI_EXIT_OK && good != DR_ASM_COUNT)
        rc = CLI_EXIT_CIP;
    return rc;
}

const cli_cmd_t cli_cmd_identity = {
    "identity", "ask the device who it is (ListIdentity, Identity object)",
    identity_help, run_identity, true,
};

const cli_cmd_t cli_cmd_probe = {
    "probe", "check which assembly instances exist and their sizes",
    probe_help, run_probe, true,
};
