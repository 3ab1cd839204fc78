/* SPDX-License-Identifier: MIT */
/*
 * libmicrohttpd and libcrypt by dlopen (mhd_lib.h): one table of their
 * functions, filled once, on the first [http] side created (or the first
 * --check-config of a TLS console). They stay loaded for the life of the
 * process, as libmosquitto does (mqtt_lib.c says why).
 */
#include "http/mhd_lib.h"

#include <dlfcn.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The table's members, once: X(member, library symbol, which library). */
#define MHL_EACH(X) \
    X(start_daemon, MHD_start_daemon, 0) \
    X(stop_daemon, MHD_stop_daemon, 0) \
    X(get_daemon_info, MHD_get_daemon_info, 0) \
    X(run, MHD_run, 0) \
    X(get_timeout, MHD_get_timeout, 0) \
    X(get_connection_info, MHD_get_connection_info, 0) \
    X(get_connection_values, MHD_get_connection_values, 0) \
    X(lookup_connection_value, MHD_lookup_connection_value, 0) \
    X(queue_response, MHD_queue_response, 0) \
    X(set_connection_option, MHD_set_connection_option, 0) \
    X(suspend_connection, MHD_suspend_connection, 0) \
    X(resume_connection, MHD_resume_connection, 0) \
    X(create_response_from_callback, MHD_create_response_from_callback, 0) \
    X(create_response_from_buffer, MHD_create_response_from_buffer, 0) \
    X(destroy_response, MHD_destroy_response, 0) \
    X(add_response_header, MHD_add_response_header, 0) \
    X(free, MHD_free, 0) \
    X(basic_auth_get_username_password, MHD_basic_auth_get_username_password, 0) \
    X(queue_basic_auth_fail_response, MHD_queue_basic_auth_fail_response, 0) \
    X(crypt_r, crypt_r, 1)

/* Each member's type is that of the header's function: only
 * type-checked (sizeof does not evaluate, so nothing references the
 * libraries at link time). */
#define MHL_CHECK(m, sym, lib) (void)sizeof(mhl_probe.m = sym);
static gw_mhdlib_t mhl_probe;

static gw_mhdlib_t mhl;
static bool mhl_loaded;

#define MHL_FN(m, sym, lib) {#sym, offsetof(gw_mhdlib_t, m), lib},
static const struct {
    const char *sym;
    size_t off;
    int lib; /* 0: libmicrohttpd, 1: libcrypt */
} mhl_fns[] = {MHL_EACH(MHL_FN)};

typedef char mhl_all_named[sizeof mhl_fns / sizeof mhl_fns[0] * sizeof(void *) ==
                                   sizeof(gw_mhdlib_t) &&
                               sizeof(void *) == sizeof(void (*)(void))
                               ? 1
                               : -1];

static void mhl_check_prototypes(void)
{
    MHL_EACH(MHL_CHECK)
}

static void *open_lib(const char *name, const char *package, char *err, size_t errlen)
{
    /* RTLD_LOCAL: their symbols (and GnuTLS's) stay out of the global
     * scope; RTLD_NOW: a library that cannot be bound fails here. */
    void *h = dlopen(name, RTLD_NOW | RTLD_LOCAL);
    if (h == NULL) {
        const char *why = dlerror();
        snprintf(err, errlen, "http: cannot load %s (%s): install %s, or remove [http]", name,
                 why != NULL ? why : "unknown error", package);
    }
    return h;
}

const gw_mhdlib_t *gw_mhdlib_load(char *err, size_t errlen)
{
    mhl_check_prototypes(); /* compiles to nothing */
    if (mhl_loaded)
        return &mhl;
    const char *name = getenv("DRGATE_MHD_LIB");
    if (name == NULL || name[0] == '\0')
        name = GW_MHDLIB_SONAME;
    void *h[2];
    h[0] = open_lib(name, "libmicrohttpd12", err, errlen);
    if (h[0] == NULL)
        return NULL;
    h[1] = open_lib(GW_CRYPTLIB_SONAME, "libcrypt1", err, errlen);
    if (h[1] == NULL) {
        (void)dlclose(h[0]);
        return NULL;
    }
    gw_mhdlib_t t;
    for (size_t i = 0; i < sizeof mhl_fns / sizeof mhl_fns[0]; i++) {
        (void)dlerror();
        void *sym = dlsym(h[mhl_fns[i].lib], mhl_fns[i].sym);
        if (sym == NULL) {
            const char *why = dlerror();
            snprintf(err, errlen, "http: cannot load %s: no %s (%s): install %s, or remove [http]",
                     mhl_fns[i].lib ? GW_CRYPTLIB_SONAME : name, mhl_fns[i].sym,
                     why != NULL ? why : "null symbol",
                     mhl_fns[i].lib ? "libcrypt1" : "libmicrohttpd12");
            /* Nothing from them was called or kept: safe to unmap. */
            (void)dlclose(h[0]);
            (void)dlclose(h[1]);
            return NULL;
        }
        /* POSIX: dlsym's pointer converts to a function pointer of the
         * same size (memcpy: ISO C has no cast for it). */
        memcpy((char *)&t + mhl_fns[i].off, &sym, sizeof sym);
    }
    mhl = t;
    mhl_loaded = true;
    return &mhl;
}
