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

/* The stroke assembler over IN with policy s -> OUT (with the start point).
 * chord_err: what each move declares it spent (pk_stroke_add). batch: add
 * vertices until the stroke says EBUSY before pulling (a fast sender), else
 * pull after every vertex (a slow one). */
static uint8_t g_budget;     /* pk_stroke_set_pull_budget for stroke_run_ex */
static unsigned g_yields;    /* PK_STROKE_YIELD seen */

/* pk_stroke_pull, pulling again while it yields. */
static int pull(struct pk_stroke *st, pk_um_t o[PK_AXES])
{
    int r;
    while ((r = pk_stroke_pull(st, o)) == PK_STROKE_YIELD)
        g_yields++;
    return r;
}

static void stroke_run_ex(const struct pk_smooth_cfg *s, pk_um_t chord_err, int batch)
{
    static struct pk_stroke st;
    pk_stroke_init(&st, s, 2);
    pk_stroke_set_pull_budget(&st, g_budget);
    pk_um_t p[PK_AXES] = { 0 }, o[PK_AXES];
    p[0] = (pk_um_t)IN.p[0][0];
    p[1] = (pk_um_t)IN.p[0][1];
    OUT.n = 0;
    add(&OUT, p[0], p[1]);
    TH_ASSERT_EQ(pk_stroke_begin(&st, p), 0);
    for (size_t i = 1; i < IN.n; i++) {
        p[0] = (pk_um_t)IN.p[i][0];
        p[1] = (pk_um_t)IN.p[i][1];
        int r;
        while ((r = pk_stroke_add(&st, p, chord_err)) == PK_EBUSY)
            while (pull(&st, o) == PK_OK)
                add(&OUT, o[0], o[1]);
        TH_ASSERT_EQ(r, PK_OK);
        if (!batch)
            while (pull(&st, o) == PK_OK)
                add(&OUT, o[0], o[1]);
    }
    pk_stroke_finish(&st);
    int r;
    while ((r = pull(&st, o)) == PK_OK)
        add(&OUT, o[0], o[1]);
    TH_EXPECT_EQ(r, PK_END);
    TH_EXPECT(!pk_stroke_is_open(&st));
}

static void stroke_run(const struct pk_smooth_cfg *s) { stroke_run_ex(s, 0, 0); }

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

/* Largest distance from the polyline OUT (its vertices and, sampled every
 * 0.25 µm, its edges) to the polyline IN: brute force over every segment of
 * IN, an oracle independent of the code under test. */
static double dev_out_from_in(void)
{
    double worst = 0;
    size_t j0 = 0;   /* where the last sample was nearest: search outwards from there */
    for (size_t i = 0; i + 1 < OUT.n; i++) {
        double L = hypot(OUT.p[i + 1][0] - OUT.p[i][0], OUT.p[i + 1][1] - OUT.p[i][1]);
        unsigned ns = (unsigned)fmin(4000.0, ceil(L * 4) + 1);
        for (unsigned k = 0; k <= ns; k++) {
            double t = (double)k / ns;
            double q[2] = { OUT.p[i][0] + t * (OUT.p[i + 1][0] - OUT.p[i][0]),
                            OUT.p[i][1] + t * (OUT.p[i + 1][1] - OUT.p[i][1]) };
            double best = 1e300;
            size_t nseg = IN.n > 1 ? IN.n - 1 : 0, c = j0 < nseg ? j0 : 0;
            for (size_t dd = 0; dd < nseg && best > worst; dd++) {
                /* c, c+1, c-1, c+2, c-2, ...: every segment once, nearest first */
                for (int side = 0; side < 2; side++) {
                    if (dd == 0 && side == 1)
                        break;
                    size_t j = side == 0 ? c + dd : c - dd;
                    if ((side == 0 && j >= nseg) || (side == 1 && dd > c))
                        continue;
                    double dj = seg_dist(IN.p[j], IN.p[j + 1], q);
                    if (dj < best) {
                        best = dj;
                        j0 = j;
                    }
                }
            }
            if (IN.n == 1)
                best = hypot(q[0] - IN.p[0][0], q[1] - IN.p[0][1]);
            if (best > worst)
                worst = best;
        }
    }
    return worst;
}

static void make_zigzag(unsigned n, double leg, double deg)
{
    IN.n = 0;
    double x = 0, y = 0, a = deg * M_PI / 180.0;
    add(&IN, 0, 0);
    for (unsigned k = 0; k < n; k++) {
        x += leg * cos(a);
        y += (k % 2 ? -1 : 1) * leg * sin(a);
        add(&IN, lround(x), lround(y));
    }
}

static uint32_t lcg = 12345u;
static double urand(void)
{
    lcg = lcg * 1664525u + 1013904223u;
    return (lcg >> 8) / 16777216.0;
}

/* The shapes the property runs on: random and adversarial polylines. */
#define NSHAPES 13
static const char *make_shape(int k)
{
    IN.n = 0;
    switch (k) {
    case 0: make_circle(200, 20000); return "200-gon r=20mm";
    case 1: make_wave(120, 80000, 6000, 3); return "wave";
    case 2: make_zigzag(6, 150000, 45); return "zig-zag of 150 mm legs, 45 deg";
    case 3: add(&IN, 10000, 10000); add(&IN, 110000, 10000); add(&IN, 210000, 50000);
            return "the 21.8 degree case";
    case 4: add(&IN, 0, 0); add(&IN, 50000, 0); add(&IN, 0, 87);    /* 179.9 deg */
            add(&IN, 50000, 174); return "179.9 degree reversals";
    case 5: add(&IN, 0, 0); add(&IN, 30000, 0); add(&IN, 30000, 1000); add(&IN, 0, 1000);
            add(&IN, 0, 2000); add(&IN, 30000, 2000); return "hairpins 1 mm apart";
    case 6: for (int i = 0; i <= 3000; i++)   /* 1 µm segments, wobbling */
                add(&IN, i, (i / 7) % 2);
            return "1 um segments";
    case 7: for (int i = 0; i <= 50; i++) add(&IN, 1000.0 * i, 0);
            for (int i = 1; i <= 50; i++) add(&IN, 50000, 1000.0 * i);
            return "collinear runs and a corner";
    case 8: make_circle(1257, 20000); return "dense circle, 0.1 mm chords";
    case 9: add(&IN, 0, 0); add(&IN, 40000, 0); add(&IN, 40000 + 10000, 10000);
            add(&IN, 100000, 10000); return "45 degree chamfer";
    default: {
        double x = 0, y = 0;
        add(&IN, 0, 0);
        unsigned n = 20 + (unsigned)(urand() * 200);
        double sc = k == 10 ? 200 : k == 11 ? 5000 : 60000;
        for (unsigned i = 0; i < n; i++) {
            x += (urand() - 0.5) * sc;
            y += (urand() - 0.5) * sc;
            add(&IN, lround(x), lround(y));
        }
        return "random walk";
    }
    }
}

/* The promise: within T of the PROGRAMMED polyline, at every point of the
 * executed polygon, for every shape, tolerance and corner threshold. */
static void test_tolerance_mode_keeps_the_path_within_T_of_the_programmed_polyline(void)
{
    static const pk_um_t tols[] = { 4, 20, 50, 200 };
    static const uint16_t sharp[] = { 60, 175 };
    for (int k = 0; k < NSHAPES; k++) {
        const char *name = make_shape(k);
        for (unsigned t = 0; t < TH_COUNT(tols); t++)
            for (unsigned sh = 0; sh < 2; sh++) {
                struct pk_smooth_cfg s;
                memset(&s, 0, sizeof s);
                s.mode = PK_SMOOTH_TOLERANCE;
                s.tolerance_um = tols[t];
                s.sharp_turn_deg = sharp[sh];
                stroke_run(&s);
                double d = dev_out_from_in();
                TH_EXPECT(d <= tols[t]);
                if (d > tols[t]) {
                    th_print("  ");
                    th_print(name);
                    th_print(": tol ");
                    th_print_i64(tols[t]);
                    th_print(" dev*1000 ");
                    th_print_i64((int64_t)(d * 1000));
                    th_print("\n");
                }
                /* it starts and ends exactly where the polyline does */
                TH_EXPECT(OUT.p[OUT.n - 1][0] == IN.p[IN.n - 1][0]);
                TH_EXPECT(OUT.p[OUT.n - 1][1] == IN.p[IN.n - 1][1]);
            }
    }
}

/* Corners are rounded by what the tolerance allows, not by the legs: the
 * 150 mm zig-zag and the 21.8 degree case use most of the budget at their
 * corners, and far from a corner the path stays on the leg. */
static void test_blends_are_sized_by_the_tolerance_not_by_the_legs(void)
{
    for (int k = 2; k <= 3; k++) {
        make_shape(k);
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.tolerance_um = 20;
        s.sharp_turn_deg = 175;
        stroke_run(&s);
        double d = dev_out_from_in();
        TH_EXPECT(d <= 20.0);
        TH_EXPECT(d >= 5.0);   /* the corner really is blended */
        /* every executed vertex more than 2 mm from all programmed vertices
         * lies on a leg (within the 2 µm rounding) */
        for (size_t i = 0; i < OUT.n; i++) {
            double near = 1e300, on = 1e300;
            for (size_t j = 0; j < IN.n; j++)
                near = fmin(near, hypot(OUT.p[i][0] - IN.p[j][0], OUT.p[i][1] - IN.p[j][1]));
            for (size_t j = 0; j + 1 < IN.n; j++)
                on = fmin(on, seg_dist(IN.p[j], IN.p[j + 1], OUT.p[i]));
            if (near > 2000)
                TH_EXPECT(on <= 2.0);
        }
    }
}

/* A dense polyline that approximates a curve is smoothed into that curve:
 * the executed polygon turns less per vertex than the chords do, and needs
 * fewer segments. */
static void test_a_dense_polyline_is_smoothed_into_its_curve(void)
{
    make_shape(8); /* 0.1 mm chords on r = 20 mm: 5 mrad per vertex */
    struct pk_smooth_cfg s;
    memset(&s, 0, sizeof s);
    s.mode = PK_SMOOTH_TOLERANCE;
    s.tolerance_um = 20;
    s.sharp_turn_deg = 60;
    stroke_run(&s);
    double in_turn = 0, out_turn = 0;
    for (size_t i = 1; i + 1 < IN.n; i++) {
        double a1 = atan2(IN.p[i][1] - IN.p[i - 1][1], IN.p[i][0] - IN.p[i - 1][0]);
        double a2 = atan2(IN.p[i + 1][1] - IN.p[i][1], IN.p[i + 1][0] - IN.p[i][0]);
        in_turn = fmax(in_turn, fabs(remainder(a2 - a1, 2 * M_PI)));
    }
    /* the output's turn per unit length, against the chords' 1/R */
    double worst_k = 0;
    for (size_t i = 1; i + 1 < OUT.n; i++) {
        double a1 = atan2(OUT.p[i][1] - OUT.p[i - 1][1], OUT.p[i][0] - OUT.p[i - 1][0]);
        double a2 = atan2(OUT.p[i + 1][1] - OUT.p[i][1], OUT.p[i + 1][0] - OUT.p[i][0]);
        double tu = fabs(remainder(a2 - a1, 2 * M_PI));
        double l = 0.5 * (hypot(OUT.p[i][0] - OUT.p[i - 1][0], OUT.p[i][1] - OUT.p[i - 1][1])
                          + hypot(OUT.p[i + 1][0] - OUT.p[i][0], OUT.p[i + 1][1] - OUT.p[i][1]));
        out_turn = fmax(out_turn, tu);
        if (l > 0)
            worst_k = fmax(worst_k, tu / l);
    }
    TH_EXPECT(dev_out_from_in() <= 20.0);
    TH_EXPECT(OUT.n < IN.n);                 /* fewer segments than chords */
    /* discrete curvature close to the circle's (1/20000 per µm), never the
     * chords' kinks: within 25 % (rounding of whole µm included) */
    TH_EXPECT(worst_k < 1.25 / 20000.0);
    (void)in_turn;
}

static void test_a_looser_tolerance_never_needs_more_segments(void)
{
    make_circle(200, 20000);
    size_t prev = SIZE_MAX;
    static const pk_um_t tols[] = { 4, 10, 50, 200, 1000 };
    for (unsigned t = 0; t < TH_COUNT(tols); t++) {
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.tolerance_um = tols[t];
        stroke_run(&s);
        TH_EXPECT(OUT.n <= prev);
        prev = OUT.n;
    }
    TH_EXPECT(prev < 120); /* 1 mm on a 20 mm circle: few chords */
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
    stroke_run(&s);
    size_t straight = 0;
    for (size_t i = 1; i < OUT.n; i++)
        straight += OUT.p[i][0] < 45000 && OUT.p[i][1] == 0;
    TH_EXPECT(straight <= 2);   /* the line is one chord */
    TH_EXPECT(dev_out_from_in() <= 10.0);
}

/* The points depend on the program only: a sender that delivers every
 * vertex at once and one that waits for the stroke after each give the same
 * executed path (here, at stroke level). */
static void test_the_smoothed_path_does_not_depend_on_arrival(void)
{
    static struct poly A;
    for (int k = 0; k < NSHAPES; k++) {
        make_shape(k);
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.tolerance_um = 20;
        s.sharp_turn_deg = 120;
        stroke_run_ex(&s, 0, 1);
        A = OUT;
        stroke_run_ex(&s, 0, 0);
        TH_ASSERT_EQ(A.n, OUT.n);
        TH_EXPECT(memcmp(A.p, OUT.p, A.n * sizeof A.p[0]) == 0);
    }
}

/* A pull budget only splits the work: the same path, pulled in more calls. */
static void test_a_pull_budget_changes_nothing_in_the_path(void)
{
    static struct poly A;
    static const uint8_t budgets[] = { 1, 2, 4, 7 };
    for (int k = 0; k < NSHAPES; k++) {
        make_shape(k);
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.tolerance_um = 20;
        s.sharp_turn_deg = 120;
        g_budget = 0;
        g_yields = 0;
        stroke_run_ex(&s, 0, k & 1);
        TH_EXPECT_EQ(g_yields, 0);
        A = OUT;
        for (unsigned b = 0; b < TH_COUNT(budgets); b++) {
            g_budget = budgets[b];
            g_yields = 0;
            stroke_run_ex(&s, 0, k & 1);
            TH_ASSERT_EQ(A.n, OUT.n);
            TH_EXPECT(memcmp(A.p, OUT.p, A.n * sizeof A.p[0]) == 0);
            if (budgets[b] == 1)
                TH_EXPECT(g_yields > 0);
        }
    }
    g_budget = 0;
}

/* Chords of a flattened curve declare their error: the path then stays
 * within T of the curve itself, not only of the chords. */
static void test_chord_vertices_keep_the_path_within_T_of_the_curve(void)
{
    const double R = 20000, T = 20;
    for (unsigned t = 0; t < 3; t++) {
        double e = (double)(2 + 4 * t);              /* chord error 2, 6, 10 µm */
        double c = 2 * sqrt(2 * R * e - e * e);      /* chord with sagitta e */
        unsigned n = (unsigned)ceil(2 * M_PI * R / c);
        IN.n = 0;
        for (unsigned k = 0; k <= n / 2; k++) {
            double a = M_PI * 2 * k / n;
            add(&IN, lround(R * cos(a)), lround(R * sin(a)));
        }
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.tolerance_um = (pk_um_t)T;
        s.sharp_turn_deg = 60;
        stroke_run_ex(&s, (pk_um_t)ceil(e + 0.5), 0);  /* + rounding of the vertices */
        double worst = 0;
        for (size_t i = 0; i + 1 < OUT.n; i++)
            for (unsigned k = 0; k <= 64; k++) {
                double x = OUT.p[i][0] + (OUT.p[i + 1][0] - OUT.p[i][0]) * k / 64.0;
                double y = OUT.p[i][1] + (OUT.p[i + 1][1] - OUT.p[i][1]) * k / 64.0;
                double ang = atan2(y, x);
                double dd = ang >= -1e-9 && ang <= M_PI + 1e-9 ? fabs(hypot(x, y) - R)
                            : fmin(hypot(x - R, y), hypot(x + R, y));
                worst = fmax(worst, dd);
            }
        TH_EXPECT(worst <= T);
        if (worst > T) {
            th_print("  chord error ");
            th_print_i64((int64_t)e);
            th_print(": dev*1000 ");
            th_print_i64((int64_t)(worst * 1000));
            th_print("\n");
        }
    }
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
        stroke_run(&s);
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
    stroke_run(&s);
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
        if (!(w > 0.85)) { th_print("  mode "); th_print_i64(mi); th_print_i64((int64_t)(w * 1000)); th_print("\n"); }
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
    static struct pk_mrun_op ops[401];
    struct pk_motion_cfg c = mcfg(PK_SMOOTH_TOLERANCE);
    size_t n = circle_ops(ops, 400, 15000, 1.0);
    memset(&ops[n], 0, sizeof ops[n]);
    ops[n++].type = MR_END;
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
    /* the same pins at the same times after the first edge: the start waits
     * for the look-ahead to fill, which takes longer for the slow sender */
    size_t diff = 0, f1 = 0, f2 = 0;
    while (f1 < R.n && R.ev[f1].tick == 0)     /* the writes of pk_machine_init */
        f1++;
    while (f2 < R2.n && R2.ev[f2].tick == 0)
        f2++;
    TH_ASSERT(f1 < R.n && f2 < R2.n && R.n - f1 == R2.n - f2);
    for (size_t k = 0; f1 + k < R.n; k++) {
        const struct pk_rec_event *a = &R.ev[f1 + k], *b = &R2.ev[f2 + k];
        diff += a->tick - R.ev[f1].tick != b->tick - R2.ev[f2].tick || a->kind != b->kind
                || a->mask != b->mask || a->levels != b->levels;
    }
    TH_EXPECT_EQ(diff, 0);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_level_k_polygon_is_within_the_stated_bound_of_the_curve),
        TH_CASE(test_tolerance_mode_keeps_the_path_within_T_of_the_programmed_polyline),
        TH_CASE(test_blends_are_sized_by_the_tolerance_not_by_the_legs),
        TH_CASE(test_a_dense_polyline_is_smoothed_into_its_curve),
        TH_CASE(test_the_smoothed_path_does_not_depend_on_arrival),
        TH_CASE(test_a_pull_budget_changes_nothing_in_the_path),
        TH_CASE(test_chord_vertices_keep_the_path_within_T_of_the_curve),
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
