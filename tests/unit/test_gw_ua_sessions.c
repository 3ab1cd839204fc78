/* SPDX-License-Identifier: MIT */
/*
 * Which sessions the OPC UA side closes without a login
 * (gateway/opcua/ua_sessions.c, ua_sessions_pick): each one not logged
 * in within the window, and, when the server is full, the oldest not
 * logged in, until there is room for one more; never one logged in.
 * The hooks into open62541 and the closing itself run in tests/opcua
 * (test_opcua_security.py test_held_sessions_do_not_lock_out). Built
 * only with open62541 (the Makefile's OPCUA_TEST_SRC).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include "opcua/ua_sessions.h"

#define W 10000 /* the window, ms */

static void test_young_ones_stay_until_the_window(void **state)
{
    (void)state;
    const int64_t age[] = {500, 2500, 100};
    bool close[3];
    int64_t next;
    assert_int_equal(ua_sessions_pick(age, close, 3, 2, 20, W, &next), 0);
    assert_false(close[0] || close[1] || close[2]);
    assert_int_equal(next, W - 2500); /* the oldest's window ends first */
}

static void test_past_the_window_closed(void **state)
{
    (void)state;
    const int64_t age[] = {W, 3000, W + 5000};
    bool close[3];
    int64_t next;
    assert_int_equal(ua_sessions_pick(age, close, 3, 0, 20, W, &next), 2);
    assert_true(close[0] && !close[1] && close[2]);
    assert_int_equal(next, W - 3000);
}

static void test_full_the_oldest_goes(void **state)
{
    (void)state;
    /* room for 6: 3 logged in and 3 not: one closed, the oldest */
    const int64_t age[] = {50, 4000, 700};
    bool close[3];
    int64_t next;
    assert_int_equal(ua_sessions_pick(age, close, 3, 3, 6, W, &next), 1);
    assert_true(!close[0] && close[1] && !close[2]);
    assert_int_equal(next, W - 700);
    /* one more than full (a count from before a close): two go */
    assert_int_equal(ua_sessions_pick(age, close, 3, 4, 6, W, &next), 2);
    assert_true(!close[0] && close[1] && close[2]);
    assert_int_equal(next, W - 50);
}

static void test_logged_in_never_closed(void **state)
{
    (void)state;
    /* full with logins alone: every other one goes, and no more */
    const int64_t age[] = {10, 20};
    bool close[2];
    int64_t next;
    assert_int_equal(ua_sessions_pick(age, close, 2, 6, 6, W, &next), 2);
    assert_true(close[0] && close[1]);
    assert_int_equal(next, -1);
    assert_int_equal(ua_sessions_pick(age, close, 0, 6, 6, W, &next), 0);
    assert_int_equal(next, -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_young_ones_stay_until_the_window),
        cmocka_unit_test(test_past_the_window_closed),
        cmocka_unit_test(test_full_the_oldest_goes),
        cmocka_unit_test(test_logged_in_never_closed),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
