/* SPDX-License-Identifier: MIT */
/*
 * drgate enip: the EtherNet/IP and CIP numbers and records an application
 * hands to the client or gets back from it: the standard ports, the
 * objects and services of explicit messages (dr_client_call_sync and
 * _async take a service and a path built by dr_cip_path), the Identity
 * record and the largest encapsulated message.
 *
 * The wire code itself (encapsulation, CPF, Forward Open, Class 1 frames)
 * is private to the library and its test peers (lib/cip_internal.h).
 */
#ifndef DRGATE_ENIP_H
#define DRGATE_ENIP_H

#include <stddef.h>
#include <stdint.h>

#include "drgate/transport.h"

#ifdef __cplusplus
extern "C" {
#endif

#define DR_ENIP_TCP_PORT 44818u
#define DR_ENIP_UDP_PORT 2222u

/* Largest encapsulated message we build or accept (header included). */
#define DR_ENCAP_MAX_LEN 600u

/* Services of explicit messages (CIP Vol. 1, appendix A). */
enum {
    DR_CIP_SVC_GET_ATTRIBUTES_ALL = 0x01,
    DR_CIP_SVC_GET_ATTRIBUTE_SINGLE = 0x0E,
    DR_CIP_SVC_SET_ATTRIBUTE_SINGLE = 0x10
};

enum {
    DR_CIP_CLASS_IDENTITY = 0x01,
    DR_CIP_CLASS_MESSAGE_ROUTER = 0x02,
    DR_CIP_CLASS_ASSEMBLY = 0x04,
    DR_CIP_CLASS_CONNECTION_MANAGER = 0x06
};

/* Attributes of an assembly instance: its data and its size in bytes. */
#define DR_CIP_ASM_ATTR_DATA 3u
#define DR_CIP_ASM_ATTR_SIZE 4u

/* The path of class/instance[/attribute] as logical segments, 8 or 16-bit
 * as each value needs (attr < 0 leaves the attribute out), written to
 * buf: its length in bytes (at most 12), or 0 if cap is too small. */
size_t dr_cip_path(uint8_t *buf, size_t cap, uint16_t cls, uint16_t inst, int attr);

/* The Identity object (class 1): what dr_client_read_identity_sync,
 * dr_client_list_identity_sync and dr_discover report. */
typedef struct {
    uint16_t vendor, device_type, product_code;
    uint8_t rev_major, rev_minor;
    uint16_t status;
    uint32_t serial;
    char product_name[33]; /* SHORT_STRING, NUL-terminated here */
    uint8_t state;         /* ListIdentity only; 0xFF if unknown */
    dr_sockaddr_t sockaddr; /* ListIdentity only */
} dr_identity_t;

#ifdef __cplusplus
}
#endif
#endif /* DRGATE_ENIP_H */
