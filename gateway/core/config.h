/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd configuration: one INI file (parsed with libinih).
 *
 *   [daemon]            log level (the core's)
 *   [robot NAME]        one section per robot (the core's)
 *   the sides' own      each side's folder: its config_<side>.h (the
 *                       struct) and config_<side>.c (the sections and
 *                       their keys), listed once in gateway/sides.h
 *
 * "[robot NAME]" and "[robot.NAME]" are the same section ("[robot]" alone
 * names the robot "robot"); likewise for every named section.
 * Every key, default and range: docs/configuration.md.
 *
 * gw_config_load() validates everything and reports the first error as
 * "FILE:LINE: message (allowed: ...)"; the daemon exits with 78 (EX_CONFIG).
 */
#ifndef DRGATE_GW_CONFIG_H
#define DRGATE_GW_CONFIG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "drgate/codec.h"
#include "drgate/layout.h"

#include "core/config_types.h"

typedef enum { GW_MODE_IMPLICIT = 0, GW_MODE_EXPLICIT } gw_robot_mode_t;
/* How a T->O assembly is opened (open.<assembly>): an exclusive owner
 * connection with its O->T partner, input-only or listen-only (heartbeat
 * O->T), or not at all. */
typedef enum { GW_OPEN_OWNER = 0, GW_OPEN_INPUT_ONLY, GW_OPEN_LISTEN_ONLY, GW_OPEN_NONE } gw_open_kind_t;

typedef struct {
    gw_open_kind_t kind;
    int o2t; /* owner: the O->T dr_asm_t; else -1 */
} gw_open_t;

/* The sides' structs (gateway/sides.h): each side's configuration header
 * gives its member of gw_config_t and its member of a robot's. */
#include "sides.h"

/* What each side keeps of one robot (its keys of [robot NAME]), one
 * member per side, laid out by the side list. */
#define GW_SIDE_ROBOT_MEMBER(name) gw_##name##_robot_config_t name;
typedef struct {
    GW_SIDES(GW_SIDE_ROBOT_MEMBER)
} gw_robot_sides_config_t;
#undef GW_SIDE_ROBOT_MEMBER

typedef struct {
    char name[GW_NAME_MAX];   /* section name */
    char host[64];
    uint16_t tcp_port;        /* default 44818 */
    uint16_t udp_port;        /* robot's Class 1 port, default 2222 */
    char local_addr[64];      /* local UDP address, "" = any */
    uint16_t local_udp_port;  /* default 2222 */
    gw_robot_mode_t mode;     /* default implicit */
    uint32_t rpi_ms;          /* default 10 (implicit) / poll period (explicit) */
    uint8_t timeout_mult;     /* code 0..7, default 2 */
    uint32_t timeout_ms;      /* explicit request timeout, default 1000 */
    uint16_t instance[DR_ASM_COUNT]; /* default 101..110 */
    /* The connection plan (implicit mode; explicit mode polls what it
     * opens): the configuration instance of every Forward Open (default
     * 1), the heartbeat connection points of input-only (198) and
     * listen-only (199) connections, and how each T->O assembly is opened,
     * indexed by dr_asm_t (O->T entries are GW_OPEN_NONE). Default: the
     * four owner pairs io_control/io_state, bit_in/bit_out, int_in/int_out,
     * float_in/float_out, joint_state and task_state input-only. */
    uint16_t config_instance;
    uint16_t input_only_heartbeat;
    uint16_t listen_only_heartbeat;
    gw_open_t open[DR_ASM_COUNT];
    /* How the assemblies travel (drgate/layout.h). per_assembly (the
     * default): instance[] and open[] above. combined, gpr_only: one
     * Class 1 connection (explicit mode: one Get and one Set per period)
     * between the point `input` (T->O) and the point `output` (O->T;
     * count 0: none, an input-only connection on input_only_heartbeat);
     * instance[] and open[] are not used, and the checks leave open[]
     * all GW_OPEN_NONE. Sizes equal their assemblies' sum (checked). */
    dr_layout_kind_t layout;
    dr_point_t input, output;
    /* The robot's EDS, as written (`eds`; "": none): the checks take its
     * plan (layout, points, configuration instance, heartbeats, rpi_ms)
     * for every one of those keys the section does not set. */
    char eds[256];
    /* implicit: O->T only on its own timer ("strict"), or also sent with
     * an arriving T->O packet when due within a quarter RPI ("follow",
     * default): one wake-up per RPI instead of two. */
    bool o2t_strict;
    /* The originator serial number of its Forward Opens; 0 (default):
     * dr_originator_serial_local(name), from /etc/machine-id (else the
     * host name) and the section name, the same at every start, so that
     * a restarted gateway may take its connections back (issue 19). */
    uint32_t originator_serial;
    unsigned line;            /* where the section starts, for messages */
    /* The sides' keys of this robot: each reads its own member, named as
     * in gateway/sides.h (its config_NAME.h: gw_NAME_robot_config_t). */
    gw_robot_sides_config_t side;
} gw_robot_config_t;

#define GW_SIDE_CONFIG_MEMBER(name) gw_##name##_side_config_t name;
typedef struct {
    GW_SIDES(GW_SIDE_CONFIG_MEMBER)
} gw_sides_config_t;
#undef GW_SIDE_CONFIG_MEMBER

/* One block, copied whole: a refused reload leaves the running one as it
 * was, and a side may keep its own copy. The core reads its own members;
 * `side` is the sides' (each reads its own member, named as in
 * gateway/sides.h; the loader reaches them through their sections'
 * offsets). */
typedef struct {
    char path[256];
    unsigned robot_count;
    gw_robot_config_t robot[GW_MAX_ROBOTS];
    char log_level[16];       /* [daemon] log_level: error|warning|info|debug */
    gw_sides_config_t side;
} gw_config_t;

/* What a side is to the configuration: gw_side_cfg_NAME, in its
 * config_NAME.c, reached through the side list (gateway/sides.h). Every
 * member but the sections may be NULL. */
struct gw_cfg_side;    /* a section kind: core/config_internal.h */
struct gw_write_policy; /* core/robot.h */
typedef struct {
    const char *name;
    /* The sections it reads, NULL after the last (at most
     * GW_CFG_SIDE_SECTIONS, config_internal.h). */
    const struct gw_cfg_side *const *sections;
    /* The write path's rules its settings make for robot `robot`
     * (single-writer mode, bits GPIO inputs drive), added to p:
     * gw_write_policy_set (core/write.h). */
    void (*write_policy)(const gw_config_t *cfg, unsigned robot, struct gw_write_policy *p);
    /* What --check-config and the start line say of it after the robots,
     * appended to buf: ", 3 GPIO line(s)". */
    void (*brief)(const gw_config_t *cfg, char *buf, size_t size);
    /* Whether it shows the log (the console): the ring keeps it. */
    bool (*keeps_log)(const gw_config_t *cfg);
    /* Its keys of [robot NAME] (config_internal.h), read into its member
     * of gw_robot_config_t.side; NULL: none. */
    const struct gw_cfg_robot_keys *robot;
    /* What the link's "connecting" line says of robot r, appended to
     * buf: ", unit ID 1". */
    void (*robot_brief)(const gw_robot_config_t *r, char *buf, size_t size);
} gw_side_cfg_t;

#define GW_SIDE_CFG_DECL(name) extern const gw_side_cfg_t gw_side_cfg_##name;
GW_SIDES(GW_SIDE_CFG_DECL)
#undef GW_SIDE_CFG_DECL

/* Every side's, in list order (GW_SIDE_COUNT of them). */
extern const gw_side_cfg_t *const gw_side_cfgs[];

/* "2 robot(s), 3 GPIO line(s)": the robots, then each side's brief. */
const char *gw_config_brief(const gw_config_t *cfg);
/* What the sides say of robot r (robot_brief), into buf: "" or
 * ", unit ID 1". */
const char *gw_config_robot_brief(const gw_robot_config_t *r, char *buf, size_t size);
/* Does a side show the log (keeps_log)? */
bool gw_config_keeps_log(const gw_config_t *cfg);

/* Room for gw_config_load's message: the file's path (a build tree or
 * /etc/drgate, well under 1 KiB) before a message of up to 1 KiB (the
 * robot's "unknown key" lists 28 keys; CI's deeper checkout once cut it). */
#define GW_CONFIG_ERR_SIZE 2048

/* Load and validate `path`. On error returns false and writes
 * "FILE:LINE: what is wrong (allowed: ...)" into err[errlen] (errors about
 * the file itself, such as "cannot open", have no LINE); *out is written
 * only on success, so a failed reload leaves the running config intact. */
bool gw_config_load(const char *path, gw_config_t *out, char *err, size_t errlen);

/* The robot's plan carries O->T assembly a with an owner connection
 * (per_assembly: an open.* owner of it; combined: the output point has
 * it), so that writes to it reach the robot. */
bool gw_robot_owns(const gw_robot_config_t *r, dr_asm_t a);
/* The plan reads T->O assembly a (opens or polls it). */
bool gw_robot_reads(const gw_robot_config_t *r, dr_asm_t a);

/* Today's connection plan (see gw_robot_config_t.open) into r. */
void gw_robot_default_plan(gw_robot_config_t *r);

/* Defaults for everything (used before parsing). */
void gw_config_defaults(gw_config_t *cfg);

/* Two robot sections equal in everything the link depends on (for SIGHUP:
 * an unchanged robot keeps its connection). */
bool gw_robot_config_same_link(const gw_robot_config_t *a, const gw_robot_config_t *b);

/* "[daemon], [modbus], [robot NAME], ...": every section, for messages. */
const char *gw_config_sections(void);

/* The keys of [section] ("robot", "modbus", ...: the keyword) as a
 * Markdown table: key, default, allowed, meaning (the tables of
 * docs/configuration.md). False for an unknown section. */
bool gw_config_print_keys(FILE *out, const char *section);

/* The configuration in effect, as INI text into buf[size]: every section
 * the daemon runs with and every key with its value, the defaults
 * included; a key whose name says it is a secret (password, secret,
 * token, key, auth) shows whether it is set, not its value; keys only a
 * hook stores (allow, map, instance.*, open.*) are named as comments
 * ("as in the file"). False: it did not fit (buf then holds nothing). */
bool gw_config_effective(const gw_config_t *cfg, char *buf, size_t size);

#endif /* DRGATE_GW_CONFIG_H */
