/* SPDX-License-Identifier: MIT */
/* The software debouncer of gateway/gpio/gpio_debounce.c, on made-up times. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include "gpio/gpio.h"

#define MS 1000000ull /* ns */

static void test_init(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 10 * MS, 1, 5 * MS);
    assert_int_equal(d.stable, 1);
    assert_int_equal(d.raw, 1);
    assert_true(gw_gpio_debounce_deadline(&d) == UINT64_MAX);
    assert_false(gw_gpio_debounce_update(&d, 1000 * MS));
    /* Any non-zero level is 1. */
    gw_gpio_debounce_init(&d, 0, 7, 0);
    assert_int_equal(d.stable, 1);
}

static void test_change_after_period(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 10 * MS, 0, 0);
    gw_gpio_debounce_feed(&d, 1, 100 * MS);
    assert_true(gw_gpio_debounce_deadline(&d) == 110 * MS);
    assert_false(gw_gpio_debounce_update(&d, 105 * MS));
    assert_int_equal(d.stable, 0);
    assert_false(gw_gpio_debounce_update(&d, 110 * MS - 1));
    assert_true(gw_gpio_debounce_update(&d, 110 * MS)); /* boundary counts */
    assert_int_equal(d.stable, 1);
    assert_false(gw_gpio_debounce_update(&d, 200 * MS)); /* once only */
    assert_true(gw_gpio_debounce_deadline(&d) == UINT64_MAX);
}

static void test_short_pulse_ignored(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 10 * MS, 0, 0);
    gw_gpio_debounce_feed(&d, 1, 100 * MS);
    gw_gpio_debounce_feed(&d, 0, 103 * MS);
    assert_true(gw_gpio_debounce_deadline(&d) == UINT64_MAX);
    assert_false(gw_gpio_debounce_update(&d, 1000 * MS));
    assert_int_equal(d.stable, 0);
}

static void test_bounces_restart_timer(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 10 * MS, 0, 0);
    /* A contact that chatters for 8 ms before it closes for good. */
    for (uint64_t t = 100; t <= 108; t += 2)
        gw_gpio_debounce_feed(&d, (int)((t / 2) & 1) ^ 1, t * MS);
    /* Last edge at 108 ms went to 1 ((54 & 1) ^ 1 = 1). */
    assert_int_equal(d.raw, 1);
    assert_true(gw_gpio_debounce_deadline(&d) == 118 * MS);
    assert_false(gw_gpio_debounce_update(&d, 111 * MS));
    assert_true(gw_gpio_debounce_update(&d, 118 * MS));
    assert_int_equal(d.stable, 1);
}

static void test_repeated_level_restarts(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    /* Two rising edges in a row: the falling one between them was lost,
     * so the line is still moving and the timer starts again. */
    gw_gpio_debounce_init(&d, 10 * MS, 0, 0);
    gw_gpio_debounce_feed(&d, 1, 100 * MS);
    gw_gpio_debounce_feed(&d, 1, 107 * MS);
    assert_false(gw_gpio_debounce_update(&d, 110 * MS));
    assert_true(gw_gpio_debounce_update(&d, 117 * MS));
}

static void test_zero_period_passes_through(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 0, 0, 50 * MS);
    gw_gpio_debounce_feed(&d, 1, 60 * MS);
    /* Even with "now" before the edge's stamp (clocks read at different
     * moments), period 0 takes the edge at once. */
    assert_true(gw_gpio_debounce_update(&d, 59 * MS));
    assert_int_equal(d.stable, 1);
    gw_gpio_debounce_feed(&d, 0, 61 * MS);
    assert_true(gw_gpio_debounce_update(&d, 61 * MS));
    assert_int_equal(d.stable, 0);
}

static void test_out_of_order_timestamps(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 10 * MS, 0, 0);
    gw_gpio_debounce_feed(&d, 1, 100 * MS);
    /* An older stamp must not pull the deadline earlier. */
    gw_gpio_debounce_feed(&d, 1, 90 * MS);
    assert_true(gw_gpio_debounce_deadline(&d) == 110 * MS);
    assert_false(gw_gpio_debounce_update(&d, 105 * MS));
    assert_true(gw_gpio_debounce_update(&d, 110 * MS));
}

static void test_saturation(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    /* A period that would overflow means "never", not "at once". */
    gw_gpio_debounce_init(&d, UINT64_MAX - 5, 0, 0);
    gw_gpio_debounce_feed(&d, 1, 100);
    assert_true(gw_gpio_debounce_deadline(&d) == UINT64_MAX);
    assert_false(gw_gpio_debounce_update(&d, UINT64_MAX - 1));
    assert_int_equal(d.stable, 0);
}

static void test_down_then_up_again(void **state)
{
    gw_gpio_debounce_t d;

    (void)state;
    gw_gpio_debounce_init(&d, 5 * MS, 1, 0);
    gw_gpio_debounce_feed(&d, 0, 10 * MS);
    assert_true(gw_gpio_debounce_update(&d, 15 * MS));
    assert_int_equal(d.stable, 0);
    gw_gpio_debounce_feed(&d, 1, 20 * MS);
    gw_gpio_debounce_feed(&d, 0, 21 * MS);
    gw_gpio_debounce_feed(&d, 1, 22 * MS);
    assert_false(gw_gpio_debounce_update(&d, 26 * MS));
    assert_true(gw_gpio_debounce_update(&d, 27 * MS));
    assert_int_equal(d.stable, 1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_init),
        cmocka_unit_test(test_change_after_period),
        cmocka_unit_test(test_short_pulse_ignored),
        cmocka_unit_test(test_bounces_restart_timer),
        cmocka_unit_test(test_repeated_level_restarts),
        cmocka_unit_test(test_zero_period_passes_through),
        cmocka_unit_test(test_out_of_order_timestamps),
        cmocka_unit_test(test_saturation),
        cmocka_unit_test(test_down_then_up_again),
    };
    return cmocka_run_group_tests_name("gpio_debounce", tests, NULL, NULL);
}
