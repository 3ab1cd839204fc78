/* SPDX-License-Identifier: MIT */
/*
 * The Linux conveniences of the client: storage from malloc, and the POSIX
 * transport when the configuration names none. Kept apart from client.c
 * so that firmware, which links neither malloc nor the POSIX transport,
 * leaves this object out (make check-firmware checks it).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "drgate/client.h"

/* The first line of /etc/machine-id (32 hex digits, systemd and D-Bus
 * write it at installation), else the host name; "" if neither. */
static void host_identity(char *out, size_t size)
{
    out[0] = '\0';
    FILE *f = fopen("/etc/machine-id", "r");
    if (f != NULL) {
        if (fgets(out, (int)size, f) == NULL)
            out[0] = '\0';
        (void)fclose(f); /* read-only: nothing to lose */
        out[strcspn(out, " \t\r\n")] = '\0';
    }
    if (out[0] == '\0' && gethostname(out, size) != 0)
        out[0] = '\0';
    out[size - 1] = '\0'; /* gethostname may not terminate a cut name */
}

uint32_t dr_originator_serial_local(const char *name)
{
    char id[256];
    host_identity(id, sizeof id);
    return dr_originator_serial(id, name);
}

dr_client_t *dr_client_new(const dr_client_config_t *cfg, dr_status_t *err)
{
    if (cfg == NULL) {
        if (err != NULL)
            *err = DR_EINVAL;
        return NULL;
    }
    dr_client_config_t cc = *cfg;
    if (cc.transport.ops == NULL)
        cc.transport = dr_transport_posix();
    size_t size = dr_client_size();
    void *storage = malloc(size); /* malloc's alignment suits any type */
    if (storage == NULL) {
        if (err != NULL)
            *err = DR_ENOMEM;
        return NULL;
    }
    dr_client_t *c = dr_client_init(storage, size, &cc, err);
    if (c == NULL)
        free(storage);
    return c;
}

void dr_client_free(dr_client_t *c)
{
    dr_client_deinit(c);
    free(c); /* the client sits at the start of its storage */
}

dr_udp_port_t *dr_udp_port_new(const char *local_addr, uint16_t port,
                               dr_transport_t transport, dr_status_t *err)
{
    if (transport.ops == NULL)
        transport = dr_transport_posix();
    size_t size = dr_udp_port_size();
    void *storage = malloc(size);
    if (storage == NULL) {
        if (err != NULL)
            *err = DR_ENOMEM;
        return NULL;
    }
    dr_udp_port_t *p = dr_udp_port_init(storage, size, local_addr, port, transport, err);
    if (p == NULL)
        free(storage);
    return p;
}

void dr_udp_port_free(dr_udp_port_t *p)
{
    dr_udp_port_deinit(p);
    free(p);
}
