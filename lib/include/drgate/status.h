/* SPDX-License-Identifier: MIT */
/*
 * drgate status codes: one list for the whole library.
 *
 * Every function that can fail returns a dr_status_t: DR_OK (0) on success,
 * otherwise one of the codes below. Three bands share the 32-bit space:
 *   - plain library codes (small positive numbers, from DR_STATUS_LIST),
 *   - CIP errors: DR_CIP_BAND | general status << 16 | extended status,
 *   - encapsulation errors: DR_ENCAP_BAND | encapsulation status.
 * dr_strerror() turns any of them into a static, human-readable string.
 *
 * The plain codes keep their numbers (drgatewayd shows them in its status
 * registers); new ones are added at the end. Two timeouts are apart:
 * DR_ETIMEDOUT is the client's own (an EtherNet/IP request, a Class 1
 * connection, the session as a whole), DR_ENOANSWER is TCP's (a connect
 * that never completes, or the peer that stopped acknowledging), and
 * DR_ENOREGISTER a peer that took the TCP connection but never answered
 * RegisterSession. A Class 1 connection that times out before its first
 * T->O packet is DR_ENODATA: the adapter accepted it, and its data goes
 * elsewhere (a firewall, or another address than the originator's).
 */
#ifndef DRGATE_STATUS_H
#define DRGATE_STATUS_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef int32_t dr_status_t;

/* X(name, value, text): the enum and the strings come from this one list. */
#define DR_STATUS_LIST(X)                                                      \
    X(DR_OK, 0, "success")                                                     \
    X(DR_EINVAL, 1, "invalid argument")                                        \
    X(DR_ELENGTH, 2, "wrong data length for this assembly")                    \
    X(DR_ENOENT, 3, "unknown field or assembly name")                          \
    X(DR_EINDEX, 4, "index out of range")                                      \
    X(DR_ERANGE, 5, "value out of range for the field's type")                 \
    X(DR_ESYNTAX, 6, "malformed value or name")                                \
    X(DR_EREADONLY, 7, "field is produced by the robot (T->O), not writable")  \
    X(DR_ENONFINITE, 8, "non-finite REAL for a field the robot consumes")      \
    X(DR_ENOSPACE, 9, "output buffer too small")                               \
    X(DR_ESHORT, 10, "frame shorter than its header says")                     \
    X(DR_ELONG, 11, "frame longer than its header says")                       \
    X(DR_EMALFORMED, 12, "malformed frame")                                    \
    X(DR_EUNSUPPORTED, 13, "unsupported command or item")                      \
    X(DR_ETIMEDOUT, 14, "timed out")                                           \
    X(DR_ECONNREFUSED, 15, "connection refused")                               \
    X(DR_ECLOSED, 16, "connection closed by peer")                             \
    X(DR_EIO, 17, "network I/O error")                                         \
    X(DR_EAGAIN, 18, "operation would block")                                  \
    X(DR_ESTATE, 19, "operation not allowed in this state")                    \
    X(DR_ESESSION, 20, "no EtherNet/IP session")                               \
    X(DR_EMISMATCH, 21, "reply does not match the request")                    \
    X(DR_ENOTFOUND, 22, "host not found")                                      \
    X(DR_EFULL, 23, "no free slot")                                            \
    X(DR_EHOSTUNREACH, 24, "no route to host")                                 \
    X(DR_ENETUNREACH, 25, "network unreachable")                               \
    X(DR_ENOANSWER, 26, "no answer: TCP connection timed out")                 \
    X(DR_ENOREGISTER, 27, "connection accepted, but no reply to RegisterSession") \
    X(DR_EADDRINUSE, 28, "address already in use")                             \
    X(DR_EADDRNOTAVAIL, 29, "address not available on this host")              \
    X(DR_EACCES, 30, "not permitted (firewall rule, prohibit route or privileged port)") \
    X(DR_ENOMEM, 31, "out of memory")                                         \
    X(DR_ENODATA, 32, "the robot accepted the connection but sends no data")

enum {
#define DR_STATUS_ENUM(name, value, text) name = value,
    DR_STATUS_LIST(DR_STATUS_ENUM)
#undef DR_STATUS_ENUM
};

/* CIP band: general status in bits 16..23, extended status in bits 0..15. */
#define DR_CIP_BAND 0x01000000L
#define DR_CIP(general, extended)                                              \
    ((dr_status_t)(DR_CIP_BAND | ((int32_t)(general) << 16) |                 \
                   (int32_t)(extended)))
#define DR_IS_CIP(st) (((st) & 0x7F000000L) == DR_CIP_BAND)
#define DR_CIP_GENERAL(st) ((uint8_t)(((st) >> 16) & 0xFF))
#define DR_CIP_EXTENDED(st) ((uint16_t)((st) & 0xFFFF))

/* Encapsulation band: the 32-bit status of an encapsulation header. */
#define DR_ENCAP_BAND 0x02000000L
#define DR_ENCAP(status) ((dr_status_t)(DR_ENCAP_BAND | ((status) & 0xFFFF)))
#define DR_IS_ENCAP(st) (((st) & 0x7F000000L) == DR_ENCAP_BAND)

/* A static string for any status code; never NULL. For CIP codes it is the
 * most specific text known (extended status first, then general). */
const char *dr_strerror(dr_status_t status);

/* Text of a CIP general status alone, e.g. 0x05 "path destination unknown". */
const char *dr_cip_general_text(uint8_t general);

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_STATUS_H */
