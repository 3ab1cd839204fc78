/* SPDX-License-Identifier: MIT */
/*
 * When a leaf is published again: the rule both MQTT payloads follow (the
 * JSON data topic and Sparkplug B's DDATA, docs/mqtt.md "deadband"): a
 * leaf never published goes out; integers and bits on any change; REALs
 * when they moved by more than the deadband (any change with deadband 0),
 * and when they become or stop being NaN or infinite.
 */
#ifndef DRGATE_GW_MQTT_DEADBAND_H
#define DRGATE_GW_MQTT_DEADBAND_H

#include <stdbool.h>

#include "drgate/codec.h"

/* What was last published of one leaf. */
typedef struct {
    bool have; /* published at least once since the last full message */
    double v;
} gw_mqtt_last_t;

bool gw_mqtt_changed(const gw_mqtt_last_t *last, const dr_value_t *v, double deadband);

#endif /* DRGATE_GW_MQTT_DEADBAND_H */
