/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd GPIO: kernel GPIO lines behind a small interface shaped like
 * libgpiod 2's line requests.
 *
 * Open a chip, resolve lines by offset or name, request a set of lines once
 * for the daemon's lifetime, then get/set logical values and read edge
 * events from pollable descriptors. Two backends implement it, chosen at
 * build time: gpio_v1.c on libgpiod 1.6 (Debian bookworm) and gpio_v2.c on
 * libgpiod >= 2.0.
 *
 * Values are logical everywhere: the kernel applies active-low, so 1 means
 * "active" and that is what Modbus sees.
 *
 * Safety: every output has a safe value. It is the value the line is
 * requested with, gw_gpio_set_safe() writes it on every fault path, and
 * gw_gpio_request_release() writes it before letting the line go (the
 * kernel then returns the line to its hardware default, which should be
 * the safe state too).
 *
 * Errors: functions return a gw_gpio_status_t and, when err is not NULL,
 * fill *err with the code, the errno behind it and a message that names
 * the chip and the line, e.g.
 *   gpiochip0 [gpio-mockup-A] line 3 "relay": cannot request as output:
 *   Device or resource busy (used by "gpioset")
 *
 * Threads: none inside; a chip and its requests belong to one thread.
 * Memory: opening a chip and requesting lines allocate; get/set, events
 * and debouncing do not.
 */
#ifndef DRGATE_GATEWAY_GPIO_H
#define DRGATE_GATEWAY_GPIO_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* X(name, text): the enum and the strings come from this one list. */
#define GW_GPIO_STATUS_LIST(X)                                            \
    X(GW_GPIO_OK, "success")                                              \
    X(GW_GPIO_EINVAL, "invalid argument or line configuration")           \
    X(GW_GPIO_ENOCHIP, "no such GPIO chip")                               \
    X(GW_GPIO_ENOLINE, "no such GPIO line")                               \
    X(GW_GPIO_EBUSY, "GPIO line already in use")                          \
    X(GW_GPIO_EPERM, "permission denied")                                 \
    X(GW_GPIO_ENOTSUP, "not supported by this kernel, driver or backend") \
    X(GW_GPIO_EDIRECTION, "wrong line direction for this operation")      \
    X(GW_GPIO_ENOMEM, "out of memory")                                    \
    X(GW_GPIO_EIO, "GPIO I/O error")

typedef enum {
#define GW_GPIO_STATUS_ENUM(name, text) name,
    GW_GPIO_STATUS_LIST(GW_GPIO_STATUS_ENUM)
#undef GW_GPIO_STATUS_ENUM
        GW_GPIO_STATUS_COUNT
} gw_gpio_status_t;

/* What went wrong, for logs: code, errno (0 if none) and a full sentence. */
typedef struct {
    gw_gpio_status_t code;
    int sys_errno;
    char msg[320];
} gw_gpio_error_t;

/* Lines per request; the kernel's v2 uAPI limit (GPIO_V2_LINES_MAX). */
#define GW_GPIO_MAX_LINES 64
/* Longest consumer label the kernel keeps (GPIO_MAX_NAME_SIZE - 1). */
#define GW_GPIO_NAME_MAX 31

typedef enum { GW_GPIO_DIR_INPUT = 0, GW_GPIO_DIR_OUTPUT } gw_gpio_direction_t;

typedef enum {
    GW_GPIO_BIAS_AS_IS = 0, /* leave whatever firmware/DT configured */
    GW_GPIO_BIAS_DISABLE,
    GW_GPIO_BIAS_PULL_UP,
    GW_GPIO_BIAS_PULL_DOWN
} gw_gpio_line_bias_t;

typedef enum { GW_GPIO_EDGE_NONE = 0, GW_GPIO_EDGE_BOTH } gw_gpio_edge_t;

/* One line of a request. Zero-initialised means: input, active-high,
 * bias as-is, no edge events, no debounce. */
typedef struct {
    unsigned int offset;
    gw_gpio_direction_t direction;
    bool active_low;
    gw_gpio_line_bias_t bias;
    gw_gpio_edge_t edge;  /* inputs only */
    uint32_t debounce_us; /* inputs with edge BOTH only; 0: none */
    int safe_value;       /* outputs: logical 0 or 1 */
} gw_gpio_line_config_t;

typedef struct {
    const char *consumer; /* shown by gpioinfo; NULL: "drgatewayd" */
    const gw_gpio_line_config_t *lines;
    size_t num_lines; /* 1..GW_GPIO_MAX_LINES */
} gw_gpio_request_config_t;

typedef enum {
    GW_GPIO_EVENT_RISING = 1, /* the line became logically 1 */
    GW_GPIO_EVENT_FALLING = 2 /* the line became logically 0 */
} gw_gpio_event_type_t;

typedef struct {
    unsigned int offset;
    gw_gpio_event_type_t type;
    uint64_t timestamp_ns; /* kernel time of the edge, CLOCK_MONOTONIC */
    uint64_t line_seqno;   /* 1, 2, ... per line (v2: the kernel's) */
} gw_gpio_event_t;

typedef struct gw_gpio_chip gw_gpio_chip_t;
typedef struct gw_gpio_request gw_gpio_request_t;

/* Static text of a status code; never NULL. */
const char *gw_gpio_strerror(gw_gpio_status_t status);

/* The backend compiled in, e.g. "libgpiod 1.6.3 (v1 API)". Static. */
const char *gw_gpio_backend(void);

/* CLOCK_MONOTONIC in ns: the clock of event timestamps and debouncing. */
uint64_t gw_gpio_now_ns(void);

/* ---- chips ---------------------------------------------------------- */

/* Opens a chip named by spec: a path ("/dev/gpiochip0"), a kernel name
 * ("gpiochip0"), a number ("0") or a label ("gpio-mockup-A", "pinctrl-
 * bcm2711"). A label must match exactly one chip. On success *out owns
 * the chip (close with gw_gpio_chip_close). ENOCHIP (the message lists
 * the chips present), EPERM, EINVAL (ambiguous label). */
gw_gpio_status_t gw_gpio_chip_open(const char *spec, gw_gpio_chip_t **out,
                                   gw_gpio_error_t *err);

/* Releases the chip's remaining requests (safe values first, as
 * gw_gpio_request_release does), then closes it. NULL is fine. */
void gw_gpio_chip_close(gw_gpio_chip_t *chip);

const char *gw_gpio_chip_name(const gw_gpio_chip_t *chip);  /* gpiochip0 */
const char *gw_gpio_chip_label(const gw_gpio_chip_t *chip); /* driver's */
const char *gw_gpio_chip_path(const gw_gpio_chip_t *chip);  /* /dev/... */
unsigned int gw_gpio_chip_num_lines(const gw_gpio_chip_t *chip);

/* Resolves a line given as a decimal offset ("3") or a line name
 * ("gpio-mockup-A-3"); digits always mean an offset. ENOLINE. */
gw_gpio_status_t gw_gpio_chip_find_line(gw_gpio_chip_t *chip, const char *spec,
                                        unsigned int *offset,
                                        gw_gpio_error_t *err);

/* ---- requests ------------------------------------------------------- */

/* Requests cfg's lines in one go: all or none. Outputs start at their
 * safe value. The configuration is copied. On success *out owns the
 * request (release with gw_gpio_request_release; it also goes when the
 * chip is closed). EINVAL (bad configuration, duplicate offset), ENOLINE,
 * EBUSY (the message names the line and its current consumer), EPERM,
 * ENOMEM; EINVAL also when the kernel refuses a flag it does not know
 * (bias before Linux 5.5). A driver that cannot bias ignores the bias. */
gw_gpio_status_t gw_gpio_chip_request_lines(gw_gpio_chip_t *chip,
                                            const gw_gpio_request_config_t *cfg,
                                            gw_gpio_request_t **out,
                                            gw_gpio_error_t *err);

/* Current logical level of a requested line (inputs: not debounced).
 * ENOLINE if offset is not in the request, EIO. */
gw_gpio_status_t gw_gpio_request_get_value(gw_gpio_request_t *req,
                                           unsigned int offset, int *value,
                                           gw_gpio_error_t *err);

/* Drives an output to a logical value (any non-zero is 1).
 * EDIRECTION for inputs, ENOLINE, EIO. */
gw_gpio_status_t gw_gpio_request_set_value(gw_gpio_request_t *req,
                                           unsigned int offset, int value,
                                           gw_gpio_error_t *err);

/* Writes every output's safe value. Tries all lines even if one fails and
 * reports the first failure. Call it on every fault path (robot link
 * loss, watchdog expiry, SIGTERM). NULL is fine (GW_GPIO_OK). */
gw_gpio_status_t gw_gpio_set_safe(gw_gpio_request_t *req, gw_gpio_error_t *err);

/* Descriptors to poll for POLLIN (edge events): one per request on v2,
 * one per edge-detecting line on v1. Copies up to cap into fds and
 * returns how many there are in all. Valid until release. */
size_t gw_gpio_request_fds(const gw_gpio_request_t *req, int *fds, size_t cap);

/* Reads the edge events pending now, up to cap, without blocking
 * (*n = 0 when there are none), and feeds them to the lines' debouncers.
 * Events left over stay pending (the fd stays readable). EIO. */
gw_gpio_status_t gw_gpio_request_read_events(gw_gpio_request_t *req,
                                             gw_gpio_event_t *events,
                                             size_t cap, size_t *n,
                                             gw_gpio_error_t *err);

/* The value an input line stands for at now_ns: debounced for lines with
 * edge events (see the debouncer below), read from the line otherwise.
 * *changed (may be NULL) tells whether the debounced value changed in
 * this call. EDIRECTION for outputs, ENOLINE, EIO. */
gw_gpio_status_t gw_gpio_request_input_value(gw_gpio_request_t *req,
                                             unsigned int offset,
                                             uint64_t now_ns, int *value,
                                             bool *changed,
                                             gw_gpio_error_t *err);

/* Earliest time (CLOCK_MONOTONIC ns) at which a debounced input may
 * settle; UINT64_MAX when none is pending. Arm the loop's timer with it. */
uint64_t gw_gpio_request_next_deadline(const gw_gpio_request_t *req);

/* Reads every edge-detecting input and feeds a level the debouncer did
 * not see as an edge, so an event lost to a full kernel queue cannot
 * leave a stale value for long. Call it from a slow timer. EIO. */
gw_gpio_status_t gw_gpio_request_sync_inputs(gw_gpio_request_t *req,
                                             uint64_t now_ns,
                                             gw_gpio_error_t *err);

/* Writes the safe values, then releases the lines and frees req (always,
 * even when a write failed: the status reports that failure). NULL is
 * fine. */
gw_gpio_status_t gw_gpio_request_release(gw_gpio_request_t *req,
                                         gw_gpio_error_t *err);

/* ---- software debounce (pure, no I/O) ------------------------------- */

/* A level counts once it has held, with no further edge, for the period:
 * a pulse shorter than the period is ignored, and a real change shows
 * up one period after its last bounce. Period 0 passes every edge
 * through. Times are ns on one monotonic clock; they may repeat but an
 * edge older than the last one is taken as simultaneous with it. */
typedef struct {
    uint64_t period_ns;
    uint64_t last_edge_ns; /* time of the latest edge fed */
    int stable;            /* the debounced value (0/1) */
    int raw;               /* the level after the latest edge (0/1) */
} gw_gpio_debounce_t;

void gw_gpio_debounce_init(gw_gpio_debounce_t *d, uint64_t period_ns, int value,
                           uint64_t now_ns);

/* An edge at ts_ns after which the line reads value. */
void gw_gpio_debounce_feed(gw_gpio_debounce_t *d, int value, uint64_t ts_ns);

/* Settles the value if it has held long enough by now_ns; returns true
 * when d->stable changed in this call. */
bool gw_gpio_debounce_update(gw_gpio_debounce_t *d, uint64_t now_ns);

/* When update() could next change stable; UINT64_MAX if nothing pends. */
uint64_t gw_gpio_debounce_deadline(const gw_gpio_debounce_t *d);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_GATEWAY_GPIO_H */
