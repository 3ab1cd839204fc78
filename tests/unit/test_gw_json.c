/* SPDX-License-Identifier: MIT */
/*
 * gw_json_quote (gateway/core/json.c), the JSON strings of everything the
 * console and MQTT say: valid UTF-8 passes as it is ("nopeé" stays
 * "nopeé", not "nope\u00c3\u00a9"), control characters and DEL are
 * escaped, quotes and backslashes too, and a byte that starts no valid
 * UTF-8 sequence (a stray continuation byte, an overlong form, a
 * surrogate, a sequence cut short, a code point above U+10FFFF) becomes
 * U+FFFD, so the text is always valid UTF-8.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "core/json.h"

static const char *quote(const char *s, size_t n)
{
    static char buf[256];
    gw_json_t j;
    gw_json_init(&j, buf, sizeof buf);
    gw_json_quote(&j, s, n);
    assert_false(j.full);
    return buf;
}

#define Q(lit) quote(lit, sizeof lit - 1)

static void test_utf8_passes(void **state)
{
    (void)state;
    assert_string_equal(Q("nope\xc3\xa9"), "\"nope\xc3\xa9\"");
    assert_string_equal(Q("\xe2\x82\xac 5"), "\"\xe2\x82\xac 5\"");         /* euro sign */
    assert_string_equal(Q("\xf0\x9f\xa4\x96"), "\"\xf0\x9f\xa4\x96\"");     /* U+1F916 */
    assert_string_equal(Q("\xf4\x8f\xbf\xbf"), "\"\xf4\x8f\xbf\xbf\"");     /* U+10FFFF */
    assert_string_equal(Q("\xed\x9f\xbf"), "\"\xed\x9f\xbf\"");             /* U+D7FF */
    assert_string_equal(Q("plain"), "\"plain\"");
}

static void test_escaped(void **state)
{
    (void)state;
    assert_string_equal(Q("a\"b\\c"), "\"a\\\"b\\\\c\"");
    assert_string_equal(Q("l1\nl2\r\x01\x7f"), "\"l1\\u000al2\\u000d\\u0001\\u007f\"");
    assert_string_equal(Q("nul\0x"), "\"nul\\u0000x\"");
}

static void test_invalid_replaced(void **state)
{
    (void)state;
#define FFFD "\xef\xbf\xbd"
    assert_string_equal(Q("a\x80z"), "\"a" FFFD "z\"");                   /* stray continuation */
    assert_string_equal(Q("\xc3"), "\"" FFFD "\"");                        /* cut at the end */
    assert_string_equal(Q("\xc3(x"), "\"" FFFD "(x\"");                    /* cut in the middle */
    assert_string_equal(Q("\xc0\xaf"), "\"" FFFD FFFD "\"");               /* overlong '/' */
    assert_string_equal(Q("\xe0\x80\xaf"), "\"" FFFD FFFD FFFD "\"");      /* overlong */
    assert_string_equal(Q("\xed\xa0\x80"), "\"" FFFD FFFD FFFD "\"");      /* surrogate */
    assert_string_equal(Q("\xf4\x90\x80\x80"), "\"" FFFD FFFD FFFD FFFD "\""); /* > U+10FFFF */
    assert_string_equal(Q("\xff\xfe"), "\"" FFFD FFFD "\"");
    assert_string_equal(Q("\xe2\x82"), "\"" FFFD FFFD "\"");
}

static void test_full(void **state)
{
    char buf[8];
    gw_json_t j;
    (void)state;
    gw_json_init(&j, buf, sizeof buf);
    gw_json_quote(&j, "\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9", 8);
    assert_true(j.full); /* marked, never cut inside a sequence and used */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_utf8_passes),
        cmocka_unit_test(test_escaped),
        cmocka_unit_test(test_invalid_replaced),
        cmocka_unit_test(test_full),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
