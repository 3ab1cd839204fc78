/* SPDX-License-Identifier: MIT */
/*
 * Writes the seed corpora under DIR/<target>/ (default fuzz/corpus) from
 * frames the library's own builders make, so the seeds follow the code:
 * `make fuzz-corpus` reruns it; the output is committed. Deterministic:
 * the same library gives the same files.
 */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "drgate/cip.h"
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

    dr_wr_init(&w, b, sizeof b);
    dr_cip_rsp_write(&w, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 0x0E, NULL, 0, NULL, 0);
    put_w("cip_reply", "not_settable", &w);
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

int main(int argc, char **argv)
{
    if (argc > 1)
        root = argv[1];
    mkdir_p(root);
    gen_encap();
    gen_cip_reply();
    gen_cip_request();
    gen_io_frame();
    gen_path();
    return failed;
}
