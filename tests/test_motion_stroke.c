/*
 * test_motion_stroke.c — strokes and the smoothing policy, with the real
 * refinement kernel: the tolerance bound holds (measured against the kernel's
 * own depth-8 polygon of the same stroke, an independent dense reference),
 * the depth rule's polygon-to-curve bound holds level by level, sharp
 * corners stay exact, fewer segments are used where the path is straight, and
 * at machine level smoothed strokes end exactly and complete even when the
 * sender stops in the middle.
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

#define MAXP 70000

struct poly {
    size_t n;
    double p[MAXP][2];
};

static struct poly IN, OUT, REF;

static double seg_dist(const double *a, const double *b, const double *p)
{
    double dx = b[0] - a[0], dy = b[1] - a[1], L = dx * dx + dy * dy;
    double t = L > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double x = a[0] + t * dx - p[0], y = a[1] + t * dy - p[1];
    return sqrt(x * x + y * y);
}

/* Fraction of arc length at each vertex (both polylines follow the same
 * curve, so equal fractions are nearby points). */
static void arc_frac(const struct poly *q, double *f)
{
    double L = 0;
    f[0] = 0;
    for (size_t i = 1; i < q->n; i++) {
        L += hypot(q->p[i][0] - q->p[i - 1][0], q->p[i][1] - q->p[i - 1][1]);
        f[i] = L;
    }
    for (size_t i = 0; i < q->n; i++)
        f[i] = L > 0 ? f[i] / L : 0;
}

/* max over the vertices of a of the distance to polyline b, searching b's
 * segments within +-3% of arc length around the same fraction (exhaustive
 * enough: a wrong match can only overstate the distance) */
static double one_sided(const struct poly *a, const struct poly *b)
{
    static double fa[MAXP], fb[MAXP];
    arc_frac(a, fa);
    arc_frac(b, fb);
    double worst = 0;
    size_t lo = 0;
    for (size_t i = 0; i < a->n; i++) {
        while (lo + 1 < b->n && fb[lo + 1] < fa[i] - 0.03)
            lo++;
        double best = b->n == 1 ? hypot(a->p[i][0] - b->p[0][0], a->p[i][1] - b->p[0][1]) : 1e300;
        for (size_t j = lo; j + 1 < b->n && fb[j] <= fa[i] + 0.03; j++) {
            double d = seg_dist(b->p[j], b->p[j + 1], a->p[i]);
            if (d < best)
                best = d;
        }
        if (best > worst)
            worst = best;
    }
    return worst;
}

static double hausdorff(const struct poly *a, const struct poly *b)
{
    return fmax(one_sided(a, b), one_sided(b, a));
}

static void add(struct poly *q, double x, double y)
{
    if (q->n < MAXP) {
        q->p[q->n][0] = x;
        q->p[q->n][1] = y;
        q->n++;
    }
}

/* The kernel alone over IN, scheme B-spline of degree D, depth k -> out. */
static void kernel_run(unsigned D, unsigned k, struct poly *out)
{
    struct pk_refine r;
    struct pk_refine_cfg c;
    memset(&c, 0, sizeof c);
    c.scheme = PK_SCHEME_BSPLINE;
    c.degree = (uint8_t)D;
    c.depth = (uint8_t)k;
    out->n = 0;
    TH_ASSERT_EQ(pk_refine_init(&r, &c), PK_OK);
    struct pk_refine_out o;
    for (size_t i = 0; i < IN.n; i++) {
        pk_um_t p[PK_AXES] = { (pk_um_t)IN.p[i][0], (pk_um_t)IN.p[i][1] };
        TH_ASSERT_EQ(pk_refine_push(&r, p), PK_OK);
        while (pk_refine_pull(&r, &o) == PK_OK)
            add(out, o.p[0], o.p[1]);
    }
    pk_refine_finish(&r);
    while (pk_refine_pull(&r, &o) == PK_OK)
        add(out, o.p[0], o.p[1]);
}

/* The stroke assembler over IN with policy s -> OUT (with the start point). */
static void stroke_run(const struct pk_smooth_cfg *s, uint32_t hint)
{
    static struct pk_stroke st;
    pk_stroke_init(&st, s);
    pk_um_t p[PK_AXES] = { 0 }, o[PK_AXES];
    p[0] = (pk_um_t)IN.p[0][0];
    p[1] = (pk_um_t)IN.p[0][1];
    OUT.n = 0;
    add(&OUT, p[0], p[1]);
    TH_ASSERT_EQ(pk_stroke_begin(&st, p, hint), 0);
    for (size_t i = 1; i < IN.n; i++) {
        p[0] = (pk_um_t)IN.p[i][0];
        p[1] = (pk_um_t)IN.p[i][1];
        int r;
        while ((r = pk_stroke_add(&st, p)) == PK_EBUSY)
            while (pk_stroke_pull(&st, o) == PK_OK)
                add(&OUT, o[0], o[1]);
        TH_ASSERT_EQ(r, PK_OK);
        while (pk_stroke_pull(&st, o) == PK_OK)
            add(&OUT, o[0], o[1]);
    }
    pk_stroke_finish(&st);
    int r;
    while ((r = pk_stroke_pull(&st, o)) == PK_OK)
        add(&OUT, o[0], o[1]);
    TH_EXPECT_EQ(r, PK_END);
    TH_EXPECT(!pk_stroke_is_open(&st));
}

static void make_circle(unsigned n, double r)
{
    IN.n = 0;
    for (unsigned k = 0; k <= n; k++) {
        double a = M_PI + 2 * M_PI * k / n;
        add(&IN, lround(r + r * cos(a)), lround(r * sin(a)));
    }
}

static void make_wave(unsigned n, double len, double amp, double waves)
{
    IN.n = 0;
    for (unsigned k = 0; k <= n; k++) {
        double x = len * k / n;
        add(&IN, lround(x), lround(amp * sin(2 * M_PI * waves * x / len)));
    }
}

static uint32_t max_d2(void)
{
    double m = 0;
    for (size_t i = 1; i + 1 < IN.n; i++)
        m = fmax(m, hypot(IN.p[i - 1][0] - 2 * IN.p[i][0] + IN.p[i + 1][0],
                          IN.p[i - 1][1] - 2 * IN.p[i][1] + IN.p[i + 1][1]));
    return (uint32_t)ceil(m);
}

/* Rounding of the kernel's outputs to whole µm: each point is within
 * sqrt(2)/2 µm of its exact value (plus the kernel's stated 1/256 µm per
 * level); a distance between two rounded polylines carries up to twice
 * that: 1.5 µm. */
#define ROUND_UM 1.5

static void test_level_k_polygon_is_within_the_stated_bound_of_the_curve(void)
{
    /* the depth rule's premise: dist(level-k polygon, curve) <= M/(2*4^k),
     * clamped ends included; the depth-8 polygon stands in for the curve
     * (itself within M/(2*4^8) of it) */
    static const unsigned degrees[] = { 2, 3 };
    for (int shape = 0; shape < 3; shape++) {
        if (shape == 0)
            make_circle(60, 20000);
        else if (shape == 1)
            make_wave(40, 60000, 8000, 2.5);
        else
            make_wave(30, 30000, 3000, 6);
        double M = max_d2();
        for (unsigned di = 0; di < 2; di++) {
            kernel_run(degrees[di], 8, &REF);
            for (unsigned k = 0; k <= 5; k++) {
                kernel_run(degrees[di], k, &OUT);
                double bound = M / (2.0 * pow(4, k)) + M / (2.0 * pow(4, 8)) + ROUND_UM;
                double d = hausdorff(&OUT, &REF);
                TH_EXPECT(d <= bound);
                if (d > bound) {
                    th_print("  shape/degree/depth ");
                    th_print_i64(shape);
                    th_print_i64(degrees[di]);
                    th_print_i64(k);
                    th_print(" d*1000=");
                    th_print_i64((int64_t)(d * 1000));
                    th_print(" bound*1000=");
                    th_print_i64((int64_t)(bound * 1000));
                    th_print(" M=");
                    th_print_i64((int64_t)M);
                    th_print("\n");
                }
            }
        }
    }
}

static void test_tolerance_mode_keeps_the_path_within_T_of_the_limit_curve(void)
{
    static const pk_um_t tols[] = { 10, 50, 200 };
    for (int shape = 0; shape < 2; shape++) {
        if (shape == 0)
            make_circle(200, 20000);
        else
            make_wave(120, 80000, 6000, 3);
        kernel_run(3, 8, &REF);
        for (unsigned t = 0; t < TH_COUNT(tols); t++) {
            struct pk_smooth_cfg s;
            memset(&s, 0, sizeof s);
            s.mode = PK_SMOOTH_TOLERANCE;
            s.tolerance_um = tols[t];
            s.sharp_turn_deg = 60;
            stroke_run(&s, max_d2());
            double d = hausdorff(&OUT, &REF);
            TH_EXPECT(d <= tols[t] + ROUND_UM);
            if (d > tols[t] + ROUND_UM) {
                th_print("  shape/tol/d*1000 ");
                th_print_i64(shape);
                th_print(" ");
                th_print_i64(tols[t]);
                th_print(" ");
                th_print_i64((int64_t)(d * 1000));
                th_print("\n");
            }
            /* and it ends exactly where the polyline ends */
            TH_EXPECT(OUT.p[OUT.n - 1][0] == IN.p[IN.n - 1][0]);
            TH_EXPECT(OUT.p[OUT.n - 1][1] == IN.p[IN.n - 1][1]);
        }
    }
}

static void test_a_looser_tolerance_never_needs_more_segments(void)
{
    make_circle(200, 20000);
    size_t prev = SIZE_MAX;
    static const pk_um_t tols[] = { 2, 10, 50, 200, 1000 };
    for (unsigned t = 0; t < TH_COUNT(tols); t++) {
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.tolerance_um = tols[t];
        stroke_run(&s, max_d2());
        TH_EXPECT(OUT.n <= prev);
        prev = OUT.n;
    }
    TH_EXPECT(prev < 60); /* 1 mm on a 20 mm circle: a few dozen chords */
}

static void test_straight_stretches_collapse_to_few_segments(void)
{
    /* 100 collinear points, then a quarter circle of 50 */
    IN.n = 0;
    for (int k = 0; k <= 100; k++)
        add(&IN, 500.0 * k, 0);
    for (int k = 1; k <= 50; k++) {
        double a = -M_PI / 2 + (M_PI / 2) * k / 50;
        add(&IN, 50000 + lround(20000 * cos(a)), 20000 + lround(20000 * sin(a)));
    }
    struct pk_smooth_cfg s;
    memset(&s, 0, sizeof s);
    s.mode = PK_SMOOTH_TOLERANCE;
    s.tolerance_um = 10;
    stroke_run(&s, max_d2());
    size_t straight = 0;
    for (size_t i = 1; i < OUT.n; i++)
        straight += OUT.p[i][0] < 45000 && OUT.p[i][1] == 0;
    /* 400 refined points on the line: one segment per PK_STROKE_DEC at most */
    TH_EXPECT(straight <= 400 / PK_STROKE_DEC + 1);
    kernel_run(3, 8, &REF);
    TH_EXPECT(hausdorff(&OUT, &REF) <= 10 + ROUND_UM);
}

static void test_sharp_corners_are_kept_exactly(void)
{
    /* a square spiral with 90-degree corners: every corner is on the path */
    IN.n = 0;
    static const int sq[][2] = { { 0, 0 }, { 10000, 0 }, { 10000, 10000 }, { 0, 10000 },
                                 { 0, 2000 }, { 8000, 2000 }, { 8000, 8000 } };
    for (unsigned k = 0; k < TH_COUNT(sq); k++)
        add(&IN, sq[k][0], sq[k][1]);
    static const uint8_t modes[] = { PK_SMOOTH_FIXED, PK_SMOOTH_TOLERANCE };
    for (unsigned mi = 0; mi < 2; mi++) {
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = modes[mi];
        s.scheme = PK_SCHEME_BSPLINE;
        s.degree = 3;
        s.depth = 4;
        s.tolerance_um = 10;
        s.sharp_turn_deg = 60;
        stroke_run(&s, max_d2());
        for (unsigned k = 0; k < TH_COUNT(sq); k++) {
            int found = 0;
            for (size_t i = 0; i < OUT.n; i++)
                found |= OUT.p[i][0] == sq[k][0] && OUT.p[i][1] == sq[k][1];
            TH_EXPECT(found);
        }
        /* and nothing strays outside the square */
        for (size_t i = 0; i < OUT.n; i++)
            TH_EXPECT(OUT.p[i][0] >= 0 && OUT.p[i][0] <= 10000 && OUT.p[i][1] >= 0
                      && OUT.p[i][1] <= 10000);
    }
    /* with sharp_turn_deg = 180 the corners are rounded instead */
    struct pk_smooth_cfg s;
    memset(&s, 0, sizeof s);
    s.mode = PK_SMOOTH_FIXED;
    s.degree = 3;
    s.depth = 4;
    s.sharp_turn_deg = 180;
    stroke_run(&s, 0);
    int found = 0;
    for (size_t i = 0; i < OUT.n; i++)
        found |= OUT.p[i][0] == 10000 && OUT.p[i][1] == 10000;
    TH_EXPECT(!found);
}

/* ---------------------------------------------------------------- machine */

static struct pk_machine M, M2;
static struct pk_rec R, R2;

static struct pk_motion_cfg mcfg(uint8_t mode)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = (pk_spmm_q16_t)llround((i ? 78.74 : 80.0) * 65536.0);
        c.max_rate[i] = 6000000;
        c.accel[i] = 1000000;
    }
    c.junction_dev_um = 20;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.smooth.mode = mode;
    c.smooth.scheme = PK_SCHEME_BSPLINE;
    c.smooth.degree = 3;
    c.smooth.depth = 3;
    c.smooth.tolerance_um = 10;
    c.smooth.sharp_turn_deg = 60;
    return c;
}

static long oracle_steps(double um, pk_spmm_q16_t s) { return lround(um * ((double)s / 65536.0) / 1000.0); }

static size_t circle_ops(struct pk_mrun_op *ops, unsigned n, double r, double turns)
{
    for (unsigned k = 1; k <= n; k++) {
        double a = M_PI + 2 * M_PI * turns * k / n;
        memset(&ops[k - 1], 0, sizeof ops[0]);
        ops[k - 1].type = MR_FEED;
        ops[k - 1].p[0] = (pk_um_t)lround(r + r * cos(a));
        ops[k - 1].p[1] = (pk_um_t)lround(r * sin(a));
        ops[k - 1].arg = 3000000;
    }
    return n;
}

static void test_smoothed_strokes_end_exactly_at_the_commanded_step(void)
{
    static const uint8_t modes[] = { PK_SMOOTH_FIXED, PK_SMOOTH_TOLERANCE };
    static struct pk_mrun_op ops[300];
    for (unsigned mi = 0; mi < 2; mi++) {
        struct pk_motion_cfg c = mcfg(modes[mi]);
        pk_rec_free(&R);
        pk_rec_init(&R, 1000000);
        TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
        size_t n = circle_ops(ops, 200, 20000, 0.8);
        struct pk_mrun_result res = pk_mrun(&M, &R, ops, n, NULL);
        TH_ASSERT(!res.timed_out);
        pk_steps_t p[PK_AXES];
        pk_machine_position_steps(&M, p);
        TH_EXPECT_EQ(p[0], oracle_steps(ops[n - 1].p[0], c.steps_per_mm_q16[0]));
        TH_EXPECT_EQ(p[1], oracle_steps(ops[n - 1].p[1], c.steps_per_mm_q16[1]));
    }
}

/* Path speed from the step trace: positions (µm) sampled every W ticks by
 * counting edges; over a window the distance is known to within one step
 * per axis at each end, so speed <= F + 2*sqrt(2)*step/W. */
static double worst_path_speed_ratio(const struct pk_rec *r, double f_mm_s, double step_um, uint64_t W)
{
    uint64_t *t[2];
    int8_t *d[2];
    size_t n[2];
    for (unsigned a = 0; a < 2; a++)
        n[a] = pk_mrun_edges(r, a, &t[a], &d[a]);
    uint64_t end = 0;
    for (unsigned a = 0; a < 2; a++)
        if (n[a] && t[a][n[a] - 1] > end)
            end = t[a][n[a] - 1];
    size_t idx[2] = { 0, 0 };
    long pos[2] = { 0, 0 }, prev[2] = { 0, 0 };
    double worst = 0, hz = r->hal.tick_hz;
    for (uint64_t s = W; s <= end + W; s += W) {
        for (unsigned a = 0; a < 2; a++)
            while (idx[a] < n[a] && t[a][idx[a]] < s)
                pos[a] += d[a][idx[a]++];
        double dist = hypot((double)(pos[0] - prev[0]), (double)(pos[1] - prev[1])) * step_um;
        double v = dist / 1000.0 / ((double)W / hz);
        double allowed = f_mm_s + 2.0 * sqrt(2.0) * step_um / 1000.0 / ((double)W / hz);
        if (v / allowed > worst)
            worst = v / allowed;
        prev[0] = pos[0];
        prev[1] = pos[1];
    }
    for (unsigned a = 0; a < 2; a++) {
        free(t[a]);
        free(d[a]);
    }
    return worst;
}

static void test_path_speed_on_arcs_and_smoothed_strokes_never_exceeds_the_feed(void)
{
    static const uint8_t modes[] = { PK_SMOOTH_OFF, PK_SMOOTH_FIXED, PK_SMOOTH_TOLERANCE };
    static struct pk_mrun_op ops[300];
    for (unsigned mi = 0; mi < 3; mi++) {
        struct pk_motion_cfg c = mcfg(modes[mi]);
        c.steps_per_mm_q16[1] = c.steps_per_mm_q16[0]; /* one step length for both */
        pk_rec_free(&R);
        pk_rec_init(&R, 1000000);
        TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
        size_t n = circle_ops(ops, 200, 20000, 1.0);
        struct pk_mrun_result res = pk_mrun(&M, &R, ops, n, NULL);
        TH_ASSERT(!res.timed_out);
        double w = worst_path_speed_ratio(&R, 50.0, 12.5, 10000); /* F3000 = 50 mm/s, 10 ms */
        TH_EXPECT(w <= 1.0);
        TH_EXPECT(w > 0.85); /* and it does run at the feed */
    }
}

static void test_a_stroke_whose_sender_stops_midway_still_completes(void)
{
    static const uint8_t modes[] = { PK_SMOOTH_OFF, PK_SMOOTH_FIXED, PK_SMOOTH_TOLERANCE };
    static struct pk_mrun_op ops[300];
    for (unsigned mi = 0; mi < 3; mi++) {
        struct pk_motion_cfg c = mcfg(modes[mi]);
        pk_rec_free(&R);
        pk_rec_init(&R, 1000000);
        TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
        size_t n = circle_ops(ops, 100, 15000, 1.0);
        /* the sender sends 37 moves, never an end-of-program, and goes quiet */
        struct pk_mrun_opts o = { .stop_after = 37 };
        struct pk_mrun_result res = pk_mrun(&M, &R, ops, n, &o);
        TH_ASSERT(!res.timed_out);
        TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
        pk_steps_t p[PK_AXES];
        pk_machine_position_steps(&M, p);
        TH_EXPECT_EQ(p[0], oracle_steps(ops[36].p[0], c.steps_per_mm_q16[0]));
        TH_EXPECT_EQ(p[1], oracle_steps(ops[36].p[1], c.steps_per_mm_q16[1]));
    }
}

static void test_a_paused_kernel_behind_a_full_queue_changes_nothing_in_the_output(void)
{
    static struct pk_mrun_op ops[400];
    struct pk_motion_cfg c = mcfg(PK_SMOOTH_TOLERANCE);
    size_t n = circle_ops(ops, 400, 15000, 1.0);
    pk_rec_free(&R);
    pk_rec_init(&R, 1000000);
    TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
    struct pk_mrun_opts fast = { .poll_ticks = 10 };
    struct pk_mrun_result ra = pk_mrun(&M, &R, ops, n, &fast);
    pk_rec_free(&R2);
    pk_rec_init(&R2, 1000000);
    TH_ASSERT_EQ(pk_machine_init(&M2, &c, &R2.hal), PK_MOTION_OK);
    struct pk_mrun_opts slow = { .poll_ticks = 1000, .feed_every = 5 };
    struct pk_mrun_result rb = pk_mrun(&M2, &R2, ops, n, &slow);
    TH_ASSERT(!ra.timed_out && !rb.timed_out);
    TH_EXPECT(rb.efull > 50);
    TH_ASSERT_EQ(R.n, R2.n);
    size_t diff = 0;
    for (size_t k = 0; k < R.n; k++) {
        const struct pk_rec_event *a = &R.ev[k], *b = &R2.ev[k];
        diff += a->tick != b->tick || a->kind != b->kind || a->mask != b->mask || a->levels != b->levels;
    }
    TH_EXPECT_EQ(diff, 0);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_level_k_polygon_is_within_the_stated_bound_of_the_curve),
        TH_CASE(test_tolerance_mode_keeps_the_path_within_T_of_the_limit_curve),
        TH_CASE(test_a_looser_tolerance_never_needs_more_segments),
        TH_CASE(test_straight_stretches_collapse_to_few_segments),
        TH_CASE(test_sharp_corners_are_kept_exactly),
        TH_CASE(test_smoothed_strokes_end_exactly_at_the_commanded_step),
        TH_CASE(test_path_speed_on_arcs_and_smoothed_strokes_never_exceeds_the_feed),
        TH_CASE(test_a_stroke_whose_sender_stops_midway_still_completes),
        TH_CASE(test_a_paused_kernel_behind_a_full_queue_changes_nothing_in_the_output),
    };
    int r = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    pk_rec_free(&R2);
    return r;
}
