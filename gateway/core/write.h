/* SPDX-License-Identifier: MIT */
/*
 * The one write path (issue 30, item 4): every side that writes a robot's
 * O->T image (Modbus TCP and RTU, MQTT's set topics, Sparkplug's DCMD,
 * GPIO inputs) decodes what it received into a list of field writes and
 * hands the whole list here, once. gw_robot_write() holds every rule of a
 * write, in this order, and applies nothing unless every item passes:
 *
 *   1. the side's right for this client (origin.may_write: [modbus] allow
 *      rw, [modbus_rtu] read_only = no, [mqtt] writes = yes, [opcua] writes
 *      = yes);
 *   2. single-writer mode ([modbus] single_writer): the outputs belong to
 *      one Modbus TCP client (origin.owner); an MQTT, Sparkplug or OPC UA
 *      write is refused; an RTU master and GPIO inputs are not arbitrated;
 *   3. the write fault latch (gw_robot_t.fault): every write is refused
 *      but the reset (origin.reset, with no field in it); GPIO inputs are
 *      the wiring's and go on;
 *   then for each item, on a copy of the images (so that several items on
 *   one field compose, and a refusal leaves the robot as it was):
 *   4. a field the robot consumes (direction: O->T);
 *   5. an assembly the connection plan sends (gw_robot_t.o2t_unsent: a
 *      write nothing would carry to the robot is refused);
 *   6. a bit a GPIO input drives may be named but not changed (but by the
 *      input itself);
 *   7. the codec's range and type checks (dr_field_set: a BIT 0/1, USINT
 *      0..255, a DINT in range, a finite REAL).
 * Accepted: the images are written, the robot's last_write set and the
 * write logged (origin.log: rate-limited per client), the latch cleared by
 * a reset; the caller tells the link (env->outputs_changed, res->dirty).
 *
 * The sides keep only what belongs to their protocol: addressing (Modbus
 * addresses, torn 32-bit values, the default map's read-only switch,
 * the user's map entries), the parsing of payloads, and how a refusal is
 * answered (a Modbus exception, an MQTT error message, a Sparkplug echo).
 */
#ifndef DRGATE_GW_WRITE_H
#define DRGATE_GW_WRITE_H

#include <stdbool.h>
#include <stdint.h>

#include "core/log.h"
#include "core/robot.h"

/* The most items one write takes: FC 15's 1968 coils, one item each. */
#define GW_WRITE_MAX_ITEMS 2000u

typedef enum {
    GW_ORIGIN_MODBUS_TCP = 0,
    GW_ORIGIN_MODBUS_RTU,
    GW_ORIGIN_MQTT,      /* <prefix>/<robot>/set/<path> */
    GW_ORIGIN_SPARKPLUG, /* DCMD */
    GW_ORIGIN_GPIO,      /* an input line */
    GW_ORIGIN_OPCUA,     /* a write of an O->T variable */
    GW_ORIGINS
} gw_origin_side_t;

/* Who writes. */
typedef struct {
    gw_origin_side_t side;
    const char *client;  /* for the write log: "modbus 192.0.2.7:50412",
                            "modbus_rtu bus1 unit 2", "mqtt TOPIC" */
    bool may_write;      /* the side's right for this client (rule 1) */
    bool owner;          /* Modbus TCP: this client owns the outputs, or
                            nobody does (rule 2) */
    bool reset;          /* the write is the fault reset (rule 3) */
    gw_log_limit_t *log; /* the client's write-log limiter; NULL: not logged */
} gw_write_origin_t;

/* One field write. mask 0: the element takes value; else only the bits of
 * mask change, in the element's raw value: a whole BITS field (elem -1:
 * its mask), a DINT element (its 32 bits as unsigned: a 16-bit half). */
typedef struct {
    dr_ref_t ref;
    dr_value_t value;
    uint64_t mask;
} gw_write_item_t;

typedef enum {
    GW_WRITE_OK = 0,
    GW_WRITE_RIGHTS,    /* 1: the side does not let this client write */
    GW_WRITE_SINGLE,    /* 2: single-writer mode, not the owner */
    GW_WRITE_FAULT,     /* 3: the write fault is latched */
    GW_WRITE_FIELD,     /* no such field, or more than GW_WRITE_MAX_ITEMS */
    GW_WRITE_DIRECTION, /* 4: a T->O field */
    GW_WRITE_UNSENT,    /* 5: no connection of the plan carries the assembly */
    GW_WRITE_GPIO,      /* 6: would change a bit a GPIO input drives */
    GW_WRITE_VALUE      /* 7: out of range, wrong type, not finite (res.st) */
} gw_write_status_t;

typedef struct {
    gw_write_status_t status;
    unsigned item;  /* refused: the item (rules 4-7) */
    dr_status_t st; /* GW_WRITE_VALUE: the codec's reason */
    unsigned dirty; /* accepted: the O->T images written, bit per assembly */
    bool reset;     /* accepted: it cleared the latched write fault */
} gw_write_result_t;

/* The rules of robot `index` of cfg that the write path needs (single-
 * writer mode, the bits its GPIO inputs drive) into r->write_policy: at
 * start and at every reload, before any side writes. Each side says its
 * part (gw_side_cfg_t.write_policy, core/config.h); defined in
 * core/config.c with the side list. */
void gw_write_policy_set(gw_robot_t *r, const gw_config_t *cfg, unsigned index);

/* Rules 1-3 alone (no item looked at, nothing changed): a side that must
 * answer them before it parses a request (Modbus's 0x01 comes before
 * 0x03) asks first. */
gw_write_status_t gw_write_allowed(const gw_robot_t *r, const gw_write_origin_t *o);

/* items[0..n) from o, all or nothing: GW_WRITE_OK and the images written,
 * or the first rule refused (res->item, res->st) and nothing changed. n
 * may be 0 (a Modbus write of its control registers alone: rules 1-3).
 * res may be NULL. */
gw_write_status_t gw_robot_write(gw_robot_t *r, const gw_write_item_t *items, unsigned n,
                                 const gw_write_origin_t *o, gw_write_result_t *res);

/* "single-writer mode: the outputs belong to the Modbus writer", ... (the
 * words MQTT answers with). */
const char *gw_write_status_text(gw_write_status_t s);

/* The robot's last_write logged at info, "robot R: write by CLIENT:
 * FIELDS", at most one line per second per client (`limit`). */
#define GW_WRITE_LOG_MS 1000u
void gw_write_log(const gw_robot_t *r, gw_log_limit_t *limit);

#endif /* DRGATE_GW_WRITE_H */
