/*
 * pk_arm.h — what plotkin's Cortex-M images share (hal/arm/): the start-up
 * code (pk_arm_start.c: reset handler, .data copy, .bss clear, the default
 * handler), main() (pk_arm_main.c: the controller of hal/pk_app.h and its
 * loop), and the functions every Cortex-M board file provides, alone naming
 * its registers, pins and vectors (hal/arm/<board>/).
 *
 * One image drives one machine, so the board has one backend instance, the
 * only object of the image outside the caller-owned structs (interrupt
 * handlers take no argument).
 */
#ifndef PLOTKIN_PK_ARM_H
#define PLOTKIN_PK_ARM_H

#include "hal.h"
#include "pk_uart.h"

/** Clocks, pins, step timer, servo (pen up), serial registers (receive
 *  interrupt still off); returns the board's HAL instance. MAIN, once. */
const struct pk_hal *pk_board_init(void);

/** Attach the UART rings and enable the receive interrupt. MAIN. */
void pk_board_uart_start(struct pk_uart *u);

/** Start the transmitter if bytes are queued. MAIN, after every iteration. */
void pk_board_uart_kick(void);

/** Interrupts on / off for the whole core (PRIMASK). */
static inline void pk_arm_irq_enable(void) { __asm__ volatile("cpsie i" ::: "memory"); }
static inline uint32_t pk_arm_irq_save(void)
{
    uint32_t p;
    __asm__ volatile("mrs %0, primask\n\tcpsid i" : "=r"(p)::"memory");
    return p;
}
static inline void pk_arm_irq_restore(uint32_t p) { __asm__ volatile("msr primask, %0" ::"r"(p) : "memory"); }

/** The reset handler (pk_arm_start.c), for the board's vector table. */
void pk_arm_reset(void);
/** Every exception without a handler of its own: stops here, drivers as
 *  they were (pk_arm_start.c). */
void pk_arm_default_handler(void);

#endif
