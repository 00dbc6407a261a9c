/*
 * pk_fixed.c — the out-of-line helpers of the fixed-point layer (pk_fixed.h),
 * shared by the kernel and the motion core.
 */
#include "pk_fixed.h"

uint32_t pk_isqrt64(uint64_t x)
{
    /* Digit by digit, two bits of x per step from the top: after step j (of
     * 32) root = floor(sqrt(the top 2j bits)) < 2^j and rem = those bits -
     * root^2 <= 2 root. So up to step 30 (rem * 4 + 3 < 2^32, trial
     * 4 root + 1 <= 2^31) every step runs in 32 bits, and only the last two
     * need 64 (none for x < 2^32: there root < 2^(j - 16)). The bits are
     * taken a byte at a time (8-bit shifts): on an 8-bit core the plain
     * 64-bit form's shifts, compares and subtractions were long sequences
     * and libgcc calls (~7,100 cycles a root on the AVR). The result is the
     * same exact floor. Leading zero bytes leave root and rem at 0: skipped. */
    const uint32_t hi = (uint32_t)(x >> 32), lo = (uint32_t)x;
    const uint8_t by[8] = { (uint8_t)(hi >> 24), (uint8_t)(hi >> 16), (uint8_t)(hi >> 8), (uint8_t)hi,
                            (uint8_t)(lo >> 24), (uint8_t)(lo >> 16), (uint8_t)(lo >> 8), (uint8_t)lo };
    uint32_t root = 0, rem = 0;
    unsigned k = 0;
    while (k < 8u && by[k] == 0u)
        k++;
    const unsigned last32 = hi != 0u ? 7u : 8u; /* whole bytes in 32 bits */
    unsigned pairs = 0;                          /* of by[k] left */
    uint8_t v = 0;
    for (;;) {
        if (pairs == 0u) {
            if (k == last32)
                break;
            v = by[k++];
            pairs = 4;
        }
        rem = (rem << 2) | (uint32_t)(v >> 6);
        v = (uint8_t)(v << 2);
        pairs--;
        const uint32_t t = (root << 2) | 1u;
        root <<= 1;
        if (rem >= t) {
            rem -= t;
            root |= 1u;
        }
    }
    if (last32 == 8u)
        return root;
    {               /* by[7]: steps 29 and 30 in 32 bits, 31 and 32 in 64 */
        v = by[7];
        for (unsigned j = 0; j < 2u; j++) {
            rem = (rem << 2) | (uint32_t)(v >> 6);
            v = (uint8_t)(v << 2);
            const uint32_t t = (root << 2) | 1u;
            root <<= 1;
            if (rem >= t) {
                rem -= t;
                root |= 1u;
            }
        }
    }
    uint64_t m = rem;
    for (unsigned j = 0; j < 2u; j++) {
        m = (m << 2) | (uint64_t)(v >> 6);
        v = (uint8_t)(v << 2);
        const uint64_t t = ((uint64_t)root << 2) | 1u;
        root <<= 1;
        if (m >= t) {
            m -= t;
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
