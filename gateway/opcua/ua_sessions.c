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

static int active_index(const ua_sessions_t *s, const UA_NodeId *id)
{
    for (unsigned i = 0; i < s->n_active; i++)
        if (UA_NodeId_equal(&s->active[i], id))
            return (int)i;
    return -1;
}

static int pending_index(const ua_sessions_t *s, const UA_NodeId *id)
{
    for (unsigned i = 0; i < s->n_pending; i++)
        if (UA_NodeId_equal(&s->pending[i].id, id))
            return (int)i;
    return -1;
}

static void forget(ua_sessions_t *s, const UA_NodeId *id)
{
    int i = active_index(s, id);
    if (i >= 0) {
        UA_NodeId_clear(&s->active[i]);
        s->active[i] = s->active[--s->n_active];
    }
    i = pending_index(s, id);
    if (i >= 0) {
        UA_NodeId_clear(&s->pending[i].id);
        s->pending[i] = s->pending[--s->n_pending];
    }
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
    bool known = active_index(s, id) >= 0;
    if (!known && s->n_active >= s->max_active) {
        s->refused++;
        return UA_STATUSCODE_BADTOOMANYSESSIONS;
    }
    UA_StatusCode st = s->activate(server, ac, ep, cert, id, token, sctx);
    if (st != UA_STATUSCODE_GOOD || known)
        return st;
    int i = pending_index(s, id);
    if (i >= 0) {
        s->active[s->n_active++] = s->pending[i].id; /* (a GUID: nothing held) */
        s->pending[i] = s->pending[--s->n_pending];
    } else if (UA_NodeId_copy(id, &s->active[s->n_active]) == UA_STATUSCODE_GOOD) {
        s->n_active++;
    }
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
    if (s->n_pending < sizeof s->pending / sizeof s->pending[0] && pending_index(s, id) < 0 &&
        UA_NodeId_copy(id, &s->pending[s->n_pending].id) == UA_STATUSCODE_GOOD)
        s->pending[s->n_pending++].created_us = ev_now_us();
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
    for (unsigned i = 0; i < s->n_active; i++)
        UA_NodeId_clear(&s->active[i]);
    for (unsigned i = 0; i < s->n_pending; i++)
        UA_NodeId_clear(&s->pending[i].id);
    s->n_active = s->n_pending = 0;
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
    enum { N = sizeof s->pending / sizeof s->pending[0] };
    int64_t age[N] = {0};
    bool close[N] = {false};
    UA_NodeId doomed[N];
    size_t n = s->n_pending, k = 0;
    for (size_t i = 0; i < n; i++)
        age[i] = (int64_t)((now_us - s->pending[i].created_us) / 1000u);
    int64_t next_ms;
    size_t limit = UA_Server_getConfig(server)->maxSessions;
    size_t marked = ua_sessions_pick(age, close, n, s->n_active, limit, UA_LOGIN_WINDOW_MS,
                                     &next_ms);
    /* their ids first (GUIDs: copies hold nothing): closing one takes it
     * out of pending (gone) */
    for (size_t i = 0; i < n; i++)
        if (close[i])
            doomed[k++] = s->pending[i].id;
    for (size_t i = 0; i < k; i++) {
        if (UA_Server_closeSession(server, &doomed[i]) == UA_STATUSCODE_GOOD)
            s->closed++;
        else
            forget(s, &doomed[i]); /* gone already */
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
