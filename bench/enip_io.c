/* SPDX-License-Identifier: MIT */
/*
 * make bench: Class 1 production timing of our client, side by side with a
 * bare timerfd loop in the same run.
 *
 * Three processes on loopback:
 *   receiver  a measuring adapter: drsim's protocol logic (sim/adapter.c,
 *             the same code as drsim) behind a small epoll loop that notes
 *             the kernel's receive timestamp (SO_TIMESTAMPNS) of every
 *             datagram. It answers the Forward Opens and produces T->O at
 *             the RPI like drsim, so the client does all its usual work.
 *   timer     the baseline: a timerfd at absolute 1 ms deadlines, sending
 *             one datagram per expiry to the receiver's second port.
 *   client    (this process) our library with N Class 1 connections at the
 *             RPI, in a poll loop on dr_client_pollfds().
 * Both streams are timed the same way, at the same place, at the same
 * time. For each O->T connection and for the timer the receiver keeps the
 * intervals between arrivals during the window, and reports p50/p99/max of
 * the interval and of its deviation from the period; CPU shares come from
 * getrusage over the window, and so do the wake-ups per period (voluntary
 * context switches: the times a loop went to sleep).
 *
 * usage: enip_io [SECONDS [CONNECTIONS [RPI_US [FOLLOW_US [loop]]]]]  (10, 6, 1000, 0)
 * FOLLOW_US is the connections' o2t_follow_us (0: O->T on the client's own
 * timer only). "loop": the client runs on a transport without timer calls
 * and the loop waits with ppoll until dr_client_next_deadline(), to the
 * microsecond (as drgatewayd does), instead of polling the client's timerfd.
 * prints lines starting with "io" (parsed by bench/bench_enip.py): "io cpu
 * client|timerfd|receiver PCT", "io wakeups client|timerfd PER_PERIOD", ...
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/timerfd.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "adapter.h"
#include "cip_internal.h"
#include "drgate/client.h"

#define ADDR "127.0.0.2"
#define MAX_STREAMS 17        /* the timer + up to 16 connections */
#define MAX_IV 65536u         /* intervals kept per stream (60 s at 1 ms) */
#define MAX_TCP 8
#define WARMUP_S 1.0

/* ---- small helpers --------------------------------------------------------- */

static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static double cpu_s(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return (double)ru.ru_utime.tv_sec + (double)ru.ru_utime.tv_usec / 1e6 +
           (double)ru.ru_stime.tv_sec + (double)ru.ru_stime.tv_usec / 1e6;
}

/* Voluntary context switches: the times this process went to sleep
 * waiting (one per wake-up of its loop). */
static long wakeups(void)
{
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_nvcsw;
}

static struct sockaddr_in sin_of(uint32_t addr, uint16_t port)
{
    struct sockaddr_in sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    sa.sin_port = htons(port);
    sa.sin_addr.s_addr = htonl(addr);
    return sa;
}

/* A socket bound to ADDR at a port the kernel picks; its port in *port. */
static int bound(int type, uint16_t *port)
{
    struct sockaddr_in sa;
    socklen_t sl = sizeof sa;
    int fd = socket(AF_INET, type | SOCK_CLOEXEC, 0);
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    inet_pton(AF_INET, ADDR, &sa.sin_addr);
    if (fd < 0 || bind(fd, (struct sockaddr *)&sa, sizeof sa) != 0 ||
        (type == SOCK_STREAM && listen(fd, 8) != 0) ||
        getsockname(fd, (struct sockaddr *)&sa, &sl) != 0) {
        perror("enip_io: socket");
        exit(1);
    }
    *port = ntohs(sa.sin_port);
    return fd;
}

static void put_line(int fd, const char *s)
{
    size_t n = strlen(s), off = 0;
    while (off < n) {
        ssize_t w = write(fd, s + off, n - off);
        if (w < 0 && errno == EINTR)
            continue;
        if (w <= 0)
            return;
        off += (size_t)w;
    }
}

/* Read one line from fd within timeout_ms ('\n' excluded). */
static int get_line(int fd, char *buf, size_t cap, int timeout_ms)
{
    size_t n = 0;
    uint64_t end = now_ns() + (uint64_t)timeout_ms * 1000000u;
    while (n + 1 < cap) {
        uint64_t t = now_ns();
        if (t >= end)
            return -1;
        struct pollfd p = {fd, POLLIN, 0};
        if (poll(&p, 1, (int)((end - t) / 1000000u) + 1) <= 0)
            continue;
        char ch;
        ssize_t r = read(fd, &ch, 1);
        if (r <= 0)
            return -1;
        if (ch == '\n')
            break;
        buf[n++] = ch;
    }
    buf[n] = '\0';
    return 0;
}

/* ---- statistics ------------------------------------------------------------ */

typedef struct {
    uint32_t cid;
    bool bare;
    uint64_t last_ns; /* kernel receive time of the previous datagram */
    uint32_t last_seq;
    bool have_seq;
    uint64_t lost;
    uint32_t *iv;     /* intervals, ns */
    size_t n;
} stream_t;

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return (x > y) - (x < y);
}

static double pct(const uint32_t *sorted, size_t n, double q)
{
    if (n == 0)
        return 0.0;
    size_t i = (size_t)(q * (double)(n - 1) + 0.5);
    return (double)sorted[i] / 1000.0;
}

/* Intervals and their deviations from the period, in microseconds. */
static void report(int out, const char *what, const uint32_t *iv, size_t n,
                   uint32_t period_ns, uint64_t lost)
{
    char line[512];
    if (n == 0) {
        snprintf(line, sizeof line, "io %s n 0\n", what);
        put_line(out, line);
        return;
    }
    uint32_t *s = malloc(n * sizeof *s), *d = malloc(n * sizeof *d);
    if (s == NULL || d == NULL)
        exit(1);
    for (size_t i = 0; i < n; i++) {
        s[i] = iv[i];
        d[i] = iv[i] > period_ns ? iv[i] - period_ns : period_ns - iv[i];
    }
    qsort(s, n, sizeof *s, cmp_u32);
    qsort(d, n, sizeof *d, cmp_u32);
    snprintf(line, sizeof line,
             "io %s n %zu lost %llu p50 %.1f p99 %.1f max %.1f dev_p50 %.1f dev_p99 %.1f dev_max %.1f\n",
             what, n, (unsigned long long)lost, pct(s, n, 0.5), pct(s, n, 0.99), pct(s, n, 1.0),
             pct(d, n, 0.5), pct(d, n, 0.99), pct(d, n, 1.0));
    put_line(out, line);
    free(s);
    free(d);
}

/* ---- the receiver: drsim's adapter logic, timestamping every datagram ---- */

typedef struct {
    int fd;
    drsim_peer_t peer;
    size_t in_len;
    uint8_t in[2 * DR_ENCAP_MAX_LEN];
} tcp_client_t;

typedef struct {
    drsim_t sim;
    int ep, lfd, ufd, bfd, tfd, ctl;
    uint64_t armed;
    tcp_client_t cl[MAX_TCP];
    stream_t st[MAX_STREAMS];
    unsigned nst;
    bool recording;
    uint32_t period_ns;
} rx_t;

static rx_t R;

static void rx_send(void *ctx, const dr_sockaddr_t *to, const uint8_t *buf, size_t len)
{
    (void)ctx;
    struct sockaddr_in sa = sin_of(to->addr, to->port);
    (void)sendto(R.ufd, buf, len, MSG_DONTWAIT, (struct sockaddr *)&sa, sizeof sa);
}

static stream_t *stream_for(uint32_t cid, bool bare)
{
    for (unsigned i = 0; i < R.nst; i++)
        if (R.st[i].bare == bare && R.st[i].cid == cid)
            return &R.st[i];
    if (R.nst == MAX_STREAMS)
        return NULL;
    stream_t *s = &R.st[R.nst++];
    s->cid = cid;
    s->bare = bare;
    s->iv = malloc(MAX_IV * sizeof *s->iv);
    if (s->iv == NULL)
        exit(1);
    return s;
}

static void note(stream_t *s, uint64_t ts, uint32_t seq)
{
    if (s == NULL || !R.recording)
        return;
    if (s->last_ns != 0 && ts > s->last_ns && s->n < MAX_IV) {
        uint64_t iv = ts - s->last_ns;
        s->iv[s->n++] = iv > UINT32_MAX ? UINT32_MAX : (uint32_t)iv;
    }
    if (s->have_seq && seq - s->last_seq > 1u && seq - s->last_seq < 0x80000000u)
        s->lost += seq - s->last_seq - 1u;
    s->last_ns = ts;
    s->last_seq = seq;
    s->have_seq = true;
}

/* One datagram with its kernel receive timestamp (CLOCK_REALTIME, ns). */
static ssize_t recv_ts(int fd, uint8_t *buf, size_t cap, struct sockaddr_in *from,
                       uint64_t *ts)
{
    struct iovec io = {buf, cap};
    union {
        char b[CMSG_SPACE(sizeof(struct timespec))];
        struct cmsghdr align;
    } ctl;
    struct msghdr m;
    memset(&m, 0, sizeof m);
    m.msg_name = from;
    m.msg_namelen = sizeof *from;
    m.msg_iov = &io;
    m.msg_iovlen = 1;
    m.msg_control = ctl.b;
    m.msg_controllen = sizeof ctl.b;
    ssize_t n = recvmsg(fd, &m, MSG_DONTWAIT);
    *ts = 0;
    if (n < 0)
        return n;
    for (struct cmsghdr *c = CMSG_FIRSTHDR(&m); c != NULL; c = CMSG_NXTHDR(&m, c))
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SCM_TIMESTAMPNS) {
            struct timespec t;
            memcpy(&t, CMSG_DATA(c), sizeof t);
            *ts = (uint64_t)t.tv_sec * 1000000000u + (uint64_t)t.tv_nsec;
        }
    return n;
}

static void rx_udp(int fd, bool bare)
{
    uint8_t buf[1500];
    for (;;) {
        struct sockaddr_in sa;
        uint64_t ts;
        ssize_t n = recv_ts(fd, buf, sizeof buf, &sa, &ts);
        if (n < 0)
            return;
        if (bare) {
            uint32_t seq;
            if (n >= 4) {
                memcpy(&seq, buf, 4);
                note(stream_for(0, true), ts, seq);
            }
            continue;
        }
        dr_io_frame_t f;
        if (dr_io_frame_parse(buf, (size_t)n, false, &f) == DR_OK)
            note(stream_for(f.cid, false), ts, f.encap_seq);
        dr_sockaddr_t from = {ntohl(sa.sin_addr.s_addr), ntohs(sa.sin_port)};
        drsim_io_receive(&R.sim, now_ns(), &from, buf, (size_t)n);
    }
}

static void rx_close(int i)
{
    epoll_ctl(R.ep, EPOLL_CTL_DEL, R.cl[i].fd, NULL);
    close(R.cl[i].fd);
    R.cl[i].fd = -1;
}

static void rx_tcp(int i)
{
    tcp_client_t *c = &R.cl[i];
    ssize_t n = recv(c->fd, c->in + c->in_len, sizeof c->in - c->in_len, MSG_DONTWAIT);
    if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
        rx_close(i);
        return;
    }
    if (n < 0)
        return;
    c->in_len += (size_t)n;
    for (;;) {
        size_t total;
        dr_status_t st = dr_encap_frame_len(c->in, c->in_len, &total);
        if (st == DR_ELONG) {
            rx_close(i);
            return;
        }
        if (st != DR_OK || c->in_len < total)
            return;
        uint8_t out[DR_ENCAP_MAX_LEN];
        size_t out_len = 0;
        drsim_action_t act = drsim_encap(&R.sim, &c->peer, now_ns(), c->in, total, out,
                                         sizeof out, &out_len);
        memmove(c->in, c->in + total, c->in_len - total);
        c->in_len -= total;
        if (act == DRSIM_CLOSE) {
            rx_close(i);
            return;
        }
        /* replies are small and the client reads them: a short or failed
         * send ends this bench client */
        if (act == DRSIM_REPLY &&
            send(c->fd, out, out_len, MSG_NOSIGNAL | MSG_DONTWAIT) != (ssize_t)out_len) {
            rx_close(i);
            return;
        }
    }
}

static void rx_accept(void)
{
    struct sockaddr_in sa;
    socklen_t sl = sizeof sa;
    int fd = accept4(R.lfd, (struct sockaddr *)&sa, &sl, SOCK_CLOEXEC);
    if (fd < 0)
        return;
    for (int i = 0; i < MAX_TCP; i++)
        if (R.cl[i].fd < 0) {
            tcp_client_t *c = &R.cl[i];
            memset(c, 0, sizeof *c);
            c->fd = fd;
            c->peer.addr = ntohl(sa.sin_addr.s_addr);
            c->peer.port = ntohs(sa.sin_port);
            sl = sizeof sa;
            getsockname(fd, (struct sockaddr *)&sa, &sl);
            c->peer.local_addr = ntohl(sa.sin_addr.s_addr);
            struct epoll_event ev = {EPOLLIN, {.u32 = 100u + (uint32_t)i}};
            epoll_ctl(R.ep, EPOLL_CTL_ADD, fd, &ev);
            return;
        }
    close(fd);
}

static void rx_results(int out)
{
    char line[128];
    size_t total = 0;
    for (unsigned i = 0; i < R.nst; i++)
        if (!R.st[i].bare)
            total += R.st[i].n;
    uint32_t *pool = malloc((total + 1) * sizeof *pool);
    if (pool == NULL)
        exit(1);
    size_t k = 0;
    uint64_t lost = 0;
    unsigned conns = 0;
    for (unsigned i = 0; i < R.nst; i++) {
        stream_t *s = &R.st[i];
        if (s->bare) {
            report(out, "timerfd", s->iv, s->n, R.period_ns, s->lost);
            continue;
        }
        snprintf(line, sizeof line, "conn %08x", (unsigned)s->cid);
        report(out, line, s->iv, s->n, R.period_ns, s->lost);
        memcpy(pool + k, s->iv, s->n * sizeof *pool);
        k += s->n;
        lost += s->lost;
        conns++;
    }
    snprintf(line, sizeof line, "client %u", conns);
    report(out, line, pool, k, R.period_ns, lost);
    free(pool);
}

static void rx_arm(void)
{
    uint64_t t = drsim_next_deadline(&R.sim);
    if (t == R.armed || t == UINT64_MAX)
        return;
    struct itimerspec its;
    memset(&its, 0, sizeof its);
    its.it_value.tv_sec = (time_t)(t / 1000000000u);
    its.it_value.tv_nsec = (long)(t % 1000000000u);
    if (its.it_value.tv_sec == 0 && its.it_value.tv_nsec == 0)
        its.it_value.tv_nsec = 1;
    if (timerfd_settime(R.tfd, TFD_TIMER_ABSTIME, &its, NULL) == 0)
        R.armed = t;
}

/* Commands on ctl: 'S' start recording, 'E' stop and report on `out`,
 * 'Q' (or the parent gone) quit. */
static int receiver(int ctl, int out, uint32_t period_ns)
{
    uint16_t tcp_port, udp_port, bare_port;
    R.period_ns = period_ns;
    R.ctl = ctl;
    R.lfd = bound(SOCK_STREAM, &tcp_port);
    R.ufd = bound(SOCK_DGRAM, &udp_port);
    R.bfd = bound(SOCK_DGRAM, &bare_port);
    int one = 1;
    setsockopt(R.ufd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
    setsockopt(R.bfd, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one);
    R.tfd = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC);
    R.ep = epoll_create1(EPOLL_CLOEXEC);
    for (int i = 0; i < MAX_TCP; i++)
        R.cl[i].fd = -1;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.address = 0x7F000002u;
    cfg.tcp_port = tcp_port;
    cfg.udp_port = udp_port;
    drsim_init(&R.sim, &cfg, now_ns());
    /* The UDP sockets are not in the epoll set: the receiver drains them
     * on its own timer (T->O production, every RPI) and takes the times
     * from the kernel's receive timestamps. So a datagram wakes nobody, and
     * the senders are not preempted by the receiver in the middle of a
     * burst -- on a real cell the receiver is another machine. */
    const int fds[] = {R.lfd, -1, -1, R.tfd, ctl};
    for (uint32_t i = 0; i < 5; i++) {
        struct epoll_event ev = {EPOLLIN, {.u32 = i}};
        if (fds[i] >= 0)
            epoll_ctl(R.ep, EPOLL_CTL_ADD, fds[i], &ev);
    }
    char line[64];
    snprintf(line, sizeof line, "ports %u %u %u\n", tcp_port, udp_port, bare_port);
    put_line(out, line);
    double cpu0 = 0.0;
    uint64_t wall0 = 0;
    for (;;) {
        struct epoll_event ev[16];
        int n = epoll_wait(R.ep, ev, 16, 1000);
        for (int i = 0; i < n; i++) {
            uint32_t tag = ev[i].data.u32;
            if (tag == 0) {
                rx_accept();
            } else if (tag == 1) {
                rx_udp(R.ufd, false);
            } else if (tag == 2) {
                rx_udp(R.bfd, true);
            } else if (tag == 3) {
                uint64_t exp;
                (void)!read(R.tfd, &exp, sizeof exp);
                R.armed = 0;
            } else if (tag == 4) {
                char cmd = 'Q';
                if (read(ctl, &cmd, 1) != 1)
                    cmd = 'Q';
                if (cmd == 'S') {
                    for (unsigned k = 0; k < R.nst; k++) {
                        R.st[k].n = 0;
                        R.st[k].lost = 0;
                        R.st[k].last_ns = 0;
                        R.st[k].have_seq = false;
                    }
                    R.recording = true;
                    cpu0 = cpu_s();
                    wall0 = now_ns();
                } else if (cmd == 'E') {
                    R.recording = false;
                    double share = (cpu_s() - cpu0) / ((double)(now_ns() - wall0) / 1e9);
                    rx_results(out);
                    snprintf(line, sizeof line, "io cpu receiver %.2f\nend\n", 100.0 * share);
                    put_line(out, line);
                } else {
                    return 0;
                }
            } else if (tag >= 100u && tag < 100u + MAX_TCP) {
                rx_tcp((int)(tag - 100u));
            }
        }
        rx_udp(R.ufd, false);
        rx_udp(R.bfd, true);
        drsim_run(&R.sim, now_ns(), rx_send, NULL);
        rx_arm();
    }
}

/* ---- the bare timerfd loop ------------------------------------------------------ */

/* Wait for 'S' on ctl, then send one datagram per period for `secs`, on
 * absolute deadlines (restarting from now after a stall, as the client
 * does); report its CPU share on out. */
static int bare_timer(int ctl, int out, uint16_t port, uint32_t period_ns, double secs)
{
    char cmd;
    if (read(ctl, &cmd, 1) != 1 || cmd != 'S')
        return 1;
    int fd = socket(AF_INET, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    int tfd = timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC);
    struct sockaddr_in to = sin_of(0x7F000002u, port);
    double cpu0 = cpu_s();
    long wake0 = wakeups();
    uint64_t start = now_ns(), end = start + (uint64_t)(secs * 1e9), next = start + period_ns;
    uint32_t seq = 0;
    uint8_t pkt[20];
    memset(pkt, 0, sizeof pkt);
    while (next < end) {
        struct itimerspec its;
        memset(&its, 0, sizeof its);
        its.it_value.tv_sec = (time_t)(next / 1000000000u);
        its.it_value.tv_nsec = (long)(next % 1000000000u);
        timerfd_settime(tfd, TFD_TIMER_ABSTIME, &its, NULL);
        struct pollfd p = {tfd, POLLIN, 0};
        if (poll(&p, 1, 1000) <= 0)
            continue;
        uint64_t exp;
        (void)!read(tfd, &exp, sizeof exp);
        seq++;
        memcpy(pkt, &seq, sizeof seq);
        (void)sendto(fd, pkt, sizeof pkt, 0, (struct sockaddr *)&to, sizeof to);
        uint64_t t = now_ns();
        next += period_ns;
        if (next <= t)
            next = t + period_ns;
    }
    char line[96];
    double wall = (double)(now_ns() - start) / 1e9;
    snprintf(line, sizeof line, "io cpu timerfd %.2f\nio wakeups timerfd %.3f\n",
             100.0 * (cpu_s() - cpu0) / wall,
             (double)(wakeups() - wake0) / (wall * 1e9 / period_ns));
    put_line(out, line);
    return 0;
}

/* ---- the client ------------------------------------------------------------------ */

static bool loop_timer; /* "loop": no timerfd, ppoll to the deadline */

static struct timespec wait_for(dr_client_t *c, uint64_t until_ns)
{
    uint64_t now = now_ns(), end = until_ns;
    if (end > now + 100000000u)
        end = now + 100000000u;
    uint64_t d = dr_client_next_deadline(c); /* us, the same clock */
    if (loop_timer && d != UINT64_MAX && d * 1000u < end)
        end = d * 1000u;
    uint64_t w = end > now ? end - now : 0;
    struct timespec ts = {(time_t)(w / 1000000000u), (long)(w % 1000000000u)};
    return ts;
}

static void run_client(dr_client_t *c, uint64_t until_ns, int extra_fd)
{
    while (now_ns() < until_ns) {
        dr_pollfd_t dfd[DR_CLIENT_MAX_FDS];
        struct pollfd p[DR_CLIENT_MAX_FDS + 1];
        int n = dr_client_pollfds(c, dfd, DR_CLIENT_MAX_FDS);
        for (int i = 0; i < n; i++) {
            p[i].fd = dfd[i].fd;
            p[i].events = (short)(((dfd[i].events & DR_POLL_IN) ? POLLIN : 0) |
                                  ((dfd[i].events & DR_POLL_OUT) ? POLLOUT : 0));
            p[i].revents = 0;
        }
        if (extra_fd >= 0) {
            p[n].fd = extra_fd;
            p[n].events = POLLIN;
            p[n].revents = 0;
        }
        int np = n + (extra_fd >= 0);
        if (loop_timer) {
            struct timespec ts = wait_for(c, until_ns);
            (void)ppoll(p, (nfds_t)np, &ts, NULL);
        } else {
            uint64_t left = (until_ns - now_ns()) / 1000000u;
            (void)poll(p, (nfds_t)np, left > 100 ? 100 : (int)left + 1);
        }
        for (int i = 0; i < n; i++)
            dfd[i].revents = p[i].revents;
        dr_client_process_ready(c, dfd, n);
        if (extra_fd >= 0 && (p[n].revents & (POLLIN | POLLHUP)))
            return;
    }
}

static pid_t spawn(int (*fn)(int, int, uint16_t, uint32_t, double), int ctl, int out,
                   uint16_t port, uint32_t period, double secs)
{
    pid_t pid = fork();
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        _exit(fn(ctl, out, port, period, secs));
    }
    return pid;
}

static int receiver_main(int ctl, int out, uint16_t port, uint32_t period, double secs)
{
    (void)port;
    (void)secs;
    return receiver(ctl, out, period);
}

static void reap(pid_t pid)
{
    for (int i = 0; i < 100; i++) {
        if (waitpid(pid, NULL, WNOHANG) == pid)
            return;
        struct timespec ts = {0, 50000000};
        nanosleep(&ts, NULL);
    }
    kill(pid, SIGKILL);
    waitpid(pid, NULL, 0);
}

int main(int argc, char **argv)
{
    double secs = argc > 1 ? strtod(argv[1], NULL) : 10.0;
    unsigned nconn = argc > 2 ? (unsigned)strtoul(argv[2], NULL, 10) : 6u;
    uint32_t rpi = argc > 3 ? (uint32_t)strtoul(argv[3], NULL, 10) : 1000u;
    uint32_t follow = argc > 4 ? (uint32_t)strtoul(argv[4], NULL, 10) : 0u;
    loop_timer = argc > 5 && strcmp(argv[5], "loop") == 0;
    if (!(secs > 0.0 && secs <= 60.0) || nconn < 1 || nconn > 16 || rpi < 1000u ||
        rpi > 1000000u || follow > rpi || (argc > 5 && !loop_timer)) {
        fprintf(stderr, "usage: enip_io [SECONDS (<= 60) [CONNECTIONS (1..16) [RPI_US (>= 1000)"
                        " [FOLLOW_US (<= RPI_US) [loop]]]]]\n");
        return 2;
    }
    signal(SIGPIPE, SIG_IGN);
    int rctl[2], rout[2], tctl[2], tout[2];
    if (pipe(rctl) || pipe(rout) || pipe(tctl) || pipe(tout))
        return 1;
    pid_t rx = spawn(receiver_main, rctl[0], rout[1], 0, rpi * 1000u, 0.0);
    char line[512];
    unsigned tcp_port, udp_port, bare_port;
    if (get_line(rout[0], line, sizeof line, 5000) != 0 ||
        sscanf(line, "ports %u %u %u", &tcp_port, &udp_port, &bare_port) != 3) {
        fprintf(stderr, "enip_io: the receiver did not start\n");
        reap(rx);
        return 1;
    }
    pid_t tm = spawn(bare_timer, tctl[0], tout[1], (uint16_t)bare_port, rpi * 1000u, secs);

    /* our UDP port: a free one on 127.0.0.1, announced in the 0x8001 item */
    uint16_t local_udp;
    {
        int fd = socket(AF_INET, SOCK_DGRAM, 0);
        struct sockaddr_in sa = sin_of(0x7F000001u, 0);
        socklen_t sl = sizeof sa;
        bind(fd, (struct sockaddr *)&sa, sizeof sa);
        getsockname(fd, (struct sockaddr *)&sa, &sl);
        local_udp = ntohs(sa.sin_port);
        close(fd);
    }
    dr_client_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.host = ADDR;
    cfg.tcp_port = (uint16_t)tcp_port;
    cfg.local_addr = "127.0.0.1";
    cfg.local_udp_port = local_udp;
    cfg.timeout_ms = 2000;
    static dr_transport_ops_t untimed;
    if (loop_timer) {
        /* ppoll's timeout has the task's timer slack (50 us by default);
         * a timerfd has none */
        (void)prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0);
        cfg.transport = dr_transport_posix();
        untimed = *cfg.transport.ops;
        untimed.timer_open = NULL;
        untimed.timer_arm = NULL;
        cfg.transport.ops = &untimed;
    }
    dr_client_t *c = dr_client_new(&cfg, NULL);
    static const struct { int o2t; dr_asm_t t2o; } pairs[] = {
        {DR_ASM_IO_CONTROL, DR_ASM_IO_STATE}, {DR_ASM_BIT_IN, DR_ASM_BIT_OUT},
        {DR_ASM_INT_IN, DR_ASM_INT_OUT}, {DR_ASM_FLOAT_IN, DR_ASM_FLOAT_OUT},
        {-1, DR_ASM_JOINT_STATE}, {-1, DR_ASM_TASK_STATE}};
    dr_conn_t *cn[16];
    for (unsigned i = 0; c != NULL && i < nconn; i++) {
        dr_conn_config_t cc;
        memset(&cc, 0, sizeof cc);
        cc.o2t_asm = pairs[i % 6].o2t;
        cc.t2o_asm = pairs[i % 6].t2o;
        cc.rpi_us = rpi;
        cc.timeout_mult = 5; /* x128: a busy VM stalls for tens of ms */
        cc.o2t_follow_us = follow;
        if (i >= 6)
            cc.o2t_asm = -1; /* O->T instances have one owner each */
        cn[i] = dr_conn_add(c, &cc, NULL);
        if (cn[i] == NULL) {
            fprintf(stderr, "enip_io: cannot add connection %u\n", i);
            return 1;
        }
    }
    int status = 0;
    if (c == NULL) {
        fprintf(stderr, "enip_io: client did not start\n");
        status = 1;
    } else {
        dr_client_start(c);
    }
    /* open everything (bounded), warm up, then the window */
    uint64_t deadline = now_ns() + 10000000000ull;
    bool up = false;
    while (status == 0 && !up && now_ns() < deadline) {
        run_client(c, now_ns() + 10000000u, -1);
        up = true;
        for (unsigned i = 0; i < nconn; i++)
            up = up && dr_conn_state(cn[i]) == DR_CONN_ESTABLISHED;
    }
    if (status == 0 && !up) {
        fprintf(stderr, "enip_io: connections did not open\n");
        status = 1;
    }
    if (status == 0) {
        run_client(c, now_ns() + (uint64_t)(WARMUP_S * 1e9), -1);
        uint64_t tx0 = 0, timeouts0 = 0;
        for (unsigned i = 0; i < nconn; i++) {
            tx0 += dr_conn_stats(cn[i])->tx_packets;
            timeouts0 += dr_conn_stats(cn[i])->timeouts;
        }
        double cpu0 = cpu_s();
        long wake0 = wakeups();
        uint64_t t0 = now_ns();
        put_line(rctl[1], "S");
        put_line(tctl[1], "S");
        run_client(c, t0 + (uint64_t)(secs * 1e9), -1);
        double cpu = cpu_s() - cpu0, wall = (double)(now_ns() - t0) / 1e9;
        long wake = wakeups() - wake0;
        put_line(rctl[1], "E");
        uint64_t tx = 0, timeouts = 0, lost = 0;
        for (unsigned i = 0; i < nconn; i++) {
            tx += dr_conn_stats(cn[i])->tx_packets;
            timeouts += dr_conn_stats(cn[i])->timeouts;
            lost += dr_conn_stats(cn[i])->rx_lost;
        }
        printf("io setup seconds %.1f connections %u rpi_us %u\n", secs, nconn, (unsigned)rpi);
        printf("io cpu client %.2f\n", 100.0 * cpu / wall);
        printf("io wakeups client %.3f\n", (double)wake / (wall * 1e6 / rpi));
        printf("io client tx %llu timeouts %llu t2o_lost %llu\n", (unsigned long long)(tx - tx0),
               (unsigned long long)(timeouts - timeouts0), (unsigned long long)lost);
        /* keep the connections fed while the receiver reports */
        uint64_t until = now_ns() + 10000000000ull;
        bool ended = false;
        while (!ended && now_ns() < until) {
            run_client(c, until, rout[0]);
            if (get_line(rout[0], line, sizeof line, 100) == 0) {
                if (strcmp(line, "end") == 0)
                    ended = true;
                else
                    printf("%s\n", line);
            }
        }
        /* the bare loop's two lines: its CPU, its wake-ups per period */
        for (int k = 0; k < 2; k++)
            if (get_line(tout[0], line, sizeof line, (int)(secs * 1000.0) + 5000) == 0)
                printf("%s\n", line);
        if (!ended) {
            fprintf(stderr, "enip_io: no report from the receiver\n");
            status = 1;
        }
    }
    dr_client_free(c); /* Forward Close, UnRegisterSession */
    put_line(rctl[1], "Q");
    close(tctl[1]);
    reap(rx);
    reap(tm);
    fflush(stdout);
    return status;
}
