/* SPDX-License-Identifier: MIT */
/*
 * The Prometheus text exposition format (0.0.4), written into a caller's
 * buffer for GET /metrics: no allocation, and a text that did not fit is
 * marked full (as core/json.h does) rather than cut, so that a scraper
 * never reads half a family.
 *
 * A family is declared once with gw_prom_family() (its # HELP and # TYPE
 * lines: written the first time the name is declared, never again), then
 * its samples follow with gw_prom_sample(). The format wants all samples
 * of a family together: a caller that writes one family from several
 * places (every robot's link_up) writes them in one loop. Label values
 * and HELP texts come from outside (robot names, serial devices, client
 * addresses) and are escaped: backslash, double quote (labels only) and
 * newline.
 */
#ifndef DRGATE_GW_PROM_H
#define DRGATE_GW_PROM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define GW_PROM_FAMILIES 128 /* distinct families in one text */

typedef enum { GW_PROM_COUNTER, GW_PROM_GAUGE, GW_PROM_HISTOGRAM } gw_prom_type_t;

typedef struct {
    const char *name, *value;
} gw_prom_label_t;

typedef struct {
    char *buf;
    size_t cap; /* bytes of buf, one of them for the final '\0' */
    size_t len;
    bool full;  /* something did not fit: the text is not to be used */
    /* the families declared so far (hashes of their names), for "once" */
    uint32_t family[GW_PROM_FAMILIES];
    unsigned families;
} gw_prom_t;

/* An empty text in buf[cap] (cap >= 1). */
void gw_prom_init(gw_prom_t *m, char *buf, size_t cap);
/* # HELP and # TYPE of family `name`, the first time it is declared
 * (a second declaration writes nothing). */
void gw_prom_family(gw_prom_t *m, const char *name, gw_prom_type_t type, const char *help);
/* One sample: name{l0="v0",l1="v1"} value (no braces without labels).
 * name is the family's, or with its suffix (_bucket, _sum, _count). */
void gw_prom_sample(gw_prom_t *m, const char *name, const gw_prom_label_t *labels,
                    unsigned nlabels, double value);
/* Shorthands: a family of one sample without labels. */
void gw_prom_one(gw_prom_t *m, const char *name, gw_prom_type_t type, const char *help,
                 double value);

#endif /* DRGATE_GW_PROM_H */
