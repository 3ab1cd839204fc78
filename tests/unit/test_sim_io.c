/* SPDX-License-Identifier: MIT */
/* drsim adapter: Forward Open/Close and Class 1 I/O. */
#include "test_sim_support.h"

static uint16_t next_serial = 1;

/* A Forward Open for O->T point `o2t`, T->O point `t2o`, sizes as given. */
static dr_fwd_open_t fo_make(uint16_t o2t, uint16_t t2o, uint16_t o2t_size,
                             uint16_t t2o_size, uint32_t rpi_us, uint8_t *path,
                             size_t cap)
{
    dr_fwd_open_t fo;
    memset(&fo, 0, sizeof fo);
    fo.priority_tick = 0x0A;
    fo.timeout_ticks = 0x0E;
    fo.t2o_cid = 0x7700 + next_serial;
    fo.conn_serial = next_serial++;
    fo.vendor = 0x1234;
    fo.orig_serial = 0xCAFE;
    fo.timeout_mult = 0; /* timeout = 4 x RPI */
    fo.o2t_rpi_us = fo.t2o_rpi_us = rpi_us;
    fo.o2t.size = o2t_size;
    fo.o2t.type = DR_CONN_TYPE_P2P;
    fo.t2o.size = t2o_size;
    fo.t2o.type = DR_CONN_TYPE_P2P;
    fo.transport = 0x01;
    fo.path = path;
    fo.path_len = dr_conn_path_write(path, cap, 1, o2t, t2o);
    return fo;
}

static dr_status_t fo_send(fx_t *f, const dr_fwd_open_t *fo, const dr_sockaddr_t *t2o)
{
    uint8_t path[8], data[128], req[160];
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, 6, 1, -1);
    size_t pl = w.len;
    dr_wr_init(&w, data, sizeof data);
    dr_fwd_open_write(&w, fo);
    size_t dl = w.len;
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, fo->large ? DR_CIP_SVC_LARGE_FORWARD_OPEN : DR_CIP_SVC_FORWARD_OPEN,
                     path, pl, data, dl);
    return fx_rr(f, req, w.len, t2o);
}

static dr_status_t fc_send(fx_t *f, const dr_fwd_open_t *fo)
{
    uint8_t path[8], data[64], req[96];
    dr_fwd_close_t fc = {fo->priority_tick, fo->timeout_ticks, fo->conn_serial,
                         fo->vendor, fo->orig_serial, fo->path, fo->path_len};
    dr_wr_t w;
    dr_wr_init(&w, path, sizeof path);
    dr_epath_write(&w, 6, 1, -1);
    size_t pl = w.len;
    dr_wr_init(&w, data, sizeof data);
    dr_fwd_close_write(&w, &fc);
    size_t dl = w.len;
    dr_wr_init(&w, req, sizeof req);
    dr_cip_req_write(&w, DR_CIP_SVC_FORWARD_CLOSE, path, pl, data, dl);
    return fx_rr(f, req, w.len, NULL);
}

/* An O->T datagram for connection `cid`. */
static size_t o2t_packet(uint8_t *buf, size_t cap, uint32_t cid, uint32_t encap_seq,
                         uint16_t cip_seq, bool run, const uint8_t *data, size_t len)
{
    dr_io_frame_t fr = {.cid = cid, .encap_seq = encap_seq, .cip_seq = cip_seq,
                        .data = data, .data_len = len, .run_idle = run ? 1u : 0u,
                        .has_run_idle = true};
    size_t n = 0;
    assert_int_equal(dr_io_frame_write(buf, cap, &fr, &n), DR_OK);
    return n;
}

static void test_forward_open_accepted(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(109, 105, 96 + 6, 96 + 2, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
    assert_int_equal(r.t2o_cid, fo.t2o_cid);
    assert_int_equal(r.conn_serial, fo.conn_serial);
    assert_int_equal(r.vendor, fo.vendor);
    assert_int_equal(r.orig_serial, fo.orig_serial);
    assert_int_equal(r.o2t_api_us, 10000);
    assert_int_equal(r.t2o_api_us, 10000);
    assert_int_not_equal(r.o2t_cid, 0);
    /* Our UDP address in a 0x8000 item, after the data item. */
    assert_int_equal(f.cpf.count, 3);
    assert_int_equal(f.cpf_extra, 0);
    assert_int_equal(f.cpf.item[2].type, DR_CPF_SOCKADDR_O2T);
    dr_sockaddr_t sa;
    assert_int_equal(dr_cpf_sockaddr_parse(&f.cpf.item[2], &sa), DR_OK);
    assert_int_equal(sa.addr, 0x7F000002u);
    assert_int_equal(sa.port, 2222);
    assert_int_equal(drsim_conn_count(&f.sim), 1);
    assert_int_equal(drsim_identity_status(&f.sim) & 0x1, 1); /* owned */

    /* T->O: right away, then every API, to the originator at 2222. */
    drsim_run(&f.sim, T0, fx_capture, &f);
    assert_int_equal(f.sent, 1);
    assert_int_equal(f.sent_to.addr, 0x7F000001u);
    assert_int_equal(f.sent_to.port, 2222);
    dr_io_frame_t io;
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    assert_int_equal(io.cid, fo.t2o_cid);
    assert_int_equal(io.data_len, 96);
    uint32_t seq0 = io.encap_seq;
    uint16_t cseq0 = io.cip_seq;
    assert_int_equal(drsim_next_deadline(&f.sim), T0 + 10 * MS);
    drsim_run(&f.sim, T0 + 5 * MS, fx_capture, &f);
    assert_int_equal(f.sent, 1);
    drsim_run(&f.sim, T0 + 10 * MS, fx_capture, &f);
    assert_int_equal(f.sent, 2);
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    assert_int_equal(io.encap_seq, seq0 + 1);
    assert_int_equal(io.cip_seq, (uint16_t)(cseq0 + 1));

    /* O->T in run mode lands in int_in and echoes to int_out. */
    uint8_t data[96], pkt[160];
    for (int i = 0; i < 96; i++)
        data[i] = (uint8_t)(i + 1);
    size_t n = o2t_packet(pkt, sizeof pkt, r.o2t_cid, 1, 1, true, data, 96);
    dr_sockaddr_t from = {0x7F000001u, 2222};
    drsim_io_receive(&f.sim, T0 + 11 * MS, &from, pkt, n);
    assert_memory_equal(f.sim.img.buf[DR_ASM_INT_IN], data, 96);
    assert_memory_equal(f.sim.img.buf[DR_ASM_INT_OUT], data, 96);
    assert_int_equal(drsim_identity_status(&f.sim) >> 4, 6); /* run */
    drsim_run(&f.sim, T0 + 20 * MS, fx_capture, &f);
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    assert_memory_equal(io.data, data, 96);

    /* Forward Close removes it; a second close finds nothing. */
    assert_int_equal(fc_send(&f, &fo), DR_OK);
    assert_int_equal(drsim_conn_count(&f.sim), 0);
    assert_int_equal(fc_send(&f, &fo), DR_CIP(0x01, 0x0107));
    unsigned sent = f.sent;
    drsim_run(&f.sim, T0 + 40 * MS, fx_capture, &f);
    assert_int_equal(f.sent, sent);
}

static void test_forward_open_sockaddr_and_large(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint8_t path[16];
    /* 0x5B with 32-bit parameters; T->O to an announced address/port. */
    dr_fwd_open_t fo = fo_make(DRSIM_HB_INPUT_ONLY, 102, 6, 146, 1000, path, sizeof path);
    fo.large = true;
    dr_sockaddr_t t2o = {0x0A000005u, 2300};
    assert_int_equal(fo_send(&f, &fo, &t2o), DR_OK);
    assert_int_equal(f.rsp.service, DR_CIP_SVC_LARGE_FORWARD_OPEN | DR_CIP_REPLY);
    drsim_run(&f.sim, T0, fx_capture, &f);
    assert_int_equal(f.sent_to.addr, 0x0A000005u);
    assert_int_equal(f.sent_to.port, 2300);
    dr_io_frame_t io;
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    assert_int_equal(io.data_len, 144);
    /* Input-only connections do not own anything. */
    assert_int_equal(drsim_identity_status(&f.sim) & 0x1, 0);
    /* A zero address in 0x8001 means the originator's own. */
    dr_fwd_open_t fo2 = fo_make(DRSIM_HB_INPUT_ONLY, 101, 2, 38, 1000, path, sizeof path);
    dr_sockaddr_t port_only = {0, 2400};
    assert_int_equal(fo_send(&f, &fo2, &port_only), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
    drsim_conn_t *c = drsim_conn_by_o2t(&f.sim, r.o2t_cid);
    assert_non_null(c);
    assert_int_equal(c->t2o_dest.addr, 0x7F000001u);
    assert_int_equal(c->t2o_dest.port, 2400);
    assert_false(c->o2t_run_idle); /* size 2: modeless heartbeat */
}

static void test_forward_open_refused(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.max_conns = 2;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t path[16];
    dr_fwd_open_t fo;

    /* Wrong sizes: 0x0109 with the wanted size as the second word. */
    fo = fo_make(107, 101, 12 + 2, 38, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0109));
    assert_int_equal(f.rsp.ext_count, 2);
    assert_int_equal(f.rsp.ext[1], 18);
    /* The failure data names the connection. */
    assert_true(f.rsp.data_len >= 8);
    assert_int_equal(dr_get_le16(f.rsp.data), fo.conn_serial);
    fo = fo_make(107, 102, 18, 144, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0109));
    assert_int_equal(f.rsp.ext[1], 146);
    fo = fo_make(DRSIM_HB_INPUT_ONLY, 102, 4, 146, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0109));
    /* RPI out of range. */
    fo = fo_make(107, 101, 18, 38, 999, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0111));
    fo = fo_make(107, 101, 18, 38, 10000001, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0111));
    /* Bad paths: a T->O point as O->T, an O->T point as T->O, unknown. */
    fo = fo_make(101, 102, 42, 146, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0315));
    fo = fo_make(107, 108, 18, 10, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0315));
    fo = fo_make(107, 555, 18, 10, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0315));
    /* Not class 1. */
    fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    fo.transport = 0xA3;
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0103));
    /* Multicast T->O is not offered. */
    fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    fo.t2o.type = DR_CONN_TYPE_MULTICAST;
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0124));
    /* Any configuration instance without data is fine. */
    fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    fo.path_len = dr_conn_path_write(path, sizeof path, 0x97, 107, 101);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    dr_fwd_open_t owner = fo;
    /* The same triad again: duplicate. */
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0100));
    /* Another owner for io_control: ownership conflict. */
    fo = fo_make(107, 103, 18, 98, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0106));
    /* Second connection fits, the third does not. */
    fo = fo_make(108, 104, 14, 10, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    fo = fo_make(DRSIM_HB_INPUT_ONLY, 104, 6, 10, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0113));
    /* After a close the owner's place is free again. */
    assert_int_equal(fc_send(&f, &owner), DR_OK);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
}

static void test_refuse_fault(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.refuse_fo = 0x0109;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(110, 106, 102, 98, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0109));
    assert_int_equal(f.rsp.ext_count, 2);
    assert_int_equal(f.rsp.ext[1], 102);
    f.sim.cfg.refuse_fo = 0x0113;
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0113));
    assert_int_equal(f.rsp.ext_count, 1);
    assert_int_equal(drsim_conn_count(&f.sim), 0);
}

/* What a controller's EDS decides: the configuration instance and the
 * heartbeat points; listen-only needs a connection that produces its T->O. */
static void test_connection_points(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.config_instance = 199;
    cfg.hb_input_only = 0; /* no input-only */
    cfg.hb_listen_only = 252;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t path[16];
    /* Configuration instance 1 where the EDS says 199. */
    dr_fwd_open_t fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0129));
    fo.path_len = dr_conn_path_write(path, sizeof path, 199, 107, 101);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    /* Input-only is not offered: 198 is no consuming point here. */
    fo = fo_make(DRSIM_HB_INPUT_ONLY, 102, 6, 146, 10000, path, sizeof path);
    fo.path_len = dr_conn_path_write(path, sizeof path, 199, DRSIM_HB_INPUT_ONLY, 102);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x012A));
    /* Listen-only to joint_state, which nobody produces: 0x0119. */
    fo = fo_make(252, 102, 6, 146, 10000, path, sizeof path);
    fo.path_len = dr_conn_path_write(path, sizeof path, 199, 252, 102);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0119));
    /* Listen-only to io_state, which the owner above produces. */
    fo = fo_make(252, 101, 6, 38, 10000, path, sizeof path);
    fo.path_len = dr_conn_path_write(path, sizeof path, 199, 252, 101);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
    drsim_conn_t *c = drsim_conn_by_o2t(&f.sim, r.o2t_cid);
    assert_non_null(c);
    assert_true(c->listen_only);
    assert_int_equal(c->o2t_asm, -1);
    /* A listen-only connection does not make another one possible. */
    dr_fwd_open_t lo2 = fo_make(252, 103, 6, 98, 10000, path, sizeof path);
    lo2.path_len = dr_conn_path_write(path, sizeof path, 199, 252, 103);
    assert_int_equal(fo_send(&f, &lo2, NULL), DR_CIP(0x01, 0x0119));
    assert_int_equal(drsim_conn_count(&f.sim), 2);
}

/* Forward Opens fo (ok), returns the O->T connection ID. */
static uint32_t fo_open(fx_t *f, const dr_fwd_open_t *fo)
{
    assert_int_equal(fo_send(f, fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f->rsp.data, f->rsp.data_len, &r), DR_OK);
    return r.o2t_cid;
}

/* A heartbeat (run/idle header, no data) for connection `cid` at t. */
static void send_heartbeat(fx_t *f, uint32_t cid, uint32_t seq, uint64_t t)
{
    uint8_t pkt[64], none[1] = {0};
    size_t n = o2t_packet(pkt, sizeof pkt, cid, seq, (uint16_t)seq, true, none, 0);
    dr_sockaddr_t from = {0x7F000001u, 2222};
    drsim_io_receive(&f->sim, t, &from, pkt, n);
}

/* Listen-only connections end with the last connection producing their
 * T->O assembly, by Forward Close or by timeout (as OpENer's do), and not
 * while another owner or input-only connection still produces it. */
static void test_listen_only_follows_its_producer(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint8_t p1[16], p2[16], p3[16], p4[16], p5[16];
    /* io_state: an owner, an input-only and a listen-only connection */
    dr_fwd_open_t own = fo_make(107, 101, 18, 38, 10000, p1, sizeof p1);
    uint32_t own_cid = fo_open(&f, &own);
    dr_fwd_open_t in1 = fo_make(DRSIM_HB_INPUT_ONLY, 101, 6, 38, 10000, p2, sizeof p2);
    uint32_t in1_cid = fo_open(&f, &in1);
    dr_fwd_open_t lo1 = fo_make(DRSIM_HB_LISTEN_ONLY, 101, 6, 38, 10000, p3, sizeof p3);
    uint32_t lo1_cid = fo_open(&f, &lo1);
    /* joint_state: an input-only and a listen-only connection */
    dr_fwd_open_t in2 = fo_make(DRSIM_HB_INPUT_ONLY, 102, 6, 146, 10000, p4, sizeof p4);
    uint32_t in2_cid = fo_open(&f, &in2);
    dr_fwd_open_t lo2 = fo_make(DRSIM_HB_LISTEN_ONLY, 102, 6, 146, 10000, p5, sizeof p5);
    uint32_t lo2_cid = fo_open(&f, &lo2);
    assert_int_equal(drsim_conn_count(&f.sim), 5);
    /* the owner closes; the input-only one still produces io_state */
    assert_int_equal(fc_send(&f, &own), DR_OK);
    assert_null(drsim_conn_by_o2t(&f.sim, own_cid));
    assert_non_null(drsim_conn_by_o2t(&f.sim, lo1_cid));
    /* the last producer of io_state closes: its listener goes too, the
     * joint_state ones stay */
    assert_int_equal(fc_send(&f, &in1), DR_OK);
    assert_null(drsim_conn_by_o2t(&f.sim, in1_cid));
    assert_null(drsim_conn_by_o2t(&f.sim, lo1_cid));
    assert_non_null(drsim_conn_by_o2t(&f.sim, in2_cid));
    assert_non_null(drsim_conn_by_o2t(&f.sim, lo2_cid));
    assert_int_equal(drsim_conn_count(&f.sim), 2);
    /* by timeout: joint_state's producer never sends (closed after the
     * first-packet grace); its listener, alive by its own heartbeats
     * until T0 + 10030 ms (4 x RPI), is closed with it */
    send_heartbeat(&f, lo2_cid, 1, T0 + 9990 * MS);
    drsim_run(&f.sim, T0 + 9999 * MS, fx_capture, &f);
    assert_int_equal(drsim_conn_count(&f.sim), 2);
    drsim_run(&f.sim, T0 + 10000 * MS, fx_capture, &f);
    assert_null(drsim_conn_by_o2t(&f.sim, in2_cid));
    assert_null(drsim_conn_by_o2t(&f.sim, lo2_cid));
    assert_int_equal(drsim_conn_count(&f.sim), 0);
    /* a listen-only Forward Close leaves its producer alone */
    own = fo_make(107, 101, 18, 38, 10000, p1, sizeof p1);
    own_cid = fo_open(&f, &own);
    lo1 = fo_make(DRSIM_HB_LISTEN_ONLY, 101, 6, 38, 10000, p3, sizeof p3);
    lo1_cid = fo_open(&f, &lo1);
    assert_int_equal(fc_send(&f, &lo1), DR_OK);
    assert_null(drsim_conn_by_o2t(&f.sim, lo1_cid));
    assert_non_null(drsim_conn_by_o2t(&f.sim, own_cid));
}

/* Opens io_control/io_state at 10 ms, returns the O->T connection ID. */
static uint32_t open_io(fx_t *f, uint8_t mult)
{
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    fo.timeout_mult = mult;
    assert_int_equal(fo_send(f, &fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f->rsp.data, f->rsp.data_len, &r), DR_OK);
    return r.o2t_cid;
}

static void send_ctl(fx_t *f, uint32_t cid, uint32_t eseq, uint16_t cseq, bool run,
                     uint16_t cb_do, uint64_t t)
{
    dr_io_control_t ctl = {.cb_do = cb_do};
    uint8_t data[12], pkt[64];
    assert_int_equal(dr_io_control_encode(&ctl, data, sizeof data), DR_OK);
    size_t n = o2t_packet(pkt, sizeof pkt, cid, eseq, cseq, run, data, 12);
    dr_sockaddr_t from = {0x7F000001u, 2222};
    drsim_io_receive(&f->sim, t, &from, pkt, n);
}

static uint16_t io_cb_do(fx_t *f)
{
    dr_io_state_t io;
    assert_int_equal(dr_io_state_decode(f->sim.img.buf[DR_ASM_IO_STATE], 36, &io), DR_OK);
    return io.cb_do;
}

static void test_sequence_handling(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint32_t cid = open_io(&f, 2);
    drsim_conn_t *c = drsim_conn_by_o2t(&f.sim, cid);
    assert_non_null(c);
    /* The first packet is taken whatever its numbers (here past 2^31). */
    send_ctl(&f, cid, 0x90000000u, 0xFFFF, true, 0x0001, T0 + MS);
    assert_int_equal(io_cb_do(&f), 0x0001);
    /* 16-bit wrap: 0x0000 is newer than 0xFFFF. */
    send_ctl(&f, cid, 0x90000001u, 0x0000, true, 0x0002, T0 + 2 * MS);
    assert_int_equal(io_cb_do(&f), 0x0002);
    /* Same CIP sequence count: not new data, not applied. */
    send_ctl(&f, cid, 0x90000002u, 0x0000, true, 0x0003, T0 + 3 * MS);
    assert_int_equal(io_cb_do(&f), 0x0002);
    /* An older encapsulation sequence number: discarded whole. */
    send_ctl(&f, cid, 0x90000001u, 0x0001, true, 0x0004, T0 + 4 * MS);
    assert_int_equal(io_cb_do(&f), 0x0002);
    assert_int_equal(c->stale, 1);
    /* Idle: the packet keeps the connection alive but is not applied. */
    send_ctl(&f, cid, 0x90000003u, 0x0001, false, 0x0005, T0 + 5 * MS);
    assert_int_equal(io_cb_do(&f), 0x0002);
    assert_int_equal(drsim_identity_status(&f.sim) >> 4, 7); /* all idle */
    send_ctl(&f, cid, 0x90000004u, 0x0002, true, 0x0006, T0 + 6 * MS);
    assert_int_equal(io_cb_do(&f), 0x0006);
    /* Wrong data length, unknown connection ID: ignored. */
    uint8_t pkt[64], data[13] = {0xFF};
    size_t n = o2t_packet(pkt, sizeof pkt, cid, 0x90000005u, 3, true, data, 13);
    dr_sockaddr_t from = {0x7F000001u, 2222};
    drsim_io_receive(&f.sim, T0 + 7 * MS, &from, pkt, n);
    assert_int_equal(io_cb_do(&f), 0x0006);
    n = o2t_packet(pkt, sizeof pkt, cid + 1, 0x90000005u, 3, true, data, 12);
    drsim_io_receive(&f.sim, T0 + 7 * MS, &from, pkt, n);
    assert_int_equal(io_cb_do(&f), 0x0006);
    /* Garbage is no crash. */
    for (size_t len = 0; len < n; len++)
        drsim_io_receive(&f.sim, T0 + 7 * MS, &from, pkt, len);
    assert_int_equal(c->applied, 3);
}

static void test_timeouts(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    /* No O->T at all: timed out after the 10 s grace (an owner is held
     * for its originator, see test_owner_takeover). */
    uint32_t cid = open_io(&f, 0);
    drsim_run(&f.sim, T0 + 9999 * MS, fx_capture, &f);
    assert_false(drsim_conn_by_o2t(&f.sim, cid)->held);
    drsim_run(&f.sim, T0 + 10000 * MS, fx_capture, &f);
    assert_true(drsim_conn_by_o2t(&f.sim, cid)->held);
    /* After O->T: RPI x (4 << 1) = 80 ms of silence. */
    uint32_t old = cid;
    cid = open_io(&f, 1); /* opened at T0, taking the held one over */
    assert_null(drsim_conn_by_o2t(&f.sim, old));
    send_ctl(&f, cid, 1, 1, true, 0, T0 + 100 * MS);
    drsim_run(&f.sim, T0 + 179 * MS, fx_capture, &f);
    assert_false(drsim_conn_by_o2t(&f.sim, cid)->held);
    assert_true(drsim_next_deadline(&f.sim) <= T0 + 180 * MS);
    drsim_run(&f.sim, T0 + 180 * MS, fx_capture, &f);
    assert_true(drsim_conn_by_o2t(&f.sim, cid)->held);
    assert_int_equal(drsim_conn_count(&f.sim), 1);
    /* An input-only connection is not held: it closes. */
    uint8_t path[16];
    dr_fwd_open_t in = fo_make(DRSIM_HB_INPUT_ONLY, 102, 6, 146, 10000, path, sizeof path);
    uint32_t in_cid = fo_open(&f, &in);
    drsim_run(&f.sim, T0 + 10000 * MS, fx_capture, &f);
    assert_null(drsim_conn_by_o2t(&f.sim, in_cid));
}

/* Issue 19: an exclusive owner whose originator went silent is held, as an
 * ODVA adapter holds it (OpENer, GetExclusiveOwnerConnection): it produces
 * nothing and takes nothing, other originators are refused with 0x0106,
 * and only the same vendor ID + originator serial may take it over (the
 * held one is closed). An established owner refuses its own originator
 * too. --owner-hold frees a held one after a while; a Forward Close at
 * once. */
static void test_owner_takeover(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.max_conns = 2;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t p1[16], p2[16], p3[16];
    dr_fwd_open_t a = fo_make(107, 101, 18, 38, 10000, p1, sizeof p1);
    a.timeout_mult = 1; /* 80 ms */
    uint32_t cid = fo_open(&f, &a);
    send_ctl(&f, cid, 1, 1, true, 0x0001, T0 + 10 * MS);
    drsim_run(&f.sim, T0 + 89 * MS, fx_capture, &f);
    assert_false(drsim_conn_by_o2t(&f.sim, cid)->held);
    assert_int_equal(drsim_identity_status(&f.sim) & 1u, 1); /* owned */
    /* the originator vanishes: held, no longer owned, not producing */
    drsim_run(&f.sim, T0 + 90 * MS, fx_capture, &f);
    drsim_conn_t *c = drsim_conn_by_o2t(&f.sim, cid);
    assert_non_null(c);
    assert_true(c->held);
    assert_int_equal(drsim_identity_status(&f.sim), 0x30); /* no I/O connection */
    assert_int_equal(drsim_next_deadline(&f.sim), f.sim.next_model_ns); /* held for good */
    unsigned sent = f.sent;
    drsim_run(&f.sim, T0 + 500 * MS, fx_capture, &f);
    assert_int_equal(f.sent, sent);
    /* its O->T packets do not bring it back */
    send_ctl(&f, cid, 2, 2, true, 0x0002, T0 + 510 * MS);
    assert_true(c->held);
    assert_int_equal(io_cb_do(&f), 0x0001);
    /* another originator: refused, by serial or by vendor */
    dr_fwd_open_t b = fo_make(107, 101, 18, 38, 10000, p2, sizeof p2);
    b.orig_serial = 0xBEEF;
    assert_int_equal(fo_send(&f, &b, NULL), DR_CIP(0x01, 0x0106));
    b = fo_make(107, 103, 18, 98, 10000, p2, sizeof p2);
    b.vendor = 0x4321;
    assert_int_equal(fo_send(&f, &b, NULL), DR_CIP(0x01, 0x0106));
    /* the held one keeps its slot: one more fits (max 2), not two */
    b = fo_make(DRSIM_HB_INPUT_ONLY, 102, 6, 146, 10000, p2, sizeof p2);
    b.orig_serial = 0xBEEF;
    assert_int_equal(fo_send(&f, &b, NULL), DR_OK);
    b = fo_make(DRSIM_HB_INPUT_ONLY, 103, 6, 98, 10000, p3, sizeof p3);
    b.orig_serial = 0xBEEF;
    assert_int_equal(fo_send(&f, &b, NULL), DR_CIP(0x01, 0x0113));
    /* the same originator, with a new connection serial: taken over, the
     * held one closed, its slot given to the new one */
    a = fo_make(107, 101, 18, 38, 10000, p1, sizeof p1);
    uint32_t cid2 = fo_open(&f, &a);
    assert_null(drsim_conn_by_o2t(&f.sim, cid));
    assert_false(drsim_conn_by_o2t(&f.sim, cid2)->held);
    assert_int_equal(drsim_conn_count(&f.sim), 2);
    /* established: even its own originator is refused */
    dr_fwd_open_t again = fo_make(107, 101, 18, 38, 10000, p3, sizeof p3);
    assert_int_equal(fo_send(&f, &again, NULL), DR_CIP(0x01, 0x0106));
    /* a held one closes by Forward Close */
    drsim_run(&f.sim, T0 + 20000 * MS, fx_capture, &f);
    assert_true(drsim_conn_by_o2t(&f.sim, cid2)->held);
    assert_int_equal(fc_send(&f, &a), DR_OK);
    assert_null(drsim_conn_by_o2t(&f.sim, cid2));
    /* --owner-hold: freed after it */
    cfg.owner_hold_ns = 5000 * MS;
    fx_init(&f, &cfg);
    fx_register(&f);
    a = fo_make(107, 101, 18, 38, 10000, p1, sizeof p1);
    cid = fo_open(&f, &a); /* no O->T: held after the 10 s grace */
    drsim_run(&f.sim, T0 + 10000 * MS, fx_capture, &f);
    assert_true(drsim_conn_by_o2t(&f.sim, cid)->held);
    drsim_run(&f.sim, T0 + 14999 * MS, fx_capture, &f);
    assert_non_null(drsim_conn_by_o2t(&f.sim, cid));
    assert_true(drsim_next_deadline(&f.sim) <= T0 + 15000 * MS);
    drsim_run(&f.sim, T0 + 15000 * MS, fx_capture, &f);
    assert_null(drsim_conn_by_o2t(&f.sim, cid));
    b = fo_make(107, 101, 18, 38, 10000, p2, sizeof p2);
    b.orig_serial = 0xBEEF;
    assert_int_equal(fo_send(&f, &b, NULL), DR_OK);
}

static void test_drop_and_stop(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.drop_pct = 100;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint32_t cid = open_io(&f, 7);
    send_ctl(&f, cid, 1, 1, true, 0x00FF, T0 + MS);
    assert_int_equal(io_cb_do(&f), 0);
    drsim_run(&f.sim, T0 + 100 * MS, fx_capture, &f);
    assert_int_equal(f.sent, 0);

    /* Half of them, the same ones for the same seed. */
    unsigned counts[2];
    for (int k = 0; k < 2; k++) {
        static fx_t g;
        cfg.drop_pct = 50;
        fx_init(&g, &cfg);
        fx_register(&g);
        open_io(&g, 7);
        for (unsigned i = 0; i < 200; i++)
            drsim_run(&g.sim, T0 + i * 10 * MS, fx_capture, &g);
        counts[k] = g.sent;
    }
    assert_int_equal(counts[0], counts[1]);
    assert_true(counts[0] > 60 && counts[0] < 140);

    /* --stop-producing-after: T->O ends, the connection stays. */
    cfg.drop_pct = 0;
    cfg.stop_producing_ns = 50 * MS;
    fx_init(&f, &cfg);
    fx_register(&f);
    cid = open_io(&f, 7);
    for (unsigned i = 0; i < 20; i++)
        drsim_run(&f.sim, T0 + i * 10 * MS, fx_capture, &f);
    assert_int_equal(f.sent, 5);
    assert_non_null(drsim_conn_by_o2t(&f.sim, cid));
}

/* A late loop skips the periods it missed instead of bunching them. */
static void test_produce_grid(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    open_io(&f, 7);
    drsim_run(&f.sim, T0, fx_capture, &f);
    drsim_run(&f.sim, T0 + 35 * MS, fx_capture, &f);
    assert_int_equal(f.sent, 2);
    drsim_run(&f.sim, T0 + 36 * MS, fx_capture, &f);
    assert_int_equal(f.sent, 2);
    uint64_t next = T0 + 40 * MS;
    assert_true(drsim_next_deadline(&f.sim) <= next);
    drsim_run(&f.sim, next, fx_capture, &f);
    assert_int_equal(f.sent, 3);
}

/* Class 1 data is the model's step at the moment it is produced: at
 * every 10 ms step for 4 s (through STANDBY into OPERATING, the arm
 * moving), the joint_state packet drsim_run sends equals an explicit Get
 * right after it. Before, the packet went out before the step and was one
 * step behind the Get. */
static void test_produce_after_model_step(void **state)
{
    (void)state;
    static fx_t f;
    fx_init(&f, NULL);
    fx_register(&f);
    uint8_t path[16], last[DR_ASM_MAX_SIZE];
    dr_fwd_open_t fo = fo_make(DRSIM_HB_INPUT_ONLY, 102, 6, 144 + 2, 10000, path, sizeof path);
    fo.timeout_mult = 7; /* no O->T heartbeat here: 5.12 s */
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    drsim_run(&f.sim, T0, fx_capture, &f);
    unsigned changed = 0;
    memset(last, 0, sizeof last);
    for (unsigned k = 1; k <= 400; k++) {
        unsigned before = f.sent;
        drsim_run(&f.sim, T0 + k * 10 * MS, fx_capture, &f);
        assert_int_equal(f.sent, before + 1);
        dr_io_frame_t io;
        assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
        assert_int_equal(io.data_len, 144);
        assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 102, 3, NULL, 0), DR_OK);
        assert_int_equal(f.rsp.data_len, 144);
        assert_memory_equal(io.data, f.rsp.data, 144);
        changed += memcmp(last, io.data, 144) != 0;
        memcpy(last, io.data, 144);
    }
    assert_true(changed > 300); /* the data moved: the comparison meant something */
}

/* The CIP sequence count of the packet drsim_run sends at `t`. */
static uint16_t produced_at(fx_t *f, uint64_t t)
{
    unsigned before = f->sent;
    drsim_run(&f->sim, t, fx_capture, f);
    assert_int_equal(f->sent, before + 1);
    dr_io_frame_t io;
    assert_int_equal(dr_io_frame_parse(f->pkt, f->pkt_len, false, &io), DR_OK);
    return io.cip_seq;
}

/* --seq-on-change: the CIP count moves with the data only, the
 * encapsulation number with every packet; --still keeps the data still. */
static void test_seq_on_change(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.seq_on_change = true;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(109, 105, 96 + 6, 96 + 2, 10000, path, sizeof path);
    fo.timeout_mult = 7;
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
    uint16_t c0 = produced_at(&f, T0);
    dr_io_frame_t io;
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    uint32_t e0 = io.encap_seq;
    /* int_out does not change by itself: the count stays */
    for (uint64_t k = 1; k <= 3; k++)
        assert_int_equal(produced_at(&f, T0 + k * 10 * MS), c0);
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    assert_int_equal(io.encap_seq, e0 + 3);
    /* a write echoed to int_out: the next packet has a new count */
    uint8_t data[96] = {42}, pkt[160];
    size_t n = o2t_packet(pkt, sizeof pkt, r.o2t_cid, 1, 1, true, data, 96);
    dr_sockaddr_t from = {0x7F000001u, 2222};
    drsim_io_receive(&f.sim, T0 + 35 * MS, &from, pkt, n);
    assert_int_equal(produced_at(&f, T0 + 40 * MS), (uint16_t)(c0 + 1));
    assert_int_equal(produced_at(&f, T0 + 50 * MS), (uint16_t)(c0 + 1));

    /* io_state, robot OPERATING: it moves (noise, AI1) without --still,
     * and stands still with it */
    for (int still = 0; still <= 1; still++) {
        cfg.still = still != 0;
        fx_init(&f, &cfg);
        fx_register(&f);
        open_io(&f, 7);
        (void)produced_at(&f, T0);
        /* a packet goes before the model's step at the same instant: the
         * one at 3.5 s still shows INITIALIZING, the next OPERATING */
        (void)produced_at(&f, T0 + 3500 * MS);
        uint16_t c = produced_at(&f, T0 + 3510 * MS);
        unsigned changes = 0;
        for (uint64_t k = 2; k <= 6; k++) {
            uint16_t now = produced_at(&f, T0 + 3500 * MS + k * 10 * MS);
            changes += now != c;
            c = now;
        }
        assert_int_equal(changes, still ? 0 : 5);
    }
}

/* --tick: the APIs are the RPIs rounded up to the tick, production and
 * the O->T timeout follow them; --api-report requested states the RPIs. */
static void test_tick_and_api_report(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.tick_us = 10000;
    for (int requested = 0; requested <= 1; requested++) {
        cfg.api_requested = requested != 0;
        fx_init(&f, &cfg);
        fx_register(&f);
        uint8_t path[16];
        dr_fwd_open_t fo = fo_make(107, 101, 18, 38, 5000, path, sizeof path);
        assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
        dr_fwd_open_reply_t r;
        assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
        assert_int_equal(r.o2t_api_us, requested ? 5000 : 10000);
        assert_int_equal(r.t2o_api_us, requested ? 5000 : 10000);
        drsim_run(&f.sim, T0, fx_capture, &f);
        assert_int_equal(f.sent, 1);
        drsim_run(&f.sim, T0 + 5 * MS, fx_capture, &f); /* not at the RPI */
        assert_int_equal(f.sent, 1);
        drsim_run(&f.sim, T0 + 10 * MS, fx_capture, &f); /* at the tick */
        assert_int_equal(f.sent, 2);
        /* O->T timeout: 4 x 10 ms after the last packet, not 4 x 5 ms */
        send_ctl(&f, r.o2t_cid, 1, 1, true, 0, T0 + 10 * MS);
        drsim_run(&f.sim, T0 + 39 * MS, fx_capture, &f);
        assert_false(drsim_conn_by_o2t(&f.sim, r.o2t_cid)->held);
        drsim_run(&f.sim, T0 + 50 * MS, fx_capture, &f);
        assert_true(drsim_conn_by_o2t(&f.sim, r.o2t_cid)->held);
    }
    /* an RPI that is a multiple of the tick is kept */
    cfg.api_requested = false;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(107, 101, 18, 38, 20000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
    assert_int_equal(r.t2o_api_us, 20000);
}

/* --trailing-item: Forward Open replies, accepted or refused, carry an
 * undeclared 0x8001 item (an echo of the request's, else the originator's
 * address at 2222); other replies do not. */
static void test_trailing_item(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    cfg.trailing_item = true;
    fx_init(&f, &cfg);
    fx_register(&f);
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    dr_sockaddr_t mine = {0x7F000001u, 40001};
    assert_int_equal(fo_send(&f, &fo, &mine), DR_OK);
    assert_int_equal(f.cpf.count, 3); /* null, data, 0x8000 */
    assert_int_equal(f.cpf_extra, 4 + 16);
    const uint8_t *tail = f.body + f.hdr.length - 20;
    assert_int_equal(dr_get_le16(tail), DR_CPF_SOCKADDR_T2O);
    dr_cpf_item_t it = {DR_CPF_SOCKADDR_T2O, 16, tail + 4};
    dr_sockaddr_t sa;
    assert_int_equal(dr_cpf_sockaddr_parse(&it, &sa), DR_OK);
    assert_int_equal(sa.port, 40001);
    /* a strict reader refuses it: the point of the option */
    uint32_t iface;
    uint16_t tmo;
    dr_cpf_t cpf;
    assert_int_equal(dr_rr_parse(f.body, f.hdr.length, &iface, &tmo, &cpf), DR_ELONG);
    /* refused: the same extra item, without a 0x8001 in the request */
    fo = fo_make(107, 101, 18, 38, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0106));
    assert_int_equal(f.cpf.count, 2);
    assert_int_equal(f.cpf_extra, 20);
    it.data = f.body + f.hdr.length - 16;
    assert_int_equal(dr_cpf_sockaddr_parse(&it, &sa), DR_OK);
    assert_int_equal(sa.addr, 0x7F000001u);
    assert_int_equal(sa.port, 2222);
    /* explicit messaging is untouched */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 101, 3, NULL, 0), DR_OK);
    assert_int_equal(f.cpf_extra, 0);
}

/* --layout combined: instance 100 is the six T->O assemblies back to back
 * (476 bytes), 150 the four O->T ones (212); the per-assembly instances
 * are gone. Explicit Get/Set and a Class 1 connection carry the same
 * bytes as the assemblies' own images. gpr_only: 200 bytes each way. */
static void test_layouts(void **state)
{
    (void)state;
    static fx_t f;
    drsim_config_t cfg;
    drsim_config_default(&cfg);
    dr_layout_default(&cfg.layout, DR_LAYOUT_COMBINED);
    fx_init(&f, &cfg);
    fx_register(&f);
    /* explicit: sizes, data, class attribute 3 (instances) */
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 100, 4, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le16(f.rsp.data), 476);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 150, 4, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le16(f.rsp.data), 212);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 0, 3, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le16(f.rsp.data), 2);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 101, 3, NULL, 0),
                     DR_CIP(0x05, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 100, 3, NULL, 0), DR_OK);
    assert_int_equal(f.rsp.data_len, 476);
    assert_memory_equal(f.rsp.data, f.sim.img.buf[DR_ASM_IO_STATE], 36);
    assert_memory_equal(f.rsp.data + 36, f.sim.img.buf[DR_ASM_JOINT_STATE], 144);
    assert_memory_equal(f.rsp.data + 380, f.sim.img.buf[DR_ASM_FLOAT_OUT], 96);
    uint8_t out[212];
    for (unsigned i = 0; i < sizeof out; i++)
        out[i] = (uint8_t)(i * 7u + 3u);
    memset(out, 0, 12); /* io_control: reserved bits must stay 0 */
    out[0] = 0x05;
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 150, 3, out, 211),
                     DR_CIP(0x13, 0));
    assert_int_equal(fx_req(&f, DR_CIP_SVC_SET_ATTRIBUTE_SINGLE, 4, 150, 3, out, 212), DR_OK);
    assert_memory_equal(f.sim.img.buf[DR_ASM_IO_CONTROL], out, 12);
    assert_memory_equal(f.sim.img.buf[DR_ASM_BIT_IN], out + 12, 8);
    assert_memory_equal(f.sim.img.buf[DR_ASM_INT_IN], out + 20, 96);
    assert_memory_equal(f.sim.img.buf[DR_ASM_INT_OUT], out + 20, 96); /* echo */
    assert_memory_equal(f.sim.img.buf[DR_ASM_FLOAT_IN], out + 116, 96);

    /* Class 1: sizes with the headers, 0x0109 names the wanted one */
    uint8_t path[16];
    dr_fwd_open_t fo = fo_make(150, 100, 212 + 6, 476, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_CIP(0x01, 0x0109));
    assert_int_equal(f.rsp.ext[1], 478);
    fo = fo_make(150, 100, 212 + 6, 476 + 2, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
    dr_fwd_open_reply_t r;
    assert_int_equal(dr_fwd_open_reply_parse(f.rsp.data, f.rsp.data_len, &r), DR_OK);
    drsim_run(&f.sim, T0, fx_capture, &f);
    dr_io_frame_t io;
    assert_int_equal(dr_io_frame_parse(f.pkt, f.pkt_len, false, &io), DR_OK);
    assert_int_equal(io.data_len, 476);
    assert_memory_equal(io.data + 276, f.sim.img.buf[DR_ASM_BIT_OUT], 8);
    out[12] = 0xA5;
    uint8_t pkt[64 + 212];
    size_t n = o2t_packet(pkt, sizeof pkt, r.o2t_cid, 1, 1, true, out, 212);
    dr_sockaddr_t from = {0x7F000001u, 2222};
    drsim_io_receive(&f.sim, T0 + 1 * MS, &from, pkt, n);
    assert_int_equal(f.sim.img.buf[DR_ASM_BIT_IN][0], 0xA5);
    assert_int_equal(f.sim.img.buf[DR_ASM_BIT_OUT][0], 0xA5);
    /* one owner for the whole O->T image */
    dr_fwd_open_t two = fo_make(150, 100, 212 + 6, 478, 10000, path, sizeof path);
    two.orig_serial = 0xBEEF;
    assert_int_equal(fo_send(&f, &two, NULL), DR_CIP(0x01, 0x0106));

    /* gpr_only: registers only, 200 bytes each way */
    dr_layout_default(&cfg.layout, DR_LAYOUT_GPR_ONLY);
    fx_init(&f, &cfg);
    fx_register(&f);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 100, 3, NULL, 0), DR_OK);
    assert_int_equal(f.rsp.data_len, 200);
    assert_memory_equal(f.rsp.data, f.sim.img.buf[DR_ASM_BIT_OUT], 8);
    assert_int_equal(fx_req(&f, DR_CIP_SVC_GET_ATTRIBUTE_SINGLE, 4, 150, 4, NULL, 0), DR_OK);
    assert_int_equal(dr_get_le16(f.rsp.data), 200);
    fo = fo_make(150, 100, 200 + 6, 200 + 2, 10000, path, sizeof path);
    assert_int_equal(fo_send(&f, &fo, NULL), DR_OK);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_forward_open_accepted),
        cmocka_unit_test(test_forward_open_sockaddr_and_large),
        cmocka_unit_test(test_forward_open_refused),
        cmocka_unit_test(test_refuse_fault),
        cmocka_unit_test(test_connection_points),
        cmocka_unit_test(test_listen_only_follows_its_producer),
        cmocka_unit_test(test_sequence_handling),
        cmocka_unit_test(test_timeouts),
        cmocka_unit_test(test_owner_takeover),
        cmocka_unit_test(test_drop_and_stop),
        cmocka_unit_test(test_produce_grid),
        cmocka_unit_test(test_produce_after_model_step),
        cmocka_unit_test(test_seq_on_change),
        cmocka_unit_test(test_tick_and_api_report),
        cmocka_unit_test(test_trailing_item),
        cmocka_unit_test(test_layouts),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
