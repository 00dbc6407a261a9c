/*
 * ref_fixed.h — every fixed-point format plotkin's core uses, in one place.
 *
 * Each format has one typedef whose name carries its unit or Q format, named
 * constants for its range, and conversion helpers. Overflow is prevented by
 * validating inputs against the documented ranges at the boundary (the kernel,
 * the G-code parser, the settings), never by hoping.
 *
 * Formats
 *   ref_um_t    int32   coordinate in whole micrometres (decimal fixed point,
 *                      1 LSB = 0.001 mm). Valid range |v| <= REF_UM_MAX
 *                      (±2097.151 mm): G-code with three decimals is exact.
 *   ref_w8_t    int32   the kernel's working format: micrometres in Q.8
 *                      (1 LSB = 1/256 µm). Inputs are shifted in exactly;
 *                      REF_UM_MAX << 8 < 2^29 leaves two bits of headroom for
 *                      the sums of the refinement masks (see ref_refine.c).
 *   ref_q30_t   int32   a unit-vector component in Q1.30 (1.0 = 2^30), used for
 *                      curve tangents and move directions.
 *
 * Rounding: every division by a power of two rounds to nearest with ties away
 * from zero (ref_rshift_round*), which is odd-symmetric: f(-x) = -f(x). That is
 * what makes mirrored inputs give exactly mirrored outputs.
 */
#ifndef PLOTKIN_REF_FIXED_H
#define PLOTKIN_REF_FIXED_H

#include <stdint.h>

typedef int32_t ref_um_t;
#define REF_UM_PER_MM 1000
#define REF_UM_MAX ((ref_um_t)((1L << 21) - 1))

typedef int32_t ref_w8_t;
#define REF_W8_SHIFT 8
#define REF_W8_ONE_UM ((ref_w8_t)1 << REF_W8_SHIFT)

typedef int32_t ref_q30_t;
#define REF_Q30_ONE ((ref_q30_t)1 << 30)

/** Round x / 2^s to nearest, ties away from zero. 1 <= s <= 31, |x| < 2^31. */
static inline int32_t ref_rshift_round32(int32_t x, unsigned s)
{
    int32_t half = (int32_t)1 << (s - 1);
    return x >= 0 ? (int32_t)((x + half) >> s) : (int32_t)-((-x + half) >> s);
}

/** Round x / 2^s to nearest, ties away from zero. 1 <= s <= 62, |x| < 2^62. */
static inline int64_t ref_rshift_round64(int64_t x, unsigned s)
{
    int64_t half = (int64_t)1 << (s - 1);
    return x >= 0 ? (x + half) >> s : -((-x + half) >> s);
}

/** floor(sqrt(x)) for any 64-bit x (bitwise, no division, bounded loop). */
uint32_t ref_isqrt64(uint64_t x);

/** Round x / d to nearest, ties away from zero. d > 0, |x| < 2^62. */
static inline int64_t ref_div_round64(int64_t x, int64_t d)
{
    return x >= 0 ? (x + d / 2) / d : -((-x + d / 2) / d);
}

#endif
