/* SPDX-License-Identifier: MIT */
/* Pure checks of a console request's parts: see request.h. */
#include "http/request.h"

#include <stdlib.h>
#include <string.h>
#include <strings.h>

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
