/* SPDX-License-Identifier: MIT */
/*
 * The EDS reader (common/eds.c), which drcli eds and drgatewayd's `eds`
 * key use, on any text: eds_parse over the input's bytes (not
 * NUL-terminated), with a 1..64-byte error buffer chosen by the first
 * byte; then the plan it gives (common/eds_plan.c).
 *
 * Checks: on failure the message is terminated, one line of printable
 * text, and its line is a line of the input (1..lines + 1); on success
 * every table is within its bound, every string kept is terminated, each
 * assembly's size is -1 or 0..65535 and its instance not 0, every AssemN
 * and ParamN a connection names is there (or its table was full), a
 * resolved size is -1..65535; every note has a line of the input; the same
 * bytes parse the same way twice (no state kept between calls). The plan:
 * its connections within bounds and each one of the EDS's, its indexes
 * -1 or within them, a matched layout's kind valid, its rpi_ms 0 or
 * 1..10000 inside the connection's range, its lines lines of the input.
 */
#include <string.h>

#include "common/eds.h"
#include "fuzz.h"

static eds_t A, B;
static eds_plan_t P;

static void check_plan(unsigned lines)
{
    eds_plan(&A, &P);
    FUZZ_CHECK(P.nconn <= A.n_conn);
    const int idx[] = {P.main_i, P.in_only_i, P.listen_i, P.plan_i};
    for (unsigned k = 0; k < sizeof idx / sizeof idx[0]; k++)
        FUZZ_CHECK(idx[k] >= -1 && idx[k] < (int)P.nconn);
    for (unsigned i = 0; i < P.nconn; i++)
        FUZZ_CHECK(P.conn[i].c >= A.conn && P.conn[i].c < A.conn + A.n_conn);
    FUZZ_CHECK(!P.matched || (unsigned)P.kind < DR_LAYOUT_COUNT);
    FUZZ_CHECK(P.plan_line <= lines && P.rpi_line <= lines);
    FUZZ_CHECK(P.rpi_ms <= 10000);
    if (P.rpi_ms != 0) {
        const eds_conn_plan_t *rp = &P.conn[P.plan_i >= 0 ? P.plan_i : 0];
        FUZZ_CHECK(P.rpi_ms == eds_pick_rpi_ms(rp));
        FUZZ_CHECK((uint64_t)P.rpi_ms * 1000u >= rp->rpi_min &&
                   (uint64_t)P.rpi_ms * 1000u <= (uint64_t)rp->rpi_max + 999u);
    }
    for (unsigned i = 0; i < A.n_note; i++)
        FUZZ_CHECK(A.note_line[i] >= 1 && A.note_line[i] <= lines);
}

static unsigned count_lines(const uint8_t *d, size_t n)
{
    unsigned lines = 1;
    for (size_t i = 0; i < n; i++)
        lines += d[i] == '\n';
    return lines;
}

static void check_str(const char *s, size_t size)
{
    FUZZ_CHECK(memchr(s, '\0', size) != NULL);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1)
        return 0;
    size_t errsize = 1u + data[0] % 64u;
    data++;
    size--;
    char err[64], err2[64];
    unsigned line = 0, line2 = 0;
    unsigned lines = count_lines(data, size);
    bool ok = eds_parse((const char *)data, size, &A, &line, err, errsize);
    bool ok2 = eds_parse((const char *)data, size, &B, &line2, err2, errsize);
    FUZZ_CHECK(ok == ok2);
    if (!ok) {
        FUZZ_CHECK(line == line2 && strcmp(err, err2) == 0);
        FUZZ_CHECK(line >= 1 && line <= lines);
        FUZZ_CHECK(memchr(err, '\0', errsize) != NULL);
        for (const char *p = err; *p != '\0'; p++)
            FUZZ_CHECK((unsigned char)*p >= 0x20 && *p != 0x7F);
        return 0;
    }
    FUZZ_CHECK(A.n_assem <= EDS_MAX_ASSEM && A.n_conn <= EDS_MAX_CONN &&
               A.n_param <= EDS_MAX_PARAM && A.n_note <= EDS_MAX_NOTES);
    FUZZ_CHECK(A.lines == lines);
    check_str(A.vendor_name, sizeof A.vendor_name);
    check_str(A.product_name, sizeof A.product_name);
    check_str(A.catalog, sizeof A.catalog);
    FUZZ_CHECK(A.vendor <= 0xFFFFu && A.product_code <= 0xFFFFu && A.major_rev <= 0xFFu);
    for (unsigned i = 0; i < A.n_assem; i++) {
        const eds_assem_t *a = &A.assem[i];
        check_str(a->name, sizeof a->name);
        FUZZ_CHECK(a->size >= -1 && a->size <= 0xFFFF);
        FUZZ_CHECK(a->line >= 1 && a->line <= lines);
        FUZZ_CHECK(eds_assem(&A, a->number) == a); /* numbers unique */
    }
    for (unsigned i = 0; i < A.n_param; i++) {
        FUZZ_CHECK(eds_param(&A, A.param[i].number) == &A.param[i]);
        check_str(A.param[i].units, sizeof A.param[i].units);
    }
    for (unsigned i = 0; i < A.n_conn; i++) {
        const eds_conn_t *c = &A.conn[i];
        check_str(c->name, sizeof c->name);
        FUZZ_CHECK(c->line >= 1 && c->line <= lines);
        const eds_ref_t *r[] = {&c->ot_format, &c->to_format, &c->cfg_format,
                                    &c->ot_size, &c->to_size, &c->ot_rpi, &c->to_rpi};
        for (unsigned k = 0; k < sizeof r / sizeof r[0]; k++) {
            if (r[k]->kind == 'A' && A.n_assem < EDS_MAX_ASSEM)
                FUZZ_CHECK(eds_assem(&A, r[k]->value) != NULL);
            if (r[k]->kind == 'P' && A.n_param < EDS_MAX_PARAM)
                FUZZ_CHECK(eds_param(&A, r[k]->value) != NULL);
        }
        int32_t s = eds_size(&A, c->ot_size, c->ot_format);
        FUZZ_CHECK(s >= -1 && s <= 0xFFFF);
        s = eds_size(&A, c->to_size, c->to_format);
        FUZZ_CHECK(s >= -1 && s <= 0xFFFF);
        (void)eds_instance(&A, c->to_format, c->path_to);
    }
    for (unsigned i = 0; i < A.n_note; i++) {
        check_str(A.note[i], sizeof A.note[i]);
        FUZZ_CHECK(A.note_line[i] >= 1 && A.note_line[i] <= lines);
    }
    check_plan(lines);
    return 0;
}
