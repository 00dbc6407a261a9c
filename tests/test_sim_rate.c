/*
 * test_sim_rate.c — speed and acceleration estimates from step traces
 * (host-sim/sim_rate.h), against step trains made here from known motions:
 * the step instants of an ideal motion x(t) (the times it crosses whole
 * steps, rounded to ticks; a minor axis rounded to the nearest step at the
 * events of a dominant one, as Bresenham does), so the true speeds and
 * accelerations are known exactly.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "sim_rate.h"

static const uint32_t HZ = 1000000u;

static struct pk_rate_cfg cfg_hz(void)
{
    struct pk_rate_cfg c;
    memset(&c, 0, sizeof c);
    c.tick_hz = HZ;
    return c;
}

/* Time (s) at which x(t) = x0 + v0 t + a t^2 / 2 reaches position s (> x0), a >= 0. */
static double t_at(double s, double v0, double a)
{
    if (a == 0.0)
        return s / v0;
    return (sqrt(v0 * v0 + 2.0 * a * s) - v0) / a;
}

static void test_a_steady_axis_reads_its_rate_over_2_and_16_steps(void)
{
    struct pk_rate r;
    struct pk_rate_cfg c = cfg_hz();
    pk_rate_init(&r, &c);
    for (int k = 1; k <= 200; k++)
        pk_rate_step(&r, (uint64_t)k * 250u, +1, 0); /* 4000 steps/s */
    TH_EXPECT(fabs(r.speed2.vmax.v - 4000.0) < 1e-9);
    TH_EXPECT(fabs(r.speed16.vmax.v - 4000.0) < 1e-9);
    /* alone on its ticks: only the 1-tick timer rounding is allowed for */
    TH_EXPECT(r.speed2.lo_max <= 4000.0 && r.speed2.lo_max > 4000.0 * 250.0 / 252.0 - 1e-9);
    TH_EXPECT(fabs(r.accel.amax.a) < 1e-6);
    TH_EXPECT(r.accel_proven.lo_abs_max == 0.0);
}

static void test_a_one_step_per_second_axis_reads_one_step_per_second(void)
{
    struct pk_rate r;
    struct pk_rate_cfg c = cfg_hz();
    pk_rate_init(&r, &c);
    pk_rate_set_scale(&r, 1.0); /* 1 mm per step: 1 step/mm */
    for (int k = 1; k <= 40; k++)
        pk_rate_step(&r, (uint64_t)k * HZ, k % 2 ? -1 : -1, 1); /* shares its ticks (a minor axis) */
    TH_EXPECT(fabs(r.speed2.vmax.v - 1.0) < 1e-12);
    TH_EXPECT(fabs(r.speed16.vmax.v - 1.0) < 1e-12);
    TH_EXPECT(r.speed16.windows == 25u);
    /* 15 steps +- 1/2 at each end, over 15 s +- 2 ticks */
    TH_EXPECT(fabs(r.speed16.lo_max - 14.0 / (15.0 + 2e-6)) < 1e-9);
    TH_EXPECT(r.speed2.lo_max == 0.0); /* a minor axis's single interval proves nothing */
}

/* Steps of x(t) = v0 t + a t^2 / 2 from 0 for n steps, at 1 MHz, rounded. */
static void accel_train(struct pk_rate *r, double v0, double a, int n, int shared, double t0)
{
    for (int k = 1; k <= n; k++)
        pk_rate_step(r, (uint64_t)llround((t0 + t_at(k, v0, a)) * HZ), +1, shared);
}

static void test_constant_acceleration_is_measured_exactly_within_its_bounds(void)
{
    const double a = 80000.0; /* 1000 mm/s^2 at 80 steps/mm */
    struct pk_rate r;
    struct pk_rate_cfg c = cfg_hz();
    c.a_limit = a;
    pk_rate_init(&r, &c);
    accel_train(&r, 0.0, a, 8000, 0, 0.001);
    TH_ASSERT(r.accel.windows > 10u);
    /* every estimate is a weighted mean of x'': here exactly a, up to the rounding */
    TH_EXPECT(fabs(r.accel.amax.a - a) < 0.002 * a);
    TH_EXPECT(r.accel.amax.lo <= a && r.accel.amax.hi >= a);
    /* nothing proves more than the truth */
    TH_EXPECT(r.accel_proven.lo_abs_max <= a);
    TH_EXPECT(r.accel_proven.lo_abs_max > 0.99 * a); /* alone on its ticks: tight */
    TH_EXPECT_EQ(r.accel_proven.proven_over, 0);
    if (getenv("PK_VERBOSE"))
        printf("    a %.1f [%.1f, %.1f], proven %.1f\n", r.accel.amax.a, r.accel.amax.lo, r.accel.amax.hi,
               r.accel_proven.lo_abs_max);
}

/*
 * A diagonal-ish move: a dominant axis at constant acceleration and a minor
 * axis at ratio 3/7 of it, stepped by Bresenham at the dominant axis's
 * events (the firmware's rule: accumulator from -events/2, step when > 0).
 * The minor axis's true acceleration is 3/7 a; its estimates must bound it.
 */
static void test_a_bresenham_minor_axis_is_bounded_by_its_quantisation(void)
{
    const double a = 80000.0, ratio = 3.0 / 7.0;
    const int events = 7000;
    struct pk_rate dom, minor;
    struct pk_rate_cfg c = cfg_hz();
    c.a_limit = a * ratio;
    c.v_limit = 0.0;
    pk_rate_init(&dom, &c);
    pk_rate_init(&minor, &c);
    int32_t acc = -(events / 2);
    const int32_t steps = 3000;
    double vmax_true = 0.0;
    for (int k = 1; k <= events; k++) {
        uint64_t t = (uint64_t)llround((0.001 + t_at(k, 0.0, a)) * HZ);
        acc += steps;
        int ms = 0;
        if (acc > 0) {
            acc -= events;
            ms = 1;
        }
        pk_rate_step(&dom, t, +1, ms);
        if (ms)
            pk_rate_step(&minor, t, +1, 1);
        vmax_true = sqrt(2.0 * a * k) * ratio;
    }
    TH_EXPECT_EQ(minor.steps, 3000u);
    /* its peak speed is at the end; no window proves more than it */
    TH_EXPECT(minor.speed16.lo_max <= vmax_true);
    TH_EXPECT(minor.speed2.lo_max <= vmax_true);
    TH_EXPECT(minor.speed16.vmax.v > 0.95 * vmax_true);
    /* nor more acceleration than it has */
    TH_EXPECT(minor.accel_proven.lo_abs_max <= a * ratio);
    TH_EXPECT_EQ(minor.accel_proven.proven_over, 0);
    /* every estimate's bounds hold the true a * ratio: the largest one's too */
    TH_EXPECT(minor.accel.amax.lo <= a * ratio && minor.accel.amax.hi >= a * ratio);
}

/* A speed jump (a junction without deceleration): 1000 -> 3000 steps/s at
 * once. Short windows prove an acceleration no planner allowing 80,000
 * steps/s^2 can make; the speed limit 2500 steps/s is proven broken. */
static void test_a_speed_jump_and_a_step_burst_are_proven(void)
{
    struct pk_rate r;
    struct pk_rate_cfg c = cfg_hz();
    c.a_limit = 80000.0;
    c.v_limit = 2500.0;
    pk_rate_init(&r, &c);
    uint64_t t = 0;
    for (int k = 0; k < 100; k++)
        pk_rate_step(&r, t += 1000u, +1, 0);
    for (int k = 0; k < 100; k++)
        pk_rate_step(&r, t += 333u, +1, 0);
    TH_EXPECT(r.speed16.proven_over > 0u);
    TH_EXPECT(r.speed16.lo_max > 2990.0);
    TH_EXPECT(r.accel_proven.proven_over > 0u);
    /* two windows of 2 intervals around the jump: (3003 - 1000) / ~1.33 ms */
    TH_EXPECT(r.accel_proven.lo_abs_max > 1.0e6);
    /* the M3 symptom: one interval 3.6 times too short at 1 step/mm */
    struct pk_rate b;
    c.v_limit = 50.0;
    c.a_limit = 0.0;
    pk_rate_init(&b, &c);
    t = 0;
    for (int k = 0; k < 30; k++)
        pk_rate_step(&b, t += (k == 15 ? 5556u : 20000u), +1, 0);
    TH_EXPECT(b.speed2.proven_over == 1u);
    TH_EXPECT(b.speed2.lo_max > 179.0);
    TH_EXPECT(b.speed16.lo_max > 52.0 && b.speed16.lo_max < 53.0); /* 15 / 285.556 ms */
}

/*
 * The bounds themselves, over random ideal motions: the true mean speed of
 * every window and the true acceleration estimate of every pair of windows
 * lie within [lo, hi] computed from step instants perturbed within the
 * stated bounds (times within tau ticks, positions within q steps).
 */
static void test_the_bounds_contain_the_ideal_values(void)
{
    uint64_t seed = 12345;
    unsigned bad = 0;
    for (int k = 0; k < 20000; k++) {
        seed = seed * 6364136223846793005ull + 1442695040888963407ull;
        double u[8];
        for (int i = 0; i < 8; i++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            u[i] = (double)(seed >> 11) / 9007199254740992.0;
        }
        double v0 = 100 + 5000 * u[0], a = (u[1] - 0.5) * 2e5; /* steps/s, steps/s^2 */
        double T[3] = { 0.0, 0.002 + 0.05 * u[2], 0.0 };
        T[2] = T[1] + 0.002 + 0.05 * u[3];
        double X[3];
        for (int i = 0; i < 3; i++)
            X[i] = v0 * T[i] + a * T[i] * T[i] / 2.0;
        /* decoded instants: ticks within 1 of the truth, steps within q */
        double q = 0.5, tau = 1.0;
        uint64_t t[3];
        int64_t x[3];
        for (int i = 0; i < 3; i++) {
            t[i] = (uint64_t)llround(T[i] * HZ + 1000.0 + (u[4 + i] - 0.5) * 1.0);
            x[i] = (int64_t)llround(X[i]); /* within q = 1/2 of the truth */
        }
        double true_v1 = (X[1] - X[0]) / (T[1] - T[0]), true_v2 = (X[2] - X[1]) / (T[2] - T[1]);
        double true_a = (true_v2 - true_v1) / ((T[2] - T[0]) / 2.0);
        struct pk_rate_speed s1;
        struct pk_rate_accel ac;
        TH_ASSERT_EQ(pk_rate_speed_bounds(x[1] - x[0], t[1] - t[0], q, q, tau, HZ, &s1), 0);
        TH_ASSERT_EQ(pk_rate_accel_bounds(x[1] - x[0], x[2] - x[1], t[0], t[1], t[2], q, q, q, tau, HZ, &ac), 0);
        int ok = fabs(true_v1) >= s1.lo - 1e-9 && fabs(true_v1) <= s1.hi + 1e-9 && true_a >= ac.lo - 1e-6 &&
                 true_a <= ac.hi + 1e-6 && ac.lo_abs <= fabs(true_a) + 1e-6;
        if (!ok && bad++ < 3)
            printf("    v %.3f in [%.3f, %.3f]? a %.1f in [%.1f, %.1f]?\n", true_v1, s1.lo, s1.hi, true_a, ac.lo,
                   ac.hi);
        /* the only exact case is a = 0 with no rounding; the width is about 4 q / (L D) */
    }
    TH_EXPECT_EQ(bad, 0);
}

static void test_a_new_scale_starts_new_windows(void)
{
    struct pk_rate r;
    struct pk_rate_cfg c = cfg_hz();
    pk_rate_init(&r, &c);
    pk_rate_set_scale(&r, 1.0 / 80.0); /* mm per step at 80 steps/mm */
    uint64_t t = 0;
    for (int k = 0; k < 100; k++)
        pk_rate_step(&r, t += 1250u, +1, 0); /* 800 steps/s = 10 mm/s */
    pk_rate_set_scale(&r, 1.0 / 160.0);      /* $100=160 */
    for (int k = 0; k < 100; k++)
        pk_rate_step(&r, t += 625u, +1, 0); /* 1600 steps/s = 10 mm/s */
    TH_EXPECT(fabs(r.speed16.vmax.v - 10.0) < 1e-9);
    TH_EXPECT(fabs(r.speed2.vmax.v - 10.0) < 1e-9);
    TH_EXPECT(fabs(r.accel.amax.a) < 1e-6); /* no window mixes the two scales */
}

/* A whole trace at once: steps on one tick are shared, the others alone. */
static void test_a_trace_is_fed_with_its_shared_ticks(void)
{
    struct pk_rate a[2], b[2];
    struct pk_rate_cfg c = cfg_hz();
    const uint64_t t[6] = { 100, 100, 300, 500, 500, 700 };
    const uint8_t ax[6] = { 0, 1, 0, 0, 1, 0 };
    const int8_t d[6] = { 1, -1, 1, 1, -1, 1 };
    for (int i = 0; i < 2; i++) {
        pk_rate_init(&a[i], &c);
        pk_rate_init(&b[i], &c);
    }
    pk_rate_feed(a, 2, 6, t, ax, d);
    const int shared[6] = { 1, 1, 0, 1, 1, 0 };
    for (int i = 0; i < 6; i++)
        pk_rate_step(&b[ax[i]], t[i], d[i], shared[i]);
    for (int i = 0; i < 2; i++) {
        TH_EXPECT(memcmp(a[i].q, b[i].q, sizeof a[i].q) == 0);
        TH_EXPECT(a[i].speed2.lo_max == b[i].speed2.lo_max && a[i].steps == b[i].steps);
    }
    TH_EXPECT(a[0].q[0] == 0.5 && a[0].q[1] == 0.0); /* the first X step shared its tick */
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_steady_axis_reads_its_rate_over_2_and_16_steps),
        TH_CASE(test_a_one_step_per_second_axis_reads_one_step_per_second),
        TH_CASE(test_constant_acceleration_is_measured_exactly_within_its_bounds),
        TH_CASE(test_a_bresenham_minor_axis_is_bounded_by_its_quantisation),
        TH_CASE(test_a_speed_jump_and_a_step_burst_are_proven),
        TH_CASE(test_the_bounds_contain_the_ideal_values),
        TH_CASE(test_a_new_scale_starts_new_windows),
        TH_CASE(test_a_trace_is_fed_with_its_shared_ticks),
    };
    return th_run(cases, TH_COUNT(cases));
}
