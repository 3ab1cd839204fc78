/* SPDX-License-Identifier: MIT */
/*
 * make bench: a bare TCP ping-pong on loopback, the physical limit that
 * explicit messaging is measured against (bench/bench_enip.py). A child
 * process answers every REQ-byte message with REP bytes, as drsim answers
 * a Get_Attribute_Single; the parent counts round trips for SECONDS. Both
 * sides are blocking C with TCP_NODELAY, nothing else: no parsing, no
 * event loop. Every receive has a 2 s timeout.
 *
 * usage: pingpong ADDR REQ_BYTES REP_BYTES SECONDS
 * prints: pingpong ROUND_TRIPS SECONDS RATE_PER_S
 * SECONDS 0: read durations from stdin, one per line, and measure one
 * slice per line on the same connection (bench_enip.py interleaves the
 * slices with the other measurements), until end of input.
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <signal.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define MAX_MSG 1024

static double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec / 1e9;
}

static void tune(int fd)
{
    int one = 1;
    struct timeval tv = {2, 0};
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
}

/* Exactly n bytes, or -1 (error, timeout or close). */
static int read_all(int fd, unsigned char *buf, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t r = recv(fd, buf + got, n - got, 0);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return -1;
        got += (size_t)r;
    }
    return 0;
}

static int write_all(int fd, const unsigned char *buf, size_t n)
{
    size_t put = 0;
    while (put < n) {
        ssize_t r = send(fd, buf + put, n - put, MSG_NOSIGNAL);
        if (r < 0 && errno == EINTR)
            continue;
        if (r <= 0)
            return -1;
        put += (size_t)r;
    }
    return 0;
}

static void serve(int lfd, size_t req, size_t rep)
{
    unsigned char in[MAX_MSG], out[MAX_MSG];
    memset(out, 0x5A, sizeof out);
    int fd = accept(lfd, NULL, NULL);
    if (fd < 0)
        _exit(1);
    tune(fd);
    while (read_all(fd, in, req) == 0)
        if (write_all(fd, out, rep) != 0)
            break;
    close(fd);
    _exit(0);
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: pingpong ADDR REQ_BYTES REP_BYTES SECONDS\n");
        return 2;
    }
    size_t req = strtoul(argv[2], NULL, 10), rep = strtoul(argv[3], NULL, 10);
    double secs = strtod(argv[4], NULL);
    if (req == 0 || rep == 0 || req > MAX_MSG || rep > MAX_MSG || !(secs >= 0.0)) {
        fprintf(stderr, "pingpong: bad sizes or duration\n");
        return 2;
    }
    struct sockaddr_in sa;
    socklen_t sl = sizeof sa;
    memset(&sa, 0, sizeof sa);
    sa.sin_family = AF_INET;
    if (inet_pton(AF_INET, argv[1], &sa.sin_addr) != 1) {
        fprintf(stderr, "pingpong: bad address %s\n", argv[1]);
        return 2;
    }
    int lfd = socket(AF_INET, SOCK_STREAM, 0);
    if (lfd < 0 || bind(lfd, (struct sockaddr *)&sa, sizeof sa) != 0 || listen(lfd, 1) != 0 ||
        getsockname(lfd, (struct sockaddr *)&sa, &sl) != 0) {
        perror("pingpong: listen");
        return 1;
    }
    pid_t pid = fork();
    if (pid < 0)
        return 1;
    if (pid == 0) {
        prctl(PR_SET_PDEATHSIG, SIGKILL);
        serve(lfd, req, rep);
    }
    close(lfd);
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0 || connect(fd, (struct sockaddr *)&sa, sizeof sa) != 0) {
        perror("pingpong: connect");
        kill(pid, SIGKILL);
        return 1;
    }
    tune(fd);
    unsigned char out[MAX_MSG], in[MAX_MSG];
    memset(out, 0xA5, sizeof out);
    int status = 0;
    char line[64];
    bool once = secs > 0.0;
    while (status == 0) {
        if (!once) {
            if (fgets(line, sizeof line, stdin) == NULL)
                break;
            secs = strtod(line, NULL);
            if (!(secs > 0.0))
                break;
        }
        unsigned long n = 0;
        double t0 = now_s(), t = t0;
        while (t - t0 < secs) {
            if (write_all(fd, out, req) != 0 || read_all(fd, in, rep) != 0) {
                fprintf(stderr, "pingpong: round trip failed\n");
                status = 1;
                break;
            }
            n++;
            if ((n & 63u) == 0)
                t = now_s();
        }
        t = now_s() - t0;
        printf("pingpong %lu %.3f %.1f\n", n, t, (double)n / t);
        fflush(stdout);
        if (once)
            break;
    }
    close(fd);
    waitpid(pid, NULL, 0);
    return status;
}
