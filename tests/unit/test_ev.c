/* SPDX-License-Identifier: MIT */
/*
 * The event loop drsim and drgatewayd share (common/ev.c): callbacks get
 * what is ready, deadlines are never kept early (an early wake-up would
 * make the caller spin), no wait is unbounded, signals arrive as events,
 * and the loop leaves no descriptor open.
 */
#define _GNU_SOURCE /* pipe2 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/epoll.h>
#include <unistd.h>
#include <cmocka.h>

#include "common/ev.h"

#define MS 1000000u

typedef struct {
    unsigned calls;
    uint32_t events;
} seen_t;

static void on_ready(void *obj, uint32_t events)
{
    seen_t *s = obj;
    s->calls++;
    s->events = events;
}

static unsigned open_fds(void)
{
    DIR *d = opendir("/proc/self/fd");
    unsigned n = 0;
    assert_non_null(d);
    while (readdir(d) != NULL)
        n++;
    closedir(d);
    return n;
}

/* A readable pipe's callback runs once per turn it is ready, with its
 * events; unwatched, it runs no more. */
static void test_watch(void **state)
{
    (void)state;
    ev_loop_t L;
    int p[2];
    seen_t seen = {0, 0};
    ev_t ev = {on_ready, &seen, -1, 0};
    assert_true(ev_open(&L, EV_FINE));
    assert_int_equal(pipe2(p, O_NONBLOCK | O_CLOEXEC), 0);
    assert_true(ev_watch(L.epfd, &ev, p[0], EPOLLIN));
    assert_true(ev_watch(L.epfd, &ev, p[0], EPOLLIN)); /* the same again */
    assert_int_equal(ev.fd, p[0]);
    assert_int_equal(write(p[1], "x", 1), 1);
    assert_int_equal(ev_run(&L, ev_now_ns() + 1000u * MS), 1);
    assert_int_equal(seen.calls, 1);
    assert_int_equal(seen.events, EPOLLIN);
    ev_unwatch(L.epfd, &ev);
    assert_int_equal(ev.fd, -1);
    assert_int_equal(ev_run(&L, 0), 0); /* still readable, but not watched */
    assert_int_equal(seen.calls, 1);
    close(p[0]);
    close(p[1]);
    ev_close(&L);
}

/* EV_FINE: the wait ends on its timeout, never before the deadline, with
 * epoll_pwait2 or on whole milliseconds. */
static void test_fine_deadline(void **state)
{
    (void)state;
    ev_loop_t L;
    assert_true(ev_open(&L, EV_FINE));
    for (unsigned i = 0; i < 5; i++) {
        uint64_t d = ev_now_ns() + 3u * MS + i * 123457u;
        assert_int_equal(ev_run(&L, d), 0);
        assert_true(ev_now_ns() >= d);
    }
    ev_close(&L);
}

/* EV_TIMER: the loop's timerfd wakes it (one ready descriptor, not the
 * timeout), not before the deadline, and again for the next one. */
static void test_timer_deadline(void **state)
{
    (void)state;
    ev_loop_t L;
    assert_true(ev_open(&L, EV_TIMER));
    for (unsigned i = 0; i < 5; i++) {
        uint64_t d = ev_now_ns() + 3u * MS + i * 123457u;
        assert_int_equal(ev_run(&L, d), 1);
        assert_true(ev_now_ns() >= d);
    }
    /* a deadline that has passed: at once */
    assert_int_equal(ev_run(&L, ev_now_ns() - 1u), 1);
    ev_close(&L);
}

/* No deadline at all: the wait still ends, after a second at most. */
static void test_bounded_wait(void **state)
{
    (void)state;
    ev_loop_t L;
    ev_timing_t t[2] = {EV_FINE, EV_TIMER};
    for (unsigned i = 0; i < 2; i++) {
        assert_true(ev_open(&L, t[i]));
        assert_int_equal(ev_run(&L, UINT64_MAX), 0);
        ev_close(&L);
    }
}

static int got_signal;

static void on_signal(void *obj, int signo)
{
    (void)obj;
    got_signal = signo;
}

/* A signal is an event of the loop; SIGPIPE is ignored. */
static void test_signals(void **state)
{
    (void)state;
    static const int sigs[] = {SIGUSR1};
    ev_loop_t L;
    assert_true(ev_open(&L, EV_FINE));
    assert_true(ev_signals(&L, sigs, 1, on_signal, NULL));
    assert_int_equal(raise(SIGUSR1), 0); /* blocked: waits in the signalfd */
    assert_int_equal(ev_run(&L, ev_now_ns() + 1000u * MS), 1);
    assert_int_equal(got_signal, SIGUSR1);
    struct sigaction sa;
    assert_int_equal(sigaction(SIGPIPE, NULL, &sa), 0);
    assert_true(sa.sa_handler == SIG_IGN);
    ev_close(&L);
}

/* ev_close closes what the loop opened: the epoll set, the timer, the
 * signalfd. */
static void test_close(void **state)
{
    (void)state;
    static const int sigs[] = {SIGUSR2};
    ev_loop_t L;
    unsigned before = open_fds();
    assert_true(ev_open(&L, EV_TIMER));
    assert_true(ev_signals(&L, sigs, 1, on_signal, NULL));
    assert_int_equal(open_fds(), before + 3);
    ev_close(&L);
    assert_int_equal(open_fds(), before);
    assert_int_equal(L.epfd, -1);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_watch),
        cmocka_unit_test(test_fine_deadline),
        cmocka_unit_test(test_timer_deadline),
        cmocka_unit_test(test_bounded_wait),
        cmocka_unit_test(test_signals),
        cmocka_unit_test(test_close),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
