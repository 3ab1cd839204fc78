/* SPDX-License-Identifier: MIT */
/*
 * The Modbus register map: one slot per address, built from the field
 * table at start-up, so every field of every assembly is reachable and no
 * address is written down by hand (docs/register-map.md is printed from
 * the same slots).
 */
#include <math.h>
#include <string.h>

#include "modbus/regmap.h"
#include "modbus/usermap.h"

typedef enum {
    SL_NONE = 0,
    SL_VALUE,   /* BIT / USINT / ENUM element as one register */
    SL_PACKED,  /* 16 bits of a BITS mask; part = word index */
    SL_WORD32,  /* half of a DINT/REAL; part 0 = first register */
    SL_SCALED,  /* REAL as INT16 x scale */
    SL_BIT,     /* one bit (coil / discrete input) */
    SL_STATUS,  /* status block register or bit; elem = index */
    SL_TEST,    /* constant test register; elem = index */
    SL_CONTROL  /* holding register with its own meaning; elem = index */
} slot_kind_t;

typedef struct {
    uint8_t kind;
    uint8_t part;
    uint16_t field; /* dr_field_at(field) */
    int16_t elem;
} slot_t;

static slot_t map[GW_AREAS][GW_AREA_SIZE];
static uint16_t extent[GW_AREAS]; /* one past the last mapped address */
static bool built;

/* Where each assembly starts: registers (and +1000 for the scaled view)
 * and bits. T->O go to input registers / discrete inputs, O->T to holding
 * registers / coils. */
static const uint16_t reg_base[DR_ASM_COUNT] = {100, 200, 300, 400, 500, 600,
                                                100, 200, 300, 400};
static const uint16_t bit_base[DR_ASM_COUNT] = {100, 0, 0, 400, 0, 0,
                                                100, 200, 0, 0};
#define SCALED_OFFSET 1000u

#define STATUS_REGS 32u
#define TEST_BASE 32u
#define TEST_REGS 8u
/* The status block goes on after the test registers (IR 0-31 was full and
 * IR 32-39 are read by PLC programs): status elements 32.. at IR 40.. */
#define STATUS_EXT_BASE 40u
#define STATUS_EXT_REGS 4u
#define STATUS_BITS 4u
#define CONTROL_REGS 2u

static void put(gw_area_t area, uint16_t *addr, slot_kind_t kind, uint8_t part,
                uint16_t field, int16_t elem)
{
    slot_t s = {(uint8_t)kind, part, field, elem};
    map[area][(*addr)++] = s;
}

static void build_field(uint16_t fi, gw_area_t ra, gw_area_t ba, uint16_t *r,
                        uint16_t *s, uint16_t *b)
{
    const dr_field_t *f = dr_field_at(fi);
    unsigned n = f->count;
    switch ((dr_kind_t)f->kind) {
    case DR_KIND_BIT:
        put(ra, r, SL_VALUE, 0, fi, 0);
        put(ba, b, SL_BIT, 0, fi, 0);
        break;
    case DR_KIND_BITS:
        for (unsigned w = 0; w < (n + 15u) / 16u; w++)
            put(ra, r, SL_PACKED, (uint8_t)w, fi, -1);
        for (unsigned e = 0; e < n; e++)
            put(ba, b, SL_BIT, 0, fi, (int16_t)e);
        break;
    case DR_KIND_USINT:
    case DR_KIND_ENUM:
        for (unsigned e = 0; e < n; e++)
            put(ra, r, SL_VALUE, 0, fi, (int16_t)e);
        break;
    case DR_KIND_DINT:
    case DR_KIND_REAL:
        for (unsigned e = 0; e < n; e++) {
            put(ra, r, SL_WORD32, 0, fi, (int16_t)e);
            put(ra, r, SL_WORD32, 1, fi, (int16_t)e);
            if (f->kind == DR_KIND_REAL)
                put(ra, s, SL_SCALED, 0, fi, (int16_t)e);
        }
        break;
    }
}

void gw_regmap_init(void)
{
    if (built)
        return;
    memset(map, 0, sizeof map);
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        const dr_asm_info_t *info = dr_asm_info((dr_asm_t)a);
        bool t2o = info->dir == DR_DIR_T2O;
        gw_area_t ra = t2o ? GW_INPUT : GW_HOLDING;
        gw_area_t ba = t2o ? GW_DISCRETE : GW_COILS;
        uint16_t r = reg_base[a], s = (uint16_t)(reg_base[a] + SCALED_OFFSET), b = bit_base[a];
        for (unsigned k = 0; k < info->field_count; k++)
            build_field((uint16_t)(info->first_field + k), ra, ba, &r, &s, &b);
    }
    uint16_t addr = 0;
    for (unsigned i = 0; i < STATUS_REGS; i++)
        put(GW_INPUT, &addr, SL_STATUS, 0, 0, (int16_t)i);
    for (unsigned i = 0; i < TEST_REGS; i++)
        put(GW_INPUT, &addr, SL_TEST, 0, 0, (int16_t)i);
    addr = STATUS_EXT_BASE;
    for (unsigned i = 0; i < STATUS_EXT_REGS; i++)
        put(GW_INPUT, &addr, SL_STATUS, 0, 0, (int16_t)(STATUS_REGS + i));
    addr = 0;
    for (unsigned i = 0; i < STATUS_BITS; i++)
        put(GW_DISCRETE, &addr, SL_STATUS, 0, 0, (int16_t)i);
    addr = 0;
    for (unsigned i = 0; i < CONTROL_REGS; i++)
        put(GW_HOLDING, &addr, SL_CONTROL, 0, 0, (int16_t)i);
    for (unsigned t = 0; t < GW_AREAS; t++)
        for (unsigned a = 0; a < GW_AREA_SIZE; a++)
            if (map[t][a].kind != SL_NONE)
                extent[t] = (uint16_t)(a + 1u);
    built = true;
}

/* ---- word order ---------------------------------------------------------- */

static uint16_t swap_bytes(uint16_t w)
{
    return (uint16_t)(w << 8 | w >> 8);
}

const char *const gw_word_order_names[] = {"abcd", "cdab", "badc", "dcba", NULL};

const char *gw_word_order_name(gw_word_order_t w)
{
    unsigned i = (unsigned)w;
    return i <= (unsigned)GW_WORD_DCBA ? gw_word_order_names[i] : "?";
}

void gw_words_from_u32(uint32_t v, gw_word_order_t order, uint16_t out[2])
{
    uint16_t hi = (uint16_t)(v >> 16), lo = (uint16_t)v;
    switch (order) {
    case GW_WORD_ABCD: out[0] = hi; out[1] = lo; break;
    case GW_WORD_CDAB: out[0] = lo; out[1] = hi; break;
    case GW_WORD_BADC: out[0] = swap_bytes(hi); out[1] = swap_bytes(lo); break;
    case GW_WORD_DCBA: out[0] = swap_bytes(lo); out[1] = swap_bytes(hi); break;
    }
}

uint32_t gw_words_to_u32(const uint16_t in[2], gw_word_order_t order)
{
    uint16_t hi = 0, lo = 0;
    switch (order) {
    case GW_WORD_ABCD: hi = in[0]; lo = in[1]; break;
    case GW_WORD_CDAB: hi = in[1]; lo = in[0]; break;
    case GW_WORD_BADC: hi = swap_bytes(in[0]); lo = swap_bytes(in[1]); break;
    case GW_WORD_DCBA: hi = swap_bytes(in[1]); lo = swap_bytes(in[0]); break;
    }
    return (uint32_t)hi << 16 | lo;
}

/* ---- reading ------------------------------------------------------------- */

unsigned gw_regmap_scale(const dr_field_t *f)
{
    /* x100 where values are small (currents, analog I/O, general purpose
     * floats); x10 where they reach hundreds or thousands (degrees, mm,
     * temperatures, torques, forces), which keeps +-3276.7 in range. */
    if (strcmp(f->unit, "A") == 0 || f->unit[0] == '\0')
        return 100;
    return 10;
}

static const dr_field_t *slot_field(const slot_t *s)
{
    return dr_field_at(s->field);
}

static size_t asm_size(const dr_field_t *f)
{
    return dr_asm_info((dr_asm_t)f->assembly)->size;
}

static const uint8_t *asm_img(const gw_unit_t *u, const dr_field_t *f)
{
    return u->robot->img[f->assembly];
}

/* Element elem of field f in the robot's image (-1: the whole field). */
static dr_value_t field_value(const gw_unit_t *u, const dr_field_t *f, int elem)
{
    dr_ref_t ref = {f, (int16_t)elem};
    dr_value_t v = dr_value_uint(0);
    (void)dr_field_get(asm_img(u, f), asm_size(f), ref, &v);
    return v;
}

static dr_value_t get_value(const gw_unit_t *u, const slot_t *s, int16_t elem)
{
    return field_value(u, slot_field(s), elem);
}

/* x rounded half away from zero, clamped to [lo, 32767]; NaN reads
 * -32768. */
static uint16_t round_int16(double x, double lo)
{
    if (x != x)
        return 0x8000;
    x = x < 0 ? ceil(x - 0.5) : floor(x + 0.5);
    if (x > 32767.0)
        x = 32767.0;
    if (x < lo)
        x = lo;
    return (uint16_t)(int16_t)x;
}

/* The default map's scaled view: -32768 is kept for "not a number". */
static uint16_t scaled(double f, unsigned scale)
{
    return round_int16(f * scale, -32767.0);
}

/* The block is assembled here from both owners: the robot's facts (its
 * link, counters, errors; the daemon's heartbeat, uptime, generation) and
 * Modbus's own (exceptions, clients, the single writer, word order, RTU
 * counters). */
static uint16_t status_reg(const gw_unit_t *u, unsigned i)
{
    const gw_status_t *st = &u->status;
    const gw_robot_t *rb = u->robot;
    const gw_robot_link_t *lk = &rb->link;
    switch (i) {
    case 0: return GW_MAP_LAYOUT_VERSION;
    case 1: return lk->link_state;
    case 2: return lk->fresh;
    case 3: return lk->age_ms > 0xFFFF ? 0xFFFF : (uint16_t)lk->age_ms;
    case 4: return rb->heartbeat;
    case 5: return lk->rpi_ms;
    /* 32-bit counters: high word first, whatever the word order */
    case 6: return (uint16_t)(lk->rx_packets >> 16);
    case 7: return (uint16_t)lk->rx_packets;
    case 8: return (uint16_t)(lk->lost_packets >> 16);
    case 9: return (uint16_t)lk->lost_packets;
    case 10: return (uint16_t)(st->exceptions >> 16);
    case 11: return (uint16_t)st->exceptions;
    case 12: return lk->last_error;
    case 13: return st->clients;
    case 14: return (uint16_t)(rb->uptime_s >> 16);
    case 15: return (uint16_t)rb->uptime_s;
    case 26: return rb->fault;
    case 27: return st->writer_present;
    case 28: return (uint16_t)u->order;
    case 29: return rb->generation;
    case 30: return lk->last_cip_general;
    /* 31 is reserved (reads 0); the block goes on at IR 40, its 32-bit
     * counters high word first too */
    case STATUS_REGS + 0: return (uint16_t)(st->rtu_dropped >> 16);
    case STATUS_REGS + 1: return (uint16_t)st->rtu_dropped;
    case STATUS_REGS + 2: return (uint16_t)(st->rtu_other >> 16);
    case STATUS_REGS + 3: return (uint16_t)st->rtu_other;
    default:
        if (i >= 16 && i < 16 + GW_ROBOT_CONNS)
            return lk->conn_state[i - 16];
        return 0;
    }
}

static uint16_t status_bit(const gw_unit_t *u, unsigned i)
{
    switch (i) {
    case 0: return u->robot->link.link_state == 2;
    case 1: return u->robot->link.fresh;
    case 2: return u->robot->fault;
    default: return u->status.writer_present;
    }
}

/* Known constants so a PLC programmer can check the word order. */
static uint16_t test_reg(const gw_unit_t *u, unsigned i)
{
    uint16_t w[2];
    float f;
    uint32_t bits;
    switch (i) {
    case 0: return 0x1234;
    case 1: case 2:
        gw_words_from_u32(0x12345678u, u->order, w);
        return w[i - 1];
    case 3: case 4:
        f = 123456.0f; /* 0x47F12000 */
        memcpy(&bits, &f, 4);
        gw_words_from_u32(bits, u->order, w);
        return w[i - 3];
    case 5: case 6:
        f = -1.5f; /* 0xBFC00000 */
        memcpy(&bits, &f, 4);
        gw_words_from_u32(bits, u->order, w);
        return w[i - 5];
    default: return 0xFFFE; /* INT16 -2 */
    }
}

static uint16_t read_slot(const gw_unit_t *u, gw_area_t area, const slot_t *s)
{
    const dr_field_t *f = slot_field(s);
    switch ((slot_kind_t)s->kind) {
    case SL_VALUE:
    case SL_BIT:
        return (uint16_t)get_value(u, s, s->elem).u;
    case SL_PACKED:
        return (uint16_t)(get_value(u, s, -1).u >> (16u * s->part));
    case SL_WORD32: {
        uint16_t w[2];
        gw_words_from_u32(dr_get_le32(asm_img(u, f) + f->offset + 4u * (unsigned)s->elem),
                          u->order, w);
        return w[s->part];
    }
    case SL_SCALED:
        return scaled(get_value(u, s, s->elem).f, gw_regmap_scale(f));
    case SL_STATUS:
        return area == GW_DISCRETE ? status_bit(u, (unsigned)s->elem)
                                   : status_reg(u, (unsigned)s->elem);
    case SL_TEST:
        return test_reg(u, (unsigned)s->elem);
    case SL_CONTROL:
        return s->elem == GW_HR_WATCHDOG ? u->watchdog : 0;
    default:
        return 0;
    }
}

static bool in_range(uint16_t addr, uint16_t count)
{
    return count > 0 && (uint32_t)addr + count <= GW_AREA_SIZE;
}

/* ---- the user's map ---------------------------------------------------------- */

static uint32_t entry_end(const gw_umap_entry_t *e)
{
    return (uint32_t)e->addr + e->size;
}

/* The index of the first entry of `area` that ends after addr (entries
 * are sorted by table, then address, and do not overlap); m->count if
 * none. */
static unsigned user_first(const gw_umap_t *m, gw_area_t area, uint32_t addr)
{
    unsigned lo = 0, hi = m->count;
    while (lo < hi) {
        unsigned mid = lo + (hi - lo) / 2u;
        const gw_umap_entry_t *e = &m->entry[mid];
        if (e->table < (unsigned)area || (e->table == (unsigned)area && entry_end(e) <= addr))
            lo = mid + 1u;
        else
            hi = mid;
    }
    return lo;
}

/* The entry that holds area/addr, or NULL. */
static const gw_umap_entry_t *user_at(const gw_unit_t *u, gw_area_t area, uint32_t addr)
{
    const gw_umap_t *m = u->umap;
    if (m == NULL)
        return NULL;
    unsigned i = user_first(m, area, addr);
    if (i < m->count && m->entry[i].table == (unsigned)area && m->entry[i].addr <= addr)
        return &m->entry[i];
    return NULL;
}

static uint32_t unit_extent(const gw_unit_t *u, gw_area_t area)
{
    uint32_t x = extent[area];
    const gw_umap_t *m = u->umap;
    if (m != NULL)
        for (unsigned i = 0; i < m->count; i++)
            if (m->entry[i].table == (unsigned)area && entry_end(&m->entry[i]) > x)
                x = entry_end(&m->entry[i]);
    return x;
}

static bool default_slot(gw_area_t area, uint32_t a)
{
    return a < GW_AREA_SIZE && map[area][a].kind != SL_NONE;
}


/* Elements first..first+n-1 of a BIT/BITS field as bits 0..n-1. */
static uint16_t user_bits(const gw_unit_t *u, const dr_field_t *f, unsigned first, unsigned n)
{
    if (f->kind == DR_KIND_BIT)
        return (uint16_t)(field_value(u, f, 0).u & 1u);
    uint64_t mask = field_value(u, f, -1).u >> first;
    return (uint16_t)(mask & ((n >= 16 ? 0x10000u : 1u << n) - 1u));
}

static uint16_t user_read(const gw_unit_t *u, const gw_umap_entry_t *e, uint32_t addr)
{
    const dr_field_t *f = dr_field_at(e->field);
    unsigned off = (unsigned)(addr - e->addr);
    switch ((gw_view_t)e->view) {
    case GW_VIEW_BIT:
        return user_bits(u, f, e->elem + off, 1);
    case GW_VIEW_BITS: {
        unsigned first = 16u * off, left = e->count - first;
        return user_bits(u, f, e->elem + first, left > 16 ? 16 : left);
    }
    case GW_VIEW_REAL:
    case GW_VIEW_DINT: {
        uint16_t w[2];
        gw_words_from_u32(dr_get_le32(asm_img(u, f) + f->offset + 4u * (e->elem + off / 2u)),
                          u->order, w);
        return w[off % 2u];
    }
    case GW_VIEW_INT16: {
        dr_value_t v = field_value(u, f, (int)(e->elem + off));
        return round_int16(dr_value_as_double(&v) * e->scale, -32768.0);
    }
    case GW_VIEW_UINT16: {
        dr_value_t v = field_value(u, f, (int)(e->elem + off));
        if (f->kind == DR_KIND_DINT)
            return (uint16_t)((uint32_t)(int32_t)v.i >> (e->half ? 16 : 0));
        return (uint16_t)v.u;
    }
    }
    return 0;
}

static bool touches_user(const gw_unit_t *u, gw_area_t area, uint16_t addr, uint16_t count)
{
    const gw_umap_t *m = u->umap;
    if (m == NULL)
        return false;
    unsigned i = user_first(m, area, addr);
    return i < m->count && m->entry[i].table == (unsigned)area &&
           m->entry[i].addr < (uint32_t)addr + count;
}

bool gw_regmap_touches_robot_data(gw_area_t area, uint16_t addr, uint16_t count)
{
    if (!in_range(addr, count))
        return false;
    for (uint32_t a = addr; a < (uint32_t)addr + count; a++) {
        uint8_t k = map[area][a].kind;
        if (k != SL_NONE && k != SL_STATUS && k != SL_TEST && k != SL_CONTROL)
            return true;
    }
    return false;
}

uint16_t gw_regmap_extent(gw_area_t area)
{
    return (unsigned)area < GW_AREAS ? extent[area] : 0;
}

/* Reserved addresses between the blocks read 0 by default, so that a PLC
 * can read 125 registers in one request across blocks; past the table's
 * last mapped address nothing is read. */
int gw_regmap_read(const gw_unit_t *u, gw_area_t area, uint16_t addr,
                   uint16_t count, uint16_t *values)
{
    if ((unsigned)area >= GW_AREAS || count == 0 ||
        (uint32_t)addr + count > unit_extent(u, area))
        return GW_EX_ILLEGAL_ADDRESS;
    const gw_umap_t *m = u->umap != NULL && u->umap->count > 0 ? u->umap : NULL;
    if (m == NULL) { /* the default map alone: a slot per address */
        if (u->unmapped == GW_UNMAPPED_EXCEPTION)
            for (uint32_t a = addr; a < (uint32_t)addr + count; a++)
                if (map[area][a].kind == SL_NONE)
                    return GW_EX_ILLEGAL_ADDRESS;
        if (u->on_loss == GW_LOSS_EXCEPTION && u->robot->link.link_state != 2 &&
            (area == GW_INPUT || area == GW_DISCRETE) &&
            gw_regmap_touches_robot_data(area, addr, count))
            return GW_EX_TARGET_FAILED;
        for (uint16_t i = 0; i < count; i++)
            values[i] = read_slot(u, area, &map[area][addr + i]);
        return 0;
    }
    /* Both maps: the default's slot, else the user's entry (walked in
     * address order from the first one that can hold addr). */
    if (u->on_loss == GW_LOSS_EXCEPTION && u->robot->link.link_state != 2 &&
        (((area == GW_INPUT || area == GW_DISCRETE) &&
          gw_regmap_touches_robot_data(area, addr, count)) ||
         touches_user(u, area, addr, count)))
        return GW_EX_TARGET_FAILED;
    unsigned k = user_first(m, area, addr);
    uint32_t last = (uint32_t)addr + count;
    for (uint32_t a = addr; a < last;) {
        if (default_slot(area, a)) {
            values[a - addr] = read_slot(u, area, &map[area][a]);
            a++;
            continue;
        }
        while (k < m->count && m->entry[k].table == (unsigned)area && entry_end(&m->entry[k]) <= a)
            k++;
        const gw_umap_entry_t *e = &m->entry[k];
        if (k < m->count && e->table == (unsigned)area && e->addr <= a) {
            /* the rest of the block at once (no default slot inside it:
             * the loader keeps the maps apart) */
            uint32_t end = entry_end(e) < last ? entry_end(e) : last;
            for (; a < end; a++)
                values[a - addr] = user_read(u, e, a);
            continue;
        }
        if (u->unmapped == GW_UNMAPPED_EXCEPTION)
            return GW_EX_ILLEGAL_ADDRESS;
        values[a - addr] = 0;
        a++;
    }
    return 0;
}

/* ---- writing ------------------------------------------------------------- */

/* A write request decoded from registers or bits into field writes (the
 * one write path, core/write.h, checks and applies them) and the control
 * registers' effects, applied once the path accepted the rest. */
typedef struct {
    gw_write_item_t *items;
    unsigned n;
    bool watchdog_set, reset;
    uint16_t watchdog;
} decoded_t;

/* One request at a time (one loop, no threads): FC 15's 1968 coils. */
static gw_write_item_t write_items[GW_WRITE_MAX_ITEMS];

static int add_item(decoded_t *d, const dr_field_t *f, int elem, dr_value_t v, uint64_t mask)
{
    if (d->n >= GW_WRITE_MAX_ITEMS)
        return GW_EX_ILLEGAL_VALUE; /* not reached: a request holds fewer */
    d->items[d->n++] = (gw_write_item_t){{f, (int16_t)elem}, v, mask};
    return 0;
}

/* Bits first..first+n-1 of a BIT/BITS field from v's bits 0..n-1. */
static int user_set_bits(decoded_t *d, const dr_field_t *f, unsigned first, unsigned n,
                         uint16_t v)
{
    if (f->kind == DR_KIND_BIT) {
        if (v > 1)
            return GW_EX_ILLEGAL_VALUE;
        return add_item(d, f, 0, dr_value_uint(v), 0);
    }
    if (n == 1) {
        if (v > 1)
            return GW_EX_ILLEGAL_VALUE;
        return add_item(d, f, (int)first, dr_value_uint(v), 0);
    }
    uint64_t bits = (n >= 16 ? 0xFFFFu : (1u << n) - 1u);
    return add_item(d, f, -1, dr_value_uint(((uint64_t)v & bits) << first), bits << first);
}

/* One write to a user entry at values[*i] (a 32-bit view takes two). */
static int user_write(decoded_t *d, const gw_unit_t *u, const gw_umap_entry_t *e, uint32_t a,
                      uint16_t *i, uint16_t count, const uint16_t *values)
{
    const dr_field_t *f = dr_field_at(e->field);
    unsigned off = (unsigned)(a - e->addr);
    uint16_t v = values[*i];
    int elem = (int)(e->elem + off);
    if (!e->writable)
        return GW_EX_ILLEGAL_ADDRESS;
    switch ((gw_view_t)e->view) {
    case GW_VIEW_BIT:
        return user_set_bits(d, f, e->elem + off, 1, v);
    case GW_VIEW_BITS: {
        unsigned first = 16u * off, left = e->count - first;
        return user_set_bits(d, f, e->elem + first, left > 16 ? 16 : left, v);
    }
    case GW_VIEW_REAL:
    case GW_VIEW_DINT: {
        if (off % 2u != 0 || *i + 1u >= count)
            return GW_EX_ILLEGAL_ADDRESS; /* half a value would be torn */
        uint16_t w[2] = {v, values[*i + 1u]};
        uint32_t bits = gw_words_to_u32(w, u->order);
        (*i)++;
        elem = (int)(e->elem + off / 2u);
        if (f->kind == DR_KIND_DINT)
            return add_item(d, f, elem, dr_value_int(bits <= INT32_MAX ? (int64_t)bits
                                                                      : (int64_t)bits - 4294967296LL),
                            0);
        float fl;
        memcpy(&fl, &bits, 4);
        return add_item(d, f, elem, dr_value_real((double)fl), 0);
    }
    case GW_VIEW_INT16: {
        int32_t sv = v <= 0x7FFF ? (int32_t)v : (int32_t)v - 65536;
        if (f->kind == DR_KIND_BIT && e->scale == 1 && v <= 1)
            return user_set_bits(d, f, 0, 1, v);
        if (e->scale == 1)
            return add_item(d, f, elem, dr_value_int(sv), 0);
        return add_item(d, f, elem, dr_value_real((double)sv / e->scale), 0);
    }
    case GW_VIEW_UINT16:
        if (f->kind == DR_KIND_DINT) /* one half of the DINT: the other stays */
            return add_item(d, f, elem, dr_value_uint(e->half ? (uint64_t)v << 16 : v),
                            e->half ? 0xFFFF0000u : 0xFFFFu);
        if (f->kind == DR_KIND_BIT && v <= 1)
            return user_set_bits(d, f, 0, 1, v);
        return add_item(d, f, elem, dr_value_uint(v), 0);
    }
    return GW_EX_ILLEGAL_ADDRESS;
}

/* Decode one write at map[area][*i] (a 32-bit value takes two). */
static int write_slot(decoded_t *d, const gw_unit_t *u, gw_area_t area, uint16_t addr,
                      uint16_t *i, uint16_t count, const uint16_t *values)
{
    const slot_t *s = &map[area][addr + *i];
    const dr_field_t *f = slot_field(s);
    uint16_t v = values[*i];

    switch ((slot_kind_t)s->kind) {
    case SL_VALUE:
    case SL_BIT:
        return add_item(d, f, s->elem, dr_value_uint(v), 0);
    case SL_PACKED: {
        unsigned shift = 16u * s->part;
        return add_item(d, f, -1, dr_value_uint((uint64_t)v << shift),
                        (uint64_t)0xFFFF << shift);
    }
    case SL_WORD32: {
        /* Both halves must be in this request, or the value would be torn. */
        const slot_t *next = &map[area][addr + *i + 1u];
        if (s->part != 0 || *i + 1u >= count || next->kind != SL_WORD32 ||
            next->field != s->field || next->elem != s->elem)
            return GW_EX_ILLEGAL_ADDRESS;
        uint16_t w[2] = {v, values[*i + 1u]};
        uint32_t bits = gw_words_to_u32(w, u->order);
        (*i)++;
        if (f->kind == DR_KIND_DINT)
            return add_item(d, f, s->elem,
                            dr_value_int(bits <= INT32_MAX ? (int64_t)bits
                                                           : (int64_t)bits - 4294967296LL),
                            0);
        float fl;
        memcpy(&fl, &bits, 4);
        return add_item(d, f, s->elem, dr_value_real((double)fl), 0);
    }
    case SL_SCALED: {
        int32_t sv = v <= 0x7FFF ? (int32_t)v : (int32_t)v - 65536;
        return add_item(d, f, s->elem, dr_value_real((double)sv / gw_regmap_scale(f)), 0);
    }
    case SL_CONTROL:
        if (s->elem == GW_HR_WATCHDOG) {
            d->watchdog_set = true;
            d->watchdog = v;
            return 0;
        }
        if (v > 1)
            return GW_EX_ILLEGAL_VALUE;
        d->reset = d->reset || v == 1;
        return 0;
    default:
        return GW_EX_ILLEGAL_ADDRESS;
    }
}

int gw_regmap_exception(gw_write_status_t st)
{
    switch (st) {
    case GW_WRITE_OK: return 0;
    case GW_WRITE_RIGHTS:
    case GW_WRITE_SINGLE: return GW_EX_ILLEGAL_FUNCTION;
    case GW_WRITE_FAULT: return GW_EX_DEVICE_FAILURE;
    case GW_WRITE_VALUE: return GW_EX_ILLEGAL_VALUE;
    case GW_WRITE_FIELD:
    case GW_WRITE_DIRECTION:
    case GW_WRITE_UNSENT:
    case GW_WRITE_GPIO: break;
    }
    return GW_EX_ILLEGAL_ADDRESS;
}

int gw_regmap_write(gw_unit_t *u, gw_area_t area, uint16_t addr, uint16_t count,
                    const uint16_t *values, const gw_write_origin_t *o, gw_write_result_t *res)
{
    static const gw_write_origin_t plain = {GW_ORIGIN_MODBUS_TCP, NULL, true, true, false, NULL};
    gw_write_result_t local;
    if (res == NULL)
        res = &local;
    memset(res, 0, sizeof *res);
    if ((area != GW_HOLDING && area != GW_COILS) || count == 0 ||
        (uint32_t)addr + count > 65536u)
        return GW_EX_ILLEGAL_ADDRESS;
    for (uint32_t a = addr; a < (uint32_t)addr + count; a++)
        if (!default_slot(area, a) && user_at(u, area, a) == NULL)
            return GW_EX_ILLEGAL_ADDRESS;
    /* Decode all of it first (addresses, halves, the control registers),
     * then one write of its fields: nothing changes unless all of it
     * passes. */
    decoded_t d = {write_items, 0, false, false, 0};
    for (uint16_t i = 0; i < count; i++) {
        uint32_t a = (uint32_t)addr + i;
        if (default_slot(area, a) && u->default_ro && map[area][a].kind != SL_CONTROL)
            return GW_EX_ILLEGAL_ADDRESS; /* default_map_writes = no */
        int ex = default_slot(area, a) ? write_slot(&d, u, area, addr, &i, count, values)
                                       : user_write(&d, u, user_at(u, area, a), a, &i, count,
                                                    values);
        if (ex != 0)
            return ex;
    }
    int ex = gw_regmap_exception(gw_robot_write(u->robot, d.items, d.n, o != NULL ? o : &plain,
                                                res));
    if (ex != 0)
        return ex;
    if (d.watchdog_set)
        u->watchdog = d.watchdog;
    u->fault_reset = u->fault_reset || d.reset;
    return 0;
}

bool gw_regmap_default_used(gw_area_t area, uint32_t addr, uint32_t n, uint16_t *at)
{
    gw_regmap_init();
    for (uint32_t a = addr; a < addr + n && a < GW_AREA_SIZE; a++)
        if (map[area][a].kind != SL_NONE) {
            *at = (uint16_t)a;
            return true;
        }
    return false;
}

/* ---- printing ---------------------------------------------------------------- */

static const char *const area_name[GW_AREAS] = {"coil", "discrete input",
                                                "holding register", "input register"};
static const char *const area_short[GW_AREAS] = {"CO", "DI", "HR", "IR"};
static const unsigned area_prefix[GW_AREAS] = {0, 1, 4, 3};

static const char *const status_names[STATUS_REGS + STATUS_EXT_REGS] = {
    "status.layout_version", "status.link_state (0 down, 1 connecting, 2 up)",
    "status.data_fresh", "status.data_age_ms", "status.heartbeat", "status.rpi_ms",
    "status.rx_packets (high word)", "status.rx_packets (low word)",
    "status.lost_packets (high word)", "status.lost_packets (low word)",
    "status.modbus_exceptions (high word)", "status.modbus_exceptions (low word)",
    "status.last_error", "status.clients", "status.uptime_s (high word)",
    "status.uptime_s (low word)", "status.conn_state[0]", "status.conn_state[1]",
    "status.conn_state[2]", "status.conn_state[3]", "status.conn_state[4]",
    "status.conn_state[5]", "status.conn_state[6]", "status.conn_state[7]",
    "status.conn_state[8]", "status.conn_state[9]", "status.write_fault",
    "status.writer_present", "status.word_order (0 abcd, 1 cdab, 2 badc, 3 dcba)",
    "status.config_generation", "status.last_cip_general", "status.reserved31",
    "status.rtu_frames_dropped (high word)", "status.rtu_frames_dropped (low word)",
    "status.rtu_frames_other_slave (high word)", "status.rtu_frames_other_slave (low word)",
};
static const char *const status_bit_names[STATUS_BITS] = {
    "status.link_up", "status.data_fresh", "status.write_fault", "status.writer_present"};
static const char *const test_names[TEST_REGS] = {
    "test.u16 = 0x1234", "test.dint 0x12345678 (word 1)", "test.dint 0x12345678 (word 2)",
    "test.real 123456.0 = 0x47F12000 (word 1)", "test.real 123456.0 (word 2)",
    "test.real -1.5 = 0xBFC00000 (word 1)", "test.real -1.5 (word 2)", "test.int16 -2 = 0xFFFE"};
static const char *const control_names[CONTROL_REGS] = {
    "control.writer_watchdog (single-writer mode: keep changing it)",
    "control.fault_reset (write 1)"};

static bool same_group(const slot_t *a, const slot_t *b)
{
    if (a->kind != b->kind)
        return false;
    switch ((slot_kind_t)a->kind) {
    case SL_WORD32: return a->field == b->field && a->elem == b->elem && b->part == 1;
    case SL_PACKED: return a->field == b->field;
    default: return false;
    }
}

/* words: registers in the printed group (a packed mask takes several). */
static void slot_text(const slot_t *s, gw_area_t area, unsigned words, char *name,
                      size_t nsize, char *type, size_t tsize, char *unit, size_t usize)
{
    const dr_field_t *f = slot_field(s);
    dr_ref_t ref = {f, (int16_t)(s->kind == SL_PACKED ? -1 : s->elem)};
    name[0] = type[0] = unit[0] = '\0';
    switch ((slot_kind_t)s->kind) {
    case SL_STATUS:
        snprintf(name, nsize, "%s", area == GW_DISCRETE ? status_bit_names[s->elem]
                                                         : status_names[s->elem]);
        snprintf(type, tsize, area == GW_DISCRETE ? "bit" : "UINT16");
        return;
    case SL_TEST:
        snprintf(name, nsize, "%s", test_names[s->elem]);
        snprintf(type, tsize, "constant");
        return;
    case SL_CONTROL:
        snprintf(name, nsize, "%s", control_names[s->elem]);
        snprintf(type, tsize, "UINT16");
        return;
    default:
        break;
    }
    (void)dr_ref_path(ref, name, nsize);
    snprintf(unit, usize, "%s", f->unit);
    switch ((slot_kind_t)s->kind) {
    case SL_VALUE:
        snprintf(type, tsize, "%s (%s)", dr_kind_name((dr_kind_t)f->kind),
                 f->kind == DR_KIND_BIT ? "0/1" : "0..255");
        break;
    case SL_PACKED: {
        /* the whole mask: one row for all its registers */
        unsigned first = f->first_index, last = f->first_index + f->count - 1u;
        if (words > 1)
            snprintf(type, tsize, "bits %u-%u packed, 16 per register (bit 0 = [%u], [%u], ...)",
                     first, last, first, first + 16u);
        else
            snprintf(type, tsize, "bits %u-%u packed (bit 0 = [%u])", first, last, first);
        break;
    }
    case SL_WORD32:
        snprintf(type, tsize, "%s, 2 registers in word order", dr_kind_name((dr_kind_t)f->kind));
        break;
    case SL_SCALED:
        snprintf(type, tsize, "INT16 = REAL x %u", gw_regmap_scale(f));
        break;
    case SL_BIT:
        snprintf(type, tsize, "bit");
        break;
    default:
        break;
    }
}

void gw_regmap_slot_name(gw_area_t area, uint16_t addr, char *buf, size_t size)
{
    char type[96], unit[16];
    gw_regmap_init();
    buf[0] = '\0';
    if (addr < GW_AREA_SIZE && map[area][addr].kind != SL_NONE)
        slot_text(&map[area][addr], area, 1, buf, size, type, sizeof type, unit, sizeof unit);
}

/* One address's field, written as its canonical path into buf ("" for
 * none: a control, status or reserved address). */
static void field_at(const gw_unit_t *u, gw_area_t area, uint32_t a, char *buf, size_t size)
{
    buf[0] = '\0';
    if (default_slot(area, a)) {
        const slot_t *s = &map[area][a];
        if (s->kind == SL_CONTROL || s->kind == SL_STATUS || s->kind == SL_TEST)
            return;
        dr_ref_t ref = {slot_field(s), (int16_t)(s->kind == SL_PACKED ? -1 : s->elem)};
        (void)dr_ref_path(ref, buf, size);
        return;
    }
    const gw_umap_entry_t *e = user_at(u, area, a);
    if (e == NULL)
        return;
    unsigned off = (unsigned)(a - e->addr), elem = e->elem + off;
    if (e->view == GW_VIEW_BITS)
        elem = e->elem + 16u * off;
    else if (e->view == GW_VIEW_REAL || e->view == GW_VIEW_DINT)
        elem = e->elem + off / 2u;
    const dr_field_t *f = dr_field_at(e->field);
    dr_ref_t ref = {f, (int16_t)(f->indexed ? elem : 0)};
    (void)dr_ref_path(ref, buf, size);
}

void gw_regmap_write_fields(const gw_unit_t *u, gw_area_t area, uint16_t addr, uint16_t count,
                            void (*fn)(void *user, const char *path), void *user)
{
    char path[64], last[64] = "";
    gw_regmap_init();
    for (uint32_t a = addr; a < (uint32_t)addr + count; a++) {
        field_at(u, area, a, path, sizeof path);
        if (path[0] == '\0' || strcmp(path, last) == 0)
            continue; /* the other half of a REAL, or another part of a mask */
        memcpy(last, path, sizeof last);
        fn(user, path);
    }
}

/* One CSV field (RFC 4180): quoted when it holds a comma, a quote or a
 * line break, its quotes doubled; then a comma, or the line's end. */
static void csv_field(FILE *out, const char *s, bool last)
{
    if (strpbrk(s, ",\"\r\n") == NULL) {
        fputs(s, out);
    } else {
        fputc('"', out);
        for (; *s != '\0'; s++) {
            if (*s == '"')
                fputc('"', out);
            fputc(*s, out);
        }
        fputc('"', out);
    }
    fputs(last ? "\r\n" : ",", out);
}

/* One printed row: area, addresses a..end-1. */
static void print_row(FILE *out, gw_print_fmt_t fmt, bool *first, unsigned area, unsigned a,
                      unsigned end, const char *name, const char *type, const char *unit,
                      const char *robot, bool writable)
{
    unsigned p = area_prefix[area];
    switch (fmt) {
    case GW_PRINT_TEXT:
        fprintf(out, "%s %4u-%-4u %u%04u  %-40s %s %s\n", area_short[area], a, end - 1, p,
                a + 1, name, type, unit);
        break;
    case GW_PRINT_MARKDOWN:
        if (end - 1 > a)
            fprintf(out, "| %u-%u | %u%04u-%u%04u | `%s` | %s | %s |\n", a, end - 1, p, a + 1,
                    p, end, name, type, unit);
        else
            fprintf(out, "| %u | %u%04u | `%s` | %s | %s |\n", a, p, a + 1, name, type, unit);
        break;
    case GW_PRINT_CSV: {
        char num[3][16];
        snprintf(num[0], sizeof num[0], "%u", a);
        snprintf(num[1], sizeof num[1], "%u", end - a);
        snprintf(num[2], sizeof num[2], "%u%04u", p, a + 1);
        const char *cols[] = {area_short[area], num[0], num[1], num[2], name, type, unit,
                              robot != NULL ? robot : "",
                              robot != NULL ? (writable ? "true" : "false") : ""};
        for (unsigned i = 0; i < sizeof cols / sizeof cols[0]; i++)
            csv_field(out, cols[i], i + 1 == sizeof cols / sizeof cols[0]);
        break;
    }
    case GW_PRINT_JSON:
        fprintf(out, "%s  {\"area\": \"%s\", \"address\": %u, \"count\": %u, \"name\": \"%s\", "
                     "\"type\": \"%s\", \"unit\": \"%s\"",
                first != NULL && *first ? "" : ",\n", area_short[area], a, end - a, name, type,
                unit);
        if (robot != NULL)
            fprintf(out, ", \"robot\": \"%s\", \"writable\": %s", robot,
                    writable ? "true" : "false");
        fputs("}", out);
        *first = false;
        break;
    }
}

/* Where the map's rows go: printed (out, in fmt), or each handed to
 * `row` (the console's raw register view). */
typedef struct map_out {
    FILE *out; /* NULL: rows to `row` only, no headers */
    gw_print_fmt_t fmt;
    bool first;
    void (*row)(struct map_out *o, unsigned area, unsigned a, unsigned end, const char *name,
                bool user);
    void *user;
} map_out_t;

static void emit(map_out_t *o, unsigned area, unsigned a, unsigned end, const char *name,
                 const char *type, const char *unit, const char *robot, bool writable)
{
    if (o->row != NULL)
        o->row(o, area, a, end, name, robot != NULL);
    else
        print_row(o->out, o->fmt, &o->first, area, a, end, name, type, unit, robot, writable);
}

static void print_default(map_out_t *o, const char *filter)
{
    for (unsigned area = 0; area < GW_AREAS; area++) {
        if (o->out != NULL && o->fmt == GW_PRINT_MARKDOWN)
            fprintf(o->out, "\n### %ss\n\n| Address | Modbus | Name | Type | Unit |\n|---|---|---|---|---|\n",
                    area_name[area]);
        for (unsigned a = 0; a < GW_AREA_SIZE;) {
            const slot_t *s = &map[area][a];
            if (s->kind == SL_NONE) {
                a++;
                continue;
            }
            unsigned end = a + 1;
            while (end < GW_AREA_SIZE && same_group(s, &map[area][end]))
                end++;
            char name[96], type[96], unit[16];
            slot_text(s, (gw_area_t)area, end - a, name, sizeof name, type, sizeof type, unit,
                      sizeof unit);
            if (filter == NULL || strstr(name, filter) != NULL)
                emit(o, area, a, end, name, type, unit, NULL, false);
            a = end;
        }
    }
}

void gw_regmap_print(FILE *out, gw_print_fmt_t fmt)
{
    gw_regmap_print_all(out, fmt, NULL, NULL);
}

/* A user entry's rows: one per element (a 32-bit view: two addresses). */
static void print_user(map_out_t *o, const char *filter, const char *robot,
                       const gw_umap_entry_t *e)
{
    const dr_field_t *f = dr_field_at(e->field);
    unsigned per = e->view == GW_VIEW_REAL || e->view == GW_VIEW_DINT ? 2u : 1u;
    unsigned rows = e->view == GW_VIEW_BITS ? e->size : e->count;
    for (unsigned r = 0; r < rows; r++) {
        char name[96], type[96];
        unsigned a = e->addr + r * per;
        if (e->view == GW_VIEW_BITS) {
            unsigned lo = e->elem + 16u * r, n = e->count - 16u * r;
            dr_ref_t r0 = {f, (int16_t)lo};
            (void)dr_ref_path(r0, name, sizeof name);
            snprintf(type, sizeof type, "%u bit(s) packed, bit 0 = the first",
                     n > 16 ? 16 : n);
        } else {
            dr_ref_t ref = {f, (int16_t)(f->kind == DR_KIND_BIT ? 0 : e->elem + r)};
            (void)dr_ref_path(ref, name, sizeof name);
            if (e->view == GW_VIEW_INT16)
                snprintf(type, sizeof type, "INT16 = %s x %u%s", dr_kind_name((dr_kind_t)f->kind),
                         (unsigned)e->scale, e->saturate ? ", saturated" : "");
            else if (e->view == GW_VIEW_UINT16 && f->kind == DR_KIND_DINT)
                snprintf(type, sizeof type, "UINT16, %s half of the DINT",
                         e->half ? "high" : "low");
            else if (e->view == GW_VIEW_REAL || e->view == GW_VIEW_DINT)
                snprintf(type, sizeof type, "%s, 2 registers in word order",
                         e->view == GW_VIEW_REAL ? "REAL" : "DINT");
            else
                snprintf(type, sizeof type, "%s", e->view == GW_VIEW_BIT ? "bit" : "UINT16");
        }
        if (e->writable && o->fmt != GW_PRINT_JSON && o->fmt != GW_PRINT_CSV)
            snprintf(type + strlen(type), sizeof type - strlen(type), ", writable");
        if (filter == NULL || strstr(name, filter) != NULL)
            emit(o, e->table, a, a + per, name, type, f->unit, robot, e->writable);
    }
}

/* The default map and the robots' own (cfg NULL: none; only: that robot's
 * alone, else every robot's). */
static void print_maps(map_out_t *o, const char *filter, const gw_config_t *cfg, int only)
{
    gw_regmap_init();
    FILE *out = o->out;
    gw_print_fmt_t fmt = out != NULL ? o->fmt : GW_PRINT_TEXT;
    if (out != NULL && fmt == GW_PRINT_JSON)
        fputs("[\n", out);
    if (out != NULL && fmt == GW_PRINT_CSV)
        fputs("area,address,count,reference,name,type,unit,robot,writable\r\n", out);
    print_default(o, filter);
    for (unsigned r = 0; cfg != NULL && r < cfg->robot_count; r++) {
        const gw_umap_t *m = &cfg->robot[r].side.modbus.map;
        if (m->count == 0 || (only >= 0 && r != (unsigned)only))
            continue;
        if (out != NULL && fmt == GW_PRINT_MARKDOWN)
            fprintf(out, "\n### Robot %s (unit %u): its own map\n\n| Address | Modbus | Name | Type | Unit |\n|---|---|---|---|---|\n",
                    cfg->robot[r].name, (unsigned)cfg->robot[r].side.modbus.unit_id);
        else if (out != NULL && fmt == GW_PRINT_TEXT)
            fprintf(out, "# robot %s (unit %u): its own map\n", cfg->robot[r].name,
                    (unsigned)cfg->robot[r].side.modbus.unit_id);
        for (unsigned i = 0; i < m->count; i++)
            print_user(o, filter, cfg->robot[r].name, &m->entry[i]);
    }
    if (out != NULL && fmt == GW_PRINT_JSON)
        fputs("\n]\n", out);
}

void gw_regmap_print_all(FILE *out, gw_print_fmt_t fmt, const char *filter,
                         const gw_config_t *cfg)
{
    map_out_t o = {out, fmt, true, NULL, NULL};
    print_maps(&o, filter, cfg, -1);
}

bool gw_regmap_csv(gw_json_t *j, const gw_config_t *cfg, unsigned robot)
{
    if (robot >= cfg->robot_count || j->cap - j->len < 2)
        return false;
    size_t room = j->cap - j->len - 1;
    FILE *f = fmemopen(j->buf + j->len, room + 1, "w");
    if (f == NULL) {
        j->full = true;
        return false;
    }
    map_out_t o = {f, GW_PRINT_CSV, true, NULL, NULL};
    print_maps(&o, NULL, cfg, (int)robot);
    long n = ftell(f);
    bool err = ferror(f) != 0;
    (void)fclose(f);
    if (err || n < 0 || (size_t)n >= room) { /* did not fit (fmemopen stops at the end) */
        j->full = true;
        return false;
    }
    j->len += (size_t)n;
    j->buf[j->len] = '\0';
    return true;
}

/* ---- the raw registers (/api/v1/modbus/registers/NAME) ------------------------- */

typedef struct {
    gw_json_t *j;
    const gw_unit_t *u;
    gw_area_t area; /* the table being written; GW_AREAS: none yet */
    bool first;
} raw_t;

/* One row of the map: its words (bits 0/1) as a Modbus read of exactly
 * those addresses answers now, or the exception that read gets. */
static void raw_row(map_out_t *o, unsigned area, unsigned a, unsigned end, const char *name,
                    bool user)
{
    raw_t *r = o->user;
    char t[96];
    if (area != (unsigned)r->area) {
        snprintf(t, sizeof t, "%s\"%s\":[", r->area == GW_AREAS ? "" : "],", area_short[area]);
        gw_json_str(r->j, t);
        r->area = (gw_area_t)area;
        r->first = true;
    }
    uint16_t v[2] = {0, 0};
    bool pair = end - a >= 2u; /* a 32-bit value's two registers (the map's rows have 1 or 2) */
    unsigned n = pair ? 2u : 1u;
    int ex = gw_regmap_read(r->u, (gw_area_t)area, (uint16_t)a, (uint16_t)n, v);
    snprintf(t, sizeof t, "%s{\"address\":%u,\"count\":%u,\"ref\":\"%u%04u\",\"name\":",
             r->first ? "" : ",", a, n, area_prefix[area], a + 1u);
    gw_json_str(r->j, t);
    gw_json_quote(r->j, name, strlen(name));
    if (ex != 0)
        snprintf(t, sizeof t, ",\"ex\":%d%s}", ex, user ? ",\"user\":true" : "");
    else if (pair)
        snprintf(t, sizeof t, ",\"words\":[%u,%u]%s}", v[0], v[1], user ? ",\"user\":true" : "");
    else
        snprintf(t, sizeof t, ",\"words\":[%u]%s}", v[0], user ? ",\"user\":true" : "");
    gw_json_str(r->j, t);
    r->first = false;
}

bool gw_regmap_raw_json(gw_json_t *j, const gw_unit_t *u, const gw_config_t *cfg, unsigned robot)
{
    if (robot >= cfg->robot_count)
        return false;
    raw_t r = {j, u, GW_AREAS, true};
    map_out_t o = {NULL, GW_PRINT_JSON, true, raw_row, &r};
    gw_json_str(j, "{\"robot\":");
    gw_json_quote(j, cfg->robot[robot].name, strlen(cfg->robot[robot].name));
    gw_json_str(j, ",\"tables\":{");
    print_maps(&o, NULL, cfg, (int)robot);
    gw_json_str(j, r.area == GW_AREAS ? "}}" : "]}}");
    return !j->full;
}

/* ---- the console's map (/api/v1/robots/NAME/map) ----------------------------- */

/* Where each leaf (one element of one field, as drcli get --json keys
 * them) sits in the default map, found once from the slots themselves so
 * that the addresses are the ones served and printed. A leaf has at most
 * a register view (value, packed bits or 32-bit pair) and a second one (its
 * bit, or the scaled INT16 of a REAL). */
#define LEAF_MAX 1024u
#define LEAF_LOCS 3u
#define FIELD_MAX 512u
typedef struct {
    uint16_t addr;
    uint8_t area;
    uint8_t kind; /* slot_kind_t; SL_NONE: unused */
    uint8_t bit;  /* SL_PACKED: the leaf's bit in the register */
} leaf_loc_t;

static leaf_loc_t leaf_loc[LEAF_MAX][LEAF_LOCS];
static uint16_t field_leaf[FIELD_MAX]; /* first leaf of each field */
static uint16_t leaf_total;
static bool leaf_built;

static void leaf_add(unsigned leaf, gw_area_t area, uint16_t addr, slot_kind_t kind,
                     unsigned bit)
{
    for (unsigned i = 0; leaf < leaf_total && i < LEAF_LOCS; i++)
        if (leaf_loc[leaf][i].kind == SL_NONE) {
            leaf_loc_t l = {addr, (uint8_t)area, (uint8_t)kind, (uint8_t)bit};
            leaf_loc[leaf][i] = l;
            return;
        }
}

static unsigned leaves_of_field(const dr_field_t *f)
{
    return f->indexed ? f->count : 1u;
}

static bool leaf_index_build(void)
{
    if (leaf_built)
        return true;
    if (dr_field_count() > FIELD_MAX || dr_leaf_count() > LEAF_MAX)
        return false;
    gw_regmap_init();
    unsigned n = 0;
    for (uint16_t fi = 0; fi < dr_field_count(); fi++) {
        field_leaf[fi] = (uint16_t)n;
        n += leaves_of_field(dr_field_at(fi));
    }
    leaf_total = (uint16_t)n;
    for (unsigned area = 0; area < GW_AREAS; area++)
        for (unsigned a = 0; a < GW_AREA_SIZE; a++) {
            const slot_t *s = &map[area][a];
            const dr_field_t *f = slot_field(s);
            unsigned base = field_leaf[s->field];
            switch ((slot_kind_t)s->kind) {
            case SL_VALUE:
            case SL_SCALED:
            case SL_BIT:
                leaf_add(base + (unsigned)s->elem, (gw_area_t)area, (uint16_t)a,
                         (slot_kind_t)s->kind, 0);
                break;
            case SL_WORD32:
                if (s->part == 0)
                    leaf_add(base + (unsigned)s->elem, (gw_area_t)area, (uint16_t)a,
                             SL_WORD32, 0);
                break;
            case SL_PACKED:
                for (unsigned e = 16u * s->part; e < f->count && e < 16u * s->part + 16u; e++)
                    leaf_add(base + e, (gw_area_t)area, (uint16_t)a, SL_PACKED, e % 16u);
                break;
            default:
                break;
            }
        }
    leaf_built = true;
    return true;
}

/* One address of a leaf: {"table": "IR", "address": 102, "count": 2,
 * "ref": "30103", "view": ..., ...}; `extra` is written before the
 * closing brace (view-specific members, each starting with ", "). */
static void json_loc(gw_json_t *j, bool *first, unsigned area, unsigned addr, unsigned count,
                     const char *view, const char *extra, bool writable, bool user)
{
    char t[192];
    snprintf(t, sizeof t, "%s{\"table\": \"%s\", \"address\": %u, \"count\": %u, "
             "\"ref\": \"%u%04u\", \"view\": \"%s\"", *first ? "" : ", ", area_short[area],
             addr, count, area_prefix[area], addr + 1u, view);
    gw_json_str(j, t);
    gw_json_str(j, extra);
    snprintf(t, sizeof t, ", \"writable\": %s%s}", writable ? "true" : "false",
             user ? ", \"user\": true" : "");
    gw_json_str(j, t);
    *first = false;
}

static void json_default_locs(gw_json_t *j, bool *first, unsigned leaf, const dr_field_t *f,
                              gw_word_order_t order, bool writable)
{
    for (unsigned i = 0; i < LEAF_LOCS; i++) {
        const leaf_loc_t *l = &leaf_loc[leaf][i];
        char extra[64] = "";
        switch ((slot_kind_t)l->kind) {
        case SL_VALUE:
            json_loc(j, first, l->area, l->addr, 1, "uint16", "", writable, false);
            break;
        case SL_BIT:
            json_loc(j, first, l->area, l->addr, 1, "bit", "", writable, false);
            break;
        case SL_PACKED:
            snprintf(extra, sizeof extra, ", \"bit\": %u", (unsigned)l->bit);
            json_loc(j, first, l->area, l->addr, 1, "bits", extra, writable, false);
            break;
        case SL_WORD32:
            snprintf(extra, sizeof extra, ", \"order\": \"%s\"", gw_word_order_name(order));
            json_loc(j, first, l->area, l->addr, 2, f->kind == DR_KIND_REAL ? "real" : "dint",
                     extra, writable, false);
            break;
        case SL_SCALED:
            snprintf(extra, sizeof extra, ", \"scale\": %u", gw_regmap_scale(f));
            json_loc(j, first, l->area, l->addr, 1, "int16", extra, writable, false);
            break;
        default:
            break;
        }
    }
}

/* The user's entries that serve element `elem` of field `fi`. */
static void json_user_locs(gw_json_t *j, bool *first, const gw_umap_t *m, unsigned fi,
                           unsigned elem, gw_word_order_t order)
{
    for (unsigned i = 0; m != NULL && i < m->count; i++) {
        const gw_umap_entry_t *e = &m->entry[i];
        if (e->field != fi || elem < e->elem || elem >= (unsigned)e->elem + e->count)
            continue;
        unsigned k = elem - e->elem;
        char extra[96] = "";
        const char *view = gw_umap_view_name(e->view);
        switch ((gw_view_t)e->view) {
        case GW_VIEW_BITS:
            snprintf(extra, sizeof extra, ", \"bit\": %u", k % 16u);
            json_loc(j, first, e->table, e->addr + k / 16u, 1, view, extra, e->writable, true);
            break;
        case GW_VIEW_REAL:
        case GW_VIEW_DINT:
            snprintf(extra, sizeof extra, ", \"order\": \"%s\"", gw_word_order_name(order));
            json_loc(j, first, e->table, e->addr + 2u * k, 2, view, extra, e->writable, true);
            break;
        case GW_VIEW_INT16:
            snprintf(extra, sizeof extra, ", \"scale\": %u%s", (unsigned)e->scale,
                     e->saturate ? ", \"saturate\": true" : "");
            json_loc(j, first, e->table, e->addr + k, 1, view, extra, e->writable, true);
            break;
        case GW_VIEW_UINT16:
            if (dr_field_at((uint16_t)fi)->kind == DR_KIND_DINT)
                snprintf(extra, sizeof extra, ", \"half\": \"%s\"", e->half ? "high" : "low");
            json_loc(j, first, e->table, e->addr + k, 1, view, extra, e->writable, true);
            break;
        case GW_VIEW_BIT:
            json_loc(j, first, e->table, e->addr + k, 1, view, "", e->writable, true);
            break;
        }
    }
}

/* A bit a GPIO input drives: Modbus may not write it (gw_regmap_write). */
static bool gpio_driven(const gw_config_t *cfg, unsigned r, dr_ref_t ref)
{
    for (unsigned g = 0; g < cfg->side.gpio.count; g++) {
        const gw_gpio_config_t *gp = &cfg->side.gpio.line[g];
        if (gp->dir == GW_GPIO_INPUT && gp->robot_index == r && gp->field.field == ref.field &&
            (gp->field.elem == ref.elem || gp->field.elem < 0))
            return true;
    }
    return false;
}

static void json_leaf(gw_json_t *j, const gw_config_t *cfg, unsigned r, unsigned fi,
                      unsigned elem, bool first)
{
    const dr_field_t *f = dr_field_at((uint16_t)fi);
    const gw_robot_config_t *rc = &cfg->robot[r];
    dr_ref_t ref = {f, (int16_t)elem};
    bool o2t = dr_asm_info((dr_asm_t)f->assembly)->dir == DR_DIR_O2T;
    char path[96];
    (void)dr_ref_path(ref, path, sizeof path);
    gw_json_str(j, first ? "\n  {\"path\": " : ",\n  {\"path\": ");
    gw_json_quote(j, path, strlen(path));
    gw_json_str(j, ", \"type\": \"");
    gw_json_str(j, f->kind == DR_KIND_BITS ? "BOOL" : dr_kind_name((dr_kind_t)f->kind));
    gw_json_str(j, "\", \"unit\": ");
    gw_json_quote(j, f->unit, strlen(f->unit));
    gw_json_str(j, o2t ? ", \"dir\": \"O->T\"" : ", \"dir\": \"T->O\"");
    gw_json_str(j, ", \"help\": ");
    gw_json_quote(j, f->help, strlen(f->help));
    if (f->kind == DR_KIND_ENUM) {
        gw_json_str(j, ", \"enum\": [");
        for (unsigned v = 0; dr_robot_state_name(v) != NULL; v++) {
            gw_json_str(j, v == 0 ? "\"" : ", \"");
            gw_json_str(j, dr_robot_state_name(v));
            gw_json_str(j, "\"");
        }
        gw_json_str(j, "]");
    }
    gw_json_str(j, ", \"modbus\": [");
    bool lfirst = true;
    bool writable = o2t && rc->side.modbus.default_map_writes && !gpio_driven(cfg, r, ref);
    json_default_locs(j, &lfirst, field_leaf[fi] + elem, f, cfg->side.modbus.word_order, writable);
    json_user_locs(j, &lfirst, &rc->side.modbus.map, fi, elem, cfg->side.modbus.word_order);
    gw_json_str(j, "]}");
}

bool gw_regmap_json(gw_json_t *j, const gw_config_t *cfg, unsigned robot)
{
    if (robot >= cfg->robot_count || !leaf_index_build())
        return false;
    const gw_robot_config_t *rc = &cfg->robot[robot];
    char t[160];
    gw_json_str(j, "{\"robot\": ");
    gw_json_quote(j, rc->name, strlen(rc->name));
    snprintf(t, sizeof t, ", \"unit_id\": %u, \"word_order\": \"%s\", \"default_map_writes\": %s, "
             "\"layout_version\": %u, \"fields\": [", (unsigned)rc->side.modbus.unit_id,
             gw_word_order_name(cfg->side.modbus.word_order),
             rc->side.modbus.default_map_writes ? "true" : "false", (unsigned)GW_MAP_LAYOUT_VERSION);
    gw_json_str(j, t);
    bool first = true;
    for (uint16_t fi = 0; fi < dr_field_count(); fi++)
        for (unsigned e = 0; e < leaves_of_field(dr_field_at(fi)); e++) {
            json_leaf(j, cfg, robot, fi, e, first);
            first = false;
        }
    gw_json_str(j, "\n]}\n");
    return !j->full;
}

/* ---- last_error's codes (drgatewayd --print-errors) ------------------------------ */

/* One row: the codes as the registers show them, the cause in words and,
 * where the daemon knows one, what to check. */
static void error_row(FILE *out, gw_print_fmt_t fmt, const char *code, const char *general,
                      const char *cause, const char *hint)
{
    if (fmt == GW_PRINT_MARKDOWN)
        fprintf(out, "| %s | %s | %s | %s |\n", code, general, cause, hint != NULL ? hint : "");
    else
        fprintf(out, "%-15s %-11s %s%s%s\n", code, general, cause, hint != NULL ? ": " : "",
                hint != NULL ? hint : "");
}

/* A code in hexadecimal and, for PLC programs that show decimal, decimal. */
static void hex_dec(char *buf, size_t size, unsigned v, int digits)
{
    snprintf(buf, size, "0x%0*X (%u)", digits, v, v);
}

#define ERR_CODE(name, value, text) value,
static const int plain_codes[] = {DR_STATUS_LIST(ERR_CODE)};
#undef ERR_CODE

void gw_regmap_print_errors(FILE *out, gw_print_fmt_t fmt)
{
    char code[40], gen[24], cause[160];
    if (fmt == GW_PRINT_MARKDOWN)
        fputs("| `last_error` (IR 12) | `last_cip_general` (IR 30) | cause | what to check |\n"
              "|---|---|---|---|\n", out);
    else
        fprintf(out, "%-15s %-11s %s\n", "last_error", "cip_general", "cause");
    error_row(out, fmt, "0", "0", "no failure since the robot's link started", NULL);
    /* drgate's own codes: the whole list, in its order (1, 2, ...) */
    for (size_t i = 0; i < sizeof plain_codes / sizeof plain_codes[0]; i++) {
        dr_status_t st = plain_codes[i];
        if (st == DR_OK)
            continue;
        snprintf(code, sizeof code, "%d", (int)st);
        error_row(out, fmt, code, "0", dr_strerror(st), gw_robot_error_hint(st));
    }
    /* encapsulation statuses, moved above drgate's codes */
    const char *unknown = dr_strerror(DR_ENCAP(0xFFFF));
    for (unsigned s = 1; s < GW_ERROR_OTHER - GW_ERROR_ENCAP; s++) {
        if (strcmp(dr_strerror(DR_ENCAP(s)), unknown) == 0)
            continue;
        hex_dec(code, sizeof code, GW_ERROR_ENCAP + s, 4);
        gw_robot_error_text(DR_ENCAP(s), cause, sizeof cause);
        error_row(out, fmt, code, "0", cause,
                  s == 0x69 ? "the robot refused RegisterSession's protocol version" : NULL);
    }
    error_row(out, fmt, "0x8000 + s", "0",
              "any other encapsulation status s from the robot (0x0001-0x7FFE)", NULL);
    hex_dec(code, sizeof code, GW_ERROR_OTHER, 4);
    error_row(out, fmt, code, "0", "an encapsulation status above 0x7FFE", NULL);
    /* CIP: a refused Forward Open's extended status, then replies that
     * carry a general status alone */
    for (unsigned x = 1; x <= 0xFFFFu; x++) {
        dr_status_t st = DR_CIP(0x01, x);
        if (strcmp(dr_strerror(st), dr_cip_general_text(0x01)) == 0)
            continue;
        hex_dec(code, sizeof code, x, 4);
        hex_dec(gen, sizeof gen, 0x01, 2);
        gw_robot_error_text(st, cause, sizeof cause);
        error_row(out, fmt, code, gen, cause, NULL);
    }
    const char *unknown_general = dr_cip_general_text(0xFF);
    for (unsigned g = 1; g <= 0xFFu; g++) {
        if (strcmp(dr_cip_general_text((uint8_t)g), unknown_general) == 0)
            continue;
        hex_dec(code, sizeof code, g, 2);
        hex_dec(gen, sizeof gen, g, 2);
        gw_robot_error_text(DR_CIP(g, 0), cause, sizeof cause);
        snprintf(cause + strlen(cause), sizeof cause - strlen(cause),
                 " (a reply without extended status)");
        error_row(out, fmt, code, gen, cause, NULL);
    }
    error_row(out, fmt, "x", "g",
              "any other CIP reply: general status g with extended status x (or x = g "
              "when it has none)", NULL);
}
