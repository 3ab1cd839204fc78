/* SPDX-License-Identifier: MIT */
/*
 * Logins off the event loop (gateway/core/auth.c), as the console and the
 * OPC UA side use them: a check runs on the worker and its verdict is
 * cached (a good pair then costs no check, a refused one is refused
 * unchecked); refusals are counted per source, and from the 5th on the
 * source waits (1 s, 2 s, ...) with its new logins refused unchecked,
 * while another source and a cached good pair still pass; credentials
 * that cannot be read are refused and counted; a full queue answers BUSY;
 * the refusal's log line names the source as the side says (an address,
 * or per user). crypt is a stand-in that the test can hold, so that
 * "checked" is counted exactly (libcrypt's own: tests/gateway, tests/opcua).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <poll.h>
#include <pthread.h>
#include <stdio.h>
#include <string.h>
#include <cmocka.h>

#include "core/auth.h"
#include "core/log.h"

#define HASH "$6$salt$good-hash"

static pthread_mutex_t hold_mu = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t hold_cv = PTHREAD_COND_INITIALIZER;
static bool held;

/* "good" gives the hash back; anything else does not. Waits while held. */
static char *fake_crypt(const char *phrase, const char *setting, struct crypt_data *data)
{
    (void)data;
    (void)pthread_mutex_lock(&hold_mu);
    while (held)
        (void)pthread_cond_wait(&hold_cv, &hold_mu);
    (void)pthread_mutex_unlock(&hold_mu);
    static char out[64]; /* one worker: one caller at a time */
    snprintf(out, sizeof out, "%s", strcmp(phrase, "good") == 0 ? setting : "$6$salt$other-hash");
    return out;
}

static void hold(bool on)
{
    (void)pthread_mutex_lock(&hold_mu);
    held = on;
    (void)pthread_cond_broadcast(&hold_cv);
    (void)pthread_mutex_unlock(&hold_mu);
}

static gw_auth_t *make(const char *per)
{
    static gw_users_t users;
    char err[200];
    memset(&users, 0, sizeof users);
    users.count = 1;
    snprintf(users.user[0].user, sizeof users.user[0].user, "plant");
    snprintf(users.user[0].hash, sizeof users.user[0].hash, "%s", HASH);
    gw_auth_t *a = gw_auth_new(&users, fake_crypt, "opcua", per, err, sizeof err);
    assert_non_null(a);
    return a;
}

typedef struct {
    int calls;
    bool ok;
} verdict_t;

static void done(void *user, void *cookie, bool ok, uint64_t until)
{
    verdict_t *v = cookie;
    (void)user;
    (void)until;
    v->calls++;
    v->ok = ok;
}

/* A login to its verdict: 'O' good from the cache, 'R' refused at once,
 * 'B' busy, 'o' / 'r' good / refused after a check. */
static char login(gw_auth_t *a, const char *user, const char *pass, const char *from,
                  uint64_t now, uint64_t *until)
{
    verdict_t v = {0, false};
    uint64_t u;
    switch (gw_auth_check(a, user, pass, from, &v, now, until != NULL ? until : &u)) {
    case GW_AUTH_OK: return 'O';
    case GW_AUTH_REFUSED: return 'R';
    case GW_AUTH_BUSY: return 'B';
    case GW_AUTH_PENDING: break;
    }
    while (v.calls == 0) {
        struct pollfd p = {gw_auth_fd(a), POLLIN, 0};
        assert_true(poll(&p, 1, 10000) == 1);
        gw_auth_collect(a, now, done, NULL);
    }
    assert_int_equal(v.calls, 1);
    return v.ok ? 'o' : 'r';
}

#define S 1000000ull /* a second in microseconds */

static void test_cache(void **state)
{
    (void)state;
    gw_auth_t *a = make("user");
    uint64_t now = 100 * S;
    assert_int_equal(login(a, "plant", "good", "plant", now, NULL), 'o');
    assert_int_equal(login(a, "plant", "good", "plant", now + S, NULL), 'O'); /* no check */
    assert_int_equal(login(a, "plant", "bad", "plant", now, NULL), 'r');
    assert_int_equal(login(a, "plant", "bad", "plant", now + S, NULL), 'R'); /* no check */
    assert_int_equal(login(a, "nobody", "good", "(unknown user)", now, NULL), 'r');
    gw_auth_stats_t st = gw_auth_stats(a);
    assert_int_equal(st.checks, 3);
    assert_int_equal(st.ok, 1);
    assert_int_equal(st.refused, 3);
    /* a good pair's verdict lasts GW_AUTH_OK_TTL_S, then it is checked again */
    assert_int_equal(login(a, "plant", "good", "plant", now + (GW_AUTH_OK_TTL_S + 1) * S, NULL),
                     'o');
    gw_auth_free(a);
}

static void test_back_off_per_source(void **state)
{
    (void)state;
    gw_auth_t *a = make("user");
    uint64_t now = 100 * S, until = 0;
    assert_int_equal(login(a, "plant", "good", "plant", now, NULL), 'o'); /* cached before */
    for (unsigned i = 0; i <= GW_AUTH_FREE_FAILS; i++) {
        char pass[16];
        snprintf(pass, sizeof pass, "guess%u", i);
        assert_int_equal(login(a, "plant", pass, "plant", now, &until), 'r');
    }
    /* the 5th refusal began a wait of 1 s: new passwords are not checked */
    uint64_t checks = gw_auth_stats(a).checks;
    assert_int_equal(login(a, "plant", "guess-new", "plant", now, &until), 'R');
    assert_true(until >= now + S);
    assert_int_equal(gw_auth_stats(a).checks, checks);
    /* the cached good pair passes all the same; so does another source */
    assert_int_equal(login(a, "plant", "good", "plant", now, NULL), 'O');
    assert_int_equal(login(a, "ops", "x", "(unknown user)", now, NULL), 'r');
    /* the wait over: checked again (and refused: the wait doubles) */
    assert_int_equal(login(a, "plant", "guess-later", "plant", until + 1, &until), 'r');
    assert_int_equal(gw_auth_stats(a).checks, checks + 2);
    gw_auth_free(a);
}

static void test_unreadable_and_busy(void **state)
{
    (void)state;
    gw_auth_t *a = make("address");
    uint64_t now = 100 * S;
    assert_int_equal(login(a, NULL, NULL, "10.0.0.1", now, NULL), 'R');
    assert_int_equal(gw_auth_stats(a).refused, 1);
    assert_int_equal(gw_auth_stats(a).checks, 0);
    hold(true);
    verdict_t v[GW_AUTH_QUEUE + 1];
    uint64_t until;
    for (unsigned i = 0; i < GW_AUTH_QUEUE; i++) {
        char from[16], pass[16];
        snprintf(from, sizeof from, "10.0.1.%u", i);
        snprintf(pass, sizeof pass, "p%u", i);
        v[i] = (verdict_t){0, false};
        assert_int_equal(gw_auth_check(a, "plant", pass, from, &v[i], now, &until),
                         GW_AUTH_PENDING);
    }
    assert_int_equal(gw_auth_check(a, "plant", "one-more", "10.0.2.1", &v[GW_AUTH_QUEUE], now,
                                   &until),
                     GW_AUTH_BUSY);
    gw_auth_cancel(a, &v[0]); /* its request went: still checked, not told */
    hold(false);
    unsigned told = 0;
    while (told < GW_AUTH_QUEUE - 1) {
        struct pollfd p = {gw_auth_fd(a), POLLIN, 0};
        assert_true(poll(&p, 1, 10000) == 1);
        gw_auth_collect(a, now, done, NULL);
        told = 0;
        for (unsigned i = 0; i < GW_AUTH_QUEUE; i++)
            told += (unsigned)v[i].calls;
    }
    assert_int_equal(v[0].calls, 0);
    assert_int_equal(gw_auth_stats(a).busy, 1);
    gw_auth_free(a);
}

typedef struct {
    char last[GW_LOG_TEXT];
} last_t;

static void last_line(void *user, const gw_log_event_t *e)
{
    last_t *l = user;
    snprintf(l->last, sizeof l->last, "%s", e->text);
}

static void test_log_line_names_the_source(void **state)
{
    (void)state;
    last_t l = {""};
    gw_auth_t *a = make("user");
    assert_int_equal(login(a, "plant", "bad", "plant", 100 * S, NULL), 'r');
    gw_log_ring_each(last_line, &l);
    assert_string_equal(l.last, "opcua: login refused for user \"plant\" (1 refused for this user)");
    gw_auth_free(a);
    a = make("address");
    assert_int_equal(login(a, "plant\n<0>x", "bad", "10.0.0.7", 100 * S, NULL), 'r');
    gw_log_ring_each(last_line, &l);
    /* the user name as the client sent it, escaped */
    assert_string_equal(l.last, "opcua: login refused for user \"plant\\x0a<0>x\" from 10.0.0.7 "
                                "(1 refused from this address)");
    gw_auth_free(a);
}

int main(void)
{
    gw_log_ring_keep(true);
    gw_log_set_level(GW_LOG_INFO); /* the refusals kept in the ring */
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_cache),
        cmocka_unit_test(test_back_off_per_source),
        cmocka_unit_test(test_unreadable_and_busy),
        cmocka_unit_test(test_log_line_names_the_source),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
