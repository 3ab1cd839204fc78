/* SPDX-License-Identifier: MIT */
/*
 * dr_codec: links drgate::codec alone (no client, no text); decodes a
 * joint_state image with position[1] = 31.5 degrees (0x41FC0000,
 * little-endian) and says what it read.
 */
#include <stdio.h>

#include "drgate/codec.h"

int main(void)
{
    uint8_t img[144] = {0};
    img[2] = 0xFC;
    img[3] = 0x41;
    dr_joint_state_t js;
    if (dr_joint_state_decode(img, sizeof img, &js) != DR_OK || js.position[0] != 31.5f)
        return 1;
    printf("codec: %u fields, joint_state.position[1] = 31.5\n", (unsigned)dr_field_count());
    return 0;
}
