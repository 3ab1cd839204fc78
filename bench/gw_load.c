/* SPDX-License-Identifier: MIT */
/*
 * gw_load: a Modbus TCP load generator for `make bench` (drgatewayd against
 * its baselines). One thread, one epoll loop driving N connections; each
 * connection keeps exactly one request outstanding and sends the next one
 * as soon as the answer is in, so the server always has N requests to
 * serve. Requests cycle through the given list (by default FC03 and FC04
 * reads of 125 registers at address 0); every answer is checked (transaction
 * ID, function code, byte count), exceptions and malformed answers are
 * counted as errors.
 *
 * usage: gw_load [-H HOST] -p PORT [-c CLIENTS] [-d SECONDS] [-w WARMUP]
 *                [-u UNIT] [-r FC:ADDR:COUNT]... [-l LABEL]
 * Prints one JSON object: requests per second over the measured period
 * (after the warm-up), latency percentiles (send of the request to the end
 * of its answer, in microseconds), errors.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#define MAX_CONNS 1024
#define MAX_REQS 8
#define ADU_MAX 260

typedef struct {
    uint8_t fc;
    uint16_t addr, count;
} req_spec_t;

typedef struct {
    int fd;
    uint16_t tid;
    unsigned next;      /* index into the request list */
    uint8_t fc;         /* of the outstanding request */
    uint16_t count;
    uint64_t sent_ns;
    uint8_t buf[ADU_MAX * 2];
    size_t len;
} conn_t;

static req_spec_t reqs[MAX_REQS];
static unsigned nreqs;

static uint32_t *lat;   /* nanoseconds, measured period only */
static size_t nlat, caplat;

static uint64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

static void die(const char *what)
{
    fprintf(stderr, "gw_load: %s: %s\n", what, strerror(errno));
    exit(1);
}

static void record(uint64_t ns)
{
    if (nlat == caplat) {
        caplat = caplat ? caplat * 2 : 1u << 16;
        lat = realloc(lat, caplat * sizeof *lat);
        if (lat == NULL)
            die("realloc");
    }
    lat[nlat++] = ns > UINT32_MAX ? UINT32_MAX : (uint32_t)ns;
}

static int cmp_u32(const void *a, const void *b)
{
    uint32_t x = *(const uint32_t *)a, y = *(const uint32_t *)b;
    return x < y ? -1 : x > y;
}

static double pct_us(double p)
{
    if (nlat == 0)
        return 0;
    size_t i = (size_t)(p / 100.0 * (double)(nlat - 1) + 0.5);
    return lat[i] / 1000.0;
}

static void send_request(conn_t *c, uint8_t unit)
{
    const req_spec_t *r = &reqs[c->next];
    c->next = (c->next + 1) % nreqs;
    c->tid++;
    uint8_t q[12] = {(uint8_t)(c->tid >> 8), (uint8_t)c->tid, 0, 0, 0, 6, unit, r->fc,
                     (uint8_t)(r->addr >> 8), (uint8_t)r->addr,
                     (uint8_t)(r->count >> 8), (uint8_t)r->count};
    c->fc = r->fc;
    c->count = r->count;
    c->sent_ns = now_ns();
    ssize_t n = send(c->fd, q, sizeof q, MSG_NOSIGNAL);
    if (n != (ssize_t)sizeof q)
        die("send (short or failed)"); /* 12 bytes into an empty socket buffer */
}

static bool parse_spec(const char *s, req_spec_t *r)
{
    unsigned fc, addr, count;
    char tail;
    if (sscanf(s, "%u:%u:%u%c", &fc, &addr, &count, &tail) != 3)
        return false;
    if ((fc != 3 && fc != 4) || count < 1 || count > 125 || addr + count > 65536)
        return false;
    r->fc = (uint8_t)fc;
    r->addr = (uint16_t)addr;
    r->count = (uint16_t)count;
    return true;
}

static void usage(void)
{
    fprintf(stderr,
            "usage: gw_load [-H HOST] -p PORT [-c CLIENTS] [-d SECONDS] [-w WARMUP_S]\n"
            "               [-u UNIT] [-r FC:ADDR:COUNT]... [-l LABEL]\n"
            "  -r  request, FC 3 or 4, COUNT 1..125; repeat to cycle through several\n"
            "      (default 3:0:125 and 4:0:125)\n");
    exit(2);
}

int main(int argc, char **argv)
{
    const char *host = "127.0.0.1", *label = "";
    int port = 0, nconns = 1, opt;
    double dur = 3.0, warm = 0.5;
    unsigned unit = 1;
    while ((opt = getopt(argc, argv, "H:p:c:d:w:u:r:l:")) != -1) {
        switch (opt) {
        case 'H': host = optarg; break;
        case 'p': port = atoi(optarg); break;
        case 'c': nconns = atoi(optarg); break;
        case 'd': dur = atof(optarg); break;
        case 'w': warm = atof(optarg); break;
        case 'u': unit = (unsigned)atoi(optarg); break;
        case 'l': label = optarg; break;
        case 'r':
            if (nreqs == MAX_REQS || !parse_spec(optarg, &reqs[nreqs++]))
                usage();
            break;
        default: usage();
        }
    }
    if (port <= 0 || port > 65535 || nconns < 1 || nconns > MAX_CONNS || dur <= 0 ||
        warm < 0 || unit > 255 || optind != argc)
        usage();
    if (nreqs == 0) {
        reqs[0] = (req_spec_t){3, 0, 125};
        reqs[1] = (req_spec_t){4, 0, 125};
        nreqs = 2;
    }

    struct sockaddr_in sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_port = htons((uint16_t)port);
    if (inet_pton(AF_INET, host, &sin.sin_addr) != 1) {
        fprintf(stderr, "gw_load: %s is not an IPv4 address\n", host);
        return 2;
    }
    int ep = epoll_create1(0);
    if (ep < 0)
        die("epoll_create1");
    conn_t *conns = calloc((size_t)nconns, sizeof *conns);
    if (conns == NULL)
        die("calloc");
    /* Connect everyone first (blocking), then start. */
    for (int i = 0; i < nconns; i++) {
        conn_t *c = &conns[i];
        c->fd = socket(AF_INET, SOCK_STREAM, 0);
        int one = 1;
        if (c->fd < 0)
            die("socket");
        (void)setsockopt(c->fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
        if (connect(c->fd, (struct sockaddr *)&sin, sizeof sin) < 0)
            die("connect");
        c->next = (unsigned)i % nreqs; /* mix the request kinds across clients */
        c->tid = (uint16_t)(i * 1000);
        struct epoll_event e = {.events = EPOLLIN, .data.ptr = c};
        if (epoll_ctl(ep, EPOLL_CTL_ADD, c->fd, &e) < 0)
            die("epoll_ctl");
    }
    for (int i = 0; i < nconns; i++)
        send_request(&conns[i], (uint8_t)unit);

    uint64_t t0 = now_ns();
    uint64_t t_start = t0 + (uint64_t)(warm * 1e9), t_end = t_start + (uint64_t)(dur * 1e9);
    uint64_t done = 0, errors = 0, exceptions = 0;
    uint64_t first_error_fc = 0;
    struct epoll_event evs[256];
    bool measuring = false;
    for (;;) {
        int n = epoll_wait(ep, evs, 256, 1000);
        if (n < 0 && errno != EINTR)
            die("epoll_wait");
        if (n == 0) {
            fprintf(stderr, "gw_load: %s: no answer for 1 s\n", label);
            return 1;
        }
        uint64_t t = now_ns();
        if (!measuring && t >= t_start)
            measuring = true;
        if (t >= t_end)
            break;
        for (int i = 0; i < n; i++) {
            conn_t *c = evs[i].data.ptr;
            ssize_t got = recv(c->fd, c->buf + c->len, sizeof c->buf - c->len, 0);
            if (got <= 0) {
                if (got < 0 && (errno == EAGAIN || errno == EINTR))
                    continue;
                fprintf(stderr, "gw_load: %s: connection %s\n", label,
                        got == 0 ? "closed by the server" : strerror(errno));
                return 1;
            }
            c->len += (size_t)got;
            while (c->len >= 8) {
                size_t total = 6u + (size_t)(c->buf[4] << 8 | c->buf[5]);
                if (total > ADU_MAX || total < 8) {
                    fprintf(stderr, "gw_load: %s: bad MBAP length %zu\n", label, total);
                    return 1;
                }
                if (c->len < total)
                    break;
                uint64_t tr = now_ns();
                uint16_t tid = (uint16_t)(c->buf[0] << 8 | c->buf[1]);
                uint8_t fc = c->buf[7];
                bool ok = tid == c->tid && fc == c->fc && total == 9u + 2u * c->count &&
                          c->buf[8] == 2u * c->count;
                if (!ok) {
                    errors++;
                    if (fc == (c->fc | 0x80)) {
                        exceptions++;
                        if (first_error_fc == 0)
                            first_error_fc = (uint64_t)fc << 8 | c->buf[8];
                    }
                } else if (measuring) {
                    done++;
                    record(tr - c->sent_ns);
                }
                memmove(c->buf, c->buf + total, c->len - total);
                c->len -= total;
                send_request(c, (uint8_t)unit);
            }
        }
    }
    double secs = (double)(now_ns() - t_start) / 1e9;
    qsort(lat, nlat, sizeof *lat, cmp_u32);
    printf("{\"label\": \"%s\", \"clients\": %d, \"seconds\": %.3f, \"requests\": %llu, "
           "\"rps\": %.0f, \"p50_us\": %.1f, \"p90_us\": %.1f, \"p99_us\": %.1f, "
           "\"p999_us\": %.1f, \"max_us\": %.1f, \"errors\": %llu, \"exceptions\": %llu",
           label, nconns, secs, (unsigned long long)done, (double)done / secs, pct_us(50),
           pct_us(90), pct_us(99), pct_us(99.9), pct_us(100), (unsigned long long)errors,
           (unsigned long long)exceptions);
    if (first_error_fc != 0)
        printf(", \"first_exception\": \"fc 0x%02x code 0x%02x\"",
               (unsigned)(first_error_fc >> 8), (unsigned)(first_error_fc & 0xFF));
    printf("}\n");
    for (int i = 0; i < nconns; i++)
        close(conns[i].fd);
    free(conns);
    free(lat);
    return errors != 0;
}
