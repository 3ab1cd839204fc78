/* SPDX-License-Identifier: MIT */
/* Log lines: "<N>" priority prefixes when stderr is the journal (systemd
 * sets JOURNAL_STREAM), a level word otherwise. */
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "log.h"
#include "loop.h"

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

/* suppressed: a count of the same kind to end the line with (0: none). */
static void vlog(gw_log_level_t level, unsigned suppressed, const char *fmt, va_list ap)
{
    static const char *const words[8] = {"", "", "", "error", "warning", "", "info", "debug"};
    if (level > max_level)
        return;
    if (getenv("JOURNAL_STREAM") != NULL)
        fprintf(stderr, "<%d>", (int)level);
    else
        fprintf(stderr, "drgatewayd: %s: ", words[level]);
    vfprintf(stderr, fmt, ap);
    if (suppressed > 0)
        fprintf(stderr, " [%u similar message%s suppressed]", suppressed,
                suppressed == 1 ? "" : "s");
    fputc('\n', stderr);
}

void gw_log(gw_log_level_t level, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vlog(level, 0, fmt, ap);
    va_end(ap);
}

void gw_log_limited(gw_log_level_t level, gw_log_limit_t *limit, const char *fmt, ...)
{
    uint64_t now = gw_now_us();
    if (limit->last_us != 0 && now - limit->last_us < LIMIT_US) {
        limit->suppressed++;
        return;
    }
    limit->last_us = now;
    va_list ap;
    va_start(ap, fmt);
    vlog(level, limit->suppressed, fmt, ap);
    va_end(ap);
    limit->suppressed = 0;
}
