/*
 * ref_fixed.c — the out-of-line helpers of the fixed-point layer (ref_fixed.h),
 * shared by the kernel and the motion core.
 */
#include "ref_fixed.h"

uint32_t ref_isqrt64(uint64_t x)
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
