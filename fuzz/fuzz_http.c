/* SPDX-License-Identifier: MIT */
/*
 * The console's handling of what a client sends that is not robot data
 * (gateway/http): the Authorization value (gw_http_basic_parse, then the
 * whole login of auth.c: the HMAC cache, the per-address waits and the
 * worker thread, with a fake crypt), the Host header (gw_http_host_ok),
 * and the path as it is logged (gw_log_escape) and quoted into a JSON
 * error (gw_json_quote). libmicrohttpd itself is not here: it parses the
 * request line and headers before any of this runs.
 *
 * Input layout: fields separated by '\0':
 *   path '\0' host '\0' authorization '\0' [port byte] [address byte]
 * (missing fields are empty; the port is 8080 + the byte, the client
 * address 10.0.0.<byte>).
 *
 * Properties: a Basic value that parses gives a user without ':' and,
 * encoded again, the same user and password; the login result agrees
 * with the password file (only "admin" with the fake's good password is
 * ever accepted, and then again from the cache); a refused login is never
 * answered before its address's wait; the Host check takes exactly the
 * names it documents; the escaped log text has no control character and
 * fits; the JSON string is valid UTF-8 with no raw control character.
 */
#include <poll.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>
#include <strings.h>

#include "core/auth.h"
#include "core/json.h"
#include "core/log.h"
#include "fuzz.h"
#include "http/request.h"

#define HASH "$6$abcdefgh$fakefakefakefake"

/* The fake crypt_r: the hash itself for the good password. */
static char *fake_crypt(const char *phrase, const char *setting, struct crypt_data *data)
{
    (void)data;
    static char bad[] = "*0", hash[512];
    if (strcmp(phrase, "good") != 0)
        return bad;
    (void)snprintf(hash, sizeof hash, "%s", setting);
    return hash;
}

static bool utf8_ok(const unsigned char *s, size_t n)
{
    for (size_t i = 0; i < n;) {
        unsigned char c = s[i];
        size_t len = c < 0x80 ? 1 : c >= 0xc2 && c <= 0xdf ? 2 : c >= 0xe0 && c <= 0xef ? 3
                   : c >= 0xf0 && c <= 0xf4 ? 4 : 0;
        if (len == 0 || i + len > n)
            return false;
        if (len == 1 && c < 0x20)
            return false;
        for (size_t k = 1; k < len; k++)
            if ((s[i + k] & 0xc0) != 0x80)
                return false;
        i += len;
    }
    return true;
}

static void b64_encode(const char *in, size_t n, char *out)
{
    static const char d[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    size_t o = 0;
    for (size_t i = 0; i < n; i += 3) {
        uint32_t v = (uint32_t)(unsigned char)in[i] << 16;
        if (i + 1 < n)
            v |= (uint32_t)(unsigned char)in[i + 1] << 8;
        if (i + 2 < n)
            v |= (unsigned char)in[i + 2];
        out[o++] = d[v >> 18 & 63];
        out[o++] = d[v >> 12 & 63];
        out[o++] = '=';
        out[o++] = '=';
        if (i + 1 < n)
            out[o - 2] = d[v >> 6 & 63];
        if (i + 2 < n)
            out[o - 1] = d[v & 63];
    }
    out[o] = '\0';
}

static bool cb_ok, cb_called;
static void on_done(void *user, void *cookie, bool ok, uint64_t until)
{
    (void)user, (void)cookie, (void)until;
    cb_ok = ok;
    cb_called = true;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    static gw_auth_t *auth;
    static uint64_t now = 1000000000u;
    char field[3][1024];
    size_t len[3] = {0, 0, 0}, at = 0;
    unsigned k = 0;
    for (; k < 3 && at <= size; k++) {
        const uint8_t *z = at < size ? memchr(data + at, 0, size - at) : NULL;
        size_t n = z != NULL ? (size_t)(z - (data + at)) : size - at;
        len[k] = n < sizeof field[k] - 1 ? n : sizeof field[k] - 1;
        memcpy(field[k], data + at, len[k]);
        field[k][len[k]] = '\0';
        at += n + 1;
    }
    for (; k < 3; k++)
        field[k][0] = '\0';
    unsigned port = 8080u + (at < size ? data[at] : 0u);
    uint32_t ip = 0x0a000000u | (at + 1 < size ? data[at + 1] : 1u);

    /* the path, logged and quoted */
    char esc[128];
    size_t el = gw_log_escape(esc, sizeof esc, field[0], len[0]);
    FUZZ_CHECK(el < sizeof esc && esc[el] == '\0' && strlen(esc) == el);
    for (size_t i = 0; i < el; i++)
        FUZZ_CHECK((unsigned char)esc[i] >= 0x20 && esc[i] != 0x7f);
    static char jbuf[8192];
    gw_json_t j;
    gw_json_init(&j, jbuf, sizeof jbuf);
    gw_json_quote(&j, field[0], len[0]);
    FUZZ_CHECK(!j.full && j.len >= 2 && jbuf[0] == '"' && jbuf[j.len - 1] == '"');
    FUZZ_CHECK(utf8_ok((const unsigned char *)jbuf, j.len));

    /* the Host header */
    bool host = gw_http_host_ok(field[1], port, "127.0.0.1");
    if (host) {
        const char *c = field[1][0] == '[' ? strstr(field[1], "]:") : strchr(field[1], ':');
        size_t hn = c != NULL ? (size_t)(c - field[1]) + (field[1][0] == '[') : len[1];
        FUZZ_CHECK((hn == 9 && strncasecmp(field[1], "localhost", 9) == 0) ||
                   (hn == 9 && strncmp(field[1], "127.0.0.1", 9) == 0) ||
                   (hn == 5 && strncmp(field[1], "[::1]", 5) == 0));
    }
    FUZZ_CHECK(gw_http_host_ok(NULL, port, NULL));

    /* the Authorization value */
    char user[GW_USER_MAX], pass[256];
    if (gw_http_basic_parse(field[2], user, sizeof user, pass, sizeof pass)) {
        FUZZ_CHECK(strchr(user, ':') == NULL);
        char both[GW_USER_MAX + 256 + 2], again[sizeof both * 2 + 16], u2[sizeof user],
            p2[sizeof pass];
        size_t bl = (size_t)snprintf(both, sizeof both, "%s:%s", user, pass);
        (void)snprintf(again, sizeof again, "%s", "Basic ");
        b64_encode(both, bl, again + 6);
        FUZZ_CHECK(gw_http_basic_parse(again, u2, sizeof u2, p2, sizeof p2));
        FUZZ_CHECK(strcmp(u2, user) == 0 && strcmp(p2, pass) == 0);
    }
    if (auth == NULL) {
        gw_log_set_level(GW_LOG_ERROR); /* the refusals' info lines: not printed */
        static gw_users_t users;
        memset(&users, 0, sizeof users);
        users.count = 1;
        memcpy(users.user[0].user, "admin", 6);
        memcpy(users.user[0].hash, HASH, sizeof HASH);
        char err[200];
        auth = gw_auth_new(&users, fake_crypt, "http", "address", err, sizeof err);
        FUZZ_CHECK(auth != NULL);
    }
    now += 100000u; /* 0.1 s a request */
    uint64_t until;
    int cookie;
    char from[GW_AUTH_FROM_MAX];
    (void)snprintf(from, sizeof from, "10.0.0.%u", (unsigned)(ip & 255u));
    bool basic = gw_http_basic_parse(field[2], user, sizeof user, pass, sizeof pass);
    gw_auth_result_t r = gw_auth_check(auth, basic ? user : NULL, basic ? pass : NULL, from,
                                       &cookie, now, &until);
    bool should = basic && strcmp(user, "admin") == 0 && strcmp(pass, "good") == 0;
    if (r == GW_AUTH_PENDING) {
        struct pollfd p = {gw_auth_fd(auth), POLLIN, 0};
        cb_called = false;
        while (!cb_called) {
            (void)poll(&p, 1, 1000);
            gw_auth_collect(auth, now, on_done, NULL);
        }
        FUZZ_CHECK(cb_ok == should);
        if (cb_ok) /* and now from the cache */
            FUZZ_CHECK(gw_auth_check(auth, user, pass, from, &cookie, now, &until) == GW_AUTH_OK);
    } else if (r == GW_AUTH_OK) {
        FUZZ_CHECK(should);
    } else {
        FUZZ_CHECK(r == GW_AUTH_REFUSED);
        FUZZ_CHECK(until >= now);
    }
    return 0;
}
