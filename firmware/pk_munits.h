/*
 * pk_munits.h — the fixed-point formats of the motion core, and the integer
 * helpers (square root, µm <-> steps) every motion module shares.
 *
 * pk_fixed.h (owned by the kernel) holds the geometric formats; these are the
 * kinematic ones. Each has one typedef whose name carries the unit, and a
 * validated range that keeps every intermediate product of the planner and the
 * step generator inside 64 bits (the bounds are derived next to each use).
 *
 *   pk_um_min_t    uint32  speed, µm/min (G-code F in mm/min, 3 decimals exact)
 *   pk_um_s_t      uint32  speed, µm/s (internal; = µm/min / 60, rounded)
 *   pk_um_s2_t     uint32  acceleration, µm/s^2
 *   pk_v2_q4_t     uint64  squared speed, (µm/s)^2 in Q4 (1 LSB = 1/16 (µm/s)^2)
 *   pk_spmm_q16_t  uint32  steps per mm, unsigned Q16.16
 *   pk_steps_t     int32   whole motor steps
 *   pk_tq8_t       uint64  time in timer ticks, Q8 (1 LSB = 1/256 tick)
 */
#ifndef PLOTKIN_PK_MUNITS_H
#define PLOTKIN_PK_MUNITS_H

#include <stdint.h>
#include "pk_fixed.h"

/* PK_FLASH_FIRST=1 (a board whose flash is the constraint, the Uno): the
 * motion core's main-loop helpers stay out of line where inlining would copy
 * their 64-bit sequences into every caller (on an 8-bit core each 64-bit
 * operation costs tens of bytes of register moves). Same results. */
#ifndef PK_FLASH_FIRST
#define PK_FLASH_FIRST 0
#endif

/* PK_SOFT_DIV=1: the few divisions whose quotient and remainder fit 32 bits
 * are done by shift and subtract in 32-bit words instead of libgcc's 64-bit
 * division (pk_frac_q30): cores without a divide instruction and with
 * narrow registers. Same results. */
#ifndef PK_SOFT_DIV
#if UINTPTR_MAX <= 0xFFFFu
#define PK_SOFT_DIV 1
#else
#define PK_SOFT_DIV 0
#endif
#endif

typedef uint32_t pk_um_min_t;
#define PK_UM_MIN_MAX 60000000u          /**< 60 m/min = 1 m/s */

typedef uint32_t pk_um_s_t;
#define PK_UM_S_MAX (PK_UM_MIN_MAX / 60u) /**< 1,000,000 µm/s < 2^20 */

typedef uint32_t pk_um_s2_t;
#define PK_UM_S2_MAX 100000000u          /**< 100 m/s^2 < 2^27 */

/** (µm/s)^2 in Q4: at most (2^20)^2 * 16 = 2^44 for speeds, and v^2 + 2*a*s
 *  with a < 2^27, s < 2^23 µm stays below 2^51 * 16 = 2^55. */
typedef uint64_t pk_v2_q4_t;
#define PK_V2_Q4_SHIFT 4

typedef uint32_t pk_spmm_q16_t;
#define PK_SPMM_Q16_SHIFT 16
#define PK_SPMM_Q16_MIN ((pk_spmm_q16_t)1 << 16)        /**< 1 step per mm (bounds the step generator's products) */
#define PK_SPMM_Q16_MAX ((pk_spmm_q16_t)10000u << 16)   /**< 10,000 steps per mm */

typedef int32_t pk_steps_t;

typedef uint64_t pk_tq8_t;
#define PK_TQ8_SHIFT 8

/** Compiler barrier: memory accesses are not moved across it. Orders the
 *  chunk data against the ring index shared with the timer callback (one
 *  core: the hardware keeps program order for an interrupt; only the
 *  compiler needs telling). */
#if defined(__GNUC__) || defined(__clang__)
#define PK_BARRIER() __atomic_signal_fence(__ATOMIC_SEQ_CST)
#else
#define PK_BARRIER() ((void)0)
#endif

/** Absolute step position of a coordinate: round(um * spmm / 1000) with ties
 *  away from zero. |um| <= PK_UM_MAX and spmm <= PK_SPMM_Q16_MAX keep the
 *  product below 2^21 * 2^30 = 2^51. */
pk_steps_t pk_um_to_steps(pk_um_t um, pk_spmm_q16_t spmm);

/** Inverse for reports: round(steps * 1000 / spmm), ties away from zero. */
pk_um_t pk_steps_to_um(pk_steps_t steps, pk_spmm_q16_t spmm);

/** µm/min -> µm/s, rounded to nearest (at least 1 for a non-zero input). */
pk_um_s_t pk_um_min_to_um_s(pk_um_min_t v);

/* 32-bit results of 64-bit intermediates. On an 8-bit core every 64-bit
 * operation is a libgcc call or a long inline sequence with its operands
 * moved into fixed registers; the motion core's 64-bit products and
 * quotients whose result fits 32 bits go through these few out-of-line
 * helpers, so that each caller handles 32-bit values only. The results are
 * exactly those of the 64-bit expressions (the saturation only matters to a
 * caller whose range argument allows a result of 2^32 or more). */

/** floor(a * b / d) (d > 0), saturated at UINT32_MAX. */
uint32_t pk_muldiv_u32(uint32_t a, uint32_t b, uint32_t d);

/** floor(a * b / 2^s) (s < 64), saturated at UINT32_MAX. */
uint32_t pk_mulshr_u32(uint32_t a, uint32_t b, unsigned s);

/** num * 2^s / den truncated towards zero, as the 64-bit C division does
 *  (den > 0, |num| * 2^s < 2^63); the caller's range argument keeps the
 *  quotient within int32 (direction cosines in Q1.30: |num| <= den). */
int32_t pk_ratio_i32(int32_t num, unsigned s, uint32_t den);

/** floor(x * 2^30 / r) for 0 <= x <= r, 0 < r < 2^31 (a ratio at most 1
 *  in Q1.30: the decimator's unit directions and cone angles); at most 2^30.
 *  On an 8- or 16-bit core (PK_SOFT_DIV, by default where UINTPTR_MAX <=
 *  0xFFFF) a 30-step shift-and-subtract division whose remainder stays below
 *  r < 2^31, so it is 32-bit throughout (~650 AVR cycles against ~1,360 for
 *  the libgcc 64-bit division it replaces); elsewhere the 64-bit division.
 *  The same results either way (tests/test_motion_planner.c). */
uint32_t pk_frac_q30(uint32_t x, uint32_t r);

/** The shift-and-subtract form of pk_frac_q30, on every build (so that the
 *  host tests check it against the 64-bit division). */
uint32_t pk_frac_q30_soft(uint32_t x, uint32_t r);

/** num * 2^30 / r truncated towards zero, as the 64-bit C division gives it,
 *  for |num| <= r, 0 < r < 2^31 (a signed unit-vector component in Q1.30):
 *  pk_frac_q30 of |num|, the sign put back. */
static inline int32_t pk_frac_q30_signed(int32_t num, uint32_t r)
{
    const int32_t u = (int32_t)pk_frac_q30((uint32_t)(num < 0 ? -num : num), r);
    return num < 0 ? -u : u;
}

#endif
