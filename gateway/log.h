/* SPDX-License-Identifier: MIT */
/* Logging to stderr (the journal under systemd) with levels and a limiter
 * for errors that repeat. */
#ifndef DRGATE_GW_LOG_H
#define DRGATE_GW_LOG_H

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

void gw_log(gw_log_level_t level, const char *fmt, ...) GW_PRINTF(2, 3);
/* At most one line every 10 s per *last_us; the lines in between are
 * counted and the count is reported with the next one that passes. */
void gw_log_limited(gw_log_level_t level, uint64_t *last_us, const char *fmt, ...)
    GW_PRINTF(3, 4);

#endif
