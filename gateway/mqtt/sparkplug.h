/* SPDX-License-Identifier: MIT */
/*
 * Sparkplug B (Eclipse Sparkplug 3.0, namespace spBv1.0) over the MQTT
 * side's connection: [mqtt] payload = sparkplug (docs/mqtt.md
 * "Sparkplug B"). The gateway is one edge node (group_id, edge_node_id);
 * each robot is a device named as in the configuration.
 *
 * north_mqtt.c owns the connection (libmosquitto in the daemon's loop) and
 * calls these hooks; this module owns what goes over it: NBIRTH/NDEATH
 * with bdSeq, DBIRTH/DDEATH per robot link, DDATA by alias, the seq
 * counter, NCMD (Rebirth), DCMD (plant writes) and the primary host's
 * STATE. Payloads are protobuf (sparkplug_b.proto, nanopb), encoded
 * without malloc: the metrics of a birth stream from the field table into
 * one buffer.
 */
#ifndef GW_MQTT_SPARKPLUG_H
#define GW_MQTT_SPARKPLUG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/north.h"
#include "drgate/codec.h"

/* Sparkplug 3.0 datatypes (Metric.datatype) the gateway uses. */
#define SPB_DT_INT8 1u
#define SPB_DT_INT16 2u
#define SPB_DT_INT32 3u
#define SPB_DT_INT64 4u
#define SPB_DT_UINT8 5u
#define SPB_DT_UINT16 6u
#define SPB_DT_UINT32 7u
#define SPB_DT_UINT64 8u
#define SPB_DT_FLOAT 9u
#define SPB_DT_DOUBLE 10u
#define SPB_DT_BOOLEAN 11u
#define SPB_DT_STRING 12u

#define SPB_REBIRTH "Node Control/Rebirth"

typedef struct spb spb_t;

/* What the module asks of the connection (north_mqtt.c). */
typedef struct {
    void *user;
    /* Queue one message with [mqtt] qos; false: not queued. */
    bool (*publish)(void *user, const char *topic, const void *payload, size_t len,
                    bool retain);
    bool (*subscribe)(void *user, const char *topic, int qos);
    /* Room for one more message now (nothing unsent, in-flight bound). */
    bool (*room)(void *user);
    /* A plant write of `v` into the robot's O->T image with the checks of
     * an MQTT or Modbus write; false with `why` when refused. */
    bool (*write)(void *user, unsigned robot, dr_ref_t ref, const dr_value_t *v, char *why,
                  size_t whylen);
    /* Drop the connection (it reconnects with the next bdSeq). */
    void (*reconnect)(void *user);
} spb_io_t;

/* From [mqtt]; `host` is the machine's name (edge_node_id's default).
 * NULL with err. */
spb_t *spb_new(const gw_mqtt_config_t *q, const gw_north_env_t *env, const spb_io_t *io,
               const char *host, char *err, size_t errlen);
void spb_free(spb_t *s);

/* The Will of the next connection: NDEATH with the next bdSeq (each
 * connection takes a new one). Valid until the next call. */
void spb_will(spb_t *s, const char **topic, const void **payload, size_t *len);

/* The connection is up (subscribes; births once the primary host, if
 * any, is online) or gone. */
void spb_connected(spb_t *s);
void spb_disconnected(spb_t *s);

/* A message from the broker: true if it was Sparkplug's (handled). */
bool spb_message(spb_t *s, const char *topic, const void *payload, size_t len);

/* Publish what is due, as far as there is room. */
void spb_tick(spb_t *s, uint64_t now_us);
/* When the next tick is needed for this module (UINT64_MAX: none). */
uint64_t spb_deadline(const spb_t *s, uint64_t now_us);

void spb_on_data(spb_t *s, unsigned robot, dr_asm_t a);
void spb_on_link(spb_t *s, unsigned robot, bool up);
/* The robots as they are now (start, reload): every birth again. */
void spb_sync(spb_t *s, bool links);

/* A deliberate disconnect: NDEATH published first (the broker does not
 * send the Will then). */
void spb_goodbye(spb_t *s);

/* Decode an NCMD/DCMD payload's metrics (the fuzz harness's entry):
 * calls `fn` for each metric; false if the payload is malformed. */
struct _Payload_Metric;
typedef bool (*spb_metric_fn)(void *ctx, const struct _Payload_Metric *m);
bool spb_decode_cmd(const void *payload, size_t len, spb_metric_fn fn, void *ctx);

#endif
