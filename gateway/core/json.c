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

void gw_json_quote(gw_json_t *j, const char *s, size_t n)
{
    gw_json_raw(j, "\"", 1);
    for (size_t i = 0; i < n; i++) {
        unsigned char ch = (unsigned char)s[i];
        char esc[8];
        if (ch == '"' || ch == '\\') {
            esc[0] = '\\', esc[1] = (char)ch;
            gw_json_raw(j, esc, 2);
        } else if (ch < 0x20 || ch > 0x7e) {
            snprintf(esc, sizeof esc, "\\u%04x", ch);
            gw_json_raw(j, esc, 6);
        } else {
            gw_json_raw(j, (const char *)&s[i], 1);
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
