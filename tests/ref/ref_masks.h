/*
 * ref_masks.h -- limit-point (evaluation) and tangent masks of every
 * subdivision scheme of the refinement kernel, for its --limit/--tangents
 * stage. GENERATED FILE, do not edit: regenerate with
 *
 *     python3 tests/tools/derive_masks.py --emit firmware
 *
 * (the same script re-derives every mask exactly and verifies it by brute
 * force: python3 tests/tools/derive_masks.py --verify).
 *
 * Derivation. One level of refinement is a linear map S: new points = S *
 * old points (S depends on the polygon size near the ends of open curves).
 * Follow one "anchor" from level to level: a vertex (odd degree, DLG) or an
 * edge (even degree) maps to the anchor at the same curve parameter on the
 * next level, index a -> sigma(a) (uniform B-spline: 2a - (D-1)/2 for
 * vertices, 2a - (D/2-1) for edges; DLG: 2a).
 *  - Uniform region: the local subdivision matrix of a window closed under S
 *    has the eigenvalues 1, 1/2, 1/4, ... (B-splines; DLG: 1, 1/2, 1/4, 1/4,
 *    1/8). The left eigenvector of 1 (sum 1) is the evaluation mask: A^k ->
 *    1 l0, so every point of the window converges to l0.P. The left
 *    eigenvector of the subdominant 1/2 is the tangent mask: the window
 *    points approach l0.P along l1.P (error ~ (lambda2/lambda1)^k). For the
 *    B-splines these are the cardinal B-spline and its derivative sampled at
 *    the knots (cubic (1,4,1)/6 and (-1,0,1)/2; quadratic: edge midpoint and
 *    edge direction; quintic (1,26,66,26,1)/120 ...); DLG: the vertex itself
 *    (interpolating) and (1,-8,0,8,-1)/12.
 *  - End of an open curve, stationary anchor (sigma(a) = a; the end point):
 *    the same eigen-analysis on the smallest window [L0..Lw-1] that S maps
 *    into itself. The end rules make these spectra differ: replace D=3
 *    {1, (5+sqrt5)/8, (5-sqrt5)/8} -- the subdominant eigenvalue is
 *    irrational, so the tangent mask is too and is stored as integers over
 *    2^24 (far below the 0.05 degree requirement). Replace D >= 4 have
 *    subdominant eigenvalues very close to 1 (the curve creeps towards L0).
 *  - Anchors near an end that are not stationary are followed along sigma
 *    until they reach a uniform or stationary anchor and that mask is pulled
 *    back through S (mask_a = mask_sigma(a) * S), e.g. DLG vertex 1.
 *    Anchors whose sigma-chain collapses into the end point (replace: vertex
 *    1 of the cubic) converge to the same limit point as anchor 0 and are
 *    dropped (drop_mask).
 *  - Clamped ends: the limit curve is the clamped B-spline itself; anchor a
 *    is evaluated at its Greville abscissa (odd D; vertex 1 of the clamped
 *    cubic is not stationary under refinement, its Greville abscissa 1/3
 *    moves towards 0 -- the mask is C(1/3), a point on the curve) or, for the
 *    clamped quadratic, at the knot where the curve touches edge a (edge 0:
 *    L0, tangent along L0L1). Cross-checked against the eigen-analysis.
 *  - Open `none` is exactly the uniform B-spline restricted to the anchors
 *    whose uniform stencil lies inside the polygon; the others are dropped.
 *  - Right ends are mirror images of left ends (checked: every open S is
 *    reversal-symmetric): value = sum_r w[r] * L[n-1-(a+first+r)] for the
 *    anchor a counted from the right end (vertex n-1-a, or edge n-2-a joining
 *    L[n-2-a] and L[n-1-a]); tangent weights negated.
 *  - Short polygons (n < min_n) get their own per-n masks (ref_limit_small_get),
 *    derived by following the refinement (which may grow, keep or shrink
 *    such a polygon) until the standard rules apply or the polygon becomes
 *    stationary; their slots are output positions 0..A-1 in polygon order.
 *  - Degree 1: the limit is the polygon; the tangent at an interior vertex
 *    (a corner) is undefined and given as an empty mask (len 0: output a
 *    zero tangent); at an open end it is the one-sided L1-L0.
 *
 * Weight bounds: every |w| < 2^31 and sum |w| <= REF_MASK_ABS_SUM_MAX, so a
 * mask sum over ref_w8_t points (|L| < 2^30) fits comfortably in int64_t.
 * Position masks are exact (den > 0, sum w = den). Tangent masks sum to 0
 * exactly (straight lines give exact tangents); only their direction counts.
 * Rational tangent masks are normalised to give exactly +1 on L_j = j (the
 * derivative along the polygon index; uniform cubic (-1,0,1)/2), so den is
 * that rational's denominator; irrational ones have den = 2^24 and positive
 * weights summing to 2^24 (each rounded to nearest, the largest adjusted so
 * that the sum stays 0). Tangents point forward (towards higher indices).
 *
 * Per-rule summary (generated):
 *   bspline:1 closed: anchors are vertices; uniform position (L0:1); tangent undefined (zero)
 *   chaikin closed: anchors are edges; uniform position (L0:1/2, L1:1/2); tangent (L0:-1, L1:1)
 *   bspline:3 closed: anchors are vertices; uniform position (L-1:1/6, L0:2/3, L1:1/6); tangent (L-1:-1/2, L1:1/2)
 *   bspline:4 closed: anchors are edges; uniform position (L-1:1/24, L0:11/24, L1:11/24, L2:1/24); tangent (L-1:-1/6, L0:-1/2, L1:1/2, L2:1/6)
 *   bspline:5 closed: anchors are vertices; uniform position (L-2:1/120, L-1:13/60, L0:11/20, L1:13/60, L2:1/120); tangent (L-2:-1/24, L-1:-5/12, L1:5/12, L2:1/24)
 *   bspline:6 closed: anchors are edges; uniform position (L-2:1/720, L-1:19/240, L0:151/360, L1:151/360, L2:19/240, L3:1/720); tangent (L-2:-1/120, L-1:-5/24, L0:-1/3, L1:1/3, L2:5/24, L3:1/120)
 *   bspline:7 closed: anchors are vertices; uniform position (L-3:1/5040, L-2:1/42, L-1:397/1680, L0:151/315, L1:397/1680, L2:1/42, L3:1/5040); tangent (L-3:-1/720, L-2:-7/90, L-1:-49/144, L1:49/144, L2:7/90, L3:1/720)
 *   dlg closed: anchors are vertices; uniform position (L0:1); tangent (L-2:1/12, L-1:-2/3, L1:2/3, L2:-1/12)
 *       uniform window 5: spectrum {1, 0.5, 0.25, 0.25, 0.125}; subdominant 1/2
 *   bspline:1 none: anchors are vertices; uniform position (L0:1); tangent undefined (zero)
 *       end anchor 0: position (L0:1); tangent (L0:-1, L1:1)
 *       min_n 2 (per-n masks below that)
 *   chaikin none: anchors are edges; uniform position (L0:1/2, L1:1/2); tangent (L0:-1, L1:1)
 *       min_n 3 (per-n masks below that)
 *   bspline:3 none: anchors are vertices; uniform position (L-1:1/6, L0:2/3, L1:1/6); tangent (L-1:-1/2, L1:1/2)
 *       end anchor 0: dropped (no full uniform stencil: outside the curve)
 *       min_n 4 (per-n masks below that)
 *   bspline:4 none: anchors are edges; uniform position (L-1:1/24, L0:11/24, L1:11/24, L2:1/24); tangent (L-1:-1/6, L0:-1/2, L1:1/2, L2:1/6)
 *       end anchor 0: dropped (no full uniform stencil: outside the curve)
 *       min_n 5 (per-n masks below that)
 *   bspline:5 none: anchors are vertices; uniform position (L-2:1/120, L-1:13/60, L0:11/20, L1:13/60, L2:1/120); tangent (L-2:-1/24, L-1:-5/12, L1:5/12, L2:1/24)
 *       end anchor 0: dropped (no full uniform stencil: outside the curve)
 *       end anchor 1: dropped (no full uniform stencil: outside the curve)
 *       min_n 6 (per-n masks below that)
 *   bspline:6 none: anchors are edges; uniform position (L-2:1/720, L-1:19/240, L0:151/360, L1:151/360, L2:19/240, L3:1/720); tangent (L-2:-1/120, L-1:-5/24, L0:-1/3, L1:1/3, L2:5/24, L3:1/120)
 *       end anchor 0: dropped (no full uniform stencil: outside the curve)
 *       end anchor 1: dropped (no full uniform stencil: outside the curve)
 *       min_n 7 (per-n masks below that)
 *   bspline:7 none: anchors are vertices; uniform position (L-3:1/5040, L-2:1/42, L-1:397/1680, L0:151/315, L1:397/1680, L2:1/42, L3:1/5040); tangent (L-3:-1/720, L-2:-7/90, L-1:-49/144, L1:49/144, L2:7/90, L3:1/720)
 *       end anchor 0: dropped (no full uniform stencil: outside the curve)
 *       end anchor 1: dropped (no full uniform stencil: outside the curve)
 *       end anchor 2: dropped (no full uniform stencil: outside the curve)
 *       min_n 8 (per-n masks below that)
 *   bspline:1 replace: anchors are vertices; uniform position (L0:1); tangent undefined (zero)
 *       end anchor 0: position (L0:1); tangent (L0:-1, L1:1)
 *       min_n 2 (per-n masks below that)
 *   chaikin replace: anchors are edges; uniform position (L0:1/2, L1:1/2); tangent (L0:-1, L1:1)
 *       end anchor 0: position (L0:1); tangent (L0:-1, L1:1)
 *       min_n 3 (per-n masks below that)
 *       end window 2: spectrum {1, 0.75}; subdominant 3/4
 *   bspline:3 replace: anchors are vertices; uniform position (L-1:1/6, L0:2/3, L1:1/6); tangent (L-1:-1/2, L1:1/2)
 *       end anchor 0: position (L0:1); tangent (L0:-0.809016994, L1:0.618033989, L2:0.190983006) [irrational]
 *       end anchor 1: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       min_n 4 (per-n masks below that)
 *       end window 3: spectrum {1, 0.904508, 0.345492}; subdominant 5/8 + 1/8*sqrt(5)  (root of +16x^2 -20x +5)
 *   bspline:4 replace: anchors are edges; uniform position (L-1:1/24, L0:11/24, L1:11/24, L2:1/24); tangent (L-1:-1/6, L0:-1/2, L1:1/2, L2:1/6)
 *       end anchor 0: position (L0:1); tangent (L0:-0.628637289, L1:0.286880218, L2:0.312151431, L3:0.029605640) [irrational]
 *       end anchor 1: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       min_n 5 (per-n masks below that)
 *       end window 4: spectrum {1, 0.971478, 0.425743, 0.165279}; subdominant 0.971477966796997 (root of +512x^3 -800x^2 +330x -35)
 *   bspline:5 replace: anchors are vertices; uniform position (L-2:1/120, L-1:13/60, L0:11/20, L1:13/60, L2:1/120); tangent (L-2:-1/24, L-1:-5/12, L1:5/12, L2:1/24)
 *       end anchor 0: position (L0:1); tangent (L0:-0.493364922, L1:0.104752474, L2:0.274837119, L3:0.109528028, L4:0.004247301) [irrational]
 *       end anchor 1: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       end anchor 2: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       min_n 6 (per-n masks below that)
 *       end window 5: spectrum {1, 0.993365, 0.472094, 0.204255, 0.0802862}; subdominant 0.993364921876114 (root of +8192x^4 -14336x^3 +7392x^2 -1290x +63)
 *   bspline:6 replace: anchors are edges; uniform position (L-2:1/720, L-1:19/240, L0:151/360, L1:151/360, L2:19/240, L3:1/720); tangent (L-2:-1/120, L-1:-5/24, L0:-1/3, L1:1/3, L2:5/24, L3:1/120)
 *       end anchor 0: position (L0:1); tangent (L0:-0.399021731, L1:0.031228062, L2:0.167480414, L3:0.167999791, L4:0.031755582, L5:0.000557881) [irrational]
 *       end anchor 1: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       end anchor 2: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       min_n 7 (per-n masks below that)
 *       end window 6: spectrum {1, 0.998777, 0.49194, 0.230303, 0.0990401, 0.0393142}; subdominant 0.998777163186989 (root of +524288x^5 -974848x^4 +564480x^3 -123384x^2 +9912x -231)
 *   bspline:7 replace: anchors are vertices; uniform position (L-3:1/5040, L-2:1/42, L-1:397/1680, L0:151/315, L1:397/1680, L2:1/42, L3:1/5040); tangent (L-3:-1/720, L-2:-7/90, L-1:-49/144, L1:49/144, L2:7/90, L3:1/720)
 *       end anchor 0: position (L0:1); tangent (L0:-0.333209900, L1:0.007896831, L2:0.078712304, L3:0.159797505, L4:0.078796440, L5:0.007940636, L6:0.000066185) [irrational]
 *       end anchor 1: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       end anchor 2: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       end anchor 3: dropped (its limit is the end point (duplicate) or it lies outside the curve)
 *       min_n 8 (per-n masks below that)
 *       end window 7: spectrum {1, 0.999815, 0.4982, 0.243415, 0.112758, 0.0483423, 0.0193447}; subdominant 0.999814849472802 (root of +33554432x^7 -98041856x^6 +104267776x^5 -49576576x^4 +10784520x^3 -1026204x^2 +38337x -429)
 *   bspline:1 clamped: anchors are vertices; uniform position (L0:1); tangent undefined (zero)
 *       end anchor 0: position (L0:1); tangent (L0:-1, L1:1)
 *       min_n 2 (per-n masks below that)
 *   chaikin clamped: anchors are edges; uniform position (L0:1/2, L1:1/2); tangent (L0:-1, L1:1)
 *       end anchor 0: position (L0:1); tangent (L0:-2, L1:2)
 *       min_n 3 (per-n masks below that)
 *       end window 2: spectrum {1, 0.5}; subdominant 1/2
 *   bspline:3 clamped: anchors are vertices; uniform position (L-1:1/6, L0:2/3, L1:1/6); tangent (L-1:-1/2, L1:1/2)
 *       end anchor 0: position (L0:1); tangent (L0:-3, L1:3)
 *       end anchor 1: position (L0:8/27, L1:61/108, L2:43/324, L3:1/162); tangent (L0:-4/3, L1:7/12, L2:25/36, L3:1/18)
 *       end anchor 2: position (L1:1/4, L2:7/12, L3:1/6); tangent (L1:-3/4, L2:1/4, L3:1/2)
 *       min_n 6 (per-n masks below that)
 *       end window 2: spectrum {1, 0.5}; subdominant 1/2
 *   dlg open: anchors are vertices; uniform position (L0:1); tangent (L-2:1/12, L-1:-2/3, L1:2/3, L2:-1/12)
 *       end anchor 0: position (L0:1); tangent (L0:-7/6, L1:4/3, L2:-1/6)
 *       end anchor 1: position (L1:1); tangent (L0:-1/2, L1:-1/12, L2:2/3, L3:-1/12)
 *       min_n 4 (per-n masks below that)
 *       uniform window 5: spectrum {1, 0.5, 0.25, 0.25, 0.125}; subdominant 1/2
 *       end window 3: spectrum {1, 0.5, 0.125}; subdominant 1/2
 */
#ifndef PLOTKIN_REF_MASKS_H
#define PLOTKIN_REF_MASKS_H

#include <stdint.h>

/** Most weights in one mask. */
#define REF_MASK_MAXLEN 8
/** Largest sum of |w| over any mask in the tables. */
#define REF_MASK_ABS_SUM_MAX 33554432L
/** Denominator of the irrational (rounded) tangent masks. */
#define REF_MASK_Q24 (1L << 24)

/** One mask: value = sum_r w[r] * L[anchor + first + r] / den. */
struct ref_mask {
    int8_t first;              /**< index of w[0] relative to the anchor (e.g. -1) */
    uint8_t len;               /**< number of weights used (0: undefined tangent: output zero) */
    int32_t den;               /**< > 0. Position masks: exact, sum w = den. Tangent masks:
                                    direction only (sum w = 0); den is the exact rational's
                                    denominator, or 1<<24 if irrational (w rounded) */
    int32_t w[REF_MASK_MAXLEN];
};

/** Limit rule of one scheme/degree/closed/ends combination. */
struct ref_limit_rule {
    uint8_t edge_anchors;      /**< 1: anchors are edges (even D), 0: vertices */
    uint8_t nend;              /**< anchors 0..nend-1 from each end use pos_end/tan_end */
    uint8_t drop_mask;         /**< bit a set: end anchor a (from either end) is dropped (duplicate limit point) */
    uint8_t min_n;             /**< smallest polygon size for which uniform + end masks are valid without overlap */
    struct ref_mask pos_uniform, tan_uniform;
    struct ref_mask pos_end[4], tan_end[4];   /**< left end; the right end is the mirror image */
};

/**
 * Limit rule lookup. scheme 0 = B-spline (degree 1..7), 1 = DLG (degree
 * ignored); ends 1 clamped, 2 replace, 3 none (open only; DLG ignores it);
 * closed ignores ends. Closed rules have nend 0 and min_n 1: apply the
 * uniform masks at every anchor with indices taken modulo n (weights of a
 * stencil wider than n wrap more than once).
 * @return the rule, or NULL if that combination does not exist.
 * Calling context: any (pure table lookup).
 */
const struct ref_limit_rule *ref_limit_rule_get(unsigned scheme, unsigned degree, unsigned closed, unsigned ends);

/**
 * Masks for a short open polygon, n < rule->min_n. Slots 0..A-1 (A = the
 * anchor count: n vertices, or n-1 edges for even D; but A = n when n <= 2,
 * where the polygon's end points are the outputs) are output positions in
 * polygon order; call for every slot and emit the non-NULL ones in order.
 * first is relative to the slot.
 * @param tangent 0: position mask, 1: tangent mask (len 0: zero tangent)
 * @return the mask, or NULL: slot dropped / not derived.
 * Calling context: any (pure table lookup).
 */
const struct ref_mask *ref_limit_small_get(unsigned scheme, unsigned degree, unsigned ends, unsigned n, unsigned anchor, unsigned tangent);

#endif
