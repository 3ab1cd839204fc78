/* SPDX-License-Identifier: MIT */
/*
 * The Linux conveniences of the client: storage from malloc, and the POSIX
 * transport when the configuration names none. Kept apart from client.c
 * so that firmware, which links neither malloc nor the POSIX transport,
 * leaves this object out (make check-firmware checks it).
 */
#include <stdlib.h>

#include "drgate/client.h"

dr_client_t *dr_client_new(const dr_client_config_t *cfg)
{
    if (cfg == NULL)
        return NULL;
    dr_client_config_t cc = *cfg;
    if (cc.transport.ops == NULL)
        cc.transport = dr_transport_posix();
    size_t size = dr_client_size();
    void *storage = malloc(size); /* malloc's alignment suits any type */
    if (storage == NULL)
        return NULL;
    dr_client_t *c = dr_client_init(storage, size, &cc, NULL);
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
            *err = DR_EFULL;
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
