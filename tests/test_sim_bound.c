/*
 * test_sim_bound.c — the lower bound on motion time (host-sim/sim_bound.h):
 * its pieces against closed forms computed here, its corner rule against the
 * geometry it claims (the widest circle inside the tolerance tube), and the
 * bound against the firmware itself: a planner that beats a lower bound is
 * faster than physics, or the bound is wrong — either is a bug.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "sim_bound.h"
#include "sim_run.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static const struct pk_timing_limits drv8825 = PK_TIMING_DRV8825;

static struct pk_bound_cfg cfg_xy(double vmax, double acc)
{
    struct pk_bound_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    c.vmax_mm_s[0] = c.vmax_mm_s[1] = vmax;
    c.acc_mm_s2[0] = c.acc_mm_s2[1] = acc;
    c.junction_mm = 0.01;
    return c;
}

static void add_line(struct pk_bound *b, double x0, double y0, double x1, double y1, double feed, double tol)
{
    double a[3] = { x0 * 1000.0, y0 * 1000.0, 0 }, e[3] = { x1 * 1000.0, y1 * 1000.0, 0 };
    struct pk_path_prim p;
    pk_path_line(&p, a, e);
    pk_bound_prim(b, &p, feed, tol, 1);
}

static void test_a_straight_move_is_its_trapezoid(void)
{
    struct pk_bound_cfg c = cfg_xy(100, 1000);
    struct pk_bound b;
    pk_bound_init(&b, &c);
    add_line(&b, 0, 0, 100, 0, 50, 0.02);
    /* accelerate 2.5 mm, cruise 95 mm, decelerate: 100/50 + 50/1000 */
    TH_EXPECT(fabs(pk_bound_finish(&b) - 2.05) < 1e-9);
    pk_bound_free(&b);
    /* too short to reach the feed: a triangle, 2 sqrt(L/A) */
    pk_bound_init(&b, &c);
    add_line(&b, 0, 0, 1, 0, 50, 0.02);
    TH_EXPECT(fabs(pk_bound_finish(&b) - 2.0 * sqrt(1.0 / 1000.0)) < 1e-9);
    pk_bound_free(&b);
    /* a diagonal: each axis carries 1/sqrt(2) of it, so the path may go
     * sqrt(2) times faster and accelerate sqrt(2) times harder */
    pk_bound_init(&b, &c);
    add_line(&b, 0, 0, 100, 100, 0, 0.02);
    double v = 100 * sqrt(2.0), A = 1000 * sqrt(2.0), L = 100 * sqrt(2.0);
    TH_EXPECT(fabs(pk_bound_finish(&b) - (L / v + v / A)) < 1e-9);
    pk_bound_free(&b);
}

static void test_a_square_slows_to_the_tube_circle_at_each_corner(void)
{
    struct pk_bound_cfg c = cfg_xy(100, 1000);
    struct pk_bound b;
    pk_bound_init(&b, &c);
    add_line(&b, 0, 0, 100, 0, 50, 0.02);
    add_line(&b, 100, 0, 100, 100, 50, 0.02);
    add_line(&b, 100, 100, 0, 100, 50, 0.02);
    add_line(&b, 0, 100, 0, 0, 50, 0.02);
    /* a 90-degree turn: r = 2P / (1 - cos 45), the velocity change diagonal
     * (each axis sees 1/sqrt(2) of the centripetal acceleration) */
    double r = 2 * 0.02 / (1 - cos(M_PI / 4)), vc = sqrt(1000 * sqrt(2.0) * r);
    double want = 2 * pk_bound_trapezoid_s(100, 0, vc, 50, 1000) + 2 * pk_bound_trapezoid_s(100, vc, vc, 50, 1000);
    /* the trapezoid itself, by hand: from vc to 50 and back over 100 mm */
    double t_mid = 2 * (50 - vc) / 1000 + (100 - 2 * (2500 - vc * vc) / 2000) / 50;
    TH_EXPECT(fabs(pk_bound_trapezoid_s(100, vc, vc, 50, 1000) - t_mid) < 1e-12);
    TH_EXPECT(fabs(pk_bound_finish(&b) - want) < 1e-9);
    pk_bound_free(&b);
}

/* Distance from p to the two legs V + s u1, V + s u2 (s in [0, L]). */
static double dist_legs(const double p[2], const double u1[2], const double u2[2], double L)
{
    double best = INFINITY;
    const double *u[2] = { u1, u2 };
    for (int k = 0; k < 2; k++) {
        double s = p[0] * u[k][0] + p[1] * u[k][1];
        s = s < 0 ? 0 : s > L ? L : s;
        double d = hypot(p[0] - s * u[k][0], p[1] - s * u[k][1]);
        if (d < best)
            best = d;
    }
    return best;
}

/* The farthest a circle of radius r (tangent to both outer tube edges, so
 * its centre on the inner bisector) strays from the legs over its turn. */
static double circle_excess(double phi, double P, double r, double L)
{
    double h = phi / 2; /* legs from V = 0 at angles pi -/+ (pi - phi)/2 around the bisector -y */
    double a = (M_PI - phi) / 2;
    double u1[2] = { -sin(a), -cos(a) }, u2[2] = { sin(a), -cos(a) };
    /* the centre at distance D below V on the bisector; tangent to the outer
     * edges (the leg lines moved by P away from the centre): D sin(a) + P = r */
    double D = (r - P) / sin(a);
    double worst = 0;
    for (int i = 0; i <= 20000; i++) {
        double t = -h + phi * i / 20000.0; /* the turn: angles around the top of the circle */
        double p[2] = { r * sin(t), -D + r * cos(t) };
        double d = dist_legs(p, u1, u2, L);
        if (d > worst)
            worst = d;
    }
    return worst;
}

static void test_the_corner_circle_is_the_widest_inside_the_tube(void)
{
    const double P = 0.02;
    const double phis[] = { 0.05, 0.38, M_PI / 4, M_PI / 2, 2.5, 3.1 };
    for (unsigned k = 0; k < TH_COUNT(phis); k++) {
        double phi = phis[k], r = pk_bound_corner_radius_mm(phi, P, 1e9, 1e9);
        TH_EXPECT(fabs(r - 2 * P / (1 - cos(phi / 2))) < 1e-12 * r);
        /* it stays within P (sampling), a 1 % wider one does not */
        TH_EXPECT(circle_excess(phi, P, r, 1e9) <= P * (1 + 1e-6));
        TH_EXPECT(circle_excess(phi, P, r * 1.01, 1e9) > P);
    }
    /* the circle touches the outer edges r tan(phi/2) along each leg: a
     * shorter leg does not hold the path, the rule then says nothing (the
     * window rule of sim_bound.h takes over) */
    double r = 2.0 / (1 - cos(M_PI / 4));
    TH_EXPECT(fabs(pk_bound_corner_radius_mm(M_PI / 2, 1.0, r, r) - r) < 1e-12);
    TH_EXPECT(isinf(pk_bound_corner_radius_mm(M_PI / 2, 1.0, 2.0, 3.0)));
    TH_EXPECT(isinf(pk_bound_corner_radius_mm(M_PI / 2, 1.0, 1e9, 0.99 * r)));
}

static void test_a_dense_circle_runs_at_its_curvature_speed(void)
{
    /* R = 20 mm in 0.1 mm chords at a feed no axis limits: a path within
     * 0.01 mm runs at most about sqrt(A_c R), A_c between A (on an axis) and
     * sqrt(2) A (diagonal); the 0.1 mm legs are too short for the tube
     * circle, the window rule holds the bound to about 1.2 x sqrt(sqrt(2) A R)
     * (best window h = 2.56 mm), which with the start and the stop stays in
     * the band below */
    struct pk_bound_cfg c = cfg_xy(1000, 1000);
    struct pk_bound b;
    pk_bound_init(&b, &c);
    const double R = 20;
    int n = (int)(2 * M_PI * R / 0.1);
    for (int i = 0; i < n; i++) {
        double a0 = 2 * M_PI * i / n, a1 = 2 * M_PI * (i + 1) / n;
        add_line(&b, R * cos(a0), R * sin(a0), R * cos(a1), R * sin(a1), 500, 0.01);
    }
    double t = pk_bound_finish(&b), L = 2 * M_PI * R;
    TH_EXPECT(t > L / sqrt(1000 * sqrt(2.0) * R));
    TH_EXPECT(t < L / sqrt(1000 * R) + 2 * sqrt(1000 * R) / 1000); /* + start and stop */
    pk_bound_free(&b);
}

/* The bound of a piece that no corner slows: a trapezoid over the programmed
 * length at the feed F with the axes' acceleration A (each segment's own limit
 * is at least A). Computed here by hand: F/A + L/F when the ramps fit. */
static double feed_trapezoid(double L, double F, double A)
{
    return L >= F * F / A ? L / F + F / A : 2 * sqrt(L / A);
}

/* A straight line of 20 mm drawn as a zigzag 6 um high in 50 um steps
 * (points of a traced bitmap, noise of a CAM tool): the straight line is
 * within 3 um of it, inside any tolerance of 10 um, so the zigzag's turns
 * (0.24 rad each) must not slow the bound — they did when each turn was
 * confined to half of its 50 um legs. */
static double zigzag_bound(double tol)
{
    struct pk_bound_cfg c = cfg_xy(100, 1000);
    struct pk_bound b;
    pk_bound_init(&b, &c);
    for (int i = 0; i < 400; i++)
        add_line(&b, 0.05 * i, (i & 1) ? 0.006 : 0, 0.05 * (i + 1), (i & 1) ? 0 : 0.006, 50, tol);
    double t = pk_bound_finish(&b);
    pk_bound_free(&b);
    return t;
}

static void test_a_zigzag_inside_the_tube_runs_at_its_feed(void)
{
    double L = 400 * hypot(0.05, 0.006);
    double want = feed_trapezoid(L, 50, 1000), t = zigzag_bound(0.01), exact = zigzag_bound(0);
    TH_EXPECT(t <= want + 1e-9);
    TH_EXPECT(t >= L / 50); /* never faster than the feed */
    TH_EXPECT(t <= exact + 1e-9);
}

/* A circle of radius 5 mm in chords alternating 8 um and 1 um (the pattern
 * of pcb2gcode's isolation paths): at F = 50 mm/s the circle itself needs
 * F^2 / R = 500 mm/s^2 < A, so nothing but the feed limits it. Confining each
 * turn to half of its shorter leg read the 1 um chords as a 1.1 mm radius. */
static double uneven_circle_bound(double tol, double *len)
{
    struct pk_bound_cfg c = cfg_xy(100, 1000);
    struct pk_bound b;
    pk_bound_init(&b, &c);
    const double R = 5, step[2] = { 0.008, 0.001 };
    double a = 0, L = 0;
    for (int i = 0; a < 2 * M_PI; i++) {
        double a1 = a + step[i & 1] / R;
        if (a1 > 2 * M_PI)
            a1 = 2 * M_PI;
        add_line(&b, R * cos(a), R * sin(a), R * cos(a1), R * sin(a1), 50, tol);
        L += 2 * R * sin((a1 - a) / 2);
        a = a1;
    }
    double t = pk_bound_finish(&b);
    pk_bound_free(&b);
    *len = L;
    return t;
}

static void test_an_unevenly_sampled_circle_runs_at_its_feed(void)
{
    double L, t = uneven_circle_bound(0.01, &L), exact = uneven_circle_bound(0, &L);
    double want = feed_trapezoid(L, 50, 1000);
    TH_EXPECT(t <= want + 1e-9);
    TH_EXPECT(t >= L / 50);
    TH_EXPECT(t <= exact + 1e-9);
}

/* The firmware never beats the bound: plotkin sim, tolerance and exact. */
static void check_firmware_not_faster(const char *chip, const char *prog, int exact, double tol)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    cfg.axes = 2;
    cfg.force_smoothing = 1;
    cfg.smooth_mode = exact ? 0u : 2u;
    if (!exact)
        cfg.tolerance = tol;
    memset(&o, 0, sizeof o);
    o.chip = chip;
    o.cfg = &cfg;
    o.program = prog;
    o.len = strlen(prog);
    o.lim = drv8825;
    o.lower_bound = 1;
    if (pk_sim_run(&o, &r) != 0) {
        th_fail(__FILE__, __LINE__, r.err);
        pk_sim_result_free(&r);
        return;
    }
    TH_EXPECT_EQ(r.run_status, PK_SIM_RUN_FINISHED);
    double t = (double)r.ticks / cfg.tick_hz;
    TH_EXPECT(r.lower_bound_s > 0.1);
    if (!(r.lower_bound_s <= t)) {
        char msg[200];
        snprintf(msg, sizeof msg, "%s: plotkin %.4f s < bound %.4f s", chip, t, r.lower_bound_s);
        th_fail(__FILE__, __LINE__, msg);
    }
    pk_sim_result_free(&r);
}

static void test_the_firmware_never_beats_the_bound(void)
{
    const char *corner = "G21 G90\nG0 X10 Y10\nM3\nG1 X110 Y10 F6000\nG1 X210 Y50\nM5\nM2\n";
    const char *chamfer = "G21 G90\nG0 X10 Y10\nM3\nG1 X60 Y10 F6000\nG1 X70 Y20\nG1 X70 Y70\nM5\nM2\n";
    static char circle[64 * 1024];
    size_t k = (size_t)snprintf(circle, sizeof circle, "G21 G90\nG0 X60 Y40\nM3\n");
    for (int i = 1; i <= 400; i++)
        k += (size_t)snprintf(circle + k, sizeof circle - k, "G1 X%.4f Y%.4f F12000\n",
                              40 + 20 * cos(2 * M_PI * i / 400), 40 + 20 * sin(2 * M_PI * i / 400));
    snprintf(circle + k, sizeof circle - k, "M5\nM2\n");
    /* the two shapes above that a half-leg corner rule overestimated */
    static char zigzag[64 * 1024];
    k = (size_t)snprintf(zigzag, sizeof zigzag, "G21 G90\nG0 X10 Y10\nM3\nG1 F3000\n");
    for (int i = 1; i <= 400; i++)
        k += (size_t)snprintf(zigzag + k, sizeof zigzag - k, "X%.3f Y%.3f\n", 10 + 0.05 * i, (i & 1) ? 10.006 : 10);
    snprintf(zigzag + k, sizeof zigzag - k, "M5\nM2\n");
    static char uneven[256 * 1024];
    k = (size_t)snprintf(uneven, sizeof uneven, "G21 G90\nG0 X45 Y40\nM3\nG1 F3000\n");
    double a = 0;
    for (int i = 0; a < 2 * M_PI && k < sizeof uneven - 64; i++) {
        a += ((i & 1) ? 0.001 : 0.008) / 5;
        k += (size_t)snprintf(uneven + k, sizeof uneven - k, "X%.5f Y%.5f\n", 40 + 5 * cos(a), 40 + 5 * sin(a));
    }
    snprintf(uneven + k, sizeof uneven - k, "M5\nM2\n");
    check_firmware_not_faster("bound-corner-tol", corner, 0, 0.02);
    check_firmware_not_faster("bound-corner-exact", corner, 1, 0);
    check_firmware_not_faster("bound-chamfer-tol", chamfer, 0, 0.02);
    check_firmware_not_faster("bound-circle-tol", circle, 0, 0.02);
    check_firmware_not_faster("bound-circle-exact", circle, 1, 0);
    check_firmware_not_faster("bound-zigzag-tol", zigzag, 0, 0.01);
    check_firmware_not_faster("bound-uneven-circle-tol", uneven, 0, 0.01);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_straight_move_is_its_trapezoid),
        TH_CASE(test_a_square_slows_to_the_tube_circle_at_each_corner),
        TH_CASE(test_the_corner_circle_is_the_widest_inside_the_tube),
        TH_CASE(test_a_dense_circle_runs_at_its_curvature_speed),
        TH_CASE(test_a_zigzag_inside_the_tube_runs_at_its_feed),
        TH_CASE(test_an_unevenly_sampled_circle_runs_at_its_feed),
        TH_CASE(test_the_firmware_never_beats_the_bound),
    };
    return th_run(cases, TH_COUNT(cases));
}
