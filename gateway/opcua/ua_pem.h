/* SPDX-License-Identifier: MIT */
/*
 * The server's certificate and key files ([opcua] cert_file, key_file):
 * DER as it is, or PEM (the first "-----BEGIN ...-----" block) decoded to
 * DER, which is what OPC UA puts on the wire (the ServerCertificate of the
 * endpoints) and what open62541's mbedTLS policies parse.
 */
#ifndef DRGATE_GW_UA_PEM_H
#define DRGATE_GW_UA_PEM_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#define UA_PEM_FILE_MAX 65536u

/* The DER bytes of text[0..len) into der[cap] (PEM decoded, DER copied);
 * how many, 0 if it is neither (a PEM block that does not decode, or does
 * not fit). */
size_t ua_pem_to_der(const char *text, size_t len, uint8_t *der, size_t cap);

#ifdef GW_HAVE_OPCUA
#include <open62541/types.h>
/* The file at path as DER into *out (UA_ByteString_clear frees it):
 * false with "PATH: ..." in err. */
bool ua_pem_load(const char *path, UA_ByteString *out, char *err, size_t errlen);
#endif

#endif /* DRGATE_GW_UA_PEM_H */
