/*
 * pk_refine_build.h — the kernel's compile-time selection (axes, depth,
 * schemes, end rules, closed curves, limit stage) and what follows from it:
 * which engines are compiled and how wide the exact working values are
 * (PK_UMF_BITS). In a header of its own because pk_fixed.h needs the width
 * for pk_umf_t: every translation unit must see the same one, whichever of
 * pk_fixed.h and pk_refine.h it includes first (a unit that took a 64-bit
 * default while the kernel was built with 32-bit values saw another layout
 * of struct pk_refine, and so of every struct that holds one: in the Uno's
 * PK_MAX_DEPTH <= 5 build pk_motion.c read the stroke's `finishing` flag
 * from inside the kernel's state, and the machine stalled).
 */
#ifndef PLOTKIN_PK_REFINE_BUILD_H
#define PLOTKIN_PK_REFINE_BUILD_H

/** Axes stored per point (compile-time; 2 halves the state of XY-only builds). */
#ifndef PK_AXES
#define PK_AXES 3
#endif
/** Deepest refinement supported. */
#ifndef PK_MAX_DEPTH
#define PK_MAX_DEPTH 8
#endif

/* ---- build selection ------------------------------------------------------
 * PK_BUILD_DEGREES  bit D set: B-spline degree D is built (D = 1..7).
 *                   Default 0xFE (all); Chaikin only: 0x04; Chaikin and the
 *                   cubic: 0x0C.
 * PK_BUILD_DLG      1: the DLG 4-point scheme is built (default 1).
 * PK_BUILD_ENDS     bit e set: open end rule e is built, with e =
 *                   PK_ENDS_CLAMPED (1), PK_ENDS_REPLACE (2), PK_ENDS_NONE
 *                   (3). Default 0x0E (all); clamped only: 0x02.
 * PK_BUILD_CLOSED   1: closed curves are built (default 1).
 * PK_BUILD_LIMIT    1: the limit/tangent stage (cfg.limit, cfg.tangents) is
 *                   built (default 1).
 * A configuration outside what is built gets PK_ENOTSUP from pk_refine_init.
 * The smallest useful build, Chaikin with clamped ends on 2 axes:
 *   -DPK_AXES=2 -DPK_BUILD_DEGREES=0x04 -DPK_BUILD_DLG=0 -DPK_BUILD_ENDS=0x02
 *   -DPK_BUILD_CLOSED=0 [-DPK_BUILD_LIMIT=0] [-DPK_MAX_DEPTH=5]
 * (PK_MAX_DEPTH <= 5 there also switches the working values to 32 bits.) */
#ifndef PK_BUILD_DEGREES
#define PK_BUILD_DEGREES 0xFE
#endif
#ifndef PK_BUILD_DLG
#define PK_BUILD_DLG 1
#endif
#ifndef PK_BUILD_ENDS
#define PK_BUILD_ENDS 0x0E
#endif
#ifndef PK_BUILD_CLOSED
#define PK_BUILD_CLOSED 1
#endif
#ifndef PK_BUILD_LIMIT
#define PK_BUILD_LIMIT 1
#endif

/** PK_REFINE_FAST_PULL (Chaikin-only builds without the limit stage): 1
 *  gives pk_refine_pull a hot path of its own for points inside a run at
 *  F = 8 (depths <= 4 of 32-bit builds) and the refill one for the next
 *  interior span: about 90 cycles less per point on AVR (Chaikin d4,
 *  bench-avr builds with it), for about 200 B more flash on Cortex-M0+ and
 *  700 B on AVR (bench-sizes). 0 (default): flash first. */
#ifndef PK_REFINE_FAST_PULL
#define PK_REFINE_FAST_PULL 0
#endif

/** Chaikin with clamped ends only: the kernel is pk_refine_chaikin.c alone
 *  (written out for the smallest chips), the general one is not compiled. */
#define PK_CHAIKIN_ONLY (PK_BUILD_DEGREES == 0x04 && !PK_BUILD_DLG && PK_BUILD_ENDS == 0x02 && !PK_BUILD_CLOSED)

/* Which engines that selection needs (see pk_refine.c). The closed-form span
 * engine serves B-spline degrees 1..3 with clamped or no end rule and closed
 * curves (and degree 1 with any rule); the level cascade serves DLG, the
 * replace rule of degrees 2..3 and every degree >= 4. */
#define PK_HAVE_SPAN (((PK_BUILD_DEGREES & 0x02) != 0 || \
                       ((PK_BUILD_DEGREES & 0x0C) != 0 && ((PK_BUILD_ENDS & 0x0A) != 0 || PK_BUILD_CLOSED))) && \
                      !PK_CHAIKIN_ONLY)
#define PK_HAVE_CASCADE ((PK_BUILD_DLG || (PK_BUILD_DEGREES & 0xF0) != 0 || \
                          ((PK_BUILD_ENDS & 0x04) != 0 && (PK_BUILD_DEGREES & 0x0C) != 0)) && !PK_CHAIKIN_ONLY)
/** Highest degree the span engine handles in this build. */
#define PK_SPAN_DMAX ((PK_BUILD_DEGREES & 0x08) ? 3 : (PK_BUILD_DEGREES & 0x04) ? 2 : 1)
/** Input points the span engine keeps (a ring, so a power of two): a
 *  clamped span's D + 1 plus the lookahead that tells it from the stroke's
 *  last spans (2D in all), or D + 2 for the plain rule (one span per push). */
#define PK_SPAN_WIN (PK_SPAN_DMAX == 3 ? 8 : 4)
/** The span engine's degree when the build has only one (else 0). */
#define PK_SPAN_ONE_D ((PK_BUILD_DEGREES & 0x0E) == 0x04 ? 2 : (PK_BUILD_DEGREES & 0x0E) == 0x08 ? 3 \
                       : (PK_BUILD_DEGREES & 0x0E) == 0x02 ? 1 : 0)

/* Largest number of fraction bits F a level-K value needs in this build
 * (pk_refine.c, "Ranges"); 32-bit working values when that is <= 10. */
#define PK_F_MAX_SPAN ((PK_BUILD_DEGREES & 0x08) ? 3 * PK_MAX_DEPTH + 1 \
                       : (PK_BUILD_DEGREES & 0x04) ? 2 * PK_MAX_DEPTH : PK_MAX_DEPTH)
#ifndef PK_UMF_BITS
#if PK_HAVE_CASCADE || PK_F_MAX_SPAN > 10
#define PK_UMF_BITS 64
#else
#define PK_UMF_BITS 32
#endif
#endif

#endif
