/* SPDX-License-Identifier: MIT */
/*
 * The Prometheus text writer (gateway/core/prom.c) behind GET /metrics:
 * HELP and TYPE once per family however often it is declared, label
 * values escaped as the exposition format wants (backslash, double quote,
 * newline) and HELP texts too (backslash, newline), whole numbers without
 * an exponent, NaN and infinities spelled as Prometheus reads them, and a
 * buffer too small marked full instead of holding a cut text.
 */
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "core/prom.h"

static gw_prom_t M;
static char buf[4096];

static int setup(void **state)
{
    (void)state;
    gw_prom_init(&M, buf, sizeof buf);
    return 0;
}

static unsigned count(const char *hay, const char *needle)
{
    unsigned n = 0;
    for (const char *p = strstr(hay, needle); p != NULL; p = strstr(p + 1, needle))
        n++;
    return n;
}

static void test_family_once(void **state)
{
    (void)state;
    gw_prom_label_t a = {"robot", "r0"}, b = {"robot", "r1"};
    gw_prom_family(&M, "drgate_link_up", GW_PROM_GAUGE, "Link up");
    gw_prom_sample(&M, "drgate_link_up", &a, 1, 1);
    gw_prom_family(&M, "drgate_link_up", GW_PROM_GAUGE, "Link up");
    gw_prom_sample(&M, "drgate_link_up", &b, 1, 0);
    gw_prom_one(&M, "drgate_x_total", GW_PROM_COUNTER, "X", 3);
    assert_false(M.full);
    assert_string_equal(buf, "# HELP drgate_link_up Link up\n"
                             "# TYPE drgate_link_up gauge\n"
                             "drgate_link_up{robot=\"r0\"} 1\n"
                             "drgate_link_up{robot=\"r1\"} 0\n"
                             "# HELP drgate_x_total X\n"
                             "# TYPE drgate_x_total counter\n"
                             "drgate_x_total 3\n");
    assert_int_equal(count(buf, "# TYPE drgate_link_up"), 1);
    assert_int_equal(M.len, strlen(buf));
}

static void test_escaping(void **state)
{
    (void)state;
    gw_prom_label_t l[2] = {{"robot", "a\"b\\c\nd"}, {"device", "/dev/ttyUSB0"}};
    gw_prom_family(&M, "m", GW_PROM_GAUGE, "back\\slash \"quoted\"\nnext");
    gw_prom_sample(&M, "m", l, 2, 0.5);
    assert_false(M.full);
    /* HELP: \\ and \n only (a quote stays); label values: \", \\, \n */
    assert_string_equal(buf, "# HELP m back\\\\slash \"quoted\"\\nnext\n"
                             "# TYPE m gauge\n"
                             "m{robot=\"a\\\"b\\\\c\\nd\",device=\"/dev/ttyUSB0\"} 0.5\n");
}

static void test_values(void **state)
{
    (void)state;
    gw_prom_sample(&M, "a", NULL, 0, 4294967296.0);
    gw_prom_sample(&M, "b", NULL, 0, NAN);
    gw_prom_sample(&M, "c", NULL, 0, INFINITY);
    gw_prom_sample(&M, "d", NULL, 0, -INFINITY);
    gw_prom_sample(&M, "e", NULL, 0, 0.000125);
    assert_string_equal(buf, "a 4294967296\nb NaN\nc +Inf\nd -Inf\ne 0.000125\n");
}

static void test_histogram_type(void **state)
{
    (void)state;
    gw_prom_family(&M, "h_seconds", GW_PROM_HISTOGRAM, "H");
    assert_non_null(strstr(buf, "# TYPE h_seconds histogram\n"));
}

/* Too small: full, and nothing after the first thing that did not fit
 * (no sample cut in the middle followed by a later one). */
static void test_full(void **state)
{
    (void)state;
    char small[40];
    gw_prom_t m;
    gw_prom_init(&m, small, sizeof small);
    gw_prom_one(&m, "drgate_uptime_seconds", GW_PROM_GAUGE, "Seconds since the daemon started",
                12);
    assert_true(m.full);
    assert_true(m.len < sizeof small);
    assert_int_equal(strlen(small), m.len);
    size_t len = m.len;
    gw_prom_sample(&m, "x", NULL, 0, 1); /* would fit, but the text is spoilt */
    assert_int_equal(m.len, len);
    /* exactly the right size fits: cap = text + '\0' */
    char exact[sizeof "x 1\n"];
    gw_prom_init(&m, exact, sizeof exact);
    gw_prom_sample(&m, "x", NULL, 0, 1);
    assert_false(m.full);
    assert_string_equal(exact, "x 1\n");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_family_once, setup),
        cmocka_unit_test_setup(test_escaping, setup),
        cmocka_unit_test_setup(test_values, setup),
        cmocka_unit_test_setup(test_histogram_type, setup),
        cmocka_unit_test_setup(test_full, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
