/*
 * pk_fixed.h — every fixed-point format plotkin's core uses, in one place.
 *
 * Each format has one typedef whose name carries its unit or Q format, named
 * constants for its range, and conversion helpers. Overflow is prevented by
 * validating inputs against the documented ranges at the boundary (the kernel,
 * the G-code parser, the settings), never by hoping.
 *
 * Formats
 *   pk_um_t    int32   coordinate in whole micrometres (decimal fixed point,
 *                      1 LSB = 0.001 mm). Valid range |v| <= PK_UM_MAX
 *                      (±2097.151 mm): G-code with three decimals is exact.
 *   pk_w8_t    int32   the kernel's working format: micrometres in Q.8
 *                      (1 LSB = 1/256 µm). Inputs are shifted in exactly;
 *                      PK_UM_MAX << 8 < 2^29 leaves two bits of headroom for
 *                      the sums of the refinement masks (see pk_refine.c).
 *   pk_umf_t   int64   the kernel's exact working values: micrometres with F
 *              (int32) fraction bits, N / 2^F µm, where F is fixed per stream
 *                      (its depth and scheme, at most 42; pk_refine.c). No
 *                      rounding happens in this format: every level-K point
 *                      of the refinement is such a dyadic rational exactly.
 *                      32 bits in builds whose F never exceeds 10
 *                      (PK_UMF_BITS, set by pk_refine_build.h from the
 *                      build knobs), so |N| < 2^31.
 *   pk_q30_t   int32   a unit-vector component in Q1.30 (1.0 = 2^30), used for
 *                      curve tangents and move directions.
 *
 * Rounding: every division by a power of two rounds to nearest with ties away
 * from zero (pk_rshift_round*), which is odd-symmetric: f(-x) = -f(x). That is
 * what makes mirrored inputs give exactly mirrored outputs.
 */
#ifndef PLOTKIN_PK_FIXED_H
#define PLOTKIN_PK_FIXED_H

#include <stdint.h>

#include "pk_refine_build.h" /* PK_UMF_BITS: the build's one width of pk_umf_t */

typedef int32_t pk_um_t;
#define PK_UM_PER_MM 1000
#define PK_UM_MAX ((pk_um_t)((1L << 21) - 1))

typedef int32_t pk_w8_t;
#define PK_W8_SHIFT 8
#define PK_W8_ONE_UM ((pk_w8_t)1 << PK_W8_SHIFT)

#if PK_UMF_BITS == 64
typedef int64_t pk_umf_t;
#elif PK_UMF_BITS == 32
typedef int32_t pk_umf_t;
#else
#error "PK_UMF_BITS must be 32 or 64"
#endif

typedef int32_t pk_q30_t;
#define PK_Q30_ONE ((pk_q30_t)1 << 30)

/** The high 32 bits of x, (uint32_t)(x >> 32). On the AVR a register
 *  move: avr-gcc 5.4 makes even this constant 64-bit shift a call of
 *  libgcc's __lshrdi3 (~80 cycles); the union reads the upper word of the
 *  little-endian value. */
static inline uint32_t pk_hi32(uint64_t x)
{
#if defined(__AVR__) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    union {
        uint64_t v;
        uint32_t w[2];
    } u;
    u.v = x;
    return u.w[1];
#else
    return (uint32_t)(x >> 32);
#endif
}

/** Round x / 2^s to nearest, ties away from zero. 1 <= s <= 31, |x| < 2^31. */
static inline int32_t pk_rshift_round32(int32_t x, unsigned s)
{
    int32_t half = (int32_t)1 << (s - 1);
    return x >= 0 ? (int32_t)((x + half) >> s) : (int32_t)-((-x + half) >> s);
}

/** Round x / 2^s to nearest, ties away from zero. 1 <= s <= 62, |x| < 2^62. */
static inline int64_t pk_rshift_round64(int64_t x, unsigned s)
{
    int64_t half = (int64_t)1 << (s - 1);
    return x >= 0 ? (x + half) >> s : -((-x + half) >> s);
}

/** Round x / 2^f to the nearest micrometre, ties away from zero (f >= 1,
 *  half = 2^(f-1); the result fits pk_um_t when |x| < 2^(f+31)). Branch-free:
 *  adding -1 for negative x turns floor((x + half) / 2^f) into its mirror
 *  image (arithmetic shifts of negative values: pk_refine.c checks that the
 *  compiler does them). On AVR a shift by 8 first: that is a byte move, where
 *  a variable shift is a loop (32-bit kernel builds carry F = 8 wherever they
 *  can, pk_refine_span.c). */
static inline pk_um_t pk_umf_round(pk_umf_t x, unsigned f, pk_umf_t half)
{
    x = x + half + (x >> (PK_UMF_BITS - 1));
#if defined(__AVR__)
    if (f == 8u)
        return (pk_um_t)(x >> 8);
    return (pk_um_t)(f > 8u ? (x >> 8) >> (f - 8u) : x >> f);
#else
    return (pk_um_t)(x >> f);
#endif
}

/** floor(sqrt(x)) for any 64-bit x (bitwise, no division, bounded loop). */
uint32_t pk_isqrt64(uint64_t x);

/** Unit vector (Q1.30) along d (dims <= 3 components); all zero if d is
 *  zero. Good to ~1e-9 rad; integer operations only and no division (a
 *  restoring division in 32 bits), so no library divide on small targets. */
void pk_unit_q30(const int64_t *d, unsigned dims, pk_q30_t *t);

/** Round x / d to nearest, ties away from zero. d > 0, |x| < 2^62. */
static inline int64_t pk_div_round64(int64_t x, int64_t d)
{
    return x >= 0 ? (x + d / 2) / d : -((-x + d / 2) / d);
}

#endif
