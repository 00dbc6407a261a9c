/*
 * pk_avr.h — the HAL backend shared by plotkin's AVR boards (Klipper's
 * src/avr/): pin writes, the step timer, critical sections, the UART and the
 * pen servo, on top of one board's hal/avr/<board>/board.h, which alone names
 * the pins, timers and vectors (compiled with -Ihal/avr/<board>).
 *
 * One image drives one machine, so there is exactly one backend instance,
 * pk_avr_board, the only object of the image outside the caller-owned
 * structs: interrupt vectors take no argument, so the ISRs reach their state
 * through it. Everything else stays in struct pk_app (hal/pk_app.h).
 *
 * Step timer (pk_avr_timer.c): a free-running 16-bit timer at
 * PK_BOARD_TICK_HZ (2 MHz), extended to 48 bits by its overflow interrupt; the
 * callback runs from compare A's interrupt at the tick it asked for. An event
 * due within PK_AVR_TIMER_LEAD ticks when the previous callback returns is
 * not armed for its tick (the compare could be passed before it is written)
 * but a few ticks later, for the next interrupt: one interrupt runs one
 * callback (the main loop gets in between), no event is ever early and none
 * is lost. Step pulses end
 * by compare B's interrupt (the HAL's step_pulse), so a step is one callback.
 *
 * Calling contexts are those of struct pk_hal_ops (hal.h); everything here
 * that the main loop calls saves SREG and disables interrupts around what
 * the ISRs also touch.
 */
#ifndef PLOTKIN_PK_AVR_H
#define PLOTKIN_PK_AVR_H

#include <stdint.h>
#include "hal.h"
#include "pk_uart.h"

/** Events closer than this (ticks) are not armed for their tick on the
 *  compare unit (it could be passed before the write lands): one found due
 *  at the interrupt's entry is waited for inside it, one due when the
 *  callback returns is armed PK_AVR_TIMER_GAP ticks on. Any value is safe: an
 *  event whose compare value the counter passed while it was being written
 *  is run at once. */
#define PK_AVR_TIMER_LEAD 4u

/** The backend instance (private members: use the functions and the ops). */
struct pk_avr {
    struct pk_hal hal;            /**< what the core uses: ops, ctx = this, polarity */
    /* step timer */
    pk_hal_timer_cb cb;           /**< set by timer_start (MAIN, ISR off) */
    void *cb_arg;
    uint32_t next;                /**< tick of the pending callback, clock bits 0..31 (ISR) */
    volatile uint16_t ovf_lo;     /**< timer overflows: clock bits 16..31 ... (the */
    volatile uint16_t ovf_hi;     /**< ... and 32..47; overflow ISR writes, read with ISR off) */
    volatile uint8_t armed;       /**< compare interrupt enabled */
#ifdef PK_AVR_STEP_INC
    uint8_t cb_inline;            /**< cb is the one the step interrupt runs inline
                                       (pk_avr_step.h; timer_start decides) */
#endif
    /* step pulse (compare B) */
    /* (armed: compare B's interrupt enabled, pk_avr_pulse_armed) */
    uint16_t pulse_end;           /**< TCNT at which the pulse ends */
    uint8_t pulse_m0;             /**< port 0's bits of the pulse's lines (0: no write) ... */
    uint8_t pulse_v0;             /**< ... those of them it raised (within pulse_m0): the
                                       end writes port 0 = (port 0 | m0) ^ v0 */
    uint8_t pulse_m1;             /**< the same for port 1 (boards with */
    uint8_t pulse_v1;             /**< PK_BOARD_STEP_PORT1; board.h) */
    /* inputs (pk_avr_inputs.c, boards with PK_BOARD_INPUTS) */
    pk_hal_input_cb in_cb;        /**< edge callback (input_watch, MAIN, ISR off) */
    void *in_arg;
    volatile uint8_t in_step;     /**< the step callback runs (step ISR): an edge waits */
    volatile uint8_t in_pend;     /**< an edge came meanwhile: reported after it */
    /* serial */
    struct pk_uart *uart;         /**< rings of the UART (pk_avr_uart_start) */
    /* servo (the pen): the last spindle value (M3 S) is its down position */
    uint16_t pen_value;           /**< last spindle_write value (0: full scale) */
    uint8_t pen_down;             /**< last tool_write level */
    volatile uint16_t servo_ocr;  /**< compare value to apply at the next safe point */
    volatile uint8_t servo_phase; /**< pk_avr_servo8.c: period of the 5-period frame */
};

/** The image's one backend instance (defined in pk_avr_hal.c). */
extern struct pk_avr pk_avr_board;

/** Set up pins, step timer, servo (pen up) and the UART registers (receive
 *  interrupt still off) and fill a->hal. MAIN, interrupts off. */
void pk_avr_init(struct pk_avr *a);

/** Attach the UART rings and enable the receive interrupt. MAIN. */
void pk_avr_uart_start(struct pk_avr *a, struct pk_uart *u);

/** Start the transmitter if bytes are queued (call after every main-loop
 *  iteration). MAIN. */
void pk_avr_uart_kick(struct pk_avr *a);

/* ---- parts of the ops table, one file each (pk_avr_hal.c fills the table) -- */
/** Step timer (pk_avr_timer.c). */
void pk_avr_timer_init(struct pk_avr *a);
int pk_avr_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick);
int pk_avr_timer_stop(void *ctx);
uint64_t pk_avr_clock_ticks(void *ctx);
/** The HAL's step_pulse: raw levels on the step lines of mask now, their
 *  complement width_ticks (<= 32,767) later from compare B's interrupt.
 *  [ISR][MAIN] */
int pk_avr_step_pulse(void *ctx, uint32_t mask, uint32_t levels, uint32_t width_ticks);
/** The same with 8-bit masks and a 16-bit width (<= 32,767 used), out of
 *  line; the step generator of the AVR boards compiles its body inline
 *  instead (pk_avr_pulse.h; their board.mk: -DPK_SG_PULSE_INC,
 *  -DPK_SG_PULSE_FN=pk_avr_step_pulse8_inline, see pk_stepgen.c), without
 *  the ops table or a call. [ISR][MAIN] */
int pk_avr_step_pulse8(void *ctx, uint8_t mask, uint8_t levels, uint16_t width_ticks);

/** Pen servo (pk_avr_servo8.c or pk_avr_servo16.c, as the board's source
 *  list chooses): value_q16 = fraction of the board's pulse range
 *  PK_BOARD_SERVO_MIN_US .. PK_BOARD_SERVO_MAX_US. [ISR][MAIN] */
void pk_avr_servo_init(struct pk_avr *a);
int pk_avr_servo_write(void *ctx, uint16_t value_q16);

/** Input lines (pk_avr_inputs.c; a board whose board.h defines
 *  PK_BOARD_INPUTS): raw levels, bits of enum pk_hal_input. [ISR][MAIN] */
int pk_avr_input_read(void *ctx, uint32_t *raw_levels);
/** Edge reports from the board's pin-change / external interrupts. [MAIN] */
int pk_avr_input_watch(void *ctx, pk_hal_input_cb cb, void *arg);
/** The report of an edge that came while the step callback ran (in_pend),
 *  once it has returned: the step ISR, interrupts off. */
void pk_avr_input_pending(struct pk_avr *a);

/** EEPROM store (pk_avr_nvm.c): the whole EEPROM, blocking. [MAIN] */
uint32_t pk_avr_nvm_size(void *ctx);
int pk_avr_nvm_read(void *ctx, uint32_t offset, uint8_t *buf, size_t len);
int pk_avr_nvm_write(void *ctx, uint32_t offset, const uint8_t *buf, size_t len);

/** Serial line (pk_avr_uart.c). */
void pk_avr_uart_init(struct pk_avr *a);

#endif
