/* SPDX-License-Identifier: MIT */
/* Modbus TCP server: see mbserver.h. */
#define _GNU_SOURCE /* accept4, TCP_KEEPIDLE */
#include <arpa/inet.h>
#include <errno.h>
#include <stddef.h>
#include <stdio.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <unistd.h>

#include "common/ev.h"
#include "core/log.h"
#include "modbus/mbproto.h"
#include "modbus/mbserver.h"
#include "modbus/regmap.h"
#include "modbus/reqlog.h"

#define MAX_CLIENTS_HARD 256u

typedef struct {
    ev_t ev;
    gw_mbs_t *srv;
    bool used;
    int fd;
    uint32_t addr;
    uint16_t port;
    bool rw;
    bool unit_logged; /* a refused unit ID of this client was logged */
    uint32_t requests, exceptions; /* answered, and with an exception */
    gw_log_limit_t write_log;      /* its accepted writes (rate-limited) */
    uint64_t last_us; /* accepted, or its last complete request */
    uint64_t req_us;  /* first byte of the request in buf; 0: none pending */
    uint8_t buf[GW_ADU_MAX];
    size_t len;
    /* Its last requests (reqlog.h). Kept when it goes, for the console,
     * until the slot is taken again: by the same address first (a PLC
     * that connects anew keeps its past), by another one last. */
    gw_reqlog_t log;
} client_t;

struct gw_mbs {
    gw_modbus_config_t cfg;
    gw_mbs_hooks_t hooks;
    int epfd;
    ev_t listen_ev;
    int listen_fd;
    gw_mb_result_t result;  /* of the request being answered */
    client_t clients[MAX_CLIENTS_HARD];
    unsigned nclients;
    client_t *writer;       /* single-writer mode: the owner */
    unsigned writer_claims; /* clients that became the owner so far */
    uint32_t exceptions;
    uint32_t requests;
    gw_log_limit_t refused_log;
};

static uint16_t be16(const uint8_t *p)
{
    return (uint16_t)(p[0] << 8 | p[1]);
}

static void fmt_addr(uint32_t a, uint16_t port, char *out, size_t n)
{
    snprintf(out, n, "%u.%u.%u.%u:%u", a >> 24, (a >> 16) & 0xFF, (a >> 8) & 0xFF,
             a & 0xFF, port);
}

/* ---- clients ---------------------------------------------------------------- */

static void client_close(client_t *cl, const char *why)
{
    gw_mbs_t *s = cl->srv;
    char who[32];
    fmt_addr(cl->addr, cl->port, who, sizeof who);
    gw_log(GW_LOG_INFO, "modbus: client %s closed: %s", who, why);
    ev_unwatch(s->epfd, &cl->ev);
    close(cl->fd);
    if (s->writer == cl)
        s->writer = NULL; /* its watchdog will expire and latch the fault */
    cl->used = false;
    s->nclients--;
}

/* First matching allowlist entry; none configured: everyone read-write. */
static bool allowed(const gw_mbs_t *s, uint32_t addr, bool *rw)
{
    if (s->cfg.allow_count == 0) {
        *rw = true;
        return true;
    }
    for (unsigned i = 0; i < s->cfg.allow_count; i++) {
        const gw_allow_t *a = &s->cfg.allow[i];
        if ((addr & a->mask) == (a->net & a->mask)) {
            *rw = a->read_write;
            return true;
        }
    }
    return false;
}

static void set_keepalive(int fd)
{
    int one = 1, idle = 10, intvl = 5, cnt = 3;
    (void)setsockopt(fd, SOL_SOCKET, SO_KEEPALIVE, &one, sizeof one);
    (void)setsockopt(fd, IPPROTO_TCP, TCP_KEEPIDLE, &idle, sizeof idle);
    (void)setsockopt(fd, IPPROTO_TCP, TCP_KEEPINTVL, &intvl, sizeof intvl);
    (void)setsockopt(fd, IPPROTO_TCP, TCP_KEEPCNT, &cnt, sizeof cnt);
}

static void on_client(void *obj, uint32_t events);

/* All max_clients slots taken: the client that has gone longest without a
 * complete request makes room, if that is at least request_timeout_ms (a
 * client that polls, however slowly, is never pushed out by one that
 * merely connects) and it is not the single writer. NULL: none qualifies,
 * the newcomer is refused. */
static client_t *evict_idle(gw_mbs_t *s, const char *newcomer)
{
    uint64_t now = ev_now_us(), min_idle = (uint64_t)s->cfg.request_timeout_ms * 1000u;
    client_t *victim = NULL;
    if (s->nclients != s->cfg.max_clients)
        return NULL; /* over the limit after a reload: one slot would not do */
    for (unsigned i = 0; i < MAX_CLIENTS_HARD; i++) {
        client_t *cl = &s->clients[i];
        if (cl->used && cl != s->writer && now - cl->last_us >= min_idle &&
            (victim == NULL || cl->last_us < victim->last_us))
            victim = cl;
    }
    if (victim != NULL) {
        char why[160];
        snprintf(why, sizeof why, "evicted for %s (no request for %llu ms, all %u slots taken)",
                 newcomer, (unsigned long long)((now - victim->last_us) / 1000u),
                 s->cfg.max_clients);
        client_close(victim, why);
    }
    return victim;
}

/* A slot for a new client from addr: the last one that served addr (its
 * request log goes on: a PLC that connects anew keeps its past), else
 * one that never logged, else the one whose last request is the oldest.
 * NULL: none free. */
static client_t *free_slot(gw_mbs_t *s, uint32_t addr)
{
    client_t *same = NULL, *other = NULL;
    for (unsigned i = 0; i < MAX_CLIENTS_HARD; i++) {
        client_t *c = &s->clients[i];
        if (c->used)
            continue;
        if (c->log.total > 0 && c->addr == addr) {
            if (same == NULL || c->last_us > same->last_us)
                same = c;
        } else if (other == NULL || (other->log.total > 0 && (c->log.total == 0 ||
                                                              c->last_us < other->last_us))) {
            other = c;
        }
    }
    return same != NULL ? same : other;
}

static void on_accept(void *obj, uint32_t events)
{
    gw_mbs_t *s = obj;
    (void)events;
    for (;;) {
        struct sockaddr_in sin;
        socklen_t sl = sizeof sin;
        /* zeroed: clang's analyzer does not see accept4 fill a sockaddr
         * passed through glibc's transparent union (_GNU_SOURCE) */
        memset(&sin, 0, sizeof sin);
        int fd = accept4(s->listen_fd, (struct sockaddr *)&sin, &sl, SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0)
            return; /* EAGAIN: all taken; other errors: try at the next event */
        uint32_t addr = ntohl(sin.sin_addr.s_addr);
        uint16_t port = ntohs(sin.sin_port);
        char who[32];
        fmt_addr(addr, port, who, sizeof who);
        bool rw = false;
        if (!allowed(s, addr, &rw)) {
            gw_log(GW_LOG_WARNING, "modbus: refused %s: not in the allowlist", who);
            close(fd);
            continue;
        }
        client_t *cl = s->nclients < s->cfg.max_clients ? free_slot(s, addr) : NULL;
        if (cl == NULL)
            cl = evict_idle(s, who);
        if (cl == NULL) {
            gw_log_limited(GW_LOG_WARNING, &s->refused_log,
                           "modbus: refused %s: %u clients already (max_clients)", who,
                           s->nclients);
            close(fd);
            continue;
        }
        if (cl->addr != addr)
            memset(&cl->log, 0, sizeof cl->log);
        memset(cl, 0, offsetof(client_t, log)); /* the log is the last member */
        cl->used = true;
        cl->srv = s;
        cl->fd = fd;
        cl->addr = addr;
        cl->port = port;
        cl->rw = rw;
        cl->last_us = ev_now_us();
        cl->ev.fn = on_client;
        cl->ev.obj = cl;
        cl->ev.fd = -1;
        if (s->cfg.keepalive)
            set_keepalive(fd);
        int one = 1;
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        if (!ev_watch(s->epfd, &cl->ev, fd, EPOLLIN)) {
            close(fd);
            cl->used = false;
            continue;
        }
        s->nclients++;
        gw_log(GW_LOG_INFO, "modbus: client %s connected (%s)", who, rw ? "read-write" : "read-only");
    }
}

/* ---- requests --------------------------------------------------------------- */

/* The right to write ([modbus] allow), and whether the client owns the
 * outputs or nobody does (the single-writer rule is the write path's,
 * core/write.h); asking changes nothing (a write refused by a later check
 * must not make its client the owner). */
static bool client_may_write(void *obj)
{
    const client_t *cl = obj;
    return cl->rw;
}

static bool client_owner(void *obj)
{
    const client_t *cl = obj;
    const gw_mbs_t *s = cl->srv;
    return s->writer == NULL || s->writer == cl;
}

/* A write of this client was applied: in single-writer mode, with no
 * owner, it is the owner from now on (the first writer, or the one whose
 * fault reset got through). */
static void client_wrote(void *obj)
{
    client_t *cl = obj;
    gw_mbs_t *s = cl->srv;
    if (!s->cfg.single_writer || s->writer != NULL)
        return;
    s->writer = cl;
    s->writer_claims++;
    char who[32];
    fmt_addr(cl->addr, cl->port, who, sizeof who);
    gw_log(GW_LOG_INFO, "modbus: client %s is now the single writer", who);
}

/* One complete ADU (mbproto.c checks and applies it). Returns false if the
 * client must be dropped. */
static bool handle_request(gw_mbs_t *s, client_t *cl, const uint8_t *req, size_t len,
                           uint64_t now)
{
    char client[48] = "modbus ";
    fmt_addr(cl->addr, cl->port, client + 7, sizeof client - 7);
    const gw_mb_env_t env = {s->hooks.unit_for, s->hooks.user, client_may_write, client_wrote,
                             cl, s->hooks.version, GW_ORIGIN_MODBUS_TCP, client, &cl->write_log,
                             client_owner};
    int ex = gw_mbs_decide(req, len, &env, &s->result);
    if (ex < 0)
        return false; /* not reached: drain_frames hands whole frames only */
    if (s->result.reset) {
        char who[32];
        fmt_addr(cl->addr, cl->port, who, sizeof who);
        gw_log(GW_LOG_INFO, "modbus: client %s reset the write fault of unit %u", who,
               s->result.unit_id);
    }
    if (ex == 0x0A && s->result.unit == NULL && !cl->unit_logged) {
        /* once per client: a PLC that polls the wrong unit ID would
         * otherwise fill the log */
        char who[32];
        fmt_addr(cl->addr, cl->port, who, sizeof who);
        gw_log(GW_LOG_WARNING,
               "modbus: client %s asked for unit ID %u, which no robot answers to "
               "(exception 0x0A): set the PLC's unit ID to a robot's unit_id, or give "
               "the robot unit_id_alias = %s (logged once per client)",
               who, s->result.unit_id,
               s->result.unit_id == 0 || s->result.unit_id == 255 ? (s->result.unit_id == 0 ? "0" : "255")
                                                                  : "0 or 255 for those IDs");
        cl->unit_logged = true;
    }
    if (ex == 0 && s->result.write && s->result.dirty != 0)
        s->hooks.on_write(s->hooks.user, s->result.unit, s->result.dirty);
    s->requests++;
    cl->requests++;
#ifndef GW_MB_NO_REQLOG /* the bench's daemon without it (bench-gw) */
    gw_reqlog_add(&cl->log, now, &s->result, ex);
#else
    (void)now;
#endif
    if (ex != 0) {
        s->exceptions++;
        cl->exceptions++;
    }
    if (s->hooks.on_request != NULL)
        s->hooks.on_request(s->hooks.user, &s->result, ex, client, &cl->write_log);
    /* All of it or the client is dropped, as libmodbus's send did. */
    uint8_t out[GW_ADU_MAX];
    size_t n = gw_mbap_reply(req, &s->result, out);
    return send(cl->fd, out, n, MSG_NOSIGNAL) == (ssize_t)n;
}

/* Take complete frames out of the client's buffer; *frames counts them. */
static bool drain_frames(gw_mbs_t *s, client_t *cl, unsigned *frames, uint64_t now)
{
    for (;;) {
        size_t total = 0;
        switch (gw_mbap_frame(cl->buf, cl->len, &total)) {
        case GW_MBAP_MORE:
            return true;
        case GW_MBAP_BAD: {
            char who[32];
            fmt_addr(cl->addr, cl->port, who, sizeof who);
            gw_log(GW_LOG_WARNING,
                   "modbus: client %s: malformed MBAP header (protocol %u, length %u)", who,
                   be16(cl->buf + 2), be16(cl->buf + 4));
            return false;
        }
        case GW_MBAP_FRAME:
            break;
        }
        if (!handle_request(s, cl, cl->buf, total, now))
            return false;
        ++*frames;
        memmove(cl->buf, cl->buf + total, cl->len - total);
        cl->len -= total;
    }
}

static void on_client(void *obj, uint32_t events)
{
    client_t *cl = obj;
    gw_mbs_t *s = cl->srv;
    if (events & (EPOLLERR | EPOLLHUP)) {
        client_close(cl, "connection error");
        return;
    }
    /* One receive per readiness event, not until EAGAIN: a client that
     * sends its next request as soon as it has the answer would otherwise
     * keep the loop here, and the other clients, the robot links and the
     * timers would wait (epoll is level-triggered: what is left is
     * reported again at the next turn of the loop). */
    ssize_t got = recv(cl->fd, cl->buf + cl->len, sizeof cl->buf - cl->len, 0);
    if (got < 0 && (errno == EAGAIN || errno == EINTR))
        return;
    if (got <= 0) {
        client_close(cl, got == 0 ? "closed by the client" : "receive error");
        return;
    }
    uint64_t now = ev_now_us();
    if (cl->len == 0)
        cl->req_us = now; /* a request's first byte: its deadline starts */
    cl->len += (size_t)got;
    unsigned frames = 0;
    if (!drain_frames(s, cl, &frames, now)) {
        client_close(cl, "bad request or send failure");
        return;
    }
    /* Only whole requests count as activity (idle timeout, eviction): a
     * client that trickles bytes is not busy. What is left in the buffer
     * is the start of a request that arrived now. */
    if (frames > 0) {
        cl->last_us = now;
        cl->req_us = cl->len > 0 ? now : 0;
    }
}

/* ---- lifecycle ----------------------------------------------------------------- */

static int open_listener(const gw_modbus_config_t *cfg, char *err, size_t errlen)
{
    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = htons(cfg->port);
    if (inet_pton(AF_INET, cfg->listen, &sin.sin_addr) != 1) {
        snprintf(err, errlen, "modbus listen address '%s' is not an IPv4 address", cfg->listen);
        return -1;
    }
    int fd = socket(AF_INET, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    int one = 1;
    if (fd < 0 || setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one) < 0 ||
        bind(fd, (struct sockaddr *)&sin, sizeof sin) < 0 || listen(fd, 64) < 0) {
        int e = errno; /* kept for the caller (EADDRINUSE) */
        snprintf(err, errlen, "modbus: cannot listen on %s:%u: %s", cfg->listen, cfg->port,
                 strerror(e));
        if (fd >= 0)
            close(fd);
        errno = e;
        return -1;
    }
    return fd;
}

gw_mbs_t *gw_mbs_new(const gw_modbus_config_t *cfg, int epfd,
                     const gw_mbs_hooks_t *hooks, char *err, size_t errlen)
{
    gw_mbs_t *s = calloc(1, sizeof *s);
    if (s == NULL) {
        snprintf(err, errlen, "out of memory");
        return NULL;
    }
    s->cfg = *cfg;
    if (s->cfg.max_clients > MAX_CLIENTS_HARD)
        s->cfg.max_clients = MAX_CLIENTS_HARD;
    s->hooks = *hooks;
    s->epfd = epfd;
    s->listen_ev.fd = -1;
    s->listen_fd = open_listener(cfg, err, errlen);
    if (s->listen_fd < 0) {
        gw_mbs_free(s);
        return NULL;
    }
    s->listen_ev.fn = on_accept;
    s->listen_ev.obj = s;
    if (!ev_watch(epfd, &s->listen_ev, s->listen_fd, EPOLLIN)) {
        snprintf(err, errlen, "epoll: %s", strerror(errno));
        gw_mbs_free(s);
        return NULL;
    }
    gw_log(GW_LOG_INFO, "modbus: listening on %s:%u (max %u clients, word order %s)",
           cfg->listen, cfg->port, s->cfg.max_clients, gw_word_order_name(cfg->word_order));
    return s;
}

void gw_mbs_free(gw_mbs_t *s)
{
    if (s == NULL)
        return;
    for (unsigned i = 0; i < MAX_CLIENTS_HARD; i++)
        if (s->clients[i].used)
            client_close(&s->clients[i], "gateway stopping");
    ev_unwatch(s->epfd, &s->listen_ev);
    if (s->listen_fd >= 0)
        close(s->listen_fd);
    free(s);
}

/* Moves the listener to cfg's address and port. The old one stays open
 * until the new one works, so a port that cannot be had (in use) leaves
 * the gateway serving where it was. Returns false only if no listener is
 * left at all. */
static bool move_listener(gw_mbs_t *s, const gw_modbus_config_t *cfg)
{
    char err[256];
    int fd = open_listener(cfg, err, sizeof err);
    if (fd < 0 && errno == EADDRINUSE && cfg->port == s->cfg.port) {
        /* The same port on another address: ours is in the way. */
        ev_unwatch(s->epfd, &s->listen_ev);
        close(s->listen_fd);
        s->listen_fd = -1;
        fd = open_listener(cfg, err, sizeof err);
        if (fd < 0) {
            char again[256];
            s->listen_fd = open_listener(&s->cfg, again, sizeof again);
            if (s->listen_fd < 0 ||
                !ev_watch(s->epfd, &s->listen_ev, s->listen_fd, EPOLLIN)) {
                gw_log(GW_LOG_ERROR, "reload: %s; and again %s", err, again);
                return false;
            }
        }
    }
    if (fd < 0) {
        gw_log(GW_LOG_ERROR, "reload: %s: still listening on %s:%u", err, s->cfg.listen,
               s->cfg.port);
        return true;
    }
    if (!ev_watch(s->epfd, &s->listen_ev, fd, EPOLLIN)) {
        gw_log(GW_LOG_ERROR, "reload: epoll: %s: still listening on %s:%u", strerror(errno),
               s->cfg.listen, s->cfg.port);
        close(fd);
        return true;
    }
    if (s->listen_fd >= 0)
        close(s->listen_fd);
    s->listen_fd = fd;
    gw_log(GW_LOG_INFO, "modbus: listening on %s:%u (was %s:%u)", cfg->listen, cfg->port,
           s->cfg.listen, s->cfg.port);
    snprintf(s->cfg.listen, sizeof s->cfg.listen, "%s", cfg->listen);
    s->cfg.port = cfg->port;
    return true;
}

bool gw_mbs_reconfigure(gw_mbs_t *s, const gw_modbus_config_t *cfg)
{
    if ((strcmp(cfg->listen, s->cfg.listen) != 0 || cfg->port != s->cfg.port) &&
        !move_listener(s, cfg))
        return false;
    /* Everything else is taken; the address stays where move_listener left it. */
    char listen[sizeof s->cfg.listen];
    uint16_t port = s->cfg.port;
    memcpy(listen, s->cfg.listen, sizeof listen);
    s->cfg = *cfg;
    memcpy(s->cfg.listen, listen, sizeof listen);
    s->cfg.port = port;
    if (s->cfg.max_clients > MAX_CLIENTS_HARD)
        s->cfg.max_clients = MAX_CLIENTS_HARD;
    /* Clients keep their connections; their rights follow the new list. */
    for (unsigned i = 0; i < MAX_CLIENTS_HARD; i++) {
        client_t *cl = &s->clients[i];
        bool rw;
        if (cl->used && !allowed(s, cl->addr, &rw))
            client_close(cl, "no longer in the allowlist");
        else if (cl->used)
            cl->rw = rw;
    }
    if (!s->cfg.single_writer)
        s->writer = NULL;
    return true;
}

/* When a client's time is up: a pending request's deadline, or the idle
 * timeout since its last complete request. */
static uint64_t client_deadline(const gw_mbs_t *s, const client_t *cl)
{
    uint64_t d = UINT64_MAX;
    if (s->cfg.idle_timeout_s != 0)
        d = cl->last_us + (uint64_t)s->cfg.idle_timeout_s * 1000000u;
    if (cl->req_us != 0 && cl->req_us + (uint64_t)s->cfg.request_timeout_ms * 1000u < d)
        d = cl->req_us + (uint64_t)s->cfg.request_timeout_ms * 1000u;
    return d;
}

void gw_mbs_tick(gw_mbs_t *s, uint64_t now)
{
    /* Called at every turn of the loop: stop after the last client. */
    for (unsigned i = 0, seen = 0, n = s->nclients; i < MAX_CLIENTS_HARD && seen < n; i++) {
        client_t *cl = &s->clients[i];
        if (!cl->used)
            continue;
        seen++;
        if (now < client_deadline(s, cl))
            continue;
        if (cl->req_us != 0 && now - cl->req_us >= (uint64_t)s->cfg.request_timeout_ms * 1000u)
            client_close(cl, "request not complete within request_timeout_ms");
        else
            client_close(cl, "idle timeout");
    }
}

uint64_t gw_mbs_next_deadline(const gw_mbs_t *s)
{
    uint64_t d = UINT64_MAX;
    for (unsigned i = 0, seen = 0; i < MAX_CLIENTS_HARD && seen < s->nclients; i++) {
        const client_t *cl = &s->clients[i];
        if (!cl->used)
            continue;
        seen++;
        uint64_t t = client_deadline(s, cl);
        if (t < d)
            d = t;
    }
    return d;
}

unsigned gw_mbs_client_count(const gw_mbs_t *s)
{
    return s->nclients;
}

uint32_t gw_mbs_exceptions(const gw_mbs_t *s)
{
    return s->exceptions;
}

bool gw_mbs_writer_present(const gw_mbs_t *s)
{
    return s->writer != NULL;
}

unsigned gw_mbs_writer_claims(const gw_mbs_t *s)
{
    return s->writer_claims;
}

void gw_mbs_release_writer(gw_mbs_t *s)
{
    s->writer = NULL;
}

static void each_slot(const gw_mbs_t *s, bool gone_too,
                      void (*fn)(void *user, const gw_mbs_client_info_t *c), void *user)
{
    for (unsigned i = 0; i < MAX_CLIENTS_HARD; i++) {
        const client_t *cl = &s->clients[i];
        if (!cl->used && !(gone_too && cl->log.total > 0))
            continue;
        gw_mbs_client_info_t c;
        memset(&c, 0, sizeof c);
        fmt_addr(cl->addr, cl->port, c.address, sizeof c.address);
        c.requests = cl->requests;
        c.exceptions = cl->exceptions;
        c.read_write = cl->rw;
        c.writer = cl->used && s->writer == cl;
        c.connected = cl->used;
        c.log = &cl->log;
        fn(user, &c);
    }
}

void gw_mbs_each_client(const gw_mbs_t *s,
                        void (*fn)(void *user, const gw_mbs_client_info_t *c), void *user)
{
    each_slot(s, false, fn, user);
}

void gw_mbs_each_log(const gw_mbs_t *s, void (*fn)(void *user, const gw_mbs_client_info_t *c),
                     void *user)
{
    each_slot(s, true, fn, user);
}

uint32_t gw_mbs_requests(const gw_mbs_t *s)
{
    return s->requests;
}
