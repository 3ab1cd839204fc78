/* SPDX-License-Identifier: MIT */
/*
 * Shared by the fuzz harnesses: the libFuzzer entry point's prototype (the
 * project builds with -Wmissing-prototypes) and the invariant checks.
 *
 * A harness calls a parser on bytes from outside and, where the parser
 * accepts them, checks what the parser promised: views inside the input,
 * lengths that add up, and re-encoding that gives the input back where the
 * format has one spelling. A broken promise calls abort(), which libFuzzer
 * and the standalone driver both report as a crash with the input saved.
 */
#ifndef DRGATE_FUZZ_H
#define DRGATE_FUZZ_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define FUZZ_CHECK(cond)                                                       \
    do {                                                                       \
        if (!(cond)) {                                                         \
            fprintf(stderr, "%s:%d: invariant broken: %s\n", __FILE__,         \
                    __LINE__, #cond);                                          \
            abort();                                                           \
        }                                                                      \
    } while (0)

/* p[0..n) lies inside base[0..size). Compared as integers: relational
 * operators on pointers into different objects would themselves be UB. */
static inline int fuzz_within(const void *p, size_t n, const void *base,
                              size_t size)
{
    uintptr_t a = (uintptr_t)p, b = (uintptr_t)base;
    if (p == NULL)
        return n == 0;
    return a >= b && a - b <= size && n <= size - (size_t)(a - b);
}

#endif /* DRGATE_FUZZ_H */
