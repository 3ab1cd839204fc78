/* SPDX-License-Identifier: MIT */
/*
 * Forced into every gateway source of the bench build drgatewayd-lat
 * (gcc -include, mk/bench_gw.mk), never into the real daemon: the event
 * loop's epoll_wait goes through gw_bench_epoll_wait (bench/gw_lat.c,
 * linked into that build), which notes when the loop woke up, so the
 * latency of a robot packet can be split into "until the loop ran" and "in
 * the loop".
 */
#ifndef DRGATE_GW_LAT_HOOK_H
#define DRGATE_GW_LAT_HOOK_H
/* No #include here: it would come before the sources' own feature macros
 * (_GNU_SOURCE). sys/epoll.h's declaration, renamed, matches this one. */
struct epoll_event;
int gw_bench_epoll_wait(int epfd, struct epoll_event *events, int maxevents, int timeout);
#define epoll_wait gw_bench_epoll_wait
/* The same for the loop's epoll_pwait2, which is a syscall() in
 * common/ev.c. */
void gw_bench_woke(void);
#define EV_BENCH_WOKE() gw_bench_woke()

#endif
