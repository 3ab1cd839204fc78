/* SPDX-License-Identifier: MIT */
/*
 * The console's password file parser (gateway/core/passwd.c): `user:HASH`
 * lines with crypt(3) hashes as `openssl passwd -6` and `mkpasswd` write
 * them, comments and blank lines skipped, CRLF files read; a plain
 * password, a DES hash, a missing ':' or user, a user twice, bytes that
 * are not text, too many users, and a file without a user are refused
 * with the line. Checking a password against a hash is libcrypt's
 * (crypt_r), tested end to end (tests/gateway/test_http.py).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "core/passwd.h"

#define SHA512 "$6$Frj6jrGJ.WTM25BQ$xYq8dr6acIEgxqKA2FJ5WEyvxXQqAtvPLDu0BPUlINpsN6Opvwzct4/om7M6E5r1CXsXGPM5hz.of7v5XRkiY."
#define YESCRYPT "$y$j9T$Zu7hVq4yGcsyZ0EQ7oP5H.$G1BA/mRWnT0hl8OkBsBqTo/PHfWrdEZ3Y7dUBVhd2n6"

static gw_users_t U;

static bool parse(const char *text, unsigned *line, char *why)
{
    return gw_passwd_parse(text, strlen(text), &U, line, why, 200);
}

static void test_good(void **state)
{
    unsigned line;
    char why[200];
    (void)state;
    assert_true(parse("# users of the console\n\nadmin:" SHA512 "\r\nops:" YESCRYPT, &line, why));
    assert_int_equal(U.count, 2);
    assert_string_equal(U.user[0].user, "admin");
    assert_string_equal(U.user[0].hash, SHA512); /* the CR is not part of it */
    assert_string_equal(U.user[1].user, "ops");
    assert_string_equal(U.user[1].hash, YESCRYPT); /* no newline at the end */
    assert_ptr_equal(gw_passwd_find(&U, "ops"), &U.user[1]);
    assert_null(gw_passwd_find(&U, "op"));
    assert_null(gw_passwd_find(&U, "root"));
}

static void expect_refused(const char *text, unsigned want_line, const char *want)
{
    unsigned line = 99;
    char why[200] = "";
    assert_false(gw_passwd_parse(text, strlen(text), &U, &line, why, sizeof why));
    assert_int_equal(line, want_line);
    if (strstr(why, want) == NULL)
        fail_msg("'%s' does not say '%s'", why, want);
}

static void test_refused(void **state)
{
    (void)state;
    expect_refused("admin:secret\n", 1, "not a crypt(3) hash");
    expect_refused("admin:abJnggxhB/yWI\n", 1, "not a crypt(3) hash"); /* DES */
    expect_refused("# c\nadmin " SHA512 "\n", 2, "no ':'");
    expect_refused(":" SHA512 "\n", 1, "no user name");
    expect_refused("admin:\n", 1, "no hash");
    expect_refused("admin:$6$\n", 1, "not a crypt(3) hash");
    expect_refused("ad min:" SHA512 "\n", 1, "blank or control character");
    expect_refused("a:" SHA512 "\nb:" SHA512 "\na:" SHA512 "\n", 3, "user a listed twice");
    expect_refused("admin:$6$abcdefgh$xy z\n", 1, "invalid character in the hash");
    expect_refused("\n# nobody\n", 0, "no user in it");
    expect_refused("", 0, "no user in it");
    static const char nul[] = "a:" SHA512 "\nb\0c:x\n";
    unsigned line = 0;
    char why[200];
    assert_false(gw_passwd_parse(nul, sizeof nul - 1, &U, &line, why, sizeof why));
    assert_int_equal(line, 2);
    assert_non_null(strstr(why, "NUL"));
}

/* The hash policy: broken kinds and costs that would hold a login for
 * long are refused with what to use instead; the defaults of mkpasswd
 * and openssl pass, and so do costs up to the bounds. */
static void test_policy(void **state)
{
    unsigned line;
    char why[200];
    (void)state;
    expect_refused("admin:$1$uvQIcxeK$G9TGyFsvmD3mp.nhbWyis.\n", 1, "MD5 hash ($1$): broken");
    expect_refused("admin:$1$uvQIcxeK$G9TGyFsvmD3mp.nhbWyis.\n", 1, "mkpasswd -m yescrypt");
    expect_refused("admin:$3$$8846f7eaee8fb117ad06bdd830b7586c\n", 1, "not one the console accepts");
    expect_refused("admin:$md5$rounds=9$abcdefgh$x\n", 1, "not one the console accepts");
    expect_refused("admin:$6$rounds=999999999$abcdefgh$x5ue8x8ebAkvbD9dK\n", 1,
                   "more than 100000 rounds");
    expect_refused("admin:$5$rounds=100001$abcdefgh$x5ue8x8ebAkvbD9dK\n", 1, "at most rounds=100000");
    expect_refused("admin:$6$rounds=99999999999999999999999$ab$x5ue8x8ebAkvbD9dK\n", 1,
                   "more than 100000 rounds");
    expect_refused("admin:$2b$31$abcdefghijklmnopqrstuuvKFO6LV7gEhMK8RwhoBVR8VG5GulpU.\n", 1,
                   "bcrypt cost 31");
    expect_refused("admin:$2b$13$abcdefghijklmnopqrstuuvKFO6LV7gEhMK8RwhoBVR8VG5GulpU.\n", 1,
                   "at most 12");
    expect_refused("admin:$y$jDT$Zu7hVq4yGcsyZ0EQ7oP5H.$TOyP6LmcJhEZC6XK.1.E8Co1fhDMsHvkpkOpFupgtX9\n",
                   1, "N=2^16 and r=32 needs more than 64 MiB");
    expect_refused("admin:$y$j9T1$Zu7hVq4yGcsyZ0EQ7oP5H.$TOyP6LmcJhEZC6XK.1.E8Co1fhDMsHvkpkOpFupgtX9\n",
                   1, "beyond N and r");
    expect_refused("a:" SHA512 "\nb:$1$uvQIcxeK$G9TGyFsvmD3mp.nhbWyis.\n", 2, "MD5");
    /* up to the bounds */
    assert_true(parse("a:$6$rounds=100000$abcdefgh$x5ue8x8ebAkvbD9dK/v62FosX0uTCy8ci8OPN6cy1vP6L\n"
                      "b:$2b$12$abcdefghijklmnopqrstuuvKFO6LV7gEhMK8RwhoBVR8VG5GulpU.\n"
                      "c:$y$jBT$Zu7hVq4yGcsyZ0EQ7oP5H.$l2Ccp8S1WE/Pc8ly7ADanHHzhGBBq1Ns62YeF7lY9y5\n"
                      "d:$5$abcdefgh$x5ue8x8ebAkvbD9dK/v62FosX0uTCy8ci8OPN6cy1vP6L\n",
                      &line, why));
    assert_int_equal(U.count, 4);
}

static void test_limits(void **state)
{
    static char text[GW_USERS_MAX * 200 + 400];
    size_t len = 0;
    (void)state;
    for (unsigned i = 0; i < GW_USERS_MAX; i++)
        len += (size_t)snprintf(text + len, sizeof text - len, "u%u:%s\n", i, SHA512);
    unsigned line;
    char why[200];
    assert_true(gw_passwd_parse(text, len, &U, &line, why, sizeof why));
    assert_int_equal(U.count, GW_USERS_MAX);
    snprintf(text + len, sizeof text - len, "one-more:%s\n", SHA512);
    expect_refused(text, GW_USERS_MAX + 1, "too many users");
    char user[GW_USER_MAX + 8];
    memset(user, 'u', GW_USER_MAX);
    user[GW_USER_MAX] = '\0';
    snprintf(text, sizeof text, "%s:%s\n", user, SHA512);
    expect_refused(text, 1, "user name too long");
}

static void test_load(void **state)
{
    char err[400];
    (void)state;
    assert_false(gw_passwd_load("/nonexistent/users", &U, err, sizeof err));
    assert_string_equal(err, "/nonexistent/users: No such file or directory");
    char path[] = "/tmp/test_gw_passwd.XXXXXX";
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs("admin:" SHA512 "\nroot:toor\n", f);
    (void)fclose(f);
    assert_false(gw_passwd_load(path, &U, err, sizeof err));
    char want[200];
    snprintf(want, sizeof want, "%s:2: not a crypt(3) hash", path);
    assert_memory_equal(err, want, strlen(want));
    (void)remove(path);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_good),
        cmocka_unit_test(test_refused),
        cmocka_unit_test(test_policy),
        cmocka_unit_test(test_limits),
        cmocka_unit_test(test_load),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
