/* SPDX-License-Identifier: MIT */
/* The fake GPIO backend described in gpio_fake.h. */
#include "gpio_fake.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

fake_state_t fake;

struct gw_gpio_be_chip {
    int index; /* 0: fake-A, 1: fake-B */
};

struct gw_gpio_be_req {
    int chip;
    size_t n;
    gw_gpio_line_config_t lines[GW_GPIO_MAX_LINES];
};

const bool gw_gpio_be_kernel_debounce = false;

/* Lines of chip 1 are never shared with the tests' state. */
static int chip1_value[4];

void fake_reset(void)
{
    memset(&fake, 0, sizeof fake);
    memset(chip1_value, 0, sizeof chip1_value);
}

void fake_edge(unsigned int offset, int value, uint64_t ts_ns)
{
    if (fake.nqueue == FAKE_QUEUE || offset >= FAKE_LINES)
        return;
    fake.value[offset] = value;
    fake.queue_offset[fake.nqueue] = offset;
    fake.queue[fake.nqueue].rising = value != 0;
    fake.queue[fake.nqueue].timestamp_ns = ts_ns;
    fake.queue[fake.nqueue].line_seqno = 0;
    fake.nqueue++;
}

const char *gw_gpio_be_name(void)
{
    return "fake (tests)";
}

int gw_gpio_be_chip_open(const char *path, struct gw_gpio_be_chip **out,
                         gw_gpio_be_chip_info_t *info)
{
    int index;

    if (strcmp(path, "/dev/gpiochip0") == 0)
        index = 0;
    else if (strcmp(path, "/dev/gpiochip1") == 0)
        index = 1;
    else {
        errno = ENOENT;
        return -1;
    }
    *out = malloc(sizeof **out);
    if (*out == NULL)
        return -1;
    (*out)->index = index;
    snprintf(info->name, sizeof info->name, "gpiochip%d", index);
    snprintf(info->label, sizeof info->label, "fake-%c", 'A' + index);
    info->num_lines = index == 0 ? FAKE_LINES : 4;
    fake.open_chips++;
    return 0;
}

void gw_gpio_be_chip_close(struct gw_gpio_be_chip *chip)
{
    if (chip == NULL)
        return;
    fake.open_chips--;
    free(chip);
}

int gw_gpio_be_line_info(struct gw_gpio_be_chip *chip, unsigned int offset,
                         gw_gpio_be_line_info_t *info)
{
    memset(info, 0, sizeof *info);
    if (chip->index != 0)
        return 0; /* unnamed, unused */
    snprintf(info->name, sizeof info->name, "fake-A-%u", offset);
    if (fake.busy[offset]) {
        info->used = true;
        snprintf(info->consumer, sizeof info->consumer, "other");
    } else if (fake.requested[offset]) {
        info->used = true;
        snprintf(info->consumer, sizeof info->consumer, "%s",
                 fake.consumer[offset]);
    }
    return 0;
}

int gw_gpio_be_find_line(struct gw_gpio_be_chip *chip, const char *name,
                         unsigned int *offset)
{
    for (unsigned int i = 0; chip->index == 0 && i < FAKE_LINES; i++) {
        char n[16];
        snprintf(n, sizeof n, "fake-A-%u", i);
        if (strcmp(n, name) == 0) {
            *offset = i;
            return 0;
        }
    }
    errno = ENOENT;
    return -1;
}

static int *value_of(int chip, unsigned int offset)
{
    return chip == 0 ? &fake.value[offset] : &chip1_value[offset];
}

static void log_write(int chip, unsigned int offset, int value)
{
    if (chip == 0 && fake.nlog < FAKE_LOG) {
        fake.log[fake.nlog].offset = offset;
        fake.log[fake.nlog].value = value;
        fake.nlog++;
    }
}

int gw_gpio_be_request(struct gw_gpio_be_chip *chip, const char *consumer,
                       const gw_gpio_line_config_t *lines, size_t n,
                       struct gw_gpio_be_req **out, size_t *failed)
{
    struct gw_gpio_be_req *r;

    for (size_t i = 0; chip->index == 0 && i < n; i++)
        if (fake.busy[lines[i].offset] || fake.requested[lines[i].offset]) {
            *failed = fake.whole_request_fails ? n : i;
            errno = EBUSY;
            return -1;
        }
    r = calloc(1, sizeof *r);
    if (r == NULL)
        return -1;
    r->chip = chip->index;
    r->n = n;
    for (size_t i = 0; i < n; i++) {
        unsigned int o = lines[i].offset;
        r->lines[i] = lines[i];
        if (chip->index == 0) {
            fake.requested[o] = true;
            snprintf(fake.consumer[o], sizeof fake.consumer[o], "%s", consumer);
        }
        if (lines[i].direction == GW_GPIO_DIR_OUTPUT) {
            *value_of(r->chip, o) = lines[i].safe_value;
            log_write(r->chip, o, lines[i].safe_value);
        }
    }
    *out = r;
    return 0;
}

void gw_gpio_be_release(struct gw_gpio_be_req *req)
{
    if (req == NULL)
        return;
    for (size_t i = 0; req->chip == 0 && i < req->n; i++)
        fake.requested[req->lines[i].offset] = false;
    fake.releases++;
    free(req);
}

int gw_gpio_be_get(struct gw_gpio_be_req *req, size_t index, int *value)
{
    unsigned int o = req->lines[index].offset;

    if (req->chip == 0 && fake.get_errno[o] != 0) {
        errno = fake.get_errno[o];
        return -1;
    }
    *value = *value_of(req->chip, o);
    return 0;
}

int gw_gpio_be_set(struct gw_gpio_be_req *req, size_t index, int value)
{
    unsigned int o = req->lines[index].offset;

    if (req->chip == 0 && fake.set_errno[o] != 0) {
        errno = fake.set_errno[o];
        return -1;
    }
    *value_of(req->chip, o) = value;
    log_write(req->chip, o, value);
    return 0;
}

size_t gw_gpio_be_fds(const struct gw_gpio_be_req *req, int *fds, size_t cap)
{
    size_t n = 0;

    /* Like v1: one descriptor per edge line (made-up numbers). */
    for (size_t i = 0; i < req->n; i++)
        if (req->lines[i].edge == GW_GPIO_EDGE_BOTH) {
            if (fds != NULL && n < cap)
                fds[n] = 100 + (int)i;
            n++;
        }
    return n;
}

int gw_gpio_be_read_events(struct gw_gpio_be_req *req,
                           gw_gpio_be_event_t *events, size_t cap, size_t *n)
{
    size_t got = 0, keep = 0;

    for (size_t q = 0; q < fake.nqueue; q++) {
        size_t i = req->n;
        for (size_t j = 0; j < req->n; j++)
            if (req->lines[j].offset == fake.queue_offset[q])
                i = j;
        if (req->chip == 0 && i < req->n && got < cap) {
            events[got] = fake.queue[q];
            events[got].index = i;
            got++;
        } else {
            fake.queue[keep] = fake.queue[q];
            fake.queue_offset[keep] = fake.queue_offset[q];
            keep++;
        }
    }
    fake.nqueue = keep;
    *n = got;
    return 0;
}
