/* SPDX-License-Identifier: MIT */
/* The event loop of drsim and drgatewayd (ev.h). */
#define _GNU_SOURCE /* signalfd, timerfd, syscall */
#include <errno.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdio.h>
#include <string.h>
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/prctl.h>
#include <sys/signalfd.h>
#include <sys/syscall.h>
#include <sys/timerfd.h>
#include <time.h>
#include <unistd.h>

#include "common/ev.h"

#define MAX_EVENTS 32          /* per wait; the rest wait for the next turn */
#define WAIT_MAX_NS 1000000000u /* no wait is longer */

/* ---- the clock ------------------------------------------------------------------ */

uint64_t ev_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

uint64_t ev_now_us(void)
{
    return ev_now_ns() / 1000u;
}

/* ---- registration ----------------------------------------------------------------- */

bool ev_watch(int epfd, ev_t *ev, int fd, uint32_t events)
{
    if (ev->fd >= 0 && ev->fd != fd)
        ev_unwatch(epfd, ev);
    struct epoll_event e;
    memset(&e, 0, sizeof e);
    e.events = events;
    e.data.ptr = ev;
    int op = ev->fd == fd ? EPOLL_CTL_MOD : EPOLL_CTL_ADD;
    if (op == EPOLL_CTL_MOD && ev->events == events)
        return true;
    if (epoll_ctl(epfd, op, fd, &e) < 0)
        return false;
    ev->fd = fd;
    ev->events = events;
    return true;
}

void ev_unwatch(int epfd, ev_t *ev)
{
    if (ev->fd >= 0)
        (void)epoll_ctl(epfd, EPOLL_CTL_DEL, ev->fd, NULL);
    ev->fd = -1;
    ev->events = 0;
}

/* ---- the wait ------------------------------------------------------------------------ */

/* epoll_pwait2 takes its timeout as a timespec. glibc has a wrapper only
 * since 2.35, hence syscall(). */
#ifdef SYS_epoll_pwait2
#define SIGSET_BYTES 8 /* the kernel's sigset_t (_NSIG / 8); no mask is passed */
static int pwait2(int epfd, struct epoll_event *evs, int max, uint64_t wait_ns)
{
    struct timespec ts = {(time_t)(wait_ns / 1000000000u), (long)(wait_ns % 1000000000u)};
    return (int)syscall(SYS_epoll_pwait2, epfd, evs, max, &ts, NULL, SIGSET_BYTES);
}
#endif

static bool probe_pwait2(int epfd)
{
#ifdef SYS_epoll_pwait2
    struct epoll_event ev;
    /* The kernel's timer slack (50 us by default) would make every wake-up
     * on the wait's timeout that much late; a timerfd has none. */
    if (pwait2(epfd, &ev, 1, 0) >= 0 && prctl(PR_SET_TIMERSLACK, 1000UL, 0, 0, 0) == 0)
        return true;
#else
    (void)epfd;
#endif
    return false;
}

/* EV_TIMER: the timerfd at the absolute deadline, unless it is already. */
static void arm(ev_loop_t *L, uint64_t deadline_ns)
{
    if (deadline_ns == 0)
        deadline_ns = 1; /* 0 would disarm it */
    if (deadline_ns == L->armed_ns)
        return;
    struct itimerspec its;
    memset(&its, 0, sizeof its);
    its.it_value.tv_sec = (time_t)(deadline_ns / 1000000000u);
    its.it_value.tv_nsec = (long)(deadline_ns % 1000000000u);
    if (timerfd_settime(L->timer.fd, TFD_TIMER_ABSTIME, &its, NULL) == 0)
        L->armed_ns = deadline_ns;
}

static int wait_events(ev_loop_t *L, struct epoll_event *evs, uint64_t deadline_ns)
{
    if (L->timer.fd >= 0) {
        arm(L, deadline_ns);
        return epoll_wait(L->epfd, evs, MAX_EVENTS, (int)(WAIT_MAX_NS / 1000000u));
    }
    uint64_t now = ev_now_ns();
    uint64_t wait = deadline_ns <= now ? 0 : deadline_ns - now;
    if (wait > WAIT_MAX_NS)
        wait = WAIT_MAX_NS;
#ifdef SYS_epoll_pwait2
    if (L->fine) {
        int n = pwait2(L->epfd, evs, MAX_EVENTS, wait);
#ifdef EV_BENCH_WOKE
        EV_BENCH_WOKE(); /* make bench's drgatewayd-lat: bench/gw_lat_hook.h */
#endif
        return n;
    }
#endif
    return epoll_wait(L->epfd, evs, MAX_EVENTS, (int)((wait + 999999u) / 1000000u));
}

int ev_run(ev_loop_t *L, uint64_t deadline_ns)
{
    struct epoll_event evs[MAX_EVENTS];
    int n = wait_events(L, evs, deadline_ns);
    if (n < 0)
        return errno == EINTR ? 0 : -1;
    for (int i = 0; i < n; i++) {
        ev_t *ev = evs[i].data.ptr;
        ev->fn(ev->obj, evs[i].events);
    }
    return n;
}

/* ---- the loop's own descriptors ---------------------------------------------------------- */

static void on_timer(void *obj, uint32_t events)
{
    ev_loop_t *L = obj;
    uint64_t expirations;
    (void)events;
    if (read(L->timer.fd, &expirations, sizeof expirations) == (ssize_t)sizeof expirations)
        L->armed_ns = 0; /* expired: the next deadline arms it again */
}

static void on_signalfd(void *obj, uint32_t events)
{
    ev_loop_t *L = obj;
    struct signalfd_siginfo si;
    (void)events;
    while (read(L->sig.fd, &si, sizeof si) == (ssize_t)sizeof si)
        L->on_signal(L->sig_obj, (int)si.ssi_signo);
}

/* ---- a worker beside the loop ----------------------------------------------------- */

static void *worker_main(void *arg)
{
    ev_worker_t *w = arg;
    struct sched_param p = {.sched_priority = 0};
    (void)pthread_setname_np(pthread_self(), w->name); /* a name too long: left as it was */
    (void)pthread_setschedparam(pthread_self(), SCHED_IDLE, &p);
    return w->fn(w->arg);
}

int ev_worker_open(ev_worker_t *w, const char *name, void *(*fn)(void *), void *arg)
{
    w->stop = false;
    w->fn = fn;
    w->arg = arg;
    snprintf(w->name, sizeof w->name, "%s", name);
    w->efd = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    if (w->efd < 0)
        return errno;
    int e = pthread_mutex_init(&w->mu, NULL);
    if (e == 0 && (e = pthread_cond_init(&w->cv, NULL)) != 0)
        (void)pthread_mutex_destroy(&w->mu);
    if (e == 0 && (e = pthread_create(&w->thread, NULL, worker_main, w)) != 0) {
        (void)pthread_cond_destroy(&w->cv);
        (void)pthread_mutex_destroy(&w->mu);
    }
    if (e != 0) {
        (void)close(w->efd);
        w->efd = -1;
    }
    return e;
}

void ev_worker_close(ev_worker_t *w)
{
    (void)pthread_mutex_lock(&w->mu);
    w->stop = true;
    (void)pthread_cond_broadcast(&w->cv);
    (void)pthread_mutex_unlock(&w->mu);
    (void)pthread_join(w->thread, NULL);
    (void)pthread_cond_destroy(&w->cv);
    (void)pthread_mutex_destroy(&w->mu);
    (void)close(w->efd);
    w->efd = -1;
}

void ev_worker_done(ev_worker_t *w)
{
    uint64_t one = 1;
    while (write(w->efd, &one, sizeof one) < 0 && errno == EINTR)
        ;
}

bool ev_open(ev_loop_t *L, ev_timing_t timing)
{
    memset(L, 0, sizeof *L);
    L->timer = (ev_t){on_timer, L, -1, 0};
    L->sig = (ev_t){on_signalfd, L, -1, 0};
    L->epfd = epoll_create1(EPOLL_CLOEXEC);
    if (L->epfd < 0)
        return false;
    if (timing == EV_FINE) {
        L->fine = probe_pwait2(L->epfd);
        return true;
    }
    int fd = timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    if (fd < 0)
        return false;
    if (!ev_watch(L->epfd, &L->timer, fd, EPOLLIN)) {
        close(fd);
        return false;
    }
    return true;
}

bool ev_signals(ev_loop_t *L, const int *signals, size_t n, ev_signal_fn fn, void *obj)
{
    sigset_t set;
    sigemptyset(&set);
    for (size_t i = 0; i < n; i++)
        sigaddset(&set, signals[i]);
    if (sigprocmask(SIG_BLOCK, &set, NULL) != 0)
        return false;
    (void)signal(SIGPIPE, SIG_IGN);
    int fd = signalfd(-1, &set, SFD_NONBLOCK | SFD_CLOEXEC);
    if (fd < 0)
        return false;
    L->on_signal = fn;
    L->sig_obj = obj;
    if (!ev_watch(L->epfd, &L->sig, fd, EPOLLIN)) {
        close(fd);
        return false;
    }
    return true;
}

void ev_close(ev_loop_t *L)
{
    int fds[] = {L->timer.fd, L->sig.fd, L->epfd};
    for (size_t i = 0; i < sizeof fds / sizeof fds[0]; i++)
        if (fds[i] >= 0)
            close(fds[i]);
    L->timer.fd = L->sig.fd = L->epfd = -1;
}
