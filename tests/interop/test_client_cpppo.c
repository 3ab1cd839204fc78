/* SPDX-License-Identifier: MIT */
/*
 * Our client against cpppo's EtherNet/IP server, an implementation that is
 * not ours: explicit messaging (RegisterSession, SendRRData/UCMM,
 * Get/Set_Attribute_Single on the Assembly object, Unconnected Send,
 * Identity, ListIdentity) with cpppo parsing our requests and building the
 * replies we parse.
 *
 * tests/interop/with_cpppo.py starts the server with one tag per assembly
 * at its CIP path (io_state@0x04/101/3=USINT[36], ...) plus a deliberately
 * wrong-sized one at instance 111, and passes its address in CPPPO_HOST /
 * CPPPO_PORT. Every call has the client's timeout (2 s).
 */
#define _GNU_SOURCE
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "drgate/client.h"
#include "drgate/layout.h"

/* The wrong-sized tag with_cpppo.py adds: 35 bytes where io_state has 36. */
#define SHORT_INSTANCE 111
#define UNKNOWN_INSTANCE 150
/* The combined layout's points with_cpppo.py adds (476 and 212 bytes). */
#define COMBINED_INPUT 120
#define COMBINED_OUTPUT 121

static const char *host;
static uint16_t port;

static dr_client_t *new_client(bool route, uint16_t io_state_instance)
{
    dr_client_config_t cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.host = host;
    cfg.tcp_port = port;
    cfg.timeout_ms = 2000;
    cfg.route = route;
    cfg.instance[DR_ASM_IO_STATE] = io_state_instance;
    dr_client_t *c = dr_client_new(&cfg, NULL);
    assert_non_null(c);
    return c;
}

static int setup(void **state)
{
    dr_client_t *c = new_client(false, 0);
    if (dr_client_connect_sync(c) != DR_OK) {
        dr_client_free(c);
        return -1;
    }
    *state = c;
    return 0;
}

static int teardown(void **state)
{
    dr_client_free(*state);
    return 0;
}

static size_t size_of(int a)
{
    return dr_asm_info((dr_asm_t)a)->size;
}

/* A pattern that differs per assembly and per round. */
static void pattern(uint8_t *buf, size_t len, int a, int round)
{
    for (size_t i = 0; i < len; i++)
        buf[i] = (uint8_t)(i * 7u + (unsigned)a * 31u + (unsigned)round * 101u + 1u);
}

static void test_read_every_assembly(void **state)
{
    dr_client_t *c = *state;
    for (int a = 0; a < DR_ASM_COUNT; a++) {
        uint8_t buf[DR_ASM_MAX_SIZE];
        dr_status_t st = dr_client_read_asm_sync(c, (dr_asm_t)a, buf, size_of(a));
        if (st != DR_OK)
            fail_msg("%s: %s", dr_asm_info((dr_asm_t)a)->name, dr_strerror(st));
    }
}

/* cpppo's tags are plain data: every instance is writable, so all ten
 * go out and come back (the direction rules are drsim's, tested there). */
static void test_write_and_read_back_every_assembly(void **state)
{
    dr_client_t *c = *state;
    for (int round = 0; round < 2; round++)
        for (int a = 0; a < DR_ASM_COUNT; a++) {
            uint8_t out[DR_ASM_MAX_SIZE], in[DR_ASM_MAX_SIZE];
            pattern(out, size_of(a), a, round);
            dr_status_t st = dr_client_write_asm_sync(c, (dr_asm_t)a, out, size_of(a));
            if (st != DR_OK)
                fail_msg("write %s: %s", dr_asm_info((dr_asm_t)a)->name, dr_strerror(st));
            assert_int_equal(dr_client_read_asm_sync(c, (dr_asm_t)a, in, size_of(a)), DR_OK);
            assert_memory_equal(out, in, size_of(a));
        }
}

/* The values stay where they were written: a second session sees them. */
static void test_second_session_sees_writes(void **state)
{
    dr_client_t *c = *state;
    uint8_t out[96], in[96];
    pattern(out, sizeof out, 99, 3);
    assert_int_equal(dr_client_write_asm_sync(c, DR_ASM_FLOAT_IN, out, sizeof out), DR_OK);
    dr_client_t *other = new_client(false, 0);
    assert_int_equal(dr_client_connect_sync(other), DR_OK);
    assert_int_equal(dr_client_read_asm_sync(other, DR_ASM_FLOAT_IN, in, sizeof in), DR_OK);
    assert_memory_equal(out, in, sizeof out);
    dr_client_free(other);
}

/* The same through Unconnected Send (0x52) with route 1/0, as a PLC's
 * requests come; cpppo unwraps it like a ControlLogix would. */
static void test_unconnected_send(void **state)
{
    (void)state;
    dr_client_t *c = new_client(true, 0);
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    uint8_t out[12], in[12];
    pattern(out, sizeof out, 6, 9);
    assert_int_equal(dr_client_write_asm_sync(c, DR_ASM_IO_CONTROL, out, sizeof out), DR_OK);
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_CONTROL, in, sizeof in), DR_OK);
    assert_memory_equal(out, in, sizeof out);
    dr_client_free(c);
}

/* An instance whose data has another size than the specification's is
 * refused, not half-read. */
static void test_wrong_size_refused(void **state)
{
    (void)state;
    dr_client_t *c = new_client(false, SHORT_INSTANCE);
    uint8_t buf[36];
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_IO_STATE, buf, sizeof buf), DR_ELENGTH);
    /* the raw attribute still reads, with its 35 bytes */
    size_t len = 0;
    assert_int_equal(dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, SHORT_INSTANCE, 3,
                                             buf, sizeof buf, &len), DR_OK);
    assert_int_equal(len, 35);
    dr_client_free(c);
}

/* A combined layout's points (issue 31), as drgatewayd's explicit mode
 * and drcli --layout combined use them: each point written whole, its
 * assemblies put in their places (dr_point_put), reads back with every
 * assembly at its offset (dr_point_slice); the sizes are the layout's,
 * 476 and 212 bytes, which cpppo's tags have. */
static void test_combined_points(void **state)
{
    dr_client_t *c = *state;
    dr_layout_t l;
    dr_layout_default(&l, DR_LAYOUT_COMBINED);
    l.input.instance = COMBINED_INPUT;
    l.output.instance = COMBINED_OUTPUT;
    const dr_point_t *pts[2] = {&l.output, &l.input};
    for (unsigned k = 0; k < 2; k++) {
        const dr_point_t *p = pts[k];
        uint8_t img[DR_POINT_MAX_SIZE], back[DR_POINT_MAX_SIZE];
        uint8_t part[DR_ASM_MAX_SIZE], got[DR_ASM_MAX_SIZE];
        memset(img, 0, sizeof img);
        for (unsigned i = 0; i < p->count; i++) {
            int a = p->asm_id[i];
            pattern(part, size_of(a), a, 5);
            assert_int_equal(dr_point_put(p, img, p->size, (dr_asm_t)a, part, size_of(a)), DR_OK);
        }
        assert_int_equal(dr_client_set_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, p->instance, 3, img,
                                                 p->size), DR_OK);
        size_t len = 0;
        assert_int_equal(dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, p->instance, 3, back,
                                                 sizeof back, &len), DR_OK);
        assert_int_equal(len, p->size);
        for (unsigned i = 0; i < p->count; i++) {
            int a = p->asm_id[i];
            pattern(part, size_of(a), a, 5);
            assert_int_equal(dr_point_slice(p, back, len, (dr_asm_t)a, got, size_of(a)), DR_OK);
            assert_memory_equal(part, got, size_of(a));
        }
    }
}

static void test_identity(void **state)
{
    dr_client_t *c = *state;
    dr_identity_t a, b;
    memset(&a, 0, sizeof a);
    memset(&b, 0, sizeof b);
    assert_int_equal(dr_client_read_identity_sync(c, &a), DR_OK);
    assert_int_equal(dr_client_list_identity_sync(c, &b), DR_OK);
    assert_true(strlen(a.product_name) > 0);
    assert_string_equal(a.product_name, b.product_name);
    assert_int_equal(a.vendor, b.vendor);
    assert_int_equal(a.serial, b.serial);
    printf("# cpppo identity: vendor %u, device type %u, \"%s\"\n",
           (unsigned)a.vendor, (unsigned)a.device_type, a.product_name);
}

/* cpppo answers a request for an object it does not have with a
 * non-standard encapsulation status (0x08) and closes the session. The
 * client must report an error (not hang, not crash) and be able to start
 * over. */
static void test_peer_hangs_up_then_reconnect(void **state)
{
    dr_client_t *c = *state;
    uint8_t buf[DR_ASM_MAX_SIZE];
    size_t len = 0;
    dr_status_t st = dr_client_get_attr_sync(c, DR_CIP_CLASS_ASSEMBLY, UNKNOWN_INSTANCE, 3,
                                             buf, sizeof buf, &len);
    printf("# unknown instance: %s\n", dr_strerror(st));
    assert_int_not_equal(st, DR_OK);
    assert_int_not_equal(st, DR_ETIMEDOUT);
    dr_client_close_sync(c);
    assert_int_equal(dr_client_connect_sync(c), DR_OK);
    assert_int_equal(dr_client_read_asm_sync(c, DR_ASM_BIT_OUT, buf, 8), DR_OK);
}

int main(void)
{
    host = getenv("CPPPO_HOST");
    const char *p = getenv("CPPPO_PORT");
    if (host == NULL || p == NULL) {
        fprintf(stderr, "test_client_cpppo: run it through tests/interop/with_cpppo.py "
                        "(CPPPO_HOST, CPPPO_PORT)\n");
        return 2;
    }
    port = (uint16_t)strtoul(p, NULL, 10);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup_teardown(test_read_every_assembly, setup, teardown),
        cmocka_unit_test_setup_teardown(test_write_and_read_back_every_assembly, setup, teardown),
        cmocka_unit_test_setup_teardown(test_second_session_sees_writes, setup, teardown),
        cmocka_unit_test(test_unconnected_send),
        cmocka_unit_test(test_wrong_size_refused),
        cmocka_unit_test_setup_teardown(test_combined_points, setup, teardown),
        cmocka_unit_test_setup_teardown(test_identity, setup, teardown),
        cmocka_unit_test_setup_teardown(test_peer_hangs_up_then_reconnect, setup, teardown),
    };
    return cmocka_run_group_tests_name("client_cpppo", tests, NULL, NULL);
}
