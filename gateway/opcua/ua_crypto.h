/* SPDX-License-Identifier: MIT */
/*
 * open62541's public-key operations off the daemon's loop.
 *
 * Every client that opens a secure channel costs the server an RSA
 * decryption and a signature (OpenSecureChannel), then another signature
 * (CreateSession) and the decryption of its password (ActivateSession):
 * a few ms each in mbedTLS (RSA-2048 to 4096). Run in the loop, that is
 * a few ms during which no robot packet is answered and no Modbus request
 * served, for anybody who can reach the port, authenticated or not
 * (bench-opcua (d): Modbus p99 0.13 -> 10.9 ms under a flood of logins).
 *
 * open62541 wants each result before its call returns, so the security
 * policies' asymmetric functions (sign, verify, encrypt, decrypt) are
 * wrapped: the call is handed to ONE worker thread, and the caller waits
 * for it through `wait`, which the side implements as its wait aside
 * (core/north.h wait_aside: the loop turns for the robots and the other
 * sides, the server's own descriptor out of it). open62541 itself thus
 * runs on one thread at a time: the worker runs the policy's original
 * function while the loop thread runs everything but the server. The
 * worker touches the call's buffers and the policy's keys, no robot data.
 *
 * open62541 gives those functions no user pointer, only its channel's
 * context, so each wrapped policy takes one of UA_CRYPTO_SLOTS slots, each
 * with functions of its own that know their slot (a process-wide table).
 */
#ifndef DRGATE_GW_UA_CRYPTO_H
#define DRGATE_GW_UA_CRYPTO_H

#include <stdbool.h>
#include <stddef.h>

#include <open62541/plugin/securitypolicy.h>

/* Wrapped policies at once: a server's three secure ones, twice (a reload
 * builds the new server before the old one goes), and room. */
#define UA_CRYPTO_SLOTS 8

/* SecurityPolicy#None's URI (open62541 does not export it): a policy
 * without keys, left alone. */
#define UA_POLICY_NONE_URI "http://opcfoundation.org/UA/SecurityPolicy#None"

typedef struct ua_crypto ua_crypto_t;

/* Waits until fd is readable with the loop going on (not for this
 * server); false if it cannot wait now: ua_crypto then blocks until the
 * operation is done (it takes ms, not a network's time). */
typedef bool (*ua_crypto_wait_fn)(void *user, int fd);

/* The worker thread started. NULL with err. */
ua_crypto_t *ua_crypto_new(ua_crypto_wait_fn wait, void *user, char *err, size_t errlen);

/* The asymmetric functions of each of the n policies that have any (None
 * has none) run on k's worker from now on. false with err (no slot left):
 * none is wrapped then. */
bool ua_crypto_wrap(ua_crypto_t *k, UA_SecurityPolicy *policies, size_t n, char *err,
                    size_t errlen);

/* Stops the worker, frees k's slots. The policies it wrapped must be gone
 * (the server deleted) or never called again. NULL: nothing. */
void ua_crypto_free(ua_crypto_t *k);

/* Operations run by the worker since k was made. */
unsigned long long ua_crypto_jobs(const ua_crypto_t *k);

#endif /* DRGATE_GW_UA_CRYPTO_H */
