/* SPDX-License-Identifier: MIT */
/*
 * The side list (gateway/sides.h, docs/gateway.md "Adding a side"): every
 * count and every table the core keeps of the sides is made from it, so
 * that a new side is its folder and one entry there. Checked here: the
 * counts are the list's length, every listed side's sections reach the
 * loader (parsed, in the allowed list, documented), each side's
 * configuration lies in its own member of gw_config_t, its keys of
 * [robot NAME] in its own member of the robot's, and the write path's
 * rules come from the sides' own configuration code.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/config.h"
#include "core/config_internal.h"
#include "core/north.h"
#include "core/write.h"
#include "sides.h"

/* The list's entries, spelled out once more by the preprocessor. */
#define NAME_OF(name) #name,
static const char *const listed[] = {GW_SIDES(NAME_OF)};

static void test_counts_come_from_the_list(void **state)
{
    (void)state;
    size_t n = sizeof listed / sizeof listed[0];
    assert_int_equal(GW_SIDE_COUNT, n);
    assert_int_equal(GW_NORTH_SIDES, n);
    for (size_t i = 0; i < n; i++) {
        assert_non_null(gw_side_cfgs[i]);
        assert_string_equal(gw_side_cfgs[i]->name, listed[i]);
        assert_non_null(gw_side_cfgs[i]->sections);
    }
    /* the loader's bound: the core's two sections and every side's */
    const gw_cfg_side_t *all[GW_CFG_MAX_SECTIONS];
    unsigned total = gw_cfg_all_sections(all);
    unsigned want = 2;
    for (size_t i = 0; i < n; i++) {
        unsigned k = 0;
        while (gw_side_cfgs[i]->sections[k] != NULL)
            k++;
        if (k > GW_CFG_SIDE_SECTIONS)
            fail_msg("side %s has %u sections (at most %u)", listed[i], k,
                     GW_CFG_SIDE_SECTIONS);
        want += k;
    }
    assert_int_equal(total, want);
    assert_true(total <= GW_CFG_MAX_SECTIONS);
}

/* Ranks are distinct (the order of messages and docs is the sections'
 * own), and the core's come where they always did. */
static void test_sections_in_rank_order(void **state)
{
    (void)state;
    const gw_cfg_side_t *all[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(all);
    for (unsigned i = 1; i < n; i++)
        if (all[i - 1]->rank >= all[i]->rank)
            fail_msg("[%s] rank %u, then [%s] rank %u", all[i - 1]->kw, all[i - 1]->rank,
                     all[i]->kw, all[i]->rank);
    assert_string_equal(all[0]->kw, "daemon");
    assert_string_equal(gw_config_sections(),
                        "[daemon], [modbus], [robot NAME], [gpio NAME], [modbus_rtu NAME], "
                        "[mqtt], [http], [opcua]");
}

/* Every listed side's sections: documented (--help-config), in the
 * allowed list, and their structs inside the sides' part of gw_config_t
 * (gw_sides_config_t, laid out from the list), not the core's. */
static void test_every_side_reaches_the_loader(void **state)
{
    (void)state;
    size_t lo = offsetof(gw_config_t, side), hi = lo + sizeof(gw_sides_config_t);
    for (unsigned i = 0; i < GW_SIDE_COUNT; i++) {
        for (unsigned k = 0; gw_side_cfgs[i]->sections[k] != NULL; k++) {
            const gw_cfg_side_t *s = gw_side_cfgs[i]->sections[k];
            char want[64];
            snprintf(want, sizeof want, "[%s%s]", s->kw, s->named ? " NAME" : "");
            if (strstr(gw_config_sections(), want) == NULL)
                fail_msg("%s not in the allowed sections", want);
            FILE *f = fopen("/dev/null", "w");
            assert_non_null(f);
            assert_true(gw_config_print_keys(f, s->kw));
            assert_int_equal(fclose(f), 0);
            size_t end = s->base + (s->named ? (size_t)s->max * s->stride : 0);
            if (s->base < lo || end > hi || (s->named && (s->count_off < lo || s->count_off >= hi)))
                fail_msg("[%s] lies outside gw_config_t.side", s->kw);
        }
    }
}

/* A file with a section of every side loads, each into its member. */
static void test_a_file_with_every_side(void **state)
{
    (void)state;
    char path[] = "/tmp/test_gw_sides_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    static const char text[] = "[robot arm]\nhost = 10.0.0.5\n"
                               "[modbus]\nport = 1502\nsingle_writer = yes\n"
                               "[modbus_rtu line]\ndevice = /dev/ttyS1\n"
                               "[gpio lamp]\nchip = gpiochip0\nline = 3\ndirection = input\n"
                               "field = bit_in[1]\n"
                               "[mqtt]\nhost = broker\n"
                               "[http]\nport = 8081\n";
    assert_int_equal(write(fd, text, sizeof text - 1), (ssize_t)(sizeof text - 1));
    assert_int_equal(close(fd), 0);
    static gw_config_t c;
    char err[512];
    bool ok = gw_config_load(path, &c, err, sizeof err);
    (void)unlink(path);
    if (!ok)
        fail_msg("%s", err);
    assert_int_equal(c.side.modbus.port, 1502);
    assert_int_equal(c.side.modbus.rtu_count, 1);
    assert_int_equal(c.side.gpio.count, 1);
    assert_true(c.side.mqtt.enabled);
    assert_true(c.side.http.enabled);
    /* what the sides' configuration tells the core */
    assert_string_equal(gw_config_brief(&c), "1 robot(s), 1 GPIO line(s)");
    assert_true(gw_config_keeps_log(&c));
    static gw_robot_t r;
    gw_write_policy_set(&r, &c, 0);
    assert_true(r.write_policy.one_owner);       /* the Modbus side's */
    assert_int_equal(r.write_policy.gpio_in_count, 1); /* the GPIO side's */
}

/* Each side's keys of [robot NAME]: in the robot's table (none left out
 * past GW_CFG_MAX_KEYS), each once, after the core key it names, their
 * values in the side's member of gw_robot_config_t.side; the Modbus
 * side's are where they always were among the core's, and a file's
 * Modbus keys land in the Modbus side's member. */
static void test_sides_robot_keys(void **state)
{
    (void)state;
    const gw_cfg_side_t *all[GW_CFG_MAX_SECTIONS];
    (void)gw_cfg_all_sections(all); /* merges them */
    const gw_cfg_side_t *r = &gw_cfg_robot;
    size_t lo = offsetof(gw_robot_config_t, side), hi = lo + sizeof(gw_robot_sides_config_t);
    unsigned total = 0;
    for (unsigned i = 0; i < GW_SIDE_COUNT; i++) {
        const gw_cfg_robot_keys_t *rk = gw_side_cfgs[i]->robot;
        for (unsigned k = 0; rk != NULL && k < rk->nkeys; k++) {
            const gw_cfg_key_t *key = &rk->keys[k];
            unsigned at = 0, n = 0;
            for (unsigned j = 0; j < r->nkeys; j++)
                if (strcmp(r->keys[j].name, key->name) == 0) {
                    at = j;
                    n++;
                }
            if (n != 1)
                fail_msg("side %s: robot key %s is %u times in [robot]", listed[i], key->name, n);
            if (key->after != NULL && (at == 0 || strcmp(r->keys[at - 1].name, key->after) != 0) &&
                (k == 0 || strcmp(r->keys[at - 1].name, rk->keys[k - 1].name) != 0))
                fail_msg("side %s: robot key %s not after %s", listed[i], key->name, key->after);
            if (key->type != GW_CFG_HOOK && (key->off < lo || key->off + key->size > hi))
                fail_msg("side %s: robot key %s lies outside gw_robot_config_t.side", listed[i],
                         key->name);
            total++;
        }
    }
    assert_true(r->nkeys <= GW_CFG_MAX_KEYS);
    /* the core's keys and the sides', every one of them */
    unsigned core = 0;
    for (unsigned j = 0; j < r->nkeys; j++) {
        bool side = false;
        for (unsigned i = 0; i < GW_SIDE_COUNT; i++) {
            const gw_cfg_robot_keys_t *rk = gw_side_cfgs[i]->robot;
            side |= rk != NULL && r->keys[j].off >= lo && r->keys[j].off < hi &&
                    r->keys[j].type != GW_CFG_HOOK;
            for (unsigned k = 0; rk != NULL && k < rk->nkeys; k++)
                side |= strcmp(rk->keys[k].name, r->keys[j].name) == 0;
        }
        core += !side;
    }
    assert_int_equal(core + total, r->nkeys);
    /* the order of messages and docs, as before the Modbus keys moved */
    static const char *const order[] = {
        "host", "tcp_port", "udp_port", "local_address", "local_udp_port", "unit_id",
        "unit_id_alias", "map", "default_map_writes", "mode", "rpi_ms",
        "timeout_multiplier", "timeout_ms", "fallback", "o2t_timing"};
    for (unsigned j = 0; j < sizeof order / sizeof order[0]; j++)
        assert_string_equal(r->keys[j].name, order[j]);

    char path[] = "/tmp/test_gw_sides_XXXXXX";
    int fd = mkstemp(path);
    assert_true(fd >= 0);
    static const char text[] = "[robot a]\nhost = 10.0.0.5\nunit_id = 7\nunit_id_alias = 0\n"
                               "map = hr 3000 float_in[0..1] real writable\n"
                               "default_map_writes = no\nfallback = hold\n"
                               "[robot b]\nhost = 10.0.0.6\nunit_id = 7\n";
    assert_int_equal(write(fd, text, sizeof text - 1), (ssize_t)(sizeof text - 1));
    assert_int_equal(close(fd), 0);
    static gw_config_t c;
    char err[512];
    assert_false(gw_config_load(path, &c, err, sizeof err));
    char want[600];
    snprintf(want, sizeof want,
             "%s:10: robot 'b': unit_id 7 already used by robot 'a' (line 3; each robot "
             "needs its own unit_id, allowed: 1..247)", path);
    assert_string_equal(err, want);
    fd = open(path, O_WRONLY | O_TRUNC);
    assert_true(fd >= 0);
    size_t keep = strlen(text) - strlen("unit_id = 7\n");
    assert_int_equal(write(fd, text, keep), (ssize_t)keep);
    assert_int_equal(close(fd), 0);
    bool ok = gw_config_load(path, &c, err, sizeof err);
    (void)unlink(path);
    if (!ok)
        fail_msg("%s", err);
    const gw_modbus_robot_config_t *m = &c.robot[0].side.modbus;
    assert_int_equal(m->unit_id, 7);
    assert_true(m->alias0 && !m->alias255);
    assert_int_equal(m->map.count, 1);
    assert_false(m->default_map_writes);
    assert_true(m->fallback_hold);
    assert_int_equal(c.robot[1].side.modbus.unit_id, 1);
    assert_true(c.robot[1].side.modbus.default_map_writes);
    char brief[64];
    assert_string_equal(gw_config_robot_brief(&c.robot[0], brief, sizeof brief), ", unit ID 7");
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_counts_come_from_the_list),
        cmocka_unit_test(test_sections_in_rank_order),
        cmocka_unit_test(test_every_side_reaches_the_loader),
        cmocka_unit_test(test_a_file_with_every_side),
        cmocka_unit_test(test_sides_robot_keys),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
