/* SPDX-License-Identifier: MIT */
/*
 * The Modbus register map, generated from the codec's field table.
 *
 * Every Modbus unit (one per robot) has the same default layout, and
 * may have its own map besides, at addresses the default leaves free
 * (the robot's `map` lines, usermap.h); addresses are 0-based PDU offsets. T->O data is read-only (input registers, discrete
 * inputs), O->T data read/write (holding registers, coils). REAL and DINT
 * take two registers in the configured word order; bit fields appear both
 * as single bits and packed into words; REALs also as scaled INT16.
 * docs/register-map.md is generated from gw_regmap_print().
 *
 * Requests are checked completely before anything is applied: a write
 * that fails a check changes nothing.
 */
#ifndef DRGATE_GW_REGMAP_H
#define DRGATE_GW_REGMAP_H

#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>

#include "drgate/codec.h"
#include "core/config.h"
#include "core/json.h"
#include "core/north.h"
#include "core/robot.h"
#include "core/write.h"

#define GW_MAP_LAYOUT_VERSION 1
#define GW_AREA_SIZE 2048 /* addresses per area */

typedef enum { GW_COILS = 0, GW_DISCRETE, GW_HOLDING, GW_INPUT, GW_AREAS } gw_area_t;

/* Modbus exception codes used here. */
enum {
    GW_EX_ILLEGAL_FUNCTION = 0x01,
    GW_EX_ILLEGAL_ADDRESS = 0x02,
    GW_EX_ILLEGAL_VALUE = 0x03,
    GW_EX_DEVICE_FAILURE = 0x04, /* a write while the write fault is latched */
    GW_EX_TARGET_FAILED = 0x0B
};

/* Modbus's part of the status block (the rest is the robot's: link
 * state, freshness, counters, errors, connection states, heartbeat,
 * uptime and generation, from gw_robot_t; write_fault too: the robot's
 * latch, gw_robot_t.fault). Refreshed ten times a second by the Modbus
 * side (north_modbus.c). */
typedef struct {
    uint32_t exceptions;      /* Modbus exceptions sent, TCP and RTU */
    uint16_t clients;
    bool writer_present;
    /* Modbus RTU lines of this robot: frames dropped (bad CRC, short,
     * long, cut by t3.5) and frames for other slave addresses (IR 40-43). */
    uint32_t rtu_dropped, rtu_other;
} gw_status_t;

/* One robot as Modbus sees it: the robot (its images and link facts,
 * robot.h: the daemon's, shared with every side) and the [modbus] rules
 * and state that are Modbus's alone. The Modbus side keeps one per robot
 * position and carries it over a reload by the robot's serial. */
typedef struct {
    gw_robot_t *robot;
    gw_word_order_t order;
    gw_link_loss_t on_loss; /* exception: 0x0B while the link is not up (hold
                             * and zero read the images: zero is applied to
                             * them, robot.h) */
    gw_unmapped_read_t unmapped; /* reserved addresses: read 0 or 0x02 */
    gw_status_t status;
    /* The robot's own map (its `map` lines, in the configuration the
     * daemon runs: unit_policy points here), served at the addresses the
     * default map leaves free. NULL or empty: the default map alone. */
    const gw_umap_t *umap;
    /* default_map_writes = no: the default map's robot data is read-only
     * (its control registers stay writable), so that the user's map says
     * alone what Modbus may write. */
    bool default_ro;
    uint16_t watchdog;        /* last value written to the watchdog register */
    bool fault_reset;         /* set when a client wrote the reset register */
} gw_unit_t;

/* Holding registers with a meaning of their own (0-based). */
#define GW_HR_WATCHDOG 0    /* the single writer bumps it */
#define GW_HR_FAULT_RESET 1 /* write 1 to clear the latched write fault */

/* Build the map (once; cheap to call again). */
void gw_regmap_init(void);

/* One past the last mapped address of a table: reads end there. */
uint16_t gw_regmap_extent(gw_area_t area);

/* True if the robot data (not status/test/control) is addressed. */
bool gw_regmap_touches_robot_data(gw_area_t area, uint16_t addr, uint16_t count);

/* Read `count` registers (values) or bits (0/1 in values) starting at
 * `addr`. Returns 0 or a Modbus exception code: 0x02 for an address past
 * the table's last mapped one, or (unmapped = exception) for any reserved
 * address in the range, which otherwise reads 0; 0x0B with on_link_loss =
 * exception and robot data addressed while the link is down. */
int gw_regmap_read(const gw_unit_t *u, gw_area_t area, uint16_t addr,
                   uint16_t count, uint16_t *values);

/* A write of `count` values to holding registers or coils from `o`
 * (NULL: a Modbus TCP client with every right, not logged): decoded here
 * into field writes (addresses, the halves of 32-bit values, packed
 * masks, the user's map, the control registers), then checked and
 * applied by the one write path, gw_robot_write (core/write.h), whose
 * refusal is mapped to the exception a PLC has always seen
 * (gw_regmap_exception). Returns 0 or an exception code: 0x02 an
 * unmapped address, the default map's data with default_map_writes = no,
 * a user's entry that is not writable, a write that covers only one half
 * of a 32-bit value; then the path's: 0x01 the client's right or the
 * single writer, 0x04 the write fault latch, 0x02 a T->O field, an
 * assembly the plan does not send, a bit a GPIO input drives, 0x03 a
 * value out of range, NaN/infinite REAL. On error nothing changes. res
 * (may be NULL): the path's result; res->dirty has bit (1 << assembly) set
 * for every O->T image written. */
int gw_regmap_write(gw_unit_t *u, gw_area_t area, uint16_t addr, uint16_t count,
                    const uint16_t *values, const gw_write_origin_t *o, gw_write_result_t *res);

/* The Modbus exception for a refusal of the write path (0: none). */
int gw_regmap_exception(gw_write_status_t st);

/* The fields a write of area/addr..addr+count-1 reaches, each once by
 * its canonical path (control registers left out), for the write log. */
void gw_regmap_write_fields(const gw_unit_t *u, gw_area_t area, uint16_t addr, uint16_t count,
                            void (*fn)(void *user, const char *path), void *user);

/* Does the default map use any address of area in addr..addr+n-1? The
 * first one used into *at. (The user's map must stay out of them.) */
bool gw_regmap_default_used(gw_area_t area, uint32_t addr, uint32_t n, uint16_t *at);
/* The name of what the default map has at area/addr ("" if nothing). */
void gw_regmap_slot_name(gw_area_t area, uint16_t addr, char *buf, size_t size);

/* The scale of a REAL field's INT16 view (10 or 100). */
unsigned gw_regmap_scale(const dr_field_t *f);

/* Print the map: plain text, Markdown (docs/register-map.md) or JSON. */
/* gw_print_fmt_t: core/north.h (the print_map side op). */
void gw_regmap_print(FILE *out, gw_print_fmt_t fmt);
/* The same, of the default map's entries whose name contains `filter`
 * (NULL: all), then, for each robot that has one, its own map. */
void gw_regmap_print_all(FILE *out, gw_print_fmt_t fmt, const char *filter,
                         const gw_config_t *cfg);
/* The map as the console shows it (/api/v1/robots/NAME/map): robot
 * `robot` of cfg, every leaf (one element of one field, keyed by its
 * canonical path as drcli get --json keys it) with its type, unit,
 * direction, enum names and every Modbus address that serves it: the
 * default map's views (register, packed bits, 32-bit pair in the word
 * order, scaled INT16, bit) and the robot's own map, each with its table,
 * 0-based address, count, reference number (30001-style) and whether
 * Modbus may write it. From the same slots that serve and print the map.
 * False if robot is out of range or j is full. GW_REGMAP_JSON_SIZE bytes
 * always fit: the default map takes about 120 kB, each element a user's
 * entry serves about 140 bytes more (GW_MAX_MAP entries of 64 elements). */
#define GW_REGMAP_JSON_SIZE (768u * 1024u)
bool gw_regmap_json(gw_json_t *j, const gw_config_t *cfg, unsigned robot);
/* /api/v1/robots/NAME/map.csv: the rows `--print-map --json` prints for
 * robot `robot` (the default map, then its own), as CSV (RFC 4180, a
 * header line: area,address,count,reference,name,type,unit,robot,
 * writable; robot and writable empty on the default map's rows). False:
 * no such robot, or j is full. */
bool gw_regmap_csv(gw_json_t *j, const gw_config_t *cfg, unsigned robot);
/* /api/v1/modbus/registers/NAME: the words a PLC reads from unit u (robot
 * `robot`), row by row of the map as --print-map has them, in address
 * order per table: {"robot", "tables": {"CO": [{"address", "count",
 * "ref", "name", "words": [...]} or {..., "ex": code}, ...], ...}} (a
 * row of the robot's own map: "user": true). False: no such robot, or j
 * is full. */
bool gw_regmap_raw_json(gw_json_t *j, const gw_unit_t *u, const gw_config_t *cfg, unsigned robot);

/* Every value of the status block's last_error (IR 12) with
 * last_cip_general (IR 30): text or Markdown (docs/register-map.md). */
void gw_regmap_print_errors(FILE *out, gw_print_fmt_t fmt);

/* The word orders' names as [modbus] word_order takes them, in
 * gw_word_order_t's order, NULL-terminated (the configuration's table);
 * gw_word_order_name(): "?" for a value outside the enum. */
extern const char *const gw_word_order_names[];
const char *gw_word_order_name(gw_word_order_t w);

/* 32-bit value <-> two registers in a word order (our own codec, not
 * libmodbus's float helpers). */
void gw_words_from_u32(uint32_t v, gw_word_order_t order, uint16_t out[2]);
uint32_t gw_words_to_u32(const uint16_t in[2], gw_word_order_t order);

#endif /* DRGATE_GW_REGMAP_H */
