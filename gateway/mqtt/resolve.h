/* SPDX-License-Identifier: MIT */
/*
 * A broker's host name looked up without stopping the daemon's loop
 * (resolve.c): glibc's getaddrinfo_a does the lookup in a thread of its
 * own, the MQTT side asks for the answer from its tick. An IPv4 address
 * needs no lookup and is answered at once.
 */
#ifndef GW_MQTT_RESOLVE_H
#define GW_MQTT_RESOLVE_H

#include <stddef.h>

typedef struct gw_mqtt_lookup gw_mqtt_lookup_t;

/* Start looking up `host`; NULL with err if it cannot be started (too
 * many lookups still running). */
gw_mqtt_lookup_t *gw_mqtt_lookup_start(const char *host, char *err, size_t errlen);

/* The answer: 1 with the first address in addr (numeric text), 0 while
 * the lookup runs, -1 with err (the resolver's reason). After 1 or -1
 * the lookup is over (l is freed). */
int gw_mqtt_lookup_poll(gw_mqtt_lookup_t *l, char *addr, size_t addrlen, char *err,
                        size_t errlen);

/* Give up on a lookup (NULL: nothing): it may still run, its slot is
 * taken back once it ends. */
void gw_mqtt_lookup_end(gw_mqtt_lookup_t *l);

#endif
