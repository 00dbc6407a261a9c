/*
 * test_motion_findings.c — the motion core's fuzz findings M4 and M5, fixed,
 * kept as regression tests (their inputs are in tests/fuzz/corpus/fuzz_motion/
 * as regress-M4-* and regress-M5-*; tests/fuzz/README.md tells the story).
 *
 * M4 (soft limits): with DLG smoothing the path can leave the hull of its
 * control points, and pk_machine_move bounds that overshoot from the run's
 * points (their box and second differences). A run that started right after
 * init or after a reset left out where the machine stands, the stroke's first
 * control point: Y 0, 40, 3200 (ghost -40) put DLG's first new point at
 * (40 + 9*0 + 9*40 - 3200)/16 = -175 um, below a soft limit at Y = 0, and
 * both moves were accepted. Now every run starts at the planned position
 * (pk_motion.c, run_start): a move is refused with ETRAVEL, or the executed
 * path (decoded from the step pins) stays inside the box.
 *
 * M5 (exact end): 137.4997 steps/mm, the exact path, feed moves to -40 um
 * then 1960 um: the second block's ends, in Q8 steps, are -5.5 and 269.5
 * (275 steps of distance) for 274 whole steps, so its per-event increment
 * exceeded one step, the first event missed and the block ended a step
 * short. An axis now steps at most once per event by construction (its
 * increment is capped at the period).
 *
 * M12 (a feed run 5x slower than commanded): X at 1 step/mm, Y at 137,
 * tolerance 1 um, feed moves of 4.5 and 9 mm. The steps follow the exact
 * position, and a piece of the smoothed path could move X most of a
 * millimetre (inside one X step) while Y made a single 7 um step; the block
 * was timed by its whole steps' length, so the axes' limits cut its speed by
 * the ratio of the two, and its junctions took the whole steps' direction
 * (one Y step, then one X step: a 90 degree turn on a straight line). A
 * block is now timed, directed and limited by its exact displacement
 * (pk_planner.c).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "hal_record.h"
#include "motion_run.h"
#include "th.h"

int th_main(int argc, char **argv);

#define TICK_HZ 1000000u

static struct pk_machine M;
static struct pk_rec R;

/* A fresh recording HAL and the machine M on it. */
static int machine_on(const struct pk_motion_cfg *c)
{
    pk_rec_free(&R);
    pk_rec_init(&R, TICK_HZ);
    return pk_machine_init(&M, c, &R.hal);
}

static void setup(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = 100u << 16;
        c.max_rate[i] = 6000000;
        c.accel[i] = 1000000;
    }
    c.junction_dev_um = 20;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.pen_down_level = 1;
    c.smooth.mode = PK_SMOOTH_FIXED;
    c.smooth.scheme = PK_SCHEME_DLG;
    c.smooth.depth = 1;
    c.smooth.sharp_turn_deg = 180;
    TH_EXPECT_EQ(machine_on(&c), PK_MOTION_OK);
}

static void run_until_idle(void)
{
    for (uint64_t k = 0; k < 20u * 1000u; k++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 1000u);
        if (pk_machine_state(&M) == PK_STATE_IDLE && !pk_rec_armed(&R) &&
            pk_machine_room(&M) == PK_MACHINE_INQ)
            break;
    }
}

/* Lowest Y position (steps) the pins went to. */
static long y_min_steps(void)
{
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 1, &t, &d);
    long y = 0, ymin = 0;
    for (size_t i = 0; i < n; i++) {
        y += d[i];
        if (y < ymin)
            ymin = y;
    }
    free(t);
    free(d);
    return ymin;
}

/* Soft limits Y in [0, 10 mm]; the run 0 -> (0, 40 um) -> (0, 3.2 mm) from
 * where the machine stands. */
static void run_from_here(void)
{
    pk_um_t lo[PK_AXES] = { -10000, 0 }, hi[PK_AXES] = { 10000, 10000 };
    TH_ASSERT_EQ(pk_machine_set_soft_limits(&M, true, lo, hi), PK_MOTION_OK);
    pk_um_t a[PK_AXES] = { 0, 40 }, b[PK_AXES] = { 0, 3200 };
    int r = pk_machine_move(&M, a, 600000, PK_MOVE_FEED);
    TH_ASSERT(r == PK_MOTION_OK || r == PK_MOTION_ETRAVEL);
    r = pk_machine_move(&M, b, 600000, PK_MOVE_FEED);
    TH_ASSERT(r == PK_MOTION_OK || r == PK_MOTION_ETRAVEL);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle();
    TH_EXPECT(pk_machine_state(&M) == PK_STATE_IDLE);
    /* half a step of rounding: at 100 steps/mm Y = 0 is step 0 */
    TH_EXPECT(y_min_steps() >= 0);
}

static void test_dlg_stays_inside_the_soft_limits_when_the_program_starts_with_a_feed_move(void)
{
    setup();
    run_from_here();
}

static void test_dlg_stays_inside_the_soft_limits_when_a_run_starts_after_a_reset(void)
{
    setup();
    pk_um_t p[PK_AXES] = { 0, 0 };
    /* a first run that ends where the next one starts, then a reset */
    TH_ASSERT_EQ(pk_machine_move(&M, p, 0, PK_MOVE_RAPID), PK_MOTION_OK);
    run_until_idle();
    pk_machine_reset(&M);
    run_from_here();
}

/* M5: two exact-path feed moves at 137.4997 steps/mm (Q16 9011179) end one
 * step short: -40 um is round(-5.49998) = -5 steps, 1960 um round(269.4994)
 * = 269 steps, and the pins stop at 268 with the machine idle, no alarm. The
 * settings are the fuzz input's (tests/fuzz/findings/fuzz_motion/M5-...). */
static void test_two_exact_moves_end_exactly_on_the_commanded_step(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    const uint32_t spmm[2] = { 9011179u, 65536u }, rate[2] = { 10800000u, 7520000u },
                   acc[2] = { 5150000u, 50000u };
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = spmm[i];
        c.max_rate[i] = rate[i];
        c.accel[i] = acc[i];
    }
    c.junction_dev_um = 630;
    c.step_pulse_ticks = 4;
    c.dir_setup_ticks = 7;
    c.pen_settle_ms = 15;
    c.pen_down_level = 1;
    c.smooth.mode = PK_SMOOTH_OFF;
    TH_ASSERT_EQ(machine_on(&c), PK_MOTION_OK);
    pk_um_t a[PK_AXES] = { -40, -40 }, b[PK_AXES] = { 1960, -40 };
    TH_ASSERT_EQ(pk_machine_move(&M, a, 300000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_move(&M, b, 300000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle();
    TH_EXPECT(pk_machine_state(&M) == PK_STATE_IDLE);
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], 269);
    TH_EXPECT_EQ(p[1], 0); /* -40 um at 1 step/mm */
}

/* M12: the settings and moves of the fuzz input (corpus regress-M12-*). The
 * machine must finish within the time a trapezoid at the commanded feed
 * over the exact path takes (L/v + v/a), with 25 % for the smoothed path's
 * extra length and the corners; it took 4.5 times that. */
static void test_a_coarse_axis_runs_its_exact_motion_at_the_commanded_feed(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    const uint32_t spmm[2] = { 65536u, 8978255u }; /* 1, 136.9973 steps/mm */
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = spmm[i];
        c.max_rate[i] = 6000000; /* 6000 mm/min */
        c.accel[i] = 1000000;    /* 1000 mm/s^2 */
    }
    c.junction_dev_um = 10;
    c.step_pulse_ticks = 4;
    c.dir_setup_ticks = 1;
    c.pen_down_level = 1;
    c.smooth.mode = PK_SMOOTH_TOLERANCE;
    c.smooth.scheme = PK_SCHEME_BSPLINE;
    c.smooth.degree = 3;
    c.smooth.tolerance_um = 1;
    c.smooth.sharp_turn_deg = 180;
    TH_ASSERT_EQ(machine_on(&c), PK_MOTION_OK);
    const uint32_t feed = 3972000u; /* um/min */
    pk_um_t a[PK_AXES] = { -4520, -40 }, b[PK_AXES] = { -9040, -80 };
    TH_ASSERT_EQ(pk_machine_move(&M, a, feed, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_move(&M, b, feed, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle();
    TH_EXPECT(pk_machine_state(&M) == PK_STATE_IDLE);
    /* the time of the last step edge on any axis, from the pins */
    uint64_t t_end = 0;
    for (unsigned ax = 0; ax < 2; ax++) {
        uint64_t *t;
        int8_t *d;
        size_t n = pk_mrun_edges(&R, ax, &t, &d);
        if (n > 0 && t[n - 1] > t_end)
            t_end = t[n - 1];
        free(t);
        free(d);
    }
    const double L_mm = 9.04035, v = feed / 60000.0, acc = 1000.0;
    const double budget_s = L_mm / v + v / acc;
    const double ran_s = (double)t_end / TICK_HZ;
    fprintf(stderr, "# M12: last step at %.3f s, budget %.3f s (x%.2f)\n", ran_s, budget_s, ran_s / budget_s);
    TH_EXPECT(ran_s > 0.5 * budget_s);
    TH_EXPECT(ran_s <= 1.25 * budget_s);
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    TH_EXPECT_EQ(p[0], -9);
    TH_EXPECT_EQ(p[1], -11);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_dlg_stays_inside_the_soft_limits_when_the_program_starts_with_a_feed_move),
        TH_CASE(test_dlg_stays_inside_the_soft_limits_when_a_run_starts_after_a_reset),
        TH_CASE(test_two_exact_moves_end_exactly_on_the_commanded_step),
        TH_CASE(test_a_coarse_axis_runs_its_exact_motion_at_the_commanded_feed),
    };
    int f = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return f;
}
