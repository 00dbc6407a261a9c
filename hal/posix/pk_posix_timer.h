/*
 * pk_posix_timer.h — timer, clock and main loop for plotkin on a Linux board.
 *
 * The "base" HAL under the gpiod backend on a real board: a monotonic clock
 * (clock_gettime(CLOCK_MONOTONIC) in ticks of tick_hz), a one-shot timer
 * whose callback is run from the same thread as the main loop, and trivial
 * critical sections (there is no second thread to exclude). pk_posix_run is
 * the loop: it runs the main-loop function, then any callback that is due,
 * sleeping (clock_nanosleep to an absolute time) until 100 µs before the next
 * callback while the main function is idle and busy-waiting the rest, so
 * that step edges come as close to their tick as Linux allows without a
 * SCHED_FIFO loop using its whole core (which the kernel's RT throttling
 * answers with 50 ms stalls every second). For steadier edges
 * run it with SCHED_FIFO and mlockall (pk_posix_realtime). A callback is
 * called with the tick it really runs at (>= its scheduled tick, as the AVR
 * and Cortex-M timers do), so a late step still gets its full pulse width and
 * the step generator moves its schedule (counted in its `late`) instead of
 * firing missed steps back to back; how late each edge is written against
 * its scheduled tick (running_due) is what the board's timing benchmark
 * measures (bench/gpiod_timing.py). After a late callback the next one may
 * already be due; min_gap_ticks keeps it at least that far from the return
 * of the previous one in real time (so also when the process was preempted
 * inside a callback, between reading the clock and writing the lines), so a late step pulse's fall is not followed at once by
 * the next rise (a driver needs its minimum low time and direction set-up
 * however late the loop ran).
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
    uint64_t running_due;   /**< while a callback runs: the tick it was scheduled for */
    uint8_t in_cb;          /**< 1 while a callback runs (for an edge recorder) */
    uint32_t starts;        /**< timer_start calls (each arming of the step timer) */
    uint32_t callbacks;     /**< callbacks run */
    uint64_t min_gap_ticks; /**< 0, or the least time between two callbacks (set by the
                                 board: its step pulse / direction set-up), see below */
    uint64_t ran_at;        /**< private: tick the last callback returned at */
    uint64_t main_max;      /**< longest main-function call seen, ticks (callbacks wait
                                 for it: the loop is one thread) */
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

/** Nanoseconds on CLOCK_MONOTONIC since tick 0 (the real clock the ticks
 *  are read from, at full resolution). Any context. */
uint64_t pk_posix_timer_ns(const struct pk_posix_timer *p);

/**
 * Ask for real-time behaviour: SCHED_FIFO at half the highest priority for
 * the calling process, then mlockall(MCL_CURRENT | MCL_FUTURE) (no page
 * fault in the step loop). Both are attempted; each may be refused (EPERM
 * without CAP_SYS_NICE / an RLIMIT_RTPRIO, ENOMEM or EPERM past
 * RLIMIT_MEMLOCK without CAP_IPC_LOCK).
 * @param[out] sched_err  0 if SCHED_FIFO is in force, else the errno
 * @param[out] lock_err   0 if memory is locked, else the errno
 * @return 0 if both took effect, -1 otherwise. Calling context: MAIN, once,
 *         before the loop.
 */
int pk_posix_realtime(int *sched_err, int *lock_err);

#endif
