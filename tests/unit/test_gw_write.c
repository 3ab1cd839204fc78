/* SPDX-License-Identifier: MIT */
/*
 * The one write path (gateway/core/write.h, issue 30 item 4): the refusal
 * matrix, every rule against every origin (Modbus TCP, Modbus RTU, MQTT,
 * Sparkplug, GPIO), and all-or-nothing: a refused write leaves the
 * robot's images, its latch and its last_write as they were. The robot is
 * a plain gw_robot_t, as the daemon's is.
 */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "core/write.h"

static gw_robot_t R;
static gw_log_limit_t LOG;

static int setup(void **state)
{
    (void)state;
    gw_robot_init(&R, "arm", 1);
    memset(&LOG, 0, sizeof LOG);
    return 0;
}

static dr_ref_t ref(const char *path)
{
    dr_ref_t r;
    assert_int_equal(dr_path_parse(path, &r), DR_OK);
    return r;
}

static gw_write_item_t item(const char *path, dr_value_t v)
{
    return (gw_write_item_t){ref(path), v, 0};
}

static double real(const char *path)
{
    dr_value_t v;
    assert_int_equal(gw_robot_get(&R, ref(path), &v), DR_OK);
    return v.f;
}

static uint64_t uns(const char *path)
{
    dr_value_t v;
    assert_int_equal(gw_robot_get(&R, ref(path), &v), DR_OK);
    return v.u;
}

static int64_t sgn(const char *path)
{
    dr_value_t v;
    assert_int_equal(gw_robot_get(&R, ref(path), &v), DR_OK);
    return v.i;
}

static const gw_origin_side_t sides[] = {GW_ORIGIN_MODBUS_TCP, GW_ORIGIN_MODBUS_RTU,
                                         GW_ORIGIN_MQTT, GW_ORIGIN_SPARKPLUG, GW_ORIGIN_GPIO};
#define NSIDES (sizeof sides / sizeof sides[0])

static gw_write_origin_t origin(gw_origin_side_t side)
{
    return (gw_write_origin_t){side, "test", true, true, false, &LOG};
}

/* One write of items from side: its status, and (refused) nothing of the
 * robot changed. */
static gw_write_status_t try_write(gw_origin_side_t side, const gw_write_item_t *items,
                                   unsigned n, gw_write_result_t *res)
{
    static gw_robot_t before;
    before = R;
    gw_write_origin_t o = origin(side);
    gw_write_status_t st = gw_robot_write(&R, items, n, &o, res);
    assert_int_equal(st, res->status);
    if (st != GW_WRITE_OK) {
        assert_memory_equal(&before, &R, sizeof R);
        assert_int_equal(res->dirty, 0);
    }
    return st;
}

/* The same write through every side: the same answer. */
static void every_side(const gw_write_item_t *items, unsigned n, gw_write_status_t want)
{
    for (unsigned s = 0; s < NSIDES; s++) {
        gw_write_result_t res;
        assert_int_equal(try_write(sides[s], items, n, &res), want);
    }
}

/* The rules every side shares. */
static void test_direction_plan_range(void **state)
{
    (void)state;
    gw_write_item_t t2o = item("joint_state.position[1]", dr_value_real(1.0));
    every_side(&t2o, 1, GW_WRITE_DIRECTION);
    /* the plan: float_in travels on no connection (float_out input-only) */
    R.o2t_unsent = 1u << DR_ASM_FLOAT_IN;
    gw_write_item_t unsent = item("float_in[1]", dr_value_real(2.5));
    every_side(&unsent, 1, GW_WRITE_UNSENT);
    assert_true(real("float_in[1]") == 0.0);
    R.o2t_unsent = 0;
    /* range and type: the codec's, with its reason */
    gw_write_item_t bad[] = {item("float_in[0]", dr_value_real(NAN)),
                             item("bit_in[0]", dr_value_uint(2)),
                             item("int_in[0]", dr_value_int(INT64_C(3000000000)))};
    for (unsigned i = 0; i < 3; i++)
        for (unsigned s = 0; s < NSIDES; s++) {
            gw_write_result_t res;
            assert_int_equal(try_write(sides[s], &bad[i], 1, &res), GW_WRITE_VALUE);
            assert_int_not_equal(res.st, DR_OK);
        }
    gw_write_item_t good = item("float_in[1]", dr_value_real(2.5));
    every_side(&good, 1, GW_WRITE_OK);
    assert_true(real("float_in[1]") == 2.5);
    gw_write_item_t none = {{NULL, 0}, dr_value_uint(0), 0};
    every_side(&none, 1, GW_WRITE_FIELD);
}

/* The side's own right for its client (allow ro, read_only, writes = no);
 * GPIO inputs are the wiring and have no client. */
static void test_rights(void **state)
{
    (void)state;
    gw_write_item_t it = item("int_in[1]", dr_value_int(5));
    for (unsigned s = 0; s < NSIDES; s++) {
        gw_write_origin_t o = origin(sides[s]);
        o.may_write = false;
        gw_write_result_t res;
        gw_write_status_t want = sides[s] == GW_ORIGIN_GPIO ? GW_WRITE_OK : GW_WRITE_RIGHTS;
        assert_int_equal(gw_robot_write(&R, &it, 1, &o, &res), want);
        assert_int_equal(gw_write_allowed(&R, &o), want);
    }
}

/* Single-writer mode: the outputs are one Modbus TCP client's; MQTT and
 * Sparkplug are refused even with the owner's flag; the RTU master and
 * GPIO inputs are not arbitrated (docs/configuration.md). */
static void test_single_writer(void **state)
{
    (void)state;
    R.write_policy.one_owner = true;
    gw_write_item_t it = item("int_in[2]", dr_value_int(7));
    static const gw_write_status_t owner[NSIDES] = {GW_WRITE_OK, GW_WRITE_OK, GW_WRITE_SINGLE,
                                                    GW_WRITE_SINGLE, GW_WRITE_OK};
    for (unsigned s = 0; s < NSIDES; s++) {
        gw_write_result_t res;
        assert_int_equal(try_write(sides[s], &it, 1, &res), owner[s]);
    }
    gw_write_origin_t other = origin(GW_ORIGIN_MODBUS_TCP);
    other.owner = false;
    assert_int_equal(gw_robot_write(&R, &it, 1, &other, NULL), GW_WRITE_SINGLE);
    R.write_policy.one_owner = false;
    assert_int_equal(gw_robot_write(&R, &it, 1, &other, NULL), GW_WRITE_OK);
}

/* The latch refuses every write but the reset, which carries no field and
 * clears it at once; GPIO inputs go on. */
static void test_fault_latch(void **state)
{
    (void)state;
    R.fault = true;
    gw_write_item_t it = item("int_in[3]", dr_value_int(9));
    static const gw_write_status_t want[NSIDES] = {GW_WRITE_FAULT, GW_WRITE_FAULT, GW_WRITE_FAULT,
                                                   GW_WRITE_FAULT, GW_WRITE_OK};
    for (unsigned s = 0; s < NSIDES; s++) {
        gw_write_result_t res;
        assert_int_equal(try_write(sides[s], &it, 1, &res), want[s]);
    }
    assert_true(R.fault);
    /* a "reset" that carries a field is not the reset */
    gw_write_origin_t o = origin(GW_ORIGIN_MODBUS_TCP);
    o.reset = true;
    gw_write_result_t res;
    assert_int_equal(gw_robot_write(&R, &it, 1, &o, &res), GW_WRITE_FAULT);
    assert_true(R.fault);
    /* the reset (a ro client's neither) */
    o.may_write = false;
    assert_int_equal(gw_robot_write(&R, NULL, 0, &o, &res), GW_WRITE_RIGHTS);
    assert_true(R.fault);
    o.may_write = true;
    assert_int_equal(gw_robot_write(&R, NULL, 0, &o, &res), GW_WRITE_OK);
    assert_true(res.reset);
    assert_false(R.fault);
    every_side(&it, 1, GW_WRITE_OK);
}

/* A bit a GPIO input drives may be named with its value, not changed, but
 * by the input. */
static void test_gpio_bits(void **state)
{
    (void)state;
    R.write_policy.gpio_in[R.write_policy.gpio_in_count++] = ref("bit_in[3]");
    gw_write_item_t same = item("bit_in[3]", dr_value_uint(0));
    gw_write_item_t change = item("bit_in[3]", dr_value_uint(1));
    for (unsigned s = 0; s < NSIDES; s++) {
        gw_write_result_t res;
        assert_int_equal(try_write(sides[s], &same, 1, &res), GW_WRITE_OK);
        if (sides[s] != GW_ORIGIN_GPIO)
            assert_int_equal(try_write(sides[s], &change, 1, &res), GW_WRITE_GPIO);
    }
    /* a packed mask that flips it, and one that leaves it */
    gw_write_item_t mask = {ref("bit_in"), dr_value_uint(0x000Fu), 0xFFFFu};
    gw_write_result_t res;
    assert_int_equal(try_write(GW_ORIGIN_MODBUS_TCP, &mask, 1, &res), GW_WRITE_GPIO);
    mask.value = dr_value_uint(0x0007u);
    assert_int_equal(try_write(GW_ORIGIN_MODBUS_TCP, &mask, 1, &res), GW_WRITE_OK);
    assert_int_equal(uns("bit_in") & 0xFu, 0x7u);
    assert_int_equal(try_write(GW_ORIGIN_GPIO, &change, 1, &res), GW_WRITE_OK);
    assert_int_equal(uns("bit_in[3]"), 1);
}

/* All or nothing: the last item refused, the first ones not applied; the
 * items compose on one copy (two masks of one field, DINT halves). */
static void test_all_or_nothing(void **state)
{
    (void)state;
    R.o2t_unsent = 1u << DR_ASM_FLOAT_IN;
    gw_write_item_t two[] = {item("int_in[5]", dr_value_int(55)),
                             item("float_in[0]", dr_value_real(1.0))};
    for (unsigned s = 0; s < NSIDES; s++) {
        gw_write_result_t res;
        assert_int_equal(try_write(sides[s], two, 2, &res), GW_WRITE_UNSENT);
        assert_int_equal(res.item, 1);
    }
    assert_int_equal(sgn("int_in[5]"), 0);
    gw_write_item_t nan[] = {item("io_control.ao[0]", dr_value_real(3.5)),
                             item("io_control.ao[1]", dr_value_real(NAN))};
    every_side(nan, 2, GW_WRITE_VALUE);
    assert_true(real("io_control.ao[0]") == 0.0);
    /* compose: two 16-bit words of one mask, two halves of one DINT */
    gw_write_item_t parts[] = {
        {ref("bit_in"), dr_value_uint(0x00A5u), 0xFFFFu},
        {ref("bit_in"), dr_value_uint(UINT64_C(0x5A) << 16), UINT64_C(0xFFFF) << 16},
        {ref("int_in[6]"), dr_value_uint(0xFFFFu), 0xFFFFu},
        {ref("int_in[6]"), dr_value_uint(0xFFFF0000u), 0xFFFF0000u}};
    gw_write_result_t res;
    assert_int_equal(try_write(GW_ORIGIN_MODBUS_TCP, parts, 4, &res), GW_WRITE_OK);
    assert_int_equal(uns("bit_in") & 0xFFFFFFFFu, 0x005A00A5u);
    assert_int_equal(sgn("int_in[6]"), -1);
    assert_int_equal(res.dirty, 1u << DR_ASM_BIT_IN | 1u << DR_ASM_INT_IN);
    /* too many items: refused before any */
    static gw_write_item_t many[GW_WRITE_MAX_ITEMS + 1];
    for (unsigned i = 0; i < GW_WRITE_MAX_ITEMS + 1; i++)
        many[i] = item("int_in[7]", dr_value_int(1));
    assert_int_equal(try_write(GW_ORIGIN_MODBUS_TCP, many, GW_WRITE_MAX_ITEMS + 1, &res),
                     GW_WRITE_FIELD);
}

/* An accepted write is the robot's last write, by client and fields; a
 * refused one is no write; GPIO inputs are not logged. */
static void test_write_log(void **state)
{
    (void)state;
    gw_write_item_t two[] = {item("int_in[0]", dr_value_int(1)),
                             item("float_in[2]", dr_value_real(0.5))};
    gw_write_origin_t o = {GW_ORIGIN_MQTT, "mqtt drgate/arm/set/int_in[0]", true, false, false,
                           &LOG};
    assert_int_equal(gw_robot_write(&R, two, 2, &o, NULL), GW_WRITE_OK);
    assert_string_equal(R.last_write.client, "mqtt drgate/arm/set/int_in[0]");
    char text[256];
    gw_robot_write_fields_text(&R, text, sizeof text);
    assert_string_equal(text, "int_in[0], float_in[2]");
    gw_robot_write_t last = R.last_write;
    two[1].value = dr_value_real(INFINITY);
    o.client = "other";
    assert_int_equal(gw_robot_write(&R, two, 2, &o, NULL), GW_WRITE_VALUE);
    assert_memory_equal(&last, &R.last_write, sizeof last);
    gw_write_origin_t gpio = origin(GW_ORIGIN_GPIO);
    gpio.log = NULL;
    two[1].value = dr_value_real(0.25);
    assert_int_equal(gw_robot_write(&R, two, 2, &gpio, NULL), GW_WRITE_OK);
    assert_memory_equal(&last, &R.last_write, sizeof last);
}

/* The daemon's policy from a configuration: single-writer mode, the
 * robot's own GPIO inputs only. */
static void test_policy_from_config(void **state)
{
    (void)state;
    static gw_config_t c;
    gw_config_defaults(&c);
    c.side.modbus.single_writer = true;
    c.side.gpio.count = 2;
    c.side.gpio.line[0].dir = GW_GPIO_INPUT;
    c.side.gpio.line[0].robot_index = 0;
    c.side.gpio.line[0].field = ref("bit_in[1]");
    c.side.gpio.line[1].dir = GW_GPIO_INPUT;
    c.side.gpio.line[1].robot_index = 1;
    c.side.gpio.line[1].field = ref("bit_in[2]");
    gw_write_policy_set(&R, &c, 0);
    assert_true(R.write_policy.one_owner);
    assert_int_equal(R.write_policy.gpio_in_count, 1);
    assert_ptr_equal(R.write_policy.gpio_in[0].field, ref("bit_in[1]").field);
    assert_int_equal(R.write_policy.gpio_in[0].elem, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_direction_plan_range, setup),
        cmocka_unit_test_setup(test_rights, setup),
        cmocka_unit_test_setup(test_single_writer, setup),
        cmocka_unit_test_setup(test_fault_latch, setup),
        cmocka_unit_test_setup(test_gpio_bits, setup),
        cmocka_unit_test_setup(test_all_or_nothing, setup),
        cmocka_unit_test_setup(test_write_log, setup),
        cmocka_unit_test_setup(test_policy_from_config, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
