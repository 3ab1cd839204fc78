/* SPDX-License-Identifier: MIT */
/*
 * Sessions that log in, and sessions that do not.
 *
 * open62541 1.4 counts a session against its maxSessions from
 * CreateSession on, before any login, and keeps one that never sends
 * ActivateSession until its timeout (the client asks; up to an hour). So
 * anybody who could reach the port held every session with max_sessions
 * connections, no password needed (a certificate of their own is enough
 * without trust_dir), and each plant client was refused with
 * BadTooManySessions for as long as they liked (tests/opcua/
 * test_opcua_security.py test_held_sessions_do_not_lock_out).
 *
 * Here the side counts the logins itself and gives open62541 room for
 * sessions in the making:
 *   - open62541's maxSessions is twice max_sessions; a login beyond
 *     max_sessions is refused with BadTooManySessions before its password
 *     is checked (the access control's activate function wrapped), so
 *     max_sessions keeps its meaning: sessions logged in at once;
 *   - each session is seen when open62541 makes its diagnostics object
 *     (a SessionDiagnosticsObjectType instance, built in CreateSession:
 *     the type's constructor is set) and when that goes (its destructor);
 *   - after each turn of the server (ua_sessions_sweep), a session that
 *     has not logged in within UA_LOGIN_WINDOW_MS is closed, and when the
 *     server is full the oldest not logged in is closed at once, so that
 *     the next CreateSession finds room. A client logs in within ms of its
 *     CreateSession; its password check (core/auth.h) takes a second or
 *     two at most when busy.
 * open62541 calls these while it runs its services, which must not close
 * a session: they only note, and the sweep closes, outside them.
 */
#ifndef DRGATE_GW_UA_SESSIONS_H
#define DRGATE_GW_UA_SESSIONS_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include <open62541/server.h>

#include "core/log.h"

#define UA_LOGIN_WINDOW_MS 10000 /* from CreateSession to a login, at most */
#define UA_SESSIONS_MAX 100      /* [opcua] max_sessions' upper bound */

/* A session the side knows of: made (CreateSession), or logged in. */
typedef struct {
    UA_NodeId id;
    uint64_t created_us; /* ev_now_us */
    bool active;         /* logged in: the access control said yes */
} ua_session_t;

typedef struct {
    unsigned max_active;
    ua_session_t session[2 * UA_SESSIONS_MAX]; /* open62541's maxSessions at most */
    unsigned n;
    /* the access control's own functions, and its context: the key the
     * wrappers find this by */
    UA_StatusCode (*activate)(UA_Server *, UA_AccessControl *, const UA_EndpointDescription *,
                              const UA_ByteString *, const UA_NodeId *,
                              const UA_ExtensionObject *, void **);
    void (*close)(UA_Server *, UA_AccessControl *, const UA_NodeId *, void *);
    void *ac_context;
    bool created;        /* a session made since the last sweep */
    uint64_t next_us;    /* the next window's end (ev_now_us), UINT64_MAX: none */
    gw_log_limit_t log;  /* the closings' line: one per 10 s */
    /* counters since the server started */
    unsigned long long closed;  /* sessions closed without a login */
    unsigned long long refused; /* logins refused with max_sessions logged in */
} ua_sessions_t;

/* Hooks s into server (made, not started): its access control's activate
 * and close functions wrapped, the sessions' diagnostics type's
 * constructor and destructor set; max_sessions logins at once (the
 * server's maxSessions should be twice that). false with err. */
bool ua_sessions_hook(ua_sessions_t *s, UA_Server *server, unsigned max_sessions, char *err,
                      size_t errlen);

/* The sessions logged in now. */
unsigned ua_sessions_logged_in(const ua_sessions_t *s);

/* Forgets s: after the server is deleted (deleting it closes its sessions
 * through the hooks). Never hooked (zeroed): nothing. */
void ua_sessions_unhook(ua_sessions_t *s);

/* After a turn of the server: the sessions not logged in closed as
 * above. Returns when it wants to run again at the latest (ev_now_us's
 * clock; UINT64_MAX: after the next CreateSession). */
uint64_t ua_sessions_sweep(ua_sessions_t *s, UA_Server *server, uint64_t now_us);

/* The sweep's choice, on its own: of n sessions not logged in (their
 * ages), marks in close[] each one older than window_ms, then, while
 * `limit` or more sessions would be left with the `logged_in` others, the
 * oldest left. Returns how many it marked; *next_ms is when the first one
 * left reaches window_ms (ms from now), -1 if none is left. */
size_t ua_sessions_pick(const int64_t *age_ms, bool *close, size_t n, size_t logged_in,
                        size_t limit, int64_t window_ms, int64_t *next_ms);

#endif /* DRGATE_GW_UA_SESSIONS_H */
