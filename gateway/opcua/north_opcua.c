/* SPDX-License-Identifier: MIT */
/*
 * OPC UA as a northbound side (north.h): an open62541 1.4 server with the
 * robots' fields ([opcua], docs/opcua.md).
 *
 * The server runs in the daemon's one loop, on no thread of its own
 * (open62541 1.4 built with UA_MULTITHREADING 100 takes locks but starts
 * no thread). Its POSIX event loop keeps its sockets in an epoll set of
 * its own; that set's descriptor is itself pollable (readable while one of
 * its sockets is), so it goes into the daemon's epoll set, and when it is
 * readable UA_Server_run_iterate(server, false) runs the server's
 * callbacks without waiting. What the server has to do on time (session
 * timeouts and the like) is its next cyclic time: our deadline.
 * Publishing and sampling go with the robots' packets, and requests wait
 * for them while they come ("the server's clock" below). open62541 gives
 * no accessor for the descriptor, so it is found as the one epoll
 * descriptor the process gained while the server started
 * (/proc/self/fd); should that ever fail, the side polls the server every
 * UA_POLL_MS instead (logged), which is no busy loop either.
 *
 * The flat view (docs/opcua.md): Objects/drgate/<robot>/<path>, one
 * variable per field element by its canonical path (the names of drcli,
 * the Modbus map and MQTT), NodeId ns=<urn:drgate:robots>;s=<robot>/<path>.
 * Values come from the robot's images at the moment they are read or
 * sampled (a DataSource: nothing is copied per packet), with the time the
 * assembly's packet went into the images as source timestamp and a status
 * code: Good; UncertainLastUsableValue while the robot's link is down;
 * BadNoCommunication before the first packet of the assembly. O->T
 * variables are written through the one write path (core/write.h).
 */
#include "core/north.h"

#include <crypt.h>
#include <dirent.h>
#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <open62541/plugin/accesscontrol_default.h>
#include <open62541/plugin/log.h>
#include <open62541/plugin/pki_default.h>
#include <open62541/server.h>
#include <open62541/server_config_default.h>

#include "common/ev.h"
#include "core/auth.h"
#include "core/log.h"
#include "core/passwd.h"
#include "core/write.h"
#include "opcua/ua_crypto.h"
#include "opcua/ua_model.h"
#include "opcua/ua_pem.h"
#include "opcua/ua_robotics.h"
#include "opcua/ua_sessions.h"

#define UA_NS_FLAT "urn:drgate:robots"
#define UA_POLL_MS 10u          /* without the event loop's descriptor */
#define UA_WAIT_MAX_MS 60000u   /* the longest wait for the server's next cyclic time */
#define UA_FD_SCAN 4096         /* descriptors looked at for it */
#define UA_LOG_KINDS 16u        /* open62541's log categories (UA_LogCategory) */
#define UA_LOGIN_WAIT_US 10000000u /* a login's check, at most (core/auth.h's worker) */
#define UA_CRYPTO_WAIT_US 10000000u /* a public-key operation's turn (ua_crypto.h), at most */
#define UA_MAX_MESSAGE (2u << 20) /* bytes of a message, either way: set_limits */
#define UA_MAX_PER_CALL 1000u     /* nodes of a Read, Write, Browse, ... call */
#define UA_MAX_RETRANSMIT 64u     /* notifications kept per subscription for Republish */

typedef struct ua ua_t;

/* A cyclic callback of the server that the side runs: see "the server's
 * clock". */
typedef struct {
    UA_UInt64 id; /* UA_CYC_ID | n: the event loop's own ids count from 1 */
    UA_Callback cb; /* NULL: removed while running */
    void *app, *data;
    uint64_t interval_us, next_us;
    bool aligned; /* a multiple of the RPI: runs with the robots' packets */
} ua_cyclic_t;
#define UA_CYC_ID (1ull << 63)

typedef UA_StatusCode (*ua_el_add_fn)(UA_EventLoop *el, UA_Callback cb, void *app, void *data,
                                      UA_Double interval_ms, UA_DateTime *base,
                                      UA_TimerPolicy policy, UA_UInt64 *id);
typedef UA_StatusCode (*ua_el_modify_fn)(UA_EventLoop *el, UA_UInt64 id, UA_Double interval_ms,
                                         UA_DateTime *base, UA_TimerPolicy policy);
typedef void (*ua_el_remove_fn)(UA_EventLoop *el, UA_UInt64 id);

/* What a variable of the flat view is: the robot (its index) and the
 * field element. */
typedef struct {
    ua_t *t;
    unsigned robot;
    dr_ref_t ref;
    ua_view_kind_t kind; /* the Robotics view's variables: ua_robotics.h */
    const UA_DataType *type; /* UA_VIEW_NONE: the value's type */
} ua_node_t;
#define UA_VIEW_NODES 128u /* the Robotics view's variables per robot (79) */

struct ua {
    const gw_north_env_t *env;
    gw_opcua_config_t cfg; /* a copy: a reload compares the new one with it */
    /* The robots as the server's nodes have them (index and name): a
     * reload that changes them builds a new server. */
    unsigned robot_count;
    char robot_name[GW_MAX_ROBOTS][GW_NAME_MAX];
    UA_Server *server;
    UA_Logger logger;
    ev_t ev;                /* the server's event loop's epoll descriptor */
    bool polled;            /* no such descriptor: iterate every UA_POLL_MS */
    bool building;          /* adding nodes: open62541 reads each to check its type */
    bool started;           /* UA_Server_run_startup succeeded */
    uint64_t next_us;       /* the server's next cyclic time */
    UA_UInt16 ns;           /* urn:drgate:robots */
    /* The server's cyclic callbacks at a multiple of the RPI, run by the
     * side (aligned to the robots' packets): see "the server's clock". */
    UA_EventLoop *el;
    ua_el_add_fn el_add;    /* the event loop's own functions */
    ua_el_modify_fn el_modify;
    ua_el_remove_fn el_remove;
    ua_cyclic_t *cyc;
    size_t cyc_count, cyc_cap;
    bool cyc_running;       /* in cyc_run: removals only mark */
    UA_UInt64 cyc_ids;
    uint64_t rpi_us;        /* the fastest robot's RPI */
    uint64_t burst_us;      /* when the last burst of robot packets ended */
    unsigned data_seq, tick_seq; /* on_data calls, and as the last tick saw them */
    bool fresh;             /* robot data since the server last ran */
    bool complete;          /* a robot's burst has come whole */
    uint64_t fresh_us;      /* when the first of that data came */
    unsigned burst_want[GW_MAX_ROBOTS]; /* the T->O assemblies of a robot's burst */
    unsigned burst_got[GW_MAX_ROBOTS];  /* ... as they came since its last burst */
    bool muted;             /* the server's descriptor taken out of the loop */
    uint64_t run_by;        /* muted: the server runs by then at the latest */
    ua_node_t *nodes;       /* robot_count * dr_leaf_count() */
    ua_node_t *view;        /* the Robotics view's: robot_count * UA_VIEW_NODES */
    size_t view_used;
    gw_auth_t *auth;       /* auth_file's logins, checked off the loop */
    gw_auth_t *next_auth;  /* auth_file read again by a reload's prepare */
    uint64_t trust;        /* trust_digest of trust_dir when the server was built */
    ua_crypto_t *crypto;   /* the policies' public-key operations, off the loop */
    ua_sessions_t sessions; /* logins counted, sessions without one closed */
    bool aside;            /* waiting aside for a login's check or a crypto operation */
    bool serving;          /* in serve(), called from the daemon's turn: may wait aside */
    pthread_t loop_thread; /* the daemon's loop: open62541 logs from the worker too */
    /* a line open62541 logged on the crypto worker, logged when the wait ends */
    char late_line[512];
    gw_log_level_t late_level;
    UA_LogCategory late_cat;
    /* Per robot: the T->O assemblies received since the side started, and
     * when each last came (UA_DateTime), the O->T ones when last written. */
    unsigned seen[GW_MAX_ROBOTS];
    UA_DateTime at[GW_MAX_ROBOTS][DR_ASM_COUNT];
    gw_log_limit_t write_log[GW_MAX_ROBOTS], refused_log;
    gw_log_limit_t ua_log_limit[UA_LOG_KINDS]; /* open62541's, by category */
    /* the console's: counters since the side started */
    unsigned long long reads, writes, refused, logins, logins_refused;
};

/* ---- logging ------------------------------------------------------------------ */

/* open62541's lines, tabs as spaces. Its warnings and notes about
 * connections, channels and sessions come once per client's try (a
 * refused login, an unknown certificate), so each of those categories
 * is held to one line per 10 s, the rest counted (core/log.h): a client
 * cannot flood the log. The server's own lines are not held back. */
static void ua_log_line(ua_t *t, gw_log_level_t lv, UA_LogCategory cat, const char *line)
{
    bool per_client = cat == UA_LOGCATEGORY_NETWORK || cat == UA_LOGCATEGORY_SECURECHANNEL ||
                      cat == UA_LOGCATEGORY_SESSION || cat == UA_LOGCATEGORY_SECURITYPOLICY ||
                      cat == UA_LOGCATEGORY_USERLAND || cat == UA_LOGCATEGORY_CLIENT;
    if (t != NULL && per_client && (unsigned)cat < UA_LOG_KINDS)
        gw_log_limited(lv, &t->ua_log_limit[cat], "opcua: %s", line);
    else
        gw_log(lv, "opcua: %s", line);
}

static void ua_log(void *ctx, UA_LogLevel level, UA_LogCategory cat, const char *msg, va_list ap)
{
    ua_t *t = ctx;
    char line[512];
    if (level < UA_LOGLEVEL_INFO)
        return;
    vsnprintf(line, sizeof line, msg, ap);
    for (char *p = line; *p != '\0'; p++)
        if (*p == '\t') /* open62541 separates its fields with tabs */
            *p = ' ';
    gw_log_level_t lv = level >= UA_LOGLEVEL_ERROR     ? GW_LOG_ERROR
                        : level >= UA_LOGLEVEL_WARNING ? GW_LOG_WARNING
                                                       : GW_LOG_DEBUG;
    /* From the crypto worker (the loop waits aside meanwhile): the log is
     * the loop's, so the first such line waits for the wait's end. */
    if (t != NULL && !pthread_equal(pthread_self(), t->loop_thread)) {
        if (t->late_line[0] == '\0') {
            snprintf(t->late_line, sizeof t->late_line, "%s", line);
            t->late_level = lv;
            t->late_cat = cat;
        }
        return;
    }
    ua_log_line(t, lv, cat, line);
}

/* ---- logins ------------------------------------------------------------------- */

typedef struct {
    bool done, ok;
} ua_verdict_t;

static void login_done(void *user, void *cookie, bool ok, uint64_t until)
{
    ua_verdict_t *v = cookie;
    (void)user;
    (void)until;
    v->done = true;
    v->ok = ok;
}

/* Waits aside (env->wait_aside: the loop turns for the robots and the
 * other sides) until fd is readable and ready(t, arg) says so (NULL:
 * readable is enough), or until
 * `until`. open62541 wants a login's verdict and a signature before its
 * callback returns, and neither crypt nor RSA may run in the loop. The
 * server's descriptor is out of the loop meanwhile, so that open62541 is
 * not run inside itself: its other clients wait (only they:
 * docs/opcua.md "Security"). false: could not wait, or not ready. */
static bool wait_ready(ua_t *t, int fd, uint64_t until, bool (*ready)(ua_t *t, void *arg),
                       void *arg)
{
    uint32_t events = t->ev.events;
    bool watched = t->ev.fd >= 0, ok = false;
    /* Only from serve(), which the daemon's turn calls: not while the side
     * is being made or reloaded (ua_start's first turns of the server, a
     * client already knocking), when the daemon's turn is not to be run. */
    if (t->env->wait_aside == NULL || t->aside || !t->serving)
        return false;
    if (watched && !ev_watch(t->env->epfd, &t->ev, t->ev.fd, 0))
        return false; /* the loop would run the server inside itself */
    t->aside = true;
    while (ev_now_us() < until && t->env->wait_aside(t->env->user, t, fd, until))
        if ((ok = ready == NULL || ready(t, arg)))
            break;
    t->aside = false;
    if (watched && !ev_watch(t->env->epfd, &t->ev, t->ev.fd, events)) {
        t->polled = true; /* iterated every UA_POLL_MS from now on */
        gw_log(GW_LOG_WARNING, "opcua: cannot watch the server's descriptor again: polling it");
    }
    return ok;
}

static bool login_ready(ua_t *t, void *arg)
{
    const ua_verdict_t *v = arg;
    gw_auth_collect(t->auth, ev_now_us(), login_done, t);
    return v->done;
}

/* A check on core/auth.h's worker, waited for aside. */
static bool login_wait(ua_t *t, ua_verdict_t *v)
{
    (void)wait_ready(t, gw_auth_fd(t->auth), ev_now_us() + UA_LOGIN_WAIT_US, login_ready, v);
    if (!v->done)
        gw_auth_cancel(t->auth, v);
    return v->done && v->ok;
}

/* ua_crypto_wait_fn: an RSA operation on ua_crypto's worker, waited for
 * aside; then the line open62541 logged meanwhile, if any. False only if
 * the loop cannot wait aside (the daemon stops): ua_crypto then blocks for
 * the rest of the operation (ms). */
static bool crypto_wait(void *user, int fd)
{
    ua_t *t = user;
    uint64_t until = ev_now_us() + UA_CRYPTO_WAIT_US;
    /* not done by then (a machine too busy for the worker): waited again */
    /* (the worker writes its eventfd when the operation is done) */
    bool ok = wait_ready(t, fd, until, NULL, NULL) || ev_now_us() >= until;
    if (t->late_line[0] != '\0') {
        ua_log_line(t, t->late_level, t->late_cat, t->late_line);
        t->late_line[0] = '\0';
    }
    return ok;
}

/* user:password against auth_file's hash (the console's format), the
 * console's way (core/auth.h): cached after a check, refusals counted per
 * user name (open62541 does not tell the client's address here), unknown
 * names together. */
static UA_StatusCode ua_login(const UA_String *user, const UA_ByteString *pass, size_t n,
                              const UA_UsernamePasswordLogin *list, void **sctx, void *lctx)
{
    ua_t *t = lctx;
    char name[GW_USER_MAX], word[GW_AUTH_PASS_MAX];
    (void)n;
    (void)list;
    (void)sctx;
    bool readable = user->length > 0 && user->length < sizeof name && pass->length < sizeof word &&
                    memchr(user->data, '\0', user->length) == NULL &&
                    memchr(pass->data, '\0', pass->length) == NULL;
    if (readable) {
        memcpy(name, user->data, user->length);
        name[user->length] = '\0';
        memcpy(word, pass->data, pass->length);
        word[pass->length] = '\0';
    }
    if (t->auth == NULL || t->aside) { /* no auth_file; or a login in a wait */
        t->logins_refused++;
        return UA_STATUSCODE_BADUSERACCESSDENIED;
    }
    ua_verdict_t v = {false, false};
    uint64_t until;
    gw_auth_result_t r = gw_auth_check(t->auth, readable ? name : NULL, readable ? word : NULL,
                                       NULL, &v, ev_now_us(), &until);
    memset(word, 0, sizeof word);
    bool ok = r == GW_AUTH_OK || (r == GW_AUTH_PENDING && login_wait(t, &v));
    if (!ok) {
        t->logins_refused++;
        return r == GW_AUTH_BUSY ? UA_STATUSCODE_BADTOOMANYOPERATIONS
                                 : UA_STATUSCODE_BADUSERACCESSDENIED;
    }
    t->logins++;
    return UA_STATUSCODE_GOOD;
}

/* ---- the flat view's values ------------------------------------------------------- */

/* The value as the variable's kind has it. */
static UA_StatusCode view_value(const ua_node_t *n, const gw_robot_t *rb, const dr_value_t *v,
                                UA_Variant *out)
{
    if (n->kind == UA_VIEW_DOUBLE) {
        UA_Double d = v->f;
        return UA_Variant_setScalarCopy(out, &d, &UA_TYPES[UA_TYPES_DOUBLE]);
    }
    if (n->kind == UA_VIEW_VERSION) {
        static const char *const parts[] = {"io_state.version.major", "io_state.version.minor",
                                            "io_state.version.patch"};
        unsigned num[3] = {0, 0, 0};
        char text[16];
        for (unsigned i = 0; i < 3; i++) {
            dr_ref_t ref;
            dr_value_t p;
            if (dr_path_parse(parts[i], &ref) == DR_OK && gw_robot_get(rb, ref, &p) == DR_OK)
                num[i] = (unsigned)(p.u & 0xFFu);
        }
        snprintf(text, sizeof text, "%u.%u.%u", num[0], num[1], num[2]);
        UA_String str = ua_model_text(text);
        return UA_Variant_setScalarCopy(out, &str, &UA_TYPES[UA_TYPES_STRING]);
    }
    return ua_model_value(n->ref, v, out);
}

static UA_StatusCode node_read(UA_Server *s, const UA_NodeId *sid, void *sctx,
                               const UA_NodeId *nid, void *nctx, UA_Boolean with_ts,
                               const UA_NumericRange *range, UA_DataValue *dv)
{
    const ua_node_t *n = nctx;
    ua_t *t = n->t;
    (void)s;
    (void)sid;
    (void)sctx;
    (void)nid;
    t->reads++;
    if (range != NULL) {
        dv->hasStatus = true;
        dv->status = UA_STATUSCODE_BADINDEXRANGEINVALID;
        return UA_STATUSCODE_GOOD;
    }
    if (ua_robotics_is_identity(n->kind) && !t->building) {
        ua_robotics_identity_read(n->kind, &t->env->robots[n->robot].identity, dv);
        return UA_STATUSCODE_GOOD;
    }
    if (n->kind == UA_VIEW_NONE || ua_robotics_is_identity(n->kind)) {
        /* not in the assemblies: docs/opcua.md */
        if (t->building) { /* what open62541 checks the type of */
            void *zero = UA_new(n->type);
            if (zero == NULL)
                return UA_STATUSCODE_BADOUTOFMEMORY;
            UA_Variant_setScalar(&dv->value, zero, n->type);
            dv->hasValue = true;
            return UA_STATUSCODE_GOOD;
        }
        dv->hasStatus = true;
        dv->status = UA_STATUSCODE_BADNOTSUPPORTED;
        return UA_STATUSCODE_GOOD;
    }
    const gw_robot_t *rb = &t->env->robots[n->robot];
    dr_asm_t a = (dr_asm_t)n->ref.field->assembly;
    bool t2o = dr_asm_info(a)->dir == DR_DIR_T2O;
    if (t2o && !(t->seen[n->robot] & (1u << a)) && !t->building) {
        dv->hasStatus = true;
        dv->status = UA_STATUSCODE_BADNOCOMMUNICATION;
        return UA_STATUSCODE_GOOD;
    }
    dr_value_t v;
    if (gw_robot_get(rb, n->ref, &v) != DR_OK) {
        dv->hasStatus = true;
        dv->status = UA_STATUSCODE_BADINTERNALERROR;
        return UA_STATUSCODE_GOOD;
    }
    UA_StatusCode rc = view_value(n, rb, &v, &dv->value);
    if (rc != UA_STATUSCODE_GOOD)
        return rc;
    dv->hasValue = true;
    if (t2o && !t->building && !t->env->link_up(t->env->user, n->robot)) {
        dv->hasStatus = true;
        dv->status = UA_STATUSCODE_UNCERTAINLASTUSABLEVALUE;
    }
    if (with_ts && t->at[n->robot][a] != 0) {
        dv->hasSourceTimestamp = true;
        dv->sourceTimestamp = t->at[n->robot][a];
    }
    return UA_STATUSCODE_GOOD;
}

/* The write path's refusal as OPC UA says it. */
static UA_StatusCode write_status(gw_write_status_t st)
{
    switch (st) {
    case GW_WRITE_OK: return UA_STATUSCODE_GOOD;
    case GW_WRITE_RIGHTS:
    case GW_WRITE_SINGLE: return UA_STATUSCODE_BADUSERACCESSDENIED;
    case GW_WRITE_FAULT: return UA_STATUSCODE_BADINVALIDSTATE;
    case GW_WRITE_FIELD: return UA_STATUSCODE_BADNODEIDUNKNOWN;
    case GW_WRITE_DIRECTION:
    case GW_WRITE_UNSENT:
    case GW_WRITE_GPIO: return UA_STATUSCODE_BADNOTWRITABLE;
    case GW_WRITE_VALUE: return UA_STATUSCODE_BADOUTOFRANGE;
    }
    return UA_STATUSCODE_BADINTERNALERROR;
}

static UA_StatusCode node_write(UA_Server *s, const UA_NodeId *sid, void *sctx,
                                const UA_NodeId *nid, void *nctx, const UA_NumericRange *range,
                                const UA_DataValue *dv)
{
    const ua_node_t *n = nctx;
    ua_t *t = n->t;
    (void)s;
    (void)sctx;
    (void)nid;
    if (range != NULL)
        return UA_STATUSCODE_BADINDEXRANGEINVALID;
    gw_write_item_t item = {n->ref, {DR_VAL_UINT, 0, 0, 0.0}, 0};
    if (!dv->hasValue || ua_model_from_variant(n->ref, &dv->value, &item.value) != DR_OK) {
        t->refused++;
        return UA_STATUSCODE_BADTYPEMISMATCH;
    }
    char who[GW_WRITE_CLIENT] = "opcua session";
    UA_String sess = UA_STRING_NULL;
    if (UA_NodeId_print(sid, &sess) == UA_STATUSCODE_GOOD)
        snprintf(who, sizeof who, "opcua session %.*s", (int)(sess.length > 40 ? 40 : sess.length),
                 (const char *)sess.data);
    UA_String_clear(&sess);
    gw_write_origin_t o = {GW_ORIGIN_OPCUA, who, t->cfg.writes, false, false,
                           &t->write_log[n->robot]};
    gw_write_result_t res;
    gw_write_status_t st = gw_robot_write(&t->env->robots[n->robot], &item, 1, &o, &res);
    if (st != GW_WRITE_OK) {
        char path[GW_WRITE_PATH] = "?";
        (void)dr_ref_path(n->ref, path, sizeof path);
        t->refused++;
        gw_log_limited(GW_LOG_WARNING, &t->refused_log, "opcua: write of %s/%s by %s refused: %s",
                       t->env->robots[n->robot].name, path, who, gw_write_status_text(st));
        return write_status(st);
    }
    t->writes++;
    t->at[n->robot][n->ref.field->assembly] = UA_DateTime_now();
    if (res.dirty != 0)
        t->env->outputs_changed(t->env->user, n->robot, res.dirty);
    return UA_STATUSCODE_GOOD;
}

/* ---- building the server ------------------------------------------------------------ */

/* The flat view of robot r under `parent`. */
static bool add_robot(ua_t *t, unsigned r, UA_NodeId parent, char *err, size_t errlen)
{
    const gw_robot_config_t *rc = &t->env->cfg->robot[r];
    char id[GW_NAME_MAX + 64];
    UA_NodeId folder = UA_NODEID_STRING(t->ns, t->robot_name[r]);
    UA_ObjectAttributes oa = UA_ObjectAttributes_default;
    oa.displayName = UA_LOCALIZEDTEXT("", t->robot_name[r]);
    UA_StatusCode st = UA_Server_addObjectNode(
        t->server, folder, parent, UA_NODEID_NUMERIC(0, UA_NS0ID_ORGANIZES),
        UA_QUALIFIEDNAME(t->ns, t->robot_name[r]), UA_NODEID_NUMERIC(0, UA_NS0ID_FOLDERTYPE), oa,
        NULL, NULL);
    if (st != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "robot %s: %s", t->robot_name[r], UA_StatusCode_name(st));
        return false;
    }
    uint16_t leaves = dr_leaf_count();
    UA_DataSource ds = {node_read, node_write};
    for (uint16_t i = 0; i < leaves; i++) {
        ua_node_t *n = &t->nodes[(size_t)r * leaves + i];
        char path[64];
        n->t = t;
        n->robot = r;
        if (dr_leaf_at(i, &n->ref) != DR_OK || dr_ref_path(n->ref, path, sizeof path) != DR_OK)
            continue;
        snprintf(id, sizeof id, "%s/%s", t->robot_name[r], path);
        ua_model_var_t var = {
            .id = UA_NODEID_STRING(t->ns, id),
            .parent = folder,
            .name = UA_QUALIFIEDNAME(t->ns, path),
            .ref = n->ref,
            .writable = t->cfg.writes,
            .rpi_ms = rc->rpi_ms,
            .source = ds,
            .context = n,
        };
        st = ua_model_add_field(t->server, &var);
        if (st != UA_STATUSCODE_GOOD) {
            snprintf(err, errlen, "%s: %s", id, UA_StatusCode_name(st));
            return false;
        }
    }
    return true;
}

/* A variable of the Robotics view (ua_robotics.h): its context. */
static void *view_context(void *user, unsigned r, ua_view_kind_t kind, const char *path,
                          const UA_DataType *type)
{
    ua_t *t = user;
    if (t->view_used == (size_t)t->robot_count * UA_VIEW_NODES)
        return NULL;
    ua_node_t *n = &t->view[t->view_used];
    n->t = t;
    n->robot = r;
    n->kind = kind;
    n->type = type;
    /* the version's and the unavailable ones' status: io_state's */
    if (dr_path_parse(path != NULL ? path : "io_state.version.major", &n->ref) != DR_OK)
        return NULL;
    t->view_used++;
    return n;
}

static bool add_robotics_view(ua_t *t, char *err, size_t errlen)
{
    ua_robotics_t v = {t->ns, {node_read, node_write}, view_context, t};
    UA_StatusCode st = ua_robotics_types(t->server);
    if (st != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "the Robotics types: %s", UA_StatusCode_name(st));
        return false;
    }
    for (unsigned r = 0; r < t->robot_count; r++)
        if (ua_robotics_add(t->server, &v, r, t->robot_name[r], err, errlen) !=
            UA_STATUSCODE_GOOD)
            return false;
    return true;
}

static bool add_flat_view(ua_t *t, char *err, size_t errlen)
{
    UA_NodeId root = UA_NODEID_STRING(t->ns, "drgate");
    UA_ObjectAttributes oa = UA_ObjectAttributes_default;
    oa.displayName = UA_LOCALIZEDTEXT("", "drgate");
    oa.description = UA_LOCALIZEDTEXT("en", "the robots' fields by canonical path");
    UA_StatusCode st = UA_Server_addObjectNode(
        t->server, root, UA_NODEID_NUMERIC(0, UA_NS0ID_OBJECTSFOLDER),
        UA_NODEID_NUMERIC(0, UA_NS0ID_ORGANIZES), UA_QUALIFIEDNAME(t->ns, "drgate"),
        UA_NODEID_NUMERIC(0, UA_NS0ID_FOLDERTYPE), oa, NULL, NULL);
    if (st != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "the drgate folder: %s", UA_StatusCode_name(st));
        return false;
    }
    for (unsigned r = 0; r < t->robot_count; r++)
        if (!add_robot(t, r, root, err, errlen))
            return false;
    return true;
}

/* The slowest a subscription may sample: the fastest robot's RPI (open62541
 * takes nothing under 5 ms). */
static double fastest_rpi_ms(const gw_config_t *cfg)
{
    double ms = 1000.0;
    for (unsigned r = 0; r < cfg->robot_count; r++)
        if (cfg->robot[r].rpi_ms < ms)
            ms = cfg->robot[r].rpi_ms;
    return ms < 5.0 ? 5.0 : ms;
}

/* No X.509 user tokens: with no trust list (open62541 accepts every
 * certificate then) any certificate would log in past auth_file. The
 * server takes a token only under a policy its endpoint offers. */
static void drop_x509_tokens(UA_AccessControl *ac)
{
    size_t kept = 0;
    for (size_t i = 0; i < ac->userTokenPoliciesSize; i++) {
        if (ac->userTokenPolicies[i].tokenType == UA_USERTOKENTYPE_CERTIFICATE)
            UA_UserTokenPolicy_clear(&ac->userTokenPolicies[i]);
        else
            ac->userTokenPolicies[kept++] = ac->userTokenPolicies[i];
    }
    ac->userTokenPoliciesSize = kept;
}

/* trust_dir's files as they are loaded (set_trust). */
typedef struct {
    UA_ByteString cert[GW_OPCUA_TRUST_MAX], crl[GW_OPCUA_TRUST_MAX];
    size_t ncert, ncrl;
    char *err;
    size_t errlen;
    bool ok;
} trust_load_t;

static bool trust_load(void *ctx, const char *path, const char *name, gw_opcua_trust_kind_t k)
{
    trust_load_t *l = ctx;
    (void)name;
    if (k == GW_OPCUA_TRUST_UNKNOWN) /* refused by the configuration's check */
        return true;
    if (l->ncert + l->ncrl == GW_OPCUA_TRUST_MAX)
        return false;
    UA_ByteString *to = k == GW_OPCUA_TRUST_CERT ? &l->cert[l->ncert++] : &l->crl[l->ncrl++];
    l->ok = ua_pem_load(path, to, l->err, l->errlen);
    if (!l->ok)
        *to = UA_BYTESTRING_NULL;
    return l->ok;
}

/* trust_dir's certificates and revocation lists as the server's trust
 * list, for secure channels and sessions alike. */
static bool set_trust(const ua_t *t, UA_ServerConfig *c, char *err, size_t errlen)
{
    static trust_load_t l; /* 64 byte strings each: not on the stack */
    memset(&l, 0, sizeof l);
    l.err = err;
    l.errlen = errlen;
    l.ok = true;
    if (!gw_opcua_trust_each(t->cfg.trust_dir, trust_load, &l)) {
        snprintf(err, errlen, "trust_dir %s: %s", t->cfg.trust_dir, strerror(errno));
        return false;
    }
    UA_StatusCode st = UA_STATUSCODE_GOOD;
    if (l.ok) {
        c->secureChannelPKI.clear(&c->secureChannelPKI);
        st = UA_CertificateVerification_Trustlist(&c->secureChannelPKI, l.cert, l.ncert, NULL,
                                                  0, l.crl, l.ncrl);
        c->sessionPKI.clear(&c->sessionPKI);
        if (st == UA_STATUSCODE_GOOD)
            st = UA_CertificateVerification_Trustlist(&c->sessionPKI, l.cert, l.ncert, NULL, 0,
                                                      l.crl, l.ncrl);
        if (st != UA_STATUSCODE_GOOD)
            snprintf(err, errlen, "trust_dir %s: %s (a certificate or revocation list that "
                     "does not parse?)", t->cfg.trust_dir, UA_StatusCode_name(st));
    }
    for (size_t i = 0; i < l.ncert; i++)
        UA_ByteString_clear(&l.cert[i]);
    for (size_t i = 0; i < l.ncrl; i++)
        UA_ByteString_clear(&l.crl[i]);
    return l.ok && st == UA_STATUSCODE_GOOD;
}

/* A file's part of trust_digest: its name, size and times. */
static bool trust_hash(void *ctx, const char *path, const char *name, gw_opcua_trust_kind_t k)
{
    uint64_t *h = ctx, part = 1469598103934665603ull; /* FNV-1a */
    struct stat st;
    (void)k;
    for (const char *p = name; *p != '\0'; p++)
        part = (part ^ (uint8_t)*p) * 1099511628211ull;
    if (stat(path, &st) == 0)
        part ^= (uint64_t)st.st_size * 31u ^ (uint64_t)st.st_mtim.tv_sec * 1000003u ^
                (uint64_t)st.st_mtim.tv_nsec;
    *h ^= part * 1099511628211ull; /* the order readdir gives does not count */
    return true;
}

/* What trust_dir holds, as a digest of its files' names, sizes and times
 * (0: no trust_dir): a reload that finds another builds a new server. */
static uint64_t trust_digest(const char *dir)
{
    uint64_t h = 1469598103934665603ull;
    return dir[0] != '\0' && gw_opcua_trust_each(dir, trust_hash, &h) ? h : 0;
}

/* The security policies and their endpoints, the users. */
static bool set_security(ua_t *t, UA_ServerConfig *c, char *err, size_t errlen)
{
    UA_ByteString cert = UA_BYTESTRING_NULL, key = UA_BYTESTRING_NULL;
    UA_StatusCode st = UA_STATUSCODE_GOOD;
    if (t->cfg.cert_file[0] != '\0' &&
        (!ua_pem_load(t->cfg.cert_file, &cert, err, errlen) ||
         !ua_pem_load(t->cfg.key_file, &key, err, errlen))) {
        UA_ByteString_clear(&cert);
        return false;
    }
    const UA_ByteString *cp = cert.length > 0 ? &cert : NULL;
    unsigned p = t->cfg.policies;
    /* None as a policy always, as an endpoint only when configured: a
     * client discovers the endpoints (GetEndpoints) over a None channel,
     * the one service open62541 serves on a policy without an endpoint */
    st |= UA_ServerConfig_addSecurityPolicyNone(c, cp);
    if (p & GW_OPCUA_POLICY_BASIC256SHA256)
        st |= UA_ServerConfig_addSecurityPolicyBasic256Sha256(c, &cert, &key);
    if (p & GW_OPCUA_POLICY_AES128)
        st |= UA_ServerConfig_addSecurityPolicyAes128Sha256RsaOaep(c, &cert, &key);
    if (p & GW_OPCUA_POLICY_AES256)
        st |= UA_ServerConfig_addSecurityPolicyAes256Sha256RsaPss(c, &cert, &key);
    if (key.data != NULL)
        memset(key.data, 0, key.length); /* the private key: not left in freed memory */
    UA_ByteString_clear(&key);
    UA_ByteString_clear(&cert);
    /* The users before the endpoints, which copy their token policies.
     * A user name policy is offered only with a list of logins: one that
     * the callback (auth_file) answers for instead. */
    bool auth = t->cfg.auth_file[0] != '\0';
    UA_UsernamePasswordLogin stand_in = {UA_STRING_STATIC("auth_file"), UA_STRING_STATIC("")};
    if (st == UA_STATUSCODE_GOOD)
        st = UA_AccessControl_defaultWithLoginCallback(c, !auth, NULL, auth ? 1 : 0, &stand_in,
                                                       ua_login, t);
    if (st == UA_STATUSCODE_GOOD)
        drop_x509_tokens(&c->accessControl);
    if (st == UA_STATUSCODE_GOOD && t->cfg.trust_dir[0] != '\0' &&
        !set_trust(t, c, err, errlen))
        return false;
    if (st == UA_STATUSCODE_GOOD && (p & GW_OPCUA_POLICY_SECURE))
        st = UA_ServerConfig_addAllSecureEndpoints(c);
    if (st == UA_STATUSCODE_GOOD && (p & GW_OPCUA_POLICY_NONE))
        st = UA_ServerConfig_addEndpoint(c, UA_STRING(UA_POLICY_NONE_URI),
                                         UA_MESSAGESECURITYMODE_NONE);
    if (st != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "security policies: %s (cert_file, key_file)",
                 UA_StatusCode_name(st));
        return false;
    }
    return true;
}

/* What one client may ask of the daemon's loop at once. open62541 runs a
 * request whole, in the loop, and by default limits neither a message's
 * size nor the nodes of a call: one Read of 100000 nodes held the loop
 * some 30 ms (robot packets wait meanwhile); a message of any size was
 * taken in and decrypted before any login; a client that never
 * acknowledged its notifications grew their queue without end. Clients
 * read the limits (Server/ServerCapabilities/OperationLimits) and split
 * their calls, or get BadTooManyOperations. */
static void set_limits(const ua_t *t, UA_ServerConfig *c)
{
    c->tcpMaxMsgSize = UA_MAX_MESSAGE;
    c->maxNodesPerRead = c->maxNodesPerWrite = c->maxNodesPerBrowse = UA_MAX_PER_CALL;
    c->maxNodesPerRegisterNodes = c->maxNodesPerTranslateBrowsePathsToNodeIds = UA_MAX_PER_CALL;
    c->maxNodesPerMethodCall = c->maxNodesPerNodeManagement = UA_MAX_PER_CALL;
    c->maxMonitoredItemsPerCall = UA_MAX_PER_CALL;
    c->maxReferencesPerNode = UA_MAX_PER_CALL; /* more: a continuation point */
    c->maxMonitoredItems = t->cfg.max_monitored_items;
    c->maxRetransmissionQueueSize = UA_MAX_RETRANSMIT;
    c->maxPublishReqPerSession = 2u * t->cfg.max_subscriptions;
}

static bool set_config(ua_t *t, UA_ServerConfig *c, char *err, size_t errlen)
{
    char url[128], host[80];
    memset(c, 0, sizeof *c);
    c->logging = &t->logger;
    if (UA_ServerConfig_setBasics_withPort(c, t->cfg.port) != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "cannot configure the server");
        return false;
    }
    if (!set_security(t, c, err, errlen))
        return false;
    snprintf(url, sizeof url, "opc.tcp://%s:%u", t->cfg.listen, (unsigned)t->cfg.port);
    UA_Array_delete(c->serverUrls, c->serverUrlsSize, &UA_TYPES[UA_TYPES_STRING]);
    c->serverUrls = UA_String_new();
    c->serverUrlsSize = c->serverUrls != NULL ? 1 : 0;
    if (c->serverUrls != NULL)
        *c->serverUrls = UA_String_fromChars(url);
    if (gethostname(host, sizeof host) != 0)
        snprintf(host, sizeof host, "localhost");
    host[sizeof host - 1] = '\0';
    char uri[sizeof t->cfg.application_uri + 8];
    if (t->cfg.application_uri[0] != '\0')
        snprintf(uri, sizeof uri, "%s", t->cfg.application_uri);
    else
        snprintf(uri, sizeof uri, "urn:drgate:%.80s:drgatewayd", host);
    UA_ApplicationDescription *ad = &c->applicationDescription;
    UA_String_clear(&ad->applicationUri);
    ad->applicationUri = UA_String_fromChars(uri);
    UA_LocalizedText_clear(&ad->applicationName);
    ad->applicationName = UA_LOCALIZEDTEXT_ALLOC("en", t->cfg.application_name);
    UA_String_clear(&ad->productUri);
    ad->productUri = UA_String_fromChars("urn:drgate:drgatewayd");
    /* the endpoints carry the description as it is now */
    for (size_t i = 0; i < c->endpointsSize; i++) {
        UA_ApplicationDescription_clear(&c->endpoints[i].server);
        (void)UA_ApplicationDescription_copy(ad, &c->endpoints[i].server);
    }
    c->tcpReuseAddr = true;
    /* room for as many sessions in the making as logged in (ua_sessions.h) */
    c->maxSessions = (UA_UInt16)(2u * t->cfg.max_sessions);
    c->maxSecureChannels = (UA_UInt16)(2u * t->cfg.max_sessions + 2u);
    c->maxSubscriptionsPerSession = t->cfg.max_subscriptions;
    set_limits(t, c);
    double ms = fastest_rpi_ms(t->env->cfg);
    c->samplingIntervalLimits.min = ms;
    c->publishingIntervalLimits.min = ms;
    return true;
}

/* The descriptors open now, as bits (not the one that reads them, whose
 * number a later descriptor may take). */
static void fd_snapshot(uint8_t *bits)
{
    memset(bits, 0, UA_FD_SCAN / 8);
    DIR *d = opendir("/proc/self/fd");
    if (d == NULL)
        return;
    int self = dirfd(d);
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        char *end;
        long fd = strtol(e->d_name, &end, 10);
        if (*end == '\0' && fd >= 0 && fd < UA_FD_SCAN && fd != self)
            bits[fd / 8] |= (uint8_t)(1u << (fd % 8));
    }
    closedir(d);
}

/* The one epoll descriptor opened since `before`, or -1. */
static int new_epoll_fd(const uint8_t *before)
{
    uint8_t now[UA_FD_SCAN / 8];
    int found = -1, count = 0;
    fd_snapshot(now);
    for (int fd = 0; fd < UA_FD_SCAN; fd++) {
        if (!(now[fd / 8] & (1u << (fd % 8))) || (before[fd / 8] & (1u << (fd % 8))))
            continue;
        char link[64], target[64];
        snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
        ssize_t n = readlink(link, target, sizeof target - 1);
        if (n <= 0)
            continue;
        target[n] = '\0';
        if (strcmp(target, "anon_inode:[eventpoll]") == 0) {
            found = fd;
            count++;
        }
    }
    return count == 1 ? found : -1;
}

/* ---- the server's clock ---------------------------------------------------------------
 *
 * A subscription publishes, and samples what it monitors, from a cyclic
 * callback of the server's event loop, each at a phase of its own: ten
 * clients at the RPI were ten more wake-ups of the daemon per RPI, each
 * sampling values up to an RPI old, and each client's next Publish request
 * one more. So the side runs the server itself, on the robots' time:
 *
 * - The callbacks whose interval is a multiple of the fastest robot's RPI
 *   are the side's (the event loop's functions that add, change and remove
 *   cyclic callbacks are replaced by ours: the UA_EventLoop plugin
 *   interface is a table of function pointers; every other callback stays
 *   with the loop). They run when a burst of robot packets has gone into
 *   the images and they are due within half an RPI, and on their own time
 *   only when no packet comes (half an RPI after it, so that a packet late
 *   by less still takes them along).
 * - A robot's burst has ended when every T->O assembly of its plan has
 *   come (or a quarter RPI after the first of it), in the first turn of
 *   the daemon's loop that reads no more robot data: the turn that read it
 *   sends its O->T packets first.
 * - While packets come, the server's descriptor is out of the daemon's
 *   loop once a request has woken it: requests (a client's next Publish
 *   among them) are served with the next burst, within UA_DEFER_MAX_US at
 *   the latest; when no packet comes for that long it is watched again.
 *
 * The replaced functions are given the event loop only: ua_loops maps it
 * to its side (one server at a time; two while a reload replaces it). */

#define UA_LOOPS 2
#define UA_DEFER_MAX_US 15000u /* a request waits for the next burst this long at most */
#define UA_CYC_MAX_MS 3.6e6    /* longer intervals stay with the event loop */

static struct {
    UA_EventLoop *el;
    ua_t *t;
} ua_loops[UA_LOOPS];

static ua_t *loop_side(const UA_EventLoop *el)
{
    for (unsigned i = 0; i < UA_LOOPS; i++)
        if (ua_loops[i].el == el && el != NULL)
            return ua_loops[i].t;
    return NULL;
}

static uint64_t ms_to_us(UA_Double ms)
{
    return (uint64_t)(ms * 1000.0 + 0.5);
}

/* An interval the side runs in step with the packets. */
static bool cyc_aligned(const ua_t *t, UA_Double ms)
{
    uint64_t us = ms_to_us(ms);
    return t->rpi_us > 0 && us >= t->rpi_us && us % t->rpi_us == 0;
}

/* When c runs at the latest without packets. */
static uint64_t cyc_due(const ua_t *t, const ua_cyclic_t *c)
{
    return c->aligned ? c->next_us + t->rpi_us / 2u : c->next_us;
}

static void cyc_compact(ua_t *t)
{
    size_t kept = 0;
    for (size_t i = 0; i < t->cyc_count; i++)
        if (t->cyc[i].cb != NULL)
            t->cyc[kept++] = t->cyc[i];
    t->cyc_count = kept;
}

static ua_cyclic_t *cyc_find(ua_t *t, UA_UInt64 id)
{
    for (size_t i = 0; i < t->cyc_count; i++)
        if (t->cyc[i].id == id && t->cyc[i].cb != NULL)
            return &t->cyc[i];
    return NULL;
}

static UA_StatusCode cyc_add(UA_EventLoop *el, UA_Callback cb, void *app, void *data,
                             UA_Double ms, UA_DateTime *base, UA_TimerPolicy policy,
                             UA_UInt64 *id)
{
    ua_t *t = loop_side(el);
    if (t == NULL)
        return UA_STATUSCODE_BADINTERNALERROR;
    /* a base time asks for a phase of its own */
    if (cb == NULL || base != NULL || !(ms > 0.0 && ms < UA_CYC_MAX_MS) || !cyc_aligned(t, ms))
        return t->el_add(el, cb, app, data, ms, base, policy, id);
    if (t->cyc_count == t->cyc_cap) {
        size_t cap = t->cyc_cap > 0 ? t->cyc_cap * 2u : 16u;
        ua_cyclic_t *more = realloc(t->cyc, cap * sizeof *more);
        if (more == NULL)
            return UA_STATUSCODE_BADOUTOFMEMORY;
        t->cyc = more;
        t->cyc_cap = cap;
    }
    ua_cyclic_t *c = &t->cyc[t->cyc_count++];
    *c = (ua_cyclic_t){UA_CYC_ID | ++t->cyc_ids, cb, app, data, ms_to_us(ms), 0, true};
    c->next_us = ev_now_us() + c->interval_us;
    if (id != NULL)
        *id = c->id;
    return UA_STATUSCODE_GOOD;
}

static UA_StatusCode cyc_modify(UA_EventLoop *el, UA_UInt64 id, UA_Double ms, UA_DateTime *base,
                                UA_TimerPolicy policy)
{
    ua_t *t = loop_side(el);
    if (t == NULL)
        return UA_STATUSCODE_BADINTERNALERROR;
    if (!(id & UA_CYC_ID))
        return t->el_modify(el, id, ms, base, policy);
    ua_cyclic_t *c = cyc_find(t, id);
    if (c == NULL)
        return UA_STATUSCODE_BADNOTFOUND;
    if (!(ms > 0.0 && ms < UA_CYC_MAX_MS))
        return UA_STATUSCODE_BADINTERNALERROR;
    /* the event loop's rule without a base time: the next run an interval
     * from now; an interval that is no multiple of the RPI keeps it */
    c->interval_us = ms_to_us(ms);
    c->next_us = ev_now_us() + c->interval_us;
    c->aligned = cyc_aligned(t, ms);
    return UA_STATUSCODE_GOOD;
}

static void cyc_remove(UA_EventLoop *el, UA_UInt64 id)
{
    ua_t *t = loop_side(el);
    if (t == NULL)
        return;
    if (!(id & UA_CYC_ID)) {
        t->el_remove(el, id);
        return;
    }
    ua_cyclic_t *c = cyc_find(t, id);
    if (c == NULL)
        return;
    c->cb = NULL; /* cyc_run may be on its way through the table */
    if (!t->cyc_running)
        cyc_compact(t);
}

/* The side's callbacks that are due: with a burst of packets, the aligned
 * ones due within half an RPI (and the next run an interval from now,
 * which keeps them in step); else each on its own time. A callback may add
 * or remove others (the table may move). How many ran. */
static unsigned cyc_run(ua_t *t, uint64_t now, bool burst)
{
    unsigned ran = 0;
    t->cyc_running = true;
    for (size_t i = 0; i < t->cyc_count; i++) {
        ua_cyclic_t *c = &t->cyc[i];
        if (c->cb == NULL)
            continue;
        bool early = burst && c->aligned && c->next_us <= now + t->rpi_us / 2u;
        if (!early && cyc_due(t, c) > now)
            continue;
        c->next_us += c->interval_us;
        if (early || c->next_us <= now)
            c->next_us = now + c->interval_us;
        UA_Callback cb = c->cb;
        void *app = c->app, *data = c->data;
        cb(app, data);
        ran++;
    }
    t->cyc_running = false;
    cyc_compact(t);
    return ran;
}

static uint64_t cyc_deadline(const ua_t *t)
{
    uint64_t d = UINT64_MAX;
    for (size_t i = 0; i < t->cyc_count; i++) {
        uint64_t x = cyc_due(t, &t->cyc[i]);
        if (x < d)
            d = x;
    }
    return d;
}

/* The server's event loop with our cyclic callbacks (false: the table of
 * loops is full, and the loop keeps them all). */
static bool hook_loop(ua_t *t)
{
    UA_EventLoop *el = UA_Server_getConfig(t->server)->eventLoop;
    for (unsigned i = 0; i < UA_LOOPS; i++) {
        if (ua_loops[i].el != NULL)
            continue;
        ua_loops[i].el = el;
        ua_loops[i].t = t;
        t->el = el;
        t->el_add = el->addCyclicCallback;
        t->el_modify = el->modifyCyclicCallback;
        t->el_remove = el->removeCyclicCallback;
        el->addCyclicCallback = cyc_add;
        el->modifyCyclicCallback = cyc_modify;
        el->removeCyclicCallback = cyc_remove;
        return true;
    }
    return false;
}

static void unhook_loop(ua_t *t)
{
    for (unsigned i = 0; i < UA_LOOPS; i++)
        if (ua_loops[i].t == t) {
            ua_loops[i].el = NULL;
            ua_loops[i].t = NULL;
        }
    free(t->cyc);
    t->cyc = NULL;
    t->cyc_count = t->cyc_cap = 0;
}

/* The server's callbacks that are due and its sockets that are ready;
 * then its next cyclic time, to the microsecond. (run_iterate's return
 * value is in whole milliseconds, rounded down: a callback due in 0.9 ms
 * would be "due now" and the loop would spin until it is.) */
static void iterate(ua_t *t)
{
    (void)UA_Server_run_iterate(t->server, false);
    UA_EventLoop *el = UA_Server_getConfig(t->server)->eventLoop;
    UA_DateTime left = el->nextCyclicTime(el) - el->dateTime_nowMonotonic(el);
    uint64_t cap_us = (t->polled ? UA_POLL_MS : UA_WAIT_MAX_MS) * 1000u;
    uint64_t us = left <= 0 ? 0 : ((uint64_t)left + UA_DATETIME_USEC - 1) / UA_DATETIME_USEC;
    uint64_t now = ev_now_us();
    t->next_us = now + (us < cap_us ? us : cap_us);
    uint64_t sweep = ua_sessions_sweep(&t->sessions, t->server, now);
    if (sweep < t->next_us)
        t->next_us = sweep;
}

static uint64_t defer_us(const ua_t *t)
{
    uint64_t us = t->rpi_us * 3u / 2u;
    return us < UA_DEFER_MAX_US ? us : UA_DEFER_MAX_US;
}

/* The server's turn: the side's callbacks (publishing, with a client's
 * Publish request that came before), then the requests that came since
 * (a Publish request for a subscription that had none is answered at
 * once, with what was just sampled: a client that keeps one request out
 * gets each burst's values with that burst, not one burst late). */
static void serve(ua_t *t, uint64_t now, bool burst)
{
    /* A burst with nothing for the server (no callback of its ran, no
     * request waits, its own time has not come): its event loop is not
     * turned, which would only look at its sockets and timers (an idle
     * server: 100 turns a second at RPI 10 ms for nothing). */
    t->serving = true;
    bool idle = cyc_run(t, now, burst) == 0 && burst && !t->muted && now < t->next_us;
    if (!idle)
        iterate(t);
    t->serving = false;
    if (!t->muted)
        return;
    if (burst) {
        t->run_by = now + defer_us(t);
    } else if (ev_watch(t->env->epfd, &t->ev, t->ev.fd, EPOLLIN)) {
        t->muted = false; /* no packets: requests wake the loop again */
    } else {
        t->run_by = now + defer_us(t); /* tried again then */
    }
}

static void on_ready(void *obj, uint32_t events)
{
    ua_t *t = obj;
    uint64_t now = ev_now_us();
    (void)events;
    if (t->aside) /* (muted then: an error or hang-up event only) */
        return;
    /* packets come: the request waits for the next burst */
    if (t->burst_us != 0 && now - t->burst_us < defer_us(t) &&
        ev_watch(t->env->epfd, &t->ev, t->ev.fd, 0)) {
        t->muted = true;
        t->run_by = now + defer_us(t);
        return;
    }
    serve(t, now, false);
}

/* No object per session in the address space (nor, below it, per
 * subscription). open62541 makes one for each CreateSession, before any
 * login: a SessionDiagnosticsObjectType instance, some 60 nodes built and
 * later deleted in the loop, 1-2 ms each time; a flood of anonymous
 * CreateSession requests thus held the loop (bench-opcua (d): Modbus p99
 * 0.7-1.0 ms with them, 0.2-0.5 ms without). Without the type's children
 * the object it makes is one node. The same figures stay readable, every
 * session's in one place: Server/ServerDiagnostics/SessionsDiagnosticsSummary
 * SessionDiagnosticsArray and SessionSecurityDiagnosticsArray, and
 * ServerDiagnostics' SubscriptionDiagnosticsArray (docs/opcua.md). */
static bool drop_session_objects(UA_Server *s, char *err, size_t errlen)
{
    static const UA_UInt32 child[] = {
        UA_NS0ID_SESSIONDIAGNOSTICSOBJECTTYPE_SESSIONDIAGNOSTICS,
        UA_NS0ID_SESSIONDIAGNOSTICSOBJECTTYPE_SESSIONSECURITYDIAGNOSTICS,
        UA_NS0ID_SESSIONDIAGNOSTICSOBJECTTYPE_SUBSCRIPTIONDIAGNOSTICSARRAY};
    for (size_t i = 0; i < sizeof child / sizeof child[0]; i++) {
        UA_StatusCode st = UA_Server_deleteNode(s, UA_NODEID_NUMERIC(0, child[i]), true);
        if (st != UA_STATUSCODE_GOOD && st != UA_STATUSCODE_BADNODEIDUNKNOWN) {
            snprintf(err, errlen, "cannot leave out the sessions' diagnostics objects: %s",
                     UA_StatusCode_name(st));
            return false;
        }
    }
    return true;
}

/* The server up and listening, in the loop. */
static bool ua_start(ua_t *t, char *err, size_t errlen)
{
    uint8_t before[UA_FD_SCAN / 8];
    UA_ServerConfig c;
    fd_snapshot(before);
    t->trust = trust_digest(t->cfg.trust_dir);
    if (!set_config(t, &c, err, errlen)) {
        UA_ServerConfig_clean(&c);
        return false;
    }
    t->server = UA_Server_newWithConfig(&c);
    if (t->server == NULL) {
        snprintf(err, errlen, "cannot create the server");
        return false;
    }
    UA_ServerConfig *sc = UA_Server_getConfig(t->server);
    t->crypto = ua_crypto_new(crypto_wait, t, err, errlen);
    if (t->crypto == NULL ||
        !ua_crypto_wrap(t->crypto, sc->securityPolicies, sc->securityPoliciesSize, err, errlen))
        return false;
    if (!hook_loop(t))
        gw_log(GW_LOG_WARNING, "opcua: subscriptions keep the server's own time (not the "
               "robots' packets)");
    if (!drop_session_objects(t->server, err, errlen) ||
        !ua_sessions_hook(&t->sessions, t->server, t->cfg.max_sessions, err, errlen))
        return false;
    t->ns = UA_Server_addNamespace(t->server, UA_NS_FLAT);
    size_t n = (size_t)t->robot_count * dr_leaf_count();
    t->nodes = calloc(n > 0 ? n : 1, sizeof *t->nodes);
    t->view = calloc(t->robot_count > 0 ? (size_t)t->robot_count * UA_VIEW_NODES : 1,
                     sizeof *t->view);
    if (t->nodes == NULL || t->view == NULL) {
        snprintf(err, errlen, "out of memory");
        return false;
    }
    t->building = true;
    bool built = add_flat_view(t, err, errlen) && add_robotics_view(t, err, errlen);
    t->building = false;
    if (!built)
        return false;
    UA_StatusCode st = UA_Server_run_startup(t->server);
    if (st != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "cannot listen on %s:%u: %s", t->cfg.listen, (unsigned)t->cfg.port,
                 UA_StatusCode_name(st));
        return false;
    }
    t->started = true;
    iterate(t); /* the event loop makes its epoll set when it first runs */
    int fd = new_epoll_fd(before);
    t->ev.fn = on_ready;
    t->ev.obj = t;
    t->ev.fd = -1;
    if (fd < 0 || !ev_watch(t->env->epfd, &t->ev, fd, EPOLLIN)) {
        t->polled = true;
        gw_log(GW_LOG_WARNING, "opcua: the server's event loop descriptor was not found: polling "
               "it every %u ms", UA_POLL_MS);
    }
    iterate(t);
    char pol[128];
    gw_log(GW_LOG_INFO, "opcua: listening on opc.tcp://%s:%u (%s%s)", t->cfg.listen,
           (unsigned)t->cfg.port, gw_opcua_policies_text(t->cfg.policies, pol, sizeof pol),
           t->cfg.auth_file[0] != '\0' ? ", user names" : ", anonymous");
    return true;
}

static void ua_free(ua_t *t)
{
    if (t == NULL)
        return;
    if (t->server != NULL) {
        ev_unwatch(t->env->epfd, &t->ev);
        if (t->started)
            (void)UA_Server_run_shutdown(t->server);
        UA_Server_delete(t->server);
    }
    ua_sessions_unhook(&t->sessions); /* after the server: closing its sessions calls it */
    ua_crypto_free(t->crypto); /* after the server: its policies call the worker */
    unhook_loop(t);
    free(t->nodes);
    free(t->view);
    gw_auth_free(t->auth);
    gw_auth_free(t->next_auth);
    for (unsigned i = 0; i < UA_LOG_KINDS; i++)
        gw_log_limit_end(&t->ua_log_limit[i]);
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        gw_log_limit_end(&t->write_log[r]);
    gw_log_limit_end(&t->refused_log);
    free(t);
}

/* The T->O assemblies robot r has data of now (a new side, or one a
 * reload made, starts from what the robot has). */
static void seed_seen(ua_t *t)
{
    UA_DateTime now = UA_DateTime_now();
    for (unsigned r = 0; r < t->robot_count; r++) {
        const gw_robot_t *rb = &t->env->robots[r];
        if (rb->link.rx_us == 0)
            continue;
        for (unsigned a = 0; a < DR_ASM_COUNT; a++)
            if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O &&
                gw_robot_reads(&t->env->cfg->robot[r], (dr_asm_t)a)) {
                t->seen[r] |= 1u << a;
                t->at[r][a] = now;
            }
    }
}

/* A side for cfg (env->cfg's robots): NULL with err. */
static ua_t *ua_new(const gw_config_t *cfg, const gw_north_env_t *env, char *err, size_t errlen)
{
    ua_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "opcua: out of memory");
        return NULL;
    }
    t->env = env;
    t->cfg = cfg->side.opcua;
    t->ev.fd = -1;
    t->logger.log = ua_log;
    t->logger.context = t;
    t->loop_thread = pthread_self();
    t->robot_count = cfg->robot_count;
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        snprintf(t->robot_name[r], sizeof t->robot_name[r], "%s", cfg->robot[r].name);
        uint64_t us = (uint64_t)cfg->robot[r].rpi_ms * 1000u;
        if (t->rpi_us == 0 || us < t->rpi_us)
            t->rpi_us = us;
        for (unsigned a = 0; a < DR_ASM_COUNT; a++)
            if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O &&
                gw_robot_reads(&cfg->robot[r], (dr_asm_t)a))
                t->burst_want[r] |= 1u << a;
    }
    return t;
}

/* auth_file's users' logins checker (its worker thread) into *auth;
 * nothing without auth_file. */
static bool load_users(const ua_t *t, gw_auth_t **auth, char *err, size_t errlen)
{
    static gw_users_t users; /* 8 KiB; gw_auth_new keeps its own copy */
    char why[400];
    *auth = NULL;
    if (t->cfg.auth_file[0] == '\0')
        return true;
    if (!gw_passwd_load(t->cfg.auth_file, &users, why, sizeof why)) {
        snprintf(err, errlen, "opcua: auth_file %s", why);
        return false;
    }
    *auth = gw_auth_new(&users, crypt_r, "opcua", "user", err, errlen);
    return *auth != NULL;
}

/* ---- the side's operations ------------------------------------------------------------ */

static void *op_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    char why[400];
    ua_t *t = ua_new(env->cfg, env, err, errlen);
    if (t == NULL || !t->cfg.enabled)
        return t;
    if (!load_users(t, &t->auth, err, errlen)) {
        ua_free(t);
        return NULL;
    }
    if (!ua_start(t, why, sizeof why)) {
        snprintf(err, errlen, "opcua: %s", why);
        ua_free(t);
        return NULL;
    }
    seed_seen(t);
    return t;
}

/* Every key of [opcua] the same (the struct compared member by member:
 * its padding and the text after a string's end are not the keys'). */
static bool same_section(const gw_opcua_config_t *a, const gw_opcua_config_t *b)
{
    return a->enabled == b->enabled && strcmp(a->listen, b->listen) == 0 &&
           a->port == b->port && strcmp(a->application_uri, b->application_uri) == 0 &&
           strcmp(a->application_name, b->application_name) == 0 &&
           a->policies == b->policies && strcmp(a->auth_file, b->auth_file) == 0 &&
           strcmp(a->cert_file, b->cert_file) == 0 && strcmp(a->key_file, b->key_file) == 0 &&
           strcmp(a->trust_dir, b->trust_dir) == 0 &&
           a->max_sessions == b->max_sessions && a->max_subscriptions == b->max_subscriptions &&
           a->max_monitored_items == b->max_monitored_items &&
           a->writes == b->writes && a->insecure == b->insecure;
}

static bool same_robots(const ua_t *t, const gw_config_t *cfg)
{
    if (cfg->robot_count != t->robot_count)
        return false;
    for (unsigned r = 0; r < cfg->robot_count; r++)
        if (strcmp(cfg->robot[r].name, t->robot_name[r]) != 0 ||
            cfg->robot[r].rpi_ms != t->env->cfg->robot[r].rpi_ms)
            return false;
    return true;
}

/* A reload: the same section and robots keep the server (its clients
 * stay); anything else builds a new one at commit, whose files are read
 * here so that a bad one refuses the reload. */
static gw_north_reload_t op_prepare(void *self, const gw_config_t *next, const gw_north_env_t *env,
                                    void **out, char *err, size_t errlen)
{
    ua_t *t = self;
    if (same_section(&next->side.opcua, &t->cfg) && same_robots(t, next) &&
        trust_digest(t->cfg.trust_dir) == t->trust) {
        /* the same server; auth_file read again (its users may change) */
        gw_auth_free(t->next_auth);
        if (!load_users(t, &t->next_auth, err, errlen))
            return GW_NORTH_REFUSED;
        *out = t;
        return GW_NORTH_OK;
    }
    ua_t *n = ua_new(next, env, err, errlen);
    if (n == NULL)
        return GW_NORTH_REFUSED;
    if (n->cfg.enabled && !load_users(n, &n->auth, err, errlen)) {
        ua_free(n);
        return GW_NORTH_REFUSED;
    }
    *out = n;
    return GW_NORTH_OK;
}

static void op_abort(void *self, void *out)
{
    ua_t *t = self;
    if (out != self)
        ua_free(out);
    gw_auth_free(t->next_auth);
    t->next_auth = NULL;
}

static void *op_commit(void *self, void *out, const gw_north_env_t *env)
{
    ua_t *t = self, *n = out;
    char why[400];
    if (n == t) {
        if (t->next_auth != NULL) { /* the users as the file says now; logins checked again */
            gw_auth_free(t->auth);
            t->auth = t->next_auth;
            t->next_auth = NULL;
        }
        return t;
    }
    ua_free(t); /* its port is the new one's, maybe */
    n->env = env;
    if (n->cfg.enabled) {
        if (!ua_start(n, why, sizeof why)) {
            gw_log(GW_LOG_ERROR, "opcua: %s", why);
            ua_free(n);
            return NULL;
        }
        seed_seen(n);
    }
    return n;
}

static void op_tick(void *self, uint64_t now)
{
    ua_t *t = self;
    if (t->server == NULL)
        return;
    if (t->fresh) {
        if (t->data_seq != t->tick_seq) { /* read in this turn: O->T first */
            t->tick_seq = t->data_seq;
            return;
        }
        if (!t->complete && now < t->fresh_us + t->rpi_us / 4u)
            return; /* the rest of the burst is on its way */
        t->fresh = t->complete = false;
        t->burst_us = now;
        serve(t, now, true);
        return;
    }
    if (t->muted && now >= t->run_by)
        serve(t, now, false);
    else if (now >= t->next_us || now >= cyc_deadline(t))
        serve(t, now, false);
}

static uint64_t op_deadline(const void *self)
{
    const ua_t *t = self;
    if (t->server == NULL)
        return UINT64_MAX;
    if (t->fresh) /* the next turn, without waiting, or the rest of the burst: op_tick */
        return t->complete ? 0 : t->fresh_us + t->rpi_us / 4u;
    uint64_t d = cyc_deadline(t);
    if (t->next_us < d)
        d = t->next_us;
    if (t->muted && t->run_by < d)
        d = t->run_by;
    return d;
}

static void op_on_data(void *self, unsigned robot, dr_asm_t a)
{
    ua_t *t = self;
    if (t->server == NULL || robot >= t->robot_count || a >= DR_ASM_COUNT)
        return;
    t->seen[robot] |= 1u << a;
    t->at[robot][a] = UA_DateTime_now();
    if (!t->fresh)
        t->fresh_us = ev_now_us();
    t->fresh = true;
    t->data_seq++;
    /* a burst is whole when every T->O assembly of the robot's plan has
     * come: one that came in two reads is served once, after the second */
    t->burst_got[robot] |= 1u << a;
    if ((t->burst_got[robot] & t->burst_want[robot]) == t->burst_want[robot]) {
        t->complete = true;
        t->burst_got[robot] = 0;
    }
}

static void op_on_link(void *self, unsigned robot, bool up)
{
    (void)self;
    (void)robot;
    (void)up; /* read from the link when a value is read */
}

static void op_on_fault(void *self, unsigned robot, bool latched)
{
    (void)self;
    (void)robot;
    (void)latched;
}

static void op_refresh(void *self)
{
    (void)self;
}

static void op_safe(void *self)
{
    (void)self; /* holds no output of its own */
}

static void op_free(void *self)
{
    ua_free(self);
}

static void op_report(const void *self, gw_json_t *j)
{
    const ua_t *t = self;
    char text[512]; /* every counter at its widest: 8 numbers, some 180 bytes of names */
    if (!t->cfg.enabled)
        return;
    gw_json_str(j, "\"opcua\":{\"endpoint\":");
    snprintf(text, sizeof text, "opc.tcp://%s:%u", t->cfg.listen, (unsigned)t->cfg.port);
    gw_json_quote(j, text, strlen(text));
    snprintf(text, sizeof text,
             ",\"reads\":%llu,\"writes\":{\"enabled\":%s,\"accepted\":%llu,"
             "\"refused\":%llu},\"logins\":{\"accepted\":%llu,\"refused\":%llu},"
             "\"sessions\":{\"logged_in\":%u,\"refused_full\":%llu,"
             "\"closed_without_login\":%llu},\"crypto_ops\":%llu}",
             t->reads, t->cfg.writes ? "true" : "false", t->writes, t->refused, t->logins,
             t->logins_refused, ua_sessions_logged_in(&t->sessions), t->sessions.refused, t->sessions.closed,
             ua_crypto_jobs(t->crypto));
    gw_json_str(j, text);
}

static void op_summary(const void *self, gw_side_summary_t *s)
{
    const ua_t *t = self;
    if (!t->cfg.enabled)
        return;
    snprintf(s->label, sizeof s->label, "OPC UA");
    snprintf(s->line, sizeof s->line, "opc.tcp://%s:%u, %llu read(s), %llu write(s), %llu refused",
             t->cfg.listen, (unsigned)t->cfg.port, t->reads, t->writes, t->refused);
    snprintf(s->brief, sizeof s->brief, "OPC UA :%u", (unsigned)t->cfg.port);
}

const gw_north_ops_t gw_north_opcua = {
    .name = "opcua",
    .create = op_create,
    .prepare = op_prepare,
    .abort = op_abort,
    .commit = op_commit,
    .tick = op_tick,
    .deadline = op_deadline,
    .on_data = op_on_data,
    .on_link = op_on_link,
    .on_fault = op_on_fault,
    .refresh = op_refresh,
    .safe = op_safe,
    .free = op_free,
    .report = op_report,
    .summary = op_summary,
};
