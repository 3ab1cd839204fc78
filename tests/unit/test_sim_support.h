/* SPDX-License-Identifier: MIT */
/* Helpers for the drsim unit tests: build requests with lib/cip.c, run
 * them through the adapter, parse the replies with lib/cip.c. */
#ifndef TEST_SIM_SUPPORT_H
#define TEST_SIM_SUPPORT_H

#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "adapter.h"

#define T0 1000000000ull /* adapter start time in the tests */
#define MS 1000000ull

typedef struct {
    drsim_t sim;
    drsim_peer_t peer;
    uint8_t out[DR_ENCAP_MAX_LEN];
    size_t out_len;
    dr_encap_t hdr;       /* last reply header */
    const uint8_t *body;  /* last reply body */
    dr_cpf_t cpf;         /* last SendRRData reply CPF */
    size_t cpf_extra;     /* bytes after its declared items */
    dr_cip_rsp_t rsp;     /* last CIP reply */
    /* packets sent by drsim_run */
    unsigned sent;
    dr_sockaddr_t sent_to;
    uint8_t pkt[64 + DR_POINT_MAX_SIZE];
    size_t pkt_len;
} fx_t;

static inline void fx_init(fx_t *f, const drsim_config_t *cfg)
{
    memset(f, 0, sizeof *f);
    drsim_config_t c;
    if (cfg == NULL) {
        drsim_config_default(&c);
        cfg = &c;
    }
    drsim_init(&f->sim, cfg, T0);
    f->peer.addr = 0x7F000001u;
    f->peer.port = 40000;
    f->peer.local_addr = 0x7F000002u;
}

/* Send one encapsulation frame; returns the action. */
static inline drsim_action_t fx_encap(fx_t *f, uint16_t cmd, uint32_t session,
                                      const uint8_t *body, size_t len)
{
    uint8_t frame[DR_ENCAP_MAX_LEN];
    dr_encap_t h;
    memset(&h, 0, sizeof h);
    h.command = cmd;
    h.session = session;
    memcpy(h.context, "drsimtst", 8);
    assert_true(len <= sizeof frame - DR_ENCAP_HEADER_LEN);
    if (len > 0)
        memcpy(frame + DR_ENCAP_HEADER_LEN, body, len);
    assert_int_equal(dr_encap_write(frame, sizeof frame, &h, len), DR_OK);
    f->out_len = 0;
    drsim_action_t act = drsim_encap(&f->sim, &f->peer, T0, frame,
                                     DR_ENCAP_HEADER_LEN + len, f->out,
                                     sizeof f->out, &f->out_len);
    if (act == DRSIM_REPLY) {
        assert_int_equal(dr_encap_parse(f->out, f->out_len, &f->hdr, &f->body), DR_OK);
        assert_int_equal(f->hdr.command, cmd);
        assert_memory_equal(f->hdr.context, "drsimtst", 8);
    }
    return act;
}

static inline uint32_t fx_register(fx_t *f)
{
    uint8_t b[4];
    dr_wr_t w;
    dr_wr_init(&w, b, sizeof b);
    dr_register_write(&w, 1, 0);
    assert_int_equal(fx_encap(f, DR_ENCAP_REGISTER_SESSION, 0, b, w.len), DRSIM_REPLY);
    assert_int_equal(f->hdr.status, 0);
    assert_int_not_equal(f->hdr.session, 0);
    return f->hdr.session;
}

/* SendRRData carrying `req`; optional 0x8001 item. Parses the CIP reply
 * into f->rsp and returns its status code. */
static inline dr_status_t fx_rr(fx_t *f, const uint8_t *req, size_t len,
                                const dr_sockaddr_t *t2o)
{
    uint8_t body[DR_ENCAP_MAX_LEN];
    dr_wr_t w;
    dr_wr_init(&w, body, sizeof body);
    dr_rr_begin(&w, 0);
    dr_cpf_begin(&w, t2o ? 3 : 2);
    size_t m = dr_cpf_item_begin(&w, DR_CPF_NULL);
    dr_cpf_item_end(&w, m);
    m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_wr_bytes(&w, req, len);
    dr_cpf_item_end(&w, m);
    if (t2o)
        dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, *t2o);
    assert_false(w.overflow);
    assert_int_equal(fx_encap(f, DR_ENCAP_SEND_RR_DATA, f->peer.session, body, w.len),
                     DRSIM_REPLY);
    assert_int_equal(f->hdr.status, 0);
    /* Interface handle and timeout, then the CPF, read as the client
     * reads replies (--trailing-item adds bytes after the items). */
    assert_true(f->hdr.length >= 6);
    assert_int_equal(dr_cpf_parse_reply(f->body + 6, f->hdr.length - 6u, &f->cpf,
                                        &f->cpf_extra), DR_OK);
    const dr_cpf_item_t *it = dr_cpf_find(&f->cpf, DR_CPF_UNCONNECTED_DATA);
    assert_non_null(it);
    assert_int_equal(dr_cip_rsp_parse(it->data, it->length, &f->rsp), DR_OK);
    return dr_cip_rsp_status(&f->rsp);
}

/* A request to class/instance[/attribute] with data. */
static inline dr_status_t fx_req(fx_t *f, uint8_t svc, uint16_t cls, uint16_t inst,
                                 int attr, const void *data, size_t len)
{
    uint8_t path[16], req[DR_ENCAP_MAX_LEN];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, cls, inst, attr);
    size_t pl = w.len;
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, svc, path, pl, data, len);
    dr_status_t st = fx_rr(f, req, w.len, NULL);
    assert_int_equal(f->rsp.service, svc | DR_CIP_REPLY);
    return st;
}

static inline void fx_capture(void *ctx, const dr_sockaddr_t *to, const uint8_t *buf,
                              size_t len)
{
    fx_t *f = ctx;
    f->sent++;
    f->sent_to = *to;
    assert_true(len <= sizeof f->pkt);
    memcpy(f->pkt, buf, len);
    f->pkt_len = len;
}

#endif /* TEST_SIM_SUPPORT_H */
