/* SPDX-License-Identifier: MIT */
/* Values as text and back: formatting people read, parsing they type. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drgate/text.h"

static dr_ref_t ref_of(const char *path)
{
    dr_ref_t r = {NULL, 0};
    assert_int_equal(dr_path_parse(path, &r), DR_OK);
    return r;
}

static void expect_format(const char *path, dr_value_t v, unsigned flags, const char *want)
{
    char out[64];
    assert_int_equal(dr_text_format(ref_of(path), &v, flags, out, sizeof out), DR_OK);
    assert_string_equal(out, want);
}

static void test_format(void **state)
{
    (void)state;
    expect_format("io_state.robot_state", dr_value_uint(2), 0, "OPERATING (2)");
    expect_format("io_state.robot_state", dr_value_uint(13), 0, "UNKNOWN(13)");
    expect_format("io_state.cb_di", dr_value_uint(5), 0, "5 (0x0005)");
    expect_format("io_state.tool_do", dr_value_uint(0x21), 0, "33 (0x21)");
    expect_format("bit_in", dr_value_uint(1), 0, "1 (0x0000000000000001)");
    expect_format("io_state.cb_di[5]", dr_value_uint(1), 0, "1");
    expect_format("joint_state.position[3]", dr_value_real(31.5), DR_TEXT_UNIT, "31.5 degree");
    expect_format("joint_state.position[3]", dr_value_real(31.5), 0, "31.5");
    expect_format("float_in[0]", dr_value_real((float)0.1), DR_TEXT_UNIT, "0.1");
    expect_format("int_in[0]", dr_value_int(-42), 0, "-42");
    expect_format("joint_state.motor_temperature[1]", dr_value_real(NAN), DR_TEXT_UNIT, "nan degC");
    char tiny[4];
    dr_value_t v = dr_value_uint(2);
    assert_int_equal(dr_text_format(ref_of("io_state.robot_state"), &v, 0, tiny, sizeof tiny), DR_ENOSPACE);
}

/* Shortest round trip: the text reads back to the same float, and one
 * digit fewer would not. */
static void test_real_shortest(void **state)
{
    (void)state;
    static const float cases[] = {0.1f, 1.0f / 3.0f, 123456.0f, -1e-7f, 3.4028235e38f, 1.17549435e-38f, 0.0f, 31.5f};
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        char out[32];
        assert_int_equal(dr_text_real(cases[i], out, sizeof out), DR_OK);
        assert_true(strtof(out, NULL) == cases[i]);
    }
    char out[32];
    dr_text_real(0.1f, out, sizeof out);
    assert_string_equal(out, "0.1");
    dr_text_real(1.0f / 3.0f, out, sizeof out);
    assert_string_equal(out, "0.33333334");
    dr_text_real(-(float)INFINITY, out, sizeof out);
    assert_string_equal(out, "-inf");
}

static void expect_json(dr_val_type_t type, double x, const char *want)
{
    char out[32];
    dr_value_t v = {type, (uint64_t)(x < 0 ? 0 : x), (int64_t)x, x};
    assert_int_equal(dr_text_json(&v, out, sizeof out), DR_OK);
    assert_string_equal(out, want);
}

/* The JSON tokens drcli's --json prints (jansson at 9 digits) and the
 * console's API shares (tests/gateway/test_http.py compares the two). */
static void test_json_golden(void **state)
{
    (void)state;
    expect_json(DR_VAL_BOOL, 1, "true");
    expect_json(DR_VAL_BOOL, 0, "false");
    expect_json(DR_VAL_UINT, 255, "255");
    expect_json(DR_VAL_INT, -2147483648.0, "-2147483648");
    expect_json(DR_VAL_REAL, 0.1f, "0.1");
    expect_json(DR_VAL_REAL, 100.0f, "100.0");
    expect_json(DR_VAL_REAL, 0.0f, "0.0");
    expect_json(DR_VAL_REAL, -0.0f, "-0.0");
    expect_json(DR_VAL_REAL, 123456792.0f, "123456790.0");
    expect_json(DR_VAL_REAL, 1e15f, "1e15");
    expect_json(DR_VAL_REAL, -1e-7f, "-1e-7");
    expect_json(DR_VAL_REAL, 3.4028235e38f, "3.4028235e38");
    expect_json(DR_VAL_REAL, 1.0f / 3.0f, "0.33333334");
    expect_json(DR_VAL_REAL, (double)NAN, "\"nan\"");
    expect_json(DR_VAL_REAL, -(double)INFINITY, "\"-inf\"");
    char tiny[4];
    dr_value_t v = {DR_VAL_REAL, 0, 0, 100.0};
    assert_int_equal(dr_text_json(&v, tiny, sizeof tiny), DR_ENOSPACE);
}

static void expect_real(float f, const char *want)
{
    char out[32];
    assert_int_equal(dr_text_real(f, out, sizeof out), DR_OK);
    assert_string_equal(out, want);
}

/* Numbers as people write them: plain notation for 1e-5 <= |x| < 1e16,
 * an exponent (sign always, no leading zeros) outside; -0 keeps its sign. */
static void test_real_golden(void **state)
{
    (void)state;
    expect_real(100.0f, "100");
    expect_real(10.0f, "10");
    expect_real(110.0f, "110");
    expect_real(1000.0f, "1000");
    expect_real(1e-7f, "1e-7");
    expect_real(123456789.0f, "123456790"); /* the float is 123456792 */
    expect_real(-0.0f, "-0");
    expect_real(0.0f, "0");
    expect_real(FLT_MAX, "3.4028235e+38");
    expect_real(-FLT_MAX, "-3.4028235e+38");
    expect_real(31.5f, "31.5");
    expect_real(-123.456f, "-123.456");
    expect_real(1e-5f, "0.00001");           /* the lower bound: plain */
    expect_real(9.99e-6f, "9.99e-6");        /* just under it */
    expect_real(0.00012f, "0.00012");
    expect_real(1e15f, "1000000000000000");  /* the float is 999999986991104 */
    expect_real(1e16f, "1e+16");             /* the upper bound: exponent */
    expect_real(-2.5e20f, "-2.5e+20");
    expect_real(1.17549435e-38f, "1.1754944e-38");
    expect_real(1.4e-45f, "1e-45");          /* the smallest subnormal */
    char tiny[4];
    assert_int_equal(dr_text_real(100000.0f, tiny, sizeof tiny), DR_ENOSPACE);
}

/* Whatever dr_text_real prints, dr_text_parse (drcli's parser) reads back
 * to the same bits: a deterministic walk over binary32 bit patterns of
 * every exponent, and both zeros. */
static void test_real_parse_back(void **state)
{
    (void)state;
    dr_ref_t ref = ref_of("float_in[3]");
    uint32_t x = 0x12345678u;
    for (unsigned i = 0; i < 200000u; i++) {
        x = x * 1664525u + 1013904223u;
        uint32_t bits = i < 2 ? (i == 0 ? 0u : 0x80000000u) : x;
        float f;
        memcpy(&f, &bits, sizeof f);
        if (f != f || f > FLT_MAX || f < -FLT_MAX)
            continue;
        char text[32];
        dr_value_t v;
        assert_int_equal(dr_text_real(f, text, sizeof text), DR_OK);
        assert_int_equal(dr_text_parse(ref, text, 0, &v), DR_OK);
        float back = (float)v.f;
        uint32_t got;
        memcpy(&got, &back, sizeof got);
        if (got != bits)
            fail_msg("0x%08X printed as %s reads back as 0x%08X", (unsigned)bits, text,
                     (unsigned)got);
    }
}

static void test_parse(void **state)
{
    (void)state;
    dr_value_t v;
    assert_int_equal(dr_text_parse(ref_of("io_state.robot_state"), "SAFE_STOP", 0, &v), DR_OK);
    assert_int_equal(v.u, 5);
    assert_int_equal(dr_text_parse(ref_of("io_state.robot_state"), "7", 0, &v), DR_OK);
    assert_int_equal(v.u, 7);
    assert_int_equal(dr_text_parse(ref_of("io_control.cb_do"), "0xA5A5", 0, &v), DR_OK);
    assert_int_equal(v.u, 0xA5A5);
    assert_int_equal(dr_text_parse(ref_of("io_control.cb_do[2]"), "true", 0, &v), DR_OK);
    assert_int_equal(v.u, 1);
    assert_int_equal(v.type, DR_VAL_BOOL);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "-2147483648", 0, &v), DR_OK);
    assert_true(v.i == INT32_MIN);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "-1.25e3", 0, &v), DR_OK);
    assert_true(v.f == -1250.0);
}

/* What dr_text_real prints reads back, up to the largest float: the
 * shortest text of FLT_MAX is a little above it, yet rounds to it. */
static void test_parse_float_limits(void **state)
{
    (void)state;
    char text[32];
    uint8_t img[96] = {0};
    dr_value_t v, got;
    assert_int_equal(dr_text_real(FLT_MAX, text, sizeof text), DR_OK);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), text, 0, &v), DR_OK);
    assert_int_equal(dr_field_set(img, 96, ref_of("float_in[3]"), &v, 0), DR_OK);
    assert_int_equal(dr_field_get(img, 96, ref_of("float_in[3]"), &got), DR_OK);
    /* FLT_MAX, not 3.4028235e38f: where FLT_EVAL_METHOD is 1 (s390x) that
     * constant keeps its double value. */
    assert_true((float)got.f == FLT_MAX);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "-3.4028235e38", 0, &v), DR_OK);
    /* FLT_MAX + half an ulp (2^128 - 2^103) rounds to infinity. */
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "3.4028236e38", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "-3.4028236e38", 0, &v), DR_ERANGE);
}

static void test_parse_errors(void **state)
{
    (void)state;
    dr_value_t v = dr_value_uint(99);
    assert_int_equal(dr_text_parse(ref_of("io_control.cb_do[2]"), "2", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("io_control.cb_do[2]"), "yes", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("io_control.cb_do"), "65536", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("io_control.cb_do"), "-1", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "2147483648", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "99999999999999999999999", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "12abc", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "1.5", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), " 1", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("int_in[3]"), "010", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "nan", 0, &v), DR_ENONFINITE);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "inf", 0, &v), DR_ENONFINITE);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "1e40", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("float_in[3]"), "1,5", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("io_state.robot_state"), "operating", 0, &v), DR_ESYNTAX);
    assert_int_equal(dr_text_parse(ref_of("io_state.robot_state"), "256", 0, &v), DR_ERANGE);
    assert_int_equal(dr_text_parse(ref_of("float_out[3]"), "1", DR_SET_O2T_ONLY, &v), DR_EREADONLY);
    assert_int_equal(v.u, 99); /* never written on error */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_json_golden),
        cmocka_unit_test(test_format),
        cmocka_unit_test(test_real_shortest),
        cmocka_unit_test(test_real_golden),
        cmocka_unit_test(test_real_parse_back),
        cmocka_unit_test(test_parse),
        cmocka_unit_test(test_parse_float_limits),
        cmocka_unit_test(test_parse_errors),
    };
    return cmocka_run_group_tests_name("text", tests, NULL, NULL);
}
