/*
 * test_motion_divs.c — the motion core's static arithmetic helpers that
 * replace 64-bit library divisions on 8-bit cores (pk_motion.c, pk_planner.c)
 * give exactly what the plain C expressions they stand for give, on the
 * ranges their comments state: edges, ties and random values. (The sources
 * are included, so the helpers are tested as compiled, not copies of them.)
 */
#include <stdint.h>
#include <string.h>
#include "th.h"
#include "../firmware/pk_motion.c"

int th_main(int argc, char **argv);

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static uint64_t xr(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

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

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_one_division_gives_the_steps_and_the_steps_q8_of_a_coordinate),
    };
    return th_run(cases, TH_COUNT(cases));
}
