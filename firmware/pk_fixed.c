/*
 * pk_fixed.c — the out-of-line helpers of the fixed-point layer (pk_fixed.h),
 * shared by the kernel and the motion core.
 */
#include "pk_fixed.h"

/* One step of pk_isqrt64's 16-bit phase (steps 1..12: rem <= 2 root < 2^13,
 * so 4 rem + 3 < 2^15; t = 4 root + 1 < 2^14, 2 t + 3 < 2^15), the trial
 * kept as in the 32-bit phase below. */
static inline __attribute__((always_inline)) void isqrt_step16(uint16_t *rem, uint16_t *t, uint8_t *v)
{
#if defined(__AVR__) && !defined(PK_NO_ASM)
    __asm__("lsl %2\n\trol %A0\n\trol %B0\n\t"
            "lsl %2\n\trol %A0\n\trol %B0\n\t"
            "cp %A0, %A1\n\tcpc %B0, %B1\n\t"
            "brlo 1f\n\t"
            "sub %A0, %A1\n\tsbc %B0, %B1\n\t"
            "lsl %A1\n\trol %B1\n\t"
            "subi %A1, 0xFD\n\tsbci %B1, 0xFF\n\t"
            "rjmp 2f\n"
            "1:\tlsl %A1\n\trol %B1\n\t"
            "subi %A1, 1\n\tsbci %B1, 0\n"
            "2:"
            : "+r"(*rem), "+d"(*t), "+r"(*v));
#else
    uint16_t r = (uint16_t)((uint16_t)(*rem << 2) | (uint16_t)(*v >> 6));
    *v = (uint8_t)(*v << 2);
    if (r >= *t) {
        r = (uint16_t)(r - *t);
        *t = (uint16_t)(*t + *t + 3u);
    } else {
        *t = (uint16_t)(*t + *t - 1u);
    }
    *rem = r;
#endif
}

/* One step of pk_isqrt64's 32-bit phase: the top two bits of v into rem,
 * then the trial t = 4 root + 1 (rem < 2^30 before the step: 4 rem + 3 <
 * 2^32, t < 2^32 after it). */
static inline __attribute__((always_inline)) void isqrt_step32(uint32_t *rem, uint32_t *t, uint8_t *v)
{
#if defined(__AVR__) && !defined(PK_NO_ASM)
    /* avr-gcc makes the two bits' way into rem ~30 cycles and the step ~60;
     * shifted through the carry, ~30 (the same operations) */
    __asm__("lsl %2\n\trol %A0\n\trol %B0\n\trol %C0\n\trol %D0\n\t"
            "lsl %2\n\trol %A0\n\trol %B0\n\trol %C0\n\trol %D0\n\t"
            "cp %A0, %A1\n\tcpc %B0, %B1\n\tcpc %C0, %C1\n\tcpc %D0, %D1\n\t"
            "brlo 1f\n\t"
            /* rem >= t: rem -= t, t = 2 t + 3 */
            "sub %A0, %A1\n\tsbc %B0, %B1\n\tsbc %C0, %C1\n\tsbc %D0, %D1\n\t"
            "lsl %A1\n\trol %B1\n\trol %C1\n\trol %D1\n\t"
            "subi %A1, 0xFD\n\tsbci %B1, 0xFF\n\tsbci %C1, 0xFF\n\tsbci %D1, 0xFF\n\t"
            "rjmp 2f\n"
            /* else t = 2 t - 1 */
            "1:\tlsl %A1\n\trol %B1\n\trol %C1\n\trol %D1\n\t"
            "subi %A1, 1\n\tsbci %B1, 0\n\tsbci %C1, 0\n\tsbci %D1, 0\n"
            "2:"
            : "+r"(*rem), "+d"(*t), "+r"(*v));
#else
    uint32_t r = *rem;
    uint8_t b = *v;
    r = r + r + (uint32_t)(b >> 7);
    b = (uint8_t)(b << 1);
    r = r + r + (uint32_t)(b >> 7);
    b = (uint8_t)(b << 1);
    if (r >= *t) {
        r -= *t;
        *t = *t + *t + 3u;
    } else {
        *t = *t + *t - 1u;
    }
    *rem = r;
    *v = b;
#endif
}

uint32_t pk_isqrt64(uint64_t x)
{
    /* Digit by digit, two bits of x per step from the top: after step j (of
     * 32) root = floor(sqrt(the top 2j bits)) < 2^j and rem = those bits -
     * root^2 <= 2 root. The bits are taken a byte (four steps) at a time and
     * leading zero bytes are skipped (root and rem stay 0 there). The widths
     * follow the bounds, since on an 8-bit core every operation costs a
     * cycle per byte (on the AVR: the plain 64-bit form ~7,100 cycles a
     * root, all steps in 32 bits ~1,875, this one ~1,300 on the roots of a
     * dense drawing; bench/avr/avr_arith_cycles.c measures it alone):
     *   - steps 1..12 (the first three bytes) in 16 bits: root < 2^12,
     *     rem <= 2 root < 2^13, so 4 rem + 3 < 2^15 and 4 root + 1 < 2^14
     *     (the trial kept in place of root, as below);
     *   - then 32 bits up to step 30 (rem < 2^30 before it: 4 rem + 3 <
     *     2^32), keeping the trial t = 4 root + 1 < 2^32 itself in place of
     *     root: the next trial is 2 t - 1 (digit 0) or 2 t + 3 (digit 1), so a
     *     step is a compare, a subtract and two 1-bit shifts;
     *   - steps 31 and 32 (only for x >= 2^56, all eight bytes) in 64 bits.
     * The result is the exact floor for every x (tests/test_motion_planner.c,
     * and on the chip bench/avr/avr_arith_cycles.c). */
    const uint32_t hi = pk_hi32(x), lo = (uint32_t)x;
    const uint8_t by[8] = { (uint8_t)(hi >> 24), (uint8_t)(hi >> 16), (uint8_t)(hi >> 8), (uint8_t)hi,
                            (uint8_t)(lo >> 24), (uint8_t)(lo >> 16), (uint8_t)(lo >> 8), (uint8_t)lo };
    uint8_t k = 0;
    while (k < 8u && by[k] == 0u)
        k++;
    if (k == 8u)
        return 0;
    const uint8_t last = k == 0u ? 7u : 8u; /* whole bytes done in 32 bits */
    uint8_t end = (uint8_t)(k + 3u);
    if (end > 8u)
        end = 8u;
    uint16_t t16 = 1u, m16 = 0; /* t16 = 4 root + 1 */
    for (; k < end; k++) {
        uint8_t v = by[k];
        for (uint8_t j = 0; j < 4u; j++)
            isqrt_step16(&m16, &t16, &v);
    }
    if (k == 8u)
        return t16 >> 2;
    uint32_t rem = m16, t = t16; /* t = 4 root + 1 */
    /* whole bytes k .. last - 1, then (last == 7) byte 7's first two steps */
    uint8_t v = 0u;
    for (; k <= last; k++) {
        if (k == 8u)
            break;
        v = by[k];
        const uint8_t n = k < last ? 4u : 2u; /* (k == last only when last == 7) */
        for (uint8_t j = 0; j < n; j++)
            isqrt_step32(&rem, &t, &v);
    }
    uint32_t root = t >> 2;
    if (last == 8u)
        return root;
    /* steps 31 and 32: the last two pairs of by[7] (v holds them on top) */
    uint64_t m = rem;
    for (uint8_t j = 0; j < 2u; j++) {
        m = (m << 2) | (uint64_t)(v >> 6);
        v = (uint8_t)(v << 2);
        const uint64_t tt = ((uint64_t)root << 2) | 1u;
        root <<= 1;
        if (m >= tt) {
            m -= tt;
            root |= 1u;
        }
    }
    return root;
}

/* Unit vector along d in Q1.30: scale so that the largest component lies in
 * [2^29, 2^30) (direction good to ~1e-9 rad; squares sum below 2^62), take
 * the integer square root of the squared length, and divide each component
 * by it bit by bit (restoring division: 32-bit operations only, so no
 * library divide on targets without one). Rounds half away from zero. */
void pk_unit_q30(const int64_t *d, unsigned dims, pk_q30_t *t)
{
    uint64_t mx = 0;
    for (unsigned a = 0; a < dims; a++) {
        uint64_t m = d[a] < 0 ? (uint64_t)0 - (uint64_t)d[a] : (uint64_t)d[a];
        if (m > mx)
            mx = m;
    }
    for (unsigned a = 0; a < dims; a++)
        t[a] = 0;
    if (mx == 0u)
        return;
    int sh = 0, up = 0; /* one-bit steps: no library shift in the loops */
    while (mx >= ((uint64_t)1 << 30)) {
        mx >>= 1;
        sh++;
    }
    while (mx < ((uint64_t)1 << 29)) {
        mx <<= 1;
        up++;
    }
    int64_t v[3];
    uint64_t ss = 0;
    for (unsigned a = 0; a < dims; a++) {
        v[a] = sh ? pk_rshift_round64(d[a], (unsigned)sh) : d[a] * ((int64_t)1 << up);
        uint64_t m = v[a] < 0 ? (uint64_t)0 - (uint64_t)v[a] : (uint64_t)v[a];
        ss += m * m;
    }
    uint32_t len = pk_isqrt64(ss); /* >= 2^29 - 1, < 2^31 */
    if (len == 0u)
        return;
    for (unsigned a = 0; a < dims; a++) {
        uint32_t num = (uint32_t)(v[a] < 0 ? -v[a] : v[a]); /* <= len */
        uint32_t rem = num, q = 0;
        if (rem >= len) { /* the integer bit (num = len) */
            rem -= len;
            q = 1;
        }
        for (int i = 0; i < 31; i++) { /* q = floor(num * 2^31 / len); rem < len < 2^31 */
            rem <<= 1;
            q <<= 1;
            if (rem >= len) {
                rem -= len;
                q |= 1u;
            }
        }
        uint32_t m = (q + 1u) >> 1; /* floor(num * 2^30 / len + 1/2) */
        t[a] = v[a] < 0 ? -(pk_q30_t)m : (pk_q30_t)m;
    }
}
