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
#include "trial.h"
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
    "the length of its data, attribute 3) against the specified size, and the\n"
    "Identity object (or ListIdentity) in one line. When the ten are not all\n"
    "there: the same for the two instances of a combined layout (input 100,\n"
    "output 150, or as --instance input=N, output=N say) and the Assembly\n"
    "object's class attributes (how many instances, the highest). Then the\n"
    "layout the sizes match (per_assembly,\n"
    "combined: 476 and 212 bytes, gpr_only: 200 and 200) and a [robot]\n"
    "section for drgatewayd's configuration. Read-only: Get_Attribute_Single\n"
    "and Get_Attributes_All, nothing is written, no connection opened.\n"
    "\n"
    "With --open, where those sizes match no layout (an adapter that does not\n"
    "answer Get on its assemblies), a Forward Open trial for each instance\n"
    "whose size is unknown: input-only (heartbeat 198) for a T->O one, an\n"
    "exclusive owner with a T->O instance already sized for an O->T one,\n"
    "idle O->T (no output is applied). The adapter accepts the size asked\n"
    "for, or refuses it with 0x01/0x0109 and names its own; whatever opened\n"
    "is closed at once (Forward Close), one that got no answer by its triad.\n"
    "An owner trial takes the outputs for a moment: not while a PLC or\n"
    "drgatewayd owns them (it is refused with 0x0106 then).\n"
    "\n"
    "options:\n"
    CLI_NET_HELP
    "  -o, --open          the Forward Open trial (above)\n"
    "      --udp-port N    with --open: the local UDP port for T->O (2222)\n"
    "      --rpi MS        with --open: the trial's RPI (default 100)\n"
    "  -h, --help          this text\n"
    "\n"
    "With --json: {\"assemblies\": [...], \"points\": [...], \"identity\": {...},\n"
    "\"trials\": [...], \"layout\": NAME or null, \"ok\": BOOL}; --raw does not\n"
    "apply.\n"
    "Exit status: 0 the sizes match a layout, 4 they match none (the table\n"
    "says what differs), 2 usage, 3 network.\n";

/* Options of probe's own (--open, --udp-port, --rpi). */
#define PROBE_NOPTS 3

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

/* Parse the options of identity and probe (the network options, then
 * extra[nextra], a command's own); returns an exit code, or -1 after
 * printing the help. */
static int parse_common(const cli_cmd_t *self, int argc, char **argv,
                        const cli_net_opts_t *lead, cli_net_opts_t *o,
                        dr_client_config_t *cfg, const cli_opt_t *extra, size_t nextra)
{
    bool help = false;
    *o = *lead;
    cli_opt_t opts[CLI_NET_NOPTS + PROBE_NOPTS];
    size_t nopts = cli_net_optv(o, opts);
    for (size_t i = 0; i < nextra && i < PROBE_NOPTS; i++)
        opts[nopts++] = extra[i];
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

static int run_identity(const char *cmd, int argc, char **argv,
                        const cli_net_opts_t *lead)
{
    cli_net_opts_t o;
    cli_net_t net;
    dr_client_config_t cfg;
    int rc = parse_common(&cli_cmd_identity, argc, argv, lead, &o, &cfg, NULL, 0);
    if (rc == CLI_EXIT_OK)
        rc = cli_net_connect(cmd, &cfg, &net);
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
    bool from_open;      /* size from a Forward Open trial (--open) */
    dr_status_t error;   /* DR_OK, or why the instance is unusable */
} probe_row_t;

/* Where a row's size came from, for the table and --json. */
static const char *size_from(const probe_row_t *r)
{
    return r->from_open ? "forward open" : r->from_data ? "data" : "attribute 4";
}

/* Statuses that mean "this attribute or service is not there". */
static bool not_supported(dr_status_t st)
{
    return DR_IS_CIP(st) &&
           (DR_CIP_GENERAL(st) == 0x14 || DR_CIP_GENERAL(st) == 0x08);
}

/* Probe one instance. Returns an exit code for failures that end the
 * probe (network); CIP errors land in row->error. */
static int probe_instance(cli_net_t *net, uint16_t instance, const char *label,
                          probe_row_t *row)
{
    uint16_t size = 0;
    memset(row, 0, sizeof *row);
    row->instance = instance;
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
    /* An encapsulation error is how some targets (cpppo) answer a request
     * for an object they do not have: it ends their session. */
    if (row->error != DR_OK && !DR_IS_CIP(row->error) && row->error != DR_EMALFORMED &&
        !DR_IS_ENCAP(row->error))
        return cli_net_fail(net, row->error, label);
    return CLI_EXIT_OK;
}

static int probe_asm(cli_net_t *net, dr_asm_t a, probe_row_t *row)
{
    char label[96];
    cli_net_asm_label(net, a, label, sizeof label);
    return probe_instance(net, dr_client_instance(net->client, a), label, row);
}

static bool row_ok(dr_asm_t a, const probe_row_t *row)
{
    return row->error == DR_OK && row->size == (int)dr_asm_info(a)->size;
}

static void row_result(dr_asm_t a, const probe_row_t *row, char *out, size_t size)
{
    const char *from = row->from_open ? " (size from a Forward Open)"
                       : row->from_data ? " (size from data)" : "";
    if (row->error != DR_OK)
        snprintf(out, size, "missing: %s", dr_strerror(row->error));
    else if (!row_ok(a, row))
        snprintf(out, size, "size differs%s", from);
    else
        snprintf(out, size, "ok%s", row->from_open || !row->from_data
                                        ? from : " (size from data, no attribute 4)");
}

/* One Forward Open trial (--open) and what it gave. */
typedef struct {
    cli_trial_req_t rq;
    cli_trial_res_t res;
} probe_trial_t;

#define PROBE_MAX_TRIALS (DR_ASM_COUNT + 6u) /* room for repeats */

/* The two instances of a combined layout, the class attributes, the
 * Forward Open trials, and the layout everything matches. */
typedef struct {
    probe_row_t in, out;
    bool asked;         /* the combined instances were probed */
    int count, max;     /* class attributes 3 and 2; -1: not answered */
    bool matched;
    dr_layout_kind_t kind;
    bool open;          /* --open given */
    probe_trial_t trial[PROBE_MAX_TRIALS];
    unsigned ntrial;
} probe_layout_t;

static void print_point(const char *what, const probe_row_t *r)
{
    if (r->error != DR_OK)
        printf("%s instance %u: missing: %s\n", what, (unsigned)r->instance,
               dr_strerror(r->error));
    else
        printf("%s instance %u: %d bytes%s\n", what, (unsigned)r->instance, r->size,
               r->from_open ? " (size from a Forward Open)"
               : r->from_data ? " (size from data)" : "");
}

/* A [robot] section for drgatewayd with what the probe found. */
static void print_section(const cli_net_t *net, const probe_layout_t *pl)
{
    uint16_t inst[DR_ASM_COUNT];
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        inst[a] = dr_client_instance(net->client, (dr_asm_t)a);
    cli_print_robot_section(net->host, net->tcp_port, pl->kind, inst, pl->in.instance,
                            pl->in.size, pl->out.instance, pl->out.size);
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

static void print_layout(const cli_net_t *net, const probe_layout_t *pl)
{
    if (pl->asked) {
        print_point("input", &pl->in);
        print_point("output", &pl->out);
    } else {
        printf("input and output instances: not asked (the ten assemblies are there)\n");
    }
    if (!pl->asked)
        ; /* the class attributes were not asked either */
    else if (pl->count >= 0 && pl->max >= 0)
        printf("assembly object: %d instances, the highest %d\n", pl->count, pl->max);
    else
        printf("assembly object: no class attributes\n");
    for (unsigned i = 0; i < pl->ntrial; i++) {
        char text[320];
        cli_trial_text(&pl->trial[i].rq, &pl->trial[i].res, text, sizeof text);
        printf("forward open trial: %s\n", text);
    }
    if (!pl->matched) {
        printf("layout: none matches (per_assembly wants the ten sizes above, combined "
               "476 and 212 bytes, gpr_only 200 and 200)\n");
        if (!pl->open)
            printf("sizes the adapter would not tell: drcli probe --open tries a Forward "
                   "Open for each (see drcli probe --help)\n");
        return;
    }
    printf("layout: %s\n", dr_layout_name(pl->kind));
    print_section(net, pl);
}

/* A class attribute of the Assembly object (UINT); -1 if not answered. */
static int class_attr(cli_net_t *net, uint8_t attr)
{
    uint8_t tmp[DR_ENCAP_MAX_LEN];
    size_t got = 0;
    dr_status_t st = dr_client_get_attr_sync(net->client, DR_CIP_CLASS_ASSEMBLY, 0, attr, tmp,
                                             sizeof tmp, &got);
    return st == DR_OK && got == 2 ? (int)dr_get_le16(tmp) : -1;
}

/* Which layout the sizes found match. */
static void probe_match(const probe_row_t *rows, probe_layout_t *pl)
{
    uint16_t sizes[DR_ASM_COUNT];
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        sizes[a] = rows[a].error == DR_OK && rows[a].size > 0 ? (uint16_t)rows[a].size : 0;
    uint16_t si = pl->in.error == DR_OK && pl->in.size > 0 ? (uint16_t)pl->in.size : 0;
    uint16_t so = pl->out.error == DR_OK && pl->out.size > 0 ? (uint16_t)pl->out.size : 0;
    pl->matched = dr_layout_match(sizes, si, so, &pl->kind) == DR_OK;
}

/* The combined layout's instances and the class attributes; then which
 * layout the sizes match. */
static int probe_points(cli_net_t *net, const probe_row_t *rows, probe_layout_t *pl)
{
    uint16_t in = net->layout.input.instance ? net->layout.input.instance
                                             : DR_LAYOUT_INPUT_INSTANCE;
    uint16_t out = net->layout.output.instance ? net->layout.output.instance
                                               : DR_LAYOUT_OUTPUT_INSTANCE;
    char label[64];
    snprintf(label, sizeof label, "input (instance %u)", (unsigned)in);
    pl->asked = true;
    pl->count = pl->max = -1;
    int rc = probe_instance(net, in, label, &pl->in);
    if (rc == CLI_EXIT_OK && DR_IS_ENCAP(pl->in.error)) {
        /* the session is gone: nothing more can be asked in it */
        pl->out = pl->in;
        pl->out.instance = out;
    } else if (rc == CLI_EXIT_OK) {
        snprintf(label, sizeof label, "output (instance %u)", (unsigned)out);
        rc = probe_instance(net, out, label, &pl->out);
    }
    if (rc != CLI_EXIT_OK)
        return rc;
    if (!DR_IS_ENCAP(pl->out.error)) {
        pl->count = class_attr(net, 3);
        pl->max = class_attr(net, 2);
    }
    probe_match(rows, pl);
    return CLI_EXIT_OK;
}

/* ---- the Forward Open trial (--open) ----------------------------------- */

static unsigned count_good(const probe_row_t *rows)
{
    unsigned good = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        good += row_ok((dr_asm_t)a, &rows[a]);
    return good;
}


/* A row's size, if known and within what a connection may carry. */
static uint16_t known_size(const probe_row_t *r)
{
    return r->error == DR_OK && r->size > 0 && r->size <= DR_CLIENT_IO_MAX ? (uint16_t)r->size
                                                                          : 0;
}

/* Run one trial and take the size it learned into *row; one that got no
 * answer (closed by its triad since) is tried once more. */
static int trial_into(cli_net_t *net, probe_layout_t *pl, const cli_trial_req_t *rq,
                      uint32_t rpi_ms, probe_row_t *row)
{
    if (pl->ntrial >= PROBE_MAX_TRIALS)
        return CLI_EXIT_OK;
    probe_trial_t *t = &pl->trial[pl->ntrial++];
    t->rq = *rq;
    int rc = cli_trial(net, rq, rpi_ms, &t->res);
    if (rc == CLI_EXIT_OK && !t->res.answered && pl->ntrial < PROBE_MAX_TRIALS) {
        t = &pl->trial[pl->ntrial++];
        t->rq = *rq;
        rc = cli_trial(net, rq, rpi_ms, &t->res);
    }
    if (rc == CLI_EXIT_OK && t->res.size >= 0) {
        row->size = t->res.size;
        row->error = DR_OK;
        row->from_open = true;
        row->from_data = false;
    }
    return rc;
}

/* A trial for every instance whose size Get did not give: the T->O ones
 * first (input-only), then the O->T ones as owners beside a T->O
 * instance now sized. */
static int probe_trials(cli_net_t *net, probe_row_t *rows, probe_layout_t *pl,
                        uint32_t rpi_ms)
{
    int rc = CLI_EXIT_OK;
    int partner = -1;
    for (unsigned a = 0; rc == CLI_EXIT_OK && a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        if (info->dir != DR_DIR_T2O)
            continue;
        if (rows[a].error != DR_OK) {
            cli_trial_req_t rq = {rows[a].instance, info->size, 0, 0, (dr_asm_t)a, -1};
            rc = trial_into(net, pl, &rq, rpi_ms, &rows[a]);
        }
        if (partner < 0 && known_size(&rows[a]) != 0)
            partner = (int)a;
    }
    for (unsigned a = 0; rc == CLI_EXIT_OK && partner >= 0 && a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        if (info->dir != DR_DIR_O2T || rows[a].error == DR_OK)
            continue;
        cli_trial_req_t rq = {rows[partner].instance, known_size(&rows[partner]),
                              rows[a].instance, info->size, (dr_asm_t)partner, (int)a};
        rc = trial_into(net, pl, &rq, rpi_ms, &rows[a]);
    }
    if (!pl->asked || count_good(rows) == DR_ASM_COUNT)
        return rc; /* the ten found: no point to ask for */
    /* the points: sizes asked for are those of the layout given with
     * --layout, else the combined one's */
    dr_layout_t def;
    dr_layout_default(&def, net->layout.kind == DR_LAYOUT_GPR_ONLY ? DR_LAYOUT_GPR_ONLY
                                                                   : DR_LAYOUT_COMBINED);
    if (rc == CLI_EXIT_OK && pl->in.error != DR_OK) {
        cli_trial_req_t rq = {pl->in.instance, def.input.size, 0, 0,
                              (dr_asm_t)def.input.asm_id[0], -1};
        rc = trial_into(net, pl, &rq, rpi_ms, &pl->in);
    }
    if (rc == CLI_EXIT_OK && pl->out.error != DR_OK && known_size(&pl->in) != 0) {
        cli_trial_req_t rq = {pl->in.instance, known_size(&pl->in), pl->out.instance,
                              def.output.size, (dr_asm_t)def.input.asm_id[0],
                              def.output.asm_id[0]};
        rc = trial_into(net, pl, &rq, rpi_ms, &pl->out);
    }
    return rc;
}

static json_t *point_json(const char *name, const probe_row_t *r)
{
    bool sized = r->error == DR_OK && r->size >= 0;
    return json_pack("{s:s, s:i, s:o, s:s?, s:s?}", "name", name, "instance",
                     (int)r->instance, "size", sized ? json_integer(r->size) : json_null(),
                     "size_from", sized ? size_from(r) : NULL,
                     "error", r->error != DR_OK ? dr_strerror(r->error) : NULL);
}

static json_t *trials_json(const probe_layout_t *pl)
{
    json_t *arr = json_array();
    for (unsigned i = 0; arr != NULL && i < pl->ntrial; i++) {
        const probe_trial_t *t = &pl->trial[i];
        bool owner = t->rq.o2t_instance != 0;
        json_t *o = json_pack(
            "{s:s, s:i, s:i?, s:i, s:b, s:b, s:o, s:o, s:s?}",
            "type", owner ? "exclusive_owner" : "input_only",
            "t2o_instance", (int)t->rq.t2o_instance,
            "o2t_instance", owner ? json_integer(t->rq.o2t_instance) : json_null(),
            "asked", (int)(owner ? t->rq.o2t_size : t->rq.t2o_size),
            "opened", t->res.opened, "answered", t->res.answered,
            "size", t->res.size >= 0 ? json_integer(t->res.size) : json_null(),
            "wanted", t->res.wanted != 0 ? json_integer(t->res.wanted) : json_null(),
            "error", t->res.status != DR_OK ? dr_strerror(t->res.status) : NULL);
        if (json_array_append_new(arr, o) != 0) {
            json_decref(arr);
            arr = NULL;
        }
    }
    return arr;
}

static json_t *probe_json(const probe_row_t *rows, const dr_identity_t *id,
                          bool have_id, const probe_layout_t *pl)
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
                              "size_from", r->size < 0 ? NULL : size_from(r),
                              "result", result,
                              "error", r->error != DR_OK ? dr_strerror(r->error) : NULL);
        if (json_array_append_new(arr, o) != 0) {
            json_decref(arr);
            arr = NULL;
        }
    }
    json_t *ident = have_id ? identity_json(id, false) : json_null();
    json_t *points = pl->asked ? json_pack("[o?, o?]", point_json("input", &pl->in),
                                           point_json("output", &pl->out))
                               : json_array();
    return json_pack("{s:o?, s:o?, s:o?, s:o?, s:s?, s:b}", "assemblies", arr, "points",
                     points, "identity", ident, "trials", trials_json(pl), "layout",
                     pl->matched ? dr_layout_name(pl->kind) : NULL, "ok", pl->matched);
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

/* probe's own options: --open and what the trial needs. */
typedef struct {
    bool open;
    const char *udp_port, *rpi;
    uint32_t rpi_ms;
} probe_opts_t;

static int probe_parse(const char *cmd, int argc, char **argv, const cli_net_opts_t *lead,
                       cli_net_opts_t *o, probe_opts_t *po, dr_client_config_t *cfg)
{
    memset(po, 0, sizeof *po);
    const cli_opt_t extra[PROBE_NOPTS] = {
        {"open", 'o', &po->open, NULL, NULL},
        {"udp-port", 0, NULL, &po->udp_port, NULL},
        {"rpi", 0, NULL, &po->rpi, NULL},
    };
    int rc = parse_common(&cli_cmd_probe, argc, argv, lead, o, cfg, extra, PROBE_NOPTS);
    if (rc != CLI_EXIT_OK)
        return rc;
    unsigned long n = 100;
    if ((po->udp_port != NULL || po->rpi != NULL) && !po->open)
        return cli_error(CLI_EXIT_USAGE, cmd, "--udp-port and --rpi go with --open");
    if (po->udp_port != NULL && !cli_parse_ulong(po->udp_port, 1, 65535, &n))
        return cli_error(CLI_EXIT_USAGE, cmd,
                         "--udp-port '%s': expected a port number in 1..65535", po->udp_port);
    if (po->udp_port != NULL)
        cfg->local_udp_port = (uint16_t)n;
    n = 100;
    if (po->rpi != NULL && !cli_parse_ulong(po->rpi, 1, 10000, &n))
        return cli_error(CLI_EXIT_USAGE, cmd, "--rpi '%s': expected milliseconds in 1..10000",
                         po->rpi);
    po->rpi_ms = (uint32_t)n;
    return CLI_EXIT_OK;
}

static int run_probe(const char *cmd, int argc, char **argv,
                     const cli_net_opts_t *lead)
{
    cli_net_opts_t o;
    cli_net_t net;
    probe_opts_t po;
    dr_client_config_t cfg;
    int rc = probe_parse(cmd, argc, argv, lead, &o, &po, &cfg);
    if (rc == CLI_EXIT_OK)
        rc = cli_net_connect(cmd, &cfg, &net);
    if (rc != CLI_EXIT_OK)
        return rc < 0 ? CLI_EXIT_OK : rc;

    probe_row_t rows[DR_ASM_COUNT];
    for (unsigned a = 0; rc == CLI_EXIT_OK && a < DR_ASM_COUNT; a++)
        rc = probe_asm(&net, (dr_asm_t)a, &rows[a]);
    unsigned good = rc == CLI_EXIT_OK ? count_good(rows) : 0;
    dr_identity_t id;
    bool have_id = false;
    char ident[160];
    if (rc == CLI_EXIT_OK)
        rc = probe_identity(&net, &id, &have_id, ident, sizeof ident);
    /* The combined layout's instances only when the ten are not all
     * there: a target may end the session over an object it lacks. */
    probe_layout_t pl;
    memset(&pl, 0, sizeof pl);
    pl.count = pl.max = -1;
    pl.open = po.open;
    if (rc == CLI_EXIT_OK && good == DR_ASM_COUNT) {
        pl.matched = true;
        pl.kind = DR_LAYOUT_PER_ASSEMBLY;
    } else if (rc == CLI_EXIT_OK) {
        rc = probe_points(&net, rows, &pl);
    }
    /* Get was not enough: the Forward Open trial, when asked for */
    if (rc == CLI_EXIT_OK && !pl.matched && po.open) {
        rc = probe_trials(&net, rows, &pl, po.rpi_ms);
        good = count_good(rows);
        probe_match(rows, &pl);
    }
    if (rc == CLI_EXIT_OK && o.json)
        rc = cli_json_print(cmd, probe_json(rows, &id, have_id, &pl));
    else if (rc == CLI_EXIT_OK) {
        print_probe(rows, ident, good);
        print_layout(&net, &pl);
    }
    cli_net_close(&net); /* waits for the answers of the trials' Forward Closes */
    if (rc == CLI_EXIT_OK && !pl.matched)
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
