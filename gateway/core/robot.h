/* SPDX-License-Identifier: MIT */
/*
 * One robot as the gateway holds it, whatever serves it: its live wire
 * images (T->O as received, O->T as the northbound sides write them), what
 * its link knows (state, connections, counters, last error), and what the
 * daemon says about it (name, configuration generation, heartbeat).
 *
 * The robots' side (link.c) writes the T->O images and the link facts;
 * the northbound sides (north.h: Modbus, GPIO, MQTT) read them and write
 * the O->T images. Nothing here knows how a side serves the data: the
 * Modbus rules (word order, on_link_loss = exception, unmapped reads, the
 * single writer, GPIO-owned bits, the status block's layout) are the
 * Modbus side's own, in its unit (regmap.h) that points at a gw_robot_t.
 * Neither this file nor robot.c nor the link may include a Modbus header
 * or name a Modbus symbol: make check-gw-boundary (mk/gw-boundary.sh,
 * also run by check-gateway) fails if they do.
 */
#ifndef DRGATE_GW_ROBOT_H
#define DRGATE_GW_ROBOT_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/config.h"
#include "drgate/codec.h"
#include "drgate/status.h"

/* Class 1 connections a link reports the state of (one per T->O assembly
 * the plan may open, and room to grow). */
#define GW_ROBOT_CONNS 10

/* What the link knows; refreshed by the link every turn of the loop
 * (link_state, fresh, age_ms, the counters) or when it happens (errors,
 * connection states). */
typedef struct {
    uint16_t link_state;       /* 0 down, 1 connecting, 2 up */
    bool fresh;                /* robot data younger than the timeout */
    uint32_t age_ms;           /* age of the oldest T->O data */
    uint64_t rx_us;            /* when the newest T->O data went into the
                                  images (ev_now_us(), monotonic): the time
                                  a side stamps its data with; 0: none yet */
    uint16_t rpi_ms;           /* API in use (explicit: the poll period) */
    uint32_t rx_packets, lost_packets;
    uint16_t last_error;       /* gw_robot_error_code() of last_status */
    uint16_t last_cip_general; /* CIP general status of last_error, 0: not CIP */
    dr_status_t last_status;   /* why the link last failed, DR_OK: not yet */
    uint16_t conn_state[GW_ROBOT_CONNS]; /* dr_conn_state_t per connection */
    /* Per connection (implicit mode: by the link's slot, as conn_state;
     * explicit mode: slot 0 counts the polls): the T->O assembly it
     * carries (conn_t2o, DR_ASM_COUNT: no connection in the slot) and its
     * packets received and lost since the link started (counters for the
     * console's /metrics; rx_packets and lost_packets are their sums). */
    uint16_t conn_t2o[GW_ROBOT_CONNS];
    /* A combined or gpr_only layout's one connection (slot 0) is named for
     * what it carries, "combined T->O (6 assemblies, 476 bytes)" (the
     * console, /api/v1 and the metrics' `connection` label); "": the
     * per_assembly plan, whose connections the assembly names. */
    char conn_name[48];
    uint32_t conn_rx[GW_ROBOT_CONNS], conn_lost[GW_ROBOT_CONNS];
    /* T->O packets a connection dropped since the link started: stale,
     * duplicate or too far ahead (dropped_seq), from an address not the
     * robot's (dropped_addr), and the jumps of the robot's sequence it
     * followed (resyncs); implicit mode only (dr_conn_stats_t), and the
     * robot's sums (issue 29: every drop counter visible). */
    uint32_t conn_dropped_seq[GW_ROBOT_CONNS], conn_dropped_addr[GW_ROBOT_CONNS];
    uint32_t conn_resyncs[GW_ROBOT_CONNS];
    uint32_t dropped_seq, dropped_addr, resyncs;
    /* Times the link went down after being up (it then reconnects), and
     * times a connection or poll timed out (no data from the robot). */
    uint32_t reconnects, timeouts;
    /* Where the robot was to send T->O when last_status became
     * DR_ENODATA ("10.0.0.5:2222"): gw_robot_cause() names it. */
    char t2o_to[24];
    /* Explicit mode: Set_Attribute_Single requests the robot refused with
     * a CIP error (an assembly's error, recorded in last_error; the link
     * stays up). */
    uint32_t sets_refused;
    /* The originator serial number its Forward Opens carry (the
     * configuration's, or the one made from the machine ID). */
    uint32_t originator_serial;
    /* Has the link ever been up since the robot started (a reload that
     * keeps the robot keeps it)? The console's "never linked": values
     * that were never the robot's. */
    bool ever_up;
} gw_robot_link_t;

/* The robot's Identity object (class 1, instance 1), as the link reads it
 * (Get_Attributes_All) after each session it registers: who the robot says
 * it is, for the sides that show it (OPC UA's MotionDevice and Controller
 * identification, the console's /api/v1 robot object, drgatewayd status).
 * WAITING until the first read answers (also while the link never came
 * up); REFUSED when the robot refused the read or answered something that
 * is not an Identity: the values stay unknown, the link is not touched.
 * A later session reads it again: the robot behind the address may have
 * been replaced. */
typedef enum {
    GW_IDENTITY_WAITING = 0,
    GW_IDENTITY_KNOWN = 1,
    GW_IDENTITY_REFUSED = 2
} gw_identity_state_t;
#define GW_IDENTITY_NAME 33 /* SHORT_STRING, at most 32 characters (CIP Vol. 1, 5A-2) */
typedef struct {
    uint8_t state;          /* gw_identity_state_t */
    dr_status_t why;        /* REFUSED: the robot's answer (DR_CIP(), DR_ESHORT, ...) */
    uint16_t vendor_id, device_type, product_code;
    uint8_t rev_major, rev_minor;
    uint32_t serial;
    char product_name[GW_IDENTITY_NAME]; /* printable ASCII only ('?' for the rest) */
} gw_robot_identity_t;

/* The last write a northbound side accepted for the robot (the console
 * shows it): when, from whom, and the fields it changed by canonical path. */
#define GW_WRITE_CLIENT 64
#define GW_WRITE_FIELDS 8
#define GW_WRITE_PATH 48
typedef struct {
    uint64_t time_us;           /* wall clock, microseconds since 1970; 0: none yet */
    char client[GW_WRITE_CLIENT]; /* "192.0.2.7:50412", "rtu /dev/ttyUSB0 unit 2", "mqtt TOPIC" */
    unsigned nfields;           /* fields changed; the first GW_WRITE_FIELDS kept */
    char fields[GW_WRITE_FIELDS][GW_WRITE_PATH];
} gw_robot_write_t;

/* What the one write path (core/write.h) needs of the configuration for
 * this robot: set by gw_write_policy_set() at start and at each reload. */
typedef struct gw_write_policy {
    bool one_owner; /* the outputs have one owner: single-writer mode */
    unsigned gpio_in_count;
    dr_ref_t gpio_in[GW_MAX_GPIO]; /* the O->T bits its GPIO inputs drive */
} gw_write_policy_t;

typedef struct {
    uint8_t img[DR_ASM_COUNT][DR_ASM_MAX_SIZE]; /* wire images, both ways */
    char name[GW_NAME_MAX];
    /* Which start of this robot it is: a robot a reload keeps (same name,
     * same link settings) keeps its serial and its data; a new or changed
     * one gets a new serial. A side carries its own per-robot state over a
     * reload by it (robot positions change). 0: no robot. */
    uint32_t serial;
    gw_robot_link_t link;
    /* O->T assemblies the connection plan gives no owner connection (set
     * by the link): nothing would carry a write to the robot, so the sides
     * refuse writes to them rather than keep them where nobody reads. */
    unsigned o2t_unsent;
    /* T->O data while the link is not up: cleared when it goes down, and
     * what arrives before it is up again (connections of a partly open
     * link) dropped without telling the sides. Set from [modbus]
     * on_link_loss = zero by the Modbus side, but applied to the images
     * here because every side reads the same images: GPIO outputs and
     * MQTT's snapshot after a reconnect see what Modbus sees (the daemon
     * has always behaved so). on_link_loss = exception is the Modbus read
     * path's alone (regmap.c). */
    bool clear_while_down;
    /* A fault latched for this robot by a side (the Modbus single writer's
     * watchdog) and told to every side (north.h: env->fault): the daemon
     * keeps it here so that a side that starts or reloads later knows it,
     * and the write path (core/write.h) refuses writes while it is set
     * (a reset clears it at once; the other sides hear it at the next
     * turn). Modbus's status block shows it (write_fault). */
    bool fault;
    gw_write_policy_t write_policy;
    /* The daemon's, shown with the robot (refreshed ten times a second):
     * +1 every second, seconds since start, configuration generation. */
    uint16_t heartbeat;
    uint32_t uptime_s;
    uint16_t generation;
    gw_robot_write_t last_write; /* set by gw_robot_wrote() */
    gw_robot_identity_t identity; /* set by the link (gw_robot_identity_answer) */
} gw_robot_t;

/* A robot that has not started: images, link facts and counters zero,
 * name and serial set. */
void gw_robot_init(gw_robot_t *r, const char *name, uint32_t serial);

/* r replaces `old`, the same robot before a reload changed its section:
 * what a PLC watches for liveness and progress goes on from where it was
 * (the heartbeat and the packet counters never go backwards; the
 * generation register says that a reload happened). */
void gw_robot_carry_over(gw_robot_t *r, const gw_robot_t *old);

/* Why the link last failed (DR_OK: nothing to record), in last_status and
 * as gw_robot_error_code() in last_error and last_cip_general. */
void gw_robot_record_error(gw_robot_t *r, dr_status_t why);

/* last_error's code space, one number for every cause a PLC may act on:
 *   general != 0: a CIP reply's status: last_error is its extended status
 *                 (the general one when the reply had none);
 *   general == 0: 1..0x7FFF a drgate status code (drgate/status.h, whose
 *                 numbers never change), GW_ERROR_ENCAP + an encapsulation
 *                 status (RegisterSession or a request refused by the
 *                 robot's encapsulation layer), GW_ERROR_OTHER for an
 *                 encapsulation status above 0x7FFE.
 * docs/register-map.md's table of them is `drgatewayd --print-errors`. */
#define GW_ERROR_ENCAP 0x8000u
#define GW_ERROR_OTHER 0xFFFFu
uint16_t gw_robot_error_code(dr_status_t why, uint16_t *general);

/* The cause in words, as the log, MQTT's state and drcli say it:
 * "connection refused", "CIP 0x01/0x0106 ownership conflict",
 * "encapsulation: unsupported protocol version (0x0069)"; "" for DR_OK. */
void gw_robot_error_text(dr_status_t why, char *buf, size_t size);

/* Why the robot's link last failed, in the words of its log, status
 * summary, API and MQTT state: gw_robot_error_text() of last_status, with
 * the address for DR_ENODATA ("the robot accepted the connection but sends
 * no data to 10.0.0.5:2222: a firewall, or the robot answers another
 * address"); "" before the first failure. */
void gw_robot_cause(const gw_robot_t *r, char *buf, size_t size);

/* What is wrong with `line`, the first line of /etc/machine-id, as the
 * source of the default originator serial (docs/deployment.md): NULL when
 * it looks like a real machine ID; else "missing or empty",
 * "uninitialized" (systemd's placeholder of an image not yet booted) or
 * "all zeros". A machine ID shared by boxes cloned from one image cannot
 * be seen from one box. */
const char *gw_machine_id_problem(const char *line);

/* What usually causes `why` on a robot link and what to check, for the
 * documentation's table; NULL when there is nothing to add. */
const char *gw_robot_error_hint(dr_status_t why);

/* The link went down: with clear_while_down, the T->O images go to 0
 * (the O->T images are the sides' and stay). */
void gw_robot_link_down(gw_robot_t *r);

/* May T->O data that arrives now go into the images? (Not while the link
 * is down with clear_while_down.) */
bool gw_robot_takes_data(const gw_robot_t *r, bool link_up);

/* A write from `client` was accepted (core/write.c, the one write path,
 * calls these): last_write holds it (its time now); its fields are added
 * with gw_robot_write_field(). */
void gw_robot_wrote(gw_robot_t *r, const char *client);
/* One more field of that write (a path already there is not repeated). */
void gw_robot_write_field(gw_robot_t *r, const char *path);
/* The fields of last_write as "a, b, c (+N more)" into buf. */
void gw_robot_write_fields_text(const gw_robot_t *r, char *buf, size_t size);

/* The robot's answer to the link's Get_Attributes_All of its Identity:
 * `st` the request's status, data[0..len) the reply's data. DR_OK with
 * the seven attributes (more may follow, as CIP allows) makes the identity
 * KNOWN; a refusal (a CIP or encapsulation error), a reply that is not one
 * (DR_EMALFORMED, DR_EMISMATCH), or one too short for the attributes or
 * its name (DR_ESHORT) makes it REFUSED; anything else (no answer: a
 * timeout, the session lost) leaves it as it was, for the next session to
 * ask again. Returns the new state's status: DR_OK (known), the refusal,
 * or `st` (left). */
dr_status_t gw_robot_identity_answer(gw_robot_t *r, dr_status_t st, const uint8_t *data,
                                     size_t len);

/* a and b say the same (state, cause and every field). */
bool gw_robot_identity_same(const gw_robot_identity_t *a, const gw_robot_identity_t *b);

/* The name ODVA gives vendor ID `vendor` for the vendors this gateway
 * knows of (1573: "Doosan Robotics"), else "vendor N", into buf. */
void gw_identity_vendor_text(uint16_t vendor, char *buf, size_t size);

/* The Identity's serial number as drcli identity prints it: "0x0012abcd". */
void gw_identity_serial_text(uint32_t serial, char *buf, size_t size);

/* Why a REFUSED identity is unknown: "CIP 0x08 service not supported",
 * "a reply too short for an Identity". */
void gw_robot_identity_refusal(const gw_robot_identity_t *id, char *buf, size_t size);

/* One line for logs and drgatewayd status: "Doosan Robotics, 'M1013
 * controller' (product code 3, revision 2.12, serial 0x0012abcd)"; "not
 * read yet" / "refused: CIP 0x08 service not supported". */
void gw_robot_identity_text(const gw_robot_identity_t *id, char *buf, size_t size);

/* Field `ref` of the robot's images; DR_OK or why not. */
dr_status_t gw_robot_get(const gw_robot_t *r, dr_ref_t ref, dr_value_t *v);

#endif /* DRGATE_GW_ROBOT_H */
