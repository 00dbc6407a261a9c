/*
 * pk_bezier.h — flatten G5 (cubic) and G5.1 (quadratic) Bézier curves into a
 * polyline within a tolerance, by adaptive midpoint subdivision, one point at
 * a time (pull-based), with no recursion, no heap and no float.
 *
 * Why this bound: for a cubic with control points P0..P3 the distance between
 * the curve and its chord, at equal parameter, never exceeds
 *     3/4 * max(|P0 - 2 P1 + P2|, |P1 - 2 P2 + P3|)
 * and for a quadratic P0..P2 it is exactly |P0 - 2 P1 + P2| / 4 at t = 1/2.
 * A piece is emitted as one segment when that bound is <= the tolerance,
 * otherwise it is split in two at t = 1/2 (de Casteljau). So every output
 * segment stays within `tol` of the piece of curve it replaces, up to the
 * fixed-point rounding of the split points (Q.8 µm, at most 1/256 µm per level,
 * PK_BEZ_MAX_DEPTH levels) and the final rounding to whole µm (0.5 µm).
 * Pieces still too curved at PK_BEZ_MAX_DEPTH (2^12 segments per curve) are
 * emitted anyway: the tolerance is then not met (never for curves inside
 * ±PK_UM_MAX and tolerances >= 1 µm, see the tests).
 *
 * Exactness of the ends: de Casteljau keeps a piece's end points unchanged,
 * so the last point emitted is exactly P3 (P2 for a quadratic).
 */
#ifndef PLOTKIN_PK_BEZIER_H
#define PLOTKIN_PK_BEZIER_H

#include <stdint.h>
#include "pk_fixed.h"

#define PK_BEZ_MAX_DEPTH 12

/** Iterator state (caller-owned; about 420 bytes). Members are private. */
struct pk_bez {
    int32_t stk[PK_BEZ_MAX_DEPTH + 1][4][2]; /**< pieces to visit, Q.8 µm; top = next */
    uint8_t lvl[PK_BEZ_MAX_DEPTH + 1];       /**< subdivision depth of each piece */
    uint8_t sp;                              /**< pieces on the stack */
    uint8_t quad;                            /**< 1: quadratic (uses points 0..2) */
    int64_t lim2;                            /**< squared second-difference limit, Q.8^2 */
};

/**
 * Start a cubic (quad = 0: p[0..3]) or quadratic (quad = 1: p[0..2]) curve.
 * Points in µm, |v| <= PK_UM_MAX. tol_um >= 1 (smaller values are taken as 1).
 * Calling context: any.
 */
void pk_bez_init(struct pk_bez *b, const pk_um_t p[4][2], int quad, pk_um_t tol_um);

/**
 * Next polyline vertex (the start point itself is not emitted).
 * @return 1 with *out set, or 0 when the curve is complete.
 */
int pk_bez_next(struct pk_bez *b, pk_um_t out[2]);

#endif
