/* SPDX-License-Identifier: MIT */
/*
 * drgate text: values as text and back, for tools and logs.
 *
 * Kept apart from the codec because it needs the C library's number
 * formatting (snprintf, strtod); firmware that only moves bytes can leave
 * text.c out and keep a codec without stdio.
 */
#ifndef DRGATE_TEXT_H
#define DRGATE_TEXT_H

#include <stddef.h>

#include "drgate/codec.h"

#ifdef __cplusplus
extern "C" {
#endif

/* Shortest decimal text that reads back to the same binary32 value, the
 * way people write numbers: plain notation for 1e-5 <= |f| < 1e16 ("100",
 * "31.5", "0.1", "0.00001", "123456790"), an exponent outside it ("1e-7",
 * "3.4028235e+38"), as JavaScript's Number.prototype.toString does with
 * its own bounds; "-0" for negative zero; "nan", "inf", "-inf" for
 * non-finite values. Returns DR_OK or DR_ENOSPACE. */
#define DR_TEXT_PLAIN_MIN_EXP (-5) /* decimal exponents printed plain */
#define DR_TEXT_PLAIN_MAX_EXP 15
dr_status_t dr_text_real(float f, char *out, size_t size);

/* A value as a JSON token, as `drcli get --json` prints it (and the
 * gateway's console API, docs/http.md): bits true/false, integers and
 * enums in decimal, REALs as the double nearest their dr_text_real text
 * printed with 9 significant digits and ".0" added to a whole number
 * ("0.1", "100.0", "1e-7", "3.40282347e38"), non-finite REALs as the
 * strings "nan", "inf", "-inf" (JSON has no such numbers). Returns DR_OK
 * or DR_ENOSPACE (32 bytes always do). */
dr_status_t dr_text_json(const dr_value_t *v, char *out, size_t size);

#define DR_TEXT_UNIT 0x1u /* append " unit" where the field has one */

/* A value of the field `ref` names, as people read it: bits "0"/"1",
 * masks "5 (0x0005)", enums "OPERATING (2)" or "UNKNOWN(13)", integers in
 * decimal, REALs shortest round-trip. Returns DR_OK, DR_ENOSPACE, DR_EINVAL. */
dr_status_t dr_text_format(dr_ref_t ref, const dr_value_t *v, unsigned flags,
                           char *out, size_t size);

/* Parse text for the field `ref` names and check it fits (dr_value_check
 * with `flags`): bits "0"/"1"/"true"/"false", integers in decimal or 0x
 * hex, enum names or numbers, REALs as decimal. Errors: DR_ESYNTAX,
 * DR_ERANGE, DR_ENONFINITE, DR_EREADONLY. `out` is written only on DR_OK. */
dr_status_t dr_text_parse(dr_ref_t ref, const char *text, unsigned flags,
                          dr_value_t *out);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_TEXT_H */
