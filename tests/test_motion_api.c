/*
 * test_motion_api.c — the machine API the Grbl layer drives beyond plain
 * moves: feed/rapid overrides, soft limits (with the smoothed path's bound),
 * the spindle/laser output in sync and laser modes, the smallest feed, and
 * which resets count as "motion cut". Everything is observed on the recording
 * HAL's pin log and checked against independent computations (rates from the
 * step timestamps, the kernel run on its own for the overshoot).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "motion_run.h"
#include "pk_refine.h"
#include "th.h"

#define TICK_HZ 1000000u

static struct pk_machine M;
static struct pk_rec R;

static struct pk_motion_cfg cfg_default(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = 80u << 16;
        c.max_rate[i] = 6000000;            /* 100 mm/s */
        c.accel[i] = 1000000;               /* 1000 mm/s^2 */
    }
    c.junction_dev_um = 10;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.pen_settle_ms = 5;
    c.pen_down_level = 1;
    c.smooth.mode = PK_SMOOTH_OFF;
    return c;
}

static void setup(void)
{
    pk_rec_free(&R);
    pk_rec_init(&R, TICK_HZ);
    struct pk_motion_cfg c = cfg_default();
    TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
}

static struct pk_mrun_op op_feed(pk_um_t x, pk_um_t y, uint32_t f)
{
    struct pk_mrun_op o;
    memset(&o, 0, sizeof o);
    o.type = MR_FEED;
    o.p[0] = x;
    o.p[1] = y;
    o.arg = f;
    return o;
}

/* Run the machine until idle (polling every 20 µs), calling hook(t) on the way. */
static void run_until_idle(void (*hook)(uint64_t), uint64_t max_ticks)
{
    uint64_t end = R.now + max_ticks;
    while (R.now < end) {
        if (hook)
            hook(R.now);
        pk_machine_poll(&M);
        if (pk_machine_state(&M) == PK_STATE_IDLE && !pk_rec_armed(&R))
            return;
        pk_rec_advance(&R, R.now + 20);
    }
    th_fail(__FILE__, __LINE__, "machine did not become idle");
}

/* Median step rate (steps/s) of axis 0 between times [t0, t1] (ticks). */
static double rate_between(uint64_t t0, uint64_t t1)
{
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 0, &t, &d);
    double *iv = malloc((n + 1) * sizeof *iv);
    size_t k = 0;
    for (size_t i = 1; i < n; i++)
        if (t[i - 1] >= t0 && t[i] <= t1)
            iv[k++] = (double)(t[i] - t[i - 1]);
    double med = 0;
    if (k > 0) {
        for (size_t i = 1; i < k; i++)
            for (size_t j = i; j > 0 && iv[j - 1] > iv[j]; j--) {
                double x = iv[j]; iv[j] = iv[j - 1]; iv[j - 1] = x;
            }
        med = (double)TICK_HZ / iv[k / 2];
    }
    free(iv);
    free(t);
    free(d);
    return med;
}

static void a_feed_below_one_mm_per_min_is_refused(void)
{
    setup();
    pk_um_t p[PK_AXES] = { 1000, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, p, PK_UM_MIN_MIN - 1u, PK_MOVE_FEED), PK_MOTION_ERANGE);
    TH_ASSERT_EQ(pk_machine_room(&M), (uint32_t)PK_MACHINE_INQ);
    TH_ASSERT_EQ(pk_machine_move(&M, p, PK_UM_MIN_MIN, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_dwell(&M, PK_DWELL_MS_MAX + 1u), PK_MOTION_ERANGE);
}

static void the_feed_override_scales_the_cruise_speed(void)
{
    /* 100 mm at F3000 (50 mm/s = 4000 steps/s): at 50 % the cruise is 2000 steps/s */
    setup();
    TH_ASSERT_EQ(pk_machine_set_override(&M, 50, 100), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_set_override(&M, 9, 100), PK_MOTION_ERANGE);
    TH_ASSERT_EQ(pk_machine_set_override(&M, 201, 100), PK_MOTION_ERANGE);
    TH_ASSERT_EQ(pk_machine_set_override(&M, 100, 0), PK_MOTION_ERANGE);
    pk_um_t p[PK_AXES] = { 100000, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, p, 3000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle(NULL, 10u * TICK_HZ);
    double r = rate_between(TICK_HZ / 2, TICK_HZ);   /* well inside the cruise */
    TH_ASSERT(fabs(r - 2000.0) < 20.0);
}

static void ovr_hook(uint64_t t)
{
    static int done;
    if (t == 0)
        done = 0;
    if (!done && t >= TICK_HZ / 2) {
        (void)pk_machine_set_override(&M, 200, 100);
        done = 1;
    }
}

static void an_override_during_a_move_changes_speed_within_the_acceleration(void)
{
    /* 200 mm at F1500 (25 mm/s = 2000 steps/s); at 0.5 s: 200 % -> 4000 steps/s */
    setup();
    ovr_hook(0);
    pk_um_t p[PK_AXES] = { 200000, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, p, 1500000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle(ovr_hook, 20u * TICK_HZ);
    TH_ASSERT(fabs(rate_between(TICK_HZ / 4, TICK_HZ / 2) - 2000.0) < 20.0);
    TH_ASSERT(fabs(rate_between(2u * TICK_HZ, 3u * TICK_HZ) - 4000.0) < 40.0);
    /* speed changes no faster than 1000 mm/s^2 = 80000 steps/s^2: going from
     * 2000 to 4000 steps/s takes at least 25 ms; check over windows of 16 steps */
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 0, &t, &d);
    double worst = 0;
    for (size_t i = 32; i < n; i += 16) {
        double v1 = 16.0 * TICK_HZ / (double)(t[i - 16] - t[i - 32]);
        double v2 = 16.0 * TICK_HZ / (double)(t[i] - t[i - 16]);
        double dt = ((double)(t[i] - t[i - 32]) / 2.0) / TICK_HZ;
        double a = fabs(v2 - v1) / dt;
        if (a > worst)
            worst = a;
    }
    free(t);
    free(d);
    TH_ASSERT(worst < 80000.0 * 1.05);
}

static void soft_limits_refuse_a_target_outside_the_travel(void)
{
    setup();
    pk_um_t lo[PK_AXES] = { 0, 0 }, hi[PK_AXES] = { 100000, 50000 };
    TH_ASSERT_EQ(pk_machine_set_soft_limits(&M, true, hi, lo), PK_MOTION_ERANGE);
    TH_ASSERT_EQ(pk_machine_set_soft_limits(&M, true, lo, hi), PK_MOTION_OK);
    pk_um_t out[PK_AXES] = { 100001, 0 }, in[PK_AXES] = { 100000, 50000 };
    TH_ASSERT_EQ(pk_machine_move(&M, out, 0, PK_MOVE_RAPID), PK_MOTION_ETRAVEL);
    TH_ASSERT_EQ(pk_machine_move(&M, out, 600000, PK_MOVE_FEED), PK_MOTION_ETRAVEL);
    TH_ASSERT_EQ(pk_machine_room(&M), (uint32_t)PK_MACHINE_INQ);
    TH_ASSERT_EQ(pk_machine_move(&M, in, 600000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_set_soft_limits(&M, false, NULL, NULL), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_move(&M, out, 0, PK_MOVE_RAPID), PK_MOTION_OK);
}

/* A square wave along the y = 0 travel edge, smoothed by DLG: the 4-point scheme
 * overshoots below its control points. */
#define SQW 12
static void square_wave(pk_um_t pts[SQW][2])
{
    for (int i = 0; i < SQW; i++) {
        pts[i][0] = 5000 + i * 4000;
        pts[i][1] = ((i / 2) % 2) ? 0 : 3000;   /* a square wave: 3,3,0,0,3,3,... */
    }
}

static void dlg_overshoot_past_the_travel_is_refused_before_it_runs(void)
{
    pk_um_t pts[SQW][2];
    square_wave(pts);
    /* independent evidence that the path would leave y >= 0: the kernel alone */
    struct pk_refine k;
    struct pk_refine_cfg kc;
    memset(&kc, 0, sizeof kc);
    kc.scheme = PK_SCHEME_DLG;
    kc.depth = 4;
    kc.dims = 2;
    TH_ASSERT_EQ(pk_refine_init(&k, &kc), PK_OK);
    pk_um_t min_y = 0;
    struct pk_refine_out o;
    for (int i = 0; i < SQW; i++) {
        pk_um_t q[PK_AXES] = { pts[i][0], pts[i][1] };
        TH_ASSERT_EQ(pk_refine_push(&k, q), PK_OK);
        while (pk_refine_pull(&k, &o) == PK_OK)
            if (o.p[1] < min_y)
                min_y = o.p[1];
    }
    pk_refine_finish(&k);
    while (pk_refine_pull(&k, &o) == PK_OK)
        if (o.p[1] < min_y)
            min_y = o.p[1];
    TH_ASSERT(min_y < -100);   /* it really goes below the edge */

    setup();
    struct pk_smooth_cfg s;
    memset(&s, 0, sizeof s);
    s.mode = PK_SMOOTH_FIXED;
    s.scheme = PK_SCHEME_DLG;
    s.depth = 4;
    s.sharp_turn_deg = 180;
    TH_ASSERT_EQ(pk_machine_set_smoothing(&M, &s), PK_MOTION_OK);
    pk_um_t lo[PK_AXES] = { 0, 0 }, hi[PK_AXES] = { 200000, 200000 };
    TH_ASSERT_EQ(pk_machine_set_soft_limits(&M, true, lo, hi), PK_MOTION_OK);
    pk_um_t start[PK_AXES] = { pts[0][0], pts[0][1] };
    TH_ASSERT_EQ(pk_machine_move(&M, start, 0, PK_MOVE_RAPID), PK_MOTION_OK);
    int refused = 0;
    for (int i = 1; i < SQW && !refused; i++) {
        pk_um_t q[PK_AXES] = { pts[i][0], pts[i][1] };
        int r;
        while ((r = pk_machine_move(&M, q, 600000, PK_MOVE_FEED)) == PK_MOTION_EFULL) {
            pk_machine_poll(&M);
            pk_rec_advance(&R, R.now + 20);
        }
        if (r == PK_MOTION_ETRAVEL)
            refused = 1;
        else
            TH_ASSERT_EQ(r, PK_MOTION_OK);
    }
    TH_ASSERT(refused);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle(NULL, 60u * TICK_HZ);
    /* what was accepted ran, and never below y = 0 (by more than rounding) */
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
    TH_ASSERT(n > 0);
    TH_ASSERT(ymin >= 0);
}

static int64_t spindle_ev(size_t *k)
{
    for (; *k < R.n; (*k)++)
        if (R.ev[*k].kind == PK_REC_SPINDLE)
            return (int64_t)R.ev[(*k)++].levels;
    return -1;
}

static void a_synchronous_spindle_change_stops_and_a_laser_mode_one_does_not(void)
{
    /* sync: X 0 -> 20 mm, spindle, X -> 40 mm: the write happens with the
     * axis at rest (no step for pen_settle_ms after it) */
    setup();
    struct pk_mrun_op ops[3];
    ops[0] = op_feed(20000, 0, 3000000);
    ops[1] = op_feed(40000, 0, 3000000);
    TH_ASSERT_EQ(pk_machine_move(&M, ops[0].p, ops[0].arg, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_spindle(&M, 0x8000u, true), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_move(&M, ops[1].p, ops[1].arg, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle(NULL, 10u * TICK_HZ);
    size_t k = 0;
    TH_ASSERT_EQ(spindle_ev(&k), 0x8000);
    uint64_t tw = R.ev[k - 1].tick;
    uint64_t *t;
    int8_t *d;
    size_t n = pk_mrun_edges(&R, 0, &t, &d);
    TH_ASSERT_EQ(n, (size_t)3200);
    size_t before = 0;
    while (before < n && t[before] < tw)
        before++;
    TH_ASSERT_EQ(before, (size_t)1600);                   /* the whole first move first */
    TH_ASSERT(t[before] >= tw + 5u * (TICK_HZ / 1000u));  /* then the settle time */
    free(t);
    free(d);

    /* laser mode: the value rides with the next move; no stop at the change */
    setup();
    TH_ASSERT_EQ(pk_machine_move(&M, ops[0].p, ops[0].arg, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_spindle(&M, 0x4000u, false), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_move(&M, ops[1].p, ops[1].arg, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    run_until_idle(NULL, 10u * TICK_HZ);
    k = 0;
    TH_ASSERT_EQ(spindle_ev(&k), 0x4000);
    tw = R.ev[k - 1].tick;
    TH_ASSERT_EQ(spindle_ev(&k), -1);
    n = pk_mrun_edges(&R, 0, &t, &d);
    TH_ASSERT_EQ(n, (size_t)3200);
    before = 0;
    while (before < n && t[before] < tw)
        before++;
    TH_ASSERT_EQ(before, (size_t)1600);
    /* still at cruise across the change: 4000 steps/s, interval 250 ticks */
    TH_ASSERT(t[before] - t[before - 1] < 260u);
    free(t);
    free(d);
}

static void a_reset_after_a_completed_hold_loses_no_position(void)
{
    setup();
    pk_um_t p[PK_AXES] = { 100000, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, p, 3000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    for (int i = 0; i < 5000; i++) {          /* 0.1 s of motion */
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    TH_ASSERT_EQ(pk_machine_state(&M), PK_STATE_RUN);
    pk_machine_hold(&M);
    for (int i = 0; i < 50000 && pk_machine_state(&M) != PK_STATE_HOLD; i++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    TH_ASSERT_EQ(pk_machine_state(&M), PK_STATE_HOLD);
    TH_ASSERT(!pk_machine_reset(&M));         /* stopped: nothing cut */
    TH_ASSERT_EQ(pk_machine_state(&M), PK_STATE_IDLE);

    TH_ASSERT_EQ(pk_machine_move(&M, p, 3000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    for (int i = 0; i < 5000; i++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 20);
    }
    TH_ASSERT(pk_machine_reset(&M));          /* moving: cut */
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(a_feed_below_one_mm_per_min_is_refused),
        TH_CASE(the_feed_override_scales_the_cruise_speed),
        TH_CASE(an_override_during_a_move_changes_speed_within_the_acceleration),
        TH_CASE(soft_limits_refuse_a_target_outside_the_travel),
        TH_CASE(dlg_overshoot_past_the_travel_is_refused_before_it_runs),
        TH_CASE(a_synchronous_spindle_change_stops_and_a_laser_mode_one_does_not),
        TH_CASE(a_reset_after_a_completed_hold_loses_no_position),
    };
    int r = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return r;
}
