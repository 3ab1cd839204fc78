/* SPDX-License-Identifier: MIT */
/*
 * drsim end to end without sockets (sim/adapter.h): encapsulation frames
 * from two TCP peers (drsim_encap), datagrams on UDP 44818
 * (drsim_encap_udp), Class 1 packets (drsim_io_receive) and the passing of
 * time (drsim_run), in any order, against one adapter whose state carries
 * over from record to record.
 *
 * Input layout (gen_corpus.c writes seeds in it):
 *   [config] record...
 * config bits 0-1: max_conns 1, 2, 16, 64; bit 2: refuse every Forward
 * Open; bit 3: no Large Forward Open; bit 4: GPR echo; bit 5: drop half of
 * the I/O packets; bit 6: stop producing after 50 ms.
 * A record starts with an op byte; op & 3 says what follows:
 *   0  an encapsulation frame, as long as its header says (the rest of the
 *      input if shorter: the stream ends there), from peer (op >> 2) & 1;
 *      op bit 3: the peer's session handle is put into the header first
 *      (so that the fuzzer need not guess it)
 *   1  [len] bytes: a UDP datagram on port 44818
 *   2  [len] bytes: a Class 1 packet; op bit 2: its connection ID (bytes
 *      6-9) is replaced by that of open connection number (op >> 3)
 *   3  [ms]: time goes on by ms + 1 milliseconds, then drsim_run
 *
 * Properties: every reply is one well-formed encapsulation frame that our
 * own parsers accept, with the request's command and sender context;
 * replies to SendRRData with status 0 carry a null address item, a 0x00B2
 * item whose CIP reply parses and answers the request's service, and a
 * 0x8000 item exactly when a Forward Open succeeded, whose O->T connection
 * ID is then open; only NOP is not answered; only UnregisterSession and a
 * broken frame close the connection; every T->O packet parses and belongs
 * to an open connection, with that connection's data size; the adapter
 * never holds more connections than allowed.
 */
#include <string.h>

#include "../sim/adapter.h"
#include "fuzz.h"

#define NOW0 1000000000ull

static drsim_t sim;
static uint8_t *out; /* exactly DR_ENCAP_MAX_LEN bytes, on the heap */
static uint64_t now;
static unsigned max_conns;

static const uint32_t es_allowed[] = {0x0000, 0x0001, 0x0003, 0x0064, 0x0065, 0x0069};

static void check_conns(void)
{
    unsigned n = 0;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
        const drsim_conn_t *c = &sim.conn[i];
        if (!c->used)
            continue;
        n++;
        FUZZ_CHECK((unsigned)c->t2o_asm < DR_ASM_COUNT);
        FUZZ_CHECK(c->o2t_asm < (int)DR_ASM_COUNT);
        FUZZ_CHECK(c->o2t_data_len <= DR_ASM_MAX_SIZE);
        if (c->o2t_asm >= 0)
            FUZZ_CHECK(c->o2t_data_len == dr_asm_info((dr_asm_t)c->o2t_asm)->size);
        FUZZ_CHECK(drsim_conn_by_o2t(&sim, c->o2t_cid) != NULL);
    }
    FUZZ_CHECK(n == drsim_conn_count(&sim) && n <= max_conns);
}

/* drsim_run's sender: every T->O packet parses and is for an open
 * connection, with its assembly's size. (The originator picks a T->O
 * connection ID, so connections may share one: one of them fits.) */
static void io_send(void *ctx, const dr_sockaddr_t *to, const uint8_t *buf, size_t len)
{
    (void)ctx;
    (void)to;
    dr_io_frame_t f;
    FUZZ_CHECK(dr_io_frame_parse(buf, len, false, &f) == DR_OK);
    bool fits = false;
    for (unsigned i = 0; i < DRSIM_MAX_CONNS && !fits; i++) {
        const drsim_conn_t *c = &sim.conn[i];
        fits = c->used && c->t2o_cid == f.cid && f.data_len == dr_asm_info(c->t2o_asm)->size;
    }
    FUZZ_CHECK(fits);
}

/* A SendRRData reply with status 0, to the request body `req`. */
static void check_rr_reply(const uint8_t *req, size_t req_len, const uint8_t *body,
                           size_t len)
{
    uint32_t iface;
    uint16_t timeout;
    dr_cpf_t cpf, rq_cpf;
    FUZZ_CHECK(dr_rr_parse(body, len, &iface, &timeout, &cpf) == DR_OK);
    FUZZ_CHECK(iface == 0 && (cpf.count == 2 || cpf.count == 3));
    FUZZ_CHECK(cpf.item[0].type == DR_CPF_NULL && cpf.item[0].length == 0);
    FUZZ_CHECK(cpf.item[1].type == DR_CPF_UNCONNECTED_DATA);
    dr_cip_rsp_t rsp;
    FUZZ_CHECK(dr_cip_rsp_parse(cpf.item[1].data, cpf.item[1].length, &rsp) == DR_OK);
    FUZZ_CHECK(rsp.service & 0x80u);

    /* The request was accepted (status 0), so it parses too. */
    FUZZ_CHECK(dr_rr_parse(req, req_len, &iface, &timeout, &rq_cpf) == DR_OK);
    const dr_cpf_item_t *data = dr_cpf_find(&rq_cpf, DR_CPF_UNCONNECTED_DATA);
    FUZZ_CHECK(data != NULL);
    /* The service answered: the request's, or the embedded one of an
     * Unconnected Send that was followed. */
    uint8_t svc = data->length > 0 ? (uint8_t)(data->data[0] & 0x7Fu) : 0;
    bool fwd_open = false;
    if (svc == DR_CIP_SVC_UNCONNECTED_SEND && (rsp.service & 0x7Fu) != svc) {
        dr_cip_req_t rq;
        dr_ucmm_send_t us;
        FUZZ_CHECK(dr_cip_req_parse(data->data, data->length, &rq) == DR_OK);
        FUZZ_CHECK(dr_ucmm_send_parse(rq.data, rq.data_len, &us) == DR_OK);
        FUZZ_CHECK(us.message_len > 0 && (rsp.service & 0x7Fu) == (us.message[0] & 0x7Fu));
        svc = us.message[0] & 0x7Fu;
    } else {
        FUZZ_CHECK((rsp.service & 0x7Fu) == svc);
    }
    fwd_open = (svc == DR_CIP_SVC_FORWARD_OPEN || svc == DR_CIP_SVC_LARGE_FORWARD_OPEN) &&
               rsp.general == 0;

    /* Our O->T socket address exactly when a Forward Open succeeded. */
    FUZZ_CHECK((cpf.count == 3) == fwd_open);
    if (fwd_open) {
        dr_sockaddr_t sa;
        FUZZ_CHECK(cpf.item[2].type == DR_CPF_SOCKADDR_O2T);
        FUZZ_CHECK(dr_cpf_sockaddr_parse(&cpf.item[2], &sa) == DR_OK);
        dr_fwd_open_reply_t r;
        FUZZ_CHECK(dr_fwd_open_reply_parse(rsp.data, rsp.data_len, &r) == DR_OK);
        FUZZ_CHECK(drsim_conn_by_o2t(&sim, r.o2t_cid) != NULL);
    }
}

static void check_reply(const dr_encap_t *rq, const uint8_t *rq_body, drsim_peer_t *peer,
                        size_t out_len, bool udp)
{
    dr_encap_t h;
    const uint8_t *body;
    FUZZ_CHECK(out_len >= DR_ENCAP_HEADER_LEN && out_len <= DR_ENCAP_MAX_LEN);
    FUZZ_CHECK(dr_encap_parse(out, out_len, &h, &body) == DR_OK);
    FUZZ_CHECK(h.command == rq->command);
    FUZZ_CHECK(memcmp(h.context, rq->context, 8) == 0);
    FUZZ_CHECK(h.options == 0);
    bool known = false;
    for (size_t i = 0; i < sizeof es_allowed / sizeof es_allowed[0]; i++)
        known |= h.status == es_allowed[i];
    FUZZ_CHECK(known);

    dr_identity_t id;
    dr_cpf_t cpf;
    uint16_t version, options;
    switch (h.command) {
    case DR_ENCAP_LIST_IDENTITY:
        FUZZ_CHECK(h.status == 0);
        FUZZ_CHECK(dr_list_identity_parse(body, h.length, &id) == DR_OK);
        FUZZ_CHECK(strcmp(id.product_name, DRSIM_PRODUCT_NAME) == 0);
        break;
    case DR_ENCAP_LIST_SERVICES:
        FUZZ_CHECK(h.status == 0);
        FUZZ_CHECK(dr_cpf_parse(body, h.length, &cpf) == DR_OK && cpf.count == 1);
        FUZZ_CHECK(cpf.item[0].type == DR_CPF_LIST_SERVICES);
        break;
    case DR_ENCAP_LIST_INTERFACES:
        FUZZ_CHECK(!udp && h.status == 0);
        FUZZ_CHECK(dr_cpf_parse(body, h.length, &cpf) == DR_OK && cpf.count == 0);
        break;
    case DR_ENCAP_REGISTER_SESSION:
        FUZZ_CHECK(!udp);
        if (h.length != 0)
            FUZZ_CHECK(dr_register_parse(body, h.length, &version, &options) == DR_OK &&
                       version == 1 && options == 0);
        if (h.status == 0)
            FUZZ_CHECK(h.length == 4 && h.session != 0 && h.session == peer->session);
        break;
    case DR_ENCAP_SEND_RR_DATA:
        FUZZ_CHECK(!udp);
        if (h.status == 0)
            check_rr_reply(rq_body, rq->length, body, h.length);
        else
            FUZZ_CHECK(h.length == 0);
        break;
    case DR_ENCAP_UNREGISTER_SESSION: /* answered only when refused */
        FUZZ_CHECK(!udp && h.status == 0x0064 && h.length == 0);
        break;
    default:
        FUZZ_CHECK(!udp && h.status == 0x0001 && h.length == 0);
        break;
    }
}

static void tcp_frame(drsim_peer_t *peer, const uint8_t *frame, size_t len)
{
    dr_encap_t h;
    const uint8_t *body;
    bool parses = dr_encap_parse(frame, len, &h, &body) == DR_OK;
    uint32_t session = peer->session;
    size_t out_len = 0;
    drsim_action_t act = drsim_encap(&sim, peer, now, frame, len, out, DR_ENCAP_MAX_LEN,
                                     &out_len);
    if (!parses) {
        FUZZ_CHECK(act == DRSIM_CLOSE);
    } else if (h.command == DR_ENCAP_NOP) {
        FUZZ_CHECK(act == DRSIM_SILENT);
    } else if (act == DRSIM_CLOSE) {
        FUZZ_CHECK(h.command == DR_ENCAP_UNREGISTER_SESSION && session != 0 &&
                   h.session == session);
    } else {
        FUZZ_CHECK(act == DRSIM_REPLY);
        check_reply(&h, body, peer, out_len, false);
    }
    /* A session is registered once per connection. */
    FUZZ_CHECK(session == 0 || peer->session == session);
    if (act == DRSIM_CLOSE)
        peer->session = 0; /* the loop closes it; the next frame is a new peer */
}

static void udp_datagram(const uint8_t *buf, size_t len)
{
    drsim_peer_t peer = {0x7F000002u, 50000, 0x7F000001u, 0};
    dr_encap_t h;
    const uint8_t *body;
    bool parses = dr_encap_parse(buf, len, &h, &body) == DR_OK;
    size_t out_len = 0;
    drsim_action_t act = drsim_encap_udp(&sim, &peer, buf, len, out, DR_ENCAP_MAX_LEN,
                                         &out_len);
    FUZZ_CHECK(act != DRSIM_CLOSE);
    if (!parses || (h.command != DR_ENCAP_LIST_IDENTITY &&
                    h.command != DR_ENCAP_LIST_SERVICES)) {
        FUZZ_CHECK(act == DRSIM_SILENT);
        return;
    }
    FUZZ_CHECK(act == DRSIM_REPLY);
    check_reply(&h, body, &peer, out_len, true);
}

static void io_packet(unsigned op, const uint8_t *buf, size_t len)
{
    uint8_t pkt[256];
    dr_sockaddr_t from = {0x7F000002u, 2222};
    if (len > sizeof pkt)
        len = sizeof pkt;
    memcpy(pkt, buf, len);
    unsigned n = drsim_conn_count(&sim);
    if ((op & 4u) && n > 0 && len >= 10) {
        unsigned want = (op >> 3) % n;
        for (unsigned i = 0; i < DRSIM_MAX_CONNS; i++) {
            if (!sim.conn[i].used)
                continue;
            if (want-- == 0) {
                uint32_t cid = sim.conn[i].o2t_cid;
                pkt[6] = (uint8_t)cid;
                pkt[7] = (uint8_t)(cid >> 8);
                pkt[8] = (uint8_t)(cid >> 16);
                pkt[9] = (uint8_t)(cid >> 24);
                break;
            }
        }
    }
    /* Exactly the packet, on the heap: ASan sees a read past it. */
    uint8_t *copy = malloc(len > 0 ? len : 1);
    FUZZ_CHECK(copy != NULL);
    memcpy(copy, pkt, len);
    drsim_io_receive(&sim, now, &from, copy, len);
    free(copy);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (out == NULL)
        out = malloc(DR_ENCAP_MAX_LEN);
    FUZZ_CHECK(out != NULL);
    if (size < 1)
        return 0;
    static const unsigned conns[4] = {1, 2, 16, 64};
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.max_conns = conns[data[0] & 3u];
    cfg.refuse_fo = (data[0] & 4u) ? 0x0100 : 0;
    cfg.no_large_fo = (data[0] & 8u) != 0;
    cfg.echo = (data[0] & 16u) != 0;
    cfg.drop_pct = (data[0] & 32u) ? 50 : 0;
    cfg.stop_producing_ns = (data[0] & 64u) ? 50000000ull : 0;
    cfg.address = 0x7F000001u;
    max_conns = cfg.max_conns;
    now = NOW0;
    drsim_init(&sim, &cfg, now);
    drsim_peer_t peer[2] = {{0x7F000002u, 40000, 0x7F000001u, 0},
                            {0x7F000003u, 40001, 0x7F000001u, 0}};

    const uint8_t *p = data + 1, *end = data + size;
    while (p < end) {
        unsigned op = *p++;
        size_t rest = (size_t)(end - p), n;
        switch (op & 3u) {
        case 0: {
            drsim_peer_t *pe = &peer[(op >> 2) & 1u];
            size_t total = 0;
            n = dr_encap_frame_len(p, rest, &total) == DR_OK && total <= rest ? total : rest;
            /* Exactly the frame, on the heap: ASan sees a read past it. */
            uint8_t *frame = malloc(n > 0 ? n : 1);
            FUZZ_CHECK(frame != NULL);
            memcpy(frame, p, n);
            if ((op & 8u) && n >= 8) {
                frame[4] = (uint8_t)pe->session;
                frame[5] = (uint8_t)(pe->session >> 8);
                frame[6] = (uint8_t)(pe->session >> 16);
                frame[7] = (uint8_t)(pe->session >> 24);
            }
            tcp_frame(pe, frame, n);
            free(frame);
            break;
        }
        case 1:
        case 2:
            if (rest < 1)
                return 0;
            n = *p++;
            rest--;
            if (n > rest)
                n = rest;
            if ((op & 3u) == 1) {
                uint8_t *dg = malloc(n > 0 ? n : 1);
                FUZZ_CHECK(dg != NULL);
                memcpy(dg, p, n);
                udp_datagram(dg, n);
                free(dg);
            } else {
                io_packet(op, p, n);
            }
            break;
        default:
            n = rest > 0 ? 1 : 0;
            now += ((rest > 0 ? *p : 0) + 1ull) * 1000000ull;
            drsim_run(&sim, now, io_send, NULL);
            break;
        }
        p += n;
        check_conns();
    }
    return 0;
}
