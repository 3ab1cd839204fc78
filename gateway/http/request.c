/* SPDX-License-Identifier: MIT */
/* Pure checks of a console request's parts: see request.h. */
#include "http/request.h"

#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/auth.h"

bool gw_http_host_ok(const char *host, unsigned port, const char *listen)
{
    static const char *const names[] = {"localhost", "127.0.0.1", "[::1]"};
    if (host == NULL)
        return true;
    const char *colon = host[0] == '[' ? strstr(host, "]:") : strchr(host, ':');
    if (colon != NULL && host[0] == '[')
        colon++;
    size_t n = colon != NULL ? (size_t)(colon - host) : strlen(host);
    if (colon != NULL) {
        const char *p = colon + 1;
        unsigned long v = 0;
        if (*p == '\0' || strlen(p) > 5)
            return false;
        for (; *p != '\0'; p++) {
            if (*p < '0' || *p > '9')
                return false;
            v = v * 10u + (unsigned long)(*p - '0');
        }
        if (v != port)
            return false;
    }
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
        if (strlen(names[i]) == n && strncasecmp(host, names[i], n) == 0)
            return true;
    return listen != NULL && listen[0] != '\0' && strlen(listen) == n &&
           strncmp(host, listen, n) == 0 && strcmp(listen, "0.0.0.0") != 0;
}

/* ---- Basic ------------------------------------------------------------------------- */

static int b64(char ch)
{
    if (ch >= 'A' && ch <= 'Z')
        return ch - 'A';
    if (ch >= 'a' && ch <= 'z')
        return ch - 'a' + 26;
    if (ch >= '0' && ch <= '9')
        return ch - '0' + 52;
    return ch == '+' ? 62 : ch == '/' ? 63 : -1;
}

bool gw_http_basic_parse(const char *authz, char *user, size_t ucap, char *pass, size_t pcap)
{
    char text[GW_AUTH_PASS_MAX + GW_USER_MAX + 8];
    size_t n = 0;
    if (authz == NULL || ucap == 0 || pcap == 0)
        return false;
    if (strncmp(authz, "Basic ", 6) != 0 && strncmp(authz, "basic ", 6) != 0)
        return false;
    const char *p = authz + 6;
    while (*p == ' ')
        p++;
    uint32_t acc = 0;
    unsigned bits = 0, pads = 0;
    for (; *p != '\0' && *p != ' '; p++) {
        if (*p == '=') {
            pads++;
            continue;
        }
        int v = b64(*p);
        if (v < 0 || pads > 0)
            return false;
        acc = (acc << 6 | (uint32_t)v) & 0xffffffu;
        bits += 6;
        if (bits >= 8) {
            bits -= 8;
            if (n >= sizeof text - 1)
                return false;
            text[n++] = (char)(acc >> bits & 0xffu);
        }
    }
    while (*p == ' ')
        p++;
    if (*p != '\0' || pads > 2)
        return false;
    text[n] = '\0';
    if (memchr(text, '\0', n) != NULL)
        return false; /* a NUL inside: no user or password has one */
    const char *colon = memchr(text, ':', n);
    if (colon == NULL)
        return false;
    size_t un = (size_t)(colon - text), pn = n - un - 1;
    if (un >= ucap || pn >= pcap)
        return false;
    memcpy(user, text, un);
    user[un] = '\0';
    memcpy(pass, colon + 1, pn);
    pass[pn] = '\0';
    memset(text, 0, sizeof text);
    return true;
}
