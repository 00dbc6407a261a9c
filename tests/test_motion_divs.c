/*
 * test_motion_divs.c — the motion core's static arithmetic helpers that
 * replace 64-bit library divisions on 8-bit cores (pk_motion.c, pk_planner.c)
 * give exactly what the plain C expressions they stand for give, on the
 * ranges their comments state: edges, ties and random values (the planner's
 * against the expressions they replaced, copied here). (The sources
 * are included, so the helpers are tested as compiled, not copies of them,
 * in their PK_SOFT_DIV=1 forms.)
 */
#include <stdint.h>
#include <string.h>
#include "th.h"
/* the forms an 8-bit core compiles (shift-and-subtract divisions where
 * their quotients fit 32 bits, steps_to_um_q8's among them), so the host
 * tests the chip's arithmetic; the plain forms are the C expressions
 * themselves */
#define PK_SOFT_DIV 1
#define PK_MOTION_SOFT_DIV 1
#include "../firmware/pk_motion.c"
#include "../firmware/pk_planner.c"

int th_main(int argc, char **argv);

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static uint64_t xr(void) { return th_xorshift64(&rng); }

/* um_conv against pk_um_to_steps and the rounded division it replaces */
static unsigned conv_bad(pk_um_t um, pk_spmm_q16_t spmm)
{
    struct pk_axconv c;
    um_conv(um, spmm, &c);
    const int64_t q8 = pk_div_round64((int64_t)um * (int64_t)spmm, 256000);
    return c.st != pk_um_to_steps(um, spmm) || c.q8 != q8 || c.um != um || c.spmm != spmm;
}

static void test_one_division_gives_the_steps_and_the_steps_q8_of_a_coordinate(void)
{
    /* 128000 = 1.953 steps/mm: um odd is a tie of the Q8 rounding, um = 256
     * mod 512 one of the whole steps; 65536 (1 step/mm): um = 500 mod 1000 */
    static const pk_spmm_q16_t sp[] = { PK_SPMM_Q16_MIN, 128000u, 80u << 16, 5242881u, 100u << 16,
                                        PK_SPMM_Q16_MAX - 1u, PK_SPMM_Q16_MAX };
    unsigned bad = 0, n = 0;
    for (unsigned k = 0; k < TH_COUNT(sp); k++) {
        for (pk_um_t um = -3000; um <= 3000; um++, n++)
            bad += conv_bad(um, sp[k]);
        static const pk_um_t edge[] = { PK_UM_MAX, PK_UM_MAX - 1, -PK_UM_MAX, -PK_UM_MAX + 1, 2 * PK_UM_MAX,
                                        -2 * PK_UM_MAX, 1000000, -999999 };
        for (unsigned e = 0; e < TH_COUNT(edge); e++, n++)
            bad += conv_bad(edge[e], sp[k]);
    }
    for (int k = 0; k < 1000000; k++, n++) {
        const pk_um_t um = (pk_um_t)(xr() % (4u * PK_UM_MAX + 1u)) - 2 * PK_UM_MAX;
        const pk_spmm_q16_t spmm = PK_SPMM_Q16_MIN + (pk_spmm_q16_t)(xr() % (PK_SPMM_Q16_MAX - PK_SPMM_Q16_MIN + 1u));
        bad += conv_bad(um, spmm);
    }
    TH_EXPECT(n > 1000000);
    TH_EXPECT_EQ(bad, 0);
}

/* steps_to_um_q8's 32-bit-word division against the rounded 64-bit one it
 * replaces: every displacement a block can have (|n| <= PK_PLANNER_MAX_STEPS
 * within 2 PK_UM_MAX at the steps/mm), edges and random values */
static unsigned q8_bad(pk_steps_t n, pk_spmm_q16_t spmm)
{
    const int64_t want = pk_div_round64((int64_t)n * ((int64_t)256000 << PK_SPMM_Q16_SHIFT), (int64_t)spmm);
    return steps_to_um_q8(n, spmm) != want;
}

static void test_the_steps_q8_of_a_displacement_are_those_of_the_64_bit_division(void)
{
    static const pk_spmm_q16_t sp[] = { PK_SPMM_Q16_MIN, 128000u, 80u << 16, 5242881u, 100u << 16,
                                        PK_SPMM_Q16_MAX - 1u, PK_SPMM_Q16_MAX };
    unsigned bad = 0, n = 0;
    for (unsigned k = 0; k < TH_COUNT(sp); k++) {
        /* the largest |n| within 2 PK_UM_MAX (and the block's bound) */
        int64_t top = (int64_t)2 * PK_UM_MAX * sp[k] / (1000 << PK_SPMM_Q16_SHIFT) + 1;
        if (top > (int64_t)PK_PLANNER_MAX_STEPS)
            top = PK_PLANNER_MAX_STEPS;
        for (pk_steps_t s = -3000; s <= 3000; s++, n++)
            bad += q8_bad(s, sp[k]);
        for (int64_t s = top - 2000; s <= top; s++, n += 2)
            bad += q8_bad((pk_steps_t)s, sp[k]) + q8_bad((pk_steps_t)-s, sp[k]);
    }
    for (int k = 0; k < 1000000; k++, n++) {
        const pk_spmm_q16_t spmm = PK_SPMM_Q16_MIN + (pk_spmm_q16_t)(xr() % (PK_SPMM_Q16_MAX - PK_SPMM_Q16_MIN + 1u));
        int64_t top = (int64_t)2 * PK_UM_MAX * spmm / (1000 << PK_SPMM_Q16_SHIFT) + 1;
        if (top > (int64_t)PK_PLANNER_MAX_STEPS)
            top = PK_PLANNER_MAX_STEPS;
        const pk_steps_t s = (pk_steps_t)(xr() % (uint64_t)(2 * top + 1)) - (pk_steps_t)top;
        bad += q8_bad(s, spmm);
    }
    TH_EXPECT(n > 1000000);
    TH_EXPECT_EQ(bad, 0);
}

/* pk_planner_junction_v2 as it was, with its 64-bit division testing the
 * saturation */
static pk_v2_q4_t ref_junction(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES], uint8_t axes,
                               pk_um_s2_t a, pk_um_t delta)
{
    int64_t dd = 0;
    for (unsigned i = 0; i < axes; i++)
        dd += (int64_t)u1[i] * u2[i];
    dd = pk_rshift_round64(dd, 30);
    int32_t d = dd > PK_Q30_ONE ? PK_Q30_ONE : dd < -PK_Q30_ONE ? -PK_Q30_ONE : (int32_t)dd;
    uint32_t h = ((uint32_t)PK_Q30_ONE - (uint32_t)d) / 2u;
    if (h == 0)
        return UINT64_MAX;
    uint32_t s2 = ((uint32_t)PK_Q30_ONE + (uint32_t)d) / 2u;
    uint32_t s = pk_isqrt64((uint64_t)s2 << 30);
    if (s == 0 || delta == 0)
        return 0;
    uint32_t r = pk_mulshr_u32(s, (uint32_t)PK_Q30_ONE + s, 30);
    uint64_t q = ((uint64_t)r << 20) / h;
    uint64_t ad = (uint64_t)a * (uint64_t)delta;
    if (q != 0 && ad > (UINT64_MAX >> 1) / q)
        return UINT64_MAX;
    return (ad * q) >> 16;
}

/* pk_planner_curvature_v2 as it was (64-bit signed squares) */
static pk_v2_q4_t ref_curvature(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES], uint8_t axes,
                                uint32_t l1_q8, uint32_t l2_q8, pk_um_s2_t a)
{
    uint64_t ss = 0;
    for (unsigned i = 0; i < axes; i++) {
        int64_t d = (int64_t)u2[i] - u1[i];
        ss += (uint64_t)(d * d) >> 4;
    }
    uint64_t du = (uint64_t)pk_isqrt64(ss) << 2;
    if (du == 0)
        return UINT64_MAX;
    uint64_t lmin = l1_q8 < l2_q8 ? l1_q8 : l2_q8;
    uint64_t num = (uint64_t)a * (2u * lmin);
    uint64_t qt = num / du;
    return qt > (UINT64_MAX >> 25) ? UINT64_MAX : qt << 25;
}

/* a component of a unit vector (|u| <= 2^30), now and then 0 or +-2^30 */
static pk_q30_t rnd_u(void)
{
    switch (xr() % 8u) {
    case 0:
        return 0;
    case 1:
        return xr() % 2u ? PK_Q30_ONE : -PK_Q30_ONE;
    default:
        return (pk_q30_t)(xr() % (2u * (uint32_t)PK_Q30_ONE + 1u)) - PK_Q30_ONE;
    }
}

static void test_the_junction_and_curvature_limits_are_those_of_the_64_bit_expressions(void)
{
    unsigned bad = 0, sat = 0;
    for (int k = 0; k < 400000; k++) {
        pk_q30_t u1[PK_AXES] = { 0 }, u2[PK_AXES] = { 0 };
        const uint8_t axes = (uint8_t)(2u + xr() % (PK_AXES - 1u));
        for (unsigned i = 0; i < axes; i++) {
            u1[i] = rnd_u();
            /* small turns too: u2 near u1 */
            u2[i] = xr() % 2u ? rnd_u() : u1[i] + (pk_q30_t)(xr() % 2001u) - 1000;
            if (u2[i] > PK_Q30_ONE || u2[i] < -PK_Q30_ONE)
                u2[i] = u1[i];
        }
        /* accelerations and deviations over their whole ranges, and beyond
         * (the saturation) */
        const pk_um_s2_t a = (pk_um_s2_t)(xr() >> (xr() % 64u));
        const pk_um_t delta = (pk_um_t)(xr() % 4u == 0u ? xr() % 10001u : xr() >> 33);
        const pk_v2_q4_t j = pk_planner_junction_v2(u1, u2, axes, a, delta);
        bad += j != ref_junction(u1, u2, axes, a, delta);
        sat += j == UINT64_MAX;
        const uint32_t l1 = (uint32_t)(xr() >> (32u + xr() % 32u)), l2 = (uint32_t)(xr() >> (32u + xr() % 32u));
        bad += pk_planner_curvature_v2(u1, u2, axes, l1, l2, a) != ref_curvature(u1, u2, axes, l1, l2, a);
    }
    TH_EXPECT(sat > 1000);
    TH_EXPECT_EQ(bad, 0);
}

/* the unit vector (Q30) along (c, s) in the XY plane */
static void unit_near(pk_q30_t u[PK_AXES], int64_t c, int64_t s)
{
    int64_t d[PK_AXES] = { 0 };
    d[0] = c;
    d[1] = s;
    pk_unit_q30(d, PK_AXES, u);
}

/* min(J, cap) and whether cap < J, for caps on both sides of J and at it:
 * the bound that skips J must never decide wrongly */
static unsigned junction_min_bad(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES], uint8_t axes,
                                 pk_um_s2_t a, pk_um_t delta, pk_v2_q4_t cap)
{
    const pk_v2_q4_t j = ref_junction(u1, u2, axes, a, delta);
    bool below = false;
    const pk_v2_q4_t m = pk_planner_junction_min_v2(u1, u2, axes, a, delta, cap, &below);
    return m != (cap < j ? cap : j) || below != (cap < j);
}

static void test_the_junction_limit_against_a_cap_is_the_minimum_of_the_two(void)
{
    unsigned bad = 0, n = 0, below = 0;
    for (int k = 0; k < 300000; k++) {
        pk_q30_t u1[PK_AXES] = { 0 }, u2[PK_AXES] = { 0 };
        uint8_t axes = 2;
        if (k % 3 == 0) {
            /* any vectors (and over 90 degree turns) */
            axes = (uint8_t)(2u + xr() % (PK_AXES - 1u));
            for (unsigned i = 0; i < axes; i++) {
                u1[i] = rnd_u();
                u2[i] = xr() % 2u ? rnd_u() : u1[i] + (pk_q30_t)(xr() % 2001u) - 1000;
                if (u2[i] > PK_Q30_ONE || u2[i] < -PK_Q30_ONE)
                    u2[i] = u1[i];
            }
        } else {
            /* unit vectors a small turn apart (the dense drawings' vertices) */
            const int64_t c = (int64_t)(xr() % 2000001u) - 1000000, s = (int64_t)(xr() % 2000001u) - 1000000;
            const int64_t tc = (int64_t)(xr() >> (40u + xr() % 24u)), ts = (int64_t)(xr() >> (40u + xr() % 24u));
            unit_near(u1, c, s);
            unit_near(u2, c + (xr() % 2u ? tc : -tc), s + (xr() % 2u ? ts : -ts));
        }
        const pk_um_s2_t a = k % 5 == 0 ? (pk_um_s2_t)(xr() >> (xr() % 64u)) : (pk_um_s2_t)(1u + xr() % (1u << 27));
        const pk_um_t delta = (pk_um_t)(k % 7 == 0 ? xr() >> 33 : xr() % 10001u);
        const pk_v2_q4_t j = ref_junction(u1, u2, axes, a, delta);
        pk_v2_q4_t caps[8] = { j, j - 1u, j + 1u, UINT64_MAX, 0u, xr() >> (xr() % 64u), j - (j >> 12), j + (j >> 12) };
        if (j > 0u && j < UINT64_MAX) {
            caps[6] = j - (j >> (8u + xr() % 20u));
            caps[7] = j + (j >> (8u + xr() % 20u));
        }
        for (unsigned c = 0; c < TH_COUNT(caps); c++, n++) {
            bad += junction_min_bad(u1, u2, axes, a, delta, caps[c]);
            below += caps[c] < j;
        }
    }
    TH_EXPECT(n >= 2400000u);
    TH_EXPECT(below > n / 4u);
    TH_EXPECT_EQ(bad, 0);
}

static void test_a_feed_s_speed_squared_is_the_rounded_quotient_of_the_64_bit_division(void)
{
    unsigned bad = 0, n = 0;
    for (uint32_t v = 0; v < 200000u; v++, n++)
        bad += v2_of_um_min(v) != ((uint64_t)v * v + 112u) / 225u;
    for (uint32_t v = PK_UM_MIN_MAX - 100000u; v <= PK_UM_MIN_MAX + 100000u; v++, n++)
        bad += v2_of_um_min(v) != ((uint64_t)v * v + 112u) / 225u;
    for (int k = 0; k < 2000000; k++, n++) {
        const uint32_t v = (uint32_t)(xr() >> 38); /* < 2^26 */
        bad += v2_of_um_min(v) != ((uint64_t)v * v + 112u) / 225u;
    }
    for (uint32_t v = (1u << 26) - 100000u; v < (1u << 26); v++, n++)
        bad += v2_of_um_min(v) != ((uint64_t)v * v + 112u) / 225u;
    TH_EXPECT(n > 2400000u);
    TH_EXPECT_EQ(bad, 0);
}

static void test_the_shares_of_an_acceleration_are_those_of_the_64_bit_products(void)
{
    static const uint32_t sh[] = { 0u, 1u, 23170u, 32767u, 32768u };
    unsigned bad = 0;
    for (int k = 0; k < 200000; k++) {
        const uint32_t a = k < 64 ? UINT32_MAX - (uint32_t)k : (uint32_t)(xr() >> (xr() % 64u));
        for (unsigned i = 0; i < TH_COUNT(sh); i++)
            bad += share_q15(a, sh[i]) != (uint32_t)(((uint64_t)a * sh[i]) >> 15);
    }
    TH_EXPECT_EQ(bad, 0);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_one_division_gives_the_steps_and_the_steps_q8_of_a_coordinate),
        TH_CASE(test_the_steps_q8_of_a_displacement_are_those_of_the_64_bit_division),
        TH_CASE(test_the_junction_and_curvature_limits_are_those_of_the_64_bit_expressions),
        TH_CASE(test_the_junction_limit_against_a_cap_is_the_minimum_of_the_two),
        TH_CASE(test_a_feed_s_speed_squared_is_the_rounded_quotient_of_the_64_bit_division),
        TH_CASE(test_the_shares_of_an_acceleration_are_those_of_the_64_bit_products),
    };
    return th_run(cases, TH_COUNT(cases));
}
