/* SPDX-License-Identifier: MIT */
/*
 * drgatewayd's configuration loader, gw_config_load, on any file: the input
 * is written to a memfd and loaded through /proc/self/fd/N (gw_config_load
 * takes a path and opens it itself).
 *
 * Properties: on failure *out is untouched, byte for byte, and the message
 * is "PATH:LINE: text" with LINE a line of the file (1 for an empty file),
 * one line of printable text, no "internal error"; on success every value
 * is within its documented range and the cross-section rules hold (unique
 * unit IDs and instances, GPIO lines on a bit of their robot, inputs on
 * O->T bits); loading the same bytes twice gives the same values.
 */
#define _GNU_SOURCE /* memfd_create */
#include <arpa/inet.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "core/config.h"
#include "fuzz.h"

static int fd = -1;
static char path[64];
static gw_config_t out, again;

/* Byte for byte, padding included: what "untouched" means here. */
static bool same_bytes(const void *a, const void *b, size_t n)
{
    return memcmp(a, b, n) == 0;
}

/* Member by member: the padding of what the loader copies (dr_ref_t's
 * after its element, for one) holds whatever its stack held. */
static bool same_config(const gw_config_t *a, const gw_config_t *b)
{
    const gw_modbus_config_t *ma = &a->side.modbus, *mb = &b->side.modbus;
    bool same = strcmp(a->path, b->path) == 0 && strcmp(a->log_level, b->log_level) == 0 &&
                strcmp(ma->listen, mb->listen) == 0 && ma->port == mb->port &&
                ma->max_clients == mb->max_clients &&
                ma->idle_timeout_s == mb->idle_timeout_s && ma->keepalive == mb->keepalive &&
                ma->word_order == mb->word_order && ma->on_link_loss == mb->on_link_loss &&
                ma->allow_count == mb->allow_count && ma->single_writer == mb->single_writer &&
                ma->writer_watchdog_ms == mb->writer_watchdog_ms &&
                a->robot_count == b->robot_count && a->side.gpio.count == b->side.gpio.count;
    for (unsigned i = 0; same && i < ma->allow_count; i++)
        same = ma->allow[i].net == mb->allow[i].net && ma->allow[i].mask == mb->allow[i].mask &&
               ma->allow[i].read_write == mb->allow[i].read_write;
    for (unsigned i = 0; same && i < a->robot_count; i++) {
        const gw_robot_config_t *x = &a->robot[i], *y = &b->robot[i];
        same = strcmp(x->name, y->name) == 0 && gw_robot_config_same_link(x, y) &&
               x->side.modbus.unit_id == y->side.modbus.unit_id && x->side.modbus.fallback_hold == y->side.modbus.fallback_hold &&
               x->line == y->line;
    }
    for (unsigned i = 0; same && i < a->side.gpio.count; i++) {
        const gw_gpio_config_t *x = &a->side.gpio.line[i], *y = &b->side.gpio.line[i];
        same = strcmp(x->name, y->name) == 0 && strcmp(x->chip, y->chip) == 0 &&
               x->offset == y->offset && strcmp(x->line_name, y->line_name) == 0 &&
               x->dir == y->dir && strcmp(x->robot, y->robot) == 0 &&
               x->robot_index == y->robot_index && x->field.field == y->field.field &&
               x->field.elem == y->field.elem && x->active_low == y->active_low &&
               x->bias == y->bias && x->debounce_ms == y->debounce_ms &&
               x->safe_value == y->safe_value && x->line == y->line;
    }
    return same;
}

static bool terminated(const char *s, size_t size)
{
    return memchr(s, '\0', size) != NULL;
}

static bool printable(const char *s)
{
    for (; *s; s++)
        if ((unsigned char)*s < 0x20 || *s == 0x7f)
            return false;
    return true;
}

/* Lines as the loader counts them: a last line without '\n' counts. */
static unsigned count_lines(const uint8_t *data, size_t size)
{
    unsigned n = 0;
    for (size_t i = 0; i < size; i++)
        n += data[i] == '\n';
    return n + (size > 0 && data[size - 1] != '\n');
}

static void check_error(const char *err, const uint8_t *data, size_t size)
{
    size_t plen = strlen(path);
    FUZZ_CHECK(terminated(err, 512));
    FUZZ_CHECK(strncmp(err, path, plen) == 0 && err[plen] == ':');
    /* Only file-level errors (open, read) have no line; a memfd has none. */
    const char *p = err + plen + 1;
    unsigned long line = 0;
    FUZZ_CHECK(*p >= '1' && *p <= '9');
    while (*p >= '0' && *p <= '9')
        line = line * 10u + (unsigned long)(*p++ - '0');
    unsigned lines = count_lines(data, size);
    FUZZ_CHECK(line >= 1 && line <= (lines > 0 ? lines : 1u));
    FUZZ_CHECK(p[0] == ':' && p[1] == ' ' && p[2] != '\0');
    FUZZ_CHECK(printable(err));
    FUZZ_CHECK(strncmp(p + 2, "internal error", 14) != 0);
}

static bool is_bit(dr_ref_t r)
{
    return r.field->kind == DR_KIND_BIT || (r.field->kind == DR_KIND_BITS && r.elem >= 0);
}

static void check_config(const gw_config_t *c)
{
    struct in_addr ia;
    FUZZ_CHECK(strcmp(c->path, path) == 0);
    FUZZ_CHECK(terminated(c->log_level, sizeof c->log_level));
    FUZZ_CHECK(strcmp(c->log_level, "error") == 0 || strcmp(c->log_level, "warning") == 0 ||
               strcmp(c->log_level, "info") == 0 || strcmp(c->log_level, "debug") == 0);

    const gw_modbus_config_t *m = &c->side.modbus;
    FUZZ_CHECK(terminated(m->listen, sizeof m->listen));
    FUZZ_CHECK(inet_pton(AF_INET, m->listen, &ia) == 1);
    FUZZ_CHECK(m->max_clients >= 1 && m->max_clients <= 256);
    FUZZ_CHECK((unsigned)m->word_order <= GW_WORD_DCBA);
    FUZZ_CHECK((unsigned)m->on_link_loss <= GW_LOSS_EXCEPTION);
    FUZZ_CHECK(m->allow_count <= GW_MAX_ALLOW);
    for (unsigned i = 0; i < m->allow_count; i++) {
        /* A prefix: ones, then zeros; the network has no host bits. */
        uint32_t inv = ~m->allow[i].mask;
        FUZZ_CHECK((inv & (inv + 1u)) == 0);
        FUZZ_CHECK((m->allow[i].net & inv) == 0);
        /* No entry is shadowed by an earlier one (it would never match). */
        for (unsigned j = 0; j < i; j++)
            FUZZ_CHECK(!((m->allow[i].net & m->allow[j].mask) == m->allow[j].net &&
                         m->allow[i].mask >= m->allow[j].mask));
    }

    FUZZ_CHECK(c->robot_count >= 1 && c->robot_count <= GW_MAX_ROBOTS);
    for (unsigned i = 0; i < c->robot_count; i++) {
        const gw_robot_config_t *r = &c->robot[i];
        FUZZ_CHECK(terminated(r->name, sizeof r->name) && r->name[0] != '\0');
        FUZZ_CHECK(terminated(r->host, sizeof r->host) && r->host[0] != '\0');
        FUZZ_CHECK(terminated(r->local_addr, sizeof r->local_addr));
        FUZZ_CHECK(r->side.modbus.unit_id >= 1 && r->side.modbus.unit_id <= 247);
        FUZZ_CHECK(r->timeout_mult <= 7);
        FUZZ_CHECK((unsigned)r->mode <= GW_MODE_EXPLICIT);
        FUZZ_CHECK(r->line >= 1);
        for (unsigned a = 0; a < DR_ASM_COUNT; a++)
            for (unsigned b = a + 1; b < DR_ASM_COUNT; b++)
                FUZZ_CHECK(r->instance[a] != r->instance[b]);
        for (unsigned j = 0; j < i; j++) {
            FUZZ_CHECK(c->robot[j].side.modbus.unit_id != r->side.modbus.unit_id);
            FUZZ_CHECK(strcmp(c->robot[j].name, r->name) != 0);
        }
        FUZZ_CHECK(gw_robot_config_same_link(r, r));
    }

    FUZZ_CHECK(c->side.gpio.count <= GW_MAX_GPIO);
    for (unsigned i = 0; i < c->side.gpio.count; i++) {
        const gw_gpio_config_t *g = &c->side.gpio.line[i];
        FUZZ_CHECK(terminated(g->name, sizeof g->name) && g->name[0] != '\0');
        FUZZ_CHECK(terminated(g->chip, sizeof g->chip) && g->chip[0] != '\0');
        FUZZ_CHECK(terminated(g->line_name, sizeof g->line_name));
        FUZZ_CHECK(g->offset >= 0 || g->line_name[0] != '\0');
        FUZZ_CHECK(g->robot_index < c->robot_count);
        FUZZ_CHECK(strcmp(g->robot, c->robot[g->robot_index].name) == 0);
        FUZZ_CHECK(dr_field_index(g->field.field) != DR_FIELD_NONE);
        FUZZ_CHECK(is_bit(g->field));
        if (g->dir == GW_GPIO_INPUT)
            FUZZ_CHECK(dr_asm_info((dr_asm_t)g->field.field->assembly)->dir == DR_DIR_O2T);
        else
            FUZZ_CHECK(g->dir == GW_GPIO_OUTPUT && g->debounce_ms == 0);
        FUZZ_CHECK((unsigned)g->bias <= GW_BIAS_PULL_DOWN);
        for (unsigned j = 0; j < i; j++)
            FUZZ_CHECK(strcmp(c->side.gpio.line[j].name, g->name) != 0);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (fd < 0) {
        fd = memfd_create("fuzz_config", MFD_CLOEXEC);
        FUZZ_CHECK(fd >= 0);
        snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    }
    FUZZ_CHECK(ftruncate(fd, 0) == 0);
    FUZZ_CHECK(size == 0 || pwrite(fd, data, size, 0) == (ssize_t)size);

    /* The second load writes its message into an exact-size heap block
     * of 1..64 bytes: ASan sees a write past it; it is a prefix of the
     * first message. */
    char err[512];
    size_t small = 1u + (size > 0 ? data[size - 1] % 64u : 0u);
    char *err2 = malloc(small);
    FUZZ_CHECK(err2 != NULL);
    memset(&out, 0xA5, sizeof out);
    memset(&again, 0xA5, sizeof again);
    memset(err, 0x5A, sizeof err);
    bool ok = gw_config_load(path, &out, err, sizeof err);
    bool ok2 = gw_config_load(path, &again, err2, small);
    FUZZ_CHECK(ok == ok2);
    FUZZ_CHECK(memchr(err2, '\0', small) != NULL);
    FUZZ_CHECK(strncmp(err, err2, strlen(err2)) == 0);
    free(err2);
    if (!ok) {
        gw_config_t pattern;
        memset(&pattern, 0xA5, sizeof pattern);
        FUZZ_CHECK(same_bytes(&out, &pattern, sizeof out));
        check_error(err, data, size);
        return 0;
    }
    FUZZ_CHECK(err[0] == '\0');
    FUZZ_CHECK(same_config(&out, &again));
    check_config(&out);
    return 0;
}
