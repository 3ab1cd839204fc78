/* SPDX-License-Identifier: MIT */
/* drsim adapter: encapsulation commands and explicit messaging. */
#include "test_sim_support.h"

static void test_register_session(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    uint8_t b[4];
    dr_wr_t w;
    /* Wrong protocol version: 0x69, no session. */
    dr_wr_init(&w, b, sizeof b);
    dr_register_write(&w, 2, 0);
    assert_int_equal(fx_encap(&f, DR_ENCAP_REGISTER_SESSION, 0, b, 4), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x69);
    assert_int_equal(f.hdr.session, 0);
    assert_int_equal(f.peer.session, 0);
    /* Wrong length: 0x65. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_REGISTER_SESSION, 0, b, 3), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x65);
    uint32_t s = fx_register(&f);
    assert_int_equal(f.peer.session, s);
    /* The body comes back as version 1, options 0. */
    uint16_t v, o;
    assert_int_equal(dr_register_parse(f.body, f.hdr.length, &v, &o), DR_OK);
    assert_int_equal(v, 1);
    assert_int_equal(o, 0);
    /* A second registration on the same connection is refused. */
    dr_wr_init(&w, b, sizeof b);
    dr_register_write(&w, 1, 0);
    assert_int_equal(fx_encap(&f, DR_ENCAP_REGISTER_SESSION, 0, b, 4), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x01);
    /* Another TCP connection gets another handle. */
    drsim_peer_t first = f.peer;
    f.peer.session = 0;
    assert_int_not_equal(fx_register(&f), first.session);
}

static void test_session_checks(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    uint8_t body[8] = {0};
    /* SendRRData before RegisterSession. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_SEND_RR_DATA, 0, body, 8), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x64);
    uint32_t s = fx_register(&f);
    /* Wrong handle. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_SEND_RR_DATA, s + 1, body, 8), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x64);
    assert_int_equal(f.hdr.length, 0);
    /* Right handle, malformed CPF: incorrect data. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_SEND_RR_DATA, s, body, 8), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x03);
    /* Unknown command, and SendUnitData without a Class 3 connection. */
    assert_int_equal(fx_encap(&f, 0x0042, s, NULL, 0), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x01);
    assert_int_equal(fx_encap(&f, DR_ENCAP_SEND_UNIT_DATA, s, body, 8), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x01);
    /* NOP has no reply. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_NOP, 0, body, 4), DRSIM_SILENT);
    /* UnRegisterSession: a wrong handle is an error, the right one closes. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_UNREGISTER_SESSION, s + 1, NULL, 0), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0x64);
    assert_int_equal(fx_encap(&f, DR_ENCAP_UNREGISTER_SESSION, s, NULL, 0), DRSIM_CLOSE);
}

static void test_list_identity(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    assert_int_equal(fx_encap(&f, DR_ENCAP_LIST_IDENTITY, 0, NULL, 0), DRSIM_REPLY);
    assert_int_equal(f.hdr.status, 0);
    dr_identity_t id;
    assert_int_equal(dr_list_identity_parse(f.body, f.hdr.length, &id), DR_OK);
    assert_string_equal(id.product_name, DRSIM_PRODUCT_NAME);
    assert_int_equal(id.device_type, DRSIM_DEVICE_TYPE);
    assert_int_equal(id.sockaddr.addr, 0x7F000002u); /* the local address */
    assert_int_equal(id.sockaddr.port, 44818);
    assert_int_equal(id.state, 3);
    /* Over UDP too; other commands are ignored there. */
    uint8_t frame[DR_ENCAP_HEADER_LEN], out[DR_ENCAP_MAX_LEN];
    dr_encap_t h;
    memset(&h, 0, sizeof h);
    h.command = DR_ENCAP_LIST_IDENTITY;
    assert_int_equal(dr_encap_write(frame, sizeof frame, &h, 0), DR_OK);
    size_t n = 0;
    assert_int_equal(drsim_encap_udp(&f.sim, &f.peer, frame, sizeof frame, out,
                                     sizeof out, &n), DRSIM_REPLY);
    assert_true(n > DR_ENCAP_HEADER_LEN);
    h.command = DR_ENCAP_REGISTER_SESSION;
    assert_int_equal(dr_encap_write(frame, sizeof frame, &h, 0), DR_OK);
    assert_int_equal(drsim_encap_udp(&f.sim, &f.peer, frame, sizeof frame, out,
                                     sizeof out, &n), DRSIM_SILENT);
    /* ListServices: one Communications item. */
    assert_int_equal(fx_encap(&f, DR_ENCAP_LIST_SERVICES, 0, NULL, 0), DRSIM_REPLY);
    dr_cpf_t cpf;
    assert_int_equal(dr_cpf_parse(f.body, f.hdr.length, &cpf), DR_OK);
    assert_non_null(dr_cpf_find(&cpf, DR_CPF_LIST_SERVICES));
}

static void test_get_every_assembly(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        uint16_t inst = DR_ASM_DEFAULT_INSTANCE(a);
        assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, inst, 3, NULL, 0), DR_OK);
        assert_int_equal(f.rsp.data_len, dr_asm_info((dr_asm_t)a)->size);
        assert_memory_equal(f.rsp.data, f.sim.img.buf[a], f.rsp.data_len);
        assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, inst, 4, NULL, 0), DR_OK);
        assert_int_equal(f.rsp.data_len, 2);
        assert_int_equal(dr_get_le16(f.rsp.data), dr_asm_info((dr_asm_t)a)->size);
    }
    /* The robot's version is in io_state. */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 101, 3, NULL, 0), DR_OK);
    dr_io_state_t io;
    assert_int_equal(dr_io_state_decode(f.rsp.data, f.rsp.data_len, &io), DR_OK);
    assert_int_equal(io.version.major, 2);
    assert_int_equal(io.version.minor, 12);
    assert_int_equal(io.version.patch, 3);
}

static void test_set_o2t_and_echo(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    dr_int_gpr_t in;
    for (int i = 0; i < 24; i++)
        in.reg[i] = i * 1000 - 7;
    uint8_t img[96];
    assert_int_equal(dr_asm_encode(DR_ASM_INT_IN, &in, img, sizeof img), DR_OK);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 109, 3, img, 96), DR_OK);
    assert_int_equal(f.rsp.data_len, 0);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 109, 3, NULL, 0), DR_OK);
    assert_memory_equal(f.rsp.data, img, 96);
    /* int_in echoes to int_out at once. */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 105, 3, NULL, 0), DR_OK);
    assert_memory_equal(f.rsp.data, img, 96);

    /* io_control shows up in io_state. */
    dr_io_control_t ctl = {.cb_do = 0xA5A5, .tool_do = 0x21, .ao_type = {true, false},
                           .ao = {3.5f, -1.25f}};
    uint8_t c[12];
    assert_int_equal(dr_io_control_encode(&ctl, c, sizeof c), DR_OK);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 107, 3, c, 12), DR_OK);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 101, 3, NULL, 0), DR_OK);
    dr_io_state_t io;
    assert_int_equal(dr_io_state_decode(f.rsp.data, f.rsp.data_len, &io), DR_OK);
    assert_int_equal(io.cb_do, 0xA5A5);
    assert_int_equal(io.tool_do, 0x21);
    assert_true(io.aio_type.ao0);
    assert_false(io.aio_type.ao1);
    assert_true(io.ao[0] == 3.5f);
    assert_true(io.ao[1] == -1.25f);
    /* ...and stays there after the model runs. */
    drsim_run(&f.sim, T0 + 50 * MS, fx_capture, &f);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 101, 3, NULL, 0), DR_OK);
    assert_int_equal(dr_io_state_decode(f.rsp.data, f.rsp.data_len, &io), DR_OK);
    assert_int_equal(io.cb_do, 0xA5A5);
}

/* --refuse-identity: Get_Attributes_All refused with 0x08, the single
 * attributes still answer; --vendor-id: the vendor it says. */
static void test_identity_refused(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.refuse_identity = true;
    cfg.vendor_id = 1573;
    fx_init(&f, &cfg);
    fx_register(&f);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTES_ALL, 1, 1, -1, NULL, 0),
                     DR_CIP(0x08, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 1, 1, 1, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le16(f.rsp.data), 1573);
}

static void test_no_echo(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.echo = false;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t bits[8] = {1, 2, 3, 4, 5, 6, 7, 8};
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 108, 3, bits, 8), DR_OK);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 104, 3, NULL, 0), DR_OK);
    uint8_t zero[8] = {0};
    assert_memory_equal(f.rsp.data, zero, 8);
}

static void test_errors(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint8_t big[160] = {0};
    /* Set on a T->O assembly: attribute not settable. */
    for (uint16_t inst = 101; inst <= 106; inst++)
        assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, inst, 3, big,
                                dr_asm_info((dr_asm_t)(inst - 101))->size),
                         DR_CIP(0x0E, 0));
    /* Wrong sizes. */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 107, 3, big, 11), DR_CIP(0x13, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 107, 3, big, 13), DR_CIP(0x15, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 110, 3, big, 0), DR_CIP(0x13, 0));
    /* Size attribute is read-only; unknown attribute. */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 107, 4, big, 2), DR_CIP(0x0E, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 107, 9, NULL, 0), DR_CIP(0x14, 0));
    /* Unknown instance, unknown class. */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 111, 3, NULL, 0), DR_CIP(0x05, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 300, 3, NULL, 0), DR_CIP(0x05, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 0x77, 1, 1, NULL, 0), DR_CIP(0x05, 0));
    /* Unsupported service. */
    assert_int_equal(fx_req(&f, 0x4B, 4, 101, 3, NULL, 0), DR_CIP(0x08, 0));
    assert_int_equal(fx_req(&f, 0x05, 1, 1, -1, NULL, 0), DR_CIP(0x08, 0));
    /* A path segment drsim does not know (a symbolic segment). */
    static const uint8_t sym[] = {0x0E, 0x02, 0x91, 0x02, 'a', 'b'};
    assert_int_equal(fx_rr(&f, sym, sizeof sym, NULL), DR_CIP(0x04, 0));
    assert_int_equal(f.rsp.service, 0x8E);
    /* A path that says it is longer than the request. */
    static const uint8_t lying[] = {0x0E, 0x09, 0x20, 0x04};
    assert_int_equal(fx_rr(&f, lying, sizeof lying, NULL), DR_CIP(0x04, 0));
}

static void test_identity(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTES_ALL, 1, 1, -1, NULL, 0), DR_OK);
    dr_identity_t id;
    assert_int_equal(dr_identity_parse_all(f.rsp.data, f.rsp.data_len, &id), DR_OK);
    assert_int_equal(id.vendor, DRSIM_VENDOR_ID);
    assert_int_equal(id.device_type, 0x0C);
    assert_int_equal(id.rev_major, 2);
    assert_string_equal(id.product_name, DRSIM_PRODUCT_NAME);
    assert_int_equal(id.status, 0x0030); /* no I/O connection */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 1, 1, 7, NULL, 0), DR_OK);
    assert_int_equal(f.rsp.data[0], strlen(DRSIM_PRODUCT_NAME));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 1, 1, 6, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le32(f.rsp.data), id.serial);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 1, 1, 42, NULL, 0), DR_CIP(0x14, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 1, 1, 1, "ab", 2), DR_CIP(0x0E, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 1, 2, 1, NULL, 0), DR_CIP(0x05, 0));
    /* Class attribute: max instance of the Assembly class. */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 0, 2, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le16(f.rsp.data), 110);
}

/* An Unconnected Send to the Connection Manager with a route path, as a
 * PLC sends it: the embedded request is answered. */
static void test_unconnected_send(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint8_t path[8], inner[32], data[64], req[96];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, 4, 102, 3);
    size_t pl = w.len;
    dr_wr_init(&w, inner, sizeof inner);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, pl, NULL, 0);
    size_t il = w.len;
    static const uint8_t route[] = {0x01, 0x00}; /* backplane, slot 0 */
    dr_wr_init(&w, data, sizeof data);
    dr_ucmm_send_write(&w, inner, il, route, sizeof route);
    size_t dl = w.len;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, 6, 1, -1);
    pl = w.len;
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, path, pl, data, dl);
    assert_int_equal(fx_rr(&f, req, w.len, NULL), DR_OK);
    assert_int_equal(f.rsp.service, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE | DR_CIP_REPLY);
    assert_int_equal(f.rsp.data_len, 144);
    assert_memory_equal(f.rsp.data, f.sim.img.buf[DR_ASM_JOINT_STATE], 144);

    /* The embedded error comes back as it is. */
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, 4, 250, 3);
    pl = w.len;
    dr_wr_init(&w, inner, sizeof inner);
    dr_cip_req_write(&w, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, path, pl, NULL, 0);
    il = w.len;
    dr_wr_init(&w, data, sizeof data);
    dr_ucmm_send_write(&w, inner, il, route, sizeof route);
    dl = w.len;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, 6, 1, -1);
    pl = w.len;
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, path, pl, data, dl);
    assert_int_equal(fx_rr(&f, req, w.len, NULL), DR_CIP(0x05, 0));

    /* A truncated Unconnected Send: parameter error. */
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_UNCONNECTED_SEND, path, pl, data, 3);
    assert_int_equal(fx_rr(&f, req, w.len, NULL), DR_CIP(0x01, 0x0205));
}

static void test_instance_override(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.instance[DR_ASM_JOINT_STATE] = 150;
    fx_init(&f, &cfg);
    fx_register(&f);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 150, 3, NULL, 0), DR_OK);
    assert_int_equal(f.rsp.data_len, 144);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 102, 3, NULL, 0), DR_CIP(0x05, 0));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_register_session),
        cmocka_unit_test(test_session_checks),
        cmocka_unit_test(test_list_identity),
        cmocka_unit_test(test_get_every_assembly),
        cmocka_unit_test(test_set_o2t_and_echo),
        cmocka_unit_test(test_no_echo),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_identity),
        cmocka_unit_test(test_identity_refused),
        cmocka_unit_test(test_unconnected_send),
        cmocka_unit_test(test_instance_override),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
