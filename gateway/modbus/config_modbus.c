/* SPDX-License-Identifier: MIT */
/*
 * The Modbus side's sections (config_internal.h): [modbus], the TCP
 * server, with its allowlist, and [modbus_rtu NAME], one serial line on
 * which the gateway is an RTU slave (their struct: config_modbus.h). Its
 * robots are resolved once the whole file is read (rtu_check, below).
 * And its keys of [robot NAME] (unit_id, unit_id_alias, map,
 * default_map_writes, fallback), in the robot's side.modbus, merged into
 * the core's table of [robot NAME] (config_internal.h: gw_cfg_robot_keys_t).
 */
#include "core/config_internal.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdlib.h>
#include <string.h>

#include "core/robot.h" /* gw_write_policy_t */
#include "modbus/regmap.h"
#include "modbus/usermap.h"

/* ---- [modbus] -------------------------------------------------------------- */

#define M(m) GW_CFG_AT(gw_modbus_config_t, m)

static gw_cfg_parse_fn modbus_allow;

static const gw_cfg_key_t modbus_keys[] = {
    { .name = "listen", .type = GW_CFG_IPV4, M(listen), .def_text = "0.0.0.0", .allowed = "an IPv4 address such as 0.0.0.0", .help = "local address to listen on; `0.0.0.0` = all interfaces" },
    { .name = "port", .type = GW_CFG_UINT, M(port), .lo = 1, .hi = 65535, .def = 502, .help = "TCP port. Ports below 1024 need `CAP_NET_BIND_SERVICE`, which the systemd unit grants" },
    { .name = "max_clients", .type = GW_CFG_UINT, M(max_clients), .lo = 1, .hi = 256, .def = 16, .help = "clients served at once. One more is accepted, logged and closed at once, never left hanging" },
    { .name = "idle_timeout", .type = GW_CFG_UINT, M(idle_timeout_s), .lo = 0, .hi = 86400, .def = 60, .allowed = "0..86400 seconds, 0 = never", .help = "close a client that sent no complete request for this long (bytes of an unfinished request do not count); `0` = never" },
    { .name = "keepalive", .type = GW_CFG_BOOL, M(keepalive), .def = 1, .help = "TCP keepalive on client sockets, so dead peers (a PLC switched off) are found" },
    { .name = "word_order", .type = GW_CFG_ENUM, M(word_order), .names = gw_word_order_names, .def = GW_WORD_ABCD, .help = "how 32-bit values (REAL, DINT) are laid out in two registers; see below" },
    { .name = "allow", .type = GW_CFG_HOOK, .flags = GW_CFG_LIST, .parse = modbus_allow, .allowed = "a.b.c.d/len [ro|rw]", .doc_default = "(none: everyone read-write)", .doc_allowed = "`a.b.c.d/len [ro|rw]`, repeatable, at most 16", .help = "client networks allowed to connect; see below" },
    { .name = "on_link_loss", .type = GW_CFG_ENUM, M(on_link_loss), GW_CFG_NAMES("hold", "zero", "exception"), .def = GW_LOSS_HOLD, .help = "what Modbus sees of a robot whose link is down; see below" },
    { .name = "unmapped_read", .type = GW_CFG_ENUM, M(unmapped_read), GW_CFG_NAMES("zero", "exception"), .def = GW_UNMAPPED_ZERO, .help = "a read that covers reserved addresses between the map's blocks: they read 0 (so 125-register block reads work), or the whole read is refused with 0x02. Reads past a table's last mapped address and writes to reserved addresses are refused either way ([register-map.md](register-map.md))" },
    { .name = "single_writer", .type = GW_CFG_BOOL, M(single_writer), .def = 0, .help = "write lock: only one client may write O->T data; see below" },
    { .name = "writer_watchdog_ms", .type = GW_CFG_UINT, M(writer_watchdog_ms), .lo = 10, .hi = 60000, .def = 1000, .help = "single-writer mode: the owner must write the watchdog register at least this often" },
    { .name = "request_timeout_ms", .type = GW_CFG_UINT, M(request_timeout_ms), .lo = 100, .hi = 60000, .def = 3000, .help = "a request must be complete this long after its first byte, or its client is closed; also how long a client must have gone without a complete request before a newcomer may evict it (see max_clients below)" },
};

/* The line of each allow entry: the side's scratch. */
typedef struct {
    unsigned allow_line[GW_MAX_ALLOW];
} modbus_lines_t;

static const gw_cfg_side_t gw_cfg_modbus = {
    .kw = "modbus",
    .rank = 20,
    .base = offsetof(gw_config_t, side.modbus),
    .name_off = GW_CFG_NONE,
    .line_off = GW_CFG_NONE,
    GW_CFG_KEYS(modbus_keys),
    .scratch = sizeof(modbus_lines_t),
};

/* "a.b.c.d/len [ro|rw]": config.c's gw_cfg_allow, shared with [http]. */
static void modbus_allow(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                         const char *name, const char *v)
{
    gw_modbus_config_t *m = sec;
    modbus_lines_t *ml = gw_cfg_scratch(c, &gw_cfg_modbus, 0);
    (void)k;
    (void)name;
    gw_cfg_allow(c, v, m->allow, &m->allow_count, ml->allow_line);
}

/* ---- [modbus_rtu NAME] ------------------------------------------------------ */

#define U(m) GW_CFG_AT(gw_rtu_config_t, m)
#define BAUDS "1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400"

/* [modbus_rtu NAME] robots = ..., as written: resolved against the robot
 * sections once the file is read (rtu_check). The side's scratch. */
typedef struct {
    char robot[GW_MAX_ROBOTS][GW_NAME_MAX];
    bool addr_given[GW_MAX_ROBOTS];
} gw_cfg_rtu_robots_t;

static gw_cfg_parse_fn rtu_baud, rtu_robots;
static void rtu_check(gw_cfg_ctx_t *c);

static const gw_cfg_key_t rtu_keys[] = {
    { .name = "device", .type = GW_CFG_TEXT, .flags = GW_CFG_REQUIRED, U(device), .valid = gw_cfg_no_blank, .allowed = "a serial port such as /dev/ttyS0", .doc_allowed = "a serial port, such as `/dev/ttyS1`, `/dev/ttyUSB0`, `/dev/ttyAMA0`; each line its own", .help = "opened non-blocking, raw, no flow control" },
    { .name = "baud", .type = GW_CFG_UINT, U(baud), .lo = 1200, .hi = 230400, .def = 19200, .parse = rtu_baud, .allowed = BAUDS, .help = "line speed in bits per second" },
    { .name = "parity", .type = GW_CFG_ENUM, U(parity), GW_CFG_NAMES("none", "even", "odd"), .def = GW_PARITY_EVEN, .help = "the Modbus default is even; with `none` the specification asks for `stop_bits = 2`" },
    { .name = "data_bits", .type = GW_CFG_UINT, U(data_bits), .lo = 8, .hi = 8, .def = 8, .allowed = "8", .help = "RTU carries 8-bit bytes" },
    { .name = "stop_bits", .type = GW_CFG_UINT, U(stop_bits), .lo = 1, .hi = 2, .def = 1, .allowed = "1, 2", .help = "stop bits after each byte" },
    { .name = "rs485", .type = GW_CFG_BOOL, U(rs485), .help = "ask the kernel driver for RS-485 mode (`TIOCSRS485`): it drives RTS, the transceiver's direction, around each reply. A port that refuses (a pty, many USB adapters, which switch by themselves) is logged as a warning and served anyway" },
    { .name = "rts_on_send", .type = GW_CFG_ENUM, U(rts_on_send_low), GW_CFG_NAMES("high", "low"), .help = "RS-485 mode: the RTS level while sending" },
    { .name = "rts_delay_before_ms", .type = GW_CFG_UINT, U(rts_before_ms), .lo = 0, .hi = 100, .help = "RS-485 mode: RTS set this long before the first bit" },
    { .name = "rts_delay_after_ms", .type = GW_CFG_UINT, U(rts_after_ms), .lo = 0, .hi = 100, .help = "RS-485 mode: RTS kept this long after the last bit" },
    { .name = "read_only", .type = GW_CFG_BOOL, U(read_only), .help = "the line's master may only read (writes get 0x01)" },
    { .name = "robots", .type = GW_CFG_HOOK, .parse = rtu_robots, .allowed = "robot names, each optionally NAME:ADDRESS (1..247)", .doc_default = "every robot, at its `unit_id`", .doc_allowed = "robot names separated by commas or blanks, each optionally `NAME:ADDRESS` (1..247)", .help = "the robots on this line and their slave addresses; an address must be unique on the line" },
};

static const gw_cfg_side_t gw_cfg_rtu = {
    .kw = "modbus_rtu",
    .rank = 50,
    GW_CFG_NAMED(side.modbus.rtu, side.modbus.rtu_count, gw_rtu_config_t),
    GW_CFG_KEYS(rtu_keys),
    .scratch = sizeof(gw_cfg_rtu_robots_t),
    .check = rtu_check,
};

static const gw_cfg_side_t *const modbus_sections[] = { &gw_cfg_modbus, &gw_cfg_rtu, NULL };

/* Single-writer mode: the outputs are one Modbus TCP client's. */
static void modbus_write_policy(const gw_config_t *cfg, unsigned robot, gw_write_policy_t *p)
{
    (void)robot;
    p->one_owner = cfg->side.modbus.single_writer;
}

/* ---- [robot NAME]'s Modbus keys ----------------------------------------------- */

#define RM(m) GW_CFG_AT(gw_robot_config_t, side.modbus.m)

static gw_cfg_parse_fn robot_alias, robot_map;

/* Where each comes among the core's keys of [robot NAME]: `after`. */
static const gw_cfg_key_t robot_keys[] = {
    /* 0 is broadcast, 248..255 reserved (Modbus spec 4.1) */
    { .name = "unit_id", .type = GW_CFG_UINT, RM(unit_id), .lo = 1, .hi = 247, .def = 1, .doc_allowed = "1..247, unique across robots", .help = "Modbus unit ID under which this robot's registers are served", .after = "local_udp_port" },
    { .name = "unit_id_alias", .type = GW_CFG_HOOK, .parse = robot_alias, .allowed = "0, 255, 0,255 or none", .doc_default = "none", .doc_allowed = "`0`, `255`, `0,255`, `none`; one robot per alias", .help = "unit IDs this robot answers to besides `unit_id`: 0 and 255 are what many PLCs and HMIs send by default (a request with another unit ID gets exception 0x0A, logged once per client)", .after = "local_udp_port" },
    { .name = "map", .type = GW_CFG_HOOK, .flags = GW_CFG_LIST, .parse = robot_map, .allowed = "TABLE ADDRESS PATH[a..b] VIEW [writable] [saturate] [scale=N] [lo|hi]", .doc_default = "(none: the default map alone)", .doc_allowed = "`TABLE ADDRESS PATH[a..b] VIEW [options]`, repeatable, at most 64", .help = "a block of this robot's own register map, at addresses the default map leaves free: see [Your own map](register-map.md#your-own-map)", .after = "local_udp_port" },
    { .name = "default_map_writes", .type = GW_CFG_BOOL, RM(default_map_writes), .def = 1, .help = "`no`: Modbus cannot write the robot's data through the default map (exception 0x02; its control registers HR 0-1 stay writable), so that the `writable` blocks of the robot's own map are all a PLC may write", .after = "local_udp_port" },
    { .name = "fallback", .type = GW_CFG_ENUM, RM(fallback_hold), GW_CFG_NAMES("zero", "hold"), .help = "O->T image sent when the single writer's watchdog expires: all zeros, or the last values written", .after = "timeout_ms" },
};

/* unit_id_alias: 0, 255, both (comma-separated, blanks allowed), or none. */
static void robot_alias(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                        const char *name, const char *v)
{
    gw_modbus_robot_config_t *r = &((gw_robot_config_t *)sec)->side.modbus;
    r->alias0 = r->alias255 = false;
    if (strcmp(v, "none") == 0)
        return;
    const char *p = v;
    unsigned n = 0;
    for (;;) {
        while (*p == ' ' || *p == '\t')
            p++;
        size_t len = strspn(p, "0123456789");
        bool zero = len == 1 && p[0] == '0', ff = len == 3 && strncmp(p, "255", 3) == 0;
        if ((!zero && !ff) || (zero && r->alias0) || (ff && r->alias255) || ++n > 2) {
            gw_cfg_fail(c, c->lineno, "%s '%s' invalid (allowed: %s)", name, v, k->allowed);
            return;
        }
        r->alias0 |= zero;
        r->alias255 |= ff;
        p += len;
        while (*p == ' ' || *p == '\t')
            p++;
        if (*p == '\0')
            return;
        if (*p++ != ',') {
            gw_cfg_fail(c, c->lineno, "%s '%s' invalid (allowed: %s)", name, v, k->allowed);
            return;
        }
    }
}

/* One `map` line: parsed, then added to the robot's map, which refuses
 * overlaps (with its other blocks and with the default map). */
static void robot_map(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                      const char *name, const char *v)
{
    gw_modbus_robot_config_t *r = &((gw_robot_config_t *)sec)->side.modbus;
    gw_umap_entry_t e;
    char err[400];
    (void)k;
    if (!gw_umap_parse(v, c->lineno, &e, err, sizeof err) || !gw_umap_add(&r->map, &e, err, sizeof err))
        gw_cfg_fail(c, c->lineno, "%s: %s", name, err);
}

/* Robot i against robot j (j < i): its own unit ID and aliases. */
static bool robot_pair(gw_cfg_ctx_t *c, unsigned i, unsigned j)
{
    const gw_cfg_side_t *s = &gw_cfg_robot;
    const gw_robot_config_t *r = &c->cfg.robot[i], *o = &c->cfg.robot[j];
    const gw_modbus_robot_config_t *rm = &r->side.modbus, *om = &o->side.modbus;
    unsigned unit_line = gw_cfg_line(c, s, i, "unit_id");
    if (om->unit_id == rm->unit_id) {
        gw_cfg_fail(c, gw_cfg_line_or(unit_line, r->line),
                    "robot '%s': unit_id %u%s already used by robot '%s' "
                    "(line %u; each robot needs its own unit_id, allowed: "
                    "1..247)",
                    r->name, (unsigned)rm->unit_id,
                    unit_line ? "" : " (the default)", o->name,
                    gw_cfg_line_or(gw_cfg_line(c, s, j, "unit_id"), o->line));
        return false;
    }
    if ((om->alias0 && rm->alias0) || (om->alias255 && rm->alias255)) {
        gw_cfg_fail(c, gw_cfg_line_or(gw_cfg_line(c, s, i, "unit_id_alias"), r->line),
                    "robot '%s': unit_id_alias %u is already robot '%s''s "
                    "(line %u; one robot per alias)",
                    r->name, om->alias0 && rm->alias0 ? 0u : 255u, o->name,
                    gw_cfg_line_or(gw_cfg_line(c, s, j, "unit_id_alias"), o->line));
        return false;
    }
    return true;
}

static const gw_cfg_robot_keys_t modbus_robot = {
    GW_CFG_KEYS(robot_keys),
    .pair = robot_pair,
};

/* The link's "connecting" line: ", unit ID 1". */
static void modbus_robot_brief(const gw_robot_config_t *r, char *buf, size_t size)
{
    size_t n = strlen(buf);
    if (n < size)
        snprintf(buf + n, size - n, ", unit ID %u", (unsigned)r->side.modbus.unit_id);
}

/* The side to the configuration (config.h; gateway/sides.h lists it). */
const gw_side_cfg_t gw_side_cfg_modbus = {
    .name = "modbus",
    .sections = modbus_sections,
    .write_policy = modbus_write_policy,
    .robot = &modbus_robot,
    .robot_brief = modbus_robot_brief,
};

static void rtu_baud(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                     const char *name, const char *v)
{
    static const unsigned long bauds[] = { 1200,  2400,  4800,   9600,  19200,
                                           38400, 57600, 115200, 230400 };
    unsigned long n;
    if (!gw_cfg_get_uint(c, name, v, k->lo, k->hi, &n))
        return;
    for (size_t i = 0; i < GW_CFG_COUNT(bauds); i++) {
        if (bauds[i] == n) {
            gw_cfg_store(c, k, sec, n);
            return;
        }
    }
    gw_cfg_fail(c, c->lineno, "baud %lu not a standard rate (allowed: %s)", n,
                k->allowed);
}

/* ":ADDRESS" after a robot's name in robots = (p at the ':'): 1..247 into
 * *addr, the end into *end; false if it is not one. */
static bool slave_address(const char *p, uint8_t *addr, const char **end)
{
    char *e;
    errno = 0;
    unsigned long a = strtoul(p + 1, &e, 10);
    if (e == p + 1 || !gw_cfg_is_digit(p[1]) || errno != 0 || a < 1 ||
        a > 247 || (*e != '\0' && *e != ',' && !gw_cfg_is_space(*e)))
        return false;
    *addr = (uint8_t)a;
    *end = e;
    return true;
}

/* robots = arm1:5, arm2 (commas or blanks between): names are checked
 * against the robot sections once the whole file is read. */
static void rtu_robots(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                       const char *name, const char *v)
{
    gw_rtu_config_t *u = sec;
    gw_cfg_rtu_robots_t *ul = gw_cfg_scratch(c, &gw_cfg_rtu, c->idx);
    const char *p = v;
    (void)name;
    u->slave_count = 0;
    while (*p != '\0' && c->err_line == 0) {
        while (*p == ',' || gw_cfg_is_space(*p))
            p++;
        if (*p == '\0')
            break;
        size_t n = strcspn(p, ", \t:");
        if (u->slave_count >= GW_MAX_ROBOTS) {
            gw_cfg_fail(c, c->lineno, "robots: more than %d robots",
                        GW_MAX_ROBOTS);
            return;
        }
        unsigned i = u->slave_count++;
        snprintf(ul->robot[i], sizeof ul->robot[i], "%.*s", (int)n, p);
        if (n >= GW_NAME_MAX || !gw_cfg_valid_name(ul->robot[i])) {
            gw_cfg_fail(c, c->lineno,
                        "robots: '%.*s' is not a robot name (allowed: %s)",
                        (int)n, p, k->allowed);
            return;
        }
        p += n;
        ul->addr_given[i] = *p == ':';
        if (*p == ':' && !slave_address(p, &u->slave_addr[i], &p)) {
            gw_cfg_fail(c, c->lineno,
                        "robots: slave address of '%s' invalid (allowed: "
                        "1..247)",
                        ul->robot[i]);
            return;
        }
    }
    if (u->slave_count == 0)
        gw_cfg_fail(c, c->lineno, "robots has no value (allowed: %s)",
                    k->allowed);
}

/* ---- [modbus_rtu NAME] -------------------------------------------------------- */

/* robots = as written, or every robot at its unit ID, into the slaves of
 * line i. */
static bool rtu_slaves(gw_cfg_ctx_t *c, unsigned i)
{
    gw_config_t *g = &c->cfg;
    gw_rtu_config_t *u = &g->side.modbus.rtu[i];
    const gw_cfg_rtu_robots_t *ul = gw_cfg_scratch(c, &gw_cfg_rtu, i);
    unsigned robots_line = gw_cfg_line(c, &gw_cfg_rtu, i, "robots");
    if (robots_line == 0) {
        u->slave_count = g->robot_count;
        for (unsigned r = 0; r < g->robot_count; r++) {
            u->slave_robot[r] = r;
            u->slave_addr[r] = g->robot[r].side.modbus.unit_id;
        }
        return true;
    }
    for (unsigned s = 0; s < u->slave_count; s++) {
        unsigned r = 0;
        while (r < g->robot_count && strcmp(g->robot[r].name, ul->robot[s]) != 0)
            r++;
        if (r == g->robot_count) {
            gw_cfg_fail(c, robots_line,
                        "modbus_rtu '%s': no robot '%s' (allowed: the NAME of "
                        "a [robot NAME] section)",
                        u->name, ul->robot[s]);
            return false;
        }
        u->slave_robot[s] = r;
        if (!ul->addr_given[s])
            u->slave_addr[s] = g->robot[r].side.modbus.unit_id;
    }
    return true;
}

/* Each robot and each slave address once on line i. */
static bool rtu_unique(gw_cfg_ctx_t *c, unsigned i)
{
    const gw_rtu_config_t *u = &c->cfg.side.modbus.rtu[i];
    for (unsigned s = 0; s < u->slave_count; s++) {
        for (unsigned t = 0; t < s; t++) {
            bool robot = u->slave_robot[s] == u->slave_robot[t];
            if (!robot && u->slave_addr[s] != u->slave_addr[t])
                continue;
            gw_cfg_fail(c,
                        gw_cfg_line_or(gw_cfg_line(c, &gw_cfg_rtu, i, "robots"),
                                u->line),
                        robot ? "modbus_rtu '%s': robot '%s' listed twice"
                              : "modbus_rtu '%s': robot '%s' has the slave "
                                "address of another robot on the line (each "
                                "needs its own, 1..247)",
                        u->name, c->cfg.robot[u->slave_robot[s]].name);
            return false;
        }
    }
    return true;
}

/* Every [modbus_rtu]: a device, one not used by another line, robots that
 * exist (all of them if not said), each slave address once. */
static void rtu_check(gw_cfg_ctx_t *c)
{
    gw_config_t *g = &c->cfg;
    for (unsigned i = 0; i < g->side.modbus.rtu_count; i++) {
        const gw_rtu_config_t *u = &g->side.modbus.rtu[i];
        if (!gw_cfg_require(c, &gw_cfg_rtu, i))
            return;
        for (unsigned j = 0; j < i; j++) {
            if (strcmp(g->side.modbus.rtu[j].device, u->device) == 0) {
                gw_cfg_fail(c,
                            gw_cfg_line_or(gw_cfg_line(c, &gw_cfg_rtu, i, "device"),
                                    u->line),
                            "modbus_rtu '%s': device %s is already modbus_rtu "
                            "'%s' (line %u)",
                            u->name, u->device, g->side.modbus.rtu[j].name, g->side.modbus.rtu[j].line);
                return;
            }
        }
        if (!rtu_slaves(c, i) || !rtu_unique(c, i))
            return;
    }
}
