/* SPDX-License-Identifier: MIT */
/*
 * The console's register map (gw_regmap_json, /api/v1/robots/NAME/map):
 * every leaf once, keyed as drcli get --json keys it; every address the
 * default map prints for a leaf (drgatewayd --print-map --json, the same
 * slots) is in that leaf's entry; the word order, the scaled view, the
 * packed bits, the enum names, the user's map and write rights as
 * configured; a buffer too small says so instead of cutting the text.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "modbus/regmap.h"
#include "modbus/usermap.h"

static gw_config_t C;
static char *Buf;

static void umap(gw_robot_config_t *r, const char *line)
{
    gw_umap_entry_t e;
    char err[300];
    if (!gw_umap_parse(line, 1, &e, err, sizeof err) || !gw_umap_add(&r->side.modbus.map, &e, err, sizeof err))
        fail_msg("map '%s': %s", line, err);
}

static int setup(void **state)
{
    (void)state;
    gw_config_defaults(&C);
    C.robot_count = 2;
    for (unsigned r = 0; r < 2; r++) {
        snprintf(C.robot[r].name, sizeof C.robot[r].name, r ? "arm\"2" : "arm1");
        C.robot[r].side.modbus.unit_id = (uint8_t)(r + 1);
        C.robot[r].side.modbus.default_map_writes = true;
    }
    C.side.modbus.word_order = GW_WORD_CDAB;
    umap(&C.robot[0], "hr 3000 float_in[0..1] real writable");
    umap(&C.robot[0], "ir 3100 joint_state.position[1..6] int16 scale=100 saturate");
    umap(&C.robot[0], "ir 3200 io_state.cb_di bits");
    Buf = malloc(GW_REGMAP_JSON_SIZE);
    return Buf == NULL;
}

static int teardown(void **state)
{
    (void)state;
    free(Buf);
    return 0;
}

static const char *robot_json(unsigned r)
{
    gw_json_t j;
    gw_json_init(&j, Buf, GW_REGMAP_JSON_SIZE);
    assert_true(gw_regmap_json(&j, &C, r));
    assert_false(j.full);
    return Buf;
}

/* The line of leaf `path` (each leaf is one line), copied into line. */
static bool leaf_line(const char *json, const char *path, char *line, size_t size)
{
    char key[128];
    snprintf(key, sizeof key, "{\"path\": \"%s\", ", path);
    const char *p = strstr(json, key);
    if (p == NULL)
        return false;
    const char *e = strchr(p, '\n');
    size_t n = e != NULL ? (size_t)(e - p) : strlen(p);
    if (n >= size)
        n = size - 1;
    memcpy(line, p, n);
    line[n] = '\0';
    return true;
}

static void has(const char *json, const char *path, const char *want)
{
    char line[4096];
    if (!leaf_line(json, path, line, sizeof line))
        fail_msg("no leaf %s", path);
    if (strstr(line, want) == NULL)
        fail_msg("%s: '%s' has no '%s'", path, line, want);
}

static void lacks(const char *json, const char *path, const char *what)
{
    char line[4096];
    if (!leaf_line(json, path, line, sizeof line))
        fail_msg("no leaf %s", path);
    if (strstr(line, what) != NULL)
        fail_msg("%s: '%s' has '%s'", path, line, what);
}

static unsigned count(const char *s, const char *what)
{
    unsigned n = 0;
    for (const char *p = strstr(s, what); p != NULL; p = strstr(p + 1, what))
        n++;
    return n;
}

static void test_every_leaf_once(void **state)
{
    (void)state;
    const char *j = robot_json(0);
    assert_int_equal(count(j, "{\"path\": "), dr_leaf_count());
    for (uint16_t i = 0; i < dr_leaf_count(); i++) {
        dr_ref_t ref;
        char path[96], key[128];
        assert_int_equal(dr_leaf_at(i, &ref), DR_OK);
        assert_int_equal(dr_ref_path(ref, path, sizeof path), DR_OK);
        snprintf(key, sizeof key, "{\"path\": \"%s\", ", path);
        assert_int_equal(count(j, key), 1);
    }
    assert_non_null(strstr(j, "{\"robot\": \"arm1\", \"unit_id\": 1, \"word_order\": \"cdab\""));
    assert_string_equal(j + strlen(j) - 4, "\n]}\n");
    /* room for a full user map besides */
    print_message("map of arm1: %zu bytes\n", strlen(j));
    assert_true(strlen(j) < GW_REGMAP_JSON_SIZE / 2);
}

/* The value after `key` in a --print-map row: a number, or a string up to
 * its closing quote. */
static const char *after(const char *row, const char *key)
{
    const char *p = strstr(row, key);
    return p != NULL ? p + strlen(key) : NULL;
}

/* {"area": "IR", "address": 200, "count": 2, "name": "...", ...} */
static bool row_fields(const char *row, char area[4], unsigned long *addr, unsigned long *n,
                       char *name, size_t size)
{
    const char *a = after(row, "{\"area\": \""), *d = after(row, "\"address\": ");
    const char *c = after(row, "\"count\": "), *m = after(row, "\"name\": \"");
    if (a == NULL || d == NULL || c == NULL || m == NULL || a[0] == '\0' || a[1] == '\0')
        return false;
    memcpy(area, a, 2);
    area[2] = '\0';
    char *end;
    *addr = strtoul(d, &end, 10);
    if (end == d)
        return false;
    *n = strtoul(c, &end, 10);
    if (end == c)
        return false;
    const char *q = strchr(m, '"');
    if (q == NULL || (size_t)(q - m) >= size)
        return false;
    memcpy(name, m, (size_t)(q - m));
    name[q - m] = '\0';
    return true;
}

/* Every row --print-map --json prints for a leaf (not the status block,
 * the test registers or a packed mask, which name no leaf) is in that
 * leaf's entry with the same table, address and count. */
static void test_same_as_print_map(void **state)
{
    (void)state;
    const char *j = robot_json(0);
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    assert_non_null(f);
    gw_regmap_print_all(f, GW_PRINT_JSON, NULL, NULL);
    assert_int_equal(fclose(f), 0);
    assert_non_null(text);
    unsigned rows = 0, leaves = 0;
    for (char *p = strstr(text, "{\"area\""); p != NULL; p = strstr(p + 1, "{\"area\"")) {
        char area[4] = "", name[128] = "", want[128];
        unsigned long addr = 0, n = 0;
        if (!row_fields(p, area, &addr, &n, name, sizeof name))
            fail_msg("cannot read --print-map row: %.80s", p);
        rows++;
        dr_ref_t ref;
        if (dr_path_parse(name, &ref) != DR_OK || ref.elem < 0)
            continue; /* status, test, control, a whole packed mask */
        snprintf(want, sizeof want, "{\"table\": \"%s\", \"address\": %lu, \"count\": %lu, ",
                 area, addr, n);
        has(j, name, want);
        leaves++;
    }
    free(text);
    assert_true(rows > 500);
    assert_true(leaves > 400);
}

static void test_views(void **state)
{
    (void)state;
    const char *j = robot_json(0);
    /* a REAL: its two registers in the word order, and the scaled view */
    has(j, "joint_state.position[1]",
        "{\"table\": \"IR\", \"address\": 200, \"count\": 2, \"ref\": \"30201\", \"view\": "
        "\"real\", \"order\": \"cdab\", \"writable\": false}");
    has(j, "joint_state.position[1]",
        "{\"table\": \"IR\", \"address\": 1200, \"count\": 1, \"ref\": \"31201\", \"view\": "
        "\"int16\", \"scale\": 10, \"writable\": false}");
    has(j, "joint_state.position[1]", "\"type\": \"REAL\", \"unit\": \"degree\", \"dir\": \"T->O\"");
    /* the user's map: scale and saturation as written */
    has(j, "joint_state.position[2]",
        "{\"table\": \"IR\", \"address\": 3101, \"count\": 1, \"ref\": \"33102\", \"view\": "
        "\"int16\", \"scale\": 100, \"saturate\": true, \"writable\": false, \"user\": true}");
    /* an O->T REAL: writable in the default map and in the user's */
    has(j, "float_in[1]", "{\"table\": \"HR\", \"address\": 3002, \"count\": 2, \"ref\": \"43003\", "
                          "\"view\": \"real\", \"order\": \"cdab\", \"writable\": true, \"user\": true}");
    has(j, "float_in[1]", "\"dir\": \"O->T\"");
    has(j, "float_in[1]", "\"address\": 402, \"count\": 2, \"ref\": \"40403\", \"view\": \"real\", "
                          "\"order\": \"cdab\", \"writable\": true}");
    /* a bit of a mask: its packed register and bit, and its discrete input */
    has(j, "io_state.cb_di[3]", "\"view\": \"bits\", \"bit\": 2,");
    has(j, "io_state.cb_di[3]", "\"table\": \"DI\"");
    has(j, "io_state.cb_di[3]", "{\"table\": \"IR\", \"address\": 3200, \"count\": 1, \"ref\": \"33201\", "
                                "\"view\": \"bits\", \"bit\": 2, \"writable\": false, \"user\": true}");
    /* the enum's names, in the order of their values */
    has(j, "io_state.robot_state", "\"enum\": [\"INITIALIZING\", \"STANDBY\", \"OPERATING\", ");
    has(j, "io_state.robot_state", "\"type\": \"USINT enum\"");
    /* the other robot has no map of its own, and its name is escaped */
    const char *k = robot_json(1);
    assert_non_null(strstr(k, "{\"robot\": \"arm\\\"2\", \"unit_id\": 2"));
    assert_null(strstr(k, "\"user\": true"));
}

static void test_write_rights(void **state)
{
    (void)state;
    C.robot[0].side.modbus.default_map_writes = false;
    const char *j = robot_json(0);
    has(j, "float_in[0]", "\"address\": 400, \"count\": 2, \"ref\": \"40401\", \"view\": \"real\", "
                          "\"order\": \"cdab\", \"writable\": false}");
    has(j, "float_in[0]", "\"address\": 1400, \"count\": 1, \"ref\": \"41401\", \"view\": \"int16\", "
                          "\"scale\": 100, \"writable\": false}");
    has(j, "float_in[0]", "\"writable\": true, \"user\": true}");
    /* a bit a GPIO input drives: not writable over Modbus */
    C.robot[0].side.modbus.default_map_writes = true;
    C.side.gpio.count = 1;
    C.side.gpio.line[0].dir = GW_GPIO_INPUT;
    C.side.gpio.line[0].robot_index = 0;
    assert_int_equal(dr_path_parse("bit_in[5]", &C.side.gpio.line[0].field), DR_OK);
    j = robot_json(0);
    lacks(j, "bit_in[5]", "\"writable\": true");
    has(j, "bit_in[6]", "\"writable\": true");
    C.side.gpio.count = 0;
}

static void test_full_and_range(void **state)
{
    (void)state;
    char small[4096];
    gw_json_t j;
    gw_json_init(&j, small, sizeof small);
    assert_false(gw_regmap_json(&j, &C, 0));
    assert_true(j.full);
    gw_json_init(&j, Buf, GW_REGMAP_JSON_SIZE);
    assert_false(gw_regmap_json(&j, &C, 2)); /* no third robot */
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_every_leaf_once),
        cmocka_unit_test(test_same_as_print_map),
        cmocka_unit_test(test_views),
        cmocka_unit_test(test_write_rights),
        cmocka_unit_test(test_full_and_range),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
