/* SPDX-License-Identifier: MIT */
/*
 * open62541's public-key operations off the loop (gateway/opcua/ua_crypto.c):
 * a wrapped policy's sign, verify, encrypt and decrypt run on the worker
 * thread, not the caller's, while the caller waits through the side's
 * wait function (the loop's wait aside); their results and output come
 * back whole; a wait that is refused still ends with the result (the
 * caller blocks for it); None is left alone; slots run out with a clear
 * error and nothing half-wrapped, and come back when freed. The policies
 * are stand-ins that record the thread they ran on (open62541's own run
 * in tests/opcua, through the daemon). Built only with open62541 (the
 * Makefile's OPCUA_TEST_SRC).
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <cmocka.h>

#include <poll.h>
#include <pthread.h>
#include <string.h>
#include <time.h>

#include "opcua/ua_crypto.h"

static pthread_t ran_on;
static unsigned ran;
/* An operation runs only once the caller waits for it: so the test knows
 * that each one was waited for (not done before the caller looked). */
static pthread_mutex_t mu = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t cv = PTHREAD_COND_INITIALIZER;
static bool released;

static void note(void)
{
    struct timespec until;
    (void)clock_gettime(CLOCK_REALTIME, &until);
    until.tv_sec += 5; /* run in the caller's thread (a bug): no wait comes; fail, not hang */
    (void)pthread_mutex_lock(&mu);
    while (!released)
        if (pthread_cond_timedwait(&cv, &mu, &until) != 0)
            break;
    released = false;
    (void)pthread_mutex_unlock(&mu);
    ran_on = pthread_self();
    ran++;
}

static void release(void)
{
    (void)pthread_mutex_lock(&mu);
    released = true;
    (void)pthread_cond_broadcast(&cv);
    (void)pthread_mutex_unlock(&mu);
}

static UA_StatusCode fake_sign(void *cc, const UA_ByteString *m, UA_ByteString *s)
{
    note();
    if (cc != (void *)&ran || s->length < m->length)
        return UA_STATUSCODE_BADINTERNALERROR;
    for (size_t i = 0; i < m->length; i++)
        s->data[i] = (UA_Byte)(m->data[i] ^ 0x5A);
    return UA_STATUSCODE_GOOD;
}

static UA_StatusCode fake_verify(void *cc, const UA_ByteString *m, const UA_ByteString *s)
{
    (void)cc;
    note();
    return m->length == s->length ? UA_STATUSCODE_GOOD : UA_STATUSCODE_BADSECURITYCHECKSFAILED;
}

static UA_StatusCode fake_encrypt(void *cc, UA_ByteString *d)
{
    (void)cc;
    note();
    for (size_t i = 0; i < d->length; i++)
        d->data[i]++;
    return UA_STATUSCODE_GOOD;
}

static UA_StatusCode fake_decrypt(void *cc, UA_ByteString *d)
{
    (void)cc;
    note();
    d->length = 1; /* in place, shorter: as RSA's padding comes off */
    return UA_STATUSCODE_BADDECODINGERROR;
}

static void fake_policy(UA_SecurityPolicy *p, const char *uri)
{
    memset(p, 0, sizeof *p);
    p->policyUri = UA_STRING((char *)uri);
    UA_SecurityPolicyCryptoModule *m = &p->asymmetricModule.cryptoModule;
    m->signatureAlgorithm.sign = fake_sign;
    m->signatureAlgorithm.verify = fake_verify;
    m->encryptionAlgorithm.encrypt = fake_encrypt;
    m->encryptionAlgorithm.decrypt = fake_decrypt;
}

#define BASIC "http://opcfoundation.org/UA/SecurityPolicy#Basic256Sha256"
#define NONE UA_POLICY_NONE_URI

static unsigned waits;
static bool refuse_waits;

/* The side's wait: here the fd until readable (the daemon turns its loop). */
static bool wait_fd(void *user, int fd)
{
    struct pollfd p = {fd, POLLIN, 0};
    assert_ptr_equal(user, &waits);
    waits++;
    release();
    if (refuse_waits)
        return false;
    return poll(&p, 1, 5000) == 1;
}

static ua_crypto_t *crypto(void)
{
    char err[128];
    ua_crypto_t *k = ua_crypto_new(wait_fd, &waits, err, sizeof err);
    assert_non_null(k);
    waits = ran = 0;
    refuse_waits = released = false;
    return k;
}

/* A worker with one Basic256Sha256 stand-in wrapped into *p. */
static ua_crypto_t *wrapped(UA_SecurityPolicy *p)
{
    char err[128];
    ua_crypto_t *k = crypto();
    fake_policy(p, BASIC);
    assert_true(ua_crypto_wrap(k, p, 1, err, sizeof err));
    return k;
}

static void test_operations_run_on_the_worker(void **state)
{
    (void)state;
    UA_SecurityPolicy p;
    ua_crypto_t *k = wrapped(&p);
    const UA_SecurityPolicyCryptoModule *m = &p.asymmetricModule.cryptoModule;
    assert_ptr_not_equal(m->signatureAlgorithm.sign, fake_sign);

    UA_Byte msg[4] = {1, 2, 3, 4}, sig[4] = {0};
    UA_ByteString bm = {sizeof msg, msg}, bs = {sizeof sig, sig};
    assert_int_equal(m->signatureAlgorithm.sign(&ran, &bm, &bs), UA_STATUSCODE_GOOD);
    assert_false(pthread_equal(ran_on, pthread_self()));
    assert_int_equal(sig[0], 1 ^ 0x5A);
    assert_int_equal(sig[3], 4 ^ 0x5A);
    bs.length = 3;
    assert_int_equal(m->signatureAlgorithm.verify(&ran, &bm, &bs),
                     UA_STATUSCODE_BADSECURITYCHECKSFAILED);
    assert_int_equal(m->encryptionAlgorithm.encrypt(&ran, &bm), UA_STATUSCODE_GOOD);
    assert_int_equal(msg[0], 2);
    assert_int_equal(m->encryptionAlgorithm.decrypt(&ran, &bm), UA_STATUSCODE_BADDECODINGERROR);
    assert_int_equal(bm.length, 1);
    assert_false(pthread_equal(ran_on, pthread_self()));
    assert_int_equal(ran, 4);
    assert_int_equal(waits, 4); /* each one waited for aside, once */
    assert_int_equal(ua_crypto_jobs(k), 4);
    ua_crypto_free(k);
}

static void test_refused_wait_still_ends_with_the_result(void **state)
{
    (void)state;
    UA_SecurityPolicy p;
    ua_crypto_t *k = wrapped(&p);
    refuse_waits = true; /* the daemon stops: no wait aside */
    UA_Byte d[2] = {7, 8};
    UA_ByteString b = {sizeof d, d};
    assert_int_equal(p.asymmetricModule.cryptoModule.encryptionAlgorithm.encrypt(&ran, &b),
                     UA_STATUSCODE_GOOD);
    assert_int_equal(d[0], 8);
    assert_int_equal(waits, 1);
    assert_false(pthread_equal(ran_on, pthread_self()));
    ua_crypto_free(k);
}

static void test_none_is_left_alone(void **state)
{
    (void)state;
    ua_crypto_t *k = crypto();
    UA_SecurityPolicy p[2];
    char err[128];
    fake_policy(&p[0], NONE);
    fake_policy(&p[1], BASIC);
    assert_true(ua_crypto_wrap(k, p, 2, err, sizeof err));
    assert_ptr_equal(p[0].asymmetricModule.cryptoModule.signatureAlgorithm.sign, fake_sign);
    assert_ptr_not_equal(p[1].asymmetricModule.cryptoModule.signatureAlgorithm.sign, fake_sign);
    /* wrapped once: a second wrap takes no slot */
    assert_true(ua_crypto_wrap(k, p, 2, err, sizeof err));
    ua_crypto_free(k);
}

static void test_slots_run_out_and_come_back(void **state)
{
    (void)state;
    ua_crypto_t *k = crypto();
    UA_SecurityPolicy p[UA_CRYPTO_SLOTS + 1];
    char err[128] = "";
    for (unsigned i = 0; i <= UA_CRYPTO_SLOTS; i++)
        fake_policy(&p[i], BASIC);
    assert_false(ua_crypto_wrap(k, p, UA_CRYPTO_SLOTS + 1, err, sizeof err));
    assert_non_null(strstr(err, "9 security policies, room for 8 more"));
    for (unsigned i = 0; i <= UA_CRYPTO_SLOTS; i++) /* nothing half-wrapped */
        assert_ptr_equal(p[i].asymmetricModule.cryptoModule.signatureAlgorithm.sign, fake_sign);
    assert_true(ua_crypto_wrap(k, p, UA_CRYPTO_SLOTS, err, sizeof err));
    ua_crypto_t *k2 = ua_crypto_new(wait_fd, &waits, err, sizeof err);
    assert_non_null(k2);
    assert_false(ua_crypto_wrap(k2, &p[UA_CRYPTO_SLOTS], 1, err, sizeof err));
    ua_crypto_free(k); /* its server gone: its slots free */
    UA_Byte z[1] = {0};
    UA_ByteString bz = {1, z}; /* a policy that outlived its worker: refused, not run */
    assert_int_equal(p[0].asymmetricModule.cryptoModule.encryptionAlgorithm.encrypt(&ran, &bz),
                     UA_STATUSCODE_BADINTERNALERROR);
    assert_int_equal(z[0], 0);
    assert_true(ua_crypto_wrap(k2, &p[UA_CRYPTO_SLOTS], 1, err, sizeof err));
    UA_Byte d[1] = {0};
    UA_ByteString b = {1, d};
    ran = 0;
    assert_int_equal(
        p[UA_CRYPTO_SLOTS].asymmetricModule.cryptoModule.encryptionAlgorithm.encrypt(&ran, &b),
        UA_STATUSCODE_GOOD);
    assert_int_equal(d[0], 1);
    assert_int_equal(ua_crypto_jobs(k2), 1);
    ua_crypto_free(k2);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_operations_run_on_the_worker),
        cmocka_unit_test(test_refused_wait_still_ends_with_the_result),
        cmocka_unit_test(test_none_is_left_alone),
        cmocka_unit_test(test_slots_run_out_and_come_back),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
