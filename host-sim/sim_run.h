/*
 * sim_run.h — one complete simulated run: a machine's hardware (mock GPIO
 * chip + gpiod backend + scheduler + trace, sim_machine.h), the motion core
 * (struct pk_machine) on that HAL, a job feeding it a program (sim_job.h),
 * then the decoded trace and the figures of the summary.
 *
 * Used by `plotkin sim` and by the end-to-end tests; everything lives in the
 * caller's struct pk_sim_result (plus heap arrays freed by
 * pk_sim_result_free), so several runs can coexist in one process.
 *
 * Memory stays bounded on long runs: the pin edges stream into the decoder
 * (and to the CSV file, if asked) as they happen; speeds, accelerations and
 * the path deviation are measured step by step; only a thinned copy of the
 * executed path is kept for the SVG. Tests can ask to keep everything.
 */
#ifndef PLOTKIN_SIM_RUN_H
#define PLOTKIN_SIM_RUN_H

#include <stdio.h>
#include "sim_job.h"
#include "sim_machine.h"

struct pk_sim_opts {
    const char *chip;               /**< mock chip name, unique among live runs */
    const struct pk_sim_cfg *cfg;   /**< machine settings */
    const char *program;            /**< G-code text (or a polyline), when program_file is NULL */
    size_t len;
    FILE *program_file;             /**< if not NULL: the program, streamed from this file in
                                         bounded memory (sim_job.h); the caller closes it */
    const struct pk_gpiod_mock *fault; /**< fault plan for the chip, or NULL */
    struct pk_timing_limits lim;    /**< driver limits for the checks */
    uint64_t max_ticks;             /**< simulated time limit (0: 24 h) */
    FILE *progress;                 /**< progress lines, or NULL */
    unsigned rate_window;           /**< steps per speed estimate (0: 16) */
    int keep_trace;                 /**< 1: keep every pin edge in hw.trace.e (tests) */
    int keep_events;                /**< 1: keep every decoded step in dec.ev (tests) */
    FILE *trace_csv;                /**< if not NULL: every pin edge as CSV, as it happens */
    /** If not NULL: the firmware's main loop instead of the job's (e.g. the
     *  Grbl engine in `plotkin serve`); it drives r->m (the job is set up on
     *  an empty program and its counters are the caller's to fill). It must
     *  never return PK_SIM_DONE if the run is to go on until the caller stops. */
    pk_sim_main_fn main_fn;
    void *main_arg;
    int no_path;                    /**< 1: keep no executed path (memory stays flat) */
};

/** A point of the executed path kept for drawing (thinned to 0.1 mm). */
struct pk_sim_path_pt {
    double x_um, y_um;
    uint8_t pen;
};

struct pk_sim_result {
    struct pk_sim_opts opts;        /**< copy of the options (pointers shared) */
    struct pk_sim_hw hw;
    struct pk_machine m;
    struct pk_sim_job job;
    struct pk_decoded dec;          /**< pins decoded as the run goes */
    struct pk_decoder decoder;
    struct pk_rate_est rate[PK_AXES];
    struct pk_motion_cfg mcfg;
    struct pk_gpiod_cfg board;
    int shared_enable;
    /* executed path, measured as it is decoded */
    int64_t pos[PK_HAL_MAX_AXES];
    size_t dev_k;
    int step_pending;               /**< steps of tick step_t not yet measured */
    uint64_t step_t;
    struct pk_sim_path_pt *path;    /**< thinned executed path (heap) */
    size_t n_path, cap_path;
    double last_x, last_y;          /**< position before the latest step */
    int last_pen;
    int setup_failed;               /**< 1: hardware/machine setup failed (see err) */
    char err[200];
    int run_status;                 /**< enum pk_sim_run_status; -1 while running */
    pk_steps_t fw_steps[PK_AXES];   /**< position the firmware reports */
    uint64_t ticks;                 /**< simulated time at the end */
    double max_speed_mm_s[PK_AXES];
    double max_accel_mm_s2[PK_AXES];
    double deviation_um;            /**< executed vs commanded path (-1: no moves) */
};

/**
 * Run a program. Returns 0 when the run took place (whatever its outcome:
 * alarms, G-code errors, violations are in *r), -1 when setup failed (r->err
 * says why: e.g. the GPIO lines could not be requested). In both cases call
 * pk_sim_result_free(r) afterwards. r is large: static or heap storage.
 */
int pk_sim_run(const struct pk_sim_opts *o, struct pk_sim_result *r);

/**
 * The same in steps, so that several machines can be interleaved in one
 * process: pk_sim_start sets up (returns -1 on setup failure, see r->err),
 * pk_sim_advance runs up to `ticks` more simulated ticks (0: to the end) and
 * returns 1 once the run is over, pk_sim_finish decodes and measures.
 */
int pk_sim_start(const struct pk_sim_opts *o, struct pk_sim_result *r);
int pk_sim_advance(struct pk_sim_result *r, uint64_t ticks);
int pk_sim_finish(struct pk_sim_result *r);

void pk_sim_result_free(struct pk_sim_result *r);

/** Position (µm) of axis a after the decoded steps of r (from steps/mm). */
double pk_sim_steps_to_um(const struct pk_sim_result *r, unsigned a, int64_t steps);

#endif
