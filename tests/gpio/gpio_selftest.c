/* SPDX-License-Identifier: MIT */
/*
 * gateway/gpio/gpio.h against a real kernel GPIO chip: run inside the qemu
 * guest of tests/gpio/qemu (gpio-mockup loaded with
 * gpio_mockup_ranges=-1,8,-1,4 gpio_mockup_named_lines=1, debugfs and
 * tracefs mounted). The other side of every line is driven and read
 * through /sys/kernel/debug/gpio-mockup/gpiochipN/M; the kernel's gpio
 * trace events show what was written on release.
 *
 *   gpio_selftest                 all checks; "ok"/"not ok" lines and a
 *                                 closing "N passed, M failed"
 *   gpio_selftest --hold LINE     request gpiochip0 LINE as output, safe
 *                                 value 0, drive it to 1, print
 *                                 "holding", and on SIGTERM (or after
 *                                 30 s) release it like the daemon does
 */
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "gpio/gpio.h"

#define MOCKUP      "/sys/kernel/debug/gpio-mockup"
#define TRACING     "/sys/kernel/tracing"
#define CONSUMER    "gpio-selftest"
#define MS          1000000ull
#define DEBOUNCE_MS 200u /* long against TCG's jitter, short for the run */

static int passed, failed;

static void check(int cond, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;

static void check(int cond, const char *fmt, ...)
{
    va_list ap;

    printf("%s %d - ", cond ? "ok" : "not ok", passed + failed + 1);
    va_start(ap, fmt);
    vprintf(fmt, ap);
    va_end(ap);
    putchar('\n');
    (void)fflush(stdout);
    if (cond)
        passed++;
    else
        failed++;
}

static void sleep_ms(unsigned int ms)
{
    struct timespec ts = { (time_t)(ms / 1000), (long)(ms % 1000) * 1000000L };

    while (nanosleep(&ts, &ts) != 0 && errno == EINTR)
        ;
}

/* ---- the far side of the lines: debugfs and tracefs ------------------ */

static int write_file(const char *path, const char *text)
{
    int fd = open(path, O_WRONLY | O_TRUNC);
    ssize_t len = (ssize_t)strlen(text), w;

    if (fd < 0)
        return -1;
    w = write(fd, text, (size_t)len);
    close(fd);
    return w == len ? 0 : -1;
}

/* Reads up to cap-1 bytes of a small file; -1 if it cannot be read. */
static ssize_t read_file(const char *path, char *buf, size_t cap)
{
    int fd = open(path, O_RDONLY);
    size_t used = 0;
    ssize_t r;

    if (fd < 0)
        return -1;
    while (used + 1 < cap && (r = read(fd, buf + used, cap - 1 - used)) > 0)
        used += (size_t)r;
    close(fd);
    buf[used] = '\0';
    return (ssize_t)used;
}

/* The physical level of a mockup line as the chip sees it. */
static int far_read(const char *chip, unsigned int line)
{
    char path[96], buf[8];

    snprintf(path, sizeof path, MOCKUP "/%s/%u", chip, line);
    if (read_file(path, buf, sizeof buf) < 1)
        return -1;
    return buf[0] == '1';
}

/* Drives a mockup line from outside (its "pull"); inputs see it. */
static int far_write(const char *chip, unsigned int line, int value)
{
    char path[96];

    snprintf(path, sizeof path, MOCKUP "/%s/%u", chip, line);
    return write_file(path, value ? "1" : "0");
}

/* The chip's global GPIO base: trace events use global numbers. */
static int chip_base(const char *chip)
{
    static char buf[8192];
    char key[40];
    const char *p;
    char *end;
    unsigned long base;

    if (read_file("/sys/kernel/debug/gpio", buf, sizeof buf) < 0)
        return -1;
    snprintf(key, sizeof key, "%s: GPIOs ", chip);
    p = strstr(buf, key);
    if (p == NULL)
        return -1;
    p += strlen(key);
    errno = 0;
    base = strtoul(p, &end, 10);
    if (end == p || errno != 0 || base > INT_MAX)
        return -1;
    return (int)base;
}

static int trace_start(const char *marker)
{
    if (write_file(TRACING "/events/gpio/gpio_value/enable", "1") != 0)
        return -1;
    if (write_file(TRACING "/trace", "") != 0)
        return -1;
    return write_file(TRACING "/trace_marker", marker);
}

/* The last value the kernel set on global gpio after marker, or -1. */
static int trace_last_set(const char *marker, int gpio)
{
    static char buf[65536];
    const char *p;
    int last = -1;
    char key[48];

    if (read_file(TRACING "/trace", buf, sizeof buf) < 0)
        return -1;
    p = strstr(buf, marker);
    if (p == NULL)
        return -1;
    snprintf(key, sizeof key, "gpio_value: %d set ", gpio);
    while ((p = strstr(p, key)) != NULL) {
        p += strlen(key);
        last = *p == '1';
    }
    return last;
}

/* ---- helpers on the interface --------------------------------------- */

/* Waits (at most timeout_ms) for events of req and reads them. */
static size_t wait_events(gw_gpio_request_t *req, gw_gpio_event_t *ev,
                          size_t cap, int timeout_ms)
{
    struct pollfd pfd[GW_GPIO_MAX_LINES];
    int fds[GW_GPIO_MAX_LINES];
    size_t nfd = gw_gpio_request_fds(req, fds, GW_GPIO_MAX_LINES), n = 0;
    gw_gpio_error_t err;

    for (size_t i = 0; i < nfd; i++) {
        pfd[i].fd = fds[i];
        pfd[i].events = POLLIN;
    }
    if (poll(pfd, (nfds_t)nfd, timeout_ms) <= 0)
        return 0;
    if (gw_gpio_request_read_events(req, ev, cap, &n, &err) != GW_GPIO_OK) {
        printf("# read_events: %s\n", err.msg);
        return 0;
    }
    return n;
}

/* Logical value the interface reports for line, or -1 (with a note). */
static int get(gw_gpio_request_t *req, unsigned int line)
{
    gw_gpio_error_t err;
    int v;

    if (gw_gpio_request_get_value(req, line, &v, &err) != GW_GPIO_OK) {
        printf("# get %u: %s\n", line, err.msg);
        return -1;
    }
    return v;
}

static int set(gw_gpio_request_t *req, unsigned int line, int v)
{
    gw_gpio_error_t err;

    if (gw_gpio_request_set_value(req, line, v, &err) != GW_GPIO_OK) {
        printf("# set %u: %s\n", line, err.msg);
        return -1;
    }
    return 0;
}

static int input(gw_gpio_request_t *req, unsigned int line, bool *changed)
{
    gw_gpio_error_t err;
    int v;

    if (gw_gpio_request_input_value(req, line, gw_gpio_now_ns(), &v, changed,
                                    &err) != GW_GPIO_OK) {
        printf("# input %u: %s\n", line, err.msg);
        return -1;
    }
    return v;
}

/* ---- the checks ----------------------------------------------------- */

static void test_open(void)
{
    const char *specs[][2] = { { "gpiochip0", "gpiochip0" },
                               { "0", "gpiochip0" },
                               { "/dev/gpiochip1", "gpiochip1" },
                               { "gpio-mockup-B", "gpiochip1" } };
    gw_gpio_chip_t *chip;
    gw_gpio_error_t err;

    for (size_t i = 0; i < sizeof specs / sizeof specs[0]; i++) {
        gw_gpio_status_t st = gw_gpio_chip_open(specs[i][0], &chip, &err);
        check(st == GW_GPIO_OK &&
                  strcmp(gw_gpio_chip_name(chip), specs[i][1]) == 0,
              "open \"%s\" is %s", specs[i][0], specs[i][1]);
        if (st != GW_GPIO_OK)
            printf("# %s\n", err.msg);
        else if (i == 0)
            check(strcmp(gw_gpio_chip_label(chip), "gpio-mockup-A") == 0 &&
                      gw_gpio_chip_num_lines(chip) == 8,
                  "gpiochip0 is gpio-mockup-A with 8 lines (%s, %u)",
                  gw_gpio_chip_label(chip), gw_gpio_chip_num_lines(chip));
        gw_gpio_chip_close(chip);
    }
    check(gw_gpio_chip_open("gpiochip9", &chip, &err) == GW_GPIO_ENOCHIP &&
              strstr(err.msg, "\"gpiochip9\"") != NULL &&
              strstr(err.msg, "gpiochip0 [gpio-mockup-A, 8 lines]") != NULL,
          "missing chip: %s", err.msg);
    check(gw_gpio_chip_open("no-such-chip", &chip, &err) == GW_GPIO_ENOCHIP &&
              strstr(err.msg, "gpiochip1 [gpio-mockup-B, 4 lines]") != NULL,
          "unknown label: %s", err.msg);
}

static void test_find(gw_gpio_chip_t *chip)
{
    gw_gpio_error_t err;
    unsigned int off = 99;

    gw_gpio_status_t st;

    /* gpio_mockup_named_lines=1 names them "<label>-<offset>". Each call
     * comes before its check(): argument order is unspecified. */
    st = gw_gpio_chip_find_line(chip, "gpio-mockup-A-5", &off, &err);
    check(st == GW_GPIO_OK && off == 5, "line \"gpio-mockup-A-5\" is offset %u",
          off);
    st = gw_gpio_chip_find_line(chip, "7", &off, &err);
    check(st == GW_GPIO_OK && off == 7, "line \"7\" is offset %u", off);
    st = gw_gpio_chip_find_line(chip, "relay-9", &off, &err);
    check(st == GW_GPIO_ENOLINE &&
              strstr(err.msg, "gpiochip0 [gpio-mockup-A]") != NULL,
          "unknown line name: %s", err.msg);
    st = gw_gpio_chip_find_line(chip, "8", &off, &err);
    check(st == GW_GPIO_ENOLINE, "offset out of range: %s", err.msg);
}

/* The lines of the main request, by offset on gpiochip0. */
enum {
    OUT = 0,     /* output, safe 0 */
    OUT_LOW = 1, /* output, active-low, safe 0 (so physically high) */
    IN_EDGE = 2, /* input, both edges */
    IN_DEB = 3,  /* input, both edges, debounced */
    IN_UP = 4,   /* input, pull-up */
    IN_DOWN = 5, /* input, pull-down */
    IN_LOW = 6,  /* input, active-low, both edges */
    NLINES = 7
};

static gw_gpio_request_t *request_main(gw_gpio_chip_t *chip)
{
    gw_gpio_line_config_t l[NLINES];
    gw_gpio_request_config_t cfg = { CONSUMER, l, NLINES };
    gw_gpio_request_t *req = NULL;
    gw_gpio_error_t err;
    gw_gpio_status_t st;

    memset(l, 0, sizeof l);
    for (unsigned int i = 0; i < NLINES; i++)
        l[i].offset = i;
    l[OUT].direction = GW_GPIO_DIR_OUTPUT;
    l[OUT_LOW].direction = GW_GPIO_DIR_OUTPUT;
    l[OUT_LOW].active_low = true;
    l[IN_EDGE].edge = GW_GPIO_EDGE_BOTH;
    l[IN_DEB].edge = GW_GPIO_EDGE_BOTH;
    l[IN_DEB].debounce_us = DEBOUNCE_MS * 1000u;
    l[IN_UP].bias = GW_GPIO_BIAS_PULL_UP;
    l[IN_DOWN].bias = GW_GPIO_BIAS_PULL_DOWN;
    l[IN_LOW].edge = GW_GPIO_EDGE_BOTH;
    l[IN_LOW].active_low = true;
    st = gw_gpio_chip_request_lines(chip, &cfg, &req, &err);
    check(st == GW_GPIO_OK, "request 7 mixed lines%s%s", st ? ": " : "",
          st ? err.msg : "");
    return req;
}

static void test_outputs(gw_gpio_request_t *req)
{
    int a = far_read("gpiochip0", OUT), b = far_read("gpiochip0", OUT_LOW);
    gw_gpio_status_t st;

    check(a == 0 && b == 1,
          "outputs start at their safe values (physical %d %d)", a, b);
    set(req, OUT, 1);
    set(req, OUT_LOW, 1);
    check(far_read("gpiochip0", OUT) == 1, "output set to 1 reads 1");
    check(far_read("gpiochip0", OUT_LOW) == 0,
          "active-low output set to 1 is physically 0");
    check(get(req, OUT_LOW) == 1, "active-low output reads back logical 1");
    st = gw_gpio_set_safe(req, NULL);
    a = far_read("gpiochip0", OUT);
    b = far_read("gpiochip0", OUT_LOW);
    check(st == GW_GPIO_OK && a == 0 && b == 1,
          "set_safe puts both outputs back (physical %d %d)", a, b);
}

static void test_bias(gw_gpio_request_t *req)
{
    /* gpio-mockup turns a bias request into the line's pull. */
    check(get(req, IN_UP) == 1, "pull-up input reads 1");
    check(get(req, IN_DOWN) == 0, "pull-down input reads 0");
}

static void test_edges(gw_gpio_request_t *req)
{
    gw_gpio_event_t ev[8];
    uint64_t t0 = gw_gpio_now_ns(), t1;
    size_t n;

    n = wait_events(req, ev, 8, 0);
    check(n == 0, "no events before anything moves (%lu)", (unsigned long)n);
    far_write("gpiochip0", IN_EDGE, 1);
    n = wait_events(req, ev, 8, 2000);
    t1 = gw_gpio_now_ns();
    check(n == 1 && ev[0].offset == IN_EDGE &&
              ev[0].type == GW_GPIO_EVENT_RISING,
          "rising edge arrives through the fd (%lu events)", (unsigned long)n);
    check(n == 1 && ev[0].timestamp_ns >= t0 && ev[0].timestamp_ns <= t1,
          "its timestamp is on CLOCK_MONOTONIC");
    far_write("gpiochip0", IN_EDGE, 0);
    n = wait_events(req, ev, 8, 2000);
    check(n == 1 && ev[0].type == GW_GPIO_EVENT_FALLING &&
              ev[0].line_seqno == 2,
          "falling edge, line seqno 2 (got %lu)",
          n ? (unsigned long)ev[0].line_seqno : 0ul);
    check(input(req, IN_EDGE, NULL) == 0, "undebounced input follows at once");

    /* Active-low input: physical 0 at rest reads 1; driving it high is
     * a logical falling edge. */
    check(input(req, IN_LOW, NULL) == 1, "active-low input at rest is 1");
    far_write("gpiochip0", IN_LOW, 1);
    n = wait_events(req, ev, 8, 2000);
    check(n == 1 && ev[0].offset == IN_LOW &&
              ev[0].type == GW_GPIO_EVENT_FALLING,
          "active-low input driven high gives a falling edge");
    check(input(req, IN_LOW, NULL) == 0, "and reads 0");
    far_write("gpiochip0", IN_LOW, 0);
    wait_events(req, ev, 8, 2000);
}

/* Feeds events and polls until the debounced value is want or the time
 * is up; returns the ms it took, or -1. */
static long settle(gw_gpio_request_t *req, unsigned int line, int want,
                   unsigned int max_ms)
{
    uint64_t start = gw_gpio_now_ns(), end = start + max_ms * MS;
    gw_gpio_event_t ev[16];

    for (;;) {
        uint64_t now = gw_gpio_now_ns(), dl;
        int timeout;

        if (input(req, line, NULL) == want)
            return (long)((now - start) / MS);
        if (now >= end)
            return -1;
        dl = gw_gpio_request_next_deadline(req);
        dl = dl < end ? dl : end;
        timeout = dl > now ? (int)((dl - now + MS - 1) / MS) : 0;
        wait_events(req, ev, 16, timeout > 0 ? timeout : 1);
    }
}

static void test_debounce(gw_gpio_request_t *req)
{
    gw_gpio_event_t ev[16];
    long ms;

    check(input(req, IN_DEB, NULL) == 0, "debounced input starts at 0");
    /* A glitch far shorter than the period. */
    far_write("gpiochip0", IN_DEB, 1);
    far_write("gpiochip0", IN_DEB, 0);
    wait_events(req, ev, 16, 50);
    check(settle(req, IN_DEB, 1, DEBOUNCE_MS + 150) < 0,
          "a glitch shorter than %u ms is ignored", DEBOUNCE_MS);
    /* A real change shows after the period, not before. */
    far_write("gpiochip0", IN_DEB, 1);
    wait_events(req, ev, 16, 20);
    check(input(req, IN_DEB, NULL) == 0, "a new level is not taken at once");
    ms = settle(req, IN_DEB, 1, DEBOUNCE_MS + 2000);
    check(ms >= (long)DEBOUNCE_MS - 40,
          "a held level is taken after the period (%ld ms, period %u)", ms,
          DEBOUNCE_MS);
    far_write("gpiochip0", IN_DEB, 0);
    ms = settle(req, IN_DEB, 0, DEBOUNCE_MS + 2000);
    check(ms >= 0, "and back to 0 (%ld ms)", ms);
}

static void test_errors(gw_gpio_chip_t *chip, gw_gpio_request_t *req)
{
    gw_gpio_line_config_t l = { 0 };
    gw_gpio_request_config_t cfg = { "intruder", &l, 1 };
    gw_gpio_request_t *other = NULL;
    gw_gpio_chip_t *again = NULL;
    gw_gpio_error_t err;

    check(gw_gpio_request_set_value(req, IN_EDGE, 1, &err) ==
              GW_GPIO_EDIRECTION,
          "setting an input is refused: %s", err.msg);
    /* Another open of the chip competes like another process would. */
    gw_gpio_chip_open("gpiochip0", &again, NULL);
    l.offset = OUT;
    check(again != NULL &&
              gw_gpio_chip_request_lines(again, &cfg, &other, &err) ==
                  GW_GPIO_EBUSY &&
              strstr(err.msg, "line 0 \"gpio-mockup-A-0\"") != NULL &&
              strstr(err.msg, "used by \"" CONSUMER "\"") != NULL,
          "a held line is busy, and says who holds it: %s", err.msg);
    gw_gpio_request_release(other, NULL);
    gw_gpio_chip_close(again);
    (void)chip;
}

static void test_release(gw_gpio_request_t *req)
{
    const char *marker = "drgate-selftest-release";
    int base = chip_base("gpiochip0");
    gw_gpio_error_t err;

    set(req, OUT, 1);
    set(req, OUT_LOW, 1);
    if (base < 0 || trace_start(marker) != 0) {
        check(1, "# SKIP release trace: no tracefs or gpio base");
        gw_gpio_request_release(req, NULL);
        return;
    }
    check(gw_gpio_request_release(req, &err) == GW_GPIO_OK, "release succeeds");
    /* The kernel traces physical values: safe 0 on the active-low line
     * is a 1. Nothing sets values after the release itself. */
    check(trace_last_set(marker, base + OUT) == 0 &&
              trace_last_set(marker, base + OUT_LOW) == 1,
          "release wrote the safe values last (trace: %d %d)",
          trace_last_set(marker, base + OUT),
          trace_last_set(marker, base + OUT_LOW));
}

static volatile sig_atomic_t stop;

static void on_term(int sig)
{
    (void)sig;
    stop = 1;
}

/* The daemon's lifetime in miniature, for the script's own checks. */
static int hold(unsigned int line)
{
    gw_gpio_line_config_t l = { 0 };
    gw_gpio_request_config_t cfg = { CONSUMER, &l, 1 };
    gw_gpio_request_t *req = NULL;
    gw_gpio_chip_t *chip = NULL;
    gw_gpio_error_t err;
    struct sigaction sa;

    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_term;
    sigaction(SIGTERM, &sa, NULL);
    l.offset = line;
    l.direction = GW_GPIO_DIR_OUTPUT;
    if (gw_gpio_chip_open("gpiochip0", &chip, &err) != GW_GPIO_OK ||
        gw_gpio_chip_request_lines(chip, &cfg, &req, &err) != GW_GPIO_OK ||
        gw_gpio_request_set_value(req, line, 1, &err) != GW_GPIO_OK) {
        fprintf(stderr, "gpio_selftest: %s\n", err.msg);
        gw_gpio_chip_close(chip);
        return 1;
    }
    printf("holding\n");
    (void)fflush(stdout);
    for (int i = 0; i < 300 && !stop; i++)
        sleep_ms(100);
    if (gw_gpio_request_release(req, &err) != GW_GPIO_OK)
        fprintf(stderr, "gpio_selftest: %s\n", err.msg);
    gw_gpio_chip_close(chip);
    printf("released\n");
    return stop ? 0 : 2;
}

int main(int argc, char **argv)
{
    gw_gpio_chip_t *chip = NULL;
    gw_gpio_request_t *req;
    gw_gpio_error_t err;

    if (argc == 3 && strcmp(argv[1], "--hold") == 0)
        return hold((unsigned int)strtoul(argv[2], NULL, 10));
    printf("# backend: %s\n", gw_gpio_backend());
    test_open();
    if (gw_gpio_chip_open("gpio-mockup-A", &chip, &err) != GW_GPIO_OK) {
        printf("not ok - open gpio-mockup-A: %s\n", err.msg);
        return 1;
    }
    test_find(chip);
    req = request_main(chip);
    if (req != NULL) {
        test_outputs(req);
        test_bias(req);
        test_edges(req);
        test_debounce(req);
        test_errors(chip, req);
        test_release(req);
    }
    gw_gpio_chip_close(chip);
    printf("gpio_selftest: %d passed, %d failed\n", passed, failed);
    return failed == 0 && passed > 0 ? 0 : 1;
}
