/*
 * sim_bound.h — a lower bound on the motion time of a program, for the
 * corpus benchmark's "how far from optimal" column (host only).
 *
 * The question the bound answers: how fast could ANY machine with these axis
 * limits run a path that stays within the tolerance P of the programmed path?
 * plotkin's time divided by the bound says how much a better planner could
 * still gain; it is never below 1 for a correct planner and bound.
 *
 * Model (each step only loosens a constraint, so the result stays a lower
 * bound of the model's optimum):
 *  - The path is the programmed one: lines as they are, arcs and G5 curves
 *    flattened into chords within 0.5 µm (their curvature then limits the
 *    speed through the window rule below, as a real curve does).
 *  - Each segment: speed <= its feed (rapids: no feed) and <= every axis's
 *    max rate divided by that axis's share of the direction; tangential
 *    acceleration <= every axis's limit divided by its share.
 *  - Each vertex, turning by phi, P > 0 (tolerance mode): the least of
 *    - the tube circle: where both legs are long enough to hold the path
 *      (each reaches the circle's tangent point, r tan(phi/2) from the
 *      vertex), the path near it may use the whole tube of radius P around
 *      both legs, so the widest circle that turns by phi inside it
 *      (out-in-out: tangent to the outer edges, through the inner corner)
 *      has radius r = 2P / (1 - cos(phi/2)); speed <= sqrt(A_c r), A_c the
 *      centripetal limit in the direction of the velocity change (per axis
 *      as above), at the vertex (the model's assumption for a corner with
 *      such legs: the path follows the legs up to the turn, and the turn's
 *      slowest point is at the vertex). Shorter legs do not confine the turn (a zigzag or a
 *      sampled curve inside the tube may be run straight or smooth), so
 *      there the rule says nothing: confining the turn to half of either leg
 *      made the bound exceed plotkin's own time on finely sampled paths.
 *    - the window rule, for curves drawn in short segments: take the points
 *      a and c of the programmed path at arc distances h1, h2 (h = 4P, 8P,
 *      16P, ..., clipped to the piece; P the piece's largest tolerance) before
 *      and after the vertex b. The path passes within P of a, b, c, so its chords A'B', B'C' turn by at
 *      least theta = angle(ab, bc) - asin(2P/|ab|) - asin(2P/|bc|). A stretch
 *      of length l with curvature <= k has its chord within k l / 2 of its
 *      end tangent (k l <= pi/2), so somewhere between A' and C' the path's
 *      curvature is >= min(2 theta / (l1 + l2), pi / (2 l_max)), l = h + 2P
 *      (path lengths: the programmed ones, as for the time). There the speed
 *      is <= sqrt(A r), r its inverse, and b is at most l_max away, so
 *      v_b^2 <= A r + 2 A l_max, A = |(A_x, A_y, A_z)| the largest
 *      acceleration in any direction (the normal there is not known). Loose
 *      (on a circle of 20 mm at P = 0.01 mm about 1.2x the speed of
 *      sqrt(A_c R)) but a relaxation.
 *    P = 0 (exact mode): Grbl's junction rule with $11 instead,
 *    v^2 <= A_c d cos(phi/2) / (1 - cos(phi/2)) (Grbl's model of a corner,
 *    not a relaxation of the tolerance rules: the exact-mode bound can be
 *    above the tolerance-mode one or below it).
 *  - Tangential and centripetal limits are applied separately (their sum
 *    may exceed an axis's limit): looser than any real planner.
 *  - Stops: at the start and end, where the path jumps, and where the tool
 *    (pen) switches (plus $205 pen settle there, except in laser mode, where
 *    the laser switches without stopping). Dwells (G4), the time before the
 *    first move and pauses are NOT counted: compare on programs without them,
 *    or read the ratio as an upper bound on what a planner could gain.
 * Speeds at the vertices then come from a forward and a backward pass
 * (v^2 grows by at most 2 A L along a segment), each segment's time from its
 * trapezoid or triangle.
 *
 * Memory: the vertices of the piece being collected (72 bytes each) until the
 * next stop (the corner caps are computed then, the window rule needs both
 * sides); a program drawn in one pen-down piece holds all of its vertices.
 */
#ifndef PK_SIM_BOUND_H
#define PK_SIM_BOUND_H

#include <stddef.h>
#include <stdint.h>
#include "sim_path.h"

struct pk_bound_cfg {
    unsigned axes;           /**< axes (2 or 3) */
    double vmax_mm_s[3];     /**< per-axis max rate, mm/s */
    double acc_mm_s2[3];     /**< per-axis acceleration, mm/s^2 */
    double junction_mm;      /**< $11, used when the tolerance is 0 */
    double settle_s;         /**< pen settle at each tool switch (0 in laser mode) */
    int tool_stops;          /**< 1: a tool switch stops the motion */
};

struct pk_bound_vtx {
    double p[3];             /* mm */
    double cap2;             /* speed cap at this vertex, (mm/s)^2 */
    double f2;               /* speed cap of the segment ending here, (mm/s)^2 */
    double acc;              /* tangential limit of that segment, mm/s^2 */
    double len;              /* its length, mm */
    double s;                /* arc position in the piece, mm */
    double tol;              /* tolerance of that segment, mm */
};

struct pk_bound {
    struct pk_bound_cfg cfg;
    struct pk_bound_vtx *v;  /* the piece being collected */
    size_t n, cap;
    double tol_mm;           /* tolerance of the vertex being added */
    double acc_norm;         /* the largest acceleration in any direction, |(A_x, A_y, A_z)|, mm/s^2 */
    double time_s;           /**< bound for what was flushed so far, s */
    uint64_t vertices;       /**< vertices seen */
    int tool;                /* tool state of the last primitive (-1: none yet) */
    int oom;                 /**< 1: out of memory (the bound is then invalid) */
};

/** Start a bound. */
void pk_bound_init(struct pk_bound *b, const struct pk_bound_cfg *cfg);

/**
 * One programmed primitive (µm, sim_path.h), in program order: feed_mm_s its
 * feed (0 or less for a rapid: the axes' max rates), tol_mm the tolerance in
 * force for it (0: exact path), tool_on the tool state while it runs.
 */
void pk_bound_prim(struct pk_bound *b, const struct pk_path_prim *p, double feed_mm_s, double tol_mm,
                   int tool_on);

/** End: the last piece stops. Returns the bound in seconds, or -1 if out of memory. */
double pk_bound_finish(struct pk_bound *b);

void pk_bound_free(struct pk_bound *b);

/* The pieces, for tests: the time of one straight move of length L (mm)
 * from v0 to v1 (mm/s) at most vmax with acceleration acc; and the tube
 * circle's radius for a turn phi (radians), tolerance P, legs L1 and L2
 * (INFINITY where a leg does not reach its tangent point: no limit). */
double pk_bound_trapezoid_s(double len, double v0, double v1, double vmax, double acc);
double pk_bound_corner_radius_mm(double phi, double tol_mm, double l1, double l2);

#endif
