/* SPDX-License-Identifier: MIT */
/*
 * Decode and encode of every assembly against byte vectors built by hand
 * from the specification (spec/README.md), not by the encoder under test.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "drgate/codec.h"

/* Test-side wire writers, independent of the library. */
static void put_f32(uint8_t *buf, size_t off, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    buf[off] = (uint8_t)u;
    buf[off + 1] = (uint8_t)(u >> 8);
    buf[off + 2] = (uint8_t)(u >> 16);
    buf[off + 3] = (uint8_t)(u >> 24);
}

static void put_u32(uint8_t *buf, size_t off, uint32_t u)
{
    buf[off] = (uint8_t)u;
    buf[off + 1] = (uint8_t)(u >> 8);
    buf[off + 2] = (uint8_t)(u >> 16);
    buf[off + 3] = (uint8_t)(u >> 24);
}

/* io_state with every field set and reserved bits set to 1, literally. */
static const uint8_t io_state_bytes[36] = {
    0x05, 0x80, 0x01, 0x80, /* 0: cb_di 1,3,16; cb_do 1,16 */
    0xFA, 0xFF, 0xFF, 0xFF, /* 4: aio_type ai1, ao1 + reserved bits 4-31 */
    0x00, 0x00, 0xC0, 0x3F, /* 8: ai[0] = 1.5 */
    0x00, 0x00, 0x00, 0xC0, /* 12: ai[1] = -2.0 */
    0x00, 0x00, 0x20, 0x41, /* 16: ao[0] = 10.0 */
    0x00, 0x00, 0x00, 0x3F, /* 20: ao[1] = 0.5 */
    0xE1, 0xFF, 0xD2, 0xFF, /* 24: tool_di 1,6; tool_do 2,5; reserved set */
    0x02, 0x0B, 0x07, 0xFF, /* 28: version 2.11.7, reserved byte */
    0x02, 0xFF, 0xF5, 0xFF, /* 32: OPERATING, SO, ES, PBP, reserved set */
};

static void test_io_state_decode(void **state)
{
    (void)state;
    dr_io_state_t s;
    assert_int_equal(dr_io_state_decode(io_state_bytes, 36, &s), DR_OK);
    assert_int_equal(s.cb_di, 0x8005);
    assert_int_equal(s.cb_do, 0x8001);
    assert_false(s.aio_type.ai0);
    assert_true(s.aio_type.ai1);
    assert_false(s.aio_type.ao0);
    assert_true(s.aio_type.ao1);
    assert_true(s.ai[0] == 1.5f);
    assert_true(s.ai[1] == -2.0f);
    assert_true(s.ao[0] == 10.0f);
    assert_true(s.ao[1] == 0.5f);
    assert_int_equal(s.tool_di, 0x21);
    assert_int_equal(s.tool_do, 0x12);
    assert_int_equal(s.version.major, 2);
    assert_int_equal(s.version.minor, 11);
    assert_int_equal(s.version.patch, 7);
    assert_int_equal(s.robot_state, DR_ROBOT_OPERATING);
    assert_true(s.servo_on);
    assert_false(s.safety_stopped);
    assert_true(s.emergency_stopped);
    assert_false(s.direct_teach_pressed);
    assert_true(s.power_button_pressed);
}

static void test_io_state_encode_zeroes_reserved(void **state)
{
    (void)state;
    dr_io_state_t s;
    uint8_t out[36];
    assert_int_equal(dr_io_state_decode(io_state_bytes, 36, &s), DR_OK);
    assert_int_equal(dr_io_state_encode(&s, out, sizeof out), DR_OK);
    /* The same bytes with every reserved bit cleared. */
    static const uint8_t expect[36] = {
        0x05, 0x80, 0x01, 0x80, 0x0A, 0, 0, 0,
        0x00, 0x00, 0xC0, 0x3F, 0x00, 0x00, 0x00, 0xC0,
        0x00, 0x00, 0x20, 0x41, 0x00, 0x00, 0x00, 0x3F,
        0x21, 0x00, 0x12, 0x00, 0x02, 0x0B, 0x07, 0x00,
        0x02, 0x00, 0x15, 0x00,
    };
    assert_memory_equal(out, expect, 36);
}

static void test_joint_state_decode(void **state)
{
    (void)state;
    uint8_t buf[144];
    /* spec: group g (position, velocity, current, temperature, torque,
     * external torque) at 24*g, joint j at + 4*(j-1) */
    for (int g = 0; g < 6; g++)
        for (int j = 1; j <= 6; j++)
            put_f32(buf, 24 * (size_t)g + 4 * (size_t)(j - 1), (float)(g * 100 + j) + 0.25f);
    dr_joint_state_t s;
    assert_int_equal(dr_joint_state_decode(buf, 144, &s), DR_OK);
    const float *groups[6] = {s.position, s.velocity, s.motor_current,
                              s.motor_temperature, s.torque, s.external_torque};
    for (int g = 0; g < 6; g++)
        for (int j = 1; j <= 6; j++)
            assert_true(groups[g][j - 1] == (float)(g * 100 + j) + 0.25f);
    /* One literal: 31.5 degrees is 0x41FC0000. */
    memset(buf, 0, sizeof buf);
    buf[8 + 2] = 0xFC;
    buf[8 + 3] = 0x41;
    assert_int_equal(dr_joint_state_decode(buf, 144, &s), DR_OK);
    assert_true(s.position[2] == 31.5f);
}

static void test_task_state_decode(void **state)
{
    (void)state;
    uint8_t buf[96];
    for (int i = 0; i < 24; i++)
        put_f32(buf, 4 * (size_t)i, (float)i * 1.5f - 7.0f);
    dr_task_state_t s;
    assert_int_equal(dr_task_state_decode(buf, 96, &s), DR_OK);
    /* spec order: position xyz, orientation abc, velocity xyz, angular
     * velocity rx ry rz, tool offset xyz abc, external force xyz, moment xyz */
    const float got[24] = {
        s.position.x, s.position.y, s.position.z,
        s.orientation.a, s.orientation.b, s.orientation.c,
        s.velocity.x, s.velocity.y, s.velocity.z,
        s.angular_velocity.rx, s.angular_velocity.ry, s.angular_velocity.rz,
        s.tool_offset.x, s.tool_offset.y, s.tool_offset.z,
        s.tool_offset.a, s.tool_offset.b, s.tool_offset.c,
        s.external_force.x, s.external_force.y, s.external_force.z,
        s.external_moment.x, s.external_moment.y, s.external_moment.z,
    };
    for (int i = 0; i < 24; i++)
        assert_true(got[i] == (float)i * 1.5f - 7.0f);
}

static void test_bit_gpr_decode(void **state)
{
    (void)state;
    static const uint8_t bytes[8] = {0x01, 0x00, 0x00, 0x80, 0x10, 0, 0, 0x80};
    dr_bit_gpr_t g;
    for (int a = DR_ASM_BIT_OUT; a <= DR_ASM_BIT_IN; a += DR_ASM_BIT_IN - DR_ASM_BIT_OUT) {
        assert_int_equal(dr_asm_decode((dr_asm_t)a, bytes, 8, &g), DR_OK);
        /* registers 0, 31, 36, 63 */
        assert_true(g.bits == ((UINT64_C(1) << 0) | (UINT64_C(1) << 31) |
                               (UINT64_C(1) << 36) | (UINT64_C(1) << 63)));
        uint8_t out[8];
        assert_int_equal(dr_asm_encode((dr_asm_t)a, &g, out, 8), DR_OK);
        assert_memory_equal(out, bytes, 8);
    }
}

static void test_int_gpr_decode(void **state)
{
    (void)state;
    uint8_t buf[96];
    for (int r = 0; r < 24; r++)
        put_u32(buf, 4 * (size_t)r, (uint32_t)(r * 1000 - 5000));
    put_u32(buf, 4 * 22, 0x80000000u); /* INT32_MIN */
    put_u32(buf, 4 * 23, 0x7FFFFFFFu); /* INT32_MAX */
    dr_int_gpr_t g;
    for (int a = DR_ASM_INT_OUT; a <= DR_ASM_INT_IN; a += DR_ASM_INT_IN - DR_ASM_INT_OUT) {
        assert_int_equal(dr_asm_decode((dr_asm_t)a, buf, 96, &g), DR_OK);
        for (int r = 0; r < 22; r++)
            assert_int_equal(g.reg[r], r * 1000 - 5000);
        assert_true(g.reg[22] == INT32_MIN);
        assert_true(g.reg[23] == INT32_MAX);
        uint8_t out[96];
        assert_int_equal(dr_asm_encode((dr_asm_t)a, &g, out, 96), DR_OK);
        assert_memory_equal(out, buf, 96);
    }
}

static void test_float_gpr_decode(void **state)
{
    (void)state;
    uint8_t buf[96];
    for (int r = 0; r < 24; r++)
        put_f32(buf, 4 * (size_t)r, (float)r / 8.0f - 1.0f);
    dr_float_gpr_t g;
    for (int a = DR_ASM_FLOAT_OUT; a <= DR_ASM_FLOAT_IN; a += DR_ASM_FLOAT_IN - DR_ASM_FLOAT_OUT) {
        assert_int_equal(dr_asm_decode((dr_asm_t)a, buf, 96, &g), DR_OK);
        for (int r = 0; r < 24; r++)
            assert_true(g.reg[r] == (float)r / 8.0f - 1.0f);
        uint8_t out[96];
        assert_int_equal(dr_asm_encode((dr_asm_t)a, &g, out, 96), DR_OK);
        assert_memory_equal(out, buf, 96);
    }
}

static void test_io_control(void **state)
{
    (void)state;
    static const uint8_t bytes[12] = {
        0x03, 0x80, 0x3F, 0x02, /* cb_do 1,2,16; tool_do 1-6; ao_type.ao1 */
        0x00, 0x00, 0x80, 0x3F, /* ao[0] = 1.0 */
        0x00, 0x00, 0xA0, 0xC0, /* ao[1] = -5.0 */
    };
    dr_io_control_t c;
    assert_int_equal(dr_io_control_decode(bytes, 12, &c), DR_OK);
    assert_int_equal(c.cb_do, 0x8003);
    assert_int_equal(c.tool_do, 0x3F);
    assert_false(c.ao_type.ao0);
    assert_true(c.ao_type.ao1);
    assert_true(c.ao[0] == 1.0f);
    assert_true(c.ao[1] == -5.0f);
    uint8_t out[12];
    assert_int_equal(dr_io_control_encode(&c, out, 12), DR_OK);
    assert_memory_equal(out, bytes, 12);
}

/* Random images: decode, encode, decode again gives the same struct, and
 * encode(decode(x)) is x with reserved bits cleared. */
static uint32_t rng = 12345u;
static uint8_t rnd8(void)
{
    rng = rng * 1103515245u + 12345u;
    return (uint8_t)(rng >> 16);
}

static void test_round_trip_all(void **state)
{
    (void)state;
    for (int a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        for (int iter = 0; iter < 200; iter++) {
            uint8_t in[DR_ASM_MAX_SIZE], out[DR_ASM_MAX_SIZE];
            union { dr_io_state_t a; dr_joint_state_t b; dr_task_state_t c;
                    dr_bit_gpr_t d; dr_int_gpr_t e; dr_float_gpr_t f;
                    dr_io_control_t g; } s1, s2;
            for (unsigned i = 0; i < info->size; i++)
                in[i] = rnd8();
            if (info->dir == DR_DIR_O2T)
                for (unsigned i = 0; i + 4 <= info->size; i += 4)
                    if (a != DR_ASM_INT_IN && a != DR_ASM_BIT_IN &&
                        (a != DR_ASM_IO_CONTROL || i > 0))
                        put_f32(in, i, (float)rnd8()); /* finite REALs */
            assert_int_equal(dr_asm_decode((dr_asm_t)a, in, info->size, &s1), DR_OK);
            assert_int_equal(dr_asm_encode((dr_asm_t)a, &s1, out, info->size), DR_OK);
            assert_int_equal(dr_asm_decode((dr_asm_t)a, out, info->size, &s2), DR_OK);
            assert_memory_equal(&s1, &s2, info->struct_size);
            /* Every bit the encoder wrote was set in the input. */
            for (unsigned i = 0; i < info->size; i++)
                assert_int_equal(out[i] & (uint8_t)~in[i], 0);
        }
    }
}

static void test_decode_errors(void **state)
{
    (void)state;
    uint8_t buf[DR_ASM_MAX_SIZE + 1] = {0};
    dr_io_state_t s;
    memset(&s, 0xAB, sizeof s);
    dr_io_state_t before = s;
    assert_int_equal(dr_io_state_decode(buf, 35, &s), DR_ELENGTH);
    assert_int_equal(dr_io_state_decode(buf, 37, &s), DR_ELENGTH);
    assert_int_equal(dr_io_state_decode(buf, 0, &s), DR_ELENGTH);
    assert_memory_equal(&s, &before, sizeof s); /* untouched */
    assert_int_equal(dr_asm_decode(DR_ASM_COUNT, buf, 8, &s), DR_EINVAL);
    assert_int_equal(dr_asm_decode(DR_ASM_IO_STATE, NULL, 36, &s), DR_EINVAL);
    assert_int_equal(dr_asm_encode(DR_ASM_IO_STATE, &s, buf, 12), DR_ELENGTH);
}

/* dr_asm_decode/dr_asm_encode check the length against their own copy of
 * each wire size (lib/codec.c): it must be dr_asm_info's, for all ten. */
static void test_length_check_every_assembly(void **state)
{
    (void)state;
    uint8_t buf[DR_ASM_MAX_SIZE + 1] = {0};
    union { dr_io_state_t a; dr_joint_state_t b; dr_task_state_t c;
            dr_bit_gpr_t d; dr_int_gpr_t e; dr_float_gpr_t f;
            dr_io_control_t g; } s;
    memset(&s, 0, sizeof s);
    for (int a = 0; a < DR_ASM_COUNT; a++) {
        size_t size = dr_asm_info((dr_asm_t)a)->size;
        assert_int_equal(dr_asm_decode((dr_asm_t)a, buf, size - 1, &s), DR_ELENGTH);
        assert_int_equal(dr_asm_decode((dr_asm_t)a, buf, size + 1, &s), DR_ELENGTH);
        assert_int_equal(dr_asm_decode((dr_asm_t)a, buf, size, &s), DR_OK);
        assert_int_equal(dr_asm_encode((dr_asm_t)a, &s, buf, size - 1), DR_ELENGTH);
        assert_int_equal(dr_asm_encode((dr_asm_t)a, &s, buf, size + 1), DR_ELENGTH);
        assert_int_equal(dr_asm_encode((dr_asm_t)a, &s, buf, size), DR_OK);
    }
    assert_int_equal(dr_asm_decode((dr_asm_t)-1, buf, 8, &s), DR_EINVAL);
    assert_int_equal(dr_asm_encode((dr_asm_t)-1, &s, buf, 8), DR_EINVAL);
    assert_int_equal(dr_asm_encode(DR_ASM_COUNT, &s, buf, 8), DR_EINVAL);
    assert_int_equal(dr_asm_encode(DR_ASM_BIT_IN, NULL, buf, 8), DR_EINVAL);
    assert_int_equal(dr_asm_decode(DR_ASM_BIT_IN, buf, 8, NULL), DR_EINVAL);
}

static void test_encode_errors_write_nothing(void **state)
{
    (void)state;
    uint8_t out[96];
    memset(out, 0x5A, sizeof out);

    dr_io_control_t c = {0};
    c.tool_do = 0x40; /* only 6 tool outputs */
    assert_int_equal(dr_io_control_encode(&c, out, 12), DR_ERANGE);
    c.tool_do = 0;
    c.ao[1] = (float)NAN;
    assert_int_equal(dr_io_control_encode(&c, out, 12), DR_ENONFINITE);
    c.ao[1] = (float)INFINITY;
    assert_int_equal(dr_io_control_encode(&c, out, 12), DR_ENONFINITE);

    dr_float_gpr_t g = {{0}};
    g.reg[23] = -(float)INFINITY;
    assert_int_equal(dr_asm_encode(DR_ASM_FLOAT_IN, &g, out, 96), DR_ENONFINITE);
    /* the robot may produce what it likes: T->O REALs are not checked */
    dr_io_state_t s = {0};
    s.ai[0] = (float)NAN;
    s.cb_di = 0xFFFF;
    uint8_t tmp[36];
    assert_int_equal(dr_io_state_encode(&s, tmp, 36), DR_OK);
    s.tool_di = 0x80;
    assert_int_equal(dr_io_state_encode(&s, tmp, 36), DR_ERANGE);

    for (unsigned i = 0; i < sizeof out; i++)
        assert_int_equal(out[i], 0x5A);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_io_state_decode),
        cmocka_unit_test(test_io_state_encode_zeroes_reserved),
        cmocka_unit_test(test_joint_state_decode),
        cmocka_unit_test(test_task_state_decode),
        cmocka_unit_test(test_bit_gpr_decode),
        cmocka_unit_test(test_int_gpr_decode),
        cmocka_unit_test(test_float_gpr_decode),
        cmocka_unit_test(test_io_control),
        cmocka_unit_test(test_round_trip_all),
        cmocka_unit_test(test_decode_errors),
        cmocka_unit_test(test_length_check_every_assembly),
        cmocka_unit_test(test_encode_errors_write_nothing),
    };
    return cmocka_run_group_tests_name("codec_decode", tests, NULL, NULL);
}
