/* SPDX-License-Identifier: MIT */
/*
 * The client against the real drsim over real TCP/UDP on loopback:
 * explicit messaging, errors, Class 1 I/O, Forward Open refusals, I/O
 * timeouts with reconnect, session loss, packet loss.
 * drsim listens on 127.0.0.2, the client's UDP socket on 127.0.0.1, so both
 * own their own Class 1 port without root.
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <arpa/inet.h>
#include <netinet/in.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>
#include <cmocka.h>

#include "drgate/client.h"
#include "support/drsim_proc.h"

typedef struct {
    drsim_proc_t sim;
    dr_client_t *c;
    uint16_t local_udp;
} fixture_t;

static dr_client_t *new_client(const drsim_proc_t *sim, uint16_t local_udp, bool route)
{
    dr_client_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.host = sim->address;
    cfg.tcp_port = sim->tcp_port;
    cfg.local_addr = "127.0.0.1";
    cfg.local_udp_port = local_udp;
    cfg.timeout_ms = 1000;
    cfg.route = route;
    cfg.backoff_min_ms = 50;
    cfg.backoff_max_ms = 400;
    return dr_client_new(&cfg, NULL);
}

/* Start drsim with `extra` options and a client for it. */
static int start(void **state, const char *const *extra)
{
    fixture_t *f = calloc(1, sizeof *f);
    drsim_ports(&f->sim.tcp_port, &f->sim.udp_port);
    f->local_udp = (uint16_t)(f->sim.udp_port + 5000u);
    if (drsim_path() == NULL || !drsim_start(&f->sim, extra)) {
        free(f);
        return -1;
    }
    f->c = new_client(&f->sim, f->local_udp, false);
    *state = f;
    return f->c != NULL ? 0 : -1;
}

static int setup(void **state)
{
    return start(state, NULL);
}

static int teardown(void **state)
{
    fixture_t *f = *state;
    if (f == NULL)
        return 0;
    dr_client_free(f->c);
    int rc = drsim_stop(&f->sim);
    free(f);
    return rc == 0 ? 0 : -1; /* drsim must exit cleanly */
}

/* ---- explicit messaging ---------------------------------------------------- */

static void test_read_all_assemblies(void **state)
{
    fixture_t *f = *state;
    assert_int_equal(dr_client_connect_sync(f->c), DR_OK);
    for (int a = 0; a < DR_ASM_COUNT; a++) {
        uint8_t buf[DR_ASM_MAX_SIZE];
        uint16_t size = 0;
        assert_int_equal(dr_client_read_asm_sync(f->c, (dr_asm_t)a, buf, dr_asm_info((dr_asm_t)a)->size), DR_OK);
        assert_int_equal(dr_client_read_asm_size_sync(f->c, dr_client_instance(f->c, (dr_asm_t)a), &size), DR_OK);
        assert_int_equal(size, dr_asm_info((dr_asm_t)a)->size);
    }
    uint8_t small[8];
    assert_int_equal(dr_client_read_asm_sync(f->c, DR_ASM_IO_STATE, small, sizeof small), DR_ELENGTH);
}

static void test_set_and_echo(void **state)
{
    fixture_t *f = *state;
    assert_int_equal(dr_client_connect_sync(f->c), DR_OK);
    uint8_t in[96] = {0}, out[96];
    dr_put_le32(in + 4 * 7, (uint32_t)-123456);
    assert_int_equal(dr_client_write_asm_sync(f->c, DR_ASM_INT_IN, in, sizeof in), DR_OK);
    /* drsim echoes int_in to int_out on its next model step */
    for (int i = 0; i < 50; i++) {
        assert_int_equal(dr_client_read_asm_sync(f->c, DR_ASM_INT_OUT, out, sizeof out), DR_OK);
        if (memcmp(in, out, sizeof in) == 0)
            break;
        dr_client_run_once(f->c, 20);
    }
    assert_memory_equal(in, out, sizeof in);
    uint8_t back[96];
    assert_int_equal(dr_client_read_asm_sync(f->c, DR_ASM_INT_IN, back, sizeof back), DR_OK);
    assert_memory_equal(in, back, sizeof in);
}

static void test_cip_errors(void **state)
{
    fixture_t *f = *state;
    uint8_t buf[200];
    size_t len;
    uint16_t size;
    assert_int_equal(dr_client_connect_sync(f->c), DR_OK);
    /* T->O assemblies are not settable; unknown instances are unknown */
    assert_int_equal(dr_client_write_asm_sync(f->c, DR_ASM_INT_OUT, buf, 96), DR_CIP(0x0E, 0));
    assert_int_equal(dr_client_read_asm_size_sync(f->c, 150, &size), DR_CIP(0x05, 0));
    assert_int_equal(dr_client_get_attr_sync(f->c, DR_CIP_CLASS_ASSEMBLY, 101, 9, buf, sizeof buf, &len),
                     DR_CIP(0x14, 0));
    /* wrong sizes for a Set */
    assert_int_equal(dr_client_set_attr_sync(f->c, DR_CIP_CLASS_ASSEMBLY, 110, 3, buf, 95), DR_CIP(0x13, 0));
    assert_int_equal(dr_client_set_attr_sync(f->c, DR_CIP_CLASS_ASSEMBLY, 110, 3, buf, 97), DR_CIP(0x15, 0));
    /* a reply larger than the caller's buffer */
    assert_int_equal(dr_client_get_attr_sync(f->c, DR_CIP_CLASS_ASSEMBLY, 102, 3, buf, 10, &len), DR_ENOSPACE);
    /* the session still works after all that */
    assert_int_equal(dr_client_read_asm_sync(f->c, DR_ASM_IO_STATE, buf, 36), DR_OK);
}

static void test_identity(void **state)
{
    fixture_t *f = *state;
    dr_identity_t a, b;
    assert_int_equal(dr_client_connect_sync(f->c), DR_OK);
    assert_int_equal(dr_client_read_identity_sync(f->c, &a), DR_OK);
    assert_int_equal(dr_client_list_identity_sync(f->c, &b), DR_OK);
    assert_true(strlen(a.product_name) > 0);
    assert_string_equal(a.product_name, b.product_name);
    assert_int_equal(a.vendor, b.vendor);
    assert_int_equal(a.serial, b.serial);
}

static void test_unconnected_send_route(void **state)
{
    fixture_t *f = *state;
    dr_client_t *routed = new_client(&f->sim, f->local_udp, true);
    uint8_t a[36], b[36];
    assert_int_equal(dr_client_connect_sync(routed), DR_OK);
    assert_int_equal(dr_client_read_asm_sync(routed, DR_ASM_IO_STATE, a, sizeof a), DR_OK);
    assert_int_equal(dr_client_connect_sync(f->c), DR_OK);
    assert_int_equal(dr_client_read_asm_sync(f->c, DR_ASM_IO_STATE, b, sizeof b), DR_OK);
    /* controller version is constant: same bytes both ways */
    assert_memory_equal(a + 28, b + 28, 3);
    dr_client_free(routed);
}

static void test_connect_refused(void **state)
{
    (void)state;
    drsim_proc_t nobody;
    memset(&nobody, 0, sizeof nobody);
    snprintf(nobody.address, sizeof nobody.address, "127.0.0.2");
    nobody.tcp_port = 1; /* nothing listens there */
    dr_client_t *c = new_client(&nobody, 0, false);
    assert_int_equal(dr_client_connect_sync(c), DR_ECONNREFUSED);
    uint8_t buf[36];
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, 36), DR_ESESSION);
    dr_client_free(c);
}

/* A peer that accepts and never answers: no reply to RegisterSession,
 * which is not the same as no answer to the TCP connection. */
static void test_silent_peer_times_out(void **state)
{
    (void)state;
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in sin;
    socklen_t sl = sizeof sin;
    memset(&sin, 0, sizeof sin);
    sin.sin_family = AF_INET;
    sin.sin_addr.s_addr = htonl(0x7F000003);
    assert_int_equal(bind(fd, (struct sockaddr *)&sin, sizeof sin), 0);
    assert_int_equal(listen(fd, 4), 0);
    getsockname(fd, (struct sockaddr *)&sin, &sl);
    drsim_proc_t silent;
    memset(&silent, 0, sizeof silent);
    snprintf(silent.address, sizeof silent.address, "127.0.0.3");
    silent.tcp_port = ntohs(sin.sin_port);
    dr_client_t *c = new_client(&silent, 0, false);
    assert_int_equal(dr_client_connect_sync(c), DR_ENOREGISTER);
    assert_string_equal(dr_client_last_step(c), "register session");
    dr_client_free(c);
    close(fd);
}

/* ---- Class 1 ------------------------------------------------------------------ */

typedef struct {
    unsigned data;
    unsigned established, timed_out, reconnecting;
    dr_status_t last_reason;
} conn_log_t;

static void on_data(dr_conn_t *conn, const uint8_t *data, size_t len, void *user)
{
    (void)conn;
    (void)data;
    (void)len;
    ((conn_log_t *)user)->data++;
}

static void on_state(dr_conn_t *conn, dr_conn_state_t st, dr_status_t why, void *user)
{
    conn_log_t *log = user;
    (void)conn;
    if (st == DR_CONN_ESTABLISHED) log->established++;
    if (st == DR_CONN_TIMED_OUT) log->timed_out++;
    if (st == DR_CONN_RECONNECTING) log->reconnecting++;
    if (why != DR_OK)
        log->last_reason = why;
}

static dr_conn_t *add_conn(dr_client_t *c, int o2t, dr_asm_t t2o, conn_log_t *log, bool large)
{
    dr_conn_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.o2t_asm = o2t;
    cc.t2o_asm = t2o;
    /* Generous timing: this runs on small, shared CI machines. */
    cc.rpi_us = 10000;
    cc.timeout_mult = 3; /* x32: 320 ms */
    cc.large = large;
    cc.on_data = on_data;
    cc.on_state = on_state;
    cc.user = log;
    dr_status_t err;
    dr_conn_t *cn = dr_conn_add(c, &cc, &err);
    assert_non_null(cn);
    return cn;
}

static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Turns the client's loop for `ms` of the clock. dr_client_run_once
 * returns as soon as something comes, so counting its calls (ms / 5 of
 * them) ran the loop for less: "600 ms" lasted 390 ms here, and in CI's
 * coverage build once too short for 20 packets of each of six
 * connections. */
static void run_for(dr_client_t *c, int ms)
{
    int64_t end = now_ms() + ms;
    for (int64_t left = ms; left > 0; left = end - now_ms())
        dr_client_run_once(c, left < 5 ? (int)left : 5);
}

static void test_six_connections_and_output(void **state)
{
    fixture_t *f = *state;
    static const struct { int o2t; dr_asm_t t2o; } pairs[] = {
        {DR_ASM_IO_CONTROL, DR_ASM_IO_STATE}, {DR_ASM_BIT_IN, DR_ASM_BIT_OUT},
        {DR_ASM_INT_IN, DR_ASM_INT_OUT}, {DR_ASM_FLOAT_IN, DR_ASM_FLOAT_OUT},
        {-1, DR_ASM_JOINT_STATE}, {-1, DR_ASM_TASK_STATE}};
    conn_log_t log[6];
    dr_conn_t *cn[6];
    memset(log, 0, sizeof log);
    for (int i = 0; i < 6; i++)
        cn[i] = add_conn(f->c, pairs[i].o2t, pairs[i].t2o, &log[i], false);
    /* cb_do 1 and 16, tool_do 3 */
    uint8_t ctl[12] = {0x01, 0x80, 0x04, 0x00};
    assert_int_equal(dr_conn_set_output(cn[0], ctl, sizeof ctl), DR_OK);
    assert_int_equal(dr_conn_set_output(cn[0], ctl, 11), DR_ELENGTH);
    assert_int_equal(dr_conn_set_output(cn[4], ctl, 12), DR_EINVAL);
    dr_client_start(f->c);
    run_for(f->c, 600);
    for (int i = 0; i < 6; i++) {
        assert_int_equal(dr_conn_state(cn[i]), DR_CONN_ESTABLISHED);
        assert_true(log[i].data > 20);
        const dr_conn_stats_t *st = dr_conn_stats(cn[i]);
        assert_int_equal(st->t2o_api_us, 10000);
        assert_int_equal(st->rx_bad, 0);
        assert_true(st->tx_packets > 20);
    }
    /* what we produce reaches the robot: io_state.cb_do and tool_do follow */
    size_t len;
    const uint8_t *io = dr_conn_input(cn[0], &len);
    assert_non_null(io);
    assert_int_equal(len, 36);
    assert_int_equal(io[2], 0x01);
    assert_int_equal(io[3], 0x80);
    assert_int_equal(io[26], 0x04);
}

static void test_large_forward_open(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_FLOAT_IN, DR_ASM_JOINT_STATE, &log, true);
    dr_client_start(f->c);
    run_for(f->c, 500);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_true(log.data > 10);
}

static int setup_no_large(void **state)
{
    static const char *const extra[] = {"--no-large-forward-open", NULL};
    return start(state, extra);
}

/* A target that does not know 0x5B: the client falls back to 0x54. */
static void test_large_falls_back(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_FLOAT_IN, DR_ASM_FLOAT_OUT, &log, true);
    dr_client_start(f->c);
    run_for(f->c, 500);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    /* 0x5B refused, then 0x54; again after each timeout (a stall of a
     * busy machine: every new open starts with 0x5B) */
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    assert_int_equal(st->opens, 2u * (1u + st->timeouts));
    assert_true(log.data > 10);
}

static int setup_refuse_0113(void **state)
{
    static const char *const extra[] = {"--refuse-forward-open", "0x0113", NULL};
    return start(state, extra);
}

static void test_forward_open_refused(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, -1, DR_ASM_IO_STATE, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 300);
    assert_int_not_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(log.last_reason, DR_CIP(0x01, 0x0113));
    assert_true(log.reconnecting >= 1);
    assert_true(dr_conn_stats(cn)->opens >= 2); /* it keeps trying, with backoff */
    assert_true(dr_conn_stats(cn)->opens < 10);
}

static int setup_refuse_0100(void **state)
{
    static const char *const extra[] = {"--refuse-forward-open", "0x0100", NULL};
    return start(state, extra);
}

/* "Connection in use": a fresh serial right away, three times, then the
 * ordinary backoff. */
static void test_duplicate_retried_with_new_serial(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, -1, DR_ASM_TASK_STATE, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 150);
    assert_int_equal(log.last_reason, DR_CIP(0x01, 0x0100));
    assert_true(dr_conn_stats(cn)->opens >= 4);
    assert_true(log.reconnecting >= 1);
}

static int setup_refuse_0109(void **state)
{
    static const char *const extra[] = {"--refuse-forward-open", "0x0109", NULL};
    return start(state, extra);
}

static void test_forward_open_size_reported(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_BIT_IN, DR_ASM_BIT_OUT, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 200);
    assert_int_equal(log.last_reason, DR_CIP(0x01, 0x0109));
    assert_true(dr_conn_stats(cn)->size_wanted > 0);
}

static int setup_stop_producing(void **state)
{
    static const char *const extra[] = {"--stop-producing-after", "0.3", NULL};
    return start(state, extra);
}

static void test_io_timeout_and_reconnect(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_INT_IN, DR_ASM_INT_OUT, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 1500);
    assert_true(log.timed_out >= 1);
    assert_int_equal(log.last_reason, DR_ETIMEDOUT);
    assert_true(log.established >= 2); /* reconnected after the timeout */
    assert_true(dr_conn_stats(cn)->timeouts >= 1);
}

static int setup_drop_session(void **state)
{
    static const char *const extra[] = {"--drop-session-after", "0.3", NULL};
    return start(state, extra);
}

static void test_session_loss_keeps_io(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_BIT_IN, DR_ASM_BIT_OUT, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 1200);
    /* drsim drops the session every 0.3 s; wait (bounded) for a moment
     * when it is registered again, rather than hoping to be in one. */
    for (int i = 0; i < 400 && !dr_client_ready(f->c); i++)
        dr_client_run_once(f->c, 5);
    /* the TCP session was dropped and registered again; Class 1 went on */
    assert_true(dr_client_ready(f->c));
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(log.timed_out, 0);
    uint8_t buf[8];
    assert_int_equal(dr_client_read_asm_sync(f->c, DR_ASM_BIT_OUT, buf, sizeof buf), DR_OK);
}

static int setup_drop_packets(void **state)
{
    static const char *const extra[] = {"--drop", "20", "--seed", "7", NULL};
    return start(state, extra);
}

static void test_packet_loss_counted(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, -1, DR_ASM_JOINT_STATE, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 800);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_true(st->rx_lost > 0);
    assert_true(st->rx_packets > 30);
}

/* ---- adapter behaviours we accept (docs/interop.md) -------------------------- */

static int setup_seq_on_change(void **state)
{
    static const char *const extra[] = {"--seq-on-change", "--still", NULL};
    return start(state, extra);
}

/* A producer that keeps its CIP sequence count while the data stands still:
 * the connection lives on the encapsulation sequence number (it used to
 * time out after 32 RPIs here), and a change is one new sample. */
static void test_seq_on_change_no_timeout(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_INT_IN, DR_ASM_INT_OUT, &log, false);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    dr_client_start(f->c);
    run_for(f->c, 1500);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(log.timed_out, 0);
    assert_int_equal(st->timeouts, 0);
    assert_true(st->rx_repeats > 50);
    /* every new count was handed over once, no repeat was */
    assert_int_equal(log.data, st->rx_packets - st->rx_repeats);
    unsigned samples = log.data;
    uint8_t out[96] = {0};
    dr_put_le32(out, 0x5EEDu);
    assert_int_equal(dr_conn_set_output(cn, out, sizeof out), DR_OK);
    size_t len = 0;
    const uint8_t *in = NULL;
    for (int i = 0; i < 400; i++) {
        dr_client_run_once(f->c, 5);
        in = dr_conn_input(cn, &len);
        if (in != NULL && dr_get_le32(in) == 0x5EEDu)
            break;
    }
    assert_non_null(in);
    assert_int_equal(dr_get_le32(in), 0x5EEDu);
    /* the change came as the next new sample, and stands still again */
    assert_int_equal(log.data, samples + 1);
    run_for(f->c, 300);
    assert_int_equal(log.data, samples + 1);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(log.data, st->rx_packets - st->rx_repeats);
}

static int setup_tick_actual(void **state)
{
    static const char *const extra[] = {"--tick", "50", NULL};
    return start(state, extra);
}

static int setup_tick_requested(void **state)
{
    static const char *const extra[] = {"--tick", "10", "--api-report", "requested", NULL};
    return start(state, extra);
}

/* RPI 5 ms, timeout code mult (1: x8). */
static dr_conn_t *add_fast_conn(dr_client_t *c, conn_log_t *log, uint8_t mult)
{
    dr_conn_config_t cc;
    memset(&cc, 0, sizeof cc);
    cc.o2t_asm = DR_ASM_BIT_IN;
    cc.t2o_asm = DR_ASM_BIT_OUT;
    cc.rpi_us = 5000;
    cc.timeout_mult = mult;
    cc.on_data = on_data;
    cc.on_state = on_state;
    cc.user = log;
    dr_conn_t *cn = dr_conn_add(c, &cc, NULL);
    assert_non_null(cn);
    return cn;
}

/* An adapter that produces every 50 ms for a 5 ms request and says so:
 * timeouts run from the API granted (8 x 50 ms), not from the RPI asked
 * (8 x 5 ms = 40 ms, less than one period). */
static void test_coarse_tick_reported(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_fast_conn(f->c, &log, 1);
    dr_client_start(f->c);
    run_for(f->c, 1500);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(st->t2o_api_us, 50000);
    assert_int_equal(st->o2t_api_us, 50000);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(log.timed_out, 0);
    assert_true(st->rx_packets >= 5);
}

/* The same adapter rounding 5 ms to 10 ms without saying so: the reply's
 * APIs are the RPIs. Timeout x64 (320 ms, as add_conn): drsim is a process on a
 * machine that may be busy, and a 40 ms stall is not the point here;
 * that 8 x 5 ms covers the tick is test_client_fake's, in virtual time. */
static void test_coarse_tick_unreported(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_fast_conn(f->c, &log, 4);
    dr_client_start(f->c);
    run_for(f->c, 1500);
    const dr_conn_stats_t *st = dr_conn_stats(cn);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(st->t2o_api_us, 5000);
    assert_int_equal(st->timeouts, 0);
    assert_int_equal(log.timed_out, 0);
    assert_true(st->rx_packets >= 20);
}

static int setup_trailing(void **state)
{
    static const char *const extra[] = {"--trailing-item", NULL};
    return start(state, extra);
}

static int setup_trailing_refused(void **state)
{
    static const char *const extra[] = {"--trailing-item", "--refuse-forward-open", "0x0106",
                                        NULL};
    return start(state, extra);
}

/* Forward Open replies with an undeclared item after their own: the open
 * succeeds, and a refusal shows its real status (it used to be "malformed
 * frame"). */
static void test_trailing_item_accepted(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_IO_CONTROL, DR_ASM_IO_STATE, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 500);
    assert_int_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_true(log.data > 5);
    assert_true(dr_client_stats(f->c)->replies_trailing >= 1);
}

static void test_trailing_item_refusal(void **state)
{
    fixture_t *f = *state;
    conn_log_t log = {0};
    dr_conn_t *cn = add_conn(f->c, DR_ASM_IO_CONTROL, DR_ASM_IO_STATE, &log, false);
    dr_client_start(f->c);
    run_for(f->c, 300);
    assert_int_not_equal(dr_conn_state(cn), DR_CONN_ESTABLISHED);
    assert_int_equal(log.last_reason, DR_CIP(0x01, 0x0106));
    assert_true(dr_client_stats(f->c)->replies_trailing >= 1);
}

static void on_found(const dr_identity_t *id, dr_sockaddr_t from, void *user)
{
    dr_identity_t *out = user;
    *out = *id;
    out->sockaddr.addr = from.addr; /* where it answered from */
}

static void test_discover_udp(void **state)
{
    fixture_t *f = *state;
    dr_identity_t id, tcp_id;
    unsigned n = 0;
    dr_transport_t tp = dr_transport_posix(), none = {NULL, NULL};
    memset(&id, 0, sizeof id);
    /* it blocks: a transport (with wait) is required */
    assert_int_equal(dr_discover(f->sim.address, f->sim.tcp_port, 1000, none, on_found, &id, &n),
                     DR_EINVAL);
    assert_int_equal(dr_discover(f->sim.address, f->sim.tcp_port, 1000, tp, on_found, &id, &n), DR_OK);
    assert_int_equal(n, 1);
    assert_int_equal(id.sockaddr.addr, 0x7F000002u);
    assert_int_equal(dr_client_connect_sync(f->c), DR_OK);
    assert_int_equal(dr_client_read_identity_sync(f->c, &tcp_id), DR_OK);
    assert_string_equal(id.product_name, tcp_id.product_name);
    assert_int_equal(id.serial, tcp_id.serial);
    /* nobody on this port: a bounded wait, then DR_ETIMEDOUT */
    assert_int_equal(dr_discover(f->sim.address, 9, 200, tp, on_found, &id, &n), DR_ETIMEDOUT);
    assert_int_equal(n, 0);
}

/* Two robots, one UDP port: both clients' connections get their data. */
static void test_two_robots_share_udp_port(void **state)
{
    fixture_t *f = *state;
    drsim_proc_t second;
    memset(&second, 0, sizeof second);
    drsim_ports(&second.tcp_port, &second.udp_port);
    second.tcp_port = (uint16_t)(second.tcp_port + 3000u);
    second.udp_port = (uint16_t)(second.udp_port + 3000u);
    assert_true(drsim_start(&second, NULL));

    dr_status_t err;
    dr_transport_t tp = {NULL, NULL};
    dr_udp_port_t *port = dr_udp_port_new("127.0.0.1", f->local_udp, tp, &err);
    assert_non_null(port);
    dr_client_t *c[2];
    const drsim_proc_t *sims[2] = {&f->sim, &second};
    conn_log_t log[2];
    dr_conn_t *cn[2];
    memset(log, 0, sizeof log);
    for (int i = 0; i < 2; i++) {
        dr_client_config_t cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.host = sims[i]->address;
        cfg.tcp_port = sims[i]->tcp_port;
        cfg.timeout_ms = 1000;
        cfg.shared_udp = port;
        c[i] = dr_client_new(&cfg, NULL);
        assert_non_null(c[i]);
        cn[i] = add_conn(c[i], DR_ASM_BIT_IN, DR_ASM_BIT_OUT, &log[i], false);
        dr_client_start(c[i]);
    }
    for (int k = 0; k < 150; k++) {
        dr_client_run_once(c[0], 5);
        dr_client_run_once(c[1], 5);
    }
    for (int i = 0; i < 2; i++) {
        assert_int_equal(dr_conn_state(cn[i]), DR_CONN_ESTABLISHED);
        assert_true(log[i].data > 10);
        assert_int_equal(dr_conn_stats(cn[i])->timeouts, 0);
    }
    /* different connection IDs, even though one socket serves both */
    assert_int_not_equal(dr_conn_stats(cn[0])->t2o_cid, dr_conn_stats(cn[1])->t2o_cid);
    dr_client_free(c[0]);
    dr_client_free(c[1]);
    dr_udp_port_free(port);
    assert_int_equal(drsim_stop(&second), 0);
}

int main(void)
{
    if (drsim_path() == NULL) {
        /* cross builds (big-endian run) have no drsim beside the tests */
        printf("[  SKIPPED ] client tests: no drsim next to the test binary\n");
        printf("[  PASSED  ] 0 test(s).\n");
        return 0;
    }
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_read_all_assemblies, setup, teardown),
        cmocka_unit_test_setup_teardown(test_set_and_echo, setup, teardown),
        cmocka_unit_test_setup_teardown(test_cip_errors, setup, teardown),
        cmocka_unit_test_setup_teardown(test_identity, setup, teardown),
        cmocka_unit_test_setup_teardown(test_unconnected_send_route, setup, teardown),
        cmocka_unit_test(test_connect_refused),
        cmocka_unit_test(test_silent_peer_times_out),
        cmocka_unit_test_setup_teardown(test_six_connections_and_output, setup, teardown),
        cmocka_unit_test_setup_teardown(test_large_forward_open, setup, teardown),
        cmocka_unit_test_setup_teardown(test_large_falls_back, setup_no_large, teardown),
        cmocka_unit_test_setup_teardown(test_forward_open_refused, setup_refuse_0113, teardown),
        cmocka_unit_test_setup_teardown(test_forward_open_size_reported, setup_refuse_0109, teardown),
        cmocka_unit_test_setup_teardown(test_duplicate_retried_with_new_serial, setup_refuse_0100, teardown),
        cmocka_unit_test_setup_teardown(test_io_timeout_and_reconnect, setup_stop_producing, teardown),
        cmocka_unit_test_setup_teardown(test_session_loss_keeps_io, setup_drop_session, teardown),
        cmocka_unit_test_setup_teardown(test_packet_loss_counted, setup_drop_packets, teardown),
        cmocka_unit_test_setup_teardown(test_two_robots_share_udp_port, setup, teardown),
        cmocka_unit_test_setup_teardown(test_discover_udp, setup, teardown),
        cmocka_unit_test_setup_teardown(test_seq_on_change_no_timeout, setup_seq_on_change,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_coarse_tick_reported, setup_tick_actual, teardown),
        cmocka_unit_test_setup_teardown(test_coarse_tick_unreported, setup_tick_requested,
                                        teardown),
        cmocka_unit_test_setup_teardown(test_trailing_item_accepted, setup_trailing, teardown),
        cmocka_unit_test_setup_teardown(test_trailing_item_refusal, setup_trailing_refused,
                                        teardown),
    };
    return cmocka_run_group_tests_name("client_sim", tests, NULL, NULL);
}
