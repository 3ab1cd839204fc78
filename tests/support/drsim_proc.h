/* SPDX-License-Identifier: MIT */
/* Test support: run the real drsim binary as a child process. */
#ifndef DRGATE_TEST_DRSIM_PROC_H
#define DRGATE_TEST_DRSIM_PROC_H

#include <stdbool.h>
#include <stdint.h>
#include <sys/types.h>

typedef struct {
    pid_t pid;
    uint16_t tcp_port;
    uint16_t udp_port;
    char address[16];
} drsim_proc_t;

/* Path of drsim next to the test binaries ($(B)/drsim), NULL if absent. */
const char *drsim_path(void);

/* A fresh pair of ports for one test (distinct per call and per process). */
void drsim_ports(uint16_t *tcp, uint16_t *udp);

/* Start drsim on 127.0.0.2 with extra options (NULL-terminated list) and
 * wait until it accepts TCP connections (at most 5 s). */
bool drsim_start(drsim_proc_t *p, const char *const *extra);
/* SIGTERM, wait (at most 5 s, then SIGKILL). Returns drsim's exit status. */
int drsim_stop(drsim_proc_t *p);

#endif
