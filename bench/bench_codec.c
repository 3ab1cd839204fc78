/* SPDX-License-Identifier: MIT */
/*
 * make bench: how long decoding all ten assemblies into their typed structs
 * takes, and encoding them back, each as a ratio to a plain memcpy of the
 * same 688 bytes measured in the same run. Goal: under 10x each.
 *
 * The three loops are interleaved sample by sample, so a change of CPU
 * clock or a busy neighbour hits all three alike, and the ratio is taken
 * per sample before the median. memcpy is called through a volatile
 * pointer so that the compiler can neither drop nor inline it: like the
 * codec, which lives in another translation unit, it stays a real call.
 *
 * `bench_codec --count N` times nothing: it makes N calls of each of the
 * three and exits, for an instruction count that a busy machine does not
 * change (docs/performance.md):
 *   valgrind --tool=callgrind build/bench/bench_codec --count 10000
 * then callgrind_annotate --inclusive=yes: Ir of copy_all, decode_all and
 * encode_all, divided by N.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "drgate/codec.h"

#define SAMPLES 301
#define REPS 2000
#define GOAL 10.0

typedef union {
    dr_io_state_t io_state;
    dr_joint_state_t joint_state;
    dr_task_state_t task_state;
    dr_bit_gpr_t bit_gpr;
    dr_int_gpr_t int_gpr;
    dr_float_gpr_t float_gpr;
    dr_io_control_t io_control;
} any_asm_t;

static uint8_t wire[DR_ASM_TOTAL_SIZE];   /* the ten images, back to back */
static uint8_t copy_dst[DR_ASM_TOTAL_SIZE];
static uint8_t encoded[DR_ASM_TOTAL_SIZE];
static any_asm_t typed[DR_ASM_COUNT];
static size_t base[DR_ASM_COUNT];

static void *(*volatile copy_fn)(void *, const void *, size_t) = memcpy;

static double now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e9 + (double)ts.tv_nsec;
}

static uint32_t rng = 12345u;
static uint32_t rnd(void)
{
    rng = rng * 1664525u + 1013904223u;
    return rng;
}

/* Random bytes everywhere, then every REAL replaced by a finite value, so
 * that encode does all its work instead of stopping at a NaN. */
static void make_images(void)
{
    size_t off = 0;
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        base[a] = off;
        off += dr_asm_info((dr_asm_t)a)->size;
    }
    for (size_t i = 0; i < sizeof wire; i++)
        wire[i] = (uint8_t)(rnd() >> 24);
    for (uint16_t i = 0; i < dr_leaf_count(); i++) {
        dr_ref_t leaf;
        if (dr_leaf_at(i, &leaf) != DR_OK || leaf.field->kind != DR_KIND_REAL)
            continue;
        dr_asm_t a = (dr_asm_t)leaf.field->assembly;
        dr_value_t v = dr_value_real((double)(rnd() % 200000u) / 100.0 - 1000.0);
        if (dr_field_set(wire + base[a], dr_asm_info(a)->size, leaf, &v, 0) != DR_OK)
            abort();
    }
}

static void decode_all(void)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_decode((dr_asm_t)a, wire + base[a], dr_asm_info((dr_asm_t)a)->size,
                          &typed[a]) != DR_OK)
            abort();
}

static void encode_all(void)
{
    for (unsigned a = 0; a < DR_ASM_COUNT; a++)
        if (dr_asm_encode((dr_asm_t)a, &typed[a], encoded + base[a],
                          dr_asm_info((dr_asm_t)a)->size) != DR_OK)
            abort();
}

static void copy_all(void)
{
    copy_fn(copy_dst, wire, sizeof wire);
}

/* Time REPS calls of fn; ns per call. */
static double time_reps(void (*fn)(void))
{
    double t0 = now_ns();
    for (int r = 0; r < REPS; r++)
        fn();
    return (now_ns() - t0) / REPS;
}

/* One assembly at a time, for the breakdown: which ones cost the most. */
static dr_asm_t cur;
static void decode_one(void)
{
    dr_asm_decode(cur, wire + base[cur], dr_asm_info(cur)->size, &typed[cur]);
}
static void encode_one(void)
{
    dr_asm_encode(cur, &typed[cur], encoded + base[cur], dr_asm_info(cur)->size);
}

static int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

static double median(double *v, size_t n)
{
    qsort(v, n, sizeof v[0], cmp_double);
    return v[n / 2];
}

/* --count N: N untimed calls of each, for instruction counting. */
static int count_only(const char *arg)
{
    char *end;
    long n = strtol(arg, &end, 10);
    if (*end != '\0' || n <= 0) {
        fprintf(stderr, "bench_codec: --count takes a positive number, not '%s'\n", arg);
        return 2;
    }
    for (long i = 0; i < n; i++)
        copy_all();
    for (long i = 0; i < n; i++)
        decode_all();
    for (long i = 0; i < n; i++)
        encode_all();
    return 0;
}

int main(int argc, char **argv)
{
    static double t_copy[SAMPLES], t_dec[SAMPLES], t_enc[SAMPLES];
    static double r_dec[SAMPLES], r_enc[SAMPLES];

    make_images();
    decode_all();
    encode_all();
    /* Sanity: encode(decode(x)) keeps every field's bits (reserved bits
     * aside), so the loops measure real work on valid data. */
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        any_asm_t again;
        dr_asm_decode((dr_asm_t)a, encoded + base[a], dr_asm_info((dr_asm_t)a)->size, &again);
        if (memcmp(&again, &typed[a], dr_asm_info((dr_asm_t)a)->struct_size) != 0) {
            fprintf(stderr, "bench: %s does not round-trip\n", dr_asm_info((dr_asm_t)a)->name);
            return 2;
        }
    }
    if (argc == 3 && strcmp(argv[1], "--count") == 0)
        return count_only(argv[2]);
    if (argc != 1) {
        fprintf(stderr, "usage: bench_codec [--count N]\n");
        return 2;
    }

    for (int w = 0; w < 20; w++) { /* warm caches and clocks */
        time_reps(copy_all);
        time_reps(decode_all);
        time_reps(encode_all);
    }
    for (int s = 0; s < SAMPLES; s++) {
        t_copy[s] = time_reps(copy_all);
        t_dec[s] = time_reps(decode_all);
        t_enc[s] = time_reps(encode_all);
        r_dec[s] = t_dec[s] / t_copy[s];
        r_enc[s] = t_enc[s] / t_copy[s];
    }
    if (memcmp(copy_dst, wire, sizeof wire) != 0) /* and memcpy did copy */
        return 2;

    double m_copy = median(t_copy, SAMPLES), m_dec = median(t_dec, SAMPLES);
    double m_enc = median(t_enc, SAMPLES);
    double q_dec = median(r_dec, SAMPLES), q_enc = median(r_enc, SAMPLES);
    bool ok = q_dec < GOAL && q_enc < GOAL;

    printf("drgate codec bench: all ten assemblies (%u bytes), medians of %d samples x %d calls\n\n",
           DR_ASM_TOTAL_SIZE, SAMPLES, REPS);
    printf("%-32s %10s %10s %8s  %s\n", "operation", "ns", "x memcpy", "goal", "");
    printf("%-32s %10.1f %10.2f %8s\n", "memcpy of 688 bytes", m_copy, 1.0, "");
    printf("%-32s %10.1f %10.2f %8s  %s\n", "decode all ten (dr_asm_decode)", m_dec, q_dec,
           "< 10x", q_dec < GOAL ? "met" : "MISSED");
    printf("%-32s %10.1f %10.2f %8s  %s\n", "encode all ten (dr_asm_encode)", m_enc, q_enc,
           "< 10x", q_enc < GOAL ? "met" : "MISSED");
    printf("\n(ns columns are medians of their own; x memcpy is the median of the\n"
           " per-sample ratios, so the two need not divide exactly.)\n");

    printf("\nper assembly (ns, medians of %d samples):\n", SAMPLES / 6);
    printf("%-12s %6s %7s %8s %8s\n", "assembly", "fields", "bytes", "decode", "encode");
    for (unsigned a = 0; a < DR_ASM_COUNT; a++) {
        double d[SAMPLES / 6], e[SAMPLES / 6];
        cur = (dr_asm_t)a;
        for (int s = 0; s < SAMPLES / 6; s++) {
            d[s] = time_reps(decode_one);
            e[s] = time_reps(encode_one);
        }
        const dr_asm_info_t *info = dr_asm_info(cur);
        printf("%-12s %6u %7u %8.1f %8.1f\n", info->name, (unsigned)info->field_count,
               (unsigned)info->size, median(d, SAMPLES / 6), median(e, SAMPLES / 6));
    }
    return ok ? 0 : 1;
}
