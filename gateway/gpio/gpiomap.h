/* SPDX-License-Identifier: MIT */
/*
 * GPIO lines bound to robot fields, from the [gpio NAME] sections:
 * outputs follow a bit of the robot's data (safe value while the link is
 * down or a fault holds), inputs drive an O->T bit (debounced).
 *
 * An output follows its bit only while its robot's link is up, no fault
 * is latched for the robot, and the bit's assembly has been received
 * since the link (re)connected: until then the image still holds data
 * from before a loss, and the output stays at its safe value rather than
 * replay it.
 *
 * Every line is its own request, so a configuration reload keeps the lines
 * it does not change (no glitch) and re-requests only the others.
 */
#ifndef DRGATE_GW_GPIOMAP_H
#define DRGATE_GW_GPIOMAP_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/config.h"
#include "core/robot.h"

typedef struct gw_gpiomap gw_gpiomap_t;

typedef struct {
    /* Inputs changed O->T images of `robot` (bit per assembly). */
    void (*on_input)(void *user, unsigned robot, unsigned dirty);
    void *user;
} gw_gpiomap_hooks_t;

/* Open the chips and request every configured line (outputs at their safe
 * value). With no [gpio] sections this succeeds and does nothing. NULL on
 * error, with "gpio NAME: reason" in err. */
gw_gpiomap_t *gw_gpiomap_new(const gw_config_t *cfg, gw_robot_t *robots, int epfd,
                             const gw_gpiomap_hooks_t *hooks, char *err, size_t errlen);

typedef enum {
    GW_GPIOMAP_OK = 0,  /* *out is the new map; old is gone */
    GW_GPIOMAP_REFUSED, /* old is unchanged and still in use; err says why */
    GW_GPIOMAP_BROKEN   /* refused, and lines of old that had to be released
                           could not be requested again: old is freed too
                           (err says which); the daemon cannot go on */
} gw_gpiomap_reload_t;

/* SIGHUP: a map for cfg that takes over from old. A line whose chip,
 * offset and request settings (direction, active_low, bias, debounce,
 * safe_value) are unchanged keeps its request and its level; the others
 * of old are released (safe values) and the new ones requested. The
 * robots' states (link up, fault, data received) carry over by robot
 * name: call gw_gpiomap_fault() and gw_gpiomap_link() for every robot
 * afterwards, the link first. */
gw_gpiomap_reload_t gw_gpiomap_reload(gw_gpiomap_t *old, const gw_config_t *cfg,
                                      gw_robot_t *robots, int epfd,
                                      const gw_gpiomap_hooks_t *hooks, gw_gpiomap_t **out,
                                      char *err, size_t errlen);

/* Safe values, then release the lines. NULL is fine. */
void gw_gpiomap_free(gw_gpiomap_t *m);

/* The robot's link is up or down. Down: its outputs go to their safe
 * values and stay there. Up: they follow their bits once fresh data has
 * arrived (see above). */
void gw_gpiomap_link(gw_gpiomap_t *m, unsigned robot, bool up);
/* New data of assembly a for `robot`: outputs following it follow. */
void gw_gpiomap_data(gw_gpiomap_t *m, unsigned robot, dr_asm_t a);
/* A fault latched for `robot` (single-writer watchdog expired): its
 * outputs at their safe values until it is cleared (false). */
void gw_gpiomap_fault(gw_gpiomap_t *m, unsigned robot, bool fault);
/* Every output to its safe value for good (shutdown). */
void gw_gpiomap_safe_all(gw_gpiomap_t *m);

/* Debounce deadlines and the slow input resync. */
void gw_gpiomap_tick(gw_gpiomap_t *m, uint64_t now_us);
uint64_t gw_gpiomap_next_deadline(const gw_gpiomap_t *m);
unsigned gw_gpiomap_count(const gw_gpiomap_t *m);

/* The lines as the console shows them: level is what the gateway holds
 * (an output: the value last written; an input: the debounced value in
 * its O->T bit), -1 unknown (an output whose last write failed). */
typedef struct {
    const gw_gpio_config_t *cfg; /* name, dir, robot, field, active_low */
    const char *chip;            /* the kernel's name: gpiochipN */
    unsigned offset;
    int level;
    bool requested;              /* false: the line was lost (chip gone) */
} gw_gpiomap_line_info_t;
void gw_gpiomap_each_line(const gw_gpiomap_t *m,
                          void (*fn)(void *user, const gw_gpiomap_line_info_t *l), void *user);

#endif
