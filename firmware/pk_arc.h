/*
 * pk_arc.h — circular (and helical) arcs of G2/G3: the centre from Grbl's
 * R form or IJK form with Grbl's validity rules, and the flattening of the arc
 * into chord vertices with an exactly bounded chord error, one vertex at a
 * time, in bounded state and integer arithmetic (no float, no table sized by
 * the arc).
 *
 * The programmed curve. An arc is given by its start S, end E (machine µm),
 * the in-plane centre C (Q8 µm, 1/256 µm, so that an R-form centre is not
 * rounded to whole µm), the plane (axes a0, a1 in Grbl's order: G17 X,Y;
 * G18 Z,X; G19 Y,Z; counter-clockwise = positive rotation from a0 to a1) and
 * the direction. The swept angle is Grbl's: the angle from S-C to E-C in the
 * direction of travel, a full turn when that is within 5e-7 rad of zero
 * (Grbl's ARC_ANGULAR_TRAVEL_EPSILON), so S == E in IJK form is a full
 * circle. The radius goes linearly with the swept angle from r0 = |S-C| to
 * r1 = |E-C| (a circle when they are equal; Grbl lets them differ by its
 * 0.005 mm / 0.1 % rule, and LinuxCNC draws the same spiral); the linear axis
 * (helical motion) goes linearly with the angle from S to E.
 *
 * The flattening. n chords; vertex k at swept angle floor(k*sweep/n) (binary
 * angle, 2^32 per turn) with its radius and linear-axis value interpolated,
 * rounded to whole µm; the last vertex is E exactly. n is the smallest count
 * the bound below allows, up to about 1.5 % more (it uses pi^2 < 10 and
 * 1 - cos x <= x^2/2), and at least one chord per quarter turn. For a chord
 * tolerance T (µm, at least 1):
 *   - every vertex is within PK_ARC_VERTEX_ERR_Q8 (0.85 µm) of the programmed
 *     curve, in the plane: 0.71 µm from rounding to whole µm, the rest from
 *     the CORDIC rotation (30 iterations, rounded shifts; <= 0.1 µm at the
 *     largest radius) and the Q8 centre;
 *   - the exact chord between two exact vertices is within
 *     r1max*(1 - cos(d/2)) + |r1-r0|*d/(4n) of the curve (d the chord angle),
 *     and n is chosen so that this is at most T - 0.85 µm;
 *   - so every chord lies within T of the curve and the curve within T of
 *     the chords.
 * Radii up to 2^22 µm (4194.304 mm). A larger arc of at most a half turn whose
 * bulge from its chord (at most c^2 / 4r) is within the tolerance runs as that
 * one chord; any other is refused (Grbl's error 33, "invalid target").
 *
 * Arithmetic: 32-bit for the per-vertex rotation (CORDIC, Q1.30); 64-bit for
 * the radius product (Q30 * Q8 < 2^61), the set-up (square roots of squared
 * distances < 2^62, one 64/32 division) and the R-form centre.
 *
 * Calling context: any; reentrant; no globals.
 */
#ifndef PLOTKIN_PK_ARC_H
#define PLOTKIN_PK_ARC_H

#include <stdint.h>
#include "pk_fixed.h"
#include "pk_refine.h" /* PK_AXES */

/** Largest radius flattened as an arc: 2^22 µm, in Q8. */
#define PK_ARC_RADIUS_MAX_Q8 ((int64_t)1 << 30)
/** Bound on a vertex's distance from the programmed curve, Q8 µm (0.85 µm). */
#define PK_ARC_VERTEX_ERR_Q8 218
/** Binary angle units of one turn (a swept angle may exceed it by 5e-7 rad). */
#define PK_ARC_TURN ((uint64_t)1 << 32)

/** Status codes (Grbl's error numbers). */
#define PK_ARC_OK 0
#define PK_ARC_E_TARGET 33   /**< radii differ too much, or radius too large */
#define PK_ARC_E_RADIUS 34   /**< R form: |R| smaller than half the chord */

/** A programmed arc (see the file comment). */
struct pk_arc_geom {
    pk_um_t start[PK_AXES];
    pk_um_t end[PK_AXES];
    int32_t centre_q8[2];  /**< centre in (a0, a1), Q8 µm (set by pk_arc_centre_*) */
    uint8_t a0, a1;        /**< plane axes */
    uint8_t al;            /**< linear (helical) axis, or PK_AXES if none */
    uint8_t cw;            /**< 1: G2 (clockwise) */
    uint8_t straight;      /**< radius beyond 2^22 µm, at most a half turn: one chord */
    uint32_t bulge_um;     /**< straight: bound on the arc's distance from the chord */
};

/** Flattening state (caller-owned, about 110 bytes). Members are private. */
struct pk_arc {
    struct pk_arc_geom g;
    int32_t u0[2];       /**< start direction, unit / CORDIC gain, Q30 */
    uint32_t phi;        /**< swept angle of the next vertex, binary */
    uint32_t phi_q, phi_r, phi_acc;
    int32_t rho;         /**< radius of the next vertex, Q8 */
    int32_t rho_q, rho_r, rho_acc;
    int32_t lin;         /**< linear axis of the next vertex, µm */
    int32_t lin_q, lin_r, lin_acc;
    uint32_t k, n;       /**< next vertex index (1..n), chord count */
    uint64_t sweep;      /**< swept angle, binary units */
    int32_t r0_q8, r1_q8;
    uint32_t a_start;    /**< angle of S - C, binary */
};

/**
 * IJK form: g->start, end, a0, a1, al, cw set by the caller; sets the centre
 * start + (i, j) (µm, in the plane) and checks Grbl's rule: the radii to the
 * start and to the end may differ by at most 0.005 mm, or else by at most
 * 0.5 mm and 0.1 % of the start radius.
 * @return PK_ARC_OK, or PK_ARC_E_TARGET (radii differ; radius too large for an
 *         arc of more than a half turn)
 */
int pk_arc_centre_ijk(struct pk_arc_geom *g, int32_t i_um, int32_t j_um);

/**
 * R form (Grbl's construction: the centre on the perpendicular bisector of
 * the chord; R < 0 asks for the arc of more than a half turn). g->start, end,
 * a0, a1, al, cw set by the caller. The caller checks start != end (Grbl's
 * error 33 compares all axes); an empty chord in the plane is error 34 here.
 * @param r_um  R in µm, |r_um| <= 2^30
 * @return PK_ARC_OK, PK_ARC_E_RADIUS (|R| below half the chord, or no chord in
 *         the plane), or PK_ARC_E_TARGET (R < 0 with |R| beyond 2^22 µm)
 */
int pk_arc_centre_r(struct pk_arc_geom *g, int32_t r_um);

/**
 * Plan the flattening of g with chord tolerance tol_um (values below 1 are
 * taken as 1). g is copied into *a.
 * @return PK_ARC_OK, or PK_ARC_E_TARGET (a straight arc bulging more than tol)
 */
int pk_arc_plan(struct pk_arc *a, const struct pk_arc_geom *g, pk_um_t tol_um);

/**
 * Next chord vertex (the start point itself is not emitted): the plane axes
 * on the arc, the linear axis interpolated, other axes as at the start, and
 * the end point exactly for the last one.
 * @return 1 with out[] set, 0 when the arc is complete
 */
int pk_arc_next(struct pk_arc *a, pk_um_t out[PK_AXES]);

/** Chords the plan uses. */
static inline uint32_t pk_arc_chords(const struct pk_arc *a) { return a->n; }

/** Swept angle of a planned arc, binary units (PK_ARC_TURN is one turn). */
static inline uint64_t pk_arc_sweep(const struct pk_arc *a) { return a->sweep; }

/** Radius at the start (Q8 µm) of a planned arc (0 for a straight one). */
static inline int32_t pk_arc_radius_q8(const struct pk_arc *a) { return a->r0_q8; }

/** Length of the planned curve (with the linear axis), µm, rounded up;
 *  for G93 inverse-time feeds. */
uint32_t pk_arc_length_um(const struct pk_arc *a);

/**
 * Smallest and largest coordinate the programmed curve reaches on each axis,
 * µm, rounded outwards; every vertex pk_arc_next emits lies within them (a
 * vertex is within 0.85 µm of the curve, and an integer).
 */
void pk_arc_bounds(const struct pk_arc *a, int32_t lo[PK_AXES], int32_t hi[PK_AXES]);

/**
 * CORDIC primitives, exposed for the tests. pk_arc_rotate rotates v by binary
 * angle phi and multiplies it by the CORDIC gain K = 1.64676 (|v| < 2^30 / K);
 * pk_arc_atan2 is the binary angle of (x, y) in [0, 2^32) (0 for (0, 0)).
 */
void pk_arc_rotate(int32_t v[2], uint32_t phi);
uint32_t pk_arc_atan2(int64_t y, int64_t x);

#endif
