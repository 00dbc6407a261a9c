/*
 * pk_posix_timer.h — timer, clock and main loop for plotkin on a Linux board.
 *
 * The "base" HAL under the gpiod backend on a real board: a monotonic clock
 * (clock_gettime(CLOCK_MONOTONIC) in ticks of tick_hz), a one-shot timer
 * whose callback is run from the same thread as the main loop, and trivial
 * critical sections (there is no second thread to exclude). pk_posix_run is
 * the loop: it runs the main-loop function, then any callback that is due,
 * busy-waiting (with short sleeps when the next callback is far) so that
 * step edges come as close to their tick as Linux allows. For steadier edges
 * run it with SCHED_FIFO and mlockall (pk_posix_realtime).
 *
 * It has the same main-function contract as the simulator's scheduler
 * (sim_sched.h), so the same job code runs on both.
 *
 * Edge sources (the gpiod backend's input events): an optional irq_poll
 * function is called on every turn of the loop, before each due callback and
 * while waiting for one, in the same thread, so it never runs inside a
 * callback (hal.h's rule for the edge context).
 */
#ifndef PLOTKIN_PK_POSIX_TIMER_H
#define PLOTKIN_PK_POSIX_TIMER_H

#include <stdint.h>
#include "hal.h"

struct pk_posix_timer {
    uint32_t tick_hz;
    uint64_t origin_ns;     /**< CLOCK_MONOTONIC at init: tick 0 */
    pk_hal_timer_cb cb;
    void *cb_arg;
    uint64_t due;
    uint8_t armed;
    uint32_t generation;
    uint32_t irq_depth;
    uint64_t late_max;      /**< largest lateness of a callback seen, ticks */
    void (*irq_poll)(void *arg); /**< optional edge source, see above (NULL: none) */
    void *irq_arg;
};

/** Initialise with tick 0 = now. tick_hz 1..1e9. */
void pk_posix_timer_init(struct pk_posix_timer *p, uint32_t tick_hz);

/** Fill *out with the base HAL (timer, clock, irq; no pins). */
void pk_posix_timer_hal(struct pk_posix_timer *p, struct pk_hal *out);

/** main_fn as in sim_sched.h: returns -1 done, 0 idle, 1 busy. */
typedef int (*pk_posix_main_fn)(void *arg, uint64_t now_ticks);

/**
 * Run until main_fn returns -1 with the timer stopped, or *stop becomes
 * non-zero (e.g. set by a SIGINT handler). Returns 0 finished, 1 stopped.
 */
int pk_posix_run(struct pk_posix_timer *p, pk_posix_main_fn main_fn, void *arg,
                 volatile int *stop);

/** Best effort: SCHED_FIFO priority and locked memory. 0, or -errno. */
int pk_posix_realtime(void);

#endif
