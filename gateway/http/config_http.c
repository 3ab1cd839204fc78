/* SPDX-License-Identifier: MIT */
/*
 * The console's section (config_internal.h): [http], present = enabled
 * (docs/http.md). Besides the keys, the whole-file check reads the files
 * the section names (the certificate and key look like PEM, the password
 * file parses), and refuses a console reachable from other hosts without
 * both TLS and a password file unless `insecure = yes` says it is meant.
 * Whether the certificate and key load into the TLS library is checked
 * where the library is (north_http.c: gw_http_check_tls, at start, reload
 * and --check-config).
 */
#include "core/config_internal.h"

#include <arpa/inet.h>
#include <errno.h>
#include <grp.h>
#include <string.h>
#include <sys/stat.h>

#include "core/passwd.h"

#define H(m) GW_CFG_AT(gw_http_config_t, m)

static gw_cfg_parse_fn http_allow;

static const gw_cfg_key_t http_keys[] = {
    { .name = "listen", .type = GW_CFG_IPV4, H(listen), .def_text = "127.0.0.1", .allowed = "an IPv4 address such as 127.0.0.1", .help = "local address to serve the console on. Anything but a loopback address needs `tls_cert`, `tls_key` and `auth_file`, or `insecure = yes`" },
    { .name = "port", .type = GW_CFG_UINT, H(port), .lo = 1, .hi = 65535, .def = 8080, .help = "TCP port of the console (HTTP, or HTTPS with `tls_cert`)" },
    { .name = "allow", .type = GW_CFG_HOOK, .flags = GW_CFG_LIST, .parse = http_allow, .allowed = "a.b.c.d/len [ro|rw]", .doc_default = "(none: every address)", .doc_allowed = "`a.b.c.d/len [ro|rw]` as `[modbus] allow`, repeatable, at most 16", .help = "client networks allowed to connect; others are closed at once. The console only reads, so `ro` and `rw` are the same here" },
    { .name = "tls_cert", .type = GW_CFG_TEXT, H(tls_cert), .valid = gw_cfg_no_blank, .allowed = "a PEM certificate file", .doc_default = "(none: plain HTTP)", .help = "the server's certificate (PEM, the chain after it): turns HTTPS on; needs `tls_key`" },
    { .name = "tls_key", .type = GW_CFG_TEXT, H(tls_key), .valid = gw_cfg_no_blank, .allowed = "a PEM private key file", .help = "the certificate's private key (PEM, not encrypted)" },
    { .name = "auth_file", .type = GW_CFG_TEXT, H(auth_file), .valid = gw_cfg_no_blank, .allowed = "a file of user:HASH lines", .doc_default = "(none: no login)", .help = "HTTP Basic authentication for clients not on loopback: `user:HASH` lines, HASH from `openssl passwd -6` or `mkpasswd`. Read at start and reload" },
    { .name = "insecure", .type = GW_CFG_BOOL, H(insecure), .def = 0, .help = "serve a non-loopback `listen` without TLS or without `auth_file` all the same (a closed network, a reverse proxy in front)" },
    { .name = "status_port", .type = GW_CFG_UINT, H(status_port), .lo = 0, .hi = 65535, .def = 0, .allowed = "0..65535, 0 = none", .help = "with TLS: a plain HTTP listener on 127.0.0.1 at this port, for `drgatewayd status` and local tools; `0` = none" },
    { .name = "max_connections", .type = GW_CFG_UINT, H(max_connections), .lo = 1, .hi = 1024, .def = 32, .help = "connections served at once; more wait unanswered in the kernel's backlog until one closes" },
    { .name = "max_connections_per_ip", .type = GW_CFG_UINT, H(max_connections_per_ip), .lo = 0, .hi = 1024, .def = 8, .allowed = "0..1024, 0 = no limit of its own", .help = "connections one client address may hold at once; one more is closed at once, so that one client cannot take every connection of `max_connections` (a browser opens about six)" },
    { .name = "timeout_s", .type = GW_CFG_UINT, H(timeout_s), .lo = 1, .hi = 3600, .def = 10, .help = "a client must send each request (its URL and headers) within this many seconds of connecting or of the last answer, and a connection idle this long is closed. Live pages (`/api/v1/events`) are kept" },
    { .name = "tls_priorities", .type = GW_CFG_TEXT, H(tls_priorities), .valid = gw_cfg_no_blank, .allowed = "a GnuTLS priority string", .doc_default = "(built in: TLS 1.2 and 1.3, ECDHE, AEAD ciphers only)", .help = "the TLS versions, key exchanges and ciphers offered (gnutls_priority_init(3)); the default offers TLS 1.2 and 1.3 with ECDHE and AES-GCM or ChaCha20-Poly1305 only, and --check-config tries the string" },
    { .name = "max_streams", .type = GW_CFG_UINT, H(max_streams), .lo = 0, .hi = 1024, .def = 16, .allowed = "0..1024, 0 = none", .help = "live-value streams (`/api/v1/events`, one per open robot page) at once, and at most half of `max_connections`; one more gets 503 and the page asks for values every second instead. Keeps room for the rest of the console, `/metrics` and `drgatewayd status`" },
    { .name = "max_streams_per_ip", .type = GW_CFG_UINT, H(max_streams_per_ip), .lo = 1, .hi = 1024, .def = 4, .help = "live-value streams one client address may hold at once" },
    { .name = "stream_max_s", .type = GW_CFG_UINT, H(stream_max_s), .lo = 10, .hi = 86400, .def = 3600, .help = "a live-value stream ends after this many seconds (the page opens a new one at once), and one whose client took no byte for `timeout_s` x 3 (at least 30 s) is closed" },
    { .name = "max_request_bytes", .type = GW_CFG_UINT, H(max_request_bytes), .lo = 4096, .hi = 1048576, .def = 16384, .help = "room for a request's URL and headers; a longer one is refused (414 or 431)" },
};

/* The line of each allow entry: the side's scratch. */
typedef struct {
    unsigned allow_line[GW_MAX_ALLOW];
} http_lines_t;

static void http_begin(void *sec)
{
    ((gw_http_config_t *)sec)->enabled = true;
}

static void http_check(gw_cfg_ctx_t *c);

static const gw_cfg_side_t gw_cfg_http = {
    .kw = "http",
    .rank = 70,
    .base = offsetof(gw_config_t, side.http),
    .name_off = GW_CFG_NONE,
    .line_off = offsetof(gw_http_config_t, line),
    GW_CFG_KEYS(http_keys),
    .scratch = sizeof(http_lines_t),
    .begin = http_begin,
    .check = http_check,
};

static const gw_cfg_side_t *const http_sections[] = { &gw_cfg_http, NULL };

/* A console shows the log: the ring keeps it (core/log.h). */
static bool http_keeps_log(const gw_config_t *cfg)
{
    return cfg->side.http.enabled;
}

/* The side to the configuration (config.h; gateway/sides.h lists it). */
const gw_side_cfg_t gw_side_cfg_http = {
    .name = "http",
    .sections = http_sections,
    .keeps_log = http_keeps_log,
};

static void http_allow(gw_cfg_ctx_t *c, const gw_cfg_key_t *k, void *sec, const char *name,
                       const char *v)
{
    gw_http_config_t *h = sec;
    http_lines_t *hl = gw_cfg_scratch(c, &gw_cfg_http, 0);
    (void)k;
    (void)name;
    gw_cfg_allow(c, v, h->allow, &h->allow_count, hl->allow_line);
}

/* Does a PEM label ("RSA PRIVATE KEY") name what `key` needs? */
static bool pem_label_fits(const char *key, const char *label, size_t n)
{
    static const char pk[] = "PRIVATE KEY";
    if (strcmp(key, "tls_cert") == 0)
        return n == 11 && strncmp(label, "CERTIFICATE", n) == 0;
    return n >= sizeof pk - 1 && strncmp(label + n - (sizeof pk - 1), pk, sizeof pk - 1) == 0 &&
           strncmp(label, "ENCRYPTED", 9) != 0;
}

/* tls_cert / tls_key: readable, and a PEM block of the right kind in its
 * first 64 kB (a certificate; an unencrypted private key). */
static void check_pem(gw_cfg_ctx_t *c, const char *key, const char *path)
{
    static char text[65536];
    static const char begin[] = "-----BEGIN ";
    unsigned line = gw_cfg_line(c, &gw_cfg_http, 0, key);
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        gw_cfg_fail(c, line, "[http] %s %s: %s", key, path, strerror(errno));
        return;
    }
    size_t n = fread(text, 1, sizeof text - 1, f);
    (void)fclose(f);
    text[n] = '\0';
    for (const char *p = strstr(text, begin); p != NULL; p = strstr(p + 1, begin)) {
        const char *label = p + sizeof begin - 1, *end = strstr(label, "-----");
        if (end != NULL && pem_label_fits(key, label, (size_t)(end - label)))
            return;
    }
    gw_cfg_fail(c, line, "[http] %s %s: no %s in it (allowed: a PEM file with %s)", key, path,
                strcmp(key, "tls_cert") == 0 ? "certificate" : "unencrypted private key",
                strcmp(key, "tls_cert") == 0 ? "-----BEGIN CERTIFICATE-----"
                                             : "-----BEGIN PRIVATE KEY-----");
}

/* A secret (the TLS key, the password file) readable or writable by
 * others, or writable by the group, or readable by a group that is not
 * the service's own (`drgate`, the Debian package's: chmod 640 and chgrp
 * drgate, docs/http.md), is refused: whoever else reads the key can pose
 * as the console, and the hashes can be guessed offline. */
static void check_mode(gw_cfg_ctx_t *c, unsigned line, const char *key, const char *path)
{
    struct stat st;
    if (stat(path, &st) != 0)
        return; /* said where the file is read */
    struct group grp, *g = NULL;
    char buf[1024];
    if (getgrnam_r("drgate", &grp, buf, sizeof buf, &g) != 0)
        g = NULL;
    bool own_group = g != NULL && g->gr_gid == st.st_gid;
    if ((st.st_mode & (S_IRWXO | S_IWGRP | S_IXGRP)) != 0 ||
        ((st.st_mode & S_IRGRP) != 0 && !own_group))
        gw_cfg_fail(c, line,
                    "[http] %s %s is readable or writable by %s (mode %04o): only the daemon's "
                    "user may read it (allowed: chmod 600, or chmod 640 with group drgate; "
                    "docs/security.md)",
                    key, path, (st.st_mode & S_IRWXO) != 0 ? "other users" : "its group",
                    (unsigned)(st.st_mode & 07777));
}

static bool is_loopback(const char *addr)
{
    struct in_addr a;
    return inet_pton(AF_INET, addr, &a) == 1 && (ntohl(a.s_addr) >> 24) == 127u;
}

static void check_files(gw_cfg_ctx_t *c, gw_http_config_t *h)
{
    const gw_cfg_side_t *s = &gw_cfg_http;
    bool cert = h->tls_cert[0] != '\0', key = h->tls_key[0] != '\0';
    h->tls_line = gw_cfg_line(c, s, 0, cert ? "tls_cert" : "tls_key");
    h->auth_line = gw_cfg_line(c, s, 0, "auth_file");
    if (cert != key) {
        gw_cfg_fail(c, h->tls_line, "[http] tls_cert and tls_key go together (allowed: both "
                    "or neither)");
        return;
    }
    if (cert) {
        check_pem(c, "tls_cert", h->tls_cert);
        check_pem(c, "tls_key", h->tls_key);
        check_mode(c, gw_cfg_line(c, s, 0, "tls_key") ? gw_cfg_line(c, s, 0, "tls_key")
                                                       : h->tls_line,
                   "tls_key", h->tls_key);
    }
    if (h->auth_file[0] != '\0') {
        static gw_users_t users;
        char err[400];
        if (!gw_passwd_load(h->auth_file, &users, err, sizeof err))
            gw_cfg_fail(c, h->auth_line, "[http] auth_file %s", err);
        else
            check_mode(c, h->auth_line, "auth_file", h->auth_file);
    }
}

static void http_check(gw_cfg_ctx_t *c)
{
    gw_http_config_t *h = &c->cfg.side.http;
    const gw_cfg_side_t *s = &gw_cfg_http;
    if (!h->enabled)
        return;
    check_files(c, h);
    bool tls = h->tls_cert[0] != '\0', auth = h->auth_file[0] != '\0';
    if (!is_loopback(h->listen) && !(tls && auth) && !h->insecure) {
        unsigned line = gw_cfg_line(c, s, 0, "listen");
        const char *how = "to anyone", *add = "auth_file";
        if (!tls) {
            how = auth ? "in clear text (passwords too)" : "in clear text and to anyone";
            add = auth ? "tls_cert and tls_key" : "tls_cert, tls_key and auth_file";
        }
        gw_cfg_fail(c, line != 0 ? line : h->line,
                    "[http] listen %s serves the console to other hosts %s: add %s, or "
                    "insecure = yes to serve it so knowingly (docs/http.md)",
                    h->listen, how, add);
        return;
    }
    if (h->status_port != 0 && h->status_port == h->port)
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "status_port"),
                    "[http] status_port %u is the console's port (allowed: another port, or 0)",
                    (unsigned)h->status_port);
    else if (h->status_port != 0 && !tls)
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "status_port"),
                    "[http] status_port is for a TLS console (drgatewayd status reads the "
                    "plain port itself): add tls_cert and tls_key, or remove it");
    else if (c->cfg.side.modbus.port == h->port)
        gw_cfg_fail(c, gw_cfg_line(c, s, 0, "port") ? gw_cfg_line(c, s, 0, "port") : h->line,
                    "[http] port %u is the Modbus port (allowed: another port)",
                    (unsigned)h->port);
}
