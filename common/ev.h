/* SPDX-License-Identifier: MIT */
/*
 * The event loop of drsim and drgatewayd: one thread, one epoll set per
 * process. Every descriptor is registered with an ev_t, whose callback
 * gets its ready events; ev_run waits until one is ready or the caller's
 * next deadline comes, whichever is first, and runs the callbacks. The
 * caller then does what is due and asks for its next deadline again.
 *
 * How the deadline is kept (ev_timing_t):
 *   EV_FINE   by the wait's own timeout: to the microsecond with
 *             epoll_pwait2 (Linux 5.11, called through syscall(); the
 *             process's timer slack is set to 1 us), or, where the kernel
 *             or valgrind 3.19 lacks it, in whole milliseconds rounded up.
 *             ev_loop_t.fine says which, so that a caller can keep timers
 *             of its own for exact deadlines (drgatewayd's robot clients).
 *   EV_TIMER  by one timerfd armed at the absolute deadline
 *             (TFD_TIMER_ABSTIME): to the nanosecond on any kernel, no
 *             drift however long the work in between (drsim).
 * Every wait ends after a second at most, so nothing blocks for good, and
 * a deadline in the past returns at once: nothing spins unless the caller
 * keeps asking for a time that has passed.
 *
 * Linux only, so not in lib/ (firmware code): see README.md's layout.
 */
#ifndef DRGATE_EV_H
#define DRGATE_EV_H

#include <pthread.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

typedef void (*ev_fn)(void *obj, uint32_t events);

/* One watched descriptor: set fn and obj, and fd to -1 until ev_watch. */
typedef struct {
    ev_fn fn;
    void *obj;
    int fd;           /* -1 when not registered */
    uint32_t events;  /* EPOLLIN / EPOLLOUT as registered */
} ev_t;

typedef enum { EV_FINE, EV_TIMER } ev_timing_t;

typedef void (*ev_signal_fn)(void *obj, int signo);

typedef struct {
    int epfd;      /* the epoll set: what ev_watch takes */
    bool fine;     /* EV_FINE with epoll_pwait2: waits to the microsecond */
    /* the rest is ev.c's */
    ev_t timer;    /* EV_TIMER's timerfd */
    uint64_t armed_ns;
    ev_t sig;      /* ev_signals' signalfd */
    ev_signal_fn on_signal;
    void *sig_obj;
} ev_loop_t;

/* Open the loop. False (errno set) if a descriptor cannot be made; call
 * ev_close in either case. */
bool ev_open(ev_loop_t *L, ev_timing_t timing);

/* Close every descriptor the loop opened (not those watched in it). */
void ev_close(ev_loop_t *L);

/* Deliver `signals` as events: blocked, read from a signalfd, and each
 * given to fn(obj, signo) from ev_run. SIGPIPE is ignored as well, so that
 * a peer that goes away is an error return, not the end of the process.
 * False (errno set) on failure. */
bool ev_signals(ev_loop_t *L, const int *signals, size_t n, ev_signal_fn fn, void *obj);

/* Wait until something is ready or until deadline_ns (ev_now_ns's clock),
 * at most one second, and run the callbacks of what is ready. Returns the
 * number of ready descriptors, 0 on a timeout or a signal; -1 (errno set)
 * if the wait itself failed. */
int ev_run(ev_loop_t *L, uint64_t deadline_ns);

/* Register ev->fd in the set `epfd` for `events`, or change what it waits
 * for (another fd replaces the one registered); ev_unwatch removes it.
 * Asking again for what is registered costs no system call. Returns false
 * on an epoll error. */
bool ev_watch(int epfd, ev_t *ev, int fd, uint32_t events);
void ev_unwatch(int epfd, ev_t *ev);

/* A worker thread beside the loop, for what takes too long to run in it
 * (a password's crypt, an RSA operation): the thread, the mutex and
 * condition its owner and it hand jobs over with, `stop` (under mu: the
 * thread's function returns once it sees it), and an eventfd the worker
 * writes when a job is done (ev_worker_done), which the loop watches. The
 * jobs themselves are the owner's.
 *
 * The thread first takes `name` (at most 15 characters: ps -L, top -H)
 * and goes into Linux's SCHED_IDLE class, so that the loop's thread,
 * asleep most of the time, takes a CPU from it the moment it wakes, even
 * when every CPU is busy with workers. Measured without it: the loop
 * waited up to 4.5 ms for an RSA signature's thread to leave the CPU
 * (bench-opcua (d)); at nice 19 still up to 4 ms. The worker gets every CPU
 * time nothing else wants; the side that waits for it waits aside (never
 * blocking the loop), however long that is. A class refused is left as
 * it is (best effort: the work is done either way). */
typedef struct {
    pthread_mutex_t mu;
    pthread_cond_t cv;
    bool stop;
    int efd;       /* nonblocking; read it empty after each wake */
    pthread_t thread;
    char name[16];
    void *(*fn)(void *);
    void *arg;
} ev_worker_t;

/* Start w's thread running fn(arg). 0, or an errno value with nothing
 * left open. */
int ev_worker_open(ev_worker_t *w, const char *name, void *(*fn)(void *), void *arg);

/* Set stop, wake the thread, wait for it to return, and free the rest. */
void ev_worker_close(ev_worker_t *w);

/* From the worker: one more job done (w->efd readable). */
void ev_worker_done(ev_worker_t *w);

/* The monotonic clock, in nanoseconds and in microseconds. */
uint64_t ev_now_ns(void);
uint64_t ev_now_us(void);

#endif /* DRGATE_EV_H */
