/* SPDX-License-Identifier: MIT */
/*
 * One robot's EtherNet/IP link, seen from the gateway: keeps the robot's
 * T->O images live (Class 1 connections, or cyclic Get_Attribute_Single in
 * explicit mode), sends its O->T images, keeps its link facts, and reports
 * link changes. It knows the robot (robot.h) and nothing of the sides that
 * serve it: no Modbus header, no [modbus] setting (mk/gw-boundary.sh).
 */
#ifndef DRGATE_GW_LINK_H
#define DRGATE_GW_LINK_H

#include <stdbool.h>
#include <stdint.h>

#include "core/config.h"
#include "drgate/transport.h"
#include "core/robot.h"

typedef struct gw_link gw_link_t;

/* The local UDP ports the daemon's implicit-mode links share (robots on
 * the same local address and port use one socket). The daemon owns it and
 * frees it after the last link. */
typedef struct gw_link_ports gw_link_ports_t;
gw_link_ports_t *gw_link_ports_new(void);
void gw_link_ports_free(gw_link_ports_t *p);
/* The daemon's loop wakes up at gw_link_next_deadline() to the microsecond
 * (epoll_pwait2): links made from now on run their clients without a
 * timer descriptor of their own. Off by default (each client's timerfd,
 * for a loop whose timeout is whole milliseconds). */
void gw_link_ports_loop_timer(gw_link_ports_t *p, bool on);
/* The O->T packets the links produced in this turn of the loop, of every
 * robot on a port in one batch (the ports hold them: dr_udp_port_hold).
 * Call at the end of every turn. */
void gw_link_ports_flush(gw_link_ports_t *p);

typedef struct {
    /* The link came up (true) or went down (false). */
    void (*on_link)(void *user, unsigned robot, bool up, dr_status_t why);
    /* New T->O data of assembly `a` is in the robot's image. */
    void (*on_data)(void *user, unsigned robot, dr_asm_t a);
    void *user;
} gw_link_hooks_t;

/* An observer of every link, for instrumented builds: the benchmark's
 * drgatewayd-lat registers one (bench/gw_lat.c) to time a robot packet
 * from its arrival to the image; the daemon registers none. One for the
 * process, set before the first link is made (the ports take its
 * transport when they open); NULL removes it. */
typedef struct {
    /* New T->O data of assembly `a` is in the robot's image, from a Class
     * 1 packet read on udp_fd (the shared port's socket). Called before
     * the link's on_data hook. */
    void (*on_t2o)(void *user, unsigned robot, dr_asm_t a, int udp_fd);
    /* The transport of the shared Class 1 ports; {NULL, NULL}: POSIX. */
    dr_transport_t port_transport;
    void *user;
} gw_link_observer_t;
void gw_link_observe(const gw_link_observer_t *o);

gw_link_t *gw_link_new(const gw_robot_config_t *rc, unsigned robot, gw_robot_t *data,
                       int epfd, gw_link_ports_t *ports, const gw_link_hooks_t *hooks);
/* Forward Close, UnRegisterSession, free. NULL is fine. why: the reason
 * the link goes down on purpose, logged at info level ("gateway
 * stopping"), NULL for "closed". */
void gw_link_free(gw_link_t *l, const char *why);

/* O->T images changed (bit per assembly): send them from the next RPI. */
void gw_link_outputs_changed(gw_link_t *l, unsigned dirty);

/* Timers: explicit polling, freshness, status block. */
/* busy: this turn of the loop handled more than one event (Modbus load),
 * so the shared UDP port is read even if epoll has not reported it yet. */
void gw_link_tick(gw_link_t *l, uint64_t now_us, bool busy);
uint64_t gw_link_next_deadline(const gw_link_t *l);

bool gw_link_up(const gw_link_t *l);
/* The T->O assembly of the link's i-th connection slot (the order of
 * gw_robot_link_t.conn_state), -1 past the last slot. */
int gw_link_slot_asm(unsigned i);
const gw_robot_config_t *gw_link_config(const gw_link_t *l);
/* Point the link at the robot's new place (a reload keeps the link and
 * moves the robot). */
void gw_link_set_robot(gw_link_t *l, unsigned robot, gw_robot_t *data);

#endif
