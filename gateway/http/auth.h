/* SPDX-License-Identifier: MIT */
/*
 * The console's logins off the event loop (docs/http.md "Logins",
 * docs/security.md). A password is checked once by crypt_r on ONE worker
 * thread, never in the loop; what it found is cached for a while, keyed
 * by an HMAC-SHA-256 of the whole Authorization value under a key drawn
 * at start (the header itself is never kept), so that the next requests
 * with the same header cost a table lookup. An unknown user is checked
 * against a hash of the same kind and cost (the first user's), so the
 * answer takes as long as for a known one. Refusals are counted per
 * client address: from the 5th on, each one doubles a wait (1 s .. 32 s)
 * during which that address's new logins are refused without being
 * checked, and the 401 is only sent when the wait ends. Refused logins
 * are logged with the address, one line per address per 10 s (and at most
 * ten addresses' lines per 10 s in all), the rest counted.
 *
 * The worker touches only its jobs (a copy of the password, the hash, the
 * key) under the queue's mutex and an eventfd it writes when one is done:
 * no robot data, no loop state. Everything else here runs in the loop.
 */
#ifndef GW_HTTP_AUTH_H
#define GW_HTTP_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "http/passwd.h"

struct crypt_data;
typedef char *(*gw_http_crypt_fn)(const char *phrase, const char *setting,
                                  struct crypt_data *data);

#define GW_HTTP_AUTH_CACHE 64     /* verified Authorization values kept */
#define GW_HTTP_AUTH_OK_TTL_S 300 /* a good one, this long after its check */
#define GW_HTTP_AUTH_BAD_TTL_S 60 /* a refused one */
#define GW_HTTP_AUTH_QUEUE 16     /* checks waiting or running at once */
#define GW_HTTP_AUTH_CLIENTS 128  /* client addresses whose refusals count */
#define GW_HTTP_AUTH_FREE_FAILS 4 /* refusals before the waits begin */
#define GW_HTTP_AUTH_WAIT_MAX_S 32
#define GW_HTTP_AUTH_FORGET_S 600 /* an address quiet this long starts over */

typedef struct gw_http_auth gw_http_auth_t;

typedef enum {
    GW_HTTP_AUTH_OK,      /* a good login (cached) */
    GW_HTTP_AUTH_REFUSED, /* refused: answer 401 at *until (now: at once) */
    GW_HTTP_AUTH_PENDING, /* being checked: wait for gw_http_auth_collect */
    GW_HTTP_AUTH_BUSY     /* the queue is full: 503, try again */
} gw_http_auth_result_t;

typedef struct {
    uint64_t ok, refused, busy, checks; /* logins: good, refused, 503, crypt_r runs */
} gw_http_auth_stats_t;

/* For the users (copied): the worker thread started, the key drawn. NULL
 * with err. crypt: libcrypt's crypt_r (mhd_lib.h), or a test's. */
gw_http_auth_t *gw_http_auth_new(const gw_http_users_t *users, gw_http_crypt_fn crypt, char *err,
                                 size_t errlen);
/* Stops and joins the worker; pending checks are dropped. NULL: nothing. */
void gw_http_auth_free(gw_http_auth_t *a);
/* The eventfd to watch (readable when checks are done). */
int gw_http_auth_fd(const gw_http_auth_t *a);

/* A request's login: authz the Authorization header (NULL: none), ip the
 * client's IPv4 address (host order), cookie what collect hands back for
 * a PENDING one (the connection). *until: when to send a REFUSED answer. */
gw_http_auth_result_t gw_http_auth_check(gw_http_auth_t *a, const char *authz, uint32_t ip,
                                         void *cookie, uint64_t now_us, uint64_t *until);

/* The checks done: each result cached and counted, then done(user,
 * cookie, ok, until) for those whose cookie is still waiting. */
void gw_http_auth_collect(gw_http_auth_t *a, uint64_t now_us,
                          void (*done)(void *user, void *cookie, bool ok, uint64_t until),
                          void *user);
/* The cookie no longer waits (its connection is going). */
void gw_http_auth_cancel(gw_http_auth_t *a, const void *cookie);

gw_http_auth_stats_t gw_http_auth_stats(const gw_http_auth_t *a);

/* "Basic BASE64(user:pass)" into user and pass ('\0'-terminated); false
 * if it is not one or does not fit (no allocation; fuzz_http). */
bool gw_http_basic_parse(const char *authz, char *user, size_t ucap, char *pass, size_t pcap);

/* HMAC-SHA-256 (RFC 2104, FIPS 180-4) of msg under key. */
void gw_http_hmac_sha256(const uint8_t *key, size_t klen, const void *msg, size_t mlen,
                         uint8_t out[32]);

#endif
