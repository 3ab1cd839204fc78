/* SPDX-License-Identifier: MIT */
/*
 * The GPIO side's configuration (config_gpio.c reads it): [gpio NAME],
 * one line each.
 */
#ifndef DRGATE_GW_GPIO_CONFIG_H
#define DRGATE_GW_GPIO_CONFIG_H

#include "core/config_types.h"

typedef enum { GW_GPIO_OUTPUT = 0, GW_GPIO_INPUT } gw_gpio_dir_t;
typedef enum { GW_BIAS_AS_IS = 0, GW_BIAS_DISABLE, GW_BIAS_PULL_UP, GW_BIAS_PULL_DOWN } gw_gpio_bias_t;

typedef struct {
    char name[GW_NAME_MAX];
    char chip[64];            /* "gpiochip0", "/dev/gpiochip0" or a label */
    int offset;               /* -1 when given by line name */
    char line_name[64];
    gw_gpio_dir_t dir;
    char robot[GW_NAME_MAX];  /* robot it belongs to: always filled in by
                                 gw_config_load (the only robot if omitted) */
    unsigned robot_index;     /* that robot's index in gw_config_t.robot[] */
    dr_ref_t field;           /* output: follows this bit; input: drives this O->T bit */
    bool active_low;
    gw_gpio_bias_t bias;
    unsigned debounce_ms;     /* inputs only */
    bool safe_value;          /* outputs: value on link loss, fault and exit */
    unsigned line;
} gw_gpio_config_t;

/* The side's member of gw_config_t (gateway/sides.h): the [gpio NAME]
 * sections. */
typedef struct {
    unsigned count;
    gw_gpio_config_t line[GW_MAX_GPIO];
} gw_gpio_side_config_t;

/* The side's member of a robot's configuration (gw_robot_config_t.side,
 * gateway/sides.h): it has no keys of [robot NAME] (C has no empty
 * struct). */
typedef struct {
    char none;
} gw_gpio_robot_config_t;

#endif /* DRGATE_GW_GPIO_CONFIG_H */
