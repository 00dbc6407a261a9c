/*
 * pk_motion_step.h — pk_machine_timer_cb (pk_motion.h) as an inline function,
 * pk_machine_timer_cb_inline, for a board whose step-timer interrupt
 * compiles the step path into itself instead of calling the callback
 * (hal/avr: board.mk -DPK_AVR_STEP_INC='"pk_avr_step.h"', see
 * pk_avr_timer.c). The same code as the callback (pk_sg_step.h); the
 * timer still takes pk_machine_timer_cb (hal.h's contract), and the
 * interrupt runs this inline only for that callback.
 */
#ifndef PLOTKIN_PK_MOTION_STEP_H
#define PLOTKIN_PK_MOTION_STEP_H

#include "pk_motion.h"
#include "pk_sg_step.h"

/** pk_machine_timer_cb inline (arg: the struct pk_machine). [ISR] */
static inline SG_INLINE uint32_t pk_machine_timer_cb_inline(void *arg, uint32_t now_ticks)
{
    struct pk_machine *m = arg;
    return pk_sg_isr_inline(&m->sg, m->hal, now_ticks);
}

#endif
