/*
 * pk_bezier.h — flatten G5 (cubic) and G5.1 (quadratic) Bézier curves into
 * chord vertices within a chord tolerance, one vertex at a time (pull-based),
 * in bounded state (about 60 bytes, whatever the curve), with no recursion,
 * no heap and no float.
 *
 * Method: adaptive bisection in the parameter, walked as a depth-first
 * traversal of dyadic intervals [m/2^L, (m+1)/2^L] (L <= PK_BEZ_MAX_DEPTH)
 * with no stack: an interval's flatness and its end vertex are both computed
 * directly from the four control points, exactly in integers.
 *
 * Why the bound holds: on [a, b] (h = b - a) the sub-curve's second
 * differences are h^2 ((1-a) D0 + a D1) and h^2 ((1-b) D0 + b D1), with
 * D0 = P0 - 2 P1 + P2, D1 = P1 - 2 P2 + P3 (a quadratic: h^2 D0, constant),
 * and a cubic stays within 3/4 of the larger of them of its chord (a
 * quadratic within 1/4 of it). An interval is one chord when that bound is
 * at most tol - 0.71 µm; the vertex is the curve point at the interval's end,
 * computed exactly (a rational with denominator 2^3L) and rounded to whole µm
 * (at most 0.71 µm away). So every chord lies within tol of the piece of
 * curve it replaces and that piece within tol of the chord. The last vertex is
 * exactly P3 (P2 for a quadratic). At PK_BEZ_MAX_DEPTH (8192 chords) the
 * piece's bound is below 0.1 µm for any curve within ±PK_UM_MAX, so the
 * tolerance is always met for tol >= 1 µm.
 *
 * Arithmetic: 64-bit (exact curve points: weights up to 2^39 times
 * coordinates up to 2^21).
 */
#ifndef PLOTKIN_PK_BEZIER_H
#define PLOTKIN_PK_BEZIER_H

#include <stdint.h>
#include "pk_fixed.h"

#define PK_BEZ_MAX_DEPTH 13

/** Iterator state (caller-owned). Members are private. */
struct pk_bez {
    int32_t p[4][2];   /**< control points, µm */
    int32_t d[2][2];   /**< D0, D1 (second differences), µm */
    uint32_t m;        /**< current interval [m/2^lvl, (m+1)/2^lvl] */
    uint8_t lvl;
    uint8_t quad;      /**< 1: quadratic (points 0..2) */
    int32_t tolb_q8;   /**< tolerance left after vertex rounding, Q8 µm */
};

/**
 * Start a cubic (quad = 0: p[0..3]) or quadratic (quad = 1: p[0..2]) curve.
 * Points in µm, |v| <= PK_UM_MAX. tol_um is the chord tolerance (values
 * below 1 are taken as 1). Calling context: any.
 */
void pk_bez_init(struct pk_bez *b, const pk_um_t p[4][2], int quad, pk_um_t tol_um);

/**
 * Next polyline vertex (the start point itself is not emitted).
 * @return 1 with *out set, or 0 when the curve is complete.
 */
int pk_bez_next(struct pk_bez *b, pk_um_t out[2]);

#endif
