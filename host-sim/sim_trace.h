/*
 * sim_trace.h — the pin trace of a simulated machine, its CSV form, and the
 * decoder that turns it back into motion and checks it against the timing
 * limits of stepper drivers.
 *
 * Recording: the libgpiod mock reports every line value change with the
 * simulated tick; pk_trace_sink (a pk_gpiod_mock_sink_fn) maps the line
 * offset to a signal (X.step, Y.dir, enable, pen, ...) using the board's
 * gpiod configuration and appends an edge. Levels are RAW pin levels, as a
 * logic analyser would see them; the first event of each signal is the level
 * it took when requested.
 *
 * Decoding: polarity is applied (logical 1 = step active, positive direction,
 * driver enabled, pen down); each step activation moves the axis one step in
 * the direction the direction line shows at that moment. The decoder checks
 * every pulse:
 *   - high (active) time >= min_high_ns,
 *   - low time between pulses >= min_low_ns,
 *   - direction set-up: direction change to the next step activation >= dir_setup_ns,
 *   - direction hold: step activation to the next direction change >= dir_hold_ns,
 * and reports every violation, with time, axis, measured and required ns.
 *
 * Speeds and accelerations from the decoded steps: sim_rate.h.
 *
 * Host-only code (heap, stdio, doubles are fine here).
 */
#ifndef PLOTKIN_SIM_TRACE_H
#define PLOTKIN_SIM_TRACE_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include "hal.h"
#include "gpiod/pk_gpiod.h"

enum pk_sig_kind { PK_SIG_STEP = 0, PK_SIG_DIR = 1, PK_SIG_ENABLE = 2, PK_SIG_PEN = 3 };

/** One recorded level change (or initial level). */
struct pk_trace_edge {
    uint64_t t;       /**< tick */
    uint8_t kind;     /**< enum pk_sig_kind */
    uint8_t axis;     /**< axis for step/dir/enable (shared enable: 0); 0 for pen */
    uint8_t level;    /**< raw pin level 0/1 */
    uint8_t initial;  /**< 1: level taken when the line was requested */
};

/** Called for every edge as it is recorded (streaming consumers). */
typedef void (*pk_trace_edge_fn)(void *arg, const struct pk_trace_edge *e);

struct pk_trace {
    struct pk_trace_edge *e;  /**< heap array (only with keep) */
    size_t n, cap;            /**< n counts every edge, kept or not */
    int keep;                 /**< 1: store the edges in e[] (default after init) */
    pk_trace_edge_fn on_edge; /**< if not NULL: every edge, as it is recorded */
    void *on_edge_arg;
    uint32_t tick_hz;
    int oom;                  /**< an append failed for lack of memory */
    uint32_t unmapped;        /**< events on lines that map to no signal */
    int16_t map[64];          /**< line offset -> kind << 4 | axis, -1 none */
};

/** Empty trace that keeps its edges; no line mapped, no consumer. */
void pk_trace_init(struct pk_trace *t, uint32_t tick_hz);
/** Map the lines of a gpiod board configuration to signals. */
void pk_trace_map_gpiod(struct pk_trace *t, const struct pk_gpiod_cfg *cfg);
void pk_trace_free(struct pk_trace *t);
/** Record one edge: to on_edge, and to e[] if keep (0, or -1 out of memory). */
int pk_trace_add(struct pk_trace *t, uint64_t tick, enum pk_sig_kind kind, unsigned axis,
                 int level, int initial);
/** pk_gpiod_mock_sink_fn: arg is the struct pk_trace. */
void pk_trace_sink(void *arg, unsigned int offset, int value, uint64_t t, int initial);

/** Signal name for CSV and reports: "X.step", "Y.dir", "enable", "Z.enable", "pen". */
const char *pk_trace_signal_name(enum pk_sig_kind kind, unsigned axis, int shared_enable,
                                 char *buf, size_t len);

/**
 * Write the trace as CSV: a comment line with tick_hz, a header
 * `tick,time_s,signal,level,initial`, then one row per edge in order.
 * Deterministic text (no host-dependent formatting). Returns 0 or -1 on I/O error.
 */
int pk_trace_write_csv(const struct pk_trace *t, FILE *f, int shared_enable);

/** The same, streaming: the header, then one row per call. */
void pk_trace_csv_header(FILE *f, uint32_t tick_hz);
void pk_trace_csv_row(FILE *f, const struct pk_trace_edge *e, uint32_t tick_hz, int shared_enable);

/** Driver timing limits, ns. */
struct pk_timing_limits {
    uint32_t min_high_ns;
    uint32_t min_low_ns;
    uint32_t dir_setup_ns;
    uint32_t dir_hold_ns;
};
/** DRV8825 data sheet figures (the strictest of the common plotter drivers:
 *  A4988 1 us / 1 us / 200 ns / 200 ns; TMC2209 100 ns / 100 ns / 20 ns / 20 ns). */
#define PK_TIMING_DRV8825 { 1900u, 1900u, 650u, 650u }

enum pk_violation_kind { PK_VIOL_HIGH = 0, PK_VIOL_LOW, PK_VIOL_SETUP, PK_VIOL_HOLD };

struct pk_violation {
    uint64_t t;        /**< tick of the edge where it was detected */
    uint8_t kind;      /**< enum pk_violation_kind */
    uint8_t axis;
    uint64_t got_ns;   /**< measured */
    uint32_t limit_ns; /**< required minimum */
};

/** Violations kept in struct pk_decoded.viol (the rest are only counted). */
#define PK_VIOL_KEEP 10000u

/** One decoded step. */
struct pk_step_event {
    uint64_t t;
    uint8_t axis;
    int8_t dir;       /**< +1 / -1 */
    uint8_t pen;      /**< logical pen level at that moment (1 = down) */
    uint8_t enabled;  /**< the axis driver was enabled (1 if no enable line) */
};

struct pk_decode_cfg {
    uint32_t tick_hz;
    unsigned axes;
    uint32_t step_invert, dir_invert, enable_invert, pen_invert; /**< as in struct pk_hal */
    int shared_enable;   /**< 1: one enable line (recorded as axis 0) serves all axes */
    struct pk_timing_limits lim;
};

struct pk_decoded {
    int64_t pos[PK_HAL_MAX_AXES];      /**< final position, steps */
    uint64_t steps[PK_HAL_MAX_AXES];   /**< pulses per axis */
    struct pk_step_event *ev;          /**< every step, in time order (heap) */
    size_t n_ev;
    struct pk_violation *viol;         /**< the first PK_VIOL_KEEP violations, in time order (heap) */
    size_t n_viol;                     /**< violations found (all counted; min(n_viol, PK_VIOL_KEEP) kept) */
    uint64_t steps_while_disabled;     /**< steps while the axis driver was disabled */
    uint64_t t_last;                   /**< tick of the last edge */
    uint8_t pen;                       /**< final logical pen level */
};

/** Called for every decoded step, in time order. */
typedef void (*pk_step_fn)(void *arg, const struct pk_step_event *ev);

/** Streaming decoder: feed it edges one by one (e.g. as pk_trace's on_edge). */
struct pk_decoder {
    struct pk_decode_cfg cfg;
    struct pk_decoded *out;            /**< results accumulate here */
    int keep_events;                   /**< 1: also store every step in out->ev */
    pk_step_fn on_step;                /**< if not NULL: every step as it is decoded */
    void *on_step_arg;
    int oom;                           /**< an allocation failed (results incomplete) */
    uint8_t step[PK_HAL_MAX_AXES], dir[PK_HAL_MAX_AXES], en[PK_HAL_MAX_AXES], pen;
    uint64_t t_rise[PK_HAL_MAX_AXES], t_fall[PK_HAL_MAX_AXES], t_dir[PK_HAL_MAX_AXES];
    size_t cap_ev, cap_viol;
};

/** Start decoding into *out (cleared). */
void pk_decoder_init(struct pk_decoder *d, const struct pk_decode_cfg *cfg, struct pk_decoded *out,
                     int keep_events);
/** One edge, in time order. Returns 0, or -1 out of memory. */
int pk_decoder_push(struct pk_decoder *d, const struct pk_trace_edge *e);
/** pk_trace_edge_fn adapter: arg is the struct pk_decoder. */
void pk_decoder_edge(void *arg, const struct pk_trace_edge *e);

/** Decode a stored trace (keeps every step in out->ev). Returns 0, or -1 out
 *  of memory. Free with pk_decoded_free. */
int pk_decode(const struct pk_trace *t, const struct pk_decode_cfg *cfg, struct pk_decoded *out);
void pk_decoded_free(struct pk_decoded *d);

/** "min high", "min low", "dir setup", "dir hold". */
const char *pk_violation_name(enum pk_violation_kind k);

#endif
