/* SPDX-License-Identifier: MIT */
/*
 * The user's register map (gateway/modbus/usermap.c) as people type it:
 * each input line is one `map` value through gw_umap_parse and
 * gw_umap_add into one map; then the map is served (gw_regmap_read over
 * every block, gw_regmap_write of what was read back) on a unit with a
 * robot whose images are the input's bytes.
 *
 * Checks: an accepted entry is inside the address space, its view fits its
 * table, writable only on an O->T field in hr/co; the map stays sorted,
 * without overlaps and off the default map's addresses; a refused line
 * leaves the map as it was and says why in one terminated line; every
 * block reads; writing back what a writable block read is accepted and
 * changes no image; a write to a read-only block is refused with 0x02 and
 * changes nothing.
 */
#include <string.h>

#include "fuzz.h"
#include "modbus/regmap.h"
#include "modbus/usermap.h"

static gw_umap_t M;
static gw_robot_t R;
static gw_unit_t U;

static void check_map(void)
{
    for (unsigned i = 0; i < M.count; i++) {
        const gw_umap_entry_t *e = &M.entry[i];
        const dr_field_t *f = dr_field_at(e->field);
        uint16_t at;
        FUZZ_CHECK(e->size > 0 && (uint32_t)e->addr + e->size <= 65536u);
        FUZZ_CHECK(e->elem + e->count <= f->count);
        FUZZ_CHECK((e->table == GW_UMAP_CO || e->table == GW_UMAP_DI) == (e->view == GW_VIEW_BIT));
        FUZZ_CHECK(!e->writable || (dr_asm_info((dr_asm_t)f->assembly)->dir == DR_DIR_O2T &&
                                    (e->table == GW_UMAP_HR || e->table == GW_UMAP_CO)));
        FUZZ_CHECK(!gw_regmap_default_used((gw_area_t)e->table, e->addr, e->size, &at));
        if (i > 0) {
            const gw_umap_entry_t *p = &M.entry[i - 1];
            FUZZ_CHECK(p->table < e->table ||
                       (p->table == e->table && (uint32_t)p->addr + p->size <= e->addr));
        }
    }
}

static bool same_map(const gw_umap_t *a, const gw_umap_t *b)
{
    if (a->count != b->count)
        return false;
    for (unsigned i = 0; i < a->count; i++) {
        const gw_umap_entry_t *x = &a->entry[i], *y = &b->entry[i];
        if (x->table != y->table || x->addr != y->addr || x->size != y->size ||
            x->field != y->field || x->elem != y->elem || x->count != y->count ||
            x->view != y->view || x->writable != y->writable)
            return false;
    }
    return true;
}

static void serve(void)
{
    static uint16_t v[65536];
    U.umap = &M;
    U.robot = &R;
    for (unsigned i = 0; i < M.count; i++) {
        const gw_umap_entry_t *e = &M.entry[i];
        uint16_t n = (uint16_t)(e->size > 120 ? 120 : e->size);
        FUZZ_CHECK(gw_regmap_read(&U, (gw_area_t)e->table, e->addr, n, v) == 0);
        if (e->table != GW_UMAP_HR && e->table != GW_UMAP_CO)
            continue;
        gw_robot_t before = R;
        gw_write_result_t wres;
        int ex = gw_regmap_write(&U, (gw_area_t)e->table, e->addr, n, v, NULL, &wres);
        if (!e->writable)
            FUZZ_CHECK(ex == GW_EX_ILLEGAL_ADDRESS);
        /* a value read back writes the same image (an INT16 view of a
         * REAL may round, and a saturated one clamps: only exact views) */
        if (ex == 0 && (e->view == GW_VIEW_DINT || e->view == GW_VIEW_BIT ||
                        e->view == GW_VIEW_BITS || e->view == GW_VIEW_UINT16))
            FUZZ_CHECK(memcmp(before.img, R.img, sizeof R.img) == 0);
        if (ex != 0)
            FUZZ_CHECK(memcmp(before.img, R.img, sizeof R.img) == 0);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    char line[300], err[400];
    memset(&M, 0, sizeof M);
    memset(&U, 0, sizeof U);
    memset(&R, 0, sizeof R);
    gw_regmap_init();
    R.link.link_state = 2;
    /* the images: the input's bytes, repeated */
    for (unsigned a = 0; a < DR_ASM_COUNT && size > 0; a++)
        for (size_t k = 0; k < sizeof R.img[a]; k++)
            R.img[a][k] = data[(a * 37u + k) % size];
    size_t pos = 0;
    while (pos < size) {
        size_t n = 0;
        while (pos + n < size && data[pos + n] != '\n')
            n++;
        if (n < sizeof line) {
            memcpy(line, data + pos, n);
            line[n] = '\0';
            if (strlen(line) == n) {
                gw_umap_entry_t e;
                gw_umap_t before = M;
                err[0] = '\0';
                bool ok = gw_umap_parse(line, 1, &e, err, sizeof err) &&
                          gw_umap_add(&M, &e, err, sizeof err);
                if (!ok) {
                    FUZZ_CHECK(same_map(&before, &M));
                    FUZZ_CHECK(err[0] != '\0' && memchr(err, '\0', sizeof err) != NULL &&
                               strchr(err, '\n') == NULL);
                }
                check_map();
            }
        }
        pos += n + 1;
    }
    serve();
    return 0;
}
