/* SPDX-License-Identifier: MIT */
/*
 * The daemon's log for the harnesses that reach it (the write path logs
 * accepted writes, core/write.c): formatted, so that the arguments are
 * checked, but not printed. gateway/core/log.c itself (its ring, its
 * limiter's timers) is the daemon's, not the parsers'.
 */
#include <stdarg.h>
#include <stdio.h>

#include "core/log.h"

void gw_log(gw_log_level_t level, const char *fmt, ...)
{
    char line[512];
    va_list ap;
    (void)level;
    va_start(ap, fmt);
    (void)vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
}

void gw_log_limited(gw_log_level_t level, gw_log_limit_t *limit, const char *fmt, ...)
{
    char line[512];
    va_list ap;
    (void)level, (void)limit;
    va_start(ap, fmt);
    (void)vsnprintf(line, sizeof line, fmt, ap);
    va_end(ap);
}
