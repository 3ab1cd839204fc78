/* SPDX-License-Identifier: MIT */
/*
 * MQTT as a northbound side (north.h): the robots' fields published to a
 * broker, plant writes taken from it ([mqtt], docs/mqtt.md). With several
 * `servers`, connected to one at a time: the next one after a lost
 * connection, a failed attempt or (Sparkplug) the primary host's offline
 * there (docs/mqtt.md "Several brokers"); host names are looked up by
 * resolve.c without blocking.
 *
 * libmosquitto runs without its thread: its socket sits in the daemon's
 * epoll set (readable: mosquitto_loop_read, writable while it has
 * something to send: mosquitto_loop_write), keepalive and reconnection
 * are driven by tick(). A broker that is slow or gone never blocks the
 * loop: nothing is published while libmosquitto still has bytes to send,
 * so what changes meanwhile is coalesced into the next publication (the
 * fields are compared with what was last published, not with the last
 * sample), and QoS 1/2 messages in flight are bounded.
 *
 * Topics, under <prefix> = topic_prefix:
 *   <prefix>/status               "online" / "offline" (the Last Will), retained
 *   <prefix>/<robot>/state        "up" / "down" / "down: <cause>": the robot's
 *                                 link, retained
 *   <prefix>/<robot>/meta         {"path": {"type", "unit", "dir"}, ...}, retained
 *   <prefix>/<robot>/data         {"time", "quality", "age_ms", "values":
 *                                 {"path": value, ...}, "names": {...}}: what
 *                                 changed; all fields after a (re)connect
 *                                 or link up
 *   <prefix>/<robot>/snapshot     the same with every field, retained: what a
 *                                 late subscriber starts from; again at most
 *                                 once a second while data changes
 *   <prefix>/<robot>/set/<path>   plant writes (writes = yes): the value as text
 *   <prefix>/<robot>/error        {"topic", "payload", "error"}: a refused write
 *
 * A robot that a reload removes (or renames), and every robot of a prefix
 * that a reload changes, is retired: its state says "down: removed from
 * the configuration", its retained meta and snapshot are cleared.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <mosquitto.h>

#include "common/ev.h"
#include "drgate/text.h"
#include "core/json.h"
#include "core/log.h"
#include "mqtt/deadband.h"
#include "mqtt/mqtt_lib.h"
#include "mqtt/resolve.h"
#include "mqtt/sparkplug.h"
#include "core/north.h"
#include "core/report.h"

#define MQ_BACKOFF_MIN_US 500000u    /* first reconnect after 0.5 s ... */
#define MQ_BACKOFF_MAX_US 30000000u  /* ... doubling up to 30 s */
#define MQ_CONNECT_TIMEOUT_US 10000000u /* no CONNACK within 10 s (lookup included): retry */
#define MQ_LOOKUP_POLL_US 20000u     /* a host name's lookup is looked at this often */
#define MQ_LEAVE_US 2000000u         /* NDEATH's PUBACK awaited this long before leaving */
#define MQ_MAX_INFLIGHT 16u          /* QoS 1/2 messages awaiting the broker */
#define MQ_JSON_MAX 65536u           /* the largest payload (meta) is ~30 kB */
#define MQ_SET_MAX 64u               /* a write's value text */
#define MQ_READS_PER_EVENT 64        /* packets read per readiness event */
#define MQ_ERR_QUEUE 32u             /* error replies queued at once */
#define MQ_SNAPSHOT_US 1000000u      /* the retained snapshot at most once a second */
#define MQ_RETIRED "down: removed from the configuration"
#define MQ_BASE_MAX 200u             /* "<prefix>/<robot>" */
#define MQ_GONE_MAX (2u * GW_MAX_ROBOTS) /* robots to retire: a prefix's and removed ones */

/* Why a write was refused: each kind its own log rate limit. */
typedef enum {
    MQ_REF_FIELD,    /* unknown field */
    MQ_REF_PAYLOAD,  /* not a value's text */
    MQ_REF_READONLY, /* a T->O field */
    MQ_REF_VALUE,    /* does not parse or fit */
    MQ_REF_SINGLE,   /* single-writer mode */
    MQ_REF_FAULT,    /* write fault latched */
    MQ_REF_GPIO,     /* a GPIO input's bit */
    MQ_REF_UNSENT,   /* an assembly the connection plan does not send */
    MQ_REF_KINDS
} mq_refusal_t;

typedef struct {
    const gw_north_env_t *env;
    gw_mqtt_config_t cfg; /* a copy: a reload compares the new one with it */
    struct mosquitto *mosq;
    ev_t ev;
    char prefix[160], client_id[80];
    char password[256];
    unsigned server;    /* cfg.server[server]: the broker connected, or being tried */
    char addr[64];      /* its address for this attempt (numeric) */
    gw_mqtt_lookup_t *lookup; /* its name being looked up (connecting, not yet connected) */
    uint64_t host_wait_us; /* Sparkplug: the primary host online by then, or the next server */
    uint64_t leave_us;  /* Sparkplug: leaving this server once NDEATH is acknowledged, or then */
    bool connected;     /* CONNACK accepted */
    bool connecting;    /* a connection is being made */
    uint64_t retry_us;  /* next connection attempt (when neither of the above) */
    uint64_t connect_deadline_us;
    uint64_t backoff_us;
    unsigned inflight;  /* QoS 1/2 publications not yet acknowledged */
    unsigned leaves;    /* dr_leaf_count() */
    gw_mqtt_last_t *last[GW_MAX_ROBOTS]; /* what was last published, by leaf */
    uint16_t *pick;      /* publish_data: the leaves in this message ... */
    double *pick_v;      /* ... and their values */
    bool link[GW_MAX_ROBOTS];
    dr_status_t state_why[GW_MAX_ROBOTS]; /* the cause in the last state published */
    bool state_due[GW_MAX_ROBOTS], meta_due[GW_MAX_ROBOTS], full_due[GW_MAX_ROBOTS];
    bool snap_due[GW_MAX_ROBOTS];        /* data changed since the last snapshot */
    uint64_t next_snap_us[GW_MAX_ROBOTS]; /* the next snapshot, at the earliest */
    bool status_due;
    /* The robots' names as published (the configuration of the last sync):
     * a reload that drops one retires its topics by this name. */
    char pub_name[GW_MAX_ROBOTS][GW_NAME_MAX];
    unsigned pub_count;
    /* Robots still to retire, as "<prefix>/<robot>": removed by a reload
     * that kept this side, or handed over by the side this one replaced
     * (its own retirement may be lost, see retire_for). */
    char gone[MQ_GONE_MAX][MQ_BASE_MAX];
    unsigned gone_count;
    const char *closing;  /* why this side disconnects on purpose (NULL: it does not) */
    char fail_why[160];   /* why the connection attempt failed, once known */
    char down_why[256];   /* why it is not connected, as last logged (mq_report) */
    gw_log_limit_t refused[MQ_REF_KINDS];
    bool data_seen[GW_MAX_ROBOTS]; /* new T->O data since the last scan */
    unsigned asm_seen[GW_MAX_ROBOTS]; /* T->O assemblies received since link up */
    uint64_t up_us[GW_MAX_ROBOTS];    /* when the link came up */
    uint64_t next_pub_us[GW_MAX_ROBOTS];
    unsigned err_queued;   /* error replies given since libmosquitto's queue was empty */
    unsigned long dropped; /* error replies dropped (queue bound) */
    spb_t *spb;     /* payload = sparkplug (sparkplug.h), else NULL */
    gw_json_t json; /* over json_buf */
    /* MQ_JSON_MAX bytes, allocated only for an enabled side: a daemon
     * without [mqtt] keeps no page of it (its memory is what it was
     * before MQTT grew, issue 21's RSS goal). */
    char *json_buf;
    /* the console's (mq_report, mq_metrics): counters since the side started */
    struct { unsigned long long published, received, accepted, connects; gw_log_limit_t write_log[GW_MAX_ROBOTS]; } con;
} mq_t;


static unsigned lib_users; /* mosquitto_lib_init/cleanup around the sides */
/* libmosquitto's functions (mqtt_lib.h): loaded by the first enabled
 * side's mq_new, then kept for the life of the process; every call below
 * is made by an enabled side, so after the load. */
static const gw_mqttlib_t *ml;

/* ---- topics and publishing ------------------------------------------------------ */

/* The broker connected, or being tried. */
static const gw_mqtt_server_t *server(const mq_t *t)
{
    return &t->cfg.server[t->server];
}

static void topic(const mq_t *t, char *out, size_t size, int robot, const char *leaf)
{
    if (robot < 0)
        snprintf(out, size, "%s/%s", t->prefix, leaf);
    else
        snprintf(out, size, "%s/%s/%s", t->prefix, t->env->cfg->robot[robot].name, leaf);
}

/* Room for one more message: libmosquitto has sent all it was given (so
 * its queue holds nothing but this), and the in-flight bound. */
static bool room(const mq_t *t)
{
    return t->connected && !ml->want_write(t->mosq) &&
           (t->cfg.qos == 0 || t->inflight < MQ_MAX_INFLIGHT);
}

static bool publish_qos(mq_t *t, const char *top, const void *payload, size_t len, int qos,
                        bool retain)
{
    int mid = 0;
    int rc = ml->publish(t->mosq, &mid, top, (int)len, payload, qos, retain);
    if (rc != MOSQ_ERR_SUCCESS) {
        gw_log(GW_LOG_DEBUG, "mqtt: publish %s: %s", top, ml->strerror(rc));
        return false;
    }
    if (qos > 0)
        t->inflight++;
    t->con.published++;
    return true;
}

/* With [mqtt] qos (the JSON payload; Sparkplug says its own). */
static bool publish(mq_t *t, const char *top, const void *payload, size_t len, bool retain)
{
    return publish_qos(t, top, payload, len, (int)t->cfg.qos, retain);
}

static bool publish_text(mq_t *t, int robot, const char *leaf, const char *text, bool retain)
{
    char top[256];
    topic(t, top, sizeof top, robot, leaf);
    return publish(t, top, text, strlen(text), retain);
}

/* A topic under "<prefix>/<robot>" (one that may have left the
 * configuration, or another prefix's). */
static bool publish_under(mq_t *t, const char *base, const char *leaf, const char *payload,
                          bool retain)
{
    char top[256];
    snprintf(top, sizeof top, "%s/%s", base, leaf);
    return publish(t, top, payload, strlen(payload), retain);
}

/* meta's type names, by dr_kind_t. The codec's own names (dr_kind_name:
 * "BOOL", "USINT enum") are those of the specification's tables, which
 * drcli and the register map show; a plant reads one word per kind.
 * docs/mqtt.md lists these (test_mqtt_plant.py compares the two). */
static const char *const mq_type_names[] = {"BIT", "BITS", "USINT", "ENUM", "DINT", "REAL"};
typedef char mq_type_names_cover_kinds[sizeof mq_type_names / sizeof mq_type_names[0] ==
                                               DR_KIND_REAL + 1
                                           ? 1
                                           : -1];

static const char *type_name(const dr_field_t *f)
{
    return f->kind <= DR_KIND_REAL ? mq_type_names[f->kind] : "?";
}

/* Every leaf with its type, unit and direction: the units of data. */
static bool publish_meta(mq_t *t, unsigned robot)
{
    gw_json_t *j = &t->json;
    gw_json_init(j, t->json_buf, MQ_JSON_MAX);
    gw_json_raw(j, "{", 1);
    for (unsigned i = 0; i < t->leaves; i++) {
        dr_ref_t ref;
        char path[96];
        if (dr_leaf_at((uint16_t)i, &ref) != DR_OK || dr_ref_path(ref, path, sizeof path) != DR_OK)
            continue;
        const dr_field_t *f = ref.field;
        bool o2t = dr_asm_info((dr_asm_t)f->assembly)->dir == DR_DIR_O2T;
        if (j->len > 1)
            gw_json_raw(j, ",", 1);
        gw_json_quote(j, path, strlen(path));
        gw_json_str(j, ":{\"type\":");
        gw_json_quote(j, type_name(f), strlen(type_name(f)));
        gw_json_str(j, ",\"unit\":");
        gw_json_quote(j, f->unit, strlen(f->unit));
        gw_json_str(j, o2t ? ",\"dir\":\"O->T\"}" : ",\"dir\":\"T->O\"}");
    }
    gw_json_raw(j, "}", 1);
    if (j->full)
        return true; /* cannot fit: not retried */
    char top[256];
    topic(t, top, sizeof top, (int)robot, "meta");
    return publish(t, top, j->buf, j->len, t->cfg.retain);
}

/* The robot packet's receive time (monotonic) on the wall clock, as
 * ISO 8601 UTC with milliseconds: "2026-11-25T14:48:10.123Z"; null
 * before the robot sent anything. */
static void write_time(gw_json_t *j, uint64_t rx_us)
{
    struct timespec ts;
    struct tm tm;
    char day[32], text[48];
    uint64_t mono = ev_now_us();
    if (rx_us == 0 || clock_gettime(CLOCK_REALTIME, &ts) != 0) {
        gw_json_str(j, "null");
        return;
    }
    uint64_t wall_ms = (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
    uint64_t ago_ms = mono > rx_us ? (mono - rx_us) / 1000u : 0u;
    uint64_t ms = wall_ms > ago_ms ? wall_ms - ago_ms : 0u;
    time_t sec = (time_t)(ms / 1000u);
    if (gmtime_r(&sec, &tm) == NULL || strftime(day, sizeof day, "%Y-%m-%dT%H:%M:%S", &tm) == 0) {
        gw_json_str(j, "null");
        return;
    }
    snprintf(text, sizeof text, "\"%s.%03uZ\"", day, (unsigned)(ms % 1000u));
    gw_json_str(j, text);
}

/* Has every T->O assembly arrived since the link came up? */
static bool all_seen(const mq_t *t, unsigned r)
{
    unsigned all = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O)
            all |= 1u << a;
    return (t->asm_seen[r] & all) == all;
}

/* Fresh: the link is up and its data younger than the link's timeout.
 * The link refreshes its `fresh` once a millisecond, and a link that has
 * just come up is not fresh until every assembly is in: the data that
 * completes them may be published before that refresh, so a link that is
 * up with every assembly received since counts as fresh too (the link
 * goes down when its data gets older than the timeout). */
static bool data_fresh(const mq_t *t, unsigned r)
{
    return t->link[r] && (t->env->robots[r].link.fresh || all_seen(t, r));
}

/* {"time":...,"quality":"fresh"|"stale","age_ms":N,"values":{ */
static void open_message(mq_t *t, const gw_robot_t *rb, bool fresh)
{
    gw_json_t *j = &t->json;
    char text[64];
    gw_json_init(j, t->json_buf, MQ_JSON_MAX);
    gw_json_str(j, "{\"time\":");
    write_time(j, rb->link.rx_us);
    snprintf(text, sizeof text, ",\"quality\":\"%s\",\"age_ms\":%lu,\"values\":{",
             fresh ? "fresh" : "stale", (unsigned long)rb->link.age_ms);
    gw_json_str(j, text);
}

/* ,"names":{"io_state.robot_state":"STANDBY"} for the enums among the
 * message's n leaves (null for a value without a name); nothing if none. */
static void write_names(mq_t *t, unsigned n)
{
    gw_json_t *j = &t->json;
    unsigned named = 0;
    for (unsigned k = 0; k < n; k++) {
        dr_ref_t ref;
        char path[96];
        if (dr_leaf_at(t->pick[k], &ref) != DR_OK || ref.field->kind != DR_KIND_ENUM ||
            dr_ref_path(ref, path, sizeof path) != DR_OK)
            continue;
        gw_json_str(j, named++ == 0 ? ",\"names\":{" : ",");
        gw_json_quote(j, path, strlen(path));
        gw_json_raw(j, ":", 1);
        const char *name = dr_robot_state_name((unsigned)t->pick_v[k]);
        if (name != NULL)
            gw_json_quote(j, name, strlen(name));
        else
            gw_json_str(j, "null");
    }
    if (named > 0)
        gw_json_raw(j, "}", 1);
}

/* The robot's message in t->json: every leaf (`full`) or the ones that
 * changed since they were last published, the leaves and their values in
 * pick/pick_v. Returns how many leaves it holds. */
static unsigned build_message(mq_t *t, unsigned robot, bool full)
{
    const gw_robot_t *rb = &t->env->robots[robot];
    gw_json_t *j = &t->json;
    const gw_mqtt_last_t *last = t->last[robot];
    open_message(t, rb, data_fresh(t, robot));
    unsigned n = 0;
    for (unsigned i = 0; i < t->leaves; i++) {
        dr_ref_t ref;
        dr_value_t v;
        char path[96];
        if (dr_leaf_at((uint16_t)i, &ref) != DR_OK)
            continue;
        if (gw_robot_get(rb, ref, &v) != DR_OK)
            continue;
        if (!full && !gw_mqtt_changed(&last[i], &v, t->cfg.deadband))
            continue;
        if (dr_ref_path(ref, path, sizeof path) != DR_OK)
            continue;
        t->pick[n] = (uint16_t)i;
        t->pick_v[n] = dr_value_as_double(&v);
        if (n++ > 0)
            gw_json_raw(j, ",", 1);
        gw_json_quote(j, path, strlen(path));
        gw_json_raw(j, ":", 1);
        gw_json_value(j, &v);
    }
    gw_json_raw(j, "}", 1);
    write_names(t, n);
    gw_json_raw(j, "}", 1);
    return n;
}

/* What changed (everything with `full`) on <robot>/data; nothing if
 * nothing did. */
static bool publish_data(mq_t *t, unsigned robot, bool full)
{
    unsigned n = build_message(t, robot, full);
    if (n == 0 || t->json.full)
        return true;
    char top[256];
    topic(t, top, sizeof top, (int)robot, "data");
    if (!publish(t, top, t->json.buf, t->json.len, false))
        return false;
    /* Only now, and only what the message holds: a change within the
     * deadband is measured from the value the plant has, so that a slow
     * drift is published once it adds up. */
    gw_mqtt_last_t *last = t->last[robot];
    for (unsigned k = 0; k < n; k++) {
        last[t->pick[k]].have = true;
        last[t->pick[k]].v = t->pick_v[k];
    }
    t->snap_due[robot] = true;
    return true;
}

/* Every field as the images have it now, retained on <robot>/snapshot:
 * what a subscriber that arrives late starts from (docs/mqtt.md). */
static bool publish_snapshot(mq_t *t, unsigned robot)
{
    unsigned n = build_message(t, robot, true);
    if (n == 0 || t->json.full)
        return true;
    char top[256];
    topic(t, top, sizeof top, (int)robot, "snapshot");
    return publish(t, top, t->json.buf, t->json.len, t->cfg.retain);
}

/* A robot this prefix no longer publishes (a reload removed or renamed
 * it, or moved the prefix): its state says so, retained, so that no plant
 * application reads it as live; its meta and snapshot, which describe a
 * robot that is not there, are cleared (an empty retained message). */
static void retire(mq_t *t, const char *base, bool quiet)
{
    (void)publish_under(t, base, "state", MQ_RETIRED, t->cfg.retain);
    (void)publish_under(t, base, "meta", "", true);
    (void)publish_under(t, base, "snapshot", "", true);
    if (!quiet)
        gw_log(GW_LOG_INFO, "mqtt: %s: removed from the configuration, its topics retired",
               base);
}

/* ---- plant writes ---------------------------------------------------------------- */

static void refuse(mq_t *t, unsigned robot, const struct mosquitto_message *m, mq_refusal_t kind,
                   const char *why)
{
    /* A plant application that retries a bad write in a loop must not
     * flood the log: one line per kind every 10 s, the rest counted. */
    gw_log_limited(GW_LOG_INFO, &t->refused[kind], "mqtt: write %s refused: %s", m->topic, why);
    /* Called from within mosquitto_loop_read, where libmosquitto queues
     * what is published instead of writing it: each refusal of a burst
     * gets its reply, up to a bound; a flood of bad writes cannot grow
     * the queue (the refusal is still logged). */
    if (!ml->want_write(t->mosq) && (t->cfg.qos == 0 || t->inflight < MQ_MAX_INFLIGHT))
        t->err_queued = 0;
    if (!t->connected || t->err_queued >= MQ_ERR_QUEUE ||
        (t->cfg.qos > 0 && t->inflight >= MQ_MAX_INFLIGHT + MQ_ERR_QUEUE)) {
        if (t->dropped++ % 1000u == 0)
            gw_log(GW_LOG_WARNING, "mqtt: error replies dropped: %lu (queue bound)", t->dropped);
        return;
    }
    t->err_queued++;
    gw_json_t *j = &t->json;
    gw_json_init(j, t->json_buf, MQ_JSON_MAX);
    gw_json_str(j, "{\"topic\":");
    gw_json_quote(j, m->topic, strlen(m->topic));
    gw_json_str(j, ",\"payload\":");
    gw_json_quote(j, m->payload != NULL ? m->payload : "",
             m->payloadlen > 0 ? (size_t)m->payloadlen : 0u);
    gw_json_str(j, ",\"error\":");
    gw_json_quote(j, why, strlen(why));
    gw_json_raw(j, "}", 1);
    if (!j->full) {
        char top[256];
        topic(t, top, sizeof top, (int)robot, "error");
        (void)publish(t, top, j->buf, j->len, false);
    }
}

/* Why a value's text does not fit the field: the codec's reason, except
 * for text the parser calls malformed, which for a number is the wrong
 * word: 1.5 for a DINT is a number, just not an integer. */
static void value_error(dr_ref_t ref, const char *text, dr_status_t st, char *why, size_t size)
{
    char path[96], *end = NULL;
    if (st != DR_ESYNTAX || dr_ref_path(ref, path, sizeof path) != DR_OK) {
        snprintf(why, size, "invalid value: %s", dr_strerror(st));
        return;
    }
    double x = strtod(text, &end);
    bool number = end != text && *end == '\0' && isfinite(x);
    const char *what = "not a number";
    if (ref.field->kind == DR_KIND_ENUM && !number)
        what = "neither a number nor a robot_state name";
    else if (number && x != floor(x))
        what = "not an integer";
    else if (number)
        what = "an integer is written in decimal or 0x hex";
    /* A long path may cut the text; the reason comes first. */
    if (snprintf(why, size, "invalid value: %s (%s is %s %s)", what, path,
                 ref.field->kind == DR_KIND_ENUM || ref.field->kind == DR_KIND_USINT ? "an" : "a",
                 type_name(ref.field)) < 0)
        snprintf(why, size, "invalid value: %s", what);
}

/* The kind of refusal (for the log's limiter) of the write path's answer. */
static mq_refusal_t refusal_kind(gw_write_status_t st)
{
    switch (st) {
    case GW_WRITE_SINGLE: return MQ_REF_SINGLE;
    case GW_WRITE_FAULT: return MQ_REF_FAULT;
    case GW_WRITE_GPIO: return MQ_REF_GPIO;
    case GW_WRITE_DIRECTION: return MQ_REF_READONLY;
    case GW_WRITE_UNSENT: return MQ_REF_UNSENT;
    case GW_WRITE_VALUE: return MQ_REF_VALUE;
    case GW_WRITE_OK:
    case GW_WRITE_RIGHTS:
    case GW_WRITE_FIELD: break;
    }
    return MQ_REF_FIELD;
}

/* The words of a refusal: the write path's, with the codec's reason for a
 * value and the assembly the plan does not send. */
static void refusal_text(const gw_write_item_t *items, const gw_write_result_t *res, char *why,
                         size_t whylen)
{
    if (res->status == GW_WRITE_VALUE)
        snprintf(why, whylen, "invalid value: %s", dr_strerror(res->st));
    else if (res->status == GW_WRITE_UNSENT)
        snprintf(why, whylen, "not sent: the connection plan opens no connection for %s",
                 dr_asm_info((dr_asm_t)items[res->item].ref.field->assembly)->name);
    else if (res->status == GW_WRITE_RIGHTS)
        snprintf(why, whylen, "writes are off ([mqtt] writes = no)");
    else
        snprintf(why, whylen, "%s", gw_write_status_text(res->status));
}

/* A decoded plant write (JSON's set topic: one field; Sparkplug's DCMD:
 * every metric of the command) through the one write path (core/write.h),
 * all or nothing, with the rules of every write: in single-writer mode the
 * outputs belong to the one Modbus writer, the latched write fault, GPIO
 * inputs' bits, the plan, the codec's checks. Accepted: logged by the
 * path (the topic names the writer), the link told. Refused: *kind and
 * why say why (res->item: which item). */
static bool write_items(mq_t *t, unsigned robot, const char *top, const gw_write_item_t *items,
                        unsigned n, gw_write_result_t *res, mq_refusal_t *kind, char *why,
                        size_t whylen)
{
    char who[GW_WRITE_CLIENT];
    snprintf(who, sizeof who, "mqtt %s", top);
    gw_write_origin_t o = {t->spb != NULL ? GW_ORIGIN_SPARKPLUG : GW_ORIGIN_MQTT, who,
                           t->cfg.writes, false, false, &t->con.write_log[robot]};
    gw_write_status_t st = gw_robot_write(&t->env->robots[robot], items, n, &o, res);
    if (st != GW_WRITE_OK) {
        *kind = refusal_kind(st);
        refusal_text(items, res, why, whylen);
        return false;
    }
    t->con.accepted += n;
    if (res->dirty != 0)
        t->env->outputs_changed(t->env->user, robot, res->dirty);
    return true;
}

/* <prefix>/<robot>/set/<path>, the payload the value as text: the same
 * checks as a Modbus write (the codec's range and finiteness checks, GPIO
 * inputs' bits, the latched write fault), and in single-writer mode the
 * outputs belong to the one Modbus writer: refused. */
static void on_set(mq_t *t, unsigned robot, const char *path, const struct mosquitto_message *m)
{
    char text[MQ_SET_MAX + 1], why[160];
    dr_ref_t ref;
    dr_value_t v;
    mq_refusal_t kind;
    dr_status_t st = dr_path_parse(path, &ref);
    if (st != DR_OK) {
        char near[96];
        if (dr_path_closest(path, near, sizeof near) == DR_OK)
            snprintf(why, sizeof why, "unknown field (did you mean %s?)", near);
        else
            snprintf(why, sizeof why, "unknown field");
        refuse(t, robot, m, MQ_REF_FIELD, why);
        return;
    }
    if (m->payloadlen <= 0 || (size_t)m->payloadlen > MQ_SET_MAX ||
        memchr(m->payload, '\0', (size_t)m->payloadlen) != NULL) {
        refuse(t, robot, m, MQ_REF_PAYLOAD, "payload must be the value as text, 1..64 bytes");
        return;
    }
    memcpy(text, m->payload, (size_t)m->payloadlen);
    text[m->payloadlen] = '\0';
    st = dr_text_parse(ref, text, DR_SET_O2T_ONLY, &v);
    if (st == DR_EREADONLY)
        refuse(t, robot, m, MQ_REF_READONLY, "read-only: a T->O field");
    else if (st != DR_OK) {
        value_error(ref, text, st, why, sizeof why);
        refuse(t, robot, m, MQ_REF_VALUE, why);
    } else {
        gw_write_item_t item = {ref, v, 0};
        gw_write_result_t res;
        if (!write_items(t, robot, m->topic, &item, 1, &res, &kind, why, sizeof why))
            refuse(t, robot, m, kind, why);
        else
            gw_log(GW_LOG_DEBUG, "mqtt: %s = %s", m->topic, text);
    }
}

static void on_message(struct mosquitto *mosq, void *obj, const struct mosquitto_message *m)
{
    mq_t *t = obj;
    (void)mosq;
    if (t->spb != NULL) {
        (void)spb_message(t->spb, m->topic, m->payload,
                          m->payloadlen > 0 ? (size_t)m->payloadlen : 0u);
        return;
    }
    size_t pl = strlen(t->prefix);
    if (!t->cfg.writes || strncmp(m->topic, t->prefix, pl) != 0 || m->topic[pl] != '/')
        return;
    const char *rest = m->topic + pl + 1;
    const gw_config_t *cfg = t->env->cfg;
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        size_t n = strlen(cfg->robot[r].name);
        if (strncmp(rest, cfg->robot[r].name, n) == 0 && strncmp(rest + n, "/set/", 5) == 0) {
            t->con.received++;
            on_set(t, r, rest + n + 5, m);
            return;
        }
    }
}

/* ---- connection ------------------------------------------------------------------ */

/* A warning that the broker connection is down or cannot be made: the
 * same words are the console's reason (mq_report) until it is up. */
static void mq_down(mq_t *t, const char *fmt, ...) GW_PRINTF(2, 3);
static void mq_down(mq_t *t, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(t->down_why, sizeof t->down_why, fmt, ap);
    va_end(ap);
    gw_log(GW_LOG_WARNING, "mqtt: %s", t->down_why);
}

/* The next broker of `servers` for the next attempt (`why` it leaves this
 * one); with one broker, the same one. */
static void next_server(mq_t *t, const char *why)
{
    if (t->cfg.server_count < 2)
        return;
    const gw_mqtt_server_t *from = server(t);
    t->server = (t->server + 1u) % t->cfg.server_count;
    gw_log(GW_LOG_INFO, "mqtt: %s:%u: %s: next server %s:%u", from->host, from->port, why,
           server(t)->host, server(t)->port);
    if (t->spb != NULL)
        spb_server_changed(t->spb);
}

static void on_connect(struct mosquitto *mosq, void *obj, int rc)
{
    mq_t *t = obj;
    (void)mosq;
    t->connecting = false;
    if (rc != 0) {
        mq_down(t, "broker %s:%u refused the connection: %s", server(t)->host, server(t)->port,
                ml->connack_string(rc));
        if (t->spb != NULL)
            spb_connect_answered(t->spb, false); /* its bdSeq is used */
        next_server(t, "refused");
        return; /* libmosquitto closes; tick() retries */
    }
    gw_log(GW_LOG_INFO, "mqtt: connected to %s:%u", server(t)->host, server(t)->port);
    t->connected = true;
    t->down_why[0] = '\0';
    t->con.connects++;
    t->inflight = 0;
    if (t->spb != NULL) {
        /* With a primary host, a server is good once the host is online
         * there (mq_tick): the backoff is reset then, and a server where
         * it stays offline is left after primary_host_wait_s. */
        if (t->cfg.primary_host_id[0] == '\0')
            t->backoff_us = MQ_BACKOFF_MIN_US;
        else if (t->cfg.server_count > 1)
            t->host_wait_us = ev_now_us() + (uint64_t)t->cfg.host_wait_s * 1000000u;
        spb_connected(t->spb);
        return;
    }
    t->backoff_us = MQ_BACKOFF_MIN_US;
    t->status_due = true;
    for (unsigned r = 0; r < t->env->cfg->robot_count; r++) {
        t->state_due[r] = t->meta_due[r] = t->full_due[r] = true;
        t->next_pub_us[r] = t->next_snap_us[r] = 0;
        if (t->cfg.writes) {
            char top[256];
            topic(t, top, sizeof top, (int)r, "set/#");
            int e = ml->subscribe(t->mosq, NULL, top, (int)t->cfg.qos);
            if (e != MOSQ_ERR_SUCCESS)
                gw_log(GW_LOG_WARNING, "mqtt: subscribe %s: %s", top, ml->strerror(e));
        }
    }
}

static void on_disconnect(struct mosquitto *mosq, void *obj, int rc)
{
    mq_t *t = obj;
    (void)mosq;
    if (t->connected && t->closing != NULL)
        gw_log(GW_LOG_INFO, "mqtt: disconnected from %s:%u (%s)", server(t)->host,
               server(t)->port, t->closing);
    else if (t->connected) {
        mq_down(t, "connection to %s:%u lost (%s)", server(t)->host, server(t)->port,
                rc == 0 ? "closed" : ml->strerror(rc));
        next_server(t, "connection lost");
    }
    t->connected = false;
    t->host_wait_us = 0;
    if (t->spb != NULL)
        spb_disconnected(t->spb);
}

/* Why a connection attempt failed, in fail_why; the first cause found
 * is kept (a refused TCP connection also ends libmosquitto's read). */
static void note_failure(mq_t *t, int rc)
{
    if (t->fail_why[0] != '\0' || rc == MOSQ_ERR_SUCCESS)
        return;
    if (rc == MOSQ_ERR_ERRNO && errno != 0)
        snprintf(t->fail_why, sizeof t->fail_why, "%s", strerror(errno));
    else if (rc == MOSQ_ERR_TLS)
        snprintf(t->fail_why, sizeof t->fail_why,
                 "TLS failure (the broker's certificate, ca_file, cert_file, key_file)");
    else
        snprintf(t->fail_why, sizeof t->fail_why, "%s", ml->strerror(rc));
}

/* A socket whose connect failed says why in SO_ERROR (refused, no route). */
static void note_socket_error(mq_t *t)
{
    int fd = ml->socket(t->mosq), e = 0;
    socklen_t len = sizeof e;
    if (t->fail_why[0] == '\0' && fd >= 0 &&
        getsockopt(fd, SOL_SOCKET, SO_ERROR, &e, &len) == 0 && e != 0)
        snprintf(t->fail_why, sizeof t->fail_why, "%s", strerror(e));
}

static void on_publish(struct mosquitto *mosq, void *obj, int mid)
{
    mq_t *t = obj;
    (void)mosq, (void)mid;
    if (t->inflight > 0)
        t->inflight--;
}

static void on_ready(void *obj, uint32_t events);
static bool leave_due(mq_t *t, uint64_t now);

/* The socket into the loop as libmosquitto now has it; a connection that
 * went away schedules the next attempt. */
static void sync_watch(mq_t *t, uint64_t now)
{
    int fd = ml->socket(t->mosq);
    if (fd < 0) {
        ev_unwatch(t->env->epfd, &t->ev);
        if (t->connected || t->connecting) {
            if (t->connecting) {
                mq_down(t, "cannot connect to %s:%u: %s", server(t)->host, server(t)->port,
                        t->fail_why[0] ? t->fail_why : "connection closed");
                next_server(t, "cannot connect");
            }
            t->connected = t->connecting = false;
        }
        if (t->retry_us == 0) {
            t->retry_us = now + t->backoff_us;
            t->backoff_us = t->backoff_us * 2u > MQ_BACKOFF_MAX_US ? MQ_BACKOFF_MAX_US
                                                                   : t->backoff_us * 2u;
        }
        return;
    }
    uint32_t ev = EPOLLIN | (ml->want_write(t->mosq) ? (uint32_t)EPOLLOUT : 0u);
    if (!ev_watch(t->env->epfd, &t->ev, fd, ev))
        gw_log(GW_LOG_ERROR, "mqtt: epoll: %s", strerror(errno));
}

static void drop_connection(mq_t *t, uint64_t now)
{
    ev_unwatch(t->env->epfd, &t->ev);
    gw_mqtt_lookup_end(t->lookup);
    t->lookup = NULL;
    /* Not connected first: libmosquitto calls on_disconnect from here,
     * which must not take this for a lost connection. */
    t->connected = t->connecting = false;
    (void)ml->disconnect(t->mosq); /* closes the socket */
    t->host_wait_us = t->leave_us = 0;
    t->retry_us = 0;
    sync_watch(t, now);
}

static void spb_set_will(mq_t *t);

/* The attempt's CONNECT to t->addr (non-blocking: connect() returns at
 * once, the TCP and TLS handshakes go on in the loop). With TLS, a server
 * given by a host name is given to libmosquitto by that name: it checks
 * the broker's certificate against the name it connects to, so it looks
 * the name up again itself (getaddrinfo, in the loop), just after the
 * lookup here has answered; a DNS server that does not answer has been
 * found by then (docs/mqtt.md "Broker loss"). */
static void connect_addr(mq_t *t, uint64_t now)
{
    bool tls = t->cfg.ca_file[0] != '\0';
    if (t->spb != NULL)
        spb_set_will(t);
    errno = 0;
    int rc = ml->connect_async(t->mosq, tls ? server(t)->host : t->addr, server(t)->port,
                               (int)t->cfg.keepalive_s);
    if (rc != MOSQ_ERR_SUCCESS)
        note_failure(t, rc);
    sync_watch(t, now); /* a failure is logged there, and the next server taken */
}

/* A connection attempt to the current server: an address is connected at
 * once, a host name looked up first (mq_tick takes the answer). */
static void try_connect(mq_t *t, uint64_t now)
{
    struct in_addr a;
    t->retry_us = 0;
    t->fail_why[0] = '\0';
    t->host_wait_us = 0;
    ev_unwatch(t->env->epfd, &t->ev); /* the socket is replaced */
    t->connecting = true;
    t->connect_deadline_us = now + MQ_CONNECT_TIMEOUT_US;
    if (inet_pton(AF_INET, server(t)->host, &a) == 1) {
        snprintf(t->addr, sizeof t->addr, "%s", server(t)->host);
        connect_addr(t, now);
        return;
    }
    t->lookup = gw_mqtt_lookup_start(server(t)->host, t->fail_why, sizeof t->fail_why);
    if (t->lookup == NULL)
        sync_watch(t, now); /* logged, the next server */
}

/* A lookup under way: its answer connects, its failure is logged (the
 * next server then); true while it runs. */
static bool lookup_tick(mq_t *t, uint64_t now)
{
    if (t->lookup == NULL)
        return false;
    int r = gw_mqtt_lookup_poll(t->lookup, t->addr, sizeof t->addr, t->fail_why,
                                sizeof t->fail_why);
    if (r == 0)
        return true;
    t->lookup = NULL;
    if (r > 0)
        connect_addr(t, now);
    else
        sync_watch(t, now);
    return false;
}

static void on_ready(void *obj, uint32_t events)
{
    mq_t *t = obj;
    uint64_t now = ev_now_us();
    bool attempt = t->connecting && !t->connected;
    if (attempt && (events & (EPOLLERR | EPOLLHUP)))
        note_socket_error(t);
    if (events & (EPOLLIN | EPOLLERR | EPOLLHUP)) {
        /* libmosquitto reads a few packets per call; TLS may hold more
         * than the socket shows: read until it would block. */
        for (int i = 0; i < MQ_READS_PER_EVENT && ml->socket(t->mosq) >= 0; i++) {
            errno = 0;
            int rc = ml->loop_read(t->mosq, 1);
            if (rc != MOSQ_ERR_SUCCESS && attempt)
                note_failure(t, rc);
            if (rc != MOSQ_ERR_SUCCESS || errno == EAGAIN || errno == EWOULDBLOCK)
                break;
        }
    }
    if ((events & EPOLLOUT) && ml->socket(t->mosq) >= 0) {
        errno = 0;
        int rc = ml->loop_write(t->mosq, 1);
        if (rc != MOSQ_ERR_SUCCESS && attempt)
            note_failure(t, rc);
    }
    if (!leave_due(t, now))
        sync_watch(t, now);
}

/* ---- Sparkplug B (sparkplug.h): what it asks of the connection --------------------- */

static bool spb_io_publish(void *user, const char *top, const void *p, size_t len, int qos,
                           bool retain)
{
    return publish_qos(user, top, p, len, qos, retain);
}

static bool spb_io_subscribe(void *user, const char *top, int qos)
{
    const mq_t *t = user;
    int e = ml->subscribe(t->mosq, NULL, top, qos);
    if (e != MOSQ_ERR_SUCCESS)
        gw_log(GW_LOG_WARNING, "mqtt: subscribe %s: %s", top, ml->strerror(e));
    return e == MOSQ_ERR_SUCCESS;
}

static bool spb_io_room(void *user)
{
    return room(user);
}

static bool spb_io_write(void *user, unsigned robot, const gw_write_item_t *items, unsigned n,
                         gw_write_result_t *res, char *why, size_t whylen)
{
    mq_t *t = user;
    mq_refusal_t kind;
    t->con.received += n; /* writes asked for, as set topics' messages */
    return write_items(t, robot, "Sparkplug DCMD", items, n, res, &kind, why, whylen);
}

/* Sparkplug 3.0: a node whose primary host is offline on its server
 * moves to the next one (tck-id-operational-behavior-primary-application-
 * state-with-multiple-servers-walk), as it does for NCMD Node Control/Next
 * Server; with one server it connects again if it was born (a new
 * bdSeq), else it stays and waits for online. A born node's NDEATH (QoS
 * 1) is acknowledged first (leave_due): unacked, libmosquitto would send
 * it again on the next connection, after the CONNECT, where a host would
 * see an old session's death. */
static bool spb_io_leave(void *user, bool born, const char *why)
{
    mq_t *t = user;
    if (t->cfg.server_count < 2 && !born)
        return false;
    next_server(t, why);
    t->leave_us = ev_now_us() + MQ_LEAVE_US;
    if (!born)
        t->leave_us = 1; /* nothing to wait for */
    return true;
}

/* The NDEATH before leaving a server acknowledged (or waited for long
 * enough): the connection is dropped, the next one made. */
static bool leave_due(mq_t *t, uint64_t now)
{
    if (t->leave_us == 0 || !t->connected || (t->inflight > 0 && now < t->leave_us))
        return false;
    drop_connection(t, now);
    return true;
}

static bool spb_attach(mq_t *t, const char *host, char *err, size_t errlen)
{
    const spb_io_t io = {t, spb_io_publish, spb_io_subscribe, spb_io_room, spb_io_write,
                         spb_io_leave};
    t->spb = spb_new(&t->cfg, t->env, &io, host, err, errlen);
    return t->spb != NULL;
}

/* NDEATH with the next bdSeq as the Will of the connection being made
 * (Sparkplug: QoS 1, not retained). */
static void spb_set_will(mq_t *t)
{
    const char *top;
    const void *p;
    size_t len;
    spb_will(t->spb, &top, &p, &len);
    int rc = ml->will_set(t->mosq, top, (int)len, p, 1, false);
    if (rc != MOSQ_ERR_SUCCESS)
        gw_log(GW_LOG_ERROR, "mqtt: sparkplug: the Will (NDEATH): %s", ml->strerror(rc));
}

/* ---- the side ------------------------------------------------------------------------ */

static bool read_password(mq_t *t, char *err, size_t errlen)
{
    if (t->cfg.password_file[0] == '\0')
        return true;
    FILE *f = fopen(t->cfg.password_file, "r");
    if (f == NULL) {
        snprintf(err, errlen, "mqtt: password_file %s: %s", t->cfg.password_file,
                 strerror(errno));
        return false;
    }
    bool ok = fgets(t->password, sizeof t->password, f) != NULL;
    (void)fclose(f);
    if (!ok) {
        snprintf(err, errlen, "mqtt: password_file %s: empty", t->cfg.password_file);
        return false;
    }
    t->password[strcspn(t->password, "\r\n")] = '\0';
    return true;
}

static void mq_free(mq_t *t);

/* From [mqtt], not yet connected (prepare must not touch the network). */
static mq_t *mq_new(const gw_mqtt_config_t *q, const gw_north_env_t *env, char *err,
                    size_t errlen)
{
    mq_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    t->env = env;
    t->cfg = *q;
    t->ev = (ev_t){on_ready, t, -1, 0};
    t->backoff_us = MQ_BACKOFF_MIN_US;
    if (!q->enabled)
        return t;
    if ((t->json_buf = malloc(MQ_JSON_MAX)) == NULL) {
        snprintf(err, errlen, "out of memory");
        free(t);
        return NULL;
    }
    if ((ml = gw_mqttlib_load(err, errlen)) == NULL) {
        free(t->json_buf);
        free(t);
        return NULL;
    }
    if (lib_users++ == 0)
        ml->lib_init();
    char host[64] = "localhost";
    if (gethostname(host, sizeof host) != 0)
        snprintf(host, sizeof host, "localhost");
    host[sizeof host - 1] = '\0';
    if (q->topic_prefix[0] != '\0')
        snprintf(t->prefix, sizeof t->prefix, "%s", q->topic_prefix);
    else
        snprintf(t->prefix, sizeof t->prefix, "drgate/%s", host);
    if (q->client_id[0] != '\0')
        snprintf(t->client_id, sizeof t->client_id, "%s", q->client_id);
    else
        snprintf(t->client_id, sizeof t->client_id, "drgatewayd-%s", host);
    t->leaves = dr_leaf_count();
    t->pick = calloc(t->leaves, sizeof *t->pick);
    t->pick_v = calloc(t->leaves, sizeof *t->pick_v);
    if (t->pick == NULL || t->pick_v == NULL) {
        snprintf(err, errlen, "out of memory");
        mq_free(t);
        return NULL;
    }
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        if ((t->last[r] = calloc(t->leaves, sizeof *t->last[r])) == NULL) {
            snprintf(err, errlen, "out of memory");
            mq_free(t);
            return NULL;
        }
    if (!read_password(t, err, errlen)) {
        mq_free(t);
        return NULL;
    }
    t->mosq = ml->new(t->client_id, true, t);
    if (t->mosq == NULL) {
        snprintf(err, errlen, "mqtt: cannot create the client: %s", strerror(errno));
        mq_free(t);
        return NULL;
    }
    if (q->payload == GW_MQTT_SPARKPLUG && !spb_attach(t, host, err, errlen)) {
        mq_free(t);
        return NULL;
    }
    char will[200];
    snprintf(will, sizeof will, "%s/status", t->prefix);
    int rc = t->spb != NULL ? MOSQ_ERR_SUCCESS /* its Will is set at each connect */
                            : ml->will_set(t->mosq, will, 7, "offline", (int)q->qos, q->retain);
    if (rc == MOSQ_ERR_SUCCESS && q->username[0] != '\0')
        rc = ml->username_pw_set(t->mosq, q->username,
                                       q->password_file[0] ? t->password : NULL);
    const char *what = "client settings";
    if (rc == MOSQ_ERR_SUCCESS && q->ca_file[0] != '\0') {
        what = "TLS (ca_file, cert_file, key_file)";
        rc = ml->tls_set(t->mosq, q->ca_file, NULL, q->cert_file[0] ? q->cert_file : NULL,
                               q->key_file[0] ? q->key_file : NULL, NULL);
    }
    if (rc == MOSQ_ERR_SUCCESS)
        rc = ml->max_inflight_messages_set(t->mosq, MQ_MAX_INFLIGHT);
    if (rc != MOSQ_ERR_SUCCESS) {
        snprintf(err, errlen, "mqtt: %s: %s", what,
                 rc == MOSQ_ERR_ERRNO ? strerror(errno) : ml->strerror(rc));
        mq_free(t);
        return NULL;
    }
    ml->connect_callback_set(t->mosq, on_connect);
    ml->disconnect_callback_set(t->mosq, on_disconnect);
    ml->publish_callback_set(t->mosq, on_publish);
    ml->message_callback_set(t->mosq, on_message);
    return t;
}

/* The robots as they are now (after a reload; at create, sides come
 * before the links, which are all down): link states from the daemon,
 * everything published afresh once connected. */
static void mq_sync_robots(mq_t *t, bool links)
{
    const gw_north_env_t *env = t->env;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++) {
        t->link[r] = links && r < env->cfg->robot_count && env->link_up(env->user, r);
        t->state_due[r] = t->meta_due[r] = t->full_due[r] = true;
        t->snap_due[r] = false;
        t->next_pub_us[r] = t->next_snap_us[r] = 0;
        t->asm_seen[r] = ~0u; /* a link up now has its images */
        if (t->last[r] != NULL)
            memset(t->last[r], 0, t->leaves * sizeof *t->last[r]);
    }
    for (unsigned r = 0; r < env->cfg->robot_count; r++)
        snprintf(t->pub_name[r], sizeof t->pub_name[r], "%s", env->cfg->robot[r].name);
    t->pub_count = env->cfg->robot_count;
    t->status_due = true;
    if (t->spb != NULL)
        spb_sync(t->spb, links);
}

static bool has_robot(const gw_config_t *cfg, const char *name)
{
    for (unsigned r = 0; r < cfg->robot_count; r++)
        if (strcmp(cfg->robot[r].name, name) == 0)
            return true;
    return false;
}

/* "<prefix>/<robot>" into the list to retire, once. */
static void gone_add(mq_t *t, const char *base)
{
    for (unsigned i = 0; i < t->gone_count; i++)
        if (strcmp(t->gone[i], base) == 0)
            return;
    if (t->gone_count < MQ_GONE_MAX)
        snprintf(t->gone[t->gone_count++], MQ_BASE_MAX, "%s", base);
}

/* Is "<prefix>/<robot>" one this side publishes under the configuration
 * now (env->cfg)? */
static bool publishes(const mq_t *t, const char *base)
{
    size_t pl = strlen(t->prefix);
    return strncmp(base, t->prefix, pl) == 0 && base[pl] == '/' &&
           has_robot(t->env->cfg, base + pl + 1);
}

/* A reload that keeps this side: the robots it published that the new
 * configuration (env->cfg) has no more are retired from the next tick on
 * (once connected); one that comes back before is not. */
static void queue_gone(mq_t *t)
{
    char base[MQ_BASE_MAX];
    unsigned n = 0;
    for (unsigned i = 0; i < t->gone_count; i++)
        if (!publishes(t, t->gone[i]))
            memmove(t->gone[n++], t->gone[i], sizeof t->gone[i]);
    t->gone_count = n;
    for (unsigned r = 0; r < t->pub_count; r++) {
        snprintf(base, sizeof base, "%s/%s", t->prefix, t->pub_name[r]);
        if (!publishes(t, base))
            gone_add(t, base);
    }
}

/* A reload that replaces this side by `next`: the robots the new
 * configuration drops, and all of them when the prefix moves (or MQTT
 * goes), are retired now, before the goodbye. On the same broker they
 * are handed to `next` as well, which retires them again once connected:
 * `next` connects with the same client ID at once, and the broker, which
 * then closes this connection, may drop what it has not read of it yet. */
static void retire_for(mq_t *t, mq_t *next)
{
    if (!t->cfg.enabled || t->spb != NULL)
        return; /* Sparkplug's NDEATH (the goodbye) ends its devices */
    bool all = !next->cfg.enabled || next->spb != NULL || strcmp(t->prefix, next->prefix) != 0;
    bool hand = next->cfg.enabled && next->spb == NULL && server(t)->port == server(next)->port &&
                strcmp(server(t)->host, server(next)->host) == 0;
    char base[MQ_BASE_MAX];
    for (unsigned r = 0; r < t->pub_count; r++)
        if (all || !has_robot(t->env->cfg, t->pub_name[r])) {
            snprintf(base, sizeof base, "%s/%s", t->prefix, t->pub_name[r]);
            gone_add(t, base);
        }
    for (unsigned i = 0; i < t->gone_count; i++) {
        if (t->connected)
            retire(t, t->gone[i], hand);
        if (hand)
            gone_add(next, t->gone[i]);
    }
    t->gone_count = 0;
}

/* Shutdown or replacement (`why`, logged): "offline" and a clean
 * DISCONNECT (the broker then does not send the Will), flushed for at
 * most a second. */
static void mq_goodbye(mq_t *t, const char *why)
{
    if (!t->connected)
        return;
    t->closing = why;
    if (t->spb != NULL)
        spb_goodbye(t->spb); /* NDEATH */
    else
        (void)publish_text(t, -1, "status", "offline", t->cfg.retain);
    (void)ml->disconnect(t->mosq);
    uint64_t end = ev_now_us() + 1000000u;
    int fd;
    while ((fd = ml->socket(t->mosq)) >= 0 && ml->want_write(t->mosq)) {
        uint64_t now = ev_now_us();
        if (now >= end)
            break;
        struct pollfd p = {fd, POLLOUT, 0};
        if (poll(&p, 1, (int)((end - now) / 1000u) + 1) <= 0)
            break;
        if (ml->loop_write(t->mosq, 1) != MOSQ_ERR_SUCCESS)
            break;
    }
    t->connected = false;
}

static void mq_free(mq_t *t)
{
    if (t == NULL)
        return;
    if (t->env != NULL)
        ev_unwatch(t->env->epfd, &t->ev);
    gw_mqtt_lookup_end(t->lookup);
    for (unsigned k = 0; k < MQ_REF_KINDS; k++)
        gw_log_limit_end(&t->refused[k]); /* what they hold back, counted */
    if (t->mosq != NULL)
        ml->destroy(t->mosq);
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        free(t->last[r]);
    spb_free(t->spb);
    free(t->pick);
    free(t->pick_v);
    free(t->json_buf);
    if (t->cfg.enabled && --lib_users == 0)
        ml->lib_cleanup();
    free(t);
}

static void *mq_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    mq_t *t = mq_new(&env->cfg->side.mqtt, env, err, errlen);
    if (t != NULL && t->cfg.enabled) {
        mq_sync_robots(t, false);
        try_connect(t, ev_now_us());
    }
    return t;
}

/* Everything but where the section is in the file. */
static bool same_servers(const gw_mqtt_config_t *a, const gw_mqtt_config_t *b)
{
    if (a->server_count != b->server_count)
        return false;
    for (unsigned i = 0; i < a->server_count; i++)
        if (strcmp(a->server[i].host, b->server[i].host) != 0 ||
            a->server[i].port != b->server[i].port)
            return false;
    return true;
}

static bool same_config(const gw_mqtt_config_t *a, const gw_mqtt_config_t *b)
{
    return a->enabled == b->enabled && same_servers(a, b) && a->host_wait_s == b->host_wait_s &&
           strcmp(a->client_id, b->client_id) == 0 && strcmp(a->username, b->username) == 0 &&
           strcmp(a->password_file, b->password_file) == 0 &&
           strcmp(a->ca_file, b->ca_file) == 0 && strcmp(a->cert_file, b->cert_file) == 0 &&
           strcmp(a->key_file, b->key_file) == 0 && a->keepalive_s == b->keepalive_s &&
           a->qos == b->qos && strcmp(a->topic_prefix, b->topic_prefix) == 0 &&
           a->retain == b->retain && a->publish_interval_ms == b->publish_interval_ms &&
           !(a->deadband < b->deadband || a->deadband > b->deadband) && a->writes == b->writes &&
           a->payload == b->payload && strcmp(a->group_id, b->group_id) == 0 &&
           strcmp(a->edge_node_id, b->edge_node_id) == 0 &&
           strcmp(a->primary_host_id, b->primary_host_id) == 0 &&
           a->metric_names == b->metric_names && strcmp(a->bdseq_file, b->bdseq_file) == 0;
}

/* An unchanged [mqtt] keeps its connection; a changed one is prepared
 * unconnected (files read, TLS set up) and connects at commit. */
static gw_north_reload_t mq_prepare(void *self, const gw_config_t *next,
                                    const gw_north_env_t *env, void **out, char *err,
                                    size_t errlen)
{
    mq_t *t = self;
    if (same_config(&t->cfg, &next->side.mqtt)) {
        *out = self;
        return GW_NORTH_OK;
    }
    *out = mq_new(&next->side.mqtt, env, err, errlen);
    return *out != NULL ? GW_NORTH_OK : GW_NORTH_REFUSED;
}

/* cppcheck-suppress constParameter ; the signature is gw_north_ops_t's */
static void mq_abort(void *self, void *out)
{
    if (out != self)
        mq_free(out);
}

static void *mq_commit(void *self, void *out, const gw_north_env_t *env)
{
    mq_t *t = self, *n = out;
    (void)env;
    if (n != t) {
        retire_for(t, n);
        mq_goodbye(t, "reload: [mqtt] changed");
        if (t->spb != NULL && n->spb != NULL)
            spb_carry(n->spb, t->spb); /* bdSeq goes on growing */
        mq_free(t);
        if (n->cfg.enabled)
            try_connect(n, ev_now_us());
    } else if (n->cfg.enabled && n->spb == NULL)
        queue_gone(n);
    if (n->cfg.enabled)
        mq_sync_robots(n, true); /* robots may have moved, come or gone */
    return n;
}

/* After link up, the snapshot waits for every T->O assembly (each its own
 * packet), so that it holds what the robot sent, not zeros; at most a
 * second (an explicit-mode robot may not poll them all). */
static bool snapshot_ready(const mq_t *t, unsigned r, uint64_t now)
{
    return all_seen(t, r) || now >= t->up_us[r] + 1000000u;
}

/* "up", or "down" with the cause the status block has (last_error), in
 * the same words as the log: "down: connection refused". */
static bool publish_state(mq_t *t, unsigned r)
{
    char text[240], cause[200];
    dr_status_t why = t->link[r] ? DR_OK : t->env->robots[r].link.last_status;
    if (why != DR_OK)
        gw_robot_cause(&t->env->robots[r], cause, sizeof cause);
    else
        cause[0] = '\0';
    snprintf(text, sizeof text, "%s%s%s", t->link[r] ? "up" : "down", cause[0] ? ": " : "", cause);
    t->state_why[r] = why;
    return publish_text(t, (int)r, "state", text, t->cfg.retain);
}

/* One robot's due publications, as room allows: state, meta, data (only
 * while the link is up, else it is not the robot's, and at most once per
 * publish_interval_ms; the O->T images, written by Modbus, GPIO or the
 * plant, are compared at that pace too), then the snapshot. */
static void tick_robot(mq_t *t, unsigned r, uint64_t now)
{
    if (!t->link[r] && t->env->robots[r].link.last_status != t->state_why[r])
        t->state_due[r] = true; /* down for another cause now */
    if (t->state_due[r] && room(t))
        t->state_due[r] = !publish_state(t, r);
    if (t->meta_due[r] && room(t))
        t->meta_due[r] = !publish_meta(t, r);
    if (!t->link[r]) {
        /* The link went down: the retained snapshot says stale, so that
         * a subscriber that comes later does not take it as current. */
        if (t->snap_due[r] && room(t) && publish_snapshot(t, r))
            t->snap_due[r] = false;
        return;
    }
    bool full = t->full_due[r];
    if (now >= t->next_pub_us[r] && room(t) && (!full || snapshot_ready(t, r, now)) &&
        publish_data(t, r, full)) {
        t->full_due[r] = false;
        t->data_seen[r] = false;
        t->next_pub_us[r] = now + (uint64_t)t->cfg.publish_interval_ms * 1000u;
    }
    if (t->snap_due[r] && !t->full_due[r] && now >= t->next_snap_us[r] && room(t) &&
        publish_snapshot(t, r)) {
        t->snap_due[r] = false;
        t->next_snap_us[r] = now + MQ_SNAPSHOT_US;
    }
}

static void mq_tick(void *self, uint64_t now)
{
    mq_t *t = self;
    if (!t->cfg.enabled)
        return;
    if (!t->connected && !t->connecting) {
        if (t->retry_us != 0 && now >= t->retry_us)
            try_connect(t, now);
        return;
    }
    if (t->connecting && !t->connected && now >= t->connect_deadline_us) {
        mq_down(t, "no answer from %s:%u%s", server(t)->host, server(t)->port,
                t->lookup != NULL ? " (its name's lookup is still running)" : "");
        next_server(t, "no answer");
        drop_connection(t, now);
        return;
    }
    if (lookup_tick(t, now))
        return;
    if (!t->connected && !t->connecting)
        return; /* the lookup failed: the next attempt is scheduled */
    (void)ml->loop_misc(t->mosq); /* keepalive: PINGREQ, or a dead broker */
    if (t->spb != NULL) {
        if (leave_due(t, now))
            return;
        if (t->connected && spb_ready(t->spb)) {
            t->backoff_us = MQ_BACKOFF_MIN_US; /* a good server */
            t->host_wait_us = 0;
        } else if (t->host_wait_us != 0 && now >= t->host_wait_us) {
            mq_down(t, "sparkplug: primary host %s not online on %s:%u within %u s",
                    t->cfg.primary_host_id, server(t)->host, server(t)->port,
                    t->cfg.host_wait_s);
            next_server(t, "primary host not online");
            drop_connection(t, now);
            return;
        }
        spb_tick(t->spb, now);
        sync_watch(t, now);
        return;
    }
    if (t->status_due && room(t))
        t->status_due = !publish_text(t, -1, "status", "online", t->cfg.retain);
    if (!t->status_due && t->gone_count > 0 && room(t)) {
        for (unsigned i = 0; i < t->gone_count; i++)
            retire(t, t->gone[i], false); /* a few small messages: queued at once */
        t->gone_count = 0;
    }
    for (unsigned r = 0; r < t->env->cfg->robot_count && !t->status_due; r++)
        tick_robot(t, r, now);
    sync_watch(t, now);
}

static uint64_t mq_deadline(const void *self)
{
    const mq_t *t = self;
    if (!t->cfg.enabled)
        return UINT64_MAX;
    if (!t->connected && !t->connecting)
        return t->retry_us != 0 ? t->retry_us : UINT64_MAX;
    if (!t->connected && t->lookup != NULL) {
        uint64_t poll_us = ev_now_us() + MQ_LOOKUP_POLL_US;
        return poll_us < t->connect_deadline_us ? poll_us : t->connect_deadline_us;
    }
    if (!t->connected)
        return t->connect_deadline_us;
    if (t->leave_us != 0)
        return t->leave_us; /* or the PUBACK's readiness */
    if (t->host_wait_us != 0 && !room(t))
        return t->host_wait_us;
    if (!room(t))
        return UINT64_MAX; /* EPOLLOUT, or the broker's acknowledgements, first */
    if (t->spb != NULL) {
        uint64_t d = spb_deadline(t->spb, ev_now_us());
        return t->host_wait_us != 0 && t->host_wait_us < d ? t->host_wait_us : d;
    }
    /* Wake for a robot whose data arrived, when its interval allows it;
     * other robots' O->T images are looked at with the 10 Hz tick. */
    uint64_t d = UINT64_MAX, now = ev_now_us();
    for (unsigned r = 0; r < t->env->cfg->robot_count; r++) {
        uint64_t x = UINT64_MAX;
        if (t->link[r] && t->full_due[r])
            x = snapshot_ready(t, r, now) ? t->next_pub_us[r] : t->up_us[r] + 1000000u;
        else if (t->link[r] && t->data_seen[r])
            x = t->next_pub_us[r];
        if (t->link[r] && t->snap_due[r] && !t->full_due[r] && t->next_snap_us[r] < x)
            x = t->next_snap_us[r];
        if (x < d)
            d = x;
    }
    return d;
}

static void mq_on_data(void *self, unsigned robot, dr_asm_t a)
{
    mq_t *t = self;
    if (robot < GW_MAX_ROBOTS) {
        t->data_seen[robot] = true;
        t->asm_seen[robot] |= 1u << a;
    }
    if (t->spb != NULL)
        spb_on_data(t->spb, robot, a);
}

static void mq_on_link(void *self, unsigned robot, bool up)
{
    mq_t *t = self;
    if (t->spb != NULL)
        spb_on_link(t->spb, robot, up);
    if (robot >= GW_MAX_ROBOTS || t->link[robot] == up)
        return;
    t->link[robot] = up;
    t->state_due[robot] = true;
    if (!up)
        t->snap_due[robot] = true; /* the retained snapshot: stale now */
    if (up) {
        t->full_due[robot] = true; /* the plant gets every field afresh */
        t->next_snap_us[robot] = 0;  /* and the snapshot with it */
        t->asm_seen[robot] = 0;
        t->up_us[robot] = ev_now_us();
    }
}

static void mq_on_fault(void *self, unsigned robot, bool latched)
{
    (void)self, (void)robot, (void)latched; /* writes look at the robot's fault */
}

static void mq_refresh(void *self)
{
    (void)self;
}

static void mq_safe(void *self)
{
    (void)self; /* no outputs of its own */
}

static void mq_side_free(void *self)
{
    mq_t *t = self;
    if (t == NULL)
        return;
    mq_goodbye(t, "the daemon stops");
    mq_free(t);
}

/* ---- the console: last write, report and metrics ------------------------------- */

/* "mqtt": {"broker", "client_id", "connected", "published", "writes":
 * {"accepted", "refused"}, "reconnects", "reason"}; nothing without
 * [mqtt]. reason: null while connected, else the last warning's words
 * ("cannot connect to ...: connection refused"), or "connecting". */
static void mq_report(const void *self, gw_json_t *j)
{
    const mq_t *t = self;
    char num[192];
    if (t == NULL || !t->cfg.enabled)
        return;
    snprintf(num, sizeof num, "%s:%u", server(t)->host, server(t)->port);
    gw_json_str(j, "\"mqtt\":{\"broker\":");
    gw_json_quote(j, num, strlen(num));
    gw_json_str(j, ",\"client_id\":");
    gw_json_quote(j, t->client_id, strlen(t->client_id));
    gw_json_str(j, ",\"topic_prefix\":");
    gw_json_quote(j, t->prefix, strlen(t->prefix));
    snprintf(num, sizeof num,
             ",\"connected\":%s,\"published\":%llu,\"writes\":{\"enabled\":%s,"
             "\"accepted\":%llu,\"refused\":%llu},\"reconnects\":%llu",
             t->connected ? "true" : "false", t->con.published, t->cfg.writes ? "true" : "false",
             t->con.accepted, t->con.received - t->con.accepted,
             t->con.connects > 0 ? t->con.connects - 1u : 0u);
    gw_json_str(j, num);
    gw_json_str(j, ",\"reason\":");
    if (t->connected)
        gw_json_str(j, "null");
    else if (t->down_why[0] != '\0')
        gw_json_quote(j, t->down_why, strlen(t->down_why));
    else
        gw_json_str(j, "\"connecting\"");
    gw_json_str(j, "}");
}

static void mq_metrics(const void *self, gw_prom_t *p)
{
    const mq_t *t = self;
    if (t == NULL || !t->cfg.enabled)
        return;
    gw_prom_one(p, "drgate_mqtt_connected", GW_PROM_GAUGE,
                "1 while the gateway is connected to the MQTT broker", t->connected ? 1 : 0);
    gw_prom_one(p, "drgate_mqtt_published_total", GW_PROM_COUNTER,
                "MQTT messages handed to the broker connection", (double)t->con.published);
    gw_prom_family(p, "drgate_mqtt_writes_total", GW_PROM_COUNTER,
                   "Plant writes (<prefix>/<robot>/set/<path>) by result");
    gw_prom_label_t ok = {"result", "accepted"}, no = {"result", "refused"};
    gw_prom_sample(p, "drgate_mqtt_writes_total", &ok, 1, (double)t->con.accepted);
    gw_prom_sample(p, "drgate_mqtt_writes_total", &no, 1,
                   (double)(t->con.received - t->con.accepted));
    gw_prom_one(p, "drgate_mqtt_reconnects_total", GW_PROM_COUNTER,
                "Connections to the broker after the first",
                t->con.connects > 0 ? (double)(t->con.connects - 1u) : 0.0);
}

/* "MQTT: connected to broker:1883" */
static void mq_summary(const void *self, gw_side_summary_t *s)
{
    const mq_t *t = self;
    if (t == NULL || !t->cfg.enabled)
        return;
    snprintf(s->label, sizeof s->label, "MQTT");
    snprintf(s->line, sizeof s->line, "%s %s:%u", t->connected ? "connected to" : "not connected to",
             server(t)->host, (unsigned)server(t)->port);
    snprintf(s->brief, sizeof s->brief, "%s", t->connected ? "MQTT connected" : "MQTT not connected");
}

const gw_north_ops_t gw_north_mqtt = {
    .name = "mqtt",
    .create = mq_create,
    .prepare = mq_prepare,
    .abort = mq_abort,
    .commit = mq_commit,
    .tick = mq_tick,
    .deadline = mq_deadline,
    .on_data = mq_on_data,
    .on_link = mq_on_link,
    .on_fault = mq_on_fault,
    .refresh = mq_refresh,
    .safe = mq_safe,
    .free = mq_side_free,
    .report = mq_report,
    .metrics = mq_metrics,
    .summary = mq_summary,
};
