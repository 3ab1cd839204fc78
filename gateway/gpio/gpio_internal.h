/* SPDX-License-Identifier: MIT */
/*
 * Between gpio_common.c and the one backend linked with it (gpio_v1.c on
 * libgpiod 1.6, gpio_v2.c on libgpiod >= 2.0).
 *
 * The backend only talks to libgpiod; everything else (chip lookup by
 * label, validation, error messages, safe values, debouncing) is common,
 * so both backends behave alike. Backend calls return 0, or -1 with errno
 * set; lines are addressed by their index in the request.
 */
#ifndef DRGATE_GATEWAY_GPIO_INTERNAL_H
#define DRGATE_GATEWAY_GPIO_INTERNAL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "gpio/gpio.h"

struct gw_gpio_be_chip;
struct gw_gpio_be_req;

typedef struct {
    char name[GW_GPIO_NAME_MAX + 1];
    char label[GW_GPIO_NAME_MAX + 1];
    unsigned int num_lines;
} gw_gpio_be_chip_info_t;

typedef struct {
    char name[GW_GPIO_NAME_MAX + 1];     /* "" when unnamed */
    char consumer[GW_GPIO_NAME_MAX + 1]; /* "" when unused or anonymous */
    bool used;
} gw_gpio_be_line_info_t;

typedef struct {
    size_t index;          /* line index in the request */
    bool rising;           /* logical level after the edge is 1 */
    uint64_t timestamp_ns; /* CLOCK_MONOTONIC */
    uint64_t line_seqno;   /* 0: the backend has none, common counts */
} gw_gpio_be_event_t;

/* True when the backend hands debounce to the kernel (v2 uAPI); then the
 * common debouncer runs with period 0. */
extern const bool gw_gpio_be_kernel_debounce;

/* "libgpiod X.Y (vN API)". */
const char *gw_gpio_be_name(void);

int gw_gpio_be_chip_open(const char *path, struct gw_gpio_be_chip **out,
                         gw_gpio_be_chip_info_t *info);
void gw_gpio_be_chip_close(struct gw_gpio_be_chip *chip);
int gw_gpio_be_line_info(struct gw_gpio_be_chip *chip, unsigned int offset,
                         gw_gpio_be_line_info_t *info);
/* ENOENT when no line has that name. */
int gw_gpio_be_find_line(struct gw_gpio_be_chip *chip, const char *name,
                         unsigned int *offset);

/* Requests lines[0..n) (validated already). On failure *failed is the
 * index of the line the kernel refused, or n when it cannot tell. */
int gw_gpio_be_request(struct gw_gpio_be_chip *chip, const char *consumer,
                       const gw_gpio_line_config_t *lines, size_t n,
                       struct gw_gpio_be_req **out, size_t *failed);
void gw_gpio_be_release(struct gw_gpio_be_req *req);
int gw_gpio_be_get(struct gw_gpio_be_req *req, size_t index, int *value);
int gw_gpio_be_set(struct gw_gpio_be_req *req, size_t index, int value);
size_t gw_gpio_be_fds(const struct gw_gpio_be_req *req, int *fds, size_t cap);
/* Never blocks: *n = 0 when nothing is pending. */
int gw_gpio_be_read_events(struct gw_gpio_be_req *req,
                           gw_gpio_be_event_t *events, size_t cap, size_t *n);

#endif /* DRGATE_GATEWAY_GPIO_INTERNAL_H */
