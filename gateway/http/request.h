/* SPDX-License-Identifier: MIT */
/*
 * Pure checks of a console request's parts, apart from libmicrohttpd so
 * that the unit tests and fuzz_http reach them.
 */
#ifndef GW_HTTP_REQUEST_H
#define GW_HTTP_REQUEST_H

#include <stdbool.h>
#include <stddef.h>

/* The Host header of a request served without a login (from loopback):
 * DNS rebinding makes a browser send a name of the attacker's with it, so
 * only "localhost", "127.0.0.1", "[::1]" and the configured listen address
 * are taken, each alone or with ":port" equal to the listener's. NULL (an
 * HTTP/1.0 request without one) is taken: browsers always send it. */
bool gw_http_host_ok(const char *host, unsigned port, const char *listen);

/* "Basic BASE64(user:pass)" into user and pass ('\0'-terminated); false
 * if it is not one or does not fit (no allocation; fuzz_http). */
bool gw_http_basic_parse(const char *authz, char *user, size_t ucap, char *pass, size_t pcap);

#endif
