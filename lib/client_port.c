/* SPDX-License-Identifier: MIT */
/*
 * The client's UDP port, its own or shared by several clients: reading
 * the datagrams and handing each to its connection by connection ID, and
 * sending the O->T frames in batches (held for dr_udp_port_flush).
 */
#include <stdint.h>
#include <string.h>

#include "client_internal.h"

/* ---- sending ---------------------------------------------------------------- */

/* Send n O->T frames on port p (who[i]: whose frame m[i] is), in one
 * call if the transport can. */
static void send_frames(dr_udp_port_t *p, const dr_udp_msg_t *m, dr_conn_t *const *who,
                        unsigned n)
{
    unsigned sent = 0;
    if (p->h < 0)
        return;
    if (p->tp.ops->udp_send_batch != NULL) {
        while (sent < n) {
            unsigned k = 0;
            if (p->tp.ops->udp_send_batch(p->tp.ctx, p->h, &m[sent], n - sent, &k) != DR_OK ||
                k == 0)
                break; /* dropped, like a datagram the network loses */
            for (unsigned i = sent; i < sent + k; i++)
                who[i]->stats.tx_packets++;
            sent += k;
        }
    } else {
        for (unsigned i = 0; i < n; i++)
            if (p->tp.ops->udp_send(p->tp.ctx, p->h, m[i].buf, m[i].len, m[i].addr) == DR_OK)
                who[i]->stats.tx_packets++;
    }
}

/* Send the O->T frames queued by conn_produce. */
void drc_flush_io(dr_client_t *c)
{
    send_frames(c->udp, c->tx_batch, c->tx_conn, c->tx_n);
    c->tx_n = 0;
}

/* The frames every client of a shared port queued while the port was
 * read (o2t_follow_us), together: one batch call for all the robots whose
 * packets came in the same read, instead of one per robot. The frames
 * stay in their clients' buffers; only the descriptors are gathered. */
/* Frames per batch call: every frame of up to 10 robots of six connections
 * (the POSIX transport's sendmmsg takes 64), bounded by what the port can
 * hold at all, which keeps it small in firmware builds (stack). */
#define PORT_TX_BATCH (CID_SLOTS < 64u ? CID_SLOTS : 64u)
static void flush_port(dr_udp_port_t *p)
{
    dr_udp_msg_t m[PORT_TX_BATCH];
    dr_conn_t *who[PORT_TX_BATCH];
    unsigned n = 0;
    for (unsigned k = 0; k < UDP_PORT_MAX_CLIENTS; k++) {
        dr_client_t *c = p->clients[k];
        for (unsigned i = 0; c != NULL && i < c->tx_n; i++) {
            m[n] = c->tx_batch[i];
            who[n++] = c->tx_conn[i];
            if (n == PORT_TX_BATCH) {
                send_frames(p, m, who, n);
                n = 0;
            }
        }
    }
    send_frames(p, m, who, n);
}

/* ---- receiving -------------------------------------------------------------- */

static bool conn_has_t2o_cid(const dr_conn_t *cn, uint32_t cid)
{
    return cn->used && cn->state == DR_CONN_ESTABLISHED && cn->stats.t2o_cid == cid;
}

/* The established connection a T->O packet belongs to: where its ID says
 * (see struct dr_udp_port), else, only while some target chose its own
 * ID, wherever it is. */
static dr_conn_t *conn_by_t2o_cid(dr_udp_port_t *p, uint32_t cid)
{
    uint32_t slot = cid % CID_SLOTS;
    dr_client_t *c = p->clients[slot / DR_CLIENT_MAX_CONNS];
    if (c != NULL && conn_has_t2o_cid(&c->conns[slot % DR_CLIENT_MAX_CONNS], cid))
        return &c->conns[slot % DR_CLIENT_MAX_CONNS];
    for (unsigned k = 0; p->foreign > 0 && k < UDP_PORT_MAX_CLIENTS; k++)
        for (unsigned i = 0; p->clients[k] != NULL && i < DR_CLIENT_MAX_CONNS; i++)
            if (conn_has_t2o_cid(&p->clients[k]->conns[i], cid))
                return &p->clients[k]->conns[i];
    return NULL;
}

/* Whether a T->O packet from `from` may be the target's (see "Who may
 * send T->O data" in client.h): the address the session connected to, or
 * the one the Forward Open reply named for the target's I/O (o2t_to: the
 * session's address when it named none). An established connection
 * belongs to the session it was opened in (a session lost closes its
 * connections), so that address is the one it was opened with. */
static bool from_target(const dr_conn_t *cn, dr_sockaddr_t from)
{
    return from.addr == cn->client->peer.addr || from.addr == cn->o2t_to.addr;
}

static void on_datagram(dr_udp_port_t *p, const uint8_t *buf, size_t len, dr_sockaddr_t from,
                        uint64_t t)
{
    dr_io_frame_t f;
    if (dr_io_frame_parse(buf, len, false, &f) != DR_OK)
        return;
    dr_conn_t *cn = conn_by_t2o_cid(p, f.cid);
    if (cn == NULL)
        return;
    if (!from_target(cn, from)) {
        cn->stats.rx_dropped_addr++; /* no sign of life either */
        return;
    }
    dr_client_t *c = cn->client;
    drc_conn_datagram(cn, buf, len, &f, t);
    deadline_moved(c); /* its timeout, maybe its O->T deadline (follow) */
}

/* Everything that is waiting, bounded so a flood cannot starve the loop. */
void drc_read_udp(dr_udp_port_t *p, uint64_t t)
{
    if (p->tp.ops->udp_recv_batch != NULL) {
        /* Until the socket is empty: a batch that came back full may have
         * left more behind. Bounded, so a flood cannot starve the loop. */
        dr_udp_msg_t m[RX_BATCH];
        for (unsigned round = 0; p->h >= 0 && round < 100; round++) {
            unsigned got = 0;
            for (unsigned i = 0; i < RX_BATCH; i++) {
                m[i].buf = p->rx[i];
                m[i].cap = UDP_BUF;
                m[i].len = 0;
                m[i].addr.addr = 0; /* a transport that says nothing: no one's */
                m[i].addr.port = 0;
            }
            if (p->tp.ops->udp_recv_batch(p->tp.ctx, p->h, m, RX_BATCH, &got) != DR_OK)
                return;
            for (unsigned i = 0; i < got; i++)
                if (m[i].len > 0)
                    on_datagram(p, m[i].buf, m[i].len, m[i].addr, t);
            if (got < RX_BATCH)
                return;
        }
        return;
    }
    for (unsigned n = 0; p->h >= 0 && n < 1000; n++) {
        size_t got;
        dr_sockaddr_t from = {0, 0}; /* a transport that says nothing: no one's */
        dr_status_t st = p->tp.ops->udp_recv(p->tp.ctx, p->h, p->rx[0], UDP_BUF, &got, &from);
        if (st == DR_EAGAIN)
            return;
        if (st == DR_OK)
            on_datagram(p, p->rx[0], got, from, t);
    }
}

/* ---- the port as the application sees it ----------------------------------- */

/* The descriptor of a handle, -1 when the transport has none. */
int drc_fd_of(dr_transport_t tp, int h)
{
    return h >= 0 && tp.ops->fd != NULL ? tp.ops->fd(tp.ctx, h) : -1;
}

int dr_udp_port_fd(const dr_udp_port_t *p)
{
    return drc_fd_of(p->tp, p->h);
}

void dr_udp_port_process(dr_udp_port_t *p)
{
    drc_read_udp(p, p->tp.ops->now_us(p->tp.ctx));
    /* O->T produced on arrival (o2t_follow_us) goes now, and the timers
     * move past the deadlines it served; a client that produced nothing
     * has nothing to send and no deadline that moved earlier. */
    flush_port(p);
    for (unsigned k = 0; k < UDP_PORT_MAX_CLIENTS; k++) {
        dr_client_t *c = p->clients[k];
        if (c == NULL || c->tx_n == 0)
            continue;
        c->tx_n = 0;
        drc_rearm(c);
    }
}

void dr_udp_port_hold(dr_udp_port_t *p, bool hold)
{
    if (p->hold && !hold)
        dr_udp_port_flush(p);
    p->hold = hold;
}

void dr_udp_port_flush(dr_udp_port_t *p)
{
    flush_port(p);
    for (unsigned k = 0; k < UDP_PORT_MAX_CLIENTS; k++)
        if (p->clients[k] != NULL)
            p->clients[k]->tx_n = 0;
}
