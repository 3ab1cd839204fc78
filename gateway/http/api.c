/* SPDX-License-Identifier: MIT */
/* The console's JSON API and its summaries (api.h). */
#include "http/api.h"

#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "core/link.h"
#include "core/report.h"
#include "drgate/client.h"
#include "drgate/layout.h"
#include "drgate/text.h"
#include "http/metrics.h"
#include "http/report.h"

#define NUM(j, fmt, x)                                 \
    do {                                               \
        char num_[32];                                 \
        snprintf(num_, sizeof num_, fmt, x);           \
        gw_json_str(j, num_);                          \
    } while (0)

static void qstr(gw_json_t *j, const char *s)
{
    gw_json_quote(j, s, strlen(s));
}

const char *gw_http_api_config_path(const gw_config_t *cfg)
{
    /* the working directory of the start, taken once: a relative path
     * given with -c means nothing to a reader of the console */
    static char cwd[512], abs_path[sizeof cwd + sizeof cfg->path + 2];
    if (cfg->path[0] == '/' || cfg->path[0] == '\0')
        return cfg->path;
    if (cwd[0] == '\0' && getcwd(cwd, sizeof cwd) == NULL)
        return cfg->path;
    snprintf(abs_path, sizeof abs_path, "%s/%s", cwd,
             strncmp(cfg->path, "./", 2) == 0 ? cfg->path + 2 : cfg->path);
    return abs_path;
}

int gw_http_api_find(const gw_http_api_t *a, const char *name)
{
    const gw_config_t *cfg = a->env->cfg;
    for (unsigned r = 0; r < cfg->robot_count; r++)
        if (strcmp(cfg->robot[r].name, name) == 0)
            return (int)r;
    return -1;
}

const char *gw_http_api_link_name(const gw_robot_t *rb)
{
    return rb->link.link_state == 2 ? "up" : rb->link.link_state == 1 ? "connecting" : "down";
}

const char *gw_http_api_state_name(const gw_robot_t *rb)
{
    return rb->link.link_state == 2 || rb->link.ever_up ? gw_http_api_link_name(rb)
                                                        : "never linked";
}

/* "robot_state": {"value", "name"} and "servo_on" from the robot's
 * io_state, and "values_stale"; both null while the link was never up
 * (the images hold zeros, not the robot's). */
static void robot_truth(gw_json_t *j, const gw_robot_t *rb)
{
    dr_ref_t ref;
    dr_value_t v;
    bool never = !rb->link.ever_up;
    gw_json_str(j, ",\"robot_state\":");
    if (never || dr_path_parse("io_state.robot_state", &ref) != DR_OK ||
        gw_robot_get(rb, ref, &v) != DR_OK) {
        gw_json_str(j, "null");
    } else {
        unsigned x = (unsigned)dr_value_as_double(&v);
        const char *name = dr_robot_state_name(x);
        NUM(j, "{\"value\":%u,\"name\":", x);
        qstr(j, name != NULL ? name : "?");
        gw_json_str(j, "}");
    }
    gw_json_str(j, ",\"servo_on\":");
    if (never || dr_path_parse("io_state.servo_on", &ref) != DR_OK ||
        gw_robot_get(rb, ref, &v) != DR_OK)
        gw_json_str(j, "null");
    else
        gw_json_str(j, dr_value_as_double(&v) != 0 ? "true" : "false");
    /* the values are not the robot's now: never received, or older than
     * the connection timeout */
    gw_json_str(j, never || !rb->link.fresh ? ",\"values_stale\":true" : ",\"values_stale\":false");
}

/* Who the robot is: where the gateway reaches it, how, and as whom. */
static void identity(gw_json_t *j, const gw_http_api_t *a, unsigned r)
{
    const gw_robot_config_t *rc = &a->env->cfg->robot[r];
    gw_json_str(j, ",\"host\":");
    qstr(j, rc->host);
    NUM(j, ",\"tcp_port\":%u", (unsigned)rc->tcp_port);
    NUM(j, ",\"udp_port\":%u", (unsigned)rc->udp_port);
    gw_json_str(j, ",\"mode\":");
    qstr(j, rc->mode == GW_MODE_IMPLICIT ? "implicit" : "explicit");
    gw_json_str(j, ",\"layout\":");
    qstr(j, dr_layout_name(rc->layout));
    char serial[16];
    snprintf(serial, sizeof serial, "0x%08lX",
             (unsigned long)a->env->robots[r].link.originator_serial);
    gw_json_str(j, ",\"originator_serial\":");
    qstr(j, serial);
    gw_json_str(j, ",\"sides\":{");
    if (a->env->robot_sides != NULL)
        a->env->robot_sides(a->env->user, r, j);
    gw_json_str(j, "}");
}

/* "identity": the robot's Identity object as the link read it (robot.h):
 * the members of drcli identity --json, with the vendor's name; only
 * "state" ("waiting", "refused" with its "reason") before it is known. */
static void robot_identity(gw_json_t *j, const gw_robot_identity_t *id)
{
    char text[160];
    gw_json_str(j, ",\"identity\":{\"state\":");
    if (id->state != GW_IDENTITY_KNOWN) {
        qstr(j, id->state == GW_IDENTITY_WAITING ? "waiting" : "refused");
        if (id->state == GW_IDENTITY_REFUSED) {
            gw_robot_identity_refusal(id, text, sizeof text);
            gw_json_str(j, ",\"reason\":");
            qstr(j, text);
        }
        gw_json_str(j, "}");
        return;
    }
    qstr(j, "known");
    NUM(j, ",\"vendor\":%u,\"vendor_name\":", (unsigned)id->vendor_id);
    gw_identity_vendor_text(id->vendor_id, text, sizeof text);
    qstr(j, text);
    NUM(j, ",\"device_type\":%u", (unsigned)id->device_type);
    NUM(j, ",\"product_code\":%u", (unsigned)id->product_code);
    snprintf(text, sizeof text, "%u.%u", (unsigned)id->rev_major, (unsigned)id->rev_minor);
    gw_json_str(j, ",\"revision\":");
    qstr(j, text);
    NUM(j, ",\"serial\":%lu", (unsigned long)id->serial);
    gw_json_str(j, ",\"product_name\":");
    qstr(j, id->product_name);
    gw_json_str(j, "}");
}

/* "connections": each slot the robot's plan opens, with its state and its
 * packets received and lost since the link started (the overview shows
 * them beside the state). */
static void connections(gw_json_t *j, const gw_robot_config_t *rc, const gw_robot_t *rb)
{
    gw_json_str(j, "[");
    bool first = true;
    int a;
    for (unsigned i = 0; i < GW_ROBOT_CONNS && (a = gw_link_slot_asm(i)) >= 0; i++) {
        /* a combined layout has one connection (slot 0): "assembly" is
         * the first its input carries (as before), "name" what it is */
        if (rc->layout != DR_LAYOUT_PER_ASSEMBLY ? i > 0 || rb->link.conn_t2o[0] >= DR_ASM_COUNT
                                                 : rc->mode == GW_MODE_IMPLICIT &&
                                                       rc->open[a].kind == GW_OPEN_NONE)
            continue;
        if (rc->layout != DR_LAYOUT_PER_ASSEMBLY)
            a = rb->link.conn_t2o[0];
        gw_json_str(j, first ? "{\"assembly\":" : ",{\"assembly\":");
        first = false;
        qstr(j, dr_asm_info((dr_asm_t)a)->name);
        /* what it carries: the assembly, or a combined layout's name */
        gw_json_str(j, ",\"name\":");
        qstr(j, rb->link.conn_name[0] != '\0' ? rb->link.conn_name
                                              : dr_asm_info((dr_asm_t)a)->name);
        gw_json_str(j, ",\"state\":");
        qstr(j, rc->mode == GW_MODE_IMPLICIT
                    ? dr_conn_state_name((dr_conn_state_t)rb->link.conn_state[i])
                    : "polled");
        NUM(j, ",\"rx_packets\":%lu", (unsigned long)rb->link.conn_rx[i]);
        NUM(j, ",\"lost_packets\":%lu", (unsigned long)rb->link.conn_lost[i]);
        NUM(j, ",\"dropped_seq\":%lu", (unsigned long)rb->link.conn_dropped_seq[i]);
        NUM(j, ",\"dropped_addr\":%lu", (unsigned long)rb->link.conn_dropped_addr[i]);
        NUM(j, ",\"resyncs\":%lu}", (unsigned long)rb->link.conn_resyncs[i]);
    }
    gw_json_str(j, "]");
}

void gw_http_api_robot(gw_json_t *j, const gw_http_api_t *a, unsigned r)
{
    const gw_robot_t *rb = &a->env->robots[r];
    const gw_robot_link_t *lk = &rb->link;
    char why[200];
    gw_robot_cause(rb, why, sizeof why);
    gw_json_str(j, "{\"name\":");
    qstr(j, rb->name);
    gw_json_str(j, ",\"link\":");
    qstr(j, gw_http_api_link_name(rb));
    gw_json_str(j, ",\"state\":");
    qstr(j, gw_http_api_state_name(rb));
    gw_json_str(j, rb->link.ever_up ? ",\"ever_linked\":true" : ",\"ever_linked\":false");
    identity(j, a, r);
    robot_identity(j, &rb->identity);
    /* Why it is not up, in the log's words; null while up or before the
     * first failure. */
    gw_json_str(j, ",\"reason\":");
    if (lk->link_state != 2 && why[0] != '\0')
        qstr(j, why);
    else
        gw_json_str(j, "null");
    NUM(j, ",\"rpi_ms\":%u", (unsigned)lk->rpi_ms);
    /* the age of data received; none yet: null (not the time since the
     * link started) */
    if (lk->rx_us != 0)
        NUM(j, ",\"age_ms\":%lu", (unsigned long)lk->age_ms);
    else
        gw_json_str(j, ",\"age_ms\":null");
    gw_json_str(j, lk->fresh ? ",\"fresh\":true" : ",\"fresh\":false");
    robot_truth(j, rb);
    NUM(j, ",\"heartbeat\":%u", (unsigned)rb->heartbeat);
    gw_json_str(j, ",\"connections\":");
    connections(j, &a->env->cfg->robot[r], rb);
    NUM(j, ",\"rx_packets\":%lu", (unsigned long)lk->rx_packets);
    NUM(j, ",\"lost_packets\":%lu", (unsigned long)lk->lost_packets);
    NUM(j, ",\"dropped_seq\":%lu", (unsigned long)lk->dropped_seq);
    NUM(j, ",\"dropped_addr\":%lu", (unsigned long)lk->dropped_addr);
    NUM(j, ",\"resyncs\":%lu", (unsigned long)lk->resyncs);
    NUM(j, ",\"sets_refused\":%lu", (unsigned long)lk->sets_refused);
    gw_json_str(j, ",\"last_error\":");
    if (lk->last_status == DR_OK) {
        gw_json_str(j, "null");
    } else {
        NUM(j, "{\"code\":%u", (unsigned)lk->last_error);
        NUM(j, ",\"cip_general\":%u,\"text\":", (unsigned)lk->last_cip_general);
        qstr(j, why);
        gw_json_str(j, "}");
    }
    /* The last accepted write (core/robot.h, http/metrics.h). */
    gw_json_str(j, ",\"last_write\":");
    gw_http_last_write_json(j, rb);
    gw_json_str(j, "}");
}

void gw_http_api_robots(gw_json_t *j, const gw_http_api_t *a)
{
    gw_json_str(j, "[");
    for (unsigned r = 0; r < a->env->cfg->robot_count; r++) {
        if (r > 0)
            gw_json_str(j, ",");
        gw_http_api_robot(j, a, r);
    }
    gw_json_str(j, "]");
}

void gw_http_api_status(gw_json_t *j, const gw_http_api_t *a)
{
    gw_json_str(j, "{\"version\":");
    qstr(j, a->env->version);
    NUM(j, ",\"uptime_s\":%llu", (unsigned long long)a->uptime_s);
    gw_json_str(j, ",\"config\":{\"file\":");
    qstr(j, gw_http_api_config_path(a->env->cfg));
    NUM(j, ",\"generation\":%u},\"robots\":", a->generation);
    gw_http_api_robots(j, a);
    /* Each side's own object: the report part's (report.h). */
    gw_json_str(j, ",\"sides\":{");
    gw_http_report_sides(a->env, j);
    gw_json_str(j, "}}");
}

/* The texts of the values last formatted, by robot (its serial picks a
 * slot) and leaf: live streams of one robot wake up together (north_http.c
 * puts them on one 250 ms grid), see the same values, and so format each
 * changed value once between them, not once per page (bench-console).
 * The leaves' paths are made once. Touched only by a daemon that serves
 * values (.bss otherwise). */
#define TOK_MAX 32 /* dr_text_json of any value: at most 17 characters */
typedef struct {
    uint32_t serial; /* the robot's; 0: empty */
    uint64_t bits[GW_HTTP_API_LEAVES];
    char tok[GW_HTTP_API_LEAVES][TOK_MAX];
} tok_cache_t;
static tok_cache_t tok_cache[GW_MAX_ROBOTS];
static char leaf_path[GW_HTTP_API_LEAVES][64];

/* A leaf beyond the cache (a field table grown past GW_HTTP_API_LEAVES)
 * is formatted into `spare` every time. */
static const char *path_of(unsigned i, dr_ref_t ref, char *spare, size_t size)
{
    char *p = i < GW_HTTP_API_LEAVES ? leaf_path[i] : spare;
    size_t n = i < GW_HTTP_API_LEAVES ? sizeof leaf_path[i] : size;
    if ((i >= GW_HTTP_API_LEAVES || p[0] == '\0') && dr_ref_path(ref, p, n) != DR_OK)
        p[0] = '\0';
    return p[0] != '\0' ? p : NULL;
}

/* The value's text, from the cache when it is the same value (bits). */
static const char *text_of(const gw_robot_t *rb, unsigned i, uint64_t bits, const dr_value_t *v,
                           char *spare, size_t size)
{
    if (i >= GW_HTTP_API_LEAVES)
        return dr_text_json(v, spare, size) == DR_OK ? spare : NULL;
    tok_cache_t *c = &tok_cache[rb->serial % GW_MAX_ROBOTS];
    if (c->serial != rb->serial) {
        c->serial = rb->serial;
        memset(c->bits, GW_HTTP_API_UNSENT, sizeof c->bits);
    }
    if (c->bits[i] == bits && c->tok[i][0] != '\0')
        return c->tok[i];
    if (dr_text_json(v, c->tok[i], sizeof c->tok[i]) != DR_OK) {
        c->tok[i][0] = '\0';
        return NULL;
    }
    c->bits[i] = bits;
    return c->tok[i];
}

unsigned gw_http_api_values(gw_json_t *j, const gw_robot_t *rb, bool indent, uint64_t *last)
{
    unsigned n = 0, leaves = dr_leaf_count();
    char path_spare[96], tok_spare[TOK_MAX];
    gw_json_str(j, "{");
    for (unsigned i = 0; i < leaves; i++) {
        dr_ref_t ref;
        dr_value_t v;
        if (dr_leaf_at((uint16_t)i, &ref) != DR_OK || gw_robot_get(rb, ref, &v) != DR_OK)
            continue;
        /* Compared bit for bit: a NaN equals the NaN sent before it, and
         * GW_HTTP_API_UNSENT (all bits set) no value. Before the text is
         * made: a live stream formats only what changed (bench-console). */
        double x = dr_value_as_double(&v);
        uint64_t bits;
        memcpy(&bits, &x, sizeof bits);
        if (last != NULL && last[i] == bits)
            continue;
        const char *path = path_of(i, ref, path_spare, sizeof path_spare);
        const char *tok = text_of(rb, i, bits, &v, tok_spare, sizeof tok_spare);
        if (path == NULL || tok == NULL)
            continue;
        if (last != NULL)
            last[i] = bits;
        gw_json_str(j, n > 0 ? (indent ? ",\n  " : ",") : (indent ? "\n  " : ""));
        qstr(j, path);
        gw_json_str(j, indent ? ": " : ":");
        gw_json_str(j, tok);
        n++;
    }
    gw_json_str(j, indent && n > 0 ? "\n}\n" : indent ? "}\n" : "}");
    return n;
}

unsigned gw_http_api_down(const gw_http_api_t *a)
{
    unsigned n = 0;
    for (unsigned r = 0; r < a->env->cfg->robot_count; r++)
        n += a->env->robots[r].link.link_state != 2;
    return n;
}

/* "3d 04h", "1h 02m", "5m 07s", "12s" */
static void duration(char *out, size_t size, uint64_t s)
{
    if (s >= 86400u)
        snprintf(out, size, "%llud %02lluh", (unsigned long long)(s / 86400u),
                 (unsigned long long)(s % 86400u / 3600u));
    else if (s >= 3600u)
        snprintf(out, size, "%lluh %02llum", (unsigned long long)(s / 3600u),
                 (unsigned long long)(s % 3600u / 60u));
    else if (s >= 60u)
        snprintf(out, size, "%llum %02llus", (unsigned long long)(s / 60u),
                 (unsigned long long)(s % 60u));
    else
        snprintf(out, size, "%llus", (unsigned long long)s);
}

void gw_http_api_summary(gw_json_t *j, const gw_http_api_t *a)
{
    const gw_config_t *cfg = a->env->cfg;
    char line[512], up[32];
    unsigned down = gw_http_api_down(a);
    duration(up, sizeof up, a->uptime_s);
    snprintf(line, sizeof line,
             "drgatewayd %s: %s\n     Uptime: %s\n     Config: %s (generation %u)\n     Robots: "
             "%u of %u linked\n",
             a->env->version, down == 0 ? "running, every robot linked" : "running, robots down",
             up, gw_http_api_config_path(cfg), a->generation, cfg->robot_count - down,
             cfg->robot_count);
    gw_json_str(j, line);
    for (unsigned r = 0; r < cfg->robot_count; r++) {
        const gw_robot_t *rb = &a->env->robots[r];
        char st[240];
        gw_robot_state_text(rb, st, sizeof st);
        if (rb->link.link_state == 2)
            snprintf(line, sizeof line,
                     "       %-12s %s (%s:%u, RPI %u ms, data age %lu ms, %lu packets, %lu lost)\n",
                     rb->name, st, cfg->robot[r].host, (unsigned)cfg->robot[r].tcp_port,
                     (unsigned)rb->link.rpi_ms, (unsigned long)rb->link.age_ms,
                     (unsigned long)rb->link.rx_packets, (unsigned long)rb->link.lost_packets);
        else
            snprintf(line, sizeof line, "       %-12s %s (%s:%u)\n", rb->name, st,
                     cfg->robot[r].host, (unsigned)cfg->robot[r].tcp_port);
        gw_json_str(j, line);
        /* who it is, once its Identity has answered */
        if (rb->identity.state != GW_IDENTITY_WAITING) {
            gw_robot_identity_text(&rb->identity, st, sizeof st);
            snprintf(line, sizeof line, "%20sidentity: %s\n", "", st);
            gw_json_str(j, line);
        }
    }
    /* Each side's line, as it fills it (north.h: summary). */
    static gw_side_summary_t sides[GW_NORTH_SIDES];
    unsigned n = a->env->summaries != NULL
                     ? a->env->summaries(a->env->user, sides, GW_NORTH_SIDES)
                     : 0;
    for (unsigned i = 0; i < n; i++) {
        snprintf(line, sizeof line, "%11.15s: ", sides[i].label);
        gw_json_str(j, line);
        gw_json_str(j, sides[i].line);
        gw_json_str(j, "\n");
    }
}
