/*
 * sim_sched.h — the simulator's clock and scheduler: one thread, simulated
 * time, deterministic.
 *
 * A firmware has two contexts: the main loop and the step-timer callback
 * (an interrupt on a microcontroller). The simulator interleaves them on a
 * simulated clock in a single thread: the main loop runs one iteration at the
 * current tick, then time advances and every timer callback that falls due in
 * the meantime runs at exactly its due tick. Nothing depends on the host's
 * speed or on wall time, so the same input gives the same pin trace, byte for
 * byte, every run.
 *
 * Callbacks only ever run between two main-loop iterations, never inside
 * one; a critical section (irq_save/irq_restore) is therefore always
 * honoured, and the scheduler checks that it is balanced.
 *
 * A second source of interrupts (pk_sim_sched_set_irq: the GPIO chip's input
 * edges) runs the same way: at its due tick, between timer callbacks (before
 * a callback due at the same tick), never inside a callback or a main-loop
 * iteration.
 *
 * struct pk_sim_sched provides the "base" HAL members: timer, clock and
 * critical sections (pin members are NULL; the gpiod backend drives pins and
 * forwards the rest here). One instance per simulated machine.
 */
#ifndef PLOTKIN_SIM_SCHED_H
#define PLOTKIN_SIM_SCHED_H

#include <stdint.h>
#include "hal.h"

/** What one main-loop iteration tells the scheduler. */
enum pk_sim_main_status {
    PK_SIM_DONE = -1,  /**< the program is finished: stop once the timer is idle */
    PK_SIM_IDLE = 0,   /**< nothing to do until a timer callback has run */
    PK_SIM_BUSY = 1    /**< call again after main_period ticks */
};

/** Interrupt source: the tick its next interrupt is due (<= now: at once),
 *  UINT64_MAX for none. */
typedef uint64_t (*pk_sim_irq_due_fn)(void *arg, uint64_t now_ticks);
/** Interrupt source: run the interrupt handler at now. */
typedef void (*pk_sim_irq_fn)(void *arg, uint64_t now_ticks);

/** One main-loop iteration at simulated time now; returns enum pk_sim_main_status. */
typedef int (*pk_sim_main_fn)(void *arg, uint64_t now_ticks);

/** Why pk_sim_sched_run returned. */
enum pk_sim_run_status {
    PK_SIM_RUN_FINISHED = 0,  /**< main said DONE and the timer is stopped */
    PK_SIM_RUN_TIME_LIMIT = 1,/**< max_ticks of simulated time passed */
    PK_SIM_RUN_STUCK = 2,     /**< main idle with no timer armed for idle_limit ticks */
    PK_SIM_RUN_RUNAWAY = 3,   /**< a callback kept rescheduling itself at the same tick */
    PK_SIM_RUN_IRQ_IMBALANCE = 4 /**< a main iteration left a critical section open */
};

struct pk_sim_sched {
    uint64_t now;              /**< simulated time, ticks */
    uint32_t tick_hz;          /**< ticks per second */
    uint32_t main_period;      /**< ticks between busy main-loop iterations */
    uint32_t idle_period;      /**< ticks to advance when main is idle and no timer is armed */
    uint64_t idle_limit;       /**< ticks of such idleness before giving up (STUCK) */
    /* timer */
    pk_hal_timer_cb cb;
    void *cb_arg;
    uint64_t due;
    uint8_t armed;
    uint8_t in_callback;
    uint32_t generation;       /**< bumped by start/stop, so a stop inside a callback sticks */
    /* the other interrupt source (or NULL) */
    pk_sim_irq_due_fn irq_due;
    pk_sim_irq_fn irq_run;
    void *irq_arg;
    uint64_t irqs;             /**< its interrupts run */
    /* bookkeeping */
    uint32_t irq_depth;
    uint64_t callbacks;        /**< timer callbacks run */
    uint64_t main_iterations;
    uint64_t main_due;         /**< tick of the next main-loop iteration */
    uint64_t idle_since;       /**< start of an idle spell with no timer (UINT64_MAX: none) */
};

/** Initialise at tick 0. main_period and idle_period must be >= 1. */
void pk_sim_sched_init(struct pk_sim_sched *s, uint32_t tick_hz, uint32_t main_period);

/** Set the second interrupt source (due NULL: none). */
void pk_sim_sched_set_irq(struct pk_sim_sched *s, pk_sim_irq_due_fn due, pk_sim_irq_fn run, void *arg);

/** Fill *out with the base HAL of s (timer, clock, irq; no pins). */
void pk_sim_sched_hal(struct pk_sim_sched *s, struct pk_hal *out);

/** The simulated clock, for the libgpiod mock: arg is the struct pk_sim_sched. */
uint64_t pk_sim_sched_clock(void *arg);

/**
 * Run the main loop and the timer until the program is done or max_ticks of
 * simulated time have passed (0: no limit). Returns enum pk_sim_run_status.
 * After PK_SIM_RUN_TIME_LIMIT a further call resumes exactly where the run
 * stopped: slicing a run changes nothing in it (several machines can be
 * interleaved in one process).
 */
int pk_sim_sched_run(struct pk_sim_sched *s, pk_sim_main_fn main_fn, void *arg, uint64_t max_ticks);

/**
 * Advance simulated time to `until`, running every callback due on the way
 * (at its own tick). For tests that drive the timer without a main loop.
 * Returns PK_SIM_RUN_FINISHED or PK_SIM_RUN_RUNAWAY.
 */
int pk_sim_sched_advance(struct pk_sim_sched *s, uint64_t until);

#endif
