/*
 * test_arc.c — G2/G3 arc flattening (firmware/pk_arc.c) against an
 * independent reference.
 *
 * Reference: the programmed curve of pk_arc.h (centre, radius going linearly
 * from |S-C| to |E-C| with the swept angle, Grbl's swept-angle rule)
 * evaluated in long double (64-bit mantissa: below 1e-9 µm of error at these
 * magnitudes, so the bounds below are checked with a margin of 1e-6 µm).
 * The R-form reference centre is Grbl's formula evaluated in long double.
 * Where the curve is a circle with an integer centre, "vertex within 1 µm of
 * the circle" is also checked exactly in 128-bit integers.
 *
 * Stated bounds (pk_arc.h): every vertex within 1 µm of the curve (in the
 * plane), every chord within the tolerance of the curve and the curve within
 * the tolerance of its chords, the last vertex exactly the end point, the
 * linear axis within 0.5 µm of its linear interpolation; chord counts
 * within 5 % (+2) of the fewest a perfect flattener with exact vertices
 * could use for the tolerance left after the vertex error.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "pk_arc.h"

int th_main(int argc, char **argv);

typedef long double ld;
#define PI_L 3.14159265358979323846264338327950288L
#define MARGIN 1e-6L

static uint64_t rs = 0x9e3779b97f4a7c15ull;
static int64_t rnd(int64_t lo, int64_t hi)
{
    rs ^= rs << 13;
    rs ^= rs >> 7;
    rs ^= rs << 17;
    return lo + (int64_t)(rs % (uint64_t)(hi - lo + 1));
}

/* ---- the reference curve ------------------------------------------------ */

struct ref {
    ld cx, cy;        /* centre, µm */
    ld r0, r1;        /* radii at start and end */
    ld a0;            /* angle of the start */
    ld sweep;         /* swept angle, rad, > 0 */
    int cw;
};

static ld ang(ld y, ld x) { return atan2l(y, x); }

static void ref_init(struct ref *r, const struct pk_arc_geom *g, ld cx, ld cy)
{
    r->cx = cx;
    r->cy = cy;
    r->cw = g->cw;
    ld sx = g->start[g->a0] - cx, sy = g->start[g->a1] - cy;
    ld ex = g->end[g->a0] - cx, ey = g->end[g->a1] - cy;
    r->r0 = sqrtl(sx * sx + sy * sy);
    r->r1 = sqrtl(ex * ex + ey * ey);
    r->a0 = ang(sy, sx);
    /* Grbl: angular travel = atan2(cross, dot); CW: if >= -eps, -= 2pi; CCW:
     * if <= eps, += 2pi. */
    ld t = atan2l(sx * ey - sy * ex, sx * ex + sy * ey);
    if (g->cw) {
        if (t >= -5e-7L)
            t -= 2 * PI_L;
        r->sweep = -t;
    } else {
        if (t <= 5e-7L)
            t += 2 * PI_L;
        r->sweep = t;
    }
}

/* Curve point at swept fraction s in [0, 1]. */
static void ref_at(const struct ref *r, ld s, ld *x, ld *y)
{
    ld th = r->a0 + (r->cw ? -1 : 1) * s * r->sweep;
    ld rho = r->r0 + (r->r1 - r->r0) * s;
    *x = r->cx + rho * cosl(th);
    *y = r->cy + rho * sinl(th);
}

/* Swept fraction of a point's direction (the candidates 2pi apart). */
static int ref_fracs(const struct ref *r, ld x, ld y, ld out[4])
{
    ld th = ang(y - r->cy, x - r->cx);
    ld d = (r->cw ? -1 : 1) * (th - r->a0);
    d = fmodl(d, 2 * PI_L);
    if (d < 0)
        d += 2 * PI_L;
    int n = 0;
    for (int k = -1; k <= 1; k++) {
        ld s = (d + k * 2 * PI_L) / r->sweep;
        if (s >= -1e-9L && s <= 1 + 1e-9L)
            out[n++] = s < 0 ? 0 : s > 1 ? 1 : s;
    }
    if (n == 0) { /* outside the swept range: nearest end */
        ld s_end = ((d - r->sweep) < (2 * PI_L - d)) ? 1 : 0;
        out[n++] = s_end;
    }
    return n;
}

/* Distance from (x, y) to the curve, near the point's own direction. */
static ld ref_dist(const struct ref *r, ld x, ld y)
{
    ld f[4];
    int nf = ref_fracs(r, x, y, f);
    ld best = 1e30L;
    for (int i = 0; i < nf; i++) {
        ld px, py;
        ref_at(r, f[i], &px, &py);
        ld d = hypotl(px - x, py - y);
        if (d < best)
            best = d;
    }
    return best;
}

static ld seg_dist(ld qx, ld qy, ld ax, ld ay, ld bx, ld by)
{
    ld dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    ld t = l2 > 0 ? ((qx - ax) * dx + (qy - ay) * dy) / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return hypotl(ax + t * dx - qx, ay + t * dy - qy);
}

/* ---- running one arc ------------------------------------------------------ */

#define VMAX 200000
static pk_um_t V[VMAX][PK_AXES];

struct outcome {
    uint32_t n;
    ld worst_vertex;   /* max vertex distance from the curve */
    ld worst_chord;    /* max chord <-> curve distance (both ways) */
    ld worst_lin;      /* max linear-axis error */
    int end_exact;
    int exact_circle_ok; /* integer check, when applicable (else 1) */
};

static int run_arc(const struct pk_arc_geom *g, pk_um_t tol, const struct ref *r, struct outcome *o)
{
    static struct pk_arc a;
    memset(o, 0, sizeof *o);
    int rc = pk_arc_plan(&a, g, tol);
    if (rc != PK_ARC_OK)
        return rc;
    uint32_t n = 0;
    pk_um_t p[PK_AXES];
    while (n < VMAX && pk_arc_next(&a, p)) {
        memcpy(V[n], p, sizeof p);
        n++;
    }
    o->n = n;
    o->end_exact = n > 0 && memcmp(V[n - 1], g->end, sizeof g->end) == 0 &&
                   n == pk_arc_chords(&a);
    o->exact_circle_ok = 1;
    ld prevx = g->start[g->a0], prevy = g->start[g->a1];
    ld prev_s = 0;
    for (uint32_t k = 0; k < n; k++) {
        ld x = V[k][g->a0], y = V[k][g->a1];
        ld dv = ref_dist(r, x, y);
        if (dv > o->worst_vertex)
            o->worst_vertex = dv;
        /* the piece of curve this chord replaces: between the fractions of
         * its two vertices (nearest candidate after the previous one) */
        ld f[4];
        int nf = ref_fracs(r, x, y, f);
        ld s = k + 1 == n ? 1 : f[0];
        for (int i = 0; i < nf; i++)
            if (f[i] >= prev_s - 1e-6L && (s < prev_s - 1e-6L || f[i] < s))
                s = f[i];
        if (k + 1 == n)
            s = 1;
        for (int j = 0; j <= 8; j++) {
            ld cx, cy;
            ref_at(r, prev_s + (s - prev_s) * j / 8, &cx, &cy);
            ld d = seg_dist(cx, cy, prevx, prevy, x, y);
            if (d > o->worst_chord)
                o->worst_chord = d;
            ld qx = prevx + (x - prevx) * j / 8, qy = prevy + (y - prevy) * j / 8;
            ld d2 = ref_dist(r, qx, qy);
            if (d2 > o->worst_chord)
                o->worst_chord = d2;
        }
        if (g->al < PK_AXES && k + 1 < n) {
            /* nominal swept fraction of vertex k + 1: (k + 1) / n */
            ld z = g->start[g->al] + (ld)(g->end[g->al] - g->start[g->al]) * (k + 1) / n;
            ld dz = fabsl(V[k][g->al] - z);
            if (dz > o->worst_lin)
                o->worst_lin = dz;
        }
        prevx = x;
        prevy = y;
        prev_s = s;
    }
    return PK_ARC_OK;
}

/* Exact: (|p-C| - r)^2 <= 1 for integer centre C and r^2 = |S-C|^2, i.e.
 * |p-C|^2 in [r^2 - 2r + 1, r^2 + 2r + 1]: with D = |p-C|^2 - r^2 - 1,
 * D^2 <= 4 r^2. */
static int exact_on_circle(const struct pk_arc_geom *g, int64_t cx, int64_t cy, uint32_t n)
{
    __int128 r2 = (__int128)(g->start[g->a0] - cx) * (g->start[g->a0] - cx) +
                  (__int128)(g->start[g->a1] - cy) * (g->start[g->a1] - cy);
    for (uint32_t k = 0; k + 1 < n; k++) {
        __int128 dx = V[k][g->a0] - cx, dy = V[k][g->a1] - cy;
        __int128 d = dx * dx + dy * dy - r2 - 1;
        if (d * d > 4 * r2)
            return 0;
    }
    return 1;
}

/* Fewest chords with exact vertices for sagitta budget s on radius r. */
static ld optimal_chords(ld r, ld sweep, ld s)
{
    if (s >= r)
        return 1;
    ld d = 2 * acosl(1 - s / r);
    return ceill(sweep / d);
}

static void random_geom(struct pk_arc_geom *g, int64_t rmax)
{
    memset(g, 0, sizeof *g);
    int plane = (int)rnd(0, PK_AXES >= 3 ? 2 : 0);
    static const uint8_t pl[3][3] = { { 0, 1, 2 }, { 2, 0, 1 }, { 1, 2, 0 } };
    g->a0 = pl[plane][0];
    g->a1 = pl[plane][1];
    g->al = PK_AXES >= 3 ? pl[plane][2] : PK_AXES;
    g->cw = (uint8_t)rnd(0, 1);
    for (int i = 0; i < PK_AXES; i++)
        g->start[i] = (pk_um_t)rnd(-1000000, 1000000);
    (void)rmax;
}

/* ---- tests ------------------------------------------------------------------ */

static void test_cordic_rotation_and_angle_match_the_reference(void)
{
    ld worst_rot = 0, worst_ang = 0;
    for (int t = 0; t < 20000; t++) {
        uint32_t phi = (uint32_t)rnd(0, 0xffffffffll);
        int32_t v[2] = { (int32_t)rnd(-600000000, 600000000), (int32_t)rnd(-600000000, 600000000) };
        ld x0 = v[0], y0 = v[1];
        pk_arc_rotate(v, phi);
        ld th = phi * (2 * PI_L / 4294967296.0L);
        ld K = 1.6467602581210656483L;
        ld ex = K * (x0 * cosl(th) - y0 * sinl(th)), ey = K * (x0 * sinl(th) + y0 * cosl(th));
        ld e = hypotl(v[0] - ex, v[1] - ey);
        if (e > worst_rot)
            worst_rot = e;
        int64_t ax = rnd(-(1ll << 40), 1ll << 40), ay = rnd(-(1ll << 40), 1ll << 40);
        if (t % 3 == 0) {
            ax >>= 30;
            ay >>= 30;
        }
        if (ax == 0 && ay == 0)
            continue;
        uint32_t a = pk_arc_atan2(ay, ax);
        ld ref = atan2l((ld)ay, (ld)ax);
        if (ref < 0)
            ref += 2 * PI_L;
        ld got = a * (2 * PI_L / 4294967296.0L);
        ld d = fabsl(got - ref);
        if (d > PI_L)
            d = 2 * PI_L - d;
        if (d > worst_ang)
            worst_ang = d;
    }
    /* 30 steps with rounded shifts on a Q30-sized vector: a few dozen LSB,
     * i.e. a relative 3e-8; the angle to 2^-24 rad. */
    TH_EXPECT(worst_rot < 40);
    TH_EXPECT(worst_ang < 6e-8L);
}

static void test_ijk_arcs_vertices_on_the_curve_chords_within_tolerance_end_exact(void)
{
    int cases = 0, exact_cases = 0;
    ld worst_v = 0, worst_c_over = -1e9L, worst_ratio = 0;
    for (int t = 0; t < 500; t++) {
        struct pk_arc_geom g;
        random_geom(&g, 0);
        int64_t rad = t % 5 == 0 ? rnd(1, 200) : t % 5 == 1 ? rnd(200, 20000)
                      : t % 5 == 2 ? rnd(20000, 500000) : rnd(500000, 4000000);
        ld a = rnd(0, 1000000) * (2 * PI_L / 1000000);
        int32_t i = (int32_t)llroundl(-rad * cosl(a)), j = (int32_t)llroundl(-rad * sinl(a));
        int64_t cx = g.start[g.a0] + i, cy = g.start[g.a1] + j;
        ld r0 = hypotl(i, j);
        int full = t % 7 == 0;
        ld b = rnd(0, 1000000) * (2 * PI_L / 1000000);
        for (int ax = 0; ax < PK_AXES; ax++)
            g.end[ax] = g.start[ax];
        if (!full) {
            g.end[g.a0] = (pk_um_t)llroundl(cx + r0 * cosl(b));
            g.end[g.a1] = (pk_um_t)llroundl(cy + r0 * sinl(b));
        }
        if (g.al < PK_AXES)
            g.end[g.al] = (pk_um_t)(g.start[g.al] + (t % 3 ? 0 : rnd(-50000, 50000)));
        int rc = pk_arc_centre_ijk(&g, i, j);
        if (rc != PK_ARC_OK) {
            /* only radii beyond 2^22 µm may be refused */
            TH_EXPECT(rad >= (1 << 22) - 2);
            continue;
        }
        pk_um_t tol = (pk_um_t)(t % 4 == 0 ? 1 : t % 4 == 1 ? 2 : rnd(3, 100));
        struct ref r;
        ref_init(&r, &g, (ld)cx, (ld)cy);
        struct outcome o;
        TH_ASSERT_EQ(run_arc(&g, tol, &r, &o), PK_ARC_OK);
        cases++;
        TH_EXPECT(o.end_exact);
        TH_EXPECT(o.worst_vertex <= 1 + MARGIN);
        TH_EXPECT(o.worst_chord <= tol + MARGIN);
        TH_EXPECT(o.worst_lin <= 0.5L + 1e-3L + MARGIN);
        if (r.r0 == r.r1 || fabsl(r.r0 - r.r1) < 1e-12L) {
            TH_EXPECT(exact_on_circle(&g, cx, cy, o.n));
            exact_cases++;
        }
        if (o.worst_vertex > worst_v)
            worst_v = o.worst_vertex;
        if (o.worst_chord - tol > worst_c_over)
            worst_c_over = o.worst_chord - tol;
        ld opt = optimal_chords(fmaxl(r.r0, r.r1), r.sweep, tol - 0.85L);
        if (opt < ceill(r.sweep / (PI_L / 2)))
            opt = ceill(r.sweep / (PI_L / 2));
        ld ratio = o.n / opt;
        if (ratio > worst_ratio)
            worst_ratio = ratio;
        if (!(o.n <= opt * 1.05L + 2))
            printf("  n %u opt %.1Lf r0 %.1Lf r1 %.1Lf sweep %.4Lf tol %d\n", o.n, opt, r.r0, r.r1, r.sweep, tol);
        TH_EXPECT(o.n <= opt * 1.05L + 2);
        if (full)
            TH_EXPECT(fabsl(r.sweep - 2 * PI_L) < 1e-6L);
    }
    TH_EXPECT(cases > 450);
    TH_EXPECT(exact_cases > 20);
    char msg[200];
    snprintf(msg, sizeof msg, "  ijk: %d arcs, worst vertex %.3Lf um, worst chord - tol %.3Lf um, chords/optimal %.3Lf\n",
             cases, worst_v, worst_c_over, worst_ratio);
    th_print(msg);
}

static void test_full_circle_when_the_end_is_the_start_and_grbl_epsilon(void)
{
    struct pk_arc_geom g;
    memset(&g, 0, sizeof g);
    g.a0 = 0;
    g.a1 = 1;
    g.al = PK_AXES >= 3 ? 2 : PK_AXES;
    g.start[0] = 10000;
    g.start[1] = 0;
    memcpy(g.end, g.start, sizeof g.end);
    TH_ASSERT_EQ(pk_arc_centre_ijk(&g, -10000, 0), PK_ARC_OK);
    static struct pk_arc a;
    for (int cw = 0; cw <= 1; cw++) {
        g.cw = (uint8_t)cw;
        TH_ASSERT_EQ(pk_arc_plan(&a, &g, 2), PK_ARC_OK);
        TH_EXPECT_EQ(pk_arc_sweep(&a), PK_ARC_TURN);
        TH_EXPECT(pk_arc_chords(&a) >= 4);
        /* the first vertex turns the right way */
        pk_um_t p[PK_AXES];
        TH_ASSERT(pk_arc_next(&a, p));
        TH_EXPECT(cw ? p[1] < 0 : p[1] > 0);
        int32_t lo[PK_AXES], hi[PK_AXES];
        pk_arc_bounds(&a, lo, hi);
        TH_EXPECT_EQ(lo[0], -10000);
        TH_EXPECT_EQ(hi[0], 10000);
        TH_EXPECT_EQ(lo[1], -10000);
        TH_EXPECT_EQ(hi[1], 10000);
    }
    /* A CCW end a hair before the start (within Grbl's 5e-7 rad on a 10 mm
     * radius: 0.005 µm, so the same point): full circle; an end 1 µm past
     * the start is 1e-4 rad: a tiny arc, not a circle. */
    g.cw = 0;
    g.end[1] = 1;
    g.end[0] = 10000;
    TH_ASSERT_EQ(pk_arc_centre_ijk(&g, -10000, 0), PK_ARC_OK);
    TH_ASSERT_EQ(pk_arc_plan(&a, &g, 2), PK_ARC_OK);
    TH_EXPECT(pk_arc_sweep(&a) < PK_ARC_TURN / 1000u);
    TH_EXPECT_EQ(pk_arc_chords(&a), 1);
    g.end[1] = -1;
    TH_ASSERT_EQ(pk_arc_centre_ijk(&g, -10000, 0), PK_ARC_OK);
    TH_ASSERT_EQ(pk_arc_plan(&a, &g, 2), PK_ARC_OK);
    TH_EXPECT(pk_arc_sweep(&a) > PK_ARC_TURN - PK_ARC_TURN / 1000u);
}

static void test_r_form_arcs_lie_on_the_exact_circle(void)
{
    int cases = 0;
    ld worst_v = 0;
    for (int t = 0; t < 400; t++) {
        struct pk_arc_geom g;
        random_geom(&g, 0);
        for (int ax = 0; ax < PK_AXES; ax++)
            g.end[ax] = g.start[ax];
        int64_t c = t % 4 == 0 ? rnd(1, 100) : t % 4 == 1 ? rnd(100, 10000) : rnd(10000, 1000000);
        ld a = rnd(0, 1000000) * (2 * PI_L / 1000000);
        g.end[g.a0] = (pk_um_t)(g.start[g.a0] + llroundl(c * cosl(a)));
        g.end[g.a1] = (pk_um_t)(g.start[g.a1] + llroundl(c * sinl(a)));
        ld x = g.end[g.a0] - g.start[g.a0], y = g.end[g.a1] - g.start[g.a1];
        ld d = hypotl(x, y);
        if (d == 0)
            continue;
        /* |R| from just over half the chord to 100 chords */
        ld rr = t % 5 == 0 ? d / 2 + rnd(0, 3) : d / 2 * (1 + rnd(1, 100000) / 1000.0L);
        if (rr > (1 << 22) - 1)
            rr = (1 << 22) - 1;
        int32_t r = (int32_t)ceill(rr);
        if (t & 1)
            r = -r;
        int rc = pk_arc_centre_r(&g, r);
        if (4.0L * r * r < x * x + y * y) {
            TH_EXPECT_EQ(rc, PK_ARC_E_RADIUS);
            continue;
        }
        TH_ASSERT_EQ(rc, PK_ARC_OK);
        /* Grbl's centre, in long double */
        ld h = -sqrtl(4.0L * r * r - x * x - y * y) / d;
        if (!g.cw)
            h = -h;
        if (r < 0)
            h = -h;
        ld cx = g.start[g.a0] + 0.5L * (x - y * h), cy = g.start[g.a1] + 0.5L * (y + x * h);
        TH_EXPECT(hypotl(g.centre_q8[0] / 256.0L - cx, g.centre_q8[1] / 256.0L - cy) < 0.02L);
        struct ref ref;
        ref_init(&ref, &g, cx, cy);
        pk_um_t tol = (pk_um_t)rnd(1, 50);
        struct outcome o;
        TH_ASSERT_EQ(run_arc(&g, tol, &ref, &o), PK_ARC_OK);
        cases++;
        TH_EXPECT(o.end_exact);
        TH_EXPECT(o.worst_vertex <= 1 + MARGIN);
        TH_EXPECT(o.worst_chord <= tol + MARGIN);
        /* R > 0: at most a half turn; R < 0: at least one */
        TH_EXPECT(r > 0 ? ref.sweep <= PI_L + 1e-6L : ref.sweep >= PI_L - 1e-6L);
        if (o.worst_vertex > worst_v)
            worst_v = o.worst_vertex;
    }
    TH_EXPECT(cases > 250);
    char msg[120];
    snprintf(msg, sizeof msg, "  r form: %d arcs, worst vertex %.3Lf um from the exact circle\n", cases, worst_v);
    th_print(msg);
}

static void test_grbl_rules_for_invalid_arcs(void)
{
    struct pk_arc_geom g;
    memset(&g, 0, sizeof g);
    g.a0 = 0;
    g.a1 = 1;
    g.al = PK_AXES;
    g.start[0] = 0;
    g.start[1] = 0;
    /* IJK: end 4 µm off the circle of radius 10 mm: within 0.005 mm: ok */
    g.end[0] = 20004;
    g.end[1] = 0;
    TH_EXPECT_EQ(pk_arc_centre_ijk(&g, 10000, 0), PK_ARC_OK);
    /* 6 µm off on 10 mm: > 0.005 mm and > 0.1 % (10 µm)? no: 6 <= 10: ok */
    g.end[0] = 20006;
    TH_EXPECT_EQ(pk_arc_centre_ijk(&g, 10000, 0), PK_ARC_OK);
    /* 11 µm off on 10 mm: > 0.1 %: error 33 */
    g.end[0] = 20011;
    TH_EXPECT_EQ(pk_arc_centre_ijk(&g, 10000, 0), PK_ARC_E_TARGET);
    /* 0.4 mm off on 1000 mm: within 0.5 mm and 0.1 % (1 mm): ok */
    g.end[0] = 2000400;
    TH_EXPECT_EQ(pk_arc_centre_ijk(&g, 1000000, 0), PK_ARC_OK);
    /* 0.6 mm off on 1000 mm: > 0.5 mm: error 33 */
    g.end[0] = 2000600;
    TH_EXPECT_EQ(pk_arc_centre_ijk(&g, 1000000, 0), PK_ARC_E_TARGET);
    /* R form: radius smaller than half the chord: error 34 */
    g.end[0] = 20000;
    TH_EXPECT_EQ(pk_arc_centre_r(&g, 9999), PK_ARC_E_RADIUS);
    TH_EXPECT_EQ(pk_arc_centre_r(&g, -9999), PK_ARC_E_RADIUS);
    TH_EXPECT_EQ(pk_arc_centre_r(&g, 10000), PK_ARC_OK);
    /* exact half circle: centre at the midpoint */
    TH_EXPECT_EQ(g.centre_q8[0], 10000 * 256);
    TH_EXPECT_EQ(g.centre_q8[1], 0);
    /* no chord in the plane: error 34 */
    g.end[0] = 0;
    TH_EXPECT_EQ(pk_arc_centre_r(&g, 10000), PK_ARC_E_RADIUS);
    /* G3 R10 from (0,0) to (10,10): the centre (10, 0) ... the left of the
     * travel: CCW with R > 0 puts it at (0, 10); G2 at (10, 0). */
    g.end[0] = 10000;
    g.end[1] = 10000;
    g.cw = 0;
    TH_EXPECT_EQ(pk_arc_centre_r(&g, 10000), PK_ARC_OK);
    TH_EXPECT(labs(g.centre_q8[0] - 0) <= 1 && labs(g.centre_q8[1] - 10000 * 256) <= 1);
    g.cw = 1;
    TH_EXPECT_EQ(pk_arc_centre_r(&g, 10000), PK_ARC_OK);
    TH_EXPECT(labs(g.centre_q8[0] - 10000 * 256) <= 1 && labs(g.centre_q8[1]) <= 1);
    TH_EXPECT_EQ(pk_arc_centre_r(&g, -10000), PK_ARC_OK);
    TH_EXPECT(labs(g.centre_q8[0]) <= 1 && labs(g.centre_q8[1] - 10000 * 256) <= 1);
}

static void test_huge_radius_runs_as_its_chord_only_when_flat_enough(void)
{
    struct pk_arc_geom g;
    memset(&g, 0, sizeof g);
    g.a0 = 0;
    g.a1 = 1;
    g.al = PK_AXES;
    g.end[0] = 10000; /* 10 mm chord */
    static struct pk_arc a;
    /* R = 10 m: bulge 10^2 / (8 * 10^4) mm = 1.25 µm <= c^2/4R = 2.5 µm */
    TH_ASSERT_EQ(pk_arc_centre_r(&g, 10000000), PK_ARC_OK);
    TH_EXPECT(g.straight);
    TH_EXPECT_EQ(pk_arc_plan(&a, &g, 3), PK_ARC_OK);
    TH_EXPECT_EQ(pk_arc_chords(&a), 1);
    TH_EXPECT_EQ(pk_arc_plan(&a, &g, 2), PK_ARC_E_TARGET);
    TH_EXPECT_EQ(pk_arc_centre_r(&g, -10000000), PK_ARC_E_TARGET);
    /* IJK: centre 10 m away on the left, G3 from (0,0) to (10,0): short */
    g.cw = 0;
    TH_ASSERT_EQ(pk_arc_centre_ijk(&g, 5000, 9999999), PK_ARC_OK);
    TH_EXPECT(g.straight);
    g.cw = 1; /* the long way round */
    TH_EXPECT_EQ(pk_arc_centre_ijk(&g, 5000, 9999999), PK_ARC_E_TARGET);
}

static void test_bounds_contain_every_vertex_and_are_tight(void)
{
    for (int t = 0; t < 300; t++) {
        struct pk_arc_geom g;
        random_geom(&g, 0);
        int64_t rad = rnd(10, 300000);
        ld a = rnd(0, 1000000) * (2 * PI_L / 1000000);
        int32_t i = (int32_t)llroundl(-rad * cosl(a)), j = (int32_t)llroundl(-rad * sinl(a));
        ld r0 = hypotl(i, j);
        ld b = rnd(0, 1000000) * (2 * PI_L / 1000000);
        memcpy(g.end, g.start, sizeof g.end);
        g.end[g.a0] = (pk_um_t)llroundl(g.start[g.a0] + i + r0 * cosl(b));
        g.end[g.a1] = (pk_um_t)llroundl(g.start[g.a1] + j + r0 * sinl(b));
        if (pk_arc_centre_ijk(&g, i, j) != PK_ARC_OK)
            continue;
        static struct pk_arc p;
        TH_ASSERT_EQ(pk_arc_plan(&p, &g, 5), PK_ARC_OK);
        int32_t lo[PK_AXES], hi[PK_AXES];
        pk_arc_bounds(&p, lo, hi);
        int32_t vlo[PK_AXES], vhi[PK_AXES];
        for (int ax = 0; ax < PK_AXES; ax++)
            vlo[ax] = vhi[ax] = g.start[ax];
        pk_um_t v[PK_AXES];
        while (pk_arc_next(&p, v))
            for (int ax = 0; ax < PK_AXES; ax++) {
                if (v[ax] < vlo[ax]) vlo[ax] = v[ax];
                if (v[ax] > vhi[ax]) vhi[ax] = v[ax];
            }
        for (int ax = 0; ax < PK_AXES; ax++) {
            TH_EXPECT(lo[ax] <= vlo[ax] && hi[ax] >= vhi[ax]);
            /* the chords cut corners by at most the tolerance (5) + rounding */
            TH_EXPECT(vlo[ax] - lo[ax] <= 7 && hi[ax] - vhi[ax] <= 7);
        }
    }
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_cordic_rotation_and_angle_match_the_reference),
        TH_CASE(test_ijk_arcs_vertices_on_the_curve_chords_within_tolerance_end_exact),
        TH_CASE(test_full_circle_when_the_end_is_the_start_and_grbl_epsilon),
        TH_CASE(test_r_form_arcs_lie_on_the_exact_circle),
        TH_CASE(test_grbl_rules_for_invalid_arcs),
        TH_CASE(test_huge_radius_runs_as_its_chord_only_when_flat_enough),
        TH_CASE(test_bounds_contain_every_vertex_and_are_tight),
    };
    return th_run(cases, TH_COUNT(cases));
}
