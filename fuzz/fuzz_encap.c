/* SPDX-License-Identifier: MIT */
/*
 * Encapsulation framing and the common packet format, as read from a TCP
 * stream or a UDP datagram: dr_encap_frame_len, dr_encap_parse,
 * dr_register_parse and dr_rr_parse (on the body, and on the whole input),
 * dr_cpf_parse (on the whole input, and on a SendRRData/SendUnitData body),
 * dr_cpf_sockaddr_parse on every item. All these formats have exactly one
 * spelling of what they carry, so an accepted input must re-encode to
 * itself byte for byte (socket address: all but the ignored sin_zero).
 */
#include <string.h>

#include "cip_internal.h"
#include "drgate/codec.h"
#include "fuzz.h"

#define BUF_MAX (0x10000u + 64u)

static uint8_t out[BUF_MAX];

static void check_sockaddr(const dr_cpf_item_t *it)
{
    dr_sockaddr_t sa;
    if (dr_cpf_sockaddr_parse(it, &sa) != DR_OK)
        return;
    FUZZ_CHECK(it->length == 16);
    FUZZ_CHECK(it->data[0] == 0 && it->data[1] == 2);
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_cpf_sockaddr_write(&w, it->type, sa);
    FUZZ_CHECK(!w.overflow && w.len == 4u + 16u);
    FUZZ_CHECK(dr_get_le16(out) == it->type && dr_get_le16(out + 2) == 16);
    FUZZ_CHECK(memcmp(out + 4, it->data, 8) == 0); /* family, port, addr */
}

static void check_cpf(const uint8_t *buf, size_t len)
{
    dr_cpf_t cpf;
    if (dr_cpf_parse(buf, len, &cpf) != DR_OK)
        return;
    FUZZ_CHECK(cpf.count <= DR_CPF_MAX_ITEMS);
    size_t sum = 2;
    for (unsigned i = 0; i < cpf.count; i++) {
        const dr_cpf_item_t *it = &cpf.item[i];
        FUZZ_CHECK(fuzz_within(it->data, it->length, buf, len));
        /* Items follow each other with no gap: data right after 4 bytes of
         * type and length. */
        FUZZ_CHECK(it->data == buf + sum + 4);
        sum += 4u + it->length;
        FUZZ_CHECK(dr_cpf_find(&cpf, it->type) != NULL);
        FUZZ_CHECK(dr_cpf_find(&cpf, it->type)->type == it->type);
        check_sockaddr(it);
    }
    FUZZ_CHECK(sum == len);

    /* Round trip. */
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_cpf_begin(&w, cpf.count);
    for (unsigned i = 0; i < cpf.count; i++) {
        size_t m = dr_cpf_item_begin(&w, cpf.item[i].type);
        dr_wr_bytes(&w, cpf.item[i].data, cpf.item[i].length);
        dr_cpf_item_end(&w, m);
    }
    FUZZ_CHECK(!w.overflow && w.len == len);
    FUZZ_CHECK(len == 0 || memcmp(out, buf, len) == 0);
}

/* Command bodies: RegisterSession, SendRRData / SendUnitData. */
static void check_bodies(const uint8_t *buf, size_t len)
{
    uint16_t version, options;
    if (dr_register_parse(buf, len, &version, &options) == DR_OK) {
        FUZZ_CHECK(len == 4);
        dr_wr_t w;
        dr_wr_init(&w, out, sizeof out);
        dr_register_write(&w, version, options);
        FUZZ_CHECK(!w.overflow && w.len == 4 && memcmp(out, buf, 4) == 0);
    }
    uint32_t iface;
    uint16_t timeout;
    dr_cpf_t cpf, direct;
    dr_status_t st = dr_rr_parse(buf, len, &iface, &timeout, &cpf);
    /* The same verdict as the CPF parser on the rest. */
    if (len >= 6)
        FUZZ_CHECK((st == DR_OK) == (dr_cpf_parse(buf + 6, len - 6u, &direct) == DR_OK));
    else
        FUZZ_CHECK(st == DR_ESHORT);
    if (st == DR_OK) {
        FUZZ_CHECK(iface == dr_get_le32(buf) && timeout == dr_get_le16(buf + 4));
        FUZZ_CHECK(cpf.count == direct.count);
        for (unsigned i = 0; i < cpf.count; i++)
            FUZZ_CHECK(cpf.item[i].data == direct.item[i].data &&
                       cpf.item[i].length == direct.item[i].length);
        dr_wr_t w;
        dr_wr_init(&w, out, sizeof out);
        dr_rr_begin(&w, timeout);
        FUZZ_CHECK(!w.overflow && w.len == 6);
        FUZZ_CHECK(memcmp(out + 4, buf + 4, 2) == 0 && dr_get_le32(out) == 0);
        check_cpf(buf + 6, len - 6u);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    /* Stream framing: what the reader would wait for. */
    size_t total = 0;
    dr_status_t fl = dr_encap_frame_len(data, size, &total);
    if (size < DR_ENCAP_HEADER_LEN) {
        FUZZ_CHECK(fl == DR_EAGAIN);
    } else {
        size_t want = DR_ENCAP_HEADER_LEN + dr_get_le16(data + 2);
        FUZZ_CHECK(fl == (want > DR_ENCAP_MAX_LEN ? DR_ELONG : DR_OK));
        if (fl == DR_OK)
            FUZZ_CHECK(total == want);
    }

    dr_encap_t h;
    const uint8_t *body = NULL;
    dr_status_t st = dr_encap_parse(data, size, &h, &body);
    /* The two agree: a frame of exactly frame_len bytes parses. */
    if (fl == DR_OK)
        FUZZ_CHECK((st == DR_OK) == (size == total));
    if (st == DR_OK) {
        FUZZ_CHECK(size == DR_ENCAP_HEADER_LEN + (size_t)h.length);
        FUZZ_CHECK(body == data + DR_ENCAP_HEADER_LEN);
        FUZZ_CHECK(h.command == dr_get_le16(data));
        memcpy(out + DR_ENCAP_HEADER_LEN, body, h.length);
        FUZZ_CHECK(dr_encap_write(out, sizeof out, &h, h.length) == DR_OK);
        FUZZ_CHECK(memcmp(out, data, size) == 0);
        check_bodies(body, h.length);
        /* ListIdentity and ListServices replies: CPF right away. */
        check_cpf(body, h.length);
    } else {
        FUZZ_CHECK(st == DR_ESHORT || st == DR_ELONG);
    }

    /* A bare body, a Class 1 datagram or a bare CPF. */
    check_bodies(data, size);
    check_cpf(data, size);
    return 0;
}
