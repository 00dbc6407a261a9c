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
 * Input: the program's text (a caller may map a file and let the pages
 * behind `pos` go), handed over a byte at a time as the engine takes it; the
 * job acts as a sender that strips what a sender must not send as program
 * text: bytes >= 0x80 and the
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
 * The job keeps no copy of the path: the engine's observer (pk_grbl_prim in
 * pk_grbl.h) gives every accepted programmed primitive before flattening, and
 * the job hands it on as an exact primitive (a line, an arc with its centre
 * and sweep, a G5/G5.1 Bézier; struct pk_path_prim of sim_path.h) with its
 * source line number and its pen state (sim_pen.h) to an observer (struct
 * pk_sim_prim_obs: the programmed path of sim_path.h, the SVG).
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
#include "sim_path.h"
#include "sim_pen.h"

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
    /* How the program draws (sim_pen.h), for the programmed path and the SVG. */
    unsigned laser_mode;           /**< $32 Grbl laser mode: 1 = G1 with M3/M4 and S > 0 burns, G0 never */
    int pen_z_on;                  /**< 1: the pen is down at Z <= pen_z_mm ($208=h; M3/M5 then ignored) */
    double pen_z_mm;               /**< $208 pen-down height, mm (sim only: not a firmware setting) */
};

/** The pen model of c (sim_pen.h): laser if $32=1, else Z if $208 is set, else the tool line. */
void pk_sim_cfg_pen(const struct pk_sim_cfg *c, struct pk_pen_cfg *out);

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

/**
 * Observer of the programmed path. on_prim gets every accepted move as one
 * primitive (struct pk_path_prim: a line, an arc, or the exact G5/G5.1
 * Bézier; `drawn` from sim_pen.h, `line` the source line number), in program
 * order, when its execution starts. room, if not NULL, says how many more
 * primitives the observer can take without losing any: the job hands the
 * engine no further line while it is 0 (the machine goes on running, which
 * makes room). MAIN.
 */
struct pk_sim_prim_obs {
    void (*on_prim)(void *arg, const struct pk_path_prim *p);
    size_t (*room)(void *arg);
    void *arg;
};

/** The exact primitive of an engine primitive (µm; Z 0 without a Z axis),
 *  drawn per pen. line is left to the caller. */
void pk_sim_prim_from_grbl(const struct pk_grbl_prim *g, const struct pk_pen_cfg *pen,
                           struct pk_path_prim *out);

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
    const char *text;
    size_t len, pos;               /**< the program and how far it has been read (bytes) */
    uint64_t bytes_in, file_size;
    int polyline, in_stroke, eof, tail_done, midline, last_cr;
    char lbuf[300];                /**< generated lines being handed to the engine */
    size_t lbuf_n, lbuf_i;
    unsigned src_line;             /**< source lines read */
    unsigned fifo[64];             /**< source line of each line given, not yet answered */
    unsigned fifo_head, fifo_n;
    unsigned lmap[64];             /**< source line of the engine's latest lines (by its number) */
    uint32_t eng_lines;            /**< lines given to the engine */
    char ans[24];
    unsigned ans_n;
    pk_um_t cur[PK_AXES];          /**< last requested position */
    uint8_t pen;                   /**< pen state commanded (M3/M4 on) */
    struct pk_pen_cfg pen_cfg;     /**< how moves are classified as drawn */
    struct pk_sim_prim_obs obs;    /**< the programmed path's observer (all NULL: none) */
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
    /* a further observer of the engine's primitives, as they are */
    pk_grbl_observer_fn raw_obs;
    void *raw_obs_ctx;
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

/** Install an observer of the engine's primitives as they are (pk_grbl.h),
 *  beside j->obs. */
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

#endif
