/* SPDX-License-Identifier: MIT */
/*
 * lib/cip.c against byte vectors written by hand from the EtherNet/IP (CIP
 * Vol. 2) and CIP (Vol. 1) layouts: every builder is compared byte for byte
 * with a vector, every parser reads the same vector back, and every parser
 * is fed every truncation of a valid frame (and, where the format fixes the
 * length, every frame one byte too long). The truncated copies live in
 * exactly-sized heap blocks, so `make check-asan` catches any read past the
 * end that a parser might make before noticing.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "cip_internal.h"

#define N(a) (sizeof(a) / sizeof((a)[0]))

/* ---- vectors ------------------------------------------------------------ */

/* RegisterSession request: command 0x65, length 4, session 0, status 0,
 * context 0, options 0; body: protocol version 1, option flags 0. */
static const uint8_t v_register_req[] = {
    0x65, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    0x01, 0x00, 0x00, 0x00};

/* Its reply: session 0x11223344 chosen by the target, the sender context
 * echoed (01..08), a non-zero options field to see it carried through. */
static const uint8_t v_register_rsp[] = {
    0x65, 0x00, 0x04, 0x00, 0x44, 0x33, 0x22, 0x11, 0x00, 0x00, 0x00, 0x00,
    0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0xA5, 0x00, 0x00, 0x5A,
    0x01, 0x00, 0x00, 0x00};

/* SendRRData carrying an unconnected Get_Attribute_Single of assembly
 * 0x65 attribute 3: interface handle 0, timeout 10 s, CPF of two items
 * (null address, unconnected data of 8 bytes). */
static const uint8_t v_send_rr[] = {
    0x6F, 0x00, 0x18, 0x00, 0x44, 0x33, 0x22, 0x11, 0x00, 0x00, 0x00, 0x00,
    0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x00, 0x00, 0x00, 0x00,
    /* body */
    0x00, 0x00, 0x00, 0x00, 0x0A, 0x00,             /* handle, timeout */
    0x02, 0x00,                                     /* item count */
    0x00, 0x00, 0x00, 0x00,                         /* null address */
    0xB2, 0x00, 0x08, 0x00,                         /* unconnected data */
    0x0E, 0x03, 0x20, 0x04, 0x24, 0x65, 0x30, 0x03}; /* MR request */

/* Socket address item body for T->O: AF_INET (2), port 2222, address
 * 192.168.137.10, all big-endian, then 8 bytes of sin_zero. */
#define SOCKADDR_BODY                                                          \
    0x00, 0x02, 0x08, 0xAE, 0xC0, 0xA8, 0x89, 0x0A, 0x00, 0x00, 0x00, 0x00,    \
        0x00, 0x00, 0x00, 0x00
static const uint8_t v_sockaddr_t2o[] = {0x01, 0x80, 0x10, 0x00, SOCKADDR_BODY};

/* Forward Open request data (after 54 02 20 06 24 01), 16-bit network
 * parameters:
 *   O->T: point-to-point (2 << 13 = 0x4000), scheduled (2 << 10 = 0x0800),
 *         fixed, 18 bytes (12 io_control + 2 sequence + 4 run/idle) = 0x4812
 *   T->O: multicast (1 << 13 = 0x2000), high (1 << 10 = 0x0400), fixed,
 *         38 bytes (36 io_state + 2 sequence) = 0x2426 */
#define FO_HEAD                                                                \
    0x0A, 0x0E,                 /* 2^10 ms tick, 14 ticks */                   \
        0x00, 0x00, 0x00, 0x00, /* O->T CID: the target chooses */             \
        0x78, 0x56, 0x34, 0x12, /* T->O CID */                                 \
        0x42, 0x00,             /* connection serial */                        \
        0xCD, 0xAB,             /* originator vendor */                        \
        0xEF, 0xBE, 0xAD, 0xDE, /* originator serial */                        \
        0x02, 0x00, 0x00, 0x00, /* timeout multiplier x16, reserved */         \
        0x10, 0x27, 0x00, 0x00  /* O->T RPI 10000 us */
#define CONN_PATH 0x20, 0x04, 0x24, 0x01, 0x2C, 0x6B, 0x2C, 0x65
static const uint8_t v_fwd_open[] = {
    FO_HEAD,
    0x12, 0x48,             /* O->T netparams 0x4812 */
    0x10, 0x27, 0x00, 0x00, /* T->O RPI */
    0x26, 0x24,             /* T->O netparams 0x2426 */
    0x01, 0x04, CONN_PATH}; /* class 1 cyclic, 4 words of path */

/* The same under Large Forward Open (0x5B): 32-bit parameters, type at
 * bits 29-30, priority at 26-27, size in bits 0-15. */
static const uint8_t v_fwd_open_large[] = {
    FO_HEAD,
    0x12, 0x00, 0x00, 0x48, /* 0x48000012 */
    0x10, 0x27, 0x00, 0x00,
    0x26, 0x00, 0x00, 0x24, /* 0x24000026 */
    0x01, 0x04, CONN_PATH};

/* Forward Open reply data (after D4 00 00 00). */
static const uint8_t v_fwd_open_reply[] = {
    0x44, 0x33, 0x22, 0x11, /* O->T CID chosen by the target */
    0x78, 0x56, 0x34, 0x12, /* T->O CID */
    0x42, 0x00, 0xCD, 0xAB, 0xEF, 0xBE, 0xAD, 0xDE,
    0x10, 0x27, 0x00, 0x00, /* O->T API */
    0x20, 0x4E, 0x00, 0x00, /* T->O API 20000 us */
    0x00, 0x00};            /* application reply: 0 words, reserved */

/* Forward Close request data (after 4E 02 20 06 24 01). */
static const uint8_t v_fwd_close[] = {
    0x0A, 0x0E, 0x42, 0x00, 0xCD, 0xAB, 0xEF, 0xBE, 0xAD, 0xDE,
    0x04, 0x00, CONN_PATH};

/* Class 1 O->T datagram with the run/idle header: sequenced address item
 * (CID, encapsulation sequence), connected data item (CIP sequence 5,
 * run/idle = run, 12 data bytes). */
static const uint8_t v_io_run_idle[] = {
    0x02, 0x00,
    0x02, 0x80, 0x08, 0x00, 0x78, 0x56, 0x34, 0x12, 0x01, 0x00, 0x00, 0x00,
    0xB1, 0x00, 0x12, 0x00, 0x05, 0x00, 0x01, 0x00, 0x00, 0x00,
    0x00, 0x01, 0x02, 0x03, 0x04, 0x05, 0x06, 0x07, 0x08, 0x09, 0x0A, 0x0B};

/* Class 1 T->O datagram, modeless (no run/idle header), 4 data bytes. */
static const uint8_t v_io_plain[] = {
    0x02, 0x00,
    0x02, 0x80, 0x08, 0x00, 0x44, 0x33, 0x22, 0x11, 0xFF, 0xFF, 0xFF, 0xFF,
    0xB1, 0x00, 0x06, 0x00, 0x07, 0x00, 0xDE, 0xAD, 0xBE, 0xEF};

/* Identity attributes 1-7: vendor, device type 0x0C, product code 1,
 * revision 1.2, status 0x0030, serial, SHORT_STRING "drgate sim". */
#define IDENTITY_ALL                                                           \
    0xCD, 0xAB, 0x0C, 0x00, 0x01, 0x00, 0x01, 0x02, 0x30, 0x00, 0x44, 0x33,    \
        0x22, 0x11, 0x0A, 'd', 'r', 'g', 'a', 't', 'e', ' ', 's', 'i', 'm'
static const uint8_t v_identity_all[] = {IDENTITY_ALL};

/* ListIdentity reply body: one 0x0C item of 44 bytes: protocol version 1
 * (little-endian), socket address (big-endian, port 44818 = 0xAF12),
 * identity attributes 1-7, state 3. */
static const uint8_t v_list_identity[] = {
    0x01, 0x00, 0x0C, 0x00, 0x2C, 0x00, 0x01, 0x00,
    0x00, 0x02, 0xAF, 0x12, 0xC0, 0xA8, 0x89, 0x0A,
    0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
    IDENTITY_ALL, 0x03};

static const uint8_t ctx8[8] = {1, 2, 3, 4, 5, 6, 7, 8};

/* ---- encapsulation ------------------------------------------------------ */

static void test_encap_register_session(void **state)
{
    (void)state;
    dr_encap_t h;
    const uint8_t *body = NULL;
    assert_int_equal(dr_encap_parse(v_register_req, sizeof v_register_req, &h, &body),
                     DR_OK);
    assert_int_equal(h.command, DR_ENCAP_REGISTER_SESSION);
    assert_int_equal(h.length, 4);
    assert_int_equal(h.session, 0);
    assert_int_equal(h.status, 0);
    assert_int_equal(h.options, 0);
    assert_ptr_equal(body, v_register_req + 24);

    /* Build it: body first at +24, then the header around it. */
    uint8_t buf[64];
    memset(buf, 0xEE, sizeof buf);
    dr_encap_t out = {DR_ENCAP_REGISTER_SESSION, 0, 0, 0, {0}, 0};
    const uint8_t rs_body[4] = {0x01, 0x00, 0x00, 0x00};
    memcpy(buf + 24, rs_body, 4);
    assert_int_equal(dr_encap_write(buf, sizeof buf, &out, 4), DR_OK);
    assert_memory_equal(buf, v_register_req, sizeof v_register_req);

    /* The reply: session, context and options all carried. */
    assert_int_equal(dr_encap_parse(v_register_rsp, sizeof v_register_rsp, &h, &body),
                     DR_OK);
    assert_int_equal(h.session, 0x11223344u);
    assert_memory_equal(h.context, ctx8, 8);
    assert_int_equal(h.options, 0x5A0000A5u);
    dr_encap_t rsp = {DR_ENCAP_REGISTER_SESSION, 0, 0x11223344u, 0,
                      {1, 2, 3, 4, 5, 6, 7, 8}, 0x5A0000A5u};
    memcpy(buf + 24, rs_body, 4);
    assert_int_equal(dr_encap_write(buf, sizeof buf, &rsp, 4), DR_OK);
    assert_memory_equal(buf, v_register_rsp, sizeof v_register_rsp);
}

static void test_encap_status_and_body(void **state)
{
    (void)state;
    /* An error reply (status 0x69, unsupported protocol revision) with no
     * body: the status field is little-endian like the rest. */
    const uint8_t err[] = {0x65, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
                           0x69, 0x00, 0x00, 0x00, 0, 0, 0, 0, 0, 0, 0, 0,
                           0x00, 0x00, 0x00, 0x00};
    dr_encap_t h;
    const uint8_t *body = NULL;
    assert_int_equal(dr_encap_parse(err, sizeof err, &h, &body), DR_OK);
    assert_int_equal(h.status, 0x69);
    assert_int_equal(h.length, 0);
    assert_ptr_equal(body, err + 24);

    /* SendRRData: header, then handle + timeout, then the CPF. */
    assert_int_equal(dr_encap_parse(v_send_rr, sizeof v_send_rr, &h, &body), DR_OK);
    assert_int_equal(h.command, DR_ENCAP_SEND_RR_DATA);
    assert_int_equal(h.length, 24);
    dr_cpf_t cpf;
    assert_int_equal(dr_cpf_parse(body + 6, h.length - 6u, &cpf), DR_OK);
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_UNCONNECTED_DATA);
    assert_non_null(it);
    dr_cip_req_t req;
    assert_int_equal(dr_cip_req_parse(it->data, it->length, &req), DR_OK);
    assert_int_equal(req.service, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE);
    dr_epath_t ep;
    assert_int_equal(dr_epath_parse(req.path, req.path_len, &ep), DR_OK);
    assert_int_equal(ep.cls, 4);
    assert_int_equal(ep.inst, 0x65);
    assert_int_equal(ep.attr, 3);

    /* ...and built with the writer, byte for byte. */
    uint8_t buf[64];
    dr_wr_t w;
    dr_wr_init(&w, buf + 24, sizeof buf - 24);
    dr_wr_u32(&w, 0);
    dr_wr_u16(&w, 10);
    dr_cpf_begin(&w, 2);
    dr_cpf_item_end(&w, dr_cpf_item_begin(&w, DR_CPF_NULL));
    size_t m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    const uint8_t path[] = {0x20, 0x04, 0x24, 0x65, 0x30, 0x03};
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, sizeof path, NULL, 0);
    dr_cpf_item_end(&w, m);
    assert_false(w.overflow);
    dr_encap_t out = {DR_ENCAP_SEND_RR_DATA, 0, 0x11223344u, 0,
                      {1, 2, 3, 4, 5, 6, 7, 8}, 0};
    assert_int_equal(dr_encap_write(buf, sizeof buf, &out, w.len), DR_OK);
    assert_int_equal(24 + w.len, sizeof v_send_rr);
    assert_memory_equal(buf, v_send_rr, sizeof v_send_rr);
}

static void test_encap_write_errors(void **state)
{
    (void)state;
    uint8_t buf[32];
    dr_encap_t h = {DR_ENCAP_NOP, 0, 0, 0, {0}, 0};
    assert_int_equal(dr_encap_write(buf, 23, &h, 0), DR_ENOSPACE);
    assert_int_equal(dr_encap_write(buf, 24, &h, 0), DR_OK);
    assert_int_equal(dr_encap_write(buf, 27, &h, 4), DR_ENOSPACE);
    assert_int_equal(dr_encap_write(buf, 28, &h, 4), DR_OK);
    /* A body the 16-bit length cannot express is refused, never wrapped. */
    assert_int_equal(dr_encap_write(buf, SIZE_MAX, &h, 0x10000u), DR_ENOSPACE);
}

static void test_encap_frame_len(void **state)
{
    (void)state;
    uint8_t hdr[24];
    memcpy(hdr, v_send_rr, 24);
    size_t total = 0;
    for (size_t n = 0; n < 24; n++)
        assert_int_equal(dr_encap_frame_len(hdr, n, &total), DR_EAGAIN);
    assert_int_equal(dr_encap_frame_len(hdr, 24, &total), DR_OK);
    assert_int_equal(total, 48);
    /* Once the header is in, the answer does not depend on what follows. */
    assert_int_equal(dr_encap_frame_len(v_send_rr, sizeof v_send_rr, &total), DR_OK);
    assert_int_equal(total, sizeof v_send_rr);

    hdr[2] = (uint8_t)(DR_ENCAP_MAX_LEN - 24u);
    hdr[3] = (uint8_t)((DR_ENCAP_MAX_LEN - 24u) >> 8);
    assert_int_equal(dr_encap_frame_len(hdr, 24, &total), DR_OK);
    assert_int_equal(total, DR_ENCAP_MAX_LEN);
    hdr[2]++; /* one byte more than we accept */
    total = 7;
    assert_int_equal(dr_encap_frame_len(hdr, 24, &total), DR_ELONG);
    assert_int_equal(total, 7); /* untouched on error */
    hdr[2] = hdr[3] = 0xFF;
    assert_int_equal(dr_encap_frame_len(hdr, 24, &total), DR_ELONG);
}

static void test_encap_parse_lengths(void **state)
{
    (void)state;
    uint8_t buf[sizeof v_register_req + 1];
    memcpy(buf, v_register_req, sizeof v_register_req);
    buf[sizeof v_register_req] = 0;
    dr_encap_t h;
    const uint8_t *body;
    assert_int_equal(dr_encap_parse(buf, sizeof buf, &h, &body), DR_ELONG);
    assert_int_equal(dr_encap_parse(buf, 27, &h, &body), DR_ESHORT);
    assert_int_equal(dr_encap_parse(buf, 23, &h, &body), DR_ESHORT);
    /* The header says 5, four bytes follow. */
    buf[2] = 5;
    assert_int_equal(dr_encap_parse(buf, 28, &h, &body), DR_ESHORT);
}

/* ---- encapsulation command bodies ---------------------------------------- */

static void test_register_body(void **state)
{
    (void)state;
    uint16_t version = 0, options = 7;
    const uint8_t *body = v_register_req + 24;
    assert_int_equal(dr_register_parse(body, 4, &version, &options), DR_OK);
    assert_int_equal(version, 1);
    assert_int_equal(options, 0);
    assert_int_equal(dr_register_parse(body, 3, &version, &options), DR_ESHORT);
    assert_int_equal(dr_register_parse(v_register_req + 23, 5, &version, &options),
                     DR_ELONG);
    uint8_t buf[8];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_register_write(&w, 1, 0);
    assert_int_equal(w.len, 4);
    assert_memory_equal(buf, body, 4);
}

static void test_rr_body(void **state)
{
    (void)state;
    uint32_t iface = 99;
    uint16_t timeout = 0;
    dr_cpf_t cpf;
    const uint8_t *body = v_send_rr + 24;
    assert_int_equal(dr_rr_parse(body, 24, &iface, &timeout, &cpf), DR_OK);
    assert_int_equal(iface, 0);
    assert_int_equal(timeout, 10);
    assert_int_equal(cpf.count, 2);
    assert_ptr_equal(cpf.item[1].data, body + 16);
    /* Shorter than handle + timeout; the CPF's own lengths still rule. */
    assert_int_equal(dr_rr_parse(body, 5, &iface, &timeout, &cpf), DR_ESHORT);
    assert_int_equal(dr_rr_parse(body, 6, &iface, &timeout, &cpf), DR_ESHORT);
    assert_int_equal(dr_rr_parse(body, 23, &iface, &timeout, &cpf), DR_ESHORT);

    uint8_t buf[8];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_rr_begin(&w, 10);
    assert_int_equal(w.len, 6);
    assert_memory_equal(buf, body, 6);
}

static void test_list_services(void **state)
{
    (void)state;
    /* One "Communications" item: type 0x0100, 20 bytes: version 1, flags
     * CIP over TCP (bit 5) + Class 0/1 over UDP (bit 8), 16-byte name. */
    const uint8_t want[] = {0x01, 0x00, 0x00, 0x01, 0x14, 0x00, 0x01, 0x00,
                            0x20, 0x01, 'C', 'o', 'm', 'm', 'u', 'n',
                            'i', 'c', 'a', 't', 'i', 'o', 'n', 's', 0x00, 0x00};
    uint8_t buf[64];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_list_services_write(&w, DR_SVC_FLAG_CIP_TCP | DR_SVC_FLAG_CLASS01_UDP);
    assert_false(w.overflow);
    assert_int_equal(w.len, sizeof want);
    assert_memory_equal(buf, want, sizeof want);
}

/* ---- CPF ------------------------------------------------------------------ */

static void test_cpf_items(void **state)
{
    (void)state;
    dr_cpf_t cpf;
    /* One item: a null address. */
    const uint8_t one[] = {0x01, 0x00, 0x00, 0x00, 0x00, 0x00};
    assert_int_equal(dr_cpf_parse(one, sizeof one, &cpf), DR_OK);
    assert_int_equal(cpf.count, 1);
    assert_int_equal(cpf.item[0].type, DR_CPF_NULL);
    assert_int_equal(cpf.item[0].length, 0);

    /* Zero items is a valid (empty) CPF. */
    const uint8_t none[] = {0x00, 0x00};
    assert_int_equal(dr_cpf_parse(none, sizeof none, &cpf), DR_OK);
    assert_int_equal(cpf.count, 0);
    assert_null(dr_cpf_find(&cpf, DR_CPF_NULL));

    /* Two items: UCMM (from the SendRRData vector). */
    assert_int_equal(dr_cpf_parse(v_send_rr + 30, sizeof v_send_rr - 30, &cpf), DR_OK);
    assert_int_equal(cpf.count, 2);
    assert_int_equal(cpf.item[1].type, DR_CPF_UNCONNECTED_DATA);
    assert_int_equal(cpf.item[1].length, 8);
    assert_ptr_equal(cpf.item[1].data, v_send_rr + 40);

    /* Three and four items: a Forward Open reply with socket addresses. */
    const uint8_t four[] = {
        0x04, 0x00,
        0x00, 0x00, 0x00, 0x00,
        0xB2, 0x00, 0x04, 0x00, 0xD4, 0x00, 0x00, 0x00,
        0x00, 0x80, 0x10, 0x00, SOCKADDR_BODY,
        0x01, 0x80, 0x10, 0x00, SOCKADDR_BODY};
    uint8_t three[sizeof four - 20];
    memcpy(three, four, sizeof three);
    three[0] = 3;
    assert_int_equal(dr_cpf_parse(three, sizeof three, &cpf), DR_OK);
    assert_int_equal(cpf.count, 3);
    assert_int_equal(cpf.item[2].type, DR_CPF_SOCKADDR_O2T);
    assert_null(dr_cpf_find(&cpf, DR_CPF_SOCKADDR_T2O));
    assert_int_equal(dr_cpf_parse(four, sizeof four, &cpf), DR_OK);
    assert_int_equal(cpf.count, 4);
    const dr_cpf_item_t *t2o = dr_cpf_find(&cpf, DR_CPF_SOCKADDR_T2O);
    assert_ptr_equal(t2o, &cpf.item[3]);
    assert_ptr_equal(t2o->data, four + sizeof four - 16);
    /* dr_cpf_find returns the first of a type. */
    assert_ptr_equal(dr_cpf_find(&cpf, DR_CPF_NULL), &cpf.item[0]);
}

static void test_cpf_lying_lengths(void **state)
{
    (void)state;
    dr_cpf_t cpf;
    assert_int_equal(dr_cpf_parse(NULL, 0, &cpf), DR_ESHORT);
    const uint8_t one_byte[] = {0x01};
    assert_int_equal(dr_cpf_parse(one_byte, 1, &cpf), DR_ESHORT);
    /* Item length 5, two bytes there. */
    const uint8_t beyond[] = {0x01, 0x00, 0xB2, 0x00, 0x05, 0x00, 0xAA, 0xBB};
    assert_int_equal(dr_cpf_parse(beyond, sizeof beyond, &cpf), DR_ESHORT);
    /* Item length 1, two bytes there: trailing garbage. */
    const uint8_t trailing[] = {0x01, 0x00, 0xB2, 0x00, 0x01, 0x00, 0xAA, 0xBB};
    assert_int_equal(dr_cpf_parse(trailing, sizeof trailing, &cpf), DR_ELONG);
    /* Count 2, one item present. */
    const uint8_t missing[] = {0x02, 0x00, 0x00, 0x00, 0x00, 0x00};
    assert_int_equal(dr_cpf_parse(missing, sizeof missing, &cpf), DR_ESHORT);
    /* Half an item header. */
    const uint8_t half[] = {0x01, 0x00, 0xB2, 0x00, 0x00};
    assert_int_equal(dr_cpf_parse(half, sizeof half, &cpf), DR_ESHORT);
    /* Five well-formed null items: more than we hold. */
    const uint8_t five[] = {0x05, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                            0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(dr_cpf_parse(five, sizeof five, &cpf), DR_EMALFORMED);
    const uint8_t huge[] = {0xFF, 0xFF};
    assert_int_equal(dr_cpf_parse(huge, sizeof huge, &cpf), DR_EMALFORMED);
}

/* Issue 10: an adapter refused a Forward Open (0x01/0x0106, ownership
 * conflict) in a SendRRData reply whose CPF declares 2 items but carries a
 * third, an echo of our 0x8001 item. Reconstructed from the issue's
 * description (the capture itself is not in the repository): replies are
 * parsed leniently (dr_cpf_parse_reply), so the CIP status survives;
 * requests stay strict (dr_cpf_parse, dr_rr_parse). */
static const uint8_t fo_refusal_trailing[] = {
    0x00, 0x00, 0x00, 0x00,             /* interface handle */
    0x00, 0x00,                         /* timeout */
    0x02, 0x00,                         /* item count: 2 */
    0x00, 0x00, 0x00, 0x00,             /* null address item */
    0xB2, 0x00, 0x10, 0x00,             /* unconnected data, 16 bytes: */
    0xD4, 0x00, 0x01, 0x01, 0x06, 0x01, /*   Forward Open reply, 0x01, 1 word: 0x0106 */
    0x34, 0x12, 0xFE, 0xFF,             /*   connection serial, originator vendor */
    0x78, 0x56, 0x34, 0x12,             /*   originator serial */
    0x00, 0x00,                         /*   remaining path size, reserved */
    0x01, 0x80, 0x10, 0x00,             /* undeclared: 0x8001, 16 bytes */
    0x00, 0x02, 0x08, 0xAE,             /*   AF_INET, port 2222 */
    0xC0, 0xA8, 0x01, 0x0A,             /*   192.168.1.10 */
    0, 0, 0, 0, 0, 0, 0, 0};

static void test_cpf_reply_trailing_item(void **state)
{
    (void)state;
    const uint8_t *b = fo_refusal_trailing;
    size_t len = sizeof fo_refusal_trailing, extra = 99;
    uint32_t iface;
    uint16_t timeout;
    dr_cpf_t cpf;
    /* strict: what we used to do with it */
    assert_int_equal(dr_rr_parse(b, len, &iface, &timeout, &cpf), DR_ELONG);
    assert_int_equal(dr_cpf_parse(b + 6, len - 6, &cpf), DR_ELONG);
    /* lenient: the two declared items, 20 bytes left out */
    assert_int_equal(dr_cpf_parse_reply(b + 6, len - 6, &cpf, &extra), DR_OK);
    assert_int_equal(cpf.count, 2);
    assert_int_equal(extra, 20);
    assert_null(dr_cpf_find(&cpf, DR_CPF_SOCKADDR_T2O));
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_UNCONNECTED_DATA);
    assert_non_null(it);
    dr_cip_rsp_t rsp;
    assert_int_equal(dr_cip_rsp_parse(it->data, it->length, &rsp), DR_OK);
    assert_int_equal(rsp.service, 0xD4);
    assert_int_equal(dr_cip_rsp_status(&rsp), DR_CIP(0x01, 0x0106));
    /* nothing after the items: extra 0 */
    assert_int_equal(dr_cpf_parse_reply(b + 6, len - 6 - 20, &cpf, &extra), DR_OK);
    assert_int_equal(extra, 0);
    /* every declared item is still length-checked */
    for (size_t cut = 0; cut < len - 6 - 20; cut++)
        assert_int_equal(dr_cpf_parse_reply(b + 6, cut, &cpf, &extra), DR_ESHORT);
    uint8_t lying[sizeof fo_refusal_trailing];
    memcpy(lying, b, len);
    lying[14] = 0x30; /* the 0xB2 item claims 48 bytes: 36 are there */
    assert_int_equal(dr_cpf_parse_reply(lying + 6, len - 6, &cpf, &extra), DR_ESHORT);
    const uint8_t five[] = {0x05, 0x00, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                            0, 0, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(dr_cpf_parse_reply(five, sizeof five, &cpf, &extra), DR_EMALFORMED);
}

static void test_cpf_sockaddr(void **state)
{
    (void)state;
    dr_cpf_t cpf;
    uint8_t wrapped[2 + sizeof v_sockaddr_t2o] = {0x01, 0x00};
    memcpy(wrapped + 2, v_sockaddr_t2o, sizeof v_sockaddr_t2o);
    assert_int_equal(dr_cpf_parse(wrapped, sizeof wrapped, &cpf), DR_OK);
    dr_sockaddr_t sa;
    assert_int_equal(dr_cpf_sockaddr_parse(&cpf.item[0], &sa), DR_OK);
    assert_int_equal(sa.port, 2222);
    assert_int_equal(sa.addr, 0xC0A8890Au); /* 192.168.137.10 */

    /* Built: the big-endian fields land where the vector has them. */
    uint8_t buf[32];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_sockaddr_t in = {0xC0A8890Au, 2222};
    dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, in);
    assert_false(w.overflow);
    assert_int_equal(w.len, sizeof v_sockaddr_t2o);
    assert_memory_equal(buf, v_sockaddr_t2o, sizeof v_sockaddr_t2o);

    /* Family in host (little-endian) order, as some stacks get wrong. */
    uint8_t bad[16] = {SOCKADDR_BODY};
    bad[0] = 0x02;
    bad[1] = 0x00;
    dr_cpf_item_t it = {DR_CPF_SOCKADDR_T2O, 16, bad};
    assert_int_equal(dr_cpf_sockaddr_parse(&it, &sa), DR_EMALFORMED);
    /* 15 and 17 bytes. */
    uint8_t good[17] = {SOCKADDR_BODY};
    it.data = good;
    it.length = 15;
    assert_int_equal(dr_cpf_sockaddr_parse(&it, &sa), DR_ESHORT);
    it.length = 17;
    assert_int_equal(dr_cpf_sockaddr_parse(&it, &sa), DR_ELONG);
    it.length = 0;
    it.data = NULL;
    assert_int_equal(dr_cpf_sockaddr_parse(&it, &sa), DR_ESHORT);
}

/* ---- bounded writer ------------------------------------------------------ */

static void test_writer(void **state)
{
    (void)state;
    uint8_t buf[8];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_wr_u16(&w, 0x1234);
    dr_wr_u16_be(&w, 0x1234);
    dr_wr_u32_be(&w, 0xA1B2C3D4u);
    const uint8_t want[] = {0x34, 0x12, 0x12, 0x34, 0xA1, 0xB2, 0xC3, 0xD4};
    assert_false(w.overflow);
    assert_memory_equal(buf, want, 8);
    /* Overflow is sticky: a later small put does not sneak in. */
    dr_wr_init(&w, buf, 5);
    dr_wr_u32(&w, 0x01020304u);
    dr_wr_u16(&w, 0xFFFF);
    assert_true(w.overflow);
    dr_wr_u8(&w, 0x55);
    assert_true(w.overflow);
    assert_int_equal(w.len, 4);
    assert_null(dr_wr_reserve(&w, 0));
    /* An item end after an overflow writes nothing through a stale mark. */
    memset(buf, 0xEE, sizeof buf);
    dr_wr_init(&w, buf, 3);
    size_t m = dr_cpf_item_begin(&w, DR_CPF_CONNECTED_DATA);
    dr_cpf_item_end(&w, m);
    assert_true(w.overflow);
    assert_int_equal(buf[2], 0xEE);
}

/* ---- EPATH ---------------------------------------------------------------- */

static void test_epath_8bit(void **state)
{
    (void)state;
    dr_epath_t ep;
    const uint8_t p[] = {0x20, 0x04, 0x24, 0x65, 0x30, 0x03};
    assert_int_equal(dr_epath_parse(p, sizeof p, &ep), DR_OK);
    assert_true(ep.has_cls && ep.has_inst && ep.has_attr);
    assert_int_equal(ep.cls, 4);
    assert_int_equal(ep.inst, 0x65);
    assert_int_equal(ep.attr, 3);
    assert_int_equal(ep.points, 0);
    assert_false(ep.has_key);
    assert_null(ep.data);

    const uint8_t cp[] = {CONN_PATH};
    assert_int_equal(dr_epath_parse(cp, sizeof cp, &ep), DR_OK);
    assert_int_equal(ep.inst, 1);
    assert_false(ep.has_attr);
    assert_int_equal(ep.points, 2);
    assert_int_equal(ep.point[0], 0x6B); /* O->T first */
    assert_int_equal(ep.point[1], 0x65);

    /* Empty path: nothing set, not an error here (the caller decides). */
    assert_int_equal(dr_epath_parse(p, 0, &ep), DR_OK);
    assert_false(ep.has_cls);
}

static void test_epath_16bit(void **state)
{
    (void)state;
    dr_epath_t ep;
    /* 16-bit logical segments: type|1, a pad byte, then little-endian. */
    const uint8_t p[] = {0x21, 0x00, 0x34, 0x12, 0x25, 0x00, 0x00, 0x03,
                         0x31, 0x00, 0x01, 0x01, 0x2D, 0x00, 0x2C, 0x01,
                         0x2C, 0x64};
    assert_int_equal(dr_epath_parse(p, sizeof p, &ep), DR_OK);
    assert_int_equal(ep.cls, 0x1234);
    assert_int_equal(ep.inst, 0x0300);
    assert_int_equal(ep.attr, 0x0101);
    assert_int_equal(ep.points, 2);
    assert_int_equal(ep.point[0], 300);
    assert_int_equal(ep.point[1], 100);

    /* The writer picks the width the value needs. */
    uint8_t buf[16];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_epath_write(&w, 0x1234, 0x300, 0x101);
    assert_int_equal(w.len, 12);
    assert_memory_equal(buf, p, 12);
    dr_wr_init(&w, buf, sizeof buf);
    dr_epath_write(&w, 4, 0x65, 3);
    const uint8_t p8[] = {0x20, 0x04, 0x24, 0x65, 0x30, 0x03};
    assert_int_equal(w.len, sizeof p8);
    assert_memory_equal(buf, p8, sizeof p8);
    dr_wr_init(&w, buf, sizeof buf);
    dr_epath_write(&w, 1, 0xFF, -1); /* 0xFF still fits 8 bits */
    const uint8_t p_noattr[] = {0x20, 0x01, 0x24, 0xFF};
    assert_int_equal(w.len, sizeof p_noattr);
    assert_memory_equal(buf, p_noattr, sizeof p_noattr);
    dr_wr_init(&w, buf, sizeof buf);
    dr_epath_write(&w, 4, 0x100, -1);
    const uint8_t p_256[] = {0x20, 0x04, 0x25, 0x00, 0x00, 0x01};
    assert_int_equal(w.len, sizeof p_256);
    assert_memory_equal(buf, p_256, sizeof p_256);

    /* Connection paths. */
    const uint8_t cp[] = {CONN_PATH};
    assert_int_equal(dr_conn_path_write(buf, sizeof buf, 1, 0x6B, 0x65), sizeof cp);
    assert_memory_equal(buf, cp, sizeof cp);
    const uint8_t cp16[] = {0x20, 0x04, 0x24, 0x01, 0x2D, 0x00, 0x2C, 0x01,
                            0x2C, 0x65};
    assert_int_equal(dr_conn_path_write(buf, sizeof buf, 1, 300, 0x65), sizeof cp16);
    assert_memory_equal(buf, cp16, sizeof cp16);
    assert_int_equal(dr_conn_path_write(buf, 7, 1, 0x6B, 0x65), 0);
}

/* dr_cip_path, the public form for applications: the same segments as
 * dr_epath_write, its length, and 0 when the buffer is too small. */
static void test_cip_path(void **state)
{
    (void)state;
    uint8_t buf[12];
    static const uint8_t asm8[] = {0x20, 0x04, 0x24, 0x65, 0x30, 0x03};
    assert_int_equal(dr_cip_path(buf, sizeof buf, DR_CIP_CLASS_ASSEMBLY, 101,
                                 DR_CIP_ASM_ATTR_DATA), sizeof asm8);
    assert_memory_equal(buf, asm8, sizeof asm8);
    static const uint8_t id16[] = {0x20, 0x01, 0x25, 0x00, 0x02, 0x01};
    assert_int_equal(dr_cip_path(buf, sizeof buf, DR_CIP_CLASS_IDENTITY, 0x0102, -1),
                     sizeof id16);
    assert_memory_equal(buf, id16, sizeof id16);
    assert_int_equal(dr_cip_path(buf, 5, DR_CIP_CLASS_ASSEMBLY, 101, DR_CIP_ASM_ATTR_DATA), 0);
}

static void test_epath_key_and_data(void **state)
{
    (void)state;
    dr_epath_t ep;
    /* Electronic key format 4: vendor 0xABCD, device type 0x0C, product 1,
     * major 1, minor 2; then the connection path; then a simple data
     * segment of one word (config data). */
    const uint8_t p[] = {0x34, 0x04, 0xCD, 0xAB, 0x0C, 0x00, 0x01, 0x00,
                         0x01, 0x02, CONN_PATH, 0x80, 0x01, 0xAA, 0xBB};
    assert_int_equal(dr_epath_parse(p, sizeof p, &ep), DR_OK);
    assert_true(ep.has_key);
    assert_int_equal(ep.cls, 4);
    assert_int_equal(ep.points, 2);
    assert_int_equal(ep.data_words, 1);
    assert_ptr_equal(ep.data, p + sizeof p - 2);

    /* A zero-word data segment. */
    const uint8_t p0[] = {0x20, 0x04, 0x80, 0x00};
    assert_int_equal(dr_epath_parse(p0, sizeof p0, &ep), DR_OK);
    assert_int_equal(ep.data_words, 0);
    assert_non_null(ep.data);
}

static void test_epath_errors(void **state)
{
    (void)state;
    dr_epath_t ep;
    const dr_status_t seg_err = DR_CIP(0x04, 0);
    /* Port segment, 32-bit logical, symbolic: not ours. */
    const uint8_t port[] = {0x01, 0x00};
    assert_int_equal(dr_epath_parse(port, sizeof port, &ep), seg_err);
    const uint8_t l32[] = {0x26, 0x00, 0x01, 0x00, 0x00, 0x00};
    assert_int_equal(dr_epath_parse(l32, sizeof l32, &ep), seg_err);
    const uint8_t sym[] = {0x91, 0x01, 'a', 0x00};
    assert_int_equal(dr_epath_parse(sym, sizeof sym, &ep), seg_err);
    /* Good segments, then an unknown one. */
    const uint8_t late[] = {0x20, 0x04, 0x24, 0x01, 0x00, 0x00};
    assert_int_equal(dr_epath_parse(late, sizeof late, &ep), seg_err);
    /* Key format other than 4. */
    const uint8_t key5[] = {0x34, 0x05, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(dr_epath_parse(key5, sizeof key5, &ep), seg_err);
    /* Three connection points. */
    const uint8_t pts3[] = {0x2C, 0x01, 0x2C, 0x02, 0x2C, 0x03};
    assert_int_equal(dr_epath_parse(pts3, sizeof pts3, &ep), seg_err);
    /* Data segment longer than the path. */
    const uint8_t data_long[] = {0x80, 0x02, 0xAA, 0xBB};
    assert_int_equal(dr_epath_parse(data_long, sizeof data_long, &ep), seg_err);
    /* The status code is a proper CIP band code (path segment error). */
    assert_true(DR_IS_CIP(seg_err));
    assert_int_equal(DR_CIP_GENERAL(seg_err), 0x04);
}

/* ---- Message Router ------------------------------------------------------- */

static void test_mr_request(void **state)
{
    (void)state;
    dr_cip_req_t req;
    /* Set_Attribute_Single of assembly 0x6B attribute 3 with 4 data bytes. */
    const uint8_t set[] = {0x10, 0x03, 0x20, 0x04, 0x24, 0x6B, 0x30, 0x03,
                           0x01, 0x02, 0x03, 0x04};
    assert_int_equal(dr_cip_req_parse(set, sizeof set, &req), DR_OK);
    assert_int_equal(req.service, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE);
    assert_ptr_equal(req.path, set + 2);
    assert_int_equal(req.path_len, 6);
    assert_ptr_equal(req.data, set + 8);
    assert_int_equal(req.data_len, 4);

    uint8_t buf[32];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_cip_req_write(&w, 0x10, set + 2, 6, set + 8, 4);
    assert_int_equal(w.len, sizeof set);
    assert_memory_equal(buf, set, sizeof set);

    /* An odd path gets a pad byte and a rounded-up word count. */
    const uint8_t odd_path[] = {0x20, 0x04, 0x24};
    dr_wr_init(&w, buf, sizeof buf);
    dr_cip_req_write(&w, 0x0E, odd_path, 3, NULL, 0);
    const uint8_t odd_want[] = {0x0E, 0x02, 0x20, 0x04, 0x24, 0x00};
    assert_int_equal(w.len, sizeof odd_want);
    assert_memory_equal(buf, odd_want, sizeof odd_want);

    /* Path longer than the frame; no path size at all. */
    const uint8_t lying[] = {0x0E, 0x04, 0x20, 0x04, 0x24, 0x65};
    assert_int_equal(dr_cip_req_parse(lying, sizeof lying, &req), DR_ESHORT);
    assert_int_equal(dr_cip_req_parse(lying, 1, &req), DR_ESHORT);
    assert_int_equal(dr_cip_req_parse(lying, 0, &req), DR_ESHORT);
    /* Empty path, no data: fine at this level. */
    const uint8_t bare[] = {0x01, 0x00};
    assert_int_equal(dr_cip_req_parse(bare, sizeof bare, &req), DR_OK);
    assert_int_equal(req.path_len, 0);
    assert_int_equal(req.data_len, 0);
}

static void test_mr_reply(void **state)
{
    (void)state;
    dr_cip_rsp_t rsp;
    /* Get_Attribute_Single success with 2 data bytes. */
    const uint8_t ok[] = {0x8E, 0x00, 0x00, 0x00, 0x24, 0x00};
    assert_int_equal(dr_cip_rsp_parse(ok, sizeof ok, &rsp), DR_OK);
    assert_int_equal(rsp.service, 0x8E);
    assert_int_equal(rsp.general, 0);
    assert_int_equal(rsp.ext_count, 0);
    assert_int_equal(rsp.data_len, 2);
    assert_ptr_equal(rsp.data, ok + 4);
    assert_int_equal(dr_cip_rsp_status(&rsp), DR_OK);

    /* Forward Open refused: general 0x01, one word 0x0100, then the
     * failure data (serials, remaining path size, reserved). */
    const uint8_t refused[] = {0xD4, 0x00, 0x01, 0x01, 0x00, 0x01, 0x42, 0x00,
                               0xCD, 0xAB, 0xEF, 0xBE, 0xAD, 0xDE, 0x00, 0x00};
    assert_int_equal(dr_cip_rsp_parse(refused, sizeof refused, &rsp), DR_OK);
    assert_int_equal(rsp.ext_count, 1);
    assert_int_equal(rsp.ext[0], 0x0100);
    assert_int_equal(dr_cip_rsp_status(&rsp), DR_CIP(0x01, 0x0100));
    assert_int_equal(rsp.data_len, 10);

    uint8_t buf[32];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    const uint16_t ext1[] = {0x0100};
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_OPEN, 0x01, ext1, 1, NULL, 0);
    dr_fwd_fail_write(&w, 0x0042, 0xABCD, 0xDEADBEEFu);
    assert_int_equal(w.len, sizeof refused);
    assert_memory_equal(buf, refused, sizeof refused);

    /* 0x0109 invalid size with the wanted size as the second word, and a
     * third word we keep count of but do not store. */
    const uint8_t three[] = {0xD4, 0x00, 0x01, 0x03, 0x09, 0x01, 0x12, 0x00,
                             0x77, 0x77, 0xAB};
    assert_int_equal(dr_cip_rsp_parse(three, sizeof three, &rsp), DR_OK);
    assert_int_equal(rsp.ext_count, 3);
    assert_int_equal(rsp.ext[0], 0x0109);
    assert_int_equal(rsp.ext[1], 18);
    assert_int_equal(rsp.data_len, 1);
    assert_ptr_equal(rsp.data, three + 10);
    assert_int_equal(dr_cip_rsp_status(&rsp), DR_CIP(0x01, 0x0109));

    /* General status without additional words. */
    const uint8_t gen_only[] = {0x8E, 0x00, 0x14, 0x00};
    assert_int_equal(dr_cip_rsp_parse(gen_only, sizeof gen_only, &rsp), DR_OK);
    assert_int_equal(dr_cip_rsp_status(&rsp), DR_CIP(0x14, 0));

    /* A request where a reply belongs; words promised but missing. */
    const uint8_t not_reply[] = {0x0E, 0x00, 0x00, 0x00};
    assert_int_equal(dr_cip_rsp_parse(not_reply, sizeof not_reply, &rsp), DR_EMALFORMED);
    const uint8_t missing[] = {0xD4, 0x00, 0x01, 0x02, 0x00, 0x01, 0x00};
    assert_int_equal(dr_cip_rsp_parse(missing, sizeof missing, &rsp), DR_ESHORT);
    assert_int_equal(dr_cip_rsp_parse(missing, 3, &rsp), DR_ESHORT);
}

/* ---- Unconnected Send ---------------------------------------------------- */

static void test_ucmm_send(void **state)
{
    (void)state;
    /* Set_Attribute_Single with one data byte: a 9-byte (odd) embedded
     * message, so a pad byte follows it; route: port 1, link 0. */
    const uint8_t msg[] = {0x10, 0x03, 0x20, 0x04, 0x24, 0x6B, 0x30, 0x03, 0x05};
    const uint8_t route[] = {0x01, 0x00};
    const uint8_t v[] = {0x0A, 0x05, 0x09, 0x00, 0x10, 0x03, 0x20, 0x04, 0x24,
                         0x6B, 0x30, 0x03, 0x05, 0x00, 0x01, 0x00, 0x01, 0x00};
    dr_ucmm_send_t u;
    assert_int_equal(dr_ucmm_send_parse(v, sizeof v, &u), DR_OK);
    assert_int_equal(u.priority_tick, 0x0A);
    assert_int_equal(u.timeout_ticks, 0x05);
    assert_int_equal(u.message_len, 9);
    assert_ptr_equal(u.message, v + 4);
    assert_int_equal(u.route_len, 2);
    assert_ptr_equal(u.route, v + 16);

    uint8_t buf[32];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_ucmm_send_write(&w, msg, sizeof msg, route, sizeof route);
    assert_int_equal(w.len, sizeof v);
    assert_memory_equal(buf, v, sizeof v);

    /* Even message: no pad. */
    const uint8_t even[] = {0x0A, 0x05, 0x06, 0x00, 0x01, 0x02, 0x20, 0x01,
                            0x24, 0x01, 0x01, 0x00, 0x01, 0x00};
    assert_int_equal(dr_ucmm_send_parse(even, sizeof even, &u), DR_OK);
    assert_int_equal(u.message_len, 6);
    assert_int_equal(u.route_len, 2);
    dr_wr_init(&w, buf, sizeof buf);
    dr_ucmm_send_write(&w, even + 4, 6, route, 2);
    assert_int_equal(w.len, sizeof even);
    assert_memory_equal(buf, even, sizeof even);

    /* The same odd message without its pad byte: the route lands one byte
     * early and the lengths no longer add up. */
    uint8_t nopad[sizeof v - 1];
    memcpy(nopad, v, 13);
    memcpy(nopad + 13, v + 14, 4);
    assert_int_not_equal(dr_ucmm_send_parse(nopad, sizeof nopad, &u), DR_OK);
    /* Message size beyond the data. */
    uint8_t big[sizeof v];
    memcpy(big, v, sizeof v);
    big[2] = 0x40;
    assert_int_equal(dr_ucmm_send_parse(big, sizeof big, &u), DR_ESHORT);
}

/* ---- Forward Open / Close ------------------------------------------------ */

static void test_netparams(void **state)
{
    (void)state;
    dr_netparams_t o2t = {18, DR_CONN_TYPE_P2P, 2, false, false};
    assert_int_equal(dr_netparams_encode(&o2t, false), 0x4812);
    assert_int_equal(dr_netparams_encode(&o2t, true), 0x48000012u);
    dr_netparams_t t2o = {38, DR_CONN_TYPE_MULTICAST, 1, false, false};
    assert_int_equal(dr_netparams_encode(&t2o, false), 0x2426);
    assert_int_equal(dr_netparams_encode(&t2o, true), 0x24000026u);

    /* The classic 0x43F4: point-to-point, low, variable, 500 bytes. */
    dr_netparams_t np = dr_netparams_decode(0x43F4, false);
    assert_int_equal(np.type, DR_CONN_TYPE_P2P);
    assert_int_equal(np.priority, 0);
    assert_true(np.variable);
    assert_false(np.redundant_owner);
    assert_int_equal(np.size, 500);
    /* Redundant owner, urgent, and a 32-bit size above 511. */
    np = dr_netparams_decode(0x8C00u | 0x1FF, false);
    assert_true(np.redundant_owner);
    assert_int_equal(np.priority, 3);
    assert_int_equal(np.type, 0);
    assert_int_equal(np.size, 511);
    np = dr_netparams_decode(0xC2000FA0u, true);
    assert_true(np.redundant_owner);
    assert_int_equal(np.type, DR_CONN_TYPE_P2P);
    assert_true(np.variable);
    assert_int_equal(np.size, 4000);
    assert_int_equal(dr_netparams_encode(&np, true), 0xC2000FA0u);
    /* Reserved bits (12 / 28, 16-24) are ignored on decode. */
    np = dr_netparams_decode(0x1000u | 0x4812, false);
    assert_int_equal(dr_netparams_encode(&np, false), 0x4812);
    np = dr_netparams_decode(0x11FF0000u | 0x48000012u, true);
    assert_int_equal(dr_netparams_encode(&np, true), 0x48000012u);
}

static dr_fwd_open_t fo_expected(bool large, const uint8_t *path)
{
    dr_fwd_open_t fo;
    memset(&fo, 0, sizeof fo);
    fo.large = large;
    fo.priority_tick = 0x0A;
    fo.timeout_ticks = 0x0E;
    fo.o2t_cid = 0;
    fo.t2o_cid = 0x12345678u;
    fo.conn_serial = 0x0042;
    fo.vendor = 0xABCD;
    fo.orig_serial = 0xDEADBEEFu;
    fo.timeout_mult = 2;
    fo.o2t_rpi_us = 10000;
    fo.t2o_rpi_us = 10000;
    fo.o2t = (dr_netparams_t){18, DR_CONN_TYPE_P2P, 2, false, false};
    fo.t2o = (dr_netparams_t){38, DR_CONN_TYPE_MULTICAST, 1, false, false};
    fo.transport = 0x01;
    fo.path = path;
    fo.path_len = 8;
    return fo;
}

static void check_fo(const dr_fwd_open_t *got, const dr_fwd_open_t *want)
{
    assert_int_equal(got->large, want->large);
    assert_int_equal(got->priority_tick, want->priority_tick);
    assert_int_equal(got->timeout_ticks, want->timeout_ticks);
    assert_int_equal(got->o2t_cid, want->o2t_cid);
    assert_int_equal(got->t2o_cid, want->t2o_cid);
    assert_int_equal(got->conn_serial, want->conn_serial);
    assert_int_equal(got->vendor, want->vendor);
    assert_int_equal(got->orig_serial, want->orig_serial);
    assert_int_equal(got->timeout_mult, want->timeout_mult);
    assert_int_equal(got->o2t_rpi_us, want->o2t_rpi_us);
    assert_int_equal(got->t2o_rpi_us, want->t2o_rpi_us);
    assert_int_equal(got->o2t.size, want->o2t.size);
    assert_int_equal(got->o2t.type, want->o2t.type);
    assert_int_equal(got->o2t.priority, want->o2t.priority);
    assert_int_equal(got->o2t.variable, want->o2t.variable);
    assert_int_equal(got->o2t.redundant_owner, want->o2t.redundant_owner);
    assert_int_equal(got->t2o.size, want->t2o.size);
    assert_int_equal(got->t2o.type, want->t2o.type);
    assert_int_equal(got->t2o.priority, want->t2o.priority);
    assert_int_equal(got->t2o.variable, want->t2o.variable);
    assert_int_equal(got->t2o.redundant_owner, want->t2o.redundant_owner);
    assert_int_equal(got->transport, want->transport);
    assert_int_equal(got->path_len, want->path_len);
    assert_memory_equal(got->path, want->path, want->path_len);
}

static void test_fwd_open_vectors(void **state)
{
    (void)state;
    const uint8_t cp[] = {CONN_PATH};
    for (int large = 0; large <= 1; large++) {
        const uint8_t *v = large ? v_fwd_open_large : v_fwd_open;
        size_t vlen = large ? sizeof v_fwd_open_large : sizeof v_fwd_open;
        dr_fwd_open_t want = fo_expected(large, cp);
        dr_fwd_open_t got;
        assert_int_equal(dr_fwd_open_parse(v, vlen, large, &got), DR_OK);
        check_fo(&got, &want);
        assert_ptr_equal(got.path, v + vlen - 8);

        uint8_t buf[64];
        dr_wr_t w;
        dr_wr_init(&w, buf, sizeof buf);
        dr_fwd_open_write(&w, &want);
        assert_false(w.overflow);
        assert_int_equal(w.len, vlen);
        assert_memory_equal(buf, v, vlen);

        /* Under the wrong service the body does not fit its lengths. */
        assert_int_not_equal(dr_fwd_open_parse(v, vlen, !large, &got), DR_OK);
    }
    assert_int_equal(sizeof v_fwd_open, 44);
    assert_int_equal(sizeof v_fwd_open_large, 48);
}

static void test_fwd_open_round_trip(void **state)
{
    (void)state;
    /* The path is opaque here; an odd length is written with a pad byte
     * and a rounded-up word count, and read back as the padded path. */
    const uint8_t path[] = {CONN_PATH, 0x99};
    for (int large = 0; large <= 1; large++) {
        dr_fwd_open_t fo = fo_expected(large, path);
        fo.o2t_cid = 0x01020304u;
        fo.o2t = (dr_netparams_t){large ? 4000 : 511, DR_CONN_TYPE_P2P, 3, true, true};
        fo.t2o = (dr_netparams_t){0, DR_CONN_TYPE_NULL, 0, false, false};
        fo.path_len = sizeof path;
        uint8_t buf[96];
        dr_wr_t w;
        dr_wr_init(&w, buf, sizeof buf);
        dr_fwd_open_write(&w, &fo);
        assert_false(w.overflow);
        assert_int_equal(w.len, (large ? 40u : 36u) + sizeof path + 1);
        assert_int_equal(buf[w.len - sizeof path - 2], 5); /* words */
        assert_int_equal(buf[w.len - 1], 0);                /* pad */

        dr_fwd_open_t got;
        assert_int_equal(dr_fwd_open_parse(buf, w.len, large, &got), DR_OK);
        fo.path_len = sizeof path + 1;
        fo.path = buf + w.len - fo.path_len;
        check_fo(&got, &fo);
        assert_memory_equal(got.path, path, sizeof path);
    }
}

static void test_fwd_open_reply(void **state)
{
    (void)state;
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(v_fwd_open_reply, sizeof v_fwd_open_reply, &r),
                     DR_OK);
    assert_int_equal(r.o2t_cid, 0x11223344u);
    assert_int_equal(r.t2o_cid, 0x12345678u);
    assert_int_equal(r.conn_serial, 0x42);
    assert_int_equal(r.vendor, 0xABCD);
    assert_int_equal(r.orig_serial, 0xDEADBEEFu);
    assert_int_equal(r.o2t_api_us, 10000);
    assert_int_equal(r.t2o_api_us, 20000);

    uint8_t buf[64];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_fwd_open_reply_write(&w, &r);
    assert_int_equal(w.len, sizeof v_fwd_open_reply);
    assert_memory_equal(buf, v_fwd_open_reply, sizeof v_fwd_open_reply);

    /* With one word of application reply. */
    uint8_t app[sizeof v_fwd_open_reply + 2];
    memcpy(app, v_fwd_open_reply, sizeof v_fwd_open_reply);
    app[24] = 1;
    app[26] = 0x55;
    app[27] = 0x66;
    assert_int_equal(dr_fwd_open_reply_parse(app, sizeof app, &r), DR_OK);
    assert_int_equal(dr_fwd_open_reply_parse(app, sizeof app - 1, &r), DR_ESHORT);
    app[24] = 0;
    assert_int_equal(dr_fwd_open_reply_parse(app, sizeof app, &r), DR_ELONG);
}

static void test_fwd_close(void **state)
{
    (void)state;
    dr_fwd_close_t fc;
    assert_int_equal(dr_fwd_close_parse(v_fwd_close, sizeof v_fwd_close, &fc), DR_OK);
    assert_int_equal(fc.priority_tick, 0x0A);
    assert_int_equal(fc.timeout_ticks, 0x0E);
    assert_int_equal(fc.conn_serial, 0x42);
    assert_int_equal(fc.vendor, 0xABCD);
    assert_int_equal(fc.orig_serial, 0xDEADBEEFu);
    assert_int_equal(fc.path_len, 8);
    assert_ptr_equal(fc.path, v_fwd_close + 12);

    uint8_t buf[32];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_fwd_close_write(&w, &fc);
    assert_int_equal(w.len, sizeof v_fwd_close);
    assert_memory_equal(buf, v_fwd_close, sizeof v_fwd_close);

    /* Odd path: padded on write. */
    fc.path_len = 3;
    dr_wr_init(&w, buf, sizeof buf);
    dr_fwd_close_write(&w, &fc);
    assert_int_equal(w.len, 16);
    assert_int_equal(buf[10], 2);
    assert_int_equal(buf[15], 0);

    /* The reply: serials, application reply size 0, reserved. */
    const uint8_t reply[] = {0xCE, 0x00, 0x00, 0x00, 0x42, 0x00, 0xCD, 0xAB,
                             0xEF, 0xBE, 0xAD, 0xDE, 0x00, 0x00};
    dr_wr_init(&w, buf, sizeof buf);
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_CLOSE, 0, NULL, 0, NULL, 0);
    dr_fwd_close_reply_write(&w, 0x42, 0xABCD, 0xDEADBEEFu);
    assert_int_equal(w.len, sizeof reply);
    assert_memory_equal(buf, reply, sizeof reply);
}

/* ---- Class 1 -------------------------------------------------------------- */

static void test_io_frames(void **state)
{
    (void)state;
    dr_io_frame_t f;
    assert_int_equal(dr_io_frame_parse(v_io_run_idle, sizeof v_io_run_idle, true, &f),
                     DR_OK);
    assert_int_equal(f.cid, 0x12345678u);
    assert_int_equal(f.encap_seq, 1);
    assert_int_equal(f.cip_seq, 5);
    assert_true(f.has_run_idle);
    assert_int_equal(f.run_idle, 1);
    assert_int_equal(f.data_len, 12);
    assert_ptr_equal(f.data, v_io_run_idle + 24);

    uint8_t buf[64];
    size_t n = 0;
    assert_int_equal(dr_io_frame_write(buf, sizeof buf, &f, &n), DR_OK);
    assert_int_equal(n, sizeof v_io_run_idle);
    assert_memory_equal(buf, v_io_run_idle, n);

    /* The same frame read as modeless: the header becomes data. */
    assert_int_equal(dr_io_frame_parse(v_io_run_idle, sizeof v_io_run_idle, false, &f),
                     DR_OK);
    assert_false(f.has_run_idle);
    assert_int_equal(f.data_len, 16);

    assert_int_equal(dr_io_frame_parse(v_io_plain, sizeof v_io_plain, false, &f), DR_OK);
    assert_int_equal(f.cid, 0x11223344u);
    assert_int_equal(f.encap_seq, 0xFFFFFFFFu);
    assert_int_equal(f.cip_seq, 7);
    assert_int_equal(f.data_len, 4);
    assert_int_equal(f.run_idle, 0);
    assert_int_equal(dr_io_frame_write(buf, sizeof buf, &f, &n), DR_OK);
    assert_int_equal(n, sizeof v_io_plain);
    assert_memory_equal(buf, v_io_plain, n);
    /* No room: refused, nothing promised. */
    n = 99;
    assert_int_equal(dr_io_frame_write(buf, sizeof v_io_plain - 1, &f, &n), DR_ENOSPACE);
    assert_int_equal(n, 99);
}

static void test_io_frame_errors(void **state)
{
    (void)state;
    dr_io_frame_t f;
    uint8_t b[sizeof v_io_plain];

    /* Items swapped. */
    const uint8_t swapped[] = {0x02, 0x00, 0xB1, 0x00, 0x02, 0x00, 0x07, 0x00,
                               0x02, 0x80, 0x08, 0x00, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(dr_io_frame_parse(swapped, sizeof swapped, false, &f), DR_EMALFORMED);
    /* Only the address item. */
    const uint8_t one[] = {0x01, 0x00, 0x02, 0x80, 0x08, 0x00, 0, 0, 0, 0, 0, 0, 0, 0};
    assert_int_equal(dr_io_frame_parse(one, sizeof one, false, &f), DR_EMALFORMED);
    /* Connected address (class 3) instead of sequenced address. */
    memcpy(b, v_io_plain, sizeof b);
    b[2] = 0xA1;
    b[3] = 0x00;
    assert_int_equal(dr_io_frame_parse(b, sizeof b, false, &f), DR_EMALFORMED);
    /* Sequenced address item of 4 bytes (the CPF itself is consistent). */
    const uint8_t addr4[] = {0x02, 0x00, 0x02, 0x80, 0x04, 0x00, 0, 0, 0, 0,
                             0xB1, 0x00, 0x02, 0x00, 0x07, 0x00};
    assert_int_equal(dr_io_frame_parse(addr4, sizeof addr4, false, &f), DR_ESHORT);
    /* Data item of 1 byte: no room for the sequence count. */
    const uint8_t data1[] = {0x02, 0x00, 0x02, 0x80, 0x08, 0x00, 0, 0, 0, 0, 0, 0, 0, 0,
                             0xB1, 0x00, 0x01, 0x00, 0x07};
    assert_int_equal(dr_io_frame_parse(data1, sizeof data1, false, &f), DR_ESHORT);
    /* A run/idle connection whose frame has only the sequence count + 2. */
    assert_int_equal(dr_io_frame_parse(v_io_plain, sizeof v_io_plain, false, &f), DR_OK);
    memcpy(b, v_io_plain, sizeof b);
    b[16] = 4;
    assert_int_equal(dr_io_frame_parse(b, sizeof b - 2, true, &f), DR_ESHORT);
    /* Run/idle header and nothing after it: zero data bytes is fine. */
    b[16] = 6;
    assert_int_equal(dr_io_frame_parse(b, sizeof b, true, &f), DR_OK);
    assert_int_equal(f.data_len, 0);
    assert_int_equal(f.run_idle, 0xEFBEADDEu);
}

static void test_sequence_compare(void **state)
{
    (void)state;
    assert_true(dr_seq16_newer(1, 0));
    assert_false(dr_seq16_newer(0, 1));
    assert_false(dr_seq16_newer(5, 5));
    assert_true(dr_seq16_newer(0, 0xFFFF)); /* wrap */
    assert_false(dr_seq16_newer(0xFFFF, 0));
    assert_true(dr_seq16_newer(0x7FFF, 0));
    /* Exactly half the space apart: neither is newer. */
    assert_false(dr_seq16_newer(0x8000, 0));
    assert_false(dr_seq16_newer(0, 0x8000));
    assert_false(dr_seq16_newer(0x1234, 0x9234));
    assert_false(dr_seq16_newer(0x9234, 0x1234));
    assert_true(dr_seq16_newer(0x8001, 0x0002));

    assert_true(dr_seq32_newer(0, 0xFFFFFFFFu));
    assert_false(dr_seq32_newer(0xFFFFFFFFu, 0));
    assert_false(dr_seq32_newer(7, 7));
    assert_false(dr_seq32_newer(0x80000000u, 0));
    assert_false(dr_seq32_newer(0, 0x80000000u));
    assert_true(dr_seq32_newer(0x80000000u, 0x7FFFFFFFu)); /* first >= 2^31 */
    assert_true(dr_seq32_newer(0x7FFFFFFFu, 0));
}

/* ---- Identity ------------------------------------------------------------- */

static void check_identity(const dr_identity_t *id)
{
    assert_int_equal(id->vendor, 0xABCD);
    assert_int_equal(id->device_type, 0x0C);
    assert_int_equal(id->product_code, 1);
    assert_int_equal(id->rev_major, 1);
    assert_int_equal(id->rev_minor, 2);
    assert_int_equal(id->status, 0x0030);
    assert_int_equal(id->serial, 0x11223344u);
    assert_string_equal(id->product_name, "drgate sim");
}

static void test_identity_all(void **state)
{
    (void)state;
    dr_identity_t id;
    assert_int_equal(dr_identity_parse_all(v_identity_all, sizeof v_identity_all, &id),
                     DR_OK);
    check_identity(&id);
    assert_int_equal(id.state, 0xFF);

    uint8_t buf[64];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_identity_write_all(&w, &id);
    assert_int_equal(w.len, sizeof v_identity_all);
    assert_memory_equal(buf, v_identity_all, sizeof v_identity_all);

    /* Attributes 8.. after the name are allowed and ignored. */
    memcpy(buf, v_identity_all, sizeof v_identity_all);
    buf[sizeof v_identity_all] = 0x03;
    assert_int_equal(dr_identity_parse_all(buf, sizeof v_identity_all + 1, &id), DR_OK);
    check_identity(&id);

    /* Truncated product name: the length says 10, five bytes follow. */
    assert_int_equal(dr_identity_parse_all(v_identity_all, sizeof v_identity_all - 5, &id),
                     DR_ESHORT);
    assert_string_equal(id.product_name, "");

    /* A 40-character name is cut to 32; control bytes become '?'. */
    uint8_t longname[15 + 40];
    memcpy(longname, v_identity_all, 14);
    longname[14] = 40;
    for (int i = 0; i < 40; i++)
        longname[15 + i] = (uint8_t)('A' + i % 26);
    longname[16] = 0x07;
    assert_int_equal(dr_identity_parse_all(longname, sizeof longname, &id), DR_OK);
    assert_int_equal(strlen(id.product_name), 32);
    assert_memory_equal(id.product_name, "A?CDEFGHIJKLMNOPQRSTUVWXYZABCDEF", 32);
    /* An empty name. */
    longname[14] = 0;
    assert_int_equal(dr_identity_parse_all(longname, 15, &id), DR_OK);
    assert_string_equal(id.product_name, "");
}

static void test_list_identity(void **state)
{
    (void)state;
    dr_identity_t id;
    assert_int_equal(dr_list_identity_parse(v_list_identity, sizeof v_list_identity, &id),
                     DR_OK);
    check_identity(&id);
    assert_int_equal(id.state, 3);
    assert_int_equal(id.sockaddr.port, DR_ENIP_TCP_PORT);
    assert_int_equal(id.sockaddr.addr, 0xC0A8890Au);

    uint8_t buf[96];
    dr_wr_t w;
    dr_wr_init(&w, buf, sizeof buf);
    dr_list_identity_write(&w, &id);
    assert_false(w.overflow);
    assert_int_equal(w.len, sizeof v_list_identity);
    assert_memory_equal(buf, v_list_identity, sizeof v_list_identity);

    /* Truncated product name: the SHORT_STRING claims 20 bytes, the item
     * (whose own length is honest) ends after 10 and the state. */
    uint8_t t[sizeof v_list_identity];
    memcpy(t, v_list_identity, sizeof t);
    t[8 + 16 + 14] = 20;
    assert_int_equal(dr_list_identity_parse(t, sizeof t, &id), DR_ESHORT);
    /* The state byte missing (item length adjusted to match). */
    memcpy(t, v_list_identity, sizeof t);
    t[4]--;
    assert_int_equal(dr_list_identity_parse(t, sizeof t - 1, &id), DR_ESHORT);
    /* One stray byte inside the item. */
    uint8_t x[sizeof v_list_identity + 1];
    memcpy(x, v_list_identity, sizeof v_list_identity);
    x[sizeof v_list_identity] = 0;
    x[4]++;
    assert_int_equal(dr_list_identity_parse(x, sizeof x, &id), DR_ELONG);
    /* An item after the declared one (count 1, a 0x8001 socket address
     * item follows): read as Forward Open replies are, the identity is
     * kept; a truncated trailing item is ignored too, a lying count is
     * not. */
    uint8_t tr[sizeof v_list_identity + 20];
    memcpy(tr, v_list_identity, sizeof v_list_identity);
    static const uint8_t sa[20] = {0x01, 0x80, 0x10, 0x00, 0x00, 0x02, 0x08, 0xAE,
                                   0x7F, 0x00, 0x00, 0x01};
    memcpy(tr + sizeof v_list_identity, sa, sizeof sa);
    memset(&id, 0, sizeof id);
    assert_int_equal(dr_list_identity_parse(tr, sizeof tr, &id), DR_OK);
    check_identity(&id);
    assert_int_equal(id.state, 3);
    assert_int_equal(id.sockaddr.addr, 0xC0A8890Au);
    assert_int_equal(dr_list_identity_parse(tr, sizeof tr - 7, &id), DR_OK);
    tr[0] = 2; /* says two items: the second is checked and short */
    assert_int_equal(dr_list_identity_parse(tr, sizeof tr - 7, &id), DR_ESHORT);
    assert_int_equal(dr_list_identity_parse(tr, sizeof tr, &id), DR_OK);
    /* No identity item at all. */
    const uint8_t other[] = {0x01, 0x00, 0x00, 0x00, 0x00, 0x00};
    assert_int_equal(dr_list_identity_parse(other, sizeof other, &id), DR_EMALFORMED);
    /* An empty reply (no device answered with an item). */
    const uint8_t empty[] = {0x00, 0x00};
    assert_int_equal(dr_list_identity_parse(empty, sizeof empty, &id), DR_EMALFORMED);
}

/* ---- builders that cannot express a length -------------------------------- */

static void test_writer_length_limits(void **state)
{
    (void)state;
    /* A path of 256 words or a message of 64 KiB cannot be described by
     * the size fields; the writer must say so rather than wrap the count. */
    static uint8_t big[0x10001];
    static uint8_t out[0x10100];
    dr_wr_t w;
    dr_wr_init(&w, out, sizeof out);
    dr_cip_req_write(&w, 0x0E, big, 510, NULL, 0);
    assert_false(w.overflow);
    assert_int_equal(out[1], 255);
    dr_wr_init(&w, out, sizeof out);
    dr_cip_req_write(&w, 0x0E, big, 511, NULL, 0);
    assert_true(w.overflow);

    dr_wr_init(&w, out, sizeof out);
    dr_ucmm_send_write(&w, big, 0x10000, big, 2);
    assert_true(w.overflow);
    dr_wr_init(&w, out, sizeof out);
    dr_ucmm_send_write(&w, big, 2, big, 512);
    assert_true(w.overflow);

    dr_fwd_close_t fc = {0x0A, 0x0E, 1, 2, 3, big, 512};
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_close_write(&w, &fc);
    assert_true(w.overflow);

    dr_fwd_open_t fo = fo_expected(false, big);
    fo.path_len = 600;
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_open_write(&w, &fo);
    assert_true(w.overflow);
    /* A 16-bit connection size cannot carry 512 bytes. */
    fo = fo_expected(false, big);
    fo.o2t.size = 512;
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_open_write(&w, &fo);
    assert_true(w.overflow);
    fo.large = true;
    dr_wr_init(&w, out, sizeof out);
    dr_fwd_open_write(&w, &fo);
    assert_false(w.overflow);

    /* A CPF item longer than 65535 bytes. */
    dr_wr_init(&w, out, sizeof out);
    size_t m = dr_cpf_item_begin(&w, DR_CPF_CONNECTED_DATA);
    dr_wr_bytes(&w, big, 0x10000);
    dr_cpf_item_end(&w, m);
    assert_true(w.overflow);
}

/* ---- every truncation, every extension ------------------------------------ */

typedef dr_status_t (*parse_fn)(const uint8_t *buf, size_t len);

static dr_status_t p_encap(const uint8_t *b, size_t n)
{
    dr_encap_t h;
    const uint8_t *body;
    return dr_encap_parse(b, n, &h, &body);
}

/* SendRRData end to end: header, CPF, MR request, path. */
static dr_status_t p_send_rr(const uint8_t *b, size_t n)
{
    dr_encap_t h;
    const uint8_t *body;
    dr_status_t st = dr_encap_parse(b, n, &h, &body);
    if (st != DR_OK)
        return st;
    if (h.length < 6)
        return DR_ESHORT;
    dr_cpf_t cpf;
    if ((st = dr_cpf_parse(body + 6, h.length - 6u, &cpf)) != DR_OK)
        return st;
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_UNCONNECTED_DATA);
    if (it == NULL)
        return DR_EMALFORMED;
    dr_cip_req_t req;
    if ((st = dr_cip_req_parse(it->data, it->length, &req)) != DR_OK)
        return st;
    dr_epath_t ep;
    return dr_epath_parse(req.path, req.path_len, &ep);
}

static dr_status_t p_register(const uint8_t *b, size_t n)
{
    uint16_t v, o;
    return dr_register_parse(b, n, &v, &o);
}

static dr_status_t p_rr(const uint8_t *b, size_t n)
{
    uint32_t iface;
    uint16_t timeout;
    dr_cpf_t cpf;
    return dr_rr_parse(b, n, &iface, &timeout, &cpf);
}

static dr_status_t p_cpf(const uint8_t *b, size_t n)
{
    dr_cpf_t cpf;
    return dr_cpf_parse(b, n, &cpf);
}

static dr_status_t p_sockaddr(const uint8_t *b, size_t n)
{
    dr_cpf_t cpf;
    dr_status_t st = dr_cpf_parse(b, n, &cpf);
    if (st != DR_OK)
        return st;
    dr_sockaddr_t sa;
    return dr_cpf_sockaddr_parse(&cpf.item[0], &sa);
}

static dr_status_t p_req(const uint8_t *b, size_t n)
{
    dr_cip_req_t r;
    return dr_cip_req_parse(b, n, &r);
}

static dr_status_t p_rsp(const uint8_t *b, size_t n)
{
    dr_cip_rsp_t r;
    return dr_cip_rsp_parse(b, n, &r);
}

static dr_status_t p_ucmm(const uint8_t *b, size_t n)
{
    dr_ucmm_send_t u;
    return dr_ucmm_send_parse(b, n, &u);
}

static dr_status_t p_fo(const uint8_t *b, size_t n)
{
    dr_fwd_open_t f;
    return dr_fwd_open_parse(b, n, false, &f);
}

static dr_status_t p_fo_large(const uint8_t *b, size_t n)
{
    dr_fwd_open_t f;
    return dr_fwd_open_parse(b, n, true, &f);
}

static dr_status_t p_fo_reply(const uint8_t *b, size_t n)
{
    dr_fwd_open_reply_t r;
    return dr_fwd_open_reply_parse(b, n, &r);
}

static dr_status_t p_fc(const uint8_t *b, size_t n)
{
    dr_fwd_close_t f;
    return dr_fwd_close_parse(b, n, &f);
}

static dr_status_t p_io_ri(const uint8_t *b, size_t n)
{
    dr_io_frame_t f;
    return dr_io_frame_parse(b, n, true, &f);
}

static dr_status_t p_io_plain(const uint8_t *b, size_t n)
{
    dr_io_frame_t f;
    return dr_io_frame_parse(b, n, false, &f);
}

static dr_status_t p_id_all(const uint8_t *b, size_t n)
{
    dr_identity_t id;
    return dr_identity_parse_all(b, n, &id);
}

static dr_status_t p_list_id(const uint8_t *b, size_t n)
{
    dr_identity_t id;
    return dr_list_identity_parse(b, n, &id);
}

static dr_status_t p_epath(const uint8_t *b, size_t n)
{
    dr_epath_t ep;
    return dr_epath_parse(b, n, &ep);
}

/* Run fn over an exactly-sized heap copy of src[0..n) (plus one 0x00 if
 * `extra`), so that ASan sees any read past the end. */
static dr_status_t run_exact(parse_fn fn, const uint8_t *src, size_t n, bool extra)
{
    size_t m = n + (extra ? 1u : 0u);
    uint8_t *copy = malloc(m > 0 ? m : 1u); /* never malloc(0) */
    assert_non_null(copy);
    if (n > 0)
        memcpy(copy, src, n);
    if (extra)
        copy[n] = 0x00;
    dr_status_t st = fn(copy, m);
    free(copy);
    return st;
}

typedef struct {
    const char *name;
    parse_fn fn;
    const uint8_t *buf;
    size_t len;
    size_t need; /* every prefix shorter than this must fail */
    bool exact;  /* one byte more must fail too */
} frame_case_t;

static void test_every_truncation(void **state)
{
    (void)state;
    static const uint8_t get_req[] = {0x0E, 0x03, 0x20, 0x04, 0x24, 0x65, 0x30, 0x03};
    static const uint8_t err_rsp[] = {0xD4, 0x00, 0x01, 0x02, 0x09, 0x01, 0x12, 0x00};
    static const uint8_t ucmm[] = {0x0A, 0x05, 0x09, 0x00, 0x10, 0x03, 0x20, 0x04, 0x24,
                                   0x6B, 0x30, 0x03, 0x05, 0x00, 0x01, 0x00, 0x01, 0x00};
    static const uint8_t cpf4[] = {
        0x04, 0x00, 0x00, 0x00, 0x00, 0x00,
        0xB2, 0x00, 0x04, 0x00, 0xD4, 0x00, 0x00, 0x00,
        0x00, 0x80, 0x10, 0x00, SOCKADDR_BODY,
        0x01, 0x80, 0x10, 0x00, SOCKADDR_BODY};
    static uint8_t sock[2 + sizeof v_sockaddr_t2o] = {0x01, 0x00};
    memcpy(sock + 2, v_sockaddr_t2o, sizeof v_sockaddr_t2o);

    /* Frames made by the builders join the hand-written ones. */
    static uint8_t built_fo[96], built_li[96], built_io[64];
    const uint8_t path[] = {0x34, 0x04, 0xCD, 0xAB, 0x0C, 0x00, 0x01, 0x00,
                            0x01, 0x02, CONN_PATH, 0x80, 0x01, 0xAA, 0xBB};
    dr_fwd_open_t fo = fo_expected(true, path);
    fo.path_len = sizeof path;
    dr_wr_t w;
    dr_wr_init(&w, built_fo, sizeof built_fo);
    dr_fwd_open_write(&w, &fo);
    size_t built_fo_len = w.len;
    dr_identity_t id;
    memset(&id, 0, sizeof id);
    strcpy(id.product_name, "Doosan cobot gateway test name!!");
    id.sockaddr.port = 44818;
    dr_wr_init(&w, built_li, sizeof built_li);
    dr_list_identity_write(&w, &id);
    size_t built_li_len = w.len;
    const uint8_t data[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    dr_io_frame_t f = {1, 2, 3, data, sizeof data, 1, true};
    size_t built_io_len = 0;
    assert_int_equal(dr_io_frame_write(built_io, sizeof built_io, &f, &built_io_len), DR_OK);

    const frame_case_t cases[] = {
        {"register", p_encap, v_register_req, sizeof v_register_req, sizeof v_register_req, true},
        {"send_rr", p_send_rr, v_send_rr, sizeof v_send_rr, sizeof v_send_rr, true},
        {"register_body", p_register, v_register_req + 24, 4, 4, true},
        {"rr_body", p_rr, v_send_rr + 24, 24, 24, true},
        {"cpf4", p_cpf, cpf4, sizeof cpf4, sizeof cpf4, true},
        {"sockaddr", p_sockaddr, sock, sizeof sock, sizeof sock, true},
        {"mr_req", p_req, get_req, sizeof get_req, sizeof get_req, false},
        {"mr_rsp", p_rsp, err_rsp, sizeof err_rsp, sizeof err_rsp, false},
        {"ucmm", p_ucmm, ucmm, sizeof ucmm, sizeof ucmm, true},
        {"fwd_open", p_fo, v_fwd_open, sizeof v_fwd_open, sizeof v_fwd_open, true},
        {"fwd_open_large", p_fo_large, v_fwd_open_large, sizeof v_fwd_open_large,
         sizeof v_fwd_open_large, true},
        {"fwd_open_built", p_fo_large, built_fo, built_fo_len, built_fo_len, true},
        {"fwd_open_reply", p_fo_reply, v_fwd_open_reply, sizeof v_fwd_open_reply,
         sizeof v_fwd_open_reply, true},
        {"fwd_close", p_fc, v_fwd_close, sizeof v_fwd_close, sizeof v_fwd_close, true},
        {"io_run_idle", p_io_ri, v_io_run_idle, sizeof v_io_run_idle,
         sizeof v_io_run_idle, true},
        {"io_plain", p_io_plain, v_io_plain, sizeof v_io_plain, sizeof v_io_plain, true},
        {"io_built", p_io_ri, built_io, built_io_len, built_io_len, true},
        {"identity_all", p_id_all, v_identity_all, sizeof v_identity_all,
         sizeof v_identity_all, false},
        /* a reply: bytes after the declared items are ignored (see
         * test_list_identity), so one more is no error */
        {"list_identity", p_list_id, v_list_identity, sizeof v_list_identity,
         sizeof v_list_identity, false},
        {"list_identity_built", p_list_id, built_li, built_li_len, built_li_len, false},
    };
    for (size_t c = 0; c < N(cases); c++) {
        const frame_case_t *k = &cases[c];
        if (run_exact(k->fn, k->buf, k->len, false) != DR_OK)
            fail_msg("%s: the valid frame does not parse", k->name);
        for (size_t n = 0; n < k->need; n++)
            if (run_exact(k->fn, k->buf, n, false) == DR_OK)
                fail_msg("%s: prefix of %zu of %zu bytes accepted", k->name, n, k->len);
        if (k->exact && run_exact(k->fn, k->buf, k->len, true) == DR_OK)
            fail_msg("%s: one byte too many accepted", k->name);
    }

    /* An EPATH may end after any whole segment; inside one it must not. */
    const size_t cuts[] = {0, 10, 12, 14, 16, 18, 22};
    size_t ci = 0;
    for (size_t n = 0; n <= sizeof path; n++) {
        bool boundary = ci < N(cuts) && cuts[ci] == n;
        dr_status_t st = run_exact(p_epath, path, n, false);
        if (boundary) {
            ci++;
            if (st != DR_OK)
                fail_msg("epath: whole-segment prefix of %zu rejected", n);
        } else if (st != DR_CIP(0x04, 0)) {
            fail_msg("epath: mid-segment prefix of %zu accepted", n);
        }
    }
    assert_int_equal(ci, N(cuts));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_encap_register_session),
        cmocka_unit_test(test_cip_path),
        cmocka_unit_test(test_encap_status_and_body),
        cmocka_unit_test(test_encap_write_errors),
        cmocka_unit_test(test_encap_frame_len),
        cmocka_unit_test(test_encap_parse_lengths),
        cmocka_unit_test(test_register_body),
        cmocka_unit_test(test_rr_body),
        cmocka_unit_test(test_list_services),
        cmocka_unit_test(test_cpf_items),
        cmocka_unit_test(test_cpf_lying_lengths),
        cmocka_unit_test(test_cpf_reply_trailing_item),
        cmocka_unit_test(test_cpf_sockaddr),
        cmocka_unit_test(test_writer),
        cmocka_unit_test(test_epath_8bit),
        cmocka_unit_test(test_epath_16bit),
        cmocka_unit_test(test_epath_key_and_data),
        cmocka_unit_test(test_epath_errors),
        cmocka_unit_test(test_mr_request),
        cmocka_unit_test(test_mr_reply),
        cmocka_unit_test(test_ucmm_send),
        cmocka_unit_test(test_netparams),
        cmocka_unit_test(test_fwd_open_vectors),
        cmocka_unit_test(test_fwd_open_round_trip),
        cmocka_unit_test(test_fwd_open_reply),
        cmocka_unit_test(test_fwd_close),
        cmocka_unit_test(test_io_frames),
        cmocka_unit_test(test_io_frame_errors),
        cmocka_unit_test(test_sequence_compare),
        cmocka_unit_test(test_identity_all),
        cmocka_unit_test(test_list_identity),
        cmocka_unit_test(test_writer_length_limits),
        cmocka_unit_test(test_every_truncation),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
