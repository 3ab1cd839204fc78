/* SPDX-License-Identifier: MIT */
/*
 * A fake GPIO backend (gateway/gpio/gpio_internal.h) for unit tests of
 * gateway/gpio/gpio_common.c without a kernel: two chips, /dev/gpiochip0
 * "fake-A" with 8 lines named fake-A-0..7 and /dev/gpiochip1 "fake-B"
 * with 4 unnamed lines. Tests poke the state below.
 */
#ifndef DRGATE_TESTS_GPIO_FAKE_H
#define DRGATE_TESTS_GPIO_FAKE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "gpio/gpio_internal.h"

#define FAKE_LINES 8
#define FAKE_LOG   64
#define FAKE_QUEUE 64

typedef struct {
    unsigned int offset;
    int value;
} fake_write_t;

typedef struct {
    /* Line state of chip 0 (logical values). */
    int value[FAKE_LINES];
    bool requested[FAKE_LINES];
    char consumer[FAKE_LINES][32];
    bool busy[FAKE_LINES];     /* held by someone else ("other") */
    int set_errno[FAKE_LINES]; /* make writes to this line fail */
    int get_errno[FAKE_LINES]; /* make reads of this line fail */
    bool whole_request_fails;  /* like v2: cannot tell which line */
    /* Every write, including a request's initial values. */
    fake_write_t log[FAKE_LOG];
    size_t nlog;
    size_t releases;
    size_t open_chips;
    /* Pending edge events of chip 0. */
    gw_gpio_be_event_t queue[FAKE_QUEUE];
    unsigned int queue_offset[FAKE_QUEUE];
    size_t nqueue;
} fake_state_t;

extern fake_state_t fake;

void fake_reset(void);
/* An edge on line offset of chip 0 to value at ts (also sets the level). */
void fake_edge(unsigned int offset, int value, uint64_t ts_ns);

#endif /* DRGATE_TESTS_GPIO_FAKE_H */
