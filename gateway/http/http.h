/* SPDX-License-Identifier: MIT */
/*
 * The console side's own calls beside its north.h ops (north_http.c):
 * for the daemon's command line.
 */
#ifndef GW_HTTP_HTTP_H
#define GW_HTTP_HTTP_H

#include <stdbool.h>
#include <stddef.h>

#include "core/config.h"

/* --check-config: do [http]'s tls_cert and tls_key load into the TLS
 * library (a certificate and its key)? True without TLS; false with
 * "FILE:LINE: ..." in err. Loads libmicrohttpd (only with TLS). */
bool gw_http_check_tls(const gw_config_t *cfg, char *err, size_t errlen);

/* `drgatewayd status`: the running daemon's summary from its console,
 * found through the configuration at `config`, on stdout. Returns 0 when
 * every robot is linked, 1 when one is not, GW_HTTP_STATUS_UNREACHABLE
 * when the daemon cannot be asked (why on stderr). */
#define GW_HTTP_STATUS_UNREACHABLE 3
int gw_http_status_command(const char *config, bool json);

#endif
