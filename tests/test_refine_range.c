/*
 * test_refine_range.c — the kernel at the ends of its input range
 * (|p| <= PK_UM_MAX per axis, pk_refine.h), where the limit stage's
 * level-K values (F fraction bits, up to 42: pk_fixed.h) leave the least
 * headroom: a straight stroke across the whole range at degree 7, depth 6
 * (finding K2: the tangent's difference overflowed int64 and came out
 * reversed; pk_limit.c halves both points when F > 41), and a zig-zag in
 * the corner of the range through the table-driven stage and Chaikin's
 * written-out one. Every output in range, the ends exact, tangents
 * of unit length; the sanitized build (make test) catches any overflow.
 */
#include <string.h>
#include "pk_refine.h"
#include "th.h"

int th_main(int argc, char **argv);

static void check_straight_stroke(const struct pk_refine_cfg *c)
{
    static struct pk_refine r;
    TH_ASSERT_EQ(pk_refine_init(&r, c), PK_OK);
    const pk_um_t a[PK_AXES] = { PK_UM_MAX, 0, 0 }, b[PK_AXES] = { -PK_UM_MAX, 0, 0 };
    struct pk_refine_out o[8];
    unsigned n = 0;
    int rc;
    TH_ASSERT_EQ(pk_refine_push(&r, a), PK_OK);
    while (n < 8u && (rc = pk_refine_pull(&r, &o[n])) == PK_OK)
        n++;
    TH_ASSERT_EQ(pk_refine_push(&r, b), PK_OK);
    while (n < 8u && (rc = pk_refine_pull(&r, &o[n])) == PK_OK)
        n++;
    pk_refine_finish(&r);
    while (n < 8u && (rc = pk_refine_pull(&r, &o[n])) == PK_OK)
        n++;
    TH_ASSERT_EQ(rc, PK_END);
    TH_ASSERT(n >= 2u);
    TH_EXPECT_EQ(o[0].p[0], PK_UM_MAX);
    TH_EXPECT_EQ(o[n - 1u].p[0], -PK_UM_MAX);
    for (unsigned i = 0; i < n; i++) {
        TH_EXPECT_EQ(o[i].t[0], -(1 << 30));
        TH_EXPECT_EQ(o[i].t[1], 0);
        TH_EXPECT_EQ(o[i].t[2], 0);
    }
}

/* A bent stroke hugging the corner of the range (+MAX, +MAX): every
 * output within the range and each tangent of unit length. */
static void check_bent_stroke(const struct pk_refine_cfg *c, int end_exact)
{
    static struct pk_refine r;
    TH_ASSERT_EQ(pk_refine_init(&r, c), PK_OK);
    const pk_um_t m = PK_UM_MAX;
    pk_um_t pts[12][PK_AXES];
    for (unsigned i = 0; i < 12u; i++) { /* a zig-zag within 3 mm of the corner */
        pts[i][0] = m - (pk_um_t)(i % 2u ? 3000 : 0);
        pts[i][1] = m - (pk_um_t)((i * 700u) % 3000u);
        pts[i][2] = m - (pk_um_t)(i % 3u ? 1000 * (i % 3u) : 0);
    }
    pts[11][0] = pts[11][1] = pts[11][2] = m;
    struct pk_refine_out o, last;
    memset(&last, 0, sizeof last);
    unsigned n = 0;
    int rc = PK_OK;
    for (unsigned i = 0; i <= 12u; i++) {
        if (i < 12u)
            TH_ASSERT_EQ(pk_refine_push(&r, pts[i]), PK_OK);
        else
            pk_refine_finish(&r);
        while ((rc = pk_refine_pull(&r, &o)) == PK_OK) {
            n++;
            last = o;
            for (unsigned a = 0; a < 3u; a++)
                TH_ASSERT(o.p[a] <= PK_UM_MAX && o.p[a] >= PK_UM_MAX - 3000);
            double l2 = 0;
            for (unsigned a = 0; a < 3u; a++)
                l2 += ((double)o.t[a] / (1 << 30)) * ((double)o.t[a] / (1 << 30));
            TH_ASSERT(l2 > 1.0 - 4e-6 && l2 < 1.0 + 4e-6);
        }
    }
    TH_ASSERT_EQ(rc, PK_END);
    TH_EXPECT(n > 12u);
    if (end_exact) /* clamped ends: the last point is the last input */
        for (unsigned a = 0; a < 3u; a++)
            TH_EXPECT_EQ(last.p[a], PK_UM_MAX);
}

static void test_a_bent_stroke_in_the_corner_of_the_range(void)
{
    struct pk_refine_cfg c;
    memset(&c, 0, sizeof c);
    c.scheme = PK_SCHEME_BSPLINE;
    c.dims = 3;
    c.limit = 1;
    c.tangents = 1;
    c.degree = 7; /* table-driven limit stage, F = 42 */
    c.depth = 6;
    c.ends = PK_ENDS_NONE;
    check_bent_stroke(&c, 0);
    c.ends = PK_ENDS_DEFAULT; /* clamped */
    c.degree = 2; /* Chaikin's written-out stage */
    c.depth = PK_MAX_DEPTH;
    check_bent_stroke(&c, 1);
    c.degree = 3;
    c.depth = 5;
    check_bent_stroke(&c, 1);
}

static void test_a_straight_stroke_across_the_whole_range_degree_7(void)
{
    struct pk_refine_cfg c;
    memset(&c, 0, sizeof c);
    c.scheme = PK_SCHEME_BSPLINE;
    c.degree = 7;
    c.depth = 6;
    c.ends = PK_ENDS_NONE;
    c.limit = 1;
    c.tangents = 1;
    c.dims = 3;
    check_straight_stroke(&c);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_straight_stroke_across_the_whole_range_degree_7),
        TH_CASE(test_a_bent_stroke_in_the_corner_of_the_range),
    };
    return th_run(cases, TH_COUNT(cases));
}
