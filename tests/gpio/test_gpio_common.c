/* SPDX-License-Identifier: MIT */
/*
 * gateway/gpio/gpio_common.c over the fake backend: lookup, validation, the
 * wording of errors, safe values, events and debouncing. The same code
 * runs against a real kernel in tests/gpio/qemu.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <errno.h>
#include <string.h>
#include <cmocka.h>

#include "gpio/gpio.h"
#include "gpio_fake.h"

#define MS 1000000ull

static void assert_contains(const char *hay, const char *needle)
{
    if (strstr(hay, needle) == NULL)
        fail_msg("\"%s\" does not contain \"%s\"", hay, needle);
}

static int setup(void **state)
{
    (void)state;
    fake_reset();
    return 0;
}

static gw_gpio_chip_t *open_a(void)
{
    gw_gpio_chip_t *chip = NULL;
    gw_gpio_error_t err;

    assert_int_equal(gw_gpio_chip_open("gpiochip0", &chip, &err), GW_GPIO_OK);
    assert_non_null(chip);
    return chip;
}

static void test_strerror(void **state)
{
    (void)state;
    assert_string_equal(gw_gpio_strerror(GW_GPIO_OK), "success");
    assert_string_equal(gw_gpio_strerror(GW_GPIO_EBUSY),
                        "GPIO line already in use");
    assert_string_equal(gw_gpio_strerror((gw_gpio_status_t)999),
                        "unknown GPIO status");
    assert_non_null(gw_gpio_backend());
}

static void test_open_forms(void **state)
{
    const char *specs[] = { "gpiochip0", "0", "/dev/gpiochip0" };
    gw_gpio_chip_t *chip;

    (void)state;
    for (size_t i = 0; i < 3; i++) {
        chip = NULL;
        assert_int_equal(gw_gpio_chip_open(specs[i], &chip, NULL), GW_GPIO_OK);
        assert_string_equal(gw_gpio_chip_name(chip), "gpiochip0");
        assert_string_equal(gw_gpio_chip_label(chip), "fake-A");
        assert_string_equal(gw_gpio_chip_path(chip), "/dev/gpiochip0");
        assert_int_equal(gw_gpio_chip_num_lines(chip), 8);
        gw_gpio_chip_close(chip);
    }
    assert_int_equal(fake.open_chips, 0);
    gw_gpio_chip_close(NULL);
}

static void test_open_errors(void **state)
{
    gw_gpio_chip_t *chip = (gw_gpio_chip_t *)&chip;
    gw_gpio_error_t err;

    (void)state;
    assert_int_equal(gw_gpio_chip_open("gpiochip7", &chip, &err),
                     GW_GPIO_ENOCHIP);
    assert_null(chip);
    assert_int_equal(err.code, GW_GPIO_ENOCHIP);
    assert_int_equal(err.sys_errno, ENOENT);
    assert_contains(err.msg, "GPIO chip \"gpiochip7\" (/dev/gpiochip7)");
    assert_contains(err.msg, "present:");
    /* A label with no chip (the test machine has no /dev/gpiochip*). */
    assert_int_equal(gw_gpio_chip_open("no-such-label", &chip, &err),
                     GW_GPIO_ENOCHIP);
    assert_contains(err.msg, "\"no-such-label\": no chip has this name");
    assert_int_equal(gw_gpio_chip_open("", &chip, &err), GW_GPIO_EINVAL);
    assert_contains(err.msg, "empty name");
    assert_int_equal(gw_gpio_chip_open(NULL, &chip, NULL), GW_GPIO_EINVAL);
    assert_int_equal(gw_gpio_chip_open("gpiochip0", NULL, &err),
                     GW_GPIO_EINVAL);
}

static void test_find_line(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_error_t err;
    unsigned int off = 99;

    (void)state;
    assert_int_equal(gw_gpio_chip_find_line(chip, "3", &off, &err), GW_GPIO_OK);
    assert_int_equal(off, 3);
    assert_int_equal(gw_gpio_chip_find_line(chip, "fake-A-5", &off, &err),
                     GW_GPIO_OK);
    assert_int_equal(off, 5);
    assert_int_equal(gw_gpio_chip_find_line(chip, "8", &off, &err),
                     GW_GPIO_ENOLINE);
    assert_string_equal(err.msg, "gpiochip0 [fake-A]: line offset 8 out of "
                                 "range (the chip has 8 lines: 0..7)");
    assert_int_equal(
        gw_gpio_chip_find_line(chip, "99999999999999999999", &off, &err),
        GW_GPIO_ENOLINE);
    assert_int_equal(gw_gpio_chip_find_line(chip, "relay", &off, &err),
                     GW_GPIO_ENOLINE);
    assert_string_equal(err.msg, "gpiochip0 [fake-A]: no line named "
                                 "\"relay\" (gpioinfo gpiochip0 lists the "
                                 "names)");
    assert_int_equal(gw_gpio_chip_find_line(chip, "", &off, &err),
                     GW_GPIO_EINVAL);
    gw_gpio_chip_close(chip);
}

/* Requests cfg lines and expects a refusal with a message part. */
static void expect_refused(gw_gpio_chip_t *chip,
                           const gw_gpio_line_config_t *lines, size_t n,
                           gw_gpio_status_t code, const char *part)
{
    gw_gpio_request_config_t cfg = { "test", lines, n };
    gw_gpio_request_t *req = (gw_gpio_request_t *)&req;
    gw_gpio_error_t err;

    assert_int_equal(gw_gpio_chip_request_lines(chip, &cfg, &req, &err), code);
    assert_null(req);
    assert_int_equal(err.code, code);
    assert_contains(err.msg, part);
}

static void test_request_validation(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_line_config_t l[GW_GPIO_MAX_LINES + 1];

    (void)state;
    memset(l, 0, sizeof l);
    expect_refused(chip, l, 0, GW_GPIO_EINVAL, "1 to 64 lines, not 0");
    expect_refused(chip, l, GW_GPIO_MAX_LINES + 1, GW_GPIO_EINVAL, "not 65");
    l[0].offset = 8;
    expect_refused(chip, l, 1, GW_GPIO_ENOLINE, "line offset 8 out of range");
    l[0].offset = 2;
    l[1].offset = 2;
    expect_refused(chip, l, 2, GW_GPIO_EINVAL, "line 2 is listed twice");
    l[0].direction = GW_GPIO_DIR_OUTPUT;
    l[0].edge = GW_GPIO_EDGE_BOTH;
    expect_refused(chip, l, 1, GW_GPIO_EINVAL,
                   "gpiochip0 [fake-A] line 2 \"fake-A-2\": edge events "
                   "apply to inputs only");
    l[0].edge = GW_GPIO_EDGE_NONE;
    l[0].safe_value = 2;
    expect_refused(chip, l, 1, GW_GPIO_EINVAL, "safe value must be 0 or 1");
    l[0].safe_value = 0;
    l[0].debounce_us = 10;
    expect_refused(chip, l, 1, GW_GPIO_EINVAL,
                   "debounce applies to inputs only");
    l[0].direction = GW_GPIO_DIR_INPUT;
    expect_refused(chip, l, 1, GW_GPIO_EINVAL, "set edge to both");
    l[0].debounce_us = 0;
    l[0].bias = (gw_gpio_line_bias_t)9;
    expect_refused(chip, l, 1, GW_GPIO_EINVAL, "bias must be");
    l[0].bias = GW_GPIO_BIAS_AS_IS;
    l[0].direction = (gw_gpio_direction_t)7;
    expect_refused(chip, l, 1, GW_GPIO_EINVAL, "direction must be");
    assert_int_equal(fake.releases, 0);
    gw_gpio_chip_close(chip);
}

static void test_busy_names_holder(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_line_config_t l[2];

    (void)state;
    memset(l, 0, sizeof l);
    l[0].offset = 1;
    l[1].offset = 4;
    l[1].direction = GW_GPIO_DIR_OUTPUT;
    l[1].active_low = true;
    l[1].bias = GW_GPIO_BIAS_PULL_UP;
    fake.busy[4] = true;
    expect_refused(chip, l, 2, GW_GPIO_EBUSY,
                   "gpiochip0 [fake-A] line 4 \"fake-A-4\": cannot request "
                   "as output (active-low, pull-up, safe value 0): Device "
                   "or resource busy (used by \"other\")");
    /* v2 asks for all lines at once; the message still finds the line. */
    fake.whole_request_fails = true;
    expect_refused(chip, l, 2, GW_GPIO_EBUSY, "line 4 \"fake-A-4\"");
    expect_refused(chip, l, 2, GW_GPIO_EBUSY, "(used by \"other\")");
    gw_gpio_chip_close(chip);
}

/* Outputs on 0 (safe 1) and 1 (safe 0), an edge input on 2 with 10 ms
 * debounce, a plain input on 3. */
static gw_gpio_request_t *request_mix(gw_gpio_chip_t *chip)
{
    gw_gpio_line_config_t l[4];
    gw_gpio_request_config_t cfg = { NULL, l, 4 };
    gw_gpio_request_t *req = NULL;
    gw_gpio_error_t err;

    memset(l, 0, sizeof l);
    l[0].offset = 0;
    l[0].direction = GW_GPIO_DIR_OUTPUT;
    l[0].safe_value = 1;
    l[1].offset = 1;
    l[1].direction = GW_GPIO_DIR_OUTPUT;
    l[2].offset = 2;
    l[2].edge = GW_GPIO_EDGE_BOTH;
    l[2].debounce_us = 10000;
    l[3].offset = 3;
    assert_int_equal(gw_gpio_chip_request_lines(chip, &cfg, &req, &err),
                     GW_GPIO_OK);
    assert_non_null(req);
    return req;
}

static void test_outputs_and_safe_values(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_request_t *req = request_mix(chip);
    gw_gpio_error_t err;
    int v = -1;

    (void)state;
    assert_string_equal(fake.consumer[0], "drgatewayd");
    /* Outputs start at their safe values. */
    assert_int_equal(fake.value[0], 1);
    assert_int_equal(fake.value[1], 0);
    assert_int_equal(gw_gpio_request_set_value(req, 0, 0, &err), GW_GPIO_OK);
    assert_int_equal(gw_gpio_request_set_value(req, 1, 5, &err), GW_GPIO_OK);
    assert_int_equal(fake.value[1], 1); /* non-zero is 1 */
    assert_int_equal(gw_gpio_request_get_value(req, 1, &v, &err), GW_GPIO_OK);
    assert_int_equal(v, 1);
    assert_int_equal(gw_gpio_set_safe(req, &err), GW_GPIO_OK);
    assert_int_equal(fake.value[0], 1);
    assert_int_equal(fake.value[1], 0);
    /* Release writes the safe values again, then lets go. */
    assert_int_equal(gw_gpio_request_set_value(req, 0, 0, &err), GW_GPIO_OK);
    assert_int_equal(gw_gpio_request_set_value(req, 1, 1, &err), GW_GPIO_OK);
    fake.nlog = 0;
    assert_int_equal(gw_gpio_request_release(req, &err), GW_GPIO_OK);
    assert_int_equal(fake.nlog, 2);
    assert_int_equal(fake.log[0].offset, 0);
    assert_int_equal(fake.log[0].value, 1);
    assert_int_equal(fake.log[1].offset, 1);
    assert_int_equal(fake.log[1].value, 0);
    assert_int_equal(fake.releases, 1);
    assert_false(fake.requested[0]);
    assert_int_equal(gw_gpio_request_release(NULL, &err), GW_GPIO_OK);
    assert_int_equal(gw_gpio_set_safe(NULL, &err), GW_GPIO_OK);
    gw_gpio_chip_close(chip);
}

static void test_wrong_line_or_direction(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_request_t *req = request_mix(chip);
    gw_gpio_error_t err;
    int v;

    (void)state;
    assert_int_equal(gw_gpio_request_set_value(req, 3, 1, &err),
                     GW_GPIO_EDIRECTION);
    assert_string_equal(err.msg, "gpiochip0 [fake-A] line 3 \"fake-A-3\": "
                                 "is requested as an input; only outputs "
                                 "can be set");
    assert_int_equal(gw_gpio_request_get_value(req, 6, &v, &err),
                     GW_GPIO_ENOLINE);
    assert_string_equal(err.msg, "gpiochip0 [fake-A] line 6: not part of "
                                 "this request (requested: 0 1 2 3)");
    assert_int_equal(gw_gpio_request_input_value(req, 0, 0, &v, NULL, &err),
                     GW_GPIO_EDIRECTION);
    fake.get_errno[3] = EIO;
    assert_int_equal(gw_gpio_request_get_value(req, 3, &v, &err), GW_GPIO_EIO);
    assert_contains(err.msg, "line 3 \"fake-A-3\": cannot read the value: "
                             "Input/output error");
    /* The chip's close releases what is left, safe values first. */
    gw_gpio_request_set_value(req, 0, 0, NULL);
    gw_gpio_chip_close(chip);
    assert_int_equal(fake.value[0], 1);
    assert_int_equal(fake.releases, 1);
    assert_int_equal(fake.open_chips, 0);
}

static void test_safe_continues_after_failure(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_request_t *req = request_mix(chip);
    gw_gpio_error_t err;

    (void)state;
    gw_gpio_request_set_value(req, 0, 0, NULL);
    gw_gpio_request_set_value(req, 1, 1, NULL);
    fake.set_errno[0] = EIO;
    assert_int_equal(gw_gpio_request_release(req, &err), GW_GPIO_EIO);
    assert_contains(err.msg, "line 0 \"fake-A-0\": cannot write the safe "
                             "value: Input/output error");
    /* Line 1 was still made safe, and the request is gone anyway. */
    assert_int_equal(fake.value[1], 0);
    assert_int_equal(fake.releases, 1);
    gw_gpio_chip_close(chip);
}

static void test_events_and_debounce(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_request_t *req;
    gw_gpio_event_t ev[8];
    gw_gpio_error_t err;
    int fds[4], v = -1;
    bool changed = true;
    size_t n = 99;
    uint64_t t0;

    (void)state;
    req = request_mix(chip);
    t0 = gw_gpio_now_ns();
    assert_int_equal(gw_gpio_request_fds(req, fds, 4), 1);
    assert_int_equal(gw_gpio_request_fds(req, NULL, 0), 1);
    assert_int_equal(gw_gpio_request_read_events(req, ev, 8, &n, &err),
                     GW_GPIO_OK);
    assert_int_equal(n, 0);
    assert_true(gw_gpio_request_next_deadline(req) == UINT64_MAX);

    /* A 2 ms glitch, then a real rise at +20 ms. */
    fake_edge(2, 1, t0 + 10 * MS);
    fake_edge(2, 0, t0 + 12 * MS);
    fake_edge(2, 1, t0 + 20 * MS);
    assert_int_equal(gw_gpio_request_read_events(req, ev, 2, &n, &err),
                     GW_GPIO_OK);
    assert_int_equal(n, 2); /* cap respected, the rest stays */
    assert_int_equal(ev[0].offset, 2);
    assert_int_equal(ev[0].type, GW_GPIO_EVENT_RISING);
    assert_int_equal(ev[1].type, GW_GPIO_EVENT_FALLING);
    assert_true(ev[0].timestamp_ns == t0 + 10 * MS);
    assert_int_equal(ev[0].line_seqno, 1);
    assert_int_equal(ev[1].line_seqno, 2);
    assert_int_equal(gw_gpio_request_read_events(req, ev, 8, &n, &err),
                     GW_GPIO_OK);
    assert_int_equal(n, 1);
    assert_int_equal(ev[0].line_seqno, 3);
    assert_true(gw_gpio_request_next_deadline(req) == t0 + 30 * MS);
    assert_int_equal(
        gw_gpio_request_input_value(req, 2, t0 + 25 * MS, &v, &changed, &err),
        GW_GPIO_OK);
    assert_int_equal(v, 0);
    assert_false(changed);
    assert_int_equal(
        gw_gpio_request_input_value(req, 2, t0 + 30 * MS, &v, &changed, &err),
        GW_GPIO_OK);
    assert_int_equal(v, 1);
    assert_true(changed);
    /* A plain input reads the line itself. */
    fake.value[3] = 1;
    assert_int_equal(gw_gpio_request_input_value(req, 3, 0, &v, NULL, &err),
                     GW_GPIO_OK);
    assert_int_equal(v, 1);
    gw_gpio_request_release(req, NULL);
    gw_gpio_chip_close(chip);
}

static void test_sync_inputs_catches_lost_edge(void **state)
{
    gw_gpio_chip_t *chip = open_a();
    gw_gpio_request_t *req = request_mix(chip);
    gw_gpio_error_t err;
    uint64_t t = gw_gpio_now_ns() + 1000 * MS;
    int v = -1;

    (void)state;
    /* The line rose but its event never came (queue overflow). */
    fake.value[2] = 1;
    assert_int_equal(gw_gpio_request_sync_inputs(req, t, &err), GW_GPIO_OK);
    assert_true(gw_gpio_request_next_deadline(req) == t + 10 * MS);
    assert_int_equal(
        gw_gpio_request_input_value(req, 2, t + 10 * MS, &v, NULL, &err),
        GW_GPIO_OK);
    assert_int_equal(v, 1);
    /* Syncing an unchanged level does not postpone anything. */
    assert_int_equal(gw_gpio_request_sync_inputs(req, t + 20 * MS, &err),
                     GW_GPIO_OK);
    assert_true(gw_gpio_request_next_deadline(req) == UINT64_MAX);
    gw_gpio_chip_close(chip);
}

static void test_two_requests_and_chips(void **state)
{
    gw_gpio_chip_t *a = open_a(), *b = NULL;
    gw_gpio_line_config_t l = { 0 };
    gw_gpio_request_config_t cfg = { "second", &l, 1 };
    gw_gpio_request_t *r1 = request_mix(a), *r2 = NULL, *r3 = NULL;
    gw_gpio_error_t err;

    (void)state;
    /* The same line twice, even from the same process, is busy. */
    l.offset = 2;
    assert_int_equal(gw_gpio_chip_request_lines(a, &cfg, &r2, &err),
                     GW_GPIO_EBUSY);
    assert_contains(err.msg, "(used by \"drgatewayd\")");
    l.offset = 5;
    assert_int_equal(gw_gpio_chip_request_lines(a, &cfg, &r2, &err),
                     GW_GPIO_OK);
    assert_int_equal(gw_gpio_chip_open("/dev/gpiochip1", &b, &err), GW_GPIO_OK);
    assert_string_equal(gw_gpio_chip_label(b), "fake-B");
    l.offset = 3;
    l.direction = GW_GPIO_DIR_OUTPUT;
    assert_int_equal(gw_gpio_chip_request_lines(b, &cfg, &r3, &err),
                     GW_GPIO_OK);
    l.offset = 4;
    assert_int_equal(gw_gpio_chip_request_lines(b, &cfg, &r3, &err),
                     GW_GPIO_ENOLINE);
    assert_contains(err.msg, "gpiochip1 [fake-B]: line offset 4 out of range");
    /* Releasing out of order keeps the chip's list consistent. */
    gw_gpio_request_release(r1, NULL);
    gw_gpio_chip_close(a);
    assert_int_equal(fake.releases, 2);
    gw_gpio_chip_close(b);
    assert_int_equal(fake.releases, 3);
    assert_int_equal(fake.open_chips, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_strerror, setup),
        cmocka_unit_test_setup(test_open_forms, setup),
        cmocka_unit_test_setup(test_open_errors, setup),
        cmocka_unit_test_setup(test_find_line, setup),
        cmocka_unit_test_setup(test_request_validation, setup),
        cmocka_unit_test_setup(test_busy_names_holder, setup),
        cmocka_unit_test_setup(test_outputs_and_safe_values, setup),
        cmocka_unit_test_setup(test_wrong_line_or_direction, setup),
        cmocka_unit_test_setup(test_safe_continues_after_failure, setup),
        cmocka_unit_test_setup(test_events_and_debounce, setup),
        cmocka_unit_test_setup(test_sync_inputs_catches_lost_edge, setup),
        cmocka_unit_test_setup(test_two_requests_and_chips, setup),
    };
    return cmocka_run_group_tests_name("gpio_common", tests, NULL, NULL);
}
