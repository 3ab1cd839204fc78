/* SPDX-License-Identifier: MIT */
/* When a leaf is published again (deadband.h). */
#include "mqtt/deadband.h"

#include <math.h>

bool gw_mqtt_changed(const gw_mqtt_last_t *last, const dr_value_t *v, double deadband)
{
    if (!last->have)
        return true;
    double x = dr_value_as_double(v);
    if (v->type != DR_VAL_REAL)
        return x != last->v;
    if (isnan(x) || isnan(last->v))
        return isnan(x) != isnan(last->v);
    if (isinf(x) || isinf(last->v))
        return x != last->v;
    return fabs(x - last->v) > deadband || (deadband == 0.0 && x != last->v);
}
