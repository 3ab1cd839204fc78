/* SPDX-License-Identifier: MIT */
/* Status texts: library codes, CIP general/extended status (CIP Vol. 1,
 * Appendix B), encapsulation status (Vol. 2, 2-3.3). */
#include "drgate/status.h"

#include <stddef.h>

typedef struct {
    uint16_t code;
    const char *text;
} code_text_t;

static const code_text_t cip_general[] = {
    {0x00, "success"},
    {0x01, "connection failure"},
    {0x02, "resource unavailable"},
    {0x03, "invalid parameter value"},
    {0x04, "path segment error"},
    {0x05, "path destination unknown"},
    {0x06, "partial transfer"},
    {0x07, "connection lost"},
    {0x08, "service not supported"},
    {0x09, "invalid attribute value"},
    {0x0A, "attribute list error"},
    {0x0B, "already in requested mode/state"},
    {0x0C, "object state conflict"},
    {0x0D, "object already exists"},
    {0x0E, "attribute not settable"},
    {0x0F, "privilege violation"},
    {0x10, "device state conflict"},
    {0x11, "reply data too large"},
    {0x12, "fragmentation of a primitive value"},
    {0x13, "not enough data"},
    {0x14, "attribute not supported"},
    {0x15, "too much data"},
    {0x16, "object does not exist"},
    {0x17, "service fragmentation sequence not in progress"},
    {0x18, "no stored attribute data"},
    {0x19, "store operation failure"},
    {0x1A, "routing failure, request packet too large"},
    {0x1B, "routing failure, response packet too large"},
    {0x1C, "missing attribute list entry data"},
    {0x1D, "invalid attribute value list"},
    {0x1E, "embedded service error"},
    {0x1F, "vendor specific error"},
    {0x20, "invalid parameter"},
    {0x21, "write-once value or medium already written"},
    {0x22, "invalid reply received"},
    {0x25, "key failure in path"},
    {0x26, "path size invalid"},
    {0x27, "unexpected attribute in list"},
    {0x28, "invalid member ID"},
    {0x29, "member not settable"},
};

/* Extended status of general status 0x01 (connection manager). */
static const code_text_t cip_connection[] = {
    {0x0100, "connection in use or duplicate Forward Open"},
    {0x0103, "transport class and trigger combination not supported"},
    {0x0106, "ownership conflict"},
    {0x0107, "target connection not found"},
    {0x0108, "invalid network connection parameter"},
    {0x0109, "invalid connection size"},
    {0x0110, "target for connection not configured"},
    {0x0111, "RPI not supported"},
    {0x0112, "RPI value not acceptable"},
    {0x0113, "out of connections"},
    {0x0114, "vendor ID or product code mismatch"},
    {0x0115, "device type mismatch"},
    {0x0116, "revision mismatch"},
    {0x0117, "invalid produced or consumed application path"},
    {0x0118, "invalid or inconsistent configuration application path"},
    {0x0119, "non-listen only connection not opened"},
    {0x011A, "target object out of connections"},
    {0x011B, "RPI smaller than the production inhibit time"},
    {0x0123, "invalid O->T network connection type"},
    {0x0124, "invalid T->O network connection type"},
    {0x0127, "invalid O->T connection size (size mismatch)"},
    {0x0128, "invalid T->O connection size (size mismatch)"},
    {0x0129, "invalid configuration application path"},
    {0x012A, "invalid consuming application path"},
    {0x012B, "invalid producing application path"},
    {0x012F, "inconsistent application path combination"},
    {0x0203, "connection timed out"},
    {0x0204, "unconnected request timed out"},
    {0x0205, "parameter error in unconnected request"},
    {0x0206, "message too large for unconnected send"},
    {0x0301, "no buffer memory available"},
    {0x0302, "network bandwidth not available"},
    {0x0311, "invalid port"},
    {0x0312, "invalid link address"},
    {0x0315, "invalid segment in connection path"},
    {0x0316, "Forward Close connection path mismatch"},
};

static const code_text_t encap_status[] = {
    {0x0001, "encapsulation: invalid or unsupported command"},
    {0x0002, "encapsulation: insufficient memory"},
    {0x0003, "encapsulation: incorrect data"},
    {0x0064, "encapsulation: invalid session handle"},
    {0x0065, "encapsulation: invalid length"},
    {0x0069, "encapsulation: unsupported protocol version"},
};

static const char *find(const code_text_t *t, size_t n, uint16_t code)
{
    for (size_t i = 0; i < n; i++)
        if (t[i].code == code)
            return t[i].text;
    return NULL;
}

#define FIND(table, code) find(table, sizeof table / sizeof table[0], code)

const char *dr_cip_general_text(uint8_t general)
{
    const char *s = FIND(cip_general, general);
    return s != NULL ? s : "unknown CIP general status";
}

const char *dr_strerror(dr_status_t status)
{
    if (DR_IS_CIP(status)) {
        uint8_t general = DR_CIP_GENERAL(status);
        if (general == 0x01) {
            const char *s = FIND(cip_connection, DR_CIP_EXTENDED(status));
            if (s != NULL)
                return s;
        }
        return dr_cip_general_text(general);
    }
    if (DR_IS_ENCAP(status)) {
        const char *s = FIND(encap_status, (uint16_t)(status & 0xFFFF));
        return s != NULL ? s : "encapsulation: unknown error status";
    }
    switch (status) {
#define DR_STATUS_CASE(name, value, text) case value: return text;
        DR_STATUS_LIST(DR_STATUS_CASE)
#undef DR_STATUS_CASE
    default:
        return "unknown status";
    }
}
