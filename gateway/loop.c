/* SPDX-License-Identifier: MIT */
/* epoll registration helpers and the clock of the daemon's loop. */
#include <sys/epoll.h>
#include <time.h>

#include "loop.h"

bool gw_loop_watch(int epfd, gw_ev_t *ev, int fd, uint32_t events)
{
    if (ev->fd >= 0 && ev->fd != fd)
        gw_loop_unwatch(epfd, ev);
    struct epoll_event e;
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

void gw_loop_unwatch(int epfd, gw_ev_t *ev)
{
    if (ev->fd >= 0)
        (void)epoll_ctl(epfd, EPOLL_CTL_DEL, ev->fd, NULL);
    ev->fd = -1;
    ev->events = 0;
}

uint64_t gw_now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
}
