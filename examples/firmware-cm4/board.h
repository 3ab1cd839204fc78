/* SPDX-License-Identifier: MIT */
/*
 * What the example firmware's main loop needs from its board: a clock
 * (startup.c's SysTick) and a drgate transport (transport.c).
 */
#ifndef BOARD_H
#define BOARD_H

#include <stdint.h>

#include "drgate/transport.h"

/* Microseconds since reset (1 ms SysTick steps). */
uint64_t board_now_us(void);
/* Counts the SysTick interrupts (startup.c calls it every millisecond). */
void board_tick(void);
/* Sleeps until the next interrupt (WFI). */
void board_idle(void);
/* The board's network as a drgate transport (transport.c). */
dr_transport_t board_transport(void);

#endif /* BOARD_H */
