/* SPDX-License-Identifier: MIT */
/*
 * The robot's answer to the link's Identity read (gateway/core/robot.c,
 * gw_robot_identity_answer), as the robot may send it: the first byte
 * picks the request's status (0: DR_OK, 1: a CIP refusal, 2: no answer),
 * the rest is the reply's data.
 *
 * Checks: a known identity's fields are the reply's bytes where the
 * Identity puts them, its name no longer than the reply carries and 32 at
 * the most, terminated and printable; a refusal or a reply too short for
 * the seven attributes leaves nothing known; no answer changes nothing;
 * the identity's text line is terminated and printable, also cut short.
 */
#include <string.h>

#include "core/robot.h"
#include "fuzz.h"

static gw_robot_t R;

static int printable(const char *s)
{
    for (; *s != '\0'; s++)
        if ((unsigned char)*s < 0x20 || (unsigned char)*s >= 0x7F)
            return 0;
    return 1;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    static const dr_status_t status[] = {DR_OK, DR_CIP(0x08, 0), DR_ETIMEDOUT};
    dr_status_t st = status[data[0] % 3u];
    const uint8_t *reply = data + 1;
    size_t len = size - 1;
    gw_robot_identity_t before = R.identity;
    dr_status_t got = gw_robot_identity_answer(&R, st, reply, len);
    const gw_robot_identity_t *id = &R.identity;
    if (st == DR_ETIMEDOUT) {
        FUZZ_CHECK(got == DR_ETIMEDOUT && gw_robot_identity_same(&before, id));
    } else if (got == DR_OK) {
        FUZZ_CHECK(st == DR_OK && id->state == GW_IDENTITY_KNOWN && len >= 15);
        FUZZ_CHECK(id->vendor_id == dr_get_le16(reply) && id->serial == dr_get_le32(reply + 10));
        FUZZ_CHECK(id->rev_major == reply[6] && id->rev_minor == reply[7]);
        size_t n = strlen(id->product_name);
        FUZZ_CHECK(n < GW_IDENTITY_NAME && n <= reply[14] && 15u + reply[14] <= len);
        FUZZ_CHECK(printable(id->product_name));
    } else {
        FUZZ_CHECK(got == st || (st == DR_OK && got == DR_ESHORT));
        FUZZ_CHECK(id->state == GW_IDENTITY_REFUSED && id->why == got);
        FUZZ_CHECK(id->serial == 0 && id->vendor_id == 0 && id->product_name[0] == '\0');
    }
    char text[200];
    size_t cap = 1 + (len > 0 ? reply[0] % sizeof text : sizeof text - 1);
    memset(text, 'x', sizeof text);
    gw_robot_identity_text(id, text, cap);
    FUZZ_CHECK(memchr(text, '\0', cap) != NULL && printable(text));
    return 0;
}
