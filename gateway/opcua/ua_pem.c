/* SPDX-License-Identifier: MIT */
/* Certificate and key files as DER: see ua_pem.h. */
#include "opcua/ua_pem.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* A base64 character's six bits; -1: not one; -2: padding. */
static int b64(unsigned char c)
{
    if (c >= 'A' && c <= 'Z')
        return c - 'A';
    if (c >= 'a' && c <= 'z')
        return c - 'a' + 26;
    if (c >= '0' && c <= '9')
        return c - '0' + 52;
    if (c == '+')
        return 62;
    if (c == '/')
        return 63;
    return c == '=' ? -2 : -1;
}

/* Where the line after "-----BEGIN ...-----" starts in text, NULL if none. */
static const char *pem_body(const char *text, size_t len, const char **end)
{
    static const char begin[] = "-----BEGIN ", stop[] = "-----END ";
    const char *p = NULL;
    for (size_t i = 0; i + sizeof begin - 1 <= len; i++)
        if (memcmp(text + i, begin, sizeof begin - 1) == 0) {
            p = text + i;
            break;
        }
    if (p == NULL)
        return NULL;
    const char *nl = memchr(p, '\n', len - (size_t)(p - text));
    if (nl == NULL)
        return NULL;
    nl++;
    for (const char *q = nl; q + sizeof stop - 1 <= text + len; q++)
        if (memcmp(q, stop, sizeof stop - 1) == 0) {
            *end = q;
            return nl;
        }
    return NULL;
}

size_t ua_pem_to_der(const char *text, size_t len, uint8_t *der, size_t cap)
{
    const char *end = NULL, *p = pem_body(text, len, &end);
    if (p == NULL) { /* DER: an ASN.1 SEQUENCE */
        if (len == 0 || (unsigned char)text[0] != 0x30 || len > cap)
            return 0;
        memcpy(der, text, len);
        return len;
    }
    uint32_t acc = 0;
    unsigned bits = 0;
    size_t n = 0;
    bool pad = false;
    for (; p < end; p++) {
        unsigned char c = (unsigned char)*p;
        if (c == '\n' || c == '\r' || c == ' ' || c == '\t')
            continue;
        int v = b64(c);
        if (v == -1 || (pad && v != -2))
            return 0;
        if (v == -2) {
            pad = true;
            continue;
        }
        acc = (acc << 6) | (uint32_t)v;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            if (n == cap)
                return 0;
            der[n++] = (uint8_t)(acc >> bits);
            acc &= (1u << bits) - 1u;
        }
    }
    return n;
}

#ifdef GW_HAVE_OPCUA
bool ua_pem_load(const char *path, UA_ByteString *out, char *err, size_t errlen)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return false;
    }
    char *text = malloc(UA_PEM_FILE_MAX);
    uint8_t *der = malloc(UA_PEM_FILE_MAX);
    size_t len = text != NULL ? fread(text, 1, UA_PEM_FILE_MAX, f) : 0;
    bool big = len == UA_PEM_FILE_MAX;
    (void)fclose(f);
    size_t n = der != NULL && !big ? ua_pem_to_der(text, len, der, UA_PEM_FILE_MAX) : 0;
    if (text != NULL)
        memset(text, 0, UA_PEM_FILE_MAX); /* a private key: not left in freed memory */
    free(text);
    if (n == 0 || UA_ByteString_allocBuffer(out, n) != UA_STATUSCODE_GOOD) {
        snprintf(err, errlen, "%s: %s", path,
                 big ? "larger than 64 KiB" : "neither DER nor PEM (or out of memory)");
        free(der);
        return false;
    }
    memcpy(out->data, der, n);
    memset(der, 0, n);
    free(der);
    return true;
}
#endif
