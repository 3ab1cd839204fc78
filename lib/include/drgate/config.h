/* SPDX-License-Identifier: MIT */
/*
 * drgate config: the compile-time bounds of the EtherNet/IP client.
 *
 * The client allocates nothing after it is set up, and nothing at all when
 * the application gives it storage (dr_client_init): every table and
 * buffer has a bound fixed here. Each one may be overridden with -D on the
 * compiler command line (or in a header included first); the library and
 * every file that includes drgate/client.h must see the same values, since
 * DR_CLIENT_STORAGE_SIZE is computed from them. docs/firmware.md gives the
 * memory each setting costs.
 */
#ifndef DRGATE_CONFIG_H
#define DRGATE_CONFIG_H

/* Class 1 connections per client (default 16). Each costs about
 * 2 x DR_CLIENT_IO_MAX bytes of data, a UDP frame (DR_CLIENT_UDP_BUF) and
 * ~250 bytes of state. */
#ifndef DR_CLIENT_MAX_CONNS
#define DR_CLIENT_MAX_CONNS 16
#endif

/* The largest Class 1 data a connection carries, each way (default 476:
 * the combined layout's T->O image, drgate/layout.h; at least 144, the
 * largest assembly). Each connection has two buffers of it. */
#ifndef DR_CLIENT_IO_MAX
#define DR_CLIENT_IO_MAX 476
#endif

/* Requests in flight per client (default 8): explicit requests plus the
 * Forward Opens and Forward Closes of the connections. */
#ifndef DR_CLIENT_MAX_REQS
#define DR_CLIENT_MAX_REQS 8
#endif

/* TCP output buffer in bytes (default 2048): encapsulated messages queued
 * while the socket cannot take them. At least one message (624 bytes). */
#ifndef DR_CLIENT_TX_BUF
#define DR_CLIENT_TX_BUF 2048
#endif

/* One Class 1 datagram in bytes (default 600): the largest assembly with
 * its CPF header fits in 180. */
#ifndef DR_CLIENT_UDP_BUF
#define DR_CLIENT_UDP_BUF 600
#endif

/* Datagrams received per call when the transport has udp_recv_batch
 * (default 8); each costs DR_CLIENT_UDP_BUF bytes. Without a batch receive
 * only the first buffer is used: firmware may set 1. */
#ifndef DR_CLIENT_RX_BATCH
#define DR_CLIENT_RX_BATCH 8
#endif

/* Clients that can share one UDP port (dr_udp_port_t, default 32: as many
 * robots as drgatewayd takes, GW_MAX_ROBOTS; each costs a pointer). */
#ifndef DR_UDP_PORT_MAX_CLIENTS
#define DR_UDP_PORT_MAX_CLIENTS 32
#endif

/* Longest host name or address the client copies, with its NUL
 * (default 256). */
#ifndef DR_CLIENT_HOST_MAX
#define DR_CLIENT_HOST_MAX 256
#endif

/* Room in the storage sizes beyond what the structures of this version
 * need (default 1024: DR_CLIENT_STORAGE_SIZE grows by it and
 * DR_UDP_PORT_STORAGE_SIZE by a quarter of it), so that a later
 * libdrgate.so of the same soname, whose client has grown, still fits in
 * the storage a program compiled against this header reserves
 * (docs/api-changes.md, "ABI"). Firmware, which links the library it is
 * compiled with, may set 0. */
#ifndef DR_STORAGE_RESERVE
#define DR_STORAGE_RESERVE 1024
#endif

#endif /* DRGATE_CONFIG_H */
