/*
 * sim_job.h — run a G-code program (or a plain polyline) through the whole
 * firmware as a board runs it: the program is streamed, byte by byte, into
 * the firmware's Grbl engine (pk_grbl.h: the same parser, interpreter, arc
 * and G5 flattening, answers and error numbers as `plotkin serve` and a
 * board), which drives the motion core (pk_motion.h) through its adapter
 * (pk_grbl_motion.h), on any HAL.
 *
 * A job is the producer side of the firmware's main loop: pk_sim_job_main is
 * one main-loop iteration (engine poll, machine poll) with the contract of
 * sim_sched.h's pk_sim_main_fn, so the simulator's scheduler runs it on
 * simulated time and the board's POSIX loop (hal/posix/pk_posix_timer.h) on
 * real time.
 *
 * Input in bounded memory: a file is read in 64 KiB pieces as the engine
 * takes bytes (never whole), a line at a time; the job acts as a sender that
 * strips what a sender must not send as program text: bytes >= 0x80 and the
 * realtime characters ? ! ~ Ctrl-X (inside comments they would be realtime
 * commands to Grbl), counted in rt_skipped. Each line gets the engine's one
 * answer; error:N answers are listed with their line number (Grbl's codes).
 * M0 is resumed at once (an operator pressing cycle start); after M2/M30
 * ("[MSG:Pgm End]") the rest of the file is not sent; an alarm ends the job.
 *
 * Machine settings come in Grbl's `$N=value` form (struct pk_sim_cfg, with a
 * typical pen plotter as the default) with the numbers, ranges and defaults
 * of the firmware's table (pk_grbl.h), so a `$$` dump from `plotkin serve` or
 * a board can be used as is.
 *
 * The job records the commanded path (every move the engine requested from
 * the machine: chords of arcs and curves included, pen state included) for
 * the SVG and the deviation check (that list grows with the program), and
 * passes the programmed primitives (before flattening) to an optional
 * observer (pk_sim_job_set_observer, see pk_grbl_prim in pk_grbl.h).
 *
 * Host-only code (stdio, heap, doubles for settings and reports).
 */
#ifndef PLOTKIN_SIM_JOB_H
#define PLOTKIN_SIM_JOB_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "pk_gcode.h"
#include "pk_grbl.h"
#include "pk_grbl_motion.h"
#include "pk_motion.h"

/**
 * Machine configuration in user units. `set` holds every `$N` setting in the
 * firmware's units and is the one source of truth for those without a named
 * member below; the named members mirror their settings and may be edited
 * (pk_sim_cfg_to_grbl takes them over `set`).
 */
struct pk_sim_cfg {
    unsigned axes;                 /**< axes driven (2..PK_AXES), default PK_AXES (not a $ setting) */
    double steps_per_mm[3];        /**< $100-$102, default 80 */
    double max_rate[3];            /**< $110-$112 mm/min, default 6000 6000 1500 */
    double accel[3];               /**< $120-$122 mm/s^2, default 1000 1000 500 */
    double travel[3];              /**< $130-$132 mm (soft limits, with $20=1: [-travel, 0]) */
    double junction_dev;           /**< $11 mm, default 0.01 */
    double step_pulse_us;          /**< $0 µs, default 10 */
    double tolerance;              /**< $12 smoothing tolerance mm, default 0.02 */
    unsigned smooth_mode;          /**< $200 0 off (G61), 1 fixed, 2 tolerance; default 2 */
    unsigned scheme;               /**< $201 0 B-spline, 1 DLG 4-point (fixed mode) */
    unsigned degree;               /**< $202 B-spline degree, default 3 */
    unsigned depth;                /**< $203 fixed mode depth, default 3 */
    unsigned sharp_deg;            /**< $204 corners turning more than this stay sharp, default 60 */
    unsigned pen_settle_ms;        /**< $205 dwell after a pen change, default 50 */
    double dir_setup_us;           /**< $206 direction set-up µs, default 1 */
    struct pk_grbl_settings set;   /**< every $N setting (firmware units) */
    double polyline_feed;          /**< feed for plain polyline files, mm/min, default 3000 */
    int force_smoothing;           /**< 1: ignore G61/G64 in programs (keep $200/$12) */
    uint32_t tick_hz;              /**< simulated timer frequency, default 1 MHz */
};

/** A typical pen plotter: the firmware's `$N` defaults (pk_grbl_settings_default). */
void pk_sim_cfg_default(struct pk_sim_cfg *c);

/**
 * Apply `$N=value` lines (blank lines and `;`/`#` comments allowed) with the
 * firmware's parser, table and rules. Returns 0, or -1 with "line N: reason"
 * in err. warn is unused (kept for callers).
 */
int pk_sim_cfg_parse(struct pk_sim_cfg *c, const char *text, char *err, size_t errlen, FILE *warn);

/**
 * The settings of c from / to the firmware's (pk_grbl.h). to_grbl takes
 * c->set and the named members over it, checking each against the table's
 * range: 0, or -1 with the reason in err (err may be NULL).
 */
void pk_sim_cfg_from_grbl(struct pk_sim_cfg *c, const struct pk_grbl_settings *s);
int pk_sim_cfg_to_grbl(const struct pk_sim_cfg *c, struct pk_grbl_settings *s, char *err,
                       size_t errlen);

/** Convert to the motion core's settings with the firmware's own conversion
 *  (pk_grbl_motion_cfg, as the Grbl engine does), then c->axes. Returns 0, or -1 with a reason. */
int pk_sim_cfg_motion(const struct pk_sim_cfg *c, struct pk_motion_cfg *out, char *err, size_t errlen);

/**
 * If text is a plain polyline file (every non-blank line two numbers `x y`,
 * `#` comments allowed, a blank line lifts the pen between strokes), return
 * an equivalent G-code program (heap, NUL-terminated): per stroke G0 to its
 * start, M3, G1 ... at `feed` mm/min, M5; then M2. Otherwise return NULL and
 * leave *is_polyline 0. (The job detects and converts polylines itself, a
 * line at a time; this is for callers that want the text.)
 */
char *pk_sim_polyline_to_gcode(const char *text, double feed, int *is_polyline);

/** One commanded move (XY, µm). */
struct pk_sim_move {
    pk_um_t a[2], b[2];
    uint8_t rapid;   /**< G0 */
    uint8_t pen;     /**< pen down while it runs */
};

struct pk_sim_gc_error { unsigned line; int code; };

/** A running job. Members are read by the report; set up with pk_sim_job_init*. */
struct pk_sim_job {
    struct pk_machine *m;
    const struct pk_sim_cfg *cfg;
    /* the firmware's Grbl engine, as a board runs it */
    struct pk_grbl g;
    struct pk_grbl_motion gm;
    uint8_t nvm_buf[PK_GRBL_NVM_BYTES];
    struct pk_grbl_ram_nvm ram;
    /* input (private) */
    FILE *f;                       /**< file source, or NULL for text */
    FILE *own_f;                   /**< a temporary copy of a pipe (closed by free) */
    const char *text;
    size_t len, pos;               /**< text source, or the read buffer's fill/position */
    char *rbuf;                    /**< file read buffer (heap, 64 KiB) */
    uint64_t bytes_in, file_size;
    int polyline, in_stroke, eof, tail_done, midline, last_cr;
    char lbuf[300];                /**< generated lines being handed to the engine */
    size_t lbuf_n, lbuf_i;
    unsigned src_line;             /**< source lines read */
    unsigned fifo[64];             /**< source line of each line given, not yet answered */
    unsigned fifo_head, fifo_n;
    char ans[24];
    unsigned ans_n;
    pk_um_t cur[PK_AXES];          /**< last requested position */
    uint8_t pen;                   /**< pen state commanded */
    int input_done, end_sent, finished;
    /* results */
    unsigned long lines, move_requests;
    unsigned long errors;
    struct pk_sim_gc_error err[32];  /**< the first errors */
    unsigned long alarms;
    int alarm;                     /**< enum pk_alarm of the (first) machine alarm, or -Grbl alarm code */
    char alarm_text[200];
    unsigned long segments;        /**< LINE blocks the planner queued (executed segments) */
    unsigned long pen_blocks;
    unsigned long rt_skipped;      /**< bytes of the file not sent (>= 0x80, ? ! ~ Ctrl-X) */
    unsigned long pauses;          /**< M0 pauses resumed */
    struct pk_sim_move *moves;     /**< commanded path (heap) */
    size_t n_moves, cap_moves;
    /* observer of programmed primitives */
    pk_grbl_observer_fn obs;
    void *obs_ctx;
    /* progress */
    FILE *progress;                /**< if not NULL: a progress line now and then */
    uint64_t next_progress_tick;
};

/**
 * Prepare a job on an initialised machine: the program is text (must outlive
 * the job). The engine starts on a fresh RAM store with cfg's settings and
 * reconfigures the machine with them (position kept). Call
 * pk_sim_job_free afterwards.
 */
void pk_sim_job_init(struct pk_sim_job *j, struct pk_machine *m, const struct pk_sim_cfg *cfg,
                     const char *text, size_t len);

/**
 * The same with the program read from f as it runs (f must stay open until
 * pk_sim_job_free; the job does not close it). A polyline file is detected
 * with a first pass and f rewound; a stream that cannot be rewound (a pipe)
 * is first copied to a temporary file. Returns 0, or -1 (I/O error, errno).
 */
int pk_sim_job_init_file(struct pk_sim_job *j, struct pk_machine *m, const struct pk_sim_cfg *cfg,
                         FILE *f);

/** Install an observer of the programmed primitives (see pk_grbl.h). */
void pk_sim_job_set_observer(struct pk_sim_job *j, pk_grbl_observer_fn fn, void *ctx);

/** One main-loop iteration (pk_sim_main_fn / pk_posix_main_fn). */
int pk_sim_job_main(void *arg, uint64_t now_ticks);

void pk_sim_job_free(struct pk_sim_job *j);

/** The machine's part of a main-loop iteration: pk_machine_poll, counting
 *  the blocks it queues (j->segments, j->pen_blocks). For main loops other
 *  than pk_sim_job_main that drive j->m (e.g. `plotkin serve`'s). */
void pk_sim_job_poll_machine(struct pk_sim_job *j);

/** Count a G-code error (line number, code); the first 32 are listed. */
void pk_sim_job_note_error(struct pk_sim_job *j, unsigned line, int code);

/** Record a commanded move to `to` (for main loops other than the job's). */
void pk_sim_job_record_move(struct pk_sim_job *j, const pk_um_t to[PK_AXES], int rapid);

/**
 * Largest distance (µm) from any of the points (x[i], y[i]) (µm) to the
 * commanded path (every move, both pen states). Points are matched against a
 * window of moves around the previous match first, and against every move
 * when that finds nothing within 2 µm, so the result is exact and close to
 * linear in the path length. Returns -1 if there are no moves.
 */
double pk_sim_job_deviation_um(const struct pk_sim_job *j, const double *x, const double *y,
                               size_t n);

/** One point of the same measure, streaming: *k carries the last match
 *  (start at 0). Returns the distance in µm, or -1 if there are no moves. */
double pk_sim_job_point_deviation(const struct pk_sim_job *j, size_t *k, double x, double y);

#endif
