/* SPDX-License-Identifier: MIT */
/* The report part as the server calls it (report.h): /metrics, /api/v1/log
 * and the status's "sides", from the daemon's env->metrics and
 * env->report (north.h) and the log ring (core/log.h). */
#include "http/report.h"

#include "http/metrics.h"

bool gw_http_report_metrics(const gw_north_env_t *env, gw_json_t *out)
{
    size_t n = gw_http_metrics(env, out->buf, out->cap);
    out->len = n;
    out->full = n == 0; /* did not fit: the server answers 500 */
    if (n == 0)
        out->buf[0] = '\0';
    return true;
}

bool gw_http_report_log(const gw_north_env_t *env, gw_json_t *out)
{
    (void)env;
    gw_http_log_json(out, false);
    return true;
}

bool gw_http_report_writes(const gw_north_env_t *env, gw_json_t *out)
{
    (void)env;
    gw_http_log_json(out, true);
    return true;
}

void gw_http_report_sides(const gw_north_env_t *env, gw_json_t *out)
{
    if (env->report != NULL)
        env->report(env->user, out);
}
