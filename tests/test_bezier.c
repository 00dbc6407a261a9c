/*
 * test_bezier.c — G5/G5.1 flattening (firmware/pk_bezier.c) against a double
 * evaluation of the same curves: every densely sampled curve point must lie
 * within the tolerance (+ 1 µm of rounding) of the emitted polyline, and the
 * polyline must end exactly on the end point.
 */
#include <math.h>
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

/* Max distance from curve samples to the polyline; also returns the count. */
static double check_curve(const pk_um_t p[4][2], int quad, pk_um_t tol, int *count, int *end_ok)
{
    static double poly[5000][2];
    struct pk_bez b;
    pk_bez_init(&b, p, quad, tol);
    int n = 0;
    poly[n][0] = p[0][0];
    poly[n][1] = p[0][1];
    n++;
    pk_um_t o[2];
    while (n < 5000 && pk_bez_next(&b, o)) {
        poly[n][0] = o[0];
        poly[n][1] = o[1];
        n++;
    }
    int e = quad ? 2 : 3;
    *end_ok = poly[n - 1][0] == p[e][0] && poly[n - 1][1] == p[e][1];
    *count = n - 1;
    double worst = 0;
    for (int s = 0; s <= 4000; s++) {
        double c[2];
        eval(p, quad, s / 4000.0, c);
        double best = 1e300;
        for (int i = 0; i + 1 < n; i++) {
            double d = seg_dist(c, poly[i], poly[i + 1]);
            if (d < best)
                best = d;
        }
        if (best > worst)
            worst = best;
    }
    return worst;
}

static void test_random_curves_stay_within_the_tolerance_and_end_exactly(void)
{
    static const pk_um_t tols[] = { 1, 5, 20, 100 };
    for (int k = 0; k < 60; k++) {
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
            TH_EXPECT(worst <= tol + 1.0);
            TH_EXPECT(count >= 1 && count <= 4096);
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
    TH_EXPECT(w1 <= 101 && w2 <= 11);
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
