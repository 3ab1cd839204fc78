/* SPDX-License-Identifier: MIT */
/*
 * The GPIO side's section (config_internal.h): [gpio NAME], one line that
 * follows or drives one bit of a robot. Its robot and what the direction
 * allows are checked once the whole file is read (config_check.c).
 */
#include "core/config_internal.h"

#include <string.h>

#define G(m) GW_CFG_AT(gw_gpio_config_t, m)
/* The kernel keeps line names to GPIO_MAX_NAME_SIZE - 1 characters: a
 * longer name can never match. */
#define GPIO_LINE_NAME_MAX 31

static gw_cfg_parse_fn gpio_line, gpio_field;

static const gw_cfg_key_t gpio_keys[] = {
    { .name = "chip", .type = GW_CFG_TEXT, .flags = GW_CFG_REQUIRED, G(chip), .valid = gw_cfg_no_blank, .allowed = "gpiochipN, /dev/gpiochipN or a chip label", .doc_allowed = "`gpiochipN`, `/dev/gpiochipN`, `N` or a chip label", .help = "the GPIO chip (`gpiodetect` lists them)" },
    { .name = "line", .type = GW_CFG_HOOK, .flags = GW_CFG_REQUIRED, .parse = gpio_line, .allowed = "a line offset or a line name", .doc_allowed = "offset 0..65535, or a line name (at most 31 characters, no spaces)", .help = "the line on that chip (`gpioinfo` lists them). A value starting with a digit is an offset" },
    { .name = "direction", .type = GW_CFG_ENUM, .flags = GW_CFG_REQUIRED, G(dir), GW_CFG_NAMES("output", "input"), .allowed = "input, output", .help = "whether the gateway reads the line or drives it" },
    /* resolved once every robot is known */
    { .name = "robot", .type = GW_CFG_TEXT, G(robot), .valid = gw_cfg_valid_name, .allowed = "the NAME of a [robot NAME] section", .doc_default = "the only robot", .help = "which robot's data; required when there are several robots" },
    /* direction-dependent checks wait for the whole section */
    { .name = "field", .type = GW_CFG_HOOK, .flags = GW_CFG_REQUIRED, .parse = gpio_field, .allowed = "one bit, e.g. io_state.cb_do[1] or bit_in[0]", .doc_allowed = "one bit: see below", .help = "the bit this output follows, or this input drives (Modbus may then read that bit but not change it)" },
    { .name = "active_low", .type = GW_CFG_BOOL, G(active_low), .help = "the line is active when low. All values the gateway shows and takes are logical, with this inversion already applied" },
    { .name = "bias", .type = GW_CFG_ENUM, G(bias), GW_CFG_NAMES("as-is", "disable", "pull-up", "pull-down"), .def = GW_BIAS_AS_IS, .help = "line bias; `as-is` keeps what firmware or the device tree set" },
    { .name = "debounce_ms", .type = GW_CFG_UINT, G(debounce_ms), .lo = 0, .hi = 1000, .doc_allowed = "0..1000, inputs only", .help = "a change must hold this long before it counts (done in software where the kernel API has no debounce)" },
    { .name = "safe_value", .type = GW_CFG_ENUM, G(safe_value), GW_CFG_NAMES("0", "1"), .doc_allowed = "`0`, `1`, outputs only", .help = "logical value written on robot link loss, on a single-writer fault, at exit, and on every error path" },
};

static void gpio_defaults(void *sec)
{
    ((gw_gpio_config_t *)sec)->offset = -1; /* until given */
}

const gw_cfg_side_t gw_cfg_gpio = {
    .kw = "gpio",
    GW_CFG_NAMED(gpio, gpio_count, gw_gpio_config_t),
    GW_CFG_KEYS(gpio_keys),
    .defaults = gpio_defaults,
    .check = gw_cfg_check_gpio,
};

/* A leading digit means an offset: "17x" is a typo, not a name. */
static void gpio_line(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                      const char *name, const char *v)
{
    gw_gpio_config_t *g = sec;
    unsigned long n;
    if (gw_cfg_is_digit(v[0])) {
        if (gw_cfg_get_uint(c, name, v, 0, 65535, &n))
            g->offset = (int)n;
    } else if (!gw_cfg_no_blank(v)) {
        gw_cfg_fail(c, c->lineno, "line '%s' invalid (allowed: %s)", v,
                    k->allowed);
    } else if (strlen(v) > GPIO_LINE_NAME_MAX) {
        gw_cfg_fail(c, c->lineno,
                    "line name '%s' too long (at most %d characters, the "
                    "kernel's limit)",
                    v, GPIO_LINE_NAME_MAX);
    } else {
        gw_cfg_copy(c, name, v, g->line_name, sizeof g->line_name);
    }
}

/* The field a path names, even when the index is wrong or missing: tried
 * bare (a mask or a scalar), then with [0] and [1] (the two numberings). */
static const dr_field_t *field_of(const char *path)
{
    char base[80];
    size_t n = strcspn(path, "[");
    if (n + 4 > sizeof base)
        return NULL;
    static const char *const suffix[] = { "", "[0]", "[1]" };
    for (size_t i = 0; i < GW_CFG_COUNT(suffix); i++) {
        memcpy(base, path, n);
        memcpy(base + n, suffix[i], strlen(suffix[i]) + 1);
        dr_ref_t ref;
        if (dr_path_parse(base, &ref) == DR_OK)
            return ref.field;
    }
    return NULL;
}

static bool is_bit_field(const dr_field_t *f)
{
    return f->kind == DR_KIND_BIT || f->kind == DR_KIND_BITS;
}

static void not_a_bit(gw_cfg_ctx_t *c, const char *v, const dr_field_t *f)
{
    gw_cfg_fail(c, c->lineno,
                "field '%s' is a %s, not a bit (a GPIO line follows or drives "
                "one bit, e.g. io_state.cb_do[1] or bit_in[0])",
                v, dr_kind_name((dr_kind_t)f->kind));
}

/* "base[first]..base[last]" of a bit mask field (f indexed). */
static void index_range(const dr_field_t *f, const char *base, char *buf,
                        size_t size)
{
    snprintf(buf, size, "%s[%u]..%s[%u]", base, (unsigned)f->first_index,
             base, (unsigned)f->first_index + f->count - 1u);
}

/* DR_EINDEX: out of the field's numbering, or an array given without an
 * index, or a scalar given one. */
static void bad_index(gw_cfg_ctx_t *c, const char *v, dr_status_t st)
{
    const dr_field_t *f = field_of(v);
    char base[64], range[160];
    dr_ref_t mask = { f, -1 };
    if (f == NULL || dr_ref_path(mask, base, sizeof base) != DR_OK) {
        gw_cfg_fail(c, c->lineno, "field '%s' invalid: %s", v, dr_strerror(st));
    } else if (!is_bit_field(f)) {
        not_a_bit(c, v, f);
    } else if (!f->indexed) {
        gw_cfg_fail(c, c->lineno, "field '%s' takes no index (allowed: %s)", v,
                    base);
    } else {
        index_range(f, base, range, sizeof range);
        gw_cfg_fail(c, c->lineno,
                    "field '%s' index out of range (allowed: %s)", v, range);
    }
}

static void gpio_field(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec,
                       const char *name, const char *v)
{
    gw_gpio_config_t *g = sec;
    dr_ref_t ref;
    (void)k;
    (void)name;
    dr_status_t st = dr_path_parse(v, &ref);
    if (st == DR_ENOENT) {
        char closest[64];
        if (dr_path_closest(v, closest, sizeof closest) != DR_OK)
            closest[0] = '\0';
        gw_cfg_fail(c, c->lineno, "field '%s' unknown (closest: %s)", v,
                    closest);
    } else if (st == DR_ESYNTAX) {
        gw_cfg_fail(c, c->lineno,
                    "field '%s' has a malformed index (allowed: a decimal "
                    "index, e.g. io_state.cb_do[1])",
                    v);
    } else if (st != DR_OK) {
        bad_index(c, v, st);
    } else if (!is_bit_field(ref.field)) {
        not_a_bit(c, v, ref.field);
    } else if (ref.elem < 0) {
        char base[64], range[160];
        if (dr_ref_path(ref, base, sizeof base) != DR_OK)
            base[0] = '\0';
        index_range(ref.field, base, range, sizeof range);
        gw_cfg_fail(c, c->lineno,
                    "field '%s' is a whole mask, not one bit (allowed: %s)", v,
                    range);
    } else {
        g->field = ref;
    }
}
