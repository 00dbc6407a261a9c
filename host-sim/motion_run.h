/*
 * motion_run.h — drive a struct pk_machine through a program on the recording
 * HAL (host only), and read the step trace back. Used by the motion tests and
 * bench/motion_time; reusable by the simulator.
 *
 * The main loop is simulated: every poll_ticks the producer offers requests
 * (only every feed_every-th poll, to model a slow sender) and
 * pk_machine_poll() runs; in between, the timer callbacks run on the
 * simulated clock. Repeatable: no threads, no wall clock.
 */
#ifndef PLOTKIN_MOTION_RUN_H
#define PLOTKIN_MOTION_RUN_H

#include <stddef.h>
#include <stdint.h>
#include "hal_record.h"
#include "pk_motion.h"

enum pk_mrun_type { MR_FEED = 0, MR_RAPID, MR_PEN_DOWN, MR_PEN_UP, MR_DWELL, MR_END, MR_SMOOTH };

struct pk_mrun_op {
    uint8_t type;            /* enum pk_mrun_type */
    pk_um_t p[PK_AXES];      /* MR_FEED/MR_RAPID target */
    uint32_t arg;            /* feed µm/min, dwell ms */
    struct pk_smooth_cfg smooth; /* MR_SMOOTH */
};

struct pk_mrun_opts {
    uint64_t poll_ticks;     /* main-loop period (default 20 µs of ticks) */
    uint32_t feed_every;     /* producer runs every n-th poll (default 1) */
    size_t stop_after;       /* offer only the first n ops, then stop sending (0 = all) */
    uint64_t max_ticks;      /* give up after (default 600 s) */
    uint64_t hold_at;        /* if non-zero: feed hold at this tick ... */
    uint64_t resume_at;      /* ... and resume at this tick */
    uint32_t yield_every;    /* if non-zero: the machine's yield flag (pk_machine_set_yield)
                                is set on every n-th poll, as a realtime byte would */
    uint64_t ovr_at;         /* if non-zero: at this tick set the overrides ... */
    uint16_t ovr_feed_pct, ovr_rapid_pct; /* ... to these (pk_machine_set_override) */
};

struct pk_mrun_result {
    uint64_t end_tick;       /* tick when the machine became idle with all ops sent */
    size_t sent;             /* ops accepted */
    uint64_t efull;          /* EFULL answers the producer saw */
    uint64_t polls;          /* pk_machine_poll calls */
    uint32_t most_planned;   /* most line blocks one poll planned (pk_machine_lines_planned) */
    int timed_out;
};

/** Run ops on m (already initialised on rec->hal). */
struct pk_mrun_result pk_mrun(struct pk_machine *m, struct pk_rec *rec,
                              const struct pk_mrun_op *ops, size_t n,
                              const struct pk_mrun_opts *o);

/** Rising step edges of one axis in the log: times (ticks) and signed
 *  direction (+1/-1, from the logical dir level then). Arrays malloc'd;
 *  returns the count. dir_invert/step_invert as in rec->hal. */
size_t pk_mrun_edges(const struct pk_rec *rec, unsigned axis, uint64_t **t, int8_t **dir);

#endif
