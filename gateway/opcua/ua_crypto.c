/* SPDX-License-Identifier: MIT */
/*
 * open62541's public-key operations on a worker thread (ua_crypto.h).
 *
 * One operation at a time: the caller (open62541, in the loop's thread)
 * hands it over and waits until it is done, so the worker never has more
 * than one and open62541 runs on one thread at a time. The hand-over is a
 * mutex and a condition; the end is written to an eventfd that the loop
 * watches while it waits aside.
 */
#include "opcua/ua_crypto.h"

#include <pthread.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "common/ev.h"

typedef enum { OP_SIGN, OP_VERIFY, OP_ENCRYPT, OP_DECRYPT } op_t;

/* A wrapped policy's own functions, as they were. */
typedef struct {
    ua_crypto_t *k; /* NULL: free */
    UA_SecurityPolicySignatureAlgorithm sig;
    UA_SecurityPolicyEncryptionAlgorithm enc;
} slot_t;

/* One call: its arguments as open62541 gave them, and its result. */
typedef struct {
    op_t op;
    unsigned slot;
    void *cc;                   /* the channel's context */
    const UA_ByteString *msg;   /* sign, verify: what is signed */
    const UA_ByteString *sig;   /* verify: the signature */
    UA_ByteString *out;         /* sign: the signature; encrypt, decrypt: the data */
    UA_StatusCode result;
    /* the functions to call, copied from the slot in the loop's thread */
    UA_SecurityPolicySignatureAlgorithm fsig;
    UA_SecurityPolicyEncryptionAlgorithm fenc;
} job_t;

struct ua_crypto {
    ua_crypto_wait_fn wait;
    void *user;
    bool calling;               /* a call is being waited for (loop's thread) */
    unsigned long long jobs;
    ev_worker_t w;
    /* shared with the worker, under w.mu */
    job_t *job;                 /* handed over, not done yet */
    bool done;
};

/* Touched in the loop's thread only (wrap, free, the calls' start). */
static slot_t slots[UA_CRYPTO_SLOTS];

static UA_StatusCode run(const job_t *j)
{
    switch (j->op) {
    case OP_SIGN:
        return j->fsig.sign(j->cc, j->msg, j->out);
    case OP_VERIFY:
        return j->fsig.verify(j->cc, j->msg, j->sig);
    case OP_ENCRYPT:
        return j->fenc.encrypt(j->cc, j->out);
    case OP_DECRYPT:
        return j->fenc.decrypt(j->cc, j->out);
    }
    return UA_STATUSCODE_BADINTERNALERROR;
}

static void *worker(void *arg)
{
    ua_crypto_t *k = arg;
    (void)pthread_mutex_lock(&k->w.mu);
    for (;;) {
        while (!k->w.stop && k->job == NULL)
            (void)pthread_cond_wait(&k->w.cv, &k->w.mu);
        if (k->w.stop)
            break;
        job_t *j = k->job;
        (void)pthread_mutex_unlock(&k->w.mu);
        j->result = run(j);
        (void)pthread_mutex_lock(&k->w.mu);
        k->job = NULL;
        k->done = true;
        (void)pthread_cond_broadcast(&k->w.cv);
        /* under the lock: a caller that sees done finds the eventfd
         * written, and drains it (else its next wait would wake at once,
         * again and again, until that job was done) */
        ev_worker_done(&k->w);
    }
    (void)pthread_mutex_unlock(&k->w.mu);
    return NULL;
}

static bool job_done(ua_crypto_t *k)
{
    (void)pthread_mutex_lock(&k->w.mu);
    bool done = k->done;
    (void)pthread_mutex_unlock(&k->w.mu);
    return done;
}

/* The call on the worker, waited for aside; in the caller's thread if a
 * call is already waited for (not expected: the server is out of the loop
 * meanwhile). Refused if the slot's worker is gone (its policy outlived
 * it, which ua_crypto_free's caller must not let happen). */
static UA_StatusCode call(job_t *j)
{
    const slot_t *s = &slots[j->slot];
    ua_crypto_t *k = s->k;
    if (k == NULL)
        return UA_STATUSCODE_BADINTERNALERROR;
    j->fsig = s->sig;
    j->fenc = s->enc;
    if (k->calling)
        return run(j);
    k->calling = true;
    (void)pthread_mutex_lock(&k->w.mu);
    k->job = j;
    k->done = false;
    (void)pthread_cond_broadcast(&k->w.cv);
    (void)pthread_mutex_unlock(&k->w.mu);
    while (!job_done(k))
        if (!k->wait(k->user, k->w.efd)) {
            (void)pthread_mutex_lock(&k->w.mu);
            while (!k->done)
                (void)pthread_cond_wait(&k->w.cv, &k->w.mu);
            (void)pthread_mutex_unlock(&k->w.mu);
        }
    uint64_t n;
    (void)!read(k->w.efd, &n, sizeof n); /* nonblocking: drained */
    k->calling = false;
    k->jobs++;
    return j->result;
}

/* Each slot's own four functions: they know their slot by their name. */
#define UA_CRYPTO_SLOT(i)                                                                    \
    static UA_StatusCode sign_##i(void *cc, const UA_ByteString *m, UA_ByteString *s)        \
    {                                                                                        \
        job_t j = {.op = OP_SIGN, .slot = i, .cc = cc, .msg = m, .out = s};                  \
        return call(&j);                                                                     \
    }                                                                                        \
    static UA_StatusCode verify_##i(void *cc, const UA_ByteString *m, const UA_ByteString *s) \
    {                                                                                        \
        job_t j = {.op = OP_VERIFY, .slot = i, .cc = cc, .msg = m, .sig = s};                \
        return call(&j);                                                                     \
    }                                                                                        \
    static UA_StatusCode encrypt_##i(void *cc, UA_ByteString *d)                             \
    {                                                                                        \
        job_t j = {.op = OP_ENCRYPT, .slot = i, .cc = cc, .out = d};                         \
        return call(&j);                                                                     \
    }                                                                                        \
    static UA_StatusCode decrypt_##i(void *cc, UA_ByteString *d)                             \
    {                                                                                        \
        job_t j = {.op = OP_DECRYPT, .slot = i, .cc = cc, .out = d};                         \
        return call(&j);                                                                     \
    }
UA_CRYPTO_SLOT(0)
UA_CRYPTO_SLOT(1)
UA_CRYPTO_SLOT(2)
UA_CRYPTO_SLOT(3)
UA_CRYPTO_SLOT(4)
UA_CRYPTO_SLOT(5)
UA_CRYPTO_SLOT(6)
UA_CRYPTO_SLOT(7)

static const struct {
    UA_StatusCode (*sign)(void *, const UA_ByteString *, UA_ByteString *);
    UA_StatusCode (*verify)(void *, const UA_ByteString *, const UA_ByteString *);
    UA_StatusCode (*encrypt)(void *, UA_ByteString *);
    UA_StatusCode (*decrypt)(void *, UA_ByteString *);
} wrappers[] = {
#define UA_CRYPTO_FNS(i) {sign_##i, verify_##i, encrypt_##i, decrypt_##i}
    UA_CRYPTO_FNS(0), UA_CRYPTO_FNS(1), UA_CRYPTO_FNS(2), UA_CRYPTO_FNS(3),
    UA_CRYPTO_FNS(4), UA_CRYPTO_FNS(5), UA_CRYPTO_FNS(6), UA_CRYPTO_FNS(7),
};
typedef char ua_crypto_slots_named[sizeof wrappers / sizeof wrappers[0] == UA_CRYPTO_SLOTS ? 1 : -1];

ua_crypto_t *ua_crypto_new(ua_crypto_wait_fn wait, void *user, char *err, size_t errlen)
{
    ua_crypto_t *k = calloc(1, sizeof *k);
    if (k == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    k->wait = wait;
    k->user = user;
    int e = ev_worker_open(&k->w, "opcua-crypto", worker, k);
    if (e != 0) {
        snprintf(err, errlen, "cannot start the public-key worker: %s", strerror(e));
        free(k);
        return NULL;
    }
    return k;
}

static bool has_keys(const UA_SecurityPolicy *p)
{
    static const UA_String none = UA_STRING_STATIC(UA_POLICY_NONE_URI);
    const UA_SecurityPolicyCryptoModule *m = &p->asymmetricModule.cryptoModule;
    return !UA_String_equal(&p->policyUri, &none) && m->signatureAlgorithm.sign != NULL &&
           m->signatureAlgorithm.verify != NULL && m->encryptionAlgorithm.encrypt != NULL &&
           m->encryptionAlgorithm.decrypt != NULL;
}

/* A policy with keys whose functions are still its own. */
static bool to_wrap(const UA_SecurityPolicy *p)
{
    if (!has_keys(p))
        return false;
    for (unsigned i = 0; i < UA_CRYPTO_SLOTS; i++)
        if (p->asymmetricModule.cryptoModule.signatureAlgorithm.sign == wrappers[i].sign)
            return false;
    return true;
}

bool ua_crypto_wrap(ua_crypto_t *k, UA_SecurityPolicy *policies, size_t n, char *err,
                    size_t errlen)
{
    size_t want = 0, free_slots = 0;
    for (size_t p = 0; p < n; p++)
        want += to_wrap(&policies[p]);
    for (unsigned i = 0; i < UA_CRYPTO_SLOTS; i++)
        free_slots += slots[i].k == NULL;
    if (want > free_slots) {
        snprintf(err, errlen, "%zu security policies, room for %zu more (UA_CRYPTO_SLOTS)",
                 want, free_slots);
        return false;
    }
    unsigned i = 0;
    for (size_t p = 0; p < n; p++) {
        UA_SecurityPolicyCryptoModule *m = &policies[p].asymmetricModule.cryptoModule;
        if (!to_wrap(&policies[p]))
            continue;
        while (slots[i].k != NULL)
            i++;
        slots[i] = (slot_t){k, m->signatureAlgorithm, m->encryptionAlgorithm};
        m->signatureAlgorithm.sign = wrappers[i].sign;
        m->signatureAlgorithm.verify = wrappers[i].verify;
        m->encryptionAlgorithm.encrypt = wrappers[i].encrypt;
        m->encryptionAlgorithm.decrypt = wrappers[i].decrypt;
    }
    return true;
}

void ua_crypto_free(ua_crypto_t *k)
{
    if (k == NULL)
        return;
    ev_worker_close(&k->w);
    for (unsigned i = 0; i < UA_CRYPTO_SLOTS; i++)
        if (slots[i].k == k)
            slots[i] = (slot_t){0};
    free(k);
}

unsigned long long ua_crypto_jobs(const ua_crypto_t *k)
{
    return k != NULL ? k->jobs : 0;
}
