/*
 * avr_arith_cycles.c — the motion core's integer square root on the
 * ATmega328P (run by bench/avr_cycles): cycles per call of pk_isqrt64 on
 * pseudo-random operands of every width and on squares and their
 * neighbours; and how many roots differ from the exact floor, checked on the
 * chip, those and 16,000 more (the "= wrong results" row;
 * tests/extra/avr_arith.sh requires 0). The
 * roots are checked here as well as on the host (tests/test_motion_planner.c)
 * because avr-gcc's int is 16 bits wide: a promotion the host never sees
 * would only show here.
 */
#include <stdint.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include "avr_mark.h"
#include "pk_fixed.h"

#define N 300u
/** roots checked on the chip beside the timed ones (4 per step) */
#define CHECK_N 4000u

static uint64_t rng = 88172645463325252ull;
static uint64_t xr(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

static int exact_root(uint64_t x, uint32_t r)
{
    return (uint64_t)r * r <= x && (r == UINT32_MAX || (uint64_t)(r + 1u) * (r + 1u) > x);
}

int main(void)
{
    uint32_t bad = 0;
    avr_mark_label("pk_isqrt64, 0..64-bit x");
    for (uint16_t i = 0; i < N; i++) {
        const uint64_t x = xr() >> (uint8_t)(xr() % 64u);
        avr_mark_start();
        const uint32_t r = pk_isqrt64(x);
        avr_mark_stop();
        bad += !exact_root(x, r);
    }
    avr_mark_report(N);
    /* the squares and their neighbours (the digit loop's phase boundaries) */
    avr_mark_label("pk_isqrt64, r^2 - 1, r^2, r^2 + 2r");
    for (uint16_t i = 0; i < N; i++) {
        const uint32_t r = (uint32_t)(xr() >> (uint8_t)(32u + xr() % 32u));
        const uint64_t sq = (uint64_t)r * r;
        const uint64_t x = i % 3u == 0u ? sq - (r != 0u) : i % 3u == 1u ? sq : sq + 2u * (uint64_t)r;
        avr_mark_start();
        const uint32_t got = pk_isqrt64(x);
        avr_mark_stop();
        bad += !exact_root(x, got);
    }
    avr_mark_report(N);
    /* more operands, checked only (not timed): every width, and the squares
     * and their neighbours of roots of every width, up to 2^32 - 1 */
    for (uint16_t i = 0; i < CHECK_N; i++) {
        const uint64_t x = xr() >> (uint8_t)(i % 64u);
        bad += !exact_root(x, pk_isqrt64(x));
        const uint32_t r = (uint32_t)(xr() >> (uint8_t)(32u + i % 32u));
        const uint64_t sq = (uint64_t)r * r;
        bad += !exact_root(sq, pk_isqrt64(sq));
        if (r != 0u)
            bad += !exact_root(sq - 1u, pk_isqrt64(sq - 1u));
        bad += !exact_root(sq + 2u * (uint64_t)r, pk_isqrt64(sq + 2u * (uint64_t)r));
    }
    avr_mark_label("= wrong results: ");
    avr_mark_begin("pk_isqrt64");
    avr_mark_end(bad);
    cli();
    sleep_mode();
    return 0;
}
