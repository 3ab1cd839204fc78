/* SPDX-License-Identifier: MIT */
/*
 * The register map's checks that the end-to-end tests (tests/gateway)
 * cannot set up cheaply: bits owned by GPIO inputs (which need a GPIO
 * chip there; tests/gpio/gateway covers them in a guest with a real one),
 * the two policies for reserved addresses, on every table, and the status
 * block's 32-bit counters in every word order. The unit and its robot
 * here are plain structs, as the daemon's are; nothing is faked.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "modbus/regmap.h"

static gw_unit_t U;
static gw_robot_t R; /* U's robot */

static int setup(void **state)
{
    (void)state;
    gw_regmap_init();
    memset(&U, 0, sizeof U);
    memset(&R, 0, sizeof R);
    U.robot = &R;
    R.link.link_state = 2;
    return 0;
}

static dr_ref_t ref(const char *path)
{
    dr_ref_t r;
    assert_int_equal(dr_path_parse(path, &r), DR_OK);
    return r;
}

static void own(const char *path)
{
    R.write_policy.gpio_in[R.write_policy.gpio_in_count++] = ref(path);
}

static uint64_t get(const char *path)
{
    dr_ref_t r = ref(path);
    dr_value_t v;
    const dr_asm_info_t *info = dr_asm_info((dr_asm_t)r.field->assembly);
    assert_int_equal(dr_field_get(R.img[r.field->assembly], info->size, r, &v), DR_OK);
    return v.u;
}

static int write1(gw_area_t area, uint16_t addr, uint16_t v)
{
    gw_write_result_t wres;
    return gw_regmap_write(&U, area, addr, 1, &v, NULL, &wres);
}

/* Coils 200.. are bit_in[0..63], HR 200-203 the same bits packed. */
static void test_gpio_owned_bits(void **state)
{
    (void)state;
    own("bit_in[3]");
    own("io_control.cb_do[1]"); /* coil 100, HR 100 bit 0 */
    /* the coil of an owned bit: changing it is refused, the same value is not */
    assert_int_equal(write1(GW_COILS, 203, 1), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(get("bit_in[3]"), 0);
    assert_int_equal(write1(GW_COILS, 203, 0), 0);
    /* its neighbours are Modbus's */
    assert_int_equal(write1(GW_COILS, 202, 1), 0);
    assert_int_equal(get("bit_in[2]"), 1);
    /* FC15 across it: refused whole, nothing of it applied */
    uint16_t bits[4] = {1, 0, 1, 1};
    gw_write_result_t wres;
    assert_int_equal(gw_regmap_write(&U, GW_COILS, 200, 4, bits, NULL, &wres), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(get("bit_in[0]"), 0);
    assert_int_equal(wres.dirty, 0);
    bits[3] = 0;
    assert_int_equal(gw_regmap_write(&U, GW_COILS, 200, 4, bits, NULL, &wres), 0);
    assert_int_equal(get("bit_in[0]"), 1);
    assert_int_equal(wres.dirty, 1u << DR_ASM_BIT_IN);
    /* the packed word: may keep the owned bit as it is, not change it */
    assert_int_equal(write1(GW_HOLDING, 200, 0x0008 | 0x0100), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(get("bit_in[8]"), 0);
    assert_int_equal(write1(GW_HOLDING, 200, 0x0100), 0);
    assert_int_equal(get("bit_in[8]"), 1);
    assert_int_equal(get("bit_in[2]"), 0); /* the word was written whole */
    /* the input itself (gpiomap sets the image) may change it: a write
     * that keeps the new value is accepted */
    R.img[DR_ASM_BIT_IN][0] |= 0x08;
    assert_int_equal(write1(GW_HOLDING, 200, 0x0108), 0);
    assert_int_equal(write1(GW_COILS, 203, 0), GW_EX_ILLEGAL_ADDRESS);
    /* another field's owned bit, as a coil and in its packed register */
    assert_int_equal(write1(GW_COILS, 100, 1), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(write1(GW_HOLDING, 100, 0x0001), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(write1(GW_HOLDING, 100, 0x0002), 0);
    assert_int_equal(get("io_control.cb_do[2]"), 1);
    /* a unit with no inputs: everything goes */
    R.write_policy.gpio_in_count = 0;
    assert_int_equal(write1(GW_COILS, 203, 0), 0);
    assert_int_equal(write1(GW_COILS, 100, 1), 0);
}

static void test_reserved_addresses(void **state)
{
    (void)state;
    uint16_t v[125];
    static const gw_area_t areas[] = {GW_COILS, GW_DISCRETE, GW_HOLDING, GW_INPUT};
    for (unsigned i = 0; i < 4; i++) {
        gw_area_t a = areas[i];
        uint16_t end = gw_regmap_extent(a);
        assert_true(end > 100 && end < GW_AREA_SIZE);
        /* the default: reserved addresses read 0, the map's end is the end */
        U.unmapped = GW_UNMAPPED_ZERO;
        memset(v, 0xAB, sizeof v);
        assert_int_equal(gw_regmap_read(&U, a, (uint16_t)(end - 125), 125, v), 0);
        assert_int_equal(gw_regmap_read(&U, a, (uint16_t)(end - 1), 2, v), GW_EX_ILLEGAL_ADDRESS);
        assert_int_equal(gw_regmap_read(&U, a, end, 1, v), GW_EX_ILLEGAL_ADDRESS);
        /* strict: a reserved address anywhere refuses the read */
        U.unmapped = GW_UNMAPPED_EXCEPTION;
        assert_int_equal(gw_regmap_read(&U, a, (uint16_t)(end - 1), 1, v), 0);
        assert_int_equal(gw_regmap_read(&U, a, 99, 1, v), GW_EX_ILLEGAL_ADDRESS);
    }
    /* a reserved register reads 0 among its mapped neighbours: IR 44-99
     * lie between the status block's RTU counters and io_state */
    U.unmapped = GW_UNMAPPED_ZERO;
    memset(v, 0xAB, sizeof v);
    assert_int_equal(gw_regmap_read(&U, GW_INPUT, 32, 70, v), 0);
    assert_int_equal(v[0], 0x1234); /* test register 32 */
    for (unsigned i = 12; i < 68; i++)
        assert_int_equal(v[i], 0);
    /* writes to reserved addresses stay refused, whatever the policy */
    assert_int_equal(write1(GW_HOLDING, 2, 0), GW_EX_ILLEGAL_ADDRESS);
    assert_int_equal(write1(GW_COILS, 0, 0), GW_EX_ILLEGAL_ADDRESS);
}

/* IR 40-43 (Modbus RTU frames dropped, for other slaves) are 32-bit
 * counters like IR 6-15: high word first whatever the word order. IR 31
 * is reserved but part of the block: IR 0-43 is one read, also with
 * unmapped_read = exception. */
static void test_status_counters(void **state)
{
    (void)state;
    static const gw_word_order_t orders[] = {GW_WORD_ABCD, GW_WORD_CDAB, GW_WORD_BADC,
                                             GW_WORD_DCBA};
    U.status.rtu_dropped = 0x00010203u;
    U.status.rtu_other = 0x80000101u;
    R.link.rx_packets = 0x12345678u;
    U.unmapped = GW_UNMAPPED_EXCEPTION;
    for (unsigned i = 0; i < 4; i++) {
        uint16_t v[44];
        U.order = orders[i];
        memset(v, 0xAB, sizeof v);
        assert_int_equal(gw_regmap_read(&U, GW_INPUT, 0, 44, v), 0);
        assert_int_equal(v[6], 0x1234);
        assert_int_equal(v[7], 0x5678);
        assert_int_equal(v[31], 0);
        assert_int_equal(v[32], 0x1234); /* the test registers stay between */
        assert_int_equal(v[40], 0x0001);
        assert_int_equal(v[41], 0x0203);
        assert_int_equal(v[42], 0x8000);
        assert_int_equal(v[43], 0x0101);
    }
    /* the block ends at IR 43 */
    uint16_t w[2];
    assert_int_equal(gw_regmap_read(&U, GW_INPUT, 43, 2, w), GW_EX_ILLEGAL_ADDRESS);
    assert_false(gw_regmap_touches_robot_data(GW_INPUT, 0, 44));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_gpio_owned_bits, setup),
        cmocka_unit_test_setup(test_reserved_addresses, setup),
        cmocka_unit_test_setup(test_status_counters, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
