/* SPDX-License-Identifier: MIT */
/*
 * Northbound sides: what the gateway serves the robots' data to (Modbus
 * TCP and RTU, GPIO lines, MQTT). The daemon's loop (main.c) knows them
 * only through this interface and the list gw_north_sides[]: adding a side
 * (MQTT, OPC UA) means one more entry there and its configuration section,
 * nothing else in the loop.
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

#include "core/config.h"
#include "core/json.h"
#include "core/prom.h"
#include "core/robot.h"

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
} gw_north_ops_t;

/* Modbus TCP and RTU are one side (north_modbus.c): both answer from the
 * same units, whose rules and state (the single writer's watchdog, the
 * write fault latch, the status counters) are one. */
extern const gw_north_ops_t gw_north_modbus, gw_north_gpio;
extern const gw_north_ops_t gw_north_mqtt; /* north_mqtt.c */
extern const gw_north_ops_t gw_north_http; /* http/north_http.c: the console */

/* The sides the daemon runs, in this order (GPIO last, see above). */
extern const gw_north_ops_t *const gw_north_sides[];
#define GW_NORTH_SIDES 4u

#endif /* DRGATE_GW_NORTH_H */
