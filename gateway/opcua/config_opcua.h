/* SPDX-License-Identifier: MIT */
/*
 * The OPC UA side's configuration (config_opcua.c reads it): [opcua].
 */
#ifndef DRGATE_GW_OPCUA_CONFIG_H
#define DRGATE_GW_OPCUA_CONFIG_H

#include "core/config_types.h"

/* The security policies an endpoint may offer (bit per policy). */
enum {
    GW_OPCUA_POLICY_NONE = 1u << 0,           /* SecurityPolicy#None */
    GW_OPCUA_POLICY_BASIC256SHA256 = 1u << 1, /* Sign and SignAndEncrypt */
    GW_OPCUA_POLICY_AES128 = 1u << 2,         /* Aes128_Sha256_RsaOaep */
    GW_OPCUA_POLICY_AES256 = 1u << 3          /* Aes256_Sha256_RsaPss */
};
#define GW_OPCUA_POLICY_SECURE \
    (GW_OPCUA_POLICY_BASIC256SHA256 | GW_OPCUA_POLICY_AES128 | GW_OPCUA_POLICY_AES256)

/* [opcua]: present = enabled (docs/opcua.md). Strings "" = not set. */
typedef struct {
    bool enabled;               /* the section is present */
    char listen[64];            /* default "127.0.0.1" */
    uint16_t port;              /* default 4840 */
    char application_uri[128];  /* default "urn:drgate:<hostname>:drgatewayd" */
    char application_name[64];  /* default "drgatewayd" */
    unsigned policies;          /* GW_OPCUA_POLICY_* bits, default None */
    char auth_file[256];        /* user:crypt(3) hash lines ([http]'s format) */
    char cert_file[256];        /* the server's certificate (DER or PEM) */
    char key_file[256];         /* its private key */
    char trust_dir[256];        /* trusted client certificates ("": any) */
    unsigned max_sessions;      /* default 10 */
    unsigned max_subscriptions; /* per session, default 10 */
    unsigned max_monitored_items; /* of all sessions, default 10000 */
    bool insecure;              /* off loopback without security, knowingly */
    bool writes;                /* O->T nodes writable, default yes */
    unsigned line;              /* the section's line */
} gw_opcua_config_t;

/* The side's member of gw_config_t (gateway/sides.h). */
typedef gw_opcua_config_t gw_opcua_side_config_t;

/* The side's member of a robot's configuration: no keys of [robot NAME]. */
typedef struct {
    char none;
} gw_opcua_robot_config_t;

/* "None, Basic256Sha256" of policies into buf. */
const char *gw_opcua_policies_text(unsigned policies, char *buf, size_t size);

/* trust_dir's files: what each is by its name. */
typedef enum { GW_OPCUA_TRUST_SKIP, GW_OPCUA_TRUST_CERT, GW_OPCUA_TRUST_CRL,
               GW_OPCUA_TRUST_UNKNOWN } gw_opcua_trust_kind_t;
#define GW_OPCUA_TRUST_MAX 64 /* files in trust_dir */

/* A file of trust_dir by its name: "." files skipped; .der, .pem, .crt a
 * certificate; .crl a revocation list; anything else unknown (refused). */
gw_opcua_trust_kind_t gw_opcua_trust_kind(const char *name);

/* fn(ctx, path, name, kind) for each file of trust_dir dir that is not
 * skipped (unknown kinds included), until fn returns false. False (errno
 * set) if dir cannot be read. The configuration's check, the server's
 * trust list and its reload's digest all walk it so. */
bool gw_opcua_trust_each(const char *dir,
                         bool (*fn)(void *ctx, const char *path, const char *name,
                                    gw_opcua_trust_kind_t kind),
                         void *ctx);

#endif /* DRGATE_GW_OPCUA_CONFIG_H */
