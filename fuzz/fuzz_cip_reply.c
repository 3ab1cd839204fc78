/* SPDX-License-Identifier: MIT */
/*
 * What the client (originator) reads from the robot: the CPF of a reply
 * (dr_cpf_parse_reply), Message Router replies (dr_cip_rsp_parse, dr_cip_rsp_status), the Forward Open reply, the
 * Identity object's Get_Attributes_All data and the ListIdentity body. Each
 * parser gets the whole input, and the reply-data parsers also get the data
 * of an accepted MR reply. Re-encoding must give the input back, except for
 * fields the parsers skip (reserved bytes, a third additional status word,
 * an application reply, sin_zero, protocol version): those are masked first.
 */
#include <stdbool.h>
#include <string.h>

#include "cip_internal.h"
#include "drgate/codec.h"
#include "fuzz.h"

static uint8_t out[0x20000];
static uint8_t canon[0x20000];

static void check_rsp(const uint8_t *buf, size_t len, dr_cip_rsp_t *rsp)
{
    FUZZ_CHECK(rsp->service & DR_CIP_REPLY);
    FUZZ_CHECK(4u + 2u * rsp->ext_count + rsp->data_len == len);
    FUZZ_CHECK(fuzz_within(rsp->data, rsp->data_len, buf, len));
    FUZZ_CHECK(rsp->data == buf + len - rsp->data_len);
    dr_status_t st = dr_cip_rsp_status(rsp);
    if (rsp->general == 0) {
        FUZZ_CHECK(st == DR_OK);
    } else {
        FUZZ_CHECK(DR_IS_CIP(st) && DR_CIP_GENERAL(st) == rsp->general);
        FUZZ_CHECK(DR_CIP_EXTENDED(st) == (rsp->ext_count ? rsp->ext[0] : 0));
    }
    if (rsp->ext_count > 2)
        return; /* only two words are kept */
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_cip_rsp_write(&w, rsp->service, rsp->general, rsp->ext, rsp->ext_count,
                     rsp->data, rsp->data_len);
    FUZZ_CHECK(!w.overflow && w.len == len);
    memcpy(canon, buf, len);
    canon[1] = 0; /* reserved */
    FUZZ_CHECK(memcmp(out, canon, len) == 0);
}

static void check_fwd_open_reply(const uint8_t *buf, size_t len)
{
    dr_fwd_open_reply_t r;
    if (dr_fwd_open_reply_parse(buf, len, &r) != DR_OK)
        return;
    FUZZ_CHECK(len >= 26 && len == 26u + 2u * buf[24]);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_open_reply_write(&w, &r);
    FUZZ_CHECK(!w.overflow && w.len == 26);
    /* The application reply is not kept: compare what is. */
    FUZZ_CHECK(memcmp(out, buf, 24) == 0);
}

static bool printable(const uint8_t *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        if (s[i] < 0x20 || s[i] >= 0x7F)
            return false;
    return true;
}

static void check_name(const dr_identity_t *id)
{
    size_t n = strnlen(id->product_name, sizeof id->product_name);
    FUZZ_CHECK(n < sizeof id->product_name); /* NUL-terminated */
    FUZZ_CHECK(printable((const uint8_t *)id->product_name, n));
}

static void check_identity_all(const uint8_t *buf, size_t len)
{
    dr_identity_t id;
    if (dr_identity_parse_all(buf, len, &id) != DR_OK)
        return;
    check_name(&id);
    FUZZ_CHECK(len >= 15 && len >= 15u + buf[14]);
    FUZZ_CHECK(id.state == 0xFF);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_identity_write_all(&w, &id);
    FUZZ_CHECK(!w.overflow);
    size_t n = buf[14];
    if (n <= 32 && printable(buf + 15, n)) {
        /* Attributes 1-7 come back; what follows them is not kept. */
        FUZZ_CHECK(w.len == 15u + n && memcmp(out, buf, w.len) == 0);
    } else {
        FUZZ_CHECK(memcmp(out, buf, 14) == 0);
    }
}

static bool same_identity(const dr_identity_t *a, const dr_identity_t *b)
{
    return a->vendor == b->vendor && a->device_type == b->device_type &&
           a->product_code == b->product_code && a->rev_major == b->rev_major &&
           a->rev_minor == b->rev_minor && a->status == b->status &&
           a->serial == b->serial && a->state == b->state &&
           a->sockaddr.addr == b->sockaddr.addr &&
           a->sockaddr.port == b->sockaddr.port &&
           strcmp(a->product_name, b->product_name) == 0;
}

static void check_list_identity(const uint8_t *buf, size_t len)
{
    dr_identity_t id, again;
    if (dr_list_identity_parse(buf, len, &id) != DR_OK)
        return;
    check_name(&id);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_list_identity_write(&w, &id);
    FUZZ_CHECK(!w.overflow);
    /* What we write, we read back the same. */
    FUZZ_CHECK(dr_list_identity_parse(out, w.len, &again) == DR_OK);
    FUZZ_CHECK(same_identity(&id, &again));

    /* Byte for byte when the input is a single item with a name we keep
     * whole; version, family and sin_zero are not kept, so masked. */
    dr_cpf_t cpf;
    size_t extra = 0;
    FUZZ_CHECK(dr_cpf_parse_reply(buf, len, &cpf, &extra) == DR_OK);
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_LIST_IDENTITY);
    FUZZ_CHECK(it != NULL && it->length >= 2u + 16u + 15u + 1u);
    size_t n = it->data[18 + 14];
    if (cpf.count == 1 && extra == 0 && n <= 32 && printable(it->data + 18 + 15, n)) {
        FUZZ_CHECK(w.len == len);
        memcpy(canon, buf, len);
        uint8_t *d = canon + (it->data - buf);
        d[0] = 1; /* encapsulation protocol version */
        d[1] = 0;
        d[2] = 0; /* sin_family */
        d[3] = 2;
        memset(d + 10, 0, 8); /* sin_zero */
        FUZZ_CHECK(memcmp(out, canon, len) == 0);
    }
}

/* The lenient CPF parse of replies: the declared items are the strict
 * parse of the bytes before the extra ones, and the strict parse of the
 * whole input succeeds exactly when nothing is extra. */
static void check_cpf_reply(const uint8_t *buf, size_t len)
{
    dr_cpf_t cpf, strict;
    size_t extra = 0;
    dr_status_t st = dr_cpf_parse_reply(buf, len, &cpf, &extra);
    dr_status_t whole = dr_cpf_parse(buf, len, &strict);
    if (st != DR_OK) {
        FUZZ_CHECK(whole == st);
        return;
    }
    FUZZ_CHECK(extra <= len);
    FUZZ_CHECK((whole == DR_OK) == (extra == 0));
    FUZZ_CHECK(dr_cpf_parse(buf, len - extra, &strict) == DR_OK);
    FUZZ_CHECK(strict.count == cpf.count);
    for (unsigned i = 0; i < cpf.count; i++) {
        FUZZ_CHECK(cpf.item[i].type == strict.item[i].type);
        FUZZ_CHECK(cpf.item[i].length == strict.item[i].length);
        FUZZ_CHECK(fuzz_within(cpf.item[i].data, cpf.item[i].length, buf, len - extra));
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    check_cpf_reply(data, size);
    dr_cip_rsp_t rsp;
    if (dr_cip_rsp_parse(data, size, &rsp) == DR_OK) {
        check_rsp(data, size, &rsp);
        check_fwd_open_reply(rsp.data, rsp.data_len);
        check_identity_all(rsp.data, rsp.data_len);
    }
    check_fwd_open_reply(data, size);
    check_identity_all(data, size);
    check_list_identity(data, size);
    return 0;
}
