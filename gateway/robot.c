/* SPDX-License-Identifier: MIT */
/* One robot's images and link facts: see robot.h. */
#include "robot.h"

#include <stdio.h>
#include <string.h>

void gw_robot_init(gw_robot_t *r, const char *name, uint32_t serial)
{
    memset(r, 0, sizeof *r);
    snprintf(r->name, sizeof r->name, "%s", name != NULL ? name : "");
    r->serial = serial;
}

void gw_robot_carry_over(gw_robot_t *r, const gw_robot_t *old)
{
    r->heartbeat = old->heartbeat;
    r->link.rx_packets = old->link.rx_packets;
    r->link.lost_packets = old->link.lost_packets;
}

/* Kept for every failure, not only the ones that change the link's state:
 * an adapter that refuses every Forward Open never brings the link up. */
void gw_robot_record_error(gw_robot_t *r, dr_status_t why)
{
    if (why == DR_OK)
        return;
    if (DR_IS_CIP(why)) {
        r->link.last_cip_general = DR_CIP_GENERAL(why);
        r->link.last_error =
            DR_CIP_EXTENDED(why) != 0 ? DR_CIP_EXTENDED(why) : DR_CIP_GENERAL(why);
    } else {
        r->link.last_cip_general = 0;
        r->link.last_error = (uint16_t)why;
    }
}

void gw_robot_link_down(gw_robot_t *r)
{
    if (!r->clear_while_down)
        return;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O)
            memset(r->img[a], 0, DR_ASM_MAX_SIZE);
}

bool gw_robot_takes_data(const gw_robot_t *r, bool link_up)
{
    return link_up || !r->clear_while_down;
}

dr_status_t gw_robot_get(const gw_robot_t *r, dr_ref_t ref, dr_value_t *v)
{
    if (ref.field == NULL || ref.field->assembly >= DR_ASM_COUNT)
        return DR_EINVAL;
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    return dr_field_get(r->img[a], dr_asm_info(a)->size, ref, v);
}
