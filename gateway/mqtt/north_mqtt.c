/* SPDX-License-Identifier: MIT */
/*
 * MQTT as a northbound side (north.h): the robots' fields published to a
 * broker, plant writes taken from it ([mqtt], docs/mqtt.md).
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
 *   <prefix>/<robot>/data         {"path": value, ...}: what changed; all
 *                                 fields after a (re)connect or link up
 *   <prefix>/<robot>/set/<path>   plant writes (writes = yes): the value as text
 *   <prefix>/<robot>/error        {"topic", "payload", "error"}: a refused write
 */
#include <errno.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <unistd.h>

#include <mosquitto.h>

#include "common/ev.h"
#include "drgate/text.h"
#include "core/json.h"
#include "core/log.h"
#include "mqtt/mqtt_lib.h"
#include "core/north.h"
#include "core/report.h"

#define MQ_BACKOFF_MIN_US 500000u    /* first reconnect after 0.5 s ... */
#define MQ_BACKOFF_MAX_US 30000000u  /* ... doubling up to 30 s */
#define MQ_CONNECT_TIMEOUT_US 10000000u /* no CONNACK within 10 s: retry */
#define MQ_MAX_INFLIGHT 16u          /* QoS 1/2 messages awaiting the broker */
#define MQ_JSON_MAX 65536u           /* the largest payload (meta) is ~30 kB */
#define MQ_SET_MAX 64u               /* a write's value text */
#define MQ_READS_PER_EVENT 64        /* packets read per readiness event */
#define MQ_ERR_QUEUE 32u             /* error replies queued at once */

typedef struct {
    bool have;
    double v;
} mq_last_t;

typedef struct {
    const gw_north_env_t *env;
    gw_mqtt_config_t cfg; /* a copy: a reload compares the new one with it */
    struct mosquitto *mosq;
    ev_t ev;
    char prefix[160], client_id[80];
    char password[256];
    bool connected;     /* CONNACK accepted */
    bool connecting;    /* a connection is being made */
    uint64_t retry_us;  /* next connection attempt (when neither of the above) */
    uint64_t connect_deadline_us;
    uint64_t backoff_us;
    unsigned inflight;  /* QoS 1/2 publications not yet acknowledged */
    unsigned leaves;    /* dr_leaf_count() */
    mq_last_t *last[GW_MAX_ROBOTS]; /* what was last published, by leaf */
    uint16_t *pick;      /* publish_data: the leaves in this message ... */
    double *pick_v;      /* ... and their values */
    bool link[GW_MAX_ROBOTS];
    dr_status_t state_why[GW_MAX_ROBOTS]; /* the cause in the last state published */
    bool state_due[GW_MAX_ROBOTS], meta_due[GW_MAX_ROBOTS], full_due[GW_MAX_ROBOTS];
    bool status_due;
    bool data_seen[GW_MAX_ROBOTS]; /* new T->O data since the last scan */
    unsigned asm_seen[GW_MAX_ROBOTS]; /* T->O assemblies received since link up */
    uint64_t up_us[GW_MAX_ROBOTS];    /* when the link came up */
    uint64_t next_pub_us[GW_MAX_ROBOTS];
    unsigned err_queued;   /* error replies given since libmosquitto's queue was empty */
    unsigned long dropped; /* error replies dropped (queue bound) */
    gw_json_t json; /* over json_buf */
    char json_buf[MQ_JSON_MAX];
    /* the console's (mq_report, mq_metrics): counters since the side started */
    struct { unsigned long long published, received, accepted, connects; gw_log_limit_t write_log[GW_MAX_ROBOTS]; } con;
} mq_t;

static void mq_wrote(mq_t *t, unsigned robot, const char *path, const struct mosquitto_message *m);

static unsigned lib_users; /* mosquitto_lib_init/cleanup around the sides */
/* libmosquitto's functions (mqtt_lib.h): loaded by the first enabled
 * side's mq_new, then kept for the life of the process; every call below
 * is made by an enabled side, so after the load. */
static const gw_mqttlib_t *ml;

/* ---- topics and publishing ------------------------------------------------------ */

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

static bool publish(mq_t *t, const char *top, const void *payload, size_t len, bool retain)
{
    int mid = 0;
    int rc = ml->publish(t->mosq, &mid, top, (int)len, payload, (int)t->cfg.qos, retain);
    if (rc != MOSQ_ERR_SUCCESS) {
        gw_log(GW_LOG_DEBUG, "mqtt: publish %s: %s", top, ml->strerror(rc));
        return false;
    }
    if (t->cfg.qos > 0)
        t->inflight++;
    t->con.published++;
    return true;
}

static bool publish_text(mq_t *t, int robot, const char *leaf, const char *text, bool retain)
{
    char top[256];
    topic(t, top, sizeof top, robot, leaf);
    return publish(t, top, text, strlen(text), retain);
}

static const char *type_name(const dr_field_t *f)
{
    return dr_kind_name((dr_kind_t)f->kind);
}

/* Every leaf with its type, unit and direction: the units of data. */
static bool publish_meta(mq_t *t, unsigned robot)
{
    gw_json_t *j = &t->json;
    gw_json_init(j, t->json_buf, sizeof t->json_buf);
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

/* Did a leaf change enough to be published? REALs by the deadband. */
static bool changed(const mq_t *t, const mq_last_t *l, const dr_value_t *v)
{
    if (!l->have)
        return true;
    double x = dr_value_as_double(v);
    if (v->type != DR_VAL_REAL)
        return x != l->v;
    if (isnan(x) || isnan(l->v))
        return isnan(x) != isnan(l->v);
    if (isinf(x) || isinf(l->v))
        return x != l->v;
    return fabs(x - l->v) > t->cfg.deadband || (t->cfg.deadband == 0.0 && x != l->v);
}

/* The leaves that changed since they were last published (all of them
 * with `full`), as one JSON object; nothing if none did. */
static bool publish_data(mq_t *t, unsigned robot, bool full)
{
    const gw_robot_t *rb = &t->env->robots[robot];
    gw_json_t *j = &t->json;
    mq_last_t *last = t->last[robot];
    gw_json_init(j, t->json_buf, sizeof t->json_buf);
    gw_json_raw(j, "{", 1);
    unsigned n = 0;
    for (unsigned i = 0; i < t->leaves; i++) {
        dr_ref_t ref;
        dr_value_t v;
        char path[96];
        if (dr_leaf_at((uint16_t)i, &ref) != DR_OK)
            continue;
        if (gw_robot_get(rb, ref, &v) != DR_OK)
            continue;
        if (!full && !changed(t, &last[i], &v))
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
    if (n == 0 || j->full)
        return true;
    char top[256];
    topic(t, top, sizeof top, (int)robot, "data");
    if (!publish(t, top, j->buf, j->len, false))
        return false;
    /* Only now, and only what the message holds: a change within the
     * deadband is measured from the value the plant has, so that a slow
     * drift is published once it adds up. */
    for (unsigned k = 0; k < n; k++) {
        last[t->pick[k]].have = true;
        last[t->pick[k]].v = t->pick_v[k];
    }
    return true;
}

/* ---- plant writes ---------------------------------------------------------------- */

static void refuse(mq_t *t, unsigned robot, const struct mosquitto_message *m, const char *why)
{
    gw_log(GW_LOG_INFO, "mqtt: write %s refused: %s", m->topic, why);
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
    gw_json_init(j, t->json_buf, sizeof t->json_buf);
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

/* Is this bit driven by a GPIO input of the robot's (and so not the
 * plant's to write)? */
static bool gpio_driven(const gw_config_t *cfg, unsigned robot, dr_ref_t ref)
{
    for (unsigned i = 0; i < cfg->gpio_count; i++) {
        const gw_gpio_config_t *g = &cfg->gpio[i];
        if (g->dir == GW_GPIO_INPUT && g->robot_index == robot && g->field.field == ref.field &&
            (ref.elem < 0 || g->field.elem < 0 || g->field.elem == ref.elem))
            return true;
    }
    return false;
}

/* <prefix>/<robot>/set/<path>, the payload the value as text: the same
 * checks as a Modbus write (the codec's range and finiteness checks, GPIO
 * inputs' bits, the latched write fault), and in single-writer mode the
 * outputs belong to the one Modbus writer: refused. */
static void on_set(mq_t *t, unsigned robot, const char *path, const struct mosquitto_message *m)
{
    const gw_config_t *cfg = t->env->cfg;
    gw_robot_t *rb = &t->env->robots[robot];
    char text[MQ_SET_MAX + 1], why[160];
    dr_ref_t ref;
    dr_value_t v;
    dr_status_t st = dr_path_parse(path, &ref);
    if (st != DR_OK) {
        char near[96];
        if (dr_path_closest(path, near, sizeof near) == DR_OK)
            snprintf(why, sizeof why, "unknown field (did you mean %s?)", near);
        else
            snprintf(why, sizeof why, "unknown field");
        refuse(t, robot, m, why);
        return;
    }
    if (m->payloadlen <= 0 || (size_t)m->payloadlen > MQ_SET_MAX ||
        memchr(m->payload, '\0', (size_t)m->payloadlen) != NULL) {
        refuse(t, robot, m, "payload must be the value as text, 1..64 bytes");
        return;
    }
    memcpy(text, m->payload, (size_t)m->payloadlen);
    text[m->payloadlen] = '\0';
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    st = dr_text_parse(ref, text, DR_SET_O2T_ONLY, &v);
    if (st == DR_EREADONLY)
        refuse(t, robot, m, "read-only: a T->O field");
    else if (st != DR_OK) {
        snprintf(why, sizeof why, "invalid value: %s", dr_strerror(st));
        refuse(t, robot, m, why);
    } else if (cfg->modbus.single_writer)
        refuse(t, robot, m, "single-writer mode: the outputs belong to the Modbus writer");
    else if (rb->fault)
        refuse(t, robot, m, "write fault latched (reset it through Modbus)");
    else if (gpio_driven(cfg, robot, ref))
        refuse(t, robot, m, "driven by a GPIO input");
    else if ((st = dr_field_set(rb->img[a], dr_asm_info(a)->size, ref, &v, DR_SET_O2T_ONLY)) !=
             DR_OK) {
        snprintf(why, sizeof why, "invalid value: %s", dr_strerror(st));
        refuse(t, robot, m, why);
    } else {
        gw_log(GW_LOG_DEBUG, "mqtt: %s = %s", m->topic, text);
        mq_wrote(t, robot, path, m);
        t->env->outputs_changed(t->env->user, robot, 1u << a);
    }
}

static void on_message(struct mosquitto *mosq, void *obj, const struct mosquitto_message *m)
{
    mq_t *t = obj;
    (void)mosq;
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

static void on_connect(struct mosquitto *mosq, void *obj, int rc)
{
    mq_t *t = obj;
    (void)mosq;
    t->connecting = false;
    if (rc != 0) {
        gw_log(GW_LOG_WARNING, "mqtt: broker %s:%u refused the connection: %s", t->cfg.host,
               t->cfg.port, ml->connack_string(rc));
        return; /* libmosquitto closes; tick() retries */
    }
    gw_log(GW_LOG_INFO, "mqtt: connected to %s:%u", t->cfg.host, t->cfg.port);
    t->connected = true;
    t->con.connects++;
    t->backoff_us = MQ_BACKOFF_MIN_US;
    t->inflight = 0;
    t->status_due = true;
    for (unsigned r = 0; r < t->env->cfg->robot_count; r++) {
        t->state_due[r] = t->meta_due[r] = t->full_due[r] = true;
        t->next_pub_us[r] = 0;
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
    if (t->connected)
        gw_log(GW_LOG_WARNING, "mqtt: connection to %s:%u lost (%s)", t->cfg.host, t->cfg.port,
               rc == 0 ? "closed" : ml->strerror(rc));
    t->connected = false;
}

static void on_publish(struct mosquitto *mosq, void *obj, int mid)
{
    mq_t *t = obj;
    (void)mosq, (void)mid;
    if (t->inflight > 0)
        t->inflight--;
}

static void on_ready(void *obj, uint32_t events);

/* The socket into the loop as libmosquitto now has it; a connection that
 * went away schedules the next attempt. */
static void sync_watch(mq_t *t, uint64_t now)
{
    int fd = ml->socket(t->mosq);
    if (fd < 0) {
        ev_unwatch(t->env->epfd, &t->ev);
        if (t->connected || t->connecting) {
            if (t->connecting)
                gw_log(GW_LOG_WARNING, "mqtt: cannot connect to %s:%u", t->cfg.host, t->cfg.port);
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
    (void)ml->disconnect(t->mosq); /* closes the socket */
    t->connected = t->connecting = false;
    t->retry_us = 0;
    sync_watch(t, now);
}

static void try_connect(mq_t *t, uint64_t now)
{
    t->retry_us = 0;
    ev_unwatch(t->env->epfd, &t->ev); /* the socket is replaced */
    /* Non-blocking connect; the host name (if not an address) is resolved
     * here, the one blocking step (docs/mqtt.md). */
    int rc = ml->connect_async(t->mosq, t->cfg.host, t->cfg.port, (int)t->cfg.keepalive_s);
    if (rc != MOSQ_ERR_SUCCESS) {
        gw_log(GW_LOG_DEBUG, "mqtt: connect %s:%u: %s", t->cfg.host, t->cfg.port,
               rc == MOSQ_ERR_ERRNO ? strerror(errno) : ml->strerror(rc));
        t->connecting = true; /* logged by sync_watch */
    } else {
        t->connecting = true;
        t->connect_deadline_us = now + MQ_CONNECT_TIMEOUT_US;
    }
    sync_watch(t, now);
}

static void on_ready(void *obj, uint32_t events)
{
    mq_t *t = obj;
    uint64_t now = ev_now_us();
    if (events & (EPOLLIN | EPOLLERR | EPOLLHUP)) {
        /* libmosquitto reads a few packets per call; TLS may hold more
         * than the socket shows: read until it would block. */
        for (int i = 0; i < MQ_READS_PER_EVENT && ml->socket(t->mosq) >= 0; i++) {
            errno = 0;
            if (ml->loop_read(t->mosq, 1) != MOSQ_ERR_SUCCESS || errno == EAGAIN ||
                errno == EWOULDBLOCK)
                break;
        }
    }
    if ((events & EPOLLOUT) && ml->socket(t->mosq) >= 0)
        (void)ml->loop_write(t->mosq, 1);
    sync_watch(t, now);
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
    if ((ml = gw_mqttlib_load(err, errlen)) == NULL) {
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
    char will[200];
    snprintf(will, sizeof will, "%s/status", t->prefix);
    int rc = ml->will_set(t->mosq, will, 7, "offline", (int)q->qos, q->retain);
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
        t->next_pub_us[r] = 0;
        t->asm_seen[r] = ~0u; /* a link up now has its images */
        if (t->last[r] != NULL)
            memset(t->last[r], 0, t->leaves * sizeof *t->last[r]);
    }
    t->status_due = true;
}

/* Shutdown or replacement: "offline" and a clean DISCONNECT (the broker
 * then does not send the Will), flushed for at most a second. */
static void mq_goodbye(mq_t *t)
{
    if (!t->connected)
        return;
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
    if (t->mosq != NULL)
        ml->destroy(t->mosq);
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        free(t->last[r]);
    free(t->pick);
    free(t->pick_v);
    if (t->cfg.enabled && --lib_users == 0)
        ml->lib_cleanup();
    free(t);
}

static void *mq_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    mq_t *t = mq_new(&env->cfg->mqtt, env, err, errlen);
    if (t != NULL && t->cfg.enabled) {
        mq_sync_robots(t, false);
        try_connect(t, ev_now_us());
    }
    return t;
}

/* Everything but where the section is in the file. */
static bool same_config(const gw_mqtt_config_t *a, const gw_mqtt_config_t *b)
{
    return a->enabled == b->enabled && strcmp(a->host, b->host) == 0 && a->port == b->port &&
           strcmp(a->client_id, b->client_id) == 0 && strcmp(a->username, b->username) == 0 &&
           strcmp(a->password_file, b->password_file) == 0 &&
           strcmp(a->ca_file, b->ca_file) == 0 && strcmp(a->cert_file, b->cert_file) == 0 &&
           strcmp(a->key_file, b->key_file) == 0 && a->keepalive_s == b->keepalive_s &&
           a->qos == b->qos && strcmp(a->topic_prefix, b->topic_prefix) == 0 &&
           a->retain == b->retain && a->publish_interval_ms == b->publish_interval_ms &&
           !(a->deadband < b->deadband || a->deadband > b->deadband) && a->writes == b->writes;
}

/* An unchanged [mqtt] keeps its connection; a changed one is prepared
 * unconnected (files read, TLS set up) and connects at commit. */
static gw_north_reload_t mq_prepare(void *self, const gw_config_t *next,
                                    const gw_north_env_t *env, void **out, char *err,
                                    size_t errlen)
{
    mq_t *t = self;
    if (same_config(&t->cfg, &next->mqtt)) {
        *out = self;
        return GW_NORTH_OK;
    }
    *out = mq_new(&next->mqtt, env, err, errlen);
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
        mq_goodbye(t);
        mq_free(t);
        if (n->cfg.enabled)
            try_connect(n, ev_now_us());
    }
    if (n->cfg.enabled)
        mq_sync_robots(n, true); /* robots may have moved, come or gone */
    return n;
}

/* After link up, the snapshot waits for every T->O assembly (each its own
 * packet), so that it holds what the robot sent, not zeros; at most a
 * second (an explicit-mode robot may not poll them all). */
static bool snapshot_ready(const mq_t *t, unsigned r, uint64_t now)
{
    unsigned all = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O)
            all |= 1u << a;
    return (t->asm_seen[r] & all) == all || now >= t->up_us[r] + 1000000u;
}

/* "up", or "down" with the cause the status block has (last_error), in
 * the same words as the log: "down: connection refused". */
static bool publish_state(mq_t *t, unsigned r)
{
    char text[200], cause[160];
    dr_status_t why = t->link[r] ? DR_OK : t->env->robots[r].link.last_status;
    gw_robot_error_text(why, cause, sizeof cause);
    snprintf(text, sizeof text, "%s%s%s", t->link[r] ? "up" : "down", cause[0] ? ": " : "", cause);
    t->state_why[r] = why;
    return publish_text(t, (int)r, "state", text, t->cfg.retain);
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
        gw_log(GW_LOG_WARNING, "mqtt: no answer from %s:%u", t->cfg.host, t->cfg.port);
        drop_connection(t, now);
        return;
    }
    (void)ml->loop_misc(t->mosq); /* keepalive: PINGREQ, or a dead broker */
    if (t->status_due && room(t))
        t->status_due = !publish_text(t, -1, "status", "online", t->cfg.retain);
    const gw_config_t *cfg = t->env->cfg;
    for (unsigned r = 0; r < cfg->robot_count && !t->status_due; r++) {
        if (!t->link[r] && t->env->robots[r].link.last_status != t->state_why[r])
            t->state_due[r] = true; /* down for another cause now */
        if (t->state_due[r] && room(t))
            t->state_due[r] = !publish_state(t, r);
        if (t->meta_due[r] && room(t))
            t->meta_due[r] = !publish_meta(t, r);
        /* Data only while the link is up (else it is not the robot's) and
         * at most once per publish_interval_ms; the O->T images (written
         * by Modbus, GPIO or the plant) are compared at that pace too. */
        if (!t->link[r] || now < t->next_pub_us[r] || !room(t))
            continue;
        bool full = t->full_due[r];
        if (full && !snapshot_ready(t, r, now))
            continue;
        if (publish_data(t, r, full)) {
            t->full_due[r] = false;
            t->data_seen[r] = false;
            t->next_pub_us[r] = now + (uint64_t)t->cfg.publish_interval_ms * 1000u;
        }
    }
    sync_watch(t, now);
}

static uint64_t mq_deadline(const void *self)
{
    const mq_t *t = self;
    if (!t->cfg.enabled)
        return UINT64_MAX;
    if (!t->connected && !t->connecting)
        return t->retry_us != 0 ? t->retry_us : UINT64_MAX;
    if (!t->connected)
        return t->connect_deadline_us;
    if (!room(t))
        return UINT64_MAX; /* EPOLLOUT, or the broker's acknowledgements, first */
    /* Wake for a robot whose data arrived, when its interval allows it;
     * other robots' O->T images are looked at with the 10 Hz tick. */
    uint64_t d = UINT64_MAX, now = ev_now_us();
    for (unsigned r = 0; r < t->env->cfg->robot_count; r++) {
        uint64_t x = UINT64_MAX;
        if (t->link[r] && t->full_due[r])
            x = snapshot_ready(t, r, now) ? t->next_pub_us[r] : t->up_us[r] + 1000000u;
        else if (t->link[r] && t->data_seen[r])
            x = t->next_pub_us[r];
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
}

static void mq_on_link(void *self, unsigned robot, bool up)
{
    mq_t *t = self;
    if (robot >= GW_MAX_ROBOTS || t->link[robot] == up)
        return;
    t->link[robot] = up;
    t->state_due[robot] = true;
    if (up) {
        t->full_due[robot] = true; /* the plant gets every field afresh */
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
    mq_goodbye(t);
    mq_free(t);
}

/* ---- the console: last write, report and metrics ------------------------------- */

/* An accepted plant write: the robot's last write, logged (rate-limited
 * per robot: the broker does not say which plant client sent it). */
static void mq_wrote(mq_t *t, unsigned robot, const char *path, const struct mosquitto_message *m)
{
    char who[GW_WRITE_CLIENT];
    snprintf(who, sizeof who, "mqtt %s", m->topic);
    t->con.accepted++;
    gw_write_accepted(&t->env->robots[robot], &t->con.write_log[robot], who, path);
}

/* "mqtt": {"broker", "client_id", "connected", "published", "writes":
 * {"accepted", "refused"}, "reconnects"}; nothing without [mqtt]. */
static void mq_report(const void *self, gw_json_t *j)
{
    const mq_t *t = self;
    char num[192];
    if (t == NULL || !t->cfg.enabled)
        return;
    snprintf(num, sizeof num, "%s:%u", t->cfg.host, t->cfg.port);
    gw_json_str(j, "\"mqtt\":{\"broker\":");
    gw_json_quote(j, num, strlen(num));
    gw_json_str(j, ",\"client_id\":");
    gw_json_quote(j, t->client_id, strlen(t->client_id));
    gw_json_str(j, ",\"topic_prefix\":");
    gw_json_quote(j, t->prefix, strlen(t->prefix));
    snprintf(num, sizeof num,
             ",\"connected\":%s,\"published\":%llu,\"writes\":{\"enabled\":%s,"
             "\"accepted\":%llu,\"refused\":%llu},\"reconnects\":%llu}",
             t->connected ? "true" : "false", t->con.published, t->cfg.writes ? "true" : "false",
             t->con.accepted, t->con.received - t->con.accepted,
             t->con.connects > 0 ? t->con.connects - 1u : 0u);
    gw_json_str(j, num);
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

const gw_north_ops_t gw_north_mqtt = {
    "mqtt",     mq_create,  mq_prepare,  mq_abort,  mq_commit, mq_tick,      mq_deadline,
    mq_on_data, mq_on_link, mq_on_fault, mq_refresh, mq_safe,  mq_side_free,
    mq_report,  mq_metrics,
};
