/* SPDX-License-Identifier: MIT */
/*
 * gw_robot_t's own logic (gateway/core/robot.c): a robot starts empty with its
 * name and serial; a failure is recorded as the status block shows it
 * (CIP extended status, or the general one when there is none, and the
 * general status apart; anything else as its code); clear_while_down
 * clears the T->O images only, and only with it, and drops data while
 * the link is down; fields read from the images. The link and the sides
 * using it are covered end to end (tests/gateway).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "core/robot.h"

static gw_robot_t R;

static int setup(void **state)
{
    (void)state;
    memset(&R, 0xA5, sizeof R); /* gw_robot_init must clear all of it */
    gw_robot_init(&R, "arm", 7);
    return 0;
}

static void fill(uint8_t v)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        memset(R.img[a], v, DR_ASM_MAX_SIZE);
}

static void test_init(void **state)
{
    (void)state;
    assert_string_equal(R.name, "arm");
    assert_int_equal(R.serial, 7);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        for (unsigned i = 0; i < DR_ASM_MAX_SIZE; i++)
            assert_int_equal(R.img[a][i], 0);
    assert_int_equal(R.link.link_state, 0);
    assert_int_equal(R.link.rx_packets, 0);
    assert_int_equal(R.link.last_error, 0);
    assert_false(R.clear_while_down);
    assert_false(R.fault);
    assert_int_equal(R.o2t_unsent, 0);
    assert_int_equal(R.heartbeat, 0);
    /* a name longer than the field is cut, and terminated */
    gw_robot_init(&R, "a-robot-name-that-is-much-longer-than-32", 8);
    assert_int_equal(strlen(R.name), GW_NAME_MAX - 1);
    gw_robot_init(&R, NULL, 9);
    assert_string_equal(R.name, "");
}

/* A robot a reload changed starts anew (new serial, images and link facts
 * zero) but keeps its heartbeat and packet counters: they never go back. */
static void test_carry_over(void **state)
{
    (void)state;
    R.heartbeat = 41;
    R.link.rx_packets = 123456u;
    R.link.lost_packets = 7u;
    R.link.last_error = 0x0106;
    R.img[DR_ASM_IO_STATE][0] = 1;
    static gw_robot_t next;
    gw_robot_init(&next, "arm", 8);
    gw_robot_carry_over(&next, &R);
    assert_int_equal(next.serial, 8);
    assert_int_equal(next.heartbeat, 41);
    assert_int_equal(next.link.rx_packets, 123456u);
    assert_int_equal(next.link.lost_packets, 7u);
    assert_int_equal(next.link.last_error, 0);
    assert_int_equal(next.img[DR_ASM_IO_STATE][0], 0);
}

/* The link's Identity read (link.c asks, robot.c takes the answer): a
 * reply with the seven attributes makes it known, with a printable name;
 * a refusal or a reply too short for them makes it refused and forgets
 * what was known; no answer (a timeout, the session lost) changes nothing,
 * for the next session to ask again. */
static void test_identity(void **state)
{
    (void)state;
    /* vendor 1573, device type 12, product code 7, revision 2.12, status
     * 0x0030, serial 0x0012ABCD, "M1013\x01ctl", then attribute 8 */
    static const uint8_t reply[] = {0x25, 0x06, 0x0C, 0x00, 0x07, 0x00, 0x02, 0x0C, 0x30,
                                    0x00, 0xCD, 0xAB, 0x12, 0x00, 0x09, 'M',  '1',  '0',
                                    '1',  '3',  0x01, 'c',  't',  'l',  0x03};
    char text[200];
    assert_int_equal(R.identity.state, GW_IDENTITY_WAITING);
    gw_robot_identity_text(&R.identity, text, sizeof text);
    assert_string_equal(text, "not read yet");
    /* no answer before the first: still waiting */
    assert_int_equal(gw_robot_identity_answer(&R, DR_ETIMEDOUT, NULL, 0), DR_ETIMEDOUT);
    assert_int_equal(R.identity.state, GW_IDENTITY_WAITING);
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, reply, sizeof reply), DR_OK);
    assert_int_equal(R.identity.state, GW_IDENTITY_KNOWN);
    assert_int_equal(R.identity.vendor_id, 1573);
    assert_int_equal(R.identity.device_type, 12);
    assert_int_equal(R.identity.product_code, 7);
    assert_int_equal(R.identity.rev_major, 2);
    assert_int_equal(R.identity.rev_minor, 12);
    assert_int_equal(R.identity.serial, 0x0012ABCDu);
    assert_string_equal(R.identity.product_name, "M1013?ctl"); /* no control bytes */
    gw_robot_identity_text(&R.identity, text, sizeof text);
    assert_string_equal(text, "Doosan Robotics, 'M1013?ctl' (product code 7, revision 2.12, "
                              "serial 0x0012abcd)");
    gw_identity_vendor_text(0xFFFF, text, sizeof text);
    assert_string_equal(text, "vendor 65535");
    /* the session lost with the request out: what was known stays */
    assert_int_equal(gw_robot_identity_answer(&R, DR_ESESSION, NULL, 0), DR_ESESSION);
    assert_int_equal(gw_robot_identity_answer(&R, DR_ECLOSED, NULL, 0), DR_ECLOSED);
    assert_int_equal(R.identity.state, GW_IDENTITY_KNOWN);
    assert_int_equal(R.identity.serial, 0x0012ABCDu);
    /* a reply that is not one (its CIP header, another service's) */
    assert_int_equal(gw_robot_identity_answer(&R, DR_EMALFORMED, NULL, 0), DR_EMALFORMED);
    assert_int_equal(R.identity.state, GW_IDENTITY_REFUSED);
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, reply, sizeof reply), DR_OK);
    assert_int_equal(gw_robot_identity_answer(&R, DR_EMISMATCH, NULL, 0), DR_EMISMATCH);
    assert_int_equal(R.identity.state, GW_IDENTITY_REFUSED);
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, reply, sizeof reply), DR_OK);
    /* refused (another robot behind the address now): nothing known */
    assert_int_equal(gw_robot_identity_answer(&R, DR_CIP(0x08, 0), NULL, 0), DR_CIP(0x08, 0));
    assert_int_equal(R.identity.state, GW_IDENTITY_REFUSED);
    assert_int_equal(R.identity.serial, 0);
    assert_string_equal(R.identity.product_name, "");
    gw_robot_identity_text(&R.identity, text, sizeof text);
    assert_string_equal(text, "refused: CIP 0x08 service not supported");
    /* a reply too short for the six fixed attributes and the name's length */
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, reply, 14), DR_ESHORT);
    assert_int_equal(R.identity.state, GW_IDENTITY_REFUSED);
    gw_robot_identity_refusal(&R.identity, text, sizeof text);
    assert_string_equal(text, "a reply too short for an Identity");
    /* known again, then a reply whose name runs past its end */
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, reply, sizeof reply), DR_OK);
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, reply, 20), DR_ESHORT);
    assert_int_equal(R.identity.state, GW_IDENTITY_REFUSED);
    assert_int_equal(R.identity.why, DR_ESHORT);
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, NULL, 0), DR_ESHORT);
    /* a name longer than the Identity allows (32) is cut, not refused */
    uint8_t longer[15 + 40];
    memcpy(longer, reply, 14);
    longer[14] = 40;
    memset(longer + 15, 'x', 40);
    assert_int_equal(gw_robot_identity_answer(&R, DR_OK, longer, sizeof longer), DR_OK);
    assert_int_equal(strlen(R.identity.product_name), GW_IDENTITY_NAME - 1);
}

static void test_record_error(void **state)
{
    (void)state;
    gw_robot_record_error(&R, DR_CIP(0x01, 0x0129));
    assert_int_equal(R.link.last_error, 0x0129);
    assert_int_equal(R.link.last_cip_general, 0x01);
    /* no extended status: the general one stands in */
    gw_robot_record_error(&R, DR_CIP(0x05, 0));
    assert_int_equal(R.link.last_error, 0x05);
    assert_int_equal(R.link.last_cip_general, 0x05);
    /* not CIP: the code, general 0 */
    gw_robot_record_error(&R, DR_ETIMEDOUT);
    assert_int_equal(R.link.last_error, DR_ETIMEDOUT);
    assert_int_equal(R.link.last_cip_general, 0);
    /* DR_OK records nothing */
    gw_robot_record_error(&R, DR_OK);
    assert_int_equal(R.link.last_error, DR_ETIMEDOUT);
    assert_int_equal(R.link.last_status, DR_ETIMEDOUT);
    /* each cause of an unreachable robot its own code, kept as they are */
    gw_robot_record_error(&R, DR_ECONNREFUSED);
    assert_int_equal(R.link.last_error, 15);
    gw_robot_record_error(&R, DR_EHOSTUNREACH);
    assert_int_equal(R.link.last_error, 24);
    gw_robot_record_error(&R, DR_ENOANSWER);
    assert_int_equal(R.link.last_error, 26);
    gw_robot_record_error(&R, DR_ENOREGISTER);
    assert_int_equal(R.link.last_error, 27);
    assert_int_equal(R.link.last_status, DR_ENOREGISTER);
    /* issue 30: connections accepted, no T->O data: 32, and the cause in
     * words names where the data should have come */
    char cause[200];
    snprintf(R.link.t2o_to, sizeof R.link.t2o_to, "10.0.0.5:2222");
    gw_robot_record_error(&R, DR_ENODATA);
    assert_int_equal(R.link.last_error, 32);
    assert_int_equal(R.link.last_cip_general, 0);
    gw_robot_cause(&R, cause, sizeof cause);
    assert_string_equal(cause, "the robot accepted the connection but sends no data to "
                               "10.0.0.5:2222: a firewall, or the robot answers another address");
    gw_robot_record_error(&R, DR_ENOREGISTER);
    gw_robot_cause(&R, cause, sizeof cause);
    assert_string_equal(cause, "connection accepted, but no reply to RegisterSession");
    /* issue 30: a machine ID that is not a machine's own */
    assert_null(gw_machine_id_problem("4c4c4544003710528052b4c04f384e32\n"));
    assert_string_equal(gw_machine_id_problem(""), "missing or empty");
    assert_string_equal(gw_machine_id_problem("\n"), "missing or empty");
    assert_string_equal(gw_machine_id_problem(NULL), "missing or empty");
    assert_string_equal(gw_machine_id_problem("uninitialized\n"), "uninitialized");
    assert_string_equal(gw_machine_id_problem("00000000000000000000000000000000\n"),
                        "all zeros");
    /* encapsulation statuses above drgate's codes (0x0001 is not
     * DR_EINVAL, 0x0069 not 105), general 0 */
    gw_robot_record_error(&R, DR_ENCAP(0x0001));
    assert_int_equal(R.link.last_error, 0x8001);
    assert_int_equal(R.link.last_cip_general, 0);
    gw_robot_record_error(&R, DR_ENCAP(0x0069));
    assert_int_equal(R.link.last_error, 0x8069);
    gw_robot_record_error(&R, DR_ENCAP(0x7FFE));
    assert_int_equal(R.link.last_error, 0xFFFE);
    gw_robot_record_error(&R, DR_ENCAP(0x8000));
    assert_int_equal(R.link.last_error, 0xFFFF);
    assert_int_equal(R.link.last_status, DR_ENCAP(0x8000));
}

static void test_error_text(void **state)
{
    (void)state;
    char t[160];
    gw_robot_error_text(DR_OK, t, sizeof t);
    assert_string_equal(t, "");
    gw_robot_error_text(DR_ECONNREFUSED, t, sizeof t);
    assert_string_equal(t, "connection refused");
    gw_robot_error_text(DR_ENOANSWER, t, sizeof t);
    assert_string_equal(t, "no answer: TCP connection timed out");
    gw_robot_error_text(DR_CIP(0x01, 0x0106), t, sizeof t);
    assert_string_equal(t, "CIP 0x01/0x0106 ownership conflict");
    gw_robot_error_text(DR_CIP(0x05, 0), t, sizeof t);
    assert_string_equal(t, "CIP 0x05 path destination unknown");
    gw_robot_error_text(DR_ENCAP(0x0069), t, sizeof t);
    assert_string_equal(t, "encapsulation: unsupported protocol version (0x0069)");
    assert_non_null(gw_robot_error_hint(DR_EADDRINUSE));
    assert_non_null(strstr(gw_robot_error_hint(DR_EADDRINUSE), "local_udp_port"));
    assert_null(gw_robot_error_hint(DR_ESYNTAX));
}

static void test_clear_while_down(void **state)
{
    (void)state;
    /* hold (the default): images stay, data is taken in any state */
    fill(0x5A);
    gw_robot_link_down(&R);
    assert_int_equal(R.img[DR_ASM_IO_STATE][0], 0x5A);
    assert_true(gw_robot_takes_data(&R, false));
    assert_true(gw_robot_takes_data(&R, true));
    /* clear_while_down: T->O images to 0, O->T images stay */
    R.clear_while_down = true;
    gw_robot_link_down(&R);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        uint8_t want = dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O ? 0 : 0x5A;
        for (unsigned i = 0; i < DR_ASM_MAX_SIZE; i++)
            assert_int_equal(R.img[a][i], want);
    }
    assert_false(gw_robot_takes_data(&R, false));
    assert_true(gw_robot_takes_data(&R, true));
}

static void test_get(void **state)
{
    (void)state;
    dr_ref_t ref;
    dr_value_t v, one = dr_value_uint(1);
    assert_int_equal(dr_path_parse("bit_out[5]", &ref), DR_OK);
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    assert_int_equal(dr_field_set(R.img[a], dr_asm_info(a)->size, ref, &one, 0), DR_OK);
    assert_int_equal(gw_robot_get(&R, ref, &v), DR_OK);
    assert_int_equal(v.u, 1);
    assert_int_equal(dr_path_parse("bit_out[4]", &ref), DR_OK);
    assert_int_equal(gw_robot_get(&R, ref, &v), DR_OK);
    assert_int_equal(v.u, 0);
    ref.field = NULL;
    assert_int_equal(gw_robot_get(&R, ref, &v), DR_EINVAL);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_init, setup),
        cmocka_unit_test_setup(test_carry_over, setup),
        cmocka_unit_test_setup(test_identity, setup),
        cmocka_unit_test_setup(test_record_error, setup),
        cmocka_unit_test_setup(test_error_text, setup),
        cmocka_unit_test_setup(test_clear_while_down, setup),
        cmocka_unit_test_setup(test_get, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
