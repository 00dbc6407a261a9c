/*
 * sim_rate.h — per-axis step rate and acceleration estimated from a decoded
 * step trace, each with the bounds the trace's quantisation allows (host only).
 *
 * Model. Behind the pulses there is an ideal motion x(t) (in steps) of the
 * axis: the planned motion through the block ends, which are whole steps.
 * A decoded step instant i (tick t_i, position x_i after the step) differs
 * from it by at most
 *   - tau ticks in time (the step generator's timer rounding; default 1;
 *     `plotkin sim` adds the direction set-up $206, which can delay an edge), and
 *   - q_i steps in position: q_alone for a step alone on its tick, q_shared
 *     (default 1/2) for a step sharing its tick with another axis (it may be
 *     a minor axis: Bresenham rounds its position to the nearest step at
 *     each event; the position of a step instant is then within 1/2 step of
 *     the ideal line). q_alone defaults to 0: a step generator whose events
 *     are the dominant axis's steps. plotkin's is not (since finding M6 a
 *     block has 2 events per exact step of every axis, so an event may step
 *     a minor axis alone and the dominant axis is rounded like the others):
 *     `plotkin sim` sets q_alone = 1/2 (sim_run.c).
 * Every figure below is a function of whole ticks and whole steps, computed
 * with these bounds in interval arithmetic: "lo" is the least value the
 * ideal motion can have had given the trace, "hi" the largest.
 *
 * Speed over k intervals (k + 1 consecutive steps of the axis, k = 1 and
 * k = 15: "any 2 steps" and "any 16 steps"): v = |x_b - x_a| / (t_b - t_a), the
 * mean speed between two step instants, from the net displacement (so a
 * reversal inside the window counts as what it is). Bounds:
 *   v_lo = max(0, |n| - q_a - q_b) / (dt + 2 tau),
 *   v_hi = (|n| + q_a + q_b) / (dt - 2 tau).
 * The ideal motion's peak speed is at least its mean over any window, so
 * v_lo > v_max proves an overspeed; an ideal motion within v_max always gives
 * v <= v_max + (v - v_lo), which is the tolerance of the window. For a minor
 * axis over 2 steps (q = 1/2 at both ends) v_lo = 0: Bresenham may put two of
 * its steps on consecutive events whatever its speed, and the 16-step window
 * is the meaningful one; for a dominant (or single) axis over 2 steps the
 * tolerance is only the timer rounding.
 *
 * Acceleration from windowed velocities: the steps of the axis are cut into
 * successive windows, consecutive windows sharing their boundary step. For
 * two consecutive windows with mean velocities (signed) v1, v2 and centres
 * c1, c2 (the mid-times of their end instants):
 *   a = (v2 - v1) / (c2 - c1).
 * The reported acceleration (`accel`) uses windows of at least acc_steps
 * intervals AND at least acc_min_s (default 16 intervals and 20 ms), which
 * averages out the quantisation of minor axes; the proven peak (`accel_proven`)
 * is the largest least-|a| over that and six more window series of exactly
 * 2, 4, 8, 16, 32 and 64 intervals, where short windows catch short peaks
 * (a step burst, a junction's speed jump) wherever the quantisation allows.
 * For any motion, v2 - v1 is the integral of x'' against a non-negative kernel
 * of total mass c2 - c1, so a is a weighted mean of the acceleration: exact
 * for constant acceleration, never above the peak |x''|. Its bounds come from
 * the velocity bounds above (n +- (q_a + q_b), dt +- 2 tau) and the centres
 * (+- tau each): a_lo_abs, the least |a| the trace allows, > a_max proves an
 * over-acceleration. The quantisation error is about
 * 2 (q_a + q_b) / (L * D) for windows of length L and centre distance D
 * (q = 1/2: 2 / T^2 steps/s^2 at the 20 ms minimum, 5,000 steps/s^2; with
 * steps alone on their ticks, only tau counts).
 *
 * Units: steps/s and steps/s^2 times `scale` (set with pk_rate_set_scale,
 * e.g. mm per step, so the figures come out in mm/s and mm/s^2 with the
 * steps/mm in force; a scale change or pk_rate_reset starts new windows, so
 * no window mixes two scales).
 *
 * Streaming, O(1) memory per axis; feed the steps of one axis in time order.
 * Calling context: MAIN (host tools, tests).
 */
#ifndef PLOTKIN_SIM_RATE_H
#define PLOTKIN_SIM_RATE_H

#include <stddef.h>
#include <stdint.h>

/** Configuration of one axis's estimator. Zero members take the defaults. */
struct pk_rate_cfg {
    uint32_t tick_hz;          /**< ticks per second (required) */
    unsigned acc_steps;        /**< intervals per velocity window, at least (16) */
    double acc_min_s;          /**< duration of a velocity window, at least (0.020 s) */
    double q_shared;           /**< position bound of a step sharing its tick, steps (0.5) */
    double q_alone;            /**< position bound of a step alone on its tick, steps (0) */
    double tau_ticks;          /**< time bound of a step instant, ticks (1) */
    double v_limit;            /**< speed limit in scaled units/s for the counts (0: none) */
    double a_limit;            /**< acceleration limit, scaled units/s^2 (0: none) */
};

/** Bounds of one speed window (scaled units/s). */
struct pk_rate_speed { double v, lo, hi; uint64_t t; };
/** Bounds of one acceleration estimate (scaled units/s^2, signed). */
struct pk_rate_accel { double a, lo, hi, lo_abs; uint64_t t; };

/** The figures of one window length (speed) or of the acceleration. */
struct pk_rate_fig {
    uint64_t windows;          /**< windows measured */
    struct pk_rate_speed vmax; /**< the window with the largest measured speed */
    double lo_max;             /**< largest v_lo over all windows (proven speed) */
    uint64_t over;             /**< windows with v > v_limit (measured) */
    uint64_t proven_over;      /**< windows with v_lo > v_limit (beyond quantisation) */
};
struct pk_rate_afig {
    uint64_t windows;
    struct pk_rate_accel amax; /**< the estimate with the largest measured |a| */
    double lo_abs_max;         /**< largest least-|a| over all estimates */
    uint64_t over, proven_over;
};

#define PK_RATE_RING 16u
#define PK_RATE_SCALES 7u   /**< the reported series + 2, 4, ..., 64 intervals */

/** Private: one series of acceleration windows. */
struct pk_rate_series {
    unsigned w;              /* intervals per window, at least */
    double min_ticks;        /* duration, at least */
    int open, have_prev;
    uint64_t ws_t, ws_n; int64_t ws_x; double ws_q;  /* window start instant */
    double pv, pv_lo, pv_hi, pc;                       /* previous window: v, bounds, centre (ticks) */
};

/** One axis's estimator (members are read by reports and tests). */
struct pk_rate {
    struct pk_rate_cfg cfg;
    double scale;
    /* the last PK_RATE_RING step instants */
    uint64_t t[PK_RATE_RING];
    int64_t x[PK_RATE_RING];
    double q[PK_RATE_RING];
    uint64_t n;                /* steps since the last reset */
    int64_t pos;
    struct pk_rate_series ser[PK_RATE_SCALES]; /* acceleration windows */
    /* figures */
    struct pk_rate_fig speed2;   /**< over any 2 consecutive steps */
    struct pk_rate_fig speed16;  /**< over any 16 consecutive steps */
    struct pk_rate_afig accel;   /**< windows of >= acc_steps and >= acc_min_s */
    struct pk_rate_afig accel_proven; /**< every series: lo_abs_max is the proven peak, amax the
                                           estimate that proves most (its a and bounds),
                                           proven_over counts estimates with lo_abs > a_limit */
    uint64_t steps;              /**< steps fed in total */
    uint64_t zero_dt;            /**< windows of zero duration (impossible in a valid trace) */
};

/** The verdicts of an axis's figures, beyond the step quantisation (what the
 *  summary's limits line and `plotkin sim --json` report): over its max rate
 *  over any 2 or 16 steps; over its acceleration between windows of >= 20 ms;
 *  speed jumps, windows of 2-64 steps proving more than the acceleration
 *  (the junction velocity jump at a corner). Each false without its limit. */
static inline int pk_rate_over_speed(const struct pk_rate *e)
{
    return e->cfg.v_limit > 0.0 && (e->speed16.proven_over || e->speed2.proven_over);
}
static inline int pk_rate_over_accel(const struct pk_rate *e)
{
    return e->cfg.a_limit > 0.0 && e->accel.proven_over;
}
static inline int pk_rate_speed_jumps(const struct pk_rate *e)
{
    return e->cfg.a_limit > 0.0 && e->accel_proven.proven_over;
}

/** Start an estimator (figures cleared, scale 1). */
void pk_rate_init(struct pk_rate *r, const struct pk_rate_cfg *cfg);

/** Forget the windows (not the figures): the next step starts afresh. */
void pk_rate_reset(struct pk_rate *r);

/** Set the unit of the figures (units per step); starts new windows if it changes. */
void pk_rate_set_scale(struct pk_rate *r, double units_per_step);

/**
 * One step of the axis: tick, direction (+1/-1), and whether another axis
 * stepped on the same tick (shared: use q_shared instead of q_alone).
 */
void pk_rate_step(struct pk_rate *r, uint64_t tick, int dir, int shared);

/**
 * Feed a whole trace: n steps in time order (tick, axis < axes, dir +1/-1),
 * into r[0..axes-1] (initialised). Steps of several axes on one tick are
 * fed as shared. For tests on a recorded trace (e.g. hal_record's edges).
 */
void pk_rate_feed(struct pk_rate *r, unsigned axes, size_t n, const uint64_t *tick, const uint8_t *axis,
                  const int8_t *dir);

/**
 * The bounds of one speed window, for tests that check windows themselves:
 * n net steps between two step instants dt ticks apart, with position bounds
 * qa, qb (steps) and time bound tau (ticks); results in steps/s.
 * @return 0, or -1 if dt is 0
 */
int pk_rate_speed_bounds(int64_t n, uint64_t dt, double qa, double qb, double tau, uint32_t tick_hz,
                         struct pk_rate_speed *out);

/**
 * The bounds of one acceleration estimate from two consecutive windows
 * (instants a-b and b-c: n1 = x_b - x_a, n2 = x_c - x_b, ticks ta <= tb <= tc,
 * position bounds qa, qb, qc, time bound tau), in steps/s^2.
 * @return 0, or -1 if a window is not longer than 2 tau
 */
int pk_rate_accel_bounds(int64_t n1, int64_t n2, uint64_t ta, uint64_t tb, uint64_t tc, double qa,
                         double qb, double qc, double tau, uint32_t tick_hz, struct pk_rate_accel *out);

#endif
