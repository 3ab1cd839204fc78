/* SPDX-License-Identifier: MIT */
/* Sessions that log in, and sessions that do not (ua_sessions.h). */
#include "opcua/ua_sessions.h"

#include <stdio.h>
#include <string.h>

#include "common/ev.h"

#define UA_SESSIONS_SERVERS 4 /* hooked at once: a reload builds the next beside the old */
#define UA_SWEEP_LATE_MS 100  /* a window's end is swept this much after it */

/* The hooked servers' states, by their access control's context: its
 * wrappers get the access control, not a pointer of ours. Touched in the
 * loop's thread only. */
static ua_sessions_t *hooked[UA_SESSIONS_SERVERS];

static ua_sessions_t *find(const UA_AccessControl *ac)
{
    for (unsigned i = 0; i < UA_SESSIONS_SERVERS; i++)
        if (hooked[i] != NULL && hooked[i]->ac_context == ac->context)
            return hooked[i];
    return NULL;
}

static int session_index(const ua_sessions_t *s, const UA_NodeId *id)
{
    for (unsigned i = 0; i < s->n; i++)
        if (UA_NodeId_equal(&s->session[i].id, id))
            return (int)i;
    return -1;
}

/* id known, from now on: NULL if there is no room (not expected: as many
 * as the server's maxSessions). */
static ua_session_t *add(ua_sessions_t *s, const UA_NodeId *id)
{
    int i = session_index(s, id);
    if (i >= 0)
        return &s->session[i];
    if (s->n >= sizeof s->session / sizeof s->session[0])
        return NULL;
    ua_session_t *e = &s->session[s->n];
    if (UA_NodeId_copy(id, &e->id) != UA_STATUSCODE_GOOD)
        return NULL;
    e->created_us = ev_now_us();
    e->active = false;
    s->n++;
    return e;
}

static void forget(ua_sessions_t *s, const UA_NodeId *id)
{
    int i = session_index(s, id);
    if (i >= 0) {
        UA_NodeId_clear(&s->session[i].id);
        s->session[i] = s->session[--s->n];
    }
}

unsigned ua_sessions_logged_in(const ua_sessions_t *s)
{
    unsigned n = 0;
    for (unsigned i = 0; i < s->n; i++)
        n += s->session[i].active;
    return n;
}

/* ---- what open62541 calls ------------------------------------------------- */

/* ActivateSession: within max_sessions logins. A session logged in
 * already (ActivateSession again, on another channel) is let through; a
 * new one beyond the limit refused before its password is checked. */
static UA_StatusCode activate(UA_Server *server, UA_AccessControl *ac,
                              const UA_EndpointDescription *ep, const UA_ByteString *cert,
                              const UA_NodeId *id, const UA_ExtensionObject *token, void **sctx)
{
    ua_sessions_t *s = find(ac);
    if (s == NULL)
        return UA_STATUSCODE_BADINTERNALERROR;
    int i = session_index(s, id);
    bool known = i >= 0 && s->session[i].active;
    if (!known && ua_sessions_logged_in(s) >= s->max_active) {
        s->refused++;
        return UA_STATUSCODE_BADTOOMANYSESSIONS;
    }
    UA_StatusCode st = s->activate(server, ac, ep, cert, id, token, sctx);
    ua_session_t *e = st == UA_STATUSCODE_GOOD && !known ? add(s, id) : NULL;
    if (e != NULL)
        e->active = true;
    return st;
}

static void close_session(UA_Server *server, UA_AccessControl *ac, const UA_NodeId *id,
                          void *sctx)
{
    ua_sessions_t *s = find(ac);
    if (s == NULL)
        return; /* (not expected: unhooked after the server is gone) */
    forget(s, id);
    s->close(server, ac, id, sctx);
}

/* A session's diagnostics object made: the session, in CreateSession. */
static UA_StatusCode made(UA_Server *server, const UA_NodeId *sid, void *sctx,
                          const UA_NodeId *type, void *tctx, const UA_NodeId *id, void **nctx)
{
    ua_sessions_t *s = tctx;
    (void)server;
    (void)sid;
    (void)sctx;
    (void)type;
    (void)nctx;
    (void)add(s, id);
    s->created = true;
    return UA_STATUSCODE_GOOD;
}

/* ... and gone: the session closed or timed out. */
static void gone(UA_Server *server, const UA_NodeId *sid, void *sctx, const UA_NodeId *type,
                 void *tctx, const UA_NodeId *id, void **nctx)
{
    (void)server;
    (void)sid;
    (void)sctx;
    (void)type;
    (void)nctx;
    forget(tctx, id);
}

bool ua_sessions_hook(ua_sessions_t *s, UA_Server *server, unsigned max_sessions, char *err,
                      size_t errlen)
{
    UA_AccessControl *ac = &UA_Server_getConfig(server)->accessControl;
    unsigned at = UA_SESSIONS_SERVERS;
    for (unsigned i = 0; i < UA_SESSIONS_SERVERS && at == UA_SESSIONS_SERVERS; i++)
        if (hooked[i] == NULL)
            at = i;
    if (at == UA_SESSIONS_SERVERS || ac->activateSession == NULL || ac->closeSession == NULL) {
        snprintf(err, errlen, "cannot count the sessions' logins (%s)",
                 at == UA_SESSIONS_SERVERS ? "too many servers at once" : "no access control");
        return false;
    }
    memset(s, 0, sizeof *s);
    s->max_active = max_sessions < UA_SESSIONS_MAX ? max_sessions : UA_SESSIONS_MAX;
    s->next_us = UINT64_MAX;
    UA_NodeId type = UA_NODEID_NUMERIC(0, UA_NS0ID_SESSIONDIAGNOSTICSOBJECTTYPE);
    UA_NodeTypeLifecycle life = {made, gone};
    UA_StatusCode st = UA_Server_setNodeContext(server, type, s);
    if (st == UA_STATUSCODE_GOOD)
        st = UA_Server_setNodeTypeLifecycle(server, type, life);
    if (st != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "cannot watch the sessions being made: %s",
                 UA_StatusCode_name(st));
        return false;
    }
    s->activate = ac->activateSession;
    s->close = ac->closeSession;
    s->ac_context = ac->context;
    ac->activateSession = activate;
    ac->closeSession = close_session;
    hooked[at] = s;
    return true;
}

void ua_sessions_unhook(ua_sessions_t *s)
{
    for (unsigned i = 0; i < UA_SESSIONS_SERVERS; i++)
        if (hooked[i] == s)
            hooked[i] = NULL;
    for (unsigned i = 0; i < s->n; i++)
        UA_NodeId_clear(&s->session[i].id);
    s->n = 0;
    gw_log_limit_end(&s->log);
}

/* ---- the sweep ------------------------------------------------------------- */

size_t ua_sessions_pick(const int64_t *age_ms, bool *close, size_t n, size_t logged_in,
                        size_t limit, int64_t window_ms, int64_t *next_ms)
{
    size_t marked = 0;
    for (size_t i = 0; i < n; i++) {
        close[i] = age_ms[i] >= window_ms;
        marked += close[i];
    }
    /* full: room for one more, the oldest not logged in closed first */
    while (logged_in + n - marked >= limit && marked < n) {
        size_t oldest = n;
        for (size_t i = 0; i < n; i++)
            if (!close[i] && (oldest == n || age_ms[i] > age_ms[oldest]))
                oldest = i;
        close[oldest] = true;
        marked++;
    }
    *next_ms = -1;
    for (size_t i = 0; i < n; i++)
        if (!close[i] && (*next_ms < 0 || window_ms - age_ms[i] < *next_ms))
            *next_ms = window_ms - age_ms[i];
    return marked;
}

uint64_t ua_sessions_sweep(ua_sessions_t *s, UA_Server *server, uint64_t now_us)
{
    if (!s->created && now_us < s->next_us)
        return s->next_us;
    s->created = false;
    s->next_us = UINT64_MAX;
    enum { N = sizeof s->session / sizeof s->session[0] };
    /* the sessions not logged in: their ages, and their ids (GUIDs: the
     * copies hold nothing; closing one takes it out of the list, gone) */
    int64_t age[N] = {0};
    bool close[N] = {false};
    UA_NodeId id[N];
    size_t n = 0;
    for (unsigned i = 0; i < s->n; i++)
        if (!s->session[i].active) {
            age[n] = (int64_t)((now_us - s->session[i].created_us) / 1000u);
            id[n++] = s->session[i].id;
        }
    int64_t next_ms;
    size_t limit = UA_Server_getConfig(server)->maxSessions;
    size_t marked = ua_sessions_pick(age, close, n, s->n - n, limit, UA_LOGIN_WINDOW_MS,
                                     &next_ms);
    for (size_t i = 0; i < n; i++) {
        if (!close[i])
            continue;
        if (UA_Server_closeSession(server, &id[i]) == UA_STATUSCODE_GOOD)
            s->closed++;
        else
            forget(s, &id[i]); /* gone already */
    }
    if (marked > 0)
        gw_log_limited(GW_LOG_WARNING, &s->log,
                       "opcua: %zu session(s) closed without a login (%llu in all): not "
                       "logged in within %d s, or the oldest such when the server was full",
                       marked, s->closed, UA_LOGIN_WINDOW_MS / 1000);
    if (next_ms >= 0)
        s->next_us = now_us + (uint64_t)(next_ms + UA_SWEEP_LATE_MS) * 1000u;
    return s->next_us;
}
