/*
 * avr_arith_cycles.c — the motion core's 64-bit arithmetic helpers on the
 * ATmega328P (run by bench/avr_cycles): cycles per call of pk_isqrt64,
 * pk_udiv64_32 (and its shift-and-subtract form), pk_muldiv_u32 and
 * pk_div_round64, next to libgcc's 64-bit division they replace, each on the
 * same pseudo-random operands (every width); and, for each helper, how many
 * of its results differ from the exact value computed on the chip another
 * way (reported as "= ... wrong" rows; tests/extra/avr_arith.sh requires 0).
 * The results are checked here as well as on the host (tests/
 * test_motion_planner.c) because avr-gcc's int is 16 bits wide: a promotion
 * the host never sees would only show here.
 */
#include <stdint.h>
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>
#include "avr_mark.h"
#include "pk_fixed.h"
#include "pk_munits.h"

#define N 300u

static uint64_t rng = 88172645463325252ull;
static uint64_t xr(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return rng;
}

/* an operand of a random width: 0 .. 64 bits */
static uint64_t xw(void) { return xr() >> (uint8_t)(xr() % 64u); }

static void wrong_row(const char *what, uint32_t n)
{
    avr_mark_label("= wrong results: ");
    avr_mark_begin(what);
    avr_mark_end(n);
}

int main(void)
{
    uint32_t bad = 0;
    uint64_t seed = rng;

    avr_mark_label("pk_isqrt64, 0..64-bit x");
    for (uint16_t i = 0; i < N; i++) {
        const uint64_t x = xw();
        avr_mark_start();
        const uint32_t r = pk_isqrt64(x);
        avr_mark_stop();
        if (!((uint64_t)r * r <= x && (r == UINT32_MAX || (uint64_t)(r + 1u) * (r + 1u) > x)))
            bad++;
    }
    avr_mark_report(N);
    wrong_row("pk_isqrt64", bad);

    /* the divisions, on one set of (n, d) with a quotient below 2^32 */
    rng = seed;
    bad = 0;
    uint32_t bad_soft = 0;
    avr_mark_label("libgcc 64/64 division");
    for (uint16_t i = 0; i < N; i++) {
        uint32_t d = (uint32_t)xw();
        uint64_t n = xw();
        if (d == 0u)
            d = 1u;
        if ((n >> 32) >= d)
            n >>= 32;
        avr_mark_start();
        const uint64_t q = n / d;
        avr_mark_stop();
        if (pk_udiv64_32(n, d) != (uint32_t)q)
            bad++;
        if (pk_udiv64_32_soft(n, d) != (uint32_t)q)
            bad_soft++;
    }
    avr_mark_report(N);
    wrong_row("pk_udiv64_32", bad);
    wrong_row("pk_udiv64_32_soft", bad_soft);
    for (uint8_t soft = 0; soft < 2u; soft++) {
        rng = seed;
        avr_mark_label(soft ? "pk_udiv64_32_soft" : "pk_udiv64_32");
        for (uint16_t i = 0; i < N; i++) {
            uint32_t d = (uint32_t)xw();
            uint64_t n = xw();
            if (d == 0u)
                d = 1u;
            if ((n >> 32) >= d)
                n >>= 32;
            avr_mark_start();
            volatile uint32_t q = soft ? pk_udiv64_32_soft(n, d) : pk_udiv64_32(n, d);
            avr_mark_stop();
            (void)q;
        }
        avr_mark_report(N);
    }

    /* quotients of 16 to 32 bits (the motion core's: times, speeds, steps) */
    bad_soft = 0;
    for (uint8_t soft = 0; soft < 3u; soft++) {
        rng = seed;
        avr_mark_label(soft == 2u ? "libgcc 64/64, q of 16-32 bits" : soft ? "pk_udiv64_32_soft, q of 16-32 bits"
                                                                         : "pk_udiv64_32, q of 16-32 bits");
        for (uint16_t i = 0; i < N; i++) {
            const uint32_t d = (uint32_t)(xr() >> (uint8_t)(33u + xr() % 24u)) | 1u;   /* 8..31 bits */
            const uint32_t qq = (uint32_t)(xr() >> (uint8_t)(32u + xr() % 16u)) | 0x8000u; /* 16..32 bits */
            const uint64_t n = (uint64_t)qq * d + (uint32_t)(xr() % d);
            avr_mark_start();
            volatile uint32_t q = soft == 2u ? (uint32_t)(n / d) : soft ? pk_udiv64_32_soft(n, d) : pk_udiv64_32(n, d);
            avr_mark_stop();
            if (q != qq)
                bad_soft++; /* (all three forms counted together) */
        }
        avr_mark_report(N);
    }
    wrong_row("pk_udiv64_32 (16-32-bit q)", bad_soft);

    rng = seed;
    bad = 0;
    avr_mark_label("pk_muldiv_u32");
    for (uint16_t i = 0; i < N; i++) {
        const uint32_t a = (uint32_t)xw(), b = (uint32_t)xw();
        uint32_t d = (uint32_t)xw();
        if (d == 0u)
            d = 1u;
        avr_mark_start();
        const uint32_t q = pk_muldiv_u32(a, b, d);
        avr_mark_stop();
        const uint64_t w = (uint64_t)a * b / d;
        if (q != (w > UINT32_MAX ? UINT32_MAX : (uint32_t)w))
            bad++;
    }
    avr_mark_report(N);
    wrong_row("pk_muldiv_u32", bad);

    rng = seed;
    bad = 0;
    avr_mark_label("pk_div_round64, |x| < 2^62");
    for (uint16_t i = 0; i < N; i++) {
        const int64_t x = (int64_t)(xr() >> (uint8_t)(2u + xr() % 62u)) * ((xr() & 1u) ? -1 : 1);
        int64_t d = (int64_t)(xr() >> (uint8_t)(1u + xr() % 63u));
        if (d == 0)
            d = 1;
        avr_mark_start();
        const int64_t q = pk_div_round64(x, d);
        avr_mark_stop();
        if (q != (x >= 0 ? (x + d / 2) / d : -((-x + d / 2) / d)))
            bad++;
    }
    avr_mark_report(N);
    wrong_row("pk_div_round64", bad);
    cli();
    sleep_mode();
    return 0;
}
