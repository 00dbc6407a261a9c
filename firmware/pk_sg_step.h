/*
 * pk_sg_step.h — the step path of the step generator (pk_sg_isr, pk_stepgen.h)
 * as an inline function, pk_sg_isr_inline, for pk_stepgen.c's pk_sg_isr and
 * for a board whose timer interrupt compiles the step path into itself
 * (hal/avr: PK_AVR_STEP_INC, pk_avr_step.h). Called through the HAL's
 * timer callback, a step event pays two call frames of register saves (the
 * vector's and pk_sg_isr's); inline in the vector, the registers it really
 * uses are saved once. The same code either way: the host builds run it
 * through pk_sg_isr.
 *
 * The rare paths (a chunk's end, alarms, watches, the first call after
 * arming, a HAL without step_pulse on a build with PK_SG_HW_PULSE=1) stay
 * out of line in pk_stepgen.c (pk_sgi_*: the step path's internals, not an
 * interface; call pk_sg_isr). Include only from a step path: it defines
 * static functions and macros (SG_*).
 */
#ifndef PLOTKIN_PK_SG_STEP_H
#define PLOTKIN_PK_SG_STEP_H

#include <stdbool.h>
#include <stdint.h>
#include "hal.h"
#include "pk_stepgen.h"

/* The paths that run once per chunk or on a fault stay out of line: the step
 * path pays for their registers only when it takes them. The watch paths
 * likewise: with none armed the step path pays only its byte test; armed
 * with nothing to do (hard limits on a board with edge reports, no switch
 * closed), a few more byte tests and no call. */
#if defined(__GNUC__) || defined(__clang__)
#define SG_COLD __attribute__((noinline, cold))
#define SG_NOINLINE __attribute__((noinline))
#define SG_INLINE __attribute__((always_inline))
#else
#define SG_COLD
#define SG_NOINLINE
#define SG_INLINE
#endif

/* PK_SG_HW_PULSE=1: a build whose HAL ends the step pulses itself (the AVR
 * boards); see pk_sgi_pulse_low. */
#ifndef PK_SG_HW_PULSE
#define PK_SG_HW_PULSE 0
#endif

/* Where a hardware-ended pulse is, from now (the core keeps a line low at
 * least as long as it was high): the step that raised it was at
 * low_until - 2 pulse_ticks. 0: none in flight; 1: the pulse is high
 * (*wait = ticks until it ends); 2: it has ended, the line must stay low
 * for *wait more ticks. */
static inline SG_INLINE uint8_t pulse_state(const struct pk_stepgen *sg, uint32_t now, uint32_t *wait)
{
    if (!sg->pulse_hot)
        return 0u;
    uint32_t ahead = sg->low_until - now;
    if (ahead == 0u || ahead > 2u * sg->pulse_ticks)
        return 0u; /* passed (or, after a long idle, stale) */
    if (ahead > sg->pulse_ticks) {
        *wait = ahead - sg->pulse_ticks;
        return 1u;
    }
    *wait = ahead;
    return 2u;
}

/* The step path's out-of-line parts (pk_stepgen.c). [ISR] */
uint32_t pk_sgi_alarm(struct pk_stepgen *sg, uint8_t why);
int32_t pk_sgi_watch_event(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t mask);
uint32_t pk_sgi_watch_stop(struct pk_stepgen *sg);
uint32_t pk_sgi_chunks(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now);
void pk_sgi_restart(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now);

/* One axis of the Bresenham step (isr_bresenham): unrolled, so that every
 * bit and field is a constant (no shift loops, fixed displacements). */
#define SG_BRES_AXIS(sg, i, period, mask)                                                          \
    do {                                                                                           \
        int32_t a_ = (sg)->acc[i] + (int32_t)(sg)->inc[i];                                         \
        if (a_ >= 0) {                                                                             \
            a_ -= (period);                                                                        \
            (mask) = (uint8_t)((mask) | (1u << (i)));                                              \
        }                                                                                          \
        (sg)->acc[i] = a_;                                                                         \
    } while (0)

/* The axes due at this event (Bresenham over the block's events). Only the
 * axes of sg->bres: an axis driven with no increment and its accumulator
 * below 0 would neither step nor change it (and axes at and beyond sg->axes
 * never step). PK_AXES is 2 or 3 (pk_refine.h). */
static inline SG_INLINE uint8_t isr_bresenham(struct pk_stepgen *sg)
{
    uint8_t mask = 0u;
    const uint8_t b = sg->bres;
    if (b & 1u)
        SG_BRES_AXIS(sg, 0, (int32_t)sg->period, mask);
    if (b & 2u)
        SG_BRES_AXIS(sg, 1, (int32_t)sg->period, mask);
#if PK_AXES > 2
    if (b & 4u)
        SG_BRES_AXIS(sg, 2, (int32_t)sg->period, mask);
#endif
    return mask;
}

/* The emitted position: one step on every axis of mask, in its direction. */
static inline SG_INLINE void isr_count(struct pk_stepgen *sg, uint8_t mask, uint8_t dir)
{
    /* (an increment or a decrement: no +-1 constant built in 32 bits) */
    if (mask & 1u) {
        if (dir & 1u)
            sg->pos[0]++;
        else
            sg->pos[0]--;
    }
    if (mask & 2u) {
        if (dir & 2u)
            sg->pos[1]++;
        else
            sg->pos[1]--;
    }
#if PK_AXES > 2
    if (mask & 4u) {
        if (dir & 4u)
            sg->pos[2]++;
        else
            sg->pos[2]--;
    }
#endif
}

/* The HAL's step_pulse on the step path. A build that knows its HAL names
 * the function (PK_SG_PULSE_FN, same contract as ops->step_pulse with 8-bit
 * masks and a 16-bit width, min(pulse_ticks, 65,535)) and the step path
 * calls it directly: no table load, no indirect call, narrow arguments; with
 * PK_SG_PULSE_INC as well, a header of the HAL's that defines it inline (the
 * AVR boards: hal/avr/pk_avr_pulse.h, pk_avr_step_pulse8_inline), so the
 * step event makes no call and saves no registers for one. The table's
 * step_pulse must then be that HAL's (it decides hw_pulse). */
#ifdef PK_SG_PULSE_FN
#ifdef PK_SG_PULSE_INC
/* the board's header defines PK_SG_PULSE_FN inline (the AVR boards:
 * hal/avr/pk_avr_pulse.h): the step event calls nothing */
#include PK_SG_PULSE_INC
#else
int PK_SG_PULSE_FN(void *ctx, uint8_t mask, uint8_t levels, uint16_t width_ticks);
#endif
#define SG_STEP_PULSE(hal, mask, levels, w)                                                        \
    PK_SG_PULSE_FN((hal)->ctx, (mask), (levels), (uint16_t)((w) > 0xFFFFu ? 0xFFFFu : (w)))
#else
#define SG_STEP_PULSE(hal, mask, levels, w) (hal)->ops->step_pulse((hal)->ctx, (mask), (levels), (w))
#endif

/* The core's own pulse paths, for a HAL without step_pulse. Written once,
 * here: inline on the step path of such a build (the host's); in a build
 * whose HAL has step_pulse (PK_SG_HW_PULSE=1, the AVR boards) they are rare
 * (a table without step_pulse) and kept out of line, off the step path's
 * registers: defined only in pk_stepgen.c (PK_SG_PULSE_BODIES), declared for
 * the other units. */
#if PK_SG_HW_PULSE
#define SG_PULSE_LOW SG_NOINLINE
uint32_t pk_sgi_pulse_low(struct pk_stepgen *sg, const struct pk_hal *hal);
uint32_t pk_sgi_step_sw(struct pk_stepgen *sg, const struct pk_hal *hal, uint8_t mask);
#else
#define SG_PULSE_LOW static inline SG_INLINE
#endif

#if !PK_SG_HW_PULSE || defined(PK_SG_PULSE_BODIES)
/* The end of a pulse the core times itself (no step_pulse): lower the lines.
 * 0 to go on, else what the callback returns. */
SG_PULSE_LOW uint32_t pk_sgi_pulse_low(struct pk_stepgen *sg, const struct pk_hal *hal)
{
    const uint32_t all = (1u << sg->axes) - 1u;
    if (pk_hal_step_write(hal, all, 0u) != 0)
        return pk_sgi_alarm(sg, PK_ALARM_STEP_WRITE);
    sg->phase = PK_SGP_GAP;
    if (sg->kill) {
        /* a reset came while this pulse was high: it has had its full
         * width, the line is low, stop here */
        sg->kill = 0;
        sg->v_um_s = 0u;
        sg->busy = false;
        return PK_HAL_TIMER_STOP;
    }
    return 0u;
}

/* A step event on a HAL without step_pulse: the core raises the lines and
 * lowers them itself, pulse_ticks later (one more call). */
SG_PULSE_LOW uint32_t pk_sgi_step_sw(struct pk_stepgen *sg, const struct pk_hal *hal, uint8_t mask)
{
    if (pk_hal_step_write(hal, (1u << sg->axes) - 1u, mask) != 0)
        return pk_sgi_alarm(sg, PK_ALARM_STEP_WRITE);
    isr_count(sg, mask, sg->dir_cur);
    sg->phase = PK_SGP_PULSE;
    return sg->pulse_ticks;
}
#endif

/* The next event of the chunk running (left > 0): its tick from the
 * interval recurrence, never before earliest; returns the delay from now
 * (what the timer callback returns). */
static inline SG_INLINE uint32_t isr_schedule(struct pk_stepgen *sg, uint32_t now, uint32_t earliest)
{
    /* the event's time: t += I, I += A (32-bit, the fraction in 16 bits,
     * t_add's arithmetic on locals: stored once, read no more) */
    const int32_t I = sg->I;
    const uint16_t I_lo = (uint16_t)I;
    uint16_t nf = (uint16_t)(sg->next_f + I_lo);
    uint32_t nt = sg->next_t + (uint32_t)(I >> 16);
    if (nf < I_lo)
        nt++; /* the fraction's carry */
    sg->I = I + sg->A;
    sg->left--;
    /* Late by more than the interval itself (the timer callback was held
     * up, or the main loop published the chunk after its time): the
     * schedule moves to now instead of catching up, which would fire the
     * missed steps back to back at whatever rate the callback manages.
     * (next + I < now in Q16, with behind = now - next in ticks: I < 2^30,
     * so behind >= 2^15 is always late.) */
    const int32_t behind = (int32_t)(now - nt);
    if (behind > 0 && (behind >= 0x8000 || ((uint32_t)behind << 16) > (uint32_t)nf + (uint32_t)I)) {
        nt = now;
        nf = 0u;
        sg->late++;
    }
    sg->next_t = nt;
    sg->next_f = nf;
    uint32_t at = nt;
    if (nf & 0x8000u)
        at++; /* rounded to the nearest tick */
    if ((int32_t)(at - earliest) < 0)
        at = earliest;
    const int32_t dl = (int32_t)(at - now);
    return dl > 0 ? (uint32_t)dl : 0u;
}

static inline SG_INLINE uint32_t pk_sg_isr_inline(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now)
{
    if ((uint8_t)(sg->alarm | (uint8_t)sg->restart) != 0u) {
        if (sg->alarm != 0)
            return pk_sgi_alarm(sg, sg->alarm);
        pk_sgi_restart(sg, hal, now);
    }
    uint32_t earliest = now;
    const uint8_t phase = sg->phase;
    uint8_t raised = 0u; /* a pulse raised by this call */
    if (phase == PK_SGP_STEP_DUE) {
        uint8_t mask = isr_bresenham(sg);
        /* armed, and something to do: inputs to read, a watch fired, an axis locked */
        if (sg->watch != 0u && (sg->poll_in | sg->fired | sg->lock) != 0u) {
            int32_t w = pk_sgi_watch_event(sg, hal, mask);
            if (w < 0)
                return pk_sgi_watch_stop(sg);
            mask = (uint8_t)w;
        }
        if (!sg->hw_pulse && mask != 0u)
            return pk_sgi_step_sw(sg, hal, mask);
        /* (an event with no step, one of a block's fine events, raises
         * nothing and has no pulse to end, on either kind of HAL: a reset
         * then finds the machine between events, not in a pulse with no
         * line high: finding M10) */
        /* the backend ends the pulse: on to the next event in this call.
         * Phase PK_SGP_GAP and pulse_hot (with low_until) matter only if
         * this call ends before the next event is set up (the chunk's
         * end): written there, not on every step (pulse_hot was raised
         * and cleared in the same call) */
        if (mask != 0u) {
            const uint32_t pt = sg->pulse_ticks;
            earliest = now + 2u * pt;
            raised = 1u;
            if (SG_STEP_PULSE(hal, mask, (uint8_t)(mask & ~hal->step_invert), pt) != 0) {
                sg->phase = PK_SGP_GAP;
                sg->pulse_hot = 0u; /* (no pulse was raised) */
                return pk_sgi_alarm(sg, PK_ALARM_STEP_WRITE);
            }
            isr_count(sg, mask, sg->dir_cur);
        }
    } else if (phase == PK_SGP_PULSE) {
        uint32_t r = pk_sgi_pulse_low(sg, hal);
        if (r != 0u)
            return r;
    } else {
        uint32_t w;
        if (pulse_state(sg, now, &w) != 0u)
            earliest = sg->low_until; /* after a wait or a restart */
    }
    if (sg->left == 0u) {
        sg->phase = PK_SGP_GAP;
        if (raised) {
            sg->low_until = earliest;
            sg->pulse_hot = 1u;
        }
        sg->earliest = earliest;
        uint32_t r = pk_sgi_chunks(sg, hal, now);
        if (sg->left == 0u)
            return r;
        earliest = sg->earliest;
    }
    if (sg->pulse_hot)
        sg->pulse_hot = 0u; /* the next edge is after the low time */
    sg->phase = PK_SGP_STEP_DUE;
    return isr_schedule(sg, now, earliest);
}

#endif
