/* SPDX-License-Identifier: MIT */
/* The one write path: see write.h. */
#include "core/write.h"

#include <string.h>

gw_write_status_t gw_write_allowed(const gw_robot_t *r, const gw_write_origin_t *o)
{
    if (o->side == GW_ORIGIN_GPIO)
        return GW_WRITE_OK; /* the wiring: its own bits, not a client */
    if (!o->may_write)
        return GW_WRITE_RIGHTS;
    if (r->write_policy.one_owner &&
        (o->side == GW_ORIGIN_MQTT || o->side == GW_ORIGIN_SPARKPLUG || o->side == GW_ORIGIN_OPCUA ||
         (o->side == GW_ORIGIN_MODBUS_TCP && !o->owner)))
        return GW_WRITE_SINGLE;
    if (r->fault && !o->reset)
        return GW_WRITE_FAULT;
    return GW_WRITE_OK;
}

/* The bits of field f that GPIO inputs drive (a BIT field: bit 0). */
static uint64_t gpio_bits(const gw_robot_t *r, const dr_field_t *f)
{
    const gw_write_policy_t *p = &r->write_policy;
    uint64_t m = 0;
    for (unsigned i = 0; i < p->gpio_in_count && i < GW_MAX_GPIO; i++) {
        const dr_ref_t *g = &p->gpio_in[i];
        if (g->field == f)
            m |= f->kind == DR_KIND_BITS && g->elem >= 0 && g->elem < 64
                     ? (uint64_t)1 << g->elem : (uint64_t)1;
    }
    return m;
}

/* Does v (the element's new value) change a bit a GPIO input drives? A
 * write may name such a bit with the value it has. */
static bool changes_gpio_bit(const gw_robot_t *r, dr_ref_t ref, const dr_value_t *cur,
                             const dr_value_t *v)
{
    const dr_field_t *f = ref.field;
    uint64_t owned = gpio_bits(r, f);
    if (owned == 0 || (f->kind != DR_KIND_BIT && f->kind != DR_KIND_BITS))
        return false;
    if (ref.elem < 0) /* the whole mask */
        return ((v->u ^ cur->u) & owned) != 0;
    uint64_t bit = f->kind == DR_KIND_BITS && ref.elem < 64 ? (uint64_t)1 << ref.elem : 1u;
    return (owned & bit) != 0 && dr_value_as_double(v) != (double)cur->u;
}

/* The element's new value: v, or (mask) v's bits of mask over the
 * element's current raw value. */
static dr_value_t merged(const gw_write_item_t *it, const dr_value_t *cur)
{
    if (it->mask == 0)
        return it->value;
    if (it->ref.field->kind == DR_KIND_DINT) {
        uint32_t m = (uint32_t)it->mask, old = (uint32_t)(cur->i & 0xFFFFFFFF);
        uint32_t nv = (old & ~m) | ((uint32_t)it->value.u & m);
        return dr_value_int(nv <= INT32_MAX ? (int64_t)nv : (int64_t)nv - 4294967296LL);
    }
    return dr_value_uint((cur->u & ~it->mask) | (it->value.u & it->mask));
}

static gw_write_status_t refuse(gw_write_result_t *res, gw_write_status_t why, unsigned item,
                                dr_status_t st)
{
    res->status = why;
    res->item = item;
    res->st = st;
    return why;
}

/* The images the items are tried on: one loop, no threads, and too large
 * for the stack of a deep call. */
static uint8_t scratch[DR_ASM_COUNT][DR_ASM_MAX_SIZE];

gw_write_status_t gw_robot_write(gw_robot_t *r, const gw_write_item_t *items, unsigned n,
                                 const gw_write_origin_t *o, gw_write_result_t *res)
{
    gw_write_result_t local;
    if (res == NULL)
        res = &local;
    memset(res, 0, sizeof *res);
    gw_write_status_t why = gw_write_allowed(r, o);
    if (why != GW_WRITE_OK)
        return refuse(res, why, 0, DR_OK);
    if (r->fault && o->side != GW_ORIGIN_GPIO && n > 0)
        return refuse(res, GW_WRITE_FAULT, 0, DR_OK); /* a reset carries no field */
    if (n > GW_WRITE_MAX_ITEMS)
        return refuse(res, GW_WRITE_FIELD, GW_WRITE_MAX_ITEMS, DR_EINVAL);
    unsigned copied = 0;
    for (unsigned i = 0; i < n; i++) {
        const gw_write_item_t *it = &items[i];
        const dr_field_t *f = it->ref.field;
        if (f == NULL || f->assembly >= DR_ASM_COUNT)
            return refuse(res, GW_WRITE_FIELD, i, DR_EINVAL);
        dr_asm_t a = (dr_asm_t)f->assembly;
        const dr_asm_info_t *info = dr_asm_info(a);
        if (info->dir != DR_DIR_O2T)
            return refuse(res, GW_WRITE_DIRECTION, i, DR_EREADONLY);
        if (r->o2t_unsent & (1u << a))
            return refuse(res, GW_WRITE_UNSENT, i, DR_OK);
        if (!(copied & (1u << a))) {
            memcpy(scratch[a], r->img[a], sizeof scratch[a]);
            copied |= 1u << a;
        }
        dr_value_t cur, v;
        dr_status_t st = dr_field_get(scratch[a], info->size, it->ref, &cur);
        if (st != DR_OK)
            return refuse(res, GW_WRITE_VALUE, i, st);
        v = merged(it, &cur);
        if (o->side != GW_ORIGIN_GPIO && changes_gpio_bit(r, it->ref, &cur, &v))
            return refuse(res, GW_WRITE_GPIO, i, DR_OK);
        st = dr_field_set(scratch[a], info->size, it->ref, &v, DR_SET_O2T_ONLY);
        if (st == DR_EREADONLY)
            return refuse(res, GW_WRITE_DIRECTION, i, st);
        if (st != DR_OK)
            return refuse(res, GW_WRITE_VALUE, i, st);
    }
    /* Every item passed: now, and only now, the robot changes. */
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (copied & (1u << a))
            memcpy(r->img[a], scratch[a], sizeof r->img[a]);
    res->dirty = copied;
    if (o->reset && r->fault && o->side != GW_ORIGIN_GPIO) {
        r->fault = false; /* the other sides hear it from the side that reset it */
        res->reset = true;
    }
    if (n > 0 && o->log != NULL) {
        gw_robot_wrote(r, o->client != NULL ? o->client : "?");
        for (unsigned i = 0; i < n; i++) {
            char path[GW_WRITE_PATH];
            if (dr_ref_path(items[i].ref, path, sizeof path) == DR_OK)
                gw_robot_write_field(r, path);
        }
        gw_write_log(r, o->log);
    }
    return GW_WRITE_OK;
}

const char *gw_write_status_text(gw_write_status_t s)
{
    switch (s) {
    case GW_WRITE_OK: return "written";
    case GW_WRITE_RIGHTS: return "writes are off for this client";
    case GW_WRITE_SINGLE: return "single-writer mode: the outputs belong to the Modbus writer";
    case GW_WRITE_FAULT: return "write fault latched (reset it through Modbus)";
    case GW_WRITE_FIELD: return "unknown field";
    case GW_WRITE_DIRECTION: return "read-only: a T->O field";
    case GW_WRITE_UNSENT: return "not sent: the connection plan opens no connection for its assembly";
    case GW_WRITE_GPIO: return "driven by a GPIO input";
    case GW_WRITE_VALUE: return "invalid value";
    }
    return "?";
}

void gw_write_log(const gw_robot_t *r, gw_log_limit_t *limit)
{
    char fields[GW_WRITE_FIELDS * (GW_WRITE_PATH + 2) + 32];
    gw_robot_write_fields_text(r, fields, sizeof fields);
    limit->window_ms = GW_WRITE_LOG_MS;
    limit->ring = GW_LOG_WRITES; /* kept apart from the events (log.h) */
    gw_log_limited(GW_LOG_INFO, limit, "robot %s: write by %s: %s", r->name,
                   r->last_write.client, fields);
}
