/* SPDX-License-Identifier: MIT */
/* Logins off the event loop: see auth.h. */
#include "core/auth.h"

#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <crypt.h>

#include "common/ev.h"
#include "core/log.h"

#define PASS_MAX GW_AUTH_PASS_MAX

/* ---- SHA-256 and HMAC ------------------------------------------------------------- */

typedef struct {
    uint32_t h[8];
    uint64_t len;
    uint8_t buf[64];
    size_t n;
} sha256_t;

static const uint32_t K[64] = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4,
    0xab1c5ed5, 0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe,
    0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f,
    0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7,
    0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc,
    0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85, 0xa2bfe8a1, 0xa81a664b,
    0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116,
    0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7,
    0xc67178f2};

static uint32_t ror(uint32_t x, unsigned n)
{
    return (x >> n) | (x << (32u - n));
}

static void sha256_block(sha256_t *s, const uint8_t *p)
{
    uint32_t w[64], v[8];
    for (unsigned i = 0; i < 16; i++)
        w[i] = (uint32_t)p[4 * i] << 24 | (uint32_t)p[4 * i + 1] << 16 |
               (uint32_t)p[4 * i + 2] << 8 | p[4 * i + 3];
    for (unsigned i = 16; i < 64; i++) {
        uint32_t s0 = ror(w[i - 15], 7) ^ ror(w[i - 15], 18) ^ (w[i - 15] >> 3);
        uint32_t s1 = ror(w[i - 2], 17) ^ ror(w[i - 2], 19) ^ (w[i - 2] >> 10);
        w[i] = w[i - 16] + s0 + w[i - 7] + s1;
    }
    memcpy(v, s->h, sizeof v);
    for (unsigned i = 0; i < 64; i++) {
        uint32_t t1 = v[7] + (ror(v[4], 6) ^ ror(v[4], 11) ^ ror(v[4], 25)) +
                      ((v[4] & v[5]) ^ (~v[4] & v[6])) + K[i] + w[i];
        uint32_t t2 = (ror(v[0], 2) ^ ror(v[0], 13) ^ ror(v[0], 22)) +
                      ((v[0] & v[1]) ^ (v[0] & v[2]) ^ (v[1] & v[2]));
        memmove(v + 1, v, 7 * sizeof v[0]);
        v[4] += t1;
        v[0] = t1 + t2;
    }
    for (unsigned i = 0; i < 8; i++)
        s->h[i] += v[i];
}

static void sha256_init(sha256_t *s)
{
    static const uint32_t h0[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
                                   0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
    memcpy(s->h, h0, sizeof h0);
    s->len = 0;
    s->n = 0;
}

static void sha256_add(sha256_t *s, const void *data, size_t n)
{
    const uint8_t *p = data;
    s->len += n;
    while (n > 0) {
        size_t k = 64 - s->n < n ? 64 - s->n : n;
        memcpy(s->buf + s->n, p, k);
        s->n += k, p += k, n -= k;
        if (s->n == 64) {
            sha256_block(s, s->buf);
            s->n = 0;
        }
    }
}

static void sha256_end(sha256_t *s, uint8_t out[32])
{
    uint64_t bits = s->len * 8u;
    uint8_t pad = 0x80, zero = 0, len[8];
    sha256_add(s, &pad, 1);
    while (s->n != 56)
        sha256_add(s, &zero, 1);
    for (unsigned i = 0; i < 8; i++)
        len[i] = (uint8_t)(bits >> (56 - 8 * i));
    sha256_add(s, len, 8);
    for (unsigned i = 0; i < 8; i++) {
        out[4 * i] = (uint8_t)(s->h[i] >> 24);
        out[4 * i + 1] = (uint8_t)(s->h[i] >> 16);
        out[4 * i + 2] = (uint8_t)(s->h[i] >> 8);
        out[4 * i + 3] = (uint8_t)s->h[i];
    }
}

void gw_hmac_sha256(const uint8_t *key, size_t klen, const void *msg, size_t mlen,
                         uint8_t out[32])
{
    uint8_t k[64] = {0}, pad[64], inner[32];
    sha256_t s;
    if (klen > 64) {
        sha256_init(&s);
        sha256_add(&s, key, klen);
        sha256_end(&s, k);
    } else {
        memcpy(k, key, klen);
    }
    for (unsigned i = 0; i < 64; i++)
        pad[i] = k[i] ^ 0x36;
    sha256_init(&s);
    sha256_add(&s, pad, 64);
    sha256_add(&s, msg, mlen);
    sha256_end(&s, inner);
    for (unsigned i = 0; i < 64; i++)
        pad[i] = k[i] ^ 0x5c;
    sha256_init(&s);
    sha256_add(&s, pad, 64);
    sha256_add(&s, inner, 32);
    sha256_end(&s, out);
}

/* Equal, in a time that does not depend on where they differ. */
static bool same32(const uint8_t *a, const uint8_t *b)
{
    unsigned char d = 0;
    for (unsigned i = 0; i < 32; i++)
        d |= (unsigned char)(a[i] ^ b[i]);
    return d == 0;
}

/* ---- the state ---------------------------------------------------------------------- */

typedef struct {
    uint8_t key[32];
    bool used, ok;
    uint64_t expires_us;
} cached_t;

typedef struct {
    char from[GW_AUTH_FROM_MAX]; /* "": a free slot */
    unsigned fails;
    uint64_t last_us, until_us;
    gw_log_limit_t log;
} client_t;

typedef struct {
    bool used, done, ok;
    void *cookie;
    char from[GW_AUTH_FROM_MAX];
    int user; /* -1: unknown, checked against the dummy */
    uint8_t key[32];
    char name[GW_USER_MAX];
    char pass[PASS_MAX];
} job_t;

struct gw_auth {
    char label[16]; /* the side's, as its log lines start */
    bool per_user;  /* a source is a user name (OPC UA), not an address */
    gw_users_t users;
    gw_crypt_fn crypt;
    uint8_t secret[32];
    cached_t cache[GW_AUTH_CACHE];
    client_t client[GW_AUTH_CLIENTS];
    gw_auth_stats_t stats;
    gw_log_limit_t flood; /* beyond ten addresses' lines in 10 s */
    uint64_t lines_since_us;
    unsigned lines;
    ev_worker_t w; /* the jobs are shared with it, under w.mu */
    job_t job[GW_AUTH_QUEUE];
};

static void *worker(void *arg)
{
    gw_auth_t *a = arg;
    struct crypt_data *cd = calloc(1, sizeof *cd); /* 32 kB: not on the stack */
    job_t j;
    for (;;) {
        int at = -1;
        (void)pthread_mutex_lock(&a->w.mu);
        while (!a->w.stop) {
            for (int i = 0; i < GW_AUTH_QUEUE && at < 0; i++)
                if (a->job[i].used && !a->job[i].done)
                    at = i;
            if (at >= 0)
                break;
            (void)pthread_cond_wait(&a->w.cv, &a->w.mu);
        }
        if (a->w.stop || cd == NULL) {
            if (cd == NULL && !a->w.stop && at >= 0) {
                a->job[at].ok = false; /* no memory: refused, not stuck */
                a->job[at].done = true;
            }
            bool stop = a->w.stop;
            (void)pthread_mutex_unlock(&a->w.mu);
            if (stop) {
                free(cd);
                return NULL;
            }
            ev_worker_done(&a->w);
            continue;
        }
        j = a->job[at];
        (void)pthread_mutex_unlock(&a->w.mu);
        /* The unknown user: the first user's hash, so that the answer takes
         * as long; the result is a refusal whatever it says. */
        const char *hash = a->users.user[j.user >= 0 ? j.user : 0].hash;
        const char *h = a->crypt(j.pass, hash, cd);
        bool ok = false;
        if (h != NULL && strlen(h) == strlen(hash)) {
            unsigned char d = 0;
            for (size_t i = 0; h[i] != '\0'; i++)
                d |= (unsigned char)(h[i] ^ hash[i]);
            ok = d == 0 && j.user >= 0;
        }
        memset(cd, 0, sizeof *cd);
        memset(j.pass, 0, sizeof j.pass);
        (void)pthread_mutex_lock(&a->w.mu);
        memset(a->job[at].pass, 0, sizeof a->job[at].pass);
        a->job[at].ok = ok;
        a->job[at].done = true;
        (void)pthread_mutex_unlock(&a->w.mu);
        ev_worker_done(&a->w);
    }
}

gw_auth_t *gw_auth_new(const gw_users_t *users, gw_crypt_fn crypt, const char *label,
                       const char *per, char *err, size_t errlen)
{
    gw_auth_t *a = calloc(1, sizeof *a);
    if (a == NULL) {
        snprintf(err, errlen, "%s: out of memory", label);
        return NULL;
    }
    snprintf(a->label, sizeof a->label, "%s", label);
    a->per_user = strcmp(per, "user") == 0;
    a->users = *users;
    a->crypt = crypt;
        int rnd = open("/dev/urandom", O_RDONLY | O_CLOEXEC);
    bool keyed = rnd >= 0 && read(rnd, a->secret, sizeof a->secret) == (ssize_t)sizeof a->secret;
    if (rnd >= 0)
        (void)close(rnd);
    if (!keyed) {
        snprintf(err, errlen, "%s: no random key for the login cache (/dev/urandom: %s)",
                 label, strerror(errno));
        free(a);
        return NULL;
    }
    char name[16];
    snprintf(name, sizeof name, "%.9s-login", label);
    int e = ev_worker_open(&a->w, name, worker, a);
    if (e != 0) {
        snprintf(err, errlen, "%s: cannot start the login worker: %s", label, strerror(e));
        free(a);
        return NULL;
    }
    a->flood.window_ms = 10000;
    return a;
}

void gw_auth_free(gw_auth_t *a)
{
    if (a == NULL)
        return;
    ev_worker_close(&a->w);
    for (unsigned i = 0; i < GW_AUTH_CLIENTS; i++)
        if (a->client[i].from[0] != '\0')
            gw_log_limit_end(&a->client[i].log);
    gw_log_limit_end(&a->flood);
    memset(a, 0, sizeof *a); /* the cache's keys and the secret */
    free(a);
}

int gw_auth_fd(const gw_auth_t *a)
{
    return a->w.efd;
}

gw_auth_stats_t gw_auth_stats(const gw_auth_t *a)
{
    return a->stats;
}

/* ---- sources ---------------------------------------------------------------------------- */

static client_t *client_of(gw_auth_t *a, const char *from, uint64_t now, bool make)
{
    client_t *free_one = NULL, *oldest = NULL;
    for (unsigned i = 0; i < GW_AUTH_CLIENTS; i++) {
        client_t *c = &a->client[i];
        bool same = c->from[0] != '\0' && strcmp(c->from, from) == 0;
        if (same && c->fails > 0 && now - c->last_us < (uint64_t)GW_AUTH_FORGET_S * 1000000u)
            return c;
        if (same) {
            c->fails = 0; /* quiet long enough: starts over */
            c->until_us = 0;
            return make ? c : NULL;
        }
        if (c->from[0] == '\0' && free_one == NULL)
            free_one = c;
        if (oldest == NULL || c->last_us < oldest->last_us)
            oldest = c;
    }
    if (!make)
        return NULL;
    client_t *c = free_one != NULL ? free_one : oldest;
    if (c->from[0] != '\0')
        gw_log_limit_end(&c->log);
    memset(c, 0, sizeof *c);
    snprintf(c->from, sizeof c->from, "%s", from);
    c->log.window_ms = 10000;
    return c;
}

/* A refusal from `from`: counted, logged (limited), and when to answer it. */
static uint64_t refused(gw_auth_t *a, const char *from, const char *user, uint64_t now)
{
    client_t *c = client_of(a, from, now, true);
    a->stats.refused++;
    c->fails++;
    c->last_us = now;
    uint64_t wait = 0;
    if (c->fails > GW_AUTH_FREE_FAILS) {
        unsigned k = c->fails - GW_AUTH_FREE_FAILS - 1u;
        wait = k >= 5 ? GW_AUTH_WAIT_MAX_S : 1u << k;
        c->until_us = now + wait * 1000000u;
    }
    char more[64] = "";
    if (wait > 0)
        snprintf(more, sizeof more, a->per_user ? "; checked again after %llu s"
                                                : "; answered after %llu s",
                 (unsigned long long)wait);
    /* one line per source per 10 s, and ten sources' lines per 10 s in
     * all: a flood cannot push the console's last 200 events out */
    if (now - a->lines_since_us >= 10000000u) {
        a->lines_since_us = now;
        a->lines = 0;
    }
    gw_log_limit_t *lim = &c->log;
    bool due = c->log.last_us == 0 || now >= c->log.last_us + 10000000u;
    if (due && ++a->lines > 10)
        lim = &a->flood;
    if (a->per_user)
        gw_log_limited(GW_LOG_INFO, lim,
                       "%s: login refused for user \"%.63s\" (%u refused for this user%s)",
                       a->label, user, c->fails, more);
    else
        gw_log_limited(GW_LOG_INFO, lim,
                       "%s: login refused for user \"%.63s\" from %s (%u refused from this "
                       "address%s)",
                       a->label, user, from, c->fails, more);
    return c->until_us > now ? c->until_us : now;
}

static void good(gw_auth_t *a, const char *from, uint64_t now)
{
    client_t *c = client_of(a, from, now, false);
    a->stats.ok++;
    if (c != NULL) {
        gw_log_limit_end(&c->log);
        c->fails = 0;
        c->until_us = 0;
    }
}

/* ---- the cache -------------------------------------------------------------------------- */

static cached_t *cache_find(gw_auth_t *a, const uint8_t key[32], uint64_t now)
{
    cached_t *hit = NULL;
    for (unsigned i = 0; i < GW_AUTH_CACHE; i++) {
        cached_t *e = &a->cache[i];
        if (e->used && now >= e->expires_us)
            e->used = false;
        if (e->used && same32(e->key, key) && hit == NULL)
            hit = e; /* and on through the table: the same time either way */
    }
    return hit;
}

static void cache_put(gw_auth_t *a, const uint8_t key[32], bool ok, uint64_t now)
{
    cached_t *slot = cache_find(a, key, now);
    for (unsigned i = 0; slot == NULL && i < GW_AUTH_CACHE; i++)
        if (!a->cache[i].used)
            slot = &a->cache[i];
    /* full: the refused one that expires first, else the good one */
    for (unsigned pass = 0; pass < 2 && slot == NULL; pass++)
        for (unsigned i = 0; i < GW_AUTH_CACHE; i++) {
            cached_t *e = &a->cache[i];
            if ((pass == 1 || !e->ok) && (slot == NULL || e->expires_us < slot->expires_us))
                slot = e;
        }
    memcpy(slot->key, key, 32);
    slot->used = true;
    slot->ok = ok;
    slot->expires_us =
        now + (uint64_t)(ok ? GW_AUTH_OK_TTL_S : GW_AUTH_BAD_TTL_S) * 1000000u;
}

/* ---- the calls -------------------------------------------------------------------------- */

/* The cache's key of a user and password: HMAC(user NUL pass). */
static void login_key(const gw_auth_t *a, const char *user, const char *pass, uint8_t key[32])
{
    char both[GW_USER_MAX + PASS_MAX];
    size_t un = strnlen(user, GW_USER_MAX - 1), pn = strnlen(pass, PASS_MAX - 1);
    memcpy(both, user, un);
    both[un] = '\0';
    memcpy(both + un + 1, pass, pn);
    gw_hmac_sha256(a->secret, sizeof a->secret, both, un + 1 + pn, key);
    memset(both, 0, sizeof both);
}

gw_auth_result_t gw_auth_check(gw_auth_t *a, const char *user, const char *pass,
                               const char *from, void *cookie, uint64_t now_us, uint64_t *until)
{
    uint8_t key[32];
    *until = now_us;
    bool readable = user != NULL && pass != NULL && strlen(user) < GW_USER_MAX &&
                    strlen(pass) < PASS_MAX;
    const cached_t *e = NULL;
    if (readable) {
        login_key(a, user, pass, key);
        e = cache_find(a, key, now_us);
        if (e != NULL && e->ok)
            return GW_AUTH_OK;
    }
    const gw_user_t *u = readable ? gw_passwd_find(&a->users, user) : NULL;
    if (a->per_user) /* the user is the source; names that are no user's, together */
        from = u != NULL ? user : "(unknown user)";
    const client_t *c = client_of(a, from, now_us, false);
    if (e != NULL || !readable || (c != NULL && c->until_us > now_us)) {
        /* refused before, unreadable, or the source is waiting: no check */
        *until = refused(a, from, readable ? user : "?", now_us);
        if (c != NULL && c->until_us > *until)
            *until = c->until_us;
        return GW_AUTH_REFUSED;
    }
    gw_auth_result_t r = GW_AUTH_BUSY;
    (void)pthread_mutex_lock(&a->w.mu);
    for (unsigned i = 0; i < GW_AUTH_QUEUE; i++) {
        job_t *j = &a->job[i];
        if (j->used)
            continue;
        memset(j, 0, sizeof *j);
        j->used = true;
        j->cookie = cookie;
        snprintf(j->from, sizeof j->from, "%s", from);
        j->user = u != NULL ? (int)(u - a->users.user) : -1;
        memcpy(j->key, key, 32);
        snprintf(j->name, sizeof j->name, "%s", user);
        snprintf(j->pass, sizeof j->pass, "%s", pass);
        (void)pthread_cond_signal(&a->w.cv);
        r = GW_AUTH_PENDING;
        break;
    }
    (void)pthread_mutex_unlock(&a->w.mu);
    if (r == GW_AUTH_BUSY)
        a->stats.busy++;
    else
        a->stats.checks++;
    return r;
}

void gw_auth_collect(gw_auth_t *a, uint64_t now_us,
                          void (*done)(void *user, void *cookie, bool ok, uint64_t until),
                          void *user)
{
    uint64_t n;
    while (read(a->w.efd, &n, sizeof n) < 0 && errno == EINTR)
        ;
    for (;;) {
        job_t j;
        bool got = false;
        (void)pthread_mutex_lock(&a->w.mu);
        for (unsigned i = 0; i < GW_AUTH_QUEUE && !got; i++)
            if (a->job[i].used && a->job[i].done) {
                j = a->job[i];
                a->job[i].used = false;
                got = true;
            }
        (void)pthread_mutex_unlock(&a->w.mu);
        if (!got)
            return;
        cache_put(a, j.key, j.ok, now_us);
        uint64_t until = now_us;
        if (j.ok)
            good(a, j.from, now_us);
        else
            until = refused(a, j.from, j.name, now_us);
        if (j.cookie != NULL)
            done(user, j.cookie, j.ok, until);
    }
}

void gw_auth_cancel(gw_auth_t *a, const void *cookie)
{
    (void)pthread_mutex_lock(&a->w.mu);
    for (unsigned i = 0; i < GW_AUTH_QUEUE; i++)
        if (a->job[i].used && a->job[i].cookie == cookie)
            a->job[i].cookie = NULL; /* still checked and counted */
    (void)pthread_mutex_unlock(&a->w.mu);
}
