/* SPDX-License-Identifier: MIT */
/*
 * A JSON text written into a caller's buffer, for what the daemon
 * publishes (MQTT payloads, the console's API): no allocation, and a text
 * that did not fit is marked full instead of cut, so that a caller never
 * sends half a document. Keys are canonical paths or fixed identifiers;
 * strings from outside (names, topics, payloads) go through
 * gw_json_quote(), which escapes them.
 */
#ifndef DRGATE_GW_JSON_H
#define DRGATE_GW_JSON_H

#include <stdbool.h>
#include <stddef.h>

#include "drgate/codec.h"

typedef struct {
    char *buf;
    size_t cap; /* bytes of buf, one of them for the final '\0' */
    size_t len;
    bool full;  /* something did not fit: the text is not to be used */
} gw_json_t;

/* An empty text in buf[cap] (cap >= 1). */
void gw_json_init(gw_json_t *j, char *buf, size_t cap);
/* n bytes as they are. */
void gw_json_raw(gw_json_t *j, const char *s, size_t n);
/* A C string as it is. */
void gw_json_str(gw_json_t *j, const char *s);
/* A JSON string of n arbitrary bytes: quotes and backslashes escaped,
 * control characters (and DEL) as \u00XX, valid UTF-8 as it is, and each
 * byte that starts no valid UTF-8 sequence (a stray continuation byte, an
 * overlong form, a surrogate, a cut sequence) as U+FFFD: the text is
 * always valid UTF-8 JSON. */
void gw_json_quote(gw_json_t *j, const char *s, size_t n);
/* A value as a JSON number: REALs shortest round-trip (dr_text_real),
 * non-finite ones null (JSON has no NaN). */
void gw_json_value(gw_json_t *j, const dr_value_t *v);

#endif /* DRGATE_GW_JSON_H */
