/* SPDX-License-Identifier: MIT */
/*
 * libmosquitto by dlopen (mqtt_lib.h): one table of its functions, filled
 * once, on the first [mqtt] side created.
 *
 * The library stays loaded for the life of the process (no dlclose): a
 * side freed by a reload may be followed by another one, libmosquitto and
 * OpenSSL keep process-wide state (mosquitto_lib_init/cleanup are counted
 * by north_mqtt.c, not tied to the mapping), and unmapping code that a
 * callback or an OpenSSL atexit handler may still reach is not worth the
 * few pages it would give back.
 */
#include "mqtt/mqtt_lib.h"

#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* The functions of the table (mqtt_lib.h), once: X(name) for each. */
#define MQL_EACH(X) \
    X(lib_init) \
    X(lib_cleanup) \
    X(strerror) \
    X(connack_string) \
    X(new) \
    X(destroy) \
    X(will_set) \
    X(username_pw_set) \
    X(tls_set) \
    X(max_inflight_messages_set) \
    X(connect_callback_set) \
    X(disconnect_callback_set) \
    X(publish_callback_set) \
    X(message_callback_set) \
    X(connect_async) \
    X(disconnect) \
    X(publish) \
    X(subscribe) \
    X(socket) \
    X(want_write) \
    X(loop_read) \
    X(loop_write) \
    X(loop_misc)

/* Every member's type is that of the header's function: the assignments
 * are only type-checked (sizeof does not evaluate them, so nothing here
 * references libmosquitto at link time). A prototype that differs from
 * <mosquitto.h> is a compile error under -Werror. */
#define MQL_CHECK(m) (void)sizeof(mql_probe.m = mosquitto_##m);
static gw_mqttlib_t mql_probe;

static gw_mqttlib_t mql;
static bool mql_loaded;

/* name and place of each member, for dlsym */
#define MQL_FN(m) {"mosquitto_" #m, offsetof(gw_mqttlib_t, m)},
static const struct {
    const char *sym;
    size_t off;
} mql_fns[] = {MQL_EACH(MQL_FN)};

/* The table holds function pointers only, each filled from mql_fns, and
 * one is the size of dlsym's void * (memcpy below). */
typedef char mql_all_named[sizeof mql_fns / sizeof mql_fns[0] * sizeof(void *) ==
                                   sizeof(gw_mqttlib_t) &&
                               sizeof(void *) == sizeof(void (*)(void))
                               ? 1
                               : -1];

static void mql_check_prototypes(void)
{
    MQL_EACH(MQL_CHECK)
}

const gw_mqttlib_t *gw_mqttlib_load(char *err, size_t errlen)
{
    mql_check_prototypes(); /* compiles to nothing */
    if (mql_loaded)
        return &mql;
    const char *name = getenv("DRGATE_MOSQUITTO_LIB");
    if (name == NULL || name[0] == '\0')
        name = GW_MQTTLIB_SONAME;
    /* RTLD_LOCAL: its symbols (and OpenSSL's) stay out of the global
     * scope; RTLD_NOW: a library that cannot be bound fails here, at
     * start or reload, not at the first call. */
    void *h = dlopen(name, RTLD_NOW | RTLD_LOCAL);
    if (h == NULL) {
        const char *why = dlerror();
        snprintf(err, errlen,
                 "mqtt: cannot load %s (%s): install libmosquitto1, or remove [mqtt]", name,
                 why != NULL ? why : "unknown error");
        return NULL;
    }
    gw_mqttlib_t t;
    for (size_t i = 0; i < sizeof mql_fns / sizeof mql_fns[0]; i++) {
        (void)dlerror();
        void *sym = dlsym(h, mql_fns[i].sym);
        if (sym == NULL) {
            const char *why = dlerror();
            snprintf(err, errlen,
                     "mqtt: cannot load %s: no %s (%s): install libmosquitto1, or remove "
                     "[mqtt]",
                     name, mql_fns[i].sym, why != NULL ? why : "null symbol");
            /* Nothing from it was called or kept: safe to unmap. */
            (void)dlclose(h);
            return NULL;
        }
        /* POSIX: a data pointer from dlsym converts to a function
         * pointer of the same size (memcpy: ISO C has no cast for it). */
        memcpy((char *)&t + mql_fns[i].off, &sym, sizeof sym);
    }
    mql = t;
    mql_loaded = true;
    return &mql;
}
