/* SPDX-License-Identifier: MIT */
/*
 * Logins off the event loop, for every side that takes user names and
 * passwords from auth_file (core/passwd.h): the console (gateway/http,
 * docs/http.md "Logins") and OPC UA (gateway/opcua, docs/opcua.md). A
 * password is checked once by crypt_r on ONE worker thread, never in the
 * loop; what it found is cached for a while, keyed by an HMAC-SHA-256 of
 * the user and password under a key drawn at start (neither is kept), so
 * that the next logins with the same pair cost a table lookup. An unknown
 * user is checked against a hash of the same kind and cost (the first
 * user's), so the answer takes as long as for a known one. Refusals are
 * counted per source (the console: the client's address; OPC UA, which
 * does not tell its callback the address: the user name, unknown names
 * together): from the 5th on, each one doubles a wait (1 s .. 32 s)
 * during which that source's new logins are refused without being
 * checked. Refused logins are logged, one line per source per 10 s (and
 * at most ten sources' lines per 10 s in all), the rest counted.
 *
 * The worker touches only its jobs (a copy of the password, the hash, the
 * key) under the queue's mutex and an eventfd it writes when one is done:
 * no robot data, no loop state. Everything else here runs in the loop.
 */
#ifndef GW_AUTH_H
#define GW_AUTH_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "core/passwd.h"

struct crypt_data;
typedef char *(*gw_crypt_fn)(const char *phrase, const char *setting,
                                  struct crypt_data *data);

#define GW_AUTH_CACHE 64     /* verified Authorization values kept */
#define GW_AUTH_OK_TTL_S 300 /* a good one, this long after its check */
#define GW_AUTH_BAD_TTL_S 60 /* a refused one */
#define GW_AUTH_QUEUE 16     /* checks waiting or running at once */
#define GW_AUTH_CLIENTS 128  /* client addresses whose refusals count */
#define GW_AUTH_FREE_FAILS 4 /* refusals before the waits begin */
#define GW_AUTH_WAIT_MAX_S 32
#define GW_AUTH_FORGET_S 600 /* an address quiet this long starts over */

typedef struct gw_auth gw_auth_t;

#define GW_AUTH_PASS_MAX 256 /* bytes of a password, its '\0' included */
#define GW_AUTH_FROM_MAX GW_USER_MAX /* bytes of a source's name (an address, a user name) */

typedef enum {
    GW_AUTH_OK,      /* a good login (cached) */
    GW_AUTH_REFUSED, /* refused: answer 401 at *until (now: at once) */
    GW_AUTH_PENDING, /* being checked: wait for gw_auth_collect */
    GW_AUTH_BUSY     /* the queue is full: 503, try again */
} gw_auth_result_t;

typedef struct {
    uint64_t ok, refused, busy, checks; /* logins: good, refused, 503, crypt_r runs */
} gw_auth_stats_t;

/* For the users (copied): the worker thread started, the key drawn. NULL
 * with err. crypt: libcrypt's crypt_r, or a test's. label: the side, as
 * its log lines start ("http"); per: what a source is: "address" (the
 * caller's `from`), or "user" (the user name if it is a user's, else all
 * unknown names together; `from` is not used, and the refusal's line does
 * not repeat it). */
gw_auth_t *gw_auth_new(const gw_users_t *users, gw_crypt_fn crypt, const char *label,
                       const char *per, char *err, size_t errlen);
/* Stops and joins the worker; pending checks are dropped. NULL: nothing. */
void gw_auth_free(gw_auth_t *a);
/* The eventfd to watch (readable when checks are done). */
int gw_auth_fd(const gw_auth_t *a);

/* A login: user and pass as the client gave them (user NULL: credentials
 * that could not be read, refused and counted as user "?"), from its
 * source (GW_AUTH_FROM_MAX; NULL with per "user"), cookie what collect hands back for a
 * PENDING one (the request, the session). *until: when to answer a
 * REFUSED one (now: at once; later while its source waits). */
gw_auth_result_t gw_auth_check(gw_auth_t *a, const char *user, const char *pass,
                               const char *from, void *cookie, uint64_t now_us, uint64_t *until);

/* The checks done: each result cached and counted, then done(user,
 * cookie, ok, until) for those whose cookie is still waiting. */
void gw_auth_collect(gw_auth_t *a, uint64_t now_us,
                          void (*done)(void *user, void *cookie, bool ok, uint64_t until),
                          void *user);
/* The cookie no longer waits (its connection is going). */
void gw_auth_cancel(gw_auth_t *a, const void *cookie);

gw_auth_stats_t gw_auth_stats(const gw_auth_t *a);

/* HMAC-SHA-256 (RFC 2104, FIPS 180-4) of msg under key. */
void gw_hmac_sha256(const uint8_t *key, size_t klen, const void *msg, size_t mlen,
                         uint8_t out[32]);

#endif
