/* SPDX-License-Identifier: MIT */
/*
 * The bare baseline of bench-gw's latency goal (issue 30 item 6): the path
 * of a robot packet to Modbus visibility with no gateway in it. Three
 * processes on loopback:
 *
 *  - a sender (the robot): every RPI, on an absolute timerfd, a burst of
 *    six datagrams (sendmmsg) the sizes of the six T->O Class 1 packets
 *    the gateway receives (the T->O assemblies, plus 20 bytes of CPF as
 *    the Class 1 frame has);
 *  - the writer (the daemon's part): epoll_wait on its UDP socket, then
 *    each datagram read one at a time (recvfrom, as drgatewayd-lat reads
 *    them), its kernel receive stamp (SIOCGSTAMPNS, as bench/gw_lat.c),
 *    its bytes copied into an image in shared memory under a sequence
 *    lock, and the time taken: "written", the point where drgatewayd-lat
 *    takes "visible" (the data in the image Modbus reads answer from);
 *    after each wake-up's datagrams it wakes the reader (a futex);
 *  - a reader (a Modbus client's place): waits on the futex, copies the
 *    image out under the sequence lock and takes the time: "read".
 *
 * Everything CLOCK_REALTIME, as the kernel's stamp. Prints one JSON line:
 * the percentiles of written - arrival, of read - arrival, and of the
 * writer's own part (written - the later of arrival and its wake-up, as
 * gw_bench.py's "in the loop").
 *
 * usage: lat_bare [-a ADDR] [-s SECONDS] [-r RPI_US] [-w WARMUP_S] [-R]
 *        (-R: no reader process; bench/gw_bench.py runs it with the reader)
 */
#define _GNU_SOURCE
#include <errno.h>
#include <linux/futex.h>
#include <linux/sockios.h>
#include <netinet/in.h>
#include <arpa/inet.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/timerfd.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#define SLOTS 6
#define CPF 20u
#define MAX_SAMPLES (1u << 20)
static const unsigned slot_size[SLOTS] = {36, 144, 96, 8, 96, 96}; /* dr1..dr6 */

struct image {
    uint32_t seq;      /* odd while written */
    uint32_t futex;    /* bumped after each wake-up's datagrams */
    uint32_t stop;
    int64_t arrival[SLOTS];    /* the kernel stamp of the data in each slot */
    uint8_t data[SLOTS][160];
    /* the reader's samples, read - arrival (ns) */
    uint32_t nread;
    int64_t read_ns[MAX_SAMPLES];
};

/* (C99: GCC's and Clang's __atomic builtins, not C11's stdatomic.h) */
#define LOAD(p) __atomic_load_n((p), __ATOMIC_ACQUIRE)
#define STORE(p, v) __atomic_store_n((p), (v), __ATOMIC_RELEASE)
#define BUMP(p) ((void)__atomic_fetch_add((p), 1u, __ATOMIC_RELEASE))

static int64_t now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_REALTIME, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static void die(const char *what)
{
    perror(what);
    exit(2);
}

static long futex(uint32_t *addr, int op, uint32_t val)
{
    return syscall(SYS_futex, addr, op, val, NULL, NULL, 0);
}

static void sender(int fd, const struct sockaddr_in *to, unsigned rpi_us)
{
    static uint8_t buf[SLOTS][200];
    struct iovec iov[SLOTS];
    struct mmsghdr msg[SLOTS];
    memset(msg, 0, sizeof msg);
    for (unsigned i = 0; i < SLOTS; i++) {
        iov[i].iov_base = buf[i];
        iov[i].iov_len = slot_size[i] + CPF;
        msg[i].msg_hdr.msg_iov = &iov[i];
        msg[i].msg_hdr.msg_iovlen = 1;
        msg[i].msg_hdr.msg_name = (void *)to;
        msg[i].msg_hdr.msg_namelen = sizeof *to;
    }
    int tfd = timerfd_create(CLOCK_MONOTONIC, 0);
    if (tfd < 0)
        die("timerfd_create");
    struct itimerspec its = {{0, (long)rpi_us * 1000}, {0, (long)rpi_us * 1000}};
    if (timerfd_settime(tfd, 0, &its, NULL) < 0)
        die("timerfd_settime");
    for (uint32_t n = 0;; n++) {
        uint64_t exp;
        if (read(tfd, &exp, sizeof exp) < 0 && errno != EINTR)
            die("read timerfd");
        for (unsigned i = 0; i < SLOTS; i++)
            memcpy(buf[i] + CPF, &n, sizeof n);
        (void)sendmmsg(fd, msg, SLOTS, 0);
    }
}

static void reader(struct image *im)
{
    static uint8_t copy[SLOTS][160];
    int64_t seen[SLOTS] = {0}, arr[SLOTS];
    for (;;) {
        uint32_t f = LOAD(&im->futex);
        if (LOAD(&im->stop))
            _exit(0);
        futex(&im->futex, FUTEX_WAIT, f);
        uint32_t s0, s1;
        do {
            while ((s0 = LOAD(&im->seq)) & 1u)
                ;
            memcpy(copy, im->data, sizeof copy);
            memcpy(arr, im->arrival, sizeof arr);
            __atomic_thread_fence(__ATOMIC_ACQUIRE);
            s1 = __atomic_load_n(&im->seq, __ATOMIC_RELAXED);
        } while (s0 != s1);
        int64_t t = now_ns();
        for (unsigned i = 0; i < SLOTS; i++) {
            if (arr[i] != seen[i] && arr[i] != 0) {
                seen[i] = arr[i];
                uint32_t k = LOAD(&im->nread);
                if (k < MAX_SAMPLES) {
                    im->read_ns[k] = t - arr[i];
                    STORE(&im->nread, k + 1);
                }
            }
        }
    }
}

static int cmp64(const void *a, const void *b)
{
    int64_t x = *(const int64_t *)a, y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

static double pct(const int64_t *xs, size_t n, double p)
{
    if (n == 0)
        return -1;
    size_t i = (size_t)(p / 100.0 * (double)(n - 1) + 0.5);
    return (double)xs[i < n ? i : n - 1] / 1000.0;
}

static void stats(const char *name, int64_t *xs, size_t n, int comma)
{
    qsort(xs, n, sizeof *xs, cmp64);
    printf("\"%s\": {\"n\": %zu, \"p50\": %.1f, \"p99\": %.1f, \"p999\": %.1f, \"max\": %.1f}%s",
           name, n, pct(xs, n, 50), pct(xs, n, 99), pct(xs, n, 99.9), pct(xs, n, 100),
           comma ? ", " : "");
}

int main(int argc, char **argv)
{
    const char *addr = "127.0.42.1";
    double seconds = 5.0, warmup = 0.5;
    unsigned rpi_us = 2000;
    int opt;
    int no_reader = 0;
    while ((opt = getopt(argc, argv, "a:s:r:w:R")) != -1) {
        switch (opt) {
        case 'a': addr = optarg; break;
        case 's': seconds = atof(optarg); break;
        case 'r': rpi_us = (unsigned)atoi(optarg); break;
        case 'w': warmup = atof(optarg); break;
        case 'R': no_reader = 1; break;
        default:
            fprintf(stderr, "usage: lat_bare [-a ADDR] [-s SECONDS] [-r RPI_US] [-w WARMUP_S] [-R]\n");
            return 2;
        }
    }
    struct image *im = mmap(NULL, sizeof *im, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS,
                            -1, 0);
    if (im == MAP_FAILED)
        die("mmap");
    int rx = socket(AF_INET, SOCK_DGRAM, 0), tx = socket(AF_INET, SOCK_DGRAM, 0);
    if (rx < 0 || tx < 0)
        die("socket");
    struct sockaddr_in sa = {.sin_family = AF_INET};
    if (inet_pton(AF_INET, addr, &sa.sin_addr) != 1)
        die("address");
    socklen_t sl = sizeof sa;
    if (bind(rx, (struct sockaddr *)&sa, sizeof sa) < 0 || getsockname(rx, (struct sockaddr *)&sa, &sl) < 0)
        die("bind");
    pid_t rd = no_reader ? 1 : fork();
    if (rd == 0)
        reader(im);
    pid_t sd = fork();
    if (sd == 0) {
        close(rx);
        sender(tx, &sa, rpi_us);
        _exit(0);
    }
    if (rd < 0 || sd < 0)
        die("fork");
    close(tx);

    int ep = epoll_create1(0);
    struct epoll_event ev = {.events = EPOLLIN, .data.fd = rx};
    if (ep < 0 || epoll_ctl(ep, EPOLL_CTL_ADD, rx, &ev) < 0)
        die("epoll");
    size_t cap = MAX_SAMPLES, n = 0;
    int64_t *wr = malloc(cap * sizeof *wr), *loop = malloc(cap * sizeof *loop);
    if (wr == NULL || loop == NULL)
        die("malloc");
    int64_t t0 = now_ns(), from = t0 + (int64_t)(warmup * 1e9),
            end = from + (int64_t)(seconds * 1e9);
    uint32_t read_from = 0;
    int warm = 0;
    uint8_t buf[2048];
    for (;;) {
        struct epoll_event got;
        int k = epoll_wait(ep, &got, 1, 1000);
        int64_t wake = now_ns();
        if (k < 0 && errno != EINTR)
            die("epoll_wait");
        if (wake >= end)
            break;
        if (!warm && wake >= from) {
            warm = 1;
            read_from = LOAD(&im->nread);
        }
        for (;;) {
            ssize_t len = recv(rx, buf, sizeof buf, MSG_DONTWAIT);
            if (len < 0)
                break;
            struct timespec ts;
            if (ioctl(rx, SIOCGSTAMPNS, &ts) < 0)
                die("SIOCGSTAMPNS");
            int64_t at = (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
            unsigned slot = SLOTS;
            for (unsigned i = 0; i < SLOTS; i++)
                if ((size_t)len == slot_size[i] + CPF)
                    slot = i;
            if (slot == SLOTS)
                continue;
            uint32_t s = __atomic_load_n(&im->seq, __ATOMIC_RELAXED);
            __atomic_store_n(&im->seq, s + 1u, __ATOMIC_RELAXED);
            __atomic_thread_fence(__ATOMIC_RELEASE);
            memcpy(im->data[slot], buf + CPF, slot_size[slot]);
            im->arrival[slot] = at;
            STORE(&im->seq, s + 2u);
            int64_t vis = now_ns();
            if (warm && n < cap) {
                wr[n] = vis - at;
                loop[n++] = vis - (at > wake ? at : wake);
            }
        }
        BUMP(&im->futex);
        futex(&im->futex, FUTEX_WAKE, 1);
    }
    kill(sd, SIGTERM);
    STORE(&im->stop, 1u);
    BUMP(&im->futex);
    futex(&im->futex, FUTEX_WAKE, 1);
    waitpid(sd, NULL, 0);
    if (!no_reader)
        waitpid(rd, NULL, 0);
    uint32_t nr = LOAD(&im->nread);
    printf("{");
    stats("written", wr, n, 1);
    stats("loop", loop, n, 1);
    stats("read", im->read_ns + read_from, nr > read_from ? nr - read_from : 0, 0);
    printf("}\n");
    return 0;
}
