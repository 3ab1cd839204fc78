/* SPDX-License-Identifier: MIT */
/* Logging to stderr (the journal under systemd) with levels and a limiter
 * for errors that repeat. */
#ifndef DRGATE_GW_LOG_H
#define DRGATE_GW_LOG_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef enum { GW_LOG_ERROR = 3, GW_LOG_WARNING = 4, GW_LOG_INFO = 6, GW_LOG_DEBUG = 7 } gw_log_level_t;

void gw_log_set_level(gw_log_level_t max);
/* "error", "warning", "info", "debug"; false if unknown. */
int gw_log_level_parse(const char *name, gw_log_level_t *out);

#if defined(__GNUC__)
#define GW_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define GW_PRINTF(a, b)
#endif

/* One line: formatted (at most GW_LOG_LINE_MAX bytes), its control
 * characters escaped (gw_log_escape), then printed and kept. */
#define GW_LOG_LINE_MAX 2048
void gw_log(gw_log_level_t level, const char *fmt, ...) GW_PRINTF(2, 3);

/* in[0..n) (up to a '\0') into out[cap] with every control character
 * (0x00-0x1f, 0x7f) written as \xNN, so that text from outside (a user
 * name, an MQTT topic, a client id, a path) can neither start a line of
 * its own nor move the terminal; cut to fit, always terminated. Returns
 * the length written. gw_log applies it to every line. */
size_t gw_log_escape(char *out, size_t cap, const char *in, size_t n);

/* The last GW_LOG_RING lines logged (those the level lets through, as
 * printed, without the time stamp), kept for the console's /api/v1/log. */
#define GW_LOG_RING 200
#define GW_LOG_TEXT 256 /* a longer line is kept cut to this */
typedef struct {
    uint64_t time_us; /* wall clock (CLOCK_REALTIME), microseconds since 1970 */
    gw_log_level_t level;
    char text[GW_LOG_TEXT];
} gw_log_event_t;
/* Which ring a line goes to: the events' (everything), or the writes'
 * (the write log's lines, gw_write_log): a PLC that writes once a second
 * would otherwise push the start-up and link events out of the events'
 * ring within minutes. Each ring holds GW_LOG_RING lines. */
typedef enum { GW_LOG_EVENTS = 0, GW_LOG_WRITES = 1 } gw_log_ring_t;
/* Keep the ring (true) or not (false, the default): only a daemon with a
 * console ([http]) keeps it, so that one without has no page of it in
 * memory (issue 21: the same RSS as before the console). */
void gw_log_ring_keep(bool on);
/* fn for each event in the ring, the oldest first. */
void gw_log_ring_each(void (*fn)(void *user, const gw_log_event_t *e), void *user);
/* Events ever logged (those beyond GW_LOG_RING have left the ring). */
uint64_t gw_log_ring_total(void);
/* The same for the writes' ring. */
void gw_log_writes_each(void (*fn)(void *user, const gw_log_event_t *e), void *user);
uint64_t gw_log_writes_total(void);
/* "error", "warning", "info", "debug". */
const char *gw_log_level_name(gw_log_level_t level);

/* One kind of message that may repeat (one per call site and object):
 * zero-initialised. */
typedef struct {
    uint64_t last_us;    /* when one was last printed */
    unsigned suppressed; /* of this kind since, when log.c had no room for them */
    unsigned slot;       /* log.c's entry for the ones it holds (0: none) */
    uint32_t window_ms;  /* at most one line per window_ms (whole seconds); 0: 10 s */
    uint8_t ring;        /* gw_log_ring_t its lines are kept in (0: the events') */
} gw_log_limit_t;

/* At most one line every 10 s per limit (window_ms: another window, such
 * as the write log's second); the lines in between are counted
 * for that kind, and when its 10 s are over gw_log_flush prints the latest
 * of them with the count ("... [N similar messages suppressed in 10 s, the
 * last shown]"). A line of the kind that comes after the 10 s and before
 * the flush ends with the count instead ("... [N similar messages
 * suppressed]"). */
void gw_log_limited(gw_log_level_t level, gw_log_limit_t *limit, const char *fmt, ...)
    GW_PRINTF(3, 4);

/* The condition the kind's lines were about is over (a link came up):
 * what it still holds back is printed now, as "... [N similar messages
 * suppressed until now, the last shown]", before the caller says what
 * changed, so that no count of past faults follows it and reads like a
 * current one; and the kind's next line is shown at once. */
void gw_log_limit_end(gw_log_limit_t *limit);

/* Prints the counts of the kinds whose 10 s ended by now (ev_now_us()); the
 * daemon's tick calls it. What is still pending at exit is printed then. */
void gw_log_flush(uint64_t now);

#endif
