/* SPDX-License-Identifier: MIT */
/*
 * GPIO backend on libgpiod 1.6 (the v1 API; Debian bookworm's
 * libgpiod-dev). See gpio_internal.h for the contract.
 *
 * v1 requests share one configuration per call, so each line is requested
 * on its own: that lets one gateway request mix inputs and outputs with
 * different flags, gives one event fd per edge-detecting line, and tells
 * exactly which line the kernel refused. Bias flags exist since
 * libgpiod 1.5 (kernel 5.5); v1 has no debounce, so the common code does
 * it in software.
 */
#include "gpio/gpio_internal.h"

#include <errno.h>
#include <fcntl.h>
#include <gpiod.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Events read per read(2); the kernel's v1 queue holds 16 per line. */
#define V1_EVENT_BATCH 16

struct gw_gpio_be_chip {
    struct gpiod_chip *chip;
};

struct v1_line {
    struct gpiod_line *line; /* owned by the chip */
    int fd;                  /* non-blocking event fd, or -1 */
};

struct gw_gpio_be_req {
    size_t n;
    size_t next; /* where the next read starts, so no line starves */
    struct v1_line l[];
};

const bool gw_gpio_be_kernel_debounce = false;

const char *gw_gpio_be_name(void)
{
    static char name[48];

    if (name[0] == '\0')
        snprintf(name, sizeof name, "libgpiod %s (v1 API)",
                 gpiod_version_string());
    return name;
}

/* Copies a libgpiod string that may be NULL into a fixed buffer. */
static void copy_name(char *dst, size_t cap, const char *src)
{
    snprintf(dst, cap, "%s", src != NULL ? src : "");
}

int gw_gpio_be_chip_open(const char *path, struct gw_gpio_be_chip **out,
                         gw_gpio_be_chip_info_t *info)
{
    struct gw_gpio_be_chip *c = malloc(sizeof *c);

    if (c == NULL)
        return -1;
    c->chip = gpiod_chip_open(path);
    if (c->chip == NULL) {
        int e = errno;
        free(c);
        errno = e;
        return -1;
    }
    copy_name(info->name, sizeof info->name, gpiod_chip_name(c->chip));
    copy_name(info->label, sizeof info->label, gpiod_chip_label(c->chip));
    info->num_lines = gpiod_chip_num_lines(c->chip);
    *out = c;
    return 0;
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
    struct gpiod_line *line = gpiod_chip_get_line(chip->chip, offset);

    if (line == NULL)
        return -1;
    /* The line object caches what the kernel said when it was created;
     * refresh it so "used by" reflects now. */
    if (gpiod_line_update(line) != 0)
        return -1;
    copy_name(info->name, sizeof info->name, gpiod_line_name(line));
    copy_name(info->consumer, sizeof info->consumer, gpiod_line_consumer(line));
    info->used = gpiod_line_is_used(line);
    return 0;
}

int gw_gpio_be_find_line(struct gw_gpio_be_chip *chip, const char *name,
                         unsigned int *offset)
{
    struct gpiod_line *line = gpiod_chip_find_line(chip->chip, name);

    if (line == NULL)
        return -1; /* errno ENOENT: no line of that name */
    *offset = gpiod_line_offset(line);
    return 0;
}

static int request_type(const gw_gpio_line_config_t *c)
{
    if (c->direction == GW_GPIO_DIR_OUTPUT)
        return GPIOD_LINE_REQUEST_DIRECTION_OUTPUT;
    if (c->edge == GW_GPIO_EDGE_BOTH)
        return GPIOD_LINE_REQUEST_EVENT_BOTH_EDGES;
    return GPIOD_LINE_REQUEST_DIRECTION_INPUT;
}

static int request_flags(const gw_gpio_line_config_t *c)
{
    int flags = c->active_low ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;

    switch (c->bias) {
    case GW_GPIO_BIAS_DISABLE:
        flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE;
        break;
    case GW_GPIO_BIAS_PULL_UP:
        flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP;
        break;
    case GW_GPIO_BIAS_PULL_DOWN:
        flags |= GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN;
        break;
    default: break;
    }
    return flags;
}

/* Requests one line; for edge lines, makes its event fd non-blocking so a
 * read after a spurious wakeup cannot stall the daemon's loop. */
static int request_one(struct gw_gpio_be_chip *chip, const char *consumer,
                       const gw_gpio_line_config_t *c, struct v1_line *out)
{
    struct gpiod_line_request_config rc;
    int fl;

    out->fd = -1;
    out->line = gpiod_chip_get_line(chip->chip, c->offset);
    if (out->line == NULL)
        return -1;
    memset(&rc, 0, sizeof rc);
    rc.consumer = consumer;
    rc.request_type = request_type(c);
    rc.flags = request_flags(c);
    /* The default value is logical (the kernel applies active-low), so
     * the output starts at its safe value without a glitch. */
    if (gpiod_line_request(out->line, &rc, c->safe_value) != 0)
        return -1;
    if (c->edge != GW_GPIO_EDGE_BOTH)
        return 0;
    out->fd = gpiod_line_event_get_fd(out->line);
    fl = out->fd < 0 ? -1 : fcntl(out->fd, F_GETFL);
    if (fl < 0 || fcntl(out->fd, F_SETFL, fl | O_NONBLOCK) < 0) {
        int e = errno;
        gpiod_line_release(out->line);
        errno = e;
        return -1;
    }
    return 0;
}

int gw_gpio_be_request(struct gw_gpio_be_chip *chip, const char *consumer,
                       const gw_gpio_line_config_t *lines, size_t n,
                       struct gw_gpio_be_req **out, size_t *failed)
{
    struct gw_gpio_be_req *r = calloc(1, sizeof *r + n * sizeof r->l[0]);

    *failed = n;
    if (r == NULL)
        return -1;
    r->n = n;
    for (size_t i = 0; i < n; i++) {
        if (request_one(chip, consumer, &lines[i], &r->l[i]) != 0) {
            int e = errno;
            /* All or none: the lines taken so far sit at their safe
             * (initial) values, so letting them go is harmless. */
            for (size_t j = 0; j < i; j++)
                gpiod_line_release(r->l[j].line);
            free(r);
            *failed = i;
            errno = e;
            return -1;
        }
    }
    *out = r;
    return 0;
}

void gw_gpio_be_release(struct gw_gpio_be_req *req)
{
    if (req == NULL)
        return;
    for (size_t i = 0; i < req->n; i++)
        gpiod_line_release(req->l[i].line);
    free(req);
}

int gw_gpio_be_get(struct gw_gpio_be_req *req, size_t index, int *value)
{
    int v = gpiod_line_get_value(req->l[index].line);

    if (v < 0)
        return -1;
    *value = v;
    return 0;
}

int gw_gpio_be_set(struct gw_gpio_be_req *req, size_t index, int value)
{
    return gpiod_line_set_value(req->l[index].line, value) == 0 ? 0 : -1;
}

size_t gw_gpio_be_fds(const struct gw_gpio_be_req *req, int *fds, size_t cap)
{
    size_t n = 0;

    for (size_t i = 0; i < req->n; i++) {
        if (req->l[i].fd < 0)
            continue;
        if (fds != NULL && n < cap)
            fds[n] = req->l[i].fd;
        n++;
    }
    return n;
}

/* Reads up to cap events of one line; 0 with *got = 0 when none wait. */
static int read_line(struct v1_line *l, size_t index,
                     gw_gpio_be_event_t *events, size_t cap, size_t *got)
{
    struct gpiod_line_event ev[V1_EVENT_BATCH];
    unsigned int want =
        cap < V1_EVENT_BATCH ? (unsigned int)cap : V1_EVENT_BATCH;
    int k = gpiod_line_event_read_fd_multiple(l->fd, ev, want);

    *got = 0;
    if (k < 0)
        return errno == EAGAIN || errno == EWOULDBLOCK ? 0 : -1;
    for (int j = 0; j < k; j++) {
        events[j].index = index;
        events[j].rising = ev[j].event_type == GPIOD_LINE_EVENT_RISING_EDGE;
        events[j].timestamp_ns = (uint64_t)ev[j].ts.tv_sec * 1000000000u +
                                 (uint64_t)ev[j].ts.tv_nsec;
        events[j].line_seqno = 0; /* v1 has none: common counts */
    }
    *got = (size_t)k;
    return 0;
}

int gw_gpio_be_read_events(struct gw_gpio_be_req *req,
                           gw_gpio_be_event_t *events, size_t cap, size_t *n)
{
    size_t total = 0;

    *n = 0;
    if (req->n == 0)
        return 0;
    for (size_t k = 0; k < req->n && total < cap; k++) {
        size_t i = (req->next + k) % req->n, got;
        struct v1_line *l = &req->l[i];

        if (l->fd < 0)
            continue;
        if (read_line(l, i, events + total, cap - total, &got) != 0)
            return -1;
        total += got;
        if (total == cap)
            req->next = (i + 1) % req->n;
    }
    *n = total;
    return 0;
}
