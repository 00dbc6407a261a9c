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
 * Memory stays flat however long the run: the pin edges stream into the
 * decoder (and to the CSV file, if asked) as they happen; each decoded step
 * instant (once every axis stepping at that tick has stepped) is measured at
 * once: speed and acceleration per axis (sim_rate.h), deviation from the
 * programmed path and from a second reference path (sim_path.h, windowed),
 * and a point of the SVG (sim_svg.h, streamed). The job hands its programmed
 * primitives to the path as it accepts them (struct pk_sim_prim_obs) and
 * waits while the path's window is full. Steps convert to millimetres with
 * the steps/mm in force when they are made (the machine's configuration at
 * that tick), so a `$100=` change in `plotkin serve` shows the right speeds.
 * What grows: the list of timing violations, capped at PK_VIOL_KEEP entries
 * (all are counted), and the trace / step event arrays if a test asks to keep
 * them (keep_trace, keep_events).
 */
#ifndef PLOTKIN_SIM_RUN_H
#define PLOTKIN_SIM_RUN_H

#include <stdio.h>
#include "sim_bound.h"
#include "sim_job.h"
#include "sim_machine.h"
#include "sim_path.h"
#include "sim_pen.h"
#include "sim_rate.h"
#include "sim_svg.h"

struct pk_sim_opts {
    const char *chip;               /**< mock chip name, unique among live runs */
    const struct pk_sim_cfg *cfg;   /**< machine settings */
    const char *program;            /**< G-code text (see pk_sim_polyline_to_gcode) */
    size_t len;
    const struct pk_gpiod_mock *fault; /**< fault plan for the chip, or NULL */
    struct pk_timing_limits lim;    /**< driver limits for the checks */
    uint64_t max_ticks;             /**< simulated time limit (0: 24 h) */
    FILE *progress;                 /**< progress lines, or NULL */
    int keep_trace;                 /**< 1: keep every pin edge in hw.trace.e (tests) */
    int keep_events;                /**< 1: keep every decoded step in dec.ev (tests) */
    FILE *trace_csv;                /**< if not NULL: every pin edge as CSV, as it happens */
    /** If not NULL: the firmware's main loop instead of the job's (e.g. the
     *  Grbl engine in `plotkin serve`); it drives r->m (the job is set up on
     *  an empty program and its counters are the caller's to fill). It must
     *  never return PK_SIM_DONE if the run is to go on until the caller stops. */
    pk_sim_main_fn main_fn;
    void *main_arg;
    struct pk_svg *svg;             /**< if not NULL: draw the run into it (sim_svg.h) */
    uint32_t path_cap;              /**< window of the programmed path, primitives (0: default) */
    /** If not NULL: called after each main-loop pass with how far the job has
     *  read its program (bytes), so a caller that mapped the file can let the
     *  pages behind go. */
    void (*input_read)(void *arg, size_t pos);
    void *input_arg;
    const struct pk_sim_input *inputs; /**< scripted input edges and switches (sim_machine.h) */
    size_t n_inputs;
    int hard_limits;                /**< 1: hard limits on from the start ($21=1) */
    int lower_bound;                /**< 1: compute lower_bound_s (sim_bound.h; memory grows
                                         with the longest pen-down piece) */
};

struct pk_sim_result {
    struct pk_sim_opts opts;        /**< copy of the options (pointers shared) */
    struct pk_sim_hw hw;
    struct pk_machine m;
    struct pk_sim_job job;
    struct pk_decoded dec;          /**< pins decoded as the run goes */
    struct pk_decoder decoder;
    struct pk_rate rate[PK_AXES];   /**< speed and acceleration per axis, mm/s, mm/s^2 */
    struct pk_path prog;            /**< the programmed path and the deviation from it */
    struct pk_path ref;             /**< a second reference (the smoothed curve), if fed */
    int ref_on;                     /**< ref is set up (pk_sim_ref_point was called) */
    struct pk_pen_cfg pen;          /**< how the executed path draws */
    struct pk_motion_cfg mcfg;
    struct pk_gpiod_cfg board;
    int shared_enable;
    /* the executed path, measured as it is decoded (private) */
    int64_t pos[PK_HAL_MAX_AXES];   /**< steps */
    double pos_um[PK_AXES];         /**< µm, with the steps/mm in force at each step */
    double base_um[PK_AXES];        /* position at the last steps/mm change */
    int64_t base_steps[PK_AXES];
    pk_spmm_q16_t spmm_q16[PK_AXES]; /* steps/mm in force */
    int tick_n;                     /* steps of tick tick_t not yet measured */
    uint64_t tick_t;
    uint8_t tick_axis[PK_HAL_MAX_AXES * 2];
    int8_t tick_dir[PK_HAL_MAX_AXES * 2];
    uint8_t tick_pen;
    uint64_t last_step_tick;
    struct pk_hal_ops ops;          /* the firmware's HAL ops, with spindle_write recorded */
    uint16_t spindle_q16;           /**< spindle / laser output now (0 = off) */
    uint64_t spindle_writes;        /**< spindle writes the firmware made */
    int ref_have_last;
    double ref_last[3];
    int setup_failed;               /**< 1: hardware/machine setup failed (see err) */
    char err[200];
    int run_status;                 /**< enum pk_sim_run_status; -1 while running */
    pk_steps_t fw_steps[PK_AXES];   /**< position the firmware reports */
    uint64_t ticks;                 /**< simulated time at the end */
    /* figures, filled by pk_sim_finish from rate[], prog, ref */
    double max_speed_mm_s[PK_AXES];  /**< over any 16 steps (rate[a].speed16) */
    double max_speed2_mm_s[PK_AXES]; /**< over any 2 steps (rate[a].speed2) */
    double max_accel_mm_s2[PK_AXES]; /**< windowed (rate[a].accel) */
    double deviation_um;            /**< max deviation from the programmed path (-1: no primitive) */
    double deviation_p95_um;        /**< its 95th percentile (sim_path.h) */
    double ref_deviation_um;        /**< the same against ref (-1: not fed) */
    double ref_deviation_p95_um;
    struct pk_bound bound;          /**< opts.lower_bound: the bound being collected */
    double lower_bound_s;           /**< its result, s (-1: not computed or out of memory) */
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

/**
 * The second reference path (e.g. the firmware's smoothed curve): one more
 * point of it, µm (X Y Z); new_stroke 1 starts a separate piece (no segment
 * from the previous point). Segments of it are matched like the programmed
 * path (sim_path.h; a window of 32,768 entries) and reported as "vs smoothed
 * curve". Returns 0, or -1 if its window could not be allocated. MAIN, during
 * the run. Memory: up to about 26 MB for the programmed path's window and grid
 * and 19 MB for this one, touched as they fill.
 */
int pk_sim_ref_point(struct pk_sim_result *r, const double p_um[3], int new_stroke, uint32_t line);

#endif
