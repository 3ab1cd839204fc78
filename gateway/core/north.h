/* SPDX-License-Identifier: MIT */
/*
 * Northbound sides: what the gateway serves the robots' data to (Modbus
 * TCP and RTU, GPIO lines, MQTT, the console). The daemon (core/) knows
 * them only through this interface and the side list (gateway/sides.h),
 * from which gw_north_sides[] and GW_NORTH_SIDES are made: adding a side
 * (OPC UA) is its folder and one entry in that list, nothing in core/
 * (docs/gateway.md "Adding a side").
 *
 * A side registers its own descriptors in the loop's epoll set (env->epfd)
 * when it is created or reloaded, and tells the loop when it next needs a
 * tick (deadline). The robots (robot.h: images, link facts) are the
 * daemon's and the same for every side; what a side keeps per robot (the
 * Modbus units and their rules) is its own, carried over a reload by the
 * robot's serial. The robots' side (links) tells every side about new
 * data and link changes; a side that writes a robot's O->T image says so
 * through env->outputs_changed; a fault latched by one side (the Modbus
 * single writer's watchdog) reaches every side through env->fault.
 *
 * A reload (SIGHUP) is two phases so that a refused one changes nothing:
 * prepare() does everything that can fail while the running side keeps
 * going, and yields the side that will take over (itself, or a new one);
 * if a later side refuses, abort() drops what prepare() made; once every
 * side agreed and the robots' links are in place, commit() installs it.
 * Sides whose prepare() cannot be undone (GPIO: lines released and
 * requested again) come last in the list.
 */
#ifndef DRGATE_GW_NORTH_H
#define DRGATE_GW_NORTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "core/config.h"
#include "core/json.h"
#include "core/prom.h"
#include "core/robot.h"

/* What a side shows of itself in the status summary (`drgatewayd status`,
 * the console's text answer) and in systemd's STATUS= line: a struct the
 * side fills (its `summary` op), which the daemon and the console lay
 * out; nothing is parsed back. */
typedef struct {
    char label[16];  /* "Modbus", "MQTT"; "" (left so): nothing to show */
    char line[1280]; /* the summary's line after "LABEL: " */
    char brief[96];  /* STATUS='s part after "; " ("": none) */
} gw_side_summary_t;

/* --print-map and --print-errors. */
typedef enum { GW_PRINT_TEXT, GW_PRINT_MARKDOWN, GW_PRINT_JSON, GW_PRINT_CSV } gw_print_fmt_t;

/* The bound of a map_json answer (the console's response buffer). */
#define GW_NORTH_MAP_MAX (768u * 1024u)

typedef struct {
    int epfd;
    /* The daemon's configuration, current after every commit (stable
     * address), and the robots by index (stable address; a reload moves
     * robots to other indexes, see gw_robot_t serial). */
    const gw_config_t *cfg;
    gw_robot_t *robots;
    /* A side changed O->T images of `robot` (bit per assembly). */
    void (*outputs_changed)(void *user, unsigned robot, unsigned dirty);
    /* Is the robot's link up? */
    bool (*link_up)(void *user, unsigned robot);
    /* A fault latched (true) or cleared for `robot`: told to every side,
     * and kept in robots[robot].fault. */
    void (*fault)(void *user, unsigned robot, bool latched);
    void *user;
    const char *version; /* the gateway's */
    /* What the daemon tells the console (gateway/http), asking every side
     * in turn. report: the members of /api/v1/status's "sides" object,
     * "modbus": {...}, "gpio": {...}, "mqtt": {...}, commas between, no
     * braces around (a side with nothing to say is left out). metrics: the Prometheus text of
     * the core (robots, the loop's lag) and of every side. NULL in a
     * daemon that has none (tests). */
    void (*report)(void *user, gw_json_t *j);
    void (*metrics)(void *user, gw_prom_t *m);
    /* The status summary's part of every running side that has one (its
     * `summary` op with a label), in list order, into out[max]; how many.
     * NULL in a daemon that has none (tests). */
    unsigned (*summaries)(void *user, gw_side_summary_t *out, unsigned max);
    /* /api/v1/robots/NAME/map: robot's map of fields, by the first side
     * with a `map_json` op; false: none (or j is full). NULL: none. */
    bool (*map)(void *user, gw_json_t *j, unsigned robot);
    /* /api/v1/robots/NAME/map.csv: the same rows as a table, by the first
     * side with a `map_csv` op. NULL: none. */
    bool (*map_csv)(void *user, gw_json_t *j, unsigned robot);
    /* GET /api/v1/SIDE/PATH: the running side named `side` answers PATH
     * with its `api` op; false: no such side or path (404), or j full.
     * NULL: none. */
    bool (*side_api)(void *user, const char *side, const char *path, gw_json_t *j);
    /* A robot's "sides" members in the console's ROBOT: each running
     * side's robot_report, commas between, no braces. NULL: none. */
    void (*robot_sides)(void *user, unsigned robot, gw_json_t *j);
    /* For a side whose library asks it a question synchronously that must
     * not be answered in the loop (OPC UA: open62541 asks for a login's
     * verdict in a callback; the password's crypt runs on core/auth.h's
     * worker): run the daemon's loop for the robots and every other side
     * until fd is readable (true), until_us passes or the daemon is to
     * stop (false). `self` is neither ticked nor asked its deadline
     * meanwhile and must unwatch its own descriptors first; its on_data,
     * on_link, on_fault and the console's calls (report, metrics) still
     * come, and must not call back into what is waiting. One side at a
     * time (false at once for a second). NULL: none (tests; a side then
     * refuses what would wait). */
    bool (*wait_aside)(void *user, const void *self, int fd, uint64_t until_us);
} gw_north_env_t;

typedef enum {
    GW_NORTH_OK = 0,  /* *out takes over at commit (it may be self) */
    GW_NORTH_REFUSED, /* nothing changed; err says why */
    GW_NORTH_BROKEN   /* refused, and the running side is gone: the daemon stops */
} gw_north_reload_t;

typedef struct {
    const char *name;
    /* From the configuration: NULL with err on error. A side with nothing
     * configured is created all the same and does nothing. */
    void *(*create)(const gw_north_env_t *env, char *err, size_t errlen);
    /* SIGHUP, phase 1 (see above); `next` is the new configuration, the
     * running one is still env->cfg. */
    gw_north_reload_t (*prepare)(void *self, const gw_config_t *next, const gw_north_env_t *env,
                                 void **out, char *err, size_t errlen);
    void (*abort)(void *self, void *out);
    /* Phase 2: env->cfg and env->robots are the new ones; `out` replaces
     * self (freeing self if they differ). Returns the side to keep, NULL
     * if it failed for good (logged; the daemon stops). */
    void *(*commit)(void *self, void *out, const gw_north_env_t *env);
    void (*tick)(void *self, uint64_t now_us);
    uint64_t (*deadline)(const void *self); /* UINT64_MAX: none */
    void (*on_data)(void *self, unsigned robot, dr_asm_t a);
    void (*on_link)(void *self, unsigned robot, bool up);
    void (*on_fault)(void *self, unsigned robot, bool latched);
    /* Ten times a second, with the daemon's refresh of the robots'
     * heartbeat and uptime: what the side shows of itself (Modbus: its
     * part of the status block: clients, exceptions, RTU counters). */
    void (*refresh)(void *self);
    /* Shutdown, first of all: outputs to their safe state. */
    void (*safe)(void *self);
    void (*free)(void *self);
    /* For the console (NULL: nothing to say). report: the side's member
     * of "sides", `"name": {...}`, with no comma before or after (the
     * daemon writes those); it writes nothing at all when it has nothing
     * configured. metrics: its families (core/prom.h), each declared and
     * written in one go, names drgate_<side>_..., counters _total, base
     * units. */
    void (*report)(const void *self, gw_json_t *j);
    void (*metrics)(const void *self, gw_prom_t *m);
    /* The status summary (NULL: nothing to show): fill s, which comes
     * zeroed; a side with nothing configured leaves the label empty. */
    void (*summary)(const void *self, gw_side_summary_t *s);
    /* GET /api/v1/NAME/PATH (env->side_api): the side's own JSON answer
     * for PATH ("requests"); false: not one of its paths. NULL: none. */
    bool (*api)(const void *self, const char *path, gw_json_t *j);
    /* What the side says of robot `robot` in the console's ROBOT
     * (env->robot_sides): `"name": {...}` (Modbus: its unit ID and
     * aliases), nothing when it has nothing to say. NULL: none. */
    void (*robot_report)(const void *self, unsigned robot, gw_json_t *j);

    /* --check-config: what the loader cannot check (TLS files load);
     * false with "FILE:LINE: ..." in err. (What the daemon asks of a
     * side's configuration alone: gw_side_cfg_t, core/config.h.) */
    bool (*check_config)(const gw_config_t *cfg, char *err, size_t errlen);

    /* The daemon's commands a side serves. */
    /* /api/v1/robots/NAME/map (env->map): robot's fields with this side's
     * addresses, at most GW_NORTH_MAP_MAX bytes; false: not served. */
    bool (*map_json)(const gw_config_t *cfg, unsigned robot, gw_json_t *j);
    /* /api/v1/robots/NAME/map.csv (env->map_csv): `--print-map --json`'s
     * rows of the robot as CSV, at most GW_NORTH_MAP_MAX bytes. */
    bool (*map_csv)(const gw_config_t *cfg, unsigned robot, gw_json_t *j);
    /* --print-map [FILTER] (cfg NULL without -c) and --print-errors. */
    void (*print_map)(FILE *out, gw_print_fmt_t fmt, const char *filter, const gw_config_t *cfg);
    void (*print_errors)(FILE *out, gw_print_fmt_t fmt);
    /* `drgatewayd status [-c FILE]`: the exit status (the first side
     * that has it answers). */
    int (*status_command)(const char *config, bool json);
} gw_north_ops_t;

/* Every side's operations, gw_north_NAME (its north_NAME.c), from the
 * side list (gateway/sides.h). */
#define GW_NORTH_DECL(name) extern const gw_north_ops_t gw_north_##name;
GW_SIDES(GW_NORTH_DECL)
#undef GW_NORTH_DECL

/* The sides the daemon runs, in the list's order (GPIO last, see above),
 * and how many: both from the list. */
extern const gw_north_ops_t *const gw_north_sides[];
#define GW_NORTH_SIDES GW_SIDE_COUNT

#endif /* DRGATE_GW_NORTH_H */
