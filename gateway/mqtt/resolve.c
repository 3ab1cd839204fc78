/* SPDX-License-Identifier: MIT */
/*
 * Host names without blocking (resolve.h). getaddrinfo() in the loop
 * would stop every robot link for as long as the resolver takes (seconds
 * per server in /etc/resolv.conf when DNS is down); getaddrinfo_a runs it
 * in glibc's own thread and the loop looks at the answer (gai_error)
 * from its ticks.
 *
 * A request that was given up on may still be running in that thread,
 * which writes into its gaicb and reads its name when it ends: the
 * requests live in a static table, never freed while busy, and a slot
 * given up on is taken back when its lookup has ended.
 */
#define _GNU_SOURCE /* getaddrinfo_a, gai_error, gai_cancel */
#include "mqtt/resolve.h"

#include <netdb.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>

#define LOOKUPS 8 /* at once: a side has one, a reload may leave one running */

struct gw_mqtt_lookup {
    struct gaicb cb;
    struct addrinfo hints;
    char name[256];
    bool busy;      /* taken (by a side, or given up and still running) */
    bool abandoned; /* given up on: free once it has ended */
};

static struct gw_mqtt_lookup lookups[LOOKUPS];

/* The answer of an ended lookup is dropped and its slot made free. */
static void release(struct gw_mqtt_lookup *l)
{
    if (l->cb.ar_result != NULL)
        freeaddrinfo(l->cb.ar_result);
    memset(l, 0, sizeof *l);
}

/* Slots given up on whose lookup has ended are free again. */
static void reclaim(void)
{
    for (unsigned i = 0; i < LOOKUPS; i++)
        if (lookups[i].abandoned && gai_error(&lookups[i].cb) != EAI_INPROGRESS)
            release(&lookups[i]);
}

gw_mqtt_lookup_t *gw_mqtt_lookup_start(const char *host, char *err, size_t errlen)
{
    reclaim();
    struct gw_mqtt_lookup *l = NULL;
    for (unsigned i = 0; i < LOOKUPS && l == NULL; i++)
        if (!lookups[i].busy)
            l = &lookups[i];
    if (l == NULL || strlen(host) >= sizeof l->name) {
        snprintf(err, errlen, "%s", l == NULL ? "too many host name lookups still running"
                                              : "host name too long");
        return NULL;
    }
    memset(l, 0, sizeof *l);
    memcpy(l->name, host, strlen(host) + 1);
    l->hints.ai_family = AF_UNSPEC;
    l->hints.ai_socktype = SOCK_STREAM;
    l->cb.ar_name = l->name;
    l->cb.ar_request = &l->hints;
    struct gaicb *list[1] = {&l->cb};
    int e = getaddrinfo_a(GAI_NOWAIT, list, 1, NULL);
    if (e != 0) {
        snprintf(err, errlen, "cannot start the lookup (%s)", gai_strerror(e));
        memset(l, 0, sizeof *l);
        return NULL;
    }
    l->busy = true;
    return l;
}

int gw_mqtt_lookup_poll(gw_mqtt_lookup_t *l, char *addr, size_t addrlen, char *err,
                        size_t errlen)
{
    int e = gai_error(&l->cb);
    if (e == EAI_INPROGRESS)
        return 0;
    int found = -1;
    if (e != 0)
        snprintf(err, errlen, "cannot resolve the host name (%s)", gai_strerror(e));
    /* An IPv4 address first (the robots and `host` are IPv4; a name such
     * as localhost often lists ::1 first, where an IPv4 broker is not),
     * else an IPv6 one. */
    static const int families[] = {AF_INET, AF_INET6};
    for (unsigned f = 0; f < 2 && e == 0 && found < 0; f++)
        for (const struct addrinfo *a = l->cb.ar_result; a != NULL && found < 0; a = a->ai_next)
            if (a->ai_family == families[f] &&
                getnameinfo(a->ai_addr, a->ai_addrlen, addr, (socklen_t)addrlen, NULL, 0,
                            NI_NUMERICHOST) == 0)
                found = 1;
    if (e == 0 && found < 0)
        snprintf(err, errlen, "cannot resolve the host name (no IPv4 or IPv6 address)");
    release(l);
    return found;
}

void gw_mqtt_lookup_end(gw_mqtt_lookup_t *l)
{
    if (l == NULL)
        return;
    if (gai_cancel(&l->cb) == EAI_CANCELED || gai_error(&l->cb) != EAI_INPROGRESS)
        release(l);
    else
        l->abandoned = true;
}
