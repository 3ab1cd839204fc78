/* SPDX-License-Identifier: MIT */
/*
 * gw_plain_server: the baseline for drgatewayd's Modbus throughput in
 * `make bench`. A plain select-loop libmodbus server, the way libmodbus's
 * own examples (tests/bandwidth-server-many-up.c) write one: a mapping
 * with the gateway's register counts (GW_AREA_SIZE of each kind), no robot,
 * no checks beyond libmodbus's own, one modbus_receive + modbus_reply per
 * readable client.
 *
 * usage: gw_plain_server PORT [ADDRESS]   (default address 127.0.0.1)
 * Runs until SIGTERM/SIGINT.
 */
#include <errno.h>
#include <modbus.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <unistd.h>

#include "modbus/regmap.h" /* GW_AREA_SIZE: the same counts as the gateway */

static volatile sig_atomic_t stop;

static void on_signal(int sig)
{
    (void)sig;
    stop = 1;
}

int main(int argc, char **argv)
{
    if (argc < 2 || argc > 3) {
        fprintf(stderr, "usage: gw_plain_server PORT [ADDRESS]\n");
        return 2;
    }
    int port = atoi(argv[1]);
    const char *addr = argc > 2 ? argv[2] : "127.0.0.1";
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal; /* no SA_RESTART: select returns EINTR */
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGINT, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    modbus_t *ctx = modbus_new_tcp(addr, port);
    modbus_mapping_t *map =
        modbus_mapping_new(GW_AREA_SIZE, GW_AREA_SIZE, GW_AREA_SIZE, GW_AREA_SIZE);
    if (ctx == NULL || map == NULL) {
        fprintf(stderr, "gw_plain_server: out of memory\n");
        return 1;
    }
    for (int i = 0; i < GW_AREA_SIZE; i++) {
        map->tab_registers[i] = (uint16_t)i;
        map->tab_input_registers[i] = (uint16_t)(0x8000 | i);
    }
    int server = modbus_tcp_listen(ctx, 128);
    if (server < 0) {
        fprintf(stderr, "gw_plain_server: listen on %s:%d: %s\n", addr, port,
                modbus_strerror(errno));
        return 1;
    }
    fd_set all;
    FD_ZERO(&all);
    FD_SET(server, &all);
    int fdmax = server;
    uint8_t query[MODBUS_TCP_MAX_ADU_LENGTH];
    printf("gw_plain_server: listening on %s:%d\n", addr, port);
    fflush(stdout);

    while (!stop) {
        fd_set rd = all;
        if (select(fdmax + 1, &rd, NULL, NULL, NULL) < 0) {
            if (errno == EINTR)
                continue;
            perror("gw_plain_server: select");
            return 1;
        }
        for (int fd = 0; fd <= fdmax; fd++) {
            if (!FD_ISSET(fd, &rd))
                continue;
            if (fd == server) {
                int c = accept(server, NULL, NULL);
                if (c < 0)
                    continue;
                if (c >= FD_SETSIZE) {
                    close(c);
                    continue;
                }
                FD_SET(c, &all);
                if (c > fdmax)
                    fdmax = c;
                continue;
            }
            modbus_set_socket(ctx, fd);
            int rc = modbus_receive(ctx, query);
            if (rc > 0) {
                modbus_reply(ctx, query, rc, map);
            } else if (rc == -1) {
                close(fd);
                FD_CLR(fd, &all);
                while (fdmax > server && !FD_ISSET(fdmax, &all))
                    fdmax--;
            }
        }
    }
    close(server);
    modbus_mapping_free(map);
    modbus_free(ctx);
    return 0;
}
