/* SPDX-License-Identifier: MIT */
/*
 * The GPIO interface of gpio.h over whichever backend is linked (see
 * gpio_internal.h): chip lookup, validation, error messages that name the
 * chip and the line, safe values and debouncing live here once.
 */
#include "gpio/gpio.h"
#include "gpio/gpio_internal.h"

#include <ctype.h>
#include <dirent.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define DEFAULT_CONSUMER "drgatewayd"
#define CHIP_PATH_MAX    128
#define MAX_CHIPS        64 /* enough for any board; only for lookup by label */
/* Events converted per backend read; bounds the stack buffer only. */
#define EVENT_BATCH 16

struct gw_gpio_chip {
    struct gw_gpio_be_chip *be;
    gw_gpio_be_chip_info_t info;
    char path[CHIP_PATH_MAX];
    struct gw_gpio_request *requests; /* live ones, released on close */
};

struct gw_gpio_line {
    gw_gpio_line_config_t cfg;
    gw_gpio_debounce_t deb; /* edge inputs only */
    uint64_t seqno;         /* last event's sequence number */
};

struct gw_gpio_request {
    gw_gpio_chip_t *chip;
    struct gw_gpio_request *next;
    struct gw_gpio_be_req *be;
    char consumer[GW_GPIO_NAME_MAX + 1];
    size_t n;
    struct gw_gpio_line line[]; /* n of them */
};

/* ---- errors ------------------------------------------------------------ */

static const char *const status_text[] = {
#define GW_GPIO_STATUS_TEXT(name, text) text,
    GW_GPIO_STATUS_LIST(GW_GPIO_STATUS_TEXT)
#undef GW_GPIO_STATUS_TEXT
};

const char *gw_gpio_strerror(gw_gpio_status_t status)
{
    if ((unsigned)status >= (unsigned)GW_GPIO_STATUS_COUNT)
        return "unknown GPIO status";
    return status_text[status];
}

#if defined(__GNUC__)
#define PRINTF_LIKE(f, a) __attribute__((format(printf, f, a)))
#else
#define PRINTF_LIKE(f, a)
#endif

static gw_gpio_status_t fail(gw_gpio_error_t *err, gw_gpio_status_t code,
                             int sys_errno, const char *fmt, ...)
    PRINTF_LIKE(4, 5);

/* Fills *err (if any) and returns code, so callers can `return fail(...)`. */
static gw_gpio_status_t fail(gw_gpio_error_t *err, gw_gpio_status_t code,
                             int sys_errno, const char *fmt, ...)
{
    va_list ap;

    if (err == NULL)
        return code;
    err->code = code;
    err->sys_errno = sys_errno;
    va_start(ap, fmt);
    vsnprintf(err->msg, sizeof err->msg, fmt, ap);
    va_end(ap);
    return code;
}

static gw_gpio_status_t ok(gw_gpio_error_t *err)
{
    if (err != NULL) {
        err->code = GW_GPIO_OK;
        err->sys_errno = 0;
        err->msg[0] = '\0';
    }
    return GW_GPIO_OK;
}

/* The kernel's errno for a line operation, as one of our codes. */
static gw_gpio_status_t status_of_errno(int e, gw_gpio_status_t not_found)
{
    switch (e) {
    case ENOENT:
    case ENODEV:
    case ENXIO: return not_found;
    case EBUSY: return GW_GPIO_EBUSY;
    case EACCES:
    case EPERM: return GW_GPIO_EPERM;
    case EINVAL: return GW_GPIO_EINVAL;
    case ENOMEM: return GW_GPIO_ENOMEM;
    case ENOTSUP:
    case ENOTTY:
    case ENOSYS: return GW_GPIO_ENOTSUP;
    default: return GW_GPIO_EIO;
    }
}

/* "gpiochip0 [gpio-mockup-A]": how every message names a chip. */
static void chip_desc(const gw_gpio_chip_t *chip, char *buf, size_t cap)
{
    if (chip->info.label[0] != '\0')
        snprintf(buf, cap, "%s [%s]", chip->info.name, chip->info.label);
    else
        snprintf(buf, cap, "%s", chip->info.name);
}

/* "gpiochip0 [gpio-mockup-A] line 3 "gpio-mockup-A-3"", name if it has
 * one; consumer (may be NULL) receives the line's current user. */
static void line_desc(gw_gpio_chip_t *chip, unsigned int offset, char *buf,
                      size_t cap, char *consumer, size_t consumer_cap)
{
    gw_gpio_be_line_info_t li;
    char cd[80];

    chip_desc(chip, cd, sizeof cd);
    memset(&li, 0, sizeof li);
    if (offset >= chip->info.num_lines ||
        gw_gpio_be_line_info(chip->be, offset, &li) != 0)
        li.name[0] = li.consumer[0] = '\0';
    if (li.name[0] != '\0')
        snprintf(buf, cap, "%s line %u \"%s\"", cd, offset, li.name);
    else
        snprintf(buf, cap, "%s line %u", cd, offset);
    if (consumer != NULL && consumer_cap > 0)
        snprintf(consumer, consumer_cap, "%s",
                 li.used ? (li.consumer[0] ? li.consumer : "(unnamed)") : "");
}

static const char *bias_text(gw_gpio_line_bias_t b)
{
    switch (b) {
    case GW_GPIO_BIAS_DISABLE: return ", bias disabled";
    case GW_GPIO_BIAS_PULL_UP: return ", pull-up";
    case GW_GPIO_BIAS_PULL_DOWN: return ", pull-down";
    default: return "";
    }
}

/* "as output (active-low, pull-up, safe value 0)", for request errors. */
static void config_desc(const gw_gpio_line_config_t *c, char *buf, size_t cap)
{
    if (c->direction == GW_GPIO_DIR_OUTPUT)
        snprintf(buf, cap, "as output (%s%s, safe value %d)",
                 c->active_low ? "active-low" : "active-high",
                 bias_text(c->bias), c->safe_value);
    else if (c->debounce_us != 0)
        snprintf(buf, cap, "as input (%s%s, both edges, debounce %lu us)",
                 c->active_low ? "active-low" : "active-high",
                 bias_text(c->bias), (unsigned long)c->debounce_us);
    else
        snprintf(buf, cap, "as input (%s%s%s)",
                 c->active_low ? "active-low" : "active-high",
                 bias_text(c->bias),
                 c->edge == GW_GPIO_EDGE_BOTH ? ", both edges" : "");
}

/* ---- clock and backend ------------------------------------------------- */

uint64_t gw_gpio_now_ns(void)
{
    struct timespec ts;

    /* CLOCK_MONOTONIC cannot fail with a valid pointer. */
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

const char *gw_gpio_backend(void)
{
    return gw_gpio_be_name();
}

/* ---- chips ------------------------------------------------------------- */

static bool all_digits(const char *s)
{
    if (*s == '\0')
        return false;
    for (; *s != '\0'; s++)
        if (!isdigit((unsigned char)*s))
            return false;
    return true;
}

static int cmp_uint(const void *a, const void *b)
{
    unsigned int x = *(const unsigned int *)a, y = *(const unsigned int *)b;

    return (x > y) - (x < y);
}

/* Numbers N of the /dev/gpiochipN present, ascending. */
static size_t list_chip_numbers(unsigned int *nums, size_t cap)
{
    DIR *dir = opendir("/dev");
    struct dirent *de;
    size_t n = 0;

    if (dir == NULL)
        return 0;
    while (n < cap && (de = readdir(dir)) != NULL) {
        const char *s = de->d_name;
        if (strncmp(s, "gpiochip", 8) == 0 && all_digits(s + 8) &&
            strlen(s + 8) < 6)
            nums[n++] = (unsigned int)strtoul(s + 8, NULL, 10);
    }
    closedir(dir);
    qsort(nums, n, sizeof nums[0], cmp_uint);
    return n;
}

/* "gpiochip0 [gpio-mockup-A, 8 lines], gpiochip1 [...]" for messages
 * that must tell the operator what to write instead. */
static void describe_chips(char *buf, size_t cap)
{
    unsigned int nums[MAX_CHIPS];
    size_t n = list_chip_numbers(nums, MAX_CHIPS), used = 0;

    buf[0] = '\0';
    if (n == 0) {
        snprintf(buf, cap,
                 "no /dev/gpiochip* at all (GPIO driver not "
                 "loaded, or /dev not visible to the daemon)");
        return;
    }
    for (size_t i = 0; i < n && used < cap; i++) {
        char path[32];
        struct gw_gpio_be_chip *be;
        gw_gpio_be_chip_info_t info;
        int w;

        snprintf(path, sizeof path, "/dev/gpiochip%u", nums[i]);
        if (gw_gpio_be_chip_open(path, &be, &info) != 0)
            w = snprintf(buf + used, cap - used, "%sgpiochip%u [%s]",
                         i ? ", " : "", nums[i], strerror(errno));
        else {
            w = snprintf(buf + used, cap - used, "%s%s [%s, %u lines]",
                         i ? ", " : "", info.name, info.label, info.num_lines);
            gw_gpio_be_chip_close(be);
        }
        if (w < 0)
            break;
        used += (size_t)w;
    }
}

/* Finds the one chip whose label is label; fills path. */
static gw_gpio_status_t path_of_label(const char *label, char *path, size_t cap,
                                      gw_gpio_error_t *err)
{
    unsigned int nums[MAX_CHIPS];
    size_t n = list_chip_numbers(nums, MAX_CHIPS);
    unsigned int found[2];
    size_t matches = 0;
    char present[200];

    for (size_t i = 0; i < n; i++) {
        char p[32];
        struct gw_gpio_be_chip *be;
        gw_gpio_be_chip_info_t info;

        snprintf(p, sizeof p, "/dev/gpiochip%u", nums[i]);
        if (gw_gpio_be_chip_open(p, &be, &info) != 0)
            continue; /* not ours to judge here; the list shows why */
        if (strcmp(info.label, label) == 0 && matches < 2)
            found[matches++] = nums[i];
        gw_gpio_be_chip_close(be);
    }
    if (matches == 1) {
        snprintf(path, cap, "/dev/gpiochip%u", found[0]);
        return GW_GPIO_OK;
    }
    describe_chips(present, sizeof present);
    if (matches == 0)
        return fail(err, GW_GPIO_ENOCHIP, ENOENT,
                    "GPIO chip \"%s\": no chip has this name or label; "
                    "present: %s",
                    label, present);
    return fail(err, GW_GPIO_EINVAL, 0,
                "GPIO chip \"%s\": label matches gpiochip%u and gpiochip%u; "
                "name the chip (gpiochipN) instead; present: %s",
                label, found[0], found[1], present);
}

/* Turns a chip spec into a device path (see gw_gpio_chip_open). */
static gw_gpio_status_t chip_path(const char *spec, char *path, size_t cap,
                                  gw_gpio_error_t *err)
{
    if (strchr(spec, '/') != NULL) {
        if (strlen(spec) >= cap)
            return fail(err, GW_GPIO_EINVAL, 0,
                        "GPIO chip path too long: \"%.60s...\"", spec);
        snprintf(path, cap, "%s", spec);
        return GW_GPIO_OK;
    }
    if (all_digits(spec) && strlen(spec) < 6) {
        snprintf(path, cap, "/dev/gpiochip%s", spec);
        return GW_GPIO_OK;
    }
    if (strncmp(spec, "gpiochip", 8) == 0 && all_digits(spec + 8) &&
        strlen(spec) < 16) {
        snprintf(path, cap, "/dev/%s", spec);
        return GW_GPIO_OK;
    }
    return path_of_label(spec, path, cap, err);
}

gw_gpio_status_t gw_gpio_chip_open(const char *spec, gw_gpio_chip_t **out,
                                   gw_gpio_error_t *err)
{
    gw_gpio_chip_t *chip;
    gw_gpio_status_t st;
    char present[200];
    int e;

    if (out == NULL)
        return fail(err, GW_GPIO_EINVAL, EINVAL, "GPIO chip: no output");
    *out = NULL;
    if (spec == NULL || spec[0] == '\0')
        return fail(err, GW_GPIO_EINVAL, EINVAL,
                    "GPIO chip: empty name (want /dev/gpiochipN, "
                    "gpiochipN, N or a chip label)");
    chip = calloc(1, sizeof *chip);
    if (chip == NULL)
        return fail(err, GW_GPIO_ENOMEM, ENOMEM, "GPIO chip \"%s\": %s", spec,
                    strerror(ENOMEM));
    st = chip_path(spec, chip->path, sizeof chip->path, err);
    if (st != GW_GPIO_OK) {
        free(chip);
        return st;
    }
    if (gw_gpio_be_chip_open(chip->path, &chip->be, &chip->info) != 0) {
        e = errno;
        st = status_of_errno(e, GW_GPIO_ENOCHIP);
        if (st == GW_GPIO_EPERM)
            fail(err, st, e,
                 "GPIO chip \"%s\" (%s): %s; the daemon needs read/write "
                 "access to the device (group or udev rule)",
                 spec, chip->path, strerror(e));
        else {
            describe_chips(present, sizeof present);
            fail(err, st, e, "GPIO chip \"%s\" (%s): %s; present: %s", spec,
                 chip->path, strerror(e), present);
        }
        free(chip);
        return st;
    }
    *out = chip;
    return ok(err);
}

const char *gw_gpio_chip_name(const gw_gpio_chip_t *chip)
{
    return chip->info.name;
}

const char *gw_gpio_chip_label(const gw_gpio_chip_t *chip)
{
    return chip->info.label;
}

const char *gw_gpio_chip_path(const gw_gpio_chip_t *chip)
{
    return chip->path;
}

unsigned int gw_gpio_chip_num_lines(const gw_gpio_chip_t *chip)
{
    return chip->info.num_lines;
}

void gw_gpio_chip_close(gw_gpio_chip_t *chip)
{
    if (chip == NULL)
        return;
    /* v1 lines die with their chip: put outputs safe before that. */
    while (chip->requests != NULL)
        /* a request on the list has req->chip == chip, so release unlinks
         * it; the analyzer cannot know that */
        gw_gpio_request_release(chip->requests, NULL); // NOLINT(clang-analyzer-unix.Malloc)
    gw_gpio_be_chip_close(chip->be);
    free(chip);
}

gw_gpio_status_t gw_gpio_chip_find_line(gw_gpio_chip_t *chip, const char *spec,
                                        unsigned int *offset,
                                        gw_gpio_error_t *err)
{
    char cd[80];

    if (chip == NULL || spec == NULL || offset == NULL || spec[0] == '\0')
        return fail(err, GW_GPIO_EINVAL, EINVAL,
                    "GPIO line: empty line (want an offset or a line name)");
    chip_desc(chip, cd, sizeof cd);
    if (all_digits(spec)) {
        /* strtoul saturates; the length check keeps it far from that. */
        unsigned long v = strlen(spec) < 10 ? strtoul(spec, NULL, 10) : ~0ul;
        if (v >= chip->info.num_lines)
            return fail(err, GW_GPIO_ENOLINE, ERANGE,
                        "%s: line offset %s out of range (the chip has %u "
                        "lines: 0..%u)",
                        cd, spec, chip->info.num_lines,
                        chip->info.num_lines ? chip->info.num_lines - 1 : 0);
        *offset = (unsigned int)v;
        return ok(err);
    }
    if (gw_gpio_be_find_line(chip->be, spec, offset) != 0) {
        int e = errno;
        if (e == ENOENT)
            return fail(err, GW_GPIO_ENOLINE, e,
                        "%s: no line named \"%s\" (gpioinfo %s lists the "
                        "names)",
                        cd, spec, chip->info.name);
        return fail(err, status_of_errno(e, GW_GPIO_ENOLINE), e,
                    "%s: looking up line \"%s\": %s", cd, spec, strerror(e));
    }
    return ok(err);
}

/* ---- requests ------------------------------------------------------- */

/* Checks one line's settings (the duplicate check is the caller's). */
static gw_gpio_status_t check_line(gw_gpio_chip_t *chip,
                                   const gw_gpio_line_config_t *c,
                                   gw_gpio_error_t *err)
{
    char ld[160];
    const char *why = NULL;

    if (c->offset >= chip->info.num_lines) {
        chip_desc(chip, ld, sizeof ld);
        return fail(err, GW_GPIO_ENOLINE, ERANGE,
                    "%s: line offset %u out of range (the chip has %u "
                    "lines: 0..%u)",
                    ld, c->offset, chip->info.num_lines,
                    chip->info.num_lines ? chip->info.num_lines - 1 : 0);
    }
    if (c->direction != GW_GPIO_DIR_INPUT && c->direction != GW_GPIO_DIR_OUTPUT)
        why = "direction must be input or output";
    else if ((unsigned)c->bias > (unsigned)GW_GPIO_BIAS_PULL_DOWN)
        why = "bias must be as-is, disable, pull-up or pull-down";
    else if (c->edge != GW_GPIO_EDGE_NONE && c->edge != GW_GPIO_EDGE_BOTH)
        why = "edge must be none or both";
    else if (c->direction == GW_GPIO_DIR_OUTPUT && c->edge != GW_GPIO_EDGE_NONE)
        why = "edge events apply to inputs only";
    else if (c->direction == GW_GPIO_DIR_OUTPUT && c->debounce_us != 0)
        why = "debounce applies to inputs only";
    else if (c->debounce_us != 0 && c->edge != GW_GPIO_EDGE_BOTH)
        why = "debounce works from edge events: set edge to both";
    else if (c->direction == GW_GPIO_DIR_OUTPUT && c->safe_value != 0 &&
             c->safe_value != 1)
        why = "an output's safe value must be 0 or 1";
    if (why == NULL)
        return GW_GPIO_OK;
    line_desc(chip, c->offset, ld, sizeof ld, NULL, 0);
    return fail(err, GW_GPIO_EINVAL, EINVAL, "%s: %s", ld, why);
}

static gw_gpio_status_t check_config(gw_gpio_chip_t *chip,
                                     const gw_gpio_request_config_t *cfg,
                                     gw_gpio_error_t *err)
{
    char cd[80];

    chip_desc(chip, cd, sizeof cd);
    if (cfg->lines == NULL || cfg->num_lines == 0 ||
        cfg->num_lines > GW_GPIO_MAX_LINES)
        return fail(err, GW_GPIO_EINVAL, EINVAL,
                    "%s: a request takes 1 to %d lines, not %lu", cd,
                    GW_GPIO_MAX_LINES, (unsigned long)cfg->num_lines);
    for (size_t i = 0; i < cfg->num_lines; i++) {
        gw_gpio_status_t st = check_line(chip, &cfg->lines[i], err);
        if (st != GW_GPIO_OK)
            return st;
        for (size_t j = 0; j < i; j++)
            if (cfg->lines[j].offset == cfg->lines[i].offset)
                return fail(err, GW_GPIO_EINVAL, EINVAL,
                            "%s: line %u is listed twice in one request", cd,
                            cfg->lines[i].offset);
    }
    return GW_GPIO_OK;
}

/* The message for a refused request: which line, how it was asked for,
 * why, and who holds it when it is busy. */
static gw_gpio_status_t request_failed(gw_gpio_chip_t *chip,
                                       const gw_gpio_request_config_t *cfg,
                                       size_t failed, int e,
                                       gw_gpio_error_t *err)
{
    gw_gpio_status_t st = status_of_errno(e, GW_GPIO_ENOLINE);
    char ld[160], how[100], user[GW_GPIO_NAME_MAX + 1] = "";

    /* v2 asks for all lines at once, so the kernel cannot say which one
     * is busy: find it ourselves. */
    if (failed >= cfg->num_lines && e == EBUSY)
        for (size_t i = 0; i < cfg->num_lines && failed >= cfg->num_lines;
             i++) {
            line_desc(chip, cfg->lines[i].offset, ld, sizeof ld, user,
                      sizeof user);
            if (user[0] != '\0')
                failed = i;
        }
    if (failed >= cfg->num_lines) {
        chip_desc(chip, ld, sizeof ld);
        return fail(err, st, e, "%s: cannot request %lu lines: %s", ld,
                    (unsigned long)cfg->num_lines, strerror(e));
    }
    line_desc(chip, cfg->lines[failed].offset, ld, sizeof ld, user,
              sizeof user);
    config_desc(&cfg->lines[failed], how, sizeof how);
    if (e == EBUSY && user[0] != '\0')
        return fail(err, st, e, "%s: cannot request %s: %s (used by \"%s\")",
                    ld, how, strerror(e), user);
    return fail(err, st, e, "%s: cannot request %s: %s", ld, how, strerror(e));
}

/* Sets up the debouncers from the lines' levels right after the request. */
static gw_gpio_status_t init_inputs(gw_gpio_request_t *req,
                                    gw_gpio_error_t *err)
{
    uint64_t now = gw_gpio_now_ns();

    for (size_t i = 0; i < req->n; i++) {
        struct gw_gpio_line *l = &req->line[i];
        uint64_t period;
        int v;

        if (l->cfg.edge != GW_GPIO_EDGE_BOTH)
            continue;
        if (gw_gpio_be_get(req->be, i, &v) != 0) {
            int e = errno;
            char ld[160];
            line_desc(req->chip, l->cfg.offset, ld, sizeof ld, NULL, 0);
            return fail(err, status_of_errno(e, GW_GPIO_EIO), e,
                        "%s: cannot read the input after requesting it: %s", ld,
                        strerror(e));
        }
        period = gw_gpio_be_kernel_debounce
                     ? 0
                     : (uint64_t)l->cfg.debounce_us * 1000u;
        gw_gpio_debounce_init(&l->deb, period, v, now);
    }
    return GW_GPIO_OK;
}

gw_gpio_status_t gw_gpio_chip_request_lines(gw_gpio_chip_t *chip,
                                            const gw_gpio_request_config_t *cfg,
                                            gw_gpio_request_t **out,
                                            gw_gpio_error_t *err)
{
    gw_gpio_request_t *req;
    gw_gpio_status_t st;
    size_t failed = 0;

    if (chip == NULL || cfg == NULL || out == NULL)
        return fail(err, GW_GPIO_EINVAL, EINVAL,
                    "GPIO request: missing chip, configuration or output");
    *out = NULL;
    st = check_config(chip, cfg, err);
    if (st != GW_GPIO_OK)
        return st;
    req = calloc(1, sizeof *req + cfg->num_lines * sizeof req->line[0]);
    if (req == NULL)
        return fail(err, GW_GPIO_ENOMEM, ENOMEM, "GPIO request: %s",
                    strerror(ENOMEM));
    req->chip = chip;
    req->n = cfg->num_lines;
    snprintf(req->consumer, sizeof req->consumer, "%s",
             cfg->consumer ? cfg->consumer : DEFAULT_CONSUMER);
    for (size_t i = 0; i < req->n; i++) {
        req->line[i].cfg = cfg->lines[i];
        /* Normalise so later comparisons can use == 1. */
        req->line[i].cfg.safe_value = cfg->lines[i].safe_value != 0;
    }
    {
        gw_gpio_line_config_t lines[GW_GPIO_MAX_LINES];
        for (size_t i = 0; i < req->n; i++)
            lines[i] = req->line[i].cfg;
        if (gw_gpio_be_request(chip->be, req->consumer, lines, req->n, &req->be,
                               &failed) != 0) {
            int e = errno;
            free(req);
            return request_failed(chip, cfg, failed, e, err);
        }
    }
    st = init_inputs(req, err);
    if (st != GW_GPIO_OK) {
        gw_gpio_be_release(req->be);
        free(req);
        return st;
    }
    req->next = chip->requests;
    chip->requests = req;
    *out = req;
    return ok(err);
}

/* Index of offset in req, or req->n with *err filled. */
static size_t index_of(gw_gpio_request_t *req, unsigned int offset,
                       gw_gpio_error_t *err)
{
    char cd[80], list[GW_GPIO_MAX_LINES * 4 + 1];
    size_t used = 0;

    for (size_t i = 0; i < req->n; i++)
        if (req->line[i].cfg.offset == offset)
            return i;
    list[0] = '\0';
    for (size_t i = 0; i < req->n && used < sizeof list; i++) {
        int w = snprintf(list + used, sizeof list - used, "%s%u", i ? " " : "",
                         req->line[i].cfg.offset);
        if (w < 0)
            break;
        used += (size_t)w;
    }
    chip_desc(req->chip, cd, sizeof cd);
    fail(err, GW_GPIO_ENOLINE, ENOENT,
         "%s line %u: not part of this request (requested: %s)", cd, offset,
         list);
    return req->n;
}

static gw_gpio_status_t io_failed(gw_gpio_request_t *req, size_t i,
                                  const char *what, int e, gw_gpio_error_t *err)
{
    char ld[160];

    line_desc(req->chip, req->line[i].cfg.offset, ld, sizeof ld, NULL, 0);
    return fail(err, status_of_errno(e, GW_GPIO_EIO), e, "%s: %s: %s", ld, what,
                strerror(e));
}

gw_gpio_status_t gw_gpio_request_get_value(gw_gpio_request_t *req,
                                           unsigned int offset, int *value,
                                           gw_gpio_error_t *err)
{
    size_t i;

    if (req == NULL || value == NULL)
        return fail(err, GW_GPIO_EINVAL, EINVAL, "GPIO get: no request");
    i = index_of(req, offset, err);
    if (i == req->n)
        return GW_GPIO_ENOLINE;
    if (gw_gpio_be_get(req->be, i, value) != 0)
        return io_failed(req, i, "cannot read the value", errno, err);
    return ok(err);
}

gw_gpio_status_t gw_gpio_request_set_value(gw_gpio_request_t *req,
                                           unsigned int offset, int value,
                                           gw_gpio_error_t *err)
{
    size_t i;

    if (req == NULL)
        return fail(err, GW_GPIO_EINVAL, EINVAL, "GPIO set: no request");
    i = index_of(req, offset, err);
    if (i == req->n)
        return GW_GPIO_ENOLINE;
    if (req->line[i].cfg.direction != GW_GPIO_DIR_OUTPUT) {
        char ld[160];
        line_desc(req->chip, offset, ld, sizeof ld, NULL, 0);
        return fail(err, GW_GPIO_EDIRECTION, EPERM,
                    "%s: is requested as an input; only outputs can be set",
                    ld);
    }
    if (gw_gpio_be_set(req->be, i, value != 0) != 0)
        return io_failed(req, i, "cannot set the value", errno, err);
    return ok(err);
}

gw_gpio_status_t gw_gpio_set_safe(gw_gpio_request_t *req, gw_gpio_error_t *err)
{
    gw_gpio_status_t first = GW_GPIO_OK;

    if (req == NULL)
        return ok(err);
    /* Every output gets its chance even if an earlier one failed: a fault
     * path must leave as much of the cell safe as it can. */
    for (size_t i = 0; i < req->n; i++) {
        const gw_gpio_line_config_t *c = &req->line[i].cfg;
        if (c->direction != GW_GPIO_DIR_OUTPUT)
            continue;
        if (gw_gpio_be_set(req->be, i, c->safe_value) != 0 &&
            first == GW_GPIO_OK)
            first =
                io_failed(req, i, "cannot write the safe value", errno, err);
    }
    return first == GW_GPIO_OK ? ok(err) : first;
}

size_t gw_gpio_request_fds(const gw_gpio_request_t *req, int *fds, size_t cap)
{
    if (req == NULL)
        return 0;
    return gw_gpio_be_fds(req->be, fds, cap);
}

/* Turns a backend event into the public one and feeds the debouncer. */
static void take_event(gw_gpio_request_t *req, const gw_gpio_be_event_t *be,
                       gw_gpio_event_t *ev)
{
    struct gw_gpio_line *l = &req->line[be->index];

    l->seqno = be->line_seqno ? be->line_seqno : l->seqno + 1;
    ev->offset = l->cfg.offset;
    ev->type = be->rising ? GW_GPIO_EVENT_RISING : GW_GPIO_EVENT_FALLING;
    ev->timestamp_ns = be->timestamp_ns;
    ev->line_seqno = l->seqno;
    gw_gpio_debounce_feed(&l->deb, be->rising, be->timestamp_ns);
}

gw_gpio_status_t gw_gpio_request_read_events(gw_gpio_request_t *req,
                                             gw_gpio_event_t *events,
                                             size_t cap, size_t *n,
                                             gw_gpio_error_t *err)
{
    gw_gpio_be_event_t batch[EVENT_BATCH];
    size_t got = 0;

    if (n != NULL)
        *n = 0;
    if (req == NULL || n == NULL || (events == NULL && cap != 0))
        return fail(err, GW_GPIO_EINVAL, EINVAL, "GPIO events: no request");
    while (got < cap) {
        size_t want = cap - got;
        if (want > EVENT_BATCH)
            want = EVENT_BATCH;
        size_t k = 0;

        if (gw_gpio_be_read_events(req->be, batch, want, &k) != 0) {
            int e = errno;
            char cd[80];
            *n = got;
            chip_desc(req->chip, cd, sizeof cd);
            return fail(err, GW_GPIO_EIO, e, "%s: cannot read edge events: %s",
                        cd, strerror(e));
        }
        for (size_t j = 0; j < k && j < want; j++)
            take_event(req, &batch[j], &events[got++]);
        if (k < want)
            break; /* drained */
    }
    *n = got;
    return ok(err);
}

gw_gpio_status_t gw_gpio_request_input_value(gw_gpio_request_t *req,
                                             unsigned int offset,
                                             uint64_t now_ns, int *value,
                                             bool *changed,
                                             gw_gpio_error_t *err)
{
    struct gw_gpio_line *l;
    bool ch = false;
    size_t i;

    if (changed != NULL)
        *changed = false;
    if (req == NULL || value == NULL)
        return fail(err, GW_GPIO_EINVAL, EINVAL, "GPIO input: no request");
    i = index_of(req, offset, err);
    if (i == req->n)
        return GW_GPIO_ENOLINE;
    l = &req->line[i];
    if (l->cfg.direction != GW_GPIO_DIR_INPUT) {
        char ld[160];
        line_desc(req->chip, offset, ld, sizeof ld, NULL, 0);
        return fail(err, GW_GPIO_EDIRECTION, EPERM,
                    "%s: is an output; it has no input value", ld);
    }
    if (l->cfg.edge == GW_GPIO_EDGE_BOTH) {
        ch = gw_gpio_debounce_update(&l->deb, now_ns);
        *value = l->deb.stable;
    } else if (gw_gpio_be_get(req->be, i, value) != 0)
        return io_failed(req, i, "cannot read the input", errno, err);
    if (changed != NULL)
        *changed = ch;
    return ok(err);
}

uint64_t gw_gpio_request_next_deadline(const gw_gpio_request_t *req)
{
    uint64_t next = UINT64_MAX;

    if (req == NULL)
        return next;
    for (size_t i = 0; i < req->n; i++) {
        const struct gw_gpio_line *l = &req->line[i];
        uint64_t d;

        if (l->cfg.edge != GW_GPIO_EDGE_BOTH)
            continue;
        d = gw_gpio_debounce_deadline(&l->deb);
        if (d < next)
            next = d;
    }
    return next;
}

gw_gpio_status_t gw_gpio_request_sync_inputs(gw_gpio_request_t *req,
                                             uint64_t now_ns,
                                             gw_gpio_error_t *err)
{
    if (req == NULL)
        return fail(err, GW_GPIO_EINVAL, EINVAL, "GPIO sync: no request");
    for (size_t i = 0; i < req->n; i++) {
        struct gw_gpio_line *l = &req->line[i];
        int v;

        if (l->cfg.edge != GW_GPIO_EDGE_BOTH)
            continue;
        if (gw_gpio_be_get(req->be, i, &v) != 0)
            return io_failed(req, i, "cannot read the input", errno, err);
        /* Only a level the events did not announce counts as an edge;
         * re-feeding the same level would only postpone a pending one. */
        if ((v != 0) != l->deb.raw)
            gw_gpio_debounce_feed(&l->deb, v, now_ns);
    }
    return ok(err);
}

gw_gpio_status_t gw_gpio_request_release(gw_gpio_request_t *req,
                                         gw_gpio_error_t *err)
{
    gw_gpio_request_t **pp;
    gw_gpio_status_t st;

    if (req == NULL)
        return ok(err);
    for (pp = &req->chip->requests; *pp != NULL; pp = &(*pp)->next)
        if (*pp == req) {
            *pp = req->next;
            break;
        }
    /* Safe values first: after release the kernel returns the line to
     * its default, and the safe value must be what the cell saw last. */
    st = gw_gpio_set_safe(req, err);
    gw_gpio_be_release(req->be);
    free(req);
    return st;
}
