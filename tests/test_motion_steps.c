/*
 * test_motion_steps.c — the motion core end to end on the recording HAL:
 * requests in, step/dir pulses out, checked against independent oracles
 * (double-precision rounding of the commanded positions, kinematics
 * formulas), never against numbers copied from the code under test.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "motion_run.h"
#include "th.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

int th_main(int argc, char **argv);

#define TICK_HZ 1000000u

static struct pk_machine M, M2;
static struct pk_rec R, R2;

static pk_spmm_q16_t spmm(double s) { return (pk_spmm_q16_t)llround(s * 65536.0); }

static struct pk_motion_cfg cfg_default(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    c.steps_per_mm_q16[0] = spmm(80.0);
    c.steps_per_mm_q16[1] = spmm(78.74);    /* not a whole number: rounding matters */
    for (int i = 0; i < 2; i++) {
        c.max_rate[i] = 6000000;            /* 6000 mm/min = 100 mm/s */
        c.accel[i] = 1000000;               /* 1000 mm/s^2 */
    }
    c.accel[1] = 600000;
    c.junction_dev_um = 20;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.pen_settle_ms = 5;
    c.pen_down_level = 1;
    return c;
}

/* Oracle: where the commanded µm puts an axis, in whole steps. */
static long oracle_steps(pk_um_t um, pk_spmm_q16_t s)
{
    return lround((double)um * ((double)s / 65536.0) / 1000.0);
}

static struct pk_mrun_op feed(pk_um_t x, pk_um_t y, uint32_t f)
{
    struct pk_mrun_op o;
    memset(&o, 0, sizeof o);
    o.type = MR_FEED;
    o.p[0] = x;
    o.p[1] = y;
    o.arg = f;
    return o;
}

static struct pk_mrun_op op_of(uint8_t type, uint32_t arg)
{
    struct pk_mrun_op o;
    memset(&o, 0, sizeof o);
    o.type = type;
    o.arg = arg;
    return o;
}

static void setup(struct pk_machine *m, struct pk_rec *r, const struct pk_motion_cfg *c, uint32_t hz)
{
    pk_rec_free(r);
    pk_rec_init(r, hz);
    int rc = pk_machine_init(m, c, &r->hal);
    TH_EXPECT_EQ(rc, PK_MOTION_OK);
}

/* Signed sum of the emitted edges of an axis. */
static long edge_sum(const struct pk_rec *r, unsigned axis, size_t *count)
{
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(r, axis, &t, &d);
    long s = 0;
    for (size_t k = 0; k < n; k++)
        s += d[k];
    free(t);
    free(d);
    if (count)
        *count = n;
    return s;
}

static void test_straight_moves_end_exactly_at_the_commanded_step(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    static const pk_um_t pts[][2] = {
        { 10000, 0 }, { 10000, 5000 }, { -3333, -1234 }, { -3332, -1234 }, /* a sub-step move */
        { 7, 13 }, { 25401, -12699 }, { 0, 0 }, { 1, 1 }, { 19999, 7 }
    };
    for (unsigned k = 0; k < TH_COUNT(pts); k++) {
        struct pk_mrun_op op = feed(pts[k][0], pts[k][1], 3000000);
        struct pk_mrun_result res = pk_mrun(&M, &R, &op, 1, NULL);
        TH_ASSERT(!res.timed_out);
        pk_steps_t p[PK_AXES];
        pk_machine_position_steps(&M, p);
        TH_EXPECT_EQ(p[0], oracle_steps(pts[k][0], c.steps_per_mm_q16[0]));
        TH_EXPECT_EQ(p[1], oracle_steps(pts[k][1], c.steps_per_mm_q16[1]));
        TH_EXPECT_EQ(edge_sum(&R, 0, NULL), p[0]);
        TH_EXPECT_EQ(edge_sum(&R, 1, NULL), p[1]);
    }
}

static double worst_rate_ratio(const struct pk_rec *r, unsigned axis, double limit, unsigned k);

static void test_three_axes_end_exactly_too(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.axes = 3;
    c.steps_per_mm_q16[2] = spmm(400.0);
    c.max_rate[2] = 600000;
    c.accel[2] = 200000;
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_op ops[3];
    ops[0] = feed(3000, 4000, 3000000);
    ops[0].p[2] = -1500;
    ops[1] = feed(-2000, 1000, 3000000);
    ops[1].p[2] = 2345;
    ops[2] = op_of(MR_RAPID, 0);
    ops[2].p[0] = 10;
    ops[2].p[1] = 20;
    ops[2].p[2] = 30;
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, 3, NULL);
    TH_ASSERT(!res.timed_out);
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    for (unsigned i = 0; i < 3; i++) {
        TH_EXPECT_EQ(p[i], oracle_steps(ops[2].p[i], c.steps_per_mm_q16[i]));
        TH_EXPECT_EQ(edge_sum(&R, i, NULL), p[i]);
    }
    /* Z never ran faster than its own max rate (10 mm/s at 400 steps/mm) */
    TH_EXPECT(worst_rate_ratio(&R, 2, 10.0 * 400.0, 16) <= 1.0);
}

static size_t arc_ops(struct pk_mrun_op *ops, unsigned nseg, double r_um, double turns, uint32_t f)
{
    /* circle through the origin, centre (r, 0), starting at angle pi */
    for (unsigned k = 1; k <= nseg; k++) {
        double a = M_PI + 2.0 * M_PI * turns * k / nseg;
        ops[k - 1] = feed((pk_um_t)lround(r_um + r_um * cos(a)), (pk_um_t)lround(r_um * sin(a)), f);
    }
    return nseg;
}

static void test_polyline_arc_ends_exactly_and_emits_no_extra_steps(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    static struct pk_mrun_op ops[200];
    size_t n = arc_ops(ops, 150, 20000.0, 0.75, 3000000);
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, n, NULL);
    TH_ASSERT(!res.timed_out);
    long want_abs[2] = { 0, 0 };
    long prev[2] = { 0, 0 };
    for (size_t k = 0; k < n; k++)
        for (int i = 0; i < 2; i++) {
            long s = oracle_steps(ops[k].p[i], c.steps_per_mm_q16[i]);
            want_abs[i] += labs(s - prev[i]);
            prev[i] = s;
        }
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    for (int i = 0; i < 2; i++) {
        size_t cnt;
        TH_EXPECT_EQ(p[i], prev[i]);
        TH_EXPECT_EQ(edge_sum(&R, (unsigned)i, &cnt), prev[i]);
        TH_EXPECT_EQ((long)cnt, want_abs[i]); /* no back-and-forth extra steps */
    }
}

/* Largest (rate over k consecutive steps) / limit, limit in steps/s. */
static double worst_rate_ratio(const struct pk_rec *r, unsigned axis, double limit, unsigned k)
{
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(r, axis, &t, &d);
    double worst = 0;
    for (size_t j = 0; j + k < n; j++) {
        double span = (double)(t[j + k] - t[j]);
        double rate = k * (double)r->hal.tick_hz / span;
        /* quantisation: each edge is on a whole tick (+-1 tick on the span) */
        double allowed = limit * (1.0 + 1.0 / (k - 1)) * (1.0 + 2.0 / span);
        if (rate / allowed > worst)
            worst = rate / allowed;
    }
    free(t);
    free(d);
    return worst;
}

static void test_axis_speeds_never_exceed_their_max_rate_or_the_feed(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.max_rate[1] = 2400000; /* Y slower: 40 mm/s */
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_op ops[6];
    ops[0] = feed(60000, 10000, 6000000);
    ops[1] = feed(50000, 60000, 6000000);
    ops[2] = op_of(MR_RAPID, 0);
    ops[3] = feed(20000, 20000, 1200000); /* 20 mm/s along the diagonal */
    ops[2].p[0] = 0;
    ops[2].p[1] = 0;
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, 3, NULL);
    TH_ASSERT(!res.timed_out);
    double sx = 80.0, sy = 78.74;
    TH_EXPECT(worst_rate_ratio(&R, 0, 100.0 * sx, 16) <= 1.0);
    TH_EXPECT(worst_rate_ratio(&R, 1, 40.0 * sy, 16) <= 1.0);
    /* feed limit: along (1,1) at 20 mm/s each axis runs 20/sqrt(2) mm/s */
    setup(&M, &R, &c, TICK_HZ);
    res = pk_mrun(&M, &R, &ops[3], 1, NULL);
    TH_ASSERT(!res.timed_out);
    double w = worst_rate_ratio(&R, 0, 20.0 / sqrt(2.0) * sx, 16);
    TH_EXPECT(w <= 1.0);
    TH_EXPECT(w > 0.9); /* and it does reach the feed (1/(1 + 1/15) = 0.94 at exact speed) */
}

/*
 * Acceleration between consecutive step intervals I1, I2 (ticks) of an axis:
 * under constant acceleration the mean speed over an interval equals the
 * speed at its mid-time, so a = (f/I2 - f/I1) / ((I1 + I2) / 2f) is exact for
 * continuous motion. Tolerance: each edge sits on a whole tick, so I1 - I2 is
 * known to +-2 ticks, plus up to 0.5 tick from the step generator's interval
 * ramp within a segment: 5 f^2 / (I1 I2 (I1 + I2)); plus 3% of a for the
 * ramp's first-order model of the constant acceleration (its error grows as
 * the square of the speed's relative change over a 2 ms segment). Returns
 * worst |a|/allowed. Holds across segment boundaries too: a boundary is not
 * a jolt.
 */
static double worst_accel_ratio(const struct pk_rec *r, unsigned axis, double a_steps,
                                size_t from, size_t to)
{
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(r, axis, &t, &d);
    double f = r->hal.tick_hz, worst = 0;
    if (to > n)
        to = n;
    for (size_t j = from + 2; j < to; j++) {
        if (d[j] != d[j - 1] || d[j - 1] != d[j - 2])
            continue;
        double I1 = (double)(t[j - 1] - t[j - 2]), I2 = (double)(t[j] - t[j - 1]);
        double a = 2.0 * f * f * (I1 - I2) / (I1 * I2 * (I1 + I2));
        double allowed = a_steps * 1.03 + 5.0 * f * f / (I1 * I2 * (I1 + I2));
        if (fabs(a) / allowed > worst)
            worst = fabs(a) / allowed;
    }
    free(t);
    free(d);
    return worst;
}

static void test_acceleration_between_step_intervals_stays_within_the_limit(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, 10000000u);
    struct pk_mrun_op op = feed(30000, 0, 6000000);
    struct pk_mrun_result res = pk_mrun(&M, &R, &op, 1, NULL);
    TH_ASSERT(!res.timed_out);
    double wx = worst_accel_ratio(&R, 0, 1000.0 * 80.0, 0, SIZE_MAX);
    TH_EXPECT(wx <= 1.0);
    /* diagonal: X dominates; its accel is the block's times its share */
    setup(&M, &R, &c, 10000000u);
    op = feed(40000, 25000, 6000000);
    res = pk_mrun(&M, &R, &op, 1, NULL);
    TH_ASSERT(!res.timed_out);
    double L = sqrt(40.0 * 40.0 + 25.0 * 25.0);
    double a_blk = fmin(1000.0 * L / 40.0, 600.0 * L / 25.0);
    double wd = worst_accel_ratio(&R, 0, a_blk * 40.0 / L * 80.0, 0, SIZE_MAX);
    TH_EXPECT(wd <= 1.0);
    /* and it is really accelerating at the limit, not timidly */
    TH_EXPECT(wx > 0.9);
}

static void test_junction_speed_limit_matches_the_junction_deviation_formula(void)
{
    /* pure planner check over many angles, against the double formula */
    double worst = 0;
    for (int deg = 3; deg <= 177; deg += 3) {
        double phi = deg * M_PI / 180.0; /* turn angle */
        pk_q30_t u1[PK_AXES] = { 0 }, u2[PK_AXES] = { 0 };
        u1[0] = PK_Q30_ONE;
        u2[0] = (pk_q30_t)lround(cos(phi) * PK_Q30_ONE);
        u2[1] = (pk_q30_t)lround(sin(phi) * PK_Q30_ONE);
        pk_v2_q4_t v2 = pk_planner_junction_v2(u1, u2, 2, 1000000, 20);
        double theta = M_PI - phi, s = sin(theta / 2.0);
        double want = 1000000.0 * 20.0 * s / (1.0 - s);
        double got = (double)v2 / 16.0;
        double e = fabs(got - want) / want;
        if (e > worst)
            worst = e;
    }
    TH_EXPECT(worst < 1e-3);
}

static void test_emitted_speed_at_a_corner_is_the_junction_speed(void)
{
    static const int turns[] = { 30, 60, 90, 135 };
    for (unsigned k = 0; k < TH_COUNT(turns); k++) {
        struct pk_motion_cfg c = cfg_default();
        c.steps_per_mm_q16[0] = c.steps_per_mm_q16[1] = spmm(800.0);
        c.accel[1] = c.accel[0];
        c.max_rate[0] = c.max_rate[1] = 6000000;
        setup(&M, &R, &c, 10000000u);
        double phi = turns[k] * M_PI / 180.0;
        struct pk_mrun_op ops[2];
        ops[0] = feed(20000, 0, 3000000);
        ops[1] = feed(20000 + (pk_um_t)lround(20000 * cos(phi)),
                      (pk_um_t)lround(20000 * sin(phi)), 3000000);
        struct pk_mrun_result res = pk_mrun(&M, &R, ops, 2, NULL);
        TH_ASSERT(!res.timed_out);
        double s = sin((M_PI - phi) / 2.0);
        double vj = sqrt(1000.0 * 0.020 * s / (1.0 - s)); /* mm/s */
        if (vj > 50.0)
            vj = 50.0;
        uint64_t *t;
        int8_t *d;
        size_t n = pk_mrun_edges(&R, 0, &t, &d);
        size_t n1 = 16000; /* X steps of the first move */
        TH_ASSERT(n >= n1);
        double I = (double)(t[n1 - 1] - t[n1 - 2]) / 1e7;
        double v_last = 1.0 / 800.0 / I; /* mean speed over the last step, mm/s */
        /* over one step the speed changes by at most a*I */
        TH_EXPECT(fabs(v_last - vj) <= 1000.0 * I + 0.01 * vj);
        free(t);
        free(d);
    }
}

static void test_a_move_after_a_full_stop_starts_from_zero(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, 10000000u);
    struct pk_mrun_op ops[4];
    ops[0] = feed(10000, 0, 6000000);
    ops[1] = op_of(MR_DWELL, 0);
    ops[2] = feed(20000, 0, 6000000);
    ops[3] = feed(15000, 0, 6000000); /* reversal: the junction speed is zero */
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, 4, NULL);
    TH_ASSERT(!res.timed_out);
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 0, &t, &d);
    TH_ASSERT(n == 800 + 800 + 400);
    /* from rest at a whole step, the axis steps where its exact position
     * crosses each half step (the position contract: it is at round() of
     * it): step 1 after half a step, sqrt(2 d / (2 a)), step 2 after 1.5
     * steps, sqrt(3 d / a) (d = 1 step, a in steps/s^2) */
    double a = 1000.0 * 80.0, f = 1e7;
    size_t starts[2] = { 800, 1600 };
    for (int k = 0; k < 2; k++) {
        size_t j = starts[k];
        double I2 = (double)(t[j + 1] - t[j]);
        double want = (sqrt(3.0 / a) - sqrt(1.0 / a)) * f;
        TH_EXPECT(fabs(I2 - want) <= 0.02 * want + 2.0);
        TH_EXPECT(d[j] == (k == 0 ? 1 : -1));
    }
    free(t);
    free(d);
}

static void test_a_failing_step_write_stops_with_an_alarm_and_the_position_counts_real_pulses(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    uint64_t before = R.attempts[PK_REC_STEP]; /* init's "all low" */
    R.fail_after[PK_REC_STEP] = 501;            /* the 502nd write from now fails */
    struct pk_mrun_op op = feed(30000, 7000, 3000000);
    struct pk_mrun_result res = pk_mrun(&M, &R, &op, 1, NULL);
    TH_EXPECT(!res.timed_out);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_STEP_WRITE);
    TH_EXPECT_EQ(R.attempts[PK_REC_STEP], before + 502); /* nothing attempted after the failure */
    TH_EXPECT(!pk_rec_armed(&R));
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], edge_sum(&R, 0, NULL));
    TH_EXPECT_EQ(p[1], edge_sum(&R, 1, NULL));
    TH_EXPECT(p[0] > 0 && p[0] < oracle_steps(30000, c.steps_per_mm_q16[0]));
    TH_EXPECT_EQ(pk_machine_move(&M, op.p, 1000, PK_MOVE_FEED), PK_MOTION_EALARM);
    pk_machine_poll(&M);
    TH_EXPECT_EQ(R.attempts[PK_REC_STEP], before + 502);
    /* after a reset the machine moves on from the real position, exactly */
    R.fail_after[PK_REC_STEP] = -1;
    TH_EXPECT(!pk_machine_reset(&M));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    res = pk_mrun(&M, &R, &op, 1, NULL);
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], oracle_steps(30000, c.steps_per_mm_q16[0]));
    TH_EXPECT_EQ(p[1], oracle_steps(7000, c.steps_per_mm_q16[1]));
    TH_EXPECT_EQ(p[0], edge_sum(&R, 0, NULL));
}

static void test_a_failing_direction_write_stops_before_any_step_in_the_wrong_direction(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    R.fail_after[PK_REC_DIR] = 0; /* init wrote the lines; the next write fails */
    struct pk_mrun_op ops[2] = { feed(5000, 0, 3000000), feed(0, 0, 3000000) };
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, 2, NULL);
    TH_EXPECT(!res.timed_out);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_DIR_WRITE);
    TH_EXPECT_EQ(R.attempts[PK_REC_STEP], 1); /* only init's "all low" */
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], 0);
}

/* Events of two recordings of the same length that differ in kind, lines
 * or levels (and in time, if `ticks`). */
static size_t event_diffs(const struct pk_rec *ra, const struct pk_rec *rb, bool ticks)
{
    size_t diff = 0;
    for (size_t k = 0; k < ra->n; k++) {
        const struct pk_rec_event *a = &ra->ev[k], *b = &rb->ev[k];
        if ((ticks && a->tick != b->tick) || a->kind != b->kind || a->mask != b->mask
            || a->levels != b->levels)
            diff++;
    }
    return diff;
}

static void test_a_long_full_queue_changes_nothing_in_the_output(void)
{
    struct pk_motion_cfg c = cfg_default();
    static struct pk_mrun_op ops[400];
    size_t n = arc_ops(ops, 400, 15000.0, 1.0, 2400000);
    /* unthrottled: the main loop and the sender run every 10 µs */
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_opts fast = { .poll_ticks = 10 };
    struct pk_mrun_result ra = pk_mrun(&M, &R, ops, n, &fast);
    /* throttled: the main loop runs every 1 ms, the sender every 5 ms, and
     * is told "full" over and over while the queue stays full */
    setup(&M2, &R2, &c, TICK_HZ);
    struct pk_mrun_opts slow = { .poll_ticks = 1000, .feed_every = 5 };
    struct pk_mrun_result rb = pk_mrun(&M2, &R2, ops, n, &slow);
    TH_ASSERT(!ra.timed_out && !rb.timed_out);
    TH_EXPECT(rb.efull > 50);
    TH_EXPECT_EQ(ra.sent, n);
    TH_EXPECT_EQ(rb.sent, n);
    TH_ASSERT_EQ(R.n, R2.n);
    TH_EXPECT_EQ(event_diffs(&R, &R2, true), 0);
}

/* A caller with a realtime command pending (pk_machine_set_yield) gets the
 * CPU back after one piece of the poll's work; the machine goes on at the
 * next poll. A smoothed arc, main loop every 10 µs: the flag set at every
 * poll (each poll then plans at most one stroke point) and at every third
 * one, against no flag. The same pin events in the same order; their times
 * shift by the polls the machine waits for work (it starts some polls
 * later), so the run's length is compared, within 0.5 %. */
static void test_a_poll_that_yields_to_realtime_work_changes_nothing_in_the_path(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.smooth.mode = PK_SMOOTH_TOLERANCE;
    c.smooth.tolerance_um = 20;
    c.smooth.sharp_turn_deg = 120;
    static struct pk_mrun_op ops[400];
    size_t n = arc_ops(ops, 300, 15000.0, 1.0, 2400000);
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_opts plain = { .poll_ticks = 10 };
    struct pk_mrun_result ra = pk_mrun(&M, &R, ops, n, &plain);
    TH_ASSERT(!ra.timed_out);
    TH_EXPECT(ra.most_planned >= 4u); /* (what a poll plans without the flag) */
    const uint32_t every[] = { 1, 3 };
    for (unsigned e = 0; e < TH_COUNT(every); e++) {
        setup(&M2, &R2, &c, TICK_HZ);
        struct pk_mrun_opts yo = { .poll_ticks = 10, .yield_every = every[e] };
        struct pk_mrun_result rb = pk_mrun(&M2, &R2, ops, n, &yo);
        TH_ASSERT(!rb.timed_out);
        TH_EXPECT_EQ(rb.sent, n);
        TH_EXPECT(rb.polls > ra.polls / 2u);
        if (every[e] == 1) /* (a stroke point is one block here: no piece splits) */
            TH_EXPECT(rb.most_planned <= 1u);
        TH_ASSERT_EQ(R.n, R2.n);
        TH_ASSERT(R.n > 1000u);
        TH_EXPECT_EQ(event_diffs(&R, &R2, false), 0);
        const double la = (double)(R.ev[R.n - 1].tick - R.ev[0].tick);
        const double lb = (double)(R2.ev[R.n - 1].tick - R2.ev[0].tick);
        TH_EXPECT(lb >= la && lb <= la * 1.005);
        TH_EXPECT(M2.yield == NULL && M2.yield_ctx == NULL);
        pk_steps_t pa[PK_AXES], pb[PK_AXES];
        pk_machine_position_steps(&M, pa);
        pk_machine_position_steps(&M2, pb);
        TH_EXPECT(memcmp(pa, pb, sizeof pa) == 0);
    }
}

static void test_a_late_main_loop_delays_steps_but_loses_none(void)
{
    struct pk_motion_cfg c = cfg_default();
    static struct pk_mrun_op ops[200];
    size_t n = arc_ops(ops, 120, 10000.0, 0.9, 6000000);
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_opts late = { .poll_ticks = 80000 }; /* 80 ms between polls */
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, n, &late);
    TH_ASSERT(!res.timed_out);
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    for (int i = 0; i < 2; i++) {
        TH_EXPECT_EQ(p[i], oracle_steps(ops[n - 1].p[i], c.steps_per_mm_q16[i]));
        TH_EXPECT_EQ(edge_sum(&R, (unsigned)i, NULL), p[i]);
    }
}

static void test_two_machines_side_by_side_do_not_share_state(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    setup(&M2, &R2, &c, TICK_HZ);
    struct pk_mrun_op a = feed(12345, -2345, 3000000), b = feed(-777, 4444, 1000000);
    /* interleave: both move at once, one poll each */
    for (int k = 0; k < 400000; k++) {
        if (k == 0) {
            TH_ASSERT_EQ(pk_machine_move(&M, a.p, a.arg, PK_MOVE_FEED), PK_MOTION_OK);
            TH_ASSERT_EQ(pk_machine_move(&M2, b.p, b.arg, PK_MOVE_FEED), PK_MOTION_OK);
        }
        pk_machine_poll(&M);
        pk_machine_poll(&M2);
        pk_rec_advance(&R, R.now + 20);
        pk_rec_advance(&R2, R2.now + 20);
        if (pk_machine_state(&M) == PK_STATE_IDLE && pk_machine_state(&M2) == PK_STATE_IDLE)
            break;
    }
    pk_steps_t p[PK_AXES], q[PK_AXES];
    pk_machine_position_steps(&M, p);
    pk_machine_position_steps(&M2, q);
    TH_EXPECT_EQ(p[0], oracle_steps(12345, c.steps_per_mm_q16[0]));
    TH_EXPECT_EQ(p[1], oracle_steps(-2345, c.steps_per_mm_q16[1]));
    TH_EXPECT_EQ(q[0], oracle_steps(-777, c.steps_per_mm_q16[0]));
    TH_EXPECT_EQ(q[1], oracle_steps(4444, c.steps_per_mm_q16[1]));
}

static void test_feed_hold_decelerates_within_the_limit_and_resume_finishes_exactly(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, 10000000u);
    struct pk_mrun_op ops[3] = { feed(50000, 0, 6000000), feed(90000, 3000, 6000000),
                                 feed(0, 0, 6000000) };
    /* hold at 0.2 s (cruising at 100 mm/s), resume at 0.5 s */
    struct pk_mrun_opts o = { .poll_ticks = 200, .hold_at = 2000000, .resume_at = 5000000 };
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, 3, &o);
    TH_ASSERT(!res.timed_out);
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 0, &t, &d);
    /* no X step between the end of the deceleration (0.1 s at 1000 mm/s^2
     * from 100 mm/s, after at most PK_SG_CHUNKS chunks of 2 ms already
     * prepared, the one executing, and one poll) and the resume */
    size_t in_hold = 0, gap = 0;
    for (size_t j = 1; j < n; j++) {
        if (t[j] > 2000000 + 1000000 + (PK_SG_CHUNKS + 1) * 20000 + 400 && t[j] < 5000000)
            in_hold++;
        if (t[j - 1] < 5000000 && t[j] >= 5000000)
            gap = j;
    }
    TH_EXPECT_EQ(in_hold, 0);
    TH_EXPECT(gap > 0);
    /* the stop before the resume was within the acceleration limit */
    TH_EXPECT(worst_accel_ratio(&R, 0, 1000.0 * 80.0, 0, gap) <= 1.0);
    free(t);
    free(d);
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], 0);
    TH_EXPECT_EQ(p[1], 0);
    TH_EXPECT_EQ(edge_sum(&R, 1, NULL), 0);
}

static void test_hold_reports_holding_then_hold_and_keeps_the_position(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    pk_um_t tgt[PK_AXES] = { 80000, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, tgt, 6000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK); /* nothing follows: run at once */
    for (int k = 0; k < 5000; k++) { /* 0.1 s */
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_RUN);
    TH_EXPECT(pk_machine_speed(&M) > 0);
    pk_machine_hold(&M);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_HOLDING);
    for (int k = 0; k < 25000; k++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_HOLD);
    TH_EXPECT_EQ(pk_machine_speed(&M), 0);
    pk_steps_t p[PK_AXES], q[PK_AXES];
    pk_machine_position_steps(&M, p);
    for (int k = 0; k < 5000; k++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    pk_machine_position_steps(&M, q);
    TH_EXPECT_EQ(p[0], q[0]);
    TH_EXPECT(p[0] > 0 && p[0] < 6400);
    pk_machine_resume(&M);
    struct pk_mrun_result res = pk_mrun(&M, &R, NULL, 0, NULL);
    TH_EXPECT(!res.timed_out);
    pk_machine_position_steps(&M, q);
    TH_EXPECT_EQ(q[0], 6400);
}

static void test_reset_mid_move_reports_the_interruption_and_keeps_the_real_position(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    pk_um_t tgt[PK_AXES] = { 40000, 10000 };
    TH_ASSERT_EQ(pk_machine_move(&M, tgt, 3000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    for (int k = 0; k < 5000; k++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    TH_EXPECT(pk_machine_reset(&M));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    TH_EXPECT_EQ(R.raw[PK_REC_STEP], 0); /* no step line left high */
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], edge_sum(&R, 0, NULL));
    TH_EXPECT(p[0] > 0);
    struct pk_mrun_op op = feed(-1000, 2000, 3000000);
    struct pk_mrun_result res = pk_mrun(&M, &R, &op, 1, NULL);
    TH_EXPECT(!res.timed_out);
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], oracle_steps(-1000, c.steps_per_mm_q16[0]));
    TH_EXPECT_EQ(p[1], oracle_steps(2000, c.steps_per_mm_q16[1]));
    TH_EXPECT(!pk_machine_reset(&M));
}

static void test_a_full_request_fifo_refuses_without_losing_anything(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    pk_um_t p[PK_AXES] = { 0 };
    unsigned ok = 0;
    for (unsigned k = 0; k < PK_MACHINE_INQ + 3; k++) {
        p[0] = (pk_um_t)(1000 * (k + 1));
        uint32_t room = pk_machine_room(&M);
        int r = pk_machine_move(&M, p, 3000000, PK_MOVE_FEED);
        TH_EXPECT_EQ(r, room > 0 ? PK_MOTION_OK : PK_MOTION_EFULL);
        ok += r == PK_MOTION_OK;
    }
    TH_EXPECT_EQ(ok, PK_MACHINE_INQ);
    struct pk_mrun_result res = pk_mrun(&M, &R, NULL, 0, NULL);
    TH_EXPECT(!res.timed_out);
    pk_steps_t s[PK_AXES];
    pk_machine_position_steps(&M, s);
    TH_EXPECT_EQ(s[0], oracle_steps((pk_um_t)(1000 * PK_MACHINE_INQ), c.steps_per_mm_q16[0]));
}

static void test_new_settings_keep_the_step_position(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_op op = feed(10000, -5000, 3000000);
    struct pk_mrun_result res = pk_mrun(&M, &R, &op, 1, NULL);
    TH_ASSERT(!res.timed_out);
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    long y0 = oracle_steps(-5000, c.steps_per_mm_q16[1]);
    /* refused while moving, and for a bad value, without side effects */
    pk_um_t far[PK_AXES] = { 50000, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, far, 3000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    pk_machine_poll(&M);
    struct pk_motion_cfg c2 = c;
    c2.steps_per_mm_q16[0] = spmm(160.0);
    TH_EXPECT_EQ(pk_machine_configure(&M, &c2), PK_MOTION_EBUSY);
    TH_EXPECT(pk_machine_reset(&M));
    pk_machine_position_steps(&M, p);
    long x_now = p[0];
    struct pk_motion_cfg bad = c2;
    bad.accel[0] = 0;
    TH_EXPECT_EQ(pk_machine_configure(&M, &bad), PK_MOTION_EINVAL);
    TH_ASSERT_EQ(pk_machine_configure(&M, &c2), PK_MOTION_OK);
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], x_now);
    TH_EXPECT_EQ(p[1], y0);
    pk_um_t um[PK_AXES];
    pk_machine_position_um(&M, um);
    TH_EXPECT_EQ(um[0], lround(x_now * 1000.0 / 160.0));
    /* and the next move lands on the new scale exactly */
    op = feed(10000, 0, 3000000);
    res = pk_mrun(&M, &R, &op, 1, NULL);
    TH_ASSERT(!res.timed_out);
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], 1600);
    TH_EXPECT_EQ(p[1], 0);
    TH_EXPECT_EQ(edge_sum(&R, 0, NULL), 1600);
}

static void test_pen_changes_switch_the_tool_output_at_a_standstill(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_op ops[5] = { feed(5000, 0, 3000000), op_of(MR_PEN_DOWN, 0),
                                 feed(5000, 5000, 3000000), op_of(MR_PEN_UP, 0), op_of(MR_END, 0) };
    struct pk_mrun_result res = pk_mrun(&M, &R, ops, 5, NULL);
    TH_ASSERT(!res.timed_out);
    /* tool events: init (up = 0), down (1), up (0); no step within the
     * settle time after each change */
    uint64_t tool_t[3];
    unsigned nt = 0;
    for (size_t k = 0; k < R.n; k++)
        if (R.ev[k].kind == PK_REC_TOOL && nt < 3)
            tool_t[nt++] = R.ev[k].tick;
    TH_ASSERT_EQ(nt, 3);
    for (size_t k = 0; k < R.n; k++)
        if (R.ev[k].kind == PK_REC_STEP && R.ev[k].levels != 0) {
            for (unsigned j = 1; j < 3; j++)
                TH_EXPECT(!(R.ev[k].tick >= tool_t[j] && R.ev[k].tick < tool_t[j] + 5000));
        }
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 1, &t, &d);
    TH_EXPECT(n > 0 && t[0] > tool_t[1] && t[n - 1] < tool_t[2]);
    free(t);
    free(d);
}

/* The chunk ring is not cleared when a slot is reused (pk_stepgen.c's
 * ring_slot): every writer must set every field the step path reads for its
 * chunk's kind. A ring full of 0xA5 bytes before the run must change
 * nothing: feed and rapid moves, a slow block, pen changes, a dwell and a
 * smoothed arc (steps, slow, block, tool and wait chunks). */
static void test_a_chunk_ring_holding_stale_bytes_changes_nothing_in_the_output(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.smooth.mode = PK_SMOOTH_TOLERANCE;
    c.smooth.tolerance_um = 20;
    c.smooth.sharp_turn_deg = 120;
    static struct pk_mrun_op ops[200];
    size_t n = 0;
    ops[n++] = feed(5000, 0, 3000000);
    ops[n++] = op_of(MR_PEN_DOWN, 0);
    ops[n++] = feed(5000, 40, 600); /* slow: a few steps over seconds */
    ops[n++] = op_of(MR_DWELL, 120);
    ops[n++] = feed(-3000, 7000, 1200000);
    ops[n++] = op_of(MR_PEN_UP, 0);
    struct pk_mrun_op home = feed(0, 0, 0);
    home.type = MR_RAPID;
    ops[n++] = home;
    ops[n++] = op_of(MR_PEN_DOWN, 0);
    n += arc_ops(ops + n, 150, 4000.0, 1.0, 2400000);
    ops[n++] = op_of(MR_PEN_UP, 0);
    ops[n++] = op_of(MR_END, 0);
    setup(&M, &R, &c, TICK_HZ);
    struct pk_mrun_result ra = pk_mrun(&M, &R, ops, n, NULL);
    setup(&M2, &R2, &c, TICK_HZ);
    memset(M2.sg.ring, 0xA5, sizeof M2.sg.ring);
    struct pk_mrun_result rb = pk_mrun(&M2, &R2, ops, n, NULL);
    TH_ASSERT(!ra.timed_out && !rb.timed_out);
    TH_EXPECT(R.n > 1000u);
    TH_ASSERT_EQ(R.n, R2.n);
    TH_EXPECT_EQ(event_diffs(&R, &R2, true), 0);
    pk_steps_t p[PK_AXES], q[PK_AXES];
    pk_machine_position_steps(&M, p);
    pk_machine_position_steps(&M2, q);
    TH_EXPECT_EQ(p[0], q[0]);
    TH_EXPECT_EQ(p[1], q[1]);
}

/* An override changed while a block runs: the step generator cut the block's
 * segments for the speed of the override in force when the block started
 * (at most 2 x PK_SG_MAX_EVENTS events a segment at twice that speed), so a
 * rise from 10 % to 200 % (20x) made a cruise segment hold hundreds of
 * events: more than the free ring slots. The segment's first chunks were
 * published, the rest did not fit, and the next preparation cut the same
 * segment again: its events went out again and again, the axis ran past
 * its target without end (found by fuzz_motion). And a drop from 200 % to
 * 10 % mid-block: the deceleration from the old speed runs in the segments
 * of the new, slower one. Either way each axis must step exactly to its
 * target: one rising edge per step, none twice. */
static void test_an_override_changed_mid_block_steps_each_step_once(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.steps_per_mm_q16[0] = spmm(400.0);
    c.steps_per_mm_q16[1] = spmm(393.7);
    c.max_rate[0] = c.max_rate[1] = 12000000; /* 200 mm/s: 80,000 steps/s */
    c.accel[0] = c.accel[1] = 4000000;
    static const struct { uint16_t from, to; } ovr[] = { { 10, 200 }, { 200, 10 }, { 100, 200 } };
    for (unsigned k = 0; k < TH_COUNT(ovr); k++) {
        setup(&M, &R, &c, 10000000u);
        TH_ASSERT_EQ(pk_machine_set_override(&M, ovr[k].from, 100), PK_MOTION_OK);
        struct pk_mrun_op ops[2] = { feed(150000, 30000, 6000000), op_of(MR_END, 0) };
        /* change it while cruising in the first move (at 10 %: 10 mm/s, 0.3 s
         * in; at 200 %: 200 mm/s, 0.1 s in, before 20 mm of 150) */
        struct pk_mrun_opts o = { .poll_ticks = 1000, .ovr_at = ovr[k].from == 10 ? 3000000u : 1000000u,
                                  .ovr_feed_pct = ovr[k].to, .ovr_rapid_pct = 100,
                                  .max_ticks = 600000000u };
        struct pk_mrun_result res = pk_mrun(&M, &R, ops, 2, &o);
        TH_EXPECT(!res.timed_out);
        pk_steps_t p[PK_AXES];
        pk_machine_position_steps(&M, p);
        TH_EXPECT_EQ(p[0], oracle_steps(150000, c.steps_per_mm_q16[0]));
        TH_EXPECT_EQ(p[1], oracle_steps(30000, c.steps_per_mm_q16[1]));
        for (unsigned a = 0; a < 2; a++) {
            size_t cnt = 0;
            TH_EXPECT_EQ(edge_sum(&R, a, &cnt), p[a]);
            TH_EXPECT_EQ((long)cnt, p[a]); /* one direction: no step back and forth */
        }
        /* and never above an axis's max rate (as the overrides promise) */
        TH_EXPECT(worst_rate_ratio(&R, 0, 200.0 * 400.0, 32) <= 1.0);
        /* and from the change on the speed changes smoothly, within the
         * acceleration (no ring run dry between segments too long for it) */
        uint64_t *t;
        int8_t *d;
        size_t ne = pk_mrun_edges(&R, 0, &t, &d), from = 0;
        while (from < ne && t[from] < o.ovr_at)
            from++;
        free(t);
        free(d);
        TH_EXPECT(from > 1000u && from < ne);
        double L = sqrt(150.0 * 150.0 + 30.0 * 30.0);
        TH_EXPECT(worst_accel_ratio(&R, 0, 4000.0 * 150.0 / L * 400.0, from, SIZE_MAX) <= 1.0);
    }
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_straight_moves_end_exactly_at_the_commanded_step),
        TH_CASE(test_polyline_arc_ends_exactly_and_emits_no_extra_steps),
        TH_CASE(test_three_axes_end_exactly_too),
        TH_CASE(test_axis_speeds_never_exceed_their_max_rate_or_the_feed),
        TH_CASE(test_acceleration_between_step_intervals_stays_within_the_limit),
        TH_CASE(test_junction_speed_limit_matches_the_junction_deviation_formula),
        TH_CASE(test_emitted_speed_at_a_corner_is_the_junction_speed),
        TH_CASE(test_a_move_after_a_full_stop_starts_from_zero),
        TH_CASE(test_a_failing_step_write_stops_with_an_alarm_and_the_position_counts_real_pulses),
        TH_CASE(test_a_failing_direction_write_stops_before_any_step_in_the_wrong_direction),
        TH_CASE(test_a_long_full_queue_changes_nothing_in_the_output),
        TH_CASE(test_a_poll_that_yields_to_realtime_work_changes_nothing_in_the_path),
        TH_CASE(test_a_late_main_loop_delays_steps_but_loses_none),
        TH_CASE(test_two_machines_side_by_side_do_not_share_state),
        TH_CASE(test_feed_hold_decelerates_within_the_limit_and_resume_finishes_exactly),
        TH_CASE(test_hold_reports_holding_then_hold_and_keeps_the_position),
        TH_CASE(test_reset_mid_move_reports_the_interruption_and_keeps_the_real_position),
        TH_CASE(test_a_full_request_fifo_refuses_without_losing_anything),
        TH_CASE(test_pen_changes_switch_the_tool_output_at_a_standstill),
        TH_CASE(test_a_chunk_ring_holding_stale_bytes_changes_nothing_in_the_output),
        TH_CASE(test_new_settings_keep_the_step_position),
        TH_CASE(test_an_override_changed_mid_block_steps_each_step_once),
    };
    int r = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    pk_rec_free(&R2);
    return r;
}
