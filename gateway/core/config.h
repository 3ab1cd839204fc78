/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd configuration: one INI file (parsed with libinih).
 *
 *   [daemon]            log level
 *   [modbus]            listen address/port, clients, word order, allowlist
 *   [robot NAME]        one section per robot, each with its own unit ID
 *   [gpio NAME]         one section per GPIO line
 *   [modbus_rtu NAME]   one section per serial line (Modbus RTU slave)
 *   [mqtt]              MQTT northbound side (north_mqtt.c), off without it
 *   [http]              the console: web pages, JSON API (north_http.c)
 *
 * "[robot NAME]" and "[robot.NAME]" are the same section ("[robot]" alone
 * names the robot "robot"); likewise "[gpio NAME]" and "[gpio.NAME]".
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

/* Robots per daemon (32: the robots-per-core goal of issue 15, measured by
 * mk/bench_scale.mk; each costs about 1.8 kB of gw_config_t (1.5 kB the room of its own
 * register map, GW_MAX_MAP blocks) and 5.6 kB of
 * mostly untouched bss in the daemon, docs/performance.md). The library's
 * shared UDP port takes as many clients (DR_UDP_PORT_MAX_CLIENTS), so all
 * robots can share 2222. */
#ifndef GW_MAX_ROBOTS
#define GW_MAX_ROBOTS 32
#endif
#define GW_MAX_GPIO 64
#define GW_MAX_ALLOW 16
#define GW_NAME_MAX 32
#define GW_MAX_RTU 4

typedef enum { GW_WORD_ABCD = 0, GW_WORD_CDAB, GW_WORD_BADC, GW_WORD_DCBA } gw_word_order_t;
typedef enum { GW_LOSS_HOLD = 0, GW_LOSS_ZERO, GW_LOSS_EXCEPTION } gw_link_loss_t;
/* A read that covers reserved addresses between the map's blocks. */
typedef enum { GW_UNMAPPED_ZERO = 0, GW_UNMAPPED_EXCEPTION } gw_unmapped_read_t;
typedef enum { GW_MODE_IMPLICIT = 0, GW_MODE_EXPLICIT } gw_robot_mode_t;
/* How a T->O assembly is opened (open.<assembly>): an exclusive owner
 * connection with its O->T partner, input-only or listen-only (heartbeat
 * O->T), or not at all. */
typedef enum { GW_OPEN_OWNER = 0, GW_OPEN_INPUT_ONLY, GW_OPEN_LISTEN_ONLY, GW_OPEN_NONE } gw_open_kind_t;

typedef struct {
    gw_open_kind_t kind;
    int o2t; /* owner: the O->T dr_asm_t; else -1 */
} gw_open_t;

typedef struct {
    uint32_t net;      /* IPv4 network, host order */
    uint32_t mask;     /* prefix as mask */
    bool read_write;   /* false: read-only */
} gw_allow_t;

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
} gw_modbus_config_t;

/* A user register map (docs/register-map.md "Your own map"): `map` lines
 * of [robot NAME], each a block of consecutive addresses in one table
 * serving one field (or a range of its elements) through a view. The
 * parser and the checks: gateway/modbus/usermap.c; serving: regmap.c. */
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
    uint16_t field;    /* index into dr_field_table */
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

typedef struct {
    char name[GW_NAME_MAX];   /* section name */
    char host[64];
    uint16_t tcp_port;        /* default 44818 */
    uint16_t udp_port;        /* robot's Class 1 port, default 2222 */
    char local_addr[64];      /* local UDP address, "" = any */
    uint16_t local_udp_port;  /* default 2222 */
    uint8_t unit_id;          /* Modbus unit ID, 1..247, unique */
    bool alias0, alias255;    /* unit_id_alias: also answers to 0 / 255 */
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
    /* O->T image applied when the single writer's watchdog expires:
     * "zero" (default) or "hold". */
    bool fallback_hold;
    /* implicit: O->T only on its own timer ("strict"), or also sent with
     * an arriving T->O packet when due within a quarter RPI ("follow",
     * default): one wake-up per RPI instead of two. */
    bool o2t_strict;
    /* The originator serial number of its Forward Opens; 0 (default):
     * dr_originator_serial_local(name), from /etc/machine-id (else the
     * host name) and the section name, the same at every start, so that
     * a restarted gateway may take its connections back (issue 19). */
    uint32_t originator_serial;
    gw_umap_t map;            /* `map` lines: the user's register map */
    bool default_map_writes;  /* default yes; no: the default map's robot
                                 data is read-only over Modbus */
    unsigned line;            /* where the section starts, for messages */
} gw_robot_config_t;

typedef enum { GW_GPIO_OUTPUT = 0, GW_GPIO_INPUT } gw_gpio_dir_t;
typedef enum { GW_BIAS_AS_IS = 0, GW_BIAS_DISABLE, GW_BIAS_PULL_UP, GW_BIAS_PULL_DOWN } gw_gpio_bias_t;

typedef struct {
    char name[GW_NAME_MAX];
    char chip[64];            /* "gpiochip0", "/dev/gpiochip0" or a label */
    int offset;               /* -1 when given by line name */
    char line_name[64];
    gw_gpio_dir_t dir;
    char robot[GW_NAME_MAX];  /* robot it belongs to: always filled in by
                                 gw_config_load (the only robot if omitted) */
    unsigned robot_index;     /* that robot's index in gw_config_t.robot[] */
    dr_ref_t field;           /* output: follows this bit; input: drives this O->T bit */
    bool active_low;
    gw_gpio_bias_t bias;
    unsigned debounce_ms;     /* inputs only */
    bool safe_value;          /* outputs: value on link loss, fault and exit */
    unsigned line;
} gw_gpio_config_t;

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
/* [mqtt]: present = enabled (docs/mqtt.md). Strings "" = not set. */
typedef struct {
    bool enabled;             /* the section is present */
    char host[64];
    uint16_t port;            /* default 1883 */
    char client_id[64];       /* default "drgatewayd-<hostname>" */
    char username[64];
    char password_file[256];  /* first line is the password */
    char ca_file[256];        /* set: TLS */
    char cert_file[256];      /* client certificate, with key_file */
    char key_file[256];
    unsigned keepalive_s;     /* default 30, 5..3600 */
    unsigned qos;             /* default 0, 0..2 */
    char topic_prefix[128];   /* default "drgate/<hostname>" */
    bool retain;              /* status/state/meta retained, default yes */
    unsigned publish_interval_ms; /* per robot, default 100, 0..60000 */
    double deadband;          /* REAL fields, absolute, default 0 */
    bool writes;              /* plant writes via <prefix>/<robot>/set/<path> */
    /* payload = sparkplug: Sparkplug B (mqtt/sparkplug.h) instead of JSON */
    unsigned payload;         /* GW_MQTT_JSON (default) or GW_MQTT_SPARKPLUG */
    char group_id[64];        /* Sparkplug group, required with sparkplug */
    char edge_node_id[64];    /* default: the host name */
    char primary_host_id[64]; /* set: births wait for its STATE online */
    unsigned line;            /* the section's line */
} gw_mqtt_config_t;
enum { GW_MQTT_JSON = 0, GW_MQTT_SPARKPLUG };

/* [http]: the console (docs/http.md); present = enabled. Strings "" = not
 * set. */
typedef struct {
    bool enabled;             /* the section is present */
    char listen[64];          /* default "127.0.0.1" */
    uint16_t port;            /* default 8080 */
    unsigned allow_count;     /* 0: every address */
    gw_allow_t allow[GW_MAX_ALLOW]; /* as [modbus] allow; ro/rw alike: the
                                       console only reads */
    char tls_cert[256];       /* PEM certificate, with tls_key: HTTPS */
    char tls_key[256];
    char auth_file[256];      /* user:crypt(3) hash lines: Basic auth for
                                 clients not on loopback */
    bool insecure;            /* plain, open console off loopback, knowingly */
    uint16_t status_port;     /* with TLS: a plain listener on 127.0.0.1 for
                                 drgatewayd status (0: none) */
    unsigned max_connections; /* default 32 */
    unsigned max_connections_per_ip; /* default 8, 0: no limit of its own */
    unsigned timeout_s;       /* idle or slow client closed, default 10 */
    unsigned max_request_bytes; /* URL and headers, default 16384 */
    char tls_priorities[256]; /* GnuTLS priority string, "" = the built-in
                                 TLS 1.2+ AEAD one (north_http.c) */
    unsigned max_streams;     /* live streams at once, default 16 */
    unsigned max_streams_per_ip; /* of one client address, default 4 */
    unsigned stream_max_s;    /* a live stream's age limit, default 3600 */
    unsigned tls_line, auth_line; /* where tls_cert and auth_file are */
    unsigned line;            /* the section's line */
} gw_http_config_t;

typedef struct {
    char path[256];
    gw_modbus_config_t modbus;
    unsigned robot_count;
    gw_robot_config_t robot[GW_MAX_ROBOTS];
    unsigned gpio_count;
    gw_gpio_config_t gpio[GW_MAX_GPIO];
    unsigned rtu_count;
    gw_rtu_config_t rtu[GW_MAX_RTU];
    char log_level[16];       /* [daemon] log_level: error|warning|info|debug */
    gw_mqtt_config_t mqtt;
    gw_http_config_t http;
} gw_config_t;

/* Load and validate `path`. On error returns false and writes
 * "FILE:LINE: what is wrong (allowed: ...)" into err[errlen] (errors about
 * the file itself, such as "cannot open", have no LINE); *out is written
 * only on success, so a failed reload leaves the running config intact. */
bool gw_config_load(const char *path, gw_config_t *out, char *err, size_t errlen);

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

#endif /* DRGATE_GW_CONFIG_H */
