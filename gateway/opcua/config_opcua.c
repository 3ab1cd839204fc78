/* SPDX-License-Identifier: MIT */
/*
 * The OPC UA side's section (config_internal.h): [opcua], present =
 * enabled (docs/opcua.md). Read in every build, so that a daemon built
 * without open62541 (Debian 12: no libopen62541 package) names the line of
 * an [opcua] section it cannot serve, at --check-config as at start.
 */
#include "core/config_internal.h"

#include <arpa/inet.h>
#include <dirent.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include "core/passwd.h"
#include "opcua/ua_pem.h"

#define U(m) GW_CFG_AT(gw_opcua_config_t, m)

static gw_cfg_parse_fn opcua_policies;

/* The policies' names as OPC UA spells them (the part after '#' of the
 * policy URI), in bit order. */
static const char *const policy_names[] = { "None", "Basic256Sha256", "Aes128_Sha256_RsaOaep",
                                            "Aes256_Sha256_RsaPss" };
#define POLICY_COUNT (sizeof policy_names / sizeof policy_names[0])

static const gw_cfg_key_t opcua_keys[] = {
    { .name = "listen", .type = GW_CFG_IPV4, U(listen), .def_text = "127.0.0.1", .allowed = "an IPv4 address such as 127.0.0.1", .help = "local address of the server's endpoint. Anything but a loopback address needs a secure policy only (no `None`) and `auth_file`, or `insecure = yes`" },
    { .name = "port", .type = GW_CFG_UINT, U(port), .lo = 1, .hi = 65535, .def = 4840, .help = "TCP port of `opc.tcp://listen:port`" },
    { .name = "application_uri", .type = GW_CFG_TEXT, U(application_uri), .valid = gw_cfg_no_blank, .allowed = "a URI without blanks", .doc_default = "`urn:drgate:<hostname>:drgatewayd`", .help = "the server's ApplicationUri; with a certificate it must equal the certificate's subjectAltName URI" },
    { .name = "application_name", .type = GW_CFG_TEXT, U(application_name), .def_text = "drgatewayd", .allowed = "a name", .help = "the server's ApplicationName, as clients list it" },
    { .name = "security_policies", .type = GW_CFG_HOOK, .parse = opcua_policies, .allowed = "a list of None, Basic256Sha256, Aes128_Sha256_RsaOaep, Aes256_Sha256_RsaPss", .doc_default = "`None`", .doc_allowed = "comma-separated: `None`, `Basic256Sha256`, `Aes128_Sha256_RsaOaep`, `Aes256_Sha256_RsaPss`", .help = "the endpoints offered: each secure policy with Sign and SignAndEncrypt; the secure ones need `cert_file` and `key_file`" },
    { .name = "auth_file", .type = GW_CFG_TEXT, U(auth_file), .valid = gw_cfg_no_blank, .allowed = "a file of user:HASH lines", .doc_default = "(none: anonymous sessions)", .help = "user names and passwords: the console's format (`user:HASH` lines, HASH from `openssl passwd -6`); set, anonymous sessions are refused. Read at start and reload" },
    { .name = "cert_file", .type = GW_CFG_TEXT, U(cert_file), .valid = gw_cfg_no_blank, .allowed = "an X.509 certificate file (DER or PEM)", .help = "the server's application instance certificate, with `key_file`" },
    { .name = "key_file", .type = GW_CFG_TEXT, U(key_file), .valid = gw_cfg_no_blank, .allowed = "a private key file (DER or PEM)", .help = "the certificate's RSA private key" },
    { .name = "trust_dir", .type = GW_CFG_TEXT, U(trust_dir), .valid = gw_cfg_no_blank, .allowed = "a directory of certificates", .doc_default = "(none: any client certificate)", .help = "the client application certificates to trust, one per file (`.der`, `.pem` or `.crt`; a CA's certificate trusts those it signed, with its revocation list as a `.crl` file); set, a secure channel with any other certificate is refused. Needs a secure `security_policies`. Read at start and at every reload (a change of its files restarts the server)" },
    { .name = "max_sessions", .type = GW_CFG_UINT, U(max_sessions), .lo = 1, .hi = 100, .def = 10, .help = "sessions logged in at once; one more login is refused" },
    { .name = "max_subscriptions", .type = GW_CFG_UINT, U(max_subscriptions), .lo = 1, .hi = 100, .def = 10, .help = "subscriptions per session" },
    { .name = "max_monitored_items", .type = GW_CFG_UINT, U(max_monitored_items), .lo = 1, .hi = 100000, .def = 10000, .help = "monitored items of all sessions together; one more is refused. Each is sampled in the daemon's loop at its interval (measured: 20000 at 10 ms took a third of a core)" },
    { .name = "writes", .type = GW_CFG_BOOL, U(writes), .def = 0, .help = "the O->T nodes are writable (through the one write path: single-writer mode, the write fault, GPIO inputs' bits apply); no: every write is refused with BadUserAccessDenied" },
    { .name = "insecure", .type = GW_CFG_BOOL, U(insecure), .def = 0, .help = "serve a non-loopback `listen` with `None` or without `auth_file` all the same (a closed network)" },
};

static void opcua_begin(void *sec)
{
    gw_opcua_config_t *u = sec;
    u->enabled = true;
    u->policies = GW_OPCUA_POLICY_NONE;
}

static void opcua_defaults(void *sec)
{
    ((gw_opcua_config_t *)sec)->policies = GW_OPCUA_POLICY_NONE;
}

static void opcua_check(gw_cfg_ctx_t *c);

static const gw_cfg_side_t gw_cfg_opcua = {
    .kw = "opcua",
    .rank = 80,
    .base = offsetof(gw_config_t, side.opcua),
    .name_off = GW_CFG_NONE,
    .line_off = offsetof(gw_opcua_config_t, line),
    GW_CFG_KEYS(opcua_keys),
    .defaults = opcua_defaults,
    .begin = opcua_begin,
    .check = opcua_check,
};

static const gw_cfg_side_t *const opcua_sections[] = { &gw_cfg_opcua, NULL };

static void opcua_brief(const gw_config_t *cfg, char *buf, size_t size)
{
    const gw_opcua_config_t *u = &cfg->side.opcua;
    size_t n = strlen(buf);
    if (u->enabled && n < size)
        snprintf(buf + n, size - n, ", OPC UA on %s:%u", u->listen, (unsigned)u->port);
}

/* The side to the configuration (config.h; gateway/sides.h lists it). */
const gw_side_cfg_t gw_side_cfg_opcua = {
    .name = "opcua",
    .sections = opcua_sections,
    .brief = opcua_brief,
};

const char *gw_opcua_policies_text(unsigned policies, char *buf, size_t size)
{
    const char *names[POLICY_COUNT];
    size_t n = 0;
    for (unsigned i = 0; i < POLICY_COUNT; i++)
        if (policies & (1u << i))
            names[n++] = policy_names[i];
    gw_cfg_join(names, n, buf, size);
    return buf;
}

/* "None, Basic256Sha256": names separated by commas (blanks around them
 * allowed), each once. */
static void opcua_policies(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec, const char *name,
                           const char *v)
{
    unsigned bits = 0;
    const char *p = v;
    (void)k;
    while (*p != '\0') {
        while (gw_cfg_is_space(*p) || *p == ',')
            p++;
        size_t len = 0;
        while (p[len] != '\0' && p[len] != ',' && !gw_cfg_is_space(p[len]))
            len++;
        if (len == 0)
            break;
        unsigned i = 0;
        while (i < POLICY_COUNT &&
               (strlen(policy_names[i]) != len || strncmp(policy_names[i], p, len) != 0))
            i++;
        if (i == POLICY_COUNT || (bits & (1u << i))) {
            gw_cfg_fail(c, c->lineno,
                        "%s '%s' invalid: '%.*s' %s (allowed: a list of None, Basic256Sha256, "
                        "Aes128_Sha256_RsaOaep, Aes256_Sha256_RsaPss)",
                        name, v, (int)(len > 64 ? 64 : len), p,
                        i == POLICY_COUNT ? "is no policy" : "is named twice");
            return;
        }
        bits |= 1u << i;
        p += len;
    }
    if (bits == 0) {
        gw_cfg_fail(c, c->lineno, "%s is empty (allowed: a list of None, Basic256Sha256, "
                    "Aes128_Sha256_RsaOaep, Aes256_Sha256_RsaPss)", name);
        return;
    }
    ((gw_opcua_config_t *)sec)->policies = bits;
}

static bool is_loopback(const char *addr)
{
    struct in_addr a;
    return inet_pton(AF_INET, addr, &a) == 1 && (ntohl(a.s_addr) >> 24) == 127u;
}

/* The line of key (the section's when it is not set). */
static unsigned key_line(gw_cfg_ctx_t *c, const char *key)
{
    unsigned l = gw_cfg_line(c, &gw_cfg_opcua, 0, key);
    return l != 0 ? l : c->cfg.side.opcua.line;
}

/* Who may reach the endpoint, and how: a non-loopback endpoint with
 * SecurityPolicy None (passwords and robot data in clear, to anyone on
 * the path) or without user authentication (anyone may write) is refused
 * unless insecure = yes. */
static bool check_exposure(gw_cfg_ctx_t *c, const gw_opcua_config_t *u)
{
    if (is_loopback(u->listen) || u->insecure)
        return true;
    if (u->policies & GW_OPCUA_POLICY_NONE)
        gw_cfg_fail(c, key_line(c, "listen"),
                    "[opcua] listen %s with security_policies None serves the robots in clear "
                    "text to other hosts: offer only secure policies (Basic256Sha256, ...), or "
                    "insecure = yes to serve them so knowingly (docs/opcua.md)", u->listen);
    else if (u->auth_file[0] == '\0')
        gw_cfg_fail(c, key_line(c, "listen"),
                    "[opcua] listen %s without auth_file lets anyone on the network in: add "
                    "auth_file, or insecure = yes to serve it so knowingly (docs/opcua.md)",
                    u->listen);
    else
        return true;
    return false;
}

gw_opcua_trust_kind_t gw_opcua_trust_kind(const char *name)
{
    const char *dot = strrchr(name, '.');
    if (name[0] == '.')
        return GW_OPCUA_TRUST_SKIP;
    if (dot != NULL && (strcasecmp(dot, ".der") == 0 || strcasecmp(dot, ".pem") == 0 ||
                        strcasecmp(dot, ".crt") == 0))
        return GW_OPCUA_TRUST_CERT;
    if (dot != NULL && strcasecmp(dot, ".crl") == 0)
        return GW_OPCUA_TRUST_CRL;
    return GW_OPCUA_TRUST_UNKNOWN;
}

bool gw_opcua_trust_each(const char *dir,
                         bool (*fn)(void *ctx, const char *path, const char *name,
                                    gw_opcua_trust_kind_t kind),
                         void *ctx)
{
    DIR *d = opendir(dir);
    if (d == NULL)
        return false;
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        gw_opcua_trust_kind_t k = gw_opcua_trust_kind(e->d_name);
        char path[512];
        if (k == GW_OPCUA_TRUST_SKIP)
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (!fn(ctx, path, e->d_name, k))
            break;
    }
    (void)closedir(d);
    return true;
}

typedef struct {
    gw_cfg_ctx_t *c;
    const char *dir;
    unsigned line, files, certs;
    bool ok;
} trust_check_t;

/* One file of trust_dir: a known kind, within the count, readable, DER or
 * PEM. */
static bool check_trust_file(void *ctx, const char *path, const char *name,
                             gw_opcua_trust_kind_t k)
{
    static char text[UA_PEM_FILE_MAX];
    static uint8_t der[UA_PEM_FILE_MAX];
    trust_check_t *tc = ctx;
    (void)name;
    tc->ok = false;
    if (k == GW_OPCUA_TRUST_UNKNOWN) {
        gw_cfg_fail(tc->c, tc->line, "[opcua] trust_dir %s: not a certificate (.der, .pem, "
                    ".crt) or revocation list (.crl)", path);
        return false;
    }
    if (++tc->files > GW_OPCUA_TRUST_MAX) {
        gw_cfg_fail(tc->c, tc->line, "[opcua] trust_dir %s: over %u files", tc->dir,
                    GW_OPCUA_TRUST_MAX);
        return false;
    }
    tc->certs += k == GW_OPCUA_TRUST_CERT;
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        gw_cfg_fail(tc->c, tc->line, "[opcua] trust_dir %s: %s", path, strerror(errno));
        return false;
    }
    size_t n = fread(text, 1, sizeof text, f);
    bool big = n == sizeof text;
    (void)fclose(f);
    if (big || ua_pem_to_der(text, n, der, sizeof der) == 0) {
        gw_cfg_fail(tc->c, tc->line,
                    "[opcua] trust_dir %s: not a certificate or revocation list in DER or PEM%s",
                    path, big ? " (over 64 KiB)" : "");
        return false;
    }
    tc->ok = true;
    return true;
}

/* trust_dir: a directory of certificates (at least one) and revocation
 * lists, nothing else, with a secure policy to use them. */
static bool check_trust_dir(gw_cfg_ctx_t *c, const gw_opcua_config_t *u)
{
    trust_check_t tc = {c, u->trust_dir, key_line(c, "trust_dir"), 0, 0, true};
    if (!(u->policies & GW_OPCUA_POLICY_SECURE)) {
        gw_cfg_fail(c, tc.line, "[opcua] trust_dir needs a secure security_policies (client "
                    "certificates come only with Basic256Sha256, ...)");
        return false;
    }
    if (!gw_opcua_trust_each(u->trust_dir, check_trust_file, &tc)) {
        gw_cfg_fail(c, tc.line, "[opcua] trust_dir %s: %s", u->trust_dir, strerror(errno));
        return false;
    }
    if (tc.ok && tc.certs == 0) {
        gw_cfg_fail(c, tc.line, "[opcua] trust_dir %s holds no certificate: no client could "
                    "connect", u->trust_dir);
        tc.ok = false;
    }
    return tc.ok;
}

/* Is the side in this build (make: pkg-config found open62541)? */
static bool built_with_opcua(void)
{
#ifdef GW_HAVE_OPCUA
    return true;
#else
    return false;
#endif
}

static void opcua_check(gw_cfg_ctx_t *c)
{
    const gw_opcua_config_t *u = &c->cfg.side.opcua;
    if (!u->enabled)
        return;
    /* cppcheck-suppress knownConditionTrueFalse ; a constant of the build */
    if (!built_with_opcua()) {
        gw_cfg_fail(c, u->line,
                    "[opcua]: this drgatewayd was built without OPC UA (open62541 1.4 was not "
                    "found at build time: Debian 13's libopen62541-1.4-dev; Debian 12 has none, "
                    "docs/deployment.md)");
        return;
    }
    bool cert = u->cert_file[0] != '\0', key = u->key_file[0] != '\0';
    if (cert != key) {
        gw_cfg_fail(c, key_line(c, cert ? "cert_file" : "key_file"),
                    "[opcua] cert_file and key_file go together (allowed: both or neither)");
        return;
    }
    if ((u->policies & GW_OPCUA_POLICY_SECURE) && !cert) {
        char names[128];
        gw_cfg_fail(c, key_line(c, "security_policies"),
                    "[opcua] security_policies %s needs cert_file and key_file (the server's "
                    "certificate)", gw_opcua_policies_text(u->policies, names, sizeof names));
        return;
    }
    if (!check_exposure(c, u))
        return;
    if (u->auth_file[0] != '\0') {
        static gw_users_t users;
        char err[400];
        if (!gw_passwd_load(u->auth_file, &users, err, sizeof err)) {
            gw_cfg_fail(c, key_line(c, "auth_file"), "[opcua] auth_file %s", err);
            return;
        }
    }
    if (u->trust_dir[0] != '\0' && !check_trust_dir(c, u))
        return;
    if (c->cfg.side.modbus.port == u->port)
        gw_cfg_fail(c, key_line(c, "port"), "[opcua] port %u is the Modbus port (allowed: "
                    "another port)", (unsigned)u->port);
}
