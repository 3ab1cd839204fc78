/* SPDX-License-Identifier: MIT */
/*
 * Software debounce from edge timestamps.
 *
 * libgpiod 1.6 (the v1 uAPI) has no debounce, and hardware debounce is
 * rare anyway, so the gateway filters in software: every edge restarts a
 * quiet timer, and the level after the last edge becomes the stable value
 * once the timer runs out. This needs no polling of the line: the loop
 * arms a timer at gw_gpio_debounce_deadline() and calls update() then.
 * Pure arithmetic on the caller's timestamps, so tests drive it with
 * made-up times.
 */
#include "gpio/gpio.h"

#include <stdint.h>

static uint64_t add_sat(uint64_t a, uint64_t b)
{
    /* A huge period must mean "far future", not wrap into the past. */
    return a > UINT64_MAX - b ? UINT64_MAX : a + b;
}

void gw_gpio_debounce_init(gw_gpio_debounce_t *d, uint64_t period_ns, int value,
                           uint64_t now_ns)
{
    d->period_ns = period_ns;
    d->last_edge_ns = now_ns;
    d->stable = value != 0;
    d->raw = d->stable;
}

void gw_gpio_debounce_feed(gw_gpio_debounce_t *d, int value, uint64_t ts_ns)
{
    /* Timestamps from two sources (a kernel edge and a resync read) may
     * interleave slightly out of order; never move the timer backwards,
     * or an older edge could settle a newer level early. */
    if (ts_ns > d->last_edge_ns)
        d->last_edge_ns = ts_ns;
    /* An edge to the level we already had still restarts the timer: it
     * means an opposite edge was lost, i.e. the line is still bouncing. */
    d->raw = value != 0;
}

uint64_t gw_gpio_debounce_deadline(const gw_gpio_debounce_t *d)
{
    if (d->raw == d->stable)
        return UINT64_MAX;
    return add_sat(d->last_edge_ns, d->period_ns);
}

bool gw_gpio_debounce_update(gw_gpio_debounce_t *d, uint64_t now_ns)
{
    if (d->raw == d->stable)
        return false;
    /* Period 0 passes every edge, even one stamped after our "now". */
    if (d->period_ns != 0 && now_ns < gw_gpio_debounce_deadline(d))
        return false;
    d->stable = d->raw;
    return true;
}
