/*
 * test_sg_div.c — the step generator's shift-and-subtract divisions
 * (firmware/pk_sg_div.h, the forms an 8-bit core runs) against the C
 * division, at the edges of their contracts and on random operands spread
 * over every magnitude (the host build itself divides, so this is where the
 * soft forms are checked).
 */
#include <stdint.h>
#include "pk_sg_div.h"
#include "th.h"

int th_main(int argc, char **argv);

static uint64_t rng = 0x9E3779B97F4A7C15ull;
static uint64_t xr(void) { return th_xorshift64(&rng); }

static uint32_t div32_want(uint32_t hi, uint32_t lo, uint32_t d)
{
    const uint64_t q = (((uint64_t)hi << 32) | lo) / d;
    return q > UINT32_MAX ? UINT32_MAX : (uint32_t)q;
}

static void test_div32_is_the_saturated_floor_of_the_64_bit_quotient(void)
{
    static const uint32_t ed[] = { 1, 2, 3, 255, 256, 257, 65535, 65536, 0xFFFFFFu, 0x1000000u,
                                   0x1000001u, 0x7FFFFFFFu, 0x80000000u };
    unsigned bad = 0;
    for (unsigned k = 0; k < TH_COUNT(ed); k++) {
        const uint32_t d = ed[k];
        const uint32_t his[] = { 0, 1, d / 2u, d - 1u, d, d + 1u, 0xFFFFFFu, 0x1000000u, UINT32_MAX };
        const uint32_t los[] = { 0, 1, 0xFFu, 0xFFFFFFu, 0x1000000u, d - 1u, d, 0x80000000u, UINT32_MAX };
        for (unsigned i = 0; i < TH_COUNT(his); i++)
            for (unsigned j = 0; j < TH_COUNT(los); j++)
                bad += pk_sg_div32_soft(his[i], los[j], d) != div32_want(his[i], los[j], d);
    }
    for (int k = 0; k < 2000000; k++) {
        /* a divisor of any width up to 2^31, a dividend whose quotient has
         * any width (mostly fitting, some saturating) */
        uint32_t d = (uint32_t)(xr() >> (32 + xr() % 32)) | 1u;
        if (d > 0x80000000u)
            d = 0x80000000u;
        const uint64_t n = xr() >> (xr() % 64);
        const uint64_t m = (uint64_t)d * (xr() >> (31 + xr() % 33));
        const uint64_t num = k & 1 ? n : m + xr() % d;
        bad += pk_sg_div32_soft((uint32_t)(num >> 32), (uint32_t)num, d)
               != div32_want((uint32_t)(num >> 32), (uint32_t)num, d);
    }
    TH_EXPECT_EQ(bad, 0);
}

static void test_frac_q16_is_the_exact_floor_of_the_quotient(void)
{
    unsigned bad = 0;
    /* every r below 2^16 at the edges of x */
    for (uint32_t r = 1; r < 0x10000u; r++) {
        const uint32_t xs[] = { 0, 1, r / 2u, r - 1u, r };
        for (unsigned j = 0; j < TH_COUNT(xs); j++) {
            const uint32_t x = xs[j] > r ? r : xs[j];
            bad += pk_sg_frac_q16_soft((uint16_t)x, (uint16_t)r) != (x << 16) / r;
        }
    }
    for (int k = 0; k < 2000000; k++) {
        const uint32_t r = (uint32_t)(xr() >> (48 + xr() % 16)) | 1u;
        const uint32_t x = (uint32_t)(xr() % (r + 1u));
        bad += pk_sg_frac_q16_soft((uint16_t)x, (uint16_t)r) != (x << 16) / r;
    }
    TH_EXPECT_EQ(bad, 0);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_div32_is_the_saturated_floor_of_the_64_bit_quotient),
        TH_CASE(test_frac_q16_is_the_exact_floor_of_the_quotient),
    };
    return th_run(cases, TH_COUNT(cases));
}
