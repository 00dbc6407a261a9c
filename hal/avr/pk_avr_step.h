/*
 * pk_avr_step.h — the step path compiled into the AVR step-timer interrupt
 * (a board's board.mk: -DPK_AVR_STEP_INC='"pk_avr_step.h"', read by
 * pk_avr_timer.c). The AVR images run one controller, app (pk_avr_main.c),
 * whose machine is the step timer's one client: timer_start is called with
 * pk_machine_timer_cb and &app.m, whose HAL is the backend instance's. For
 * exactly that callback, argument and HAL the interrupt runs what the
 * callback runs, pk_sg_isr(&app.m.sg, hal, now), inline (pk_sg_isr_inline,
 * firmware/pk_sg_step.h: the same code) instead of calling it: no call
 * frames, and the step generator's state and the HAL at fixed addresses
 * (lds/sts, no pointer registers). Any other callback is called as hal.h
 * says.
 */
#ifndef PLOTKIN_PK_AVR_STEP_H
#define PLOTKIN_PK_AVR_STEP_H

#include "pk_app.h"
#include "pk_avr.h"
#include "pk_motion.h"
#include "pk_sg_step.h"

/** The image's controller (pk_avr_main.c). Weak: the backend alone (the
 *  self test, tests/avr/hal_selftest.c) links without it, and its timer
 *  callback, never pk_machine_timer_cb, is called as usual. */
extern struct pk_app app __attribute__((weak));

/** The callback (and its argument) the interrupt runs inline. */
#define PK_AVR_STEP_CB pk_machine_timer_cb
#define PK_AVR_STEP_ARG (&app.m)
/** [ISR] The callback's body, for PK_AVR_STEP_ARG driving the backend
 *  instance's HAL (PK_AVR_STEP_HAL: timer_start checks all three). */
#define PK_AVR_STEP_HAL (&pk_avr_board.hal)
#define PK_AVR_STEP_FN(now) pk_sg_isr_inline(&PK_AVR_STEP_ARG->sg, PK_AVR_STEP_HAL, (now))

#endif
