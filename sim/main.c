/* SPDX-License-Identifier: MIT */
/*
 * drsim: a simulated Doosan robot controller, as an EtherNet/IP adapter.
 *
 * One thread, one event loop (common/ev.c, the one drgatewayd has too).
 * Sockets: TCP listener and clients (encapsulation), UDP on the
 * encapsulation port (ListIdentity discovery), UDP on the Class 1 port
 * (O->T in, T->O out, one socket for all connections). The loop's timer
 * (EV_TIMER: one timerfd, armed at an absolute monotonic deadline) drives
 * everything timed: the robot model, T->O production, connection
 * timeouts, delayed replies and dropped sessions. SIGINT/SIGTERM come as
 * events of the loop too. The protocol itself is in adapter.c.
 */
#define _GNU_SOURCE /* accept4 */

#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "adapter.h"
#include "common/ev.h"
#include "log.h"

#define DRSIM_VERSION "1.0.0"
#define MAX_CLIENTS 64
/* Bytes a client may leave unread before it is dropped as too slow. */
#define CLIENT_OUT_CAP 16384u
/* Datagrams read per wake-up, so one busy socket cannot starve the rest. */
#define UDP_BURST 64
/* Replies and packets held back by --delay at any one time. */
#define DELAY_QUEUE_LEN 4096u

/* ---- options --------------------------------------------------------------- */

typedef struct {
    drsim_config_t cfg;
    uint64_t delay_ns;
    uint64_t drop_session_ns;
    dr_layout_kind_t layout;
    uint16_t input_instance, output_instance; /* 0: the layout's default */
} options_t;

static void usage(FILE *f)
{
    fputs(
"usage: drsim [OPTION]...\n"
"A simulated Doosan robot controller: an EtherNet/IP adapter that serves the\n"
"robot's ten assemblies over explicit messaging (TCP) and Class 1 I/O (UDP).\n"
"\n"
"Network:\n"
"  -a, --address ADDR        IPv4 address to listen on (default 0.0.0.0);\n"
"                            e.g. 127.0.0.2 to share a machine with a client\n"
"  -p, --tcp-port N          encapsulation port, TCP and UDP (default 44818)\n"
"  -u, --udp-port N          Class 1 I/O port (default 2222); announced to\n"
"                            originators in the Forward Open reply (0x8000)\n"
"  -i, --instance NAME=N     assembly instance for NAME (canonical name or\n"
"                            drN alias), repeatable; defaults 101..110; with\n"
"                            --layout combined or gpr_only, NAME is input or\n"
"                            output (defaults 100 and 150)\n"
"      --layout NAME         how the assemblies are offered: per_assembly (one\n"
"                            instance each, the default), combined (one T->O\n"
"                            instance of 476 bytes, the six T->O assemblies\n"
"                            back to back, and one O->T instance of 212\n"
"                            bytes) or gpr_only (the register assemblies\n"
"                            only: 200 bytes each way)\n"
"      --max-connections N   Class 1 connections at once, 1..64 (default 16)\n"
"\n"
"Robot:\n"
"      --no-echo             do not copy bit_in/int_in/float_in to\n"
"                            bit_out/int_out/float_out\n"
"      --seed N              seed for noise, drops, serial number, IDs (0)\n"
"      --still               stand still once booted: no motion, no noise, so\n"
"                            the data changes only with what is written\n"
"      --vendor-id N         the Identity object's vendor ID, 0..65535\n"
"                            (default 65535: no ODVA vendor; 1573 is Doosan\n"
"                            Robotics')\n"
"  SIGUSR1 raises the emergency stop, and clears it the next time;\n"
"  SIGUSR2 likewise the protective stop (robot_state EMERGENCY_STOP or\n"
"  SAFE_STOP, emergency_stopped or safety_stopped set; the arm holds)\n"
"\n"
"Adapter behaviours (what real adapters do, see docs/interop.md):\n"
"      --seq-on-change       advance the T->O CIP sequence count only when the\n"
"                            produced data changed (the encapsulation sequence\n"
"                            number still advances with every packet)\n"
"      --tick MS             produce at a coarser tick: the API is the RPI\n"
"                            rounded up to a multiple of MS (1..1000)\n"
"      --api-report actual|requested\n"
"                            the APIs the Forward Open reply states: those\n"
"                            produced at (default) or the RPIs requested\n"
"      --trailing-item       Forward Open replies (success and error) carry\n"
"                            one CPF item more than their item count says\n"
"                            (an echo of the request's 0x8001 item)\n"
"      --owner-hold SECONDS  free an exclusive owner whose O->T stopped after\n"
"                            this long (default: never, as OpENer). Until\n"
"                            then it is held: only the same vendor ID and\n"
"                            originator serial may take it over, others get\n"
"                            0x01/0x0106\n"
"      --clock-ppm PPM       drsim's clock runs PPM parts per million fast\n"
"                            (negative: slow), -100000..100000: T->O packets\n"
"                            every API x 1e6 / (1e6 + PPM), as from a real\n"
"                            adapter's crystal (-11000: 98.9 a second at 10 ms)\n"
"      --t2o-to-peer         send T->O to the TCP peer's address, taking only\n"
"                            the port from the Forward Open's 0x8001 item (as\n"
"                            OpENer does; default: the item's address too)\n"
"\n", f);
    /* two strings: C99 compilers need take only 4095 characters in one */
    fputs(
"Connection points (what a controller's EDS decides):\n"
"      --config-instance N   accept only configuration instance N in a\n"
"                            Forward Open; others are refused with 0x01/0x0129\n"
"                            (default: any)\n"
"      --input-only-heartbeat N\n"
"      --listen-only-heartbeat N\n"
"                            heartbeat connection point of input-only\n"
"                            (default 198) and listen-only (199) connections;\n"
"                            0: that kind is not offered. Another point is\n"
"                            refused with 0x01/0x012A; listen-only without an\n"
"                            owner or input-only connection of the same T->O\n"
"                            with 0x01/0x0119\n"
"\n"
"Fault injection:\n"
"      --drop PERCENT        drop that share of produced and consumed I/O\n"
"                            packets (deterministic for a given --seed)\n"
"      --delay MS            delay every reply and produced packet by MS\n"
"      --stop-producing-after SECONDS\n"
"                            stop sending T->O SECONDS after each Forward Open\n"
"      --refuse-forward-open STATUS\n"
"                            refuse every Forward Open with general status\n"
"                            0x01 and this extended status (e.g. 0x0113;\n"
"                            0x0109 adds the wanted size as a second word)\n"
"      --drop-session-after SECONDS\n"
"                            close each TCP connection SECONDS after accept\n"
"      --drop-t2o            accept Forward Opens but send no T->O packet, as\n"
"                            behind a firewall that drops UDP to the originator\n"
"      --no-large-forward-open\n"
"                            answer Large Forward Open (0x5B) with 0x08,\n"
"                            like a target that only knows 0x54\n"
"      --lose-forward-open-reply N\n"
"                            open the connection of the first N successful\n"
"                            Forward Opens but send no reply, as when the\n"
"                            reply is lost on the way back\n"
"      --no-get-assembly     answer Get_Attribute_Single and Get_Attributes_All\n"
"                            on an assembly instance with 0x08 (service not\n"
"                            supported), as an adapter whose assemblies are\n"
"                            reached only through I/O connections: drcli\n"
"                            probe then needs --open to find their sizes\n"
"      --refuse-identity     answer Get_Attributes_All on the Identity object\n"
"                            with 0x08 (service not supported); its single\n"
"                            attributes and ListIdentity still answer\n"
"\n"
"Other:\n"
"  -v, --verbose             log events to stderr; twice: every request\n"
"  -h, --help                show this help and exit\n"
"  -V, --version             show the version and exit\n"
"\n"
"SIGINT or SIGTERM stops drsim cleanly (SIGUSR1, SIGUSR2: see Robot). Exit status: 0 after a signal,\n"
"1 on a runtime error (e.g. a port in use), 2 on a usage error.\n"
"See drsim(1).\n", f);
}

static int parse_uint(const char *s, unsigned long min, unsigned long max,
                      unsigned long *out)
{
    char *end;
    errno = 0;
    if (s[0] == '-' || s[0] == '\0')
        return -1;
    unsigned long v = strtoul(s, &end, 0);
    if (errno != 0 || *end != '\0' || v < min || v > max)
        return -1;
    *out = v;
    return 0;
}

/* Seconds (fractions allowed, up to a day) as nanoseconds. */
static int parse_seconds(const char *s, uint64_t *ns)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno != 0 || end == s || *end != '\0' || !(v > 0.0) || v > 86400.0)
        return -1;
    *ns = (uint64_t)(v * 1e9);
    return 0;
}

static int parse_instance(const char *arg, options_t *o)
{
    drsim_config_t *cfg = &o->cfg;
    const char *eq = strchr(arg, '=');
    char name[32];
    unsigned long n;
    if (eq == NULL || (size_t)(eq - arg) >= sizeof name)
        return -1;
    memcpy(name, arg, (size_t)(eq - arg));
    name[eq - arg] = '\0';
    dr_asm_t a;
    bool in = strcmp(name, "input") == 0, out = strcmp(name, "output") == 0;
    if (parse_uint(eq + 1, 1, 0xFFFF, &n) != 0)
        return -1;
    if (in || out) {
        *(in ? &o->input_instance : &o->output_instance) = (uint16_t)n;
        return 0;
    }
    if (dr_asm_lookup(name, &a) != DR_OK)
        return -1;
    cfg->instance[a] = (uint16_t)n;
    return 0;
}

/* Instances must name one assembly each and stay clear of the heartbeat
 * connection points. */
static int check_instances(const drsim_config_t *cfg)
{
    const dr_layout_t *l = &cfg->layout;
    if (l->kind != DR_LAYOUT_PER_ASSEMBLY) {
        uint16_t pts[2] = {l->input.instance, l->output.instance};
        for (unsigned i = 0; i < 2; i++)
            if (pts[i] == cfg->hb_input_only || pts[i] == cfg->hb_listen_only) {
                fprintf(stderr, "drsim: instance %u is a heartbeat connection point\n",
                        (unsigned)pts[i]);
                return -1;
            }
        if (pts[0] == pts[1]) {
            fprintf(stderr, "drsim: input and output both use instance %u\n", (unsigned)pts[0]);
            return -1;
        }
    }
    for (unsigned a = 0; a < DR_ASM_COUNT && l->kind == DR_LAYOUT_PER_ASSEMBLY; a++) {
        uint16_t v = cfg->instance[a];
        if ((v == cfg->hb_input_only || v == cfg->hb_listen_only) && v != 0) {
            fprintf(stderr, "drsim: instance %u is a heartbeat connection point\n", v);
            return -1;
        }
        for (unsigned b = a + 1; b < DR_ASM_COUNT; b++)
            if (cfg->instance[b] == v) {
                fprintf(stderr, "drsim: %s and %s both use instance %u\n",
                        dr_asm_info((dr_asm_t)a)->name,
                        dr_asm_info((dr_asm_t)b)->name, v);
                return -1;
            }
    }
    if (cfg->hb_input_only != 0 && cfg->hb_input_only == cfg->hb_listen_only) {
        fprintf(stderr, "drsim: input-only and listen-only heartbeat are both %u\n",
                (unsigned)cfg->hb_input_only);
        return -1;
    }
    return 0;
}

enum {
    OPT_NO_ECHO = 256, OPT_SEED, OPT_DROP, OPT_DELAY, OPT_STOP_PRODUCING,
    OPT_REFUSE_FO, OPT_DROP_SESSION, OPT_MAX_CONNS, OPT_NO_LARGE_FO, OPT_NO_GET_ASM, OPT_LOSE_FO_REPLY,
    OPT_CONFIG_INSTANCE, OPT_HB_INPUT_ONLY, OPT_HB_LISTEN_ONLY,
    OPT_STILL, OPT_SEQ_ON_CHANGE, OPT_TICK, OPT_API_REPORT, OPT_TRAILING_ITEM,
    OPT_OWNER_HOLD,
    OPT_CLOCK_PPM, OPT_DROP_T2O, OPT_T2O_TO_PEER, OPT_LAYOUT, OPT_REFUSE_IDENTITY,
    OPT_VENDOR_ID
};

static const struct option long_options[] = {
    {"address", required_argument, NULL, 'a'},
    {"tcp-port", required_argument, NULL, 'p'},
    {"udp-port", required_argument, NULL, 'u'},
    {"instance", required_argument, NULL, 'i'},
    {"layout", required_argument, NULL, OPT_LAYOUT},
    {"max-connections", required_argument, NULL, OPT_MAX_CONNS},
    {"config-instance", required_argument, NULL, OPT_CONFIG_INSTANCE},
    {"input-only-heartbeat", required_argument, NULL, OPT_HB_INPUT_ONLY},
    {"listen-only-heartbeat", required_argument, NULL, OPT_HB_LISTEN_ONLY},
    {"no-echo", no_argument, NULL, OPT_NO_ECHO},
    {"seed", required_argument, NULL, OPT_SEED},
    {"drop", required_argument, NULL, OPT_DROP},
    {"delay", required_argument, NULL, OPT_DELAY},
    {"stop-producing-after", required_argument, NULL, OPT_STOP_PRODUCING},
    {"refuse-forward-open", required_argument, NULL, OPT_REFUSE_FO},
    {"no-large-forward-open", no_argument, NULL, OPT_NO_LARGE_FO},
    {"no-get-assembly", no_argument, NULL, OPT_NO_GET_ASM},
    {"lose-forward-open-reply", required_argument, NULL, OPT_LOSE_FO_REPLY},
    {"drop-session-after", required_argument, NULL, OPT_DROP_SESSION},
    {"still", no_argument, NULL, OPT_STILL},
    {"seq-on-change", no_argument, NULL, OPT_SEQ_ON_CHANGE},
    {"tick", required_argument, NULL, OPT_TICK},
    {"api-report", required_argument, NULL, OPT_API_REPORT},
    {"trailing-item", no_argument, NULL, OPT_TRAILING_ITEM},
    {"owner-hold", required_argument, NULL, OPT_OWNER_HOLD},
    {"clock-ppm", required_argument, NULL, OPT_CLOCK_PPM},
    {"drop-t2o", no_argument, NULL, OPT_DROP_T2O},
    {"t2o-to-peer", no_argument, NULL, OPT_T2O_TO_PEER},
    {"refuse-identity", no_argument, NULL, OPT_REFUSE_IDENTITY},
    {"vendor-id", required_argument, NULL, OPT_VENDOR_ID},
    {"verbose", no_argument, NULL, 'v'},
    {"help", no_argument, NULL, 'h'},
    {"version", no_argument, NULL, 'V'},
    {NULL, 0, NULL, 0}};

static int bad(const char *opt, const char *arg)
{
    fprintf(stderr, "drsim: invalid %s '%s' (see drsim --help)\n", opt, arg);
    return 2;
}

/* Returns -1 to go on, else the exit status. */
static int parse_options(int argc, char **argv, options_t *o)
{
    drsim_config_default(&o->cfg);
    o->delay_ns = 0;
    o->drop_session_ns = 0;
    o->layout = DR_LAYOUT_PER_ASSEMBLY;
    o->input_instance = o->output_instance = 0;
    unsigned long n;
    struct in_addr ia;
    int c;
    while ((c = getopt_long(argc, argv, "a:p:u:i:vhV", long_options, NULL)) != -1) {
        switch (c) {
        case 'a':
            if (inet_pton(AF_INET, optarg, &ia) != 1)
                return bad("--address", optarg);
            o->cfg.address = ntohl(ia.s_addr);
            break;
        case 'p':
            if (parse_uint(optarg, 1, 65535, &n) != 0)
                return bad("--tcp-port", optarg);
            o->cfg.tcp_port = (uint16_t)n;
            break;
        case 'u':
            if (parse_uint(optarg, 1, 65535, &n) != 0)
                return bad("--udp-port", optarg);
            o->cfg.udp_port = (uint16_t)n;
            break;
        case 'i':
            if (parse_instance(optarg, o) != 0)
                return bad("--instance (want NAME=N, e.g. io_state=100)", optarg);
            break;
        case OPT_LAYOUT:
            if (dr_layout_lookup(optarg, &o->layout) != DR_OK)
                return bad("--layout (want per_assembly, combined or gpr_only)", optarg);
            break;
        case OPT_MAX_CONNS:
            if (parse_uint(optarg, 1, DRSIM_MAX_CONNS, &n) != 0)
                return bad("--max-connections", optarg);
            o->cfg.max_conns = (unsigned)n;
            break;
        case OPT_NO_ECHO:
            o->cfg.echo = false;
            break;
        case OPT_SEED:
            if (parse_uint(optarg, 0, 0xFFFFFFFFul, &n) != 0)
                return bad("--seed", optarg);
            o->cfg.seed = n;
            break;
        case OPT_DROP:
            if (parse_uint(optarg, 0, 100, &n) != 0)
                return bad("--drop", optarg);
            o->cfg.drop_pct = (unsigned)n;
            break;
        case OPT_DELAY:
            if (parse_uint(optarg, 0, 60000, &n) != 0)
                return bad("--delay", optarg);
            o->delay_ns = (uint64_t)n * 1000000u;
            break;
        case OPT_STOP_PRODUCING:
            if (parse_seconds(optarg, &o->cfg.stop_producing_ns) != 0)
                return bad("--stop-producing-after", optarg);
            break;
        case OPT_REFUSE_FO:
            if (parse_uint(optarg, 1, 0xFFFF, &n) != 0)
                return bad("--refuse-forward-open", optarg);
            o->cfg.refuse_fo = (uint16_t)n;
            break;
        case OPT_NO_LARGE_FO:
            o->cfg.no_large_fo = true;
            break;
        case OPT_NO_GET_ASM:
            o->cfg.no_get_assembly = true;
            break;
        case OPT_LOSE_FO_REPLY:
            if (parse_uint(optarg, 1, 1000000, &n) != 0)
                return bad("--lose-forward-open-reply", optarg);
            o->cfg.lose_fo_replies = (unsigned)n;
            break;
        case OPT_CONFIG_INSTANCE:
            if (parse_uint(optarg, 1, 0xFFFF, &n) != 0)
                return bad("--config-instance", optarg);
            o->cfg.config_instance = (uint16_t)n;
            break;
        case OPT_HB_INPUT_ONLY:
        case OPT_HB_LISTEN_ONLY:
            if (parse_uint(optarg, 0, 0xFFFF, &n) != 0)
                return bad(c == OPT_HB_INPUT_ONLY ? "--input-only-heartbeat"
                                                  : "--listen-only-heartbeat", optarg);
            *(c == OPT_HB_INPUT_ONLY ? &o->cfg.hb_input_only : &o->cfg.hb_listen_only) =
                (uint16_t)n;
            break;
        case OPT_DROP_SESSION:
            if (parse_seconds(optarg, &o->drop_session_ns) != 0)
                return bad("--drop-session-after", optarg);
            break;
        case OPT_STILL:
            o->cfg.still = true;
            break;
        case OPT_SEQ_ON_CHANGE:
            o->cfg.seq_on_change = true;
            break;
        case OPT_TICK:
            if (parse_uint(optarg, 1, 1000, &n) != 0)
                return bad("--tick", optarg);
            o->cfg.tick_us = (uint32_t)n * 1000u;
            break;
        case OPT_API_REPORT:
            if (strcmp(optarg, "actual") != 0 && strcmp(optarg, "requested") != 0)
                return bad("--api-report (want actual or requested)", optarg);
            o->cfg.api_requested = strcmp(optarg, "requested") == 0;
            break;
        case OPT_TRAILING_ITEM:
            o->cfg.trailing_item = true;
            break;
        case OPT_OWNER_HOLD:
            if (parse_seconds(optarg, &o->cfg.owner_hold_ns) != 0)
                return bad("--owner-hold", optarg);
            break;
        case OPT_CLOCK_PPM: {
            char *end;
            errno = 0;
            long ppm = strtol(optarg, &end, 10);
            if (errno != 0 || end == optarg || *end != '\0' || ppm < -100000 || ppm > 100000)
                return bad("--clock-ppm (want -100000..100000)", optarg);
            o->cfg.clock_ppm = (int32_t)ppm;
            break;
        }
        case OPT_DROP_T2O:
            o->cfg.drop_t2o = true;
            break;
        case OPT_T2O_TO_PEER:
            o->cfg.t2o_to_peer = true;
            break;
        case OPT_REFUSE_IDENTITY:
            o->cfg.refuse_identity = true;
            break;
        case OPT_VENDOR_ID:
            if (parse_uint(optarg, 0, 0xFFFF, &n) != 0)
                return bad("--vendor-id", optarg);
            o->cfg.vendor_id = (uint16_t)n;
            break;
        case 'v':
            drsim_verbose++;
            break;
        case 'h':
            usage(stdout);
            return 0;
        case 'V':
            printf("drsim " DRSIM_VERSION "\n");
            return 0;
        default:
            usage(stderr);
            return 2;
        }
    }
    if (optind < argc) {
        fprintf(stderr, "drsim: unexpected argument '%s'\n", argv[optind]);
        return 2;
    }
    dr_layout_default(&o->cfg.layout, o->layout);
    if (o->layout == DR_LAYOUT_PER_ASSEMBLY && (o->input_instance || o->output_instance)) {
        fprintf(stderr, "drsim: --instance input=/output= needs --layout combined or gpr_only\n");
        return 2;
    }
    if (o->input_instance)
        o->cfg.layout.input.instance = o->input_instance;
    if (o->output_instance)
        o->cfg.layout.output.instance = o->output_instance;
    return check_instances(&o->cfg) == 0 ? -1 : 2;
}

/* ---- event loop state ------------------------------------------------------- */

typedef struct loop loop_t;

typedef struct {
    int fd; /* -1: free */
    ev_t ev; /* in the loop while fd is open */
    loop_t *L;
    int idx; /* in L->clients */
    uint32_t gen; /* bumped on every close, so delayed replies find no ghost */
    drsim_peer_t peer;
    uint64_t accepted_ns;
    size_t in_len, out_len;
    uint8_t in[DR_ENCAP_MAX_LEN];
    uint8_t out[CLIENT_OUT_CAP];
} client_t;

enum { DQ_TCP, DQ_TCP_CLOSE, DQ_UDP_IO, DQ_UDP_ENCAP };

typedef struct {
    uint64_t due;
    uint8_t kind;
    int client;
    uint32_t gen;
    dr_sockaddr_t to;
    uint16_t len;
    uint8_t data[DR_ENCAP_MAX_LEN];
} delayed_t;

/* FIFO: every entry waits the same --delay, so the head is due first. */
typedef struct {
    delayed_t *q;
    size_t head, count;
    uint64_t full_drops;
} delayq_t;

struct loop {
    options_t opt;
    drsim_t sim;
    ev_loop_t loop;
    int lfd, ufd_io, ufd_encap;
    ev_t lfd_ev, ufd_io_ev, ufd_encap_ev;
    client_t clients[MAX_CLIENTS];
    delayq_t dq;
    volatile int quit;
};

static struct sockaddr_in sin_of(uint32_t addr, uint16_t port)
{
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_port = htons(port);
    sa.sin_addr.s_addr = htonl(addr);
    return sa;
}

static const char *ip_str(uint32_t addr, char buf[INET_ADDRSTRLEN])
{
    struct in_addr ia = {htonl(addr)};
    return inet_ntop(AF_INET, &ia, buf, INET_ADDRSTRLEN);
}

/* ---- sockets ------------------------------------------------------------- */

static int open_socket(int type, uint32_t addr, uint16_t port)
{
    int fd = socket(AF_INET, type | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
    if (fd < 0)
        return -1;
    int one = 1;
    /* TCP: a restarted drsim must not wait out TIME_WAIT on its port.
     * Not UDP: there SO_REUSEADDR would let a second program bind the
     * same address and port and silently take our datagrams. */
    if (type == SOCK_STREAM)
        (void)setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    else
        (void)setsockopt(fd, SOL_SOCKET, SO_BROADCAST, &one, sizeof one);
    struct sockaddr_in sa = sin_of(addr, port);
    char ip[INET_ADDRSTRLEN];
    if (bind(fd, (struct sockaddr *)&sa, sizeof sa) != 0 ||
        (type == SOCK_STREAM && listen(fd, 16) != 0)) {
        fprintf(stderr, "drsim: cannot bind %s %s:%u: %s\n",
                type == SOCK_STREAM ? "TCP" : "UDP", ip_str(addr, ip),
                (unsigned)port, strerror(errno));
        close(fd);
        return -1;
    }
    return fd;
}

/* The local address a datagram to `peer` would leave from: what a
 * ListIdentity reply names when drsim listens on 0.0.0.0. */
static uint32_t local_addr_towards(uint32_t peer, uint16_t port)
{
    int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    uint32_t local = 0;
    if (fd < 0)
        return 0;
    struct sockaddr_in sa = sin_of(peer, port);
    socklen_t sl = sizeof sa;
    if (connect(fd, (struct sockaddr *)&sa, sizeof sa) == 0 &&
        getsockname(fd, (struct sockaddr *)&sa, &sl) == 0)
        local = ntohl(sa.sin_addr.s_addr);
    close(fd);
    return local;
}

static void udp_send(int fd, const dr_sockaddr_t *to, const uint8_t *buf, size_t len)
{
    struct sockaddr_in sa = sin_of(to->addr, to->port);
    if (sendto(fd, buf, len, 0, (struct sockaddr *)&sa, sizeof sa) < 0 &&
        errno != EAGAIN && errno != EWOULDBLOCK)
        drsim_log(2, "sendto: %s", strerror(errno));
}

/* ---- delay queue ------------------------------------------------------------ */

static delayed_t *dq_push(loop_t *L, uint8_t kind, const uint8_t *data, size_t len)
{
    delayq_t *d = &L->dq;
    if (d->count == DELAY_QUEUE_LEN || len > DR_ENCAP_MAX_LEN) {
        if (d->full_drops++ == 0)
            drsim_log(0, "delay queue full: dropping (further drops not logged)");
        return NULL;
    }
    delayed_t *e = &d->q[(d->head + d->count++) % DELAY_QUEUE_LEN];
    e->due = ev_now_ns() + L->opt.delay_ns;
    e->kind = kind;
    e->len = (uint16_t)len;
    if (len > 0)
        memcpy(e->data, data, len);
    return e;
}

/* ---- TCP clients ------------------------------------------------------------- */

static void client_close(loop_t *L, int idx, const char *why)
{
    client_t *c = &L->clients[idx];
    if (c->fd < 0)
        return;
    char ip[INET_ADDRSTRLEN];
    drsim_log(1, "client %s:%u closed (%s)", ip_str(c->peer.addr, ip),
              (unsigned)c->peer.port, why);
    ev_unwatch(L->loop.epfd, &c->ev);
    close(c->fd);
    c->fd = -1;
    c->gen++;
}

/* Write what we can; keep the rest for EPOLLOUT. */
static void client_flush(loop_t *L, int idx)
{
    client_t *c = &L->clients[idx];
    while (c->out_len > 0) {
        ssize_t n = send(c->fd, c->out, c->out_len, MSG_NOSIGNAL);
        if (n < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK)
                break;
            if (errno == EINTR)
                continue;
            client_close(L, idx, strerror(errno));
            return;
        }
        memmove(c->out, c->out + n, c->out_len - (size_t)n);
        c->out_len -= (size_t)n;
    }
    /* Back-pressure: while replies wait for the peer to read them, read
     * no more requests from it (the other clients carry on). */
    uint32_t ev = c->out_len > 0 ? EPOLLOUT : EPOLLIN;
    (void)ev_watch(L->loop.epfd, &c->ev, c->fd, ev);
}

static void client_send(loop_t *L, int idx, const uint8_t *buf, size_t len)
{
    client_t *c = &L->clients[idx];
    if (c->fd < 0)
        return;
    if (CLIENT_OUT_CAP - c->out_len < len) {
        /* It stopped reading (only delayed replies can pile up this far,
         * see client_flush); holding more would only grow memory. */
        client_close(L, idx, "not reading its replies");
        return;
    }
    memcpy(c->out + c->out_len, buf, len);
    c->out_len += len;
    client_flush(L, idx);
}

static void client_reply(loop_t *L, int idx, drsim_action_t act,
                         const uint8_t *buf, size_t len)
{
    client_t *c = &L->clients[idx];
    if (L->opt.delay_ns > 0 && act != DRSIM_SILENT) {
        delayed_t *e = dq_push(L, act == DRSIM_CLOSE ? DQ_TCP_CLOSE : DQ_TCP, buf,
                               act == DRSIM_CLOSE ? 0 : len);
        if (e != NULL) {
            e->client = idx;
            e->gen = c->gen;
        }
        return;
    }
    if (act == DRSIM_REPLY)
        client_send(L, idx, buf, len);
    else if (act == DRSIM_CLOSE)
        client_close(L, idx, "session ended");
}

/* Take every complete frame out of the input buffer. */
static void client_frames(loop_t *L, int idx)
{
    client_t *c = &L->clients[idx];
    uint8_t out[DR_ENCAP_MAX_LEN];
    while (c->fd >= 0) {
        size_t total;
        dr_status_t st = dr_encap_frame_len(c->in, c->in_len, &total);
        if (st == DR_ELONG) {
            client_close(L, idx, "frame too long");
            return;
        }
        if (st != DR_OK || c->in_len < total)
            return; /* wait for the rest */
        size_t out_len = 0;
        drsim_action_t act = drsim_encap(&L->sim, &c->peer, ev_now_ns(), c->in, total,
                                         out, sizeof out, &out_len);
        memmove(c->in, c->in + total, c->in_len - total);
        c->in_len -= total;
        client_reply(L, idx, act, out, out_len);
    }
}

static void client_readable(loop_t *L, int idx)
{
    client_t *c = &L->clients[idx];
    /* One read per wake-up (level-triggered): a client that streams
     * requests gets its turn, then the others get theirs. */
    ssize_t n = recv(c->fd, c->in + c->in_len, sizeof c->in - c->in_len, 0);
    if (n == 0) {
        client_close(L, idx, "closed by peer");
        return;
    }
    if (n < 0) {
        if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR)
            client_close(L, idx, strerror(errno));
        return;
    }
    c->in_len += (size_t)n;
    client_frames(L, idx);
}

static void accept_clients(loop_t *L)
{
    for (;;) {
        struct sockaddr_in sa;
        socklen_t sl = sizeof sa;
        /* zeroed: clang's analyzer does not see accept4 or recvfrom fill a
         * sockaddr passed through glibc's transparent union (_GNU_SOURCE) */
        memset(&sa, 0, sizeof sa);
        int fd = accept4(L->lfd, (struct sockaddr *)&sa, &sl,
                         SOCK_NONBLOCK | SOCK_CLOEXEC);
        if (fd < 0)
            return; /* EAGAIN, or an aborted connection: nothing to do */
        int idx = -1;
        for (int i = 0; i < MAX_CLIENTS && idx < 0; i++)
            if (L->clients[i].fd < 0)
                idx = i;
        if (idx < 0) {
            drsim_log(0, "too many TCP clients, refusing one");
            close(fd);
            continue;
        }
        int one = 1;
        (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        client_t *c = &L->clients[idx];
        c->fd = fd;
        c->in_len = c->out_len = 0;
        c->accepted_ns = ev_now_ns();
        memset(&c->peer, 0, sizeof c->peer);
        c->peer.addr = ntohl(sa.sin_addr.s_addr);
        c->peer.port = ntohs(sa.sin_port);
        sl = sizeof sa;
        if (getsockname(fd, (struct sockaddr *)&sa, &sl) == 0)
            c->peer.local_addr = ntohl(sa.sin_addr.s_addr);
        if (!ev_watch(L->loop.epfd, &c->ev, fd, EPOLLIN)) {
            client_close(L, idx, strerror(errno));
            continue;
        }
        char ip[INET_ADDRSTRLEN];
        drsim_log(1, "client %s:%u connected", ip_str(c->peer.addr, ip),
                  (unsigned)c->peer.port);
    }
}

/* ---- UDP --------------------------------------------------------------------- */

static void io_send(void *ctx, const dr_sockaddr_t *to, const uint8_t *buf, size_t len)
{
    loop_t *L = ctx;
    if (L->opt.delay_ns > 0) {
        delayed_t *e = dq_push(L, DQ_UDP_IO, buf, len);
        if (e != NULL)
            e->to = *to;
        return;
    }
    udp_send(L->ufd_io, to, buf, len);
}

/* When the datagram arrived, on the monotonic clock: the kernel stamps it
 * on arrival (SO_TIMESTAMPNS, CLOCK_REALTIME), so the O->T timing drsim
 * reports (adapter.c, o2t_timing) is the sender's, not how late this
 * loop got to the socket on a busy machine. Without a stamp: now. */
static uint64_t arrival_ns(const struct msghdr *mh)
{
    uint64_t mono = ev_now_ns();
    for (struct cmsghdr *cm = CMSG_FIRSTHDR(mh); cm != NULL;
         cm = CMSG_NXTHDR((struct msghdr *)mh, cm)) {
        if (cm->cmsg_level != SOL_SOCKET || cm->cmsg_type != SCM_TIMESTAMPNS)
            continue;
        struct timespec at, real;
        memcpy(&at, CMSG_DATA(cm), sizeof at);
        clock_gettime(CLOCK_REALTIME, &real);
        uint64_t at_ns = (uint64_t)at.tv_sec * 1000000000u + (uint64_t)at.tv_nsec;
        uint64_t real_ns = (uint64_t)real.tv_sec * 1000000000u + (uint64_t)real.tv_nsec;
        uint64_t ago = real_ns > at_ns ? real_ns - at_ns : 0;
        /* more than a second: the wall clock was set in between */
        return ago < 1000000000u && ago < mono ? mono - ago : mono;
    }
    return mono;
}

static void udp_io_readable(loop_t *L)
{
    uint8_t buf[1500];
    union {
        struct cmsghdr align;
        uint8_t b[CMSG_SPACE(sizeof(struct timespec))];
    } ctl;
    for (int i = 0; i < UDP_BURST; i++) {
        struct sockaddr_in sa;
        memset(&sa, 0, sizeof sa); /* see accept_clients */
        struct iovec iov = {buf, sizeof buf};
        struct msghdr mh;
        memset(&mh, 0, sizeof mh);
        mh.msg_name = &sa;
        mh.msg_namelen = sizeof sa;
        mh.msg_iov = &iov;
        mh.msg_iovlen = 1;
        mh.msg_control = ctl.b;
        mh.msg_controllen = sizeof ctl.b;
        ssize_t n = recvmsg(L->ufd_io, &mh, 0);
        if (n < 0)
            return;
        dr_sockaddr_t from = {ntohl(sa.sin_addr.s_addr), ntohs(sa.sin_port)};
        drsim_io_receive(&L->sim, arrival_ns(&mh), &from, buf, (size_t)n);
    }
}

static void udp_encap_readable(loop_t *L)
{
    uint8_t buf[DR_ENCAP_MAX_LEN], out[DR_ENCAP_MAX_LEN];
    for (int i = 0; i < UDP_BURST; i++) {
        struct sockaddr_in sa;
        socklen_t sl = sizeof sa;
        memset(&sa, 0, sizeof sa); /* see accept_clients */
        ssize_t n = recvfrom(L->ufd_encap, buf, sizeof buf, 0, (struct sockaddr *)&sa, &sl);
        if (n < 0)
            return;
        drsim_peer_t peer;
        memset(&peer, 0, sizeof peer);
        peer.addr = ntohl(sa.sin_addr.s_addr);
        peer.port = ntohs(sa.sin_port);
        peer.local_addr = L->opt.cfg.address ? L->opt.cfg.address
                                             : local_addr_towards(peer.addr, peer.port);
        size_t out_len = 0;
        if (drsim_encap_udp(&L->sim, &peer, buf, (size_t)n, out, sizeof out,
                            &out_len) != DRSIM_REPLY)
            continue;
        dr_sockaddr_t to = {peer.addr, peer.port};
        char ip[INET_ADDRSTRLEN];
        drsim_log(1, "UDP discovery from %s:%u", ip_str(peer.addr, ip), (unsigned)peer.port);
        if (L->opt.delay_ns > 0) {
            delayed_t *e = dq_push(L, DQ_UDP_ENCAP, out, out_len);
            if (e != NULL)
                e->to = to;
        } else {
            udp_send(L->ufd_encap, &to, out, out_len);
        }
    }
}

/* ---- timers ------------------------------------------------------------------- */

static void run_delayed(loop_t *L, uint64_t now)
{
    delayq_t *d = &L->dq;
    while (d->count > 0 && d->q[d->head].due <= now) {
        delayed_t *e = &d->q[d->head];
        d->head = (d->head + 1) % DELAY_QUEUE_LEN;
        d->count--;
        switch (e->kind) {
        case DQ_TCP:
        case DQ_TCP_CLOSE:
            if (L->clients[e->client].gen != e->gen)
                break; /* that client is gone */
            if (e->kind == DQ_TCP)
                client_send(L, e->client, e->data, e->len);
            else
                client_close(L, e->client, "session ended");
            break;
        case DQ_UDP_IO:
            udp_send(L->ufd_io, &e->to, e->data, e->len);
            break;
        default:
            udp_send(L->ufd_encap, &e->to, e->data, e->len);
            break;
        }
    }
}

static void drop_sessions(loop_t *L, uint64_t now)
{
    if (L->opt.drop_session_ns == 0)
        return;
    for (int i = 0; i < MAX_CLIENTS; i++) {
        client_t *c = &L->clients[i];
        if (c->fd >= 0 && now - c->accepted_ns >= L->opt.drop_session_ns)
            client_close(L, i, "--drop-session-after");
    }
}

static uint64_t next_deadline(const loop_t *L)
{
    uint64_t t = drsim_next_deadline(&L->sim);
    if (L->dq.count > 0 && L->dq.q[L->dq.head].due < t)
        t = L->dq.q[L->dq.head].due;
    if (L->opt.drop_session_ns > 0)
        for (int i = 0; i < MAX_CLIENTS; i++) {
            const client_t *c = &L->clients[i];
            if (c->fd >= 0 && c->accepted_ns + L->opt.drop_session_ns < t)
                t = c->accepted_ns + L->opt.drop_session_ns;
        }
    return t;
}

static void timers(loop_t *L)
{
    uint64_t now = ev_now_ns();
    drsim_run(&L->sim, now, io_send, L);
    run_delayed(L, now);
    drop_sessions(L, now);
}

/* ---- events ------------------------------------------------------------------ */

static void on_listen(void *obj, uint32_t events)
{
    (void)events;
    accept_clients(obj);
}

static void on_udp_io(void *obj, uint32_t events)
{
    (void)events;
    udp_io_readable(obj);
}

static void on_udp_encap(void *obj, uint32_t events)
{
    (void)events;
    udp_encap_readable(obj);
}

/* SIGUSR1 and SIGUSR2 raise and clear the robot's safety stops (tests
 * drive them so); the others stop drsim. */
static void on_signal(void *obj, int signo)
{
    loop_t *L = obj;
    if (signo == SIGUSR1 || signo == SIGUSR2) {
        drsim_robot_t *r = &L->sim.robot;
        bool estop = r->estop != (signo == SIGUSR1), pstop = r->pstop != (signo == SIGUSR2);
        drsim_robot_safety(r, estop, pstop, ev_now_ns(), &L->sim.img);
        drsim_log(1, "signal %d: %s stop %s", signo,
                  signo == SIGUSR1 ? "emergency" : "protective",
                  (signo == SIGUSR1 ? estop : pstop) ? "raised" : "cleared");
        return;
    }
    drsim_log(1, "signal %d: stopping", signo);
    L->quit = 1;
}

static void on_client(void *obj, uint32_t events)
{
    client_t *c = obj;
    if (c->fd < 0)
        return;
    if (events & (EPOLLERR | EPOLLHUP)) {
        client_close(c->L, c->idx, "connection error");
        return;
    }
    if (events & EPOLLOUT)
        client_flush(c->L, c->idx);
    if ((events & EPOLLIN) && c->fd >= 0)
        client_readable(c->L, c->idx);
}

/* ---- main ---------------------------------------------------------------------- */

static int setup(loop_t *L)
{
    static const int signals[] = {SIGINT, SIGTERM, SIGUSR1, SIGUSR2};
    const drsim_config_t *cfg = &L->opt.cfg;
    /* first: teardown closes what these opened, whatever fails below */
    for (int i = 0; i < MAX_CLIENTS; i++) {
        client_t *c = &L->clients[i];
        c->fd = -1;
        c->ev = (ev_t){on_client, c, -1, 0};
        c->L = L;
        c->idx = i;
    }
    if (!ev_open(&L->loop, EV_TIMER) ||
        !ev_signals(&L->loop, signals, sizeof signals / sizeof signals[0], on_signal, L)) {
        fprintf(stderr, "drsim: %s\n", strerror(errno));
        return -1;
    }
    L->lfd = open_socket(SOCK_STREAM, cfg->address, cfg->tcp_port);
    L->ufd_encap = open_socket(SOCK_DGRAM, cfg->address, cfg->tcp_port);
    L->ufd_io = open_socket(SOCK_DGRAM, cfg->address, cfg->udp_port);
    if (L->lfd < 0 || L->ufd_encap < 0 || L->ufd_io < 0)
        return -1;
    int one = 1; /* arrival stamps for the O->T timing (arrival_ns) */
    (void)setsockopt(L->ufd_io, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
    if (L->opt.delay_ns > 0) {
        L->dq.q = calloc(DELAY_QUEUE_LEN, sizeof *L->dq.q);
        if (L->dq.q == NULL)
            return -1;
    }
    L->lfd_ev = (ev_t){on_listen, L, -1, 0};
    L->ufd_io_ev = (ev_t){on_udp_io, L, -1, 0};
    L->ufd_encap_ev = (ev_t){on_udp_encap, L, -1, 0};
    int ep = L->loop.epfd;
    if (!ev_watch(ep, &L->lfd_ev, L->lfd, EPOLLIN) ||
        !ev_watch(ep, &L->ufd_io_ev, L->ufd_io, EPOLLIN) ||
        !ev_watch(ep, &L->ufd_encap_ev, L->ufd_encap, EPOLLIN))
        return -1;
    drsim_init(&L->sim, cfg, ev_now_ns());
    char ip[INET_ADDRSTRLEN];
    char inst[64];
    if (cfg->layout.kind == DR_LAYOUT_PER_ASSEMBLY)
        snprintf(inst, sizeof inst, "instances %u..%u", (unsigned)cfg->instance[0],
                 (unsigned)cfg->instance[DR_ASM_COUNT - 1]);
    else
        snprintf(inst, sizeof inst, "layout %s: input %u (%u bytes), output %u (%u bytes)",
                 dr_layout_name(cfg->layout.kind), (unsigned)cfg->layout.input.instance,
                 (unsigned)cfg->layout.input.size, (unsigned)cfg->layout.output.instance,
                 (unsigned)cfg->layout.output.size);
    drsim_log(1, "listening on %s, TCP/UDP %u (encapsulation), UDP %u (I/O); %s%s",
              ip_str(cfg->address, ip), (unsigned)cfg->tcp_port, (unsigned)cfg->udp_port,
              inst, cfg->echo ? "" : ", no echo");
    return 0;
}

static void teardown(loop_t *L)
{
    for (int i = 0; i < MAX_CLIENTS; i++)
        client_close(L, i, "drsim stopping");
    unsigned open = drsim_conn_count(&L->sim);
    if (open > 0)
        drsim_log(1, "%u Class 1 connection(s) left open", open);
    int fds[] = {L->lfd, L->ufd_io, L->ufd_encap};
    for (size_t i = 0; i < sizeof fds / sizeof fds[0]; i++)
        if (fds[i] >= 0)
            close(fds[i]);
    ev_close(&L->loop);
    free(L->dq.q);
}

int main(int argc, char **argv)
{
    static loop_t L; /* large (client buffers): not on the stack */
    int rc = parse_options(argc, argv, &L.opt);
    if (rc >= 0)
        return rc;
    L.lfd = L.ufd_io = L.ufd_encap = -1;
    if (setup(&L) != 0) {
        teardown(&L);
        return 1;
    }
    while (!L.quit) {
        if (ev_run(&L.loop, next_deadline(&L)) < 0) {
            fprintf(stderr, "drsim: epoll_wait: %s\n", strerror(errno));
            rc = 1;
            break;
        }
        timers(&L);
    }
    teardown(&L);
    return rc < 0 ? 0 : rc;
}
