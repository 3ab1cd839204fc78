/* SPDX-License-Identifier: MIT */
/*
 * The console's files built into the daemon (mk/gen-assets.sh,
 * gateway/http/asset.h): every file of gateway/http/www/ is in the table
 * byte for byte, with its Content-Type; names with a folder in them,
 * empty or unknown ones find nothing.
 */
#include <stdarg.h>
#include <stddef.h>
#include <setjmp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>
#include <dirent.h>

#include "http/asset.h"

static void same_as_file(const gw_http_asset_t *a)
{
    char path[512];
    static unsigned char buf[1u << 20];
    snprintf(path, sizeof path, "%s/gateway/http/www/%s", GW_TEST_TOP, a->name);
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        fail_msg("%s: in the table but not in gateway/http/www/", a->name);
    size_t n = fread(buf, 1, sizeof buf, f);
    (void)fclose(f);
    assert_int_equal(n, a->size);
    assert_memory_equal(buf, a->data, n);
}

static void test_pages(void **state)
{
    (void)state;
    static const char *const want[][2] = {
        {"index.html", "text/html; charset=utf-8"},
        {"robot.html", "text/html; charset=utf-8"},
        {"console.js", "text/javascript; charset=utf-8"},
        {"console.css", "text/css; charset=utf-8"},
    };
    for (size_t i = 0; i < sizeof want / sizeof want[0]; i++) {
        const gw_http_asset_t *a = gw_http_asset_find(want[i][0]);
        if (a == NULL) {
            fail_msg("%s: not in the table", want[i][0]);
            return;
        }
        assert_string_equal(a->type, want[i][1]);
        same_as_file(a);
    }
}

/* Every file of the folder, whatever its name: a file added to www/ is
 * built in without a change to the build. */
static void test_every_file(void **state)
{
    (void)state;
    DIR *d = opendir(GW_TEST_TOP "/gateway/http/www");
    assert_non_null(d);
    unsigned n = 0;
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        if (e->d_name[0] == '.')
            continue;
        const gw_http_asset_t *a = gw_http_asset_find(e->d_name);
        if (a == NULL) {
            fail_msg("%s: in gateway/http/www/ but not in the table", e->d_name);
            break;
        }
        same_as_file(a);
        n++;
    }
    closedir(d);
    assert_true(n >= 4);
}

static void test_not_found(void **state)
{
    (void)state;
    static const char *const bad[] = {"", "/", "nothing.js", "../index.html", "www/index.html",
                                      "/index.html", "/static/index.html", "index.html/",
                                      "INDEX.HTML", "index.htm", "index.html.gz"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        if (gw_http_asset_find(bad[i]) != NULL)
            fail_msg("'%s' found", bad[i]);
    assert_null(gw_http_asset_find(NULL));
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_pages),
        cmocka_unit_test(test_every_file),
        cmocka_unit_test(test_not_found),
    };
    return cmocka_run_group_tests(tests, NULL, NULL);
}
