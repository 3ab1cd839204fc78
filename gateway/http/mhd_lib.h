/* SPDX-License-Identifier: MIT */
/*
 * libmicrohttpd (and libcrypt, for the password file's hashes), loaded at
 * run time (dlopen) by the console only when the configuration has an
 * [http] section: a gateway without it maps neither, nor the GnuTLS that
 * libmicrohttpd pulls in (docs/http.md), as MQTT does with libmosquitto
 * (mqtt/mqtt_lib.h).
 *
 * Compiled against <microhttpd.h> and <crypt.h> for the types and
 * constants; the table's prototypes are the headers' (mhd_lib.c checks it
 * at compile time).
 */
#ifndef GW_HTTP_MHD_LIB_H
#define GW_HTTP_MHD_LIB_H

#include <stddef.h>
#include <stdint.h>
#include <sys/types.h>

#include <crypt.h>
#include <microhttpd.h>

/* The libraries' names as dlopen is given them; the environment variable
 * DRGATE_MHD_LIB replaces the first (a test and diagnostic knob,
 * drgatewayd(8)). */
#define GW_MHDLIB_SONAME "libmicrohttpd.so.12"
#define GW_CRYPTLIB_SONAME "libcrypt.so.1"

/* The functions north_http.c calls: MHD_<member>, and crypt_r. */
typedef struct {
    struct MHD_Daemon *(*start_daemon)(unsigned int flags, uint16_t port,
                                       MHD_AcceptPolicyCallback apc, void *apc_cls,
                                       MHD_AccessHandlerCallback dh, void *dh_cls, ...);
    void (*stop_daemon)(struct MHD_Daemon *daemon);
    const union MHD_DaemonInfo *(*get_daemon_info)(struct MHD_Daemon *daemon,
                                                   enum MHD_DaemonInfoType info_type, ...);
    enum MHD_Result (*run)(struct MHD_Daemon *daemon);
    enum MHD_Result (*get_timeout)(struct MHD_Daemon *daemon, MHD_UNSIGNED_LONG_LONG *timeout);
    const union MHD_ConnectionInfo *(*get_connection_info)(struct MHD_Connection *connection,
                                                           enum MHD_ConnectionInfoType info_type,
                                                           ...);
    int (*get_connection_values)(struct MHD_Connection *connection, enum MHD_ValueKind kind,
                                 MHD_KeyValueIterator iterator, void *iterator_cls);
    const char *(*lookup_connection_value)(struct MHD_Connection *connection,
                                           enum MHD_ValueKind kind, const char *key);
    enum MHD_Result (*queue_response)(struct MHD_Connection *connection, unsigned int status_code,
                                      struct MHD_Response *response);
    enum MHD_Result (*set_connection_option)(struct MHD_Connection *connection,
                                             enum MHD_CONNECTION_OPTION option, ...);
    void (*suspend_connection)(struct MHD_Connection *connection);
    void (*resume_connection)(struct MHD_Connection *connection);
    struct MHD_Response *(*create_response_from_callback)(uint64_t size, size_t block_size,
                                                          MHD_ContentReaderCallback crc,
                                                          void *crc_cls,
                                                          MHD_ContentReaderFreeCallback crfc);
    struct MHD_Response *(*create_response_from_buffer)(size_t size, void *buffer,
                                                        enum MHD_ResponseMemoryMode mode);
    void (*destroy_response)(struct MHD_Response *response);
    enum MHD_Result (*add_response_header)(struct MHD_Response *response, const char *header,
                                           const char *content);
    void (*free)(void *ptr);
    char *(*basic_auth_get_username_password)(struct MHD_Connection *connection,
                                              char **password);
    enum MHD_Result (*queue_basic_auth_fail_response)(struct MHD_Connection *connection,
                                                      const char *realm,
                                                      struct MHD_Response *response);
    char *(*crypt_r)(const char *phrase, const char *setting, struct crypt_data *data);
} gw_mhdlib_t;

/* The table, the libraries loaded on the first call (later calls return
 * the same table, or try again after a failure). NULL with `err` set
 * ("http: cannot load ...: what, and what to do") if a library or one of
 * its functions is missing. */
const gw_mhdlib_t *gw_mhdlib_load(char *err, size_t errlen);

#endif
