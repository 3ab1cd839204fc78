/* SPDX-License-Identifier: MIT */
/*
 * ListIdentity over UDP: unicast to one device, or broadcast to find every
 * EtherNet/IP device on a subnet (CIP Vol. 2, 2-4.2). Blocking, bounded by
 * a timeout, through the transport like the client.
 */
#include <string.h>

#include "cip_internal.h"
#include "drgate/client.h"

#define REPLY_MAX 600u

dr_status_t dr_discover(const char *target, uint16_t port, uint32_t timeout_ms,
                        dr_transport_t tp, dr_discover_cb found, void *user,
                        unsigned *count)
{
    /* It blocks, so it needs the transport's wait. */
    if (target == NULL || found == NULL || tp.ops == NULL || tp.ops->wait == NULL)
        return DR_EINVAL;
    if (count != NULL)
        *count = 0;
    dr_sockaddr_t to = {0, port != 0 ? port : DR_ENIP_TCP_PORT};
    dr_status_t st = tp.ops->resolve(tp.ctx, target, &to.addr);
    if (st != DR_OK)
        return st;
    int h;
    dr_sockaddr_t any = {0, 0};
    if ((st = tp.ops->udp_open(tp.ctx, any, &h)) != DR_OK)
        return st;

    uint8_t req[DR_ENCAP_HEADER_LEN];
    dr_encap_t hdr;
    memset(&hdr, 0, sizeof hdr);
    hdr.command = DR_ENCAP_LIST_IDENTITY;
    memcpy(hdr.context, "drgate\0\0", 8); /* ours: other replies are ignored */
    (void)dr_encap_write(req, sizeof req, &hdr, 0);
    st = tp.ops->udp_send(tp.ctx, h, req, sizeof req, to);

    /* A broadcast has many answers: collect them until the timeout. */
    uint64_t deadline = tp.ops->now_us(tp.ctx) + (uint64_t)timeout_ms * 1000u;
    unsigned n = 0;
    while (st == DR_OK && tp.ops->now_us(tp.ctx) < deadline) {
        bool out = false;
        tp.ops->wait(tp.ctx, &h, &out, 1, deadline);
        uint8_t buf[REPLY_MAX];
        size_t got;
        dr_sockaddr_t from;
        while (tp.ops->udp_recv(tp.ctx, h, buf, sizeof buf, &got, &from) == DR_OK) {
            dr_encap_t rh;
            const uint8_t *body;
            dr_identity_t id;
            if (dr_encap_parse(buf, got, &rh, &body) != DR_OK ||
                rh.command != DR_ENCAP_LIST_IDENTITY || rh.status != 0 ||
                memcmp(rh.context, hdr.context, 8) != 0 ||
                dr_list_identity_parse(body, rh.length, &id) != DR_OK)
                continue; /* not an answer to us, or malformed: skip it */
            n++;
            found(&id, from, user);
        }
        if (to.addr != 0xFFFFFFFFu && (to.addr & 0xFFu) != 0xFFu && n > 0)
            break; /* unicast: one answer is all there is */
    }
    tp.ops->close(tp.ctx, h);
    if (count != NULL)
        *count = n;
    if (st != DR_OK)
        return st;
    return n > 0 ? DR_OK : DR_ETIMEDOUT;
}
