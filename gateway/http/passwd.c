/* SPDX-License-Identifier: MIT */
/* The console's password file (passwd.h). */
#include "http/passwd.h"

#include <errno.h>
#include <stdio.h>
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
    if (n >= GW_HTTP_HASH_MAX) {
        snprintf(why, whylen, "hash too long (at most %d characters)", GW_HTTP_HASH_MAX - 1);
        return false;
    }
    return true;
}

static bool valid_user(const char *u, size_t n, char *why, size_t whylen)
{
    if (n == 0) {
        snprintf(why, whylen, "no user name before ':' (allowed: user:HASH)");
        return false;
    }
    if (n >= GW_HTTP_USER_MAX) {
        snprintf(why, whylen, "user name too long (at most %d characters)", GW_HTTP_USER_MAX - 1);
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
static bool parse_line(const char *s, size_t n, gw_http_users_t *out, char *why, size_t whylen)
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
    char user[GW_HTTP_USER_MAX];
    memcpy(user, s, un);
    user[un] = '\0';
    if (gw_http_passwd_find(out, user) != NULL) {
        snprintf(why, whylen, "user %s listed twice", user);
        return false;
    }
    if (out->count >= GW_HTTP_USERS_MAX) {
        snprintf(why, whylen, "too many users (at most %d)", GW_HTTP_USERS_MAX);
        return false;
    }
    gw_http_user_t *e = &out->user[out->count++];
    memcpy(e->user, user, un + 1);
    memcpy(e->hash, colon + 1, hn);
    e->hash[hn] = '\0';
    return true;
}

bool gw_http_passwd_parse(const char *text, size_t len, gw_http_users_t *out, unsigned *line,
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

bool gw_http_passwd_load(const char *path, gw_http_users_t *out, char *err, size_t errlen)
{
    static char text[GW_HTTP_PASSWD_FILE_MAX + 1];
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
    if (n > GW_HTTP_PASSWD_FILE_MAX) {
        snprintf(err, errlen, "%s: larger than %d bytes", path, GW_HTTP_PASSWD_FILE_MAX);
        return false;
    }
    unsigned line;
    char why[200];
    if (!gw_http_passwd_parse(text, n, out, &line, why, sizeof why)) {
        if (line != 0)
            snprintf(err, errlen, "%s:%u: %s", path, line, why);
        else
            snprintf(err, errlen, "%s: %s", path, why);
        return false;
    }
    return true;
}

const gw_http_user_t *gw_http_passwd_find(const gw_http_users_t *u, const char *user)
{
    for (unsigned i = 0; i < u->count; i++)
        if (strcmp(u->user[i].user, user) == 0)
            return &u->user[i];
    return NULL;
}
