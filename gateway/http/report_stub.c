/* SPDX-License-Identifier: MIT */
/* Stand-ins for the console's report part (report.h) until it is in. */
#include "http/report.h"

bool gw_http_report_metrics(const gw_north_env_t *env, gw_json_t *out)
{
    (void)env, (void)out;
    return false;
}

bool gw_http_report_log(const gw_north_env_t *env, gw_json_t *out)
{
    (void)env, (void)out;
    return false;
}

void gw_http_report_sides(const gw_north_env_t *env, gw_json_t *out)
{
    (void)env, (void)out;
}
