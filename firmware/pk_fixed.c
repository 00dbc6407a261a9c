/*
 * pk_fixed.c — the out-of-line helpers of the fixed-point layer (pk_fixed.h),
 * shared by the kernel and the motion core.
 */
#include "pk_fixed.h"

uint32_t pk_isqrt64(uint64_t x)
{
    /* Classic digit-by-digit method: 32 iterations, shifts and compares only. */
    uint64_t res = 0, bit = (uint64_t)1 << 62;
    while (bit > x)
        bit >>= 2;
    while (bit != 0) {
        if (x >= res + bit) {
            x -= res + bit;
            res = (res >> 1) + bit;
        } else {
            res >>= 1;
        }
        bit >>= 2;
    }
    return (uint32_t)res;
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
