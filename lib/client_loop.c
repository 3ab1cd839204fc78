/* SPDX-License-Identifier: MIT */
/*
 * The client's loop: dr_client_process and its variants, the descriptors
 * to poll, the next deadline and the timer that fires at it, and the
 * bounded wait of the blocking calls.
 */
#include <stdint.h>
#include <string.h>

#include "client_internal.h"

/* ---- the loop -------------------------------------------------------------- */

/* Re-arm only when the deadline moved; with none left, disarm, so an
 * expired timer does not keep the caller's poll awake. */
void drc_rearm(dr_client_t *c)
{
    uint64_t d = dr_client_next_deadline(c);
    if (c->timer_polled && c->timer >= 0 && d != c->armed) {
        c->tp.ops->timer_arm(c->tp.ctx, c->timer, d);
        c->armed = d;
    }
}

/* Every deadline of the client: a scan of its request and connection
 * slots, which dr_client_next_deadline keeps until one may have moved. */
static uint64_t compute_deadline(const dr_client_t *c)
{
    uint64_t d = c->closing != CL_NONE ? c->close_deadline : UINT64_MAX;
    if (c->state == S_CONNECTING || c->state == S_REGISTERING)
        d = c->sess_deadline;
    else if (c->state == S_BACKOFF && c->started)
        d = c->retry_at;
    for (unsigned i = 0; i < MAX_REQS; i++)
        if (c->reqs[i].active && !c->reqs[i].done && c->reqs[i].deadline < d)
            d = c->reqs[i].deadline;
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++) {
        if (!c->conns[i].used)
            continue;
        uint64_t cd = drc_conn_deadline(&c->conns[i]);
        if (cd < d)
            d = cd;
    }
    return d;
}

uint64_t dr_client_next_deadline(dr_client_t *c)
{
    if (c->next_dl_stale) {
        c->next_dl = compute_deadline(c);
        c->next_dl_stale = false;
    }
    return c->next_dl;
}

/* may_hold: the O->T frames produced may wait for dr_udp_port_flush (a
 * held port, and the application's loop calling); the blocking calls
 * send them at once, as nobody flushes while they wait. */
static void process(dr_client_t *c, bool tcp_ready, bool udp_ready, bool may_hold)
{
    uint64_t t = now_us(c);
    if (c->tcp >= 0 && c->state != S_CONNECTING && tcp_ready) {
        drc_flush_tx(c);
        drc_read_tcp(c);
    }
    if (udp_ready)
        drc_read_udp(c->udp, t);
    t = now_us(c);
    drc_session_timers(c, t);
    for (unsigned i = 0; i < DR_CLIENT_MAX_CONNS; i++)
        if (c->conns[i].used)
            drc_conn_timers(&c->conns[i], t);
    if (!may_hold || !c->udp->hold)
        drc_flush_io(c);
    if (c->closing != CL_NONE)
        drc_close_step(c, t);
    deadline_moved(c);
    drc_rearm(c);
}

void dr_client_process(dr_client_t *c)
{
    process(c, true, true, true);
}

void dr_client_process_ready(dr_client_t *c, const dr_pollfd_t *fds, int n)
{
    bool tcp = c->tcp >= 0 && c->tx_len > 0, udp = false;
    int tcp_fd = drc_fd_of(c->tp, c->tcp), udp_fd = drc_fd_of(c->tp, c->udp->h);
    for (int i = 0; i < n; i++) {
        if (fds[i].revents == 0 || fds[i].fd < 0)
            continue;
        if (fds[i].fd == tcp_fd)
            tcp = true;
        else if (fds[i].fd == udp_fd)
            udp = true;
    }
    process(c, tcp, udp, true);
}

int dr_client_pollfds(dr_client_t *c, dr_pollfd_t *fds, int max)
{
    /* From now on the timer fd is in someone's poll set and must be armed;
     * the *_sync calls alone wait with a deadline and do not need it. */
    if (c->tp.ops->fd == NULL)
        return 0; /* the application drives us by dr_client_next_deadline */
    if (!c->timer_polled && c->timer >= 0) {
        c->timer_polled = true;
        c->tp.ops->timer_arm(c->tp.ctx, c->timer, dr_client_next_deadline(c));
        c->armed = dr_client_next_deadline(c);
    }
    int n = 0;
    if (c->tcp >= 0 && n < max) {
        fds[n].fd = c->tp.ops->fd(c->tp.ctx, c->tcp);
        fds[n].revents = 0;
        fds[n].events = (short)(DR_POLL_IN |
                                (c->state == S_CONNECTING || c->tx_len > 0 ? DR_POLL_OUT : 0));
        n++;
    }
    /* A shared port is polled by the application, once for all clients. */
    if (!c->udp->shared && c->udp->h >= 0 && n < max) {
        fds[n].fd = c->tp.ops->fd(c->tp.ctx, c->udp->h);
        fds[n].events = DR_POLL_IN;
        fds[n].revents = 0;
        n++;
    }
    if (c->timer >= 0 && n < max) {
        fds[n].fd = c->tp.ops->fd(c->tp.ctx, c->timer);
        fds[n].events = DR_POLL_IN;
        fds[n].revents = 0;
        n++;
    }
    return n;
}

/* The blocking calls need the transport's wait: without it, they would
 * spin on the clock. */
bool drc_can_wait(const dr_client_t *c)
{
    return c->tp.ops->wait != NULL;
}

/* Wait for any of our handles, at most until `deadline`, then process. */
void drc_wait_and_process(dr_client_t *c, uint64_t deadline)
{
    int h[3];
    bool out[3];
    int n = 0;
    if (c->tcp >= 0) {
        h[n] = c->tcp;
        out[n++] = c->state == S_CONNECTING || c->tx_len > 0;
    }
    if (c->udp->h >= 0) {
        h[n] = c->udp->h;
        out[n++] = false;
    }
    uint64_t d = dr_client_next_deadline(c);
    if (deadline < d)
        d = deadline;
    c->tp.ops->wait(c->tp.ctx, h, out, n, d);
    process(c, true, true, false);
    if (c->udp->hold)
        dr_udp_port_flush(c->udp); /* what other clients held meanwhile */
}

dr_status_t dr_client_run_once(dr_client_t *c, int timeout_ms)
{
    if (!drc_can_wait(c))
        return DR_EINVAL;
    drc_wait_and_process(c, now_us(c) + (uint64_t)(timeout_ms < 0 ? 0 : timeout_ms) * 1000u);
    return DR_OK;
}
