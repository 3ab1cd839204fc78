/* SPDX-License-Identifier: MIT */
/*
 * EtherNet/IP originator: the lifecycle of a client and of a shared UDP
 * port (storage, configuration, defaults), its getters, and the
 * originator serial. Portable: all OS access goes through dr_transport_t.
 *
 * The client is one non-blocking state machine driven by
 * dr_client_process(), in parts (lib/client_internal.h has the structures):
 *   client_session.c  the TCP session, RegisterSession, explicit requests
 *                     and their replies, the session's timers, the close
 *   client_conn.c     Class 1 connections: Forward Open/Close, O->T
 *                     production, T->O consumption and sequence numbers
 *   client_port.c     the UDP port: receive, demultiplex, batched sends
 *   client_loop.c     dr_client_process, pollfds, deadlines, run_once
 *   client_sync.c     the blocking *_sync calls over that loop
 */
#include <stdint.h>
#include <string.h>

#include "client_internal.h"

/* ---- originator serial ----------------------------------------------------- */

static uint32_t fnv1a(uint32_t h, const char *s)
{
    for (; *s != '\0'; s++) {
        h ^= (uint8_t)*s;
        h *= 16777619u; /* the 32-bit FNV prime */
    }
    return h;
}

uint32_t dr_originator_serial(const char *host_id, const char *name)
{
    uint32_t h = fnv1a(2166136261u, host_id != NULL ? host_id : ""); /* offset basis */
    h *= 16777619u; /* the 0 byte between the two: h ^= 0, then the prime */
    h = fnv1a(h, name != NULL ? name : "");
    return h != 0 ? h : 1u;
}

/* ---- lifecycle ----------------------------------------------------------- */

/* Storage handed to dr_client_init / dr_udp_port_init must hold the
 * structure and be aligned like the public storage unions (C99 has no
 * _Static_assert: a negative array size stops the build instead). */
typedef char client_fits_storage[sizeof(struct dr_client) <= DR_CLIENT_STORAGE_SIZE ? 1 : -1];
/* A combined T->O image (DR_CLIENT_IO_MAX) with its sequence count,
 * run/idle header and CPF items (2 + 8 + 4 + 4 + 6) fits one datagram. */
typedef char io_fits_datagram[DR_CLIENT_IO_MAX + 40 <= DR_CLIENT_UDP_BUF &&
                              DR_CLIENT_IO_MAX >= DR_ASM_MAX_SIZE ? 1 : -1];
typedef char port_fits_storage[sizeof(struct dr_udp_port) <= DR_UDP_PORT_STORAGE_SIZE ? 1 : -1];
/* cppcheck-suppress unusedStructMember ; only offsetof reads them */
struct client_align { char c; dr_client_storage_t s; };
/* cppcheck-suppress unusedStructMember ; only offsetof reads them */
struct port_align { char c; dr_udp_port_storage_t s; };

static bool storage_ok(const void *storage, size_t size, size_t need, size_t align)
{
    return storage != NULL && size >= need && (uintptr_t)storage % align == 0;
}

size_t dr_client_size(void)
{
    return sizeof(struct dr_client);
}

size_t dr_udp_port_size(void)
{
    return sizeof(struct dr_udp_port);
}

/* The calls every transport must have; the others may be NULL. */
static bool transport_ok(dr_transport_t tp)
{
    const dr_transport_ops_t *o = tp.ops;
    return o != NULL && o->resolve != NULL && o->tcp_connect != NULL &&
           o->tcp_finish != NULL && o->tcp_send != NULL && o->tcp_recv != NULL &&
           o->udp_open != NULL && o->udp_send != NULL && o->udp_recv != NULL &&
           o->close != NULL && o->now_us != NULL &&
           (o->timer_open == NULL) == (o->timer_arm == NULL);
}

static dr_client_t *init_fail(dr_status_t *err, dr_status_t st)
{
    if (err != NULL)
        *err = st;
    return NULL;
}

dr_client_t *dr_client_init(void *storage, size_t size, const dr_client_config_t *cfg,
                            dr_status_t *err)
{
    if (cfg == NULL || cfg->host == NULL || strlen(cfg->host) >= DR_CLIENT_HOST_MAX ||
        !transport_ok(cfg->transport) ||
        !storage_ok(storage, size, sizeof(struct dr_client),
                    offsetof(struct client_align, s)))
        return init_fail(err, DR_EINVAL);
    dr_client_t *c = storage;
    memset(c, 0, sizeof *c);
    c->cfg = *cfg;
    memcpy(c->host, cfg->host, strlen(cfg->host) + 1);
    c->cfg.host = c->host;
    c->cfg.local_addr = NULL; /* resolved below, not kept */
    if (c->cfg.tcp_port == 0) c->cfg.tcp_port = DR_ENIP_TCP_PORT;
    if (c->cfg.udp_port == 0) c->cfg.udp_port = DR_ENIP_UDP_PORT;
    if (c->cfg.local_udp_port == 0) c->cfg.local_udp_port = DR_ENIP_UDP_PORT;
    if (c->cfg.timeout_ms == 0) c->cfg.timeout_ms = 2000;
    if (c->cfg.vendor_id == 0) c->cfg.vendor_id = 0xFFFE;
    if (c->cfg.backoff_min_ms == 0) c->cfg.backoff_min_ms = 100;
    if (c->cfg.backoff_max_ms == 0) c->cfg.backoff_max_ms = 5000;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (c->cfg.instance[a] == 0)
            c->cfg.instance[a] = DR_ASM_DEFAULT_INSTANCE(a);
    c->tp = c->cfg.transport;
    c->tcp = c->timer = -1;
    c->own_udp.h = -1;
    c->own_udp.tp = c->tp;
    c->own_udp.clients[0] = c;
    c->own_udp.nclients = 1;
    c->udp = &c->own_udp;
    c->next_dl_stale = true;
    uint64_t t = now_us(c);
    c->epoch = t;
    /* Unique but not stable: see "Originator serial" in client.h. */
    if (c->cfg.serial == 0)
        c->cfg.serial = (uint32_t)(t ^ (t >> 32)) | 1u;
    c->next_serial = (uint16_t)(t >> 4);
    /* Connection IDs differ between clients sharing a UDP port by their
     * slot (see struct dr_udp_port); the counter starts from the clock so
     * that a restarted originator does not reuse the last run's IDs. */
    c->cid_gen = (uint32_t)(t ^ (t >> 20));
    c->backoff_ms = c->cfg.backoff_min_ms;
    c->step = "";
    dr_status_t st;
    if (cfg->local_addr != NULL &&
        (st = c->tp.ops->resolve(c->tp.ctx, cfg->local_addr, &c->local_udp_addr)) != DR_OK)
        return init_fail(err, st);
    /* A local address the TCP session cannot leave from: the adapter
     * would send T->O to wherever TCP comes from (see local_addr). */
    if (c->local_udp_addr != 0 && c->tp.ops->tcp_connect_from == NULL)
        return init_fail(err, DR_EUNSUPPORTED);
    if (c->tp.ops->timer_open != NULL &&
        (st = c->tp.ops->timer_open(c->tp.ctx, &c->timer)) != DR_OK)
        return init_fail(err, st);
    if (cfg->shared_udp != NULL) {
        dr_udp_port_t *p = cfg->shared_udp;
        if (p->nclients == UDP_PORT_MAX_CLIENTS) {
            drc_close_handle(c, &c->timer);
            return init_fail(err, DR_EFULL);
        }
        unsigned slot = 0;
        while (p->clients[slot] != NULL)
            slot++;
        p->clients[slot] = c;
        p->nclients++;
        c->port_slot = slot;
        c->udp = p;
        c->epoch = p->epoch;
    }
    if (err != NULL)
        *err = DR_OK;
    return c;
}

void drc_close_handle(dr_client_t *c, int *h)
{
    if (*h >= 0)
        c->tp.ops->close(c->tp.ctx, *h);
    *h = -1;
}

void dr_client_deinit(dr_client_t *c)
{
    if (c == NULL)
        return;
    dr_client_close_sync(c);
    drc_close_handle(c, &c->timer);
    if (c->udp != &c->own_udp) {
        c->udp->clients[c->port_slot] = NULL; /* the others keep their slots */
        c->udp->nclients--;
    }
}

uint16_t dr_client_instance(const dr_client_t *c, dr_asm_t a)
{
    return (unsigned)a < DR_ASM_COUNT ? c->cfg.instance[a] : 0;
}

const char *dr_client_last_step(const dr_client_t *c)
{
    return c->step;
}

dr_sockaddr_t dr_client_t2o_addr(const dr_client_t *c)
{
    dr_sockaddr_t a = c->udp->h >= 0 ? c->udp->local
                                     : (dr_sockaddr_t){c->local_udp_addr, c->cfg.local_udp_port};
    if (a.addr == 0)
        a.addr = c->tcp_local.addr;
    return a;
}

const dr_client_stats_t *dr_client_stats(const dr_client_t *c)
{
    return &c->stats;
}

void dr_client_set_timeout(dr_client_t *c, uint32_t timeout_ms)
{
    c->cfg.timeout_ms = timeout_ms != 0 ? timeout_ms : 2000;
}

bool dr_client_ready(const dr_client_t *c)
{
    return c->state == S_READY;
}

dr_udp_port_t *dr_udp_port_init(void *storage, size_t size, const char *local_addr,
                                uint16_t port, dr_transport_t tp, dr_status_t *err)
{
    dr_status_t st = DR_EINVAL;
    dr_udp_port_t *p = storage;
    if (!transport_ok(tp) ||
        !storage_ok(storage, size, sizeof *p, offsetof(struct port_align, s)))
        goto fail;
    memset(p, 0, sizeof *p);
    p->tp = tp;
    p->h = -1;
    p->shared = true;
    p->epoch = tp.ops->now_us(tp.ctx);
    p->local.port = port != 0 ? port : DR_ENIP_UDP_PORT;
    if (local_addr != NULL &&
        (st = p->tp.ops->resolve(p->tp.ctx, local_addr, &p->local.addr)) != DR_OK)
        goto fail;
    if ((st = p->tp.ops->udp_open(p->tp.ctx, p->local, &p->h)) != DR_OK)
        goto fail;
    if (err != NULL)
        *err = DR_OK;
    return p;
fail:
    if (err != NULL)
        *err = st;
    return NULL;
}

void dr_udp_port_deinit(dr_udp_port_t *p)
{
    if (p != NULL && p->h >= 0)
        p->tp.ops->close(p->tp.ctx, p->h);
    if (p != NULL)
        p->h = -1;
}
