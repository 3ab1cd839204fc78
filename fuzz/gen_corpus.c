/* SPDX-License-Identifier: MIT */
/*
 * Writes the seed corpora under DIR/<target>/ (default fuzz/corpus) from
 * frames the library's own builders make, so the seeds follow the code:
 * `make fuzz-corpus` reruns it; the output is committed. Deterministic:
 * the same library gives the same files.
 */
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cip_internal.h"
#include "drgate/codec.h"
#include "drgate/text.h"

static const char *root = "fuzz/corpus";
static int failed;

static void mkdir_p(const char *path)
{
    if (mkdir(path, 0777) != 0 && errno != EEXIST) {
        perror(path);
        exit(1);
    }
}

static void put(const char *target, const char *name, const uint8_t *buf, size_t len)
{
    char path[512];
    snprintf(path, sizeof path, "%s/%s", root, target);
    mkdir_p(path);
    snprintf(path, sizeof path, "%s/%s/%s", root, target, name);
    FILE *f = fopen(path, "wb");
    if (f == NULL || (len > 0 && fwrite(buf, 1, len, f) != len) || fclose(f) != 0) {
        perror(path);
        exit(1);
    }
}

static void put_w(const char *target, const char *name, const dr_wr_t *w)
{
    if (w->overflow) {
        fprintf(stderr, "gen_corpus: %s/%s did not fit\n", target, name);
        failed = 1;
        return;
    }
    put(target, name, w->buf, w->len);
}

static const uint8_t ctx[8] = {'d', 'r', 'g', 'a', 't', 'e', 0, 1};
static const uint8_t asm_path[] = {0x20, 0x04, 0x24, 0x65, 0x30, 0x03};
static const uint8_t cm_path[] = {0x20, 0x06, 0x24, 0x01};
static const uint8_t route[] = {0x01, 0x00};

static dr_identity_t identity(void)
{
    dr_identity_t id;
    memset(&id, 0, sizeof id);
    id.vendor = 0xABCD;
    id.device_type = 0x0C;
    id.product_code = 1;
    id.rev_major = 1;
    id.rev_minor = 2;
    id.status = 0x0030;
    id.serial = 0x11223344u;
    strcpy(id.product_name, "drgate sim");
    id.state = 3;
    id.sockaddr.addr = 0xC0A8890Au;
    id.sockaddr.port = DR_ENIP_TCP_PORT;
    return id;
}

static dr_fwd_open_t fwd_open(bool large, const uint8_t *path, size_t path_len)
{
    dr_fwd_open_t fo;
    memset(&fo, 0, sizeof fo);
    fo.large = large;
    fo.priority_tick = 0x0A;
    fo.timeout_ticks = 0x0E;
    fo.t2o_cid = 0x12345678u;
    fo.conn_serial = 0x42;
    fo.vendor = 0xABCD;
    fo.orig_serial = 0xDEADBEEFu;
    fo.timeout_mult = 2;
    fo.o2t_rpi_us = fo.t2o_rpi_us = 10000;
    fo.o2t = (dr_netparams_t){18, DR_CONN_TYPE_P2P, 2, false, false};
    fo.t2o = (dr_netparams_t){38, DR_CONN_TYPE_MULTICAST, 1, large, false};
    fo.transport = 0x01;
    fo.path = path;
    fo.path_len = path_len;
    return fo;
}

/* An encapsulated frame: header + body written by `body` into w. */
static void encap(const char *name, uint16_t cmd, uint32_t session,
                  const uint8_t *body, size_t body_len)
{
    uint8_t buf[DR_ENCAP_MAX_LEN];
    dr_encap_t h = {cmd, 0, session, 0, {0}, 0};
    memcpy(h.context, ctx, 8);
    if (body_len > 0) /* memcpy from NULL is undefined even for 0 bytes */
        memcpy(buf + DR_ENCAP_HEADER_LEN, body, body_len);
    if (dr_encap_write(buf, sizeof buf, &h, body_len) != DR_OK) {
        failed = 1;
        return;
    }
    put("encap", name, buf, DR_ENCAP_HEADER_LEN + body_len);
}

static void gen_encap(void)
{
    uint8_t b[512], conn[32];
    dr_wr_t w;
    const uint8_t reg[] = {0x01, 0x00, 0x00, 0x00};
    encap("register_session", DR_ENCAP_REGISTER_SESSION, 0, reg, sizeof reg);
    encap("unregister_session", DR_ENCAP_UNREGISTER_SESSION, 0x11223344u, NULL, 0);
    encap("list_identity_req", DR_ENCAP_LIST_IDENTITY, 0, NULL, 0);

    /* SendRRData, UCMM Get_Attribute_Single. */
    dr_wr_init(&w, b, sizeof b);
    dr_wr_u32(&w, 0);
    dr_wr_u16(&w, 10);
    dr_cpf_begin(&w, 2);
    dr_cpf_item_end(&w, dr_cpf_item_begin(&w, DR_CPF_NULL));
    size_t m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path,
                     NULL, 0);
    dr_cpf_item_end(&w, m);
    encap("send_rr_get_attr", DR_ENCAP_SEND_RR_DATA, 0x11223344u, b, w.len);

    /* SendRRData, Forward Open. */
    size_t cl = dr_conn_path_write(conn, sizeof conn, 1, 0x6B, 0x65);
    dr_fwd_open_t fo = fwd_open(false, conn, cl);
    dr_wr_init(&w, b, sizeof b);
    dr_wr_u32(&w, 0);
    dr_wr_u16(&w, 10);
    dr_cpf_begin(&w, 2);
    dr_cpf_item_end(&w, dr_cpf_item_begin(&w, DR_CPF_NULL));
    m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_cip_req_write(&w, DR_CIP_SVC_FORWARD_OPEN, cm_path, sizeof cm_path, NULL, 0);
    dr_fwd_open_write(&w, &fo);
    dr_cpf_item_end(&w, m);
    encap("send_rr_fwd_open", DR_ENCAP_SEND_RR_DATA, 0x11223344u, b, w.len);

    /* Forward Open reply with both socket address items: four items. */
    dr_wr_init(&w, b, sizeof b);
    dr_wr_u32(&w, 0);
    dr_wr_u16(&w, 0);
    dr_cpf_begin(&w, 4);
    dr_cpf_item_end(&w, dr_cpf_item_begin(&w, DR_CPF_NULL));
    m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_OPEN, 0, NULL, 0, NULL, 0);
    dr_fwd_open_reply_t r = {0x11223344u, 0x12345678u, 0x42, 0xABCD, 0xDEADBEEFu,
                             10000, 20000};
    dr_fwd_open_reply_write(&w, &r);
    dr_cpf_item_end(&w, m);
    dr_sockaddr_t sa = {0xC0A8890Au, DR_ENIP_UDP_PORT};
    dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_O2T, sa);
    dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, sa);
    encap("send_rr_fwd_open_reply", DR_ENCAP_SEND_RR_DATA, 0x11223344u, b, w.len);

    /* SendUnitData, class 3. */
    dr_wr_init(&w, b, sizeof b);
    dr_wr_u32(&w, 0);
    dr_wr_u16(&w, 0);
    dr_cpf_begin(&w, 2);
    m = dr_cpf_item_begin(&w, DR_CPF_CONNECTED_ADDRESS);
    dr_wr_u32(&w, 0x11223344u);
    dr_cpf_item_end(&w, m);
    m = dr_cpf_item_begin(&w, DR_CPF_CONNECTED_DATA);
    dr_wr_u16(&w, 1);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path,
                     NULL, 0);
    dr_cpf_item_end(&w, m);
    encap("send_unit_data", DR_ENCAP_SEND_UNIT_DATA, 0x11223344u, b, w.len);

    /* ListIdentity reply. */
    dr_identity_t id = identity();
    dr_wr_init(&w, b, sizeof b);
    dr_list_identity_write(&w, &id);
    encap("list_identity_reply", DR_ENCAP_LIST_IDENTITY, 0, b, w.len);

    /* Bare command bodies, for dr_register_parse and dr_rr_parse. */
    dr_wr_init(&w, b, sizeof b);
    dr_register_write(&w, 1, 0);
    put_w("encap", "body_register", &w);
    dr_wr_init(&w, b, sizeof b);
    dr_rr_begin(&w, 10);
    dr_cpf_begin(&w, 2);
    dr_cpf_item_end(&w, dr_cpf_item_begin(&w, DR_CPF_NULL));
    m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path,
                     NULL, 0);
    dr_cpf_item_end(&w, m);
    put_w("encap", "body_send_rr", &w);

    /* ListServices reply. */
    dr_wr_init(&w, b, sizeof b);
    dr_list_services_write(&w, DR_SVC_FLAG_CIP_TCP | DR_SVC_FLAG_CLASS01_UDP);
    encap("list_services_reply", DR_ENCAP_LIST_SERVICES, 0, b, w.len);

    /* A bare CPF with a socket address (as the encapsulation body sees it). */
    dr_wr_init(&w, b, sizeof b);
    dr_cpf_begin(&w, 1);
    dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, sa);
    put_w("encap", "cpf_sockaddr", &w);
}

static void gen_cip_reply(void)
{
    uint8_t b[512];
    dr_wr_t w;
    const uint8_t two[] = {0x24, 0x00};
    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 0, NULL, 0, two, sizeof two);
    put_w("cip_reply", "get_attr_ok", &w);

    const uint16_t ext1[] = {0x0100};
    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_OPEN, 0x01, ext1, 1, NULL, 0);
    dr_fwd_fail_write(&w, 0x42, 0xABCD, 0xDEADBEEFu);
    put_w("cip_reply", "fwd_open_refused", &w);

    const uint16_t ext2[] = {0x0109, 18};
    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_OPEN, 0x01, ext2, 2, NULL, 0);
    dr_fwd_fail_write(&w, 0x42, 0xABCD, 0xDEADBEEFu);
    put_w("cip_reply", "fwd_open_bad_size", &w);

    dr_fwd_open_reply_t r = {0x11223344u, 0x12345678u, 0x42, 0xABCD, 0xDEADBEEFu,
                             10000, 20000};
    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_OPEN, 0, NULL, 0, NULL, 0);
    dr_fwd_open_reply_write(&w, &r);
    put_w("cip_reply", "fwd_open_reply", &w);
    dr_wr_init(&w, b, sizeof b);
    dr_fwd_open_reply_write(&w, &r);
    put_w("cip_reply", "fwd_open_reply_data", &w);

    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_FORWARD_CLOSE, 0, NULL, 0, NULL, 0);
    dr_fwd_close_reply_write(&w, 0x42, 0xABCD, 0xDEADBEEFu);
    put_w("cip_reply", "fwd_close_reply", &w);

    dr_identity_t id = identity();
    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_GET_ATTRIBUTES_ALL, 0, NULL, 0, NULL, 0);
    dr_identity_write_all(&w, &id);
    dr_wr_u8(&w, 3); /* attribute 8, state */
    put_w("cip_reply", "identity_all", &w);

    dr_wr_init(&w, b, sizeof b);
    dr_list_identity_write(&w, &id);
    put_w("cip_reply", "list_identity", &w);
    /* the same with an item its count leaves out (read leniently) */
    dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, (dr_sockaddr_t){0x7F000001u, 2222});
    put_w("cip_reply", "list_identity_trailing", &w);

    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 0x0E, NULL, 0, NULL, 0);
    put_w("cip_reply", "not_settable", &w);
}

/* The link's Identity read (fuzz_identity): the status byte (0: answered),
 * then the reply's data: a whole Identity with attribute 8, one cut in its
 * name, one refused. */
static void gen_identity(void)
{
    uint8_t b[128];
    dr_wr_t w;
    dr_identity_t id = identity();
    dr_wr_init(&w, b, sizeof b);
    dr_wr_u8(&w, 0);
    dr_identity_write_all(&w, &id);
    dr_wr_u8(&w, 3); /* attribute 8, state */
    put_w("identity", "identity_all", &w);
    put("identity", "name_cut", b, 1 + 15 + 3);
    put("identity", "refused", (const uint8_t *)"\x01", 1);
}

static void gen_cip_request(void)
{
    uint8_t b[512], conn[64];
    dr_wr_t w;
    dr_wr_init(&w, b, sizeof b);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path,
                     NULL, 0);
    put_w("cip_request", "get_attr", &w);

    uint8_t p16[16];
    dr_wr_t pw;
    dr_wr_init(&pw, p16, sizeof p16);
    dr_epath_write(&pw, 4, 0x300, 0x101);
    const uint8_t data[4] = {1, 2, 3, 4};
    dr_wr_init(&w, b, sizeof b);
    dr_cip_req_write(&w, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, p16, pw.len, data, sizeof data);
    put_w("cip_request", "set_attr_16bit", &w);

    /* Connection path with an electronic key and config data. */
    size_t cl = 0;
    const uint8_t key[] = {0x34, 0x04, 0xCD, 0xAB, 0x0C, 0x00, 0x01, 0x00, 0x01, 0x02};
    memcpy(conn, key, sizeof key);
    cl = sizeof key;
    cl += dr_conn_path_write(conn + cl, sizeof conn - cl, 1, 0x6B, 0x65);
    conn[cl++] = 0x80;
    conn[cl++] = 0x01;
    conn[cl++] = 0xAA;
    conn[cl++] = 0xBB;

    for (int large = 0; large <= 1; large++) {
        dr_fwd_open_t fo = fwd_open(large, conn, cl);
        dr_wr_init(&w, b, sizeof b);
        dr_cip_req_write(&w, large ? DR_CIP_SVC_LARGE_FORWARD_OPEN : DR_CIP_SVC_FORWARD_OPEN,
                         cm_path, sizeof cm_path, NULL, 0);
        dr_fwd_open_write(&w, &fo);
        put_w("cip_request", large ? "large_fwd_open" : "fwd_open", &w);
    }

    dr_fwd_close_t fc = {0x0A, 0x0E, 0x42, 0xABCD, 0xDEADBEEFu, conn + sizeof key, 8};
    dr_wr_init(&w, b, sizeof b);
    dr_cip_req_write(&w, DR_CIP_SVC_FORWARD_CLOSE, cm_path, sizeof cm_path, NULL, 0);
    dr_fwd_close_write(&w, &fc);
    put_w("cip_request", "fwd_close", &w);

    /* Unconnected Send carrying an odd-length Set_Attribute_Single. */
    uint8_t msg[32];
    dr_wr_t mw;
    dr_wr_init(&mw, msg, sizeof msg);
    const uint8_t one = 5;
    dr_cip_req_write(&mw, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path,
                     &one, 1);
    dr_wr_init(&w, b, sizeof b);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, cm_path, sizeof cm_path, NULL, 0);
    dr_ucmm_send_write(&w, msg, mw.len, route, sizeof route);
    put_w("cip_request", "unconnected_send", &w);

    /* Unconnected Send carrying a Forward Open. */
    uint8_t inner[128];
    dr_fwd_open_t fo = fwd_open(false, conn + sizeof key, 8);
    dr_wr_init(&mw, inner, sizeof inner);
    dr_cip_req_write(&mw, DR_CIP_SVC_FORWARD_OPEN, cm_path, sizeof cm_path, NULL, 0);
    dr_fwd_open_write(&mw, &fo);
    dr_wr_init(&w, b, sizeof b);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, cm_path, sizeof cm_path, NULL, 0);
    dr_ucmm_send_write(&w, inner, mw.len, route, sizeof route);
    put_w("cip_request", "unconnected_send_fwd_open", &w);

    put("cip_request", "epath_key_data", conn, cl);
}

static void gen_io_frame(void)
{
    uint8_t b[256], data[DR_ASM_MAX_SIZE];
    for (size_t i = 0; i < sizeof data; i++)
        data[i] = (uint8_t)(i * 7u);
    const struct {
        const char *name;
        size_t len;
        bool run_idle;
        uint16_t seq;
    } f[] = {
        {"o2t_io_control", 12, true, 5},
        {"o2t_heartbeat", 0, true, 0xFFFF},
        {"t2o_io_state", 36, false, 1},
        {"t2o_joint_state", 144, false, 0x8000},
        {"t2o_bit_out", 8, false, 0},
    };
    for (size_t k = 0; k < sizeof f / sizeof f[0]; k++) {
        dr_io_frame_t io = {0x12345678u, (uint32_t)k + 0x7FFFFFFFu, f[k].seq, data,
                            f[k].len, 1, f[k].run_idle};
        size_t n = 0;
        if (dr_io_frame_write(b, sizeof b, &io, &n) != DR_OK) {
            failed = 1;
            continue;
        }
        put("io_frame", f[k].name, b, n);
    }
}

static void gen_path(void)
{
    /* [flags][leaf lo][leaf hi] path '\0' value '\0' image. */
    /* flags: 0x01 whole mask, 0x02 O->T only, 0x04 unit, 0x08 closest
     * with size 1 + 4 * (flags >> 4). `bad`: the path is wrong on purpose. */
    const struct {
        const char *path, *value;
        uint8_t flags;
        bool bad;
    } s[] = {
        {"joint_state.position[3]", "31.5", 0x08 | 0xF0, false},
        {"dr2.velocity[1]", "-0.1", 0, false},
        {"io_state.cb_di", "0x5", 0x01, false},
        {"io_state.cb_di[5]", "true", 0, false},
        {"io_state.robot_state", "OPERATING", 0x04, false},
        {"io_state.aio_type.ai0", "1", 0, false},
        {"io_control.ao[1]", "nan", 0x02, false},
        {"float_in[23]", "3.4028235e38", 0x02 | 0x04, false},
        {"int_in[7]", "-2147483648", 0x02, false},
        {"bit_in", "18446744073709551615", 0x01, false},
        {"bit_in[64]", "0", 0x02, true}, /* one past the last bit */
        {"task_state.external_force.z", "1e-45", 0x08 | 0xA0, false},
        {"joint_state.positon[3]", "1", 0x08 | 0xF0, true}, /* typo */
        {"io_state.version.major", "255", 0, false},
    };
    for (size_t k = 0; k < sizeof s / sizeof s[0]; k++) {
        uint8_t b[256];
        dr_ref_t ref;
        uint16_t leaf = (uint16_t)(k * 27u);
        size_t n = 0;
        b[n++] = s[k].flags;
        b[n++] = (uint8_t)leaf;
        b[n++] = (uint8_t)(leaf >> 8);
        memcpy(b + n, s[k].path, strlen(s[k].path) + 1);
        n += strlen(s[k].path) + 1;
        memcpy(b + n, s[k].value, strlen(s[k].value) + 1);
        n += strlen(s[k].value) + 1;
        for (unsigned i = 0; i < 12; i++)
            b[n++] = (uint8_t)(0x3F + i * 29u);
        /* A seed that stopped parsing (a field renamed) is a stale seed. */
        if ((dr_path_parse(s[k].path, &ref) != DR_OK) != s[k].bad) {
            fprintf(stderr, "gen_corpus: path seed %s: parses %s\n", s[k].path,
                    s[k].bad ? "but should not" : "no more");
            failed = 1;
        }
        char name[32];
        snprintf(name, sizeof name, "seed_%02zu", k);
        put("path", name, b, n);
    }
}

/* ---- fuzz_modbus: [flags][k] pattern[k] then Modbus TCP ADUs ------------- */

typedef struct {
    uint8_t b[1024];
    size_t n;
} buf_t;

static void b_u8(buf_t *b, uint8_t v)
{
    if (b->n < sizeof b->b)
        b->b[b->n++] = v;
    else
        failed = 1;
}

static void b_be16(buf_t *b, uint16_t v)
{
    b_u8(b, (uint8_t)(v >> 8));
    b_u8(b, (uint8_t)v);
}

static void b_bytes(buf_t *b, const void *p, size_t n)
{
    for (size_t i = 0; i < n; i++)
        b_u8(b, ((const uint8_t *)p)[i]);
}

static void mb_begin(buf_t *b, uint8_t flags)
{
    static const uint8_t pattern[8] = {0x00, 0x11, 0x42, 0x80, 0x3F, 0xC0, 0x01, 0xFF};
    b->n = 0;
    b_u8(b, flags);
    b_u8(b, sizeof pattern);
    b_bytes(b, pattern, sizeof pattern);
}

/* One ADU: MBAP (transaction ID from the position) + the PDU. */
static void mb_adu(buf_t *b, uint8_t unit, const uint8_t *pdu, size_t n)
{
    b_be16(b, (uint16_t)(0x0100 + b->n));
    b_be16(b, 0);
    b_be16(b, (uint16_t)(n + 1));
    b_u8(b, unit);
    b_bytes(b, pdu, n);
}

/* fc addr count (reads), fc addr value (single writes). */
static void mb_4(buf_t *b, uint8_t unit, uint8_t fc, uint16_t addr, uint16_t x)
{
    uint8_t pdu[5] = {fc, (uint8_t)(addr >> 8), (uint8_t)addr, (uint8_t)(x >> 8), (uint8_t)x};
    mb_adu(b, unit, pdu, sizeof pdu);
}

static void mb_write_regs(buf_t *b, uint8_t unit, uint16_t addr, const uint16_t *v, uint16_t n)
{
    uint8_t pdu[6 + 2 * 16];
    size_t k = 0;
    pdu[k++] = 0x10;
    pdu[k++] = (uint8_t)(addr >> 8);
    pdu[k++] = (uint8_t)addr;
    pdu[k++] = (uint8_t)(n >> 8);
    pdu[k++] = (uint8_t)n;
    pdu[k++] = (uint8_t)(2 * n);
    for (uint16_t i = 0; i < n && i < 16; i++) {
        pdu[k++] = (uint8_t)(v[i] >> 8);
        pdu[k++] = (uint8_t)v[i];
    }
    mb_adu(b, unit, pdu, k);
}

static void mb_write_coils(buf_t *b, uint8_t unit, uint16_t addr, const uint8_t *bits,
                           uint16_t n)
{
    uint8_t pdu[6 + 16];
    size_t k = 0, bytes = (n + 7u) / 8u;
    pdu[k++] = 0x0F;
    pdu[k++] = (uint8_t)(addr >> 8);
    pdu[k++] = (uint8_t)addr;
    pdu[k++] = (uint8_t)(n >> 8);
    pdu[k++] = (uint8_t)n;
    pdu[k++] = (uint8_t)bytes;
    for (size_t i = 0; i < bytes && i < 16; i++)
        pdu[k++] = bits[i];
    mb_adu(b, unit, pdu, k);
}

/* ---- fuzz_rtu: [flags] then chunks [c] bytes, c bit 7 = silence after ---- */

static uint16_t rtu_crc(const uint8_t *p, size_t n)
{
    uint16_t crc = 0xFFFF;
    for (size_t i = 0; i < n; i++) {
        crc ^= p[i];
        for (unsigned k = 0; k < 8; k++)
            crc = (crc & 1u) ? (uint16_t)(crc >> 1 ^ 0xA001u) : (uint16_t)(crc >> 1);
    }
    return crc;
}

/* One chunk: address, PDU, CRC (bad: flipped), then silence or not. */
static void rtu_chunk(buf_t *b, uint8_t addr, const uint8_t *pdu, size_t n, int bad, int silence)
{
    uint8_t f[64];
    f[0] = addr;
    memcpy(f + 1, pdu, n);
    uint16_t crc = rtu_crc(f, n + 1);
    f[n + 1] = (uint8_t)(crc ^ (bad ? 0xFFu : 0u));
    f[n + 2] = (uint8_t)(crc >> 8);
    b_u8(b, (uint8_t)((n + 3) | (silence ? 0x80u : 0u)));
    b_bytes(b, f, n + 3);
}

static void gen_rtu(void)
{
    static const uint8_t rd[] = {0x04, 0x00, 0x20, 0x00, 0x08};
    static const uint8_t wr[] = {0x10, 0x00, 0xC8, 0x00, 0x02, 0x04, 0x12, 0x34, 0x56, 0x78};
    static const uint8_t coil[] = {0x05, 0x00, 0xC8, 0xFF, 0x00};
    static const uint8_t devid[] = {0x2B, 0x0E, 0x01, 0x00};
    static const uint8_t rw[] = {0x17, 0x00, 0xC8, 0x00, 0x02, 0x00, 0xC9, 0x00, 0x01, 0x02, 0xAB, 0xCD};
    static const uint8_t odd[] = {0x08, 0x00, 0x00, 0x12, 0x34};
    buf_t b;

    b.n = 0;
    b_u8(&b, 0x01);
    rtu_chunk(&b, 1, rd, sizeof rd, 0, 1);
    rtu_chunk(&b, 2, wr, sizeof wr, 0, 0);
    rtu_chunk(&b, 1, coil, sizeof coil, 0, 1);
    rtu_chunk(&b, 2, devid, sizeof devid, 0, 1);
    rtu_chunk(&b, 1, rw, sizeof rw, 0, 1);
    put("rtu", "requests", b.b, b.n);

    b.n = 0;
    b_u8(&b, 0x00);
    rtu_chunk(&b, 1, rd, sizeof rd, 1, 1);   /* bad CRC */
    rtu_chunk(&b, 9, rd, sizeof rd, 0, 1);   /* another slave */
    rtu_chunk(&b, 0, wr, sizeof wr, 0, 1);   /* broadcast */
    rtu_chunk(&b, 1, odd, sizeof odd, 0, 1); /* unknown length: at the silence */
    put("rtu", "dropped", b.b, b.n);

    /* a request split over two reads, then two back to back in one */
    b.n = 0;
    b_u8(&b, 0x05);
    {
        buf_t f;
        f.n = 0;
        rtu_chunk(&f, 1, rd, sizeof rd, 0, 0);
        b_u8(&b, 3);
        b_bytes(&b, f.b + 1, 3);
        b_u8(&b, (uint8_t)((f.n - 4) | 0x80u));
        b_bytes(&b, f.b + 4, f.n - 4);
        b_u8(&b, (uint8_t)(2 * (f.n - 1)));
        b_bytes(&b, f.b + 1, f.n - 1);
        b_bytes(&b, f.b + 1, f.n - 1);
    }
    put("rtu", "split_and_joined", b.b, b.n);
}

static void gen_modbus(void)
{
    /* Addresses: docs/register-map.md. O->T holding registers: io_control
     * 100, bit_in 200, int_in 300, float_in 400 (scaled view +1000);
     * control 0-1; T->O input registers 100-600, status 0-31 and 40-43
     * (RTU counters), test 32-39;
     * coils: io_control 100, bit_in 200. */
    buf_t b;
    const uint16_t real15[2] = {0x3FC0, 0x0000};   /* 1.5 in abcd */
    const uint16_t dint[2] = {0xFFFF, 0xFFFE};     /* -2 */
    const uint16_t nan[2] = {0x7FC0, 0x0000};
    const uint8_t bits[8] = {0xA5, 0x5A, 0xFF, 0x00, 0x01, 0x80, 0x0F, 0xF0};

    mb_begin(&b, 0x10);
    mb_4(&b, 1, 0x01, 100, 16);
    mb_4(&b, 1, 0x02, 0, 4);
    mb_4(&b, 1, 0x03, 0, 2);
    mb_4(&b, 1, 0x04, 0, 44);
    mb_4(&b, 1, 0x04, 100, 18);
    mb_4(&b, 1, 0x04, 1200, 6);
    mb_4(&b, 1, 0x03, 400, 8);
    mb_4(&b, 1, 0x03, 1400, 4);
    put("modbus", "reads", b.b, b.n);

    mb_begin(&b, 0x10);
    mb_write_regs(&b, 1, 400, real15, 2);
    mb_4(&b, 1, 0x03, 400, 2);
    mb_write_regs(&b, 1, 300, dint, 2);
    mb_4(&b, 1, 0x06, 1400, (uint16_t)-1234);
    mb_4(&b, 1, 0x06, 1401, 0x8000); /* reads back as -32767 */
    mb_4(&b, 1, 0x06, 0, 0x1234);  /* watchdog */
    mb_4(&b, 1, 0x06, 1, 1);       /* fault reset */
    mb_4(&b, 1, 0x06, 100, 0x00FF); /* io_control's mask */
    mb_write_regs(&b, 1, 400, nan, 2); /* refused */
    mb_4(&b, 1, 0x06, 300, 1);     /* half a DINT: refused */
    put("modbus", "write_registers", b.b, b.n);

    mb_begin(&b, 0x13); /* dcba */
    mb_write_regs(&b, 1, 400, real15, 2);
    mb_4(&b, 1, 0x03, 400, 2);
    mb_4(&b, 1, 0x03, 1400, 1);
    put("modbus", "word_order_dcba", b.b, b.n);

    mb_begin(&b, 0x10);
    mb_4(&b, 1, 0x05, 100, 0xFF00);
    mb_4(&b, 1, 0x05, 101, 0x0000);
    mb_4(&b, 1, 0x05, 102, 0x1234); /* refused */
    mb_write_coils(&b, 1, 100, bits, 16);
    mb_write_coils(&b, 1, 200, bits, 64);
    mb_4(&b, 1, 0x01, 200, 64);
    put("modbus", "write_coils", b.b, b.n);

    mb_begin(&b, 0x10);
    const uint8_t unknown[] = {0x2B, 0x0E, 0x01, 0x00};
    mb_adu(&b, 1, unknown, sizeof unknown);
    mb_4(&b, 9, 0x03, 0, 1);       /* no such unit */
    mb_4(&b, 1, 0x03, 0, 0);       /* count 0 */
    mb_4(&b, 1, 0x03, 2047, 2);    /* past the end */
    mb_4(&b, 1, 0x04, 40, 1);      /* unmapped */
    mb_4(&b, 1, 0x06, 500, 1);     /* nothing writable there */
    const uint8_t short_read[] = {0x03, 0x00};
    mb_adu(&b, 1, short_read, sizeof short_read);
    mb_4(&b, 1, 0x83, 0, 1);       /* high bit set: the reply keeps it */
    mb_4(&b, 7, 0xC8, 0, 1);
    put("modbus", "exceptions", b.b, b.n);

    mb_begin(&b, 0x30); /* read-only client */
    mb_4(&b, 1, 0x06, 0, 1);
    mb_4(&b, 1, 0x03, 0, 1);
    put("modbus", "read_only", b.b, b.n);

    mb_begin(&b, 0x08); /* on_link_loss = exception, link down */
    mb_4(&b, 1, 0x04, 200, 2);
    mb_4(&b, 1, 0x02, 100, 8);
    mb_4(&b, 1, 0x04, 0, 32);
    mb_4(&b, 1, 0x03, 400, 2);
    put("modbus", "link_down_exception", b.b, b.n);

    mb_begin(&b, 0x51); /* unit 2 too, cdab */
    mb_write_regs(&b, 2, 400, real15, 2);
    mb_4(&b, 2, 0x03, 400, 2);
    mb_4(&b, 1, 0x03, 400, 2);
    put("modbus", "two_units", b.b, b.n);

    mb_begin(&b, 0x90); /* unmapped_read = exception */
    b.b[1] |= 0x40;     /* GPIO inputs own bit_in[3] and io_control.cb_do[1] */
    mb_4(&b, 1, 0x05, 203, 0xFF00); /* refused if it changes the bit */
    mb_4(&b, 1, 0x05, 100, 0x0000);
    mb_write_coils(&b, 1, 200, bits, 8);
    mb_4(&b, 1, 0x06, 200, 0x0008);
    mb_4(&b, 1, 0x06, 100, 0x0003);
    mb_4(&b, 1, 0x04, 40, 1); /* reserved: refused in this mode */
    put("modbus", "gpio_owned", b.b, b.n);

    mb_begin(&b, 0x50); /* unit 2 too */
    /* FC 23: read HR 300-303 and write int_in[0] (HR 300-301) */
    const uint8_t rw[] = {0x17, 0x01, 0x2C, 0x00, 0x04, 0x01, 0x2C, 0x00, 0x02, 0x04,
                          0xFF, 0xFF, 0xFF, 0xFE};
    mb_adu(&b, 1, rw, sizeof rw);
    const uint8_t rw_bad[] = {0x17, 0x01, 0x2C, 0x00, 0x04, 0x01, 0x2D, 0x00, 0x01, 0x02,
                              0x00, 0x01}; /* half a DINT: nothing applied */
    mb_adu(&b, 2, rw_bad, sizeof rw_bad);
    const uint8_t rw_read_bad[] = {0x17, 0x07, 0xFF, 0x00, 0x02, 0x01, 0x2C, 0x00, 0x02, 0x04,
                                   0x00, 0x00, 0x00, 0x05}; /* read past the end */
    mb_adu(&b, 1, rw_read_bad, sizeof rw_read_bad);
    for (uint8_t code = 1; code <= 4; code++) {
        const uint8_t devid[] = {0x2B, 0x0E, code, code == 4 ? 0x81 : 0x00};
        mb_adu(&b, 2, devid, sizeof devid);
    }
    const uint8_t devid_restart[] = {0x2B, 0x0E, 0x02, 0x03}; /* no VendorUrl: from 0 */
    mb_adu(&b, 1, devid_restart, sizeof devid_restart);
    const uint8_t devid_none[] = {0x2B, 0x0E, 0x04, 0x03};  /* no such object: 0x02 */
    mb_adu(&b, 1, devid_none, sizeof devid_none);
    const uint8_t canopen[] = {0x2B, 0x0D, 0x00, 0x00};     /* another MEI type: 0x01 */
    mb_adu(&b, 1, canopen, sizeof canopen);
    put("modbus", "read_write_device_id", b.b, b.n);

    mb_begin(&b, 0x10);
    b.b[1] |= 0x80; /* the write fault is latched */
    const uint16_t wd_reset[2] = {0x0007, 0x0001};
    mb_4(&b, 1, 0x06, 0, 2);            /* the heartbeat: 0x04 */
    mb_write_regs(&b, 1, 300, dint, 2); /* 0x04 */
    mb_4(&b, 1, 0x05, 100, 0xFF00);     /* 0x04 */
    mb_4(&b, 1, 0x06, 1, 0);            /* not a reset: 0x04 */
    mb_write_regs(&b, 1, 0, wd_reset, 2); /* watchdog and reset: taken */
    mb_write_regs(&b, 1, 300, dint, 2); /* taken */
    put("modbus", "fault_latched", b.b, b.n);

    mb_begin(&b, 0x10);
    mb_4(&b, 1, 0x03, 0, 1);
    b_bytes(&b, "\x00\x01\x00\x01\x00\x06\x01", 7); /* protocol 1: dropped */
    put("modbus", "bad_mbap", b.b, b.n);

    mb_begin(&b, 0x10);
    mb_4(&b, 1, 0x03, 0, 1);
    b_bytes(&b, "\x00\x02\x00\x00\x00\x06\x01\x03", 8); /* cut short */
    put("modbus", "partial", b.b, b.n);
}

/* ---- fuzz_config: the example files and a few of our own ---------------- */

/* Every DIR/NAME.EXT as seed PREFIXNAME of `target`. */
static void copy_dir(const char *target, const char *dir, const char *prefix, const char *ext)
{
    size_t el = strlen(ext);
    DIR *d = opendir(dir);
    if (d == NULL) {
        perror(dir);
        failed = 1;
        return;
    }
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t len = strlen(e->d_name);
        if (len < el + 2 || e->d_name[len - el - 1] != '.' ||
            strcmp(e->d_name + len - el, ext) != 0)
            continue;
        char path[512], name[300];
        static uint8_t data[65536];
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        FILE *f = fopen(path, "rb");
        size_t n = f != NULL ? fread(data, 1, sizeof data, f) : 0;
        if (f == NULL || ferror(f)) {
            perror(path);
            failed = 1;
        } else {
            snprintf(name, sizeof name, "%s%.*s", prefix, (int)(len - el - 1), e->d_name);
            put(target, name, data, n);
        }
        if (f != NULL)
            (void)fclose(f); /* read only */
    }
    closedir(d);
}

static void gen_config(void)
{
    copy_dir("config", "gateway/examples", "example_", "ini");
    copy_dir("config", "tests/gw_config", "test_", "ini");
    const struct {
        const char *name, *text;
    } s[] = {
        {"modbus_allow", "[daemon]\nlog_level = debug\n[modbus]\nlisten = 127.0.0.1\n"
                         "port = 1502\nallow = 10.0.0.0/8 read-write\n"
                         "allow = 192.168.1.7 read-only\nword_order = cdab\n"
                         "on_link_loss = exception\nsingle_writer = yes\n"
                         "[robot.arm1]\nhost = 10.0.0.5\nunit_id = 3\n"},
        {"two_robots_clash", "[robot a]\nhost = h1\nunit_id = 2\n[robot b]\nhost = h2\n"
                             "unit_id = 2\n"},
        {"gpio_input", "[robot]\nhost = r\n[gpio.stop]\nchip = gpiochip0\nline = 4\n"
                       "direction = input\nfield = io_control.cb_do[1]\n"
                       "debounce_ms = 20\nactive_low = yes\nbias = pull-up\n"},
        {"bom_crlf", "\xEF\xBB\xBF; comment\r\n[robot]\r\nhost = 1.2.3.4\r\n"},
        {"indented", "[robot]\n  host = 1.2.3.4\n"},
        {"no_close", "[robot\nhost = x\n"},
        {"empty", ""},
        {"user_map", "[robot arm]\nhost = 1.2.3.4\nunit_id_alias = 0,255\n"
                     "map = hr 2000 io_state.robot_state uint16\n"
                     "map = hr 2001 joint_state.position[1..6] real\n"
                     "map = hr 2036 int_in[0..3] int16 writable saturate\n"
                     "map = co 2048 bit_in[0..15] writable\n"},
        {"opcua", "[robot]\nhost = 1.2.3.4\n[opcua]\nlisten = 192.0.2.1\nport = 4840\n"
                  "security_policies = Basic256Sha256, Aes256_Sha256_RsaPss\n"
                  "application_uri = urn:x:y\ncert_file = /nonexistent.der\n"
                  "key_file = /nonexistent.key\nauth_file = /nonexistent\ntrust_dir = /nonexistent.d\n"
                  "writes = yes\n"
                  "max_sessions = 5\nmax_subscriptions = 3\nmax_monitored_items = 500\ninsecure = no\n"},
    };
    for (size_t k = 0; k < sizeof s / sizeof s[0]; k++)
        put("config", s[k].name, (const uint8_t *)s[k].text, strlen(s[k].text));
}

/* ---- fuzz_usermap: map lines, one per line ---------------------------------- */

static void gen_usermap(void)
{
    const struct {
        const char *name, *text;
    } s[] = {
        {"docs_example", "hr 2000 io_state.robot_state uint16\nhr 2001 io_state.servo_on uint16\n"
                         "hr 2002 joint_state.position[1..6] real\nhr 2014 int_out[0..7] dint\n"
                         "hr 2030 joint_state.position[1..6] int16 scale=10 saturate\n"
                         "hr 2036 int_in[0..3] int16 writable saturate\n"},
        {"views", "hr 3000 int_in[4] uint16 lo writable\nhr 3001 int_in[4] uint16 hi writable\n"
                  "hr 3002 bit_in[0..63] bits writable\nir 3000 io_state.cb_di bits\n"
                  "di 3000 bit_out[0..7]\nco 3000 io_control.cb_do[1..4] writable\n"
                  "hr 3010 float_in[0..1] real writable\nhr 3020 float_in[2] int16 scale=100 saturate writable\n"},
        {"errors", "hr 300 int_in[0] dint\nhr 2000 int_out[0] dint writable\n"
                   "hr 65535 int_in[0..1] dint\nhr 2000 joint_state.positon[1] real\n"
                   "hr 2000 joint_state.position[1] int16 scale=100\nxx 1 a b\n"
                   "hr 2000 int_in[3..1] dint\nir 2000 int_in[0] dint writable\n"},
    };
    for (size_t k = 0; k < sizeof s / sizeof s[0]; k++)
        put("usermap", s[k].name, (const uint8_t *)s[k].text, strlen(s[k].text));
}

/* ---- fuzz_sim_request: [config] records ---------------------------------- */

/* Record: op 0 + an encapsulation frame; op bit 3: session filled in. */
static void sim_frame(buf_t *b, uint8_t op, uint16_t cmd, const uint8_t *body, size_t len)
{
    uint8_t f[DR_ENCAP_MAX_LEN];
    dr_encap_t h = {cmd, 0, 0, 0, {0}, 0};
    memcpy(h.context, ctx, 8);
    if (len > 0)
        memcpy(f + DR_ENCAP_HEADER_LEN, body, len);
    if (dr_encap_write(f, sizeof f, &h, len) != DR_OK) {
        failed = 1;
        return;
    }
    b_u8(b, op);
    b_bytes(b, f, DR_ENCAP_HEADER_LEN + len);
}

/* SendRRData (op 0x08: peer 0's session; 0x0C: peer 1's) around one CIP
 * request. */
static void sim_rr_op(buf_t *b, uint8_t op, const uint8_t *req, size_t len, bool t2o_sa)
{
    uint8_t body[DR_ENCAP_MAX_LEN];
    dr_wr_t w;
    dr_wr_init(&w, body, sizeof body);
    dr_rr_begin(&w, 10);
    dr_cpf_begin(&w, t2o_sa ? 3 : 2);
    dr_cpf_item_end(&w, dr_cpf_item_begin(&w, DR_CPF_NULL));
    size_t m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_wr_bytes(&w, req, len);
    dr_cpf_item_end(&w, m);
    if (t2o_sa) {
        dr_sockaddr_t sa = {0x7F000002u, DR_ENIP_UDP_PORT};
        dr_cpf_sockaddr_write(&w, DR_CPF_SOCKADDR_T2O, sa);
    }
    if (w.overflow)
        failed = 1;
    sim_frame(b, op, DR_ENCAP_SEND_RR_DATA, body, w.len);
}

static void sim_rr(buf_t *b, const uint8_t *req, size_t len, bool t2o_sa)
{
    sim_rr_op(b, 0x08, req, len, t2o_sa);
}

static void sim_register(buf_t *b, uint8_t op)
{
    const uint8_t reg[] = {0x01, 0x00, 0x00, 0x00};
    sim_frame(b, op, DR_ENCAP_REGISTER_SESSION, reg, sizeof reg);
}

/* A Forward Open of connection serial `serial` (fwd_open's T->O ID, vendor
 * and originator serial: connections differ by their serial only). */
static size_t sim_fwd_open_serial(uint8_t *req, size_t cap, bool large, uint16_t o2t_point,
                                  uint16_t t2o_point, uint16_t o2t_size, uint16_t t2o_size,
                                  uint8_t *path, size_t path_cap, uint16_t serial)
{
    dr_fwd_open_t fo = fwd_open(large, path, 0);
    fo.conn_serial = serial;
    fo.path_len = dr_conn_path_write(path, path_cap, 1, o2t_point, t2o_point);
    fo.o2t = (dr_netparams_t){o2t_size, DR_CONN_TYPE_P2P, 2, false, false};
    fo.t2o = (dr_netparams_t){t2o_size, DR_CONN_TYPE_P2P, 2, false, false};
    dr_wr_t w;
    dr_wr_init(&w, req, cap);
    dr_cip_req_write(&w, large ? DR_CIP_SVC_LARGE_FORWARD_OPEN : DR_CIP_SVC_FORWARD_OPEN,
                     cm_path, sizeof cm_path, NULL, 0);
    dr_fwd_open_write(&w, &fo);
    if (w.overflow)
        failed = 1;
    return w.len;
}

static size_t sim_fwd_open(uint8_t *req, size_t cap, bool large, uint16_t o2t_point,
                           uint16_t t2o_point, uint16_t o2t_size, uint16_t t2o_size,
                           uint8_t *path, size_t path_cap)
{
    return sim_fwd_open_serial(req, cap, large, o2t_point, t2o_point, o2t_size, t2o_size, path,
                               path_cap, 0x42);
}

/* Record: op 2 | 4 (connection number 0's ID filled in) + a Class 1 packet. */
static void sim_io(buf_t *b, uint8_t op, size_t data_len, bool run_idle, uint16_t seq)
{
    uint8_t data[DR_ASM_MAX_SIZE], pkt[256];
    for (size_t i = 0; i < sizeof data; i++)
        data[i] = (uint8_t)(i * 13u);
    dr_io_frame_t io = {0, seq, seq, data, data_len, 1, run_idle};
    size_t n = 0;
    if (dr_io_frame_write(pkt, sizeof pkt, &io, &n) != DR_OK || n > 255) {
        failed = 1;
        return;
    }
    b_u8(b, op);
    b_u8(b, (uint8_t)n);
    b_bytes(b, pkt, n);
}

static void gen_sim_request(void)
{
    buf_t b;
    uint8_t req[256], path[64], body[64];
    dr_wr_t w;

    /* Sessions, the list commands, explicit requests, unregister. */
    b.n = 0;
    b_u8(&b, 0x12);
    sim_register(&b, 0x00);
    sim_frame(&b, 0x00, DR_ENCAP_LIST_IDENTITY, NULL, 0);
    sim_frame(&b, 0x00, DR_ENCAP_LIST_SERVICES, NULL, 0);
    sim_frame(&b, 0x00, DR_ENCAP_LIST_INTERFACES, NULL, 0);
    sim_frame(&b, 0x00, DR_ENCAP_NOP, NULL, 0);
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path, NULL, 0);
    sim_rr(&b, req, w.len, false);
    uint8_t p16[16];
    dr_wr_t pw;
    dr_wr_init(&pw, p16, sizeof p16);
    dr_epath_write(&pw, DR_CIP_CLASS_IDENTITY, 1, -1);
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTES_ALL, p16, pw.len, NULL, 0);
    sim_rr(&b, req, w.len, false);
    dr_wr_init(&pw, p16, sizeof p16);
    dr_epath_write(&pw, DR_CIP_CLASS_ASSEMBLY, 107, 3);
    uint8_t twelve[12] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12};
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, p16, pw.len, twelve, sizeof twelve);
    sim_rr(&b, req, w.len, false);
    sim_frame(&b, 0x08, DR_ENCAP_UNREGISTER_SESSION, NULL, 0);
    put("sim_request", "session_lists_explicit", b.b, b.n);

    /* Forward Open, I/O both ways, Forward Close. */
    b.n = 0;
    b_u8(&b, 0x12);
    sim_register(&b, 0x00);
    size_t n = sim_fwd_open(req, sizeof req, false, 107, 101, 12 + 6, 36 + 2, path, sizeof path);
    sim_rr(&b, req, n, true);
    b_u8(&b, 0x03);
    b_u8(&b, 4); /* 5 ms */
    sim_io(&b, 0x06, 12, true, 1);
    b_u8(&b, 0x03);
    b_u8(&b, 9);
    sim_io(&b, 0x06, 12, true, 2);
    sim_io(&b, 0x06, 12, true, 2); /* duplicate */
    b_u8(&b, 0x03);
    b_u8(&b, 255);
    dr_fwd_close_t fc = {0x0A, 0x0E, 0x42, 0xABCD, 0xDEADBEEFu, path, 0};
    fc.path_len = dr_conn_path_write(path, sizeof path, 1, 107, 101);
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_FORWARD_CLOSE, cm_path, sizeof cm_path, NULL, 0);
    dr_fwd_close_write(&w, &fc);
    sim_rr(&b, req, w.len, false);
    put("sim_request", "fwd_open_io_close", b.b, b.n);

    /* Large Forward Open of an input-only heartbeat; listen-only; timeout. */
    b.n = 0;
    b_u8(&b, 0x11);
    sim_register(&b, 0x04);
    /* Heartbeat points 198 (input only) and 199 (listen only), peer 1. */
    n = sim_fwd_open(req, sizeof req, true, 198, 102, 6, 144 + 2, path, sizeof path);
    sim_rr_op(&b, 0x0C, req, n, false);
    n = sim_fwd_open(req, sizeof req, false, 199, 102, 2, 144 + 2, path, sizeof path);
    sim_rr_op(&b, 0x0C, req, n, false);
    sim_io(&b, 0x06, 0, true, 1);
    b_u8(&b, 0x03);
    b_u8(&b, 200);
    put("sim_request", "heartbeats_timeout", b.b, b.n);

    /* Two connections with the same T->O connection ID (the originator
     * picks it: fwd_open's), of two sizes, producing (the harness once took
     * a packet of one for the other's). */
    b.n = 0;
    b_u8(&b, 0x12);
    sim_register(&b, 0x00);
    n = sim_fwd_open_serial(req, sizeof req, false, 198, 102, 6, 144 + 2, path, sizeof path, 0x42);
    sim_rr(&b, req, n, true);
    n = sim_fwd_open_serial(req, sizeof req, false, 198, 101, 6, 36 + 2, path, sizeof path, 0x43);
    sim_rr(&b, req, n, true);
    b_u8(&b, 0x03);
    b_u8(&b, 30);
    put("sim_request", "shared_t2o_id", b.b, b.n);

    /* Unconnected Send around a Set_Attribute_Single of io_control. */
    b.n = 0;
    b_u8(&b, 0x12);
    sim_register(&b, 0x00);
    uint8_t inner[64];
    dr_wr_t mw;
    dr_wr_init(&mw, inner, sizeof inner);
    dr_cip_req_write(&mw, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, p16, pw.len, twelve, sizeof twelve);
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, cm_path, sizeof cm_path, NULL, 0);
    dr_ucmm_send_write(&w, inner, mw.len, route, sizeof route);
    sim_rr(&b, req, w.len, false);
    put("sim_request", "unconnected_send", b.b, b.n);

    /* ... and around nothing: refused as an Unconnected Send (drsim once
     * answered it as a request for service 0x00). */
    b.n = 0;
    b_u8(&b, 0x12);
    sim_register(&b, 0x00);
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, cm_path, sizeof cm_path, NULL, 0);
    dr_ucmm_send_write(&w, inner, 0, route, sizeof route);
    sim_rr(&b, req, w.len, false);
    put("sim_request", "unconnected_send_empty", b.b, b.n);

    /* UDP 44818: ListIdentity, ListServices, and a RegisterSession (ignored). */
    b.n = 0;
    b_u8(&b, 0x02);
    const uint16_t cmds[3] = {DR_ENCAP_LIST_IDENTITY, DR_ENCAP_LIST_SERVICES,
                              DR_ENCAP_REGISTER_SESSION};
    for (int k = 0; k < 3; k++) {
        buf_t t;
        t.n = 0;
        if (cmds[k] == DR_ENCAP_REGISTER_SESSION)
            sim_register(&t, 0);
        else
            sim_frame(&t, 0, cmds[k], NULL, 0);
        b_u8(&b, 0x01);
        b_u8(&b, (uint8_t)(t.n - 1));
        b_bytes(&b, t.b + 1, t.n - 1);
    }
    put("sim_request", "udp", b.b, b.n);

    /* A session used without registering, then a broken frame. */
    b.n = 0;
    b_u8(&b, 0x00);
    dr_wr_init(&w, body, sizeof body);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, asm_path, sizeof asm_path, NULL, 0);
    sim_rr(&b, body, w.len, false);
    sim_frame(&b, 0x00, 0x00FF, NULL, 0); /* no such command */
    b_u8(&b, 0x00);
    b_bytes(&b, "\x65\x00\x10\x00", 4); /* a header cut short */
    put("sim_request", "no_session_bad_frame", b.b, b.n);
}

/* ---- fuzz_cli: [mode][flags] arguments separated by NULs ------------------ */

static void cli_seed(const char *name, uint8_t mode, uint8_t flags, const char *const *argv,
                     size_t argc, const uint8_t *tail, size_t tail_len)
{
    buf_t b;
    b.n = 0;
    b_u8(&b, mode);
    b_u8(&b, flags);
    for (size_t i = 0; i < argc; i++) {
        b_bytes(&b, argv[i], strlen(argv[i]));
        if (i + 1 < argc || tail != NULL)
            b_u8(&b, 0);
    }
    if (tail != NULL)
        b_bytes(&b, tail, tail_len);
    put("cli", name, b.b, b.n);
}

#define ARGS(...) (const char *const[]){__VA_ARGS__}, \
    sizeof (const char *const[]){__VA_ARGS__} / sizeof(const char *)

static void gen_cli(void)
{
    cli_seed("encode_io_control", 0, 0, ARGS("io_control", "cb_do[3]=1", "ao[0]=2.5",
                                             "io_control.tcp_do=0x3"), NULL, 0);
    cli_seed("encode_float_in", 0, 0, ARGS("--hex", "float_in", "[7]=1.5", "float_in[0]=-1e-3"),
             NULL, 0);
    cli_seed("encode_bits", 0, 0, ARGS("dr8", "bit_in[5]=true", "bit_in=0xff"), NULL, 0);
    cli_seed("encode_errors", 0, 0, ARGS("int_in", "[0]=-2147483648", "positon[1]=1",
                                         "[99]=1", "io_state.cb_di[1]=1"), NULL, 0);
    cli_seed("encode_help", 0, 0, ARGS("-h"), NULL, 0);
    cli_seed("encode_unknown_option", 0, 0, ARGS("--nope", "io_control"), NULL, 0);

    uint8_t img[DR_ASM_MAX_SIZE];
    for (size_t i = 0; i < sizeof img; i++)
        img[i] = (uint8_t)(i * 37u + 1u);
    cli_seed("decode_raw", 1, 0, ARGS("io_control"), img, 12);
    cli_seed("decode_json", 1, 2, ARGS("io_state"), img, 36);
    char hex[3 * DR_ASM_MAX_SIZE + 1];
    size_t h = 0;
    for (size_t i = 0; i < 96; i++)
        h += (size_t)snprintf(hex + h, sizeof hex - h, "%02x%c", img[i],
                              i % 16 == 15 ? '\n' : ' ');
    cli_seed("decode_hex", 1, 1, ARGS("float_in"), (const uint8_t *)hex, h);
    cli_seed("decode_hex_json", 1, 3, ARGS("dr4"), (const uint8_t *)"01 02 03 04 05 06 07 0",
             22);

    cli_seed("set_get_args", 2, 0,
             ARGS("io_control.cb_do[3]=1", "dr7.ao[0]=2.5", "io_state.robot_state=1",
                  "float_in[23]=nan", "int_in[7]=-2147483648", "bit_in=0xffffffffffffffff",
                  "io_state", "joint_state.position[3]", "joint_state.positon[3]",
                  "io_control.cb_do[17]=1", "float_in[0]=3.4e38"), NULL, 0);
    cli_seed("net_config", 3, 0, ARGS("192.168.137.100", "44818", "2000", "io_state=101",
                                      "dr7=150"), NULL, 0);
    cli_seed("net_config_bad", 3, 0, ARGS("robot", "0", "x", "nope=1", "io_state=65536"),
             NULL, 0);
}

/* ---- fuzz_sparkplug: an NCMD/DCMD/STATE message -------------------------- */

/* Byte 0: bit 0 writes on, bit 1 a primary host, bits 2.. the topic
 * (0 NCMD, 1 DCMD to r0, 2 DCMD to an unknown device, 3 STATE, 4 other);
 * the rest the payload: protobuf (Sparkplug 3.0) written out by hand
 * here, so that the seeds do not come from the encoder under test. */
static void gen_sparkplug(void)
{
    static const uint8_t rebirth[] = {
        0x01, 0x08, 0x01, 0x12, 0x1a, 0x0a, 0x14, 'N', 'o', 'd', 'e', ' ', 'C', 'o', 'n', 't',
        'r', 'o', 'l', '/', 'R', 'e', 'b', 'i', 'r', 't', 'h', 0x20, 0x0b, 0x70, 0x01};
    static const uint8_t write_int[] = {
        0x05, 0x08, 0x01, 0x12, 0x0f, 0x0a, 0x09, 'i', 'n', 't', '_', 'i', 'n', '[', '0', ']',
        0x20, 0x03, 0x50, 0x2a};
    static const uint8_t write_neg[] = {
        0x05, 0x08, 0x01, 0x12, 0x13, 0x0a, 0x09, 'i', 'n', 't', '_', 'i', 'n', '[', '1', ']',
        0x20, 0x03, 0x50, 0xf9, 0xff, 0xff, 0xff, 0x0f};
    static const uint8_t write_text[] = {
        0x05, 0x08, 0x01, 0x12, 0x12, 0x0a, 0x0b, 'f', 'l', 'o', 'a', 't', '_', 'i', 'n', '[',
        '2', ']', 0x7a, 0x03, '2', '.', '5'};
    static const uint8_t alias_ro[] = {
        0x05, 0x08, 0x01, 0x12, 0x06, 0x10, 0x02, 0x20, 0x0b, 0x70, 0x01};
    static const uint8_t writes_off[] = {
        0x04, 0x08, 0x01, 0x12, 0x0f, 0x0a, 0x09, 'i', 'n', 't', '_', 'i', 'n', '[', '0', ']',
        0x20, 0x03, 0x50, 0x2a};
    static const uint8_t unknown_dev[] = {
        0x09, 0x08, 0x01, 0x12, 0x0f, 0x0a, 0x09, 'i', 'n', 't', '_', 'i', 'n', '[', '0', ']',
        0x20, 0x03, 0x50, 0x2a};
    /* bit_in[5] = 42: out of the field's range (found by the fuzzer once) */
    static const uint8_t out_of_range[] = {
        0x05, 0x08, 0x01, 0x12, 0x0f, 0x0a, 0x09, 'b', 'i', 't', '_', 'i', 'n', '[', '5', ']',
        0x20, 0x03, 0x50, 0x2a};
    static const char state_off[] = "\x0f{\"online\":false,\"timestamp\":1}";
    put("sparkplug", "ncmd_rebirth", rebirth, sizeof rebirth);
    put("sparkplug", "dcmd_int", write_int, sizeof write_int);
    put("sparkplug", "dcmd_int_negative", write_neg, sizeof write_neg);
    put("sparkplug", "dcmd_text", write_text, sizeof write_text);
    put("sparkplug", "dcmd_alias_readonly", alias_ro, sizeof alias_ro);
    put("sparkplug", "dcmd_writes_off", writes_off, sizeof writes_off);
    put("sparkplug", "dcmd_unknown_device", unknown_dev, sizeof unknown_dev);
    put("sparkplug", "dcmd_out_of_range", out_of_range, sizeof out_of_range);
    put("sparkplug", "state_offline", (const uint8_t *)state_off, sizeof state_off - 1);
}

/* ---- fuzz_http: path '\0' host '\0' authorization '\0' [port] [address] -- */

static void http_seed(const char *name, const char *text, size_t len)
{
    put("http", name, (const uint8_t *)text, len);
}

#define HTTP_SEED(name, text) http_seed(name, text, sizeof text - 1)

static void gen_http(void)
{
    /* admin:good (the fake crypt's good password) */
    HTTP_SEED("good_login", "/api/v1/status\0localhost:8080\0Basic YWRtaW46Z29vZA==\0\0\x02");
    /* admin:wrong */
    HTTP_SEED("wrong_password",
              "/robot/r0\n7.0.0.1:8080\0Basic YWRtaW46d3Jvbmc=\0\0\x03");
    /* a user name with a line break and text that looks like an escape */
    HTTP_SEED("forged_user", "/api/v1/events?robot=r\xc3\xa9\0evil.example\0"
                             "Basic eApcbjwwPmZvcmdlZDpwdw==\0\0\x04");
    HTTP_SEED("no_auth", "/x\n<0>y\0\0\0");
    HTTP_SEED("not_basic", "/\0[::1]:8080\0Bearer x\0\0\x05");
}

/* ---- fuzz_eds: the test EDS files (the first byte sizes the error
 * buffer) ---------------------------------------------------------------- */

static void gen_eds(void)
{
    copy_dir("eds", "tests/cli/eds", "", "eds");
}

int main(int argc, char **argv)
{
    if (argc > 1)
        root = argv[1];
    mkdir_p(root);
    gen_encap();
    gen_cip_reply();
    gen_identity();
    gen_cip_request();
    gen_io_frame();
    gen_path();
    gen_modbus();
    gen_rtu();
    gen_config();
    gen_usermap();
    gen_sim_request();
    gen_cli();
    gen_sparkplug();
    gen_eds();
    gen_http();
    return failed;
}
