/*
 * findings_kernel.c — deterministic reproducer of the open finding K2 in the
 * kernel's limit stage (firmware/pk_limit.c), found by tests/fuzz/fuzz_refine.c
 * (input: tests/fuzz/findings/fuzz_refine/K2-limit-stage-difference-overflows).
 * Fails while the finding is open (under UBSan it stops at the overflow), so
 * it runs in `make fuzz-findings`, not in `make test`; once fixed, move the
 * case to tests/test_refine.c.
 *
 * The limit stage keeps level-K points as pk_umf_t with F fraction bits, F up
 * to 42 (pk_fixed.h), so a point at the range limit is (2^21 - 1) * 2^42 =
 * 2^63 - 2^42: one bit of headroom for a value, none for the difference or
 * the sum of two. A straight 2-point stroke from X = +PK_UM_MAX to
 * X = -PK_UM_MAX (both in range: pk_refine_push accepts them) with degree 7,
 * depth 6, no end rule, limit points and tangents: tab_emit's 2-point branch
 * computes lim_at(0) - lim_at(1) in int64 and overflows (pk_limit.c:314; the
 * same subtraction is in tab_tangent and ch_emit, and ch_emit's A + B sum).
 * Expected (pk_refine.h): both end points exact, the tangent (-1, 0, 0) in
 * Q1.30 within 2^-20 of unit length.
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
    };
    return th_run(cases, TH_COUNT(cases));
}
