/*
 * pk_stroke.h — stroke assembler: consecutive feed moves -> smoothed points.
 *
 * A stroke is a run of feed moves at one feed rate. Its vertices are pushed
 * through the refinement kernel (pk_refine.h) according to the smoothing
 * policy, and the refined points are pulled out one at a time by the machine
 * (only while the motion queue has room: the kernel is pull-based, so a full
 * queue just pauses it).
 *
 *   OFF        vertices pass through unchanged (exact path, G61).
 *   FIXED      kernel with the configured scheme, degree and depth.
 *   TOLERANCE  B-spline (degree 2 or 3), depth chosen per stroke, then a
 *              greedy decimator that merges consecutive refined points into
 *              one segment while every merged point stays within T/2 of it.
 *              Why that keeps the path within T of the limit curve:
 *
 *   Let P be the stroke's control polygon and M = max |P[i-1] - 2P[i] + P[i+1]|
 *   (second differences, µm). Lane-Riesenfeld refinement of degree 2 or 3
 *   divides the second differences by 4 per level (e.g. cubic: the new
 *   differences are D2/4 and (D2[i] + D2[i+1])/8), so the level-k polygon Q
 *   has |D2 Q| <= M / 4^k. Away from the ends the uniform B-spline stays
 *   close to its control polygon: quadratic within |D2 Q|/8 (edge midpoints
 *   lie on the curve, the vertex is |D2 Q|/8 from it), cubic within about
 *   |D2 Q|/6 (a vertex is |D2 Q|/6 from its limit point
 *   (Q[i-1] + 4Q[i] + Q[i+1])/6). Near a clamped end the knots are not uniform
 *   and the constant is larger: tests/test_motion_stroke.c measures up to
 *   0.48 M/4^k there (cubic), which is why the rule uses 1/2:
 *
 *       dist(level-k polygon, limit curve) <= M / (2 * 4^k)
 *
 *   (checked per level, both directions, on several shapes in the tests; a
 *   proof for the clamped ends is not given). The depth is the smallest k
 *   with M / (2 * 4^k) <= T/2, i.e. M <= T * 4^k. The decimator adds at most
 *   T/2: distance to a segment is convex, so if both ends of a polygon edge
 *   are within T/2 of the merged segment, so is the edge, and every point of
 *   the segment is within T/2 of the polygon piece that projects onto it.
 *   Total: within T (plus the kernel's rounding to whole µm, < 1 µm).
 *   M is taken over the moves visible when the stroke starts (the caller's
 *   hint, at least the capacity of depth 2); a later vertex whose second
 *   difference exceeds what the depth covers splits the stroke there, as does
 *   a corner turning by more than sharp_turn_deg (kept sharp). The
 *   decimator holds at most PK_STROKE_DEC points, so a straight run longer
 *   than that is cut into pieces of PK_STROKE_DEC refined points.
 *   (With limit masks for open strokes in the kernel, points on the curve
 *   would tighten this; the kernel on main has them for closed curves only.)
 *
 * Calling context: MAIN only. No heap; the kernel state lives inside.
 */
#ifndef PLOTKIN_PK_STROKE_H
#define PLOTKIN_PK_STROKE_H

#include <stdbool.h>
#include <stdint.h>
#include "pk_refine.h"

/** Limit points the decimator may hold back (bounds its latency and work). */
#ifndef PK_STROKE_DEC
#define PK_STROKE_DEC 64
#endif

/* Smoothing policy type, shared with pk_motion.h. */
struct pk_smooth_cfg;

struct pk_stroke {
    struct pk_refine k;        /**< the kernel stream */
    uint8_t mode;              /**< enum pk_smooth_mode */
    uint8_t scheme, degree, fixed_depth;
    pk_um_t tol_um;
    pk_q30_t cos_sharp;        /**< split when cos(turn) < this (Q1.30) */
    uint8_t depth;             /**< depth of the current stroke */
    bool open;                 /**< a stroke is in progress */
    bool finishing;            /**< finish requested, draining */
    bool split_pending;        /**< restart at prev[] with pend[] once drained */
    bool have_pend;            /**< pend[] waits to be pushed */
    bool have_out;             /**< OFF mode: out[] waits to be pulled */
    uint32_t n_in;             /**< vertices of the current stroke */
    uint64_t d2_cap;           /**< TOLERANCE: largest |second difference|^2 the depth covers */
    pk_um_t prev2[PK_AXES], prev[PK_AXES]; /**< last two vertices */
    pk_um_t pend[PK_AXES];     /**< vertex not yet accepted by the kernel */
    pk_um_t out[PK_AXES];      /**< OFF mode pass-through slot */
    /* decimator (TOLERANCE) */
    bool have_anchor;
    pk_um_t anchor[PK_AXES];
    uint8_t ncand;
    pk_um_t cand[PK_STROKE_DEC][PK_AXES];
    uint8_t emit_n;            /**< points ready to return (0..2) */
    pk_um_t emit[2][PK_AXES];
    bool kernel_end;           /**< the kernel said PK_END, decimator flushing */
};

/**
 * Initialise with a smoothing policy (validated by the caller: see
 * pk_stroke_check). No stroke open.
 */
void pk_stroke_init(struct pk_stroke *st, const struct pk_smooth_cfg *s);

/** Validate a smoothing policy. @return 0 if valid, -1 otherwise. */
int pk_stroke_check(const struct pk_smooth_cfg *s);

/** Replace the policy; only when no stroke is open. @return 0, or -1 if open. */
int pk_stroke_set(struct pk_stroke *st, const struct pk_smooth_cfg *s);

/** True while a stroke is open (begun and not fully pulled). */
bool pk_stroke_is_open(const struct pk_stroke *st);

/**
 * Open a stroke at start (the machine's planned position).
 * @param d2_hint  TOLERANCE: the largest |second difference| (µm) among the
 *                 stroke's vertices the caller can see now (0 if unknown)
 * @return 0, or -1 if a stroke is already open.
 */
int pk_stroke_begin(struct pk_stroke *st, const pk_um_t start[PK_AXES], uint32_t d2_hint);

/**
 * Add the next vertex.
 * @retval PK_OK     accepted (possibly held for a split: the stroke ends at
 *                   the previous vertex and a new one starts there)
 * @retval PK_EBUSY  the previous vertex is still waiting: pull first
 * @retval PK_ESTATE no stroke open, or it is finishing
 */
int pk_stroke_add(struct pk_stroke *st, const pk_um_t p[PK_AXES]);

/** End the current stroke (idempotent). */
void pk_stroke_finish(struct pk_stroke *st);

/**
 * Next point of the executed path.
 * @retval PK_OK          *out is the next point
 * @retval PK_NEED_INPUT  add a vertex or finish
 * @retval PK_END         the stroke is complete and closed (no stroke open)
 * Negative: a kernel error (the stroke is dropped and closed).
 */
int pk_stroke_pull(struct pk_stroke *st, pk_um_t out[PK_AXES]);

/** Drop the stroke (reset). */
void pk_stroke_reset(struct pk_stroke *st);

/** TOLERANCE: depth used for a second-difference bound M (µm) and tolerance
 *  T (µm): smallest k with M / (2 * 4^k) <= T/2, capped at PK_MAX_DEPTH.
 *  Exposed for tests. */
uint8_t pk_stroke_depth_for(uint32_t m_um, pk_um_t tol_um);

#endif
