/* SPDX-License-Identifier: MIT */
/*
 * gateway/gpio/gpiomap.c (GPIO lines bound to robot fields) over the fake GPIO
 * backend (tests/gpio/gpio_fake.c) and a fake event loop: outputs follow
 * only fresh robot data, safe values on link loss and faults, inputs into
 * O->T bits with debounce, one handle per chip however it is spelled, and
 * reloads that keep unchanged lines and roll back a refused one. The same
 * code runs against a real kernel in tests/gpio/gateway/guest.sh.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/epoll.h>
#include <cmocka.h>

#include "common/ev.h"
#include "gpio/gpio.h"
#include "gpio_fake.h"
#include "gpio/gpiomap.h"

#define MS 1000000ull

/* ---- a fake event loop: gpiomap.c links against these ------------------ */

static ev_t *watched[64];
static size_t nwatched;

bool ev_watch(int epfd, ev_t *ev, int fd, uint32_t events)
{
    (void)epfd;
    ev->fd = fd;
    ev->events = events;
    for (size_t i = 0; i < nwatched; i++)
        if (watched[i] == ev)
            return true;
    if (nwatched == 64)
        return false;
    watched[nwatched++] = ev;
    return true;
}

void ev_unwatch(int epfd, ev_t *ev)
{
    (void)epfd;
    for (size_t i = 0; i < nwatched; i++)
        if (watched[i] == ev) {
            watched[i] = watched[--nwatched];
            break;
        }
    ev->fd = -1;
    ev->events = 0;
}

uint64_t ev_now_us(void)
{
    return gw_gpio_now_ns() / 1000u;
}

/* Every watched descriptor fires once (what epoll would report). */
static void fire_all(void)
{
    ev_t *copy[64];
    size_t n = nwatched;
    for (size_t i = 0; i < n; i++)
        copy[i] = watched[i];
    for (size_t i = 0; i < n; i++)
        copy[i]->fn(copy[i]->obj, EPOLLIN);
}

/* ---- fixtures ------------------------------------------------------------- */

static gw_config_t cfg;
static gw_robot_t robots[GW_MAX_ROBOTS];
static unsigned input_calls, input_dirty;

static void on_input(void *user, unsigned robot, unsigned dirty)
{
    (void)user;
    assert_int_equal(robot, 0);
    input_calls++;
    input_dirty |= dirty;
}

static const gw_gpiomap_hooks_t hooks = {on_input, NULL};

static void add_gpio(const char *name, const char *chip, const char *line, gw_gpio_dir_t dir,
                     const char *field)
{
    gw_gpio_config_t *g = &cfg.side.gpio.line[cfg.side.gpio.count++];
    memset(g, 0, sizeof *g);
    snprintf(g->name, sizeof g->name, "%s", name);
    snprintf(g->chip, sizeof g->chip, "%s", chip);
    if (line[0] >= '0' && line[0] <= '9') {
        g->offset = (int)strtol(line, NULL, 10);
    } else {
        g->offset = -1;
        snprintf(g->line_name, sizeof g->line_name, "%s", line);
    }
    g->dir = dir;
    snprintf(g->robot, sizeof g->robot, "arm");
    g->robot_index = 0;
    assert_int_equal(dr_path_parse(field, &g->field), DR_OK);
}

static gw_gpio_config_t *gpio_named(const char *name)
{
    for (unsigned i = 0; i < cfg.side.gpio.count; i++)
        if (strcmp(cfg.side.gpio.line[i].name, name) == 0)
            return &cfg.side.gpio.line[i];
    fail_msg("no gpio %s", name);
    return NULL;
}

/* A cell on chip 0 (fake-A) and chip 1:
 *   0 out bit_out[0]   1 in bit_in[0] (debounce 20 ms)
 *   2 out bit_out[1] safe 1   3 in io_control.cb_do[1] (by name)
 *   chip 1 line 0 out io_state.cb_do[1] */
static int setup(void **state)
{
    (void)state;
    fake_reset();
    nwatched = 0;
    input_calls = input_dirty = 0;
    memset(robots, 0, sizeof robots);
    memset(&cfg, 0, sizeof cfg);
    cfg.robot_count = 1;
    snprintf(cfg.robot[0].name, sizeof cfg.robot[0].name, "arm");
    add_gpio("echo", "gpiochip0", "0", GW_GPIO_OUTPUT, "bit_out[0]");
    add_gpio("door", "/dev/gpiochip0", "1", GW_GPIO_INPUT, "bit_in[0]");
    gpio_named("door")->debounce_ms = 20;
    add_gpio("lamp", "0", "2", GW_GPIO_OUTPUT, "bit_out[1]");
    gpio_named("lamp")->safe_value = true;
    add_gpio("button", "gpiochip0", "fake-A-3", GW_GPIO_INPUT, "io_control.cb_do[1]");
    add_gpio("relay", "gpiochip1", "0", GW_GPIO_OUTPUT, "io_state.cb_do[1]");
    return 0;
}

static void set_bit(dr_asm_t a, const char *path, int v)
{
    dr_ref_t ref;
    dr_value_t val = dr_value_uint((uint64_t)v);
    assert_int_equal(dr_path_parse(path, &ref), DR_OK);
    assert_int_equal(dr_field_set(robots[0].img[a], dr_asm_info(a)->size, ref, &val, 0), DR_OK);
}

static int get_bit(dr_asm_t a, const char *path)
{
    dr_ref_t ref;
    dr_value_t val;
    assert_int_equal(dr_path_parse(path, &ref), DR_OK);
    assert_int_equal(dr_field_get(robots[0].img[a], dr_asm_info(a)->size, ref, &val), DR_OK);
    return (int)val.u;
}

/* Writes to chip 0 line `offset` logged since index `from`, as "0 1 ...". */
static const char *writes(unsigned offset, size_t from)
{
    static char buf[128];
    size_t used = 0;
    buf[0] = '\0';
    for (size_t i = from; i < fake.nlog && used + 3 < sizeof buf; i++)
        if (fake.log[i].offset == offset)
            used += (size_t)snprintf(buf + used, sizeof buf - used, "%s%d", used ? " " : "",
                                     fake.log[i].value);
    return buf;
}

static gw_gpiomap_t *new_map(void)
{
    char err[512] = "";
    gw_gpiomap_t *m = gw_gpiomap_new(&cfg, robots, 3, &hooks, err, sizeof err);
    if (m == NULL)
        fail_msg("gw_gpiomap_new: %s", err);
    return m;
}

/* ---- tests -------------------------------------------------------------- */

static void test_start_safe(void **state)
{
    (void)state;
    gw_gpiomap_t *m = new_map();
    assert_int_equal(gw_gpiomap_count(m), 5);
    for (unsigned o = 0; o < 4; o++) {
        assert_true(fake.requested[o]);
        assert_string_equal(fake.consumer[o], "drgatewayd");
    }
    assert_int_equal(fake.value[0], 0);
    assert_int_equal(fake.value[2], 1);
    /* "gpiochip0", "/dev/gpiochip0" and "0" are one chip: one handle
     * each for chip 0 and chip 1 (plus none left from the lookups). */
    assert_int_equal(fake.open_chips, 2);
    /* The two inputs are watched, the outputs are not. */
    assert_int_equal(nwatched, 2);
    gw_gpiomap_free(m);
    assert_int_equal(fake.open_chips, 0);
    assert_int_equal(nwatched, 0);
    for (unsigned o = 0; o < 4; o++)
        assert_false(fake.requested[o]);
}

static void test_follow_fresh_data_only(void **state)
{
    (void)state;
    gw_gpiomap_t *m = new_map();
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    /* Up, but no data yet: the image is not the robot's. */
    gw_gpiomap_link(m, 0, true);
    assert_int_equal(fake.value[0], 0);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 1);
    assert_int_equal(fake.value[2], 0); /* bit_out[1] = 0, off its safe 1 */
    /* Loss: safe values; the image keeps the 1 (on_link_loss = hold). */
    gw_gpiomap_link(m, 0, false);
    assert_int_equal(fake.value[0], 0);
    assert_int_equal(fake.value[2], 1);
    size_t mark = fake.nlog;
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT); /* data while down: no output */
    assert_string_equal(writes(0, mark), "");
    /* Back up with that stale 1 still in the image: nothing is replayed
     * until the robot sends; the new robot says 0, then echoes 1. */
    gw_gpiomap_link(m, 0, false);
    gw_gpiomap_link(m, 0, true);
    assert_int_equal(fake.value[0], 0);
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 0);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_string_equal(writes(0, mark), "1");
    assert_int_equal(fake.value[2], 0);
    /* Data of another assembly does not touch these lines. */
    mark = fake.nlog;
    gw_gpiomap_data(m, 0, DR_ASM_JOINT_STATE);
    assert_string_equal(writes(0, mark), "");
    gw_gpiomap_free(m);
}

static void test_data_before_up(void **state)
{
    (void)state;
    /* Explicit mode and the first Class 1 connections deliver data before
     * the link counts as up: that data is fresh. */
    gw_gpiomap_t *m = new_map();
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 0);
    gw_gpiomap_link(m, 0, true);
    assert_int_equal(fake.value[0], 1);
    gw_gpiomap_free(m);
}

static void test_fault(void **state)
{
    (void)state;
    gw_gpiomap_t *m = new_map();
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    gw_gpiomap_link(m, 0, true);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 1);
    gw_gpiomap_fault(m, 0, true);
    assert_int_equal(fake.value[0], 0);
    assert_int_equal(fake.value[2], 1);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT); /* a fault holds through data */
    assert_int_equal(fake.value[0], 0);
    /* A reconnect does not clear it either. */
    gw_gpiomap_link(m, 0, false);
    gw_gpiomap_link(m, 0, true);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 0);
    gw_gpiomap_fault(m, 0, false);
    assert_int_equal(fake.value[0], 1);
    assert_int_equal(fake.value[2], 0);
    gw_gpiomap_free(m);
}

static void test_safe_all_and_free(void **state)
{
    (void)state;
    gw_gpiomap_t *m = new_map();
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    gw_gpiomap_link(m, 0, true);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    size_t mark = fake.nlog;
    gw_gpiomap_safe_all(m);
    assert_string_equal(writes(0, mark), "0");
    assert_string_equal(writes(2, mark), "1"); /* written although it was 1 */
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);   /* no following afterwards */
    assert_int_equal(fake.value[0], 0);
    mark = fake.nlog;
    gw_gpiomap_free(m);
    /* Release writes the safe values last. */
    assert_string_equal(writes(0, mark), "0");
    assert_string_equal(writes(2, mark), "1");
}

static void test_inputs(void **state)
{
    (void)state;
    gw_gpiomap_t *m = new_map();
    uint64_t t = gw_gpio_now_ns();
    /* The button (no debounce) goes to io_control.cb_do[1] at once. */
    fake_edge(3, 1, t);
    fire_all();
    assert_int_equal(get_bit(DR_ASM_IO_CONTROL, "io_control.cb_do[1]"), 1);
    assert_int_equal(input_dirty, 1u << DR_ASM_IO_CONTROL);
    /* The door (20 ms): a 5 ms glitch is ignored, a held level taken
     * once it has held 20 ms, not before. */
    input_dirty = 0;
    fake_edge(1, 1, t);
    fake_edge(1, 0, t + 5 * MS);
    fire_all();
    gw_gpiomap_tick(m, (t + 30 * MS) / 1000u);
    assert_int_equal(get_bit(DR_ASM_BIT_IN, "bit_in[0]"), 0);
    assert_int_equal(input_dirty, 0);
    fake_edge(1, 1, t + 40 * MS);
    fire_all();
    uint64_t d = gw_gpiomap_next_deadline(m);
    assert_true(d >= (t + 60 * MS) / 1000u && d <= (t + 60 * MS) / 1000u + 1u);
    gw_gpiomap_tick(m, (t + 59 * MS) / 1000u);
    assert_int_equal(get_bit(DR_ASM_BIT_IN, "bit_in[0]"), 0);
    gw_gpiomap_tick(m, d);
    assert_int_equal(get_bit(DR_ASM_BIT_IN, "bit_in[0]"), 1);
    assert_int_equal(input_dirty, 1u << DR_ASM_BIT_IN);
    /* A Modbus write over an input's bit is put back. */
    set_bit(DR_ASM_BIT_IN, "bit_in[0]", 0);
    gw_gpiomap_tick(m, d + 1000u);
    assert_int_equal(get_bit(DR_ASM_BIT_IN, "bit_in[0]"), 1);
    gw_gpiomap_free(m);
}

/* For the console (gw_gpiomap_each_line): every line with its chip's
 * kernel name, offset, direction and the level the gateway holds: an
 * output's last written value, an input's debounced bit. */
typedef struct {
    unsigned n;
    char text[512];
} lines_seen_t;

static void line_seen(void *user, const gw_gpiomap_line_info_t *l)
{
    lines_seen_t *s = user;
    size_t used = strlen(s->text);
    snprintf(s->text + used, sizeof s->text - used, "%s%s %s/%u %s %d", s->n ? "; " : "",
             l->cfg->name, l->chip, l->offset, l->cfg->dir == GW_GPIO_INPUT ? "in" : "out",
             l->level);
    s->n++;
}

static void test_each_line(void **state)
{
    (void)state;
    gw_gpiomap_t *m = new_map();
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    gw_gpiomap_link(m, 0, true);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    fake_edge(3, 1, gw_gpio_now_ns());
    fire_all();
    lines_seen_t s = {0, ""};
    gw_gpiomap_each_line(m, line_seen, &s);
    assert_int_equal(s.n, 5);
    assert_string_equal(s.text, "echo gpiochip0/0 out 1; door gpiochip0/1 in 0; "
                                "lamp gpiochip0/2 out 0; button gpiochip0/3 in 1; "
                                "relay gpiochip1/0 out 0");
    gw_gpiomap_free(m);
    gw_gpiomap_each_line(NULL, line_seen, &s); /* no map: nothing */
    assert_int_equal(s.n, 5);
}

static void test_same_line_twice(void **state)
{
    (void)state;
    /* Line 3 by offset on "/dev/gpiochip0" and by name on "gpiochip0":
     * the loader cannot see it, the map must. */
    add_gpio("again", "/dev/gpiochip0", "3", GW_GPIO_OUTPUT, "bit_out[5]");
    char err[512];
    assert_null(gw_gpiomap_new(&cfg, robots, 3, &hooks, err, sizeof err));
    assert_string_equal(err, "gpio again: line 3 of gpiochip0 is already used by gpio 'button'");
    assert_int_equal(fake.open_chips, 0);
    for (unsigned o = 0; o < 4; o++)
        assert_false(fake.requested[o]);
}

static void test_errors(void **state)
{
    (void)state;
    char err[512];
    snprintf(gpio_named("button")->line_name, sizeof cfg.side.gpio.line[0].line_name, "NOPE");
    assert_null(gw_gpiomap_new(&cfg, robots, 3, &hooks, err, sizeof err));
    assert_non_null(strstr(err, "gpio button: "));
    assert_non_null(strstr(err, "NOPE"));
    assert_int_equal(fake.open_chips, 0);
    setup(NULL);
    fake.busy[2] = true;
    assert_null(gw_gpiomap_new(&cfg, robots, 3, &hooks, err, sizeof err));
    assert_non_null(strstr(err, "gpio lamp: "));
    assert_non_null(strstr(err, "used by \"other\""));
    assert_int_equal(fake.open_chips, 0);
    assert_int_equal(nwatched, 0);
    for (unsigned o = 0; o < 4; o++)
        assert_false(fake.requested[o]);
}

static gw_gpiomap_t *running(void)
{
    gw_gpiomap_t *m = new_map();
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 1);
    gw_gpiomap_link(m, 0, true);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 1);
    assert_int_equal(fake.value[2], 0);
    return m;
}

static void test_reload_same(void **state)
{
    (void)state;
    gw_gpiomap_t *m = running(), *n;
    size_t mark = fake.nlog, rel = fake.releases;
    char err[512];
    assert_int_equal(gw_gpiomap_reload(m, &cfg, robots, 3, &hooks, &n, err, sizeof err),
                     GW_GPIOMAP_OK);
    gw_gpiomap_link(n, 0, true);
    gw_gpiomap_fault(n, 0, false);
    assert_int_equal(fake.releases, rel);
    assert_int_equal(fake.nlog, mark); /* not one write: no glitch */
    assert_int_equal(nwatched, 2);
    assert_int_equal(fake.open_chips, 2);
    /* The carried state follows on. */
    set_bit(DR_ASM_BIT_OUT, "bit_out[0]", 0);
    gw_gpiomap_data(n, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 0);
    /* The inputs still reach their bits through the new map. */
    fake_edge(3, 1, gw_gpio_now_ns());
    fire_all();
    assert_int_equal(get_bit(DR_ASM_IO_CONTROL, "io_control.cb_do[1]"), 1);
    gw_gpiomap_free(n);
    assert_int_equal(fake.open_chips, 0);
}

static void test_reload_changes(void **state)
{
    (void)state;
    gw_gpiomap_t *m = running(), *n;
    size_t mark = fake.nlog;
    char err[512];
    /* The lamp's safe value changes (re-requested); the echo now follows
     * bit_out[1] (same request: kept, and it follows the new field); the
     * door goes (released); line 4 is new. */
    gpio_named("lamp")->safe_value = false;
    snprintf(gpio_named("echo")->name, GW_NAME_MAX, "echo2");
    assert_int_equal(dr_path_parse("bit_out[1]", &gpio_named("echo2")->field), DR_OK);
    gw_gpio_config_t *door = gpio_named("door");
    *door = cfg.side.gpio.line[--cfg.side.gpio.count]; /* the relay takes the door's place */
    add_gpio("new", "gpiochip0", "4", GW_GPIO_OUTPUT, "bit_out[0]");
    assert_int_equal(gw_gpiomap_reload(m, &cfg, robots, 3, &hooks, &n, err, sizeof err),
                     GW_GPIOMAP_OK);
    gw_gpiomap_link(n, 0, true);
    gw_gpiomap_fault(n, 0, false);
    assert_false(fake.requested[1]);
    assert_true(fake.requested[4]);
    assert_int_equal(fake.value[4], 1); /* follows bit_out[0] = 1 */
    assert_int_equal(fake.value[0], 0); /* now bit_out[1] */
    assert_string_equal(writes(0, mark), "0");
    assert_int_equal(nwatched, 1);
    assert_int_equal(gw_gpiomap_count(n), 5);
    gw_gpiomap_free(n);
    assert_int_equal(fake.open_chips, 0);
}

static void test_reload_refused(void **state)
{
    (void)state;
    gw_gpiomap_t *m = running(), *n = NULL;
    char err[512];
    /* The lamp changes (so its old request is released first), and a new
     * line is busy: the reload is refused and the lamp requested again
     * as it was. */
    gpio_named("lamp")->safe_value = false;
    add_gpio("busy", "gpiochip0", "5", GW_GPIO_OUTPUT, "bit_out[0]");
    fake.busy[5] = true;
    size_t mark = fake.nlog;
    assert_int_equal(gw_gpiomap_reload(m, &cfg, robots, 3, &hooks, &n, err, sizeof err),
                     GW_GPIOMAP_REFUSED);
    assert_null(n);
    assert_non_null(strstr(err, "gpio busy: "));
    assert_true(fake.requested[2]);
    assert_int_equal(fake.value[2], 1); /* back at its old safe value 1... */
    set_bit(DR_ASM_BIT_OUT, "bit_out[1]", 0);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[2], 0); /* ...and following again */
    assert_string_equal(writes(0, mark), "");
    assert_int_equal(fake.open_chips, 2);
    assert_int_equal(nwatched, 2);
    /* The old map is whole: its lines release on free. */
    gw_gpiomap_free(m);
    assert_int_equal(fake.open_chips, 0);
    for (unsigned o = 0; o < 6; o++)
        assert_false(fake.requested[o]);
}

static void test_reload_refused_moved(void **state)
{
    (void)state;
    gw_gpiomap_t *m = running(), *n = NULL;
    char err[512];
    /* The lamp moves to line 5 (its line 2 is not in the way, so it is
     * kept until the reload commits) and the echo's safe value changes
     * (released first); a busy new line refuses it all. */
    gpio_named("lamp")->offset = 5;
    gpio_named("echo")->safe_value = true;
    add_gpio("busy", "gpiochip0", "6", GW_GPIO_OUTPUT, "bit_out[0]");
    fake.busy[6] = true;
    size_t mark = fake.nlog, rel = fake.releases;
    assert_int_equal(gw_gpiomap_reload(m, &cfg, robots, 3, &hooks, &n, err, sizeof err),
                     GW_GPIOMAP_REFUSED);
    assert_true(fake.requested[0]);
    assert_true(fake.requested[2]);
    assert_false(fake.requested[5]);
    /* Line 2 was never let go. Line 0 was (old request), requested anew
     * and let go again with line 5 when the busy line refused the
     * reload, then requested as before, at its old safe value 0. */
    assert_string_equal(writes(2, mark), "");
    assert_int_equal(fake.releases, rel + 3);
    assert_int_equal(fake.value[0], 0);
    gw_gpiomap_data(m, 0, DR_ASM_BIT_OUT);
    assert_int_equal(fake.value[0], 1);
    gw_gpiomap_free(m);
    assert_int_equal(fake.open_chips, 0);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test_setup(test_start_safe, setup),
        cmocka_unit_test_setup(test_follow_fresh_data_only, setup),
        cmocka_unit_test_setup(test_data_before_up, setup),
        cmocka_unit_test_setup(test_fault, setup),
        cmocka_unit_test_setup(test_safe_all_and_free, setup),
        cmocka_unit_test_setup(test_inputs, setup),
        cmocka_unit_test_setup(test_same_line_twice, setup),
        cmocka_unit_test_setup(test_errors, setup),
        cmocka_unit_test_setup(test_reload_same, setup),
        cmocka_unit_test_setup(test_reload_changes, setup),
        cmocka_unit_test_setup(test_reload_refused, setup),
        cmocka_unit_test_setup(test_reload_refused_moved, setup),
        cmocka_unit_test_setup(test_each_line, setup),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
