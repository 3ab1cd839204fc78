/* SPDX-License-Identifier: MIT */
/* /metrics, /api/v1/log and a robot's last write for the console: see metrics.h. */
#include "http/metrics.h"

#include <stdio.h>
#include <string.h>
#include <time.h>

#include "core/log.h"
#include "core/prom.h"

size_t gw_http_metrics(const gw_north_env_t *env, char *buf, size_t cap)
{
    static gw_prom_t m; /* the family table is a few hundred bytes: not on the stack */
    if (cap == 0)
        return 0;
    gw_prom_init(&m, buf, cap);
    if (env->metrics != NULL)
        env->metrics(env->user, &m);
    return m.full ? 0 : m.len;
}

void gw_http_time_json(gw_json_t *j, uint64_t time_us)
{
    time_t s = (time_t)(time_us / 1000000u);
    struct tm tm;
    char t[48];
    if (gmtime_r(&s, &tm) == NULL) {
        gw_json_str(j, "null");
        return;
    }
    size_t n = strftime(t, sizeof t, "%Y-%m-%dT%H:%M:%S", &tm);
    snprintf(t + n, sizeof t - n, ".%03uZ", (unsigned)(time_us / 1000u % 1000u));
    gw_json_quote(j, t, strlen(t));
}

static void log_event(void *user, const gw_log_event_t *e)
{
    gw_json_t *j = user;
    if (j->buf[j->len - 1] != '[')
        gw_json_str(j, ",");
    gw_json_str(j, "{\"time\":");
    gw_http_time_json(j, e->time_us);
    gw_json_str(j, ",\"level\":\"");
    gw_json_str(j, gw_log_level_name(e->level));
    gw_json_str(j, "\",\"text\":");
    gw_json_quote(j, e->text, strlen(e->text));
    gw_json_str(j, "}");
}

void gw_http_log_json(gw_json_t *j, bool writes)
{
    gw_json_str(j, "[");
    if (j->full)
        return;
    if (writes)
        gw_log_writes_each(log_event, j);
    else
        gw_log_ring_each(log_event, j);
    gw_json_str(j, "]");
}

void gw_http_last_write_json(gw_json_t *j, const gw_robot_t *r)
{
    const gw_robot_write_t *w = &r->last_write;
    if (w->time_us == 0) {
        gw_json_str(j, "null");
        return;
    }
    gw_json_str(j, "{\"time\":");
    gw_http_time_json(j, w->time_us);
    gw_json_str(j, ",\"client\":");
    gw_json_quote(j, w->client, strlen(w->client));
    gw_json_str(j, ",\"fields\":[");
    for (unsigned i = 0; i < w->nfields && i < GW_WRITE_FIELDS; i++) {
        if (i > 0)
            gw_json_str(j, ",");
        gw_json_quote(j, w->fields[i], strlen(w->fields[i]));
    }
    char more[32];
    snprintf(more, sizeof more, "],\"more\":%u}",
             w->nfields > GW_WRITE_FIELDS ? w->nfields - GW_WRITE_FIELDS : 0u);
    gw_json_str(j, more);
}
