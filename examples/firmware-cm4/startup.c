/* SPDX-License-Identifier: MIT */
/*
 * Reset and interrupts of a bare Cortex-M4: the vector table, .data copied
 * from flash and .bss cleared before main, and a 1 ms SysTick (the core's
 * own timer: no vendor library needed for the example).
 */
#include <stdint.h>
#include <string.h>

#include "board.h"

#define CORE_HZ 16000000u /* the internal RC oscillator after reset */
#define SYST_CSR (*(volatile uint32_t *)0xE000E010u)
#define SYST_RVR (*(volatile uint32_t *)0xE000E014u)
#define SYST_CVR (*(volatile uint32_t *)0xE000E018u)

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);
void Reset_Handler(void);
void Default_Handler(void);
void SysTick_Handler(void);

static volatile uint32_t ticks_ms;

void Reset_Handler(void)
{
    memcpy(&_sdata, &_sidata, (size_t)((char *)&_edata - (char *)&_sdata));
    memset(&_sbss, 0, (size_t)((char *)&_ebss - (char *)&_sbss));
    SYST_RVR = CORE_HZ / 1000u - 1u;
    SYST_CVR = 0;
    SYST_CSR = 7u; /* core clock, interrupt, on */
    main();
    for (;;)
        board_idle();
}

void Default_Handler(void)
{
    for (;;)
        ;
}

void SysTick_Handler(void)
{
    board_tick();
}

void board_tick(void)
{
    ticks_ms++;
}

uint64_t board_now_us(void)
{
    return (uint64_t)ticks_ms * 1000u;
}

void board_idle(void)
{
    __asm__ volatile("wfi");
}

/* Initial stack pointer, then the handlers (ARMv7-M: 16 system entries). */
typedef void (*vector_t)(void);
__attribute__((section(".isr_vector"), used)) static const vector_t vectors[16] = {
    (vector_t)(uintptr_t)&_estack, Reset_Handler,
    Default_Handler, Default_Handler, Default_Handler, Default_Handler, Default_Handler,
    0, 0, 0, 0,
    Default_Handler, Default_Handler, 0, Default_Handler, SysTick_Handler,
};
