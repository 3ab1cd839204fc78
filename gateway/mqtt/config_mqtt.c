/* SPDX-License-Identifier: MIT */
/*
 * The MQTT side's section (config_internal.h): [mqtt], present = enabled
 * (docs/mqtt.md). Whether the files open is checked when the MQTT side
 * starts, or a reload prepares it; here only what the file says.
 */
#include "core/config_internal.h"

#include <stdlib.h>
#include <string.h>

#define Q(m) GW_CFG_AT(gw_mqtt_config_t, m)

static bool valid_client_id(const char *s);
static bool valid_topic(const char *t);
static bool valid_spb_id(const char *s);
#define SPB_ID_ALLOWED "printable ASCII without '+', '#', '/' or blanks"
#define SPB_ID_DOC "printable ASCII without `+`, `#`, `/` or blanks"
static gw_cfg_parse_fn mqtt_deadband;
static gw_cfg_parse_fn mqtt_servers;
#define SERVERS_ALLOWED "HOST[:PORT] ..., at most 4 (HOST an IPv4 address or a host name)"

static const gw_cfg_key_t mqtt_keys[] = {
    { .name = "servers", .type = GW_CFG_HOOK, .parse = mqtt_servers, .allowed = SERVERS_ALLOWED, .doc_default = "(none: `host`)", .doc_allowed = "`HOST[:PORT]` separated by blanks or commas, at most 4; `HOST` an IPv4 address or a host name, `PORT` `port`'s if not given", .help = "the brokers, tried in this order: the gateway is connected to one at a time and moves to the next when the connection is lost or cannot be made, or (Sparkplug, `primary_host_id`) when the primary host is offline there. Names are looked up at each attempt without stopping the daemon (with TLS, libmosquitto looks the name up again at the connect, docs/mqtt.md)" },
    { .name = "host", .type = GW_CFG_HOST, Q(host), .allowed = "the broker's IPv4 address or host name", .doc_default = "(none: `servers`)", .help = "one broker: the same as `servers = HOST:PORT`. `host` or `servers` is required, not both" },
    { .name = "port", .type = GW_CFG_UINT, Q(port), .lo = 1, .hi = 65535, .def = 1883, .help = "`host`'s port, and that of a server in `servers` without one (TLS brokers usually listen on 8883)" },
    { .name = "client_id", .type = GW_CFG_TEXT, Q(client_id), .valid = valid_client_id, .allowed = "letters, digits, '_', '-', '.'", .doc_default = "`drgatewayd-<hostname>`", .doc_allowed = "letters, digits, `_`, `-`, `.` (at most 63)", .help = "MQTT client identifier; unique per broker" },
    { .name = "username", .type = GW_CFG_TEXT, Q(username), .allowed = "a user name", .help = "login name" },
    { .name = "password_file", .type = GW_CFG_TEXT, Q(password_file), .allowed = "a file whose first line is the password", .help = "file whose first line is the password; needs `username`. Read at start and reload; an unreadable file refuses the start or the reload" },
    { .name = "ca_file", .type = GW_CFG_TEXT, Q(ca_file), .allowed = "a PEM file of CA certificates (enables TLS)", .doc_default = "(none: plain TCP)", .help = "PEM CA certificates: turns TLS on. Each broker's certificate must chain to them and name the host as `servers` (or `host`) gives it: its name, or its address" },
    { .name = "cert_file", .type = GW_CFG_TEXT, Q(cert_file), .allowed = "a PEM client certificate", .help = "client certificate (PEM), with `key_file`; needs `ca_file`" },
    { .name = "key_file", .type = GW_CFG_TEXT, Q(key_file), .allowed = "a PEM private key", .help = "the client certificate's key (PEM), with `cert_file`" },
    { .name = "keepalive_s", .type = GW_CFG_UINT, Q(keepalive_s), .lo = 5, .hi = 3600, .def = 30, .help = "MQTT keepalive; a broker that stops answering is found after about 1.5 times this" },
    { .name = "qos", .type = GW_CFG_UINT, Q(qos), .lo = 0, .hi = 2, .help = "QoS of every publication, of the Last Will and of the `set` subscription. Not with `payload = sparkplug`, whose births and data are QoS 0 and its Will QoS 1 (Sparkplug 3.0)" },
    { .name = "topic_prefix", .type = GW_CFG_TEXT, Q(topic_prefix), .valid = valid_topic, .allowed = "topic levels such as drgate/cell1", .invalid = "topic levels separated by '/', no wildcards, blanks or empty levels, e.g. drgate/cell1", .doc_default = "`drgate/<hostname>`", .doc_allowed = "topic levels separated by `/`, no wildcards, blanks or empty levels", .help = "topics are `<prefix>/status` and `<prefix>/<robot>/...`" },
    { .name = "retain", .type = GW_CFG_BOOL, Q(retain), .def = 1, .help = "`status`, `state`, `meta` and `snapshot` are retained messages (the Will too)" },
    { .name = "publish_interval_ms", .type = GW_CFG_UINT, Q(publish_interval_ms), .lo = 0, .hi = 60000, .def = 100, .help = "at most one `data` message per robot this often; `0` = on every change" },
    { .name = "deadband", .type = GW_CFG_HOOK, .parse = mqtt_deadband, .allowed = "a number >= 0", .doc_default = "`0`", .doc_allowed = "a decimal number >= 0 (`0.5`; no sign, no exponent)", .help = "a REAL field is published again once it is more than this away from the value last published; integers and bits on any change" },
    { .name = "writes", .type = GW_CFG_BOOL, Q(writes), .help = "accept writes on `<prefix>/<robot>/set/<path>`, with the checks of a Modbus write" },
    { .name = "payload", .type = GW_CFG_ENUM, Q(payload), GW_CFG_NAMES("json", "sparkplug"), .def = GW_MQTT_JSON, .help = "`json`: the topics under `topic_prefix` above. `sparkplug`: Sparkplug B 3.0 (`spBv1.0/<group_id>/...`, protobuf), the gateway an edge node and each robot a device; `topic_prefix` and `retain` do not apply" },
    { .name = "group_id", .type = GW_CFG_TEXT, Q(group_id), .valid = valid_spb_id, .allowed = SPB_ID_ALLOWED, .doc_allowed = SPB_ID_DOC, .help = "Sparkplug group ID; required with `payload = sparkplug`" },
    { .name = "edge_node_id", .type = GW_CFG_TEXT, Q(edge_node_id), .valid = valid_spb_id, .allowed = SPB_ID_ALLOWED, .doc_default = "the host name", .doc_allowed = SPB_ID_DOC, .help = "Sparkplug edge node ID, unique in the group" },
    { .name = "primary_host_id", .type = GW_CFG_TEXT, Q(primary_host_id), .valid = valid_spb_id, .allowed = SPB_ID_ALLOWED, .doc_default = "(none: births at once)", .doc_allowed = SPB_ID_DOC, .help = "Sparkplug primary host application: births wait until its `spBv1.0/STATE/<id>` says online; when it goes offline the gateway disconnects (NDEATH) and connects to the next server (the same one if there is one) and waits again" },
    { .name = "primary_host_wait_s", .type = GW_CFG_UINT, Q(host_wait_s), .lo = 1, .hi = 3600, .def = 10, .help = "Sparkplug with `primary_host_id` and more than one server: a server on which the primary host's STATE does not say online this long after the connection is left for the next one" },
    { .name = "metric_names", .type = GW_CFG_ENUM, Q(metric_names), GW_CFG_NAMES("folders", "canonical"), .def = 0, .help = "Sparkplug metric names: `folders` (`joint_state/position/1`: a folder hierarchy, as Ignition takes tag names, which may not have `.` or `[]`) or `canonical` (`joint_state.position[1]`, as the JSON payload); the canonical path is each metric's `path` property either way" },
    { .name = "bdseq_file", .type = GW_CFG_TEXT, Q(bdseq_file), .allowed = "a file the daemon may write", .doc_default = "`$STATE_DIRECTORY/sparkplug-<group_id>-<edge_node_id>.bdseq` (systemd's `StateDirectory`), else the same name in `/var/lib/drgate`", .help = "Sparkplug: where the next bdSeq is kept, so that it keeps growing over restarts of the daemon (written at each CONNECT the broker answers); a file that cannot be written is logged and bdSeq starts at 0 at each start" },
};

static void mqtt_begin(void *sec)
{
    ((gw_mqtt_config_t *)sec)->enabled = true;
}

static void mqtt_check(gw_cfg_ctx_t *c);

static const gw_cfg_side_t gw_cfg_mqtt = {
    .kw = "mqtt",
    .rank = 60,
    .base = offsetof(gw_config_t, side.mqtt),
    .name_off = GW_CFG_NONE,
    .line_off = offsetof(gw_mqtt_config_t, line),
    GW_CFG_KEYS(mqtt_keys),
    .begin = mqtt_begin,
    .check = mqtt_check,
};

static const gw_cfg_side_t *const mqtt_sections[] = { &gw_cfg_mqtt, NULL };

/* The side to the configuration (config.h; gateway/sides.h lists it). */
const gw_side_cfg_t gw_side_cfg_mqtt = {
    .name = "mqtt",
    .sections = mqtt_sections,
};

static bool valid_client_id(const char *s)
{
    for (; *s; s++)
        if (!gw_cfg_is_alnum(*s) && *s != '_' && *s != '-' && *s != '.')
            return false;
    return true;
}

/* MQTT topic levels: no wildcards, no empty level, printable ASCII. */
static bool valid_topic(const char *t)
{
    if (t[0] == '\0' || t[0] == '/' || t[strlen(t) - 1] == '/' ||
        strstr(t, "//"))
        return false;
    for (; *t; t++)
        if (*t == '+' || *t == '#' || (unsigned char)*t <= 0x20 ||
            (unsigned char)*t >= 0x7f)
            return false;
    return true;
}

/* Sparkplug IDs (group, edge node, host) are topic levels: no
 * wildcards, no '/', printable ASCII. */
static bool valid_spb_id(const char *s)
{
    for (; *s; s++)
        if (*s == '+' || *s == '#' || *s == '/' || (unsigned char)*s <= 0x20 ||
            (unsigned char)*s >= 0x7f)
            return false;
    return true;
}

/* A non-negative decimal number such as 0.5 (no exponent, no sign). */
static void mqtt_deadband(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                          const char *name, const char *v)
{
    unsigned digits = 0, dots = 0;
    const char *p = v;
    (void)k;
    for (; *p && (gw_cfg_is_digit(*p) || *p == '.'); p++) {
        digits += gw_cfg_is_digit(*p);
        dots += *p == '.';
    }
    char *end = NULL;
    double x = *p == '\0' && digits > 0 && dots <= 1 ? strtod(v, &end) : -1.0;
    if (end == NULL || *end != '\0' || !(x >= 0.0 && x <= 1e9)) {
        gw_cfg_fail(c, c->lineno,
                    "%s '%s' invalid (allowed: a decimal number >= 0, e.g. "
                    "0.5)",
                    name, v);
        return;
    }
    ((gw_mqtt_config_t *)sec)->deadband = x;
}

/* servers = HOST[:PORT] ...: kept with port 0 where none is given
 * (mqtt_check gives them `port`, which may come later in the section). */
static void mqtt_servers(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec, const char *name,
                         const char *v)
{
    gw_mqtt_config_t *q = sec;
    char buf[GW_MQTT_SERVERS_MAX * 72u];
    (void)k;
    if (strlen(v) >= sizeof buf) {
        gw_cfg_fail(c, c->lineno, "%s too long (allowed: %s)", name, SERVERS_ALLOWED);
        return;
    }
    memcpy(buf, v, strlen(v) + 1);
    q->server_count = 0;
    for (char *save = NULL, *w = strtok_r(buf, " \t,", &save); w != NULL;
         w = strtok_r(NULL, " \t,", &save)) {
        if (q->server_count == GW_MQTT_SERVERS_MAX) {
            gw_cfg_fail(c, c->lineno, "%s: more than %u servers (allowed: %s)", name,
                        GW_MQTT_SERVERS_MAX, SERVERS_ALLOWED);
            return;
        }
        gw_mqtt_server_t *sv = &q->server[q->server_count];
        char *colon = strchr(w, ':');
        unsigned long port = 0;
        if (colon != NULL) {
            char *end = NULL;
            *colon = '\0';
            port = strtoul(colon + 1, &end, 10);
            if (colon[1] < '0' || colon[1] > '9' || *end != '\0' || port < 1 || port > 65535) {
                gw_cfg_fail(c, c->lineno, "%s: port '%s' of %s invalid (allowed: 1..65535)",
                            name, colon + 1, w);
                return;
            }
        }
        if (!gw_cfg_valid_host(w) || strlen(w) >= sizeof sv->host) {
            gw_cfg_fail(c, c->lineno, "%s: '%s' is not a host (allowed: %s)", name, w,
                        SERVERS_ALLOWED);
            return;
        }
        memcpy(sv->host, w, strlen(w) + 1);
        sv->port = (uint16_t)port;
        q->server_count++;
    }
    if (q->server_count == 0)
        gw_cfg_fail(c, c->lineno, "%s has no server (allowed: %s)", name, SERVERS_ALLOWED);
}

/* `host` or `servers` (not both) into server[]: the list the side uses. */
static void mqtt_server_list(gw_cfg_ctx_t *c, const gw_cfg_side_t *s)
{
    gw_mqtt_config_t *q = &c->cfg.side.mqtt;
    unsigned at_servers = gw_cfg_line(c, s, 0, "servers");
    if (at_servers != 0 && gw_cfg_line(c, s, 0, "host") != 0) {
        gw_cfg_fail(c, at_servers,
                    "[mqtt] servers and host: one or the other (allowed: servers = HOST[:PORT] "
                    "... for one or more brokers, or host (and port) for one; line %u has host)",
                    gw_cfg_line(c, s, 0, "host"));
        return;
    }
    if (at_servers == 0 && q->host[0] == '\0') {
        gw_cfg_fail(c, gw_cfg_section_line(c, s, 0),
                    "[mqtt] has no servers (allowed: servers = HOST[:PORT] ..., or host = "
                    "the broker's IPv4 address or host name)");
        return;
    }
    if (at_servers == 0) {
        memcpy(q->server[0].host, q->host, sizeof q->host);
        q->server[0].port = 0;
        q->server_count = 1;
    }
    for (unsigned i = 0; i < q->server_count; i++) {
        if (q->server[i].port == 0)
            q->server[i].port = q->port;
        for (unsigned j = 0; j < i; j++)
            if (strcmp(q->server[i].host, q->server[j].host) == 0 &&
                q->server[i].port == q->server[j].port) {
                gw_cfg_fail(c, at_servers, "[mqtt] servers: %s:%u named twice",
                            q->server[i].host, (unsigned)q->server[i].port);
                return;
            }
    }
}

static void mqtt_check(gw_cfg_ctx_t *c)
{
    const gw_mqtt_config_t *q = &c->cfg.side.mqtt;
    const gw_cfg_side_t *s = &gw_cfg_mqtt;
    if (!q->enabled || !gw_cfg_require(c, s, 0))
        return;
    mqtt_server_list(c, s);
    if (c->err_line != 0)
        return;
    if ((q->cert_file[0] != '\0') != (q->key_file[0] != '\0'))
        gw_cfg_fail(c,
                    gw_cfg_line(c, s, 0, q->cert_file[0] ? "cert_file"
                                                         : "key_file"),
                    "[mqtt] cert_file and key_file go together (allowed: both "
                    "or neither)");
    else if (q->cert_file[0] != '\0' && q->ca_file[0] == '\0')
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "cert_file"),
                    "[mqtt] cert_file needs ca_file (TLS)");
    else if (q->password_file[0] != '\0' && q->username[0] == '\0')
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "password_file"),
                    "[mqtt] password_file needs username");
    else if (q->payload == GW_MQTT_SPARKPLUG && q->group_id[0] == '\0')
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "payload"),
                    "[mqtt] payload = sparkplug needs group_id");
    else if (q->payload == GW_MQTT_SPARKPLUG && q->qos != 0)
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "qos"),
                    "[mqtt] qos = %u with payload = sparkplug: Sparkplug 3.0 publishes births "
                    "and data at QoS 0 and its Will (NDEATH) at QoS 1 (allowed: qos = 0, or "
                    "no qos)", q->qos);
}
