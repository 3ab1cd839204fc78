/* SPDX-License-Identifier: MIT */
/*
 * The Modbus TCP side of the gateway: listener, clients, framing, checks.
 *
 * Frames are reassembled without blocking (a slow or silent client never
 * stalls the others); each complete request's PDU goes to the one
 * request handler (mbproto.h: gw_mb_handle), and its reply PDU goes back
 * under the request's MBAP header.
 */
#ifndef DRGATE_GW_MBSERVER_H
#define DRGATE_GW_MBSERVER_H

#include <stddef.h>
#include <stdint.h>

#include "core/config.h"
#include "core/log.h"
#include "modbus/mbproto.h"
#include "modbus/regmap.h"
#include "modbus/reqlog.h"

typedef struct gw_mbs gw_mbs_t;

typedef struct {
    /* The unit (robot) for a unit ID, NULL if none. */
    gw_unit_t *(*unit_for)(void *user, uint8_t unit_id);
    /* An accepted write changed O->T images of unit u (bit per assembly
     * in dirty); u is what unit_for returned for the request. */
    void (*on_write)(void *user, gw_unit_t *u, unsigned dirty);
    void *user;
    const char *version; /* the gateway's, for FC 43 device identification */
    /* Every request answered (r: its result; ex: 0 or the exception code
     * sent), from `client` ("modbus 192.0.2.7:50412", "modbus_rtu NAME
     * unit N"), whose own log limiter is `log` (an accepted write is
     * logged with it, rate-limited per client). NULL: none. */
    void (*on_request)(void *user, const gw_mb_result_t *r, int ex, const char *client,
                       gw_log_limit_t *log);
} gw_mbs_hooks_t;

/* Listen as `cfg` says and register in the epoll set. NULL on error with
 * a message in err. */
gw_mbs_t *gw_mbs_new(const gw_modbus_config_t *cfg, int epfd,
                     const gw_mbs_hooks_t *hooks, char *err, size_t errlen);
void gw_mbs_free(gw_mbs_t *s);

/* Take new settings (SIGHUP): client limits, timeouts, word order,
 * allowlist, write lock, and the listen address and port. The listener
 * moves only once the new one is open: if the new address cannot be had,
 * the old one keeps serving (logged) and the rest is taken. Returns false
 * only if no listener is left (the caller must restart it). */
bool gw_mbs_reconfigure(gw_mbs_t *s, const gw_modbus_config_t *cfg);

/* Close idle clients, expire the single writer. Call at least every
 * gw_mbs_next_deadline(). */
void gw_mbs_tick(gw_mbs_t *s, uint64_t now_us);
uint64_t gw_mbs_next_deadline(const gw_mbs_t *s);

unsigned gw_mbs_client_count(const gw_mbs_t *s);
uint32_t gw_mbs_exceptions(const gw_mbs_t *s);
/* Single-writer mode: is a writer present? */
bool gw_mbs_writer_present(const gw_mbs_t *s);
/* How many times a client has become the writer: a new owner's watchdog
 * starts when it takes over, not where the last one's stood. */
unsigned gw_mbs_writer_claims(const gw_mbs_t *s);
/* Drop the current writer (after a watchdog fault). */
void gw_mbs_release_writer(gw_mbs_t *s);

/* The connected clients, for the console. */
typedef struct {
    char address[32]; /* "192.0.2.7:50412" */
    uint32_t requests, exceptions;
    bool read_write, writer;
    bool connected;           /* false: gone, its slot not taken again yet */
    const gw_reqlog_t *log;   /* its last requests (reqlog.h) */
} gw_mbs_client_info_t;
void gw_mbs_each_client(const gw_mbs_t *s,
                        void (*fn)(void *user, const gw_mbs_client_info_t *c), void *user);
/* The same for every slot with a request log: the clients connected and
 * the ones gone whose slot no new client took yet (mbserver.c: a client
 * that connects again from the same address takes its old slot). */
void gw_mbs_each_log(const gw_mbs_t *s, void (*fn)(void *user, const gw_mbs_client_info_t *c),
                     void *user);
/* Requests answered since the server started (all clients, past ones too). */
uint32_t gw_mbs_requests(const gw_mbs_t *s);

#endif
