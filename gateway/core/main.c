/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd: keeps the robots' assemblies live over EtherNet/IP and serves
 * them to its northbound sides (north.h; which ones: the side list,
 * gateway/sides.h). One thread, one epoll loop. It names no side: what a
 * side does for the command line (--print-map, status, --check-config) is
 * one of its operations.
 */
#include <errno.h>
#include <getopt.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <systemd/sd-daemon.h>

#include "common/ev.h"
#include "core/config.h"
#include "core/link.h"
#include "core/log.h"
#include "core/north.h"
#include "core/report.h"
#include "core/robot.h"
#include "core/write.h"

#ifndef DRGATE_VERSION
#define DRGATE_VERSION "0.0.0"
#endif
#define DEFAULT_CONFIG "/etc/drgate/drgatewayd.ini"
#define EX_CONFIG 78
#define TICK_US 100000u /* status block refresh: 10 Hz */

typedef struct {
    gw_config_t cfg;
    ev_loop_t loop; /* common/ev.c: epoll_pwait2 where the kernel has it */
    gw_robot_t robots[GW_MAX_ROBOTS]; /* by position in cfg.robot */
    gw_link_t *links[GW_MAX_ROBOTS];
    gw_link_ports_t *ports; /* the links' shared UDP ports */
    gw_north_env_t env;     /* what the northbound sides see of the daemon */
    void *side[GW_NORTH_SIDES]; /* by gw_north_sides[]; NULL: not running */
    bool sides_quiet; /* reload: old links close unheard by the new sides */
    bool stop, reload;
    const void *aside; /* a side waiting in wait_aside: not ticked meanwhile */
    uint64_t start_us, next_tick_us, next_beat_us;
    uint64_t watchdog_us; /* systemd watchdog period (0: off) */
    bool notify;          /* under systemd (NOTIFY_SOCKET): STATUS= lines */
    uint64_t last_notify_us;
    char status_line[1024]; /* the last STATUS= sent to systemd */
    uint16_t generation;
    uint32_t serial; /* the last robot's (gw_robot_t serial) */
    int exit_status; /* 0 after a signal, 1 after a failure */
    gw_lag_t lag;    /* how late the loop woke up (report.h) */
} gw_t;

static gw_t G; /* the daemon's state: large, one per process */

/* ---- hooks -------------------------------------------------------------------- */

/* A northbound side wrote O->T images of a robot. */
static void outputs_changed(void *user, unsigned robot, unsigned dirty)
{
    gw_t *g = user;
    if (robot < g->cfg.robot_count && g->links[robot] != NULL)
        gw_link_outputs_changed(g->links[robot], dirty);
}

static bool robot_link_up(void *user, unsigned robot)
{
    const gw_t *g = user;
    return robot < g->cfg.robot_count && gw_link_up(g->links[robot]);
}

static void fault(void *user, unsigned robot, bool latched)
{
    gw_t *g = user;
    if (robot < GW_MAX_ROBOTS)
        g->robots[robot].fault = latched;
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (g->side[i] != NULL)
            gw_north_sides[i]->on_fault(g->side[i], robot, latched);
}

static void on_link(void *user, unsigned robot, bool up, dr_status_t why)
{
    gw_t *g = user;
    (void)why;
    for (unsigned i = 0; i < GW_NORTH_SIDES && !g->sides_quiet; i++)
        if (g->side[i] != NULL)
            gw_north_sides[i]->on_link(g->side[i], robot, up);
}

static void on_data(void *user, unsigned robot, dr_asm_t a)
{
    gw_t *g = user;
    for (unsigned i = 0; i < GW_NORTH_SIDES && !g->sides_quiet; i++)
        if (g->side[i] != NULL)
            gw_north_sides[i]->on_data(g->side[i], robot, a);
}

static const gw_link_hooks_t link_hooks = {on_link, on_data, &G};

/* Every running side's summary (north.h) that has a label, in list order,
 * into out[max]: env->summaries. */
static unsigned summaries(void *user, gw_side_summary_t *out, unsigned max)
{
    const gw_t *g = user;
    unsigned n = 0;
    for (unsigned i = 0; i < GW_NORTH_SIDES && n < max; i++) {
        if (g->side[i] == NULL || gw_north_sides[i]->summary == NULL)
            continue;
        memset(&out[n], 0, sizeof out[n]);
        gw_north_sides[i]->summary(g->side[i], &out[n]);
        if (out[n].label[0] != '\0')
            n++;
    }
    return n;
}

/* systemd's STATUS= (systemctl status shows it) when it changes: each
 * robot's link in words, as drgatewayd status says it, and each side's
 * brief from its summary (the Modbus clients, MQTT). */
static void notify_status(gw_t *g)
{
    char line[sizeof g->status_line];
    static gw_side_summary_t sides[GW_NORTH_SIDES];
    unsigned n = summaries(g, sides, GW_NORTH_SIDES);
    gw_json_t j;
    gw_json_init(&j, line, sizeof line);
    gw_json_str(&j, "STATUS=");
    gw_report_notify(&j, g->robots, g->cfg.robot_count, sides, n);
    if (j.full || strcmp(line, g->status_line) == 0)
        return;
    memcpy(g->status_line, line, j.len + 1);
    sd_notify(0, line);
}

/* ---- what the console is told (north.h: env->report, env->metrics) ---------- */

/* "modbus": {...}, ...: each running side's member, commas between (the
 * caller writes the braces around them). */
/* One member per running side that says something (op, or robot_op for
 * robot `robot`), commas between. */
static void each_side(const gw_t *g, gw_json_t *j, bool per_robot, unsigned robot)
{
    bool first = true;
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++) {
        const gw_north_ops_t *op = gw_north_sides[i];
        if (g->side[i] == NULL || (per_robot ? op->robot_report == NULL : op->report == NULL))
            continue;
        size_t at = j->len;
        if (!first)
            gw_json_str(j, ",");
        size_t mark = j->len;
        if (per_robot)
            op->robot_report(g->side[i], robot, j);
        else
            op->report(g->side[i], j);
        if (j->len == mark && !j->full) { /* nothing to say: no comma either */
            j->len = at;
            j->buf[at] = '\0';
        } else {
            first = false;
        }
    }
}

static void report(void *user, gw_json_t *j)
{
    each_side(user, j, false, 0);
}

static void robot_sides(void *user, unsigned robot, gw_json_t *j)
{
    each_side(user, j, true, robot);
}

/* /api/v1/robots/NAME/map: from the first side that has a map. */
static bool map(void *user, gw_json_t *j, unsigned robot)
{
    const gw_t *g = user;
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (gw_north_sides[i]->map_json != NULL)
            return gw_north_sides[i]->map_json(&g->cfg, robot, j);
    return false;
}

/* /api/v1/SIDE/PATH: the running side of that name, if it has an api. */
static bool side_api(void *user, const char *side, const char *path, gw_json_t *j)
{
    const gw_t *g = user;
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (strcmp(gw_north_sides[i]->name, side) == 0)
            return g->side[i] != NULL && gw_north_sides[i]->api != NULL &&
                   gw_north_sides[i]->api(g->side[i], path, j);
    return false;
}

static bool map_csv(void *user, gw_json_t *j, unsigned robot)
{
    const gw_t *g = user;
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (gw_north_sides[i]->map_csv != NULL)
            return gw_north_sides[i]->map_csv(&g->cfg, robot, j);
    return false;
}

static void metrics(void *user, gw_prom_t *m)
{
    const gw_t *g = user;
    gw_prom_family(m, "drgate_info", GW_PROM_GAUGE, "The gateway's version (always 1)");
    gw_prom_label_t v = {"version", DRGATE_VERSION};
    gw_prom_sample(m, "drgate_info", &v, 1, 1);
    gw_prom_one(m, "drgate_uptime_seconds", GW_PROM_GAUGE, "Seconds since the daemon started",
                (double)(ev_now_us() - g->start_us) / 1e6);
    gw_prom_one(m, "drgate_config_generation", GW_PROM_GAUGE,
                "Configuration generation: +1 at every reload that was applied", g->generation);
    gw_prom_one(m, "drgate_log_events_total", GW_PROM_COUNTER,
                "Lines the daemon logged (at its log level)", (double)(gw_log_ring_total() + gw_log_writes_total()));
    gw_lag_metrics(m, &g->lag);
    gw_report_robot_metrics(m, g->robots, g->cfg.robot_count);
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (g->side[i] != NULL && gw_north_sides[i]->metrics != NULL)
            gw_north_sides[i]->metrics(g->side[i], m);
}

/* ---- status block and timers ------------------------------------------------- */

/* Side i waits in wait_aside: not ticked, refreshed or asked its deadline. */
static bool aside(const gw_t *g, unsigned i)
{
    return g->aside != NULL && g->side[i] == g->aside;
}

static void tick(gw_t *g, uint64_t now, bool busy)
{
    for (unsigned r = 0; r < g->cfg.robot_count; r++)
        gw_link_tick(g->links[r], now, busy);
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (!aside(g, i))
            gw_north_sides[i]->tick(g->side[i], now);
    if (now < g->next_tick_us)
        return;
    g->next_tick_us = now + TICK_US;
    gw_log_flush(now); /* suppressed counts whose 10 s are over */
    bool beat = now >= g->next_beat_us;
    if (beat)
        g->next_beat_us = now + 1000000u;
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
        if (!aside(g, i))
            gw_north_sides[i]->refresh(g->side[i]);
    if (beat && g->notify)
        notify_status(g); /* once a second, and only for systemd */
    for (unsigned r = 0; r < g->cfg.robot_count; r++) {
        gw_robot_t *rb = &g->robots[r];
        rb->uptime_s = (uint32_t)((now - g->start_us) / 1000000u);
        rb->generation = g->generation;
        if (beat)
            rb->heartbeat++;
    }
}

static uint64_t next_deadline(const gw_t *g)
{
    uint64_t d = g->next_tick_us;
    for (unsigned r = 0; r < g->cfg.robot_count; r++) {
        uint64_t x = gw_link_next_deadline(g->links[r]);
        if (x < d)
            d = x;
    }
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++) {
        if (aside(g, i))
            continue;
        uint64_t x = gw_north_sides[i]->deadline(g->side[i]);
        if (x < d)
            d = x;
    }
    return d;
}

/* ---- the wait ---------------------------------------------------------------------- */

/* Microseconds (the daemon's clock) as the loop's nanoseconds. */
static uint64_t deadline_ns(uint64_t us)
{
    return us < UINT64_MAX / 1000u ? us * 1000u : UINT64_MAX;
}

/* Tell systemd we are alive, but only while the loop keeps its timing. */
static void notify_watchdog(gw_t *g, uint64_t now)
{
    if (g->watchdog_us == 0 || now - g->last_notify_us < g->watchdog_us / 2u)
        return;
    g->last_notify_us = now;
    sd_notify(0, "WATCHDOG=1");
}

/* ---- set-up, reload, shutdown ---------------------------------------------- */

static void on_signal(void *obj, int signo)
{
    gw_t *g = obj;
    if (signo == SIGHUP)
        g->reload = true;
    else
        g->stop = true;
}

/* The robots before anything serves them: the sides set up their own
 * state for each at create. */
static void init_robots(gw_t *g)
{
    for (unsigned r = 0; r < g->cfg.robot_count; r++) {
        gw_robot_init(&g->robots[r], g->cfg.robot[r].name, ++g->serial);
        g->robots[r].generation = g->generation;
        gw_write_policy_set(&g->robots[r], &g->cfg, r);
    }
}

/* The default originator serial comes from /etc/machine-id: one that is
 * not a machine's own (an image that never booted, a file emptied to
 * clone the image) gives every such box the same serials, and they take
 * each other's connections. Said once at start when a robot uses the
 * default; duplicates across boxes cannot be seen from here
 * (docs/deployment.md). */
static void check_machine_id(const gw_config_t *cfg)
{
    bool derived = false;
    for (unsigned r = 0; r < cfg->robot_count; r++)
        derived |= cfg->robot[r].originator_serial == 0;
    if (!derived)
        return;
    char line[256] = "";
    FILE *f = fopen("/etc/machine-id", "r");
    if (f != NULL) {
        if (fgets(line, (int)sizeof line, f) == NULL)
            line[0] = '\0';
        (void)fclose(f);
    }
    const char *why = gw_machine_id_problem(line);
    if (why != NULL)
        gw_log(GW_LOG_WARNING,
               "/etc/machine-id is %s: the default originator serials come from it (or the "
               "host name), so boxes made from the same image share them and take over each "
               "other's robot connections; regenerate it (rm /etc/machine-id && "
               "systemd-machine-id-setup) or set originator_serial for each robot",
               why);
}

static bool start_links(gw_t *g)
{
    check_machine_id(&g->cfg);
    for (unsigned r = 0; r < g->cfg.robot_count; r++) {
        g->links[r] = gw_link_new(&g->cfg.robot[r], r, &g->robots[r], g->loop.epfd, g->ports,
                                  &link_hooks);
        if (g->links[r] == NULL)
            return false;
    }
    return true;
}

/* A failure the daemon cannot recover from: stop, and exit non-zero so
 * that systemd's Restart=on-failure brings it back. */
static void fail_stop(gw_t *g)
{
    g->stop = true;
    g->exit_status = 1;
}

/* SIGHUP: a new config that does not validate, or whose new robots or GPIO
 * lines cannot be started, is refused and the running one keeps going.
 * Robots whose section did not change keep their connection and data.
 * Everything that can fail is done before anything running is changed. */
static void reload(gw_t *g)
{
    static gw_config_t next;
    static gw_robot_t robots[GW_MAX_ROBOTS];
    char err[GW_CONFIG_ERR_SIZE];
    g->reload = false;
    if (!gw_config_load(g->cfg.path, &next, err, sizeof err)) {
        gw_log(GW_LOG_ERROR, "reload refused, keeping the running configuration: %s", err);
        return;
    }
    gw_link_t *links[GW_MAX_ROBOTS] = {NULL};
    bool kept[GW_MAX_ROBOTS] = {false}, fresh[GW_MAX_ROBOTS] = {false};
    memset(robots, 0, sizeof robots);
    for (unsigned n = 0; n < next.robot_count; n++)
        for (unsigned o = 0; o < g->cfg.robot_count; o++)
            if (!kept[o] && strcmp(next.robot[n].name, g->cfg.robot[o].name) == 0 &&
                gw_robot_config_same_link(&next.robot[n], &g->cfg.robot[o])) {
                robots[n] = g->robots[o]; /* its data, link facts and serial */
                links[n] = g->links[o];
                kept[o] = true;
            }
    /* New and changed robots first: one that cannot start (its UDP port
     * taken, say) refuses the reload while the old links still run. */
    uint32_t serial = g->serial;
    for (unsigned n = 0; n < next.robot_count; n++) {
        if (links[n] != NULL)
            continue;
        /* No data reaches it before the sides have committed (no turn of
         * the loop in between): they set it up then (clear_while_down). */
        gw_robot_init(&robots[n], next.robot[n].name, ++serial);
        for (unsigned o = 0; o < g->cfg.robot_count; o++)
            if (!kept[o] && strcmp(next.robot[n].name, g->cfg.robot[o].name) == 0)
                gw_robot_carry_over(&robots[n], &g->robots[o]); /* a changed one */
        links[n] = gw_link_new(&next.robot[n], n, &robots[n], g->loop.epfd, g->ports, &link_hooks);
        fresh[n] = true;
        if (links[n] == NULL) {
            gw_log(GW_LOG_ERROR, "reload refused, keeping the running configuration: "
                   "robot %s cannot be started", next.robot[n].name);
            for (unsigned k = 0; k < n; k++)
                if (fresh[k])
                    gw_link_free(links[k], "reload refused");
            return;
        }
    }
    /* The northbound sides next, in list order: one that refuses refuses
     * the whole reload, and those asked before it drop what they made. */
    void *out[GW_NORTH_SIDES] = {NULL};
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++) {
        gw_north_reload_t st =
            gw_north_sides[i]->prepare(g->side[i], &next, &g->env, &out[i], err, sizeof err);
        if (st == GW_NORTH_OK)
            continue;
        if (st == GW_NORTH_REFUSED)
            gw_log(GW_LOG_ERROR, "reload refused, keeping the running configuration: %s", err);
        else
            gw_log(GW_LOG_ERROR, "reload: %s: stopping", err);
        for (unsigned k = 0; k < i; k++)
            gw_north_sides[k]->abort(g->side[k], out[k]);
        g->sides_quiet = true;
        for (unsigned n = 0; n < next.robot_count; n++)
            if (fresh[n])
                gw_link_free(links[n], "reload refused");
        g->sides_quiet = false;
        if (st == GW_NORTH_BROKEN)
            fail_stop(g);
        return;
    }
    /* Closing an old link reports it down under its old index: the sides
     * (set up for the new robots) must not hear it. */
    g->sides_quiet = true;
    for (unsigned o = 0; o < g->cfg.robot_count; o++)
        if (!kept[o]) {
            gw_log(GW_LOG_INFO, "reload: robot %s changed or removed: closing its link",
                   g->cfg.robot[o].name);
            gw_link_free(g->links[o], "configuration reloaded: robot changed or removed");
        }
    g->sides_quiet = false;
    g->cfg = next;
    memcpy(g->robots, robots, sizeof robots);
    memset(g->links, 0, sizeof g->links);
    g->generation++;
    g->serial = serial;
    if (gw_config_keeps_log(&g->cfg))
        gw_log_ring_keep(true); /* a console from now on: its log starts here */
    for (unsigned r = 0; r < g->cfg.robot_count; r++) {
        g->robots[r].generation = g->generation;
        gw_write_policy_set(&g->robots[r], &g->cfg, r);
        g->links[r] = links[r];
        gw_link_set_robot(links[r], r, &g->robots[r]);
    }
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++) {
        g->side[i] = gw_north_sides[i]->commit(g->side[i], out[i], &g->env);
        if (g->side[i] == NULL) {
            fail_stop(g);
            return;
        }
    }
    gw_log(GW_LOG_INFO, "configuration %s reloaded (generation %u)", g->cfg.path, g->generation);
    sd_notify(0, "READY=1");
}

static void free_sides(gw_t *g)
{
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++) {
        if (g->side[i] != NULL)
            gw_north_sides[i]->free(g->side[i]);
        g->side[i] = NULL;
    }
}

/* One turn of the loop: wait for a descriptor or the next deadline (no
 * later than until_us), then what is due. False if the wait failed (the
 * daemon stops). */
static bool turn(gw_t *g, uint64_t until_us)
{
    uint64_t due = next_deadline(g);
    int n = ev_run(&g->loop, deadline_ns(due < until_us ? due : until_us));
    if (n < 0) {
        gw_log(GW_LOG_ERROR, "epoll_wait: %s", strerror(errno));
        g->exit_status = 1;
        g->stop = true;
        return false;
    }
    uint64_t now = ev_now_us();
    /* A deadline was due: how late did we wake up? (The first turn's
     * tick is due at 0, not late.) */
    if (now >= due && due >= g->start_us)
        gw_lag_observe(&g->lag, now - due);
    tick(g, now, n > 1);
    notify_watchdog(g, now);
    gw_link_ports_flush(g->ports);
    return true;
}

static void aside_ready(void *obj, uint32_t events)
{
    (void)events;
    *(bool *)obj = true;
}

/* env->wait_aside (north.h): the loop's turns without `self`, until fd is
 * readable, until_us passes or the daemon is to stop. A reload waits for
 * the outer turn; a second side waiting at once is refused. */
static bool wait_aside(void *user, const void *self, int fd, uint64_t until_us)
{
    gw_t *g = user;
    bool ready = false;
    ev_t ev = {aside_ready, &ready, -1, 0};
    if (g->aside != NULL || !ev_watch(g->loop.epfd, &ev, fd, EPOLLIN))
        return false;
    g->aside = self;
    while (!ready && !g->stop && ev_now_us() < until_us && turn(g, until_us))
        ;
    g->aside = NULL;
    ev_unwatch(g->loop.epfd, &ev);
    return ready;
}

/* Every side from the configuration, in list order; false (logged) if
 * one cannot start: those started are freed. */
static bool start_sides(gw_t *g)
{
    char err[GW_CONFIG_ERR_SIZE];
    g->env = (gw_north_env_t){.epfd = g->loop.epfd,
                              .cfg = &g->cfg,
                              .robots = g->robots,
                              .outputs_changed = outputs_changed,
                              .link_up = robot_link_up,
                              .fault = fault,
                              .user = g,
                              .version = DRGATE_VERSION,
                              .report = report,
                              .metrics = metrics,
                              .summaries = summaries,
                              .map = map,
                              .map_csv = map_csv,
                              .side_api = side_api,
                              .robot_sides = robot_sides,
                              .wait_aside = wait_aside};
    for (unsigned i = 0; i < GW_NORTH_SIDES; i++) {
        g->side[i] = gw_north_sides[i]->create(&g->env, err, sizeof err);
        if (g->side[i] == NULL) {
            gw_log(GW_LOG_ERROR, "%s", err);
            free_sides(g);
            return false;
        }
    }
    return true;
}

static void shutdown_all(gw_t *g)
{
    sd_notify(0, "STOPPING=1");
    /* first: the cell is safe whatever follows */
    for (unsigned i = GW_NORTH_SIDES; i-- > 0;)
        if (g->side[i] != NULL)
            gw_north_sides[i]->safe(g->side[i]);
    for (unsigned r = 0; r < g->cfg.robot_count; r++)
        gw_link_free(g->links[r], "gateway stopping"); /* Forward Close, UnRegisterSession */
    free_sides(g);
    gw_log_flush(UINT64_MAX); /* suppressed counts before the last line */
    gw_log(GW_LOG_INFO, "stopped");
}

/* The loop's own descriptors, last: nothing is left open at exit (valgrind
 * --track-fds in make check-valgrind checks it). */
static int close_loop(gw_t *g, int status)
{
    gw_link_ports_free(g->ports); /* after the last link (shutdown_all) */
    g->ports = NULL;
    ev_close(&g->loop);
    return status;
}

static int run(gw_t *g)
{
    static const int signals[] = {SIGTERM, SIGINT, SIGHUP};
    if (!ev_open(&g->loop, EV_FINE) ||
        !ev_signals(&g->loop, signals, sizeof signals / sizeof signals[0], on_signal, g)) {
        gw_log(GW_LOG_ERROR, "cannot set up the event loop: %s", strerror(errno));
        return close_loop(g, 1);
    }
    g->start_us = ev_now_us();
    g->ports = gw_link_ports_new();
    if (g->ports == NULL) {
        gw_log(GW_LOG_ERROR, "out of memory");
        return close_loop(g, 1);
    }
    /* With epoll_pwait2 the loop wakes up at the robots' O->T deadlines
     * itself, and their clients need no timer descriptor each: one
     * timerfd_settime per robot per RPI fewer. Without it (a kernel
     * before 5.11, valgrind 3.19), each client keeps its own. */
    gw_link_ports_loop_timer(g->ports, g->loop.fine);
    init_robots(g);
    if (!start_sides(g))
        return close_loop(g, 1);
    if (!start_links(g)) {
        shutdown_all(g);
        return close_loop(g, 1);
    }
    const char *ns = getenv("NOTIFY_SOCKET");
    g->notify = ns != NULL && ns[0] != '\0';
    uint64_t wd = 0;
    if (sd_watchdog_enabled(0, &wd) > 0)
        g->watchdog_us = wd;
    sd_notify(0, "READY=1");
    gw_log(GW_LOG_INFO, "drgatewayd %s running: %s", DRGATE_VERSION, gw_config_brief(&g->cfg));

    while (!g->stop && turn(g, UINT64_MAX)) {
        if (g->reload)
            reload(g);
    }
    shutdown_all(g);
    return close_loop(g, g->exit_status);
}

/* ---- command line --------------------------------------------------------------- */

static void usage(FILE *out)
{
    fprintf(out,
            "usage: drgatewayd [-c FILE] [-v]\n"
            "       drgatewayd status [-c FILE]\n"
            "       drgatewayd --check-config FILE\n"
            "       drgatewayd [-c FILE] --print-map [--json | --markdown] [FILTER]\n"
            "       drgatewayd --help-config SECTION\n"
            "       drgatewayd --print-errors [--markdown]\n"
            "Serves Doosan robots' EtherNet/IP assemblies as Modbus TCP registers, as a\n"
            "Modbus RTU slave on serial lines, as GPIO lines, and publishes them to an\n"
            "MQTT broker ([mqtt], docs/mqtt.md).\n\n"
            "  -c, --config FILE      configuration (default " DEFAULT_CONFIG ")\n"
            "      --check-config FILE  validate FILE and exit (0 valid, 78 invalid)\n"
            "  status                 the running daemon's summary from its console ([http]):\n"
            "                         exit 0 every robot linked, 1 one is not, 3 unreachable\n"
            "      --print-map        print the Modbus register map and exit: with -c, each\n"
            "                         robot's own map too; FILTER: rows whose name has it\n"
            "      --print-errors     print every value of the status block's last_error\n"
            "                         (IR 12, with IR 30) and exit\n"
            "      --json, --markdown   format of --print-map (--print-errors: --markdown)\n"
            "      --help-config SECTION  print the keys of [SECTION] (its keyword, such as\n"
            "                         robot) as a Markdown table and exit\n"
            "  -v, --verbose          log debug messages\n"
            "  -h, --help             this help\n"
            "  -V, --version          version\n\n"
            "Signals: SIGHUP reloads the configuration (a bad one is refused and the\n"
            "running one kept), SIGTERM/SIGINT put GPIO outputs to their safe values,\n"
            "close the robot connections and exit 0.\n"
            "Exit status: 0 stopped by a signal, 1 runtime error, 2 usage error,\n"
            "78 configuration error (EX_CONFIG). See drgatewayd(8).\n");
}

int main(int argc, char **argv)
{
    enum { OPT_CHECK = 256, OPT_MAP, OPT_ERRORS, OPT_JSON, OPT_MD, OPT_HELP_CONFIG };
    static const struct option opts[] = {
        {"config", required_argument, NULL, 'c'},
        {"check-config", required_argument, NULL, OPT_CHECK},
        {"print-map", no_argument, NULL, OPT_MAP},
        {"print-errors", no_argument, NULL, OPT_ERRORS},
        {"json", no_argument, NULL, OPT_JSON},
        {"markdown", no_argument, NULL, OPT_MD},
        {"help-config", required_argument, NULL, OPT_HELP_CONFIG},
        {"verbose", no_argument, NULL, 'v'},
        {"help", no_argument, NULL, 'h'},
        {"version", no_argument, NULL, 'V'},
        {NULL, 0, NULL, 0},
    };
    const char *config = DEFAULT_CONFIG, *check = NULL, *help_config = NULL;
    bool print_map = false, print_errors = false, verbose = false, config_given = false;
    gw_print_fmt_t fmt = GW_PRINT_TEXT;
    int c;
    while ((c = getopt_long(argc, argv, "c:vhV", opts, NULL)) != -1) {
        switch (c) {
        case 'c': config = optarg; config_given = true; break;
        case OPT_CHECK: check = optarg; break;
        case OPT_MAP: print_map = true; break;
        case OPT_ERRORS: print_errors = true; break;
        case OPT_JSON: fmt = GW_PRINT_JSON; break;
        case OPT_MD: fmt = GW_PRINT_MARKDOWN; break;
        case OPT_HELP_CONFIG: help_config = optarg; break;
        case 'v': verbose = true; break;
        case 'h': usage(stdout); return 0;
        case 'V': printf("drgatewayd %s\n", DRGATE_VERSION); return 0;
        default: usage(stderr); return 2;
        }
    }
    if (optind < argc && strcmp(argv[optind], "status") == 0) {
        if (optind + 1 != argc || check != NULL || print_map || print_errors || help_config ||
            fmt == GW_PRINT_MARKDOWN) {
            fprintf(stderr, "drgatewayd: status takes -c FILE and --json only\n");
            return 2;
        }
        for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
            if (gw_north_sides[i]->status_command != NULL)
                return gw_north_sides[i]->status_command(config, fmt == GW_PRINT_JSON);
        fprintf(stderr, "drgatewayd: status: no side of this build answers it\n");
        return 2;
    }
    const char *map_filter = NULL;
    if (print_map && optind + 1 == argc)
        map_filter = argv[optind++]; /* --print-map joint_state.position */
    if (optind != argc) {
        fprintf(stderr, "drgatewayd: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    if (help_config != NULL) {
        if (gw_config_print_keys(stdout, help_config))
            return 0;
        fprintf(stderr, "drgatewayd: --help-config: no section [%s] (allowed: %s)\n",
                help_config, gw_config_sections());
        return 2;
    }
    if (print_errors) {
        if (fmt == GW_PRINT_JSON || print_map) {
            fprintf(stderr, "drgatewayd: --print-errors takes --markdown only, and no --print-map\n");
            return 2;
        }
        for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
            if (gw_north_sides[i]->print_errors != NULL)
                gw_north_sides[i]->print_errors(stdout, fmt);
        return 0;
    }
    if (print_map) {
        /* with -c: each robot's own map too */
        char perr[GW_CONFIG_ERR_SIZE];
        bool with_cfg = config_given;
        if (with_cfg && !gw_config_load(config, &G.cfg, perr, sizeof perr)) {
            fprintf(stderr, "drgatewayd: %s\n", perr);
            return EX_CONFIG;
        }
        for (unsigned i = 0; i < GW_NORTH_SIDES; i++)
            if (gw_north_sides[i]->print_map != NULL)
                gw_north_sides[i]->print_map(stdout, fmt, map_filter, with_cfg ? &G.cfg : NULL);
        return 0;
    }
    char err[GW_CONFIG_ERR_SIZE];
    if (check != NULL) {
        bool ok = gw_config_load(check, &G.cfg, err, sizeof err);
        for (unsigned i = 0; ok && i < GW_NORTH_SIDES; i++)
            if (gw_north_sides[i]->check_config != NULL)
                ok = gw_north_sides[i]->check_config(&G.cfg, err, sizeof err);
        if (!ok) {
            fprintf(stderr, "drgatewayd: %s\n", err);
            return EX_CONFIG;
        }
        printf("%s: valid (%s)\n", check, gw_config_brief(&G.cfg));
        return 0;
    }
    if (!gw_config_load(config, &G.cfg, err, sizeof err)) {
        fprintf(stderr, "drgatewayd: %s\n", err);
        return EX_CONFIG;
    }
    gw_log_level_t level = GW_LOG_INFO;
    if (G.cfg.log_level[0] != '\0')
        (void)gw_log_level_parse(G.cfg.log_level, &level);
    gw_log_set_level(verbose ? GW_LOG_DEBUG : level);
    gw_log_ring_keep(gw_config_keeps_log(&G.cfg));
    return run(&G);
}
