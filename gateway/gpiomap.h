/* SPDX-License-Identifier: MIT */
/*
 * GPIO lines bound to robot fields, from the [gpio NAME] sections:
 * outputs follow a bit of the robot's data (safe value while the link is
 * down or a fault holds), inputs drive an O->T bit (debounced).
 */
#ifndef DRGATE_GW_GPIOMAP_H
#define DRGATE_GW_GPIOMAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "config.h"
#include "regmap.h"

typedef struct gw_gpiomap gw_gpiomap_t;

typedef struct {
    /* Inputs changed O->T images of `robot` (bit per assembly). */
    void (*on_input)(void *user, unsigned robot, unsigned dirty);
    void *user;
} gw_gpiomap_hooks_t;

/* Open the chips and request every configured line (outputs at their safe
 * value). With no [gpio] sections this succeeds and does nothing. NULL on
 * error, with "gpio NAME: chip/line: reason" in err. */
gw_gpiomap_t *gw_gpiomap_new(const gw_config_t *cfg, gw_unit_t *units, int epfd,
                             const gw_gpiomap_hooks_t *hooks, char *err, size_t errlen);
/* Safe values, then release the lines. NULL is fine. */
void gw_gpiomap_free(gw_gpiomap_t *m);

/* The robot's link is up (outputs follow their fields) or down (outputs
 * go to their safe values and stay there). */
void gw_gpiomap_link(gw_gpiomap_t *m, unsigned robot, bool up);
/* New data for `robot`: outputs follow. */
void gw_gpiomap_follow(gw_gpiomap_t *m, unsigned robot);
/* Every output to its safe value (fault, shutdown). */
void gw_gpiomap_safe_all(gw_gpiomap_t *m);

/* Debounce deadlines and the slow input resync. */
void gw_gpiomap_tick(gw_gpiomap_t *m, uint64_t now_us);
uint64_t gw_gpiomap_next_deadline(const gw_gpiomap_t *m);
unsigned gw_gpiomap_count(const gw_gpiomap_t *m);

#endif
