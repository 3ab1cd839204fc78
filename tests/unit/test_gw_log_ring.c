/* SPDX-License-Identifier: MIT */
/*
 * The log ring behind the console's /api/v1/log (gateway/core/log.c):
 * every line gw_log prints is kept with its time and level, the last
 * GW_LOG_RING (200) of them, the oldest first, the oldest dropped when it
 * wraps; lines the level filters out are not kept; a held-back count ends
 * the kept line as it ends the printed one; gw_http_log_json writes them
 * as a JSON array with the time in UTC and the text escaped; control
 * characters from outside (a user name with "\n<0>...") are escaped in
 * the line itself, which stays one line.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "core/log.h"
#include "http/metrics.h"

typedef struct {
    unsigned n;
    char first[GW_LOG_TEXT], last[GW_LOG_TEXT];
    gw_log_level_t last_level;
    uint64_t first_us, last_us;
    bool ordered;
} seen_t;

static void collect(void *user, const gw_log_event_t *e)
{
    seen_t *s = user;
    if (s->n == 0) {
        snprintf(s->first, sizeof s->first, "%s", e->text);
        s->first_us = e->time_us;
    } else if (e->time_us < s->last_us) {
        s->ordered = false;
    }
    snprintf(s->last, sizeof s->last, "%s", e->text);
    s->last_us = e->time_us;
    s->last_level = e->level;
    s->n++;
}

static seen_t ring(void)
{
    seen_t s = {0, "", "", GW_LOG_DEBUG, 0, 0, true};
    gw_log_ring_each(collect, &s);
    return s;
}

static void test_wrap_and_order(void **state)
{
    (void)state;
    uint64_t before = gw_log_ring_total();
    gw_log(GW_LOG_WARNING, "line %d", 0);
    seen_t s = ring();
    assert_int_equal(gw_log_ring_total(), before + 1);
    assert_string_equal(s.last, "line 0");
    assert_int_equal(s.last_level, GW_LOG_WARNING);
    /* wall clock, microseconds since 1970: within a minute of now */
    uint64_t now = (uint64_t)time(NULL) * 1000000u;
    assert_true(s.last_us + 60000000u > now && s.last_us < now + 60000000u);
    for (int i = 1; i < 450; i++)
        gw_log(GW_LOG_INFO, "line %d", i);
    s = ring();
    assert_int_equal(s.n, GW_LOG_RING);
    assert_string_equal(s.first, "line 250"); /* 450 lines: the last 200 */
    assert_string_equal(s.last, "line 449");
    assert_true(s.ordered);
    assert_int_equal(gw_log_ring_total(), before + 450);
}

/* Text from outside with a newline in it (a user name "x\n<0>forged"):
 * one line, the control characters escaped, in the journal's stream as
 * in the ring; no second line that the journal would read as an
 * emergency. */
static void test_control_characters_escaped(void **state)
{
    (void)state;
    char path[] = "/tmp/test_gw_log_ring.XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    (void)fflush(stderr);
    int saved = dup(2);
    assert_true(dup2(fd, 2) == 2);
    (void)setenv("JOURNAL_STREAM", "8:1", 1);
    gw_log(GW_LOG_INFO, "http: login refused for user %s", "x\n<0>forged emergency\r\x1b[2J\x7f");
    (void)fflush(stderr);
    (void)unsetenv("JOURNAL_STREAM");
    assert_true(dup2(saved, 2) == 2);
    close(saved);
    char out[512] = "";
    FILE *f = fdopen(fd, "r");
    assert_non_null(f);
    rewind(f);
    size_t n = fread(out, 1, sizeof out - 1, f);
    out[n] = '\0';
    (void)fclose(f);
    (void)remove(path);
    assert_string_equal(out, "<6>http: login refused for user x\\x0a<0>forged emergency\\x0d"
                             "\\x1b[2J\\x7f\n");
    seen_t s = ring();
    assert_string_equal(s.last, "http: login refused for user x\\x0a<0>forged emergency\\x0d"
                                "\\x1b[2J\\x7f");
    char esc[8];
    assert_int_equal(gw_log_escape(esc, 7, "ab\ncd", 5), 6); /* cut to fit */
    assert_string_equal(esc, "ab\\x0a");
}

static void test_level_filtered(void **state)
{
    (void)state;
    uint64_t before = gw_log_ring_total();
    gw_log(GW_LOG_DEBUG, "not printed, not kept");
    assert_int_equal(gw_log_ring_total(), before);
    gw_log_set_level(GW_LOG_DEBUG);
    gw_log(GW_LOG_DEBUG, "kept");
    gw_log_set_level(GW_LOG_INFO);
    assert_string_equal(ring().last, "kept");
}

static void test_long_line_cut(void **state)
{
    (void)state;
    char big[1000];
    memset(big, 'x', sizeof big - 1);
    big[sizeof big - 1] = '\0';
    gw_log(GW_LOG_ERROR, "%s", big);
    seen_t s = ring();
    assert_int_equal(strlen(s.last), GW_LOG_TEXT - 1);
}

static void test_json(void **state)
{
    (void)state;
    static char buf[GW_LOG_RING * (GW_LOG_TEXT * 6 + 80)];
    gw_json_t j;
    for (int i = 0; i < GW_LOG_RING; i++)
        gw_log(GW_LOG_INFO, "filler %d", i);
    gw_log(GW_LOG_WARNING, "robot \"r0\": link down\tnow");
    gw_json_init(&j, buf, sizeof buf);
    gw_http_log_json(&j, false);
    assert_false(j.full);
    assert_true(buf[0] == '[' && buf[j.len - 1] == ']');
    assert_non_null(strstr(buf, "\"level\":\"warning\",\"text\":\"robot \\\"r0\\\": link down\\\\x09now\"}]"));
    assert_non_null(strstr(buf, "[{\"time\":\"20"));
    assert_non_null(strstr(buf, "Z\",\"level\":\"info\",\"text\":\"filler 1\"}"));
    assert_null(strstr(buf, "\"filler 0\"")); /* 201 lines: the first left the ring */
    /* too small: marked full, never a cut array handed on as whole */
    char small[64];
    gw_json_init(&j, small, sizeof small);
    gw_http_log_json(&j, false);
    assert_true(j.full);
}

/* A held-back count ends the kept line as it ends the printed one. */
static void test_suppressed_count(void **state)
{
    (void)state;
    gw_log_limit_t lim;
    memset(&lim, 0, sizeof lim);
    lim.last_us = 1; /* a line was shown long ago: its window is over */
    lim.suppressed = 3;
    gw_log_limited(GW_LOG_INFO, &lim, "again");
    assert_string_equal(ring().last, "again [3 similar messages suppressed]");
}

/* Without a console nothing is kept: no page of the ring is touched. */
static void test_kept_only_with_a_console(void **state)
{
    (void)state;
    gw_log_ring_keep(false);
    uint64_t before = gw_log_ring_total();
    gw_log(GW_LOG_ERROR, "not kept");
    assert_int_equal(gw_log_ring_total(), before);
    gw_log_ring_keep(true);
    gw_log(GW_LOG_ERROR, "kept");
    assert_int_equal(gw_log_ring_total(), before + 1);
    assert_string_equal(ring().last, "kept");
}

/* A limiter's lines go to its ring: the write log's to the writes', with
 * its summary of the lines it held back; the events' ring is untouched. */
typedef struct {
    unsigned n;
    char last[GW_LOG_TEXT];
} writes_t;

static void collect_write(void *user, const gw_log_event_t *e)
{
    writes_t *w = user;
    w->n++;
    snprintf(w->last, sizeof w->last, "%s", e->text);
}

static void test_writes_ring_apart(void **state)
{
    (void)state;
    gw_log(GW_LOG_INFO, "an event");
    uint64_t events = gw_log_ring_total(), writes = gw_log_writes_total();
    gw_log_limit_t lim;
    memset(&lim, 0, sizeof lim);
    lim.ring = GW_LOG_WRITES;
    for (int i = 0; i < GW_LOG_RING + 50; i++) {
        lim.last_us = 0; /* every one shown */
        gw_log_limited(GW_LOG_INFO, &lim, "robot r0: write by modbus 10.0.0.7:%d: int_in[0]", i);
    }
    assert_int_equal(gw_log_ring_total(), events); /* no event pushed out */
    assert_string_equal(ring().last, "an event");
    assert_int_equal(gw_log_writes_total(), writes + GW_LOG_RING + 50);
    writes_t w = {0, ""};
    gw_log_writes_each(collect_write, &w);
    assert_int_equal(w.n, GW_LOG_RING);
    assert_string_equal(w.last, "robot r0: write by modbus 10.0.0.7:249: int_in[0]");
    static char buf[GW_LOG_RING * (GW_LOG_TEXT * 6 + 80)];
    gw_json_t j;
    gw_json_init(&j, buf, sizeof buf);
    gw_http_log_json(&j, true);
    assert_non_null(strstr(buf, "10.0.0.7:249"));
    assert_null(strstr(buf, "an event"));
}

static int keep_ring(void **state)
{
    (void)state;
    gw_log_ring_keep(true);
    return 0;
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_wrap_and_order),
        cmocka_unit_test(test_control_characters_escaped),
        cmocka_unit_test(test_level_filtered),
        cmocka_unit_test(test_long_line_cut),
        cmocka_unit_test(test_writes_ring_apart),
        cmocka_unit_test(test_json),
        cmocka_unit_test(test_suppressed_count),
        cmocka_unit_test(test_kept_only_with_a_console),
    };
    return cmocka_run_group_tests(tests, keep_ring, NULL);
}
