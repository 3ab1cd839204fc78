/* SPDX-License-Identifier: MIT */
/* GPIO lines bound to robot fields: see gpiomap.h. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>

#include "common/ev.h"
#include "gpio/gpio.h"
#include "gpio/gpiomap.h"
#include "core/write.h"
#include "core/log.h"

#define MAX_CHIPS 8
#define MAX_FDS 4 /* descriptors of a one-line request (1 on both backends) */
#define RESYNC_US 1000000u

/* One open chip, however the sections spell it (number, path, label). */
typedef struct {
    gw_gpiomap_t *owner;
    gw_gpio_chip_t *chip;
    char name[GW_GPIO_NAME_MAX + 1]; /* the kernel's: gpiochipN */
} chip_t;

/* One configured line and its own request. Allocated on its own: the
 * epoll entries point at it, and a reload hands it to the next map. */
typedef struct {
    gw_gpiomap_t *owner;
    const gw_gpio_config_t *cfg; /* in owner->cfg */
    unsigned robot;
    chip_t *chip;
    unsigned offset;
    gw_gpio_line_config_t lc; /* as requested */
    gw_gpio_request_t *req;
    ev_t ev[MAX_FDS];
    unsigned nev;
    int last; /* outputs: the value written last; -1 unknown */
} line_t;

typedef struct {
    char name[GW_NAME_MAX];
    bool up;
    bool fault;
    unsigned fresh; /* T->O assemblies received since the link came up */
} robot_t;

struct gw_gpiomap {
    gw_config_t cfg; /* own copy: lines point into it */
    gw_robot_t *robots;
    int epfd;
    gw_gpiomap_hooks_t hooks;
    chip_t *chips[MAX_CHIPS];
    unsigned nchips;
    line_t *lines[GW_MAX_GPIO];
    unsigned nlines;
    robot_t robot[GW_MAX_ROBOTS];
    uint64_t next_resync_us;
    gw_log_limit_t log_limit;
};

static void on_events(void *obj, uint32_t events);

/* ---- requests --------------------------------------------------------------- */

static void line_release(line_t *l, int epfd)
{
    for (unsigned i = 0; i < l->nev; i++)
        ev_unwatch(epfd, &l->ev[i]);
    l->nev = 0;
    gw_gpio_error_t e;
    if (l->req != NULL && gw_gpio_request_release(l->req, &e) != GW_GPIO_OK)
        gw_log(GW_LOG_ERROR, "gpio %s: %s", l->cfg->name, e.msg);
    l->req = NULL;
}

/* Request the line (an output starts at its safe value) and watch its
 * edge events. */
static bool line_request(line_t *l, int epfd, char *err, size_t n)
{
    gw_gpio_request_config_t rc = {"drgatewayd", &l->lc, 1};
    gw_gpio_error_t e;
    if (gw_gpio_chip_request_lines(l->chip->chip, &rc, &l->req, &e) != GW_GPIO_OK) {
        l->req = NULL;
        snprintf(err, n, "%s", e.msg);
        return false;
    }
    l->last = l->lc.direction == GW_GPIO_DIR_OUTPUT ? l->lc.safe_value : -1;
    if (l->lc.edge != GW_GPIO_EDGE_BOTH)
        return true;
    int fds[MAX_FDS];
    size_t nf = gw_gpio_request_fds(l->req, fds, MAX_FDS);
    if (nf > MAX_FDS) {
        snprintf(err, n, "%s line %u: %lu event descriptors for one line", l->chip->name,
                 l->offset, (unsigned long)nf);
        line_release(l, epfd);
        return false;
    }
    for (size_t i = 0; i < nf; i++) {
        l->ev[i].fn = on_events;
        l->ev[i].obj = l;
        l->ev[i].fd = -1;
        if (!ev_watch(epfd, &l->ev[i], fds[i], EPOLLIN)) {
            snprintf(err, n, "cannot watch the edge events of %s line %u: %s", l->chip->name,
                     l->offset, strerror(errno));
            line_release(l, epfd);
            return false;
        }
        l->nev++;
    }
    return true;
}

static bool same_request(const gw_gpio_line_config_t *a, const gw_gpio_line_config_t *b)
{
    return a->offset == b->offset && a->direction == b->direction &&
           a->active_low == b->active_low && a->bias == b->bias && a->edge == b->edge &&
           a->debounce_us == b->debounce_us && (a->safe_value != 0) == (b->safe_value != 0);
}

/* ---- chips and lines ------------------------------------------------------------ */

static chip_t *chip_named(chip_t *const *chips, unsigned n, const char *name)
{
    for (unsigned i = 0; i < n; i++)
        if (strcmp(chips[i]->name, name) == 0)
            return chips[i];
    return NULL;
}

/* The chip `spec` names: one handle per kernel chip in a map, however it
 * is spelled, shared with `old` (until the reload commits) when old has
 * that chip open. */
static chip_t *get_chip(gw_gpiomap_t *m, const gw_gpiomap_t *old, const char *spec, char *err,
                        size_t n)
{
    gw_gpio_chip_t *h;
    gw_gpio_error_t e;
    if (gw_gpio_chip_open(spec, &h, &e) != GW_GPIO_OK) {
        snprintf(err, n, "%s", e.msg);
        return NULL;
    }
    chip_t *c = chip_named(m->chips, m->nchips, gw_gpio_chip_name(h));
    if (c == NULL && old != NULL)
        c = chip_named(old->chips, old->nchips, gw_gpio_chip_name(h));
    if (c == NULL) {
        c = calloc(1, sizeof *c);
        if (c == NULL) {
            gw_gpio_chip_close(h);
            snprintf(err, n, "out of memory");
            return NULL;
        }
        c->owner = m;
        c->chip = h;
        snprintf(c->name, sizeof c->name, "%s", gw_gpio_chip_name(h));
    } else {
        gw_gpio_chip_close(h);
    }
    if (chip_named(m->chips, m->nchips, c->name) == NULL) {
        if (m->nchips == MAX_CHIPS) {
            if (c->owner == m) {
                gw_gpio_chip_close(c->chip);
                free(c);
            }
            snprintf(err, n, "more than %u GPIO chips", (unsigned)MAX_CHIPS);
            return NULL;
        }
        m->chips[m->nchips++] = c;
    }
    return c;
}

/* The map for cfg with its lines resolved (chips open, offsets found) but
 * nothing requested. NULL with err on error. */
static gw_gpiomap_t *resolve(const gw_config_t *cfg, gw_robot_t *robots, int epfd,
                             const gw_gpiomap_hooks_t *hooks, const gw_gpiomap_t *old,
                             char *err, size_t errlen);

/* Frees what m owns; lines shared with another map must be gone from m. */
static void discard(gw_gpiomap_t *m)
{
    for (unsigned i = 0; i < m->nlines; i++) {
        if (m->lines[i] == NULL)
            continue;
        line_release(m->lines[i], m->epfd);
        free(m->lines[i]);
    }
    for (unsigned i = 0; i < m->nchips; i++)
        if (m->chips[i]->owner == m) {
            gw_gpio_chip_close(m->chips[i]->chip);
            free(m->chips[i]);
        }
    free(m);
}

static gw_gpiomap_t *resolve(const gw_config_t *cfg, gw_robot_t *robots, int epfd,
                             const gw_gpiomap_hooks_t *hooks, const gw_gpiomap_t *old,
                             char *err, size_t errlen)
{
    gw_gpiomap_t *m = calloc(1, sizeof *m);
    if (m == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    m->cfg = *cfg;
    m->robots = robots;
    m->epfd = epfd;
    m->hooks = *hooks;
    for (unsigned r = 0; r < m->cfg.robot_count && r < GW_MAX_ROBOTS; r++)
        snprintf(m->robot[r].name, sizeof m->robot[r].name, "%s", m->cfg.robot[r].name);
    char why[400];
    for (unsigned i = 0; i < m->cfg.side.gpio.count; i++) {
        const gw_gpio_config_t *g = &m->cfg.side.gpio.line[i];
        line_t *l = calloc(1, sizeof *l);
        if (l == NULL) {
            snprintf(why, sizeof why, "out of memory");
            goto fail;
        }
        m->lines[m->nlines++] = l;
        l->owner = m;
        l->cfg = g;
        l->robot = g->robot_index;
        l->last = -1;
        l->chip = get_chip(m, old, g->chip, why, sizeof why);
        if (l->chip == NULL)
            goto fail;
        if (g->offset >= 0) {
            l->offset = (unsigned)g->offset;
        } else {
            gw_gpio_error_t e;
            if (gw_gpio_chip_find_line(l->chip->chip, g->line_name, &l->offset, &e) != GW_GPIO_OK) {
                snprintf(why, sizeof why, "%s", e.msg);
                goto fail;
            }
        }
        /* The loader compares spellings only: an offset and a line name,
         * or a chip number and a label, can still be one line. */
        for (unsigned j = 0; j + 1 < m->nlines; j++)
            if (m->lines[j]->chip == l->chip && m->lines[j]->offset == l->offset) {
                snprintf(why, sizeof why, "line %u of %s is already used by gpio '%s'", l->offset,
                         l->chip->name, m->lines[j]->cfg->name);
                goto fail;
            }
        l->lc.offset = l->offset;
        l->lc.direction = g->dir == GW_GPIO_OUTPUT ? GW_GPIO_DIR_OUTPUT : GW_GPIO_DIR_INPUT;
        l->lc.active_low = g->active_low;
        switch (g->bias) {
        case GW_BIAS_DISABLE: l->lc.bias = GW_GPIO_BIAS_DISABLE; break;
        case GW_BIAS_PULL_UP: l->lc.bias = GW_GPIO_BIAS_PULL_UP; break;
        case GW_BIAS_PULL_DOWN: l->lc.bias = GW_GPIO_BIAS_PULL_DOWN; break;
        default: l->lc.bias = GW_GPIO_BIAS_AS_IS; break;
        }
        if (g->dir == GW_GPIO_INPUT) {
            l->lc.edge = GW_GPIO_EDGE_BOTH;
            l->lc.debounce_us = g->debounce_ms * 1000u;
        } else {
            l->lc.safe_value = g->safe_value;
        }
        continue;
    fail:
        snprintf(err, errlen, "gpio %s: %s", g->name, why);
        discard(m);
        return NULL;
    }
    return m;
}

gw_gpiomap_t *gw_gpiomap_new(const gw_config_t *cfg, gw_robot_t *robots, int epfd,
                             const gw_gpiomap_hooks_t *hooks, char *err, size_t errlen)
{
    gw_gpiomap_t *m = resolve(cfg, robots, epfd, hooks, NULL, err, errlen);
    if (m == NULL)
        return NULL;
    char why[400];
    for (unsigned i = 0; i < m->nlines; i++)
        if (!line_request(m->lines[i], epfd, why, sizeof why)) {
            snprintf(err, errlen, "gpio %s: %s", m->lines[i]->cfg->name, why);
            discard(m);
            return NULL;
        }
    if (m->nlines > 0)
        gw_log(GW_LOG_INFO, "gpio: %u line(s) on %u chip(s) through %s", m->nlines, m->nchips,
               gw_gpio_backend());
    return m;
}

/* ---- reload ----------------------------------------------------------------- */

/* old's line on the same chip and offset as l, or NULL. */
static line_t *old_line(const gw_gpiomap_t *old, const line_t *l, unsigned *idx)
{
    for (unsigned i = 0; i < old->nlines; i++)
        if (old->lines[i] != NULL && old->lines[i]->chip == l->chip &&
            old->lines[i]->offset == l->offset) {
            *idx = i;
            return old->lines[i];
        }
    return NULL;
}

gw_gpiomap_reload_t gw_gpiomap_reload(gw_gpiomap_t *old, const gw_config_t *cfg,
                                      gw_robot_t *robots, int epfd,
                                      const gw_gpiomap_hooks_t *hooks, gw_gpiomap_t **out,
                                      char *err, size_t errlen)
{
    *out = NULL;
    if (old == NULL) {
        *out = gw_gpiomap_new(cfg, robots, epfd, hooks, err, errlen);
        return *out != NULL ? GW_GPIOMAP_OK : GW_GPIOMAP_REFUSED;
    }
    gw_gpiomap_t *m = resolve(cfg, robots, epfd, hooks, old, err, errlen);
    if (m == NULL)
        return GW_GPIOMAP_REFUSED;
    /* Which of old's lines are kept as they are, and which are in the
     * way of a new request and must go first. */
    line_t *keep[GW_MAX_GPIO] = {NULL};
    bool kept[GW_MAX_GPIO] = {false}, released[GW_MAX_GPIO] = {false};
    for (unsigned i = 0; i < m->nlines; i++) {
        unsigned o;
        line_t *ol = old_line(old, m->lines[i], &o);
        if (ol != NULL && ol->req != NULL && same_request(&ol->lc, &m->lines[i]->lc)) {
            keep[i] = ol;
            kept[o] = true;
        }
    }
    for (unsigned i = 0; i < m->nlines; i++) {
        unsigned o;
        line_t *ol = old_line(old, m->lines[i], &o);
        if (keep[i] == NULL && ol != NULL && !kept[o] && ol->req != NULL) {
            line_release(ol, epfd);
            released[o] = true;
        }
    }
    char why[400];
    for (unsigned i = 0; i < m->nlines; i++) {
        if (keep[i] != NULL || line_request(m->lines[i], epfd, why, sizeof why))
            continue;
        /* Refused: back to old as it was. */
        snprintf(err, errlen, "gpio %s: %s", m->lines[i]->cfg->name, why);
        for (unsigned j = 0; j < i; j++)
            if (keep[j] == NULL)
                line_release(m->lines[j], epfd);
        gw_gpiomap_reload_t st = GW_GPIOMAP_REFUSED;
        for (unsigned o = 0; o < old->nlines; o++) {
            char again[400];
            if (released[o] && !line_request(old->lines[o], epfd, again, sizeof again)) {
                size_t used = strlen(err);
                snprintf(err + used, errlen - used,
                         "; and gpio %s could not be requested again: %s",
                         old->lines[o]->cfg->name, again);
                st = GW_GPIOMAP_BROKEN;
            }
        }
        discard(m);
        if (st == GW_GPIOMAP_BROKEN)
            gw_gpiomap_free(old);
        return st;
    }
    /* Commit: kept lines move to m with their request and level. */
    for (unsigned i = 0; i < m->nlines; i++) {
        if (keep[i] == NULL)
            continue;
        line_t *nl = m->lines[i], *ol = keep[i];
        ol->owner = m;
        ol->cfg = nl->cfg;
        ol->robot = nl->robot;
        m->lines[i] = ol;
        free(nl);
        for (unsigned o = 0; o < old->nlines; o++)
            if (old->lines[o] == ol)
                old->lines[o] = NULL;
    }
    for (unsigned c = 0; c < m->nchips; c++)
        m->chips[c]->owner = m;
    /* The robots' states carry over by name. */
    for (unsigned r = 0; r < m->cfg.robot_count && r < GW_MAX_ROBOTS; r++)
        for (unsigned o = 0; o < old->cfg.robot_count && o < GW_MAX_ROBOTS; o++)
            if (strcmp(old->robot[o].name, m->robot[r].name) == 0)
                m->robot[r] = old->robot[o];
    m->log_limit = old->log_limit;
    unsigned nkept = 0;
    for (unsigned i = 0; i < m->nlines; i++)
        nkept += keep[i] != NULL;
    /* What is left of old (dropped lines, chips no longer used) goes. */
    discard(old);
    gw_log(GW_LOG_INFO, "gpio: %u line(s) on %u chip(s); %u kept as they were, %u requested anew",
           m->nlines, m->nchips, nkept, m->nlines - nkept);
    *out = m;
    return GW_GPIOMAP_OK;
}

void gw_gpiomap_free(gw_gpiomap_t *m)
{
    if (m != NULL)
        discard(m);
}

/* ---- outputs ---------------------------------------------------------------- */

static void write_line(gw_gpiomap_t *m, line_t *l, int v)
{
    if (l->last == v || l->req == NULL)
        return;
    gw_gpio_error_t e;
    if (gw_gpio_request_set_value(l->req, l->offset, v, &e) != GW_GPIO_OK) {
        gw_log_limited(GW_LOG_ERROR, &m->log_limit, "gpio %s: %s", l->cfg->name, e.msg);
        l->last = -1;
        return;
    }
    l->last = v;
}

/* What an output should show now. */
static int wanted(const gw_gpiomap_t *m, const line_t *l)
{
    const robot_t *r = &m->robot[l->robot];
    const dr_field_t *f = l->cfg->field.field;
    int safe = l->cfg->safe_value ? 1 : 0;
    if (!r->up || r->fault || !(r->fresh & (1u << f->assembly)))
        return safe;
    dr_value_t v;
    if (gw_robot_get(&m->robots[l->robot], l->cfg->field, &v) != DR_OK)
        return safe;
    return v.u != 0;
}

/* The outputs of `robot` (only those following assembly a, if a >= 0). */
static void update_outputs(gw_gpiomap_t *m, unsigned robot, int a)
{
    for (unsigned i = 0; i < m->nlines; i++) {
        line_t *l = m->lines[i];
        if (l->cfg->dir != GW_GPIO_OUTPUT || l->robot != robot ||
            (a >= 0 && (unsigned)l->cfg->field.field->assembly != (unsigned)a))
            continue;
        write_line(m, l, wanted(m, l));
    }
}

void gw_gpiomap_link(gw_gpiomap_t *m, unsigned robot, bool up)
{
    if (m == NULL || robot >= GW_MAX_ROBOTS)
        return;
    robot_t *r = &m->robot[robot];
    /* The image holds data from before the loss: only what arrives after
     * it (even before the link counts as up again) is followed. */
    if (!up)
        r->fresh = 0;
    r->up = up;
    update_outputs(m, robot, -1);
}

void gw_gpiomap_data(gw_gpiomap_t *m, unsigned robot, dr_asm_t a)
{
    if (m == NULL || robot >= GW_MAX_ROBOTS || (unsigned)a >= DR_ASM_COUNT)
        return;
    m->robot[robot].fresh |= 1u << a;
    update_outputs(m, robot, (int)a);
}

void gw_gpiomap_fault(gw_gpiomap_t *m, unsigned robot, bool fault)
{
    if (m == NULL || robot >= GW_MAX_ROBOTS)
        return;
    m->robot[robot].fault = fault;
    update_outputs(m, robot, -1);
}

void gw_gpiomap_safe_all(gw_gpiomap_t *m)
{
    if (m == NULL)
        return;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++) {
        m->robot[r].up = false;
        m->robot[r].fresh = 0;
    }
    for (unsigned i = 0; i < m->nlines; i++) {
        line_t *l = m->lines[i];
        if (l->cfg->dir != GW_GPIO_OUTPUT || l->req == NULL)
            continue;
        /* Written even if `last` says so already: this is the fault path. */
        gw_gpio_error_t e;
        if (gw_gpio_set_safe(l->req, &e) != GW_GPIO_OK) {
            gw_log(GW_LOG_ERROR, "gpio %s: %s", l->cfg->name, e.msg);
            l->last = -1;
        } else {
            l->last = l->cfg->safe_value ? 1 : 0;
        }
    }
}

/* ---- inputs ----------------------------------------------------------------- */

/* Inputs: the debounced values into their O->T bits, each line its own
 * write through the one write path (core/write.h: direction, plan, range;
 * the single writer and the fault latch are the clients', not the
 * wiring's; a line the path refuses does not hold the others back). */
static void poll_inputs(gw_gpiomap_t *m, uint64_t now_ns)
{
    static const gw_write_origin_t gpio = {GW_ORIGIN_GPIO, "gpio", true, false, false, NULL};
    unsigned dirty[GW_MAX_ROBOTS] = {0};
    for (unsigned i = 0; i < m->nlines; i++) {
        line_t *l = m->lines[i];
        if (l->cfg->dir != GW_GPIO_INPUT || l->req == NULL || l->robot >= GW_MAX_ROBOTS)
            continue;
        int v;
        gw_gpio_error_t e;
        if (gw_gpio_request_input_value(l->req, l->offset, now_ns, &v, NULL, &e) != GW_GPIO_OK) {
            gw_log_limited(GW_LOG_ERROR, &m->log_limit, "gpio %s: %s", l->cfg->name, e.msg);
            continue;
        }
        dr_value_t cur;
        gw_write_item_t item = {l->cfg->field, dr_value_uint((uint64_t)v), 0};
        gw_write_result_t res;
        if (gw_robot_get(&m->robots[l->robot], l->cfg->field, &cur) == DR_OK &&
            cur.u != (uint64_t)v &&
            gw_robot_write(&m->robots[l->robot], &item, 1, &gpio, &res) == GW_WRITE_OK)
            dirty[l->robot] |= res.dirty;
    }
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        if (dirty[r] != 0 && m->hooks.on_input != NULL)
            m->hooks.on_input(m->hooks.user, r, dirty[r]);
}

static void on_events(void *obj, uint32_t events)
{
    line_t *l = obj;
    gw_gpiomap_t *m = l->owner;
    gw_gpio_event_t ev[16];
    size_t n = 0;
    gw_gpio_error_t e;
    do {
        if (gw_gpio_request_read_events(l->req, ev, 16, &n, &e) != GW_GPIO_OK) {
            /* A chip that went away (a USB expander unplugged) reports
             * POLLERR for ever: stop watching rather than spin. The
             * input keeps its last value. */
            if (events & (EPOLLERR | EPOLLHUP)) {
                gw_log(GW_LOG_ERROR, "gpio %s: %s; no longer watching its edges", l->cfg->name,
                       e.msg);
                for (unsigned i = 0; i < l->nev; i++)
                    ev_unwatch(m->epfd, &l->ev[i]);
                l->nev = 0;
            } else {
                gw_log_limited(GW_LOG_ERROR, &m->log_limit, "gpio %s: %s", l->cfg->name, e.msg);
            }
            break;
        }
    } while (n == 16);
    poll_inputs(m, gw_gpio_now_ns());
}

void gw_gpiomap_tick(gw_gpiomap_t *m, uint64_t now_us)
{
    if (m == NULL || m->nlines == 0)
        return;
    uint64_t now_ns = now_us * 1000u;
    if (now_us >= m->next_resync_us) {
        m->next_resync_us = now_us + RESYNC_US;
        for (unsigned i = 0; i < m->nlines; i++) {
            line_t *l = m->lines[i];
            gw_gpio_error_t e;
            if (l->cfg->dir == GW_GPIO_INPUT && l->req != NULL &&
                gw_gpio_request_sync_inputs(l->req, now_ns, &e) != GW_GPIO_OK)
                gw_log_limited(GW_LOG_ERROR, &m->log_limit, "gpio %s: %s", l->cfg->name, e.msg);
        }
    }
    poll_inputs(m, now_ns);
}

uint64_t gw_gpiomap_next_deadline(const gw_gpiomap_t *m)
{
    if (m == NULL || m->nlines == 0)
        return UINT64_MAX;
    uint64_t d = m->next_resync_us;
    for (unsigned i = 0; i < m->nlines; i++) {
        uint64_t ns = gw_gpio_request_next_deadline(m->lines[i]->req);
        if (ns != UINT64_MAX && ns / 1000u + 1u < d)
            d = ns / 1000u + 1u;
    }
    return d;
}

unsigned gw_gpiomap_count(const gw_gpiomap_t *m)
{
    return m == NULL ? 0 : m->nlines;
}

void gw_gpiomap_each_line(const gw_gpiomap_t *m,
                          void (*fn)(void *user, const gw_gpiomap_line_info_t *l), void *user)
{
    if (m == NULL)
        return;
    for (unsigned i = 0; i < m->nlines; i++) {
        const line_t *l = m->lines[i];
        gw_gpiomap_line_info_t info = {l->cfg, l->chip != NULL ? l->chip->name : "", l->offset,
                                       l->last, l->req != NULL};
        if (l->cfg->dir == GW_GPIO_INPUT) {
            const dr_field_t *f = l->cfg->field.field;
            dr_value_t v;
            info.level = dr_field_get(m->robots[l->robot].img[f->assembly],
                                      dr_asm_info((dr_asm_t)f->assembly)->size, l->cfg->field,
                                      &v) == DR_OK
                             ? (int)(v.u & 1u)
                             : -1;
        }
        fn(user, &info);
    }
}
