/* SPDX-License-Identifier: MIT */
/*
 * The Modbus side's configuration (config_modbus.c reads it): [modbus],
 * the TCP server, and [modbus_rtu NAME], its serial lines; and its keys
 * of [robot NAME] (unit_id, unit_id_alias, map, default_map_writes,
 * fallback), kept in each robot's gw_robot_config_t.side.modbus.
 */
#ifndef DRGATE_GW_MODBUS_CONFIG_H
#define DRGATE_GW_MODBUS_CONFIG_H

#include "core/config_types.h"

#define GW_MAX_RTU 4

typedef enum { GW_PARITY_NONE = 0, GW_PARITY_EVEN, GW_PARITY_ODD } gw_parity_t;

/* One serial line on which the gateway is a Modbus RTU slave, answering
 * for some robots, each at its own slave address. */
typedef struct {
    char name[GW_NAME_MAX];
    char device[128];         /* required: /dev/ttyS0, /dev/ttyUSB0, ... */
    unsigned baud;            /* default 19200 */
    gw_parity_t parity;       /* default even (the Modbus default) */
    unsigned data_bits;       /* 8: RTU bytes are 8 bits */
    unsigned stop_bits;       /* default 1 */
    bool rs485;               /* ask the driver for RS-485 mode (TIOCSRS485) */
    bool rts_on_send_low;     /* RS-485: RTS low while sending (default high) */
    unsigned rts_before_ms, rts_after_ms; /* RS-485 RTS delays, default 0 */
    bool read_only;           /* refuse writes with 0x01 (default no) */
    unsigned slave_count;     /* robots on the line (default: all) */
    unsigned slave_robot[GW_MAX_ROBOTS]; /* robot index */
    uint8_t slave_addr[GW_MAX_ROBOTS];   /* 1..247, default the unit_id */
    unsigned line;
} gw_rtu_config_t;

typedef enum { GW_WORD_ABCD = 0, GW_WORD_CDAB, GW_WORD_BADC, GW_WORD_DCBA } gw_word_order_t;
typedef enum { GW_LOSS_HOLD = 0, GW_LOSS_ZERO, GW_LOSS_EXCEPTION } gw_link_loss_t;
/* A read that covers reserved addresses between the map's blocks. */
typedef enum { GW_UNMAPPED_ZERO = 0, GW_UNMAPPED_EXCEPTION } gw_unmapped_read_t;

typedef struct {
    char listen[64];          /* address, default "0.0.0.0" */
    uint16_t port;            /* default 502 */
    unsigned max_clients;     /* default 16, 1..256 */
    unsigned idle_timeout_s;  /* default 60; 0 = never */
    bool keepalive;           /* default true */
    gw_word_order_t word_order; /* default abcd */
    gw_link_loss_t on_link_loss; /* default hold */
    gw_unmapped_read_t unmapped_read; /* default zero */
    unsigned allow_count;     /* 0: everyone read-write */
    gw_allow_t allow[GW_MAX_ALLOW]; /* file order; the first match decides
                                       (the loader refuses shadowed entries) */
    /* Single-writer mode (EK9000-like write lock). */
    bool single_writer;       /* default false */
    unsigned writer_watchdog_ms; /* default 1000 */
    /* A request must be complete this long after its first byte. */
    unsigned request_timeout_ms; /* default 3000, 100..60000 */
    /* [modbus_rtu NAME] sections: the serial lines */
    unsigned rtu_count;
    gw_rtu_config_t rtu[GW_MAX_RTU];
} gw_modbus_config_t;

/* A user register map (docs/register-map.md "Your own map"): `map` lines
 * of [robot NAME], each a block of consecutive addresses in one table
 * serving one field (or a range of its elements) through a view. The
 * parser and the checks: usermap.c; serving: regmap.c. */
#define GW_MAX_MAP 64u
/* The tables, in gw_area_t's order (regmap.h). */
typedef enum { GW_UMAP_CO = 0, GW_UMAP_DI, GW_UMAP_HR, GW_UMAP_IR, GW_UMAP_TABLES } gw_umap_table_t;
typedef enum {
    GW_VIEW_BIT = 0, /* coils / discrete inputs: one bit per element */
    GW_VIEW_REAL,    /* REAL: 2 registers per element, the word order */
    GW_VIEW_DINT,    /* DINT: 2 registers per element, the word order */
    GW_VIEW_INT16,   /* any number x scale, rounded half away from zero */
    GW_VIEW_UINT16,  /* BIT/USINT/ENUM as is; DINT: one half (lo/hi) */
    GW_VIEW_BITS     /* BIT/BITS elements packed 16 per register */
} gw_view_t;

typedef struct {
    uint8_t table;     /* gw_umap_table_t */
    uint8_t view;      /* gw_view_t */
    bool writable;     /* the entry says so (O->T fields in HR/coils only) */
    bool saturate;     /* INT16: clamping is expected */
    uint8_t half;      /* UINT16 of a DINT: 0 low half, 1 high half */
    uint16_t field;    /* dr_field_at(field) */
    uint16_t elem;     /* first element (0-based) */
    uint16_t count;    /* elements */
    uint16_t scale;    /* INT16: the factor (1..10000) */
    uint16_t addr;     /* first address (0-based PDU address) */
    uint32_t size;     /* addresses taken (addr + size <= 65536) */
    unsigned line;     /* where it was written, for messages */
} gw_umap_entry_t;

typedef struct {
    unsigned count;
    gw_umap_entry_t entry[GW_MAX_MAP]; /* sorted by table, then address */
} gw_umap_t;

/* The side's member of a robot's configuration (gw_robot_config_t.side,
 * gateway/sides.h): its keys of [robot NAME] (config_modbus.c). */
typedef struct {
    uint8_t unit_id;          /* Modbus unit ID, 1..247, unique */
    bool alias0, alias255;    /* unit_id_alias: also answers to 0 / 255 */
    gw_umap_t map;            /* `map` lines: the user's register map */
    bool default_map_writes;  /* default yes; no: the default map's robot
                                 data is read-only over Modbus */
    /* O->T image applied when the single writer's watchdog expires:
     * "zero" (default) or "hold". */
    bool fallback_hold;
} gw_modbus_robot_config_t;

/* The side's member of gw_config_t (gateway/sides.h): [modbus] and its
 * [modbus_rtu NAME] lines. */
typedef gw_modbus_config_t gw_modbus_side_config_t;

#endif /* DRGATE_GW_MODBUS_CONFIG_H */
