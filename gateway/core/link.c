/* SPDX-License-Identifier: MIT */
/* One robot's link: see link.h. */
#include <arpa/inet.h>
#include <netdb.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>

#include "common/ev.h"
#include "drgate/client.h"
#include "core/link.h"
#include "core/log.h"

/* One Class 1 connection per T->O assembly, as the configuration's plan
 * opens it (gw_robot_config_t.open; by default the four O->T assemblies
 * paired with their natural partner and two input-only connections). Its
 * slot, and so its conn_state register, follows this order whatever the
 * plan: an assembly that is not opened leaves its slot empty. */
static const dr_asm_t slot_t2o[] = {
    DR_ASM_IO_STATE, DR_ASM_BIT_OUT, DR_ASM_INT_OUT, DR_ASM_FLOAT_OUT,
    DR_ASM_JOINT_STATE, DR_ASM_TASK_STATE,
};
#define NPAIRS (sizeof slot_t2o / sizeof slot_t2o[0])

/* A descriptor of the client in the loop, and whose it is. */
typedef struct {
    ev_t ev;
    struct gw_link *link;
} link_ev_t;

/* What an explicit-mode request's reply is for. It lives in the link, not
 * in a table by robot position: a reload moves robots to other positions
 * while their requests are out, and each reply must still reach its own
 * link. */
typedef struct {
    struct gw_link *link;
    dr_asm_t a;
    bool point; /* a combined layout's input or output point, not `a` alone */
} poll_ctx_t;

struct gw_link {
    gw_robot_config_t cfg;
    unsigned robot;
    gw_robot_t *data; /* the robot's images and link facts */
    int epfd;
    gw_link_hooks_t hooks;
    dr_client_t *client;
    dr_conn_t *conn[NPAIRS];
    struct shared_port *port;
    link_ev_t ev[DR_CLIENT_MAX_FDS];
    bool up;
    /* Per slot: a T->O packet came since the connection was last
     * established. The link is up only when every connection has one: a
     * Forward Open the robot accepted is no data yet. */
    bool flowing[NPAIRS];
    uint64_t last_rx_us[DR_ASM_COUNT]; /* per T->O assembly */
    uint64_t start_us;
    /* explicit mode */
    uint64_t next_poll_us;
    unsigned in_flight;
    unsigned poll_ok;        /* replies of the current cycle */
    unsigned dirty;          /* O->T images still to send */
    poll_ctx_t poll_ctx[DR_ASM_COUNT];
    poll_ctx_t poll_in, poll_out; /* combined layouts: the two points */
    /* combined layouts: the output point's image as last sent */
    uint8_t out_img[DR_POINT_MAX_SIZE];
    gw_log_limit_t log_limit;
    gw_log_limit_t sess_limit; /* the session's failures: a kind of their own */
    gw_log_limit_t sess_end_limit; /* sessions that end under a live link */
    gw_log_limit_t set_limit;  /* explicit mode: Sets the robot refused */
    bool sess_ready;           /* the client said its session is registered */
    dr_status_t sess_why;      /* why the last session attempt failed or ended */
    const char *closing; /* gw_link_free's reason: a planned link down */
    uint64_t status_us;      /* update_status last ran (implicit mode) */
    bool status_now;         /* the link went up or down: update at once */
    /* The robot's packet counters when this link started (carried over a
     * reload that changed the robot): the connections count from 0 */
    uint32_t rx_base, lost_base;
    unsigned t2o_planned;    /* T->O assemblies the plan opens (explicit: polls) */
    unsigned o2t_planned;    /* O->T assemblies with an owner connection */
    /* The Identity read (robot.h, gw_robot_identity_t): due after each
     * session the client registers, out while its request is; a refusal
     * is logged once (again only after a read that succeeded). */
    bool ident_due, ident_out, ident_logged;
};

/* Robots whose links use the same local address and UDP port share one
 * socket (two sockets cannot both own 2222), polled here once for all. */
typedef struct shared_port {
    dr_udp_port_t *port;
    char addr[64];
    uint16_t num;
    unsigned refs;
    ev_t ev;
    uint64_t read_us; /* when it was last read to the end */
} shared_port_t;

/* A busy loop (many Modbus requests) reads the Class 1 port at least this
 * often, rather than waiting for epoll to report it behind every ready
 * Modbus client: see gw_link_tick(). */
#define PORT_POLL_US 50u

/* The daemon's shared UDP ports: one object for all its links, owned by
 * the daemon (see link.h). */
struct gw_link_ports {
    shared_port_t port[GW_MAX_ROBOTS];
    bool loop_timer; /* gw_link_ports_loop_timer */
};

void gw_link_ports_loop_timer(gw_link_ports_t *p, bool on)
{
    p->loop_timer = on;
}

void gw_link_ports_flush(gw_link_ports_t *p)
{
    for (unsigned i = 0; i < GW_MAX_ROBOTS; i++)
        if (p->port[i].refs > 0)
            dr_udp_port_flush(p->port[i].port);
}

/* The clients' transport: POSIX, without timers when the loop keeps the
 * time (a client then has no timerfd to re-arm every RPI: with N robots,
 * N timerfd_settime per RPI fewer). */
static dr_transport_ops_t untimed_ops;
static dr_transport_t client_transport(const gw_link_ports_t *p)
{
    dr_transport_t t = {NULL, NULL}; /* the default: POSIX, with timers */
    if (!p->loop_timer)
        return t;
    t = dr_transport_posix();
    untimed_ops = *t.ops;
    untimed_ops.timer_open = NULL;
    untimed_ops.timer_arm = NULL;
    t.ops = &untimed_ops;
    return t;
}

gw_link_ports_t *gw_link_ports_new(void)
{
    return calloc(1, sizeof(gw_link_ports_t));
}

void gw_link_ports_free(gw_link_ports_t *p)
{
    free(p); /* the links have given their ports back (port_put) */
}

/* Why the link failed, in the robot's link facts (gw_robot_record_error):
 * every failure, not only the ones that change the link's state. */
static void link_record_error(gw_link_t *l, dr_status_t why)
{
    gw_robot_record_error(l->data, why);
}

static void link_set_up(gw_link_t *l, bool up, dr_status_t why)
{
    if (l->up == up)
        return;
    l->up = up;
    l->status_now = true;
    if (!up && l->closing == NULL)
        l->data->link.reconnects++; /* it was up: it reconnects from here */
    /* Explicit mode sends an O->T image only when it changed: the robot
     * may come back without it (a restart), so all of them go again. */
    if (!up && l->cfg.mode == GW_MODE_EXPLICIT)
        l->dirty = (1u << DR_ASM_COUNT) - 1u;
    link_record_error(l, why);
    /* Before any side hears of it: they all read the same images. */
    if (!up)
        gw_robot_link_down(l->data);
    /* Closed on purpose (SIGTERM, reload): not a fault, and the reason is
     * ours, not what the closing connections report. */
    const char *reason = l->closing != NULL ? l->closing : why != DR_OK ? dr_strerror(why) : "";
    if (up)
        gw_log_limit_end(&l->log_limit); /* the refusals before it are past */
    gw_log(up || l->closing != NULL ? GW_LOG_INFO : GW_LOG_WARNING,
           "robot %s (%s): link %s%s%s", l->cfg.name, l->cfg.host, up ? "up" : "down",
           reason[0] != '\0' ? ": " : "", reason);
    if (l->hooks.on_link != NULL)
        l->hooks.on_link(l->hooks.user, l->robot, up, why);
}

/* The session's news (dr_session_cb). A failed attempt (resolve, connect,
 * register) is why the link cannot come up: recorded and logged from the
 * first one, with the cause in words ("connection refused", "no route to
 * host", "no answer: TCP connection timed out", ...), so that a wrong
 * address, a robot switched off and an adapter that is disabled can be
 * told apart. A registered session that ends while the Class 1
 * connections still deliver is no link failure (they outlive it): info
 * only, and the client registers again by itself. */
static void on_session(dr_client_t *c, dr_status_t why, void *user)
{
    gw_link_t *l = user;
    bool was_ready = l->sess_ready;
    l->sess_ready = why == DR_OK;
    l->sess_why = why;
    l->status_now = true;
    if (why == DR_OK) {
        l->ident_due = true; /* asked after this turn's Forward Opens (settle) */
        return;
    }
    char cause[160];
    gw_robot_error_text(why, cause, sizeof cause);
    if (was_ready && l->up && l->cfg.mode == GW_MODE_IMPLICIT) {
        gw_log_limited(GW_LOG_INFO, &l->sess_end_limit,
                       "robot %s: %s:%u: session ended: %s (the Class 1 connections go on)",
                       l->cfg.name, l->cfg.host, (unsigned)l->cfg.tcp_port, cause);
        return;
    }
    link_record_error(l, why);
    gw_log_limited(GW_LOG_WARNING, &l->sess_limit, "robot %s: %s:%u: %s: %s", l->cfg.name,
                   l->cfg.host, (unsigned)l->cfg.tcp_port,
                   was_ready ? "session lost" : dr_client_last_step(c), cause);
}

/* ---- layouts --------------------------------------------------------------- */

/* A combined layout (combined, gpr_only): one connection, in slot 0. */
static bool combined(const gw_link_t *l)
{
    return l->cfg.layout != DR_LAYOUT_PER_ASSEMBLY;
}

/* Slot i's connection carries T->O assembly a. */
static bool slot_has(const gw_link_t *l, unsigned i, dr_asm_t a)
{
    if (combined(l))
        return i == 0 && dr_point_has(&l->cfg.input, a);
    return i < NPAIRS && slot_t2o[i] == a;
}

/* The output point's image from the robot's O->T images. */
static const uint8_t *output_image(gw_link_t *l)
{
    const dr_point_t *p = &l->cfg.output;
    for (unsigned k = 0; k < p->count; k++) {
        dr_asm_t a = (dr_asm_t)p->asm_id[k];
        (void)dr_point_put(p, l->out_img, p->size, a, l->data->img[a], dr_asm_info(a)->size);
    }
    return l->out_img;
}

/* T->O assembly a of a new image is in the robot's image: tell whoever
 * listens. */
static void t2o_taken(gw_link_t *l, dr_asm_t a);

/* ---- descriptors ----------------------------------------------------------- */

static void on_client_fd(void *obj, uint32_t events);

/* The client's descriptors change as it reconnects: mirror them in epoll. */
static void sync_fds(gw_link_t *l)
{
    dr_pollfd_t fds[DR_CLIENT_MAX_FDS];
    int n = dr_client_pollfds(l->client, fds, DR_CLIENT_MAX_FDS);
    for (int i = 0; i < DR_CLIENT_MAX_FDS; i++) {
        if (i < n) {
            uint32_t ev = ((fds[i].events & DR_POLL_IN) ? EPOLLIN : 0u) |
                          ((fds[i].events & DR_POLL_OUT) ? EPOLLOUT : 0u);
            /* A slot whose fd moved must leave epoll before another takes it. */
            for (int j = 0; j < DR_CLIENT_MAX_FDS; j++)
                if (j != i && l->ev[j].ev.fd == fds[i].fd)
                    ev_unwatch(l->epfd, &l->ev[j].ev);
            if (!ev_watch(l->epfd, &l->ev[i].ev, fds[i].fd, ev))
                gw_log_limited(GW_LOG_ERROR, &l->log_limit, "robot %s: epoll failed", l->cfg.name);
        } else {
            ev_unwatch(l->epfd, &l->ev[i].ev);
        }
    }
}

/* ---- the Identity ------------------------------------------------------------- */

/* The robot answered the Identity read (or the request ended without an
 * answer: then nothing changes, and the next session asks again). Who it
 * is goes to the log when it is new or changed; a refusal or a reply that
 * is not an Identity, once: the link goes on either way. */
static void on_identity(dr_client_t *c, dr_status_t st, const uint8_t *data, size_t len,
                        void *user)
{
    gw_link_t *l = user;
    l->ident_out = false;
    if (l->closing != NULL)
        return;
    gw_robot_identity_t before = l->data->identity;
    /* a session that failed fails its requests with its own cause (a
     * malformed frame among them): that is no answer to this one */
    if (st != DR_OK && !DR_IS_CIP(st) && !dr_client_ready(c))
        st = DR_ESESSION;
    dr_status_t got = gw_robot_identity_answer(l->data, st, data, len);
    const gw_robot_identity_t *id = &l->data->identity;
    char text[200];
    if (got == DR_OK) {
        l->ident_logged = false;
        if (!gw_robot_identity_same(&before, id)) {
            gw_robot_identity_text(id, text, sizeof text);
            gw_log(GW_LOG_INFO, "robot %s: identity: %s", l->cfg.name, text);
        }
    } else if (id->state == GW_IDENTITY_REFUSED && !l->ident_logged) {
        l->ident_logged = true;
        if (got == DR_ESHORT)
            snprintf(text, sizeof text, "answered with %u bytes, too short for its attributes",
                     (unsigned)len);
        else
            gw_robot_error_text(got, text, sizeof text);
        /* the product name is the only text from the robot, and only a
         * known identity has one: the log line holds none of it */
        gw_log(GW_LOG_WARNING,
               "robot %s: Identity object (Get_Attributes_All, class 1, instance 1): %s; the "
               "robot's identity stays unknown (the link is not affected)",
               l->cfg.name, text);
    }
}

/* Ask for the Identity when a new session wants it: never before the
 * Forward Opens the same turn of the client sent, and never in place of
 * an explicit-mode poll (a full request pool: the next turn tries again). */
static void identity_step(gw_link_t *l)
{
    if (!l->ident_due || l->ident_out || l->closing != NULL)
        return;
    if (!dr_client_ready(l->client)) {
        l->ident_due = false; /* the session is gone: the next one asks */
        return;
    }
    uint8_t path[12];
    size_t n = dr_cip_path(path, sizeof path, DR_CIP_CLASS_IDENTITY, 1, -1);
    dr_status_t st = dr_client_call_async(l->client, DR_CIP_SVC_GET_ATTRIBUTES_ALL, path, n,
                                          NULL, 0, on_identity, l);
    if (st == DR_EFULL)
        return;
    l->ident_due = false;
    l->ident_out = st == DR_OK;
}

/* After the client's turn: the requests that wait for one, then its
 * descriptors as they are now. */
static void settle(gw_link_t *l)
{
    identity_step(l);
    sync_fds(l);
}

static void process(gw_link_t *l)
{
    dr_client_process(l->client);
    settle(l);
}

/* One of the client's descriptors is ready: only that one is read (its
 * timer, TCP socket or own UDP socket), not every socket it has. */
static void on_client_fd(void *obj, uint32_t events)
{
    link_ev_t *e = obj;
    dr_pollfd_t fd = {e->ev.fd, 0, (short)(events != 0)};
    dr_client_process_ready(e->link->client, &fd, 1);
    settle(e->link);
}

/* ---- the observer -------------------------------------------------------------- */

/* Process-wide (gw_link_observe): the daemon registers none. */
static const gw_link_observer_t *link_observer;

void gw_link_observe(const gw_link_observer_t *o)
{
    link_observer = o;
}

/* The shared Class 1 ports' transport: the observer's, or POSIX. */
static dr_transport_t port_transport(void)
{
    dr_transport_t t = {NULL, NULL}; /* the default: POSIX */
    return link_observer != NULL ? link_observer->port_transport : t;
}

/* T->O data of assembly a is in the image, from a Class 1 packet. */
static void observe_t2o(const gw_link_t *l, dr_asm_t a)
{
    if (link_observer != NULL && link_observer->on_t2o != NULL)
        link_observer->on_t2o(link_observer->user, l->robot, a,
                              l->port != NULL ? dr_udp_port_fd(l->port->port) : -1);
}

/* ---- implicit mode ----------------------------------------------------------- */

/* clear_while_down (robot.h): the robot data stays 0 for as long as the
 * link is down, also while some of its connections still deliver (the
 * link is up only with all of them). */
static bool data_withheld(const gw_link_t *l)
{
    return !gw_robot_takes_data(l->data, l->up);
}

/* Every connection of the plan established and delivering. */
static bool all_flowing(const gw_link_t *l)
{
    for (unsigned i = 0; i < NPAIRS; i++)
        if (l->conn[i] != NULL &&
            (dr_conn_state(l->conn[i]) != DR_CONN_ESTABLISHED || !l->flowing[i]))
            return false;
    return true;
}

static void t2o_taken(gw_link_t *l, dr_asm_t a)
{
    l->data->link.rx_us = l->last_rx_us[a];
    observe_t2o(l, a); /* the new data is now what a Modbus read gets */
    if (l->hooks.on_data != NULL)
        l->hooks.on_data(l->hooks.user, l->robot, a);
}

/* A combined layout's input image: every assembly it carries, sliced
 * out of it into the robot's own images. */
static void take_input(gw_link_t *l, const uint8_t *data, size_t len, uint64_t now)
{
    const dr_point_t *p = &l->cfg.input;
    for (unsigned k = 0; k < p->count; k++)
        l->last_rx_us[p->asm_id[k]] = now;
    if (data_withheld(l))
        return;
    for (unsigned k = 0; k < p->count; k++) {
        dr_asm_t a = (dr_asm_t)p->asm_id[k];
        if (dr_point_slice(p, data, len, a, l->data->img[a], dr_asm_info(a)->size) == DR_OK)
            t2o_taken(l, a);
    }
}

static void on_conn_data(dr_conn_t *conn, const uint8_t *data, size_t len, void *user)
{
    gw_link_t *l = user;
    if (combined(l)) {
        if (l->conn[0] != conn)
            return;
        if (!l->flowing[0]) {
            l->flowing[0] = true;
            if (all_flowing(l))
                link_set_up(l, true, DR_OK);
        }
        take_input(l, data, len, ev_now_us());
        return;
    }
    for (unsigned i = 0; i < NPAIRS; i++) {
        if (l->conn[i] != conn)
            continue;
        dr_asm_t a = slot_t2o[i];
        l->last_rx_us[a] = ev_now_us();
        /* The connection's first packet: the last one missing brings the
         * link up, before the data is taken (clear_while_down keeps the
         * images at 0 while it is not). */
        if (!l->flowing[i]) {
            l->flowing[i] = true;
            if (all_flowing(l))
                link_set_up(l, true, DR_OK);
        }
        if (data_withheld(l))
            continue;
        memcpy(l->data->img[a], data, len);
        t2o_taken(l, a);
    }
}

/* "robot R: io_state (owner io_control): reconnecting: Forward Open refused:
 * CIP 0x01/0x0129 invalid configuration application path (path: config 1,
 * O->T 107, T->O 101)", at most as often as the link's rate limit lets
 * through. The path's instances are named because adapters answer the
 * same wrong point with different statuses (a wrong configuration
 * instance: 0x0315 from one, 0x0129 from another). */
static void log_conn_error(gw_link_t *l, dr_conn_t *conn, dr_conn_state_t st, dr_status_t why)
{
    dr_asm_t a = DR_ASM_IO_STATE;
    for (unsigned i = 0; i < NPAIRS; i++)
        if (l->conn[i] == conn)
            a = slot_t2o[i];
    const gw_open_t *o = &l->cfg.open[a];
    char how[48], what[48];
    unsigned o2t, t2o = l->cfg.instance[a];
    snprintf(what, sizeof what, "%s", dr_asm_info(a)->name);
    if (combined(l)) {
        snprintf(what, sizeof what, "input (layout %s)", dr_layout_name(l->cfg.layout));
        t2o = l->cfg.input.instance;
        if (l->cfg.output.count != 0) {
            snprintf(how, sizeof how, "owner output");
            o2t = l->cfg.output.instance;
        } else {
            snprintf(how, sizeof how, "input-only");
            o2t = l->cfg.input_only_heartbeat;
        }
    } else if (o->kind == GW_OPEN_OWNER) {
        snprintf(how, sizeof how, "owner %s", dr_asm_info((dr_asm_t)o->o2t)->name);
        o2t = l->cfg.instance[o->o2t];
    } else if (o->kind == GW_OPEN_LISTEN_ONLY) {
        snprintf(how, sizeof how, "listen-only");
        o2t = l->cfg.listen_only_heartbeat;
    } else {
        snprintf(how, sizeof how, "input-only");
        o2t = l->cfg.input_only_heartbeat;
    }
    /* A size the robot refused: both sizes, ours and the robot's, with
     * what they count (the data, the 2-byte sequence count and, O->T
     * with data, the 4-byte run/idle header), so that the plan can be
     * set to the robot's. */
    char sizes[200] = "";
    if (why == DR_CIP(0x01, 0x0109)) {
        unsigned in = combined(l) ? l->cfg.input.size : dr_asm_info(a)->size, out = 0;
        if (combined(l))
            out = l->cfg.output.size;
        else if (o->kind == GW_OPEN_OWNER)
            out = dr_asm_info((dr_asm_t)o->o2t)->size;
        unsigned want = dr_conn_stats(conn)->size_wanted;
        snprintf(sizes, sizeof sizes,
                 "; sizes: this plan's T->O %u bytes (%u data), O->T %u bytes (%u data), "
                 "the robot's %u bytes",
                 in + 2u, in, out + (out ? 6u : 2u), out, want);
    }
    if (DR_IS_CIP(why))
        gw_log_limited(GW_LOG_WARNING, &l->log_limit,
                       "robot %s: %s (%s): %s: Forward Open refused: CIP 0x%02X/0x%04X %s "
                       "(path: config %u, O->T %u, T->O %u%s)",
                       l->cfg.name, what, how, dr_conn_state_name(st),
                       (unsigned)DR_CIP_GENERAL(why), (unsigned)DR_CIP_EXTENDED(why),
                       dr_strerror(why), (unsigned)l->cfg.config_instance, o2t, t2o, sizes);
    else if (st == DR_CONN_TIMED_OUT && (why == DR_ETIMEDOUT || why == DR_ENODATA)) {
        /* not "timed out: timed out": say what timed out, and how long
         * the robot was silent (the first packet has a grace of 2 s more
         * than the timeout, so the time waited, not the timeout) */
        const dr_conn_stats_t *cs = dr_conn_stats(conn);
        uint64_t now = ev_now_us();
        uint64_t since = cs->last_rx_us > cs->opened_us ? cs->last_rx_us : cs->opened_us;
        unsigned waited = (unsigned)(now > since ? (now - since) / 1000u : 0u);
        char cause[200];
        if (why == DR_ENODATA)
            gw_robot_cause(l->data, cause, sizeof cause);
        gw_log_limited(GW_LOG_WARNING, &l->log_limit,
                       why == DR_ENODATA ? "robot %s: %s (%s): %s (nothing for %u ms)"
                                         : "robot %s: %s (%s): timed out: %sno packet from the "
                                           "robot for %u ms",
                       l->cfg.name, what, how,
                       why == DR_ENODATA ? cause : "", waited);
    } else
        gw_log_limited(GW_LOG_WARNING, &l->log_limit, "robot %s: %s (%s): %s: %s",
                       l->cfg.name, what, how, dr_conn_state_name(st),
                       dr_strerror(why));
}

static void on_conn_state(dr_conn_t *conn, dr_conn_state_t st, dr_status_t why, void *user)
{
    gw_link_t *l = user;
    for (unsigned i = 0; i < NPAIRS; i++)
        if (l->conn[i] == conn) {
            l->data->link.conn_state[i] = (uint16_t)st;
            l->flowing[i] = false; /* (again) established: no data yet */
        }
    /* Established is not up: the link comes up with the last
     * connection's first packet (on_conn_data). */
    if (st == DR_CONN_ESTABLISHED)
        return;
    if (st == DR_CONN_TIMED_OUT)
        l->data->link.timeouts++;
    if (why == DR_ENODATA) { /* where the data should have come */
        dr_sockaddr_t to = dr_client_t2o_addr(l->client);
        snprintf(l->data->link.t2o_to, sizeof l->data->link.t2o_to, "%u.%u.%u.%u:%u",
                 (unsigned)(to.addr >> 24), (unsigned)(to.addr >> 16 & 0xFFu),
                 (unsigned)(to.addr >> 8 & 0xFFu), (unsigned)(to.addr & 0xFFu),
                 (unsigned)to.port);
    }
    if (why != DR_OK) {
        link_record_error(l, why);
        log_conn_error(l, conn, st, why);
    }
    link_set_up(l, false, why);
}

/* What every connection of the link shares, whatever the layout. */
static void conn_common(gw_link_t *l, dr_conn_config_t *cc)
{
    cc->config_instance = l->cfg.config_instance;
    cc->rpi_us = l->cfg.rpi_ms * 1000u;
    cc->timeout_mult = l->cfg.timeout_mult;
    /* Sending O->T with the T->O packet's wake-up halves the wake-ups; a
     * quarter RPI early is well inside any adapter's timeout (at least 4
     * RPIs). */
    cc->o2t_follow_us = l->cfg.o2t_strict ? 0u : cc->rpi_us / 4u;
    cc->on_data = on_conn_data;
    cc->on_state = on_conn_state;
    cc->user = l;
}

/* The connection of a combined layout, in slot 0: input point T->O,
 * output point O->T (or the input-only heartbeat when there is none). */
static bool add_combined(gw_link_t *l)
{
    const dr_point_t *in = &l->cfg.input, *out = &l->cfg.output;
    dr_conn_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.t2o_asm = (dr_asm_t)in->asm_id[0];
    cc.t2o_instance = in->instance;
    cc.t2o_size = in->size;
    cc.o2t_asm = out->count != 0 ? (int)out->asm_id[0] : -1;
    if (out->count != 0) {
        cc.o2t_instance = out->instance;
        cc.o2t_size = out->size;
    }
    conn_common(l, &cc);
    cc.heartbeat_instance = l->cfg.input_only_heartbeat;
    dr_status_t err;
    l->conn[0] = dr_conn_add(l->client, &cc, &err);
    if (l->conn[0] == NULL)
        return false;
    if (out->count != 0)
        (void)dr_conn_set_output(l->conn[0], output_image(l), out->size);
    return true;
}

static bool add_connections(gw_link_t *l)
{
    if (combined(l))
        return add_combined(l);
    for (unsigned i = 0; i < NPAIRS; i++) {
        const gw_open_t *o = &l->cfg.open[slot_t2o[i]];
        if (o->kind == GW_OPEN_NONE)
            continue;
        dr_conn_config_t cc;
        memset(&cc, 0, sizeof cc);
        cc.o2t_asm = o->kind == GW_OPEN_OWNER ? o->o2t : -1;
        cc.t2o_asm = slot_t2o[i];
        conn_common(l, &cc);
        /* Listen-only is input-only on the wire; the heartbeat connection
         * point tells the robot which of the two it is. */
        cc.heartbeat_instance = o->kind == GW_OPEN_LISTEN_ONLY ? l->cfg.listen_only_heartbeat
                                                               : l->cfg.input_only_heartbeat;
        dr_status_t err;
        l->conn[i] = dr_conn_add(l->client, &cc, &err);
        if (l->conn[i] == NULL)
            return false;
        if (cc.o2t_asm >= 0)
            (void)dr_conn_set_output(l->conn[i], l->data->img[cc.o2t_asm],
                                     dr_asm_info((dr_asm_t)cc.o2t_asm)->size);
    }
    return true;
}

/* ---- explicit mode ------------------------------------------------------------- */

static unsigned planned_t2o(const gw_link_t *l)
{
    unsigned n = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        n += (l->t2o_planned >> a) & 1u;
    return n;
}

/* A combined layout's Get of the input point or Set of the output point
 * came back. A reply of another size than the plan's is the link's
 * failure, logged with both sizes. */
static void on_point_reply(gw_link_t *l, const poll_ctx_t *pc, dr_status_t st,
                           const uint8_t *data, size_t len)
{
    bool get = pc == &l->poll_in;
    const dr_point_t *p = get ? &l->cfg.input : &l->cfg.output;
    if (st == DR_OK && get && len != p->size) {
        gw_log_limited(GW_LOG_WARNING, &l->log_limit,
                       "robot %s: get input (instance %u): %u bytes, the plan's input_size "
                       "is %u (layout %s)",
                       l->cfg.name, (unsigned)p->instance, (unsigned)len, (unsigned)p->size,
                       dr_layout_name(l->cfg.layout));
        st = DR_ELENGTH;
    }
    if (st != DR_OK) {
        char cause[160];
        gw_robot_error_text(st, cause, sizeof cause);
        if (!get) {
            l->dirty |= l->o2t_planned; /* send it again next cycle */
            if (DR_IS_CIP(st)) { /* the Set's own failure, as for one assembly */
                l->data->link.sets_refused++;
                link_record_error(l, st);
                gw_log_limited(GW_LOG_WARNING, &l->set_limit,
                               "robot %s: set output (instance %u, %u bytes) refused: %s",
                               l->cfg.name, (unsigned)p->instance, (unsigned)p->size, cause);
                return;
            }
        }
        if (st != DR_ELENGTH)
            gw_log_limited(GW_LOG_WARNING, &l->log_limit, "robot %s: %s %s (instance %u): %s",
                           l->cfg.name, get ? "get" : "set", get ? "input" : "output",
                           (unsigned)p->instance, cause);
        link_record_error(l, st);
        link_set_up(l, false, st);
        return;
    }
    if (!get)
        return;
    uint64_t now = ev_now_us();
    l->data->link.rx_packets++;
    l->data->link.conn_rx[0]++;
    take_input(l, data, len, now);
    link_set_up(l, true, DR_OK);
}

static void on_poll_reply(dr_client_t *c, dr_status_t st, const uint8_t *data, size_t len,
                          void *user)
{
    poll_ctx_t *pc = user;
    gw_link_t *l = pc->link;
    const dr_asm_info_t *info = dr_asm_info(pc->a);
    (void)c;
    if (l->in_flight > 0)
        l->in_flight--;
    if (pc->point) {
        on_point_reply(l, pc, st, data, len);
        return;
    }
    if (st == DR_OK && info->dir == DR_DIR_T2O && len != info->size)
        st = DR_ELENGTH;
    if (st != DR_OK && info->dir == DR_DIR_O2T && DR_IS_CIP(st)) {
        /* The robot refused this assembly's Set (a wrong instance, a
         * size it does not take): that assembly's error, not the link's.
         * Counted, recorded and logged (a kind of its own, rate-limited);
         * the link stays up, every side's link-loss behaviour stays off. */
        char cause[160];
        gw_robot_error_text(st, cause, sizeof cause);
        l->data->link.sets_refused++;
        l->dirty |= 1u << pc->a; /* send it again next cycle */
        link_record_error(l, st);
        gw_log_limited(GW_LOG_WARNING, &l->set_limit,
                       "robot %s: set %s (instance %u) refused: %s", l->cfg.name, info->name,
                       (unsigned)dr_client_instance(l->client, pc->a), cause);
        return;
    }
    if (st != DR_OK) {
        gw_log_limited(GW_LOG_WARNING, &l->log_limit, "robot %s: %s %s: %s", l->cfg.name,
                       info->dir == DR_DIR_T2O ? "get" : "set", info->name, dr_strerror(st));
        if (info->dir == DR_DIR_O2T)
            l->dirty |= 1u << pc->a; /* send it again next cycle */
        link_record_error(l, st); /* also when the link was never up */
        link_set_up(l, false, st);
        return;
    }
    if (info->dir == DR_DIR_T2O) {
        l->last_rx_us[pc->a] = ev_now_us(); /* the link's health: counted anyway */
        l->data->link.rx_packets++;
        for (unsigned i = 0; i < NPAIRS; i++)
            if (slot_t2o[i] == pc->a)
                l->data->link.conn_rx[i]++;
        if (!data_withheld(l)) {
            memcpy(l->data->img[pc->a], data, len);
            l->data->link.rx_us = l->last_rx_us[pc->a];
            if (l->hooks.on_data != NULL)
                l->hooks.on_data(l->hooks.user, l->robot, pc->a);
        }
    }
    if (info->dir == DR_DIR_T2O && ++l->poll_ok >= planned_t2o(l))
        link_set_up(l, true, DR_OK);
}

/* A combined layout's period: one Get of the input point, one Set of
 * the output point when one of its assemblies changed. */
static void explicit_poll_points(gw_link_t *l)
{
    for (unsigned k = 0; k < 2; k++) {
        const dr_point_t *p = k == 0 ? &l->cfg.input : &l->cfg.output;
        if (p->count == 0 || (k == 1 && !(l->dirty & l->o2t_planned)))
            continue;
        uint8_t path[12];
        size_t path_len = dr_cip_path(path, sizeof path, DR_CIP_CLASS_ASSEMBLY, p->instance,
                                      DR_CIP_ASM_ATTR_DATA);
        dr_status_t st = dr_client_call_async(
            l->client, k == 0 ? DR_CIP_SVC_GET_ATTRIBUTE_SINGLE : DR_CIP_SVC_SET_ATTRIBUTE_SINGLE,
            path, path_len, k == 0 ? NULL : output_image(l), k == 0 ? 0 : p->size,
            on_poll_reply, k == 0 ? &l->poll_in : &l->poll_out);
        if (st == DR_OK) {
            l->in_flight++;
            if (k == 1)
                l->dirty &= ~l->o2t_planned;
        }
    }
}

static void explicit_poll(gw_link_t *l, uint64_t now)
{
    if (now < l->next_poll_us)
        return;
    l->next_poll_us = now + (uint64_t)l->cfg.rpi_ms * 1000u;
    if (!dr_client_ready(l->client) || l->in_flight > 0)
        return; /* the previous cycle is still out: skip, never pile up */
    l->poll_ok = 0;
    if (combined(l)) {
        explicit_poll_points(l);
        return;
    }
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        bool t2o = info->dir == DR_DIR_T2O;
        /* The plan says what is polled: T->O assemblies it opens, O->T
         * assemblies it gives an owner. */
        if (!((t2o ? l->t2o_planned : l->o2t_planned) & (1u << a)))
            continue;
        if (!t2o && !(l->dirty & (1u << a)))
            continue;
        uint8_t path[12];
        size_t path_len = dr_cip_path(path, sizeof path, DR_CIP_CLASS_ASSEMBLY,
                                      dr_client_instance(l->client, (dr_asm_t)a),
                                      DR_CIP_ASM_ATTR_DATA);
        dr_status_t st = dr_client_call_async(
            l->client, t2o ? DR_CIP_SVC_GET_ATTRIBUTE_SINGLE : DR_CIP_SVC_SET_ATTRIBUTE_SINGLE,
            path, path_len, t2o ? NULL : l->data->img[a], t2o ? 0 : info->size, on_poll_reply,
            &l->poll_ctx[a]);
        if (st == DR_OK) {
            l->in_flight++;
            if (!t2o)
                l->dirty &= ~(1u << a);
        }
    }
}

static void on_port(void *obj, uint32_t events)
{
    shared_port_t *sp = obj;
    (void)events;
    dr_udp_port_process(sp->port);
    sp->read_us = ev_now_us();
}

static shared_port_t *port_get(gw_link_ports_t *ports, const gw_robot_config_t *rc, int epfd)
{
    uint16_t num = rc->local_udp_port ? rc->local_udp_port : DR_ENIP_UDP_PORT;
    shared_port_t *free_slot = NULL;
    for (unsigned i = 0; i < GW_MAX_ROBOTS; i++) {
        shared_port_t *sp = &ports->port[i];
        if (sp->refs > 0 && sp->num == num && strcmp(sp->addr, rc->local_addr) == 0) {
            sp->refs++;
            return sp;
        }
        if (sp->refs == 0 && free_slot == NULL)
            free_slot = sp;
    }
    if (free_slot == NULL)
        return NULL;
    dr_status_t err;
    dr_transport_t tp = port_transport();
    free_slot->port = dr_udp_port_new(rc->local_addr[0] ? rc->local_addr : NULL, num, tp, &err);
    if (free_slot->port == NULL) {
        /* what to change, for the two causes a configuration fixes */
        const char *fix = err == DR_EADDRINUSE
                              ? " (another program has it, e.g. a second gateway or a PLC "
                                "runtime: set local_address to another address of this host, "
                                "or local_udp_port to a free port)"
                          : err == DR_EADDRNOTAVAIL ? " (local_address must be an address of "
                                                      "this host)"
                                                    : "";
        gw_log(GW_LOG_ERROR, "robot %s: cannot open UDP %s:%u for Class 1 I/O: %s%s", rc->name,
               rc->local_addr[0] ? rc->local_addr : "0.0.0.0", num, dr_strerror(err), fix);
        return NULL;
    }
    snprintf(free_slot->addr, sizeof free_slot->addr, "%s", rc->local_addr);
    free_slot->num = num;
    free_slot->refs = 1;
    /* Robots due at the same instant (they share the port's time grid)
     * go out in one sendmmsg: the loop flushes at the end of its turn. */
    dr_udp_port_hold(free_slot->port, true);
    free_slot->ev.fn = on_port;
    free_slot->ev.obj = free_slot;
    free_slot->ev.fd = -1;
    if (!ev_watch(epfd, &free_slot->ev, dr_udp_port_fd(free_slot->port), EPOLLIN))
        gw_log(GW_LOG_ERROR, "robot %s: epoll failed for the UDP port", rc->name);
    return free_slot;
}

static void port_put(shared_port_t *sp, int epfd)
{
    if (sp == NULL || --sp->refs > 0)
        return;
    ev_unwatch(epfd, &sp->ev);
    dr_udp_port_free(sp->port);
    sp->port = NULL;
}

/* ---- lifecycle ------------------------------------------------------------------ */

/* The robot's IPv4 address as text. A host name is resolved here, once
 * (at start and at SIGHUP), and the client gets the address: getaddrinfo
 * blocks, and with a slow or absent DNS server every reconnect would stall
 * the whole loop, Modbus clients included. */
static bool resolve_host(const gw_robot_config_t *rc, char ip[INET_ADDRSTRLEN])
{
    struct in_addr a;
    if (inet_pton(AF_INET, rc->host, &a) == 1)
        return inet_ntop(AF_INET, &a, ip, INET_ADDRSTRLEN) != NULL;
    struct addrinfo hints, *res = NULL;
    memset(&hints, 0, sizeof hints);
    hints.ai_family = AF_INET;
    hints.ai_socktype = SOCK_STREAM;
    int rv = getaddrinfo(rc->host, NULL, &hints, &res);
    if (rv != 0 || res == NULL) {
        gw_log(GW_LOG_ERROR, "robot %s: host '%s' does not resolve to an IPv4 address: %s",
               rc->name, rc->host, rv != 0 ? gai_strerror(rv) : "no address");
        return false;
    }
    const struct sockaddr_in *sin = (const struct sockaddr_in *)(const void *)res->ai_addr;
    bool ok = inet_ntop(AF_INET, &sin->sin_addr, ip, INET_ADDRSTRLEN) != NULL;
    freeaddrinfo(res);
    return ok;
}

gw_link_t *gw_link_new(const gw_robot_config_t *rc, unsigned robot, gw_robot_t *data,
                       int epfd, gw_link_ports_t *ports, const gw_link_hooks_t *hooks)
{
    if (robot >= GW_MAX_ROBOTS)
        return NULL;
    gw_link_t *l = calloc(1, sizeof *l);
    if (l == NULL)
        return NULL;
    l->cfg = *rc;
    l->epfd = epfd;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        if (gw_robot_reads(rc, (dr_asm_t)a))
            l->t2o_planned |= 1u << a;
        if (gw_robot_owns(rc, (dr_asm_t)a))
            l->o2t_planned |= 1u << a;
    }
    l->hooks = *hooks;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        l->poll_ctx[a].link = l;
        l->poll_ctx[a].a = (dr_asm_t)a;
    }
    l->poll_in = (poll_ctx_t){ l, (dr_asm_t)rc->input.asm_id[0], true };
    l->poll_out = (poll_ctx_t){ l, (dr_asm_t)rc->output.asm_id[0], true };
    for (unsigned i = 0; i < DR_CLIENT_MAX_FDS; i++) {
        l->ev[i].link = l;
        l->ev[i].ev.fn = on_client_fd;
        l->ev[i].ev.obj = &l->ev[i];
        l->ev[i].ev.fd = -1;
    }
    gw_link_set_robot(l, robot, data);
    l->rx_base = data->link.rx_packets;
    l->lost_base = data->link.lost_packets;
    for (unsigned i = 0; i < GW_ROBOT_CONNS; i++) {
        /* the slots the plan fills (explicit mode: the polled assemblies);
         * a combined layout's one connection, in slot 0, is named by the
         * first assembly its input carries */
        bool used = i < NPAIRS && rc->open[slot_t2o[i]].kind != GW_OPEN_NONE;
        uint16_t t2o = used ? (uint16_t)slot_t2o[i] : (uint16_t)DR_ASM_COUNT;
        if (rc->layout != DR_LAYOUT_PER_ASSEMBLY)
            t2o = i == 0 ? rc->input.asm_id[0] : (uint16_t)DR_ASM_COUNT;
        data->link.conn_t2o[i] = t2o;
        data->link.conn_rx[i] = data->link.conn_lost[i] = 0;
        data->link.conn_dropped_seq[i] = data->link.conn_dropped_addr[i] = 0;
        data->link.conn_resyncs[i] = 0;
    }
    data->link.conn_name[0] = '\0';
    if (rc->layout != DR_LAYOUT_PER_ASSEMBLY)
        snprintf(data->link.conn_name, sizeof data->link.conn_name,
                 "%s T->O (%u assemblies, %u bytes)", dr_layout_name(rc->layout),
                 (unsigned)rc->input.count, (unsigned)rc->input.size);
    data->o2t_unsent = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_info((dr_asm_t)a)->dir == DR_DIR_O2T && !(l->o2t_planned & (1u << a)))
            data->o2t_unsent |= 1u << a;
    char ip[INET_ADDRSTRLEN];
    if (!resolve_host(rc, ip)) {
        gw_link_free(l, NULL);
        return NULL;
    }
    dr_client_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.host = ip;
    cc.tcp_port = rc->tcp_port;
    cc.udp_port = rc->udp_port;
    cc.local_addr = rc->local_addr[0] ? rc->local_addr : NULL;
    cc.local_udp_port = rc->local_udp_port;
    cc.timeout_ms = rc->timeout_ms;
    /* Stable across restarts: the adapter hands the exclusive-owner
     * connections of a run that ended uncleanly back only to the same
     * originator (docs/configuration.md, originator_serial). */
    cc.serial = rc->originator_serial != 0 ? rc->originator_serial
                                           : dr_originator_serial_local(rc->name);
    cc.transport = client_transport(ports);
    cc.on_session = on_session;
    cc.session_user = l;
    memcpy(cc.instance, rc->instance, sizeof cc.instance);
    if (rc->mode == GW_MODE_IMPLICIT) {
        l->port = port_get(ports, rc, epfd);
        if (l->port == NULL) {
            gw_link_free(l, NULL);
            return NULL;
        }
        cc.shared_udp = l->port->port;
    }
    dr_status_t err = DR_OK;
    l->client = dr_client_new(&cc, &err);
    if (l->client == NULL || (rc->mode == GW_MODE_IMPLICIT && !add_connections(l))) {
        gw_log(GW_LOG_ERROR, "robot %s: cannot create the EtherNet/IP client%s%s", rc->name,
               l->client == NULL ? ": " : "", l->client == NULL ? dr_strerror(err) : "");
        gw_link_free(l, NULL);
        return NULL;
    }
    l->start_us = ev_now_us();
    l->dirty = (1u << DR_ASM_COUNT) - 1u;
    l->data->link.link_state = 1;
    l->data->link.rpi_ms = (uint16_t)rc->rpi_ms;
    l->data->link.originator_serial = cc.serial;
    /* Before the start, whose first attempt may fail (and say so) at once. */
    bool named = strcmp(ip, rc->host) != 0; /* a host name: show its address too */
    char lay[96] = "";
    if (rc->layout != DR_LAYOUT_PER_ASSEMBLY)
        snprintf(lay, sizeof lay, ", layout %s: input %u (%u bytes), output %u (%u bytes)",
                 dr_layout_name(rc->layout), (unsigned)rc->input.instance,
                 (unsigned)rc->input.size, (unsigned)rc->output.instance,
                 (unsigned)rc->output.size);
    char sides[96]; /* ", unit ID 1": the sides' word on the robot */
    gw_log(GW_LOG_INFO, "robot %s: connecting to %s%s%s%s (%s%s, RPI %u ms%s, "
           "originator serial 0x%08lX)",
           rc->name, rc->host, named ? " (" : "", named ? ip : "", named ? ")" : "",
           rc->mode == GW_MODE_IMPLICIT ? "implicit" : "explicit", lay, rc->rpi_ms,
           gw_config_robot_brief(rc, sides, sizeof sides), (unsigned long)cc.serial);
    dr_client_start(l->client);
    process(l);
    return l;
}

void gw_link_free(gw_link_t *l, const char *why)
{
    if (l == NULL)
        return;
    l->closing = why != NULL ? why : "closed";
    for (unsigned i = 0; i < DR_CLIENT_MAX_FDS; i++)
        ev_unwatch(l->epfd, &l->ev[i].ev);
    /* SIGTERM must end within a second even with a slow robot: the
     * Forward Close replies get a short wait. */
    if (l->client != NULL)
        dr_client_set_timeout(l->client, 250);
    dr_client_free(l->client); /* Forward Close + UnRegisterSession */
    port_put(l->port, l->epfd);
    free(l);
}

void gw_link_set_robot(gw_link_t *l, unsigned robot, gw_robot_t *data)
{
    l->robot = robot;
    l->data = data;
}

void gw_link_outputs_changed(gw_link_t *l, unsigned dirty)
{
    if (l->cfg.mode == GW_MODE_EXPLICIT) {
        l->dirty |= dirty;
        l->next_poll_us = 0; /* send soon, not a whole period later */
        return;
    }
    if (combined(l)) {
        if ((dirty & l->o2t_planned) && l->conn[0] != NULL)
            (void)dr_conn_set_output(l->conn[0], output_image(l), l->cfg.output.size);
        return;
    }
    for (unsigned i = 0; i < NPAIRS; i++) {
        const gw_open_t *o = &l->cfg.open[slot_t2o[i]];
        if (o->kind == GW_OPEN_OWNER && (dirty & (1u << o->o2t)))
            (void)dr_conn_set_output(l->conn[i], l->data->img[o->o2t],
                                     dr_asm_info((dr_asm_t)o->o2t)->size);
    }
}

/* The robot's link facts derived from the connections. They count
 * milliseconds (age_ms) and packets: refreshed at most once a millisecond,
 * and at once when the link goes up or down. The loop turns many times a
 * millisecond with many robots (a wake-up per robot's burst, a turn per
 * Modbus request), and refreshing every robot at every turn grew like N^2.
 * Explicit mode is refreshed at every turn: it also notices a silent robot
 * here. */
#define STATUS_US 1000u

static void update_status(gw_link_t *l, uint64_t now)
{
    gw_robot_link_t *st = &l->data->link;
    uint64_t oldest = UINT64_MAX;
    if (l->cfg.mode == GW_MODE_IMPLICIT && !l->status_now && now >= l->status_us &&
        now - l->status_us < STATUS_US)
        return;
    l->status_us = now;
    l->status_now = false;
    /* A packet that repeats the last data (same CIP sequence count) calls
     * no on_data, yet says the data is current: age goes by the last
     * packet the connection took, which is on the same monotonic clock. */
    if (l->cfg.mode == GW_MODE_IMPLICIT)
        for (unsigned i = 0; i < NPAIRS; i++) {
            uint64_t t = l->conn[i] ? dr_conn_stats(l->conn[i])->last_rx_us : 0;
            for (unsigned a = 0; a < DR_ASM_COUNT; a++)
                if (slot_has(l, i, (dr_asm_t)a) && t > l->last_rx_us[a])
                    l->last_rx_us[a] = t;
        }
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if ((l->t2o_planned & (1u << a)) && l->last_rx_us[a] < oldest)
            oldest = l->last_rx_us[a];
    /* `now` was taken before this tick processed the client, so data
     * may be younger than it: that is age 0, not a wrapped-around age of
     * 584,000 years (which flapped explicit links down as timed out and
     * showed data_fresh 0, data_age 65535 for a moment). */
    uint64_t since = oldest == 0 ? l->start_us : oldest;
    uint64_t age = now > since ? now - since : 0;
    st->age_ms = (uint32_t)(age / 1000u > UINT32_MAX ? UINT32_MAX : age / 1000u);
    uint64_t limit;
    if (l->cfg.mode == GW_MODE_IMPLICIT) {
        uint32_t rx = l->rx_base, lost = l->lost_base, api = 0;
        uint32_t dseq = 0, daddr = 0, resyncs = 0;
        for (unsigned i = 0; i < NPAIRS; i++) {
            if (l->conn[i] == NULL)
                continue;
            const dr_conn_stats_t *cs = dr_conn_stats(l->conn[i]);
            rx += (uint32_t)cs->rx_packets;
            lost += (uint32_t)cs->rx_lost;
            st->conn_rx[i] = (uint32_t)cs->rx_packets;
            st->conn_lost[i] = (uint32_t)cs->rx_lost;
            dseq += st->conn_dropped_seq[i] = (uint32_t)cs->rx_dropped_seq;
            daddr += st->conn_dropped_addr[i] = (uint32_t)cs->rx_dropped_addr;
            resyncs += st->conn_resyncs[i] = (uint32_t)cs->rx_resyncs;
            if (cs->t2o_api_us > api)
                api = cs->t2o_api_us;
        }
        st->rx_packets = rx;
        st->lost_packets = lost;
        st->dropped_seq = dseq;
        st->dropped_addr = daddr;
        st->resyncs = resyncs;
        if (api != 0)
            st->rpi_ms = (uint16_t)((api + 999u) / 1000u);
        limit = (uint64_t)(api ? api : l->cfg.rpi_ms * 1000u) * (4u << l->cfg.timeout_mult);
    } else {
        limit = (uint64_t)l->cfg.rpi_ms * 1000u * 4u + (uint64_t)l->cfg.timeout_ms * 1000u;
        /* explicit: no reply for a while means the link is gone */
        if (l->up && oldest != UINT64_MAX && age > limit) {
            st->timeouts++;
            link_set_up(l, false, DR_ETIMEDOUT);
        }
    }
    st->fresh = oldest != 0 && age <= limit;
    st->link_state = l->up ? 2 : (dr_client_ready(l->client) ? 1 : 0);
    st->ever_up = st->ever_up || l->up;
}

void gw_link_tick(gw_link_t *l, uint64_t now, bool busy)
{
    if (l->cfg.mode == GW_MODE_EXPLICIT) {
        explicit_poll(l, now);
        if (!dr_client_ready(l->client)) /* why the session failed, if it did */
            link_set_up(l, false, l->sess_why != DR_OK ? l->sess_why : DR_ESESSION);
        process(l);
    } else if (now >= dr_client_next_deadline(l->client)) {
        dr_client_process_ready(l->client, NULL, 0); /* timers; no socket is ready */
        settle(l);
    } else if (busy && l->port != NULL && now - l->port->read_us >= PORT_POLL_US) {
        /* Implicit mode, nothing due: the client's descriptors (its TCP
         * socket and timer) and the shared UDP port are in the loop and
         * processed when ready, so a turn of the loop (with one client:
         * every Modbus request) need not cost two receives that find
         * nothing. Only the port is read, at most every PORT_POLL_US: epoll
         * reports it behind every ready Modbus client, and robot data must
         * not wait for all of them. */
        dr_udp_port_process(l->port->port);
        l->port->read_us = now;
    }
    update_status(l, now);
}

uint64_t gw_link_next_deadline(const gw_link_t *l)
{
    uint64_t d = dr_client_next_deadline(l->client);
    if (l->cfg.mode == GW_MODE_EXPLICIT && l->next_poll_us < d)
        d = l->next_poll_us;
    return d;
}

int gw_link_slot_asm(unsigned i)
{
    return i < NPAIRS ? (int)slot_t2o[i] : -1;
}

bool gw_link_up(const gw_link_t *l)
{
    return l->up;
}

const gw_robot_config_t *gw_link_config(const gw_link_t *l)
{
    return &l->cfg;
}
