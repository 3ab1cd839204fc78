/* SPDX-License-Identifier: MIT */
/*
 * The user's register map (gateway/modbus/usermap.c, regmap.c): the
 * parser's answers and messages line by line, and serving a map on a unit
 * whose robot is a plain struct: views, word orders, rounding, saturation
 * and write rights.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "modbus/regmap.h"
#include "modbus/usermap.h"

static gw_umap_t M;
static gw_unit_t U;
static gw_robot_t R;

static int setup(void **state)
{
    (void)state;
    gw_regmap_init();
    memset(&M, 0, sizeof M);
    memset(&U, 0, sizeof U);
    memset(&R, 0, sizeof R);
    U.robot = &R;
    U.umap = &M;
    R.link.link_state = 2;
    return 0;
}

/* Parse and add; the error (or "") into err. */
static bool add(const char *line, char *err, size_t size)
{
    gw_umap_entry_t e;
    err[0] = '\0';
    return gw_umap_parse(line, 7, &e, err, size) && gw_umap_add(&M, &e, err, size);
}

static void ok(const char *line)
{
    char err[400];
    if (!add(line, err, sizeof err))
        fail_msg("'%s' refused: %s", line, err);
}

static void refused(const char *line, const char *want)
{
    char err[400];
    unsigned before = M.count;
    if (add(line, err, sizeof err))
        fail_msg("'%s' accepted", line);
    if (strstr(err, want) == NULL)
        fail_msg("'%s': '%s' has no '%s'", line, err, want);
    assert_int_equal(M.count, before);
}

static void test_parse(void **state)
{
    (void)state;
    ok("hr 2000 io_state.robot_state uint16");
    ok("hr 2001 joint_state.position[1..6] real");
    ok("hr 2020 int_in[0..3] int16 writable saturate");
    ok("co 2048 bit_in[0..15] writable");
    ok("ir 5000 io_state.cb_di bits");
    assert_int_equal(M.count, 5);
    /* sorted: co, hr..., ir */
    assert_int_equal(M.entry[0].table, GW_UMAP_CO);
    assert_int_equal(M.entry[1].addr, 2000);
    assert_int_equal(M.entry[2].size, 12);
    assert_int_equal(M.entry[4].table, GW_UMAP_IR);
    assert_int_equal(M.entry[4].size, 1);

    refused("hr 2005 int_in[4] dint", "overlaps the block at hr 2001-2012 (line 7)");
    refused("hr 300 int_in[0] dint", "hr 300 is int_in[0] in the default map");
    refused("hr 3000 int_out[0] dint writable", "cannot be writable");
    refused("ir 3000 int_in[0] dint writable", "writable in table ir");
    refused("hr 65535 int_in[0..1] dint", "past the table's last, 65535");
    refused("hr 3000 joint_state.positon[1] real", "did you mean 'joint_state.position[1]'");
    refused("hr 3000 joint_state.positon[1..2] real", "did you mean");
    refused("hr 3000 joint_state.position[1] int16 scale=100", "add 'saturate'");
    refused("hr 3000 int_in[0] int16", "add 'saturate'");
    refused("hr 3000 io_state.robot_state int16 scale=200", "add 'saturate'");
    refused("hr 3000 int_in[3..1] dint", "must not be above");
    refused("hr 3000 int_in[0] real", "does not fit a DINT field");
    refused("hr 3000 int_in[0] uint16", "does not fit a DINT field");
    refused("hr 3000 int_in[0]", "has no view");
    refused("co 3000 int_in[0] dint", "view dint in table co");
    refused("xx 3000 int_in[0] dint", "table 'xx' invalid");
    refused("hr 70000 int_in[0] dint", "address '70000' invalid");
    refused("hr 3000 int_in[0] dint bogus", "'bogus' invalid");
    refused("hr 3000 int_in[0] dint scale=3", "scale= is for the int16 view");
    refused("hr 3000", "invalid (allowed: TABLE ADDRESS");
    ok("hr 3000 io_state.robot_state int16 scale=100"); /* 255 x 100 fits */
    ok("hr 3001 int_in[5] uint16 hi writable");
}

static void put_dint(dr_asm_t a, unsigned i, int32_t v)
{
    uint32_t u = (uint32_t)v;
    for (unsigned k = 0; k < 4; k++)
        R.img[a][4 * i + k] = (uint8_t)(u >> (8 * k));
}

static int32_t get_dint(dr_asm_t a, unsigned i)
{
    uint32_t u = 0;
    for (unsigned k = 0; k < 4; k++)
        u |= (uint32_t)R.img[a][4 * i + k] << (8 * k);
    return (int32_t)u;
}

static void put_real(dr_asm_t a, unsigned i, float f)
{
    uint32_t u;
    memcpy(&u, &f, 4);
    put_dint(a, i, (int32_t)u);
}

static void test_serve(void **state)
{
    (void)state;
    uint16_t v[16];
    gw_write_result_t wres;
    ok("hr 2000 joint_state.position[1..2] real");
    ok("hr 2004 joint_state.position[1..2] int16 scale=10 saturate");
    ok("hr 2010 int_in[0..1] int16 writable saturate");
    ok("hr 2012 int_in[2] uint16 lo writable");
    ok("hr 2013 int_in[2] uint16 hi");
    ok("hr 2014 int_in[3] int16 saturate");
    put_real(DR_ASM_JOINT_STATE, 0, 1.25f);
    put_real(DR_ASM_JOINT_STATE, 1, -1.25f);
    U.order = GW_WORD_CDAB;
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2000, 6, v), 0);
    assert_int_equal(v[0], 0x0000); /* 1.25f = 0x3FA00000, low word first */
    assert_int_equal(v[1], 0x3FA0);
    assert_int_equal((int16_t)v[4], 13);  /* half away from zero */
    assert_int_equal((int16_t)v[5], -13);
    put_real(DR_ASM_JOINT_STATE, 0, 1e9f);
    put_real(DR_ASM_JOINT_STATE, 1, -1e9f);
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2004, 2, v), 0);
    assert_int_equal(v[0], 32767);
    assert_int_equal(v[1], 0x8000);
    /* a gap reads 0; past the last block: 0x02 */
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2006, 4, v), 0);
    assert_int_equal(v[0], 0);
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2014, 2, v), GW_EX_ILLEGAL_ADDRESS);
    U.unmapped = GW_UNMAPPED_EXCEPTION;
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2006, 4, v), GW_EX_ILLEGAL_ADDRESS);
    U.unmapped = GW_UNMAPPED_ZERO;

    /* writes: -2 through the INT16 view; half of a DINT */
    uint16_t w[2] = {0xFFFE, 7};
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 2010, 2, w, NULL, &wres), 0);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 0), -2);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 1), 7);
    assert_int_equal(wres.dirty, 1u << DR_ASM_INT_IN);
    put_dint(DR_ASM_INT_IN, 2, 0x12345678);
    uint16_t lo = 0xABCD;
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 2012, 1, &lo, NULL, &wres), 0);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 2), 0x1234ABCD);
    /* read-only blocks: 0x02 and nothing changes, also in a longer write */
    uint16_t three[3] = {1, 2, 3};
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 2013, 1, three, NULL, &wres),
                     GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 2011, 3, three, NULL, &wres),
                     GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 1), 7);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 2), 0x1234ABCD);
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 2000, 2, three, NULL, &wres),
                     GW_EX_ILLEGAL_ADDRESS);
    /* the DINT saturates at both ends */
    put_dint(DR_ASM_INT_IN, 3, 40000);
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2014, 1, v), 0);
    assert_int_equal(v[0], 32767);
    put_dint(DR_ASM_INT_IN, 3, -40000);
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 2014, 1, v), 0);
    assert_int_equal(v[0], 0x8000);
    /* the default map is still there */
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 300, 2, v), 0);
    assert_int_equal(v[0], 0xFFFE); /* int_in[0] = -2, cdab: low word first */
    assert_int_equal(v[1], 0xFFFF);
}

static void test_bits(void **state)
{
    (void)state;
    uint16_t v[4];
    gw_write_result_t wres;
    ok("co 3000 bit_in[4..7] writable");
    ok("hr 3000 bit_in[0..19] bits writable");
    uint16_t on[4] = {1, 0, 1, 1};
    assert_int_equal(gw_regmap_write(&U, GW_COILS, 3000, 4, on, NULL, &wres), 0);
    assert_int_equal(R.img[DR_ASM_BIT_IN][0], 0xD0);
    assert_int_equal(gw_regmap_read(&U, GW_HOLDING, 3000, 2, v), 0);
    assert_int_equal(v[0], 0x00D0);
    assert_int_equal(v[1], 0);
    uint16_t w[2] = {0x0001, 0xFFFF};
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 3000, 2, w, NULL, &wres), 0);
    /* bits 16..19 only: the second register holds 4 elements */
    assert_int_equal(R.img[DR_ASM_BIT_IN][0], 0x01);
    assert_int_equal(R.img[DR_ASM_BIT_IN][2], 0x0F);
    assert_int_equal(gw_regmap_read(&U, GW_COILS, 3000, 4, v), 0);
    assert_int_equal(v[0], 0); /* bit_in[4..7] of 0x01 */
    assert_int_equal(v[3], 0);
}

static void test_default_read_only(void **state)
{
    (void)state;
    gw_write_result_t wres;
    uint16_t v[2] = {0, 5};
    ok("hr 2000 int_in[0] int16 writable saturate");
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 310, 2, v, NULL, &wres), 0);
    U.default_ro = true;
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 312, 2, v, NULL, &wres), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(gw_regmap_write(&U, GW_COILS, 100, 1, v, NULL, &wres), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 6), 0);
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 0, 1, v + 1, NULL, &wres), 0); /* watchdog */
    assert_int_equal(U.watchdog, 5);
    assert_int_equal(gw_regmap_write(&U, GW_HOLDING, 2000, 1, v + 1, NULL, &wres), 0);
    assert_int_equal(get_dint(DR_ASM_INT_IN, 0), 5);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_parse, setup),
        cmocka_unit_test_setup(test_serve, setup),
        cmocka_unit_test_setup(test_bits, setup),
        cmocka_unit_test_setup(test_default_read_only, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
