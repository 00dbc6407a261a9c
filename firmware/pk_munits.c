/*
 * pk_munits.c — the µm <-> step conversions of the motion core (see
 * pk_munits.h for the formats and ranges; the integer square root the motion
 * core uses, pk_isqrt64, is shared with the kernel in pk_fixed.c).
 */
#include "pk_munits.h"

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

uint32_t pk_muldiv_u32(uint32_t a, uint32_t b, uint32_t d)
{
    uint64_t q = ((uint64_t)a * b) / d;
    return q > UINT32_MAX ? UINT32_MAX : (uint32_t)q;
}

uint32_t pk_mulshr_u32(uint32_t a, uint32_t b, unsigned s)
{
    uint64_t q = ((uint64_t)a * b) >> s;
    return q > UINT32_MAX ? UINT32_MAX : (uint32_t)q;
}

int32_t pk_ratio_i32(int32_t num, unsigned s, uint32_t den)
{
    return (int32_t)(((int64_t)num * ((int64_t)1 << s)) / (int64_t)den);
}

uint32_t pk_frac_q30_soft(uint32_t x, uint32_t r)
{
    /* the integer part is 0 or 1 (x <= r); then 30 fraction bits, each by
     * one compare and subtract: rem < r < 2^31, so 2 rem < 2^32 */
    uint32_t q = 0, rem = x;
    if (rem >= r) {
        rem -= r;
        q = 1;
    }
    for (uint8_t i = 0; i < 30u; i++) {
        rem <<= 1;
        q <<= 1;
        if (rem >= r) {
            rem -= r;
            q |= 1u;
        }
    }
    return q;
}

uint32_t pk_frac_q30(uint32_t x, uint32_t r)
{
#if PK_SOFT_DIV
    return pk_frac_q30_soft(x, r);
#else
    return (uint32_t)(((uint64_t)x << 30) / r);
#endif
}
