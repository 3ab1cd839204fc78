/* SPDX-License-Identifier: MIT */
/*
 * GPIO backend on libgpiod >= 2.0 (the v2 API, request-centric). See
 * gpio_internal.h for the contract. Built instead of gpio_v1.c when
 * `pkg-config --atleast-version=2.0 libgpiod` succeeds; `make
 * check-gpio-v2` builds it against the libgpiod 2 sources bundled in the
 * gpiod PyPI sdist and runs the qemu test with it.
 *
 * Uses only calls present in libgpiod 2.0. All lines go into one kernel
 * request with per-line settings; events of all lines come through the
 * request's one fd, with the kernel's per-line sequence numbers. The v2
 * uAPI debounces in the kernel (in software there when the hardware
 * cannot), so the common debouncer is bypassed.
 */
#include "gpio/gpio_internal.h"

#include <errno.h>
#include <gpiod.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Events per read; a read never asks for more than the buffer holds. */
#define V2_EVENT_BUFFER 64

struct gw_gpio_be_chip {
    struct gpiod_chip *chip;
};

struct gw_gpio_be_req {
    struct gpiod_line_request *req;
    struct gpiod_edge_event_buffer *buf; /* NULL: no edge lines */
    size_t n;
    unsigned int offsets[GW_GPIO_MAX_LINES];
};

const bool gw_gpio_be_kernel_debounce = true;

const char *gw_gpio_be_name(void)
{
    static char name[48];

    if (name[0] == '\0')
        snprintf(name, sizeof name, "libgpiod %s (v2 API)",
                 gpiod_api_version());
    return name;
}

static void copy_name(char *dst, size_t cap, const char *src)
{
    snprintf(dst, cap, "%s", src != NULL ? src : "");
}

int gw_gpio_be_chip_open(const char *path, struct gw_gpio_be_chip **out,
                         gw_gpio_be_chip_info_t *info)
{
    struct gw_gpio_be_chip *c = malloc(sizeof *c);
    struct gpiod_chip_info *ci;
    int e;

    if (c == NULL)
        return -1;
    c->chip = gpiod_chip_open(path);
    if (c->chip == NULL)
        goto fail;
    ci = gpiod_chip_get_info(c->chip);
    if (ci == NULL) {
        e = errno;
        gpiod_chip_close(c->chip);
        errno = e;
        goto fail;
    }
    copy_name(info->name, sizeof info->name, gpiod_chip_info_get_name(ci));
    copy_name(info->label, sizeof info->label, gpiod_chip_info_get_label(ci));
    info->num_lines = (unsigned int)gpiod_chip_info_get_num_lines(ci);
    gpiod_chip_info_free(ci);
    *out = c;
    return 0;
fail:
    e = errno;
    free(c);
    errno = e;
    return -1;
}

void gw_gpio_be_chip_close(struct gw_gpio_be_chip *chip)
{
    if (chip == NULL)
        return;
    gpiod_chip_close(chip->chip);
    free(chip);
}

int gw_gpio_be_line_info(struct gw_gpio_be_chip *chip, unsigned int offset,
                         gw_gpio_be_line_info_t *info)
{
    struct gpiod_line_info *li = gpiod_chip_get_line_info(chip->chip, offset);

    if (li == NULL)
        return -1;
    copy_name(info->name, sizeof info->name, gpiod_line_info_get_name(li));
    copy_name(info->consumer, sizeof info->consumer,
              gpiod_line_info_get_consumer(li));
    info->used = gpiod_line_info_is_used(li);
    gpiod_line_info_free(li);
    return 0;
}

int gw_gpio_be_find_line(struct gw_gpio_be_chip *chip, const char *name,
                         unsigned int *offset)
{
    int off = gpiod_chip_get_line_offset_from_name(chip->chip, name);

    if (off < 0)
        return -1; /* errno ENOENT: no line of that name */
    *offset = (unsigned int)off;
    return 0;
}

static enum gpiod_line_bias bias_of(gw_gpio_line_bias_t b)
{
    switch (b) {
    case GW_GPIO_BIAS_DISABLE: return GPIOD_LINE_BIAS_DISABLED;
    case GW_GPIO_BIAS_PULL_UP: return GPIOD_LINE_BIAS_PULL_UP;
    case GW_GPIO_BIAS_PULL_DOWN: return GPIOD_LINE_BIAS_PULL_DOWN;
    default: return GPIOD_LINE_BIAS_AS_IS;
    }
}

/* One line's settings; NULL with errno set on failure. */
static struct gpiod_line_settings *settings_of(const gw_gpio_line_config_t *c)
{
    struct gpiod_line_settings *s = gpiod_line_settings_new();
    int rc = 0;

    if (s == NULL)
        return NULL;
    gpiod_line_settings_set_active_low(s, c->active_low);
    rc |= gpiod_line_settings_set_bias(s, bias_of(c->bias));
    if (c->direction == GW_GPIO_DIR_OUTPUT) {
        rc |= gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_OUTPUT);
        /* Logical, like every value here: the line starts safe. */
        rc |= gpiod_line_settings_set_output_value(
            s, c->safe_value ? GPIOD_LINE_VALUE_ACTIVE
                             : GPIOD_LINE_VALUE_INACTIVE);
    } else {
        rc |= gpiod_line_settings_set_direction(s, GPIOD_LINE_DIRECTION_INPUT);
    }
    if (c->edge == GW_GPIO_EDGE_BOTH) {
        rc |= gpiod_line_settings_set_edge_detection(s, GPIOD_LINE_EDGE_BOTH);
        /* Same clock as gw_gpio_now_ns(), which the loop compares with. */
        rc |=
            gpiod_line_settings_set_event_clock(s, GPIOD_LINE_CLOCK_MONOTONIC);
        gpiod_line_settings_set_debounce_period_us(s, c->debounce_us);
    }
    if (rc != 0) {
        int e = errno;
        gpiod_line_settings_free(s);
        errno = e;
        return NULL;
    }
    return s;
}

/* The line config holding every line's own settings. */
static struct gpiod_line_config *
line_config_of(const gw_gpio_line_config_t *lines, size_t n)
{
    struct gpiod_line_config *lc = gpiod_line_config_new();

    if (lc == NULL)
        return NULL;
    for (size_t i = 0; i < n; i++) {
        struct gpiod_line_settings *s = settings_of(&lines[i]);
        int rc = s == NULL ? -1
                           : gpiod_line_config_add_line_settings(
                                 lc, &lines[i].offset, 1, s);
        int e = errno;

        gpiod_line_settings_free(s); /* the config keeps a copy */
        if (rc != 0) {
            gpiod_line_config_free(lc);
            errno = e;
            return NULL;
        }
    }
    return lc;
}

static bool any_edges(const gw_gpio_line_config_t *lines, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (lines[i].edge == GW_GPIO_EDGE_BOTH)
            return true;
    return false;
}

int gw_gpio_be_request(struct gw_gpio_be_chip *chip, const char *consumer,
                       const gw_gpio_line_config_t *lines, size_t n,
                       struct gw_gpio_be_req **out, size_t *failed)
{
    struct gw_gpio_be_req *r = NULL;
    struct gpiod_request_config *rc = NULL;
    struct gpiod_line_config *lc = line_config_of(lines, n);
    int e = errno; /* line_config_of's reason, if it failed */

    /* One request for all lines: the kernel cannot say which failed. */
    *failed = n;
    if (lc == NULL)
        goto fail;
    e = ENOMEM;
    r = calloc(1, sizeof *r);
    rc = gpiod_request_config_new();
    if (r == NULL || rc == NULL || n > GW_GPIO_MAX_LINES)
        goto fail;
    r->n = n;
    for (size_t i = 0; i < n; i++)
        r->offsets[i] = lines[i].offset;
    gpiod_request_config_set_consumer(rc, consumer);
    r->req = gpiod_chip_request_lines(chip->chip, rc, lc);
    if (r->req == NULL) {
        e = errno;
        goto fail;
    }
    if (any_edges(lines, n)) {
        r->buf = gpiod_edge_event_buffer_new(V2_EVENT_BUFFER);
        if (r->buf == NULL) {
            e = errno;
            gpiod_line_request_release(r->req);
            goto fail;
        }
    }
    gpiod_line_config_free(lc);
    gpiod_request_config_free(rc);
    *out = r;
    return 0;
fail:
    if (lc != NULL)
        gpiod_line_config_free(lc);
    if (rc != NULL)
        gpiod_request_config_free(rc);
    free(r);
    errno = e;
    return -1;
}

void gw_gpio_be_release(struct gw_gpio_be_req *req)
{
    if (req == NULL)
        return;
    if (req->buf != NULL)
        gpiod_edge_event_buffer_free(req->buf);
    gpiod_line_request_release(req->req);
    free(req);
}

int gw_gpio_be_get(struct gw_gpio_be_req *req, size_t index, int *value)
{
    enum gpiod_line_value v =
        gpiod_line_request_get_value(req->req, req->offsets[index]);

    if (v == GPIOD_LINE_VALUE_ERROR)
        return -1;
    *value = v == GPIOD_LINE_VALUE_ACTIVE;
    return 0;
}

int gw_gpio_be_set(struct gw_gpio_be_req *req, size_t index, int value)
{
    return gpiod_line_request_set_value(req->req, req->offsets[index],
                                        value ? GPIOD_LINE_VALUE_ACTIVE
                                              : GPIOD_LINE_VALUE_INACTIVE);
}

size_t gw_gpio_be_fds(const struct gw_gpio_be_req *req, int *fds, size_t cap)
{
    /* The request fd exists always, but only edge lines make it
     * readable: do not hand out a descriptor that never fires. */
    if (req->buf == NULL)
        return 0;
    if (fds != NULL && cap > 0)
        fds[0] = gpiod_line_request_get_fd(req->req);
    return 1;
}

static size_t index_of_offset(const struct gw_gpio_be_req *req,
                              unsigned int offset)
{
    for (size_t i = 0; i < req->n; i++)
        if (req->offsets[i] == offset)
            return i;
    return req->n;
}

int gw_gpio_be_read_events(struct gw_gpio_be_req *req,
                           gw_gpio_be_event_t *events, size_t cap, size_t *n)
{
    size_t want = cap, got = 0;
    int k;

    if (want > V2_EVENT_BUFFER)
        want = V2_EVENT_BUFFER;
    *n = 0;
    if (req->buf == NULL || want == 0)
        return 0;
    /* read_edge_events blocks on an empty queue; a zero wait does not. */
    k = gpiod_line_request_wait_edge_events(req->req, 0);
    if (k <= 0)
        return k;
    k = gpiod_line_request_read_edge_events(req->req, req->buf, want);
    if (k < 0)
        return -1;
    for (int j = 0; j < k; j++) {
        struct gpiod_edge_event *ev =
            gpiod_edge_event_buffer_get_event(req->buf, (unsigned long)j);
        size_t i =
            ev ? index_of_offset(req, gpiod_edge_event_get_line_offset(ev))
               : req->n;

        if (i == req->n)
            continue; /* cannot happen: the kernel reports our lines */
        events[got].index = i;
        events[got].rising =
            gpiod_edge_event_get_event_type(ev) == GPIOD_EDGE_EVENT_RISING_EDGE;
        events[got].timestamp_ns = gpiod_edge_event_get_timestamp_ns(ev);
        events[got].line_seqno = gpiod_edge_event_get_line_seqno(ev);
        got++;
    }
    *n = got;
    return 0;
}
