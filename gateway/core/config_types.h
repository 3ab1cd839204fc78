/* SPDX-License-Identifier: MIT */
/*
 * What every section's struct is made of (config.h): the daemon's limits,
 * names, allow lists. The sides' configuration headers (config_<side>.h)
 * include this one, not config.h, which includes them (through
 * gateway/sides.h) to lay out gw_config_t.
 */
#ifndef DRGATE_GW_CONFIG_TYPES_H
#define DRGATE_GW_CONFIG_TYPES_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

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

typedef struct {
    uint32_t net;      /* IPv4 network, host order */
    uint32_t mask;     /* prefix as mask */
    bool read_write;   /* false: read-only */
} gw_allow_t;

#endif /* DRGATE_GW_CONFIG_TYPES_H */
