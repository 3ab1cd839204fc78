/* SPDX-License-Identifier: MIT */
/* A JSON text in a caller's buffer (json.h). */
#include "core/json.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "drgate/text.h"

void gw_json_init(gw_json_t *j, char *buf, size_t cap)
{
    j->buf = buf;
    j->cap = cap;
    j->len = 0;
    j->full = false;
    buf[0] = '\0';
}

void gw_json_raw(gw_json_t *j, const char *s, size_t n)
{
    if (j->full || n > j->cap - 1 - j->len) {
        j->full = true;
        return;
    }
    memcpy(j->buf + j->len, s, n);
    j->len += n;
    j->buf[j->len] = '\0';
}

void gw_json_str(gw_json_t *j, const char *s)
{
    gw_json_raw(j, s, strlen(s));
}

/* The length of the valid UTF-8 sequence at s[0..n) (2..4), 0 if none:
 * no overlong form, no surrogate, nothing above U+10FFFF (RFC 3629). */
static size_t utf8_len(const unsigned char *s, size_t n)
{
    unsigned char c = s[0];
    size_t len;
    unsigned char lo = 0x80, hi = 0xbf; /* the second byte's range */
    if (c >= 0xc2 && c <= 0xdf)
        len = 2;
    else if (c >= 0xe0 && c <= 0xef) {
        len = 3;
        lo = c == 0xe0 ? 0xa0 : 0x80;
        hi = c == 0xed ? 0x9f : 0xbf;
    } else if (c >= 0xf0 && c <= 0xf4) {
        len = 4;
        lo = c == 0xf0 ? 0x90 : 0x80;
        hi = c == 0xf4 ? 0x8f : 0xbf;
    } else
        return 0;
    if (n < len || s[1] < lo || s[1] > hi)
        return 0;
    for (size_t i = 2; i < len; i++)
        if (s[i] < 0x80 || s[i] > 0xbf)
            return 0;
    return len;
}

void gw_json_quote(gw_json_t *j, const char *s, size_t n)
{
    const unsigned char *u = (const unsigned char *)s;
    gw_json_raw(j, "\"", 1);
    for (size_t i = 0; i < n;) {
        unsigned char ch = u[i];
        char esc[8];
        if (ch == '"' || ch == '\\') {
            esc[0] = '\\', esc[1] = (char)ch;
            gw_json_raw(j, esc, 2);
            i++;
        } else if (ch < 0x20 || ch == 0x7f) {
            snprintf(esc, sizeof esc, "\\u%04x", ch);
            gw_json_raw(j, esc, 6);
            i++;
        } else if (ch < 0x80) {
            gw_json_raw(j, s + i, 1);
            i++;
        } else {
            /* valid UTF-8 as it is; a byte that starts no valid sequence
             * becomes U+FFFD (one per byte) */
            size_t len = utf8_len(u + i, n - i);
            if (len > 0)
                gw_json_raw(j, s + i, len);
            else
                gw_json_raw(j, "\xef\xbf\xbd", 3);
            i += len > 0 ? len : 1;
        }
    }
    gw_json_raw(j, "\"", 1);
}

void gw_json_value(gw_json_t *j, const dr_value_t *v)
{
    char t[48];
    switch (v->type) {
    case DR_VAL_REAL:
        if (!isfinite(v->f) || dr_text_real((float)v->f, t, sizeof t) != DR_OK)
            snprintf(t, sizeof t, "null");
        break;
    case DR_VAL_INT: snprintf(t, sizeof t, "%lld", (long long)v->i); break;
    case DR_VAL_BOOL:
    case DR_VAL_UINT:
    default: snprintf(t, sizeof t, "%llu", (unsigned long long)v->u); break;
    }
    gw_json_str(j, t);
}
