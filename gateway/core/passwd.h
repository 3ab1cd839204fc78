/* SPDX-License-Identifier: MIT */
/*
 * The console's password file ([http] auth_file, docs/http.md): one
 * `user:HASH` line per user, HASH a crypt(3) hash as `openssl passwd -6`
 * or `mkpasswd` write them ($6$..., $5$..., $y$...); blank lines and
 * lines starting with '#' are skipped. Only the kinds and costs of the
 * policy below are accepted. Parsed here without a library (the
 * configuration check and the unit test use it); the daemon checks a
 * password against the hash with libcrypt's crypt_r (mhd_lib.h).
 */
#ifndef GW_PASSWD_H
#define GW_PASSWD_H

#include <stdbool.h>
#include <stddef.h>

#define GW_USERS_MAX 32
#define GW_USER_MAX 64  /* bytes of a user name, its '\0' included */
#define GW_HASH_MAX 192 /* bytes of a hash, its '\0' included */
#define GW_PASSWD_FILE_MAX 65536

/* The hash policy: what a line may hold (passwd.c hash_policy). Broken
 * kinds (DES, MD5 $1$, anything but the four below) are refused, and so
 * is a cost that would hold a login for long: SHA-crypt ($5$, $6$) above
 * rounds=100000 (the default is 5000), bcrypt above cost 12, yescrypt
 * above 64 MiB (the default $y$j9T$ is 16 MiB) or with p/t/g/ROM. */
#define GW_PASSWD_SHA_ROUNDS_MAX 100000
#define GW_PASSWD_BCRYPT_COST_MAX 12
#define GW_PASSWD_YESCRYPT_MIB_MAX 64

typedef struct {
    char user[GW_USER_MAX];
    char hash[GW_HASH_MAX];
} gw_user_t;

typedef struct {
    unsigned count;
    gw_user_t user[GW_USERS_MAX];
} gw_users_t;

/* The text of a whole file (len bytes, no '\0' needed) into *out. False
 * with the offending line (1-based) in *line and what is wrong in why;
 * a file with no user is refused too (line 0). */
bool gw_passwd_parse(const char *text, size_t len, gw_users_t *out, unsigned *line,
                          char *why, size_t whylen);

/* Read and parse the file at path: false with "PATH: ..." (the line
 * number, or the system's error) in err. */
bool gw_passwd_load(const char *path, gw_users_t *out, char *err, size_t errlen);

/* The user's entry, NULL if none. */
const gw_user_t *gw_passwd_find(const gw_users_t *u, const char *user);

#endif
