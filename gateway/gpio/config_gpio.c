/* SPDX-License-Identifier: MIT */
/*
 * The GPIO side's section (config_internal.h): [gpio NAME], one line that
 * follows or drives one bit of a robot (its struct: config_gpio.h). Its
 * robot and what the direction allows are checked once the whole file is
 * read (gpio_check, below).
 */
#include "core/config_internal.h"
#include "core/robot.h" /* gw_write_policy_t */

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

static void gpio_check(gw_cfg_ctx_t *c);

static void gpio_defaults(void *sec)
{
    ((gw_gpio_config_t *)sec)->offset = -1; /* until given */
}

static const gw_cfg_side_t gw_cfg_gpio = {
    .kw = "gpio",
    .rank = 40,
    GW_CFG_NAMED(side.gpio.line, side.gpio.count, gw_gpio_config_t),
    GW_CFG_KEYS(gpio_keys),
    .defaults = gpio_defaults,
    .check = gpio_check,
};

static const gw_cfg_side_t *const gpio_sections[] = { &gw_cfg_gpio, NULL };

/* The O->T bits robot's GPIO inputs drive (the write path's rule 6). */
static void gpio_write_policy(const gw_config_t *cfg, unsigned robot, gw_write_policy_t *p)
{
    const gw_gpio_side_config_t *g = &cfg->side.gpio;
    for (unsigned i = 0; i < g->count && p->gpio_in_count < GW_MAX_GPIO; i++)
        if (g->line[i].dir == GW_GPIO_INPUT && g->line[i].robot_index == robot)
            p->gpio_in[p->gpio_in_count++] = g->line[i].field;
}

/* "(2 robot(s), 3 GPIO line(s))" */
static void gpio_brief(const gw_config_t *cfg, char *buf, size_t size)
{
    size_t len = strlen(buf);
    if (len < size)
        snprintf(buf + len, size - len, ", %u GPIO line(s)", cfg->side.gpio.count);
}

/* The side to the configuration (config.h; gateway/sides.h lists it). */
const gw_side_cfg_t gw_side_cfg_gpio = {
    .name = "gpio",
    .sections = gpio_sections,
    .write_policy = gpio_write_policy,
    .brief = gpio_brief,
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

/* ---- [gpio NAME] ------------------------------------------------------------- */

/* "/dev/gpiochip0", "gpiochip0" and "0" name the same chip (the spellings
 * gateway/gpio/gpio.h accepts besides a label). */
static void chip_key(const char *chip, char *out, size_t size)
{
    if (strncmp(chip, "/dev/", 5) == 0)
        chip += 5;
    bool number = *chip != '\0';
    for (const char *p = chip; *p; p++)
        if (!gw_cfg_is_digit(*p))
            number = false;
    snprintf(out, size, "%s%s", number ? "gpiochip" : "", chip);
}

/* Whether the robot's connection plan opens an owner connection for O->T
 * assembly o2t: only those are written (Modbus writes to others get
 * exception 0x02). */
static bool has_owner(const gw_robot_config_t *r, int o2t)
{
    return gw_robot_owns(r, (dr_asm_t)o2t);
}

/* An input on an O->T bit no connection writes would drive nothing. The
 * hint names the T->O partner of the default plan when there is one. */
static void unowned_input(gw_cfg_ctx_t *c, unsigned i, const char *path)
{
    const gw_gpio_config_t *gp = &c->cfg.side.gpio.line[i];
    int o2t = (int)gp->field.field->assembly;
    const char *o2t_name = dr_asm_info((dr_asm_t)o2t)->name;
    gw_robot_config_t def;
    memset(&def, 0, sizeof def);
    gw_robot_default_plan(&def);
    const char *t2o_name = "<T->O assembly>";
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (def.open[a].kind == GW_OPEN_OWNER && def.open[a].o2t == o2t)
            t2o_name = dr_asm_info((dr_asm_t)a)->name;
    gw_cfg_fail(c, gw_cfg_line(c, &gw_cfg_gpio, i, "field"),
                "gpio '%s': input drives '%s', but robot '%s' opens no owner "
                "connection for %s (its open.* plan), so nothing would send "
                "it: give %s an owner (e.g. open.%s = owner:%s) or map the "
                "input elsewhere",
                gp->name, path, gp->robot, o2t_name, o2t_name, t2o_name,
                o2t_name);
}

/* gpio i's robot (the only one if not named) into robot and robot_index. */
static bool gpio_robot(gw_cfg_ctx_t *c, unsigned i)
{
    gw_config_t *g = &c->cfg;
    gw_gpio_config_t *gp = &g->side.gpio.line[i];
    const char *names[GW_MAX_ROBOTS];
    for (unsigned r = 0; r < g->robot_count; r++)
        names[r] = g->robot[r].name;
    char allowed[GW_MAX_ROBOTS * (GW_NAME_MAX + 2)];
    gw_cfg_join(names, g->robot_count, allowed, sizeof allowed);
    if (gp->robot[0] == '\0') {
        if (g->robot_count > 1) {
            gw_cfg_fail(c, gp->line,
                        "gpio '%s' has no robot (several robots, allowed: %s)",
                        gp->name, allowed);
            return false;
        }
        memcpy(gp->robot, g->robot[0].name, sizeof gp->robot);
    }
    for (unsigned r = 0; r < g->robot_count; r++) {
        if (strcmp(g->robot[r].name, gp->robot) == 0) {
            gp->robot_index = r;
            return true;
        }
    }
    gw_cfg_fail(c, gw_cfg_line(c, &gw_cfg_gpio, i, "robot"),
                "gpio '%s': robot '%s' unknown (allowed: %s)", gp->name,
                gp->robot, allowed);
    return false;
}

/* What gpio i's direction allows: an input drives an O->T bit that its
 * robot's plan sends, and has no safe_value; an output no debounce_ms. */
static void gpio_direction(gw_cfg_ctx_t *c, unsigned i)
{
    const gw_cfg_side_t *s = &gw_cfg_gpio;
    const gw_gpio_config_t *gp = &c->cfg.side.gpio.line[i];
    char path[64];
    if (dr_ref_path(gp->field, path, sizeof path) != DR_OK)
        path[0] = '\0';
    int o2t = (int)gp->field.field->assembly;
    if (gp->dir != GW_GPIO_INPUT) {
        if (gw_cfg_line(c, s, i, "debounce_ms") != 0)
            gw_cfg_fail(c, gw_cfg_line(c, s, i, "debounce_ms"),
                        "gpio '%s': debounce_ms applies to inputs only (this "
                        "is an output)",
                        gp->name);
    } else if (dr_asm_info((dr_asm_t)o2t)->dir != DR_DIR_O2T) {
        gw_cfg_fail(c, gw_cfg_line(c, s, i, "field"),
                    "gpio '%s': input cannot drive '%s', which the robot "
                    "produces (T->O); inputs drive O->T bits "
                    "(io_control.cb_do[N], io_control.tool_do[N], "
                    "io_control.ao_type.*, bit_in[N])",
                    gp->name, path);
    } else if (!has_owner(&c->cfg.robot[gp->robot_index], o2t)) {
        unowned_input(c, i, path);
    } else if (gw_cfg_line(c, s, i, "safe_value") != 0) {
        gw_cfg_fail(c, gw_cfg_line(c, s, i, "safe_value"),
                    "gpio '%s': safe_value applies to outputs only (this is "
                    "an input)",
                    gp->name);
    }
}

/* Two GPIO sections on one line, or two inputs on one bit. Only the same
 * spelling can be compared here: an offset and a line name, or a chip
 * label, resolve at run time (where the kernel refuses a second request
 * with EBUSY). */
static bool gpio_pair(gw_cfg_ctx_t *c, unsigned i, unsigned j)
{
    const gw_gpio_config_t *b = &c->cfg.side.gpio.line[i], *a = &c->cfg.side.gpio.line[j];
    bool same_line = b->offset >= 0 ? b->offset == a->offset
                                    : a->offset < 0 &&
                                          strcmp(a->line_name, b->line_name) == 0;
    char ka[80], kb[80];
    chip_key(a->chip, ka, sizeof ka);
    chip_key(b->chip, kb, sizeof kb);
    if (same_line && strcmp(ka, kb) == 0) {
        char which[80];
        if (b->offset >= 0)
            snprintf(which, sizeof which, "%d", b->offset);
        else
            snprintf(which, sizeof which, "'%s'", b->line_name);
        gw_cfg_fail(c, gw_cfg_line(c, &gw_cfg_gpio, i, "line"),
                    "gpio '%s': line %s of %s is already used by gpio '%s' "
                    "(line %u)",
                    b->name, which, b->chip, a->name, a->line);
        return false;
    }
    if (a->dir == GW_GPIO_INPUT && b->dir == GW_GPIO_INPUT &&
        a->robot_index == b->robot_index && a->field.field == b->field.field &&
        a->field.elem == b->field.elem) {
        char path[64];
        if (dr_ref_path(b->field, path, sizeof path) != DR_OK)
            path[0] = '\0';
        gw_cfg_fail(c, gw_cfg_line(c, &gw_cfg_gpio, i, "field"),
                    "gpio '%s': %s of robot '%s' is already driven by input "
                    "gpio '%s' (line %u; one input per bit)",
                    b->name, path, b->robot, a->name, a->line);
        return false;
    }
    return true;
}

static void gpio_check(gw_cfg_ctx_t *c)
{
    unsigned n = c->cfg.side.gpio.count;
    for (unsigned i = 0; i < n && c->err_line == 0; i++)
        if (gw_cfg_require(c, &gw_cfg_gpio, i) && gpio_robot(c, i))
            gpio_direction(c, i);
    for (unsigned i = 0; i < n && c->err_line == 0; i++)
        for (unsigned j = 0; j < i && gpio_pair(c, i, j); j++)
            ;
}
