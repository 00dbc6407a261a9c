/*
 * test_motion_limits.c — the promise of the motion core, end to end, as the
 * pins show it: random and adversarial polylines through the whole machine
 * (stroke assembler, kernel, planner, step generator) on the recording HAL,
 * for steps/mm from 1 to 400 and every smoothing mode, with the decoded step
 * trace checked against independent computations:
 *
 *   - tolerance mode G64 P: every position the axes take (after each step
 *     instant) is within P + half a step per axis of the PROGRAMMED polyline
 *     (distance by brute force in doubles); exact mode: within half a step;
 *   - per axis, the step rate over any 2 and any 16 consecutive steps, and the
 *     acceleration from windowed velocities, within their limits up to the
 *     quantisation tolerance derived below;
 *   - the final position is exactly round(target * steps/mm).
 *
 * Quantisation (why the tolerances are what they are). An axis steps at the
 * step generator's events; at each event it is at round() of the exact
 * position, so its steps lag the instants the exact motion crosses each
 * half-step by less than one event interval tau (the dominant axis's step
 * interval, itself at most that axis's own interval at its max rate). Over k
 * intervals the steps therefore span at least k / R - tau of the exact
 * motion's time, R the axis's max rate: the rate over 16 steps is at most
 * R * 15 / 14 for the dominant axis and, for an axis that is not dominant
 * (tau <= 1/R), the same bound; over 2 steps a non-dominant axis can be
 * stepped one event early and late in turn (Bresenham), so its single
 * interval can be one tau short: at most 2 R. Velocities over windows of
 * duration T are off by at most v tau / T, so an acceleration from two
 * windows centred T_c apart is off by at most (v1 tau1 / T1 + v2 tau2 / T2) /
 * T_c; windows here span >= 16 steps and >= 20 ms. Junction deviation is 0
 * ($11 = 0): a programmed corner is passed at rest (Grbl's own behaviour for
 * $11 = 0), so no velocity jump is allowed for anywhere.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "motion_run.h"
#include "th.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define TICK_HZ 1000000u
#define MAXV 4000
#define PK_WIN_S 0.040

static struct pk_machine M;
static struct pk_rec R;

struct pathp { double x, y; };
static struct pathp P[MAXV];
static size_t NP;

static uint32_t seed = 20261201u;
static double urand(void)
{
    seed = seed * 1664525u + 1013904223u;
    return (seed >> 8) / 16777216.0;
}

static void pt(double x, double y)
{
    if (NP < MAXV) {
        P[NP].x = round(x);
        P[NP].y = round(y);
        NP++;
    }
}

/* The paths (µm): what the issues list, scaled to fit 0..200 mm. */
#define NSHAPES 12
static const char *shape(int k)
{
    NP = 0;
    switch (k) {
    case 0: /* long legs, 45 degree zig-zag */
        pt(5000, 5000);
        for (int i = 1; i <= 5; i++)
            pt(5000 + 30000.0 * i, 5000 + (i % 2) * 30000.0);
        return "zig-zag, 42 mm legs";
    case 1: pt(10000, 10000); pt(110000, 10000); pt(210000, 50000); return "21.8 degree corner";
    case 2: pt(10000, 10000); pt(60000, 10000); pt(10000, 10087); pt(60000, 10174);
            return "179.9 degree reversals";
    case 3: for (int i = 0; i <= 6; i++) { pt(10000, 10000 + 1000.0 * i); pt(60000, 10000 + 1000.0 * i + 500); }
            return "hairpins";
    case 4: for (int i = 0; i <= 2000; i++) pt(10000 + i, 10000 + (i / 5) % 2);
            return "1 um segments";
    case 5: for (int i = 0; i <= 40; i++) pt(10000 + 1000.0 * i, 10000);
            for (int i = 1; i <= 40; i++) pt(50000, 10000 + 1000.0 * i);
            return "collinear runs";
    case 6: for (int i = 0; i <= 628; i++) { double a = 2 * M_PI * i / 628;
                pt(30000 + 10000 * cos(a), 30000 + 10000 * sin(a)); }
            return "dense circle, 0.1 mm chords";
    case 7: for (int i = 0; i <= 40; i++) { double a = 2 * M_PI * i / 40;
                pt(30000 + 20000 * cos(a), 30000 + 20000 * sin(a)); }
            return "40-gon";
    case 8: pt(10000, 10000); pt(50000, 10000); pt(60000, 20000); pt(100000, 20000);
            return "45 degree chamfer";
    default: {
        double x = 60000, y = 60000;
        pt(x, y);
        double sc = k == 9 ? 300 : k == 10 ? 3000 : 20000;
        for (int i = 0; i < 60; i++) {
            x = fmin(190000, fmax(10000, x + (urand() - 0.5) * sc));
            y = fmin(190000, fmax(10000, y + (urand() - 0.5) * sc));
            pt(x, y);
        }
        return "random walk";
    }
    }
}

static double seg_dist(const struct pathp *a, const struct pathp *b, double x, double y)
{
    double dx = b->x - a->x, dy = b->y - a->y, L = dx * dx + dy * dy;
    double t = L > 0 ? ((x - a->x) * dx + (y - a->y) * dy) / L : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return hypot(a->x + t * dx - x, a->y + t * dy - y);
}

/* Distance from (x, y) to the programmed path: exact, over every segment
 * (a segment whose bounding box is farther than the best so far is skipped;
 * the last nearest segment gives the first bound). */
static double path_dist(double x, double y, size_t *j)
{
    size_t nseg = NP - 1;
    double best = seg_dist(&P[*j], &P[*j + 1], x, y);
    for (size_t k = 0; k < nseg; k++) {
        double x0 = fmin(P[k].x, P[k + 1].x), x1 = fmax(P[k].x, P[k + 1].x);
        double y0 = fmin(P[k].y, P[k + 1].y), y1 = fmax(P[k].y, P[k + 1].y);
        double dx = x < x0 ? x0 - x : x > x1 ? x - x1 : 0;
        double dy = y < y0 ? y0 - y : y > y1 ? y - y1 : 0;
        if (dx >= best || dy >= best)
            continue;
        double v = seg_dist(&P[k], &P[k + 1], x, y);
        if (v < best) {
            best = v;
            *j = k;
        }
    }
    return best;
}

struct run_cfg {
    double spmm[2];
    double rate_mm_min, accel;
    uint8_t mode;            /* PK_SMOOTH_* */
    uint8_t scheme, degree, depth;
    double tol_um;
    uint16_t sharp;
    double feed_mm_min;
    double z_accel;          /* > 0: a third axis (Z, never moved) with this acceleration */
};

struct result {
    double dev_excess_um;    /* worst (deviation - allowed), <= 0 passes */
    double rate2_ratio, rate16_ratio, accel_ratio; /* worst measured / allowed */
    int final_ok, ran;
};

static pk_spmm_q16_t q16(double s) { return (pk_spmm_q16_t)llround(s * 65536.0); }

static void run_one(const struct run_cfg *rc, struct result *res)
{
    memset(res, 0, sizeof *res);
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = q16(rc->spmm[i]);
        c.max_rate[i] = (pk_um_min_t)llround(rc->rate_mm_min * 1000.0);
        c.accel[i] = (pk_um_s2_t)llround(rc->accel * 1000.0);
    }
    if (rc->z_accel > 0) {
        c.axes = 3;
        c.steps_per_mm_q16[2] = q16(400);
        c.max_rate[2] = (pk_um_min_t)llround(rc->rate_mm_min * 250.0);
        c.accel[2] = (pk_um_s2_t)llround(rc->z_accel * 1000.0);
    }
    c.junction_dev_um = 0;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.smooth.mode = rc->mode;
    c.smooth.scheme = rc->scheme;
    c.smooth.degree = rc->degree;
    c.smooth.depth = rc->depth;
    c.smooth.tolerance_um = (pk_um_t)rc->tol_um;
    c.smooth.sharp_turn_deg = rc->sharp;
    pk_rec_free(&R);
    pk_rec_init(&R, TICK_HZ);
    TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
    static struct pk_mrun_op ops[MAXV + 2];
    size_t n = 0;
    memset(ops, 0, sizeof ops);
    ops[n].type = MR_RAPID;
    ops[n].p[0] = (pk_um_t)P[0].x;
    ops[n].p[1] = (pk_um_t)P[0].y;
    n++;
    for (size_t i = 1; i < NP; i++, n++) {
        ops[n].type = MR_FEED;
        ops[n].p[0] = (pk_um_t)P[i].x;
        ops[n].p[1] = (pk_um_t)P[i].y;
        ops[n].arg = (uint32_t)llround(rc->feed_mm_min * 1000.0);
    }
    ops[n++].type = MR_END;
    struct pk_mrun_opts o = { .max_ticks = (uint64_t)TICK_HZ * 1200u };
    struct pk_mrun_result mr = pk_mrun(&M, &R, ops, n, &o);
    TH_ASSERT(!mr.timed_out);
    res->ran = 1;

    /* final position */
    pk_steps_t fp[PK_AXES];
    pk_machine_position_steps(&M, fp);
    res->final_ok = 1;
    uint64_t *t[2];
    int8_t *d[2];
    size_t ne[2];
    for (int a = 0; a < 2; a++) {
        ne[a] = pk_mrun_edges(&R, (unsigned)a, &t[a], &d[a]);
        if (getenv("PK_DUMP")) {
            /* PK_DUMP=FILE: every step edge, "axis tick dir" (by hand) */
            FILE *df = fopen(getenv("PK_DUMP"), a ? "a" : "w");
            for (size_t k = 0; df != NULL && k < ne[a]; k++)
                fprintf(df, "%d %llu %d\n", a, (unsigned long long)t[a][k], d[a][k]);
            if (df != NULL)
                fclose(df);
        }
        long sum = 0;
        for (size_t k = 0; k < ne[a]; k++)
            sum += d[a][k];
        long want = lround((a ? P[NP - 1].y : P[NP - 1].x) * q16(rc->spmm[a]) / 65536.0 / 1000.0);
        if (sum != want || fp[a] != want)
            res->final_ok = 0;
    }

    /* deviation: the joint position after each step instant; the rapid to the
     * start is off the path, so only from the first feed step on (the rapid
     * ends exactly at P[0]) */
    {
        /* the steps/mm the machine has: Q16.16 (7.9 is not exact in it) */
        double sp[2] = { q16(rc->spmm[0]) / 65536.0, q16(rc->spmm[1]) / 65536.0 };
        double step_um[2] = { 1000.0 / sp[0], 1000.0 / sp[1] };
        double allowed = (rc->mode == PK_SMOOTH_TOLERANCE ? rc->tol_um : 0.0)
                         + 0.5 * hypot(step_um[0], step_um[1]) * (1.0 + 1.0 / 128.0) + 0.5;
        long pos[2] = { 0, 0 };
        size_t k[2] = { 0, 0 };
        long start[2] = { lround(P[0].x * sp[0] / 1000.0), lround(P[0].y * sp[1] / 1000.0) };
        int on_path = start[0] == 0 && start[1] == 0; /* no rapid needed */
        size_t jseg = 0;
        double worst = -1e300;
        while (k[0] < ne[0] || k[1] < ne[1]) {
            uint64_t tt = UINT64_MAX;
            for (int a = 0; a < 2; a++)
                if (k[a] < ne[a] && t[a][k[a]] < tt)
                    tt = t[a][k[a]];
            for (int a = 0; a < 2; a++)
                while (k[a] < ne[a] && t[a][k[a]] == tt)
                    pos[a] += d[a][k[a]++];
            if (!on_path) {
                if (pos[0] == start[0] && pos[1] == start[1])
                    on_path = 1;  /* the rapid arrived; the feed moves follow */
                continue;
            }
            if (rc->mode == PK_SMOOTH_FIXED)
                continue;
            double x = pos[0] * step_um[0], y = pos[1] * step_um[1];
            double dd = path_dist(x, y, &jseg) - allowed;
            if (dd > worst) {
                worst = dd;
                if (getenv("PK_DEBUG") && dd > 0)
                    fprintf(stderr, "dev %.1f at t=%llu (%.1f, %.1f) seg %zu\n", dd + allowed,
                            (unsigned long long)tt, x, y, jseg);
            }
        }
        res->dev_excess_um = rc->mode == PK_SMOOTH_FIXED ? -1 : worst;
    }

    /* rates and accelerations per axis */
    double R_max = rc->rate_mm_min / 60.0 * rc->spmm[0]; /* steps/s (same for both axes) */
    double A_max[2] = { rc->accel * rc->spmm[0], rc->accel * rc->spmm[1] };
    res->rate2_ratio = res->rate16_ratio = res->accel_ratio = 0;
    for (int a = 0; a < 2; a++) {
        double Ra = rc->rate_mm_min / 60.0 * rc->spmm[a];
        (void)R_max;
        for (size_t k = 1; k < ne[a]; k++) {
            if (d[a][k] != d[a][k - 1])
                continue; /* a reversal: the axis passed through rest */
            double dt = (double)(t[a][k] - t[a][k - 1]) / TICK_HZ;
            double r2 = 1.0 / fmax(dt, 1e-9) / (2.0 * Ra);
            if (r2 > res->rate2_ratio)
                res->rate2_ratio = r2;
            if (getenv("PK_DEBUG") && r2 > 1.0)
                fprintf(stderr, "axis %d: steps at %llu and %llu ticks, rate2 %.3f of allowed\n", a,
                        (unsigned long long)t[a][k - 1], (unsigned long long)t[a][k], r2);
        }
        for (size_t k = 15; k < ne[a]; k++) {
            int same = 1;
            for (size_t j = k - 14; j <= k && same; j++)
                same = d[a][j] == d[a][j - 1];
            if (!same)
                continue;
            double dt = (double)(t[a][k] - t[a][k - 15]) / TICK_HZ;
            double r16 = 15.0 / fmax(dt, 1e-9) / (Ra * 15.0 / 14.0);
            if (r16 > res->rate16_ratio)
                res->rate16_ratio = r16;
        }
        /* windows: consecutive, each >= 16 steps and >= 20 ms, within one
         * direction of travel (a reversal starts afresh) */
        size_t w0 = 0;
        double pv = 0, pT = 0, ptau = 0;
        int have = 0;
        for (size_t k = 1; k < ne[a]; k++) {
            if (d[a][k] != d[a][w0]) {
                w0 = k;
                have = 0;
                continue;
            }
            double T = (double)(t[a][k] - t[a][w0]) / TICK_HZ;
            if (k - w0 < 16 || T < PK_WIN_S)
                continue;
            double v = (double)(k - w0) / T * d[a][w0];
            /* tau: the shortest interval seen in the window (events of any
             * axis are at least that often) */
            double tau = 1e300;
            for (size_t j = w0 + 1; j <= k; j++)
                tau = fmin(tau, (double)(t[a][j] - t[a][j - 1]) / TICK_HZ);
            if (have) {
                double Tc = (pT + T) / 2.0;
                double acc = fabs(v - pv) / Tc;
                double q = (fabs(pv) * ptau / pT + fabs(v) * tau / T) / Tc;
                double allowed = A_max[a] * 1.05 + q;
                if (acc / allowed > res->accel_ratio) {
                    res->accel_ratio = acc / allowed;
                    if (getenv("PK_DEBUG") && acc > allowed)
                        fprintf(stderr, "axis %d at %.4f s: v %.0f -> %.0f steps/s, T %.4f/%.4f, a %.0f allowed %.0f (q %.0f)\n",
                                a, (double)t[a][k] / TICK_HZ, pv, v, pT, T, acc, allowed, q);
                }
            }
            pv = v;
            pT = T;
            ptau = tau;
            have = 1;
            w0 = k;
        }
    }
    for (int a = 0; a < 2; a++) {
        free(t[a]);
        free(d[a]);
    }
}

static void report(const char *what, const struct run_cfg *rc, const struct result *r)
{
    th_print("  ");
    th_print(what);
    char b[256];
    snprintf(b, sizeof b, ": mode %u/%u/%u tol %.0f spmm %.1f/%.1f: dev excess %.3g um, rate2 %.3f, rate16 %.3f, accel %.3f, final %d\n", 
             rc->mode, rc->scheme, rc->degree, rc->tol_um, rc->spmm[0], rc->spmm[1], r->dev_excess_um, r->rate2_ratio,
             r->rate16_ratio, r->accel_ratio, r->final_ok);
    th_print(b);
}

static void check(const char *what, const struct run_cfg *rc, const struct result *r, unsigned *bad)
{
    int ok = r->ran && r->final_ok && r->dev_excess_um <= 0 && r->rate2_ratio <= 1.0
             && r->rate16_ratio <= 1.0 && r->accel_ratio <= 1.0;
    if (!ok) {
        (*bad)++;
        report(what, rc, r);
    } else if (getenv("PK_REPORT")) {
        report(what, rc, r); /* PK_REPORT=1: every run's figures (by hand) */
    }
}

/* The cases and random paths in tolerance and exact mode. */
static void test_the_executed_path_stays_within_the_tolerance_and_the_limits(void)
{
    static const double spmm[] = { 80, 7.9, 400, 1 };
    static const double tols[] = { 20, 50, 10 };
    unsigned bad = 0, runs = 0;
    for (int s = 0; s < NSHAPES; s++) {
        const char *name = shape(s);
        for (unsigned v = 0; v < 3; v++) {
            struct run_cfg rc;
            memset(&rc, 0, sizeof rc);
            rc.spmm[0] = spmm[(s + v) % 4];
            rc.spmm[1] = spmm[(s + v + 1) % 4] == 1 ? 80 : spmm[(s + v + 1) % 4];
            rc.rate_mm_min = 6000;
            rc.accel = 1000;
            rc.feed_mm_min = v == 2 ? 12000 : 6000;
            rc.mode = v == 1 ? PK_SMOOTH_OFF : PK_SMOOTH_TOLERANCE;
            rc.tol_um = tols[(s + v) % 3];
            rc.sharp = (s + v) % 2 ? 175 : 60;
            struct result r;
            run_one(&rc, &r);
            runs++;
            check(name, &rc, &r, &bad);
        }
    }
    TH_EXPECT_EQ(bad, 0);
    TH_EXPECT_EQ(runs, NSHAPES * 3);
}

/* A third axis with a much lower acceleration that never moves (Grbl's
 * default: Z) does not enter the budget of XY curves (pk_planner.c: the
 * smallest acceleration of the axes the blocks move); the XY limits still
 * hold on the pins. */
static void test_a_still_slow_axis_leaves_the_xy_limits_kept(void)
{
    unsigned bad = 0;
    const uint32_t seed0 = seed; /* the random walks of the next test stay the ones they were */
    for (int s = 0; s < NSHAPES; s++) {
        const char *name = shape(s);
        struct run_cfg rc;
        memset(&rc, 0, sizeof rc);
        rc.spmm[0] = rc.spmm[1] = 80;
        rc.rate_mm_min = 6000;
        rc.accel = 1000;
        rc.z_accel = 200;
        rc.feed_mm_min = 12000;
        rc.mode = s % 2 ? PK_SMOOTH_OFF : PK_SMOOTH_TOLERANCE;
        rc.tol_um = 50;
        rc.sharp = 60;
        struct result r;
        run_one(&rc, &r);
        check(name, &rc, &r, &bad);
    }
    seed = seed0;
    TH_EXPECT_EQ(bad, 0);
}

/* The sweep's random walks start from the seed the earlier tests leave
 * (the every-mode test records it, the M6 test after it reuses it: the run
 * numbers below are those of that sequence). */
static uint32_t sweep_seed;
static int sweep_seed_set;

/* Runs k = 0..nk-1 of the every-mode sweep, checking those listed in only[]
 * (all when none is given); the random walk of each k is drawn in order. */
static void sweep(unsigned nk, const unsigned *only, size_t nonly, unsigned *bad)
{
    static const double spmm[] = { 1, 3.3, 12.5, 80, 157.48, 400 };
    if (!sweep_seed_set) {
        sweep_seed = seed;
        sweep_seed_set = 1;
    }
    seed = sweep_seed;
    for (unsigned k = 0; k < nk; k++) {
        shape(9 + (int)(k % 3));
        int want = nonly == 0;
        for (size_t j = 0; j < nonly; j++)
            want |= only[j] == k;
        if (!want)
            continue;
        struct run_cfg rc;
        memset(&rc, 0, sizeof rc);
        rc.spmm[0] = spmm[k % 6];
        rc.spmm[1] = spmm[(k + 2) % 6];
        rc.rate_mm_min = 3000;
        rc.accel = 500;
        rc.feed_mm_min = 3000;
        switch (k % 5) {
        case 0: rc.mode = PK_SMOOTH_OFF; break;
        case 1: rc.mode = PK_SMOOTH_TOLERANCE; rc.tol_um = 20; rc.sharp = 175; break;
        case 2: rc.mode = PK_SMOOTH_FIXED; rc.scheme = PK_SCHEME_BSPLINE; rc.degree = 2; rc.depth = 3; rc.sharp = 60; break;
        case 3: rc.mode = PK_SMOOTH_FIXED; rc.scheme = PK_SCHEME_BSPLINE; rc.degree = 3; rc.depth = 2; rc.sharp = 90; break;
        default: rc.mode = PK_SMOOTH_FIXED; rc.scheme = PK_SCHEME_DLG; rc.depth = 2; rc.sharp = 60; break;
        }
        struct result r;
        run_one(&rc, &r);
        if (getenv("PK_DEBUG"))
            fprintf(stderr, "run %u\n", k);
        check("random walk", &rc, &r, bad);
    }
}

/* Issue 11's property: every smoothing mode, steps/mm from 1 to 400.
 * PK_SWEEP=N: N runs instead of 60 (a wider search, by hand); PK_ONLY=K:
 * run K alone. */
static void test_every_mode_keeps_rates_and_accelerations_at_any_steps_per_mm(void)
{
    unsigned bad = 0;
    const char *sw = getenv("PK_SWEEP"), *only = getenv("PK_ONLY");
    const unsigned nk = sw != NULL && atoi(sw) > 0 ? (unsigned)atoi(sw) : 60u;
    unsigned k1 = only != NULL ? (unsigned)atoi(only) : 0u;
    sweep(only != NULL && k1 >= nk ? k1 + 1u : nk, &k1, only != NULL, &bad);
    TH_EXPECT_EQ(bad, 0);
}

/* Finding M6 (issue 11), the sweep's runs that broke the 2-step rate bound:
 * 62 (FIXED, B-spline degree 2, 12.5 / 157.48 steps/mm: 1.122 of the bound),
 * 119 (DLG, 400 / 3.3: 1.911; an axis stepped at the end of a slow
 * four-event block and early in the next) and 439 (DLG, 3.3 / 80: 1.215; a
 * move with no whole step took no time). */
static void test_finding_m6_no_axis_steps_twice_within_half_its_interval(void)
{
    static const unsigned runs[] = { 62, 119, 439 };
    unsigned bad = 0;
    if (getenv("PK_ONLY") != NULL)
        return; /* a single sweep run was asked for */
    sweep(440, runs, 3, &bad);
    TH_EXPECT_EQ(bad, 0);
}

/* The reproducer of finding M3 (issue 11): 80 steps/mm, $110 = $111 = 3000,
 * G1 F3000 to X0 Y10, then points 1 µm apart along X. */
static void test_one_micrometre_points_along_an_axis_run_at_the_feed_not_over_it(void)
{
    if (getenv("PK_ONLY") != NULL)
        return; /* a single sweep run was asked for */
    NP = 0;
    pt(0, 0);
    pt(0, 10000);
    for (int i = 1; i <= 3000; i++)
        pt(i, 10000);
    unsigned bad = 0;
    static const double spmm[] = { 80, 1 };
    for (int k = 0; k < 2; k++) {
        struct run_cfg rc;
        memset(&rc, 0, sizeof rc);
        rc.spmm[0] = rc.spmm[1] = spmm[k];
        rc.rate_mm_min = 3000;
        rc.accel = 1000;
        rc.feed_mm_min = 3000;
        rc.mode = PK_SMOOTH_OFF;
        struct result r;
        run_one(&rc, &r);
        check("1 um points", &rc, &r, &bad);
    }
    TH_EXPECT_EQ(bad, 0);
}

/* Finding M9 (issue 11): the sweep's run 77 (FIXED, B-spline degree 2,
 * 400 / 3.3 steps/mm): X's acceleration over two 40 ms windows 1.021 times
 * the allowance, a vertex of the smoothed curve that did not bind at the
 * nominal speed turning on top of the full acceleration along the path. */
static void test_finding_m9_a_turn_at_speed_shares_the_acceleration(void)
{
    static const unsigned runs[] = { 77 };
    unsigned bad = 0;
    if (getenv("PK_ONLY") != NULL)
        return; /* a single sweep run was asked for */
    sweep(78, runs, 1, &bad);
    TH_EXPECT_EQ(bad, 0);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_the_executed_path_stays_within_the_tolerance_and_the_limits),
        TH_CASE(test_a_still_slow_axis_leaves_the_xy_limits_kept),
        TH_CASE(test_every_mode_keeps_rates_and_accelerations_at_any_steps_per_mm),
        TH_CASE(test_one_micrometre_points_along_an_axis_run_at_the_feed_not_over_it),
        TH_CASE(test_finding_m6_no_axis_steps_twice_within_half_its_interval),
        TH_CASE(test_finding_m9_a_turn_at_speed_shares_the_acceleration),
    };
    int f = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return f;
}
