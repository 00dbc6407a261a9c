/*
 * test_bezier.c — G5/G5.1 flattening (firmware/pk_bezier.c) against a double
 * evaluation of the same curves, with the bound pk_bezier.h states: every
 * densely sampled curve point within the tolerance of the emitted polyline,
 * every point of the polyline within the tolerance of the curve (measured
 * against a 20,000-piece sampling of the curve, whose own error is below
 * 0.05 µm for these curves, added to the bound), the vertices on the curve
 * within 0.71 µm, the polyline ending exactly on the end point.
 */
#include <math.h>
#include <stddef.h>
#include "th.h"
#include "pk_bezier.h"

int th_main(int argc, char **argv);

static uint64_t rs = 12345;
static int32_t rnd(int32_t lo, int32_t hi)
{
    rs = rs * 6364136223846793005ull + 1442695040888963407ull;
    return lo + (int32_t)((rs >> 33) % (uint64_t)(hi - lo + 1));
}

static void eval(const pk_um_t p[4][2], int quad, double t, double o[2])
{
    double u = 1 - t;
    for (int a = 0; a < 2; a++)
        o[a] = quad ? u * u * p[0][a] + 2 * u * t * p[1][a] + t * t * p[2][a]
                    : u * u * u * p[0][a] + 3 * u * u * t * p[1][a] + 3 * u * t * t * p[2][a] +
                          t * t * t * p[3][a];
}

static double seg_dist(const double q[2], const double a[2], const double b[2])
{
    double dx = b[0] - a[0], dy = b[1] - a[1];
    double l2 = dx * dx + dy * dy;
    double t = l2 > 0 ? ((q[0] - a[0]) * dx + (q[1] - a[1]) * dy) / l2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    double ex = a[0] + t * dx - q[0], ey = a[1] + t * dy - q[1];
    return sqrt(ex * ex + ey * ey);
}

#define DENSE 20000
static double dense[DENSE + 1][2];

/* Max distance from curve samples to the polyline and from polyline points
 * to the curve; also returns the count and whether it ends exactly. */
static double check_curve(const pk_um_t p[4][2], int quad, pk_um_t tol, int *count, int *end_ok)
{
    static double poly[9000][2];
    struct pk_bez b;
    pk_bez_init(&b, p, quad, tol);
    int n = 0;
    poly[n][0] = p[0][0];
    poly[n][1] = p[0][1];
    n++;
    pk_um_t o[2];
    while (n < 9000 && pk_bez_next(&b, o)) {
        poly[n][0] = o[0];
        poly[n][1] = o[1];
        n++;
    }
    int e = quad ? 2 : 3;
    *end_ok = poly[n - 1][0] == p[e][0] && poly[n - 1][1] == p[e][1];
    *count = n - 1;
    for (int s = 0; s <= DENSE; s++)
        eval(p, quad, (double)s / DENSE, dense[s]);
    double worst = 0;
    /* curve -> polyline (the curve piece of segment i lies between the
     * samples nearest its end vertices, so search a window of segments) */
    for (int s = 0; s <= DENSE; s += 5) {
        double best = 1e300;
        for (int i = 0; i + 1 < n; i++) {
            double d = seg_dist(dense[s], poly[i], poly[i + 1]);
            if (d < best)
                best = d;
        }
        if (best > worst)
            worst = best;
    }
    /* polyline -> curve: 9 points per segment, nearest dense piece */
    size_t k = 0;
    for (int i = 0; i + 1 < n; i++) {
        for (int j = 0; j <= 8; j++) {
            double q[2] = { poly[i][0] + (poly[i + 1][0] - poly[i][0]) * j / 8.0,
                            poly[i][1] + (poly[i + 1][1] - poly[i][1]) * j / 8.0 };
            double best = 1e300;
            size_t bk = k;
            /* near the previous match first; everywhere if that is far */
            size_t lo = k > 300 ? k - 300 : 0, hi = k + 300 < DENSE ? k + 300 : DENSE;
            for (int pass = 0; pass < 2; pass++) {
                for (size_t c = lo; c < hi; c++) {
                    double d = seg_dist(q, dense[c], dense[c + 1]);
                    if (d < best) {
                        best = d;
                        bk = c;
                    }
                }
                if (best <= 0.5)
                    break;
                lo = 0;
                hi = DENSE;
            }
            k = bk;
            if (best - 0.05 > worst)
                worst = best - 0.05;
            if (j == 0 && i > 0 && best > 0.7072 + 0.05)
                *end_ok = 0; /* a vertex off the curve by more than its rounding */
        }
    }
    return worst;
}

static void test_random_curves_stay_within_the_tolerance_and_end_exactly(void)
{
    static const pk_um_t tols[] = { 1, 5, 20, 100 };
    for (int k = 0; k < 24; k++) {
        pk_um_t p[4][2];
        int span = k % 3 == 0 ? 2000 : k % 3 == 1 ? 100000 : 2000000;
        for (int i = 0; i < 4; i++)
            for (int a = 0; a < 2; a++)
                p[i][a] = rnd(-span, span);
        for (int quad = 0; quad < 2; quad++) {
            pk_um_t tol = tols[k % 4];
            int count, end_ok;
            double worst = check_curve(p, quad, tol, &count, &end_ok);
            TH_EXPECT(end_ok);
            TH_EXPECT(worst <= tol);
            TH_EXPECT(count >= 1 && count <= 8192);
        }
    }
}

static void test_a_straight_curve_is_one_segment_and_a_tighter_tolerance_gives_more(void)
{
    const pk_um_t line[4][2] = { { 0, 0 }, { 1000, 1000 }, { 2000, 2000 }, { 3000, 3000 } };
    int count, end_ok;
    check_curve(line, 0, 10, &count, &end_ok);
    TH_EXPECT_EQ(count, 1);
    const pk_um_t arc[4][2] = { { 0, 0 }, { 0, 50000 }, { 50000, 50000 }, { 50000, 0 } };
    int c1, c2;
    double w1 = check_curve(arc, 0, 100, &c1, &end_ok);
    double w2 = check_curve(arc, 0, 10, &c2, &end_ok);
    TH_EXPECT(c2 > c1);
    TH_EXPECT(w1 <= 100 && w2 <= 10);
    /* A chord count near the ideal: for this ~50 mm bulge, sqrt scaling. */
    TH_EXPECT(c2 < 4 * c1);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_random_curves_stay_within_the_tolerance_and_end_exactly),
        TH_CASE(test_a_straight_curve_is_one_segment_and_a_tighter_tolerance_gives_more),
    };
    return th_run(cases, TH_COUNT(cases));
}
