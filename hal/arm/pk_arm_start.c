/*
 * pk_arm_start.c — start-up of plotkin's Cortex-M images: copy .data from
 * flash, clear .bss, call main (the symbols come from the board's linker
 * script). No libc start-up: the firmware needs none.
 */
#include <stdint.h>
#include "pk_arm.h"

extern uint32_t _sidata[], _sdata[], _edata[], _sbss[], _ebss[];
int main(void);

void pk_arm_reset(void)
{
    const uint32_t *src = _sidata;
    for (uint32_t *d = _sdata; d < _edata;)
        *d++ = *src++;
    for (uint32_t *d = _sbss; d < _ebss;)
        *d++ = 0u;
    (void)main();
    for (;;)
        __asm__ volatile("wfi");
}

void pk_arm_default_handler(void)
{
    for (;;)
        __asm__ volatile("bkpt 0");
}
