/* SPDX-License-Identifier: MIT */
/*
 * libmosquitto, loaded at run time (dlopen) by the MQTT side only when the
 * configuration has an [mqtt] section: a gateway without MQTT does not map
 * libmosquitto, nor the libssl and libcrypto it pulls in (~1.8 MB of RSS;
 * docs/performance.md "Gateway", docs/mqtt.md).
 *
 * Compiled against <mosquitto.h> for the types and constants; the table's
 * prototypes are those of the header (mqtt_lib.c checks it at compile time).
 */
#ifndef GW_MQTT_LIB_H
#define GW_MQTT_LIB_H

#include <stdbool.h>
#include <stddef.h>

#include <mosquitto.h>

/* The library's name as dlopen is given it; the environment variable
 * DRGATE_MOSQUITTO_LIB replaces it (a test and diagnostic knob,
 * drgatewayd(8)). */
#define GW_MQTTLIB_SONAME "libmosquitto.so.1"

/* The functions north_mqtt.c calls, each mosquitto_<member>. */
typedef struct {
    int (*lib_init)(void);
    int (*lib_cleanup)(void);
    const char *(*strerror)(int mosq_errno);
    const char *(*connack_string)(int connack_code);
    struct mosquitto *(*new)(const char *id, bool clean_session, void *obj);
    void (*destroy)(struct mosquitto *mosq);
    int (*will_set)(struct mosquitto *mosq, const char *topic, int payloadlen,
                    const void *payload, int qos, bool retain);
    int (*username_pw_set)(struct mosquitto *mosq, const char *username, const char *password);
    int (*tls_set)(struct mosquitto *mosq, const char *cafile, const char *capath,
                   const char *certfile, const char *keyfile,
                   int (*pw_callback)(char *buf, int size, int rwflag, void *userdata));
    int (*max_inflight_messages_set)(struct mosquitto *mosq, unsigned int max_inflight_messages);
    void (*connect_callback_set)(struct mosquitto *mosq,
                                 void (*on_connect)(struct mosquitto *, void *, int));
    void (*disconnect_callback_set)(struct mosquitto *mosq,
                                    void (*on_disconnect)(struct mosquitto *, void *, int));
    void (*publish_callback_set)(struct mosquitto *mosq,
                                 void (*on_publish)(struct mosquitto *, void *, int));
    void (*message_callback_set)(struct mosquitto *mosq,
                                 void (*on_message)(struct mosquitto *, void *,
                                                    const struct mosquitto_message *));
    int (*connect_async)(struct mosquitto *mosq, const char *host, int port, int keepalive);
    int (*disconnect)(struct mosquitto *mosq);
    int (*publish)(struct mosquitto *mosq, int *mid, const char *topic, int payloadlen,
                   const void *payload, int qos, bool retain);
    int (*subscribe)(struct mosquitto *mosq, int *mid, const char *sub, int qos);
    int (*socket)(struct mosquitto *mosq);
    bool (*want_write)(struct mosquitto *mosq);
    int (*loop_read)(struct mosquitto *mosq, int max_packets);
    int (*loop_write)(struct mosquitto *mosq, int max_packets);
    int (*loop_misc)(struct mosquitto *mosq);
} gw_mqttlib_t;

/* The table, the library loaded on the first call (later calls return the
 * same table, or try again after a failure). NULL with `err` set ("mqtt:
 * cannot load ...: what, where, and what to do") if the library or one of
 * its functions is missing. */
const gw_mqttlib_t *gw_mqttlib_load(char *err, size_t errlen);

#endif
