/* SPDX-License-Identifier: MIT */
/*
 * The daemon's one event loop: every descriptor is registered in one epoll
 * set with a gw_ev_t, whose callback gets the ready events.
 */
#ifndef DRGATE_GW_LOOP_H
#define DRGATE_GW_LOOP_H

#include <stdbool.h>
#include <stdint.h>

typedef void (*gw_ev_fn)(void *obj, uint32_t events);

typedef struct {
    gw_ev_fn fn;
    void *obj;
    int fd;           /* -1 when not registered */
    uint32_t events;  /* EPOLLIN / EPOLLOUT as registered */
} gw_ev_t;

/* Register, change or remove ev->fd in the loop (events 0 removes).
 * Returns false on an epoll error. */
bool gw_loop_watch(int epfd, gw_ev_t *ev, int fd, uint32_t events);
void gw_loop_unwatch(int epfd, gw_ev_t *ev);

/* Monotonic milliseconds and microseconds. */
uint64_t gw_now_us(void);

#endif
