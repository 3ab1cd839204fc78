/* SPDX-License-Identifier: MIT */
/* The GPIO lines (gpiomap.c) as a northbound side (north.h). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "gpio/gpiomap.h"
#include "core/north.h"

typedef struct {
    const gw_north_env_t *env;
    gw_gpiomap_t *map;
} gpio_t;

static void on_input(void *user, unsigned robot, unsigned dirty)
{
    const gpio_t *t = user;
    if (robot < t->env->cfg->robot_count)
        t->env->outputs_changed(t->env->user, robot, dirty);
}

static void *gpio_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    gpio_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    t->env = env;
    gw_gpiomap_hooks_t gh = {on_input, t};
    t->map = gw_gpiomap_new(env->cfg, env->robots, env->epfd, &gh, err, errlen);
    if (t->map == NULL) {
        free(t);
        return NULL;
    }
    return t;
}

/* Lines that cannot be had refuse the whole reload. The unchanged lines
 * keep their requests; the map carries the robots' states by name (they
 * are set again at commit). Cannot be undone: last in the list. */
static gw_north_reload_t gpio_prepare(void *self, const gw_config_t *next,
                                      const gw_north_env_t *env, void **out, char *err,
                                      size_t errlen)
{
    gpio_t *t = self;
    gw_gpiomap_hooks_t gh = {on_input, t};
    gw_gpiomap_t *map = NULL;
    switch (gw_gpiomap_reload(t->map, next, env->robots, env->epfd, &gh, &map, err, errlen)) {
    case GW_GPIOMAP_OK:
        /* Installed at commit, once the old links are gone: closing one
         * reports it down under its old index, which the new map must
         * not hear. */
        t->map = NULL;
        *out = map;
        return GW_NORTH_OK;
    case GW_GPIOMAP_REFUSED: return GW_NORTH_REFUSED;
    case GW_GPIOMAP_BROKEN:
    default: t->map = NULL; return GW_NORTH_BROKEN;
    }
}

static void gpio_abort(void *self, void *out)
{
    gpio_t *t = self;
    if (out != NULL && t->map == NULL)
        t->map = out; /* not reached: GPIO is asked last */
}

static void *gpio_commit(void *self, void *out, const gw_north_env_t *env)
{
    gpio_t *t = self;
    t->map = out;
    /* The link first: a robot whose link was replaced (same name, state
     * carried over) goes down before anything looks at its fresh, zeroed
     * image. For the others nothing changes and nothing is written. */
    for (unsigned r = 0; r < env->cfg->robot_count; r++) {
        gw_gpiomap_link(t->map, r, env->link_up(env->user, r));
        gw_gpiomap_fault(t->map, r, env->robots[r].fault);
    }
    return t;
}

static void gpio_tick(void *self, uint64_t now)
{
    gpio_t *t = self;
    gw_gpiomap_tick(t->map, now);
}

static uint64_t gpio_deadline(const void *self)
{
    const gpio_t *t = self;
    return gw_gpiomap_next_deadline(t->map);
}

static void gpio_on_data(void *self, unsigned robot, dr_asm_t a)
{
    gpio_t *t = self;
    gw_gpiomap_data(t->map, robot, a);
}

static void gpio_on_link(void *self, unsigned robot, bool up)
{
    gpio_t *t = self;
    gw_gpiomap_link(t->map, robot, up);
}

static void gpio_on_fault(void *self, unsigned robot, bool latched)
{
    gpio_t *t = self;
    gw_gpiomap_fault(t->map, robot, latched);
}

static void gpio_refresh(void *self)
{
    (void)self;
}

static void gpio_safe(void *self)
{
    gpio_t *t = self;
    gw_gpiomap_safe_all(t->map);
}

/* ---- the console ----------------------------------------------------------------- */

typedef struct {
    gw_json_t *j;
    bool first;
} line_json_t;

static void line_report(void *user, const gw_gpiomap_line_info_t *l)
{
    line_json_t *lj = user;
    gw_json_t *j = lj->j;
    char t[64], path[64];
    gw_json_str(j, lj->first ? "{\"name\":" : ",{\"name\":");
    lj->first = false;
    gw_json_quote(j, l->cfg->name, strlen(l->cfg->name));
    gw_json_str(j, ",\"chip\":");
    gw_json_quote(j, l->chip, strlen(l->chip));
    snprintf(t, sizeof t, ",\"line\":%u,\"line_name\":", l->offset);
    gw_json_str(j, t);
    gw_json_quote(j, l->cfg->line_name, strlen(l->cfg->line_name));
    gw_json_str(j, l->cfg->dir == GW_GPIO_INPUT ? ",\"dir\":\"in\",\"robot\":"
                                                : ",\"dir\":\"out\",\"robot\":");
    gw_json_quote(j, l->cfg->robot, strlen(l->cfg->robot));
    if (dr_ref_path(l->cfg->field, path, sizeof path) != DR_OK)
        path[0] = '\0';
    gw_json_str(j, ",\"field\":");
    gw_json_quote(j, path, strlen(path));
    if (l->level < 0)
        snprintf(t, sizeof t, ",\"level\":null,\"active_low\":%s,\"requested\":%s}",
                 l->cfg->active_low ? "true" : "false", l->requested ? "true" : "false");
    else
        snprintf(t, sizeof t, ",\"level\":%d,\"active_low\":%s,\"requested\":%s}", l->level,
                 l->cfg->active_low ? "true" : "false", l->requested ? "true" : "false");
    gw_json_str(j, t);
}

/* "gpio": {"lines": [{"name", "chip", "line", "line_name", "dir", "robot",
 * "field", "level", "active_low", "requested"}]}; nothing without lines. */
static void gpio_report(const void *self, gw_json_t *j)
{
    const gpio_t *t = self;
    if (t->map == NULL || gw_gpiomap_count(t->map) == 0)
        return;
    line_json_t lj = {j, true};
    gw_json_str(j, "\"gpio\":{\"lines\":[");
    gw_gpiomap_each_line(t->map, line_report, &lj);
    gw_json_str(j, "]}");
}

static void line_metric(void *user, const gw_gpiomap_line_info_t *l)
{
    char off[16];
    snprintf(off, sizeof off, "%u", l->offset);
    gw_prom_label_t lb[4] = {{"line", l->cfg->name},
                             {"chip", l->chip},
                             {"offset", off},
                             {"direction", l->cfg->dir == GW_GPIO_INPUT ? "in" : "out"}};
    /* an unknown level (a failed write) is NaN: a gauge without a value */
    gw_prom_sample(user, "drgate_gpio_level", lb, 4, l->level < 0 ? NAN : (double)l->level);
}

static void gpio_metrics(const void *self, gw_prom_t *m)
{
    const gpio_t *t = self;
    if (t->map == NULL || gw_gpiomap_count(t->map) == 0)
        return;
    gw_prom_family(m, "drgate_gpio_level", GW_PROM_GAUGE,
                   "A GPIO line's logical level (outputs: last written; inputs: debounced)");
    gw_gpiomap_each_line(t->map, line_metric, m);
}

static void gpio_free(void *self)
{
    gpio_t *t = self;
    if (t == NULL)
        return;
    gw_gpiomap_free(t->map);
    free(t);
}

const gw_north_ops_t gw_north_gpio = {
    .name = "gpio",
    .create = gpio_create,
    .prepare = gpio_prepare,
    .abort = gpio_abort,
    .commit = gpio_commit,
    .tick = gpio_tick,
    .deadline = gpio_deadline,
    .on_data = gpio_on_data,
    .on_link = gpio_on_link,
    .on_fault = gpio_on_fault,
    .refresh = gpio_refresh,
    .safe = gpio_safe,
    .free = gpio_free,
    .report = gpio_report,
    .metrics = gpio_metrics,
};
