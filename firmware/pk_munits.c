/*
 * pk_munits.c — integer square root and the µm <-> step conversions of the
 * motion core (see pk_munits.h for the formats and ranges).
 */
#include "pk_munits.h"

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

pk_steps_t pk_um_to_steps(pk_um_t um, pk_spmm_q16_t spmm)
{
    int64_t num = (int64_t)um * (int64_t)spmm; /* < 2^51 in magnitude */
    return (pk_steps_t)pk_div_round64(num, (int64_t)1000 << PK_SPMM_Q16_SHIFT);
}

pk_um_t pk_steps_to_um(pk_steps_t steps, pk_spmm_q16_t spmm)
{
    int64_t num = (int64_t)steps * ((int64_t)1000 << PK_SPMM_Q16_SHIFT); /* < 2^57 */
    return (pk_um_t)pk_div_round64(num, (int64_t)spmm);
}

pk_um_s_t pk_um_min_to_um_s(pk_um_min_t v)
{
    pk_um_s_t r = (pk_um_s_t)((v + 30u) / 60u);
    return (r == 0u && v != 0u) ? 1u : r;
}
