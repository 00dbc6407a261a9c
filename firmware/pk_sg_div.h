/*
 * pk_sg_div.h — the step generator's divisions in shift-and-subtract form
 * (pk_stepgen.c's chunk preparation; a header of its own so that the host
 * tests check the soft forms against the C division on every build:
 * tests/test_sg_div.c).
 *
 * On an 8-bit core (PK_SOFT_DIV, pk_munits.h) libgcc's 64-bit division is a
 * 64-step loop over 8-byte words (~1,900-2,500 AVR cycles for the segment
 * clock's quotient), and its 32-bit one a 32-step loop over 4 bytes whatever
 * the operands (~650). The preparation's quotients are narrower than that:
 * the forms here run one step per quotient bit on remainders that stay in 32
 * (or 16) bits, and skip the quotient's leading zero bytes. Same results as
 * the division they replace, for the operand ranges each states.
 */
#ifndef PLOTKIN_PK_SG_DIV_H
#define PLOTKIN_PK_SG_DIV_H

#include <stdint.h>

/**
 * floor((hi 2^32 + lo) / d) for 0 < d <= 2^31, saturated to UINT32_MAX where
 * the quotient does not fit 32 bits (which is exactly when hi >= d). One
 * compare and subtract per quotient bit on a 32-bit remainder (< d <= 2^31,
 * so twice it plus a bit is below 2^32); the leading quotient bytes that are
 * 0 are skipped a byte at a time (~25 AVR cycles a bit: ~850 for a full
 * 32-bit quotient, ~450 for a 16-bit one).
 */
static inline uint32_t pk_sg_div32_soft(uint32_t hi, uint32_t lo, uint32_t d)
{
    if (hi >= d)
        return UINT32_MAX;
    uint8_t i = 32u;
    /* the next 8 quotient bits are 0 iff (rem:next byte) < d (hi < 2^24:
     * no bit shifted out) */
#if !(defined(PK_FLASH_FIRST) && PK_FLASH_FIRST) /* (a flash-first board: bit by bit) */
    while (i > 8u && hi < ((uint32_t)1 << 24) && ((hi << 8) | (lo >> 24)) < d) {
        hi = (hi << 8) | (lo >> 24);
        lo <<= 8;
        i = (uint8_t)(i - 8u);
    }
#endif
    /* lo: the dividend's bits still to bring down, the quotient's bits
     * entering at the bottom (hi < d throughout) */
    for (; i > 0u; i--) {
        /* (the top bit taken from its byte and the words shifted apart:
         * ~25 AVR cycles a step, where (hi << 1) | (lo >> 31) took ~37) */
        const uint8_t top = (uint8_t)((uint8_t)(lo >> 24) & 0x80u);
        lo <<= 1;
        hi <<= 1;
        if (top != 0u)
            hi |= 1u;
        if (hi >= d) {
            hi -= d;
            lo |= 1u;
        }
    }
    return lo;
}

/**
 * floor(x 2^16 / r) for 0 <= x <= r, 0 < r < 2^16: at most 2^16 (a ratio at
 * most 1 in Q16). 16 steps of 16-bit words (the remainder is below r, so
 * twice it is below 2^17: the bit shifted out says it is above r).
 */
static inline uint32_t pk_sg_frac_q16_soft(uint16_t x, uint16_t r)
{
    if (x >= r)
        return (uint32_t)1 << 16;  /* x == r */
    uint16_t rem = x, q = 0u;
    for (uint8_t i = 0u; i < 16u; i++) {
        const uint8_t top = (uint8_t)(rem >> 15);
        rem = (uint16_t)(rem << 1);
        q = (uint16_t)(q << 1);
        if (top != 0u || rem >= r) {
            rem = (uint16_t)(rem - r); /* (modulo 2^16: the true difference is below r) */
            q |= 1u;
        }
    }
    return q;
}

#endif
