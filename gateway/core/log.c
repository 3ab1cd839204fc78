/* SPDX-License-Identifier: MIT */
/* Log lines: "<N>" priority prefixes when stderr is the journal (systemd
 * sets JOURNAL_STREAM), which stamps each line itself; otherwise the local
 * time to the millisecond and a level word, so that a log kept in a file
 * or read on a terminal says when each thing happened. */
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "common/ev.h"
#include "core/log.h"

#define LIMIT_US 10000000u

static gw_log_level_t max_level = GW_LOG_INFO;

void gw_log_set_level(gw_log_level_t max)
{
    max_level = max;
}

int gw_log_level_parse(const char *name, gw_log_level_t *out)
{
    static const struct { const char *n; gw_log_level_t l; } t[] = {
        {"error", GW_LOG_ERROR}, {"warning", GW_LOG_WARNING},
        {"info", GW_LOG_INFO}, {"debug", GW_LOG_DEBUG}};
    for (size_t i = 0; i < sizeof t / sizeof t[0]; i++)
        if (strcmp(name, t[i].n) == 0) {
            *out = t[i].l;
            return 1;
        }
    return 0;
}

/* "2025-03-14 09:26:53.589": the wall clock, local time. */
static const char *time_stamp(char *buf, size_t size)
{
    struct timespec ts;
    struct tm tm;
    buf[0] = '\0';
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0 || localtime_r(&ts.tv_sec, &tm) == NULL)
        return buf;
    size_t n = strftime(buf, size, "%Y-%m-%d %H:%M:%S", &tm);
    if (n > 0 && n < size)
        snprintf(buf + n, size - n, ".%03ld", ts.tv_nsec / 1000000L);
    return buf;
}

static const char *const words[8] = {"", "", "", "error", "warning", "", "info", "debug"};

/* ---- the ring of the last events (for the console) --------------------------- */

static gw_log_event_t ring[2][GW_LOG_RING]; /* by gw_log_ring_t */
static uint64_t ring_total[2];               /* lines ever put in */
static bool ring_on;

void gw_log_ring_keep(bool on)
{
    ring_on = on;
}

static void ring_put(unsigned which, gw_log_level_t level, const char *text)
{
    struct timespec ts;
    gw_log_event_t *e = &ring[which][ring_total[which] % GW_LOG_RING];
    ring_total[which]++;
    e->time_us = clock_gettime(CLOCK_REALTIME, &ts) == 0
                     ? (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u
                     : 0;
    e->level = level;
    size_t n = strlen(text);
    if (n >= sizeof e->text)
        n = sizeof e->text - 1; /* cut, as the ring always kept them */
    memcpy(e->text, text, n);
    e->text[n] = '\0';
}

static void each(unsigned which, void (*fn)(void *user, const gw_log_event_t *e), void *user)
{
    uint64_t n = ring_total[which], first = n > GW_LOG_RING ? n - GW_LOG_RING : 0;
    for (uint64_t i = first; i < n; i++)
        fn(user, &ring[which][i % GW_LOG_RING]);
}

void gw_log_ring_each(void (*fn)(void *user, const gw_log_event_t *e), void *user)
{
    each(GW_LOG_EVENTS, fn, user);
}

uint64_t gw_log_ring_total(void)
{
    return ring_total[GW_LOG_EVENTS];
}

void gw_log_writes_each(void (*fn)(void *user, const gw_log_event_t *e), void *user)
{
    each(GW_LOG_WRITES, fn, user);
}

uint64_t gw_log_writes_total(void)
{
    return ring_total[GW_LOG_WRITES];
}

const char *gw_log_level_name(gw_log_level_t level)
{
    return (unsigned)level < 8u ? words[level] : "";
}

size_t gw_log_escape(char *out, size_t cap, const char *in, size_t n)
{
    static const char hex[] = "0123456789abcdef";
    size_t len = 0;
    if (cap == 0)
        return 0;
    for (size_t i = 0; i < n && in[i] != '\0'; i++) {
        unsigned char ch = (unsigned char)in[i];
        bool ctl = ch < 0x20 || ch == 0x7f;
        if (len + (ctl ? 4u : 1u) >= cap)
            break;
        if (ctl) {
            out[len++] = '\\';
            out[len++] = 'x';
            out[len++] = hex[ch >> 4];
            out[len++] = hex[ch & 15u];
        } else {
            out[len++] = (char)ch;
        }
    }
    out[len] = '\0';
    return len;
}

/* suppressed: a count of the same kind to end the line with (0: none).
 * The line is formatted once, and every control character in it escaped
 * (gw_log_escape) before it is printed or kept: the texts of log lines
 * come partly from outside (a user name, a topic, a client id, a path),
 * and one with a newline in it must not become two lines, the second of
 * them forged ("\n<0>..." is an emergency in the journal). */
static void vlog(unsigned which, gw_log_level_t level, unsigned suppressed, const char *fmt,
                 va_list ap) GW_PRINTF(4, 0);
static void vlog(unsigned which, gw_log_level_t level, unsigned suppressed, const char *fmt,
                 va_list ap)
{
    if (level > max_level)
        return;
    char raw[GW_LOG_LINE_MAX], line[GW_LOG_LINE_MAX * 2];
    int n = vsnprintf(raw, sizeof raw, fmt, ap);
    if (n < 0)
        raw[0] = '\0';
    size_t len = gw_log_escape(line, sizeof line, raw, sizeof raw);
    if (suppressed > 0)
        snprintf(line + len, sizeof line - len, " [%u similar message%s suppressed]",
                 suppressed, suppressed == 1 ? "" : "s");
    if (ring_on)
        ring_put(which == GW_LOG_WRITES ? GW_LOG_WRITES : GW_LOG_EVENTS, level, line);
    if (getenv("JOURNAL_STREAM") != NULL) {
        fprintf(stderr, "<%d>%s\n", (int)level, line);
    } else {
        char stamp[32];
        fprintf(stderr, "%s drgatewayd: %s: %s\n", time_stamp(stamp, sizeof stamp), words[level],
                line);
    }
}

void gw_log(gw_log_level_t level, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vlog(GW_LOG_EVENTS, level, 0, fmt, ap);
    va_end(ap);
}

/* gw_log into ring `which`. */
static void log_to(unsigned which, gw_log_level_t level, const char *fmt, ...) GW_PRINTF(3, 4);
static void log_to(unsigned which, gw_log_level_t level, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vlog(which, level, 0, fmt, ap);
    va_end(ap);
}

/* ---- limited kinds ------------------------------------------------------------
 * While a kind is being suppressed, its count and a copy of its latest line
 * live here rather than in its gw_log_limit_t: gw_log_flush then never
 * reads the owner's memory, so a robot, map or server freed (by a reload)
 * with a count still pending neither dangles nor loses that count. An
 * entry also holds the kind's window: after a summary the next 10 s are
 * suppressed as well, so a flood that goes on prints one line per 10 s. */

#define PENDING_MAX 64  /* kinds suppressing at once; beyond, the old way */
#define TEXT_MAX 256

typedef struct {
    const gw_log_limit_t *limit; /* identity only, never dereferenced */
    uint64_t due_us;             /* end of the kind's window */
    uint64_t window_us;          /* its length (window_of) */
    gw_log_level_t level;
    uint8_t ring;                /* the kind's (gw_log_limit_t ring) */
    unsigned count;              /* suppressed in this window */
    char text[TEXT_MAX];         /* the latest of them */
} pending_t;

static pending_t pending[PENDING_MAX];

/* A kind's window: 10 s unless it says otherwise. */
static uint64_t window_of(const gw_log_limit_t *limit)
{
    return limit->window_ms != 0 ? (uint64_t)limit->window_ms * 1000u : LIMIT_US;
}

static pending_t *pending_of(const gw_log_limit_t *limit)
{
    if (limit->slot == 0 || limit->slot > PENDING_MAX)
        return NULL;
    pending_t *p = &pending[limit->slot - 1];
    return p->limit == limit ? p : NULL;
}

static void flush_at_exit(void)
{
    gw_log_flush(UINT64_MAX);
}

static pending_t *pending_new(gw_log_limit_t *limit, uint64_t due_us, gw_log_level_t level)
{
    static bool at_exit;
    if (!at_exit)
        at_exit = atexit(flush_at_exit) == 0;
    for (unsigned i = 0; i < PENDING_MAX; i++)
        if (pending[i].limit == NULL) {
            pending[i] = (pending_t){.limit = limit, .due_us = due_us,
                                     .window_us = window_of(limit), .level = level,
                                     .ring = limit->ring};
            limit->slot = i + 1;
            return &pending[i];
        }
    return NULL;
}

static void pending_print(const pending_t *p, const char *when)
{
    log_to(p->ring, p->level, "%s [%u similar message%s suppressed %s, the last shown]", p->text,
           p->count, p->count == 1 ? "" : "s", when);
}

void gw_log_limited(gw_log_level_t level, gw_log_limit_t *limit, const char *fmt, ...)
{
    uint64_t now = ev_now_us();
    pending_t *p = pending_of(limit);
    uint64_t end = p != NULL ? p->due_us : limit->last_us + window_of(limit);
    va_list ap;
    va_start(ap, fmt);
    if (limit->last_us != 0 && now < end) {
        if (p == NULL)
            p = pending_new(limit, end, level);
        if (p != NULL) {
            p->count++;
            p->level = level;
            (void)vsnprintf(p->text, sizeof p->text, fmt, ap);
        } else {
            limit->suppressed++; /* table full: ends the kind's next line */
        }
        va_end(ap);
        return;
    }
    /* a window over but not flushed yet (the tick runs at 10 Hz): its
     * count ends this line, as one that waited for the next line does */
    unsigned n = limit->suppressed;
    if (p != NULL) {
        n += p->count;
        p->limit = NULL;
    }
    limit->last_us = now;
    limit->suppressed = 0;
    vlog(limit->ring, level, n, fmt, ap);
    va_end(ap);
}

void gw_log_flush(uint64_t now)
{
    for (unsigned i = 0; i < PENDING_MAX; i++) {
        pending_t *p = &pending[i];
        if (p->limit == NULL || now < p->due_us)
            continue;
        if (p->count == 0) {
            p->limit = NULL; /* a quiet window: the kind is free again */
            continue;
        }
        char in[32];
        snprintf(in, sizeof in, "in %llu s", (unsigned long long)(p->window_us / 1000000u));
        pending_print(p, in);
        p->count = 0;
        p->due_us = now + p->window_us;
    }
}

void gw_log_limit_end(gw_log_limit_t *limit)
{
    pending_t *p = pending_of(limit);
    if (p != NULL) {
        if (p->count > 0)
            pending_print(p, "until now");
        p->limit = NULL;
    }
    limit->last_us = 0; /* the next line of the kind is a new story: shown */
}
