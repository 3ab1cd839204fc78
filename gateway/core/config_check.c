/* SPDX-License-Identifier: MIT */
/*
 * What spans sections, checked once the whole file is read
 * (config_internal.h): robots against each other (the sides' keys of
 * them through their `pair`, then addresses). The sides check theirs in
 * their config_NAME.c (GPIO lines and serial lines against the robots
 * they name, ...). Each table has already
 * checked every value; the first error wins, in the sections' rank order.
 */
#include "core/config_internal.h"

#include <string.h>

unsigned gw_cfg_line_or(unsigned key_line, unsigned section_line)
{
    return key_line != 0 ? key_line : section_line;
}

/* ---- robots ------------------------------------------------------------------ */

/* Robot i against the robots before it: the sides' keys (a Modbus unit
 * ID, ...: gw_cfg_robot_keys_t.pair), then its address. */
static bool robot_unique(gw_cfg_ctx_t *c, unsigned i)
{
    const gw_cfg_side_t *s = &gw_cfg_robot;
    const gw_robot_config_t *r = &c->cfg.robot[i];
    for (unsigned j = 0; j < i; j++) {
        const gw_robot_config_t *o = &c->cfg.robot[j];
        for (unsigned k = 0; k < GW_SIDE_COUNT; k++) {
            const gw_cfg_robot_keys_t *rk = gw_side_cfgs[k]->robot;
            if (rk != NULL && rk->pair != NULL && !rk->pair(c, i, j))
                return false;
        }
        if (strcmp(o->host, r->host) == 0 && o->tcp_port == r->tcp_port) {
            gw_cfg_fail(c, gw_cfg_line_or(gw_cfg_line(c, s, i, "host"), r->line),
                        "robot '%s': %s:%u is already robot '%s' (line %u)",
                        r->name, r->host, (unsigned)r->tcp_port, o->name,
                        o->line);
            return false;
        }
    }
    return true;
}

void gw_cfg_check_robots(gw_cfg_ctx_t *c)
{
    if (c->cfg.robot_count == 0) {
        gw_cfg_fail(c, c->lineno,
                    "no robot section (at least one is needed: [robot NAME] "
                    "with host = the robot's address)");
        return;
    }
    for (unsigned i = 0; i < c->cfg.robot_count; i++)
        if (!gw_cfg_require(c, &gw_cfg_robot, i) || !gw_cfg_robot_check(c, i) ||
            !robot_unique(c, i))
            return;
}
