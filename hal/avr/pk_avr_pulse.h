/*
 * pk_avr_pulse.h — the AVR backend's step pulse as an inline function, for
 * the step generator to compile into its step path (a board's board.mk:
 * -DPK_SG_PULSE_INC='"pk_avr_pulse.h"' -DPK_SG_PULSE_FN=pk_avr_step_pulse8_inline,
 * see pk_stepgen.c) and for pk_avr_timer.c's pk_avr_step_pulse8 (the same
 * body out of line: the ops table's step_pulse). A call from the step path
 * costs its register saves besides the call itself; inline, the step event
 * calls nothing.
 *
 * The lines go active at once and compare unit B's interrupt returns them to
 * idle width ticks later (pk_avr_timer.c has the whole scheme). Only state of
 * the backend instance (ctx, which is always pk_avr_board, the image's one
 * instance: reached at its fixed address) and the board's registers.
 */
#ifndef PLOTKIN_PK_AVR_PULSE_H
#define PLOTKIN_PK_AVR_PULSE_H

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"
#include "pk_avr.h"

/** Pulses this short (ticks) are timed inside step_pulse instead of by the
 *  compare B interrupt (writing OCRB takes a few ticks). */
#define PK_AVR_PULSE_SPIN 3u

/** [interrupts off] Compare B's interrupt is enabled: a pulse is high, to
 *  end at pulse_end (set and cleared with it: the pulse's own flag). */
static inline __attribute__((always_inline)) uint8_t pk_avr_pulse_armed(void)
{
    return (uint8_t)(PK_BOARD_STEP_TIMSK & _BV(PK_BOARD_PULSE_OCIE));
}

/** [interrupts off] The pulse's lines to idle: the writes prepared at its
 *  start (pk_board_step_write(mask, idle levels) as per-port masks, what the
 *  compare B vector does in assembly, pk_avr_timer.c). */
static inline __attribute__((always_inline)) void pk_avr_pulse_lines_idle(const struct pk_avr *a)
{
    /* (port | m) ^ v: the lines of m to 1, then those at 1 during the
     * pulse (v, within m) to 0; the port's other lines unchanged */
    if (a->pulse_m0 != 0u)
        PK_BOARD_STEP_PORT0 = (uint8_t)((PK_BOARD_STEP_PORT0 | a->pulse_m0) ^ a->pulse_v0);
#ifdef PK_BOARD_STEP_PORT1
    if (a->pulse_m1 != 0u)
        PK_BOARD_STEP_PORT1 = (uint8_t)((PK_BOARD_STEP_PORT1 | a->pulse_m1) ^ a->pulse_v1);
#endif
}

/** [interrupts off] The pulse's lines back to idle, compare B's interrupt off. */
static inline __attribute__((always_inline)) void pk_avr_pulse_end(struct pk_avr *a)
{
    pk_avr_pulse_lines_idle(a);
    PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK & (uint8_t)~_BV(PK_BOARD_PULSE_OCIE));
}

/** [interrupts off] The pulse's end tick has come (16-bit counter time: a
 *  pulse is at most 32,767 ticks). */
static inline __attribute__((always_inline)) uint8_t pk_avr_pulse_due(const struct pk_avr *a)
{
    return (int16_t)(PK_BOARD_STEP_TCNT - a->pulse_end) >= 0;
}

/** pk_avr_step_pulse8 (pk_avr.h) inline: raw levels on the step lines of
 *  mask now, their complement width_ticks (<= 32,767 used) later. Always
 *  PK_HAL_OK. [ISR][MAIN] */
static inline __attribute__((always_inline)) int pk_avr_step_pulse8_inline(void *ctx, uint8_t mask,
                                                                           uint8_t levels,
                                                                           uint16_t width_ticks)
{
    /* ctx is always the one backend instance (pk_avr.h): its fields at
     * fixed addresses, no pointer register (the AVR's X has no displacement) */
    (void)ctx;
    struct pk_avr *a = &pk_avr_board;
    uint16_t w = width_ticks > 0x7FFFu ? 0x7FFFu : width_ticks;
    uint8_t s = SREG;
    cli();
    if (pk_avr_pulse_armed())
        pk_avr_pulse_end(a); /* (the core never overlaps pulses) */
    /* pk_board_step_write(mask, levels) port by port (a port without a
     * line of mask is not written), and what the end's writes need, per
     * port the bits of mask and those of them set now (the idle levels,
     * ~levels & mask, are the others), so that the compare B vector only
     * applies them */
    const uint8_t m0 = pk_board_step_bits0(mask);
    const uint8_t v0 = (uint8_t)(pk_board_step_bits0(levels) & m0);
    if (m0 != 0u)
        PK_BOARD_STEP_PORT0 = (uint8_t)((PK_BOARD_STEP_PORT0 & (uint8_t)~m0) | v0);
#ifdef PK_BOARD_STEP_PORT1
    const uint8_t m1 = pk_board_step_bits1(mask);
    const uint8_t v1 = (uint8_t)(pk_board_step_bits1(levels) & m1);
    if (m1 != 0u)
        PK_BOARD_STEP_PORT1 = (uint8_t)((PK_BOARD_STEP_PORT1 & (uint8_t)~m1) | v1);
#endif
    a->pulse_end = (uint16_t)(PK_BOARD_STEP_TCNT + w);
    a->pulse_m0 = m0;
    a->pulse_v0 = v0;
#ifdef PK_BOARD_STEP_PORT1
    a->pulse_m1 = m1;
    a->pulse_v1 = v1;
#endif
    if (w <= PK_AVR_PULSE_SPIN) {
        while (!pk_avr_pulse_due(a))
            ;
        pk_avr_pulse_lines_idle(a);
    } else {
        PK_BOARD_PULSE_OCR = a->pulse_end;
        PK_BOARD_STEP_TIMSK = (uint8_t)(PK_BOARD_STEP_TIMSK | _BV(PK_BOARD_PULSE_OCIE));
    }
    SREG = s;
    return PK_HAL_OK;
}

#endif
