/* SPDX-License-Identifier: MIT */
/* GPIO lines bound to robot fields: see gpiomap.h. */
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>

#include "gpio.h"
#include "gpiomap.h"
#include "log.h"
#include "loop.h"

#define MAX_CHIPS 8
#define RESYNC_US 1000000u

typedef struct {
    const gw_gpio_config_t *cfg;
    unsigned robot;
    unsigned chip;
    unsigned offset;
    int last; /* outputs: last value written; -1 unknown */
} line_t;

typedef struct {
    gw_gpio_chip_t *chip;
    gw_gpio_request_t *req;
    char spec[64];
    gw_ev_t ev[GW_GPIO_MAX_LINES];
    unsigned nev;
} chip_t;

struct gw_gpiomap {
    gw_config_t cfg; /* own copy: lines point into it */
    gw_unit_t *units;
    int epfd;
    gw_gpiomap_hooks_t hooks;
    chip_t chips[MAX_CHIPS];
    unsigned nchips;
    line_t lines[GW_MAX_GPIO];
    unsigned nlines;
    bool up[GW_MAX_ROBOTS];
    uint64_t next_resync_us;
    uint64_t log_limit_us;
};

static unsigned robot_index(const gw_config_t *cfg, const char *name)
{
    for (unsigned i = 0; i < cfg->robot_count; i++)
        if (name[0] == '\0' || strcmp(cfg->robot[i].name, name) == 0)
            return i;
    return 0; /* the config loader has checked the name */
}

static void on_events(void *obj, uint32_t events);

static bool open_chip(gw_gpiomap_t *m, const char *spec, unsigned *idx, char *err, size_t n)
{
    for (unsigned i = 0; i < m->nchips; i++)
        if (strcmp(m->chips[i].spec, spec) == 0) {
            *idx = i;
            return true;
        }
    if (m->nchips == MAX_CHIPS) {
        snprintf(err, n, "more than %u GPIO chips", MAX_CHIPS);
        return false;
    }
    gw_gpio_error_t e;
    chip_t *c = &m->chips[m->nchips];
    if (gw_gpio_chip_open(spec, &c->chip, &e) != GW_GPIO_OK) {
        snprintf(err, n, "%s", e.msg);
        return false;
    }
    snprintf(c->spec, sizeof c->spec, "%s", spec);
    *idx = m->nchips++;
    return true;
}

/* One request per chip with all of its configured lines. */
static bool request_chip(gw_gpiomap_t *m, unsigned ci, char *err, size_t n)
{
    gw_gpio_line_config_t lc[GW_GPIO_MAX_LINES];
    size_t k = 0;
    memset(lc, 0, sizeof lc);
    for (unsigned i = 0; i < m->nlines && k < GW_GPIO_MAX_LINES; i++) {
        const line_t *l = &m->lines[i];
        if (l->chip != ci)
            continue;
        lc[k].offset = l->offset;
        lc[k].direction = l->cfg->dir == GW_GPIO_OUTPUT ? GW_GPIO_DIR_OUTPUT : GW_GPIO_DIR_INPUT;
        lc[k].active_low = l->cfg->active_low;
        lc[k].bias = (gw_gpio_line_bias_t)l->cfg->bias;
        lc[k].edge = l->cfg->dir == GW_GPIO_INPUT ? GW_GPIO_EDGE_BOTH : GW_GPIO_EDGE_NONE;
        lc[k].debounce_us = l->cfg->debounce_ms * 1000u;
        lc[k].safe_value = l->cfg->safe_value;
        k++;
    }
    gw_gpio_request_config_t rc = {"drgatewayd", lc, k};
    gw_gpio_error_t e;
    chip_t *c = &m->chips[ci];
    if (gw_gpio_chip_request_lines(c->chip, &rc, &c->req, &e) != GW_GPIO_OK) {
        snprintf(err, n, "%s", e.msg);
        return false;
    }
    int fds[GW_GPIO_MAX_LINES];
    size_t nf = gw_gpio_request_fds(c->req, fds, GW_GPIO_MAX_LINES);
    for (size_t i = 0; i < nf && i < GW_GPIO_MAX_LINES; i++) {
        c->ev[i].fn = on_events;
        c->ev[i].obj = m;
        c->ev[i].fd = -1;
        if (!gw_loop_watch(m->epfd, &c->ev[i], fds[i], EPOLLIN)) {
            snprintf(err, n, "epoll: cannot watch GPIO events of %s", c->spec);
            return false;
        }
        c->nev++;
    }
    return true;
}

gw_gpiomap_t *gw_gpiomap_new(const gw_config_t *cfg, gw_unit_t *units, int epfd,
                             const gw_gpiomap_hooks_t *hooks, char *err, size_t errlen)
{
    gw_gpiomap_t *m = calloc(1, sizeof *m);
    if (m == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    m->cfg = *cfg;
    m->units = units;
    m->epfd = epfd;
    m->hooks = *hooks;
    char why[400];
    for (unsigned i = 0; i < m->cfg.gpio_count; i++) {
        const gw_gpio_config_t *g = &m->cfg.gpio[i];
        line_t *l = &m->lines[m->nlines];
        l->cfg = g;
        l->robot = robot_index(&m->cfg, g->robot);
        l->last = -1;
        if (!open_chip(m, g->chip, &l->chip, why, sizeof why))
            goto fail;
        if (g->offset >= 0) {
            l->offset = (unsigned)g->offset;
        } else {
            gw_gpio_error_t e;
            if (gw_gpio_chip_find_line(m->chips[l->chip].chip, g->line_name, &l->offset, &e) != GW_GPIO_OK) {
                snprintf(why, sizeof why, "%s", e.msg);
                goto fail;
            }
        }
        m->nlines++;
        continue;
    fail:
        snprintf(err, errlen, "gpio %s: %s", g->name, why);
        gw_gpiomap_free(m);
        return NULL;
    }
    for (unsigned ci = 0; ci < m->nchips; ci++)
        if (!request_chip(m, ci, why, sizeof why)) {
            snprintf(err, errlen, "gpio chip %s: %s", m->chips[ci].spec, why);
            gw_gpiomap_free(m);
            return NULL;
        }
    if (m->nlines > 0)
        gw_log(GW_LOG_INFO, "gpio: %u line(s) on %u chip(s) through %s", m->nlines, m->nchips,
               gw_gpio_backend());
    return m;
}

void gw_gpiomap_free(gw_gpiomap_t *m)
{
    if (m == NULL)
        return;
    for (unsigned ci = 0; ci < m->nchips; ci++) {
        chip_t *c = &m->chips[ci];
        for (unsigned i = 0; i < c->nev; i++)
            gw_loop_unwatch(m->epfd, &c->ev[i]);
        gw_gpio_error_t e;
        if (c->req != NULL && gw_gpio_request_release(c->req, &e) != GW_GPIO_OK)
            gw_log(GW_LOG_ERROR, "gpio: %s", e.msg);
        gw_gpio_chip_close(c->chip);
    }
    free(m);
}

static void write_line(gw_gpiomap_t *m, line_t *l, int v)
{
    if (l->last == v)
        return;
    gw_gpio_error_t e;
    if (gw_gpio_request_set_value(m->chips[l->chip].req, l->offset, v, &e) != GW_GPIO_OK) {
        gw_log_limited(GW_LOG_ERROR, &m->log_limit_us, "gpio %s: %s", l->cfg->name, e.msg);
        l->last = -1;
        return;
    }
    l->last = v;
}

static void follow_robot(gw_gpiomap_t *m, unsigned robot, bool safe)
{
    for (unsigned i = 0; i < m->nlines; i++) {
        line_t *l = &m->lines[i];
        if (l->cfg->dir != GW_GPIO_OUTPUT || l->robot != robot)
            continue;
        int v = l->cfg->safe_value;
        if (!safe) {
            const dr_field_t *f = l->cfg->field.field;
            dr_value_t val;
            if (dr_field_get(m->units[robot].img[f->assembly], dr_asm_info((dr_asm_t)f->assembly)->size,
                             l->cfg->field, &val) == DR_OK)
                v = val.u != 0;
        }
        write_line(m, l, v);
    }
}

void gw_gpiomap_link(gw_gpiomap_t *m, unsigned robot, bool up)
{
    if (m == NULL || robot >= GW_MAX_ROBOTS)
        return;
    m->up[robot] = up;
    follow_robot(m, robot, !up);
}

void gw_gpiomap_follow(gw_gpiomap_t *m, unsigned robot)
{
    if (m != NULL && robot < GW_MAX_ROBOTS && m->up[robot])
        follow_robot(m, robot, false);
}

void gw_gpiomap_safe_all(gw_gpiomap_t *m)
{
    if (m == NULL)
        return;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        m->up[r] = false;
    for (unsigned ci = 0; ci < m->nchips; ci++) {
        gw_gpio_error_t e;
        if (gw_gpio_set_safe(m->chips[ci].req, &e) != GW_GPIO_OK)
            gw_log(GW_LOG_ERROR, "gpio: %s", e.msg);
    }
    for (unsigned i = 0; i < m->nlines; i++)
        if (m->lines[i].cfg->dir == GW_GPIO_OUTPUT)
            m->lines[i].last = m->lines[i].cfg->safe_value;
}

/* Inputs: the debounced values into their O->T bits. */
static void poll_inputs(gw_gpiomap_t *m, uint64_t now_ns)
{
    unsigned dirty[GW_MAX_ROBOTS] = {0};
    for (unsigned i = 0; i < m->nlines; i++) {
        line_t *l = &m->lines[i];
        if (l->cfg->dir != GW_GPIO_INPUT)
            continue;
        int v;
        bool changed = false;
        gw_gpio_error_t e;
        if (gw_gpio_request_input_value(m->chips[l->chip].req, l->offset, now_ns, &v, &changed, &e) != GW_GPIO_OK) {
            gw_log_limited(GW_LOG_ERROR, &m->log_limit_us, "gpio %s: %s", l->cfg->name, e.msg);
            continue;
        }
        const dr_field_t *f = l->cfg->field.field;
        uint8_t *img = m->units[l->robot].img[f->assembly];
        size_t size = dr_asm_info((dr_asm_t)f->assembly)->size;
        dr_value_t cur, nv = dr_value_uint((uint64_t)v);
        if (dr_field_get(img, size, l->cfg->field, &cur) == DR_OK && cur.u != (uint64_t)v &&
            dr_field_set(img, size, l->cfg->field, &nv, DR_SET_O2T_ONLY) == DR_OK)
            dirty[l->robot] |= 1u << f->assembly;
    }
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        if (dirty[r] != 0 && m->hooks.on_input != NULL)
            m->hooks.on_input(m->hooks.user, r, dirty[r]);
}

static void on_events(void *obj, uint32_t events)
{
    gw_gpiomap_t *m = obj;
    (void)events;
    for (unsigned ci = 0; ci < m->nchips; ci++) {
        gw_gpio_event_t ev[16];
        size_t n = 0;
        gw_gpio_error_t e;
        do {
            if (gw_gpio_request_read_events(m->chips[ci].req, ev, 16, &n, &e) != GW_GPIO_OK) {
                gw_log_limited(GW_LOG_ERROR, &m->log_limit_us, "gpio: %s", e.msg);
                break;
            }
        } while (n == 16);
    }
    poll_inputs(m, gw_gpio_now_ns());
}

void gw_gpiomap_tick(gw_gpiomap_t *m, uint64_t now_us)
{
    if (m == NULL || m->nlines == 0)
        return;
    uint64_t now_ns = now_us * 1000u;
    if (now_us >= m->next_resync_us) {
        m->next_resync_us = now_us + RESYNC_US;
        for (unsigned ci = 0; ci < m->nchips; ci++) {
            gw_gpio_error_t e;
            if (gw_gpio_request_sync_inputs(m->chips[ci].req, now_ns, &e) != GW_GPIO_OK)
                gw_log_limited(GW_LOG_ERROR, &m->log_limit_us, "gpio: %s", e.msg);
        }
    }
    poll_inputs(m, now_ns);
}

uint64_t gw_gpiomap_next_deadline(const gw_gpiomap_t *m)
{
    if (m == NULL || m->nlines == 0)
        return UINT64_MAX;
    uint64_t d = m->next_resync_us;
    for (unsigned ci = 0; ci < m->nchips; ci++) {
        uint64_t ns = gw_gpio_request_next_deadline(m->chips[ci].req);
        if (ns != UINT64_MAX && ns / 1000u + 1u < d)
            d = ns / 1000u + 1u;
    }
    return d;
}

unsigned gw_gpiomap_count(const gw_gpiomap_t *m)
{
    return m == NULL ? 0 : m->nlines;
}
