/* SPDX-License-Identifier: MIT */
/* lib/cip.c builders and parsers added for drsim: RegisterSession body,
 * SendRRData body, ListServices reply. */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "cip_internal.h"
#include "drgate/codec.h" /* dr_get_le16 */

static void test_register_body(void **state)
{
    (void)state;
    uint8_t b[8];
    dr_wr_t w;
    dr_wr_init(&w, b, sizeof b);
    dr_register_write(&w, 1, 0);
    assert_int_equal(w.len, 4);
    static const uint8_t want[] = {0x01, 0x00, 0x00, 0x00};
    assert_memory_equal(b, want, 4);
    uint16_t v = 9, o = 9;
    assert_int_equal(dr_register_parse(b, 4, &v, &o), DR_OK);
    assert_int_equal(v, 1);
    assert_int_equal(o, 0);
    assert_int_equal(dr_register_parse(b, 3, &v, &o), DR_ESHORT);
    assert_int_equal(dr_register_parse(b, 5, &v, &o), DR_ELONG);
    assert_int_equal(dr_register_parse(NULL, 0, &v, &o), DR_ESHORT);
}

static void test_rr_body(void **state)
{
    (void)state;
    uint8_t b[64];
    dr_wr_t w;
    dr_wr_init(&w, b, sizeof b);
    dr_rr_begin(&w, 7);
    dr_cpf_begin(&w, 2);
    size_t m = dr_cpf_item_begin(&w, DR_CPF_NULL);
    dr_cpf_item_end(&w, m);
    m = dr_cpf_item_begin(&w, DR_CPF_UNCONNECTED_DATA);
    dr_wr_u8(&w, 0x0E);
    dr_cpf_item_end(&w, m);
    static const uint8_t want[] = {0, 0, 0, 0, 7, 0, 2, 0, 0, 0, 0, 0,
                                   0xB2, 0, 1, 0, 0x0E};
    assert_int_equal(w.len, sizeof want);
    assert_memory_equal(b, want, sizeof want);
    uint32_t iface = 1;
    uint16_t timeout = 0;
    dr_cpf_t cpf;
    assert_int_equal(dr_rr_parse(b, w.len, &iface, &timeout, &cpf), DR_OK);
    assert_int_equal(iface, 0);
    assert_int_equal(timeout, 7);
    assert_int_equal(cpf.count, 2);
    assert_int_equal(cpf.item[1].length, 1);
    /* Every truncation is an error, never a read past the end. */
    for (size_t n = 0; n < w.len; n++)
        assert_int_not_equal(dr_rr_parse(b, n, &iface, &timeout, &cpf), DR_OK);
    assert_int_equal(dr_rr_parse(b, w.len + 1, &iface, &timeout, &cpf), DR_ELONG);
}

static void test_list_services(void **state)
{
    (void)state;
    uint8_t b[64];
    dr_wr_t w;
    dr_wr_init(&w, b, sizeof b);
    dr_list_services_write(&w, DR_SVC_FLAG_CIP_TCP | DR_SVC_FLAG_CLASS01_UDP);
    assert_false(w.overflow);
    dr_cpf_t cpf;
    assert_int_equal(dr_cpf_parse(b, w.len, &cpf), DR_OK);
    const dr_cpf_item_t *it = dr_cpf_find(&cpf, DR_CPF_LIST_SERVICES);
    assert_non_null(it);
    assert_int_equal(it->length, 20);
    assert_int_equal(dr_get_le16(it->data), 1);
    assert_int_equal(dr_get_le16(it->data + 2), 0x0120);
    assert_memory_equal(it->data + 4, "Communications\0\0", 16);
    /* Too small a buffer overflows instead of writing past it. */
    dr_wr_init(&w, b, 10);
    dr_list_services_write(&w, 0);
    assert_true(w.overflow);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_register_body),
        cmocka_unit_test(test_rr_body),
        cmocka_unit_test(test_list_services),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
