/* SPDX-License-Identifier: MIT */
/* The console's password file (passwd.h). */
#include "core/passwd.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The characters of a crypt(3) hash in the modular format: "$id$", then
 * salt, parameters and digest in crypt's base64 ("./0-9A-Za-z"), with '$'
 * between them, ',' and '=' in parameters ($7$, $gy$, rounds=N). */
static bool hash_char(char ch)
{
    return (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') ||
           ch == '.' || ch == '/' || ch == '$' || ch == '=' || ch == ',';
}

/* "$id$rest" with id letters and digits: what crypt_r can check. A plain
 * password, or an old DES hash (13 characters, no '$'), is refused: the
 * one is readable by whoever reads the file, the other is broken. */
static bool valid_hash(const char *h, size_t n, char *why, size_t whylen)
{
    size_t id = 0;
    if (n == 0) {
        snprintf(why, whylen, "no hash after ':'");
        return false;
    }
    if (h[0] == '$')
        for (id = 1; id < n && ((h[id] >= 'a' && h[id] <= 'z') || (h[id] >= '0' && h[id] <= '9'));)
            id++;
    if (h[0] != '$' || id < 2 || id >= n || h[id] != '$' || n < id + 8) {
        snprintf(why, whylen,
                 "not a crypt(3) hash such as $6$... (make one with `openssl passwd -6` or "
                 "`mkpasswd`; plain passwords are refused)");
        return false;
    }
    for (size_t i = 0; i < n; i++)
        if (!hash_char(h[i])) {
            snprintf(why, whylen, "invalid character in the hash (at column %zu)", i + 1);
            return false;
        }
    if (n >= GW_HASH_MAX) {
        snprintf(why, whylen, "hash too long (at most %d characters)", GW_HASH_MAX - 1);
        return false;
    }
    return true;
}

/* crypt's base64 digit of ch, or -1. */
static int b64_digit(char ch)
{
    static const char d[] = "./0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz";
    const char *p = ch != '\0' ? strchr(d, ch) : NULL;
    return p != NULL ? (int)(p - d) : -1;
}

/* One of yescrypt's variable-length numbers (its decode64_uint32) at *p,
 * plus min; false if it is not one. */
static bool yescrypt_num(const char **p, uint32_t min, uint32_t *out)
{
    uint32_t start = 0, end = 47, chars = 1, bits = 0;
    int c = b64_digit(**p);
    if (c < 0)
        return false;
    (*p)++;
    *out = min;
    while ((uint32_t)c > end) {
        *out += (end + 1 - start) << bits;
        start = end + 1;
        end = start + (62 - end) / 2;
        chars++;
        bits += 6;
    }
    *out += ((uint32_t)c - start) << bits;
    while (--chars) {
        if ((c = b64_digit(**p)) < 0)
            return false;
        (*p)++;
        bits -= 6;
        *out += (uint32_t)c << bits;
    }
    return true;
}

/* The policy (docs/http.md, docs/security.md): hashes a login can verify
 * in bounded time on the console's worker, and none that is broken. h is
 * a '\0'-terminated "$id$..." that valid_hash let through. */
static bool hash_policy(const char *h, char *why, size_t whylen)
{
    static const char use[] = "make one with `mkpasswd -m yescrypt` or `openssl passwd -6`";
    if (strncmp(h, "$6$", 3) == 0 || strncmp(h, "$5$", 3) == 0) {
        if (strncmp(h + 3, "rounds=", 7) != 0)
            return true; /* 5000 rounds, crypt's default */
        char *end;
        errno = 0;
        unsigned long long r = strtoull(h + 10, &end, 10);
        if (*end != '$' || errno != 0 || r > GW_PASSWD_SHA_ROUNDS_MAX) {
            snprintf(why, whylen,
                     "$%c$ with rounds=%.20s: more than %d rounds would hold every login for "
                     "long (allowed: at most rounds=%d; %s)",
                     h[1], h + 10, GW_PASSWD_SHA_ROUNDS_MAX, GW_PASSWD_SHA_ROUNDS_MAX, use);
            return false;
        }
        return true;
    }
    if (strncmp(h, "$2b$", 4) == 0 || strncmp(h, "$2a$", 4) == 0 || strncmp(h, "$2y$", 4) == 0) {
        if (h[4] < '0' || h[4] > '9' || h[5] < '0' || h[5] > '9' || h[6] != '$') {
            snprintf(why, whylen, "bcrypt hash without a two-digit cost (%s)", use);
            return false;
        }
        int cost = (h[4] - '0') * 10 + (h[5] - '0');
        if (cost > GW_PASSWD_BCRYPT_COST_MAX) {
            snprintf(why, whylen,
                     "bcrypt cost %d: 2^%d rounds would hold every login for long (allowed: "
                     "a cost of at most %d; %s)",
                     cost, cost, GW_PASSWD_BCRYPT_COST_MAX, use);
            return false;
        }
        return true;
    }
    if (strncmp(h, "$y$", 3) == 0) {
        const char *p = h + 3;
        uint32_t flavor, nlog2, r;
        if (!yescrypt_num(&p, 0, &flavor) || !yescrypt_num(&p, 1, &nlog2) ||
            !yescrypt_num(&p, 1, &r) || nlog2 > 63 || r == 0) {
            snprintf(why, whylen, "yescrypt hash whose parameters do not read (%s)", use);
            return false;
        }
        if (*p != '$') {
            snprintf(why, whylen,
                     "yescrypt hash with parameters beyond N and r (p, t, g or a ROM): not "
                     "accepted (%s)", use);
            return false;
        }
        /* memory: 128 * r * N bytes */
        if (nlog2 > 30 || (uint64_t)r << nlog2 > (uint64_t)GW_PASSWD_YESCRYPT_MIB_MAX << 13) {
            snprintf(why, whylen,
                     "yescrypt with N=2^%u and r=%u needs more than %d MiB per login "
                     "(allowed: at most %d MiB, such as the default $y$j9T$ of "
                     "`mkpasswd -m yescrypt`: 16 MiB)",
                     (unsigned)nlog2, (unsigned)r, GW_PASSWD_YESCRYPT_MIB_MAX,
                     GW_PASSWD_YESCRYPT_MIB_MAX);
            return false;
        }
        return true;
    }
    if (strncmp(h, "$1$", 3) == 0) {
        snprintf(why, whylen, "an MD5 hash ($1$): broken, found in seconds from the file (%s)",
                 use);
        return false;
    }
    snprintf(why, whylen,
             "a %.*s hash: not one the console accepts (allowed: yescrypt $y$, SHA-512 $6$, "
             "SHA-256 $5$, bcrypt $2b$; %s)",
             (int)(strchr(h + 1, '$') != NULL ? strchr(h + 1, '$') - h + 1 : 4), h, use);
    return false;
}

static bool valid_user(const char *u, size_t n, char *why, size_t whylen)
{
    if (n == 0) {
        snprintf(why, whylen, "no user name before ':' (allowed: user:HASH)");
        return false;
    }
    if (n >= GW_USER_MAX) {
        snprintf(why, whylen, "user name too long (at most %d characters)", GW_USER_MAX - 1);
        return false;
    }
    for (size_t i = 0; i < n; i++)
        if ((unsigned char)u[i] <= 0x20 || u[i] == 0x7f) {
            snprintf(why, whylen, "blank or control character in the user name");
            return false;
        }
    return true;
}

/* One line (no '\n'); a '\r' before it is dropped. */
static bool parse_line(const char *s, size_t n, gw_users_t *out, char *why, size_t whylen)
{
    if (n > 0 && s[n - 1] == '\r')
        n--;
    if (n == 0 || s[0] == '#')
        return true;
    const char *colon = memchr(s, ':', n);
    if (colon == NULL) {
        snprintf(why, whylen, "no ':' (allowed: user:HASH)");
        return false;
    }
    size_t un = (size_t)(colon - s), hn = n - un - 1;
    if (!valid_user(s, un, why, whylen) || !valid_hash(colon + 1, hn, why, whylen))
        return false;
    char hash[GW_HASH_MAX];
    memcpy(hash, colon + 1, hn);
    hash[hn] = '\0';
    if (!hash_policy(hash, why, whylen))
        return false;
    char user[GW_USER_MAX];
    memcpy(user, s, un);
    user[un] = '\0';
    if (gw_passwd_find(out, user) != NULL) {
        snprintf(why, whylen, "user %s listed twice", user);
        return false;
    }
    if (out->count >= GW_USERS_MAX) {
        snprintf(why, whylen, "too many users (at most %d)", GW_USERS_MAX);
        return false;
    }
    gw_user_t *e = &out->user[out->count++];
    memcpy(e->user, user, un + 1);
    memcpy(e->hash, colon + 1, hn);
    e->hash[hn] = '\0';
    return true;
}

bool gw_passwd_parse(const char *text, size_t len, gw_users_t *out, unsigned *line,
                          char *why, size_t whylen)
{
    memset(out, 0, sizeof *out);
    *line = 0;
    size_t at = 0;
    for (unsigned n = 1; at < len; n++) {
        const char *nl = memchr(text + at, '\n', len - at);
        size_t end = nl != NULL ? (size_t)(nl - text) : len;
        if (memchr(text + at, '\0', end - at) != NULL) {
            *line = n;
            snprintf(why, whylen, "a NUL byte: not a text file");
            return false;
        }
        if (!parse_line(text + at, end - at, out, why, whylen)) {
            *line = n;
            return false;
        }
        at = end + 1;
    }
    if (out->count == 0) {
        snprintf(why, whylen, "no user in it (allowed: user:HASH lines)");
        return false;
    }
    return true;
}

bool gw_passwd_load(const char *path, gw_users_t *out, char *err, size_t errlen)
{
    static char text[GW_PASSWD_FILE_MAX + 1];
    FILE *f = fopen(path, "r");
    if (f == NULL) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return false;
    }
    size_t n = fread(text, 1, sizeof text, f);
    bool bad = ferror(f) != 0;
    int e = errno;
    (void)fclose(f);
    if (bad) {
        snprintf(err, errlen, "%s: %s", path, strerror(e));
        return false;
    }
    if (n > GW_PASSWD_FILE_MAX) {
        snprintf(err, errlen, "%s: larger than %d bytes", path, GW_PASSWD_FILE_MAX);
        return false;
    }
    unsigned line;
    char why[200];
    if (!gw_passwd_parse(text, n, out, &line, why, sizeof why)) {
        if (line != 0)
            snprintf(err, errlen, "%s:%u: %s", path, line, why);
        else
            snprintf(err, errlen, "%s: %s", path, why);
        return false;
    }
    return true;
}

const gw_user_t *gw_passwd_find(const gw_users_t *u, const char *user)
{
    for (unsigned i = 0; i < u->count; i++)
        if (strcmp(u->user[i].user, user) == 0)
            return &u->user[i];
    return NULL;
}
