/*
 * test_sim_path.c — the reference-path module of the simulator
 * (host-sim/sim_path.h): exact distances to lines, arcs and Béziers, and the
 * streaming windowed matcher with its figures.
 *
 * References are computed here, independently of the code under test:
 * curves are sampled densely from their own definitions (written again
 * below from G-code's terms), with the sampling error bounded by half the
 * largest spacing between samples; the matcher is checked point by point
 * against a brute-force minimum over every primitive added so far, and its
 * maximum and 95th percentile against the sorted list of those minima.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "sim_path.h"

#define PI_T 3.14159265358979323846

/* xorshift64*: reproducible random numbers */
static uint64_t rng = 0x9E3779B97F4A7C15ull;
static double urand(void)
{
    rng ^= rng >> 12;
    rng ^= rng << 25;
    rng ^= rng >> 27;
    return (double)((rng * 2685821657736338717ull) >> 11) / 9007199254740992.0;
}
static double srand_(double a, double b) { return a + (b - a) * urand(); }

/* ---- independent references ----------------------------------------------- */
static double ref_seg(const double *a, const double *b, const double *p, unsigned dims)
{
    /* endpoints, and the foot of the perpendicular if it falls inside */
    double ab[3] = { 0 }, ap[3] = { 0 }, L2 = 0, dot = 0;
    for (unsigned i = 0; i < dims; i++) {
        ab[i] = b[i] - a[i];
        ap[i] = p[i] - a[i];
        L2 += ab[i] * ab[i];
        dot += ab[i] * ap[i];
    }
    double da = 0, db = 0;
    for (unsigned i = 0; i < dims; i++) {
        da += (p[i] - a[i]) * (p[i] - a[i]);
        db += (p[i] - b[i]) * (p[i] - b[i]);
    }
    double best = sqrt(fmin(da, db));
    if (L2 > 0 && dot > 0 && dot < L2) {
        double perp2 = da - dot * dot / L2; /* Pythagoras */
        best = fmin(best, sqrt(fmax(perp2, 0.0)));
    }
    return best;
}

/* A curve sampled at n+1 points: min distance and the largest spacing. */
struct sampled { double d, spacing; };

/* Arc from G-code terms, parametrised here: plane axes u, v, w. */
struct ref_arc { double c[2], r0, r1, th0, sweep, w0, w1; unsigned u, v, w; };

static void ref_arc_make(struct ref_arc *A, const double s[3], const double e[3], const double c[2],
                         unsigned plane, int cw, unsigned turns)
{
    static const unsigned ax[3][3] = { { 0, 1, 2 }, { 2, 0, 1 }, { 1, 2, 0 } };
    A->u = ax[plane][0];
    A->v = ax[plane][1];
    A->w = ax[plane][2];
    A->c[0] = c[0];
    A->c[1] = c[1];
    A->r0 = hypot(s[A->u] - c[0], s[A->v] - c[1]);
    A->r1 = hypot(e[A->u] - c[0], e[A->v] - c[1]);
    A->th0 = atan2(s[A->v] - c[1], s[A->u] - c[0]);
    double th1 = atan2(e[A->v] - c[1], e[A->u] - c[0]);
    /* the travel in the direction asked, in (0, 2 pi] (a full circle if equal) */
    double d = cw ? A->th0 - th1 : th1 - A->th0;
    while (d <= 1e-6)
        d += 2 * PI_T;
    while (d > 2 * PI_T + 1e-6)
        d -= 2 * PI_T;
    d += 2 * PI_T * turns;
    A->sweep = cw ? -d : d;
    A->w0 = s[A->w];
    A->w1 = e[A->w];
}

static void ref_arc_at(const struct ref_arc *A, double t, double *q)
{
    double th = A->th0 + A->sweep * t, r = A->r0 + (A->r1 - A->r0) * t;
    q[A->u] = A->c[0] + r * cos(th);
    q[A->v] = A->c[1] + r * sin(th);
    q[A->w] = A->w0 + (A->w1 - A->w0) * t;
}

static void ref_bez_at(const double (*P)[3], int n, double t, double *q)
{
    double b[4][3];
    memcpy(b, P, sizeof(double) * 3 * (size_t)(n + 1));
    for (int k = n; k > 0; k--) /* de Casteljau */
        for (int i = 0; i < k; i++)
            for (int j = 0; j < 3; j++)
                b[i][j] = (1 - t) * b[i][j] + t * b[i + 1][j];
    memcpy(q, b[0], sizeof(double) * 3);
}

static double d_pts(const double *a, const double *b, unsigned dims)
{
    double s = 0;
    for (unsigned i = 0; i < dims; i++)
        s += (a[i] - b[i]) * (a[i] - b[i]);
    return sqrt(s);
}

static struct sampled sample_arc(const struct ref_arc *A, const double *p, unsigned dims, unsigned n)
{
    struct sampled s = { INFINITY, 0 };
    double prev[3], q[3];
    for (unsigned i = 0; i <= n; i++) {
        ref_arc_at(A, (double)i / n, q);
        s.d = fmin(s.d, d_pts(q, p, dims));
        if (i)
            s.spacing = fmax(s.spacing, d_pts(q, prev, dims));
        memcpy(prev, q, sizeof q);
    }
    return s;
}

static struct sampled sample_bez(const double (*P)[3], int deg, const double *p, unsigned dims, unsigned n)
{
    struct sampled s = { INFINITY, 0 };
    double prev[3], q[3];
    for (unsigned i = 0; i <= n; i++) {
        ref_bez_at(P, deg, (double)i / n, q);
        s.d = fmin(s.d, d_pts(q, p, dims));
        if (i)
            s.spacing = fmax(s.spacing, d_pts(q, prev, dims));
        memcpy(prev, q, sizeof q);
    }
    return s;
}

/* The stated accuracy: never below the true distance, at most EPS above. */
static int within_sampled(double got, struct sampled s, double eps)
{
    /* true in [s.d - spacing/2, s.d]; got in [true, true + eps] */
    return got >= s.d - s.spacing / 2.0 - 1e-7 && got <= s.d + eps + 1e-7;
}

/* ---- distances ------------------------------------------------------------ */
static void test_line_distance_is_the_exact_distance_to_the_segment(void)
{
    for (int k = 0; k < 2000; k++) {
        unsigned dims = k % 2 ? 3u : 2u;
        double a[3], b[3], p[3];
        for (int i = 0; i < 3; i++) {
            a[i] = srand_(-5e5, 5e5);
            b[i] = k % 7 == 0 ? a[i] : srand_(-5e5, 5e5); /* some zero-length */
            p[i] = srand_(-6e5, 6e5);
        }
        struct pk_path_prim pr;
        pk_path_line(&pr, a, b);
        double got = pk_path_prim_dist(&pr, p, dims, NULL), want = ref_seg(a, b, p, dims);
        TH_ASSERT(fabs(got - want) <= 1e-9 * (1.0 + want));
    }
}

static void test_arc_distance_matches_dense_sampling_of_the_arc(void)
{
    unsigned bad = 0;
    for (int k = 0; k < 40; k++) {
        unsigned plane = (unsigned)k % 3u, dims = k % 5 == 4 ? 2u : 3u;
        int cw = k % 2, kind = (k / 2) % 4; /* circle, helix, spiral, full circle */
        if (dims == 2u)
            plane = 0; /* a 2-axis machine: XY arcs */
        double c[2] = { srand_(-2e4, 2e4), srand_(-2e4, 2e4) }, r = srand_(100, 3e3);
        double t0 = srand_(-PI_T, PI_T), t1 = kind == 3 ? t0 : srand_(-PI_T, PI_T);
        double s[3] = { 0 }, e[3] = { 0 };
        static const unsigned ax[3][3] = { { 0, 1, 2 }, { 2, 0, 1 }, { 1, 2, 0 } };
        unsigned u = ax[plane][0], v = ax[plane][1], w = ax[plane][2];
        double r1 = kind == 2 ? r * srand_(0.7, 1.3) : r;
        s[u] = c[0] + r * cos(t0);
        s[v] = c[1] + r * sin(t0);
        e[u] = c[0] + r1 * cos(t1);
        e[v] = c[1] + r1 * sin(t1);
        s[w] = srand_(-1e4, 1e4);
        e[w] = kind == 1 ? s[w] + srand_(-5e3, 5e3) : s[w];
        unsigned turns = kind == 1 && k % 3 == 0 ? 2u : 0u;
        struct pk_path_prim pr;
        TH_ASSERT_EQ(pk_path_arc(&pr, s, e, c, (enum pk_path_plane)plane, cw, turns), 0);
        struct ref_arc A;
        ref_arc_make(&A, s, e, c, plane, cw, turns);
        TH_EXPECT(fabs(pr.sweep - A.sweep) < 1e-9);
        for (int j = 0; j < 3; j++) {
            double p[3];
            double t = urand();
            ref_arc_at(&A, t, p);
            double off = j < 2 ? srand_(0, 50) : srand_(0, 1e4);
            for (int i = 0; i < 3; i++)
                p[i] += srand_(-off, off);
            double got = pk_path_prim_dist(&pr, p, dims, NULL);
            struct sampled sm = sample_arc(&A, p, dims, 60000u);
            if (!within_sampled(got, sm, PK_PATH_EPS_UM)) {
                if (bad++ < 5)
                    printf("    arc k=%d j=%d: got %.6f sampled %.6f spacing %.6f\n", k, j, got, sm.d, sm.spacing);
            }
        }
    }
    TH_EXPECT_EQ(bad, 0);
}

static void test_bezier_distance_matches_dense_sampling_of_the_curve(void)
{
    unsigned bad = 0;
    for (int k = 0; k < 50; k++) {
        int deg = k % 2 ? 3 : 2;
        unsigned dims = k % 3 ? 2u : 3u;
        double P[4][3];
        for (int i = 0; i <= deg; i++)
            for (int j = 0; j < 3; j++)
                P[i][j] = srand_(-3e3, 3e3);
        if (k % 11 == 0) /* a cusp-like curve: control points doubled back */
            memcpy(P[deg - 1], P[0], sizeof P[0]);
        struct pk_path_prim pr;
        pk_path_line(&pr, P[0], P[deg]);
        pr.kind = deg == 2 ? PK_PATH_QUAD : PK_PATH_CUBIC;
        memcpy(pr.c[0], P[1], sizeof P[1]);
        if (deg == 3)
            memcpy(pr.c[1], P[2], sizeof P[2]);
        for (int j = 0; j < 4; j++) {
            double p[3];
            ref_bez_at((const double(*)[3])P, deg, urand(), p);
            double off = j < 2 ? srand_(0, 50) : srand_(0, 1e4);
            for (int i = 0; i < 3; i++)
                p[i] += srand_(-off, off);
            double got = pk_path_prim_dist(&pr, p, dims, NULL);
            struct sampled sm = sample_bez((const double(*)[3])P, deg, p, dims, 50000u);
            if (!within_sampled(got, sm, PK_PATH_EPS_UM)) {
                if (bad++ < 5)
                    printf("    bez k=%d j=%d: got %.6f sampled %.6f spacing %.6f\n", k, j, got, sm.d, sm.spacing);
            }
        }
    }
    TH_EXPECT_EQ(bad, 0);
}

/* ---- the matcher ------------------------------------------------------------ */
/* A random path, continuous: lines (some 1 µm, some repeated points), arcs, Béziers. */
static void random_prim(struct pk_path_prim *pr, double *cur, int k, uint32_t line)
{
    double e[3];
    int kind = k % 13 == 5 ? 1 : k % 17 == 3 ? 2 : k % 19 == 7 ? 3 : 0;
    double step = k % 5 == 0 ? 1.0 : srand_(10, 3000);
    double dir = srand_(-PI_T, PI_T);
    e[0] = cur[0] + step * cos(dir);
    e[1] = cur[1] + step * sin(dir);
    e[2] = cur[2] + (k % 23 == 0 ? srand_(-500, 500) : 0.0);
    if (k % 9 == 0)
        memcpy(e, cur, sizeof e); /* a repeated point */
    if (kind == 1) {
        double c[2] = { cur[0] + srand_(-2000, 2000), cur[1] + srand_(-2000, 2000) };
        double r = hypot(cur[0] - c[0], cur[1] - c[1]), th = srand_(-PI_T, PI_T);
        e[0] = c[0] + r * cos(th);
        e[1] = c[1] + r * sin(th);
        if (pk_path_arc(pr, cur, e, c, PK_PLANE_XY, k % 2, 0) != 0)
            pk_path_line(pr, cur, e);
        else
            pk_path_prim_eval(pr, 1.0, e);
    } else {
        pk_path_line(pr, cur, e);
        if (kind >= 2) {
            pr->kind = kind == 2 ? PK_PATH_QUAD : PK_PATH_CUBIC;
            for (int i = 0; i < 2; i++)
                for (int j = 0; j < 3; j++)
                    pr->c[i][j] = (j < 2 ? cur[j] + srand_(-1500, 1500) : cur[2]);
        }
    }
    pr->line = line;
    pr->drawn = (uint8_t)(k % 4 != 0);
    memcpy(cur, e, sizeof e);
}

/* A box around a primitive, computed here: a circle's square, a Bézier's
 * control points, a line's ends. */
struct tbox { double lo[3], hi[3]; };
static void test_box(const struct pk_path_prim *p, struct tbox *b)
{
    for (int i = 0; i < 3; i++) {
        b->lo[i] = fmin(p->p0[i], p->p1[i]);
        b->hi[i] = fmax(p->p0[i], p->p1[i]);
        if (p->kind == PK_PATH_QUAD || p->kind == PK_PATH_CUBIC)
            for (int k = 0; k < (p->kind == PK_PATH_QUAD ? 1 : 2); k++) {
                b->lo[i] = fmin(b->lo[i], p->c[k][i]);
                b->hi[i] = fmax(b->hi[i], p->c[k][i]);
            }
    }
    if (p->kind == PK_PATH_ARC) { /* XY arcs in these tests */
        double r = fmax(p->r0, p->r1) * (1 + 1e-9) + 1e-6;
        for (int i = 0; i < 2; i++) {
            b->lo[i] = fmin(b->lo[i], p->centre[i] - r);
            b->hi[i] = fmax(b->hi[i], p->centre[i] + r);
        }
    }
}
static double tbox_dist(const struct tbox *b, const double *q)
{
    double s = 0;
    for (int i = 0; i < 3; i++) {
        double d = q[i] < b->lo[i] ? b->lo[i] - q[i] : q[i] > b->hi[i] ? q[i] - b->hi[i] : 0;
        s += d * d;
    }
    return sqrt(s);
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Exact nearest-rank quantile of n values (sorted in place). */
static double exact_quantile(double *v, size_t n, double q)
{
    qsort(v, n, sizeof v[0], cmp_d);
    size_t rank = (size_t)ceil(q * (double)n);
    return v[(rank < 1 ? 1 : rank) - 1];
}

static void test_the_matcher_gives_the_brute_force_distance_at_every_point(void)
{
    static struct pk_path pa;
    enum { NP = 2000 };
    static struct pk_path_prim all[NP];
    static struct tbox box[NP];
    static double dev[40 * NP];
    size_t nd = 0;
    TH_ASSERT_EQ(pk_path_init(&pa, 3, 1u << 14, 12.5), 0);
    double cur[3] = { 0, 0, 0 };
    size_t n = 0, follow = 0;
    double pos[3] = { 0, 0, 0 }, worst = -1, worst_at[3] = { 0 };
    uint32_t worst_line = 0;
    unsigned mism = 0;
    for (int k = 0; k < NP; k++) {
        random_prim(&all[n], cur, k, (uint32_t)k + 1u);
        test_box(&all[n], &box[n]);
        pk_path_add(&pa, &all[n]);
        n++;
        /* the executed path: points along a primitive far behind, with noise */
        while (follow + 40u < n || (k == NP - 1 && follow < n)) {
            for (int s = 0; s < 4; s++) {
                double q[3];
                pk_path_prim_eval(&all[follow], (s + urand()) / 4.0, q);
                double noise = (s == 3 && follow % 50 == 0) ? 800.0 : 8.0; /* now and then far off */
                for (int i = 0; i < 3; i++)
                    pos[i] = q[i] + srand_(-noise, noise);
                uint32_t line;
                double got = pk_path_measure(&pa, pos, (uint64_t)nd, &line, NULL);
                double want = INFINITY;
                uint32_t want_line = 0;
                for (size_t j = 0; j < n; j++) {
                    if (tbox_dist(&box[j], pos) > want)
                        continue; /* its box is farther than the best so far */
                    double d = pk_path_prim_dist(&all[j], pos, 3, NULL);
                    if (d < want) {
                        want = d;
                        want_line = all[j].line;
                    }
                }
                if (fabs(got - want) > 1e-6 + 1e-9 * want) {
                    if (mism++ < 5)
                        printf("    point %zu: got %.6f want %.6f\n", nd, got, want);
                }
                (void)want_line;
                dev[nd++] = want;
                if (want > worst) {
                    worst = want;
                    memcpy(worst_at, pos, sizeof pos);
                    worst_line = line;
                }
            }
            follow++;
        }
    }
    TH_EXPECT_EQ(mism, 0);
    TH_EXPECT_EQ(pa.st.points, nd);
    TH_EXPECT(pa.st.max_um == worst);
    TH_EXPECT(memcmp(pa.st.max_at_um, worst_at, sizeof worst_at) == 0);
    TH_EXPECT_EQ(pa.st.max_line, worst_line);
    TH_EXPECT_EQ(pa.st.forced_drops, 0);
    TH_EXPECT(pa.st.stored < pa.st.prims); /* the repeated points were not stored */
    double q95 = pk_path_quantile(&pa, 0.95), want95 = exact_quantile(dev, nd, 0.95);
    TH_EXPECT(q95 >= want95 && q95 <= want95 * (1 + PK_PATH_HIST_REL) + PK_PATH_HIST_MIN_UM);
    double q50 = pk_path_quantile(&pa, 0.5), want50 = exact_quantile(dev, nd, 0.5);
    TH_EXPECT(q50 >= want50 && q50 <= want50 * (1 + PK_PATH_HIST_REL) + PK_PATH_HIST_MIN_UM);
    if (getenv("PK_VERBOSE"))
        printf("    %zu points, %llu rebuilds, max %.3f um, p95 %.3f (exact %.3f)\n", nd,
               (unsigned long long)pa.st.rebuilds, worst, q95, want95);
    pk_path_free(&pa);
}

/* A hatch of long strokes with short links (the grid's cells grow, long
 * strokes go to its long list), then a dense scribble of 20 µm moves over
 * it: every point against brute force over everything added. */
static void test_hatches_and_scribbles_through_the_grid_match_brute_force(void)
{
    static struct pk_path pa;
    enum { NP = 4000 };
    static struct pk_path_prim all[NP];
    static struct tbox box[NP];
    TH_ASSERT_EQ(pk_path_init(&pa, 2, 1u << 13, 12.5), 0);
    double cur[3] = { 0, 0, 0 };
    size_t n = 0;
    unsigned mism = 0, pts = 0;
    for (int k = 0; k < NP; k++) {
        double e[3] = { 0, 0, 0 };
        if (k % 500 == 7) { /* now and then a 200 mm diagonal (the grid's long list) */
            e[0] = cur[0] > 1e5 ? 0.0 : 2e5;
            e[1] = cur[1] + (cur[0] > 1e5 ? -1e5 : 1e5);
        } else if (k < 3000) { /* strokes of 30 mm, 0.2 mm apart, joined by 0.2 mm links */
            int row = k / 2;
            e[0] = k % 2 ? cur[0] : row % 2 == 0 ? 30000.0 : 0.0;
            e[1] = k % 2 ? cur[1] + 200.0 : cur[1];
        } else {
            e[0] = cur[0] + srand_(-20, 20);
            e[1] = fmin(fmax(cur[1] + srand_(-20, 20), 0), 3e5);
        }
        pk_path_line(&all[n], cur, e);
        all[n].line = (uint32_t)k + 1u;
        test_box(&all[n], &box[n]);
        pk_path_add(&pa, &all[n]);
        memcpy(cur, e, sizeof cur);
        n++;
        if (k % 3 != 0)
            continue;
        double q[3];
        pk_path_prim_eval(&all[(size_t)(urand() * (double)n)], urand(), q);
        q[0] += srand_(-40, 40);
        q[1] += srand_(-40, 40);
        double got = pk_path_measure(&pa, q, pts++, NULL, NULL), want = INFINITY;
        for (size_t j = 0; j < n; j++)
            if (tbox_dist(&box[j], q) <= want)
                want = fmin(want, pk_path_prim_dist(&all[j], q, 2, NULL));
        if (fabs(got - want) > 1e-6 + 1e-9 * want && mism++ < 5)
            printf("    k %d: got %.6f want %.6f\n", k, got, want);
    }
    TH_EXPECT_EQ(mism, 0);
    TH_EXPECT(pa.grid_on && pa.grid_rebuilds >= 1u && pa.n_long > 0u);
    if (getenv("PK_VERBOSE"))
        printf("    grid: %llu stored, cell %.0f um, %u nodes, %u long, %llu rebuilds\n", (unsigned long long)pa.st.stored, pa.cell_um, pa.g_nodes, pa.n_long,
               (unsigned long long)pa.grid_rebuilds);
    pk_path_free(&pa);
}

/*
 * A long path through a small window, as a producer that waits for room
 * feeds it: the executed points lag far behind the newest primitive; the
 * path never comes back near itself, so the distance to the window must
 * equal the distance to the whole path, and nothing is dropped early.
 */
static void test_a_small_window_keeps_what_the_machine_has_not_passed(void)
{
    static struct pk_path pa;
    enum { NP = 20000, LAG = 700 };
    static struct pk_path_prim all[NP];
    TH_ASSERT_EQ(pk_path_init(&pa, 2, 1024, 12.5), 0);
    size_t n = 0, follow = 0;
    unsigned mism = 0, waited = 0;
    double prev[3] = { 0, 0, 0 };
    uint64_t pts = 0;
    while (follow < NP) {
        /* producer: add while the window has room, up to LAG ahead */
        while (n < NP && n < follow + LAG) {
            if (pk_path_room(&pa) == 0u) {
                waited++;
                break;
            }
            /* an outward spiral of 3..100 µm chords that zig-zags by 30 µm
             * (no run of them is straight): never near its past */
            double th = 0.0005 * (double)n, r = 5000 + 3.0 * (double)n + (n % 2 ? 30.0 : 0.0);
            double e[3] = { r * cos(th), r * sin(th), 0 };
            pk_path_line(&all[n], prev, e);
            all[n].line = (uint32_t)n + 1u;
            pk_path_add(&pa, &all[n]);
            memcpy(prev, e, sizeof e);
            n++;
        }
        if (follow >= n)
            break;
        double q[3];
        pk_path_prim_eval(&all[follow], urand(), q);
        q[0] += srand_(-6, 6);
        q[1] += srand_(-6, 6);
        double got = pk_path_measure(&pa, q, pts++, NULL, NULL);
        /* the whole path so far (a primitive 1000 behind is half a radian away) */
        double want = INFINITY;
        for (size_t j = follow > 1000 ? follow - 1000 : 0; j < n; j++)
            want = fmin(want, ref_seg(all[j].p0, all[j].p1, q, 2));
        if (fabs(got - want) > 1e-6 + 1e-9 * want && mism++ < 5)
            printf("    follow %zu: got %.6f want %.6f\n", follow, got, want);
        follow++;
    }
    TH_EXPECT_EQ(n, NP);
    TH_EXPECT_EQ(mism, 0);
    TH_EXPECT_EQ(pa.st.forced_drops, 0);
    TH_EXPECT(pa.st.dropped > 15000u);
    TH_EXPECT(waited > 0u); /* the window was full at times: the producer waited */
    pk_path_free(&pa);
}

/* A producer that does not wait: the drops are counted, and a figure can
 * then only be larger than the distance to the whole path, never smaller. */
/*
 * Runs: a million collinear points 1 µm apart are one entry (exact), however
 * far behind the points are; a slanted line of points rounded to the µm,
 * added while the window is short of room, is held within PK_PATH_MERGE_UM.
 */
static void test_straight_runs_of_points_are_held_as_one_segment(void)
{
    static struct pk_path pa;
    TH_ASSERT_EQ(pk_path_init(&pa, 2, 1024, 12.5), 0);
    double prev[3] = { 0, 10000, 0 };
    for (int i = 1; i <= 1000000; i++) {
        double e[3] = { (double)i, 10000, 0 };
        struct pk_path_prim p;
        pk_path_line(&p, prev, e);
        p.line = (uint32_t)i;
        pk_path_add(&pa, &p);
        memcpy(prev, e, sizeof e);
    }
    TH_EXPECT_EQ(pa.st.stored, 1u);
    TH_EXPECT_EQ(pa.st.merged, 999999u);
    TH_EXPECT(pa.st.approx_um == 0.0);
    double q[3] = { 123456.5, 10003.25, 0 };
    uint32_t line;
    TH_EXPECT(pk_path_measure(&pa, q, 0, &line, NULL) == 3.25);
    TH_EXPECT_EQ(line, 1u);
    TH_EXPECT_EQ(pa.st.max_line_last, 1000000u);
    pk_path_free(&pa);

    /* slanted, rounded, in a window kept short of room (the points lag 900 behind) */
    static struct pk_path_prim all[20001];
    TH_ASSERT_EQ(pk_path_init(&pa, 2, 1024, 12.5), 0);
    double cur[3] = { 0, 0, 0 };
    unsigned bad = 0;
    for (int i = 1; i <= 20000; i++) {
        double e[3] = { (double)i, (double)lround(0.37 * i), 0 };
        pk_path_line(&all[i], cur, e);
        pk_path_add(&pa, &all[i]);
        memcpy(cur, e, sizeof e);
        if (i > 900 && i % 7 == 0) {
            double q2[3];
            pk_path_prim_eval(&all[i - 900], urand(), q2);
            q2[0] += srand_(-8, 8);
            q2[1] += srand_(-8, 8);
            double got = pk_path_measure(&pa, q2, 0, NULL, NULL), want = INFINITY;
            for (int j = i > 1900 ? i - 1900 : 1; j <= i; j++)
                want = fmin(want, ref_seg(all[j].p0, all[j].p1, q2, 2));
            if (!(fabs(got - want) <= PK_PATH_MERGE_UM + 1e-9) && bad++ < 3)
                printf("    slanted %d: got %.4f want %.4f\n", i, got, want);
        }
    }
    TH_EXPECT_EQ(bad, 0);
    TH_EXPECT(pa.st.merged_approx > 0u);
    TH_EXPECT(pa.st.approx_um == PK_PATH_MERGE_UM);
    TH_EXPECT_EQ(pa.st.forced_drops, 0);
    pk_path_free(&pa);
}

static void test_forced_drops_are_counted_and_only_make_figures_larger(void)
{
    static struct pk_path pa;
    TH_ASSERT_EQ(pk_path_init(&pa, 2, 1024, 12.5), 0);
    double prev[3] = { 0, 0, 0 };
    struct pk_path_prim first;
    for (int k = 0; k < 5000; k++) {
        double e[3] = { (double)(k + 1) * 10.0, (k % 2) * 10.0, 0 };
        struct pk_path_prim p;
        pk_path_line(&p, prev, e);
        if (k == 0)
            first = p;
        pk_path_add(&pa, &p);
        memcpy(prev, e, sizeof e);
    }
    TH_EXPECT(pa.st.forced_drops >= 5000u - 1024u);
    double q[3] = { 5, 2, 0 };
    double got = pk_path_measure(&pa, q, 0, NULL, NULL);
    TH_EXPECT(got >= pk_path_prim_dist(&first, q, 2, NULL));
    TH_EXPECT(got > 1000.0); /* the point's own primitive is gone: large, not silently small */
    pk_path_free(&pa);
}

/* A square drawn 400 times (multi-pass): each pass replaces the last in the
 * window, so matching costs one square, the window never fills with copies
 * (a waiting producer is never stuck), and the figures are those of the
 * square; the line number reported is the latest pass's. */
static void test_a_stroke_drawn_many_times_is_matched_once(void)
{
    static struct pk_path pa;
    TH_ASSERT_EQ(pk_path_init(&pa, 2, 1024, 12.5), 0);
    const double sq[5][3] = { { 0, 0, 0 }, { 5000, 0, 0 }, { 5000, 5000, 0 }, { 0, 5000, 0 }, { 0, 0, 0 } };
    unsigned added = 0, mism = 0;
    for (int pass = 0; pass < 400; pass++)
        for (int e = 0; e < 4; e++) {
            TH_ASSERT(pk_path_room(&pa) > 0u);
            struct pk_path_prim p;
            pk_path_line(&p, sq[e], sq[e + 1]);
            p.line = (uint32_t)(pass * 4 + e + 1);
            pk_path_add(&pa, &p);
            added++;
            double q[3] = { sq[e][0] + (sq[e + 1][0] - sq[e][0]) * urand() + srand_(-9, 9),
                            sq[e][1] + (sq[e + 1][1] - sq[e][1]) * urand() + srand_(-9, 9), 0 };
            uint32_t line;
            double got = pk_path_measure(&pa, q, added, &line, NULL);
            double want = INFINITY;
            for (int k = 0; k < 4; k++)
                want = fmin(want, ref_seg(sq[k], sq[k + 1], q, 2));
            if (fabs(got - want) > 1e-6 || (pass > 0 && line <= (uint32_t)((pass - 1) * 4 + e + 1)))
                mism++;
        }
    TH_EXPECT_EQ(mism, 0);
    TH_EXPECT_EQ(pa.st.repeats, 399u * 4u);
    TH_EXPECT_EQ(pa.st.forced_drops, 0);
    pk_path_free(&pa);
}

static void test_points_before_any_primitive_are_counted_unmatched(void)
{
    static struct pk_path pa;
    TH_ASSERT_EQ(pk_path_init(&pa, 3, 0, 12.5), 0);
    double q[3] = { 1, 2, 3 };
    TH_EXPECT(pk_path_measure(&pa, q, 0, NULL, NULL) < 0.0);
    TH_EXPECT_EQ(pa.st.unmatched, 1);
    TH_EXPECT_EQ(pa.st.points, 0);
    TH_EXPECT(pk_path_quantile(&pa, 0.95) == 0.0);
    pk_path_free(&pa);
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_line_distance_is_the_exact_distance_to_the_segment),
        TH_CASE(test_arc_distance_matches_dense_sampling_of_the_arc),
        TH_CASE(test_bezier_distance_matches_dense_sampling_of_the_curve),
        TH_CASE(test_the_matcher_gives_the_brute_force_distance_at_every_point),
        TH_CASE(test_hatches_and_scribbles_through_the_grid_match_brute_force),
        TH_CASE(test_a_small_window_keeps_what_the_machine_has_not_passed),
        TH_CASE(test_straight_runs_of_points_are_held_as_one_segment),
        TH_CASE(test_forced_drops_are_counted_and_only_make_figures_larger),
        TH_CASE(test_a_stroke_drawn_many_times_is_matched_once),
        TH_CASE(test_points_before_any_primitive_are_counted_unmatched),
    };
    return th_run(cases, TH_COUNT(cases));
}
