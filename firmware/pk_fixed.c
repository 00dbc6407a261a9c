/*
 * pk_fixed.c — the out-of-line helpers of the fixed-point layer (pk_fixed.h),
 * shared by the kernel and the motion core.
 */
#include "pk_fixed.h"

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
     *     rem <= 2 root < 2^13, so 4 rem + 3 < 2^15 and 4 root + 1 < 2^14;
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
    uint16_t r16 = 0, m16 = 0;
    for (; k < end; k++) {
        uint8_t v = by[k];
        for (uint8_t j = 0; j < 4u; j++) {
            m16 = (uint16_t)((uint16_t)(m16 << 2) | (uint16_t)(v >> 6));
            v = (uint8_t)(v << 2);
            const uint16_t t = (uint16_t)((uint16_t)(r16 << 2) | 1u);
            r16 = (uint16_t)(r16 << 1);
            if (m16 >= t) {
                m16 = (uint16_t)(m16 - t);
                r16 |= 1u;
            }
        }
    }
    if (k == 8u)
        return r16;
    uint32_t rem = m16, t = ((uint32_t)r16 << 2) | 1u; /* t = 4 root + 1 */
    uint8_t steps = (uint8_t)(4u * (last - k));
    if (last == 7u)
        steps = (uint8_t)(steps + 2u); /* and byte 7's first two steps */
    uint8_t v = by[k];
    for (uint8_t j = 0; j < steps; j++) {
        if ((j & 3u) == 0u && j != 0u)
            v = by[++k];
        rem = rem + rem + (uint32_t)(v >> 7);
        v = (uint8_t)(v << 1);
        rem = rem + rem + (uint32_t)(v >> 7);
        v = (uint8_t)(v << 1);
        if (rem >= t) {
            rem -= t;
            t = t + t + 3u;
        } else {
            t = t + t - 1u;
        }
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
