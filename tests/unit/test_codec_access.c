/* SPDX-License-Identifier: MIT */
/*
 * Generic access by path: parsing, canonical names, get/set with range
 * checks, bit fields that never clobber neighbours, and the field table's
 * own consistency with the specification.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <math.h>
#include <string.h>
#include <cmocka.h>

#include "drgate/codec.h"

static dr_ref_t ref_of(const char *path)
{
    dr_ref_t r = {NULL, 0};
    assert_int_equal(dr_path_parse(path, &r), DR_OK);
    return r;
}

static void test_path_parse(void **state)
{
    (void)state;
    dr_ref_t r = ref_of("joint_state.position[3]");
    assert_int_equal(r.field->assembly, DR_ASM_JOINT_STATE);
    assert_int_equal(r.field->offset, 0);
    assert_int_equal(r.elem, 2);

    dr_ref_t alias = ref_of("dr2.position[3]");
    assert_ptr_equal(alias.field, r.field);
    assert_int_equal(alias.elem, 2);

    r = ref_of("io_state.cb_di[5]");
    assert_int_equal(r.field->kind, DR_KIND_BITS);
    assert_int_equal(r.elem, 4);
    r = ref_of("io_state.cb_di");
    assert_int_equal(r.elem, -1); /* the whole mask */
    r = ref_of("int_in[7]");
    assert_int_equal(r.field->assembly, DR_ASM_INT_IN);
    assert_int_equal(r.elem, 7);
    r = ref_of("int_in[07]");
    assert_int_equal(r.elem, 7);
    r = ref_of("dr10[23]");
    assert_int_equal(r.field->assembly, DR_ASM_FLOAT_IN);
    r = ref_of("task_state.external_force.z");
    assert_int_equal(r.field->offset, 80);
    r = ref_of("io_state.aio_type.ao1");
    assert_int_equal(r.field->bit, 3);
    r = ref_of("io_state.robot_state");
    assert_int_equal(r.elem, 0);
}

static void test_path_errors(void **state)
{
    (void)state;
    dr_ref_t r;
    assert_int_equal(dr_path_parse("joint_state.positon[3]", &r), DR_ENOENT);
    assert_int_equal(dr_path_parse("Joint_state.position[3]", &r), DR_ENOENT);
    assert_int_equal(dr_path_parse("joint_state.position[0]", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("joint_state.position[7]", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("joint_state.position", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("io_state.cb_di[17]", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("io_state.cb_di[0]", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("int_in[24]", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("io_state.robot_state[1]", &r), DR_EINDEX);
    assert_int_equal(dr_path_parse("int_in[x]", &r), DR_ESYNTAX);
    assert_int_equal(dr_path_parse("int_in[1", &r), DR_ESYNTAX);
    assert_int_equal(dr_path_parse("int_in[]", &r), DR_ESYNTAX);
    assert_int_equal(dr_path_parse("int_in[1]x", &r), DR_ESYNTAX);
    assert_int_equal(dr_path_parse("int_in[1000000]", &r), DR_ESYNTAX);
    assert_int_equal(dr_path_parse("", &r), DR_ENOENT);
    assert_int_equal(dr_path_parse("io_state.", &r), DR_ENOENT);
    assert_int_equal(dr_path_parse("dr11[0]", &r), DR_ENOENT);
    assert_int_equal(dr_path_parse(NULL, &r), DR_EINVAL);
}

static void test_path_closest(void **state)
{
    (void)state;
    char best[64];
    assert_int_equal(dr_path_closest("joint_state.positon[3]", best, sizeof best), DR_OK);
    assert_string_equal(best, "joint_state.position[3]");
    assert_int_equal(dr_path_closest("io_state.robotstate", best, sizeof best), DR_OK);
    assert_string_equal(best, "io_state.robot_state");
    assert_int_equal(dr_path_closest("io_state.cb_dl", best, sizeof best), DR_OK);
    assert_string_equal(best, "io_state.cb_di");
    assert_int_equal(dr_path_closest("task_state.external_force.q", best, sizeof best), DR_OK);
    assert_string_equal(best, "task_state.external_force.x");
    /* an answer that fits exactly is not "no space"; one byte less is */
    char exact[10];
    assert_int_equal(dr_path_closest("int_in[77]", exact, sizeof exact), DR_OK);
    assert_string_equal(exact, "int_in[7]");
    assert_int_equal(dr_path_closest("int_in[77]", exact, 9), DR_ENOSPACE);
}

/* Every leaf's canonical path parses back to the same leaf. */
static void test_leaves_round_trip(void **state)
{
    (void)state;
    /* io_state 61, joint 36, task 24, bit/int/float out 64+24+24,
     * io_control 26, bit/int/float in 64+24+24 */
    assert_int_equal(dr_leaf_count(), 371);
    for (uint16_t i = 0; i < dr_leaf_count(); i++) {
        dr_ref_t leaf, back;
        char path[64];
        assert_int_equal(dr_leaf_at(i, &leaf), DR_OK);
        assert_int_equal(dr_ref_path(leaf, path, sizeof path), DR_OK);
        assert_int_equal(dr_path_parse(path, &back), DR_OK);
        assert_ptr_equal(back.field, leaf.field);
        assert_int_equal(back.elem, leaf.elem);
    }
    dr_ref_t r;
    assert_int_equal(dr_leaf_at(371, &r), DR_EINDEX);
    char tiny[8];
    assert_int_equal(dr_ref_path(ref_of("joint_state.position[3]"), tiny, sizeof tiny), DR_ENOSPACE);
}

/* Spec offsets written out once more here (the test's own copy). */
static void test_offsets_match_spec(void **state)
{
    (void)state;
    static const struct { const char *path; uint16_t offset; uint8_t bit; } cases[] = {
        {"io_state.cb_di", 0, 0}, {"io_state.cb_do", 0, 16},
        {"io_state.aio_type.ai0", 4, 0}, {"io_state.aio_type.ao1", 4, 3},
        {"io_state.ai[0]", 8, 0}, {"io_state.ao[0]", 16, 0},
        {"io_state.tool_di", 24, 0}, {"io_state.tool_do", 24, 16},
        {"io_state.version.major", 28, 0}, {"io_state.version.minor", 29, 0},
        {"io_state.version.patch", 30, 0}, {"io_state.robot_state", 32, 0},
        {"io_state.servo_on", 32, 16}, {"io_state.safety_stopped", 32, 17},
        {"io_state.emergency_stopped", 32, 18},
        {"io_state.direct_teach_pressed", 32, 19},
        {"io_state.power_button_pressed", 32, 20},
        {"joint_state.velocity[1]", 24, 0}, {"joint_state.motor_current[1]", 48, 0},
        {"joint_state.motor_temperature[1]", 72, 0}, {"joint_state.torque[1]", 96, 0},
        {"joint_state.external_torque[1]", 120, 0},
        {"task_state.orientation.a", 12, 0}, {"task_state.angular_velocity.rz", 44, 0},
        {"task_state.tool_offset.x", 48, 0}, {"task_state.tool_offset.c", 68, 0},
        {"task_state.external_moment.z", 92, 0},
        {"io_control.cb_do", 0, 0}, {"io_control.tool_do", 0, 16},
        {"io_control.ao_type.ao0", 0, 24}, {"io_control.ao_type.ao1", 0, 25},
        {"io_control.ao[0]", 4, 0},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        dr_ref_t r = ref_of(cases[i].path);
        assert_int_equal(r.field->offset, cases[i].offset);
        assert_int_equal(r.field->bit, cases[i].bit);
    }
}

/* The table itself: fields inside their assembly, no two fields sharing a
 * bit, member sizes fitting their kind, assembly ranges contiguous. */
static void test_table_consistency(void **state)
{
    (void)state;
    uint16_t next = 0;
    unsigned total = 0;
    for (int a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        uint8_t used[DR_ASM_MAX_SIZE] = {0}; /* bit map of claimed bits */
        assert_int_equal(info->first_field, next);
        next = (uint16_t)(next + info->field_count);
        total += info->size;
        for (unsigned k = 0; k < info->field_count; k++) {
            const dr_field_t *f = dr_field_at((uint16_t)(info->first_field + k));
            assert_non_null(f);
            assert_int_equal(dr_field_index(f), info->first_field + k);
            assert_int_equal(f->assembly, a);
            unsigned bits, first_bit = 8u * f->offset + f->bit;
            switch (f->kind) {
            case DR_KIND_BIT: bits = 1; assert_int_equal(f->member_size, sizeof(bool)); break;
            case DR_KIND_BITS:
                bits = f->count;
                assert_true(f->bit + f->count <= 64);
                assert_int_equal(f->member_size, f->count <= 8 ? 1 : f->count <= 16 ? 2 : f->count <= 32 ? 4 : 8);
                break;
            default:
                bits = 8u * dr_kind_wire_size((dr_kind_t)f->kind) * f->count;
                assert_int_equal(f->bit, 0);
                assert_int_equal(f->member_size, dr_kind_wire_size((dr_kind_t)f->kind) * f->count);
                break;
            }
            assert_true(first_bit + bits <= 8u * info->size);
            assert_true(f->member_offset + f->member_size <= info->struct_size);
            for (unsigned b = first_bit; b < first_bit + bits; b++) {
                assert_int_equal(used[b / 8] & (1u << (b % 8)), 0);
                used[b / 8] |= (uint8_t)(1u << (b % 8));
            }
        }
    }
    assert_int_equal(next, dr_field_count());
    assert_null(dr_field_at(next));
    dr_field_t copy = *dr_field_at(0);
    assert_int_equal(dr_field_index(&copy), DR_FIELD_NONE);
    assert_int_equal(total, DR_ASM_TOTAL_SIZE);
}

/* Setting any leaf changes only that leaf's bits: start from random bytes,
 * write the complement of the current value, compare byte by byte. */
static uint32_t rng = 777u;
static uint8_t rnd8(void)
{
    rng = rng * 1103515245u + 12345u;
    return (uint8_t)(rng >> 16);
}

static void test_set_touches_only_its_bits(void **state)
{
    (void)state;
    for (uint16_t i = 0; i < dr_leaf_count(); i++) {
        dr_ref_t leaf;
        assert_int_equal(dr_leaf_at(i, &leaf), DR_OK);
        const dr_field_t *f = leaf.field;
        size_t size = dr_asm_info((dr_asm_t)f->assembly)->size;
        uint8_t before[DR_ASM_MAX_SIZE], after[DR_ASM_MAX_SIZE];
        for (size_t k = 0; k < size; k++)
            before[k] = after[k] = rnd8();

        dr_value_t v, got;
        assert_int_equal(dr_field_get(after, size, leaf, &v), DR_OK);
        unsigned first_bit, nbits;
        if (f->kind == DR_KIND_BIT || f->kind == DR_KIND_BITS) {
            v.u ^= 1u;
            first_bit = 8u * f->offset + f->bit + (f->kind == DR_KIND_BITS ? (unsigned)leaf.elem : 0u);
            nbits = 1;
        } else {
            unsigned w = dr_kind_wire_size((dr_kind_t)f->kind);
            if (v.type == DR_VAL_UINT) v.u = 255u - v.u;
            else if (v.type == DR_VAL_INT) v.i = -1 - v.i;
            else v = dr_value_real(123.25);
            first_bit = 8u * (f->offset + w * (unsigned)leaf.elem);
            nbits = 8u * w;
        }
        assert_int_equal(dr_field_set(after, size, leaf, &v, 0), DR_OK);
        assert_int_equal(dr_field_get(after, size, leaf, &got), DR_OK);
        assert_true(dr_value_as_double(&got) == dr_value_as_double(&v));
        for (unsigned b = 0; b < 8u * size; b++) {
            unsigned x = (before[b / 8] >> (b % 8)) & 1u, y = (after[b / 8] >> (b % 8)) & 1u;
            if (b < first_bit || b >= first_bit + nbits)
                assert_int_equal(x, y);
        }
    }
}

static void test_two_bits_land_together(void **state)
{
    (void)state;
    uint8_t img[12] = {0};
    dr_value_t one = dr_value_uint(1);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.cb_do[3]"), &one, DR_SET_O2T_ONLY), DR_OK);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.tool_do[6]"), &one, DR_SET_O2T_ONLY), DR_OK);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.ao_type.ao1"), &one, DR_SET_O2T_ONLY), DR_OK);
    static const uint8_t expect[12] = {0x04, 0x00, 0x20, 0x02};
    assert_memory_equal(img, expect, 12);
    dr_value_t mask = dr_value_uint(0xA5A5);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.cb_do"), &mask, 0), DR_OK);
    static const uint8_t expect2[12] = {0xA5, 0xA5, 0x20, 0x02};
    assert_memory_equal(img, expect2, 12);
    dr_value_t got;
    assert_int_equal(dr_field_get(img, 12, ref_of("io_control.cb_do[1]"), &got), DR_OK);
    assert_int_equal(got.type, DR_VAL_BOOL);
    assert_int_equal(got.u, 1);
    assert_int_equal(dr_field_get(img, 12, ref_of("io_control.cb_do"), &got), DR_OK);
    assert_int_equal(got.u, 0xA5A5);
}

static void test_set_errors_change_nothing(void **state)
{
    (void)state;
    uint8_t img[96];
    memset(img, 0x33, sizeof img);
    uint8_t copy[96];
    memcpy(copy, img, sizeof img);
    dr_value_t v;

    v = dr_value_uint(2);
    assert_int_equal(dr_field_set(img, 8, ref_of("bit_in[3]"), &v, 0), DR_ERANGE);
    v = dr_value_real(0.5);
    assert_int_equal(dr_field_set(img, 8, ref_of("bit_in[3]"), &v, 0), DR_ERANGE);
    v = dr_value_int(-1);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.ao_type.ao0"), &v, 0), DR_ERANGE);
    v = dr_value_uint(0x10000);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.cb_do"), &v, 0), DR_ERANGE);
    v = dr_value_uint(64);
    assert_int_equal(dr_field_set(img, 12, ref_of("io_control.tool_do"), &v, 0), DR_ERANGE);
    v = dr_value_int(INT64_C(2147483648));
    assert_int_equal(dr_field_set(img, 96, ref_of("int_in[0]"), &v, 0), DR_ERANGE);
    v = dr_value_int(INT64_C(-2147483649));
    assert_int_equal(dr_field_set(img, 96, ref_of("int_in[0]"), &v, 0), DR_ERANGE);
    v = dr_value_real(2147483648.0);
    assert_int_equal(dr_field_set(img, 96, ref_of("int_in[0]"), &v, 0), DR_ERANGE);
    v = dr_value_real(1.5);
    assert_int_equal(dr_field_set(img, 96, ref_of("int_in[0]"), &v, 0), DR_ERANGE);
    v = dr_value_real(NAN);
    assert_int_equal(dr_field_set(img, 96, ref_of("float_in[5]"), &v, 0), DR_ENONFINITE);
    v = dr_value_real(INFINITY);
    assert_int_equal(dr_field_set(img, 96, ref_of("float_in[5]"), &v, 0), DR_ENONFINITE);
    v = dr_value_real(1e39);
    assert_int_equal(dr_field_set(img, 96, ref_of("float_in[5]"), &v, 0), DR_ERANGE);
    v = dr_value_real(1.0);
    assert_int_equal(dr_field_set(img, 96, ref_of("float_out[5]"), &v, DR_SET_O2T_ONLY), DR_EREADONLY);
    assert_int_equal(dr_field_set(img, 95, ref_of("float_in[5]"), &v, 0), DR_ELENGTH);
    v = dr_value_uint(256);
    assert_int_equal(dr_field_set(img, 36, ref_of("io_state.version.major"), &v, 0), DR_ERANGE);
    dr_ref_t bad = ref_of("float_in[5]");
    bad.elem = 24;
    v = dr_value_real(1.0);
    assert_int_equal(dr_field_set(img, 96, bad, &v, 0), DR_EINDEX);
    assert_memory_equal(img, copy, sizeof img);

    /* and what is allowed: DINT limits, exact whole REAL, NaN in T->O */
    v = dr_value_int(INT32_MIN);
    assert_int_equal(dr_field_set(img, 96, ref_of("int_in[0]"), &v, 0), DR_OK);
    static const uint8_t min[4] = {0x00, 0x00, 0x00, 0x80};
    assert_memory_equal(img, min, 4);
    v = dr_value_real(-2.0);
    assert_int_equal(dr_field_set(img, 96, ref_of("int_in[1]"), &v, 0), DR_OK);
    static const uint8_t m2[4] = {0xFE, 0xFF, 0xFF, 0xFF};
    assert_memory_equal(img + 4, m2, 4);
    v = dr_value_real(NAN);
    assert_int_equal(dr_field_set(img, 96, ref_of("float_out[0]"), &v, 0), DR_OK);
    v = dr_value_uint(UINT64_MAX);
    assert_int_equal(dr_field_set(img, 8, ref_of("bit_out"), &v, 0), DR_OK);
    assert_int_equal(dr_field_get(img, 8, ref_of("bit_out"), &v), DR_OK);
    assert_true(v.u == UINT64_MAX);
}

static void test_names_and_status(void **state)
{
    (void)state;
    dr_asm_t a;
    assert_int_equal(dr_asm_lookup("dr7", &a), DR_OK);
    assert_int_equal(a, DR_ASM_IO_CONTROL);
    assert_int_equal(dr_asm_lookup("io_controls", &a), DR_ENOENT);
    assert_string_equal(dr_robot_state_name(2), "OPERATING");
    assert_string_equal(dr_robot_state_name(10), "SAFE_OFF2");
    assert_null(dr_robot_state_name(11));
    assert_string_equal(dr_strerror(DR_CIP(0x01, 0x0109)), "invalid connection size");
    assert_string_equal(dr_strerror(DR_CIP(0x05, 0)), "path destination unknown");
    assert_string_equal(dr_strerror(DR_CIP(0x01, 0x7777)), "connection failure");
    assert_string_equal(dr_strerror(DR_ENONFINITE), "non-finite REAL for a field the robot consumes");
    assert_string_equal(dr_strerror(DR_ENCAP(0x64)), "encapsulation: invalid session handle");
    assert_true(DR_IS_CIP(DR_CIP(0x01, 0x0100)));
    assert_int_equal(DR_CIP_EXTENDED(DR_CIP(0x01, 0x0100)), 0x0100);
    assert_string_equal(dr_strerror(-5), "unknown status");
    assert_int_equal(DR_ASM_DEFAULT_INSTANCE(DR_ASM_FLOAT_IN), 110);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_path_parse),
        cmocka_unit_test(test_path_errors),
        cmocka_unit_test(test_path_closest),
        cmocka_unit_test(test_leaves_round_trip),
        cmocka_unit_test(test_offsets_match_spec),
        cmocka_unit_test(test_table_consistency),
        cmocka_unit_test(test_set_touches_only_its_bits),
        cmocka_unit_test(test_two_bits_land_together),
        cmocka_unit_test(test_set_errors_change_nothing),
        cmocka_unit_test(test_names_and_status),
    };
    return cmocka_run_group_tests_name("codec_access", tests, NULL, NULL);
}
