/* SPDX-License-Identifier: MIT */
/*
 * drcli watch: read fields again and again. On a terminal the values are
 * redrawn in place and those that changed since the previous sample are
 * highlighted; otherwise (a pipe, a file) each sample is one line, or one
 * JSON object per line with --json. Ctrl-C (SIGINT) or SIGTERM ends it
 * cleanly with status 0.
 */
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <time.h>
#include <unistd.h>

#include "cmd.h"
#include "error.h"
#include "fields.h"
#include "net.h"
#include "opt.h"
#include "util.h"
#include "drgate/text.h"

static const char watch_help[] =
    "usage: drcli [-H HOST] watch [OPTION...] [FIELD...]\n"
    "\n"
    "Reads the FIELDs (full paths or assembly names, as for get; all fields of\n"
    "all ten assemblies by default) every interval, one request per assembly\n"
    "and sample, until Ctrl-C (exit status 0) or --count samples.\n"
    "\n"
    "On a terminal: the values are redrawn in place, `path = value unit`, and\n"
    "those that changed since the previous sample are shown in reverse video.\n"
    "Otherwise one line per sample: the UTC time, then `path=value` for each\n"
    "FIELD, values without units in a form `drcli set` accepts (masks in hex,\n"
    "robot_state by name). With --json: one JSON object per line, as get\n"
    "--json prints it.\n"
    "\n"
    "options:\n"
    "  -i, --interval MS   time between samples (default 500, 1..3600000); a\n"
    "                      sample that is late skips, it does not queue up\n"
    "  -c, --count N       stop after N samples\n"
    CLI_NET_HELP
    "  -h, --help          this text\n"
    "\n"
    "--raw does not apply. A failed read ends the watch with its exit status\n"
    "(3 network, 4 CIP); 2 for bad usage, nothing sent.\n"
    "\n"
    "example: drcli -H 192.168.137.100 watch io_state.robot_state io_state.cb_di\n";

static volatile sig_atomic_t stop_requested;

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

/* SIGINT and SIGTERM set the flag; without SA_RESTART they also cut the
 * wait between samples short. A request under way ends within the
 * client's timeout. */
static void catch_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
}

typedef struct {
    const char *cmd;
    cli_net_t net;
    cli_items_t items;
    cli_images_t im;
    char prev[CLI_ITEMS_MAX][64]; /* last values drawn on the terminal */
    int width;                    /* longest path */
    unsigned long interval_ms, count, sample;
    bool json, tty;
} watch_t;

/* ---- one sample ---------------------------------------------------------- */

/* A value in a form `drcli set` reads back: bits 0/1, masks in hex,
 * robot_state by name (or number if it has none), numbers as get prints. */
static void compact_value(const cli_images_t *im, dr_ref_t ref, char *out,
                          size_t size)
{
    dr_asm_t a = (dr_asm_t)ref.field->assembly;
    dr_value_t v;
    if (dr_field_get(im->img[a], dr_asm_info(a)->size, ref, &v) != DR_OK) {
        snprintf(out, size, "?");
        return;
    }
    const char *name = dr_robot_state_name((unsigned)v.u);
    if (ref.field->kind == DR_KIND_ENUM && name != NULL)
        snprintf(out, size, "%s", name);
    else if (ref.field->kind == DR_KIND_BITS && ref.elem < 0)
        snprintf(out, size, "0x%0*llx", (int)(ref.field->count + 3u) / 4,
                 (unsigned long long)v.u);
    else if (dr_text_format(ref, &v, 0, out, size) != DR_OK)
        snprintf(out, size, "?");
}

static void print_line(const watch_t *w)
{
    struct timespec ts;
    struct tm tm;
    char when[32];
    clock_gettime(CLOCK_REALTIME, &ts);
    gmtime_r(&ts.tv_sec, &tm);
    if (strftime(when, sizeof when, "%Y-%m-%dT%H:%M:%S", &tm) == 0)
        when[0] = '\0'; /* the array is indeterminate otherwise */
    printf("%s.%03ldZ", when, ts.tv_nsec / 1000000L);
    for (size_t i = 0; i < w->items.n; i++) {
        char path[64], value[64];
        dr_ref_path(w->items.ref[i], path, sizeof path);
        compact_value(&w->im, w->items.ref[i], value, sizeof value);
        printf(" %s=%s", path, value);
    }
    putchar('\n');
}

static int terminal_rows(void)
{
    struct winsize ws;
    if (ioctl(STDOUT_FILENO, TIOCGWINSZ, &ws) != 0 || ws.ws_row < 3)
        return 24;
    return ws.ws_row;
}

/* Redraw from the top left corner; as many fields as the terminal shows. */
static void draw(watch_t *w)
{
    struct timespec ts;
    struct tm tm;
    char when[16];
    clock_gettime(CLOCK_REALTIME, &ts);
    localtime_r(&ts.tv_sec, &tm);
    if (strftime(when, sizeof when, "%H:%M:%S", &tm) == 0)
        when[0] = '\0';
    printf("%s\033[H\033[1m%s\033[0m  every %lu ms  sample %lu  %s  (Ctrl-C quits)\033[K\n",
           w->sample == 1 ? "\033[?25l\033[2J" : "", w->net.where, w->interval_ms,
           w->sample, when);
    size_t shown = w->items.n, room = (size_t)terminal_rows() - 2u;
    if (shown > room)
        shown = room - 1u; /* keep a line to say how many are hidden */
    for (size_t i = 0; i < shown; i++) {
        char path[64], value[64];
        dr_ref_path(w->items.ref[i], path, sizeof path);
        cli_format_ref(&w->im, w->items.ref[i], DR_TEXT_UNIT, value, sizeof value);
        bool changed = w->sample > 1 && strcmp(value, w->prev[i]) != 0;
        printf("%-*s = %s%s%s\033[K\n", w->width, path, changed ? "\033[7m" : "",
               value, changed ? "\033[0m" : "");
        memcpy(w->prev[i], value, sizeof value);
    }
    if (shown < w->items.n)
        printf("... %zu more fields: name fewer, or enlarge the terminal\033[K\n",
               w->items.n - shown);
    printf("\033[J");
}

static int show_sample(watch_t *w)
{
    if (w->json)
        return cli_json_print_flags(w->cmd, cli_items_json(&w->items, &w->im),
                                    CLI_JSON_LINE);
    if (w->tty)
        draw(w);
    else
        print_line(w);
    return CLI_EXIT_OK;
}

/* ---- the loop ---------------------------------------------------------------- */

static void add_ms(struct timespec *t, unsigned long ms)
{
    t->tv_sec += (time_t)(ms / 1000u);
    t->tv_nsec += (long)(ms % 1000u) * 1000000L;
    if (t->tv_nsec >= 1000000000L) {
        t->tv_sec++;
        t->tv_nsec -= 1000000000L;
    }
}

static bool before(const struct timespec *a, const struct timespec *b)
{
    return a->tv_sec < b->tv_sec || (a->tv_sec == b->tv_sec && a->tv_nsec < b->tv_nsec);
}

/* Sleep until the next sample is due (from `next`, skipping samples that
 * are already late); returns early on a signal. */
static void wait_next(struct timespec *next, unsigned long interval_ms)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    add_ms(next, interval_ms);
    while (before(next, &now))
        add_ms(next, interval_ms);
    if (!stop_requested)
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, next, NULL);
}

static int loop(watch_t *w)
{
    struct timespec next;
    clock_gettime(CLOCK_MONOTONIC, &next);
    int rc = CLI_EXIT_OK;
    while (!stop_requested) {
        rc = cli_net_read(&w->net, &w->im);
        if (rc != CLI_EXIT_OK)
            break;
        w->sample++;
        rc = show_sample(w);
        if (rc != CLI_EXIT_OK || fflush(stdout) != 0 || ferror(stdout))
            break;
        if (w->count != 0 && w->sample >= w->count)
            break;
        wait_next(&next, w->interval_ms);
    }
    if (w->tty && w->sample > 0)
        printf("\033[0m\033[?25h");
    return rc;
}

/* ---- command ------------------------------------------------------------- */

/* Options and fields into *w; returns an exit code (or -1 after --help). */
static int parse(watch_t *w, int argc, char **argv, const cli_net_opts_t *lead,
                 dr_client_config_t *cfg)
{
    cli_net_opts_t o = *lead;
    bool help = false;
    const char *interval = NULL, *count = NULL;
    cli_opt_t opts[CLI_NET_NOPTS + 2];
    size_t nopts = cli_net_optv(&o, opts);
    opts[nopts++] = (cli_opt_t){"interval", 'i', NULL, &interval, NULL};
    opts[nopts++] = (cli_opt_t){"count", 'c', NULL, &count, NULL};
    int npos = cli_parse_opts(cli_cmd_watch.name, argc, argv, opts, nopts, &help);
    if (npos < 0)
        return CLI_EXIT_USAGE;
    if (help) {
        cli_print_help(&cli_cmd_watch);
        return -1;
    }
    w->interval_ms = 500;
    if (interval != NULL && !cli_parse_ulong(interval, 1, 3600000, &w->interval_ms))
        return cli_error(CLI_EXIT_USAGE, w->cmd,
                         "--interval '%s': expected milliseconds in 1..3600000", interval);
    if (count != NULL && !cli_parse_ulong(count, 1, 1000000000, &w->count))
        return cli_error(CLI_EXIT_USAGE, w->cmd,
                         "--count '%s': expected a number of samples in 1..1000000000",
                         count);
    int rc = cli_net_refuse(w->cmd, &o, true, false);
    if (rc == CLI_EXIT_OK)
        rc = cli_net_config(w->cmd, &o, cfg);
    if (rc != CLI_EXIT_OK)
        return rc;
    for (int i = 0; i < npos; i++)
        if (!cli_items_add_arg(w->cmd, &w->items, i + 1, argv[i], true))
            return CLI_EXIT_USAGE;
    for (unsigned a = 0; npos == 0 && a < DR_ASM_COUNT; a++)
        (void)cli_items_add_asm(&w->items, (dr_asm_t)a); /* all ten fit */
    w->json = o.json;
    return CLI_EXIT_OK;
}

static int run_watch(const char *cmd, int argc, char **argv,
                     const cli_net_opts_t *lead)
{
    static watch_t w;
    memset(&w, 0, sizeof w);
    w.cmd = cmd;
    dr_client_config_t cfg;
    int rc = parse(&w, argc, argv, lead, &cfg);
    if (rc != CLI_EXIT_OK)
        return rc < 0 ? CLI_EXIT_OK : rc;
    cli_items_want(&w.items, &w.im);
    for (size_t i = 0; i < w.items.n; i++) {
        char path[64];
        dr_ref_path(w.items.ref[i], path, sizeof path);
        if ((int)strlen(path) > w.width)
            w.width = (int)strlen(path);
    }
    w.tty = !w.json && isatty(STDOUT_FILENO);

    catch_signals(); /* from here on, Ctrl-C ends the watch with status 0 */
    rc = cli_net_connect(cmd, &cfg, &w.net);
    if (rc != CLI_EXIT_OK)
        return rc;
    rc = loop(&w);
    cli_net_close(&w.net);
    return rc;
}

const cli_cmd_t cli_cmd_watch = {
    "watch", "read fields repeatedly (in place on a terminal, lines when piped)",
    watch_help, run_watch, true,
};
