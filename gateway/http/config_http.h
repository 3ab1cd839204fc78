/* SPDX-License-Identifier: MIT */
/*
 * The console's configuration (config_http.c reads it): [http].
 */
#ifndef DRGATE_GW_HTTP_CONFIG_H
#define DRGATE_GW_HTTP_CONFIG_H

#include "core/config_types.h"

/* [http]: the console (docs/http.md); present = enabled. Strings "" = not
 * set. */
typedef struct {
    bool enabled;             /* the section is present */
    char listen[64];          /* default "127.0.0.1" */
    uint16_t port;            /* default 8080 */
    unsigned allow_count;     /* 0: every address */
    gw_allow_t allow[GW_MAX_ALLOW]; /* as [modbus] allow; ro/rw alike: the
                                       console only reads */
    char tls_cert[256];       /* PEM certificate, with tls_key: HTTPS */
    char tls_key[256];
    char auth_file[256];      /* user:crypt(3) hash lines: Basic auth for
                                 clients not on loopback */
    bool insecure;            /* plain, open console off loopback, knowingly */
    uint16_t status_port;     /* with TLS: a plain listener on 127.0.0.1 for
                                 drgatewayd status (0: none) */
    unsigned max_connections; /* default 32 */
    unsigned max_connections_per_ip; /* default 8, 0: no limit of its own */
    unsigned timeout_s;       /* idle or slow client closed, default 10 */
    unsigned max_request_bytes; /* URL and headers, default 16384 */
    char tls_priorities[256]; /* GnuTLS priority string, "" = the built-in
                                 TLS 1.2+ AEAD one (north_http.c) */
    unsigned max_streams;     /* live streams at once, default 16 */
    unsigned max_streams_per_ip; /* of one client address, default 4 */
    unsigned stream_max_s;    /* a live stream's age limit, default 3600 */
    unsigned tls_line, auth_line; /* where tls_cert and auth_file are */
    unsigned line;            /* the section's line */
} gw_http_config_t;

/* The side's member of gw_config_t (gateway/sides.h). */
typedef gw_http_config_t gw_http_side_config_t;

/* The side's member of a robot's configuration (gw_robot_config_t.side,
 * gateway/sides.h): it has no keys of [robot NAME] (C has no empty
 * struct). */
typedef struct {
    char none;
} gw_http_robot_config_t;

#endif /* DRGATE_GW_HTTP_CONFIG_H */
