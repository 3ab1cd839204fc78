/* SPDX-License-Identifier: MIT */
/* Values as text and back (see drgate/text.h). */
#include <errno.h>
#include <inttypes.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "drgate/text.h"

static dr_status_t fit(int n, size_t size)
{
    return (n < 0 || (size_t)n >= size) ? DR_ENOSPACE : DR_OK;
}

/* Shortest digits of f: the fewest significant digits (1..9; 9 always
 * do for binary32) whose text reads back to the same float, as "d.ddd"
 * in digits[] without the point, and the decimal exponent of the first. */
/* Does f printed with prec significant digits read back as f? (Into tmp.) */
static bool round_trips(float f, int prec, char tmp[32])
{
    snprintf(tmp, 32, "%.*e", prec - 1, (double)f);
    return strtof(tmp, NULL) == f;
}

static int shortest_digits(float f, char digits[16], int *exp10)
{
    char tmp[32];
    /* The fewest digits that read back: 9 always do, and if p digits do,
     * p + 1 do too (the p-digit text is a (p + 1)-digit one, and the
     * nearest (p + 1)-digit text is no farther from f), so a binary search
     * finds it in 3 or 4 conversions instead of up to 9 (the console's live
     * values format every changed REAL of every robot 4 times a second). */
    int lo = 1, hi = 9;
    while (lo < hi) {
        int mid = lo + (hi - lo) / 2;
        if (round_trips(f, mid, tmp))
            hi = mid;
        else
            lo = mid + 1;
    }
    snprintf(tmp, sizeof tmp, "%.*e", lo - 1, (double)f);
    /* tmp: [-]d[.ddd]e[+-]xx */
    const char *p = tmp + (tmp[0] == '-');
    int n = 0;
    for (; *p != 'e'; p++)
        if (*p != '.')
            digits[n++] = *p;
    while (n > 1 && digits[n - 1] == '0')
        n--; /* %e pads to the precision asked: 100 is "1.00e+02" at 3 */
    digits[n] = '\0';
    *exp10 = (int)strtol(p + 1, NULL, 10);
    return n;
}

dr_status_t dr_text_real(float f, char *out, size_t size)
{
    if (out == NULL || size == 0)
        return DR_EINVAL;
    if (f != f)
        return fit(snprintf(out, size, "nan"), size);
    if (f > 3.4028235e38f || f < -3.4028235e38f)
        return fit(snprintf(out, size, f > 0 ? "inf" : "-inf"), size);
    if (f == 0.0f) /* -0 keeps its sign: it reads back to the same bits */
        return fit(snprintf(out, size, signbit(f) ? "-0" : "0"), size);
    char d[16], text[48];
    int e;
    int n = shortest_digits(f, d, &e);
    size_t k = 0;
    if (f < 0)
        text[k++] = '-';
    if (e < DR_TEXT_PLAIN_MIN_EXP || e > DR_TEXT_PLAIN_MAX_EXP) {
        /* 1e-7, -2.5e+20, 3.4028235e+38 */
        text[k++] = d[0];
        if (n > 1)
            text[k++] = '.';
        snprintf(text + k, sizeof text - k, "%se%c%d", d + 1, e < 0 ? '-' : '+',
                 e < 0 ? -e : e);
        return fit(snprintf(out, size, "%s", text), size);
    }
    /* Plain: 0.00001, 0.33333334, 31.5, 100, 123456790 (the float is
     * 123456792: places past the shortest digits are zeros). */
    if (e < 0) {
        text[k++] = '0';
        text[k++] = '.';
        for (int i = -1; i > e; i--)
            text[k++] = '0';
    }
    for (int i = 0; i < n || i <= e; i++) {
        if (i == e + 1 && e >= 0)
            text[k++] = '.';
        if (i < n)
            text[k++] = d[i];
        else
            text[k++] = '0';
    }
    text[k] = '\0';
    return fit(snprintf(out, size, "%s", text), size);
}

static int hex_digits(unsigned bits)
{
    return (int)((bits + 3u) / 4u);
}

dr_status_t dr_text_format(dr_ref_t ref, const dr_value_t *v, unsigned flags,
                           char *out, size_t size)
{
    if (ref.field == NULL || v == NULL || out == NULL || size == 0)
        return DR_EINVAL;
    const dr_field_t *f = ref.field;
    int n;

    switch (dr_ref_type(ref)) {
    case DR_VAL_BOOL:
        n = snprintf(out, size, "%u", (unsigned)(v->u != 0));
        break;
    case DR_VAL_UINT:
        if (f->kind == DR_KIND_ENUM) {
            const char *name = dr_robot_state_name((unsigned)v->u);
            n = name != NULL
                    ? snprintf(out, size, "%s (%u)", name, (unsigned)v->u)
                    : snprintf(out, size, "UNKNOWN(%u)", (unsigned)v->u);
        } else if (f->kind == DR_KIND_BITS) {
            n = snprintf(out, size, "%" PRIu64 " (0x%0*" PRIx64 ")", v->u,
                         hex_digits(f->count), v->u);
        } else {
            n = snprintf(out, size, "%" PRIu64, v->u);
        }
        break;
    case DR_VAL_INT:
        n = snprintf(out, size, "%" PRId64, v->i);
        break;
    default: {
        dr_status_t st = dr_text_real((float)v->f, out, size);
        if (st != DR_OK)
            return st;
        n = (int)strlen(out);
        break;
    }
    }
    if (fit(n, size) != DR_OK)
        return DR_ENOSPACE;
    if ((flags & DR_TEXT_UNIT) && f->unit[0] != '\0') {
        size_t len = strlen(out);
        return fit(snprintf(out + len, size - len, " %s", f->unit), size - len);
    }
    return DR_OK;
}

/* %.9g of the double nearest the shortest text, with a '.' or an 'e' in
 * it, and the exponent without '+' or leading zeros: what jansson prints
 * for it with JSON_REAL_PRECISION(9) (drcli's CLI_JSON_FLAGS), so that
 * drcli and the gateway print the same tokens. */
static dr_status_t json_real(float f, char *out, size_t size)
{
    char text[32];
    dr_status_t st = dr_text_real(f, text, sizeof text);
    if (st != DR_OK)
        return st;
    if (!isfinite(f))
        return fit(snprintf(out, size, "\"%s\"", text), size);
    int n = snprintf(out, size, "%.9g", strtod(text, NULL));
    if (fit(n, size) != DR_OK)
        return DR_ENOSPACE;
    char *e = NULL;
    bool point = false;
    for (char *c = out; *c != '\0'; c++) { /* no strchr: firmware's libc need not have it */
        if (*c == 'e')
            e = c;
        else if (*c == '.')
            point = true;
    }
    if (e == NULL && !point)
        return fit(snprintf(out + n, size - (size_t)n, ".0"), size - (size_t)n);
    if (e != NULL) {
        char *d = e + 1, *from = e + 1;
        if (*from == '+')
            from++;
        else if (*from == '-')
            d++, from++;
        while (*from == '0' && from[1] != '\0')
            from++;
        memmove(d, from, strlen(from) + 1);
    }
    return DR_OK;
}

dr_status_t dr_text_json(const dr_value_t *v, char *out, size_t size)
{
    if (size == 0)
        return DR_ENOSPACE;
    switch (v->type) {
    case DR_VAL_BOOL: return fit(snprintf(out, size, "%s", v->u != 0 ? "true" : "false"), size);
    case DR_VAL_UINT: return fit(snprintf(out, size, "%" PRIu64, v->u), size);
    case DR_VAL_INT: return fit(snprintf(out, size, "%" PRId64, v->i), size);
    case DR_VAL_REAL: return json_real((float)v->f, out, size);
    }
    return DR_EINVAL;
}

/* Whole-string integer in decimal or 0x hex. */
static dr_status_t parse_int(const char *s, bool is_signed, dr_value_t *v)
{
    char *end;
    if (*s == '\0' || *s == ' ' || *s == '\t' || *s == '+')
        return DR_ESYNTAX;
    errno = 0;
    if (is_signed) {
        long long x = strtoll(s, &end, 0);
        if (*end != '\0')
            return DR_ESYNTAX;
        if (errno == ERANGE)
            return DR_ERANGE;
        *v = dr_value_int((int64_t)x);
    } else {
        if (*s == '-')
            return DR_ERANGE;
        unsigned long long x = strtoull(s, &end, 0);
        if (*end != '\0')
            return DR_ESYNTAX;
        if (errno == ERANGE)
            return DR_ERANGE;
        *v = dr_value_uint((uint64_t)x);
    }
    /* "08" would be read as octal by strtol's base 0: refuse that. */
    if (s[0] == '0' && s[1] >= '0' && s[1] <= '9')
        return DR_ESYNTAX;
    if (s[0] == '-' && s[1] == '0' && s[2] >= '0' && s[2] <= '9')
        return DR_ESYNTAX;
    return DR_OK;
}

static dr_status_t parse_real(const char *s, dr_value_t *v)
{
    char *end;
    if (*s == '\0' || *s == ' ' || *s == '\t')
        return DR_ESYNTAX;
    errno = 0;
    double f = strtod(s, &end);
    if (*end != '\0')
        return DR_ESYNTAX;
    *v = dr_value_real(f);
    return DR_OK;
}

dr_status_t dr_text_parse(dr_ref_t ref, const char *text, unsigned flags,
                          dr_value_t *out)
{
    if (ref.field == NULL || text == NULL || out == NULL)
        return DR_EINVAL;
    dr_value_t v;
    dr_status_t st;

    switch (dr_ref_type(ref)) {
    case DR_VAL_BOOL:
        if (strcmp(text, "true") == 0)
            v = dr_value_uint(1);
        else if (strcmp(text, "false") == 0)
            v = dr_value_uint(0);
        else if ((st = parse_int(text, false, &v)) != DR_OK)
            return st;
        v.type = DR_VAL_BOOL;
        break;
    case DR_VAL_UINT:
        st = DR_ESYNTAX;
        if (ref.field->kind == DR_KIND_ENUM) {
            for (unsigned i = 0; dr_robot_state_name(i) != NULL; i++) {
                if (strcmp(text, dr_robot_state_name(i)) == 0) {
                    v = dr_value_uint(i);
                    st = DR_OK;
                }
            }
        }
        if (st != DR_OK && (st = parse_int(text, false, &v)) != DR_OK)
            return st;
        break;
    case DR_VAL_INT:
        if ((st = parse_int(text, true, &v)) != DR_OK)
            return st;
        break;
    default:
        if ((st = parse_real(text, &v)) != DR_OK)
            return st;
        break;
    }
    st = dr_value_check(ref, &v, flags);
    if (st == DR_OK)
        *out = v;
    return st;
}
