/* SPDX-License-Identifier: MIT */
/* The Prometheus text format in a caller's buffer (prom.h). */
#include "core/prom.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

void gw_prom_init(gw_prom_t *m, char *buf, size_t cap)
{
    memset(m, 0, sizeof *m);
    m->buf = buf;
    m->cap = cap;
    buf[0] = '\0';
}

static void put(gw_prom_t *m, const char *s, size_t n)
{
    if (m->full || n > m->cap - 1 - m->len) {
        m->full = true;
        return;
    }
    memcpy(m->buf + m->len, s, n);
    m->len += n;
    m->buf[m->len] = '\0';
}

static void puts_(gw_prom_t *m, const char *s)
{
    put(m, s, strlen(s));
}

/* The exposition format's escapes: \\ and \n everywhere, \" in label
 * values (quote). */
static void escaped(gw_prom_t *m, const char *s, bool quote)
{
    for (; *s != '\0'; s++) {
        if (*s == '\\')
            put(m, "\\\\", 2);
        else if (*s == '\n')
            put(m, "\\n", 2);
        else if (*s == '"' && quote)
            put(m, "\\\"", 2);
        else
            put(m, s, 1);
    }
}

/* FNV-1a: the family names are short and few; a collision would only
 * leave out a HELP/TYPE pair, never write one twice. */
static uint32_t hash(const char *s)
{
    uint32_t h = 2166136261u;
    for (; *s != '\0'; s++)
        h = (h ^ (unsigned char)*s) * 16777619u;
    return h;
}

void gw_prom_family(gw_prom_t *m, const char *name, gw_prom_type_t type, const char *help)
{
    static const char *const types[] = {"counter", "gauge", "histogram"};
    uint32_t h = hash(name);
    for (unsigned i = 0; i < m->families; i++)
        if (m->family[i] == h)
            return;
    if (m->families < GW_PROM_FAMILIES)
        m->family[m->families++] = h;
    puts_(m, "# HELP ");
    puts_(m, name);
    put(m, " ", 1);
    escaped(m, help, false);
    puts_(m, "\n# TYPE ");
    puts_(m, name);
    put(m, " ", 1);
    puts_(m, types[type]);
    put(m, "\n", 1);
}

void gw_prom_sample(gw_prom_t *m, const char *name, const gw_prom_label_t *labels,
                    unsigned nlabels, double value)
{
    puts_(m, name);
    for (unsigned i = 0; i < nlabels; i++) {
        put(m, i == 0 ? "{" : ",", 1);
        puts_(m, labels[i].name);
        put(m, "=\"", 2);
        escaped(m, labels[i].value, true);
        put(m, "\"", 1);
    }
    if (nlabels > 0)
        put(m, "}", 1);
    char t[40];
    if (isnan(value))
        snprintf(t, sizeof t, " NaN\n");
    else if (isinf(value))
        snprintf(t, sizeof t, value > 0 ? " +Inf\n" : " -Inf\n");
    else if (value == floor(value) && fabs(value) < 9007199254740992.0)
        snprintf(t, sizeof t, " %.0f\n", value); /* counters: whole numbers as such */
    else
        snprintf(t, sizeof t, " %.9g\n", value);
    puts_(m, t);
}

void gw_prom_one(gw_prom_t *m, const char *name, gw_prom_type_t type, const char *help,
                 double value)
{
    gw_prom_family(m, name, type, help);
    gw_prom_sample(m, name, NULL, 0, value);
}
