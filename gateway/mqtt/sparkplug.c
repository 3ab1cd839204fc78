/* SPDX-License-Identifier: MIT */
/*
 * Sparkplug B over the MQTT side's connection (sparkplug.h, docs/mqtt.md
 * "Sparkplug B").
 *
 * Topics (G = group_id, E = edge_node_id, D = a robot's name):
 *   spBv1.0/G/NBIRTH/E     bdSeq, Node Control/Rebirth and /Next Server; seq 0
 *   spBv1.0/G/NDEATH/E     bdSeq: the connection's Will, or before a
 *                          deliberate disconnect
 *   spBv1.0/G/DBIRTH/E/D   every field: name, alias, datatype, engUnit, value
 *   spBv1.0/G/DDATA/E/D    the fields that changed, by alias
 *   spBv1.0/G/DDEATH/E/D   the robot's link went down
 *   spBv1.0/G/NCMD/E       Node Control/Rebirth = true: births again;
 *                          Node Control/Next Server = true: the next server
 *   spBv1.0/G/DCMD/E/D     plant writes (writes = yes)
 *   spBv1.0/STATE/H        the primary host's state (primary_host_id = H)
 *
 * seq runs 0..255 over every message but NDEATH, NBIRTH being 0; bdSeq
 * 0..255 grows with every CONNECT the broker answers, over reloads and,
 * kept in bdseq_file, over restarts (docs/mqtt.md "seq and bdSeq").
 * Births and data go at QoS 0, NDEATH at QoS 1, nothing retained; every
 * metric of NBIRTH, DBIRTH and DDATA has its timestamp (Sparkplug 3.0).
 * Aliases are unique over the node and small (a DDATA metric is mostly
 * its alias and timestamp): a robot's field 2 + robot index * leaves +
 * its leaf number; Node Control/Rebirth has none (the specification
 * forbids aliasing it).
 */
#include "mqtt/sparkplug.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <pb_decode.h>
#include <pb_encode.h>

#include "common/ev.h"
#include "core/log.h"
#include "mqtt/deadband.h"
#include "drgate/text.h"

#define SPB_NS "spBv1.0"
#define SPB_BUF 65536u           /* a DBIRTH of every field is ~25 kB */
#define SPB_ALIAS_FIRST 2u /* a robot's fields: 2 + robot * leaves + leaf */
#define SPB_SNAPSHOT_WAIT_US 1000000u /* DBIRTH waits for every T->O image, at most 1 s */

struct spb {
    const gw_north_env_t *env;
    spb_io_t io;
    char group[64], edge[64], host_id[64];
    unsigned interval_ms;
    double deadband;
    bool writes;
    unsigned names;   /* SPB_NAMES_* */
    unsigned leaves;
    uint8_t bd_next;  /* the bdSeq of the next CONNECT */
    uint8_t bd;       /* this connection's (NBIRTH) */
    bool bd_used;     /* the broker answered this bdSeq's CONNECT */
    bool bd_warned;   /* bdseq_file could not be written: said once */
    bool state_warned; /* a STATE not in 3.0's form: said once */
    char bd_file[400];
    uint8_t seq;      /* of the last message published */
    bool connected;
    bool leaving;     /* this connection is being left (io.leave): nothing more on it */
    bool host_online; /* the primary host's STATE (true without one) */
    uint64_t host_ts; /* the newest STATE's timestamp (ms): an older one is stale */
    bool nbirth_due;  /* NBIRTH (and then every DBIRTH) to publish */
    bool born;        /* NBIRTH published on this connection */
    bool link[GW_MAX_ROBOTS];
    bool dev_born[GW_MAX_ROBOTS];  /* DBIRTH published, no DDEATH since */
    char born_as[GW_MAX_ROBOTS][GW_NAME_MAX]; /* the device ID of that DBIRTH */
    char gone[GW_MAX_ROBOTS][GW_NAME_MAX]; /* born devices a reload removed: DDEATH due */
    unsigned gone_count;
    bool ddeath_due[GW_MAX_ROBOTS];
    unsigned asm_seen[GW_MAX_ROBOTS];
    bool data_seen[GW_MAX_ROBOTS]; /* robot data since the last DDATA look */
    uint64_t up_us[GW_MAX_ROBOTS];
    uint64_t next_pub_us[GW_MAX_ROBOTS];
    uint64_t data_ms[GW_MAX_ROBOTS]; /* wall clock of the robot's last packet */
    gw_mqtt_last_t *last[GW_MAX_ROBOTS];
    /* Leaves of refused DCMDs whose current value is to go back (one
     * DDATA for all, as soon as there is room), a bit per leaf. */
    uint8_t *echo[GW_MAX_ROBOTS];
    bool echo_due[GW_MAX_ROBOTS];
    unsigned long refused;  /* DCMD refusals, for the log's rate */
    uint64_t refused_log_us;
    char topic[256];
    char will_topic[256];
    uint8_t will[64];
    size_t will_len;
    uint8_t bye[64];  /* a deliberate stop's NDEATH, stamped then */
    Payload_Metric m; /* the metric being encoded */
    char name[160], path[96]; /* its name and canonical path */
    /* The DCMD being decoded: its writes, and the leaf of each metric
     * that named one (published back if the command is refused). */
    gw_write_item_t cmd_items[SPB_CMD_MAX];
    int cmd_leaf[SPB_CMD_MAX];
    uint8_t buf[SPB_BUF];
};

/* ---- time, topics ------------------------------------------------------------ */

static uint64_t wall_ms(void)
{
    struct timespec ts;
    if (clock_gettime(CLOCK_REALTIME, &ts) != 0)
        return 0;
    return (uint64_t)ts.tv_sec * 1000u + (uint64_t)ts.tv_nsec / 1000000u;
}

/* spBv1.0/<group>/<type>/<edge>[/<robot name>] */
static const char *topic(spb_t *s, const char *type, int robot)
{
    if (robot < 0)
        snprintf(s->topic, sizeof s->topic, SPB_NS "/%s/%s/%s", s->group, type, s->edge);
    else
        snprintf(s->topic, sizeof s->topic, SPB_NS "/%s/%s/%s/%s", s->group, type, s->edge,
                 s->env->cfg->robot[robot].name);
    return s->topic;
}

/* ---- fields as metrics ----------------------------------------------------------- */

static uint32_t datatype_of(dr_ref_t ref)
{
    switch (dr_ref_type(ref)) {
    case DR_VAL_BOOL:
        return SPB_DT_BOOLEAN;
    case DR_VAL_UINT:
        return SPB_DT_UINT8; /* USINT, ENUM (BITS masks are not leaves) */
    case DR_VAL_INT:
        return SPB_DT_INT32;
    case DR_VAL_REAL:
        break;
    }
    return SPB_DT_FLOAT;
}

/* The value into the metric's oneof, as the datatype says (signed
 * integers in int_value as two's complement, Sparkplug 3.0). */
static void put_value(Payload_Metric *m, const dr_value_t *v)
{
    switch (v->type) {
    case DR_VAL_BOOL:
        m->which_value = Payload_Metric_boolean_value_tag;
        m->value.boolean_value = v->u != 0;
        break;
    case DR_VAL_UINT:
        m->which_value = Payload_Metric_int_value_tag;
        m->value.int_value = (uint32_t)v->u;
        break;
    case DR_VAL_INT:
        m->which_value = Payload_Metric_int_value_tag;
        m->value.int_value = (uint32_t)(int32_t)v->i;
        break;
    case DR_VAL_REAL:
        m->which_value = Payload_Metric_float_value_tag;
        m->value.float_value = (float)v->f;
        break;
    }
}

/* ---- encoding ------------------------------------------------------------------- */

typedef enum { ENC_NBIRTH, ENC_NDEATH, ENC_DBIRTH, ENC_DDATA, ENC_ECHO, ENC_NONE } enc_kind_t;

typedef struct {
    spb_t *s;
    enc_kind_t kind;
    unsigned robot;
    const char *device; /* the topic's device ID, if not the robot's name now */
    uint64_t ts;        /* the payload's timestamp, and every metric's */
    unsigned count;     /* metrics written */
} enc_t;

/* ---- a metric's callback fields ------------------------------------------------------ */

/* Metric.name, .properties and .string_value are callbacks, all through
 * spb_metric_field (sparkplug_b.options): so that a command of any legal
 * shape decodes. Encoding takes them from mf.enc, decoding puts them into
 * mf.dec. One loop, no threads: the one context is static. */
static struct {
    const char *name, *unit, *path; /* encoding: NULL = none */
    spb_metric_t *dec;              /* decoding: the metric being decoded */
} mf;

/* A string's bytes into out (size bytes, NUL-terminated); the rest, if
 * longer, skipped and *is_long set. */
static bool read_string(pb_istream_t *is, char *out, size_t size, bool *is_long)
{
    size_t n = is->bytes_left < size - 1 ? is->bytes_left : size - 1;
    if (!pb_read(is, (pb_byte_t *)out, n))
        return false;
    out[n] = '\0';
    *is_long = is->bytes_left > 0;
    return pb_read(is, NULL, is->bytes_left);
}

static bool put_property(Payload_PropertySet *ps, const char *key, const char *value)
{
    pb_size_t i = ps->keys_count;
    if (i >= sizeof ps->keys / sizeof ps->keys[0] ||
        strlen(value) >= sizeof ps->values[0].value.string_value)
        return false;
    snprintf(ps->keys[i], sizeof ps->keys[i], "%s", key);
    Payload_PropertyValue *pv = &ps->values[i];
    pv->has_type = true;
    pv->type = SPB_DT_STRING;
    pv->which_value = Payload_PropertyValue_string_value_tag;
    snprintf(pv->value.string_value, sizeof pv->value.string_value, "%s", value);
    ps->keys_count = ps->values_count = (pb_size_t)(i + 1u);
    return true;
}

static bool enc_metric_field(pb_ostream_t *os, const pb_field_t *field)
{
    switch (field->tag) {
    case Payload_Metric_name_tag:
        return mf.name == NULL ||
               (pb_encode_tag_for_field(os, field) &&
                pb_encode_string(os, (const pb_byte_t *)mf.name, strlen(mf.name)));
    case Payload_Metric_properties_tag: {
        Payload_PropertySet ps = Payload_PropertySet_init_zero;
        if (mf.unit != NULL)
            (void)put_property(&ps, "engUnit", mf.unit);
        if (mf.path != NULL)
            (void)put_property(&ps, "path", mf.path);
        return ps.keys_count == 0 ||
               (pb_encode_tag_for_field(os, field) &&
                pb_encode_submessage(os, Payload_PropertySet_fields, &ps));
    }
    default:
        return true; /* string_value: the gateway sends none */
    }
}

static bool dec_metric_field(pb_istream_t *is, const pb_field_t *field)
{
    spb_metric_t *d = mf.dec;
    if (d == NULL)
        return pb_read(is, NULL, is->bytes_left);
    switch (field->tag) {
    case Payload_Metric_name_tag:
        d->has_name = true;
        return read_string(is, d->name, sizeof d->name, &d->name_long);
    case Payload_Metric_string_value_tag:
        /* nanopb sets a oneof's which_ for static members only */
        d->pb.which_value = Payload_Metric_string_value_tag;
        return read_string(is, d->str, sizeof d->str, &d->str_long);
    default:
        return pb_read(is, NULL, is->bytes_left); /* properties: not used */
    }
}

/* nanopb calls this for Metric's callback fields (sparkplug_b.pb.h). */
bool spb_metric_field(pb_istream_t *istream, pb_ostream_t *ostream, const pb_field_t *field)
{
    if (ostream != NULL)
        return enc_metric_field(ostream, field);
    if (istream != NULL)
        return dec_metric_field(istream, field);
    return true;
}

/* ---- metric names ------------------------------------------------------------------- */

void spb_path_to_folders(const char *path, char *out, size_t size)
{
    size_t n = 0;
    for (const char *p = path; *p && n + 1 < size; p++) {
        if (*p == ']')
            continue;
        char ch = *p;
        if (ch == '.' || ch == '[')
            ch = '/';
        out[n++] = ch;
    }
    out[n] = '\0';
}

bool spb_name_to_path(const char *name, char *out, size_t size)
{
    if (strchr(name, '/') == NULL) {
        if (strlen(name) >= size)
            return false;
        memcpy(out, name, strlen(name) + 1);
        return true;
    }
    /* folders: a level of digits is an index ("a/b/3" is "a.b[3]") */
    size_t n = 0;
    const char *p = name;
    while (*p) {
        size_t len = strcspn(p, "/");
        bool digits = len > 0 && strspn(p, "0123456789") == len;
        if (len == 0 || (digits && n == 0))
            return false;
        int w = digits ? snprintf(out + n, size - n, "[%.*s]", (int)len, p)
                       : snprintf(out + n, size - n, "%s%.*s", n ? "." : "", (int)len, p);
        if (w < 0 || (size_t)w >= size - n)
            return false;
        n += (size_t)w;
        p += len;
        if (*p == '/' && *++p == '\0')
            return false;
    }
    return n > 0;
}

/* ---- encoding ------------------------------------------------------------------- */

static bool put_metric(pb_ostream_t *st, const pb_field_iter_t *field, const Payload_Metric *m)
{
    return pb_encode_tag_for_field(st, field) &&
           pb_encode_submessage(st, Payload_Metric_fields, m);
}

/* bdSeq, and in NBIRTH Node Control/Rebirth: by name, never aliased
 * (Sparkplug 3.0, tck-id-operational-behavior-data-commands-rebirth-name-aliases). */
static bool enc_node(pb_ostream_t *st, const pb_field_iter_t *field, enc_t *e)
{
    Payload_Metric *m = &e->s->m;
    *m = (Payload_Metric)Payload_Metric_init_zero;
    mf.name = "bdSeq";
    mf.unit = mf.path = NULL;
    m->has_datatype = m->has_timestamp = true;
    m->timestamp = e->ts;
    m->datatype = SPB_DT_INT64;
    m->which_value = Payload_Metric_long_value_tag;
    m->value.long_value = e->s->bd;
    if (!put_metric(st, field, m))
        return false;
    if (e->kind == ENC_NDEATH)
        return true;
    static const char *const controls[] = {SPB_REBIRTH, SPB_NEXT_SERVER};
    for (unsigned i = 0; i < sizeof controls / sizeof controls[0]; i++) {
        *m = (Payload_Metric)Payload_Metric_init_zero;
        mf.name = controls[i];
        m->has_datatype = m->has_timestamp = true;
        m->timestamp = e->ts;
        m->datatype = SPB_DT_BOOLEAN;
        m->which_value = Payload_Metric_boolean_value_tag;
        m->value.boolean_value = false;
        if (!put_metric(st, field, m))
            return false;
    }
    return true;
}

static bool echo_has(const spb_t *s, unsigned r, unsigned leaf)
{
    return (s->echo[r][leaf / 8u] >> (leaf % 8u)) & 1u;
}

/* One robot's leaves: all (DBIRTH, with name, datatype, unit and path),
 * those that changed (DDATA, by alias) or those a refused DCMD named
 * (ENC_ECHO); each with the timestamp of the robot packet the values
 * come from. What is encoded is what the plant will have: kept in last[]. */
static bool enc_robot(pb_ostream_t *st, const pb_field_iter_t *field, enc_t *e)
{
    spb_t *s = e->s;
    const gw_robot_t *rb = &s->env->robots[e->robot];
    gw_mqtt_last_t *last = s->last[e->robot];
    Payload_Metric *m = &s->m;
    mf.name = mf.unit = mf.path = NULL;
    for (unsigned i = 0; i < s->leaves; i++) {
        dr_ref_t ref;
        dr_value_t v;
        if (e->kind == ENC_ECHO && !echo_has(s, e->robot, i))
            continue;
        if (dr_leaf_at((uint16_t)i, &ref) != DR_OK || gw_robot_get(rb, ref, &v) != DR_OK)
            continue;
        if (e->kind == ENC_DDATA && !gw_mqtt_changed(&last[i], &v, s->deadband))
            continue;
        *m = (Payload_Metric)Payload_Metric_init_zero;
        m->has_alias = m->has_timestamp = true;
        m->alias = SPB_ALIAS_FIRST + (uint64_t)e->robot * s->leaves + i;
        m->timestamp = e->ts;
        mf.name = mf.unit = mf.path = NULL;
        if (e->kind == ENC_DBIRTH) {
            if (dr_ref_path(ref, s->path, sizeof s->path) != DR_OK)
                continue;
            if (s->names == SPB_NAMES_FOLDERS)
                spb_path_to_folders(s->path, s->name, sizeof s->name);
            else
                snprintf(s->name, sizeof s->name, "%s", s->path);
            mf.name = s->name;
            mf.path = s->path;
            m->has_datatype = true;
            m->datatype = datatype_of(ref);
            const char *unit = ref.field->unit;
            mf.unit = unit != NULL && unit[0] != '\0' ? unit : NULL;
        }
        put_value(m, &v);
        bool ok = put_metric(st, field, m);
        mf.name = mf.unit = mf.path = NULL;
        if (!ok)
            return false;
        last[i].have = true;
        last[i].v = dr_value_as_double(&v);
        e->count++;
    }
    return true;
}

static bool enc_metrics(pb_ostream_t *st, const pb_field_iter_t *field, void *const *arg)
{
    enc_t *e = *arg;
    switch (e->kind) {
    case ENC_NBIRTH:
    case ENC_NDEATH:
        return enc_node(st, field, e);
    case ENC_DBIRTH:
    case ENC_DDATA:
    case ENC_ECHO:
        return enc_robot(st, field, e);
    case ENC_NONE:
        break;
    }
    return true;
}

/* The payload into buf; 0 if it does not fit (logged). `seq` < 0: none.
 * Its timestamp, and each metric's: now, but a DBIRTH's and a DDATA's
 * (a refusal's echo too) is the time of the robot packet their values
 * come from, so that a device's timestamps never step back. */
static size_t encode(spb_t *s, enc_t *e, uint8_t *buf, size_t size, int seq)
{
    Payload p = Payload_init_zero;
    bool dev = e->kind == ENC_DBIRTH || e->kind == ENC_DDATA || e->kind == ENC_ECHO;
    e->ts = dev ? s->data_ms[e->robot] : wall_ms();
    p.has_timestamp = true;
    p.timestamp = e->ts;
    p.has_seq = seq >= 0;
    p.seq = seq >= 0 ? (uint64_t)seq : 0u;
    p.metrics.funcs.encode = enc_metrics;
    p.metrics.arg = e;
    e->s = s;
    e->count = 0;
    pb_ostream_t st = pb_ostream_from_buffer(buf, size);
    if (!pb_encode(&st, Payload_fields, &p)) {
        gw_log(GW_LOG_ERROR, "mqtt: sparkplug: cannot encode a payload: %s", PB_GET_ERROR(&st));
        return 0;
    }
    return st.bytes_written;
}

/* Publish with the next seq; the seq is taken only if it went out. */
static bool publish_seq(spb_t *s, enc_t *e, const char *type, int robot)
{
    int seq = e->kind == ENC_NBIRTH ? 0 : (s->seq + 1) & 0xff;
    size_t n = encode(s, e, s->buf, sizeof s->buf, seq);
    if (n == 0)
        return false;
    if ((e->kind == ENC_DDATA || e->kind == ENC_ECHO) && e->count == 0)
        return true; /* nothing changed */
    const char *top = topic(s, type, e->device != NULL ? -1 : robot);
    if (e->device != NULL) {
        size_t used = strlen(s->topic);
        snprintf(s->topic + used, sizeof s->topic - used, "/%s", e->device);
    }
    if (!s->io.publish(s->io.user, top, s->buf, n, 0, false)) {
        /* what the plant has is unknown now: every field again */
        if (robot >= 0)
            memset(s->last[robot], 0, s->leaves * sizeof *s->last[robot]);
        return false;
    }
    s->seq = (uint8_t)seq;
    return true;
}

/* ---- the node ------------------------------------------------------------------- */

static bool valid_id(const char *id)
{
    if (id[0] == '\0')
        return false;
    for (; *id; id++)
        if (*id == '+' || *id == '#' || *id == '/' || (unsigned char)*id <= 0x20 ||
            (unsigned char)*id >= 0x7f)
            return false;
    return true;
}

/* ---- bdSeq over restarts ------------------------------------------------------------ */

/* bdseq_file, or in $STATE_DIRECTORY (systemd's StateDirectory=), else
 * /var/lib/drgate: the bdSeq of the next CONNECT, one decimal line. A
 * missing file is a first start (0); one that cannot be read or written
 * is logged, and bdSeq then starts at 0 at each start of the daemon. */
static void bd_file_init(spb_t *s, const gw_mqtt_config_t *q)
{
    const char *dir = getenv("STATE_DIRECTORY");
    if (q->bdseq_file[0] != '\0')
        snprintf(s->bd_file, sizeof s->bd_file, "%s", q->bdseq_file);
    else
        snprintf(s->bd_file, sizeof s->bd_file, "%.200s/sparkplug-%s-%s.bdseq",
                 dir != NULL && dir[0] == '/' && strchr(dir, ':') == NULL ? dir
                                                                          : "/var/lib/drgate",
                 s->group, s->edge);
    FILE *f = fopen(s->bd_file, "r");
    if (f == NULL) {
        if (errno != ENOENT)
            gw_log(GW_LOG_WARNING, "mqtt: sparkplug: cannot read %s (%s): bdSeq starts at 0",
                   s->bd_file, strerror(errno));
        return;
    }
    char line[32], *end = NULL;
    unsigned long v = 256u;
    if (fgets(line, sizeof line, f) != NULL) {
        errno = 0;
        v = strtoul(line, &end, 10);
        if (errno != 0 || end == line || (*end != '\n' && *end != '\0'))
            v = 256u;
    }
    if (v <= 255u)
        s->bd_next = (uint8_t)v;
    else
        gw_log(GW_LOG_WARNING, "mqtt: sparkplug: %s does not hold a bdSeq (0..255): bdSeq "
               "starts at 0", s->bd_file);
    (void)fclose(f);
}

/* The next bdSeq into the file (a temporary one renamed over it, so a
 * crash leaves the old or the new number). Once per CONNECT, not on any
 * data path. */
static void bd_file_write(spb_t *s)
{
    char tmp[420];
    snprintf(tmp, sizeof tmp, "%s.tmp", s->bd_file);
    FILE *f = fopen(tmp, "w");
    bool ok = f != NULL && fprintf(f, "%u\n", (unsigned)s->bd_next) > 0;
    if (f != NULL && fclose(f) != 0)
        ok = false;
    if (ok && rename(tmp, s->bd_file) != 0)
        ok = false;
    if (ok || s->bd_warned)
        return;
    s->bd_warned = true;
    gw_log(GW_LOG_WARNING, "mqtt: sparkplug: cannot keep bdSeq in %s (%s): a restart of the "
           "daemon starts at bdSeq 0 (set [mqtt] bdseq_file)", s->bd_file, strerror(errno));
    (void)remove(tmp);
}

void spb_connect_answered(spb_t *s, bool accepted)
{
    (void)accepted; /* a refused CONNECT used its number too (Sparkplug 3.0) */
    if (s->bd_used)
        return;
    s->bd_used = true;
    s->bd_next = (uint8_t)(s->bd + 1u);
    bd_file_write(s);
}

void spb_carry(spb_t *next, const spb_t *old)
{
    next->bd_next = old->bd_used ? (uint8_t)(old->bd + 1u) : old->bd_next;
}

spb_t *spb_new(const gw_mqtt_config_t *q, const gw_north_env_t *env, const spb_io_t *io,
               const char *host, char *err, size_t errlen)
{
    spb_t *s = calloc(1, sizeof *s);
    if (s == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    s->env = env;
    s->io = *io;
    snprintf(s->group, sizeof s->group, "%s", q->group_id);
    snprintf(s->edge, sizeof s->edge, "%s", q->edge_node_id[0] ? q->edge_node_id : host);
    snprintf(s->host_id, sizeof s->host_id, "%s", q->primary_host_id);
    s->interval_ms = q->publish_interval_ms;
    s->deadband = q->deadband;
    s->writes = q->writes;
    s->names = q->metric_names;
    s->leaves = dr_leaf_count();
    s->host_online = s->host_id[0] == '\0';
    if (!valid_id(s->edge)) {
        snprintf(err, errlen,
                 "mqtt: sparkplug: the host name '%s' is not a valid edge_node_id (no '+', "
                 "'#', '/' or blanks): set edge_node_id",
                 s->edge);
        free(s);
        return NULL;
    }
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        if ((s->last[r] = calloc(s->leaves, sizeof *s->last[r])) == NULL ||
            (s->echo[r] = calloc((s->leaves + 7u) / 8u, 1)) == NULL) {
            snprintf(err, errlen, "out of memory");
            spb_free(s);
            return NULL;
        }
    bd_file_init(s, q);
    return s;
}

void spb_free(spb_t *s)
{
    if (s == NULL)
        return;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++) {
        free(s->last[r]);
        free(s->echo[r]);
    }
    free(s);
}

/* Each CONNECT the broker answers uses a bdSeq up, accepted or refused
 * (Sparkplug 3.0: one more than in the previous CONNECT); an attempt
 * that never reached a broker (no TCP connection, no answer) did not
 * send one as far as any host can know, and does not. */
void spb_will(spb_t *s, const char **top, const void **payload, size_t *len)
{
    s->bd = s->bd_next;
    s->bd_used = false;
    enc_t e = {.kind = ENC_NDEATH};
    s->will_len = encode(s, &e, s->will, sizeof s->will, -1);
    snprintf(s->will_topic, sizeof s->will_topic, "%s", topic(s, "NDEATH", -1));
    *top = s->will_topic;
    *payload = s->will;
    *len = s->will_len;
}

static void all_dead(spb_t *s)
{
    s->born = false;
    s->gone_count = 0;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++)
        s->dev_born[r] = s->ddeath_due[r] = false;
}

void spb_connected(spb_t *s)
{
    s->connected = true;
    s->leaving = false;
    spb_connect_answered(s, true);
    s->host_online = s->host_id[0] == '\0';
    s->nbirth_due = true;
    all_dead(s);
    char t[256];
    snprintf(t, sizeof t, SPB_NS "/%s/NCMD/%s", s->group, s->edge);
    (void)s->io.subscribe(s->io.user, t, 1);
    snprintf(t, sizeof t, SPB_NS "/%s/DCMD/%s/+", s->group, s->edge);
    (void)s->io.subscribe(s->io.user, t, 1);
    if (s->host_id[0] != '\0') {
        snprintf(t, sizeof t, SPB_NS "/STATE/%s", s->host_id);
        (void)s->io.subscribe(s->io.user, t, 1);
    }
}

void spb_disconnected(spb_t *s)
{
    s->connected = false;
    s->leaving = false;
    all_dead(s);
}

void spb_server_changed(spb_t *s)
{
    s->host_ts = 0;
}

bool spb_ready(const spb_t *s)
{
    return s->connected && s->host_online && !s->leaving;
}

/* Born devices whose name the configuration no longer has: a DDEATH
 * each before the next births (a host would keep them alive otherwise). */
static void note_gone(spb_t *s)
{
    const gw_config_t *cfg = s->env->cfg;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++) {
        bool kept = false;
        if (!s->dev_born[r])
            continue;
        for (unsigned k = 0; k < cfg->robot_count && !kept; k++)
            kept = strcmp(cfg->robot[k].name, s->born_as[r]) == 0;
        if (!kept && s->gone_count < GW_MAX_ROBOTS)
            memcpy(s->gone[s->gone_count++], s->born_as[r], sizeof s->gone[0]);
        s->dev_born[r] = s->ddeath_due[r] = false;
    }
}

void spb_sync(spb_t *s, bool links)
{
    const gw_north_env_t *env = s->env;
    note_gone(s);
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++) {
        s->link[r] = links && r < env->cfg->robot_count && env->link_up(env->user, r);
        s->asm_seen[r] = ~0u; /* a link up now has its images */
        s->next_pub_us[r] = 0;
        if (s->data_ms[r] == 0)
            s->data_ms[r] = wall_ms();
    }
    s->nbirth_due = true; /* robots may have come, gone or moved */
}

/* The Will was encoded at the connect: a deliberate disconnect sends its
 * own NDEATH, the same bdSeq stamped now. */
static void goodbye(spb_t *s, int qos)
{
    if (!s->connected)
        return;
    enc_t e = {.kind = ENC_NDEATH};
    size_t n = encode(s, &e, s->bye, sizeof s->bye, -1);
    if (n > 0)
        (void)s->io.publish(s->io.user, s->will_topic, s->bye, n, qos, false);
}

/* Stop or reload (the client is destroyed after it): QoS 1, not retained,
 * as the Will. */
void spb_goodbye(spb_t *s)
{
    goodbye(s, 1);
}

/* Leave this server (the connection's io.leave says where to): a born
 * node's NDEATH first, QoS 1 as every NDEATH (the connection waits for
 * its PUBACK before it goes), then nothing more on this connection. */
static void leave(spb_t *s, const char *why)
{
    bool born = s->born;
    if (born)
        goodbye(s, 1);
    s->born = false;
    s->leaving = s->io.leave(s->io.user, born, why);
}

void spb_on_data(spb_t *s, unsigned robot, dr_asm_t a)
{
    if (robot < GW_MAX_ROBOTS) {
        s->asm_seen[robot] |= 1u << a;
        s->data_seen[robot] = true;
        s->data_ms[robot] = wall_ms();
    }
}

void spb_on_link(spb_t *s, unsigned robot, bool up)
{
    if (robot >= GW_MAX_ROBOTS || s->link[robot] == up)
        return;
    s->link[robot] = up;
    if (up) {
        s->asm_seen[robot] = 0;
        s->up_us[robot] = ev_now_us();
    } else if (s->dev_born[robot]) {
        s->ddeath_due[robot] = true;
    }
}

/* ---- publishing ------------------------------------------------------------------ */

/* After link up, DBIRTH waits for every T->O assembly (each its own
 * packet), so that it holds what the robot sent, not zeros; at most a
 * second (an explicit-mode robot may not poll them all). */
static bool snapshot_ready(const spb_t *s, unsigned r, uint64_t now)
{
    unsigned all = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O)
            all |= 1u << a;
    return (s->asm_seen[r] & all) == all || now >= s->up_us[r] + SPB_SNAPSHOT_WAIT_US;
}

static bool publish_nbirth(spb_t *s)
{
    enc_t e = {.kind = ENC_NBIRTH};
    if (!publish_seq(s, &e, "NBIRTH", -1))
        return false;
    s->born = true;
    for (unsigned r = 0; r < GW_MAX_ROBOTS; r++) {
        s->dev_born[r] = s->ddeath_due[r] = false;
        s->next_pub_us[r] = 0;
    }
    gw_log(GW_LOG_INFO, "mqtt: sparkplug: NBIRTH %s/%s, bdSeq %u", s->group, s->edge,
           (unsigned)s->bd);
    return true;
}

static void tick_robot(spb_t *s, unsigned r, uint64_t now)
{
    if (s->ddeath_due[r]) {
        enc_t e = {.kind = ENC_NONE, .robot = r};
        if (!s->io.room(s->io.user) || !publish_seq(s, &e, "DDEATH", (int)r))
            return;
        s->ddeath_due[r] = s->dev_born[r] = false;
    }
    if (!s->link[r] || !s->io.room(s->io.user))
        return;
    if (s->dev_born[r] && s->echo_due[r]) {
        /* every field the refused DCMDs named, in one DDATA */
        enc_t e = {.kind = ENC_ECHO, .robot = r};
        if (!publish_seq(s, &e, "DDATA", (int)r))
            return;
        s->echo_due[r] = false;
        memset(s->echo[r], 0, (s->leaves + 7u) / 8u);
        if (!s->io.room(s->io.user))
            return;
    }
    if (!s->dev_born[r]) {
        if (!snapshot_ready(s, r, now))
            return;
        enc_t e = {.kind = ENC_DBIRTH, .robot = r};
        memset(s->last[r], 0, s->leaves * sizeof *s->last[r]);
        s->echo_due[r] = false; /* the birth has every value */
        memset(s->echo[r], 0, (s->leaves + 7u) / 8u);
        if (publish_seq(s, &e, "DBIRTH", (int)r)) {
            s->dev_born[r] = true;
            snprintf(s->born_as[r], sizeof s->born_as[r], "%s", s->env->cfg->robot[r].name);
            s->next_pub_us[r] = now + (uint64_t)s->interval_ms * 1000u;
        }
        return;
    }
    /* DDATA at most once per publish_interval_ms; the O->T images (written
     * by Modbus, GPIO or the plant) are compared at that pace too. */
    if (now < s->next_pub_us[r])
        return;
    enc_t e = {.kind = ENC_DDATA, .robot = r};
    if (!publish_seq(s, &e, "DDATA", (int)r))
        return;
    s->data_seen[r] = false;
    if (e.count > 0)
        s->next_pub_us[r] = now + (uint64_t)s->interval_ms * 1000u;
}

void spb_tick(spb_t *s, uint64_t now)
{
    if (!s->connected || !s->host_online || s->leaving)
        return;
    while (s->born && s->gone_count > 0) {
        enc_t e = {.kind = ENC_NONE, .device = s->gone[s->gone_count - 1]};
        if (!s->io.room(s->io.user) || !publish_seq(s, &e, "DDEATH", -1))
            return;
        s->gone_count--;
    }
    if (s->nbirth_due) {
        if (!s->io.room(s->io.user) || !publish_nbirth(s))
            return;
        s->nbirth_due = false;
    }
    for (unsigned r = 0; r < s->env->cfg->robot_count; r++)
        tick_robot(s, r, now);
}

uint64_t spb_deadline(const spb_t *s, uint64_t now)
{
    if (!s->connected || !s->host_online || s->leaving)
        return UINT64_MAX;
    if (s->nbirth_due || s->gone_count > 0)
        return now;
    uint64_t d = UINT64_MAX;
    for (unsigned r = 0; r < s->env->cfg->robot_count; r++) {
        uint64_t x = UINT64_MAX;
        if (s->ddeath_due[r] || (s->dev_born[r] && s->echo_due[r]))
            x = now;
        else if (s->link[r] && !s->dev_born[r])
            x = snapshot_ready(s, r, now) ? now : s->up_us[r] + SPB_SNAPSHOT_WAIT_US;
        else if (s->link[r] && s->data_seen[r])
            x = s->next_pub_us[r]; /* new data: when the rate allows */
        if (x < d)
            d = x;
    }
    return d;
}

/* ---- commands --------------------------------------------------------------------- */

typedef struct {
    spb_metric_fn fn;
    void *ctx;
    spb_metric_t m;
} dec_t;

static bool dec_each(pb_istream_t *st, const pb_field_iter_t *field, void **arg)
{
    dec_t *d = *arg;
    (void)field;
    d->m.pb = (Payload_Metric)Payload_Metric_init_zero;
    d->m.has_name = d->m.name_long = d->m.str_long = false;
    d->m.name[0] = d->m.str[0] = '\0';
    mf.dec = &d->m;
    bool ok = pb_decode(st, Payload_Metric_fields, &d->m.pb);
    mf.dec = NULL;
    return ok && d->fn(d->ctx, &d->m);
}

bool spb_decode_cmd(const void *payload, size_t len, spb_metric_fn fn, void *ctx)
{
    static dec_t d; /* one loop, no threads: not on the stack (~800 bytes) */
    d.fn = fn;
    d.ctx = ctx;
    Payload p = Payload_init_zero;
    p.metrics.funcs.decode = dec_each;
    p.metrics.arg = &d;
    pb_istream_t st = pb_istream_from_buffer(payload, len);
    return pb_decode(&st, Payload_fields, &p);
}

/* The leaf number of a field element (the alias's low part). */
static int leaf_of(dr_ref_t ref, unsigned leaves)
{
    for (unsigned i = 0; i < leaves; i++) {
        dr_ref_t x;
        if (dr_leaf_at((uint16_t)i, &x) == DR_OK && x.field == ref.field && x.elem == ref.elem)
            return (int)i;
    }
    return -1;
}

/* The metric's value as the field's value: the oneof member it came in,
 * read with the datatype the birth gave it (Int32 in int_value is two's
 * complement); a string as text, as a write on <prefix>/.../set. */
static dr_status_t value_of(const spb_metric_t *sm, dr_ref_t ref, dr_value_t *v)
{
    const Payload_Metric *m = &sm->pb;
    switch (m->which_value) {
    case Payload_Metric_boolean_value_tag:
        *v = dr_value_uint(m->value.boolean_value ? 1u : 0u);
        return DR_OK;
    case Payload_Metric_int_value_tag:
        if (datatype_of(ref) == SPB_DT_INT32)
            *v = dr_value_int((int32_t)m->value.int_value);
        else
            *v = dr_value_uint(m->value.int_value);
        return DR_OK;
    case Payload_Metric_long_value_tag:
        *v = m->has_datatype && m->datatype == SPB_DT_INT64
                 ? dr_value_int((int64_t)m->value.long_value)
                 : dr_value_uint(m->value.long_value);
        return DR_OK;
    case Payload_Metric_float_value_tag:
        *v = dr_value_real(m->value.float_value);
        return DR_OK;
    case Payload_Metric_double_value_tag:
        *v = dr_value_real(m->value.double_value);
        return DR_OK;
    case Payload_Metric_string_value_tag:
        return sm->str_long ? DR_EINVAL : dr_text_parse(ref, sm->str, DR_SET_O2T_ONLY, v);
    default:
        return DR_EINVAL;
    }
}

typedef struct {
    spb_t *s;
    int robot; /* DCMD: the device; -1: NCMD */
    /* DCMD: metrics seen (their leaves in s->cmd_leaf, up to SPB_CMD_MAX),
     * writes decoded (s->cmd_items), and the first refusal: its metric
     * and why (nothing of the command is written then). */
    unsigned metrics, n;
    bool refused;
    bool left;  /* NCMD: Next Server done (once per command) */
    char what[96], why[160];
} cmd_t;

/* The current value of every field a refused DCMD named, published back
 * as DDATA, so that the host's tags, which may show the values it asked
 * for, show what the robot has: none of the command was written. Marked
 * here, sent by the tick in one DDATA as soon as there is room, so that
 * every refusal of a burst is answered (issue 32). */
static void echo_leaves(spb_t *s, unsigned robot, const cmd_t *c)
{
    unsigned n = c->metrics < SPB_CMD_MAX ? c->metrics : SPB_CMD_MAX;
    /* cppcheck-suppress knownConditionTrueFalse ; metrics is counted by
     * nanopb's decode callbacks, which cppcheck does not follow */
    for (unsigned k = 0; k < n; k++) {
        int leaf = s->cmd_leaf[k];
        if (leaf < 0 || (unsigned)leaf >= s->leaves)
            continue;
        s->echo[robot][(unsigned)leaf / 8u] |= (uint8_t)(1u << ((unsigned)leaf % 8u));
        s->echo_due[robot] = true;
    }
}

/* A refused DCMD: logged (at most once a second, with the count of those
 * not logged), its fields published back. */
static void refuse(spb_t *s, unsigned robot, const cmd_t *c, const char *what, const char *why)
{
    uint64_t now = ev_now_us();
    s->refused++;
    if (now >= s->refused_log_us) {
        gw_log(GW_LOG_INFO, "mqtt: sparkplug: DCMD %s %s refused: %s%s%s",
               s->env->cfg->robot[robot].name, what, why,
               c->metrics > 1 ? " (nothing of the command written)" : "",
               s->refused > 1 ? " (and earlier refusals not logged)" : "");
        s->refused = 0;
        s->refused_log_us = now + 1000000u;
    }
    echo_leaves(s, robot, c);
}

/* The first refusal of a command is the one said. */
static void cmd_refuse(cmd_t *c, const spb_metric_t *m, const char *why)
{
    if (c->refused)
        return;
    c->refused = true;
    snprintf(c->what, sizeof c->what, "%.80s%s", m->has_name ? m->name : "(alias)",
             m->name_long || strlen(m->name) > 80 ? "..." : "");
    snprintf(c->why, sizeof c->why, "%s", why);
}

/* One metric of a DCMD decoded into the command's writes (nothing is
 * written yet: decode first, then one write). */
static void dcmd_metric(cmd_t *c, const spb_metric_t *sm)
{
    spb_t *s = c->s;
    const Payload_Metric *m = &sm->pb;
    unsigned robot = (unsigned)c->robot;
    dr_ref_t ref;
    char why[160], path[SPB_NAME_MAX];
    int leaf = -1;
    if (sm->has_name) {
        /* either style of name (folders or canonical), whatever the births use */
        if (!sm->name_long && spb_name_to_path(sm->name, path, sizeof path) &&
            dr_path_parse(path, &ref) == DR_OK)
            leaf = leaf_of(ref, s->leaves);
    } else if (m->has_alias && m->alias >= SPB_ALIAS_FIRST + (uint64_t)robot * s->leaves &&
               m->alias < SPB_ALIAS_FIRST + (uint64_t)(robot + 1u) * s->leaves) {
        leaf = (int)(m->alias - SPB_ALIAS_FIRST - (uint64_t)robot * s->leaves);
        if (dr_leaf_at((uint16_t)leaf, &ref) != DR_OK)
            leaf = -1;
    }
    unsigned k = c->metrics++;
    if (k >= SPB_CMD_MAX) {
        snprintf(why, sizeof why, "more than %u metrics in one DCMD", SPB_CMD_MAX);
        cmd_refuse(c, sm, why);
        return;
    }
    s->cmd_leaf[k] = leaf;
    if (leaf < 0) {
        cmd_refuse(c, sm, sm->name_long ? "unknown metric (name too long)"
                                        : "unknown metric (name or alias)");
        return;
    }
    dr_value_t v;
    dr_status_t st = value_of(sm, ref, &v);
    if (st == DR_OK) /* the codec's checks (direction, range) before any write */
        st = dr_value_check(ref, &v, DR_SET_O2T_ONLY);
    if (st == DR_EREADONLY) {
        cmd_refuse(c, sm, "read-only: a T->O field");
        return;
    }
    if (st != DR_OK) {
        snprintf(why, sizeof why, "invalid value: %s%s", dr_strerror(st),
                 sm->str_long ? " (a string that long)" : "");
        cmd_refuse(c, sm, why);
        return;
    }
    if (!s->writes) {
        cmd_refuse(c, sm, "writes are off ([mqtt] writes = no)");
        return;
    }
    s->cmd_items[c->n++] = (gw_write_item_t){ref, v, 0};
}

/* The whole DCMD decoded: written in one go through the write path, or
 * refused whole. */
static void dcmd_write(spb_t *s, cmd_t *c)
{
    unsigned robot = (unsigned)c->robot;
    if (c->refused) {
        refuse(s, robot, c, c->what, c->why);
        return;
    }
    if (c->n == 0)
        return;
    char why[160], what[96];
    gw_write_result_t res;
    if (s->io.write(s->io.user, robot, s->cmd_items, c->n, &res, why, sizeof why))
        return;
    if (res.item >= c->n || dr_ref_path(s->cmd_items[res.item].ref, what, sizeof what) != DR_OK)
        snprintf(what, sizeof what, "?");
    refuse(s, robot, c, what, why);
}

static bool on_cmd_metric(void *ctx, const spb_metric_t *sm)
{
    cmd_t *c = ctx;
    spb_t *s = c->s;
    const Payload_Metric *m = &sm->pb;
    if (c->robot >= 0) {
        dcmd_metric(c, sm);
        return true;
    }
    /* by name: the birth gives them no alias */
    bool set = m->which_value == Payload_Metric_boolean_value_tag && m->value.boolean_value;
    if (set && sm->has_name && strcmp(sm->name, SPB_REBIRTH) == 0) {
        gw_log(GW_LOG_INFO, "mqtt: sparkplug: rebirth asked (NCMD)");
        s->nbirth_due = true;
    } else if (set && sm->has_name && strcmp(sm->name, SPB_NEXT_SERVER) == 0 && !c->left) {
        gw_log(GW_LOG_INFO, "mqtt: sparkplug: next server asked (NCMD)");
        c->left = true; /* once per command */
        leave(s, "next server asked");
    }
    return true;
}

/* The value after "key": in a flat JSON object, NULL if there is none. */
static const char *state_value(const char *text, const char *key)
{
    char quoted[32];
    snprintf(quoted, sizeof quoted, "\"%s\"", key);
    const char *k = strstr(text, quoted);
    if (k == NULL)
        return NULL;
    k += strlen(quoted);
    k += strspn(k, " \t\r\n");
    if (*k++ != ':')
        return NULL;
    return k + strspn(k, " \t\r\n");
}

/* STATE: {"online": true|false, "timestamp": ...} (Sparkplug 3.0). A
 * host that goes offline: the node disconnects (its NDEATH) and comes
 * back with a new bdSeq, births once the host is online again. A STATE
 * older than the newest one seen (its timestamp) is stale, as the
 * specification says, and ignored: a retained offline the broker still
 * holds from before the host came back does not take the node down. */
static void on_state(spb_t *s, const char *p, size_t len)
{
    char text[256];
    if (len >= sizeof text)
        len = sizeof text - 1;
    memcpy(text, p, len);
    text[len] = '\0';
    const char *k = state_value(text, "online"), *ts = state_value(text, "timestamp");
    if (k == NULL) {
        /* Sparkplug 2.2's text STATE (ONLINE/OFFLINE, on STATE/<id>) or
         * anything else: births wait, and the reason is said once. */
        if (!s->state_warned) {
            size_t n = strcspn(text, "\r\n");
            gw_log(GW_LOG_WARNING, "mqtt: sparkplug: primary host %s: STATE '%.*s' is not "
                   "Sparkplug 3.0's {\"online\": true|false, \"timestamp\": ms}: ignored, "
                   "births wait for a 3.0 STATE (is the host on Sparkplug B 2.2?)", s->host_id,
                   (int)(n > 40 ? 40 : n), text);
            s->state_warned = true;
        }
        return;
    }
    bool online = strncmp(k, "true", 4) == 0;
    if (ts != NULL && *ts >= '0' && *ts <= '9') {
        uint64_t t = strtoull(ts, NULL, 10);
        if (t < s->host_ts) {
            gw_log(GW_LOG_DEBUG, "mqtt: sparkplug: primary host %s: a STATE older than the "
                   "last one ignored", s->host_id);
            return;
        }
        s->host_ts = t;
    }
    if (online != s->host_online)
        gw_log(GW_LOG_INFO, "mqtt: sparkplug: primary host %s is %s", s->host_id,
               online ? "online" : "offline");
    bool was = s->host_online;
    s->host_online = online;
    if (online) {
        s->nbirth_due = s->nbirth_due || !was;
        return;
    }
    /* Offline, also as the retained STATE found at the connect: this
     * server is left (for the next one, if there are several). */
    leave(s, "primary host offline");
}

bool spb_message(spb_t *s, const char *top, const void *payload, size_t len)
{
    char want[256];
    if (s->host_id[0] != '\0') {
        snprintf(want, sizeof want, SPB_NS "/STATE/%s", s->host_id);
        if (strcmp(top, want) == 0) {
            on_state(s, payload, len);
            return true;
        }
    }
    cmd_t c = {.s = s, .robot = -1};
    snprintf(want, sizeof want, SPB_NS "/%s/NCMD/%s", s->group, s->edge);
    if (strcmp(top, want) != 0) {
        snprintf(want, sizeof want, SPB_NS "/%s/DCMD/%s/", s->group, s->edge);
        size_t n = strlen(want);
        if (strncmp(top, want, n) != 0)
            return strncmp(top, SPB_NS "/", strlen(SPB_NS "/")) == 0;
        for (unsigned r = 0; r < s->env->cfg->robot_count; r++)
            if (strcmp(top + n, s->env->cfg->robot[r].name) == 0)
                c.robot = (int)r;
        if (c.robot < 0 || !s->born)
            return true;
    }
    if (!spb_decode_cmd(payload, len, on_cmd_metric, &c)) {
        /* Nothing of it is written, the metrics before the damage neither. */
        gw_log(GW_LOG_INFO, "mqtt: sparkplug: %s: malformed payload (%zu bytes) ignored", top,
               len);
        if (c.robot >= 0)
            echo_leaves(s, (unsigned)c.robot, &c);
        return true;
    }
    if (c.robot >= 0)
        dcmd_write(s, &c);
    return true;
}
