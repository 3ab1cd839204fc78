/* SPDX-License-Identifier: MIT */
/*
 * The console as a northbound side (north.h): the web pages, the JSON API,
 * live values as Server-Sent Events, /metrics ([http], docs/http.md).
 * Read-only: nothing here writes a robot's image.
 *
 * libmicrohttpd (loaded by mhd_lib.c only when [http] exists) runs without
 * a thread of its own (MHD_USE_EPOLL): its epoll descriptor sits in the
 * daemon's epoll set, MHD_run does its work when it is readable, and
 * MHD_get_timeout bounds the loop's wait (its connection timeouts). What a
 * request costs is bounded: connections (max_connections; at the limit
 * MHD stops accepting, and more wait in the kernel's backlog; and
 * max_connections_per_ip per client address, one more closed at once),
 * URL and headers (max_request_bytes: 414 or 431), time
 * (timeout_s for an idle or slow client), and a response is built in one
 * go from the robots' images without blocking. So a slow or hostile
 * client costs the Modbus and robot sides a few microseconds per turn,
 * never a wait.
 *
 * The listening sockets are ours (MHD_OPTION_LISTEN_SOCKET): a reload that
 * keeps the address and port hands a duplicate of the socket to the new
 * server, so the port never closes; one that changes them binds the new
 * one at prepare, and a port taken refuses the reload.
 *
 * Live values (/api/v1/events?robot=NAME): a response whose body comes
 * from a callback (sse_read). With nothing to send it suspends its
 * connection (off MHD's lists: no busy loop, no timeout), and tick()
 * resumes it at the next SSE_PERIOD_US boundary of the monotonic clock,
 * when it sends what changed since its last event, or a comment line now
 * and then so that a client that went away is found. One grid for every
 * stream: the pages of a robot wake up in the same turn of the loop, see
 * the same values and share their texts (api.c), and the loop wakes once
 * for all of them.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "common/ev.h"
#include "core/json.h"
#include "core/log.h"
#include "core/north.h"
#include "drgate/codec.h"
#include "http/api.h"
#include "http/asset.h"
#include "core/auth.h"
#include "http/http.h"
#include "http/mhd_lib.h"
#include "core/passwd.h"
#include "http/report.h"
#include "http/request.h"

#define SSE_PERIOD_US 250000u      /* live values at most this often */
#define SSE_KEEPALIVE_US 10000000u /* a comment line when nothing changed */
#define SSE_BUF 65536u             /* one stream's pending event text */
/* The largest response built: a robot's map with the largest user map
 * (asset.h; /metrics and the rest are far smaller). Static .bss: only the
 * pages a response fills are ever touched. */
#define RESP_MAX GW_HTTP_MAP_MAX
#define REALM "drgatewayd"
/* Connections kept beyond max_connections for clients on loopback:
 * `drgatewayd status` and local tools get an answer when remote clients
 * hold every other one. */
#define RESERVED_LOCAL 4u
/* Requests on one kept-alive connection; the answer to the last one says
 * "Connection: close". */
#define KEEPALIVE_MAX 1000u
/* The TLS console's offer unless tls_priorities says otherwise: TLS 1.2
 * and 1.3 only, ECDHE only, AEAD ciphers only (no CBC, no SHA-1 MACs, no
 * RSA key transport), the server's order. */
#define TLS_PRIORITIES                                                                           \
    "NORMAL:-VERS-ALL:+VERS-TLS1.3:+VERS-TLS1.2:-CIPHER-ALL:+AES-256-GCM:+AES-128-GCM:"         \
    "+CHACHA20-POLY1305:-MAC-ALL:+AEAD:-KX-ALL:+ECDHE-ECDSA:+ECDHE-RSA:%SERVER_PRECEDENCE"
/* What every answer carries: the pages load nothing but their own files
 * and may not be framed (clickjacking); no referrer leaves them. */
#define CSP                                                                                      \
    "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data:; "           \
    "connect-src 'self'; object-src 'none'; base-uri 'none'; form-action 'none'; "              \
    "frame-ancestors 'none'"
#define HTTP_CODES 600
/* MHD's memory per connection beyond max_request_bytes: room for the
 * answer's head, so that a request near the limit is answered (414, 431)
 * rather than closed without a status line, which MHD does when the
 * request took the whole pool (on_request checks the limit itself). */
#define ANSWER_ROOM 8192u

typedef struct ht ht_t;

/* One listening server: the console, or the plain loopback one for
 * `drgatewayd status` beside a TLS console (status_port). */
typedef struct {
    ht_t *t;
    struct MHD_Daemon *d;
    ev_t ev;  /* MHD's epoll descriptor in the loop */
    int lfd;  /* the listening socket we made (MHD closes it) */
    bool tls, loopback_only;
    uint16_t port;
    unsigned conns; /* connections open */
} srv_t;

/* One robot of a live stream: what was last sent of it. */
typedef struct {
    char name[GW_NAME_MAX];
    uint32_t serial;     /* the robot's: a new one starts over */
    uint16_t link_state; /* as last sent */
    bool fresh, ever_up; /* as last sent */
    bool started;        /* its status and every value sent once */
    uint64_t *last;      /* per leaf: the value last sent (api.h) */
} sse_robot_t;

/* One live stream: one page's (or, through the pages' shared worker, one
 * browser's) robots and the overview, multiplexed. */
typedef struct sse {
    struct sse *next;
    ht_t *t;
    struct MHD_Connection *c;
    unsigned nrobots;
    sse_robot_t *robot;  /* [nrobots] */
    bool multi;          /* robots=: each event names its robot */
    bool overview;       /* overview=1: the status too, when it changed */
    uint64_t overview_hash, overview_next_us;
    unsigned turn;       /* the robot whose values go first (fairness) */
    uint32_t ip;         /* the client's */
    int fd;              /* its socket (a stalled one is shut down) */
    uint64_t started_us, progress_us; /* opened; last took bytes */
    uint64_t peek_us; /* its socket last looked at for a close (sse_limits) */
    bool suspended, closing;
    uint64_t next_us, quiet_since_us;
    size_t len, off; /* buf[off..len): not yet taken by MHD */
    char buf[SSE_BUF];
} sse_t;

/* One connection: how long it may take to send a request. MHD's own
 * timeout is for idleness, which a client sending a byte a second never
 * is (slowloris); so each request's head must be in within timeout_s of
 * the connection, or of the end of the previous answer, or the socket is
 * shut down (MHD then closes it as gone). No deadline while an answer is
 * being sent (a live page's, for its life). */
typedef enum { AUTH_NONE, AUTH_PENDING, AUTH_OK, AUTH_REFUSED, AUTH_BUSY } auth_state_t;

typedef struct hc {
    struct hc *next;
    struct MHD_Connection *c;
    int fd;
    uint32_t ip;     /* the client's IPv4 address, host order */
    bool loopback;   /* from 127/8: no login asked */
    bool answering;
    bool suspended;  /* waiting for its login's check, or its wait */
    auth_state_t auth; /* this request's login */
    unsigned requests; /* answered on this connection */
    uint64_t deadline_us;
    uint64_t held_until; /* a refused login's answer is due then */
} hc_t;

struct ht {
    const gw_north_env_t *env;
    gw_http_config_t cfg; /* a copy: a reload compares the new one with it */
    srv_t srv[2];         /* [0] the console, [1] status_port's (or none) */
    gw_users_t users;
    char *cert, *key; /* PEM texts, for MHD's TLS set-up */
    sse_t *streams;
    hc_t *conns;
    unsigned generation;
    gw_log_limit_t mhd_limit, slow_limit, stream_limit;
    gw_auth_t *auth; /* logins (core/auth.h), with auth_file */
    ev_t auth_ev;         /* its eventfd in the loop */
    unsigned nstreams;
    uint64_t streams_refused, streams_cut, hosts_refused;
    uint64_t answers[HTTP_CODES]; /* by status code */
};

static const gw_mhdlib_t *ml; /* loaded by the first enabled side */
static uint64_t start_us;     /* the daemon's start, for uptime_s */
static char resp[RESP_MAX];   /* the response being built (copied by MHD) */

/* ---- helpers -------------------------------------------------------------------- */

static gw_http_api_t api_of(const ht_t *t)
{
    gw_http_api_t a = {t->env, (ev_now_us() - start_us) / 1000000u, t->generation};
    return a;
}

static bool addr_loopback(const struct sockaddr *sa)
{
    if (sa == NULL || sa->sa_family != AF_INET)
        return false;
    struct sockaddr_in in;
    memcpy(&in, sa, sizeof in);
    return (ntohl(in.sin_addr.s_addr) >> 24) == 127u;
}

static bool allowed(const gw_http_config_t *h, const struct sockaddr *sa)
{
    if (h->allow_count == 0)
        return true;
    if (sa == NULL || sa->sa_family != AF_INET)
        return false;
    struct sockaddr_in in;
    memcpy(&in, sa, sizeof in);
    uint32_t a = ntohl(in.sin_addr.s_addr);
    for (unsigned i = 0; i < h->allow_count; i++)
        if ((a & h->allow[i].mask) == h->allow[i].net)
            return true;
    return false;
}

/* A whole file into a new NUL-terminated buffer; NULL with err. */
static char *read_file(const char *path, const char *key, char *err, size_t errlen)
{
    FILE *f = fopen(path, "r");
    char *buf = NULL;
    if (f == NULL) {
        snprintf(err, errlen, "http: %s %s: %s", key, path, strerror(errno));
        return NULL;
    }
    buf = malloc(GW_PASSWD_FILE_MAX + 1);
    size_t n = buf != NULL ? fread(buf, 1, GW_PASSWD_FILE_MAX, f) : 0;
    if (buf == NULL || ferror(f)) {
        snprintf(err, errlen, "http: %s %s: %s", key, path,
                 buf == NULL ? "out of memory" : strerror(errno));
        free(buf);
        buf = NULL;
    } else {
        buf[n] = '\0';
    }
    (void)fclose(f);
    return buf;
}

/* ---- responses -------------------------------------------------------------------- */

/* MHD's buffer responses take a `void *` they only read (PERSISTENT) or
 * copy (MUST_COPY). */
static void *unconst(const void *p)
{
    void *q;
    memcpy(&q, &p, sizeof q);
    return q;
}

/* The request being answered (the loop has one at a time). */
static srv_t *cur_sv;
static hc_t *cur_hc;

/* Every answer goes out here: the headers every answer carries, counted
 * by status. */
static enum MHD_Result queue(struct MHD_Connection *c, unsigned status, struct MHD_Response *r,
                             bool auth_fail)
{
    (void)ml->add_response_header(r, "X-Content-Type-Options", "nosniff");
    (void)ml->add_response_header(r, "Content-Security-Policy", CSP);
    (void)ml->add_response_header(r, "X-Frame-Options", "DENY");
    (void)ml->add_response_header(r, "Referrer-Policy", "no-referrer");
    if (cur_sv != NULL && cur_sv->tls)
        (void)ml->add_response_header(r, "Strict-Transport-Security", "max-age=31536000");
    if (cur_hc != NULL && ++cur_hc->requests >= KEEPALIVE_MAX)
        (void)ml->add_response_header(r, "Connection", "close");
    if (cur_sv != NULL && status < HTTP_CODES)
        cur_sv->t->answers[status]++;
    return auth_fail ? ml->queue_basic_auth_fail_response(c, REALM, r)
                     : ml->queue_response(c, status, r);
}

static enum MHD_Result send_buf(struct MHD_Connection *c, unsigned status, const char *type,
                                const void *data, size_t len, bool copy)
{
    struct MHD_Response *r = ml->create_response_from_buffer(
        len, unconst(data), copy ? MHD_RESPMEM_MUST_COPY : MHD_RESPMEM_PERSISTENT);
    if (r == NULL)
        return MHD_NO;
    (void)ml->add_response_header(r, "Content-Type", type);
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    if (status == 405)
        (void)ml->add_response_header(r, "Allow", "GET, HEAD");
    if (status == 503) { /* and the connection goes: a refused stream holds nothing */
        (void)ml->add_response_header(r, "Retry-After", "5");
        (void)ml->add_response_header(r, "Connection", "close");
    }
    enum MHD_Result ok = queue(c, status, r, false);
    ml->destroy_response(r);
    return ok;
}

static enum MHD_Result send_json(struct MHD_Connection *c, unsigned status, const gw_json_t *j)
{
    if (j->full) {
        static const char e[] = "{\"error\":\"response too large\"}\n";
        return send_buf(c, 500, "application/json", e, sizeof e - 1, false);
    }
    return send_buf(c, status, "application/json", j->buf, j->len, true);
}

/* An error: {"error": what, "method", "path"} under /api/, text elsewhere;
 * both say what was asked. */
static enum MHD_Result send_error(struct MHD_Connection *c, unsigned status, const char *method,
                                  const char *url, const char *what)
{
    gw_json_t j;
    gw_json_init(&j, resp, sizeof resp);
    if (strncmp(url, "/api/", 5) == 0) {
        gw_json_str(&j, "{\"error\":");
        gw_json_quote(&j, what, strlen(what));
        gw_json_str(&j, ",\"method\":");
        gw_json_quote(&j, method, strlen(method) > 16 ? 16 : strlen(method));
        gw_json_str(&j, ",\"path\":");
        gw_json_quote(&j, url, strlen(url) > 512 ? 512 : strlen(url));
        gw_json_str(&j, "}\n");
        return send_json(c, status, &j);
    }
    char line[768];
    snprintf(line, sizeof line, "%u %s: %.16s %.512s\n", status, what, method, url);
    for (char *p = line; *p; p++) /* a URL's bytes as they came: no control characters */
        if ((unsigned char)*p < 0x20 && *p != '\n')
            *p = '?';
    return send_buf(c, status, "text/plain; charset=utf-8", line, strlen(line), true);
}

/* An asset's entity tag: its bytes' FNV-1a (built in: the same until the
 * daemon is another), made once per asset. */
#define ETAGS 16
static void asset_etag(const gw_http_asset_t *a, char *out, size_t size)
{
    static const gw_http_asset_t *seen[ETAGS];
    static uint64_t tag[ETAGS];
    unsigned i = 0;
    while (i < ETAGS && seen[i] != NULL && seen[i] != a)
        i++;
    uint64_t h = i < ETAGS && seen[i] == a ? tag[i] : 14695981039346656037u;
    if (i == ETAGS || seen[i] != a) {
        for (size_t k = 0; k < a->size; k++)
            h = (h ^ a->data[k]) * 1099511628211u;
        if (i < ETAGS) {
            seen[i] = a;
            tag[i] = h;
        }
    }
    snprintf(out, size, "\"%016llx\"", (unsigned long long)h);
}

/* A page, script or style sheet: cached by the browser and asked again
 * with its tag (no-cache: a daemon upgraded serves its new files at
 * once), answered 304 when unchanged; the connection stays open. */
static enum MHD_Result send_asset(struct MHD_Connection *c, const char *name, const char *method,
                                  const char *url)
{
    const gw_http_asset_t *a = gw_http_asset_find(name);
    if (a == NULL)
        return send_error(c, 404, method, url, "not found");
    char etag[24];
    asset_etag(a, etag, sizeof etag);
    const char *inm = ml->lookup_connection_value(c, MHD_HEADER_KIND, "If-None-Match");
    bool same = inm != NULL && strstr(inm, etag) != NULL;
    struct MHD_Response *r = ml->create_response_from_buffer(
        same ? 0 : a->size, same ? NULL : unconst(a->data), MHD_RESPMEM_PERSISTENT);
    if (r == NULL)
        return MHD_NO;
    (void)ml->add_response_header(r, "Content-Type", a->type);
    (void)ml->add_response_header(r, "Cache-Control", "no-cache");
    (void)ml->add_response_header(r, "ETag", etag);
    enum MHD_Result ok = queue(c, same ? 304 : 200, r, false);
    ml->destroy_response(r);
    return ok;
}

/* /api/v1/status asked for text (drgatewayd status): the summary, and
 * the robots not linked in X-Robots-Down. */
static enum MHD_Result send_summary(struct MHD_Connection *c, const gw_http_api_t *a)
{
    gw_json_t j;
    gw_json_init(&j, resp, sizeof resp);
    gw_http_api_summary(&j, a);
    struct MHD_Response *r =
        ml->create_response_from_buffer(j.len, j.buf, MHD_RESPMEM_MUST_COPY);
    if (r == NULL)
        return MHD_NO;
    char down[16];
    snprintf(down, sizeof down, "%u", gw_http_api_down(a));
    (void)ml->add_response_header(r, "Content-Type", "text/plain; charset=utf-8");
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    (void)ml->add_response_header(r, "X-Robots-Down", down);
    enum MHD_Result ok = queue(c, 200, r, false);
    ml->destroy_response(r);
    return ok;
}

/* /api/v1/status as JSON, with the robots not linked in X-Robots-Down
 * too (`drgatewayd status --json`'s exit status). */
static enum MHD_Result send_status_json(struct MHD_Connection *c, const gw_http_api_t *a,
                                        gw_json_t *j)
{
    if (j->full)
        return send_json(c, 200, j);
    gw_json_str(j, "\n");
    struct MHD_Response *r = ml->create_response_from_buffer(j->len, j->buf, MHD_RESPMEM_MUST_COPY);
    if (r == NULL)
        return MHD_NO;
    char down[16];
    snprintf(down, sizeof down, "%u", gw_http_api_down(a));
    (void)ml->add_response_header(r, "Content-Type", "application/json");
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    (void)ml->add_response_header(r, "X-Robots-Down", down);
    enum MHD_Result ok = queue(c, 200, r, false);
    ml->destroy_response(r);
    return ok;
}

/* ---- live values (Server-Sent Events) ------------------------------------------- */

/* An event into the stream's buffer; false (nothing written) when it
 * does not fit now. */
static bool sse_append(sse_t *s, const char *event, const gw_json_t *j)
{
    size_t need = strlen(event) + j->len + 16;
    if (j->full || s->len + need > sizeof s->buf)
        return false;
    s->len += (size_t)snprintf(s->buf + s->len, sizeof s->buf - s->len, "event: %s\ndata: %s\n\n",
                               event, j->buf);
    return true;
}

static char sse_text[SSE_BUF]; /* an event's data being made (one loop) */

/* Robot k of the stream: its status when its link or the freshness of
 * its values changed (or first), and the values that changed since the
 * last event (all of them first), as far as the buffer has room; what
 * did not fit goes at the next turn. False: the robot is gone. */
static bool sse_robot(sse_t *s, const gw_http_api_t *a, sse_robot_t *k)
{
    int r = gw_http_api_find(a, k->name);
    if (r < 0)
        return false;
    const gw_robot_t *rb = &a->env->robots[r];
    gw_json_t j;
    if (!k->started || rb->serial != k->serial) {
        memset(k->last, GW_HTTP_API_UNSENT, dr_leaf_count() * sizeof *k->last);
        k->serial = rb->serial;
        k->started = false;
    }
    if (!k->started || rb->link.link_state != k->link_state || rb->link.fresh != k->fresh ||
        rb->link.ever_up != k->ever_up) {
        gw_json_init(&j, sse_text, sizeof sse_text);
        gw_http_api_robot(&j, a, (unsigned)r);
        if (!sse_append(s, "status", &j))
            return true; /* the next turn */
        k->link_state = rb->link.link_state;
        k->fresh = rb->link.fresh;
        k->ever_up = rb->link.ever_up;
        k->started = true;
    }
    /* what fits the buffer now, the leaves' last values kept for a retry */
    size_t room = sizeof s->buf - s->len;
    if (room < 512u + GW_NAME_MAX)
        return true;
    static uint64_t saved[GW_HTTP_API_LEAVES];
    size_t bytes = dr_leaf_count() * sizeof *k->last;
    bool keep = bytes <= sizeof saved;
    if (keep)
        memcpy(saved, k->last, bytes);
    gw_json_init(&j, sse_text, room - 32u);
    if (s->multi) {
        gw_json_str(&j, "{\"robot\":");
        gw_json_quote(&j, k->name, strlen(k->name));
        gw_json_str(&j, ",\"values\":");
    }
    unsigned n = gw_http_api_values(&j, rb, false, k->last);
    if (s->multi)
        gw_json_str(&j, "}");
    if (n > 0 && !sse_append(s, "values", &j) && keep)
        memcpy(k->last, saved, bytes); /* not sent: all of them again next turn */
    return true;
}

/* A 64-bit FNV-1a of a text: has the overview changed since it was sent? */
static uint64_t fnv(const char *p, size_t n)
{
    uint64_t h = 14695981039346656037u;
    for (size_t i = 0; i < n; i++)
        h = (h ^ (unsigned char)p[i]) * 1099511628211u;
    return h;
}

/* What this stream has to say now, into its buffer: the overview (at
 * most every OVERVIEW_US, when it changed), each robot's status and
 * values, else now and then a comment. False: the stream ends (the robot
 * of a robot=NAME stream is gone). */
#define OVERVIEW_US 500000u
static bool sse_fill(sse_t *s, uint64_t now)
{
    ht_t *t = s->t;
    gw_http_api_t a = api_of(t);
    if (s->overview && now >= s->overview_next_us) {
        gw_json_t j;
        gw_json_init(&j, sse_text, sizeof sse_text);
        gw_http_api_status(&j, &a);
        uint64_t h = fnv(j.buf, j.len);
        if (h != s->overview_hash && sse_append(s, "overview", &j)) {
            s->overview_hash = h;
            s->overview_next_us = now + OVERVIEW_US;
        }
    }
    for (unsigned i = 0; i < s->nrobots; i++) {
        sse_robot_t *k = &s->robot[(s->turn + i) % s->nrobots];
        if (!sse_robot(s, &a, k) && !s->multi)
            return false;
    }
    s->turn = s->nrobots > 0 ? (s->turn + 1u) % s->nrobots : 0;
    if (s->len > 0) {
        s->quiet_since_us = now;
    } else if (now - s->quiet_since_us >= SSE_KEEPALIVE_US) {
        memcpy(s->buf, ": idle\n\n", 8);
        s->len = 8;
        s->quiet_since_us = now;
    }
    /* The grid point at least half a period away: every SSE_PERIOD_US once
     * on the grid, and a first event never followed by one within 125 ms. */
    s->next_us = ((now + SSE_PERIOD_US / 2u) / SSE_PERIOD_US + 1u) * SSE_PERIOD_US;
    return true;
}

static ssize_t sse_read(void *cls, uint64_t pos, char *buf, size_t max)
{
    sse_t *s = cls;
    (void)pos;
    if (s->off == s->len) {
        s->off = s->len = 0;
        uint64_t now = ev_now_us();
        if (s->closing || (now >= s->next_us && !sse_fill(s, now)))
            return MHD_CONTENT_READER_END_OF_STREAM;
    }
    if (s->off == s->len) {
        /* Nothing now: off MHD's lists until tick() resumes it. */
        ml->suspend_connection(s->c);
        s->suspended = true;
        return 0;
    }
    size_t n = s->len - s->off < max ? s->len - s->off : max;
    memcpy(buf, s->buf + s->off, n);
    s->off += n;
    s->progress_us = ev_now_us();
    return (ssize_t)n;
}

static void sse_free_unlinked(sse_t *s)
{
    if (s->robot != NULL)
        free(s->robot[0].last);
    free(s->robot);
    free(s);
}

static void sse_free(void *cls)
{
    sse_t *s = cls;
    for (sse_t **p = &s->t->streams; *p != NULL; p = &(*p)->next)
        if (*p == s) {
            *p = s->next;
            s->t->nstreams--;
            break;
        }
    sse_free_unlinked(s);
}

/* The robots a stream asks for: robot=NAME (one), or robots=A,B,...
 * (list; at most GW_MAX_ROBOTS, each once), into names[][GW_NAME_MAX];
 * how many, 0 with *why when one is not a robot of this gateway. */
static unsigned sse_names(const ht_t *t, const char *one, const char *list,
                          char names[][GW_NAME_MAX], const char **why)
{
    gw_http_api_t a = api_of(t);
    unsigned n = 0;
    const char *p = one != NULL ? one : list;
    while (p != NULL && *p != '\0') {
        size_t len = one != NULL ? strlen(p) : strcspn(p, ",");
        if (len == 0 || len >= GW_NAME_MAX || n == GW_MAX_ROBOTS) {
            *why = len == 0 ? "an empty robot name" : "too many robots";
            return 0;
        }
        memcpy(names[n], p, len);
        names[n][len] = '\0';
        if (gw_http_api_find(&a, names[n]) < 0) {
            *why = "no such robot";
            return 0;
        }
        bool dup = false;
        for (unsigned i = 0; i < n; i++)
            dup = dup || strcmp(names[i], names[n]) == 0;
        n += !dup;
        p += len;
        if (*p == ',')
            p++;
    }
    return n;
}

static enum MHD_Result start_events(ht_t *t, struct MHD_Connection *c, const char *method,
                                    const char *url)
{
    const char *one = ml->lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "robot");
    const char *list = ml->lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "robots");
    const char *ov = ml->lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "overview");
    bool overview = ov != NULL && strcmp(ov, "1") == 0;
    if (one != NULL && one[0] == '\0')
        one = NULL;
    if (one == NULL && (list == NULL || list[0] == '\0') && !overview)
        return send_error(c, 400, method, url,
                          "robot=NAME missing (allowed: robot=NAME, or robots=A,B,... and "
                          "overview=1)");
    static char names[GW_MAX_ROBOTS][GW_NAME_MAX];
    const char *why = "no such robot";
    unsigned nrobots = sse_names(t, one, one != NULL ? NULL : list, names, &why);
    if (nrobots == 0 && (one != NULL || (list != NULL && list[0] != '\0')))
        return send_error(c, 404, method, url, why);
    /* Bounded in all (and to half the connections, so that the rest of
     * the console, /metrics and `drgatewayd status` keep room) and per
     * client address: one more gets 503, and the page polls instead. */
    uint32_t ip = cur_hc != NULL ? cur_hc->ip : 0;
    unsigned mine = 0, most = t->cfg.max_streams;
    if (most > t->cfg.max_connections / 2u)
        most = t->cfg.max_connections / 2u;
    for (const sse_t *o = t->streams; o != NULL; o = o->next)
        mine += o->ip == ip;
    if (t->nstreams >= most || mine >= t->cfg.max_streams_per_ip) {
        t->streams_refused++;
        gw_log_limited(GW_LOG_INFO, &t->stream_limit,
                       "http: live stream refused: %s (%u of %u open, %u from this address)",
                       t->nstreams >= most ? "max_streams reached" : "max_streams_per_ip reached",
                       t->nstreams, most, mine);
        return send_error(c, 503, method, url,
                          "too many live streams (the page asks for values every second)");
    }
    sse_t *s = calloc(1, sizeof *s);
    size_t leaves = dr_leaf_count();
    if (s != NULL && nrobots > 0 &&
        ((s->robot = calloc(nrobots, sizeof *s->robot)) == NULL ||
         (s->robot[0].last = calloc((size_t)nrobots * leaves, sizeof(uint64_t))) == NULL)) {
        sse_free_unlinked(s);
        s = NULL;
    }
    if (s == NULL)
        return send_error(c, 503, method, url, "out of memory");
    for (unsigned i = 0; i < nrobots; i++) {
        s->robot[i].last = s->robot[0].last + (size_t)i * leaves;
        memcpy(s->robot[i].name, names[i], sizeof s->robot[i].name);
    }
    s->nrobots = nrobots;
    s->multi = one == NULL;
    s->overview = overview;
    s->t = t;
    s->c = c;
    s->ip = ip;
    s->fd = cur_hc != NULL ? cur_hc->fd : -1;
    s->quiet_since_us = s->started_us = s->progress_us = ev_now_us();
    struct MHD_Response *r =
        ml->create_response_from_callback(MHD_SIZE_UNKNOWN, 16384, sse_read, s, sse_free);
    if (r == NULL) {
        sse_free_unlinked(s);
        return MHD_NO;
    }
    s->next = t->streams;
    t->streams = s;
    t->nstreams++;
    (void)ml->add_response_header(r, "Content-Type", "text/event-stream");
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    /* A live page is not idle: MHD's idle timeout is off, and tick() ends
     * the stream at its age limit or when its client stops taking bytes
     * (sse_limits). */
    (void)ml->set_connection_option(c, MHD_CONNECTION_OPTION_TIMEOUT, 0u);
    enum MHD_Result ok = queue(c, 200, r, false);
    ml->destroy_response(r);
    return ok;
}

/* The streams that wait and are due (all of them with `closing`: the
 * server stops, each ends its stream) get their turn. Without a thread
 * of its own MHD does not wake up for a resumed connection (its
 * inter-thread channel is not what the loop watches): MHD_run gives them
 * their turn now. */
static void sse_resume(ht_t *t, uint64_t now, bool closing)
{
    bool any = false;
    for (sse_t *s = t->streams; s != NULL; s = s->next) {
        s->closing = s->closing || closing;
        if (s->suspended && (closing || s->closing || now >= s->next_us)) {
            s->suspended = false;
            ml->resume_connection(s->c);
            any = true;
        }
    }
    for (unsigned i = 0; any && i < 2; i++)
        if (t->srv[i].d != NULL)
            (void)ml->run(t->srv[i].d);
}

/* Streams past their age (stream_max_s) end at their next turn (the page
 * opens a new one); one whose client took no byte for timeout_s x 3 (at
 * least 30 s) is shut down: a client that holds a stream and reads
 * nothing holds a connection and its buffers for nothing. */
static void sse_limits(ht_t *t, uint64_t now)
{
    uint64_t stall = (uint64_t)t->cfg.timeout_s * 3u;
    stall = (stall < 30u ? 30u : stall) * 1000000u;
    for (sse_t *s = t->streams; s != NULL; s = s->next) {
        if (!s->closing && now - s->started_us >= (uint64_t)t->cfg.stream_max_s * 1000000u)
            s->closing = true;
        /* A page closed while its stream waits (off MHD's lists, its
         * socket not watched): seen now, not at the stream's next write,
         * which for a robot whose values never change is 10 s away. */
        if (s->suspended && !s->closing && s->fd >= 0 && now - s->peek_us >= 1000000u) {
            char b;
            s->peek_us = now;
            ssize_t n = recv(s->fd, &b, 1, MSG_PEEK | MSG_DONTWAIT);
            if (n == 0 || (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR))
                s->closing = true;
        }
        if (s->fd >= 0 && now - s->progress_us >= stall) {
            (void)shutdown(s->fd, SHUT_RDWR);
            s->fd = -1;
            s->closing = true;
            t->streams_cut++;
        }
    }
}

/* ---- routes ------------------------------------------------------------------------ */

/* "/api/v1/robots/NAME[/rest]": the robot's index (-1: none) and rest. */
static int robot_of(const ht_t *t, const char *p, const char **rest)
{
    const char *slash = strchr(p, '/');
    size_t n = slash != NULL ? (size_t)(slash - p) : strlen(p);
    char name[GW_NAME_MAX];
    *rest = p + n;
    if (n == 0 || n >= sizeof name)
        return -1;
    memcpy(name, p, n);
    name[n] = '\0';
    gw_http_api_t a = api_of(t);
    return gw_http_api_find(&a, name);
}

/* /api/v1/robots/NAME/map.csv: the robot's map as a table to download
 * (a PLC tag import), named NAME-map.csv. */
static enum MHD_Result send_map_csv(const ht_t *t, struct MHD_Connection *c, const char *method,
                                    const char *url, unsigned robot)
{
    gw_json_t j;
    gw_json_init(&j, resp, sizeof resp);
    if (t->env->map_csv == NULL || !t->env->map_csv(t->env->user, &j, robot))
        return send_error(c, j.full ? 500 : 404, method, url,
                          j.full ? "response too large" : "not found");
    struct MHD_Response *r = ml->create_response_from_buffer(j.len, j.buf, MHD_RESPMEM_MUST_COPY);
    if (r == NULL)
        return MHD_NO;
    char disp[GW_NAME_MAX + 48];
    snprintf(disp, sizeof disp, "attachment; filename=\"%s-map.csv\"", t->env->robots[robot].name);
    for (char *p = disp + 22; *p != '\0'; p++) /* a name of the configuration's: only safe bytes */
        if (!((*p >= 'a' && *p <= 'z') || (*p >= 'A' && *p <= 'Z') || (*p >= '0' && *p <= '9') ||
              *p == '-' || *p == '_' || *p == '.' || (*p == '"' && p[1] == '\0')))
            *p = '_';
    (void)ml->add_response_header(r, "Content-Type", "text/csv; charset=utf-8");
    (void)ml->add_response_header(r, "Content-Disposition", disp);
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    enum MHD_Result ok = queue(c, 200, r, false);
    ml->destroy_response(r);
    return ok;
}

/* What a 404 under /api/ lists: every route. */
#define NOT_FOUND_API                                                                            \
    "not found (allowed: /api/v1/status, /api/v1/robots, /api/v1/robots/NAME, "               \
    "/api/v1/robots/NAME/values, /api/v1/robots/NAME/map, /api/v1/robots/NAME/map.csv, "      \
    "/api/v1/events?robot=NAME, "                                                                \
    "/api/v1/log, /api/v1/writes, /api/v1/config, /api/v1/modbus/requests, "                \
    "/api/v1/modbus/registers/NAME)"

/* "SIDE/PATH": the side's own answer (north.h: env->side_api). */
static bool side_api(const ht_t *t, const char *p, gw_json_t *j)
{
    const char *slash = strchr(p, '/');
    char side[32];
    size_t n = slash != NULL ? (size_t)(slash - p) : 0;
    if (t->env->side_api == NULL || n == 0 || n >= sizeof side)
        return false;
    memcpy(side, p, n);
    side[n] = '\0';
    return t->env->side_api(t->env->user, side, slash + 1, j);
}

static enum MHD_Result route_api(ht_t *t, struct MHD_Connection *c, const char *method,
                                 const char *url)
{
    gw_http_api_t a = api_of(t);
    gw_json_t j;
    gw_json_init(&j, resp, sizeof resp);
    const char *p = url + strlen("/api/v1/");
    if (strcmp(p, "status") == 0) {
        /* the text summary: asked by Accept (drgatewayd status), or by
         * format=text (a link: the pages' <noscript> notice) */
        const char *accept = ml->lookup_connection_value(c, MHD_HEADER_KIND, "Accept");
        const char *fmt = ml->lookup_connection_value(c, MHD_GET_ARGUMENT_KIND, "format");
        if ((accept != NULL && strstr(accept, "text/plain") != NULL &&
             strstr(accept, "json") == NULL) ||
            (fmt != NULL && strcmp(fmt, "text") == 0))
            return send_summary(c, &a);
        gw_http_api_status(&j, &a);
        return send_status_json(c, &a, &j);
    } else if (strcmp(p, "robots") == 0) {
        gw_http_api_robots(&j, &a);
    } else if (strcmp(p, "config") == 0) {
        if (!gw_config_effective(t->env->cfg, resp, sizeof resp))
            return send_error(c, 500, method, url, "response too large");
        return send_buf(c, 200, "text/plain; charset=utf-8", resp, strlen(resp), true);
    } else if (strcmp(p, "events") == 0) {
        return start_events(t, c, method, url);
    } else if (strcmp(p, "log") == 0 || strcmp(p, "writes") == 0) {
        if (!(p[0] == 'l' ? gw_http_report_log : gw_http_report_writes)(t->env, &j))
            return send_error(c, 501, method, url, "not built into this gateway");
    } else if (strncmp(p, "robots/", 7) == 0) {
        const char *rest;
        int r = robot_of(t, p + 7, &rest);
        if (r < 0)
            return send_error(c, 404, method, url, "no such robot");
        if (strcmp(rest, "/map.csv") == 0)
            return send_map_csv(t, c, method, url, (unsigned)r);
        if (rest[0] == '\0')
            gw_http_api_robot(&j, &a, (unsigned)r);
        else if (strcmp(rest, "/values") == 0)
            (void)gw_http_api_values(&j, &t->env->robots[r], true, NULL);
        else if (strcmp(rest, "/map") != 0 ||
                 (!gw_http_api_map(&j, t->env, (unsigned)r) && !j.full))
            return send_error(c, 404, method, url, "not found");
        /* a map that does not fit is send_json's 500 "response too large" */
    } else if (!side_api(t, p, &j)) {
        if (j.full)
            return send_error(c, 500, method, url, "response too large");
        return send_error(c, 404, method, url, NOT_FOUND_API);
    }
    if (!j.full && (j.len == 0 || j.buf[j.len - 1] != '\n'))
        gw_json_str(&j, "\n");
    return send_json(c, 200, &j);
}

static enum MHD_Result route(ht_t *t, struct MHD_Connection *c, const char *method,
                             const char *url)
{
    if (strncmp(url, "/api/v1/", 8) == 0)
        return route_api(t, c, method, url);
    if (strcmp(url, "/") == 0 || strcmp(url, "/index.html") == 0)
        return send_asset(c, "index.html", method, url);
    if (strcmp(url, "/config") == 0)
        return send_asset(c, "config.html", method, url);
    if (strncmp(url, "/robot/", 7) == 0) {
        const char *rest;
        if (robot_of(t, url + 7, &rest) < 0 || rest[0] != '\0')
            return send_error(c, 404, method, url, "no such robot");
        return send_asset(c, "robot.html", method, url);
    }
    if (strncmp(url, "/static/", 8) == 0)
        return send_asset(c, url + 8, method, url);
    if (strcmp(url, "/metrics") == 0) {
        gw_json_t j;
        gw_json_init(&j, resp, sizeof resp);
        if (!gw_http_report_metrics(t->env, &j))
            return send_error(c, 501, method, url, "not built into this gateway");
        if (j.full)
            return send_error(c, 500, method, url, "response too large");
        return send_buf(c, 200, "text/plain; version=0.0.4; charset=utf-8", j.buf, j.len, true);
    }
    return send_error(c, 404, method, url, "not found");
}

/* 401 with the realm (a login is asked). */
static enum MHD_Result send_401(struct MHD_Connection *c)
{
    static const char body[] = "401 login required\n";
    struct MHD_Response *r = ml->create_response_from_buffer(sizeof body - 1, unconst(body),
                                                             MHD_RESPMEM_PERSISTENT);
    if (r == NULL)
        return MHD_NO;
    (void)ml->add_response_header(r, "Content-Type", "text/plain; charset=utf-8");
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    enum MHD_Result ret = queue(c, 401, r, true);
    ml->destroy_response(r);
    return ret;
}

/* A login refused while its address waits out its back-off (auth.c) is
 * held to the end of the wait: that slows a password guesser down at no
 * cost to the loop. But a held login keeps its connection: four flooding
 * addresses could keep every slot (max_connections_per_ip each) for up to
 * 32 s (make bench-console). So at most HELD_PER_IP logins of one address
 * are held; the others get 429 at once, with the wait, and their
 * connection closes. (No bound in all: a connection answered at once is
 * opened again, and each new TLS handshake costs the loop more than a
 * held connection does.) */
#define HELD_PER_IP 2u

static bool may_hold(const ht_t *t, const hc_t *h)
{
    unsigned mine = 0;
    for (const hc_t *o = t->conns; o != NULL; o = o->next)
        mine += o != h && o->suspended && o->auth == AUTH_REFUSED && o->ip == h->ip;
    return mine < HELD_PER_IP;
}

static enum MHD_Result send_429(struct MHD_Connection *c, uint64_t wait_us)
{
    static const char body[] = "429 too many failed logins from this address: "
                               "try again after Retry-After seconds\n";
    char secs[24];
    (void)snprintf(secs, sizeof secs, "%lu", (unsigned long)((wait_us + 999999u) / 1000000u));
    struct MHD_Response *r = ml->create_response_from_buffer(sizeof body - 1, unconst(body),
                                                             MHD_RESPMEM_PERSISTENT);
    if (r == NULL)
        return MHD_NO;
    (void)ml->add_response_header(r, "Content-Type", "text/plain; charset=utf-8");
    (void)ml->add_response_header(r, "Cache-Control", "no-store");
    (void)ml->add_response_header(r, "Retry-After", secs);
    (void)ml->add_response_header(r, "Connection", "close");
    enum MHD_Result ret = queue(c, 429, r, false);
    ml->destroy_response(r);
    return ret;
}

static void hc_suspend(hc_t *h)
{
    if (!h->suspended) {
        ml->suspend_connection(h->c);
        h->suspended = true;
    }
}

static void hc_resume(ht_t *t, hc_t *h)
{
    if (h->suspended) {
        h->suspended = false;
        ml->resume_connection(h->c);
        for (unsigned i = 0; i < 2; i++)
            if (t->srv[i].d != NULL)
                (void)ml->run(t->srv[i].d);
    }
}

/* A check the worker finished (core/auth.h): the waiting request goes on, or
 * gets its 401 when its address's wait is over. */
static void on_auth_done(void *user, void *cookie, bool ok, uint64_t until)
{
    ht_t *t = user;
    hc_t *h = cookie;
    h->auth = ok ? AUTH_OK : AUTH_REFUSED;
    h->held_until = ok ? 0 : until;
    if (ok || until <= ev_now_us() || !may_hold(t, h))
        hc_resume(t, h); /* authorized() answers: 200, 401 or 429 */
}

static void on_auth_ready(void *obj, uint32_t events)
{
    ht_t *t = obj;
    (void)events;
    gw_auth_collect(t->auth, ev_now_us(), on_auth_done, t);
}


/* The Authorization value's login (core/auth.h): none at all is a
 * browser's first try, refused and not counted; one that is not Basic is
 * refused and counted. */
static gw_auth_result_t login(ht_t *t, hc_t *h, const char *authz, uint64_t now,
                              uint64_t *until)
{
    char user[GW_USER_MAX], pass[GW_AUTH_PASS_MAX], from[GW_AUTH_FROM_MAX];
    *until = now;
    if (authz == NULL)
        return GW_AUTH_REFUSED;
    snprintf(from, sizeof from, "%u.%u.%u.%u", (unsigned)(h->ip >> 24),
             (unsigned)(h->ip >> 16 & 255u), (unsigned)(h->ip >> 8 & 255u),
             (unsigned)(h->ip & 255u));
    bool basic = gw_http_basic_parse(authz, user, sizeof user, pass, sizeof pass);
    gw_auth_result_t r = gw_auth_check(t->auth, basic ? user : NULL, basic ? pass : NULL, from,
                                       h, now, until);
    memset(pass, 0, sizeof pass);
    return r;
}

/* Basic authentication, for clients not on loopback when auth_file is
 * set. The password is never checked here: a header checked before is a
 * lookup (auth.c's cache), a new one is handed to the worker thread and
 * the request waits, suspended, for its result; the loop goes on. True
 * when the request may go on; else *ret is what to return (an answer
 * queued, or MHD_YES with the connection suspended). */
static bool authorized(ht_t *t, hc_t *h, struct MHD_Connection *c, enum MHD_Result *ret)
{
    if (t->auth == NULL || h->loopback)
        return true;
    *ret = MHD_YES;
    switch (h->auth) {
    case AUTH_OK:
        return true;
    case AUTH_REFUSED:
        if (h->held_until > ev_now_us()) {
            if (!h->suspended && !may_hold(t, h)) {
                h->auth = AUTH_NONE;
                *ret = send_429(c, h->held_until - ev_now_us());
                return false;
            }
            hc_suspend(h); /* tick() resumes it when the wait is over */
            return false;
        }
        h->auth = AUTH_NONE;
        *ret = send_401(c);
        return false;
    case AUTH_PENDING:
        hc_suspend(h); /* resumed before its result: wait on */
        return false;
    case AUTH_BUSY:
    case AUTH_NONE:
        break;
    }
    const char *authz = ml->lookup_connection_value(c, MHD_HEADER_KIND, "Authorization");
    uint64_t until, now = ev_now_us();
    switch (login(t, h, authz, now, &until)) {
    case GW_AUTH_OK:
        h->auth = AUTH_OK;
        return true;
    case GW_AUTH_PENDING:
        h->auth = AUTH_PENDING;
        hc_suspend(h);
        return false;
    case GW_AUTH_BUSY: {
        static const char busy[] = "{\"error\":\"logins are being checked: try again\"}\n";
        h->auth = AUTH_NONE;
        struct MHD_Response *r = ml->create_response_from_buffer(
            sizeof busy - 1, unconst(busy), MHD_RESPMEM_PERSISTENT);
        *ret = MHD_NO;
        if (r != NULL) {
            (void)ml->add_response_header(r, "Content-Type", "application/json");
            (void)ml->add_response_header(r, "Retry-After", "1");
            *ret = queue(c, 503, r, false);
            ml->destroy_response(r);
        }
        return false;
    }
    case GW_AUTH_REFUSED:
        break;
    }
    h->auth = AUTH_REFUSED;
    h->held_until = until;
    if (until > now) {
        if (!may_hold(t, h)) {
            h->auth = AUTH_NONE;
            *ret = send_429(c, until - now);
            return false;
        }
        hc_suspend(h);
        return false;
    }
    h->auth = AUTH_NONE;
    *ret = send_401(c);
    return false;
}

/* Does the request carry a body (which no route takes)? */
static bool has_body(struct MHD_Connection *c)
{
    const char *len = ml->lookup_connection_value(c, MHD_HEADER_KIND, "Content-Length");
    return ml->lookup_connection_value(c, MHD_HEADER_KIND, "Transfer-Encoding") != NULL ||
           (len != NULL && strspn(len, "0") != strlen(len));
}

/* The request's head as sent, near enough: the URL, its arguments and
 * its headers, each with its separators. */
static enum MHD_Result add_size(void *cls, enum MHD_ValueKind kind, const char *key,
                                const char *value)
{
    size_t *n = cls;
    (void)kind;
    *n += strlen(key) + (value != NULL ? strlen(value) : 0) + 4u;
    return MHD_YES;
}

/* 0, or 414 (the URL is most of it) or 431 for a head over
 * max_request_bytes. */
static unsigned head_too_large(const ht_t *t, struct MHD_Connection *c, const char *url)
{
    size_t args = 0, headers = 0;
    (void)ml->get_connection_values(c, MHD_GET_ARGUMENT_KIND, add_size, &args);
    (void)ml->get_connection_values(c, MHD_HEADER_KIND, add_size, &headers);
    size_t line = strlen(url) + args, total = line + headers;
    if (total <= t->cfg.max_request_bytes)
        return 0;
    return line >= headers ? 414u : 431u;
}

static enum MHD_Result on_request(void *cls, struct MHD_Connection *c, const char *url,
                                  const char *method, const char *version,
                                  const char *upload_data, size_t *upload_data_size,
                                  void **req_cls)
{
    srv_t *sv = cls;
    ht_t *t = sv->t;
    (void)version, (void)upload_data;
    const union MHD_ConnectionInfo *ci =
        ml->get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    hc_t *h = ci != NULL ? ci->socket_context : NULL;
    bool get = strcmp(method, "GET") == 0 || strcmp(method, "HEAD") == 0;
    cur_sv = sv;
    cur_hc = h;
    *upload_data_size = 0;
    if (h == NULL)
        return send_error(c, 503, method, url, "out of memory");
    if (*req_cls == NULL) {
        /* The first call, the head in. A GET without a body is answered at
         * the next call (MHD's last for the request): an answer queued now
         * would make MHD close the connection, and every page poll would
         * log in again. Others are answered now, and closed. */
        *req_cls = sv;
        h->answering = true;
        unsigned big = head_too_large(t, c, url);
        if (big != 0)
            return send_error(c, big, method, url,
                              big == 414 ? "URI too long (max_request_bytes)"
                                         : "request headers too large (max_request_bytes)");
        if (get && !has_body(c))
            return MHD_YES;
    }
    enum MHD_Result ret = MHD_YES;
    if (h->loopback || sv->loopback_only) {
        /* served without a login: a browser here is only taken with a
         * name of this machine (DNS rebinding) */
        const char *host = ml->lookup_connection_value(c, MHD_HEADER_KIND, "Host");
        if (!gw_http_host_ok(host, sv->port, sv->loopback_only ? "127.0.0.1" : t->cfg.listen)) {
            t->hosts_refused++;
            return send_error(c, 421, method, url,
                              "Host not served (allowed: localhost, 127.0.0.1, [::1] or the "
                              "listen address, with this port)");
        }
    }
    if (!authorized(t, h, c, &ret))
        return ret;
    if (!get)
        return send_error(c, 405, method, url, "method not allowed (allowed: GET, HEAD)");
    return route(t, c, method, url);
}

static enum MHD_Result on_accept(void *cls, const struct sockaddr *addr, socklen_t len)
{
    const srv_t *sv = cls;
    (void)len;
    if (sv->loopback_only)
        return addr_loopback(addr) ? MHD_YES : MHD_NO;
    /* MHD's limit is max_connections + RESERVED_LOCAL: the last few are
     * for loopback clients only */
    if (sv->conns >= sv->t->cfg.max_connections && !addr_loopback(addr))
        return MHD_NO;
    return allowed(&sv->t->cfg, addr) ? MHD_YES : MHD_NO;
}

static void on_conn(void *cls, struct MHD_Connection *c, void **ctx,
                    enum MHD_ConnectionNotificationCode what)
{
    srv_t *sv = cls;
    ht_t *t = sv->t;
    hc_t *h = *ctx;
    if (what == MHD_CONNECTION_NOTIFY_STARTED) {
        const union MHD_ConnectionInfo *ci =
            ml->get_connection_info(c, MHD_CONNECTION_INFO_CONNECTION_FD);
        sv->conns++;
        if (ci == NULL || (h = calloc(1, sizeof *h)) == NULL)
            return; /* not tracked: MHD's idle timeout still applies; 503 */
        h->c = c;
        h->fd = ci->connect_fd;
        const union MHD_ConnectionInfo *ai =
            ml->get_connection_info(c, MHD_CONNECTION_INFO_CLIENT_ADDRESS);
        h->loopback = ai != NULL && addr_loopback(ai->client_addr);
        if (ai != NULL && ai->client_addr != NULL && ai->client_addr->sa_family == AF_INET) {
            struct sockaddr_in in;
            memcpy(&in, ai->client_addr, sizeof in);
            h->ip = ntohl(in.sin_addr.s_addr);
        }
        h->deadline_us = ev_now_us() + (uint64_t)t->cfg.timeout_s * 1000000u;
        h->next = t->conns;
        t->conns = h;
        *ctx = h;
    } else if (what == MHD_CONNECTION_NOTIFY_CLOSED) {
        sv->conns -= sv->conns > 0;
        if (h == NULL)
            return;
        if (t->auth != NULL)
            gw_auth_cancel(t->auth, h);
        if (cur_hc == h)
            cur_hc = NULL;
        for (hc_t **p = &t->conns; *p != NULL; p = &(*p)->next)
            if (*p == h) {
                *p = h->next;
                break;
            }
        free(h);
        *ctx = NULL;
    }
}

/* An answer is sent: the next request's head has timeout_s from now. */
static void on_completed(void *cls, struct MHD_Connection *c, void **req_cls,
                         enum MHD_RequestTerminationCode why)
{
    srv_t *sv = cls;
    (void)req_cls, (void)why;
    const union MHD_ConnectionInfo *ci =
        ml->get_connection_info(c, MHD_CONNECTION_INFO_SOCKET_CONTEXT);
    hc_t *h = ci != NULL ? ci->socket_context : NULL;
    if (h != NULL) {
        h->answering = false;
        h->auth = AUTH_NONE; /* each request logs in (a cache lookup) */
        h->held_until = 0;
        h->deadline_us = ev_now_us() + (uint64_t)sv->t->cfg.timeout_s * 1000000u;
    }
}

/* Connections whose request is late: shut down (once). */
static void cut_slow(ht_t *t, uint64_t now)
{
    for (hc_t *h = t->conns; h != NULL; h = h->next)
        if (!h->answering && !h->suspended && now >= h->deadline_us) {
            (void)shutdown(h->fd, SHUT_RDWR);
            h->deadline_us = UINT64_MAX;
            gw_log_limited(GW_LOG_INFO, &t->slow_limit,
                           "http: a client did not send its request within %u s: closed",
                           t->cfg.timeout_s);
        }
}

static char *mhd_err; /* where MHD's messages go while a server starts */
static size_t mhd_errlen;

static void on_mhd_log(void *cls, const char *fmt, va_list ap)
{
    ht_t *t = cls;
    char msg[256];
    vsnprintf(msg, sizeof msg, fmt, ap);
    msg[strcspn(msg, "\r\n")] = '\0';
    if (mhd_err != NULL) {
        snprintf(mhd_err, mhd_errlen, "%s", msg);
        return;
    }
    /* A page closed while its answer was being sent (a tab closed on a
     * live stream): nothing wrong, debug only. Clients' misdeeds (a TLS
     * handshake that is not one, a connection over the limit): at most
     * one line every 10 s. */
    if (strstr(msg, "Failed to send") != NULL || strstr(msg, "no longer available") != NULL)
        gw_log(GW_LOG_DEBUG, "http: %s", msg);
    else
        gw_log_limited(GW_LOG_INFO, &t->mhd_limit, "http: %s", msg);
}

/* ---- servers ------------------------------------------------------------------------ */

static void on_ready(void *obj, uint32_t events)
{
    srv_t *sv = obj;
    (void)events;
    (void)ml->run(sv->d);
}

/* A listening TCP socket on addr:port; -1 with err. */
static int open_listener(const char *addr, uint16_t port, char *err, size_t errlen)
{
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = htons(port);
    if (inet_pton(AF_INET, addr, &sin.sin_addr) != 1) {
        snprintf(err, errlen, "http: listen %s: not an IPv4 address", addr);
        return -1;
    }
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    int one = 1;
    if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) != 0 ||
        bind(fd, (const struct sockaddr *)&sin, sizeof sin) != 0 || listen(fd, 64) != 0) {
        snprintf(err, errlen, "http: cannot listen on %s:%u: %s", addr, (unsigned)port,
                 strerror(errno));
        if (fd >= 0)
            (void)close(fd);
        return -1;
    }
    return fd;
}

/* MHD on sv->lfd (taken over: MHD closes it); false with err. */
static bool srv_start(srv_t *sv, ht_t *t, char *err, size_t errlen)
{
    const gw_http_config_t *h = &t->cfg;
    unsigned flags = MHD_USE_EPOLL | MHD_ALLOW_SUSPEND_RESUME | MHD_USE_ERROR_LOG;
    char why[256] = "";
    struct MHD_OptionItem opts[] = {
        {MHD_OPTION_LISTEN_SOCKET, sv->lfd, NULL},
        {MHD_OPTION_CONNECTION_LIMIT, (intptr_t)h->max_connections, NULL},
        {MHD_OPTION_CONNECTION_TIMEOUT, (intptr_t)h->timeout_s, NULL},
        {MHD_OPTION_CONNECTION_MEMORY_LIMIT, (intptr_t)(h->max_request_bytes + ANSWER_ROOM), NULL},
        {MHD_OPTION_PER_IP_CONNECTION_LIMIT, (intptr_t)h->max_connections_per_ip, NULL},
        {MHD_OPTION_END, 0, NULL}, /* TLS: three more, below */
        {MHD_OPTION_END, 0, NULL},
        {MHD_OPTION_END, 0, NULL},
        {MHD_OPTION_END, 0, NULL},
    };
    /* room kept for loopback clients (on_accept) */
    opts[1].value = (intptr_t)h->max_connections + (intptr_t)(sv->loopback_only ? 0u : RESERVED_LOCAL);
    if (sv->tls) {
        flags |= MHD_USE_TLS;
        opts[5] = (struct MHD_OptionItem){MHD_OPTION_HTTPS_MEM_CERT, 0, t->cert};
        opts[6] = (struct MHD_OptionItem){MHD_OPTION_HTTPS_MEM_KEY, 0, t->key};
        opts[7] = (struct MHD_OptionItem){MHD_OPTION_HTTPS_PRIORITIES, 0,
                                          unconst(h->tls_priorities[0] ? h->tls_priorities
                                                                       : TLS_PRIORITIES)};
    }
    mhd_err = why;
    mhd_errlen = sizeof why;
    sv->d = ml->start_daemon(flags, 0, on_accept, sv, on_request, sv,
                             MHD_OPTION_EXTERNAL_LOGGER, on_mhd_log, t,
                             MHD_OPTION_NOTIFY_CONNECTION, on_conn, sv,
                             MHD_OPTION_NOTIFY_COMPLETED, on_completed, sv,
                             MHD_OPTION_ARRAY, opts, MHD_OPTION_END);
    mhd_err = NULL;
    if (sv->d == NULL) {
        (void)close(sv->lfd);
        sv->lfd = -1;
        snprintf(err, errlen, "http: cannot start the server on %s:%u: %s",
                 sv->loopback_only ? "127.0.0.1" : h->listen,
                 (unsigned)(sv->loopback_only ? h->status_port : h->port),
                 why[0] ? why : "libmicrohttpd refused its settings");
        return false;
    }
    return true;
}

/* MHD's epoll descriptor into the loop (commit). */
static bool srv_watch(srv_t *sv, int epfd)
{
    if (sv->d == NULL)
        return true;
    const union MHD_DaemonInfo *di = ml->get_daemon_info(sv->d, MHD_DAEMON_INFO_EPOLL_FD);
    if (di == NULL || !ev_watch(epfd, &sv->ev, di->epoll_fd, EPOLLIN)) {
        gw_log(GW_LOG_ERROR, "http: epoll: %s", strerror(errno));
        return false;
    }
    return true;
}

static void srv_stop(srv_t *sv, int epfd)
{
    if (sv->d == NULL) {
        if (sv->lfd >= 0)
            (void)close(sv->lfd);
        sv->lfd = -1;
        return;
    }
    ev_unwatch(epfd, &sv->ev);
    ml->stop_daemon(sv->d); /* closes lfd and every connection */
    sv->d = NULL;
    sv->lfd = -1;
}

/* ---- the side ------------------------------------------------------------------------ */

static void ht_free(ht_t *t)
{
    if (t == NULL)
        return;
    if (t->streams != NULL && ml != NULL) {
        /* MHD must not be stopped with suspended connections: each ends
         * its stream at its next turn, which MHD_run gives it. */
        sse_resume(t, UINT64_MAX, true);
    }
    for (hc_t *h = t->conns; h != NULL && ml != NULL; h = h->next)
        if (h->suspended) { /* a login waiting: refused now, then closed */
            h->auth = AUTH_REFUSED;
            h->held_until = 0;
            h->suspended = false;
            ml->resume_connection(h->c);
        }
    for (unsigned i = 0; i < 2 && ml != NULL; i++)
        if (t->srv[i].d != NULL)
            (void)ml->run(t->srv[i].d);
    if (t->auth_ev.fd >= 0)
        ev_unwatch(t->env->epfd, &t->auth_ev);
    for (unsigned i = 0; i < 2; i++)
        srv_stop(&t->srv[i], t->env->epfd);
    gw_auth_free(t->auth);
    gw_log_limit_end(&t->stream_limit);
    free(t->cert);
    free(t->key);
    free(t);
}

/* The listening socket of a server of `running` on the same address and
 * port, duplicated (a reload keeps the port open), else a new one. */
static int listener(const ht_t *running, const char *addr, uint16_t port, char *err,
                    size_t errlen)
{
    for (unsigned i = 0; running != NULL && running->cfg.enabled && i < 2; i++) {
        const srv_t *sv = &running->srv[i];
        const char *a = i == 0 ? running->cfg.listen : "127.0.0.1";
        uint16_t p = i == 0 ? running->cfg.port : running->cfg.status_port;
        if (sv->d != NULL && strcmp(a, addr) == 0 && p == port) {
            const union MHD_DaemonInfo *di = ml->get_daemon_info(sv->d, MHD_DAEMON_INFO_LISTEN_FD);
            int fd = di != NULL ? fcntl(di->listen_fd, F_DUPFD_CLOEXEC, 0) : -1;
            if (fd < 0)
                snprintf(err, errlen, "http: cannot keep the listening socket: %s",
                         strerror(errno));
            return fd;
        }
    }
    return open_listener(addr, port, err, errlen);
}

/* From [http]: files read, sockets listening, servers started but not yet
 * in the loop (commit, or create, puts them there). */
static ht_t *ht_new(const gw_http_config_t *h, const gw_north_env_t *env, const ht_t *running,
                    char *err, size_t errlen)
{
    ht_t *t = calloc(1, sizeof *t);
    if (t == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    t->env = env;
    t->cfg = *h;
    for (unsigned i = 0; i < 2; i++) {
        t->srv[i] = (srv_t){t, NULL, {on_ready, &t->srv[i], -1, 0}, -1, false, i == 1,
                            i == 0 ? h->port : h->status_port, 0};
    }
    t->auth_ev = (ev_t){on_auth_ready, t, -1, 0};
    t->stream_limit.window_ms = 10000;
    if (!h->enabled)
        return t;
    if ((ml = gw_mhdlib_load(err, errlen)) == NULL) {
        free(t);
        return NULL;
    }
    bool tls = h->tls_cert[0] != '\0';
    if (h->auth_file[0] != '\0' && !gw_passwd_load(h->auth_file, &t->users, err, errlen)) {
        char why[400];
        snprintf(why, sizeof why, "%s", err);
        snprintf(err, errlen, "http: auth_file %s", why);
        ht_free(t);
        return NULL;
    }
    if (t->users.count > 0 &&
        (t->auth = gw_auth_new(&t->users, ml->crypt_r, "http", "address", err, errlen)) == NULL) {
        ht_free(t);
        return NULL;
    }
    if (tls && ((t->cert = read_file(h->tls_cert, "tls_cert", err, errlen)) == NULL ||
                (t->key = read_file(h->tls_key, "tls_key", err, errlen)) == NULL)) {
        ht_free(t);
        return NULL;
    }
    t->srv[0].tls = tls;
    t->srv[0].lfd = listener(running, h->listen, h->port, err, errlen);
    if (t->srv[0].lfd < 0 || !srv_start(&t->srv[0], t, err, errlen)) {
        ht_free(t);
        return NULL;
    }
    if (tls && h->status_port != 0) {
        t->srv[1].lfd = listener(running, "127.0.0.1", h->status_port, err, errlen);
        if (t->srv[1].lfd < 0 || !srv_start(&t->srv[1], t, err, errlen)) {
            ht_free(t);
            return NULL;
        }
    }
    return t;
}

static bool ht_watch(ht_t *t)
{
    if (t->auth != NULL &&
        !ev_watch(t->env->epfd, &t->auth_ev, gw_auth_fd(t->auth), EPOLLIN))
        return false;
    return srv_watch(&t->srv[0], t->env->epfd) && srv_watch(&t->srv[1], t->env->epfd);
}

static void ht_started(const ht_t *t)
{
    const gw_http_config_t *h = &t->cfg;
    if (!h->enabled)
        return;
    gw_log(GW_LOG_INFO, "http: console on %s://%s:%u/%s%s", t->srv[0].tls ? "https" : "http",
           h->listen, (unsigned)h->port, t->users.count > 0 ? " (login for non-loopback clients)" : "",
           h->insecure ? " (insecure = yes)" : "");
}

static void *ht_create(const gw_north_env_t *env, char *err, size_t errlen)
{
    if (start_us == 0)
        start_us = ev_now_us();
    ht_t *t = ht_new(&env->cfg->side.http, env, NULL, err, errlen);
    if (t != NULL && !ht_watch(t)) {
        snprintf(err, errlen, "http: epoll: %s", strerror(errno));
        ht_free(t);
        return NULL;
    }
    if (t != NULL)
        ht_started(t);
    return t;
}

/* Everything but where the keys are in the file. */
static bool same_config(const gw_http_config_t *a, const gw_http_config_t *b)
{
    if (a->enabled != b->enabled || strcmp(a->listen, b->listen) != 0 || a->port != b->port ||
        a->allow_count != b->allow_count || strcmp(a->tls_cert, b->tls_cert) != 0 ||
        strcmp(a->tls_key, b->tls_key) != 0 || strcmp(a->auth_file, b->auth_file) != 0 ||
        a->insecure != b->insecure || a->status_port != b->status_port ||
        a->max_connections != b->max_connections ||
        a->max_connections_per_ip != b->max_connections_per_ip || a->timeout_s != b->timeout_s ||
        a->max_request_bytes != b->max_request_bytes ||
        strcmp(a->tls_priorities, b->tls_priorities) != 0 || a->max_streams != b->max_streams ||
        a->max_streams_per_ip != b->max_streams_per_ip || a->stream_max_s != b->stream_max_s)
        return false;
    for (unsigned i = 0; i < a->allow_count; i++)
        if (a->allow[i].net != b->allow[i].net || a->allow[i].mask != b->allow[i].mask ||
            a->allow[i].read_write != b->allow[i].read_write)
            return false;
    return true;
}

/* An unchanged [http] keeps its servers and connections. A changed one
 * is made whole (files read, port bound, server started) while this one
 * runs; a password or certificate file that changed on disk is read at a
 * reload only when the section changed too. */
static gw_north_reload_t ht_prepare(void *self, const gw_config_t *next, const gw_north_env_t *env,
                                    void **out, char *err, size_t errlen)
{
    ht_t *t = self;
    if (same_config(&t->cfg, &next->side.http)) {
        *out = self;
        return GW_NORTH_OK;
    }
    *out = ht_new(&next->side.http, env, t, err, errlen);
    return *out != NULL ? GW_NORTH_OK : GW_NORTH_REFUSED;
}

/* cppcheck-suppress constParameter ; the signature is gw_north_ops_t's */
static void ht_abort(void *self, void *out)
{
    if (out != self)
        ht_free(out);
}

static void *ht_commit(void *self, void *out, const gw_north_env_t *env)
{
    ht_t *t = self, *n = out;
    (void)env;
    n->generation = t->generation + 1u;
    if (n == t)
        return n;
    ht_free(t);
    if (!ht_watch(n)) {
        ht_free(n);
        return NULL;
    }
    ht_started(n);
    return n;
}

static void ht_tick(void *self, uint64_t now)
{
    ht_t *t = self;
    if (!t->cfg.enabled)
        return;
    sse_limits(t, now);
    sse_resume(t, now, false);
    cut_slow(t, now);
    /* Each login whose wait is over gets its 401. hc_resume runs MHD,
     * which may close, and so free, any connection of the list (a client
     * that went away while its login was held): the walk starts again
     * from the head after each one (it is no longer suspended). */
    for (hc_t *h = t->conns; h != NULL;)
        if (h->suspended && h->auth == AUTH_REFUSED && h->held_until <= now) {
            hc_resume(t, h);
            h = t->conns;
        } else {
            h = h->next;
        }
    for (unsigned i = 0; i < 2; i++) {
        MHD_UNSIGNED_LONG_LONG ms;
        if (t->srv[i].d != NULL && ml->get_timeout(t->srv[i].d, &ms) == MHD_YES && ms == 0)
            (void)ml->run(t->srv[i].d);
    }
}

static uint64_t ht_deadline(const void *self)
{
    const ht_t *t = self;
    if (!t->cfg.enabled)
        return UINT64_MAX;
    uint64_t d = UINT64_MAX, now = ev_now_us();
    for (const sse_t *s = t->streams; s != NULL; s = s->next)
        if (s->suspended && s->next_us < d)
            d = s->next_us;
    for (const hc_t *h = t->conns; h != NULL; h = h->next) {
        if (!h->answering && h->deadline_us < d)
            d = h->deadline_us;
        if (h->suspended && h->auth == AUTH_REFUSED && h->held_until < d)
            d = h->held_until;
    }
    if (t->streams != NULL && now + 1000000u < d)
        d = now + 1000000u; /* sse_limits, once a second */
    for (unsigned i = 0; i < 2; i++) {
        MHD_UNSIGNED_LONG_LONG ms;
        if (t->srv[i].d != NULL && ml->get_timeout(t->srv[i].d, &ms) == MHD_YES &&
            now + ms * 1000u < d)
            d = now + ms * 1000u;
    }
    return d;
}

static void ht_on_data(void *self, unsigned robot, dr_asm_t a)
{
    (void)self, (void)robot, (void)a; /* the streams look at the images at their pace */
}

static void ht_on_link(void *self, unsigned robot, bool up)
{
    (void)self, (void)robot, (void)up;
}

static void ht_on_fault(void *self, unsigned robot, bool latched)
{
    (void)self, (void)robot, (void)latched;
}

/* Ten times a second, a turn for MHD whatever its descriptors say: at
 * max_connections it takes its listening socket out of its epoll set and
 * puts it back only within MHD_run, which nothing would call once the
 * last connection is gone (no event, no timeout). One epoll_wait(0). */
static void ht_refresh(void *self)
{
    ht_t *t = self;
    for (unsigned i = 0; t->cfg.enabled && i < 2; i++)
        if (t->srv[i].d != NULL)
            (void)ml->run(t->srv[i].d);
}

static void ht_safe(void *self)
{
    (void)self; /* no outputs */
}

static void ht_side_free(void *self)
{
    ht_free(self);
}

/* The console's own families (docs/http.md "Metrics"). */
static void ht_metrics(const void *self, gw_prom_t *m)
{
    const ht_t *t = self;
    if (!t->cfg.enabled)
        return;
    gw_prom_family(m, "drgate_http_requests_total", GW_PROM_COUNTER,
                   "HTTP requests answered, by status code");
    for (unsigned code = 100; code < HTTP_CODES; code++)
        if (t->answers[code] > 0) {
            char v[8];
            snprintf(v, sizeof v, "%u", code);
            gw_prom_label_t l = {"code", v};
            gw_prom_sample(m, "drgate_http_requests_total", &l, 1, (double)t->answers[code]);
        }
    unsigned conns = t->srv[0].conns + t->srv[1].conns;
    gw_prom_one(m, "drgate_http_connections", GW_PROM_GAUGE, "HTTP connections open",
                (double)conns);
    gw_prom_one(m, "drgate_http_streams", GW_PROM_GAUGE, "live-value streams open",
                (double)t->nstreams);
    gw_prom_one(m, "drgate_http_streams_refused_total", GW_PROM_COUNTER,
                "live-value streams refused (max_streams, max_streams_per_ip)",
                (double)t->streams_refused);
    gw_prom_one(m, "drgate_http_streams_cut_total", GW_PROM_COUNTER,
                "live-value streams closed because their client took nothing",
                (double)t->streams_cut);
    gw_prom_one(m, "drgate_http_host_refused_total", GW_PROM_COUNTER,
                "requests without a login refused for their Host header (421)",
                (double)t->hosts_refused);
    gw_auth_stats_t a = {0, 0, 0, 0};
    if (t->auth != NULL)
        a = gw_auth_stats(t->auth);
    gw_prom_one(m, "drgate_http_logins_total", GW_PROM_COUNTER, "logins accepted (checked once)",
                (double)a.ok);
    gw_prom_one(m, "drgate_http_logins_failed_total", GW_PROM_COUNTER,
                "logins refused (wrong user or password, or an address waiting)",
                (double)a.refused);
    gw_prom_one(m, "drgate_http_login_checks_total", GW_PROM_COUNTER,
                "passwords checked by the login worker (crypt_r)", (double)a.checks);
    gw_prom_one(m, "drgate_http_logins_busy_total", GW_PROM_COUNTER,
                "logins answered 503: the worker's queue was full", (double)a.busy);
}


/* ---- --check-config -------------------------------------------------------------------- */

bool gw_http_check_tls(const gw_config_t *cfg, char *err, size_t errlen)
{
    const gw_http_config_t *h = &cfg->side.http;
    if (!h->enabled || h->tls_cert[0] == '\0')
        return true;
    char why[256] = "";
    if ((ml = gw_mhdlib_load(why, sizeof why)) == NULL) {
        snprintf(err, errlen, "%s:%u: %s", cfg->path, h->line, why);
        return false;
    }
    static ht_t t;
    memset(&t, 0, sizeof t);
    t.cfg = *h;
    t.cert = read_file(h->tls_cert, "tls_cert", why, sizeof why);
    t.key = t.cert != NULL ? read_file(h->tls_key, "tls_key", why, sizeof why) : NULL;
    struct MHD_Daemon *d = NULL;
    if (t.key != NULL) {
        why[0] = '\0';
        mhd_err = why;
        mhd_errlen = sizeof why;
        d = ml->start_daemon(MHD_USE_EPOLL | MHD_USE_TLS | MHD_USE_NO_LISTEN_SOCKET |
                                 MHD_USE_ERROR_LOG,
                             0, NULL, NULL, on_request, NULL, MHD_OPTION_EXTERNAL_LOGGER,
                             on_mhd_log, &t, MHD_OPTION_HTTPS_MEM_CERT, t.cert,
                             MHD_OPTION_HTTPS_MEM_KEY, t.key, MHD_OPTION_HTTPS_PRIORITIES,
                             h->tls_priorities[0] ? h->tls_priorities : TLS_PRIORITIES,
                             MHD_OPTION_END);
        mhd_err = NULL;
    }
    free(t.cert);
    free(t.key);
    if (d == NULL) {
        if (h->tls_priorities[0] != '\0' && t.key != NULL && strstr(why, "riorit") != NULL)
            snprintf(err, errlen,
                     "%s:%u: [http] tls_priorities %s: not a GnuTLS priority string: %s",
                     cfg->path, h->line, h->tls_priorities, why);
        else
            snprintf(err, errlen, "%s:%u: [http] tls_cert %s and tls_key %s do not load: %s",
                     cfg->path, h->tls_line, h->tls_cert, h->tls_key,
                     why[0] ? why : "not a certificate and its key");
        return false;
    }
    ml->stop_daemon(d);
    return true;
}

const gw_north_ops_t gw_north_http = {
    .name = "http",
    .create = ht_create,
    .prepare = ht_prepare,
    .abort = ht_abort,
    .commit = ht_commit,
    .tick = ht_tick,
    .deadline = ht_deadline,
    .on_data = ht_on_data,
    .on_link = ht_on_link,
    .on_fault = ht_on_fault,
    .refresh = ht_refresh,
    .safe = ht_safe,
    .free = ht_side_free,
    .metrics = ht_metrics,
    .check_config = gw_http_check_tls,
    .status_command = gw_http_status_command,
};
