/* SPDX-License-Identifier: MIT */
/*
 * Layouts (drgate/layout.h): the default points add up to the figures the
 * controller's documentation gives (476 = Monitoring&GPR), a combined
 * image sliced into the assemblies gives every field the value it has in
 * the assembly's own image, a point whose size does not add up is
 * refused, and a probe's sizes map onto the layout they match.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "drgate/codec.h"
#include "drgate/layout.h"

static void test_names(void **state)
{
    (void)state;
    dr_layout_kind_t k;
    for (unsigned i = 0; i < DR_LAYOUT_COUNT; i++) {
        assert_int_equal(dr_layout_lookup(dr_layout_name((dr_layout_kind_t)i), &k), DR_OK);
        assert_int_equal(k, i);
    }
    assert_string_equal(dr_layout_name(DR_LAYOUT_COMBINED), "combined");
    assert_null(dr_layout_name(DR_LAYOUT_COUNT));
    assert_int_equal(dr_layout_lookup("Combined", &k), DR_ENOENT);
    assert_int_equal(dr_layout_lookup(NULL, &k), DR_EINVAL);
}

static void test_defaults(void **state)
{
    (void)state;
    dr_layout_t l;
    dr_layout_default(&l, DR_LAYOUT_COMBINED);
    assert_int_equal(l.input.size, 476);
    assert_int_equal(l.input.count, 6);
    assert_int_equal(l.input.instance, 100);
    assert_int_equal(l.output.size, 212);
    assert_int_equal(l.output.count, 4);
    assert_int_equal(l.output.instance, 150);
    assert_int_equal(dr_point_check(&l.input, DR_DIR_T2O), DR_OK);
    assert_int_equal(dr_point_check(&l.output, DR_DIR_O2T), DR_OK);
    /* back to back, in the specification's order */
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_IO_STATE), 0);
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_JOINT_STATE), 36);
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_TASK_STATE), 180);
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_BIT_OUT), 276);
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_INT_OUT), 284);
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_FLOAT_OUT), 380);
    assert_int_equal(dr_point_offset(&l.output, DR_ASM_FLOAT_IN), 116);
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_IO_CONTROL), -1);

    dr_layout_default(&l, DR_LAYOUT_GPR_ONLY);
    assert_int_equal(l.input.size, 200);
    assert_int_equal(l.output.size, 200);
    assert_false(dr_point_has(&l.input, DR_ASM_IO_STATE));
    assert_false(dr_point_has(&l.output, DR_ASM_IO_CONTROL));
    assert_int_equal(dr_point_offset(&l.input, DR_ASM_BIT_OUT), 0);
    assert_int_equal(dr_point_offset(&l.output, DR_ASM_INT_IN), 8);

    dr_layout_default(&l, DR_LAYOUT_PER_ASSEMBLY);
    assert_int_equal(l.input.count, 0);
    assert_int_equal(dr_point_sum(&l.input), 0);
}

static void test_check(void **state)
{
    (void)state;
    dr_layout_t l;
    dr_layout_default(&l, DR_LAYOUT_COMBINED);
    dr_point_t p = l.input;
    p.size = 480;
    assert_int_equal(dr_point_check(&p, DR_DIR_T2O), DR_ELENGTH);
    assert_int_equal(dr_point_check(&l.input, DR_DIR_O2T), DR_EINVAL);
    p = l.output;
    p.asm_id[1] = DR_ASM_IO_CONTROL; /* twice */
    assert_int_equal(dr_point_check(&p, DR_DIR_O2T), DR_EINVAL);
    p = l.output;
    p.asm_id[0] = DR_ASM_COUNT; /* no such assembly */
    assert_int_equal(dr_point_check(&p, DR_DIR_O2T), DR_EINVAL);
    assert_int_equal(dr_point_sum(&p), 0);
    p.count = 0;
    assert_int_equal(dr_point_check(&p, DR_DIR_O2T), DR_EINVAL);
    p.count = DR_POINT_MAX_ASM + 1;
    assert_int_equal(dr_point_check(&p, DR_DIR_O2T), DR_EINVAL);
    assert_int_equal(dr_point_offset(&p, DR_ASM_BIT_IN), -1);
    assert_int_equal(dr_point_check(NULL, DR_DIR_O2T), DR_EINVAL);
}

/* Every leaf of a T->O assembly read from the combined image's slice is
 * the leaf of the assembly's own image; the image put back together is
 * the same bytes. */
static void test_slice_every_field(void **state)
{
    (void)state;
    dr_layout_t l;
    dr_layout_default(&l, DR_LAYOUT_COMBINED);
    uint8_t own[DR_ASM_COUNT][DR_ASM_MAX_SIZE];
    uint8_t in[DR_POINT_MAX_SIZE], out[212], back[DR_POINT_MAX_SIZE];
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        for (unsigned i = 0; i < DR_ASM_MAX_SIZE; i++)
            own[a][i] = (uint8_t)(a * 37u + i * 11u + 1u);
    memset(in, 0, sizeof in);
    memset(out, 0, sizeof out);
    for (unsigned i = 0; i < l.input.count; i++) {
        dr_asm_t a = (dr_asm_t)l.input.asm_id[i];
        assert_int_equal(dr_point_put(&l.input, in, 476, a, own[a], dr_asm_info(a)->size), DR_OK);
    }
    for (unsigned i = 0; i < l.output.count; i++) {
        dr_asm_t a = (dr_asm_t)l.output.asm_id[i];
        assert_int_equal(dr_point_put(&l.output, out, 212, a, own[a], dr_asm_info(a)->size), DR_OK);
    }
    unsigned leaves = 0;
    for (uint16_t i = 0; i < dr_leaf_count(); i++) {
        dr_ref_t r;
        assert_int_equal(dr_leaf_at(i, &r), DR_OK);
        dr_asm_t a = (dr_asm_t)r.field->assembly;
        const dr_asm_info_t *info = dr_asm_info(a);
        const dr_point_t *p = info->dir == DR_DIR_T2O ? &l.input : &l.output;
        uint8_t slice[DR_ASM_MAX_SIZE];
        assert_int_equal(dr_point_slice(p, p == &l.input ? in : out, p->size, a, slice,
                                        info->size), DR_OK);
        dr_value_t x, y;
        assert_int_equal(dr_field_get(own[a], info->size, r, &x), DR_OK);
        assert_int_equal(dr_field_get(slice, info->size, r, &y), DR_OK);
        assert_memory_equal(&x.u, &y.u, sizeof x.u);
        assert_memory_equal(&x.i, &y.i, sizeof x.i);
        if (x.type == DR_VAL_REAL)
            assert_memory_equal(&x.f, &y.f, sizeof x.f);
        leaves++;
    }
    assert_int_equal(leaves, dr_leaf_count());
    memset(back, 0xAA, sizeof back);
    for (unsigned i = 0; i < l.input.count; i++) {
        dr_asm_t a = (dr_asm_t)l.input.asm_id[i];
        uint8_t slice[DR_ASM_MAX_SIZE];
        assert_int_equal(dr_point_slice(&l.input, in, 476, a, slice, dr_asm_info(a)->size), DR_OK);
        assert_int_equal(dr_point_put(&l.input, back, 476, a, slice, dr_asm_info(a)->size), DR_OK);
    }
    assert_memory_equal(back, in, 476);
}

static void test_slice_lengths(void **state)
{
    (void)state;
    dr_layout_t l;
    dr_layout_default(&l, DR_LAYOUT_COMBINED);
    uint8_t img[DR_POINT_MAX_SIZE] = {0}, a[DR_ASM_MAX_SIZE];
    memset(a, 0x55, sizeof a);
    assert_int_equal(dr_point_slice(&l.input, img, 475, DR_ASM_IO_STATE, a, 36), DR_ELENGTH);
    assert_int_equal(dr_point_slice(&l.input, img, 477, DR_ASM_IO_STATE, a, 36), DR_ELENGTH);
    assert_int_equal(dr_point_slice(&l.input, img, 476, DR_ASM_IO_STATE, a, 35), DR_ELENGTH);
    assert_int_equal(a[0], 0x55); /* nothing written */
    assert_int_equal(dr_point_slice(&l.input, img, 476, DR_ASM_IO_CONTROL, a, 12), DR_EINVAL);
    assert_int_equal(dr_point_put(&l.input, img, 476, DR_ASM_FLOAT_OUT, a, 95), DR_ELENGTH);
    assert_int_equal(img[380], 0);
    assert_int_equal(dr_point_put(&l.input, img, 476, DR_ASM_FLOAT_OUT, a, 96), DR_OK);
    assert_int_equal(img[380], 0x55);
    assert_int_equal(img[379], 0);
    assert_int_equal(dr_point_slice(&l.input, NULL, 476, DR_ASM_IO_STATE, a, 36), DR_EINVAL);
    /* a point whose size was edited no longer slices */
    l.input.size = 480;
    assert_int_equal(dr_point_slice(&l.input, img, 480, DR_ASM_IO_STATE, a, 36), DR_ELENGTH);
}

static void test_match(void **state)
{
    (void)state;
    uint16_t sizes[DR_ASM_COUNT], none[DR_ASM_COUNT] = {0};
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        sizes[a] = dr_asm_info((dr_asm_t)a)->size;
    dr_layout_kind_t k;
    assert_int_equal(dr_layout_match(sizes, 0, 0, &k), DR_OK);
    assert_int_equal(k, DR_LAYOUT_PER_ASSEMBLY);
    assert_int_equal(dr_layout_match(none, 476, 212, &k), DR_OK);
    assert_int_equal(k, DR_LAYOUT_COMBINED);
    assert_int_equal(dr_layout_match(none, 200, 200, &k), DR_OK);
    assert_int_equal(k, DR_LAYOUT_GPR_ONLY);
    assert_int_equal(dr_layout_match(none, 32, 32, &k), DR_ENOENT);
    sizes[DR_ASM_JOINT_STATE] = 0;
    assert_int_equal(dr_layout_match(sizes, 0, 0, &k), DR_ENOENT);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_names),
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_check),
        cmocka_unit_test(test_slice_every_field),
        cmocka_unit_test(test_slice_lengths),
        cmocka_unit_test(test_match),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
