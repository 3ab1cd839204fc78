/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd configuration loader (config.h, docs/configuration.md).
 *
 * libinih does the INI syntax; this file gives the sections and keys their
 * meaning, checks every value, and then checks what spans sections (unique
 * unit IDs, one GPIO line used once, ...).
 *
 * Debian bookworm's libinih (r55) is built without INI_HANDLER_LINENO and
 * without INI_CALL_HANDLER_ON_NEW_SECTION, so by itself it tells the handler
 * neither the line number nor that a section began. We parse through
 * ini_parse_stream() with our own line reader instead:
 *  - the reader counts lines; libinih calls the handler for a line before
 *    it reads the next one, so the count is the handler's line number;
 *  - when a line starts with '[', the reader asks libinih itself for the
 *    section name (ini_parse_string on that one line), so sections are
 *    seen when they start, even empty ones ("[robot arm2]" with no keys
 *    must not vanish), and a repeated "[modbus]" is told apart;
 *  - it refuses what r55 would otherwise do silently: an indented line
 *    continues the previous value (Python configparser style), so
 *    "  port = 502" would end up inside the key above it; and a line longer
 *    than libinih's buffer is split, its tail read as a line of its own.
 *
 * Everything is parsed into a heap temporary and checked to the end before
 * *out is written: a bad file, or a bad reload, never half-applies.
 */
#include "config.h"

#include <arpa/inet.h>
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ini.h>

#if defined(__GNUC__)
#define GW_PRINTF(f, a) __attribute__((format(printf, f, a)))
#else
#define GW_PRINTF(f, a)
#endif

/* ---- keys of each section --------------------------------------------- */

/* `allowed` is what "has no value (allowed: ...)" shows; parsers of ranged
 * numbers print their range themselves. */
typedef struct {
    const char *name;
    const char *allowed;
} key_desc_t;

enum { DK_LOG_LEVEL, DK_COUNT };
static const key_desc_t daemon_keys[DK_COUNT] = {
    [DK_LOG_LEVEL] = { "log_level", "error, warning, info, debug" },
};

enum {
    MK_LISTEN,
    MK_PORT,
    MK_MAX_CLIENTS,
    MK_IDLE_TIMEOUT,
    MK_KEEPALIVE,
    MK_WORD_ORDER,
    MK_ALLOW,
    MK_ON_LINK_LOSS,
    MK_UNMAPPED_READ,
    MK_SINGLE_WRITER,
    MK_WRITER_WATCHDOG_MS,
    MK_REQUEST_TIMEOUT_MS,
    MK_COUNT
};
static const key_desc_t modbus_keys[MK_COUNT] = {
    [MK_LISTEN] = { "listen", "an IPv4 address such as 0.0.0.0" },
    [MK_PORT] = { "port", "1..65535" },
    [MK_MAX_CLIENTS] = { "max_clients", "1..256" },
    [MK_IDLE_TIMEOUT] = { "idle_timeout", "0..86400 seconds, 0 = never" },
    [MK_KEEPALIVE] = { "keepalive", "yes, no" },
    [MK_WORD_ORDER] = { "word_order", "abcd, cdab, badc, dcba" },
    [MK_ALLOW] = { "allow", "a.b.c.d/len [ro|rw]" },
    [MK_ON_LINK_LOSS] = { "on_link_loss", "hold, zero, exception" },
    [MK_UNMAPPED_READ] = { "unmapped_read", "zero, exception" },
    [MK_SINGLE_WRITER] = { "single_writer", "yes, no" },
    [MK_WRITER_WATCHDOG_MS] = { "writer_watchdog_ms", "10..60000" },
    [MK_REQUEST_TIMEOUT_MS] = { "request_timeout_ms", "100..60000" },
};

enum {
    RK_HOST,
    RK_TCP_PORT,
    RK_UDP_PORT,
    RK_LOCAL_ADDRESS,
    RK_LOCAL_UDP_PORT,
    RK_UNIT_ID,
    RK_MODE,
    RK_RPI_MS,
    RK_TIMEOUT_MULTIPLIER,
    RK_TIMEOUT_MS,
    RK_FALLBACK,
    RK_O2T_TIMING,
    RK_CONFIG_INSTANCE,
    RK_INPUT_ONLY_HEARTBEAT,
    RK_LISTEN_ONLY_HEARTBEAT,
    RK_ORIGINATOR_SERIAL,
    RK_COUNT
};
static const key_desc_t robot_keys[RK_COUNT] = {
    [RK_HOST] = { "host", "an IPv4 address or a host name" },
    [RK_TCP_PORT] = { "tcp_port", "1..65535" },
    [RK_UDP_PORT] = { "udp_port", "1..65535" },
    [RK_LOCAL_ADDRESS] = { "local_address", "an IPv4 address" },
    [RK_LOCAL_UDP_PORT] = { "local_udp_port", "1..65535" },
    [RK_UNIT_ID] = { "unit_id", "1..247" },
    [RK_MODE] = { "mode", "implicit, explicit" },
    [RK_RPI_MS] = { "rpi_ms", "1..10000" },
    [RK_TIMEOUT_MULTIPLIER] = { "timeout_multiplier", "0..7" },
    [RK_TIMEOUT_MS] = { "timeout_ms", "10..60000" },
    [RK_FALLBACK] = { "fallback", "zero, hold" },
    [RK_O2T_TIMING] = { "o2t_timing", "follow, strict" },
    [RK_CONFIG_INSTANCE] = { "config_instance", "1..65535" },
    [RK_INPUT_ONLY_HEARTBEAT] = { "input_only_heartbeat", "1..65535" },
    [RK_LISTEN_ONLY_HEARTBEAT] = { "listen_only_heartbeat", "1..65535" },
    [RK_ORIGINATOR_SERIAL] = { "originator_serial", "1..4294967295, or 0x1..0xFFFFFFFF" },
};
#define INSTANCE_PREFIX "instance."
#define OPEN_PREFIX "open."
#define OPEN_ALLOWED "owner:<O->T assembly>, input_only, listen_only, none"

enum {
    UK_DEVICE,
    UK_BAUD,
    UK_PARITY,
    UK_DATA_BITS,
    UK_STOP_BITS,
    UK_RS485,
    UK_RTS_ON_SEND,
    UK_RTS_BEFORE_MS,
    UK_RTS_AFTER_MS,
    UK_READ_ONLY,
    UK_ROBOTS,
    UK_COUNT
};
static const key_desc_t rtu_keys[UK_COUNT] = {
    [UK_DEVICE] = { "device", "a serial port such as /dev/ttyS0" },
    [UK_BAUD] = { "baud", "1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400" },
    [UK_PARITY] = { "parity", "none, even, odd" },
    [UK_DATA_BITS] = { "data_bits", "8" },
    [UK_STOP_BITS] = { "stop_bits", "1, 2" },
    [UK_RS485] = { "rs485", "yes, no" },
    [UK_RTS_ON_SEND] = { "rts_on_send", "high, low" },
    [UK_RTS_BEFORE_MS] = { "rts_delay_before_ms", "0..100" },
    [UK_RTS_AFTER_MS] = { "rts_delay_after_ms", "0..100" },
    [UK_READ_ONLY] = { "read_only", "yes, no" },
    [UK_ROBOTS] = { "robots", "robot names, each optionally NAME:ADDRESS (1..247)" },
};
/* The kernel keeps line names to GPIO_MAX_NAME_SIZE - 1 characters: a
 * longer name can never match. */
#define GPIO_LINE_NAME_MAX 31

enum {
    GK_CHIP,
    GK_LINE,
    GK_DIRECTION,
    GK_ROBOT,
    GK_FIELD,
    GK_ACTIVE_LOW,
    GK_BIAS,
    GK_DEBOUNCE_MS,
    GK_SAFE_VALUE,
    GK_COUNT
};
static const key_desc_t gpio_keys[GK_COUNT] = {
    [GK_CHIP] = { "chip", "gpiochipN, /dev/gpiochipN or a chip label" },
    [GK_LINE] = { "line", "a line offset or a line name" },
    [GK_DIRECTION] = { "direction", "input, output" },
    [GK_ROBOT] = { "robot", "the NAME of a [robot NAME] section" },
    [GK_FIELD] = { "field", "one bit, e.g. io_state.cb_do[1] or bit_in[0]" },
    [GK_ACTIVE_LOW] = { "active_low", "yes, no" },
    [GK_BIAS] = { "bias", "as-is, disable, pull-up, pull-down" },
    [GK_DEBOUNCE_MS] = { "debounce_ms", "0..1000" },
    [GK_SAFE_VALUE] = { "safe_value", "0, 1" },
};

enum {
    QK_HOST,
    QK_PORT,
    QK_CLIENT_ID,
    QK_USERNAME,
    QK_PASSWORD_FILE,
    QK_CA_FILE,
    QK_CERT_FILE,
    QK_KEY_FILE,
    QK_KEEPALIVE_S,
    QK_QOS,
    QK_TOPIC_PREFIX,
    QK_RETAIN,
    QK_PUBLISH_INTERVAL_MS,
    QK_DEADBAND,
    QK_WRITES,
    QK_COUNT
};
static const key_desc_t mqtt_keys[QK_COUNT] = {
    [QK_HOST] = { "host", "the broker's IPv4 address or host name" },
    [QK_PORT] = { "port", "1..65535" },
    [QK_CLIENT_ID] = { "client_id", "letters, digits, '_', '-', '.'" },
    [QK_USERNAME] = { "username", "a user name" },
    [QK_PASSWORD_FILE] = { "password_file", "a file whose first line is the password" },
    [QK_CA_FILE] = { "ca_file", "a PEM file of CA certificates (enables TLS)" },
    [QK_CERT_FILE] = { "cert_file", "a PEM client certificate" },
    [QK_KEY_FILE] = { "key_file", "a PEM private key" },
    [QK_KEEPALIVE_S] = { "keepalive_s", "5..3600" },
    [QK_QOS] = { "qos", "0..2" },
    [QK_TOPIC_PREFIX] = { "topic_prefix", "topic levels such as drgate/cell1" },
    [QK_RETAIN] = { "retain", "yes, no" },
    [QK_PUBLISH_INTERVAL_MS] = { "publish_interval_ms", "0..60000" },
    [QK_DEADBAND] = { "deadband", "a number >= 0" },
    [QK_WRITES] = { "writes", "yes, no" },
};

static const char *const yes_no[] = { "yes", "no" };
static const char *const log_levels[] = { "error", "warning", "info", "debug" };
static const char *const word_orders[] = { "abcd", "cdab", "badc", "dcba" };
static const char *const link_loss_names[] = { "hold", "zero", "exception" };
static const char *const unmapped_names[] = { "zero", "exception" };
static const char *const mode_names[] = { "implicit", "explicit" };
static const char *const fallback_names[] = { "zero", "hold" };
static const char *const o2t_timing_names[] = { "follow", "strict" };
static const char *const dir_names[] = { "output", "input" };
static const char *const bias_names[] = { "as-is", "disable", "pull-up",
                                          "pull-down" };
static const char *const safe_names[] = { "0", "1" };
static const char *const parity_names[] = { "none", "even", "odd" };
static const char *const rts_names[] = { "high", "low" };
#define COUNT(a) (sizeof(a) / sizeof((a)[0]))

#define SECTIONS_ALLOWED "[daemon], [modbus], [robot NAME], [gpio NAME], [modbus_rtu NAME], [mqtt]"

/* ---- parse state -------------------------------------------------------- */

typedef enum {
    SEC_NONE,
    SEC_DAEMON,
    SEC_MODBUS,
    SEC_ROBOT,
    SEC_GPIO,
    SEC_RTU,
    SEC_MQTT
} sec_kind_t;

/* Where each key was set (0: not set), for "repeated" and for messages
 * about a key that only turn out wrong once the whole file is read. */
typedef struct {
    unsigned key[RK_COUNT];
    unsigned instance[DR_ASM_COUNT];
    unsigned open[DR_ASM_COUNT];
} robot_lines_t;

typedef struct {
    unsigned key[GK_COUNT];
} gpio_lines_t;

typedef struct {
    unsigned key[UK_COUNT];
    /* robots = ...: the names as written, resolved once all robots are read */
    char robot[GW_MAX_ROBOTS][GW_NAME_MAX];
    bool addr_given[GW_MAX_ROBOTS];
} rtu_lines_t;

typedef struct {
    FILE *fp;
    const char *path;
    unsigned lineno; /* lines read so far = the line being parsed */
    gw_config_t cfg; /* the temporary */

    /* The section being read, as the reader saw it start. */
    sec_kind_t sec;
    unsigned idx;      /* robot or gpio index */
    char sec_raw[64];  /* exactly as libinih reports it */
    char sec_text[64]; /* trimmed, for messages: "robot arm1" */

    unsigned daemon_line, modbus_line; /* header lines, 0: none yet */
    unsigned daemon_key[DK_COUNT];
    unsigned modbus_key[MK_COUNT];
    unsigned allow_line[GW_MAX_ALLOW];
    robot_lines_t robot[GW_MAX_ROBOTS];
    gpio_lines_t gpio[GW_MAX_GPIO];
    rtu_lines_t rtu[GW_MAX_RTU];
    unsigned mqtt_key[QK_COUNT];

    unsigned bad_header_line; /* a '[' line libinih will reject */
    unsigned err_line;        /* 0: no error yet; the first one wins */
    char err[512];
} ctx_t;

static void fail(ctx_t *c, unsigned line, const char *fmt, ...) GW_PRINTF(3, 4);

static void fail(ctx_t *c, unsigned line, const char *fmt, ...)
{
    if (c->err_line != 0)
        return;
    c->err_line = line != 0 ? line : 1;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(c->err, sizeof c->err, fmt, ap);
    va_end(ap);
    /* Messages quote what the file says; a stray CR or escape byte must
     * not split the log line or reach the terminal. */
    for (char *p = c->err; *p; p++)
        if ((unsigned char)*p < 0x20 || *p == 0x7f)
            *p = '?';
}

/* ---- small helpers ------------------------------------------------------ */

/* Locale-independent character classes (isalpha() would follow LC_CTYPE). */
static bool is_digit(char ch)
{
    return ch >= '0' && ch <= '9';
}

static bool is_alnum(char ch)
{
    return is_digit(ch) || (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z');
}

static bool is_space(char ch)
{
    return ch == ' ' || ch == '\t' || ch == '\r' || ch == '\n' || ch == '\f' ||
           ch == '\v';
}

static bool has_space_or_control(const char *s)
{
    for (; *s; s++)
        if (is_space(*s) || (unsigned char)*s < 0x20 || *s == 0x7f)
            return true;
    return false;
}

/* Is `cand` close enough to `typed` to suggest it? A third of the length,
 * at least 2 edits: "wordorder" -> "word_order", not "foo" -> "port". */
static bool close_enough(const char *typed, const char *cand)
{
    size_t n = strlen(cand);
    unsigned limit = n / 3 > 2 ? (unsigned)(n / 3) : 2u;
    return dr_edit_distance(typed, cand) <= limit &&
           dr_edit_distance(typed, cand) < n;
}

/* "a, b, c" into buf (cut if it does not fit; messages only). */
static void join_names(const char *const *names, size_t n, char *buf,
                       size_t size)
{
    size_t len = 0;
    buf[0] = '\0';
    for (size_t i = 0; i < n && len < size; i++) {
        int w =
            snprintf(buf + len, size - len, "%s%s", i ? ", " : "", names[i]);
        if (w < 0)
            break;
        len += (size_t)w;
    }
}

static void join_keys(const key_desc_t *keys, size_t n, char *buf, size_t size)
{
    const char *names[24] = { NULL }; /* the longest list: [robot]'s keys */
    for (size_t i = 0; i < n && i < COUNT(names); i++)
        names[i] = keys[i].name;
    join_names(names, n < COUNT(names) ? n : COUNT(names), buf, size);
}

/* Copy a value into a fixed field; false (after the message) if too long. */
static bool copy_value(ctx_t *c, const char *key, const char *v, char *dst,
                       size_t size)
{
    size_t n = strlen(v);
    if (n >= size) {
        fail(c, c->lineno, "%s too long (at most %zu characters)", key,
             size - 1);
        return false;
    }
    memcpy(dst, v, n + 1);
    return true;
}

/* A decimal number in lo..hi: digits only, no sign, nothing after it
 * ("10ms" is refused rather than read as 10: units are part of the key). */
static bool get_uint(ctx_t *c, const char *key, const char *v, unsigned long lo,
                     unsigned long hi, unsigned long *out)
{
    if (!is_digit(v[0])) {
        fail(c, c->lineno, "%s '%s' invalid: not a number (allowed: %lu..%lu)",
             key, v, lo, hi);
        return false;
    }
    errno = 0;
    char *end;
    unsigned long x = strtoul(v, &end, 10);
    if (*end != '\0') {
        fail(c, c->lineno,
             "%s '%s' invalid: trailing '%s' after the number (allowed: "
             "%lu..%lu)",
             key, v, end, lo, hi);
        return false;
    }
    if (errno == ERANGE || x < lo || x > hi) {
        fail(c, c->lineno, "%s %s out of range (allowed: %lu..%lu)", key, v, lo,
             hi);
        return false;
    }
    *out = x;
    return true;
}

/* An originator serial number: decimal as get_uint, or 0x and 1 to 8 hex
 * digits; never 0 (the robot's default, see gw_robot_config_t). */
static bool get_serial(ctx_t *c, const char *key, const char *v, unsigned long *out)
{
    if (v[0] != '0' || (v[1] != 'x' && v[1] != 'X'))
        return get_uint(c, key, v, 1, 4294967295ul, out);
    size_t n = strspn(v + 2, "0123456789abcdefABCDEF");
    if (n == 0 || n > 8 || v[2 + n] != '\0') {
        fail(c, c->lineno, "%s '%s' invalid: not a 32-bit hex number (allowed: "
             "1..4294967295, or 0x1..0xFFFFFFFF)", key, v);
        return false;
    }
    *out = strtoul(v + 2, NULL, 16);
    if (*out == 0) {
        fail(c, c->lineno, "%s %s out of range (allowed: 1..4294967295, or 0x1..0xFFFFFFFF)",
             key, v);
        return false;
    }
    return true;
}

/* One of `names` exactly (lower case); the index goes to *out. */
static bool get_enum(ctx_t *c, const char *key, const char *v,
                     const char *const *names, size_t n, unsigned *out)
{
    for (size_t i = 0; i < n; i++) {
        if (strcmp(v, names[i]) == 0) {
            *out = (unsigned)i;
            return true;
        }
    }
    char allowed[128];
    join_names(names, n, allowed, sizeof allowed);
    fail(c, c->lineno, "%s '%s' invalid (allowed: %s)", key, v, allowed);
    return false;
}

static bool get_bool(ctx_t *c, const char *key, const char *v, bool *out)
{
    unsigned i;
    if (!get_enum(c, key, v, yes_no, COUNT(yes_no), &i))
        return false;
    *out = i == 0;
    return true;
}

static bool get_ipv4(ctx_t *c, const char *key, const char *v, char *dst,
                     size_t size)
{
    struct in_addr a;
    if (inet_pton(AF_INET, v, &a) != 1) {
        fail(c, c->lineno,
             "%s '%s' invalid (allowed: an IPv4 address such as 192.168.1.10)",
             key, v);
        return false;
    }
    return copy_value(c, key, v, dst, size);
}

/* An IPv4 address, or a DNS name (letters, digits, '-', dot-separated
 * labels). All digits and dots but not an address is a typo ("10.0.0.256"),
 * not a name to look up. */
static bool valid_host(const char *h)
{
    struct in_addr a;
    if (inet_pton(AF_INET, h, &a) == 1)
        return true;
    bool numeric = true;
    for (const char *p = h; *p; p++)
        if (!is_digit(*p) && *p != '.')
            numeric = false;
    if (numeric)
        return false;
    size_t label = 0;
    for (const char *p = h;; p++) {
        if (*p == '.' || *p == '\0') {
            if (label == 0 || label > 63 || p[-1] == '-')
                return false;
            if (*p == '\0')
                return true;
            label = 0;
        } else if (is_alnum(*p) || (*p == '-' && label > 0)) {
            label++;
        } else {
            return false;
        }
    }
}

/* Section and robot names: what log lines and gpio's robot = can quote. */
static bool valid_name(const char *s)
{
    size_t n = strlen(s);
    if (n == 0 || n >= GW_NAME_MAX)
        return false;
    for (; *s; s++)
        if (!is_alnum(*s) && *s != '_' && *s != '-')
            return false;
    return true;
}

static int find_key(const key_desc_t *keys, size_t n, const char *name)
{
    for (size_t i = 0; i < n; i++)
        if (strcmp(keys[i].name, name) == 0)
            return (int)i;
    return -1;
}

static void unknown_key(ctx_t *c, const char *name, const key_desc_t *keys,
                        size_t n, bool robot)
{
    const char *best = NULL;
    unsigned best_d = ~0u;
    char inst[2 * DR_ASM_COUNT][40];
    for (size_t i = 0; i < n; i++) {
        unsigned d = dr_edit_distance(name, keys[i].name);
        if (d < best_d && close_enough(name, keys[i].name)) {
            best_d = d;
            best = keys[i].name;
        }
    }
    /* "instanse.io_state" should point at "instance.io_state". */
    for (unsigned a = 0; robot && a < 2 * DR_ASM_COUNT; a++) {
        snprintf(inst[a], sizeof inst[a], "%s%s",
                 a < DR_ASM_COUNT ? INSTANCE_PREFIX : OPEN_PREFIX,
                 dr_asm_info((dr_asm_t)(a % DR_ASM_COUNT))->name);
        unsigned d = dr_edit_distance(name, inst[a]);
        if (d < best_d && close_enough(name, inst[a])) {
            best_d = d;
            best = inst[a];
        }
    }
    char allowed[300];
    join_keys(keys, n, allowed, sizeof allowed);
    if (robot)
        strncat(allowed, ", " INSTANCE_PREFIX "<assembly>, " OPEN_PREFIX "<T->O assembly>",
                sizeof allowed - strlen(allowed) - 1);
    if (best != NULL)
        fail(c, c->lineno,
             "unknown key '%s' in [%s] (did you mean '%s'? allowed: %s)", name,
             c->sec_text, best, allowed);
    else
        fail(c, c->lineno, "unknown key '%s' in [%s] (allowed: %s)", name,
             c->sec_text, allowed);
}

/* Record that key `k` was set on this line; false if it was set before. */
static bool first_use(ctx_t *c, unsigned *lines, int k, const char *name)
{
    if (lines[k] != 0) {
        fail(c, c->lineno, "key '%s' repeated in [%s] (first at line %u)", name,
             c->sec_text, lines[k]);
        return false;
    }
    lines[k] = c->lineno;
    return true;
}

/* Common start of every key handler: known, not repeated, not empty.
 * Returns the key index, or -1 after a message. */
static int begin_key(ctx_t *c, const key_desc_t *keys, size_t n,
                     unsigned *lines, const char *name, const char *v,
                     bool repeatable)
{
    int k = find_key(keys, n, name);
    if (k < 0) {
        unknown_key(c, name, keys, n, c->sec == SEC_ROBOT);
        return -1;
    }
    if (!repeatable && !first_use(c, lines, k, name))
        return -1;
    if (repeatable && lines[k] == 0)
        lines[k] = c->lineno;
    if (v[0] == '\0') {
        fail(c, c->lineno, "%s has no value (allowed: %s)", name,
             keys[k].allowed);
        return -1;
    }
    return k;
}

/* ---- [daemon] ----------------------------------------------------------- */

static void daemon_key(ctx_t *c, const char *name, const char *v)
{
    int k = begin_key(c, daemon_keys, DK_COUNT, c->daemon_key, name, v, false);
    unsigned i;
    if (k == DK_LOG_LEVEL &&
        get_enum(c, name, v, log_levels, COUNT(log_levels), &i))
        copy_value(c, name, log_levels[i], c->cfg.log_level,
                   sizeof c->cfg.log_level);
}

/* ---- [modbus] ----------------------------------------------------------- */

/* "a.b.c.d/len [ro|rw]": the network must be given exactly (no host bits),
 * and must not be shadowed by an earlier entry, since the first match
 * decides (gateway/mbserver.c) and a shadowed line would silently do
 * nothing. */
static void modbus_allow(ctx_t *c, const char *v)
{
    gw_modbus_config_t *m = &c->cfg.modbus;
    const char *form = "allowed: a.b.c.d/len [ro|rw]";
    if (m->allow_count >= GW_MAX_ALLOW) {
        fail(c, c->lineno, "too many allow entries (at most %d)", GW_MAX_ALLOW);
        return;
    }
    /* Split the value into up to three words (the value itself is ours to
     * read: libinih has already stripped it and removed comments). */
    char buf[128];
    if (strlen(v) >= sizeof buf) {
        fail(c, c->lineno, "allow too long (at most %zu characters)",
             sizeof buf - 1);
        return;
    }
    memcpy(buf, v, strlen(v) + 1);
    char *word[3] = { NULL, NULL, NULL };
    size_t nw = 0;
    for (char *p = buf; *p != '\0';) {
        while (is_space(*p))
            *p++ = '\0';
        if (*p == '\0')
            break;
        if (nw == COUNT(word)) {
            nw++;
            break;
        }
        word[nw++] = p;
        while (*p != '\0' && !is_space(*p))
            p++;
    }
    if (nw > 2) {
        fail(c, c->lineno, "allow '%s' invalid: trailing '%s' (%s)", v, word[2],
             form);
        return;
    }
    bool rw = false; /* least privilege: writing must be asked for */
    if (nw == 2) {
        if (strcmp(word[1], "rw") == 0) {
            rw = true;
        } else if (strcmp(word[1], "ro") != 0) {
            fail(c, c->lineno,
                 "allow '%s' invalid: access '%s' (allowed: ro, rw)", v,
                 word[1]);
            return;
        }
    }
    if (nw == 0) { /* not reached: begin_key refused an empty value */
        fail(c, c->lineno, "allow has no value (%s)", form);
        return;
    }
    char *slash = strchr(word[0], '/');
    unsigned long prefix = 32;
    if (slash != NULL) {
        *slash = '\0';
        const char *p = slash + 1;
        char *end;
        prefix = is_digit(*p) ? strtoul(p, &end, 10) : 99;
        if (!is_digit(*p) || *end != '\0' || prefix > 32) {
            fail(c, c->lineno,
                 "allow '%s' invalid: prefix length '%s' (allowed: 0..32)", v,
                 p);
            return;
        }
    }
    struct in_addr a;
    if (inet_pton(AF_INET, word[0], &a) != 1) {
        fail(c, c->lineno,
             "allow '%s' invalid: '%s' is not an IPv4 address (%s)", v, word[0],
             form);
        return;
    }
    uint32_t addr = ntohl(a.s_addr);
    /* A shift by 32 is undefined, hence the /0 case. */
    uint32_t mask = prefix == 0 ? 0u : 0xFFFFFFFFu << (32u - (unsigned)prefix);
    if ((addr & ~mask) != 0) {
        uint32_t n = addr & mask;
        fail(c, c->lineno,
             "allow '%s' invalid: host bits set in %s/%lu (did you mean "
             "%u.%u.%u.%u/%lu?)",
             v, word[0], prefix, (unsigned)(n >> 24),
             (unsigned)(n >> 16 & 0xFF), (unsigned)(n >> 8 & 0xFF),
             (unsigned)(n & 0xFF), prefix);
        return;
    }
    for (unsigned i = 0; i < m->allow_count; i++) {
        const gw_allow_t *e = &m->allow[i];
        if ((addr & e->mask) == e->net && mask >= e->mask) {
            fail(c, c->lineno,
                 "allow '%s' never matches: line %u already covers it (the "
                 "first matching "
                 "entry decides; put narrower networks first)",
                 v, c->allow_line[i]);
            return;
        }
    }
    c->allow_line[m->allow_count] = c->lineno;
    m->allow[m->allow_count].net = addr;
    m->allow[m->allow_count].mask = mask;
    m->allow[m->allow_count].read_write = rw;
    m->allow_count++;
}

static void modbus_key(ctx_t *c, const char *name, const char *v)
{
    gw_modbus_config_t *m = &c->cfg.modbus;
    int k = begin_key(c, modbus_keys, MK_COUNT, c->modbus_key, name, v,
                      strcmp(name, "allow") == 0);
    unsigned long n;
    unsigned e;
    switch (k) {
    case MK_LISTEN: get_ipv4(c, name, v, m->listen, sizeof m->listen); break;
    case MK_PORT:
        if (get_uint(c, name, v, 1, 65535, &n))
            m->port = (uint16_t)n;
        break;
    case MK_MAX_CLIENTS:
        if (get_uint(c, name, v, 1, 256, &n))
            m->max_clients = (unsigned)n;
        break;
    case MK_IDLE_TIMEOUT:
        if (get_uint(c, name, v, 0, 86400, &n))
            m->idle_timeout_s = (unsigned)n;
        break;
    case MK_KEEPALIVE: get_bool(c, name, v, &m->keepalive); break;
    case MK_WORD_ORDER:
        if (get_enum(c, name, v, word_orders, COUNT(word_orders), &e))
            m->word_order = (gw_word_order_t)e;
        break;
    case MK_ALLOW: modbus_allow(c, v); break;
    case MK_ON_LINK_LOSS:
        if (get_enum(c, name, v, link_loss_names, COUNT(link_loss_names), &e))
            m->on_link_loss = (gw_link_loss_t)e;
        break;
    case MK_UNMAPPED_READ:
        if (get_enum(c, name, v, unmapped_names, COUNT(unmapped_names), &e))
            m->unmapped_read = (gw_unmapped_read_t)e;
        break;
    case MK_SINGLE_WRITER: get_bool(c, name, v, &m->single_writer); break;
    case MK_WRITER_WATCHDOG_MS:
        if (get_uint(c, name, v, 10, 60000, &n))
            m->writer_watchdog_ms = (unsigned)n;
        break;
    case MK_REQUEST_TIMEOUT_MS:
        if (get_uint(c, name, v, 100, 60000, &n))
            m->request_timeout_ms = (unsigned)n;
        break;
    default: /* -1: already reported */ break;
    }
}

/* ---- [mqtt] ------------------------------------------------------------- */

/* A path to a file: anything but empty; whether it opens is checked when
 * the MQTT side starts (or a reload prepares it). */
static void mqtt_file(ctx_t *c, const char *key, const char *v, char *dst, size_t size)
{
    copy_value(c, key, v, dst, size);
}

/* MQTT topic levels: no wildcards, no empty level, printable ASCII. */
static bool valid_topic(const char *t)
{
    if (t[0] == '\0' || t[0] == '/' || t[strlen(t) - 1] == '/' || strstr(t, "//"))
        return false;
    for (; *t; t++)
        if (*t == '+' || *t == '#' || (unsigned char)*t <= 0x20 || (unsigned char)*t >= 0x7f)
            return false;
    return true;
}

static bool valid_client_id(const char *s)
{
    for (; *s; s++)
        if (!is_alnum(*s) && *s != '_' && *s != '-' && *s != '.')
            return false;
    return true;
}

/* A non-negative decimal number such as 0.5 (no exponent, no sign). */
static bool get_deadband(ctx_t *c, const char *key, const char *v, double *out)
{
    unsigned digits = 0, dots = 0;
    const char *p = v;
    for (; *p && (is_digit(*p) || *p == '.'); p++) {
        digits += is_digit(*p);
        dots += *p == '.';
    }
    char *end = NULL;
    double x = *p == '\0' && digits > 0 && dots <= 1 ? strtod(v, &end) : -1.0;
    if (end == NULL || *end != '\0' || !(x >= 0.0 && x <= 1e9)) {
        fail(c, c->lineno, "%s '%s' invalid (allowed: a decimal number >= 0, e.g. 0.5)", key, v);
        return false;
    }
    *out = x;
    return true;
}

static void mqtt_key(ctx_t *c, const char *name, const char *v)
{
    gw_mqtt_config_t *q = &c->cfg.mqtt;
    int k = begin_key(c, mqtt_keys, QK_COUNT, c->mqtt_key, name, v, false);
    unsigned long n;
    switch (k) {
    case QK_HOST:
        if (!valid_host(v))
            fail(c, c->lineno, "host '%s' invalid (allowed: an IPv4 address or a host name)", v);
        else
            copy_value(c, name, v, q->host, sizeof q->host);
        break;
    case QK_PORT:
        if (get_uint(c, name, v, 1, 65535, &n))
            q->port = (uint16_t)n;
        break;
    case QK_CLIENT_ID:
        if (!valid_client_id(v))
            fail(c, c->lineno, "client_id '%s' invalid (allowed: %s)", v, mqtt_keys[k].allowed);
        else
            copy_value(c, name, v, q->client_id, sizeof q->client_id);
        break;
    case QK_USERNAME: copy_value(c, name, v, q->username, sizeof q->username); break;
    case QK_PASSWORD_FILE: mqtt_file(c, name, v, q->password_file, sizeof q->password_file); break;
    case QK_CA_FILE: mqtt_file(c, name, v, q->ca_file, sizeof q->ca_file); break;
    case QK_CERT_FILE: mqtt_file(c, name, v, q->cert_file, sizeof q->cert_file); break;
    case QK_KEY_FILE: mqtt_file(c, name, v, q->key_file, sizeof q->key_file); break;
    case QK_KEEPALIVE_S:
        if (get_uint(c, name, v, 5, 3600, &n))
            q->keepalive_s = (unsigned)n;
        break;
    case QK_QOS:
        if (get_uint(c, name, v, 0, 2, &n))
            q->qos = (unsigned)n;
        break;
    case QK_TOPIC_PREFIX:
        if (!valid_topic(v))
            fail(c, c->lineno,
                 "topic_prefix '%s' invalid (allowed: topic levels separated by '/', no "
                 "wildcards, blanks or empty levels, e.g. drgate/cell1)",
                 v);
        else
            copy_value(c, name, v, q->topic_prefix, sizeof q->topic_prefix);
        break;
    case QK_RETAIN: get_bool(c, name, v, &q->retain); break;
    case QK_PUBLISH_INTERVAL_MS:
        if (get_uint(c, name, v, 0, 60000, &n))
            q->publish_interval_ms = (unsigned)n;
        break;
    case QK_DEADBAND: get_deadband(c, name, v, &q->deadband); break;
    case QK_WRITES: get_bool(c, name, v, &q->writes); break;
    default: break;
    }
}

static void check_mqtt(ctx_t *c)
{
    const gw_mqtt_config_t *q = &c->cfg.mqtt;
    if (!q->enabled)
        return;
    if (q->host[0] == '\0')
        fail(c, q->line, "[mqtt] has no host (allowed: the broker's IPv4 address or host name)");
    else if ((q->cert_file[0] != '\0') != (q->key_file[0] != '\0'))
        fail(c, c->mqtt_key[q->cert_file[0] ? QK_CERT_FILE : QK_KEY_FILE],
             "[mqtt] cert_file and key_file go together (allowed: both or neither)");
    else if (q->cert_file[0] != '\0' && q->ca_file[0] == '\0')
        fail(c, c->mqtt_key[QK_CERT_FILE], "[mqtt] cert_file needs ca_file (TLS)");
    else if (q->password_file[0] != '\0' && q->username[0] == '\0')
        fail(c, c->mqtt_key[QK_PASSWORD_FILE], "[mqtt] password_file needs username");
}

/* ---- [robot NAME] ------------------------------------------------------- */

/* The assembly `asm_name` (the part of key `name` after its prefix);
 * false, with a did-you-mean message, if there is no such assembly. */
static bool key_assembly(ctx_t *c, const char *name, const char *asm_name, dr_asm_t *a)
{
    if (dr_asm_lookup(asm_name, a) == DR_OK)
        return true;
    const char *names[DR_ASM_COUNT];
    const char *best = NULL;
    unsigned best_d = ~0u;
    for (unsigned i = 0; i < DR_ASM_COUNT; i++) {
        names[i] = dr_asm_info((dr_asm_t)i)->name;
        unsigned d = dr_edit_distance(asm_name, names[i]);
        if (d < best_d && close_enough(asm_name, names[i])) {
            best_d = d;
            best = names[i];
        }
    }
    char allowed[200];
    join_names(names, DR_ASM_COUNT, allowed, sizeof allowed);
    if (best != NULL)
        fail(c, c->lineno,
             "unknown assembly '%s' in '%s' (did you mean '%s'? allowed: "
             "%s, or dr1..dr10)",
             asm_name, name, best, allowed);
    else
        fail(c, c->lineno,
             "unknown assembly '%s' in '%s' (allowed: %s, or dr1..dr10)",
             asm_name, name, allowed);
    return false;
}

/* "io_state, joint_state, ..." for the assemblies of one direction. */
static void join_dir(dr_dir_t dir, char *buf, size_t size)
{
    const char *names[DR_ASM_COUNT];
    size_t n = 0;
    for (unsigned i = 0; i < DR_ASM_COUNT; i++)
        if (dr_asm_info((dr_asm_t)i)->dir == dir)
            names[n++] = dr_asm_info((dr_asm_t)i)->name;
    join_names(names, n, buf, size);
}

static void robot_instance(ctx_t *c, const char *name, const char *v)
{
    gw_robot_config_t *r = &c->cfg.robot[c->idx];
    const char *asm_name = name + strlen(INSTANCE_PREFIX);
    dr_asm_t a;
    if (!key_assembly(c, name, asm_name, &a))
        return;
    /* instance.io_state and instance.dr1 are the same key. */
    unsigned *seen = &c->robot[c->idx].instance[a];
    if (*seen != 0) {
        fail(c, c->lineno,
             "key '%s' repeated in [%s] (instance of %s, first at line %u)",
             name, c->sec_text, dr_asm_info(a)->name, *seen);
        return;
    }
    *seen = c->lineno;
    unsigned long n;
    if (v[0] == '\0')
        fail(c, c->lineno, "%s has no value (allowed: 1..65535)", name);
    else if (get_uint(c, name, v, 1, 65535, &n))
        r->instance[a] = (uint16_t)n;
}

/* The value of open.<T->O assembly>: "owner:<O->T assembly>",
 * "input_only", "listen_only" or "none". */
static void open_value(ctx_t *c, const char *name, const char *v, gw_open_t *o)
{
    static const char *const kinds[] = { "owner", "input_only", "listen_only", "none" };
    size_t n = strcspn(v, ":");
    for (unsigned k = 1; k < COUNT(kinds); k++)
        if (strcmp(v, kinds[k]) == 0) {
            o->kind = (gw_open_kind_t)k;
            o->o2t = -1;
            return;
        }
    if (strcmp(v, kinds[0]) == 0) {
        fail(c, c->lineno, "%s 'owner' invalid: an owner connection needs its O->T partner, "
             "e.g. owner:io_control (allowed: " OPEN_ALLOWED ")", name);
        return;
    }
    if (n != strlen(kinds[0]) || strncmp(v, kinds[0], n) != 0 || v[n] != ':') {
        const char *best = NULL;
        unsigned best_d = ~0u;
        for (unsigned k = 0; k < COUNT(kinds); k++) {
            unsigned d = dr_edit_distance(v, kinds[k]);
            if (d < best_d && close_enough(v, kinds[k])) {
                best_d = d;
                best = kinds[k];
            }
        }
        if (best != NULL)
            fail(c, c->lineno, "%s '%s' invalid (did you mean '%s'? allowed: " OPEN_ALLOWED ")",
                 name, v, best);
        else
            fail(c, c->lineno, "%s '%s' invalid (allowed: " OPEN_ALLOWED ")", name, v);
        return;
    }
    dr_asm_t p;
    if (!key_assembly(c, name, v + n + 1, &p))
        return;
    if (dr_asm_info(p)->dir != DR_DIR_O2T) {
        char allowed[120];
        join_dir(DR_DIR_O2T, allowed, sizeof allowed);
        fail(c, c->lineno, "%s '%s' invalid: %s is produced by the robot (T->O), an owner's "
             "partner must be an O->T assembly (allowed: %s)", name, v, dr_asm_info(p)->name,
             allowed);
        return;
    }
    o->kind = GW_OPEN_OWNER;
    o->o2t = (int)p;
}

static void robot_open(ctx_t *c, const char *name, const char *v)
{
    gw_robot_config_t *r = &c->cfg.robot[c->idx];
    dr_asm_t a;
    if (!key_assembly(c, name, name + strlen(OPEN_PREFIX), &a))
        return;
    if (dr_asm_info(a)->dir != DR_DIR_T2O) {
        char allowed[120];
        join_dir(DR_DIR_T2O, allowed, sizeof allowed);
        fail(c, c->lineno, "key '%s' invalid: %s is consumed by the robot (O->T); open.* names "
             "a T->O assembly, which brings its O->T partner with owner:<O->T> (allowed: %s)",
             name, dr_asm_info(a)->name, allowed);
        return;
    }
    /* open.io_state and open.dr1 are the same key. */
    unsigned *seen = &c->robot[c->idx].open[a];
    if (*seen != 0) {
        fail(c, c->lineno, "key '%s' repeated in [%s] (open of %s, first at line %u)", name,
             c->sec_text, dr_asm_info(a)->name, *seen);
        return;
    }
    *seen = c->lineno;
    open_value(c, name, v, &r->open[a]);
}

static void robot_key(ctx_t *c, const char *name, const char *v)
{
    gw_robot_config_t *r = &c->cfg.robot[c->idx];
    if (strncmp(name, INSTANCE_PREFIX, strlen(INSTANCE_PREFIX)) == 0) {
        robot_instance(c, name, v);
        return;
    }
    if (strncmp(name, OPEN_PREFIX, strlen(OPEN_PREFIX)) == 0) {
        robot_open(c, name, v);
        return;
    }
    int k = begin_key(c, robot_keys, RK_COUNT, c->robot[c->idx].key, name, v,
                      false);
    unsigned long n;
    unsigned e;
    switch (k) {
    case RK_HOST:
        if (!valid_host(v))
            fail(c, c->lineno,
                 "host '%s' invalid (allowed: an IPv4 address or a host name)",
                 v);
        else
            copy_value(c, name, v, r->host, sizeof r->host);
        break;
    case RK_TCP_PORT:
        if (get_uint(c, name, v, 1, 65535, &n))
            r->tcp_port = (uint16_t)n;
        break;
    case RK_UDP_PORT:
        if (get_uint(c, name, v, 1, 65535, &n))
            r->udp_port = (uint16_t)n;
        break;
    case RK_LOCAL_ADDRESS:
        get_ipv4(c, name, v, r->local_addr, sizeof r->local_addr);
        break;
    case RK_LOCAL_UDP_PORT:
        if (get_uint(c, name, v, 1, 65535, &n))
            r->local_udp_port = (uint16_t)n;
        break;
    case RK_UNIT_ID: /* 0 is broadcast, 248..255 reserved (Modbus spec 4.1) */
        if (get_uint(c, name, v, 1, 247, &n))
            r->unit_id = (uint8_t)n;
        break;
    case RK_MODE:
        if (get_enum(c, name, v, mode_names, COUNT(mode_names), &e))
            r->mode = (gw_robot_mode_t)e;
        break;
    case RK_RPI_MS:
        if (get_uint(c, name, v, 1, 10000, &n))
            r->rpi_ms = (uint32_t)n;
        break;
    case RK_TIMEOUT_MULTIPLIER: /* CIP's code: timeout = RPI x (4 << code) */
        if (get_uint(c, name, v, 0, 7, &n))
            r->timeout_mult = (uint8_t)n;
        break;
    case RK_TIMEOUT_MS:
        if (get_uint(c, name, v, 10, 60000, &n))
            r->timeout_ms = (uint32_t)n;
        break;
    case RK_FALLBACK:
        if (get_enum(c, name, v, fallback_names, COUNT(fallback_names), &e))
            r->fallback_hold = e == 1;
        break;
    case RK_O2T_TIMING:
        if (get_enum(c, name, v, o2t_timing_names, COUNT(o2t_timing_names), &e))
            r->o2t_strict = e == 1;
        break;
    case RK_CONFIG_INSTANCE:
        if (get_uint(c, name, v, 1, 65535, &n))
            r->config_instance = (uint16_t)n;
        break;
    case RK_INPUT_ONLY_HEARTBEAT:
        if (get_uint(c, name, v, 1, 65535, &n))
            r->input_only_heartbeat = (uint16_t)n;
        break;
    case RK_LISTEN_ONLY_HEARTBEAT:
        if (get_uint(c, name, v, 1, 65535, &n))
            r->listen_only_heartbeat = (uint16_t)n;
        break;
    case RK_ORIGINATOR_SERIAL: /* often written in hex, as tools show it */
        if (get_serial(c, name, v, &n))
            r->originator_serial = (uint32_t)n;
        break;
    default: break;
    }
}

/* ---- [gpio NAME] -------------------------------------------------------- */

/* The field a path names, even when the index is wrong or missing: tried
 * bare (a mask or a scalar), then with [0] and [1] (the two numberings). */
static const dr_field_t *field_of(const char *path)
{
    char base[80];
    size_t n = strcspn(path, "[");
    if (n + 4 > sizeof base)
        return NULL;
    static const char *const suffix[] = { "", "[0]", "[1]" };
    for (size_t i = 0; i < COUNT(suffix); i++) {
        memcpy(base, path, n);
        memcpy(base + n, suffix[i], strlen(suffix[i]) + 1);
        dr_ref_t ref;
        if (dr_path_parse(base, &ref) == DR_OK)
            return ref.field;
    }
    return NULL;
}

static bool is_bit_field(const dr_field_t *f)
{
    return f->kind == DR_KIND_BIT || f->kind == DR_KIND_BITS;
}

static void not_a_bit(ctx_t *c, const char *v, const dr_field_t *f)
{
    fail(c, c->lineno,
         "field '%s' is a %s, not a bit (a GPIO line follows or drives one "
         "bit, e.g. "
         "io_state.cb_do[1] or bit_in[0])",
         v, dr_kind_name((dr_kind_t)f->kind));
}

static void gpio_field(ctx_t *c, gw_gpio_config_t *g, const char *v)
{
    dr_ref_t ref;
    dr_status_t st = dr_path_parse(v, &ref);
    if (st == DR_ENOENT) {
        char closest[64];
        if (dr_path_closest(v, closest, sizeof closest) != DR_OK)
            closest[0] = '\0';
        fail(c, c->lineno, "field '%s' unknown (closest: %s)", v, closest);
        return;
    }
    if (st == DR_ESYNTAX) {
        fail(c, c->lineno,
             "field '%s' has a malformed index (allowed: a decimal index, e.g. "
             "io_state.cb_do[1])",
             v);
        return;
    }
    if (st != DR_OK) {
        /* DR_EINDEX: out of the field's numbering, or an array given
         * without an index, or a scalar given one. */
        const dr_field_t *f = field_of(v);
        char base[64];
        dr_ref_t mask = { f, -1 };
        if (f == NULL || dr_ref_path(mask, base, sizeof base) != DR_OK)
            fail(c, c->lineno, "field '%s' invalid: %s", v, dr_strerror(st));
        else if (!is_bit_field(f))
            not_a_bit(c, v, f);
        else if (!f->indexed)
            fail(c, c->lineno, "field '%s' takes no index (allowed: %s)", v,
                 base);
        else
            fail(c, c->lineno,
                 "field '%s' index out of range (allowed: %s[%u]..%s[%u])", v,
                 base, (unsigned)f->first_index, base,
                 (unsigned)f->first_index + f->count - 1u);
        return;
    }
    if (!is_bit_field(ref.field)) {
        not_a_bit(c, v, ref.field);
        return;
    }
    if (ref.elem < 0) {
        char base[64];
        if (dr_ref_path(ref, base, sizeof base) != DR_OK)
            base[0] = '\0';
        fail(
            c, c->lineno,
            "field '%s' is a whole mask, not one bit (allowed: %s[%u]..%s[%u])",
            v, base, (unsigned)ref.field->first_index, base,
            (unsigned)ref.field->first_index + ref.field->count - 1u);
        return;
    }
    g->field = ref;
}

static void gpio_key(ctx_t *c, const char *name, const char *v)
{
    gw_gpio_config_t *g = &c->cfg.gpio[c->idx];
    int k =
        begin_key(c, gpio_keys, GK_COUNT, c->gpio[c->idx].key, name, v, false);
    unsigned long n;
    unsigned e;
    switch (k) {
    case GK_CHIP:
        if (has_space_or_control(v))
            fail(c, c->lineno, "chip '%s' invalid (allowed: %s)", v,
                 gpio_keys[k].allowed);
        else
            copy_value(c, name, v, g->chip, sizeof g->chip);
        break;
    case GK_LINE:
        /* A leading digit means an offset: "17x" is a typo, not a name. */
        if (is_digit(v[0])) {
            if (get_uint(c, name, v, 0, 65535, &n))
                g->offset = (int)n;
        } else if (has_space_or_control(v)) {
            fail(c, c->lineno, "line '%s' invalid (allowed: %s)", v,
                 gpio_keys[k].allowed);
        } else if (strlen(v) > GPIO_LINE_NAME_MAX) {
            fail(c, c->lineno,
                 "line name '%s' too long (at most %d characters, the kernel's "
                 "limit)",
                 v, GPIO_LINE_NAME_MAX);
        } else {
            copy_value(c, name, v, g->line_name, sizeof g->line_name);
        }
        break;
    case GK_DIRECTION:
        if (get_enum(c, name, v, dir_names, COUNT(dir_names), &e))
            g->dir = (gw_gpio_dir_t)e;
        break;
    case GK_ROBOT: /* resolved once every robot is known */
        if (!valid_name(v))
            fail(c, c->lineno, "robot '%s' invalid (allowed: %s)", v,
                 gpio_keys[k].allowed);
        else
            copy_value(c, name, v, g->robot, sizeof g->robot);
        break;
    case GK_FIELD: /* direction-dependent checks wait for the whole section */
        gpio_field(c, g, v);
        break;
    case GK_ACTIVE_LOW: get_bool(c, name, v, &g->active_low); break;
    case GK_BIAS:
        if (get_enum(c, name, v, bias_names, COUNT(bias_names), &e))
            g->bias = (gw_gpio_bias_t)e;
        break;
    case GK_DEBOUNCE_MS:
        if (get_uint(c, name, v, 0, 1000, &n))
            g->debounce_ms = (unsigned)n;
        break;
    case GK_SAFE_VALUE:
        if (get_enum(c, name, v, safe_names, COUNT(safe_names), &e))
            g->safe_value = e == 1;
        break;
    default: break;
    }
}

/* ---- [modbus_rtu NAME] ---------------------------------------------------- */

static const unsigned rtu_bauds[] = { 1200, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400 };

/* robots = arm1:5, arm2 (commas or blanks between): names are checked
 * against the robot sections once the whole file is read. */
static void rtu_robots(ctx_t *c, gw_rtu_config_t *u, const char *v)
{
    rtu_lines_t *ul = &c->rtu[c->idx];
    const char *p = v;
    u->slave_count = 0;
    while (*p != '\0' && c->err_line == 0) {
        while (*p == ',' || is_space(*p))
            p++;
        if (*p == '\0')
            break;
        size_t n = strcspn(p, ", \t:");
        if (u->slave_count >= GW_MAX_ROBOTS) {
            fail(c, c->lineno, "robots: more than %d robots", GW_MAX_ROBOTS);
            return;
        }
        unsigned i = u->slave_count++;
        snprintf(ul->robot[i], sizeof ul->robot[i], "%.*s", (int)n, p);
        if (n >= GW_NAME_MAX || !valid_name(ul->robot[i])) {
            fail(c, c->lineno, "robots: '%.*s' is not a robot name (allowed: %s)", (int)n, p,
                 rtu_keys[UK_ROBOTS].allowed);
            return;
        }
        p += n;
        ul->addr_given[i] = *p == ':';
        if (*p == ':') {
            char *end;
            errno = 0;
            unsigned long a = strtoul(p + 1, &end, 10);
            if (end == p + 1 || !is_digit(p[1]) || errno != 0 || a < 1 || a > 247 ||
                (*end != '\0' && *end != ',' && !is_space(*end))) {
                fail(c, c->lineno, "robots: slave address of '%s' invalid (allowed: 1..247)",
                     ul->robot[i]);
                return;
            }
            u->slave_addr[i] = (uint8_t)a;
            p = end;
        }
    }
    if (u->slave_count == 0)
        fail(c, c->lineno, "robots has no value (allowed: %s)", rtu_keys[UK_ROBOTS].allowed);
}

static void rtu_key(ctx_t *c, const char *name, const char *v)
{
    gw_rtu_config_t *u = &c->cfg.rtu[c->idx];
    int k = begin_key(c, rtu_keys, UK_COUNT, c->rtu[c->idx].key, name, v, false);
    unsigned long n;
    unsigned e;
    switch (k) {
    case UK_DEVICE:
        if (has_space_or_control(v))
            fail(c, c->lineno, "device '%s' invalid (allowed: %s)", v, rtu_keys[k].allowed);
        else
            copy_value(c, name, v, u->device, sizeof u->device);
        break;
    case UK_BAUD: {
        bool ok = get_uint(c, name, v, 1200, 230400, &n);
        bool known = false;
        for (size_t i = 0; ok && i < COUNT(rtu_bauds); i++)
            known = known || rtu_bauds[i] == n;
        if (ok && !known)
            fail(c, c->lineno, "baud %lu not a standard rate (allowed: %s)", n,
                 rtu_keys[k].allowed);
        else if (ok)
            u->baud = (unsigned)n;
        break;
    }
    case UK_PARITY:
        if (get_enum(c, name, v, parity_names, COUNT(parity_names), &e))
            u->parity = (gw_parity_t)e;
        break;
    case UK_DATA_BITS:
        if (get_uint(c, name, v, 8, 8, &n))
            u->data_bits = (unsigned)n;
        break;
    case UK_STOP_BITS:
        if (get_uint(c, name, v, 1, 2, &n))
            u->stop_bits = (unsigned)n;
        break;
    case UK_RS485: get_bool(c, name, v, &u->rs485); break;
    case UK_RTS_ON_SEND:
        if (get_enum(c, name, v, rts_names, COUNT(rts_names), &e))
            u->rts_on_send_low = e == 1;
        break;
    case UK_RTS_BEFORE_MS:
    case UK_RTS_AFTER_MS:
        if (get_uint(c, name, v, 0, 100, &n))
            *(k == UK_RTS_BEFORE_MS ? &u->rts_before_ms : &u->rts_after_ms) = (unsigned)n;
        break;
    case UK_READ_ONLY: get_bool(c, name, v, &u->read_only); break;
    case UK_ROBOTS: rtu_robots(c, u, v); break;
    default: /* -1: already reported */ break;
    }
}

static void rtu_defaults(gw_rtu_config_t *u)
{
    memset(u, 0, sizeof *u);
    u->baud = 19200;
    u->parity = GW_PARITY_EVEN;
    u->data_bits = 8;
    u->stop_bits = 1;
}

static void begin_rtu(ctx_t *c, const char *name, bool named)
{
    gw_config_t *g = &c->cfg;
    if (!named) {
        fail(c, c->lineno,
             "section [modbus_rtu] needs a name (allowed: [modbus_rtu NAME] or "
             "[modbus_rtu.NAME])");
        return;
    }
    if (!valid_name(name)) {
        fail(c, c->lineno,
             "modbus_rtu name '%s' invalid (allowed: letters, digits, '_' and '-', at "
             "most %d characters)",
             name, GW_NAME_MAX - 1);
        return;
    }
    for (unsigned i = 0; i < g->rtu_count; i++) {
        if (strcmp(g->rtu[i].name, name) == 0) {
            fail(c, c->lineno, "modbus_rtu '%s' defined twice (first at line %u)", name,
                 g->rtu[i].line);
            return;
        }
    }
    if (g->rtu_count >= GW_MAX_RTU) {
        fail(c, c->lineno, "too many modbus_rtu sections (at most %d)", GW_MAX_RTU);
        return;
    }
    c->idx = g->rtu_count++;
    gw_rtu_config_t *u = &g->rtu[c->idx];
    rtu_defaults(u);
    memcpy(u->name, name, strlen(name) + 1);
    u->line = c->lineno;
    c->sec = SEC_RTU;
}

/* ---- sections ----------------------------------------------------------- */

static void robot_defaults(gw_robot_config_t *r)
{
    memset(r, 0, sizeof *r);
    r->tcp_port = 44818;
    r->udp_port = 2222;
    r->local_udp_port = 2222;
    r->unit_id = 1;
    r->mode = GW_MODE_IMPLICIT;
    r->rpi_ms = 10;
    r->timeout_mult = 2;
    r->timeout_ms = 1000;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        r->instance[a] = DR_ASM_DEFAULT_INSTANCE(a);
    r->fallback_hold = false;
    gw_robot_default_plan(r);
}

void gw_robot_default_plan(gw_robot_config_t *r)
{
    r->config_instance = 1;
    r->input_only_heartbeat = 198;
    r->listen_only_heartbeat = 199;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        r->open[a] = (gw_open_t){ GW_OPEN_NONE, -1 };
    r->open[DR_ASM_IO_STATE] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_IO_CONTROL };
    r->open[DR_ASM_BIT_OUT] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_BIT_IN };
    r->open[DR_ASM_INT_OUT] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_INT_IN };
    r->open[DR_ASM_FLOAT_OUT] = (gw_open_t){ GW_OPEN_OWNER, DR_ASM_FLOAT_IN };
    r->open[DR_ASM_JOINT_STATE] = (gw_open_t){ GW_OPEN_INPUT_ONLY, -1 };
    r->open[DR_ASM_TASK_STATE] = (gw_open_t){ GW_OPEN_INPUT_ONLY, -1 };
}

static void gpio_defaults(gw_gpio_config_t *g)
{
    memset(g, 0, sizeof *g);
    g->offset = -1;
    g->bias = GW_BIAS_AS_IS;
}

static void unknown_section(ctx_t *c, const char *kw, const char *rest)
{
    static const char *const kws[] = { "daemon", "modbus", "robot", "gpio", "modbus_rtu",
                                       "mqtt" };
    const char *best = NULL;
    unsigned best_d = ~0u;
    for (size_t i = 0; i < COUNT(kws); i++) {
        unsigned d = dr_edit_distance(kw, kws[i]);
        if (d < best_d && close_enough(kw, kws[i])) {
            best_d = d;
            best = kws[i];
        }
    }
    if (best != NULL)
        fail(c, c->lineno,
             "unknown section [%s] (did you mean [%s%s]? "
             "allowed: " SECTIONS_ALLOWED ")",
             c->sec_text, best, rest);
    else
        fail(c, c->lineno,
             "unknown section [%s] (allowed: " SECTIONS_ALLOWED ")",
             c->sec_text);
}

static void begin_robot(ctx_t *c, const char *name)
{
    gw_config_t *g = &c->cfg;
    if (!valid_name(name)) {
        fail(c, c->lineno,
             "robot name '%s' invalid (allowed: letters, digits, '_' and '-', "
             "at "
             "most %d characters)",
             name, GW_NAME_MAX - 1);
        return;
    }
    for (unsigned i = 0; i < g->robot_count; i++) {
        if (strcmp(g->robot[i].name, name) == 0) {
            fail(c, c->lineno, "robot '%s' defined twice (first at line %u)",
                 name, g->robot[i].line);
            return;
        }
    }
    if (g->robot_count >= GW_MAX_ROBOTS) {
        fail(c, c->lineno, "too many robot sections (at most %d)",
             GW_MAX_ROBOTS);
        return;
    }
    c->idx = g->robot_count++;
    gw_robot_config_t *r = &g->robot[c->idx];
    robot_defaults(r);
    memcpy(r->name, name, strlen(name) + 1);
    r->line = c->lineno;
    c->sec = SEC_ROBOT;
}

static void begin_gpio(ctx_t *c, const char *name, bool named)
{
    gw_config_t *g = &c->cfg;
    if (!named) {
        fail(c, c->lineno,
             "section [gpio] needs a name (allowed: [gpio NAME] or "
             "[gpio.NAME])");
        return;
    }
    if (!valid_name(name)) {
        fail(
            c, c->lineno,
            "gpio name '%s' invalid (allowed: letters, digits, '_' and '-', at "
            "most %d characters)",
            name, GW_NAME_MAX - 1);
        return;
    }
    for (unsigned i = 0; i < g->gpio_count; i++) {
        if (strcmp(g->gpio[i].name, name) == 0) {
            fail(c, c->lineno, "gpio '%s' defined twice (first at line %u)",
                 name, g->gpio[i].line);
            return;
        }
    }
    if (g->gpio_count >= GW_MAX_GPIO) {
        fail(c, c->lineno, "too many gpio sections (at most %d)", GW_MAX_GPIO);
        return;
    }
    c->idx = g->gpio_count++;
    gw_gpio_config_t *gp = &g->gpio[c->idx];
    gpio_defaults(gp);
    memcpy(gp->name, name, strlen(name) + 1);
    gp->line = c->lineno;
    c->sec = SEC_GPIO;
}

/* A section starts (raw: the name exactly as libinih will report it).
 * Accepted: [daemon], [modbus], [robot], [robot NAME], [robot.NAME],
 * [gpio NAME], [gpio.NAME]. */
static void begin_section(ctx_t *c, const char *raw)
{
    snprintf(c->sec_raw, sizeof c->sec_raw, "%s", raw);
    const char *s = raw;
    while (is_space(*s))
        s++;
    size_t len = strlen(s);
    while (len > 0 && is_space(s[len - 1]))
        len--;
    snprintf(c->sec_text, sizeof c->sec_text, "%.*s", (int)len, s);

    /* keyword, then '.' or blanks, then the name */
    char *t = c->sec_text;
    size_t kw_len = strcspn(t, " \t.");
    char kw[64];
    snprintf(kw, sizeof kw, "%.*s", (int)kw_len, t);
    const char *rest = t + kw_len; /* "" or the separator and name */
    const char *name = rest;
    if (*name == '.')
        name++;
    else
        while (is_space(*name))
            name++;
    bool named = *rest != '\0';

    c->sec = SEC_NONE;
    if (strcmp(kw, "daemon") == 0 || strcmp(kw, "modbus") == 0) {
        bool modbus = kw[0] == 'm';
        unsigned *first = modbus ? &c->modbus_line : &c->daemon_line;
        if (named)
            fail(c, c->lineno, "section [%s] takes no name (allowed: [%s])",
                 c->sec_text, kw);
        else if (*first != 0)
            fail(c, c->lineno, "section [%s] repeated (first at line %u)", kw,
                 *first);
        else {
            *first = c->lineno;
            c->sec = modbus ? SEC_MODBUS : SEC_DAEMON;
        }
    } else if (strcmp(kw, "mqtt") == 0) {
        if (named)
            fail(c, c->lineno, "section [%s] takes no name (allowed: [mqtt])", c->sec_text);
        else if (c->cfg.mqtt.enabled)
            fail(c, c->lineno, "section [mqtt] repeated (first at line %u)", c->cfg.mqtt.line);
        else {
            c->cfg.mqtt.enabled = true;
            c->cfg.mqtt.line = c->lineno;
            c->sec = SEC_MQTT;
        }
    } else if (strcmp(kw, "robot") == 0) {
        /* A lone [robot] is named "robot": log lines need a name. */
        begin_robot(c, named ? name : "robot");
    } else if (strcmp(kw, "gpio") == 0) {
        begin_gpio(c, name, named);
    } else if (strcmp(kw, "modbus_rtu") == 0) {
        begin_rtu(c, name, named);
    } else {
        unknown_section(c, kw, rest);
    }
}

/* libinih's own reading of a section line: the only handler call of
 * "<line>\n_=_\n" carries the section name exactly as the real parse will
 * report it (its whitespace, comments and length rules included). */
typedef struct {
    char name[64];
    bool seen;
} probe_t;

static int probe_handler(void *user, const char *section, const char *name,
                         const char *value)
{
    probe_t *p = user;
    (void)name;
    (void)value;
    snprintf(p->name, sizeof p->name, "%s", section);
    p->seen = true;
    return 1;
}

static void section_line(ctx_t *c, const char *line)
{
    char text[300];
    size_t n = strcspn(line, "\n");
    probe_t p = { "", false };
    if (n + sizeof "\n_=_\n" <= sizeof text) {
        memcpy(text, line, n);
        memcpy(text + n, "\n_=_\n", sizeof "\n_=_\n");
        if (ini_parse_string(text, probe_handler, &p) != 0)
            p.seen = false;
    }
    if (!p.seen) {
        /* libinih refuses this line; its error (reported at the end) is
         * the one to show, so the current section stays as it is. */
        c->bad_header_line = c->lineno;
        return;
    }
    begin_section(c, p.name);
}

/* ---- libinih callbacks -------------------------------------------------- */

/* ini_reader: one whole line into str[num], '\n'-terminated; counts lines
 * and looks at each before libinih parses it (see the top of the file). */
static char *read_line(char *str, int num, void *stream)
{
    ctx_t *c = stream;
    if (num < 3)
        return NULL;
    size_t cap = (size_t)num - 2; /* room for '\n' and NUL */
    size_t len = 0;
    bool too_long = false, nul = false;
    int ch;
    while ((ch = getc(c->fp)) != EOF && ch != '\n') {
        if (ch == '\0')
            nul = true;
        if (len < cap)
            str[len++] = (char)ch;
        else
            too_long = true;
    }
    if (ch == EOF && len == 0)
        return NULL;
    str[len++] = '\n';
    str[len] = '\0';
    c->lineno++;
    if (c->err_line != 0)
        return str; /* the first error stands; libinih just runs out */
    if (nul) {
        fail(c, c->lineno, "NUL byte in line (allowed: a text file)");
        return str;
    }
    if (too_long) {
        fail(c, c->lineno, "line too long (at most %zu characters)", cap);
        return str;
    }
    const char *p = str;
    if (c->lineno == 1 && strncmp(p, "\xEF\xBB\xBF", 3) == 0)
        p += 3; /* UTF-8 BOM, which libinih skips too */
    const char *q = p;
    while (is_space(*q))
        q++;
    if (*q == '\0' || *q == ';' || *q == '#')
        return str; /* blank or comment: libinih's start-of-line prefixes */
    if (q != p) {
        fail(c, c->lineno,
             "line starts with whitespace (INI reads an indented line as the "
             "continuation of the previous value; start keys and sections in "
             "column 1)");
        return str;
    }
    if (*q == '[')
        section_line(c, q);
    return str;
}

static int on_key(void *user, const char *section, const char *name,
                  const char *value)
{
    ctx_t *c = user;
    if (c->err_line != 0)
        return 0;
    if (strcmp(section, c->sec_raw) != 0) {
        /* The reader and libinih disagree on the section: a bug here. */
        fail(c, c->lineno, "internal error: section [%s] not tracked", section);
        return 0;
    }
    switch (c->sec) {
    case SEC_DAEMON: daemon_key(c, name, value); break;
    case SEC_MODBUS: modbus_key(c, name, value); break;
    case SEC_ROBOT: robot_key(c, name, value); break;
    case SEC_GPIO: gpio_key(c, name, value); break;
    case SEC_RTU: rtu_key(c, name, value); break;
    case SEC_MQTT: mqtt_key(c, name, value); break;
    case SEC_NONE:
        fail(c, c->lineno,
             "key '%s' outside any section (allowed sections: " SECTIONS_ALLOWED
             ")",
             name);
        break;
    }
    return c->err_line == 0;
}

/* ---- checks across sections --------------------------------------------- */

static unsigned line_or(unsigned key_line, unsigned section_line)
{
    return key_line != 0 ? key_line : section_line;
}

/* A connection point of the plan (config_instance or a heartbeat in use)
 * that is also an assembly's instance: the target could not tell them
 * apart. False after reporting it. */
static bool check_point(ctx_t *c, const gw_robot_config_t *r, const robot_lines_t *rl,
                        int key, uint16_t inst)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (r->instance[a] != inst)
            continue;
        unsigned lk = line_or(rl->key[key], r->line), la = line_or(rl->instance[a], r->line);
        fail(c, lk > la ? lk : la,
             "robot '%s': %s %u is also the instance of %s (a connection point names one "
             "thing)", r->name, robot_keys[key].name, (unsigned)inst, dr_asm_info((dr_asm_t)a)->name);
        return false;
    }
    return true;
}

/* The configuration point equal to a heartbeat point the plan uses (key
 * hb): a Forward Open would name one instance as both, which the robot
 * refuses at run time (the defaults invite it: listen_only_heartbeat is
 * 199, and 199 is a common configuration instance). False after
 * reporting it. */
static bool check_config_point(ctx_t *c, const gw_robot_config_t *r, const robot_lines_t *rl,
                               int hb, uint16_t inst)
{
    if (r->config_instance != inst)
        return true;
    unsigned lc = line_or(rl->key[RK_CONFIG_INSTANCE], r->line), lh = line_or(rl->key[hb], r->line);
    fail(c, lc > lh ? lc : lh,
         "robot '%s': config_instance %u is also %s (%sthe robot refuses a Forward Open that "
         "names one instance as both: set %s to another point of its EDS)", r->name,
         (unsigned)inst, robot_keys[hb].name, rl->key[hb] != 0 ? "" : "its default; ",
         robot_keys[hb].name);
    return false;
}

/* The connection plan: every O->T assembly has at most one owner, at
 * least one connection is opened, the instances it uses are distinct. */
static bool check_plan(ctx_t *c, const gw_robot_config_t *r, const robot_lines_t *rl)
{
    int owner[DR_ASM_COUNT];
    bool any = false, input_only = false, listen_only = false;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        owner[a] = -1;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const gw_open_t *o = &r->open[a];
        any |= o->kind != GW_OPEN_NONE;
        input_only |= o->kind == GW_OPEN_INPUT_ONLY;
        listen_only |= o->kind == GW_OPEN_LISTEN_ONLY;
        if (o->kind != GW_OPEN_OWNER)
            continue;
        if (owner[o->o2t] >= 0) {
            /* Reported where the second one (in the file) is. */
            unsigned b = (unsigned)owner[o->o2t];
            unsigned la = line_or(rl->open[a], r->line), lb = line_or(rl->open[b], r->line);
            unsigned later = la >= lb ? a : b, earlier = la >= lb ? b : a;
            char where[32];
            if (rl->open[earlier] != 0)
                snprintf(where, sizeof where, "line %u", rl->open[earlier]);
            else
                snprintf(where, sizeof where, "the default");
            fail(c, la >= lb ? la : lb,
                 "robot '%s': O->T %s has two owners, %s and %s (%s; one exclusive owner "
                 "connection per O->T assembly: make one of them input_only or listen_only)",
                 r->name, dr_asm_info((dr_asm_t)o->o2t)->name,
                 dr_asm_info((dr_asm_t)later)->name, dr_asm_info((dr_asm_t)earlier)->name, where);
            return false;
        }
        owner[o->o2t] = (int)a;
    }
    if (!any) {
        fail(c, r->line, "robot '%s': every open.* is none: nothing would be opened (allowed: "
             OPEN_ALLOWED ")", r->name);
        return false;
    }
    if (input_only && listen_only && r->input_only_heartbeat == r->listen_only_heartbeat) {
        unsigned li = line_or(rl->key[RK_INPUT_ONLY_HEARTBEAT], r->line);
        unsigned ll = line_or(rl->key[RK_LISTEN_ONLY_HEARTBEAT], r->line);
        fail(c, li > ll ? li : ll,
             "robot '%s': input_only_heartbeat and listen_only_heartbeat are both %u (the robot "
             "tells the two kinds apart by it)", r->name, (unsigned)r->input_only_heartbeat);
        return false;
    }
    /* explicit mode opens no connection: its points are not used */
    bool implicit = r->mode == GW_MODE_IMPLICIT;
    if (implicit && input_only &&
        !check_config_point(c, r, rl, RK_INPUT_ONLY_HEARTBEAT, r->input_only_heartbeat))
        return false;
    if (implicit && listen_only &&
        !check_config_point(c, r, rl, RK_LISTEN_ONLY_HEARTBEAT, r->listen_only_heartbeat))
        return false;
    return check_point(c, r, rl, RK_CONFIG_INSTANCE, r->config_instance) &&
           (!input_only || check_point(c, r, rl, RK_INPUT_ONLY_HEARTBEAT, r->input_only_heartbeat)) &&
           (!listen_only || check_point(c, r, rl, RK_LISTEN_ONLY_HEARTBEAT, r->listen_only_heartbeat));
}

static void check_robots(ctx_t *c)
{
    gw_config_t *g = &c->cfg;
    if (g->robot_count == 0) {
        fail(c, c->lineno,
             "no robot section (at least one is needed: [robot NAME] with host "
             "= "
             "the robot's address)");
        return;
    }
    for (unsigned i = 0; i < g->robot_count && c->err_line == 0; i++) {
        const gw_robot_config_t *r = &g->robot[i];
        const robot_lines_t *rl = &c->robot[i];
        if (r->host[0] == '\0') {
            fail(c, r->line,
                 "robot '%s' has no host (allowed: an IPv4 address or a host "
                 "name)",
                 r->name);
            return;
        }
        /* Two assemblies on one instance would read one another's data. */
        for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
            for (unsigned b = a + 1; b < DR_ASM_COUNT; b++) {
                if (r->instance[a] != r->instance[b])
                    continue;
                unsigned la = line_or(rl->instance[a], r->line);
                unsigned lb = line_or(rl->instance[b], r->line);
                fail(c, la > lb ? la : lb,
                     "robot '%s': instance %u used by both %s and %s (each "
                     "assembly needs its "
                     "own instance)",
                     r->name, (unsigned)r->instance[a],
                     dr_asm_info((dr_asm_t)a)->name,
                     dr_asm_info((dr_asm_t)b)->name);
                return;
            }
        }
        if (!check_plan(c, r, rl))
            return;
        for (unsigned j = 0; j < i; j++) {
            const gw_robot_config_t *o = &g->robot[j];
            if (o->unit_id == r->unit_id) {
                fail(c, line_or(rl->key[RK_UNIT_ID], r->line),
                     "robot '%s': unit_id %u%s already used by robot '%s' "
                     "(line %u; each robot "
                     "needs its own unit_id, allowed: 1..247)",
                     r->name, (unsigned)r->unit_id,
                     rl->key[RK_UNIT_ID] ? "" : " (the default)", o->name,
                     line_or(c->robot[j].key[RK_UNIT_ID], o->line));
                return;
            }
            if (strcmp(o->host, r->host) == 0 && o->tcp_port == r->tcp_port) {
                fail(c, line_or(rl->key[RK_HOST], r->line),
                     "robot '%s': %s:%u is already robot '%s' (line %u)",
                     r->name, r->host, (unsigned)r->tcp_port, o->name, o->line);
                return;
            }
        }
    }
}

/* Every [modbus_rtu]: a device, one not used by another line, robots
 * that exist (all of them if not said), each slave address once. */
static void check_rtu(ctx_t *c)
{
    gw_config_t *g = &c->cfg;
    for (unsigned i = 0; i < g->rtu_count && c->err_line == 0; i++) {
        gw_rtu_config_t *u = &g->rtu[i];
        const rtu_lines_t *ul = &c->rtu[i];
        if (u->device[0] == '\0') {
            fail(c, u->line, "modbus_rtu '%s' has no device (allowed: %s)", u->name,
                 rtu_keys[UK_DEVICE].allowed);
            return;
        }
        for (unsigned j = 0; j < i; j++)
            if (strcmp(g->rtu[j].device, u->device) == 0) {
                fail(c, line_or(ul->key[UK_DEVICE], u->line),
                     "modbus_rtu '%s': device %s is already modbus_rtu '%s' (line %u)",
                     u->name, u->device, g->rtu[j].name, g->rtu[j].line);
                return;
            }
        if (ul->key[UK_ROBOTS] == 0) {
            u->slave_count = g->robot_count;
            for (unsigned r = 0; r < g->robot_count; r++) {
                u->slave_robot[r] = r;
                u->slave_addr[r] = g->robot[r].unit_id;
            }
        } else {
            for (unsigned s = 0; s < u->slave_count; s++) {
                unsigned r = 0;
                while (r < g->robot_count && strcmp(g->robot[r].name, ul->robot[s]) != 0)
                    r++;
                if (r == g->robot_count) {
                    fail(c, ul->key[UK_ROBOTS],
                         "modbus_rtu '%s': no robot '%s' (allowed: the NAME of a "
                         "[robot NAME] section)",
                         u->name, ul->robot[s]);
                    return;
                }
                u->slave_robot[s] = r;
                if (!ul->addr_given[s])
                    u->slave_addr[s] = g->robot[r].unit_id;
            }
        }
        for (unsigned s = 0; s < u->slave_count; s++)
            for (unsigned t = 0; t < s; t++)
                if (u->slave_robot[s] == u->slave_robot[t] ||
                    u->slave_addr[s] == u->slave_addr[t]) {
                    fail(c, line_or(ul->key[UK_ROBOTS], u->line),
                         u->slave_robot[s] == u->slave_robot[t]
                             ? "modbus_rtu '%s': robot '%s' listed twice"
                             : "modbus_rtu '%s': robot '%s' has the slave address of "
                               "another robot on the line (each needs its own, 1..247)",
                         u->name, g->robot[u->slave_robot[s]].name);
                    return;
                }
    }
}

/* "/dev/gpiochip0", "gpiochip0" and "0" name the same chip (the spellings
 * gateway/gpio.h accepts besides a label). */
static void chip_key(const char *chip, char *out, size_t size)
{
    if (strncmp(chip, "/dev/", 5) == 0)
        chip += 5;
    bool number = *chip != '\0';
    for (const char *p = chip; *p; p++)
        if (!is_digit(*p))
            number = false;
    snprintf(out, size, "%s%s", number ? "gpiochip" : "", chip);
}

/* Whether the robot's connection plan opens an owner connection for O->T
 * assembly o2t: only those are written (Modbus writes to others get
 * exception 0x02). */
static bool has_owner(const gw_robot_config_t *r, int o2t)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (r->open[a].kind == GW_OPEN_OWNER && r->open[a].o2t == o2t)
            return true;
    return false;
}

/* An input on an O->T bit no connection writes would drive nothing. The
 * hint names the T->O partner of the default plan when there is one. */
static void unowned_input(ctx_t *c, const gw_gpio_config_t *gp, const gpio_lines_t *gl,
                          const char *path)
{
    int o2t = (int)gp->field.field->assembly;
    const char *o2t_name = dr_asm_info((dr_asm_t)o2t)->name;
    gw_robot_config_t def;
    memset(&def, 0, sizeof def);
    gw_robot_default_plan(&def);
    const char *t2o_name = "<T->O assembly>";
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (def.open[a].kind == GW_OPEN_OWNER && def.open[a].o2t == o2t)
            t2o_name = dr_asm_info((dr_asm_t)a)->name;
    fail(c, gl->key[GK_FIELD],
         "gpio '%s': input drives '%s', but robot '%s' opens no owner connection for %s "
         "(its open.* plan), so nothing would send it: give %s an owner (e.g. "
         "open.%s = owner:%s) or map the input elsewhere",
         gp->name, path, gp->robot, o2t_name, o2t_name, t2o_name, o2t_name);
}

static void check_gpio_one(ctx_t *c, unsigned i)
{
    gw_config_t *g = &c->cfg;
    gw_gpio_config_t *gp = &g->gpio[i];
    const gpio_lines_t *gl = &c->gpio[i];
    static const int required[] = { GK_CHIP, GK_LINE, GK_DIRECTION, GK_FIELD };
    for (size_t k = 0; k < COUNT(required); k++) {
        if (gl->key[required[k]] == 0) {
            fail(c, gp->line, "gpio '%s' has no %s (allowed: %s)", gp->name,
                 gpio_keys[required[k]].name, gpio_keys[required[k]].allowed);
            return;
        }
    }
    const char *names[GW_MAX_ROBOTS];
    for (unsigned r = 0; r < g->robot_count; r++)
        names[r] = g->robot[r].name;
    char allowed[GW_MAX_ROBOTS * (GW_NAME_MAX + 2)];
    join_names(names, g->robot_count, allowed, sizeof allowed);
    if (gp->robot[0] == '\0') {
        if (g->robot_count > 1) {
            fail(c, gp->line,
                 "gpio '%s' has no robot (several robots, allowed: %s)",
                 gp->name, allowed);
            return;
        }
        memcpy(gp->robot, g->robot[0].name, sizeof gp->robot);
    }
    bool found = false;
    for (unsigned r = 0; r < g->robot_count && !found; r++) {
        if (strcmp(g->robot[r].name, gp->robot) == 0) {
            gp->robot_index = r;
            found = true;
        }
    }
    if (!found) {
        fail(c, gl->key[GK_ROBOT],
             "gpio '%s': robot '%s' unknown (allowed: %s)", gp->name, gp->robot,
             allowed);
        return;
    }
    char path[64];
    if (dr_ref_path(gp->field, path, sizeof path) != DR_OK)
        path[0] = '\0';
    if (gp->dir == GW_GPIO_INPUT) {
        if (dr_asm_info((dr_asm_t)gp->field.field->assembly)->dir !=
            DR_DIR_O2T) {
            fail(c, gl->key[GK_FIELD],
                 "gpio '%s': input cannot drive '%s', which the robot produces "
                 "(T->O); "
                 "inputs drive O->T bits (io_control.cb_do[N], "
                 "io_control.tool_do[N], "
                 "io_control.ao_type.*, bit_in[N])",
                 gp->name, path);
        } else if (!has_owner(&g->robot[gp->robot_index], (int)gp->field.field->assembly)) {
            unowned_input(c, gp, gl, path);
        } else if (gl->key[GK_SAFE_VALUE] != 0) {
            fail(c, gl->key[GK_SAFE_VALUE],
                 "gpio '%s': safe_value applies to outputs only (this is an "
                 "input)",
                 gp->name);
        }
    } else if (gl->key[GK_DEBOUNCE_MS] != 0) {
        fail(
            c, gl->key[GK_DEBOUNCE_MS],
            "gpio '%s': debounce_ms applies to inputs only (this is an output)",
            gp->name);
    }
}

static void check_gpio(ctx_t *c)
{
    gw_config_t *g = &c->cfg;
    for (unsigned i = 0; i < g->gpio_count && c->err_line == 0; i++)
        check_gpio_one(c, i);
    for (unsigned i = 0; i < g->gpio_count && c->err_line == 0; i++) {
        const gw_gpio_config_t *b = &g->gpio[i];
        for (unsigned j = 0; j < i && c->err_line == 0; j++) {
            const gw_gpio_config_t *a = &g->gpio[j];
            /* Only the same spelling can be compared here: an offset and
             * a line name, or a chip label, resolve at run time (where
             * the kernel refuses a second request with EBUSY). */
            bool same_line =
                b->offset >= 0
                    ? b->offset == a->offset
                    : a->offset < 0 && strcmp(a->line_name, b->line_name) == 0;
            char ka[80], kb[80];
            chip_key(a->chip, ka, sizeof ka);
            chip_key(b->chip, kb, sizeof kb);
            if (same_line && strcmp(ka, kb) == 0) {
                char which[80];
                if (b->offset >= 0)
                    snprintf(which, sizeof which, "%d", b->offset);
                else
                    snprintf(which, sizeof which, "'%s'", b->line_name);
                fail(c, c->gpio[i].key[GK_LINE],
                     "gpio '%s': line %s of %s is already used by gpio '%s' "
                     "(line %u)",
                     b->name, which, b->chip, a->name, a->line);
                return;
            }
            if (a->dir == GW_GPIO_INPUT && b->dir == GW_GPIO_INPUT &&
                a->robot_index == b->robot_index &&
                a->field.field == b->field.field &&
                a->field.elem == b->field.elem) {
                char path[64];
                if (dr_ref_path(b->field, path, sizeof path) != DR_OK)
                    path[0] = '\0';
                fail(c, c->gpio[i].key[GK_FIELD],
                     "gpio '%s': %s of robot '%s' is already driven by input "
                     "gpio '%s' (line %u; "
                     "one input per bit)",
                     b->name, path, b->robot, a->name, a->line);
                return;
            }
        }
    }
}

/* ---- public API --------------------------------------------------------- */

void gw_config_defaults(gw_config_t *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    gw_modbus_config_t *m = &cfg->modbus;
    memcpy(m->listen, "0.0.0.0", sizeof "0.0.0.0");
    m->port = 502;
    m->max_clients = 16;
    m->idle_timeout_s = 60;
    m->keepalive = true;
    m->word_order = GW_WORD_ABCD;
    m->on_link_loss = GW_LOSS_HOLD;
    m->unmapped_read = GW_UNMAPPED_ZERO;
    m->allow_count = 0;
    m->single_writer = false;
    m->writer_watchdog_ms = 1000;
    m->request_timeout_ms = 3000;
    for (unsigned i = 0; i < GW_MAX_ROBOTS; i++)
        robot_defaults(&cfg->robot[i]);
    for (unsigned i = 0; i < GW_MAX_GPIO; i++)
        gpio_defaults(&cfg->gpio[i]);
    for (unsigned i = 0; i < GW_MAX_RTU; i++)
        rtu_defaults(&cfg->rtu[i]);
    memcpy(cfg->log_level, "info", sizeof "info");
    cfg->mqtt.port = 1883;
    cfg->mqtt.keepalive_s = 30;
    cfg->mqtt.retain = true;
    cfg->mqtt.publish_interval_ms = 100;
}

/* Errors about the file as a whole carry no line. */
static void file_error(char *err, size_t errlen, const char *path,
                       const char *what, const char *detail)
{
    if (err != NULL && errlen > 0)
        snprintf(err, errlen, "%s: %s%s%s", path, what, detail ? ": " : "",
                 detail ? detail : "");
}

bool gw_config_load(const char *path, gw_config_t *out, char *err,
                    size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (path == NULL || out == NULL) {
        file_error(err, errlen, path ? path : "(null)",
                   "no configuration to load", NULL);
        return false;
    }
    ctx_t *c = calloc(1, sizeof *c);
    if (c == NULL) {
        file_error(err, errlen, path, "out of memory", NULL);
        return false;
    }
    gw_config_defaults(&c->cfg);
    if (strlen(path) >= sizeof c->cfg.path) {
        file_error(err, errlen, path, "path too long", NULL);
        free(c);
        return false;
    }
    memcpy(c->cfg.path, path, strlen(path) + 1);
    c->path = path;
    c->fp = fopen(path, "r");
    if (c->fp == NULL) {
        file_error(err, errlen, path, "cannot open", strerror(errno));
        free(c);
        return false;
    }
    int ret = ini_parse_stream(read_line, c, on_key, c);
    int read_errno = errno;
    bool read_error = ferror(c->fp) != 0;
    (void)fclose(c->fp); /* read only */
    c->fp = NULL;

    bool ok = false;
    if (read_error) {
        file_error(err, errlen, path, "cannot read", strerror(read_errno));
    } else if (ret < 0) {
        file_error(err, errlen, path, "libinih failed",
                   ret == -2 ? "out of memory" : NULL);
    } else {
        if (ret > 0 && (c->err_line == 0 || (unsigned)ret < c->err_line)) {
            /* A line libinih refused without calling us, before any error
             * of ours. */
            c->err_line = 0;
            if ((unsigned)ret == c->bad_header_line)
                fail(c, (unsigned)ret,
                     "section header without a closing ']' "
                     "(allowed: " SECTIONS_ALLOWED ")");
            else
                fail(c, (unsigned)ret,
                     "syntax error (allowed: [section], key = value, or a "
                     "comment starting with ; or #)");
        }
        if (c->err_line == 0)
            check_robots(c);
        if (c->err_line == 0)
            check_gpio(c);
        if (c->err_line == 0)
            check_rtu(c);
        if (c->err_line == 0)
            check_mqtt(c);
        if (c->err_line != 0) {
            if (err != NULL && errlen > 0)
                snprintf(err, errlen, "%s:%u: %s", path, c->err_line, c->err);
        } else {
            *out = c->cfg;
            ok = true;
        }
    }
    free(c);
    return ok;
}

static bool same_plan(const gw_robot_config_t *a, const gw_robot_config_t *b)
{
    for (unsigned i = 0; i < DR_ASM_COUNT; i++)
        if (a->open[i].kind != b->open[i].kind || a->open[i].o2t != b->open[i].o2t)
            return false;
    return true;
}

bool gw_robot_config_same_link(const gw_robot_config_t *a,
                               const gw_robot_config_t *b)
{
    /* Not compared: name (the caller pairs robots by it), unit_id and
     * fallback_hold (Modbus side only), line. */
    return strcmp(a->host, b->host) == 0 && a->tcp_port == b->tcp_port &&
           a->udp_port == b->udp_port &&
           strcmp(a->local_addr, b->local_addr) == 0 &&
           a->local_udp_port == b->local_udp_port && a->mode == b->mode &&
           a->rpi_ms == b->rpi_ms && a->timeout_mult == b->timeout_mult &&
           a->timeout_ms == b->timeout_ms && a->o2t_strict == b->o2t_strict &&
           memcmp(a->instance, b->instance, sizeof a->instance) == 0 &&
           a->config_instance == b->config_instance &&
           a->input_only_heartbeat == b->input_only_heartbeat &&
           a->listen_only_heartbeat == b->listen_only_heartbeat &&
           a->originator_serial == b->originator_serial && same_plan(a, b);
}

const char *gw_word_order_name(gw_word_order_t w)
{
    unsigned i = (unsigned)w;
    return i < COUNT(word_orders) ? word_orders[i] : "?";
}
