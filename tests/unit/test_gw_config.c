/* SPDX-License-Identifier: MIT */
/*
 * gateway/core/config.c: good files (every key, every section spelling, every
 * shipped example), the defaults, and each kind of error with its exact
 * "FILE:LINE: message". Error cases are written to a temporary gw.ini so
 * each one sits in the table below next to the message it must produce.
 */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include <dirent.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "core/config.h"
#include "core/config_internal.h"
#include "modbus/regmap.h"

#ifndef GW_TEST_TOP
#define GW_TEST_TOP "."
#endif

static char tmpdir[256];
static char tmpini[300];

static int make_tmpdir(void **state)
{
    (void)state;
    const char *base = getenv("TMPDIR");
    snprintf(tmpdir, sizeof tmpdir, "%s/gwcfg.XXXXXX",
             base && *base ? base : "/tmp");
    if (mkdtemp(tmpdir) == NULL)
        return -1;
    snprintf(tmpini, sizeof tmpini, "%s/gw.ini", tmpdir);
    return 0;
}

static int remove_tmpdir(void **state)
{
    (void)state;
    unlink(tmpini);
    rmdir(tmpdir);
    return 0;
}

static void write_bytes(const char *text, size_t len)
{
    FILE *f = fopen(tmpini, "wb");
    assert_non_null(f);
    assert_int_equal(fwrite(text, 1, len, f), len);
    assert_int_equal(fclose(f), 0);
}

/* Load `text` as gw.ini; returns what gw_config_load returned. */
static bool load_text(const char *text, gw_config_t *cfg, char *err,
                      size_t errlen)
{
    write_bytes(text, strlen(text));
    return gw_config_load(tmpini, cfg, err, errlen);
}

static bool load_file(const char *rel, gw_config_t *cfg, char *err,
                      size_t errlen)
{
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", GW_TEST_TOP, rel);
    return gw_config_load(path, cfg, err, errlen);
}

/* ---- defaults -------------------------------------------------------------- */

static void test_defaults(void **state)
{
    (void)state;
    gw_config_t c;
    memset(&c, 0xA5, sizeof c);
    gw_config_defaults(&c);
    assert_string_equal(c.side.modbus.listen, "0.0.0.0");
    assert_int_equal(c.side.modbus.port, 502);
    assert_int_equal(c.side.modbus.max_clients, 16);
    assert_int_equal(c.side.modbus.idle_timeout_s, 60);
    assert_true(c.side.modbus.keepalive);
    assert_int_equal(c.side.modbus.word_order, GW_WORD_ABCD);
    assert_int_equal(c.side.modbus.on_link_loss, GW_LOSS_HOLD);
    assert_int_equal(c.side.modbus.unmapped_read, GW_UNMAPPED_ZERO);
    assert_int_equal(c.side.modbus.allow_count, 0);
    assert_false(c.side.modbus.single_writer);
    assert_int_equal(c.side.modbus.writer_watchdog_ms, 1000);
    assert_int_equal(c.side.modbus.request_timeout_ms, 3000);
    assert_int_equal(c.robot_count, 0);
    assert_int_equal(c.side.gpio.count, 0);
    assert_string_equal(c.log_level, "info");
    const gw_robot_config_t *r = &c.robot[0];
    assert_int_equal(r->tcp_port, 44818);
    assert_int_equal(r->udp_port, 2222);
    assert_int_equal(r->local_udp_port, 2222);
    assert_string_equal(r->local_addr, "");
    assert_int_equal(r->side.modbus.unit_id, 1);
    assert_int_equal(r->mode, GW_MODE_IMPLICIT);
    assert_int_equal(r->rpi_ms, 10);
    assert_int_equal(r->timeout_mult, 2);
    assert_int_equal(r->timeout_ms, 1000);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        assert_int_equal(r->instance[a], 101 + a);
    assert_false(r->side.modbus.fallback_hold);
    assert_false(r->o2t_strict);
    assert_int_equal(r->originator_serial, 0); /* derived at start, see link.c */
    assert_int_equal(c.side.gpio.line[0].offset, -1);
    assert_int_equal(c.side.gpio.line[0].bias, GW_BIAS_AS_IS);
}

static void test_minimal_gets_defaults(void **state)
{
    (void)state;
    gw_config_t c, d;
    char err[512];
    assert_true(
        load_text("[robot arm1]\nhost = 10.0.0.1\n", &c, err, sizeof err));
    assert_string_equal(err, "");
    gw_config_defaults(&d);
    assert_string_equal(c.path, tmpini);
    assert_memory_equal(&c.side.modbus, &d.side.modbus, sizeof c.side.modbus);
    assert_string_equal(c.log_level, "info");
    assert_int_equal(c.robot_count, 1);
    assert_string_equal(c.robot[0].name, "arm1");
    assert_string_equal(c.robot[0].host, "10.0.0.1");
    assert_int_equal(c.robot[0].line, 1);
    /* everything but name, host and line is the default */
    gw_robot_config_t r = c.robot[0];
    memcpy(r.name, d.robot[0].name, sizeof r.name);
    memcpy(r.host, d.robot[0].host, sizeof r.host);
    r.line = d.robot[0].line;
    assert_memory_equal(&r, &d.robot[0], sizeof r);
    assert_int_equal(c.side.gpio.count, 0);
}

/* ---- good files ------------------------------------------------------------ */

static void test_all_keys(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    bool ok = load_file("tests/gw_config/all-keys.ini", &c, err, sizeof err);
    if (!ok)
        fail_msg("%s", err);
    assert_string_equal(c.log_level, "debug");

    const gw_modbus_config_t *m = &c.side.modbus;
    assert_string_equal(m->listen, "127.0.0.1");
    assert_int_equal(m->port, 1502);
    assert_int_equal(m->max_clients, 3);
    assert_int_equal(m->idle_timeout_s, 0);
    assert_false(m->keepalive);
    assert_int_equal(m->word_order, GW_WORD_DCBA);
    assert_int_equal(m->allow_count, 3);
    assert_int_equal(m->allow[0].net, 0x7F000001u);
    assert_int_equal(m->allow[0].mask, 0xFFFFFFFFu);
    assert_true(m->allow[0].read_write);
    assert_int_equal(m->allow[1].net, 0x0A000000u);
    assert_int_equal(m->allow[1].mask, 0xFF000000u);
    assert_false(m->allow[1].read_write); /* no access word: read-only */
    assert_int_equal(m->allow[2].net, 0);
    assert_int_equal(m->allow[2].mask, 0);
    assert_false(m->allow[2].read_write);
    assert_int_equal(m->on_link_loss, GW_LOSS_EXCEPTION);
    assert_int_equal(m->unmapped_read, GW_UNMAPPED_EXCEPTION);
    assert_true(m->single_writer);
    assert_int_equal(m->writer_watchdog_ms, 250);
    assert_int_equal(m->request_timeout_ms, 1500);

    assert_int_equal(c.robot_count, 2);
    const gw_robot_config_t *r = &c.robot[0];
    assert_string_equal(r->name, "arm1");
    assert_string_equal(r->host, "robot-1.cell.example");
    assert_int_equal(r->tcp_port, 44819);
    assert_int_equal(r->udp_port, 2223);
    assert_string_equal(r->local_addr, "127.0.0.1");
    assert_int_equal(r->local_udp_port, 2224);
    assert_int_equal(r->side.modbus.unit_id, 7);
    assert_int_equal(r->mode, GW_MODE_EXPLICIT);
    assert_int_equal(r->rpi_ms, 50);
    assert_int_equal(r->timeout_mult, 5);
    assert_int_equal(r->timeout_ms, 300);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        assert_int_equal(r->instance[a], 201 + a);
    assert_true(r->side.modbus.fallback_hold);
    assert_true(r->o2t_strict);
    assert_int_equal(r->config_instance, 150);
    assert_int_equal(r->input_only_heartbeat, 151);
    assert_int_equal(r->listen_only_heartbeat, 152);
    assert_int_equal(r->originator_serial, 0xC0FFEE01u);
    assert_int_equal(c.robot[1].originator_serial, 3405691582u);
    assert_int_equal(r->open[DR_ASM_IO_STATE].o2t, DR_ASM_BIT_IN);
    assert_int_equal(r->open[DR_ASM_JOINT_STATE].kind, GW_OPEN_OWNER);
    assert_int_equal(r->open[DR_ASM_JOINT_STATE].o2t, DR_ASM_IO_CONTROL);
    assert_int_equal(r->open[DR_ASM_TASK_STATE].kind, GW_OPEN_LISTEN_ONLY);
    assert_int_equal(r->open[DR_ASM_BIT_OUT].kind, GW_OPEN_NONE);
    assert_int_equal(r->open[DR_ASM_INT_OUT].kind, GW_OPEN_INPUT_ONLY);
    assert_int_equal(r->open[DR_ASM_FLOAT_OUT].o2t, DR_ASM_INT_IN);
    assert_int_equal(r->line, 23);
    assert_string_equal(c.robot[1].name, "arm2");
    assert_int_equal(c.robot[1].side.modbus.unit_id, 8);
    assert_false(c.robot[1].side.modbus.fallback_hold);
    assert_false(c.robot[1].o2t_strict);

    assert_int_equal(c.side.gpio.count, 2);
    const gw_gpio_config_t *g = &c.side.gpio.line[0];
    char path[64];
    assert_string_equal(g->name, "lamp");
    assert_string_equal(g->chip, "/dev/gpiochip1");
    assert_int_equal(g->offset, 5);
    assert_string_equal(g->line_name, "");
    assert_int_equal(g->dir, GW_GPIO_OUTPUT);
    assert_string_equal(g->robot, "arm2");
    assert_int_equal(g->robot_index, 1);
    assert_int_equal(dr_ref_path(g->field, path, sizeof path), DR_OK);
    assert_string_equal(path, "io_state.cb_do[3]");
    assert_true(g->active_low);
    assert_int_equal(g->bias, GW_BIAS_DISABLE);
    assert_true(g->safe_value);
    g = &c.side.gpio.line[1];
    assert_string_equal(g->name, "button");
    assert_string_equal(g->chip, "gpio-mockup-A");
    assert_int_equal(g->offset, -1);
    assert_string_equal(g->line_name, "BUTTON_1");
    assert_int_equal(g->dir, GW_GPIO_INPUT);
    assert_string_equal(g->robot, "arm1");
    assert_int_equal(g->robot_index, 0);
    assert_int_equal(dr_ref_path(g->field, path, sizeof path), DR_OK);
    assert_string_equal(path, "bit_in[7]");
    assert_false(g->active_low);
    assert_int_equal(g->bias, GW_BIAS_PULL_UP);
    assert_int_equal(g->debounce_ms, 15);
    assert_false(g->safe_value);
}

static void test_section_forms(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    bool ok = load_file("tests/gw_config/forms.ini", &c, err, sizeof err);
    if (!ok)
        fail_msg("%s", err);
    assert_int_equal(c.side.modbus.port, 1503);
    assert_int_equal(c.robot_count, 3);
    assert_string_equal(c.robot[0].name, "robot"); /* a lone [robot] */
    assert_string_equal(c.robot[1].name, "tab_and_spaces");
    assert_string_equal(c.robot[2].name, "dotted-name");
    assert_int_equal(c.side.gpio.count, 2);
    assert_string_equal(c.side.gpio.line[0].name, "spaced");
    assert_int_equal(c.side.gpio.line[0].robot_index, 0);
    assert_string_equal(c.side.gpio.line[1].name, "dotted");
    assert_int_equal(c.side.gpio.line[1].robot_index, 2);
    char path[64];
    assert_int_equal(dr_ref_path(c.side.gpio.line[1].field, path, sizeof path), DR_OK);
    assert_string_equal(path, "io_state.aio_type.ai0");
}

static void test_gpio_robot_defaults_to_the_only_one(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    bool ok =
        load_text("[robot cell]\nhost = 10.0.0.1\n"
                  "[gpio x]\nchip = gpiochip0\nline = 3\ndirection = output\n"
                  "field = dr4[63]\n",
                  &c, err, sizeof err);
    if (!ok)
        fail_msg("%s", err);
    assert_string_equal(c.side.gpio.line[0].robot, "cell");
    assert_int_equal(c.side.gpio.line[0].robot_index, 0);
    assert_false(c.side.gpio.line[0].safe_value);
    assert_false(c.side.gpio.line[0].active_low);
}

static void test_text_variants(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    /* UTF-8 BOM, CRLF line ends, an indented comment, no final newline */
    static const char good[] =
        "\xEF\xBB\xBF[robot a]\r\n  ; note\r\nhost = 10.0.0.9";
    bool ok = load_text(good, &c, err, sizeof err);
    if (!ok)
        fail_msg("%s", err);
    assert_string_equal(c.robot[0].host, "10.0.0.9");
}

static void test_examples_load(void **state)
{
    (void)state;
    static const char *const required[] = { "minimal.ini",
                                            "explicit-polling.ini",
                                            "two-robots.ini", "gpio-cell.ini",
                                            "secure.ini" };
    char dirpath[512];
    snprintf(dirpath, sizeof dirpath, "%s/gateway/examples", GW_TEST_TOP);
    DIR *d = opendir(dirpath);
    assert_non_null(d);
    unsigned found = 0, loaded = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL) {
        size_t n = strlen(e->d_name);
        if (n < 5 || strcmp(e->d_name + n - 4, ".ini") != 0)
            continue;
        char rel[300];
        snprintf(rel, sizeof rel, "gateway/examples/%s", e->d_name);
        gw_config_t c;
        char err[512];
        if (!load_file(rel, &c, err, sizeof err))
            fail_msg("example %s: %s", e->d_name, err);
        loaded++;
        for (size_t i = 0; i < sizeof required / sizeof required[0]; i++)
            if (strcmp(e->d_name, required[i]) == 0)
                found++;
    }
    closedir(d);
    assert_int_equal(found, sizeof required / sizeof required[0]);
    assert_true(loaded >= found);
}

/* Spot checks that the examples say what their comments say. */
static void test_example_values(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    assert_true(load_file("gateway/examples/secure.ini", &c, err, sizeof err));
    assert_int_equal(c.side.modbus.allow_count, 3);
    assert_true(c.side.modbus.allow[0].read_write);
    assert_false(c.side.modbus.allow[1].read_write);
    assert_true(c.side.modbus.single_writer);
    assert_true(
        load_file("gateway/examples/two-robots.ini", &c, err, sizeof err));
    assert_int_equal(c.robot_count, 2);
    assert_int_equal(c.robot[1].side.modbus.unit_id, 2);
    assert_true(
        load_file("gateway/examples/gpio-cell.ini", &c, err, sizeof err));
    assert_int_equal(c.side.gpio.count, 4);
    assert_int_equal(c.side.gpio.line[2].dir, GW_GPIO_INPUT);
    assert_true(load_file("gateway/examples/explicit-polling.ini", &c, err,
                          sizeof err));
    assert_int_equal(c.robot[0].mode, GW_MODE_EXPLICIT);
    assert_true(load_file("gateway/examples/rs485-cell.ini", &c, err, sizeof err));
    assert_int_equal(c.side.modbus.rtu_count, 1);
    assert_true(c.side.modbus.rtu[0].rs485);
    assert_int_equal(c.side.modbus.rtu[0].parity, GW_PARITY_EVEN);
    assert_int_equal(c.side.modbus.rtu[0].slave_count, 2);
    assert_int_equal(c.side.modbus.rtu[0].slave_addr[0], 10); /* weld:10 */
    assert_int_equal(c.side.modbus.rtu[0].slave_addr[1], 2);  /* handling: its unit_id */
}

/* [modbus_rtu]: defaults (19200 8E1, every robot at its unit_id). */
static void test_rtu_defaults(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nunit_id = 7\n"
                          "[robot b]\nhost = 10.0.0.2\nunit_id = 9\n"
                          "[modbus_rtu.l]\ndevice = /dev/ttyUSB0\n",
                          &c, err, sizeof err));
    assert_int_equal(c.side.modbus.rtu_count, 1);
    assert_string_equal(c.side.modbus.rtu[0].device, "/dev/ttyUSB0");
    assert_int_equal(c.side.modbus.rtu[0].baud, 19200);
    assert_int_equal(c.side.modbus.rtu[0].parity, GW_PARITY_EVEN);
    assert_int_equal(c.side.modbus.rtu[0].stop_bits, 1);
    assert_false(c.side.modbus.rtu[0].rs485);
    assert_int_equal(c.side.modbus.rtu[0].slave_count, 2);
    assert_int_equal(c.side.modbus.rtu[0].slave_robot[1], 1);
    assert_int_equal(c.side.modbus.rtu[0].slave_addr[0], 7);
    assert_int_equal(c.side.modbus.rtu[0].slave_addr[1], 9);
}

/* ---- errors ---------------------------------------------------------------- */

#define ROBOT "[robot a]\nhost = 10.0.0.1\n" /* lines 1-2 */
#define GPIO_HEAD \
    "[gpio g]\nchip = gpiochip0\n" /* then line, direction, field */

typedef struct {
    const char *text;
    const char *want; /* "LINE: message", after "PATH:" */
} err_case_t;

#define MODBUS_KEYS                                                           \
    "listen, port, max_clients, idle_timeout, keepalive, word_order, allow, " \
    "on_link_loss, unmapped_read, "                                           \
    "single_writer, writer_watchdog_ms, request_timeout_ms"
#define ROBOT_KEYS                                                             \
    "host, tcp_port, udp_port, local_address, local_udp_port, unit_id, unit_id_alias, map, default_map_writes, mode, " \
    "rpi_ms, "                                                                 \
    "timeout_multiplier, timeout_ms, fallback, o2t_timing, config_instance, "  \
    "input_only_heartbeat, listen_only_heartbeat, originator_serial, "        \
    "eds, layout, input_instance, input_assemblies, input_size, output_instance, " \
    "output_assemblies, output_size, "                                         \
    "instance.<assembly>, open.<T->O assembly>"
#define OPEN_ALLOWED "owner:<O->T assembly>, input_only, listen_only, none"
#define SECTIONS "[daemon], [modbus], [robot NAME], [gpio NAME], [modbus_rtu NAME], [mqtt], [http], [opcua]"
#define NOT_A_BIT                                                        \
    "(a GPIO line follows or drives one bit, e.g. io_state.cb_do[1] or " \
    "bit_in[0])"

#define RTU_HEAD "[modbus_rtu l]\ndevice = /dev/ttyS1\n" /* then lines 5.. */

static const err_case_t err_cases[] = {
    /* layouts (issue 31) */
    { ROBOT "layout = combined\ninput_size = 480\n",
      "4: robot 'a': input_size 480 does not add up: io_state 36 + joint_state 144 + "
      "task_state 96 + bit_out 8 + int_out 96 + float_out 96 = 476 bytes (layout "
      "combined; set input_size to 476, or input_assemblies to what the robot's EDS or "
      "drcli probe says its instance carries)" },
    { ROBOT "layout = gpr_only\noutput_size = 212\n",
      "4: robot 'a': output_size 212 does not add up: bit_in 8 + int_in 96 + float_in 96 "
      "= 200 bytes (layout gpr_only; set output_size to 200, or output_assemblies to what "
      "the robot's EDS or drcli probe says its instance carries)" },
    { ROBOT "layout = combined\noutput_size = 24\noutput_assemblies = io_control, bit_in\n",
      "5: robot 'a': output_size 24 does not add up: io_control 12 + bit_in 8 = 20 bytes "
      "(layout combined; set output_size to 20, or output_assemblies to what the robot's "
      "EDS or drcli probe says its instance carries)" },
    { ROBOT "input_instance = 100\n",
      "3: robot 'a': input_instance applies to layout combined or gpr_only (this robot's "
      "layout is per_assembly: set layout = combined, or use instance.* and open.*)" },
    { ROBOT "layout = combined\ninstance.io_state = 5\n",
      "4: robot 'a': instance.io_state applies to layout per_assembly (layout combined has "
      "input_instance and output_instance)" },
    { ROBOT "layout = combined\nopen.bit_out = none\n",
      "4: robot 'a': open.bit_out applies to layout per_assembly (layout combined has "
      "input_instance and output_instance)" },
    { ROBOT "layout = combined\ninput_assemblies = io_state, io_control\n",
      "4: input_assemblies 'io_control' invalid: io_control is consumed by the robot "
      "(O->T); the input carries T->O assemblies (allowed: io_state, joint_state, "
      "task_state, bit_out, int_out, float_out)" },
    { ROBOT "layout = combined\noutput_assemblies = bit_in dr8\n",
      "4: output_assemblies: bit_in named twice" },
    { ROBOT "layout = combined\noutput_assemblies = bit_in, bitt_in\n",
      "4: unknown assembly 'bitt_in' in 'output_assemblies' (did you mean 'bit_in'? "
      "allowed: io_state, joint_state, task_state, bit_out, int_out, float_out, "
      "io_control, bit_in, int_in, float_in, or dr1..dr10)" },
    { ROBOT "layout = combined\ninput_instance = 7\noutput_instance = 7\n",
      "5: robot 'a': input_instance and output_instance are both 7 (each needs its own "
      "instance)" },
    { ROBOT "layout = gpr_only\nconfig_instance = 150\n",
      "4: robot 'a': config_instance 150 is also the output instance (a connection point "
      "names one thing)" },
    { ROBOT "layout = combined\noutput_assemblies = none\noutput_size = 4\n",
      "5: robot 'a': output_size 4, but output_assemblies is none" },
    { ROBOT "layout = combined\noutput_assemblies = none\ninput_only_heartbeat = 100\n",
      "5: robot 'a': input_only_heartbeat 100 is also the input instance (a connection "
      "point names one thing)" },
    { ROBOT "layout = sliced\n",
      "3: layout 'sliced' invalid (allowed: per_assembly, combined, gpr_only)" },
    /* [modbus_rtu NAME] */
    { ROBOT "[modbus_rtu]\ndevice = /dev/ttyS1\n",
      "3: section [modbus_rtu] needs a name (allowed: [modbus_rtu NAME] or "
      "[modbus_rtu.NAME])" },
    { ROBOT "[modbus_rtu l]\nbaud = 9600\n",
      "3: modbus_rtu 'l' has no device (allowed: a serial port such as /dev/ttyS0)" },
    { ROBOT RTU_HEAD "baud = 14400\n",
      "5: baud 14400 not a standard rate (allowed: 1200, 2400, 4800, 9600, 19200, "
      "38400, 57600, 115200, 230400)" },
    { ROBOT RTU_HEAD "parity = mark\n",
      "5: parity 'mark' invalid (allowed: none, even, odd)" },
    { ROBOT RTU_HEAD "data_bits = 7\n",
      "5: data_bits 7 out of range (allowed: 8..8)" },
    { ROBOT RTU_HEAD "robots = b\n",
      "5: modbus_rtu 'l': no robot 'b' (allowed: the NAME of a [robot NAME] section)" },
    { ROBOT RTU_HEAD "robots = a:248\n",
      "5: robots: slave address of 'a' invalid (allowed: 1..247)" },
    { ROBOT "[robot b]\nhost = 10.0.0.2\nunit_id = 5\n" RTU_HEAD "robots = a:5, b\n",
      "8: modbus_rtu 'l': robot 'b' has the slave address of another robot on the "
      "line (each needs its own, 1..247)" },
    { ROBOT RTU_HEAD "[modbus_rtu m]\ndevice = /dev/ttyS1\n",
      "6: modbus_rtu 'm': device /dev/ttyS1 is already modbus_rtu 'l' (line 3)" },
    /* unknown keys, with and without a suggestion */
    { ROBOT "[modbus]\nwordorder = abcd\n",
      "4: unknown key 'wordorder' in [modbus] (did you mean 'word_order'? "
      "allowed: " MODBUS_KEYS ")" },
    { ROBOT "[modbus]\nfoo = 1\n",
      "4: unknown key 'foo' in [modbus] (allowed: " MODBUS_KEYS ")" },
    { ROBOT "hots = x\n", "3: unknown key 'hots' in [robot a] (did you mean "
                          "'host'? allowed: " ROBOT_KEYS ")" },
    /* the user's register map and unit ID aliases (issue 22) */
    { ROBOT "map = hr 2000 int_in[0..3] dint\nmap = hr 2006 int_in[4] dint\n",
      "4: map: hr 2006-2007 overlaps the block at hr 2000-2007 (line 3)" },
    { ROBOT "map = hr 310 int_in[0] int16 saturate\n",
      "3: map: hr 310 is int_in[5] in the default map (place the block where "
      "drgatewayd --print-map shows nothing, e.g. hr 2048 and up)" },
    { ROBOT "map = hr 2000 int_out[0] dint writable\n",
      "3: map: 'int_out[0]' is written by the robot (T->O int_out): it cannot be "
      "writable (only O->T fields: io_control, bit_in, int_in, float_in)" },
    { ROBOT "map = hr 65534 float_in[0..1] real\n",
      "3: map: block hr 65534 takes 4 addresses: past the table's last, 65535" },
    { ROBOT "map = hr 2000 float_in[0] int16 scale=10\n",
      "3: map: int16 x 10 cannot hold every value of a REAL field (add 'saturate' "
      "to clamp to -32768..32767, or a smaller scale)" },
    { ROBOT "map = hr 2000 int_in[0..30] dint\n",
      "3: map: range 'int_in[0..30]' invalid: index out of range (allowed: "
      "int_in[0..23])" },
    { ROBOT "unit_id_alias = 0,255\n[robot b]\nhost = 10.0.0.2\nunit_id = 2\n"
            "unit_id_alias = 255\n",
      "7: robot 'b': unit_id_alias 255 is already robot 'a''s (line 3; one robot per alias)" },
    { ROBOT "instanse.io_state = 5\n",
      "3: unknown key 'instanse.io_state' in [robot a] (did you mean "
      "'instance.io_state'? "
      "allowed: " ROBOT_KEYS ")" },
    { ROBOT "instance.io_stat = 5\n",
      "3: unknown assembly 'io_stat' in 'instance.io_stat' (did you mean "
      "'io_state'? allowed: "
      "io_state, joint_state, task_state, bit_out, int_out, float_out, "
      "io_control, bit_in, "
      "int_in, float_in, or dr1..dr10)" },
    { "[daemon]\nlevel = info\n" ROBOT,
      "2: unknown key 'level' in [daemon] (allowed: log_level)" },
    { ROBOT GPIO_HEAD "lines = 3\n",
      "5: unknown key 'lines' in [gpio g] (did you mean 'line'? allowed: chip, "
      "line, direction, "
      "robot, field, active_low, bias, debounce_ms, safe_value)" },
    /* enumerations */
    { ROBOT "[modbus]\nword_order = abdc\n",
      "4: word_order 'abdc' invalid (allowed: abcd, cdab, badc, dcba)" },
    { ROBOT "[modbus]\nword_order = ABCD\n",
      "4: word_order 'ABCD' invalid (allowed: abcd, cdab, badc, dcba)" },
    { ROBOT "[modbus]\non_link_loss = keep\n",
      "4: on_link_loss 'keep' invalid (allowed: hold, zero, exception)" },
    { ROBOT "[modbus]\nunmapped_read = hold\n",
      "4: unmapped_read 'hold' invalid (allowed: zero, exception)" },
    { ROBOT "[modbus]\nkeepalive = maybe\n",
      "4: keepalive 'maybe' invalid (allowed: yes, no)" },
    { ROBOT "[modbus]\nsingle_writer = 1\n",
      "4: single_writer '1' invalid (allowed: yes, no)" },
    { ROBOT "mode = cyclic\n",
      "3: mode 'cyclic' invalid (allowed: implicit, explicit)" },
    { ROBOT "fallback = last\n",
      "3: fallback 'last' invalid (allowed: zero, hold)" },
    { ROBOT "o2t_timing = early\n",
      "3: o2t_timing 'early' invalid (allowed: follow, strict)" },
    { "[daemon]\nlog_level = verbose\n" ROBOT,
      "2: log_level 'verbose' invalid (allowed: error, warning, info, debug)" },
    { ROBOT GPIO_HEAD "direction = in\n",
      "5: direction 'in' invalid (allowed: output, input)" },
    { ROBOT GPIO_HEAD "bias = pullup\n",
      "5: bias 'pullup' invalid (allowed: as-is, disable, pull-up, "
      "pull-down)" },
    { ROBOT GPIO_HEAD "safe_value = high\n",
      "5: safe_value 'high' invalid (allowed: 0, 1)" },
    /* numbers: range, garbage, empty */
    { ROBOT "[modbus]\nport = 70000\n",
      "4: port 70000 out of range (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = 0\n",
      "4: port 0 out of range (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = 99999999999999999999999\n",
      "4: port 99999999999999999999999 out of range (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = 502x\n", "4: port '502x' invalid: trailing 'x' "
                                       "after the number (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = 0x1f6\n",
      "4: port '0x1f6' invalid: trailing 'x1f6' after the number (allowed: "
      "1..65535)" },
    { ROBOT "[modbus]\nport = -1\n",
      "4: port '-1' invalid: not a number (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = +502\n",
      "4: port '+502' invalid: not a number (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = 5 02\n", "4: port '5 02' invalid: trailing ' 02' "
                                       "after the number (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport =\n", "4: port has no value (allowed: 1..65535)" },
    { ROBOT "[modbus]\nport = 5\r\x1b[2J02\r\n",
      "4: port '5??[2J02' invalid: trailing '??[2J02' after the number "
      "(allowed: 1..65535)" },
    { ROBOT "[modbus]\nmax_clients = 257\n",
      "4: max_clients 257 out of range (allowed: 1..256)" },
    { ROBOT "[modbus]\nidle_timeout = 1d\n",
      "4: idle_timeout '1d' invalid: trailing 'd' after the number (allowed: "
      "0..86400)" },
    { ROBOT "[modbus]\nwriter_watchdog_ms = 5\n",
      "4: writer_watchdog_ms 5 out of range (allowed: 10..60000)" },
    { ROBOT "[modbus]\nrequest_timeout_ms = 99\n",
      "4: request_timeout_ms 99 out of range (allowed: 100..60000)" },
    { ROBOT "rpi_ms = 10ms\n", "3: rpi_ms '10ms' invalid: trailing 'ms' after "
                               "the number (allowed: 1..10000)" },
    { ROBOT "rpi_ms = 10001\n",
      "3: rpi_ms 10001 out of range (allowed: 1..10000)" },
    { ROBOT "rpi_ms = 0\n", "3: rpi_ms 0 out of range (allowed: 1..10000)" },
    { ROBOT "originator_serial = 0\n",
      "3: originator_serial 0 out of range (allowed: 1..4294967295)" },
    { ROBOT "originator_serial = 4294967296\n",
      "3: originator_serial 4294967296 out of range (allowed: 1..4294967295)" },
    { ROBOT "originator_serial = 0x0\n",
      "3: originator_serial 0x0 out of range (allowed: 1..4294967295, or 0x1..0xFFFFFFFF)" },
    { ROBOT "originator_serial = 0x123456789\n",
      "3: originator_serial '0x123456789' invalid: not a 32-bit hex number (allowed: "
      "1..4294967295, or 0x1..0xFFFFFFFF)" },
    { ROBOT "originator_serial = 0xC0FFEEZ\n",
      "3: originator_serial '0xC0FFEEZ' invalid: not a 32-bit hex number (allowed: "
      "1..4294967295, or 0x1..0xFFFFFFFF)" },
    { ROBOT "timeout_multiplier = 8\n",
      "3: timeout_multiplier 8 out of range (allowed: 0..7)" },
    { ROBOT "timeout_ms = 1.5\n", "3: timeout_ms '1.5' invalid: trailing '.5' "
                                  "after the number (allowed: 10..60000)" },
    { ROBOT "unit_id = 0\n", "3: unit_id 0 out of range (allowed: 1..247)" },
    { ROBOT "unit_id = 248\n",
      "3: unit_id 248 out of range (allowed: 1..247)" },
    { ROBOT "tcp_port = 65536\n",
      "3: tcp_port 65536 out of range (allowed: 1..65535)" },
    { ROBOT "instance.io_state = 0\n",
      "3: instance.io_state 0 out of range (allowed: 1..65535)" },
    { ROBOT "instance.dr3 =\n",
      "3: instance.dr3 has no value (allowed: 1..65535)" },
    { ROBOT GPIO_HEAD "debounce_ms = 1001\n",
      "5: debounce_ms 1001 out of range (allowed: 0..1000)" },
    { ROBOT GPIO_HEAD "line = 17a\n", "5: line '17a' invalid: trailing 'a' "
                                      "after the number (allowed: 0..65535)" },
    /* addresses */
    { ROBOT "[modbus]\nlisten = localhost\n",
      "4: listen 'localhost' invalid (allowed: an IPv4 address such as "
      "192.168.1.10)" },
    { ROBOT "[modbus]\nlisten = ::\n", "4: listen '::' invalid (allowed: an "
                                       "IPv4 address such as 192.168.1.10)" },
    { ROBOT "local_address = 10.0.0\n",
      "3: local_address '10.0.0' invalid (allowed: an IPv4 address such as "
      "192.168.1.10)" },
    { "[robot a]\nhost = 10.0.0.256\n",
      "2: host '10.0.0.256' invalid (allowed: an IPv4 address or a host "
      "name)" },
    { "[robot a]\nhost = robot_1\n",
      "2: host 'robot_1' invalid (allowed: an IPv4 address or a host name)" },
    { "[robot a]\nhost = -robot\n",
      "2: host '-robot' invalid (allowed: an IPv4 address or a host name)" },
    { "[robot a]\nhost = robot..cell\n",
      "2: host 'robot..cell' invalid (allowed: an IPv4 address or a host "
      "name)" },
    /* allowlist */
    { ROBOT "[modbus]\nallow = 192.168.1.5/24 rw\n",
      "4: allow '192.168.1.5/24 rw' invalid: host bits set in 192.168.1.5/24 "
      "(did you mean "
      "192.168.1.0/24?)" },
    { ROBOT "[modbus]\nallow = 192.168.1.0/33\n",
      "4: allow '192.168.1.0/33' invalid: prefix length '33' (allowed: "
      "0..32)" },
    { ROBOT "[modbus]\nallow = 192.168.1.0/\n",
      "4: allow '192.168.1.0/' invalid: prefix length '' (allowed: 0..32)" },
    { ROBOT "[modbus]\nallow = 192.168.1.0/24x\n",
      "4: allow '192.168.1.0/24x' invalid: prefix length '24x' (allowed: "
      "0..32)" },
    { ROBOT "[modbus]\nallow = 192.168.1/24\n",
      "4: allow '192.168.1/24' invalid: '192.168.1' is not an IPv4 address "
      "(allowed: "
      "a.b.c.d/len [ro|rw])" },
    { ROBOT "[modbus]\nallow = 10.0.0.0/8 wr\n",
      "4: allow '10.0.0.0/8 wr' invalid: access 'wr' (allowed: ro, rw)" },
    { ROBOT "[modbus]\nallow = 10.0.0.0/8 rw # office\n",
      "4: allow '10.0.0.0/8 rw # office' invalid: trailing '#' (allowed: "
      "a.b.c.d/len [ro|rw])" },
    { ROBOT "[modbus]\nallow = 10.0.0.0/8 ro\nallow = 10.1.2.3 rw\n",
      "5: allow '10.1.2.3 rw' never matches: line 4 already covers it (the "
      "first matching entry "
      "decides; put narrower networks first)" },
    { ROBOT "[modbus]\nallow = 10.0.0.0/8\nallow = 10.0.0.0/8 rw\n",
      "5: allow '10.0.0.0/8 rw' never matches: line 4 already covers it (the "
      "first matching "
      "entry decides; put narrower networks first)" },
    { ROBOT "[modbus]\nallow =\n",
      "4: allow has no value (allowed: a.b.c.d/len [ro|rw])" },
    { ROBOT
      "[modbus]\nallow = 10.0.0.1\nallow = 10.0.0.2\nallow = 10.0.0.3\n"
      "allow = 10.0.0.4\nallow = 10.0.0.5\nallow = 10.0.0.6\nallow = 10.0.0.7\n"
      "allow = 10.0.0.8\nallow = 10.0.0.9\nallow = 10.0.0.10\nallow = "
      "10.0.0.11\n"
      "allow = 10.0.0.12\nallow = 10.0.0.13\nallow = 10.0.0.14\nallow = "
      "10.0.0.15\n"
      "allow = 10.0.0.16\nallow = 10.0.0.17\n",
      "20: too many allow entries (at most 16)" },
    /* fields */
    { ROBOT GPIO_HEAD "field = io_state.cb_dl[3]\n",
      "5: field 'io_state.cb_dl[3]' unknown (closest: io_state.cb_di[3])" },
    { ROBOT GPIO_HEAD "field = io_state.cb_di\n",
      "5: field 'io_state.cb_di' is a whole mask, not one bit (allowed: "
      "io_state.cb_di[1]..io_state.cb_di[16])" },
    { ROBOT GPIO_HEAD "field = bit_in\n",
      "5: field 'bit_in' is a whole mask, not one bit (allowed: "
      "bit_in[0]..bit_in[63])" },
    { ROBOT GPIO_HEAD "field = io_state.cb_di[17]\n",
      "5: field 'io_state.cb_di[17]' index out of range (allowed: "
      "io_state.cb_di[1]..io_state.cb_di[16])" },
    { ROBOT GPIO_HEAD "field = io_state.cb_di[0]\n",
      "5: field 'io_state.cb_di[0]' index out of range (allowed: "
      "io_state.cb_di[1]..io_state.cb_di[16])" },
    { ROBOT GPIO_HEAD "field = io_state.servo_on[1]\n",
      "5: field 'io_state.servo_on[1]' takes no index (allowed: "
      "io_state.servo_on)" },
    { ROBOT GPIO_HEAD "field = bit_in[x]\n",
      "5: field 'bit_in[x]' has a malformed index (allowed: a decimal index, "
      "e.g. "
      "io_state.cb_do[1])" },
    { ROBOT GPIO_HEAD "field = joint_state.position[1]\n",
      "5: field 'joint_state.position[1]' is a REAL, not a bit " NOT_A_BIT },
    { ROBOT GPIO_HEAD "field = joint_state.position\n",
      "5: field 'joint_state.position' is a REAL, not a bit " NOT_A_BIT },
    { ROBOT GPIO_HEAD "field = io_state.robot_state\n",
      "5: field 'io_state.robot_state' is a USINT enum, not a bit " NOT_A_BIT },
    { ROBOT GPIO_HEAD "field = int_in[3]\n",
      "5: field 'int_in[3]' is a DINT, not a bit " NOT_A_BIT },
    { ROBOT GPIO_HEAD
      "line = 1\ndirection = input\nfield = io_state.cb_do[3]\n",
      "7: gpio 'g': input cannot drive 'io_state.cb_do[3]', which the robot "
      "produces (T->O); "
      "inputs drive O->T bits (io_control.cb_do[N], io_control.tool_do[N], "
      "io_control.ao_type.*, bit_in[N])" },
    { ROBOT GPIO_HEAD "field = bit_out[2]\nline = 1\ndirection = input\n",
      "5: gpio 'g': input cannot drive 'bit_out[2]', which the robot produces "
      "(T->O); "
      "inputs drive O->T bits (io_control.cb_do[N], io_control.tool_do[N], "
      "io_control.ao_type.*, bit_in[N])" },
    /* an input on an O->T assembly no owner connection writes (runtime
     * writes to it get exception 0x02: the input would drive nothing) */
    { ROBOT "open.bit_out = input_only\n" GPIO_HEAD
      "line = 1\ndirection = input\nfield = bit_in[2]\n",
      "8: gpio 'g': input drives 'bit_in[2]', but robot 'a' opens no owner "
      "connection for bit_in (its open.* plan), so nothing would send it: give "
      "bit_in an owner (e.g. open.bit_out = owner:bit_in) or map the input "
      "elsewhere" },
    { ROBOT "open.io_state = listen_only\n" GPIO_HEAD
      "field = io_control.cb_do[1]\nline = 1\ndirection = input\n",
      "6: gpio 'g': input drives 'io_control.cb_do[1]', but robot 'a' opens no "
      "owner connection for io_control (its open.* plan), so nothing would send "
      "it: give io_control an owner (e.g. open.io_state = owner:io_control) or "
      "map the input elsewhere" },
    /* sections */
    { "[modbsu]\nport = 502\n" ROBOT,
      "1: unknown section [modbsu] (did you mean [modbus]? allowed: " SECTIONS
      ")" },
    { "[robto arm1]\nhost = 10.0.0.1\n",
      "1: unknown section [robto arm1] (did you mean [robot arm1]? "
      "allowed: " SECTIONS ")" },
    { "[gpio_x]\n",
      "1: unknown section [gpio_x] (did you mean [gpio]? allowed: " SECTIONS
      ")" },
    { ROBOT "[general]\n",
      "3: unknown section [general] (allowed: " SECTIONS ")" },
    { ROBOT "[]\n", "3: unknown section [] (allowed: " SECTIONS ")" },
    { ROBOT "[modbus tcp]\n",
      "3: section [modbus tcp] takes no name (allowed: [modbus])" },
    { ROBOT "[modbus]\n[modbus]\n",
      "4: section [modbus] repeated (first at line 3)" },
    { "[daemon]\n" ROBOT "[daemon]\n",
      "4: section [daemon] repeated (first at line 1)" },
    { ROBOT "[robot.a]\nhost = 10.0.0.2\n",
      "3: robot 'a' defined twice (first at line 1)" },
    { "[robot]\nhost = 10.0.0.1\n[robot]\nhost = 10.0.0.2\n",
      "3: robot 'robot' defined twice (first at line 1)" },
    { ROBOT GPIO_HEAD "[gpio.g]\n",
      "5: gpio 'g' defined twice (first at line 3)" },
    { ROBOT "[gpio]\nchip = gpiochip0\n",
      "3: section [gpio] needs a name (allowed: [gpio NAME] or [gpio.NAME])" },
    { "[robot a b]\nhost = 10.0.0.1\n",
      "1: robot name 'a b' invalid (allowed: letters, digits, '_' and '-', at "
      "most 31 "
      "characters)" },
    { "[robot arm/1]\n", "1: robot name 'arm/1' invalid (allowed: letters, "
                         "digits, '_' and '-', at most 31 "
                         "characters)" },
    { "[robot "
      "abcdefghijklmnopqrstuvwxyz012345"
      "]\n",
      "1: robot name 'abcdefghijklmnopqrstuvwxyz012345' invalid (allowed: "
      "letters, digits, '_' "
      "and '-', at most 31 characters)" },
    { ROBOT "[gpio g!]\n", "3: gpio name 'g!' invalid (allowed: letters, "
                           "digits, '_' and '-', at most 31 "
                           "characters)" },
    { "port = 502\n" ROBOT,
      "1: key 'port' outside any section (allowed sections: " SECTIONS ")" },
    /* repeated keys */
    { ROBOT "[modbus]\nport = 502\nlisten = 0.0.0.0\nport = 503\n",
      "6: key 'port' repeated in [modbus] (first at line 4)" },
    { ROBOT "host = 10.0.0.2\n",
      "3: key 'host' repeated in [robot a] (first at line 2)" },
    { ROBOT "instance.io_state = 5\ninstance.dr1 = 6\n",
      "4: key 'instance.dr1' repeated in [robot a] (instance of io_state, "
      "first at line 3)" },
    { ROBOT GPIO_HEAD "chip = gpiochip1\n",
      "5: key 'chip' repeated in [gpio g] (first at line 4)" },
    /* required keys and whole-file checks */
    { "", "1: no robot section (at least one is needed: [robot NAME] with host "
          "= the robot's "
          "address)" },
    { "[modbus]\nport = 502\n", "2: no robot section (at least one is needed: "
                                "[robot NAME] with host = the robot's "
                                "address)" },
    { "[robot a]\nunit_id = 2\n",
      "1: robot 'a' has no host (allowed: an IPv4 address or a host name)" },
    { "[robot a]\n[robot b]\nhost = 10.0.0.1\n",
      "1: robot 'a' has no host (allowed: an IPv4 address or a host name)" },
    { ROBOT "[robot b]\nhost = 10.0.0.2\n",
      "3: robot 'b': unit_id 1 (the default) already used by robot 'a' (line "
      "1; each robot "
      "needs its own unit_id, allowed: 1..247)" },
    { ROBOT "unit_id = 9\n[robot b]\nhost = 10.0.0.2\nunit_id = 9\n",
      "6: robot 'b': unit_id 9 already used by robot 'a' (line 3; each robot "
      "needs its own "
      "unit_id, allowed: 1..247)" },
    { ROBOT "[robot b]\nunit_id = 2\nhost = 10.0.0.1\n",
      "5: robot 'b': 10.0.0.1:44818 is already robot 'a' (line 1)" },
    /* connection plans */
    { ROBOT "opn.io_state = none\n",
      "3: unknown key 'opn.io_state' in [robot a] (did you mean "
      "'open.io_state'? allowed: " ROBOT_KEYS ")" },
    { ROBOT "open.io_stat = none\n",
      "3: unknown assembly 'io_stat' in 'open.io_stat' (did you mean "
      "'io_state'? allowed: io_state, joint_state, task_state, bit_out, "
      "int_out, float_out, io_control, bit_in, int_in, float_in, or "
      "dr1..dr10)" },
    { ROBOT "open.io_control = input_only\n",
      "3: key 'open.io_control' invalid: io_control is consumed by the robot "
      "(O->T); open.* names a T->O assembly, which brings its O->T partner "
      "with owner:<O->T> (allowed: io_state, joint_state, task_state, "
      "bit_out, int_out, float_out)" },
    { ROBOT "open.joint_state = input-only\n",
      "3: open.joint_state 'input-only' invalid (did you mean 'input_only'? "
      "allowed: " OPEN_ALLOWED ")" },
    { ROBOT "open.joint_state = owner\n",
      "3: open.joint_state 'owner' invalid: an owner connection needs its "
      "O->T partner, e.g. owner:io_control (allowed: " OPEN_ALLOWED ")" },
    { ROBOT "open.joint_state = owner:task_state\n",
      "3: open.joint_state 'owner:task_state' invalid: task_state is "
      "produced by the robot (T->O), an owner's partner must be an O->T "
      "assembly (allowed: io_control, bit_in, int_in, float_in)" },
    { ROBOT "open.joint_state = owner:bit_inn\n",
      "3: unknown assembly 'bit_inn' in 'open.joint_state' (did you mean "
      "'bit_in'? allowed: io_state, joint_state, task_state, bit_out, "
      "int_out, float_out, io_control, bit_in, int_in, float_in, or "
      "dr1..dr10)" },
    { ROBOT "open.dr1 = none\nopen.io_state = none\n",
      "4: key 'open.io_state' repeated in [robot a] (open of io_state, first "
      "at line 3)" },
    { ROBOT "open.joint_state = owner:bit_in\n",
      "3: robot 'a': O->T bit_in has two owners, joint_state and bit_out "
      "(the default; one exclusive owner connection per O->T assembly: make one "
      "of them input_only or listen_only)" },
    { ROBOT "open.bit_out = owner:bit_in\nopen.joint_state = owner:bit_in\n",
      "4: robot 'a': O->T bit_in has two owners, joint_state and bit_out "
      "(line 3; one exclusive owner connection per O->T assembly: make one "
      "of them input_only or listen_only)" },
    { ROBOT "open.io_state = none\nopen.joint_state = none\nopen.task_state = "
      "none\nopen.bit_out = none\nopen.int_out = none\nopen.float_out = "
      "none\n",
      "1: robot 'a': every open.* is none: nothing would be opened (allowed: "
      OPEN_ALLOWED ")" },
    { ROBOT "config_instance = 0\n",
      "3: config_instance 0 out of range (allowed: 1..65535)" },
    { ROBOT "input_only_heartbeat = 65536\n",
      "3: input_only_heartbeat 65536 out of range (allowed: 1..65535)" },
    { ROBOT "config_instance = 104\n",
      "3: robot 'a': config_instance 104 is also the instance of bit_out (a "
      "connection point names one thing)" },
    { ROBOT "input_only_heartbeat = 199\nopen.task_state = listen_only\n",
      "3: robot 'a': input_only_heartbeat and listen_only_heartbeat are both "
      "199 (the robot tells the two kinds apart by it)" },
    /* the docs' example configuration instance and the default
     * listen-only heartbeat: the robot would refuse it at run time */
    { ROBOT "config_instance = 199\nopen.task_state = listen_only\n",
      "3: robot 'a': config_instance 199 is also listen_only_heartbeat (its "
      "default; the robot refuses a Forward Open that names one instance as "
      "both: set listen_only_heartbeat to another point of its EDS)" },
    { ROBOT "input_only_heartbeat = 7\nconfig_instance = 7\n",
      "4: robot 'a': config_instance 7 is also input_only_heartbeat (the robot "
      "refuses a Forward Open that names one instance as both: set "
      "input_only_heartbeat to another point of its EDS)" },
    { ROBOT "open.task_state = listen_only\ninstance.float_in = 199\n",
      "4: robot 'a': listen_only_heartbeat 199 is also the instance of "
      "float_in (a connection point names one thing)" },
    { ROBOT "instance.bit_in = 102\n",
      "3: robot 'a': instance 102 used by both joint_state and bit_in (each "
      "assembly needs its "
      "own instance)" },
    { ROBOT "[gpio g]\nline = 1\ndirection = output\nfield = bit_out[0]\n",
      "3: gpio 'g' has no chip (allowed: gpiochipN, /dev/gpiochipN or a chip "
      "label)" },
    { ROBOT GPIO_HEAD "direction = output\nfield = bit_out[0]\n",
      "3: gpio 'g' has no line (allowed: a line offset or a line name)" },
    { ROBOT GPIO_HEAD "line = 1\nfield = bit_out[0]\n",
      "3: gpio 'g' has no direction (allowed: input, output)" },
    { ROBOT GPIO_HEAD "line = 1\ndirection = output\n",
      "3: gpio 'g' has no field (allowed: one bit, e.g. io_state.cb_do[1] or "
      "bit_in[0])" },
    { ROBOT "[robot b]\nhost = 10.0.0.2\nunit_id = 2\n"
            "[gpio g]\nchip = gpiochip0\nline = 1\n"
            "direction = output\nfield = bit_out[0]\n",
      "6: gpio 'g' has no robot (several robots, allowed: a, b)" },
    { ROBOT GPIO_HEAD
      "line = 1\ndirection = output\nfield = bit_out[0]\nrobot = b\n",
      "8: gpio 'g': robot 'b' unknown (allowed: a)" },
    { ROBOT GPIO_HEAD
      "line = 1\ndirection = output\nfield = bit_out[0]\ndebounce_ms = 10\n",
      "8: gpio 'g': debounce_ms applies to inputs only (this is an output)" },
    { ROBOT GPIO_HEAD
      "line = 1\ndirection = input\nfield = bit_in[0]\nsafe_value = 1\n",
      "8: gpio 'g': safe_value applies to outputs only (this is an input)" },
    { ROBOT GPIO_HEAD "line = 1\ndirection = output\nfield = bit_out[0]\n"
                      "[gpio h]\nchip = /dev/gpiochip0\nline = 1\ndirection = "
                      "output\nfield = bit_out[1]\n",
      "10: gpio 'h': line 1 of /dev/gpiochip0 is already used by gpio 'g' "
      "(line 3)" },
    { ROBOT GPIO_HEAD
      "line = 4\ndirection = output\nfield = bit_out[0]\n"
      "[gpio h]\nchip = 0\nline = 4\ndirection = output\nfield = bit_out[1]\n",
      "10: gpio 'h': line 4 of 0 is already used by gpio 'g' (line 3)" },
    { ROBOT "[gpio g]\nchip = gpio-mockup-A\nline = 4\ndirection = "
            "output\nfield = bit_out[0]\n"
            "[gpio h]\nchip = gpio-mockup-B\nline = 4\ndirection = "
            "output\nfield = bit_out[1]\n"
            "[gpio i]\nchip = gpio-mockup-A\nline = 4\ndirection = "
            "output\nfield = bit_out[1]\n",
      "15: gpio 'i': line 4 of gpio-mockup-A is already used by gpio 'g' (line "
      "3)" },
    { ROBOT GPIO_HEAD "line = ABCDEFGHIJKLMNOPQRSTUVWXYZ012345\n",
      "5: line name 'ABCDEFGHIJKLMNOPQRSTUVWXYZ012345' too long (at most 31 "
      "characters, the "
      "kernel's limit)" },
    { ROBOT GPIO_HEAD "line = DOOR SWITCH\n",
      "5: line 'DOOR SWITCH' invalid (allowed: a line offset or a line name)" },
    { ROBOT GPIO_HEAD "line = LED\ndirection = output\nfield = bit_out[0]\n"
                      "[gpio h]\nchip = gpiochip0\nline = LED\ndirection = "
                      "output\nfield = bit_out[1]\n",
      "10: gpio 'h': line 'LED' of gpiochip0 is already used by gpio 'g' (line "
      "3)" },
    { ROBOT GPIO_HEAD "line = 1\ndirection = input\nfield = bit_in[7]\n"
                      "[gpio h]\nchip = gpiochip0\nline = 2\ndirection = "
                      "input\nfield = dr8[7]\n",
      "12: gpio 'h': bit_in[7] of robot 'a' is already driven by input gpio "
      "'g' (line 3; one "
      "input per bit)" },
    /* the text itself */
    { ROBOT "[modbus]\nport = 1\n  listen = 0.0.0.0\n",
      "5: line starts with whitespace (INI reads an indented line as the "
      "continuation of the "
      "previous value; start keys and sections in column 1)" },
    { ROBOT "\t[modbus]\n",
      "3: line starts with whitespace (INI reads an indented line as the "
      "continuation of the "
      "previous value; start keys and sections in column 1)" },
    { ROBOT "[modbus]\nport\n", "4: syntax error (allowed: [section], key = "
                                "value, or a comment starting with ; or #)" },
    { ROBOT "[modbus\nport = 1\n",
      "3: section header without a closing ']' (allowed: " SECTIONS ")" },
    /* a syntax error before a handler error wins, and the other way round */
    { ROBOT "[modbus]\nport\nfoo = 1\n",
      "4: syntax error (allowed: [section], key = value, or a comment starting "
      "with ; or #)" },
    { ROBOT "[modbus]\nfoo = 1\nport\n",
      "4: unknown key 'foo' in [modbus] (allowed: " MODBUS_KEYS ")" },
    /* [mqtt] */
    { ROBOT "[mqtt]\nport = 1883\n",
      "3: [mqtt] has no servers (allowed: servers = HOST[:PORT] ..., or host = the broker's "
      "IPv4 address or host name)" },
    { ROBOT "[mqtt]\nhost = b\nservers = a:1883 b\n",
      "5: [mqtt] servers and host: one or the other (allowed: servers = HOST[:PORT] ... for "
      "one or more brokers, or host (and port) for one; line 4 has host)" },
    { ROBOT "[mqtt]\nservers = a:1883 b:0\n",
      "4: servers: port '0' of b invalid (allowed: 1..65535)" },
    { ROBOT "[mqtt]\nservers = a:1883x\n",
      "4: servers: port '1883x' of a invalid (allowed: 1..65535)" },
    { ROBOT "[mqtt]\nservers = a b 10.0.0.256\n",
      "4: servers: '10.0.0.256' is not a host (allowed: HOST[:PORT] ..., at most 4 (HOST an "
      "IPv4 address or a host name))" },
    { ROBOT "[mqtt]\nservers = a b c d e\n",
      "4: servers: more than 4 servers (allowed: HOST[:PORT] ..., at most 4 (HOST an IPv4 "
      "address or a host name))" },
    { ROBOT "[mqtt]\nservers = a:1883 a\n", "4: [mqtt] servers: a:1883 named twice" },
    { ROBOT "[mqtt]\nhost = b\n[mqtt]\n",
      "5: section [mqtt] repeated (first at line 3)" },
    { ROBOT "[mqtt broker]\n", "3: section [mqtt broker] takes no name (allowed: [mqtt])" },
    { ROBOT "[mqt]\n",
      "3: unknown section [mqt] (did you mean [mqtt]? allowed: " SECTIONS ")" },
    { ROBOT "[mqtt]\nhost = b\nqos = 3\n", "5: qos 3 out of range (allowed: 0..2)" },
    { ROBOT "[mqtt]\nhost = b\ntopic_prefx = x\n",
      "5: unknown key 'topic_prefx' in [mqtt] (did you mean 'topic_prefix'? allowed: "
      "servers, host, port, client_id, username, password_file, ca_file, cert_file, key_file, "
      "keepalive_s, qos, topic_prefix, retain, publish_interval_ms, deadband, writes, "
      "payload, group_id, edge_node_id, primary_host_id, primary_host_wait_s, metric_names, "
      "bdseq_file)" },
    { ROBOT "[mqtt]\nhost = b\ntopic_prefix = plant/#\n",
      "5: topic_prefix 'plant/#' invalid (allowed: topic levels separated by '/', no "
      "wildcards, blanks or empty levels, e.g. drgate/cell1)" },
    { ROBOT "[mqtt]\nhost = b\ntopic_prefix = a//b\n",
      "5: topic_prefix 'a//b' invalid (allowed: topic levels separated by '/', no "
      "wildcards, blanks or empty levels, e.g. drgate/cell1)" },
    { ROBOT "[mqtt]\nhost = b\ndeadband = -1\n",
      "5: deadband '-1' invalid (allowed: a decimal number >= 0, e.g. 0.5)" },
    { ROBOT "[mqtt]\nhost = b\ndeadband = 1.2.3\n",
      "5: deadband '1.2.3' invalid (allowed: a decimal number >= 0, e.g. 0.5)" },
    { ROBOT "[mqtt]\nhost = b\ndeadband = nan\n",
      "5: deadband 'nan' invalid (allowed: a decimal number >= 0, e.g. 0.5)" },
    { ROBOT "[mqtt]\nhost = b\nca_file = ca.pem\ncert_file = c.pem\n",
      "6: [mqtt] cert_file and key_file go together (allowed: both or neither)" },
    { ROBOT "[mqtt]\nhost = b\ncert_file = c.pem\nkey_file = k.pem\n",
      "5: [mqtt] cert_file needs ca_file (TLS)" },
    { ROBOT "[mqtt]\nhost = b\npassword_file = p\n",
      "5: [mqtt] password_file needs username" },
    { ROBOT "[mqtt]\nhost = b\nclient_id = a b\n",
      "5: client_id 'a b' invalid (allowed: letters, digits, '_', '-', '.')" },
    { ROBOT "[mqtt]\nhost = b\nwrites = on\n", "5: writes 'on' invalid (allowed: yes, no)" },
};

/* [mqtt]: every key, and the defaults of those not given. */
static void test_mqtt(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    if (!load_text(ROBOT, &c, err, sizeof err))
        fail_msg("%s", err);
    assert_false(c.side.mqtt.enabled);
    if (!load_text(ROBOT "[mqtt]\nhost = broker.local\n", &c, err, sizeof err))
        fail_msg("%s", err);
    const gw_mqtt_config_t *q = &c.side.mqtt;
    assert_true(q->enabled);
    assert_string_equal(q->host, "broker.local");
    assert_int_equal(q->port, 1883);
    assert_int_equal(q->keepalive_s, 30);
    assert_int_equal(q->qos, 0);
    assert_true(q->retain);
    assert_int_equal(q->publish_interval_ms, 100);
    assert_true(q->deadband == 0.0);
    assert_false(q->writes);
    assert_string_equal(q->topic_prefix, "");
    assert_int_equal(q->server_count, 1); /* host and port: the one server */
    assert_string_equal(q->server[0].host, "broker.local");
    assert_int_equal(q->server[0].port, 1883);
    assert_int_equal(q->host_wait_s, 10);
    /* servers: in order, `port` for those without one (given after them) */
    if (!load_text(ROBOT "[mqtt]\nservers = b1:8883, 10.0.0.2 b3:1\nport = 2883\n"
                         "primary_host_wait_s = 3\n", &c, err, sizeof err))
        fail_msg("%s", err);
    assert_int_equal(q->server_count, 3);
    assert_string_equal(q->server[0].host, "b1");
    assert_int_equal(q->server[0].port, 8883);
    assert_string_equal(q->server[1].host, "10.0.0.2");
    assert_int_equal(q->server[1].port, 2883);
    assert_string_equal(q->server[2].host, "b3");
    assert_int_equal(q->server[2].port, 1);
    assert_int_equal(q->host_wait_s, 3);
    if (!load_text(ROBOT "[mqtt]\nhost = 10.0.0.9\nport = 8883\nclient_id = cell-1.gw\n"
                         "username = gw\npassword_file = /etc/drgate/mqtt.pw\n"
                         "ca_file = ca.pem\ncert_file = c.pem\nkey_file = k.pem\n"
                         "keepalive_s = 5\nqos = 1\ntopic_prefix = plant/cell1\nretain = no\n"
                         "publish_interval_ms = 0\ndeadband = 0.25\nwrites = yes\n",
                   &c, err, sizeof err))
        fail_msg("%s", err);
    assert_int_equal(q->port, 8883);
    assert_string_equal(q->client_id, "cell-1.gw");
    assert_string_equal(q->username, "gw");
    assert_string_equal(q->password_file, "/etc/drgate/mqtt.pw");
    assert_string_equal(q->ca_file, "ca.pem");
    assert_string_equal(q->cert_file, "c.pem");
    assert_string_equal(q->key_file, "k.pem");
    assert_int_equal(q->keepalive_s, 5);
    assert_int_equal(q->qos, 1);
    assert_string_equal(q->topic_prefix, "plant/cell1");
    assert_false(q->retain);
    assert_int_equal(q->publish_interval_ms, 0);
    assert_true(q->deadband == 0.25);
    assert_true(q->writes);
    assert_int_equal(q->line, 3);
}

static void test_errors(void **state)
{
    (void)state;
    unsigned failures = 0;
    for (size_t i = 0; i < sizeof err_cases / sizeof err_cases[0]; i++) {
        gw_config_t c;
        char err[1024], want[1400];
        memset(err, 0, sizeof err);
        bool ok = load_text(err_cases[i].text, &c, err, sizeof err);
        snprintf(want, sizeof want, "%s:%s", tmpini, err_cases[i].want);
        if (ok || strcmp(err, want) != 0) {
            print_error("case %zu:\n  text: %s\n  want: %s\n  got:  %s\n", i,
                        err_cases[i].text, want, ok ? "(loaded)" : err);
            failures++;
        }
    }
    assert_int_equal(failures, 0);
}

/* `n` robot sections r1..rn, each with its own host and unit_id, written
 * into `text`; returns the line number of the last section's header. */
static unsigned robots_text(char *text, size_t size, unsigned n)
{
    size_t len = 0;
    unsigned line = 0;
    text[0] = '\0';
    for (unsigned i = 1; i <= n; i++) {
        int w = snprintf(text + len, size - len,
                         "[robot r%u]\nhost = 10.0.%u.%u\nunit_id = %u\n", i,
                         i / 200, i % 200 + 1, i);
        assert_true(w > 0 && (size_t)w < size - len);
        len += (size_t)w;
        line += 3;
    }
    return line - 2;
}

/* The robot limit (GW_MAX_ROBOTS, 32): that many sections load, one more
 * is refused at its header. */
static void test_robot_limit(void **state)
{
    (void)state;
    static char text[(GW_MAX_ROBOTS + 1) * 64];
    static gw_config_t c;
    char err[512], want[700];
    assert_int_equal(GW_MAX_ROBOTS, 32);
    robots_text(text, sizeof text, GW_MAX_ROBOTS);
    assert_true(load_text(text, &c, err, sizeof err));
    assert_int_equal(c.robot_count, GW_MAX_ROBOTS);
    assert_string_equal(c.robot[GW_MAX_ROBOTS - 1].name, "r32");
    unsigned line = robots_text(text, sizeof text, GW_MAX_ROBOTS + 1);
    assert_false(load_text(text, &c, err, sizeof err));
    snprintf(want, sizeof want, "%s:%u: too many robot sections (at most 32)",
             tmpini, line);
    assert_string_equal(err, want);
}

static void test_long_line(void **state)
{
    (void)state;
    char text[600], err[512], want[700];
    int n = snprintf(text, sizeof text, ROBOT "[robot b]\nhost = ");
    memset(text + n, 'h', 300);
    memcpy(text + n + 300, "\nunit_id = 2\n", sizeof "\nunit_id = 2\n");
    gw_config_t c;
    assert_false(load_text(text, &c, err, sizeof err));
    snprintf(want, sizeof want, "%s:4: line too long (at most 198 characters)",
             tmpini);
    assert_string_equal(err, want);
}

static void test_nul_byte(void **state)
{
    (void)state;
    static const char text[] = ROBOT "[modbus]\nport = 5\0"
                                     "02\n";
    char err[512], want[700];
    gw_config_t c;
    write_bytes(text, sizeof text - 1);
    assert_false(gw_config_load(tmpini, &c, err, sizeof err));
    snprintf(want, sizeof want, "%s:4: NUL byte in line (allowed: a text file)",
             tmpini);
    assert_string_equal(err, want);
}

static void test_file_errors(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512], want[700];
    char missing[400];
    snprintf(missing, sizeof missing, "%s/missing.ini", tmpdir);
    assert_false(gw_config_load(missing, &c, err, sizeof err));
    snprintf(want, sizeof want, "%s: cannot open: No such file or directory",
             missing);
    assert_string_equal(err, want);
    assert_false(gw_config_load(tmpdir, &c, err, sizeof err));
    snprintf(want, sizeof want, "%s: cannot read: Is a directory", tmpdir);
    assert_string_equal(err, want);
    assert_false(gw_config_load(NULL, &c, err, sizeof err));
    assert_false(gw_config_load(missing, NULL, err, sizeof err));
}

/* A failed load leaves *out exactly as it was; a good one replaces it. */
static void test_nothing_half_applied(void **state)
{
    (void)state;
    gw_config_t c, before;
    char err[512];
    memset(&c, 0x5A, sizeof c);
    before = c;
    /* good [modbus] and robot, then an error at the very end */
    assert_false(
        load_text("[modbus]\nport = 1502\nword_order = dcba\n" ROBOT
                  "[gpio g]\nchip = gpiochip0\nline = 1\ndirection = output\n",
                  &c, err, sizeof err));
    assert_memory_equal(&c, &before, sizeof c);
    assert_true(
        load_text("[modbus]\nport = 1502\n" ROBOT, &c, err, sizeof err));
    assert_int_equal(c.side.modbus.port, 1502);
    assert_int_equal(c.robot_count, 1);
}

/* Short or absent error buffers are fine (the message is cut, never overrun). */
static void test_small_error_buffer(void **state)
{
    (void)state;
    gw_config_t c;
    char err[8];
    memset(err, 'x', sizeof err);
    assert_false(load_text("[bogus]\n", &c, err, sizeof err));
    assert_int_equal(strlen(err), sizeof err - 1);
    assert_false(load_text("[bogus]\n", &c, NULL, 0));
    assert_false(load_text("[bogus]\n", &c, err, 0));
}

/* ---- helpers ---------------------------------------------------------------- */

static void test_same_link(void **state)
{
    (void)state;
    gw_config_t c;
    gw_config_defaults(&c);
    gw_robot_config_t a = c.robot[0], b;
    memcpy(a.host, "10.0.0.1", sizeof "10.0.0.1");
    b = a;
    assert_true(gw_robot_config_same_link(&a, &b));
    /* Modbus-side settings and bookkeeping do not touch the link */
    b.side.modbus.unit_id = 9;
    b.side.modbus.fallback_hold = true;
    b.line = 99;
    memcpy(b.name, "other", sizeof "other");
    assert_true(gw_robot_config_same_link(&a, &b));
    /* each link setting does */
    b = a;
    b.tcp_port = 1;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.udp_port = 1;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.local_udp_port = 1;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    memcpy(b.local_addr, "10.0.0.2", sizeof "10.0.0.2");
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    memcpy(b.host, "10.0.0.3", sizeof "10.0.0.3");
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.mode = GW_MODE_EXPLICIT;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.rpi_ms = 11;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.timeout_mult = 3;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.timeout_ms = 5;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.instance[DR_ASM_FLOAT_IN] = 1;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.o2t_strict = true;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.originator_serial = 7;
    assert_false(gw_robot_config_same_link(&a, &b));
}

/* The default plan is today's six connections; the keys change it. */
/* Layouts: the defaults of each, assemblies of one's own, no output. */
static void test_layouts(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    const gw_robot_config_t *r = &c.robot[0];
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\n", &c, err, sizeof err));
    assert_int_equal(r->layout, DR_LAYOUT_PER_ASSEMBLY);
    assert_true(gw_robot_owns(r, DR_ASM_INT_IN));
    assert_true(gw_robot_reads(r, DR_ASM_JOINT_STATE));
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nlayout = combined\n", &c, err,
                          sizeof err));
    assert_int_equal(r->layout, DR_LAYOUT_COMBINED);
    assert_int_equal(r->input.instance, 100);
    assert_int_equal(r->input.size, 476);
    assert_int_equal(r->input.count, 6);
    assert_int_equal(r->output.instance, 150);
    assert_int_equal(r->output.size, 212);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        assert_int_equal(r->open[a].kind, GW_OPEN_NONE);
        assert_true(dr_asm_info((dr_asm_t)a)->dir == DR_DIR_T2O ? gw_robot_reads(r, (dr_asm_t)a)
                                                                : gw_robot_owns(r, (dr_asm_t)a));
    }
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nlayout = gpr_only\ninput_size = 200\n"
                          "input_instance = 3\noutput_instance = 4\n",
                          &c, err, sizeof err));
    assert_int_equal(r->input.size, 200);
    assert_int_equal(r->output.size, 200);
    assert_int_equal(r->input.instance, 3);
    assert_false(gw_robot_reads(r, DR_ASM_IO_STATE));
    assert_false(gw_robot_owns(r, DR_ASM_IO_CONTROL));
    assert_true(gw_robot_owns(r, DR_ASM_FLOAT_IN));
    /* the EDS's order, not ours; an input-only plan */
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nlayout = combined\n"
                          "input_assemblies = float_out int_out\ninput_size = 192\n"
                          "output_assemblies = none\n",
                          &c, err, sizeof err));
    assert_int_equal(r->input.count, 2);
    assert_int_equal(dr_point_offset(&r->input, DR_ASM_INT_OUT), 96);
    assert_int_equal(r->output.count, 0);
    assert_false(gw_robot_owns(r, DR_ASM_FLOAT_IN));
    /* the layout is part of the link: a change reconnects */
    gw_config_t d;
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nlayout = combined\n", &c, err,
                          sizeof err));
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nlayout = combined\n"
                          "output_instance = 151\n", &d, err, sizeof err));
    assert_false(gw_robot_config_same_link(&c.robot[0], &d.robot[0]));
}

static void test_connection_plan(void **state)
{
    (void)state;
    gw_config_t c;
    char err[512];
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\n", &c, err, sizeof err));
    const gw_robot_config_t *r = &c.robot[0];
    assert_int_equal(r->config_instance, 1);
    assert_int_equal(r->input_only_heartbeat, 198);
    assert_int_equal(r->listen_only_heartbeat, 199);
    assert_int_equal(r->open[DR_ASM_IO_STATE].kind, GW_OPEN_OWNER);
    assert_int_equal(r->open[DR_ASM_IO_STATE].o2t, DR_ASM_IO_CONTROL);
    assert_int_equal(r->open[DR_ASM_BIT_OUT].o2t, DR_ASM_BIT_IN);
    assert_int_equal(r->open[DR_ASM_INT_OUT].o2t, DR_ASM_INT_IN);
    assert_int_equal(r->open[DR_ASM_FLOAT_OUT].o2t, DR_ASM_FLOAT_IN);
    assert_int_equal(r->open[DR_ASM_JOINT_STATE].kind, GW_OPEN_INPUT_ONLY);
    assert_int_equal(r->open[DR_ASM_TASK_STATE].kind, GW_OPEN_INPUT_ONLY);
    for (unsigned a = DR_ASM_IO_CONTROL; a < DR_ASM_COUNT; a++)
        assert_int_equal(r->open[a].kind, GW_OPEN_NONE);
    /* config 199 (which the listen-only default would collide with, but
     * nothing listens), io_state and float_out swapped partners, one
     * listen-only, one not opened, drN aliases. */
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nconfig_instance = 199\n"
                          "input_only_heartbeat = 250\nopen.dr1 = owner:float_in\n"
                          "open.float_out = owner:dr7\nopen.bit_out = input_only\n"
                          "open.int_out = none\nlisten_only_heartbeat = 251\n"
                          "open.task_state = listen_only\n",
                          &c, err, sizeof err));
    assert_string_equal(err, "");
    assert_int_equal(r->config_instance, 199);
    assert_int_equal(r->input_only_heartbeat, 250);
    assert_int_equal(r->listen_only_heartbeat, 251);
    assert_int_equal(r->open[DR_ASM_IO_STATE].o2t, DR_ASM_FLOAT_IN);
    assert_int_equal(r->open[DR_ASM_FLOAT_OUT].o2t, DR_ASM_IO_CONTROL);
    assert_int_equal(r->open[DR_ASM_BIT_OUT].kind, GW_OPEN_INPUT_ONLY);
    assert_int_equal(r->open[DR_ASM_BIT_OUT].o2t, -1);
    assert_int_equal(r->open[DR_ASM_INT_OUT].kind, GW_OPEN_NONE);
    assert_int_equal(r->open[DR_ASM_TASK_STATE].kind, GW_OPEN_LISTEN_ONLY);
    assert_int_equal(r->open[DR_ASM_JOINT_STATE].kind, GW_OPEN_INPUT_ONLY);
    /* config 199 beside the default listen-only heartbeat 199 is fine
     * while nothing is opened listen-only, and in explicit mode, which
     * opens no connection */
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nconfig_instance = 199\n", &c, err,
                          sizeof err));
    assert_true(load_text("[robot a]\nhost = 10.0.0.1\nconfig_instance = 199\nmode = explicit\n"
                          "open.task_state = listen_only\n", &c, err, sizeof err));
    /* A plan change is a link change (SIGHUP reconnects). */
    gw_config_t d;
    gw_config_defaults(&d);
    gw_robot_config_t a = d.robot[0], b = a;
    assert_true(gw_robot_config_same_link(&a, &b));
    b.open[DR_ASM_INT_OUT].kind = GW_OPEN_NONE;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.config_instance = 2;
    assert_false(gw_robot_config_same_link(&a, &b));
    b = a;
    b.listen_only_heartbeat = 2;
    assert_false(gw_robot_config_same_link(&a, &b));
}

static void test_word_order_name(void **state)
{
    (void)state;
    assert_string_equal(gw_word_order_name(GW_WORD_ABCD), "abcd");
    assert_string_equal(gw_word_order_name(GW_WORD_CDAB), "cdab");
    assert_string_equal(gw_word_order_name(GW_WORD_BADC), "badc");
    assert_string_equal(gw_word_order_name(GW_WORD_DCBA), "dcba");
    assert_string_equal(gw_word_order_name((gw_word_order_t)4), "?");
}


/* ---- the key tables (gateway/core/config_internal.h) ----------------------------- */


static size_t names_in(const char *const *names)
{
    size_t n = 0;
    while (names != NULL && names[n] != NULL)
        n++;
    return n;
}

/* One table line: what the generic parser, the defaults and the docs read
 * from it must be there and fit the value it names. */
static void check_key(const gw_cfg_side_t *s, const gw_cfg_key_t *k)
{
    size_t n = names_in(k->names);
    const char *name = k->name != NULL ? k->name : "";
    bool integer = k->type == GW_CFG_UINT || k->type == GW_CFG_ENUM ||
                   k->type == GW_CFG_BOOL;
    if (name[0] == '\0' || k->help == NULL || k->help[0] == '\0')
        fail_msg("[%s] key '%s': no name or no help", s->kw, name);
    if (integer && k->size != 1 && k->size != 2 && k->size != 4)
        fail_msg("[%s] %s: a %zu-byte integer", s->kw, name, k->size);
    if (k->type == GW_CFG_BOOL && k->size != sizeof(bool))
        fail_msg("[%s] %s: not a bool", s->kw, name);
    if (k->type == GW_CFG_UINT &&
        (k->lo > k->hi || k->def < k->lo || k->def > k->hi ||
         (k->size < 4 && k->hi >= 1ul << (8 * k->size)) || k->hi > 0xFFFFFFFFul))
        fail_msg("[%s] %s: range %lu..%lu, default %lu in %zu bytes", s->kw,
                 name, k->lo, k->hi, k->def, k->size);
    if ((k->type == GW_CFG_ENUM || k->type == GW_CFG_WORD) &&
        (n == 0 || (k->type == GW_CFG_ENUM && k->def >= n)))
        fail_msg("[%s] %s: %zu names, default %lu", s->kw, name, n, k->def);
    for (size_t i = 0; k->type == GW_CFG_WORD && i < n; i++)
        if (strlen(k->names[i]) >= k->size)
            fail_msg("[%s] %s: '%s' does not fit", s->kw, name, k->names[i]);
    if (k->def_text != NULL && strlen(k->def_text) >= k->size)
        fail_msg("[%s] %s: default '%s' does not fit", s->kw, name, k->def_text);
    if ((k->type == GW_CFG_HOOK || k->type == GW_CFG_PREFIX) && k->parse == NULL)
        fail_msg("[%s] %s: no parse hook", s->kw, name);
    if (k->type == GW_CFG_PREFIX && (k->item == NULL || strchr(name, '<') == NULL))
        fail_msg("[%s] %s: a family without items or '<'", s->kw, name);
    if ((k->type == GW_CFG_TEXT || k->type == GW_CFG_IPV4 || k->type == GW_CFG_HOST ||
         k->type == GW_CFG_HOOK) && k->allowed == NULL)
        fail_msg("[%s] %s: no allowed text for messages", s->kw, name);
    if ((k->flags & GW_CFG_LINK) && s != &gw_cfg_robot)
        fail_msg("[%s] %s: only robot keys reconnect a link", s->kw, name);
}

static void test_key_tables(void **state)
{
    (void)state;
    /* every section: the core's and, through the side list, the sides' */
    const gw_cfg_side_t *all_sides[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(all_sides);
    assert_int_equal(n, 8);
    for (size_t j = 0; j < n; j++) {
        const gw_cfg_side_t *s = all_sides[j];
        assert_true(s->nkeys > 0 && s->nkeys <= GW_CFG_MAX_KEYS);
        for (unsigned k = 0; k < s->nkeys; k++) {
            check_key(s, &s->keys[k]);
            for (unsigned l = 0; l < k; l++)
                if (strcmp(s->keys[k].name, s->keys[l].name) == 0)
                    fail_msg("[%s] %s twice", s->kw, s->keys[k].name);
        }
        if (s->named && (s->max == 0 || s->name_off == GW_CFG_NONE))
            fail_msg("[%s]: named without a maximum or a name", s->kw);
    }
}

/* Every key of a section, in the table of --help-config, in the order of
 * "unknown key" messages. */
static void test_print_keys(void **state)
{
    (void)state;
    char text[8192];
    const gw_cfg_side_t *all_sides[GW_CFG_MAX_SECTIONS];
    unsigned n = gw_cfg_all_sections(all_sides);
    for (size_t j = 0; j < n; j++) {
        const gw_cfg_side_t *s = all_sides[j];
        FILE *f = fmemopen(text, sizeof text, "w");
        assert_non_null(f);
        assert_true(gw_config_print_keys(f, s->kw));
        assert_int_equal(fclose(f), 0);
        const char *p = text;
        for (unsigned k = 0; k < s->nkeys; k++) {
            char cell[80];
            snprintf(cell, sizeof cell, "\n| `%s` |", s->keys[k].name);
            const char *q = strstr(p, cell);
            if (q == NULL) {
                fail_msg("[%s]: %s missing or out of order", s->kw, s->keys[k].name);
                return;
            }
            p = q + 1;
        }
    }
    FILE *f = fmemopen(text, sizeof text, "w");
    assert_non_null(f);
    assert_false(gw_config_print_keys(f, "robots"));
    assert_int_equal(fclose(f), 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_defaults),
        cmocka_unit_test(test_minimal_gets_defaults),
        cmocka_unit_test(test_all_keys),
        cmocka_unit_test(test_section_forms),
        cmocka_unit_test(test_gpio_robot_defaults_to_the_only_one),
        cmocka_unit_test(test_text_variants),
        cmocka_unit_test(test_examples_load),
        cmocka_unit_test(test_rtu_defaults),
        cmocka_unit_test(test_example_values),
        cmocka_unit_test(test_errors),
        cmocka_unit_test(test_mqtt),
        cmocka_unit_test(test_robot_limit),
        cmocka_unit_test(test_long_line),
        cmocka_unit_test(test_nul_byte),
        cmocka_unit_test(test_file_errors),
        cmocka_unit_test(test_nothing_half_applied),
        cmocka_unit_test(test_small_error_buffer),
        cmocka_unit_test(test_same_link),
        cmocka_unit_test(test_word_order_name),
        cmocka_unit_test(test_connection_plan),
        cmocka_unit_test(test_layouts),
        cmocka_unit_test(test_key_tables),
        cmocka_unit_test(test_print_keys),
    };
    return cmocka_run_group_tests_name("gw_config", tests, make_tmpdir,
                                       remove_tmpdir);
}
