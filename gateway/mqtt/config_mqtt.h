/* SPDX-License-Identifier: MIT */
/*
 * The MQTT side's configuration (config_mqtt.c reads it): [mqtt].
 */
#ifndef DRGATE_GW_MQTT_CONFIG_H
#define DRGATE_GW_MQTT_CONFIG_H

#include "core/config_types.h"

/* The most brokers `servers` may name. */
#define GW_MQTT_SERVERS_MAX 4u

/* One broker: an IPv4 address or a host name, and its port. */
typedef struct {
    char host[64];
    uint16_t port;
} gw_mqtt_server_t;

/* [mqtt]: present = enabled (docs/mqtt.md). Strings "" = not set. */
typedef struct {
    bool enabled;             /* the section is present */
    char host[64];            /* one broker (or `servers`) */
    uint16_t port;            /* default 1883: host's, and that of a server without one */
    /* The brokers in the order they are tried: `servers`, or `host` and
     * `port` (mqtt_check fills it in either way; the side reads only this). */
    gw_mqtt_server_t server[GW_MQTT_SERVERS_MAX];
    unsigned server_count;
    unsigned host_wait_s;     /* primary_host_wait_s: STATE online within this, or next server */
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
    unsigned metric_names;    /* SPB_NAMES_FOLDERS (default) or SPB_NAMES_CANONICAL */
    char bdseq_file[256];     /* "": $STATE_DIRECTORY or /var/lib/drgate, see sparkplug.c */
    unsigned line;            /* the section's line */
} gw_mqtt_config_t;
enum { GW_MQTT_JSON = 0, GW_MQTT_SPARKPLUG };

/* The side's member of gw_config_t (gateway/sides.h). */
typedef gw_mqtt_config_t gw_mqtt_side_config_t;

/* The side's member of a robot's configuration (gw_robot_config_t.side,
 * gateway/sides.h): it has no keys of [robot NAME] (C has no empty
 * struct). */
typedef struct {
    char none;
} gw_mqtt_robot_config_t;

#endif /* DRGATE_GW_MQTT_CONFIG_H */
