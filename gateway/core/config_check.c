/* SPDX-License-Identifier: MIT */
/*
 * What spans sections, checked once the whole file is read
 * (config_internal.h): robots against each other (unit IDs, addresses),
 * GPIO lines and serial lines against the robots they name, GPIO lines
 * against each other. Each side's table has already checked every value;
 * the first error wins, in the order of the side list.
 */
#include "core/config_internal.h"

#include <string.h>

static unsigned line_or(unsigned key_line, unsigned section_line)
{
    return key_line != 0 ? key_line : section_line;
}

/* ---- robots ------------------------------------------------------------------ */

/* Robot i against the robots before it: its own unit ID and address. */
static bool robot_unique(gw_cfg_ctx_t *c, unsigned i)
{
    const gw_cfg_side_t *s = &gw_cfg_robot;
    const gw_robot_config_t *r = &c->cfg.robot[i];
    for (unsigned j = 0; j < i; j++) {
        const gw_robot_config_t *o = &c->cfg.robot[j];
        unsigned unit_line = gw_cfg_line(c, s, i, "unit_id");
        if (o->unit_id == r->unit_id) {
            gw_cfg_fail(c, line_or(unit_line, r->line),
                        "robot '%s': unit_id %u%s already used by robot '%s' "
                        "(line %u; each robot needs its own unit_id, allowed: "
                        "1..247)",
                        r->name, (unsigned)r->unit_id,
                        unit_line ? "" : " (the default)", o->name,
                        line_or(gw_cfg_line(c, s, j, "unit_id"), o->line));
            return false;
        }
        if ((o->alias0 && r->alias0) || (o->alias255 && r->alias255)) {
            gw_cfg_fail(c, line_or(gw_cfg_line(c, s, i, "unit_id_alias"), r->line),
                        "robot '%s': unit_id_alias %u is already robot '%s''s "
                        "(line %u; one robot per alias)",
                        r->name, o->alias0 && r->alias0 ? 0u : 255u, o->name,
                        line_or(gw_cfg_line(c, s, j, "unit_id_alias"), o->line));
            return false;
        }
        if (strcmp(o->host, r->host) == 0 && o->tcp_port == r->tcp_port) {
            gw_cfg_fail(c, line_or(gw_cfg_line(c, s, i, "host"), r->line),
                        "robot '%s': %s:%u is already robot '%s' (line %u)",
                        r->name, r->host, (unsigned)r->tcp_port, o->name,
                        o->line);
            return false;
        }
    }
    return true;
}

void gw_cfg_check_robots(gw_cfg_ctx_t *c)
{
    if (c->cfg.robot_count == 0) {
        gw_cfg_fail(c, c->lineno,
                    "no robot section (at least one is needed: [robot NAME] "
                    "with host = the robot's address)");
        return;
    }
    for (unsigned i = 0; i < c->cfg.robot_count; i++)
        if (!gw_cfg_require(c, &gw_cfg_robot, i) || !gw_cfg_robot_check(c, i) ||
            !robot_unique(c, i))
            return;
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
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (r->open[a].kind == GW_OPEN_OWNER && r->open[a].o2t == o2t)
            return true;
    return false;
}

/* An input on an O->T bit no connection writes would drive nothing. The
 * hint names the T->O partner of the default plan when there is one. */
static void unowned_input(gw_cfg_ctx_t *c, unsigned i, const char *path)
{
    const gw_gpio_config_t *gp = &c->cfg.gpio[i];
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
    gw_gpio_config_t *gp = &g->gpio[i];
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
    const gw_gpio_config_t *gp = &c->cfg.gpio[i];
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
    const gw_gpio_config_t *b = &c->cfg.gpio[i], *a = &c->cfg.gpio[j];
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

void gw_cfg_check_gpio(gw_cfg_ctx_t *c)
{
    unsigned n = c->cfg.gpio_count;
    for (unsigned i = 0; i < n && c->err_line == 0; i++)
        if (gw_cfg_require(c, &gw_cfg_gpio, i) && gpio_robot(c, i))
            gpio_direction(c, i);
    for (unsigned i = 0; i < n && c->err_line == 0; i++)
        for (unsigned j = 0; j < i && gpio_pair(c, i, j); j++)
            ;
}

/* ---- [modbus_rtu NAME] -------------------------------------------------------- */

/* robots = as written, or every robot at its unit ID, into the slaves of
 * line i. */
static bool rtu_slaves(gw_cfg_ctx_t *c, unsigned i)
{
    gw_config_t *g = &c->cfg;
    gw_rtu_config_t *u = &g->rtu[i];
    const gw_cfg_rtu_robots_t *ul = gw_cfg_scratch(c, &gw_cfg_rtu, i);
    unsigned robots_line = gw_cfg_line(c, &gw_cfg_rtu, i, "robots");
    if (robots_line == 0) {
        u->slave_count = g->robot_count;
        for (unsigned r = 0; r < g->robot_count; r++) {
            u->slave_robot[r] = r;
            u->slave_addr[r] = g->robot[r].unit_id;
        }
        return true;
    }
    for (unsigned s = 0; s < u->slave_count; s++) {
        unsigned r = 0;
        while (r < g->robot_count && strcmp(g->robot[r].name, ul->robot[s]) != 0)
            r++;
        if (r == g->robot_count) {
            gw_cfg_fail(c, robots_line,
                        "modbus_rtu '%s': no robot '%s' (allowed: the NAME of "
                        "a [robot NAME] section)",
                        u->name, ul->robot[s]);
            return false;
        }
        u->slave_robot[s] = r;
        if (!ul->addr_given[s])
            u->slave_addr[s] = g->robot[r].unit_id;
    }
    return true;
}

/* Each robot and each slave address once on line i. */
static bool rtu_unique(gw_cfg_ctx_t *c, unsigned i)
{
    const gw_rtu_config_t *u = &c->cfg.rtu[i];
    for (unsigned s = 0; s < u->slave_count; s++) {
        for (unsigned t = 0; t < s; t++) {
            bool robot = u->slave_robot[s] == u->slave_robot[t];
            if (!robot && u->slave_addr[s] != u->slave_addr[t])
                continue;
            gw_cfg_fail(c,
                        line_or(gw_cfg_line(c, &gw_cfg_rtu, i, "robots"),
                                u->line),
                        robot ? "modbus_rtu '%s': robot '%s' listed twice"
                              : "modbus_rtu '%s': robot '%s' has the slave "
                                "address of another robot on the line (each "
                                "needs its own, 1..247)",
                        u->name, c->cfg.robot[u->slave_robot[s]].name);
            return false;
        }
    }
    return true;
}

/* Every [modbus_rtu]: a device, one not used by another line, robots that
 * exist (all of them if not said), each slave address once. */
void gw_cfg_check_rtu(gw_cfg_ctx_t *c)
{
    gw_config_t *g = &c->cfg;
    for (unsigned i = 0; i < g->rtu_count; i++) {
        const gw_rtu_config_t *u = &g->rtu[i];
        if (!gw_cfg_require(c, &gw_cfg_rtu, i))
            return;
        for (unsigned j = 0; j < i; j++) {
            if (strcmp(g->rtu[j].device, u->device) == 0) {
                gw_cfg_fail(c,
                            line_or(gw_cfg_line(c, &gw_cfg_rtu, i, "device"),
                                    u->line),
                            "modbus_rtu '%s': device %s is already modbus_rtu "
                            "'%s' (line %u)",
                            u->name, u->device, g->rtu[j].name, g->rtu[j].line);
                return;
            }
        }
        if (!rtu_slaves(c, i) || !rtu_unique(c, i))
            return;
    }
}
