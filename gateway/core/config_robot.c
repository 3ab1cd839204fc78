/* SPDX-License-Identifier: MIT */
/*
 * [robot NAME] (the core): its keys, the instance.* and open.* families,
 * the defaults of the connection plan, and the checks of one robot's own
 * keys (config_internal.h; robots against each other: config_check.c).
 * The sides' keys of [robot NAME] (gw_side_cfg_t.robot) are merged into
 * its table here, each where its `after` says.
 */
#include "core/config_internal.h"

#include <stdlib.h>
#include <string.h>

#define R(m) GW_CFG_AT(gw_robot_config_t, m)
/* Robot keys of the connection plan (gw_robot_default_plan). */
#define RK_PLAN (1u << 16)
#define LINK GW_CFG_LINK
#define OPEN_ALLOWED "owner:<O->T assembly>, input_only, listen_only, none"

static gw_cfg_parse_fn robot_serial, robot_instance, robot_open, robot_point;
static const char *asm_item(unsigned i);

static const gw_cfg_key_t robot_keys[] = {
    { .name = "host", .type = GW_CFG_HOST, .flags = GW_CFG_REQUIRED | LINK, R(host), .allowed = "an IPv4 address or a host name", .help = "the robot controller. A name is resolved once, when the configuration is loaded (start, SIGHUP), so that reconnects never wait for DNS; one that does not resolve stops the start (exit 1, systemd retries) or refuses the reload. While it resolves, the daemon waits (at most the resolver's timeout, `/etc/resolv.conf`); an IPv4 address never waits" },
    { .name = "tcp_port", .type = GW_CFG_UINT, .flags = LINK, R(tcp_port), .lo = 1, .hi = 65535, .def = 44818, .help = "EtherNet/IP encapsulation port" },
    { .name = "udp_port", .type = GW_CFG_UINT, .flags = LINK, R(udp_port), .lo = 1, .hi = 65535, .def = 2222, .help = "the robot's Class 1 (implicit I/O) UDP port" },
    { .name = "local_address", .type = GW_CFG_IPV4, .flags = LINK, R(local_addr), .allowed = "an IPv4 address", .doc_default = "any", .help = "local address for the Class 1 UDP socket" },
    { .name = "local_udp_port", .type = GW_CFG_UINT, .flags = LINK, R(local_udp_port), .lo = 1, .hi = 65535, .def = 2222, .help = "local Class 1 UDP port. If another program has it (`cannot open UDP 0.0.0.0:2222 for Class 1 I/O: address already in use`), set `local_address` to another address of this host or `local_udp_port` to a free port (the robot is told where to send in the Forward Open)" },
    { .name = "mode", .type = GW_CFG_ENUM, .flags = LINK, R(mode), GW_CFG_NAMES("implicit", "explicit"), .def = GW_MODE_IMPLICIT, .help = "`implicit`: Class 1 connections exchanging data every `rpi_ms`. `explicit`: cyclic Get/Set_Attribute_Single over TCP every `rpi_ms` (for networks that block UDP 2222)" },
    { .name = "rpi_ms", .type = GW_CFG_UINT, .flags = LINK, R(rpi_ms), .lo = 1, .hi = 10000, .def = 10, .help = "implicit: requested packet interval. Explicit: poll period" },
    /* CIP's code: timeout = RPI x (4 << code) */
    { .name = "timeout_multiplier", .type = GW_CFG_UINT, .flags = LINK, R(timeout_mult), .lo = 0, .hi = 7, .def = 2, .help = "implicit: the connection times out after `rpi_ms × (4 << code)`, that is ×4, ×8, ×16 (default), ×32, ×64, ×128, ×256, ×512" },
    { .name = "timeout_ms", .type = GW_CFG_UINT, .flags = LINK, R(timeout_ms), .lo = 10, .hi = 60000, .def = 1000, .help = "explicit request timeout" },
    { .name = "o2t_timing", .type = GW_CFG_ENUM, .flags = LINK, R(o2t_strict), GW_CFG_NAMES("follow", "strict"), .help = "implicit: when O->T packets go out. `strict`: on the gateway's own timer, every `rpi_ms`. `follow`: an O->T packet due within a quarter of `rpi_ms` is sent as soon as the robot's T->O packet of that connection arrives, so the gateway wakes up once per RPI instead of twice (about a third less CPU); a packet leaves at most a quarter RPI before its time, two packets of a connection are never closer than three quarters of an RPI, and the rate never exceeds one packet per RPI; when the arrivals drift out of that window (the robot's clock runs a little slow or fast, as every real clock does) the O->T schedule moves later to follow them, by at most an eighth of an RPI per period (intervals a little longer, never shorter): no interval is longer than 1.25 RPI (a packet a quarter RPI early, the next on its time)" },
    { .name = "config_instance", .type = GW_CFG_UINT, .flags = LINK | RK_PLAN, R(config_instance), .lo = 1, .hi = 65535, .def = 1, .help = "configuration instance (connection point) in every Forward Open; see [Connection plan](#connection-plan)" },
    { .name = "input_only_heartbeat", .type = GW_CFG_UINT, .flags = LINK | RK_PLAN, R(input_only_heartbeat), .lo = 1, .hi = 65535, .def = 198, .help = "O->T connection point of input-only connections" },
    { .name = "listen_only_heartbeat", .type = GW_CFG_UINT, .flags = LINK | RK_PLAN, R(listen_only_heartbeat), .lo = 1, .hi = 65535, .def = 199, .help = "O->T connection point of listen-only connections" },
    /* often written in hex, as tools show it; 0 (the default): derived at start (link.c) */
    { .name = "originator_serial", .type = GW_CFG_HOOK, .flags = LINK, R(originator_serial), .parse = robot_serial, .allowed = "1..4294967295, or 0x1..0xFFFFFFFF", .doc_default = "derived from the machine and the robot's name, see [below](#originator_serial)", .help = "the originator serial number of every Forward Open: the robot gives the owner connections of a gateway that stopped uncleanly back only to the same serial" },
    { .name = "eds", .type = GW_CFG_TEXT, .flags = LINK, R(eds), .allowed = "an EDS file (absolute, or relative to this file's folder)", .doc_default = "(none)", .doc_allowed = "an EDS file", .help = "the robot's EDS (Electronic Data Sheet): its plan, as `drcli eds FILE` prints it, sets `layout`, `input_instance`, `input_size`, `output_instance`, `output_size` (or `output_assemblies = none` for an input-only plan), `config_instance`, `input_only_heartbeat`, `listen_only_heartbeat` and `rpi_ms`; a key set in the section wins over the EDS, and `rpi_ms` must lie in the EDS's RPI range. Read at start, `--check-config` and reload; an error in it is told as the EDS's FILE:LINE at this key's line. See [EDS files](#eds-files)" },
    { .name = "layout", .type = GW_CFG_ENUM, .flags = LINK, R(layout), GW_CFG_NAMES("per_assembly", "combined", "gpr_only"), .def = DR_LAYOUT_PER_ASSEMBLY, .help = "how the robot offers the assemblies: `per_assembly`, one instance each (`instance.*`, `open.*`); `combined`, one T->O instance carrying the six T->O assemblies back to back (476 bytes) and one O->T instance carrying the four O->T ones (212 bytes), one connection between them; `gpr_only`, the same with the register assemblies only (200 bytes each way). See [Layouts](#layouts)" },
    { .name = "input_instance", .type = GW_CFG_UINT, .flags = LINK, R(input.instance), .lo = 1, .hi = 65535, .def = DR_LAYOUT_INPUT_INSTANCE, .help = "`combined`, `gpr_only`: the T->O (input) assembly instance" },
    { .name = "input_assemblies", .type = GW_CFG_HOOK, .flags = LINK, R(input), .parse = robot_point, .allowed = "T->O assembly names in wire order, separated by commas or blanks", .doc_default = "the layout's: all six T->O assemblies (`combined`), `bit_out, int_out, float_out` (`gpr_only`)", .doc_allowed = "T->O assembly names in wire order", .help = "`combined`, `gpr_only`: what the input instance carries, back to back, in that order" },
    { .name = "input_size", .type = GW_CFG_UINT, .flags = LINK, R(input.size), .lo = 0, .hi = 65535, .doc_allowed = "0..65535, 0 = the sum", .doc_default = "the sum of `input_assemblies`", .help = "`combined`, `gpr_only`: the input instance's size in bytes, as the robot's EDS or `drcli probe` gives it; `--check-config` refuses one that is not the sum of `input_assemblies`" },
    { .name = "output_instance", .type = GW_CFG_UINT, .flags = LINK, R(output.instance), .lo = 1, .hi = 65535, .def = DR_LAYOUT_OUTPUT_INSTANCE, .help = "`combined`, `gpr_only`: the O->T (output) assembly instance" },
    { .name = "output_assemblies", .type = GW_CFG_HOOK, .flags = LINK, R(output), .parse = robot_point, .allowed = "O->T assembly names in wire order, separated by commas or blanks, or none", .doc_default = "the layout's: all four O->T assemblies (`combined`), `bit_in, int_in, float_in` (`gpr_only`)", .doc_allowed = "O->T assembly names in wire order, or `none`", .help = "`combined`, `gpr_only`: what the output instance carries; `none`: no output, the connection is input-only (another device, a PLC, owns the outputs)" },
    { .name = "output_size", .type = GW_CFG_UINT, .flags = LINK, R(output.size), .lo = 0, .hi = 65535, .doc_allowed = "0..65535, 0 = the sum", .doc_default = "the sum of `output_assemblies`", .help = "`combined`, `gpr_only`: the output instance's size in bytes; must be the sum of `output_assemblies`" },
    /* the families last: "allowed:" lists them after the plain keys */
    { .name = "instance.<assembly>", .type = GW_CFG_PREFIX, .flags = LINK, R(instance), .parse = robot_instance, .item = asm_item, .doc_default = "see below", .doc_allowed = "1..65535, one per assembly", .help = "assembly instance numbers, if the robot is configured differently" },
    { .name = "open.<T->O assembly>", .type = GW_CFG_PREFIX, .flags = LINK, R(open), .parse = robot_open, .item = asm_item, .doc_default = "see below", .doc_allowed = "`owner:<O->T assembly>`, `input_only`, `listen_only`, `none`", .help = "how the connection for that T->O assembly is opened" },
};

/* Where instance.* and open.* were set, by assembly (0: not set): the
 * side's scratch. */
typedef struct {
    unsigned instance[DR_ASM_COUNT];
    unsigned open[DR_ASM_COUNT];
    bool output_none; /* output_assemblies = none */
} robot_lines_t;

static void robot_defaults(void *sec);

/* The core's keys and the sides' (gw_cfg_robot_merge): the table the
 * loader, its messages and the docs read. */
static gw_cfg_key_t robot_all[GW_CFG_MAX_KEYS];

gw_cfg_side_t gw_cfg_robot = {
    .kw = "robot",
    .rank = 30,
    GW_CFG_NAMED(robot, robot_count, gw_robot_config_t),
    .lone_name = "robot",
    GW_CFG_KEYS(robot_keys), /* until gw_cfg_robot_merge */
    .scratch = sizeof(robot_lines_t),
    .defaults = robot_defaults,
    .check = gw_cfg_check_robots,
};

/* The sides' keys that come after core key `after` (NULL: those whose
 * `after` is NULL or names no core key) appended to robot_all[*n]. */
static void merge_after(const char *after, unsigned *n)
{
    for (unsigned j = 0; j < GW_SIDE_COUNT; j++) {
        const gw_cfg_robot_keys_t *rk = gw_side_cfgs[j]->robot;
        for (unsigned k = 0; rk != NULL && k < rk->nkeys; k++) {
            const char *a = rk->keys[k].after;
            bool known = false;
            for (unsigned i = 0; a != NULL && i < GW_CFG_COUNT(robot_keys); i++)
                known |= robot_keys[i].name != NULL && strcmp(robot_keys[i].name, a) == 0;
            bool here = after != NULL ? known && a != NULL && strcmp(a, after) == 0 : !known;
            /* past GW_CFG_MAX_KEYS a key is left out (test_gw_config.c
             * checks that every side's key is in) */
            if (here && *n < GW_CFG_MAX_KEYS)
                robot_all[(*n)++] = rk->keys[k];
        }
    }
}

void gw_cfg_robot_merge(void)
{
    static bool merged;
    if (merged)
        return;
    unsigned n = 0;
    bool rest = false; /* the keys of no core key: before the families */
    for (unsigned i = 0; i < GW_CFG_COUNT(robot_keys); i++) {
        if (robot_keys[i].type == GW_CFG_PREFIX && !rest) {
            merge_after(NULL, &n);
            rest = true;
        }
        if (n < GW_CFG_MAX_KEYS)
            robot_all[n++] = robot_keys[i];
        merge_after(robot_keys[i].name, &n);
    }
    if (!rest)
        merge_after(NULL, &n);
    gw_cfg_robot.keys = robot_all;
    gw_cfg_robot.nkeys = n;
    merged = true;
}

static robot_lines_t *lines_of(gw_cfg_ctx_t *c, unsigned i)
{
    return gw_cfg_scratch(c, &gw_cfg_robot, i);
}

static const char *asm_item(unsigned i)
{
    return i < DR_ASM_COUNT ? dr_asm_info((dr_asm_t)i)->name : NULL;
}

/* An originator serial number: decimal as any number, or 0x and 1 to 8
 * hex digits; never 0 (the default, see gw_robot_config_t). */
static void robot_serial(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                         const char *name, const char *v)
{
    unsigned long n;
    if (v[0] != '0' || (v[1] != 'x' && v[1] != 'X')) {
        if (gw_cfg_get_uint(c, name, v, 1, 4294967295ul, &n))
            gw_cfg_store(c, k, sec, n);
        return;
    }
    size_t digits = strspn(v + 2, "0123456789abcdefABCDEF");
    if (digits == 0 || digits > 8 || v[2 + digits] != '\0') {
        gw_cfg_fail(c, c->lineno,
                    "%s '%s' invalid: not a 32-bit hex number (allowed: %s)",
                    name, v, k->allowed);
        return;
    }
    n = strtoul(v + 2, NULL, 16);
    if (n == 0)
        gw_cfg_fail(c, c->lineno, "%s %s out of range (allowed: %s)", name, v,
                    k->allowed);
    else
        gw_cfg_store(c, k, sec, n);
}

/* ---- instance.* and open.* ---------------------------------------------- */

/* The assembly `asm_name` (the part of key `name` after its prefix);
 * false, with a did-you-mean message, if there is no such assembly. */
static bool key_assembly(gw_cfg_ctx_t *c, const char *name,
                         const char *asm_name, dr_asm_t *a)
{
    if (dr_asm_lookup(asm_name, a) == DR_OK)
        return true;
    const char *names[DR_ASM_COUNT];
    gw_cfg_guess_t g = GW_CFG_GUESS(asm_name);
    for (unsigned i = 0; i < DR_ASM_COUNT; i++) {
        names[i] = asm_item(i);
        gw_cfg_guess(&g, names[i]);
    }
    char allowed[200], hint[96];
    gw_cfg_join(names, DR_ASM_COUNT, allowed, sizeof allowed);
    gw_cfg_fail(c, c->lineno,
                "unknown assembly '%s' in '%s' (%sallowed: %s, or dr1..dr10)",
                asm_name, name,
                gw_cfg_did_you_mean(&g, "'", "'", hint, sizeof hint), allowed);
    return false;
}

/* "io_state, joint_state, ..." for the assemblies of one direction. */
static void join_dir(dr_dir_t dir, char *buf, size_t size)
{
    const char *names[DR_ASM_COUNT];
    size_t n = 0;
    for (unsigned i = 0; i < DR_ASM_COUNT; i++)
        if (dr_asm_info((dr_asm_t)i)->dir == dir)
            names[n++] = asm_item(i);
    gw_cfg_join(names, n, buf, size);
}

/* key_assembly, of direction dir: else "SUBJECT invalid: ASSEMBLY WHY
 * (allowed: the assemblies of dir)". False after the message. */
static bool assembly_of(gw_cfg_ctx_t *c, const char *name, const char *asm_name,
                        dr_dir_t dir, const char *subject, const char *why,
                        dr_asm_t *a)
{
    if (!key_assembly(c, name, asm_name, a))
        return false;
    if (dr_asm_info(*a)->dir == dir)
        return true;
    char allowed[120];
    join_dir(dir, allowed, sizeof allowed);
    gw_cfg_fail(c, c->lineno, "%s invalid: %s %s (allowed: %s)", subject,
                asm_item(*a), why, allowed);
    return false;
}

/* A family key's assembly set once: instance.io_state and instance.dr1
 * are the same key. False after the message. */
static bool first_of_family(gw_cfg_ctx_t *c, const char *name, unsigned *seen,
                            const char *what, dr_asm_t a)
{
    if (*seen != 0) {
        gw_cfg_fail(c, c->lineno,
                    "key '%s' repeated in [%s] (%s of %s, first at line %u)",
                    name, c->sec_text, what, asm_item(a), *seen);
        return false;
    }
    *seen = c->lineno;
    return true;
}

static void robot_instance(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                           const char *name, const char *v)
{
    gw_robot_config_t *r = sec;
    dr_asm_t a;
    (void)k;
    if (!key_assembly(c, name, name + strlen("instance."), &a) ||
        !first_of_family(c, name, &lines_of(c, c->idx)->instance[a],
                         "instance", a))
        return;
    unsigned long n;
    if (v[0] == '\0')
        gw_cfg_fail(c, c->lineno, "%s has no value (allowed: 1..65535)", name);
    else if (gw_cfg_get_uint(c, name, v, 1, 65535, &n))
        r->instance[a] = (uint16_t)n;
}

/* The value of open.<T->O assembly>: "owner:<O->T assembly>",
 * "input_only", "listen_only" or "none". */
static void open_value(gw_cfg_ctx_t *c, const char *name, const char *v,
                       gw_open_t *o)
{
    static const char *const kinds[] = { "owner", "input_only", "listen_only",
                                         "none" };
    size_t n = strcspn(v, ":");
    for (unsigned k = 1; k < GW_CFG_COUNT(kinds); k++)
        if (strcmp(v, kinds[k]) == 0) {
            o->kind = (gw_open_kind_t)k;
            o->o2t = -1;
            return;
        }
    if (strcmp(v, kinds[0]) == 0) {
        gw_cfg_fail(c, c->lineno,
                    "%s 'owner' invalid: an owner connection needs its O->T "
                    "partner, e.g. owner:io_control (allowed: " OPEN_ALLOWED
                    ")",
                    name);
        return;
    }
    if (n != strlen(kinds[0]) || strncmp(v, kinds[0], n) != 0 || v[n] != ':') {
        gw_cfg_guess_t g = GW_CFG_GUESS(v);
        char hint[96];
        for (unsigned k = 0; k < GW_CFG_COUNT(kinds); k++)
            gw_cfg_guess(&g, kinds[k]);
        gw_cfg_fail(c, c->lineno, "%s '%s' invalid (%sallowed: " OPEN_ALLOWED ")",
                    name, v, gw_cfg_did_you_mean(&g, "'", "'", hint, sizeof hint));
        return;
    }
    char subject[300];
    snprintf(subject, sizeof subject, "%s '%s'", name, v);
    dr_asm_t p;
    if (!assembly_of(c, name, v + n + 1, DR_DIR_O2T, subject,
                     "is produced by the robot (T->O), an owner's partner must "
                     "be an O->T assembly",
                     &p))
        return;
    o->kind = GW_OPEN_OWNER;
    o->o2t = (int)p;
}

static void robot_open(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                       const char *name, const char *v)
{
    gw_robot_config_t *r = sec;
    dr_asm_t a;
    (void)k;
    char subject[300];
    snprintf(subject, sizeof subject, "key '%s'", name);
    if (!assembly_of(c, name, name + strlen("open."), DR_DIR_T2O, subject,
                     "is consumed by the robot (O->T); open.* names a T->O "
                     "assembly, which brings its O->T partner with owner:<O->T>",
                     &a))
        return;
    if (!first_of_family(c, name, &lines_of(c, c->idx)->open[a], "open", a))
        return;
    open_value(c, name, v, &r->open[a]);
}

/* input_assemblies / output_assemblies: assembly names of the key's
 * direction, each once, in wire order; output_assemblies may be none. */
static void robot_point(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                        const char *name, const char *v)
{
    gw_robot_config_t *r = sec;
    bool in = strcmp(name, "input_assemblies") == 0;
    dr_point_t *p = in ? &r->input : &r->output;
    dr_dir_t dir = in ? DR_DIR_T2O : DR_DIR_O2T;
    (void)k;
    uint16_t instance = p->instance, size = p->size;
    dr_point_t np;
    memset(&np, 0, sizeof np);
    if (!in && strcmp(v, "none") == 0) {
        lines_of(c, c->idx)->output_none = true;
        *p = np;
        p->instance = instance;
        p->size = size;
        return;
    }
    char buf[200];
    snprintf(buf, sizeof buf, "%s", v);
    char subject[300];
    char *save = NULL;
    for (char *tok = strtok_r(buf, ", \t", &save); tok != NULL;
         tok = strtok_r(NULL, ", \t", &save)) {
        dr_asm_t a;
        snprintf(subject, sizeof subject, "%s '%s'", name, tok);
        if (!assembly_of(c, name, tok, dir, subject,
                         in ? "is consumed by the robot (O->T); the input carries T->O assemblies"
                            : "is produced by the robot (T->O); the output carries O->T assemblies",
                         &a))
            return;
        for (unsigned i = 0; i < np.count; i++)
            if (np.asm_id[i] == (uint8_t)a) {
                gw_cfg_fail(c, c->lineno, "%s: %s named twice", name, asm_item(a));
                return;
            }
        if (np.count >= DR_POINT_MAX_ASM) { /* a repeat would have been caught */
            gw_cfg_fail(c, c->lineno, "%s: more than %u assemblies", name, DR_POINT_MAX_ASM);
            return;
        }
        np.asm_id[np.count++] = (uint8_t)a;
    }
    if (np.count == 0) {
        gw_cfg_fail(c, c->lineno, "%s has no value (allowed: %s)", name,
                    in ? "T->O assembly names" : "O->T assembly names, or none");
        return;
    }
    np.instance = instance;
    np.size = size;
    *p = np;
}

/* ---- defaults ------------------------------------------------------------- */

static void robot_defaults(void *sec)
{
    gw_robot_config_t *r = sec;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        r->instance[a] = DR_ASM_DEFAULT_INSTANCE(a);
    gw_robot_default_plan(r);
}

void gw_robot_default_plan(gw_robot_config_t *r)
{
    for (unsigned k = 0; k < GW_CFG_COUNT(robot_keys); k++)
        if (robot_keys[k].flags & RK_PLAN)
            gw_cfg_key_default(&robot_keys[k], r);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        r->open[a] = (gw_open_t){ GW_OPEN_NONE, -1 };
    r->open[DR_ASM_IO_STATE] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_IO_CONTROL };
    r->open[DR_ASM_BIT_OUT] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_BIT_IN };
    r->open[DR_ASM_INT_OUT] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_INT_IN };
    r->open[DR_ASM_FLOAT_OUT] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_FLOAT_IN };
    r->open[DR_ASM_JOINT_STATE] = (gw_open_t){ GW_OPEN_INPUT_ONLY, -1 };
    r->open[DR_ASM_TASK_STATE] = (gw_open_t){ GW_OPEN_INPUT_ONLY, -1 };
}

/* ---- one robot's own checks ------------------------------------------------ */

static unsigned line_or(unsigned key_line, unsigned section_line)
{
    return key_line != 0 ? key_line : section_line;
}

static unsigned max_line(unsigned a, unsigned b)
{
    return a > b ? a : b;
}

/* Two assemblies on one instance would read one another's data. */
static bool check_instances(gw_cfg_ctx_t *c, const gw_robot_config_t *r,
                            const robot_lines_t *rl)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        for (unsigned b = a + 1; b < DR_ASM_COUNT; b++) {
            if (r->instance[a] != r->instance[b])
                continue;
            gw_cfg_fail(c,
                        max_line(line_or(rl->instance[a], r->line),
                                 line_or(rl->instance[b], r->line)),
                        "robot '%s': instance %u used by both %s and %s (each "
                        "assembly needs its own instance)",
                        r->name, (unsigned)r->instance[a], asm_item(a),
                        asm_item(b));
            return false;
        }
    }
    return true;
}

/* A connection point of the plan (config_instance or a heartbeat in use)
 * that is also an assembly's instance: the target could not tell them
 * apart. False after reporting it. */
static bool check_point(gw_cfg_ctx_t *c, unsigned i, const char *key,
                        uint16_t inst)
{
    const gw_robot_config_t *r = &c->cfg.robot[i];
    const robot_lines_t *rl = lines_of(c, i);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (r->instance[a] != inst)
            continue;
        gw_cfg_fail(c,
                    max_line(line_or(gw_cfg_line(c, &gw_cfg_robot, i, key), r->line),
                             line_or(rl->instance[a], r->line)),
                    "robot '%s': %s %u is also the instance of %s (a "
                    "connection point names one thing)",
                    r->name, key, (unsigned)inst, asm_item(a));
        return false;
    }
    return true;
}

/* The configuration point equal to the heartbeat point `key` the plan
 * uses: a Forward Open would name one instance as both, which the robot
 * refuses at run time (the defaults invite it: listen_only_heartbeat is
 * 199, and 199 is a common configuration instance). False after
 * reporting it. */
static bool check_config_point(gw_cfg_ctx_t *c, unsigned i, const char *key,
                               uint16_t inst)
{
    const gw_robot_config_t *r = &c->cfg.robot[i];
    if (r->config_instance != inst)
        return true;
    unsigned hb_line = gw_cfg_line(c, &gw_cfg_robot, i, key);
    gw_cfg_fail(c,
                max_line(line_or(gw_cfg_line(c, &gw_cfg_robot, i, "config_instance"),
                                 r->line),
                         line_or(hb_line, r->line)),
                "robot '%s': config_instance %u is also %s (%sthe robot refuses "
                "a Forward Open that names one instance as both: set %s to "
                "another point of its EDS)",
                r->name, (unsigned)inst, key, hb_line != 0 ? "" : "its default; ",
                key);
    return false;
}

/* An O->T assembly with two owners: reported where the second one (in
 * the file) is. */
static void two_owners(gw_cfg_ctx_t *c, const gw_robot_config_t *r,
                       const robot_lines_t *rl, unsigned a, unsigned b)
{
    unsigned la = line_or(rl->open[a], r->line), lb = line_or(rl->open[b], r->line);
    unsigned later = la >= lb ? a : b, earlier = la >= lb ? b : a;
    char where[32];
    if (rl->open[earlier] != 0)
        snprintf(where, sizeof where, "line %u", rl->open[earlier]);
    else
        snprintf(where, sizeof where, "the default");
    gw_cfg_fail(c, max_line(la, lb),
                "robot '%s': O->T %s has two owners, %s and %s (%s; one "
                "exclusive owner connection per O->T assembly: make one of "
                "them input_only or listen_only)",
                r->name, asm_item((unsigned)r->open[a].o2t), asm_item(later),
                asm_item(earlier), where);
}

/* The connection plan: every O->T assembly has at most one owner, at
 * least one connection is opened, the instances it uses are distinct. */
static bool check_plan(gw_cfg_ctx_t *c, unsigned i)
{
    const gw_robot_config_t *r = &c->cfg.robot[i];
    const robot_lines_t *rl = lines_of(c, i);
    int owner[DR_ASM_COUNT];
    bool any = false, input_only = false, listen_only = false;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        owner[a] = -1;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const gw_open_t *o = &r->open[a];
        any |= o->kind != GW_OPEN_NONE;
        input_only |= o->kind == GW_OPEN_INPUT_ONLY;
        listen_only |= o->kind == GW_OPEN_LISTEN_ONLY;
        if (o->kind != GW_OPEN_OWNER)
            continue;
        if (owner[o->o2t] >= 0) {
            two_owners(c, r, rl, a, (unsigned)owner[o->o2t]);
            return false;
        }
        owner[o->o2t] = (int)a;
    }
    if (!any) {
        gw_cfg_fail(c, r->line,
                    "robot '%s': every open.* is none: nothing would be opened "
                    "(allowed: " OPEN_ALLOWED ")",
                    r->name);
        return false;
    }
    if (input_only && listen_only &&
        r->input_only_heartbeat == r->listen_only_heartbeat) {
        unsigned li = line_or(gw_cfg_line(c, &gw_cfg_robot, i, "input_only_heartbeat"), r->line);
        unsigned ll = line_or(gw_cfg_line(c, &gw_cfg_robot, i, "listen_only_heartbeat"), r->line);
        gw_cfg_fail(c, max_line(li, ll),
                    "robot '%s': input_only_heartbeat and listen_only_heartbeat "
                    "are both %u (the robot tells the two kinds apart by it)",
                    r->name, (unsigned)r->input_only_heartbeat);
        return false;
    }
    /* explicit mode opens no connection: its points are not used */
    bool implicit = r->mode == GW_MODE_IMPLICIT;
    if (implicit && input_only &&
        !check_config_point(c, i, "input_only_heartbeat", r->input_only_heartbeat))
        return false;
    if (implicit && listen_only &&
        !check_config_point(c, i, "listen_only_heartbeat", r->listen_only_heartbeat))
        return false;
    return check_point(c, i, "config_instance", r->config_instance) &&
           (!input_only ||
            check_point(c, i, "input_only_heartbeat", r->input_only_heartbeat)) &&
           (!listen_only ||
            check_point(c, i, "listen_only_heartbeat", r->listen_only_heartbeat));
}

/* "io_state 36 + joint_state 144 = 180" for the point's assemblies. */
static void point_sum_text(const dr_point_t *p, char *buf, size_t size)
{
    size_t n = 0;
    buf[0] = '\0';
    for (unsigned k = 0; k < p->count && n < size; k++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)p->asm_id[k]);
        int w = snprintf(buf + n, size - n, "%s%s %u", k ? " + " : "", info->name,
                         (unsigned)info->size);
        if (w < 0)
            return;
        n += (size_t)w;
    }
    if (n < size)
        snprintf(buf + n, size - n, " = %u", (unsigned)dr_point_sum(p));
}

/* ---- the robot's EDS (`eds`) ---------------------------------------------- */

/* Key `key` of robot i is not set in its section. */
static bool unset(gw_cfg_ctx_t *c, unsigned i, const char *key)
{
    return gw_cfg_line(c, &gw_cfg_robot, i, key) == 0;
}

/* An instance from the EDS where the configuration takes 1..65535. */
static bool eds_instance_ok(uint32_t v)
{
    return v >= 1 && v <= 65535;
}

/* "5 ms" or "0.5 ms" for a microsecond count, into buf. */
static void ms_text(uint32_t us, char *buf, size_t size)
{
    if (us % 1000u == 0)
        snprintf(buf, size, "%lu", (unsigned long)(us / 1000u));
    else
        snprintf(buf, size, "%lu.%03lu", (unsigned long)(us / 1000u),
                 (unsigned long)(us % 1000u));
}

/* rpi_ms (the section's or the EDS's) inside the plan connection's RPI
 * range (implicit mode). False after the message. */
static bool eds_rpi_check(gw_cfg_ctx_t *c, unsigned i, const eds_plan_t *p,
                          const char *file, unsigned key_line)
{
    const gw_robot_config_t *r = &c->cfg.robot[i];
    if (!p->has_rpi || r->mode != GW_MODE_IMPLICIT)
        return true;
    uint64_t us = (uint64_t)r->rpi_ms * 1000u;
    if (us >= p->rpi_min_us && us <= p->rpi_max_us)
        return true;
    char lo[24], hi[24];
    ms_text(p->rpi_min_us, lo, sizeof lo);
    ms_text(p->rpi_max_us, hi, sizeof hi);
    gw_cfg_fail(c, line_or(gw_cfg_line(c, &gw_cfg_robot, i, "rpi_ms"), key_line),
                "robot '%s': rpi_ms %lu is outside the robot's RPI range %s..%s ms "
                "(eds %s:%u, Connection%lu)", r->name, (unsigned long)r->rpi_ms, lo, hi,
                file, p->rpi_line, (unsigned long)p->rpi_conn);
    return false;
}

/* The points of a combined or gpr_only plan, where the section sets none. */
static void eds_points(gw_cfg_ctx_t *c, unsigned i, const eds_plan_t *p)
{
    gw_robot_config_t *r = &c->cfg.robot[i];
    if (unset(c, i, "input_instance") && eds_instance_ok(p->in_instance))
        r->input.instance = (uint16_t)p->in_instance;
    if (unset(c, i, "input_size"))
        r->input.size = p->in_size;
    if (p->out_instance == 0) { /* input-only: another device owns the outputs */
        if (unset(c, i, "output_assemblies") && unset(c, i, "output_instance") &&
            unset(c, i, "output_size")) {
            lines_of(c, i)->output_none = true;
            r->output.count = 0;
        }
        return;
    }
    if (unset(c, i, "output_instance") && eds_instance_ok(p->out_instance))
        r->output.instance = (uint16_t)p->out_instance;
    if (unset(c, i, "output_size"))
        r->output.size = p->out_size;
}

/* Robot i's EDS, if it names one: its plan for every key the section
 * does not set. False after the message. */
static bool apply_eds(gw_cfg_ctx_t *c, unsigned i)
{
    gw_robot_config_t *r = &c->cfg.robot[i];
    if (r->eds[0] == '\0')
        return true;
    unsigned kl = line_or(gw_cfg_line(c, &gw_cfg_robot, i, "eds"), r->line);
    eds_plan_t plan;
    char file[600];
    if (!gw_cfg_eds_load(c, kl, r->name, r->eds, &plan, file, sizeof file))
        return false;
    if (unset(c, i, "layout")) {
        if (!plan.matched) {
            gw_cfg_fail(c, kl,
                        "robot '%s': eds %s:%u: its sizes match no layout (input %u, "
                        "output %u bytes; per_assembly wants the ten assemblies at "
                        "101..110, combined 476 and 212 bytes, gpr_only 200 and 200): "
                        "set layout and its keys here (drcli eds %s says more)",
                        r->name, file, plan.plan_line != 0 ? plan.plan_line : 1u,
                        (unsigned)plan.in_size, (unsigned)plan.out_size, file);
            return false;
        }
        r->layout = plan.kind;
    }
    if (plan.matched && plan.kind == r->layout && r->layout != DR_LAYOUT_PER_ASSEMBLY)
        eds_points(c, i, &plan);
    if (unset(c, i, "config_instance") && eds_instance_ok(plan.config_instance))
        r->config_instance = (uint16_t)plan.config_instance;
    if (unset(c, i, "input_only_heartbeat") && eds_instance_ok(plan.input_only_hb))
        r->input_only_heartbeat = (uint16_t)plan.input_only_hb;
    if (unset(c, i, "listen_only_heartbeat") && eds_instance_ok(plan.listen_only_hb))
        r->listen_only_heartbeat = (uint16_t)plan.listen_only_hb;
    if (unset(c, i, "rpi_ms") && plan.rpi_ms != 0)
        r->rpi_ms = plan.rpi_ms;
    return eds_rpi_check(c, i, &plan, file, kl);
}

/* The layout keys apply to their layout only; a combined layout's points
 * get their default assemblies and sizes here, and a size that does not
 * add up is refused where it is written. False after the message. */
static bool check_layout(gw_cfg_ctx_t *c, unsigned i)
{
    gw_robot_config_t *r = &c->cfg.robot[i];
    const robot_lines_t *rl = lines_of(c, i);
    static const char *const point_keys[] = { "input_instance", "input_assemblies",
                                              "input_size", "output_instance",
                                              "output_assemblies", "output_size" };
    if (r->layout == DR_LAYOUT_PER_ASSEMBLY) {
        for (unsigned k = 0; k < GW_CFG_COUNT(point_keys); k++) {
            unsigned line = gw_cfg_line(c, &gw_cfg_robot, i, point_keys[k]);
            if (line == 0)
                continue;
            gw_cfg_fail(c, line,
                        "robot '%s': %s applies to layout combined or gpr_only (this "
                        "robot's layout is per_assembly: set layout = combined, or "
                        "use instance.* and open.*)",
                        r->name, point_keys[k]);
            return false;
        }
        return true;
    }
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        unsigned line = rl->instance[a] ? rl->instance[a] : rl->open[a];
        if (line == 0)
            continue;
        gw_cfg_fail(c, line,
                    "robot '%s': %s.%s applies to layout per_assembly (layout %s has "
                    "input_instance and output_instance)",
                    r->name, rl->instance[a] ? "instance" : "open", asm_item(a),
                    dr_layout_name(r->layout));
        return false;
    }
    dr_layout_t def;
    dr_layout_default(&def, r->layout);
    dr_point_t *pts[2] = { &r->input, &r->output };
    const dr_point_t *defs[2] = { &def.input, &def.output };
    for (unsigned k = 0; k < 2; k++) {
        dr_point_t *p = pts[k];
        bool none = k == 1 && rl->output_none;
        if (p->count == 0 && !none) { /* the layout's assemblies */
            uint16_t inst = p->instance, size = p->size;
            *p = *defs[k];
            p->instance = inst;
            p->size = size;
        }
        const char *what = k == 0 ? "input" : "output";
        char key[24];
        snprintf(key, sizeof key, "%s_size", what);
        unsigned size_line = gw_cfg_line(c, &gw_cfg_robot, i, key);
        if (none) {
            if (size_line != 0) {
                gw_cfg_fail(c, size_line,
                            "robot '%s': output_size %u, but output_assemblies is none",
                            r->name, (unsigned)p->size);
                return false;
            }
            p->size = 0;
            continue;
        }
        uint16_t sum = dr_point_sum(p);
        if (p->size == 0)
            p->size = sum;
        if (p->size != sum) {
            char text[200];
            point_sum_text(p, text, sizeof text);
            snprintf(key, sizeof key, "%s_assemblies", what);
            unsigned asm_line = gw_cfg_line(c, &gw_cfg_robot, i, key);
            gw_cfg_fail(c, max_line(line_or(size_line, r->line), asm_line),
                        "robot '%s': %s_size %u does not add up: %s bytes (layout %s; "
                        "set %s_size to %u, or %s_assemblies to what the robot's EDS or "
                        "drcli probe says its instance carries)",
                        r->name, what, (unsigned)p->size, text, dr_layout_name(r->layout),
                        what, (unsigned)sum, what);
            return false;
        }
    }
    unsigned li = line_or(gw_cfg_line(c, &gw_cfg_robot, i, "input_instance"), r->line);
    unsigned lo = line_or(gw_cfg_line(c, &gw_cfg_robot, i, "output_instance"), r->line);
    if (r->output.count != 0 && r->input.instance == r->output.instance) {
        gw_cfg_fail(c, max_line(li, lo),
                    "robot '%s': input_instance and output_instance are both %u (each "
                    "needs its own instance)",
                    r->name, (unsigned)r->input.instance);
        return false;
    }
    struct { const char *key; uint16_t v; bool used; } pt[] = {
        { "config_instance", r->config_instance, true },
        { "input_only_heartbeat", r->input_only_heartbeat, r->output.count == 0 },
    };
    for (unsigned k = 0; k < GW_CFG_COUNT(pt); k++) {
        if (!pt[k].used)
            continue;
        bool in = pt[k].v == r->input.instance;
        if (!in && !(r->output.count != 0 && pt[k].v == r->output.instance))
            continue;
        gw_cfg_fail(c,
                    max_line(line_or(gw_cfg_line(c, &gw_cfg_robot, i, pt[k].key), r->line),
                             in ? li : lo),
                    "robot '%s': %s %u is also the %s instance (a connection point "
                    "names one thing)",
                    r->name, pt[k].key, (unsigned)pt[k].v, in ? "input" : "output");
        return false;
    }
    if (r->mode == GW_MODE_IMPLICIT && r->output.count == 0 &&
        !check_config_point(c, i, "input_only_heartbeat", r->input_only_heartbeat))
        return false;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        r->open[a] = (gw_open_t){ GW_OPEN_NONE, -1 };
    return true;
}

bool gw_cfg_robot_check(gw_cfg_ctx_t *c, unsigned i)
{
    if (!apply_eds(c, i) || !check_layout(c, i))
        return false;
    if (c->cfg.robot[i].layout != DR_LAYOUT_PER_ASSEMBLY)
        return true;
    return check_instances(c, &c->cfg.robot[i], lines_of(c, i)) &&
           check_plan(c, i);
}

bool gw_robot_owns(const gw_robot_config_t *r, dr_asm_t a)
{
    if (r->layout != DR_LAYOUT_PER_ASSEMBLY)
        return dr_point_has(&r->output, a);
    for (unsigned t = 0; t < DR_ASM_COUNT; t++)
        if (r->open[t].kind == GW_OPEN_OWNER && r->open[t].o2t == (int)a)
            return true;
    return false;
}

bool gw_robot_reads(const gw_robot_config_t *r, dr_asm_t a)
{
    if (r->layout != DR_LAYOUT_PER_ASSEMBLY)
        return dr_point_has(&r->input, a);
    return r->open[a].kind != GW_OPEN_NONE;
}

/* ---- public API ------------------------------------------------------------ */

bool gw_robot_config_same_link(const gw_robot_config_t *a,
                               const gw_robot_config_t *b)
{
    /* The core's keys marked LINK; not compared: name (the caller pairs
     * robots by it), line, and the sides' keys (none reconnects). */
    for (unsigned k = 0; k < GW_CFG_COUNT(robot_keys); k++) {
        const gw_cfg_key_t *key = &robot_keys[k];
        if (!(key->flags & GW_CFG_LINK))
            continue;
        const char *x = (const char *)a + key->off, *y = (const char *)b + key->off;
        bool text = key->type == GW_CFG_HOST || key->type == GW_CFG_IPV4 ||
                    key->type == GW_CFG_TEXT;
        if (text ? strcmp(x, y) != 0 : memcmp(x, y, key->size) != 0)
            return false;
    }
    return true;
}
