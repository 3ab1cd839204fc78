/* SPDX-License-Identifier: MIT */
/*
 * What the adapter (drsim, or a gateway's own adapter) reads from a
 * scanner: Message Router requests (dr_cip_req_parse), their EPATH
 * (dr_epath_parse), and the Connection Manager's request data:
 * Unconnected Send (dr_ucmm_send_parse, one level of nesting followed),
 * Forward Open in both sizes and Forward Close. Every data parser gets the
 * request data whatever the service code, so the fuzzer need not guess it.
 * Re-encoding must give the input back once the fields the writers fix
 * (reserved bytes and bits, pad bytes, the UCMM tick and timeout) are
 * masked in the input.
 */
#include <string.h>

#include "cip_internal.h"
#include "drgate/codec.h"
#include "fuzz.h"

static uint8_t out[0x20000];
static uint8_t canon[0x20000];

static void check_epath(const uint8_t *p, size_t n)
{
    dr_epath_t ep;
    dr_status_t st = dr_epath_parse(p, n, &ep);
    if (st != DR_OK) {
        FUZZ_CHECK(st == DR_CIP(0x04, 0)); /* the one error it answers */
        return;
    }
    FUZZ_CHECK(ep.points <= 2);
    FUZZ_CHECK(ep.has_cls || ep.cls == 0);
    FUZZ_CHECK(ep.has_inst || ep.inst == 0);
    FUZZ_CHECK(ep.has_attr || ep.attr == 0);
    if (ep.data != NULL)
        FUZZ_CHECK(fuzz_within(ep.data, 2u * ep.data_words, p, n));
    else
        FUZZ_CHECK(ep.data_words == 0);
    /* What the writer makes of the values, the parser reads back. */
    if (ep.has_cls && ep.has_inst) {
        dr_wr_t w;
        dr_wr_init(&w, out, sizeof out);
        dr_epath_write(&w, ep.cls, ep.inst, ep.has_attr ? ep.attr : -1);
        dr_epath_t again;
        FUZZ_CHECK(!w.overflow);
        FUZZ_CHECK(dr_epath_parse(out, w.len, &again) == DR_OK);
        FUZZ_CHECK(again.cls == ep.cls && again.inst == ep.inst);
        FUZZ_CHECK(again.has_attr == ep.has_attr && again.attr == ep.attr);
    }
}

static void check_req(const uint8_t *buf, size_t len, const dr_cip_req_t *req)
{
    FUZZ_CHECK(len >= 2 && req->path_len == 2u * buf[1]);
    FUZZ_CHECK(req->path == buf + 2);
    FUZZ_CHECK(2u + req->path_len + req->data_len == len);
    FUZZ_CHECK(fuzz_within(req->data, req->data_len, buf, len));
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_cip_req_write(&w, req->service, req->path, req->path_len, req->data,
                     req->data_len);
    FUZZ_CHECK(!w.overflow && w.len == len && memcmp(out, buf, len) == 0);
    check_epath(req->path, req->path_len);
}

static void check_fwd_open(const uint8_t *buf, size_t len, bool large)
{
    dr_fwd_open_t fo;
    if (dr_fwd_open_parse(buf, len, large, &fo) != DR_OK)
        return;
    size_t head = large ? 40u : 36u;
    FUZZ_CHECK(fo.large == large);
    FUZZ_CHECK(len == head + fo.path_len && fo.path == buf + head);
    FUZZ_CHECK(fo.path_len == 2u * buf[head - 1]);
    if (!large)
        FUZZ_CHECK(fo.o2t.size <= 0x1FF && fo.t2o.size <= 0x1FF);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_open_write(&w, &fo);
    FUZZ_CHECK(!w.overflow && w.len == len);
    memcpy(canon, buf, len);
    memset(canon + 19, 0, 3); /* reserved after the timeout multiplier */
    if (large) {
        /* 32-bit network parameters: bits 16-24 and 28 reserved. */
        canon[28] = 0;
        canon[29] &= (uint8_t)~0x11u;
        canon[36] = 0;
        canon[37] &= (uint8_t)~0x11u;
    } else {
        /* 16-bit: bit 12 reserved. */
        canon[27] &= (uint8_t)~0x10u;
        canon[33] &= (uint8_t)~0x10u;
    }
    FUZZ_CHECK(memcmp(out, canon, len) == 0);
    check_epath(fo.path, fo.path_len);
}

static void check_fwd_close(const uint8_t *buf, size_t len)
{
    dr_fwd_close_t fc;
    if (dr_fwd_close_parse(buf, len, &fc) != DR_OK)
        return;
    FUZZ_CHECK(len == 12u + fc.path_len && fc.path == buf + 12);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_close_write(&w, &fc);
    FUZZ_CHECK(!w.overflow && w.len == len);
    memcpy(canon, buf, len);
    canon[11] = 0; /* reserved */
    FUZZ_CHECK(memcmp(out, canon, len) == 0);
    check_epath(fc.path, fc.path_len);
}

static void check_data(const uint8_t *buf, size_t len, int depth);

static void check_ucmm(const uint8_t *buf, size_t len, int depth)
{
    dr_ucmm_send_t u;
    if (dr_ucmm_send_parse(buf, len, &u) != DR_OK)
        return;
    size_t pad = u.message_len % 2u;
    FUZZ_CHECK(u.message == buf + 4);
    FUZZ_CHECK(len == 4u + u.message_len + pad + 2u + u.route_len);
    FUZZ_CHECK(fuzz_within(u.route, u.route_len, buf, len));
    FUZZ_CHECK(u.route == buf + len - u.route_len);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_ucmm_send_write(&w, u.message, u.message_len, u.route, u.route_len);
    FUZZ_CHECK(!w.overflow && w.len == len);
    memcpy(canon, buf, len);
    canon[0] = 0x0A; /* the writer's fixed tick and timeout */
    canon[1] = 0x05;
    if (pad)
        canon[4 + u.message_len] = 0;
    canon[4 + u.message_len + pad + 1] = 0; /* reserved */
    FUZZ_CHECK(memcmp(out, canon, len) == 0);

    /* The embedded request, as the adapter would route it. */
    if (depth < 2) {
        dr_cip_req_t req;
        if (dr_cip_req_parse(u.message, u.message_len, &req) == DR_OK) {
            check_req(u.message, u.message_len, &req);
            check_data(req.data, req.data_len, depth + 1);
        }
    }
}

static void check_data(const uint8_t *buf, size_t len, int depth)
{
    check_ucmm(buf, len, depth);
    check_fwd_open(buf, len, false);
    check_fwd_open(buf, len, true);
    check_fwd_close(buf, len);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    dr_cip_req_t req;
    if (dr_cip_req_parse(data, size, &req) == DR_OK) {
        check_req(data, size, &req);
        check_data(req.data, req.data_len, 0);
    }
    /* The bare EPATH, for a fuzzer that has not found the header yet. */
    check_epath(data, size);
    return 0;
}
