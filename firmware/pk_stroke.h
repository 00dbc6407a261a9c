/*
 * pk_stroke.h — stroke assembler: consecutive feed moves -> the points of the
 * path the machine executes (the smoothing policy; the "why" is at the top of
 * pk_stroke.c).
 *
 * A stroke is a run of feed moves at one feed rate, from the machine's planned
 * position. Its vertices go in with pk_stroke_add; the points of the executed
 * path come out of pk_stroke_pull, one at a time, only while the motion queue
 * has room (everything is pull-based: a full queue just pauses the stroke).
 *
 *   OFF        vertices pass through unchanged (exact path, G61).
 *   FIXED      the refinement kernel with the configured scheme, degree and
 *              depth over the vertices; corners turning by more than
 *              sharp_turn_deg split the stroke (kept sharp); refined points
 *              within PK_STROKE_FIXED_DEC_UM of a chord are merged. No
 *              promise about the distance to the programmed path.
 *   TOLERANCE  G64 P<T>: the executed path stays within T of the programmed
 *              polyline (plus the kernel's rounding, 2 µm, inside T) and, at
 *              chord vertices of flattened curves, within T of the curve. A
 *              control polygon is built on the programmed path: each corner
 *              gets a blend whose size follows from T and the corner's angle
 *              (a long straight leg stays straight; only a neighbourhood of
 *              the corner is blended), the Chaikin kernel (quadratic B-spline,
 *              clamped ends) refines it, and a decimator keeps the fewest
 *              points within T/4 of the refined polygon. Decisions depend on
 *              the vertices only (two vertices of look-ahead), never on when
 *              they arrive.
 *
 * Calling context: MAIN only. No heap; the kernel state lives inside.
 */
#ifndef PLOTKIN_PK_STROKE_H
#define PLOTKIN_PK_STROKE_H

#include <stdbool.h>
#include <stdint.h>
#include "pk_refine.h"
#include "pk_planner.h"

/** Refinement depth of the tolerance mode (smoothness of the blends only: any
 *  depth keeps the tolerance; 3 puts the polygon within E/64 of its curve). */
#ifndef PK_STROKE_TOL_DEPTH
#define PK_STROKE_TOL_DEPTH 3
#endif
#if PK_STROKE_TOL_DEPTH < 1 || PK_STROKE_TOL_DEPTH > PK_MAX_DEPTH
#error "PK_STROKE_TOL_DEPTH must be 1..PK_MAX_DEPTH"
#endif

/** 1: the FIXED mode is built in (default); 0: pk_stroke_check refuses it
 *  (-2, not built into this firmware), for images short of flash that
 *  smooth in the tolerance mode only. */
#ifndef PK_STROKE_FIXED
#define PK_STROKE_FIXED 1
#endif

/** FIXED mode: refined points within this many µm of a chord through their
 *  neighbours are merged into it (nearly collinear points make blocks of a
 *  few steps, whose step-rounded directions would only slow the machine). */
#define PK_STROKE_FIXED_DEC_UM 2

/** Rounding allowance inside the tolerance, µm: control points and kernel
 *  outputs are whole micrometres (each within sqrt(3)/2 µm of exact). */
#define PK_STROKE_ROUND_UM 2

/* Smoothing policy type, shared with pk_motion.h. */
struct pk_smooth_cfg;

/** Observer events (pk_stroke.observe): what the stroke hands to the kernel,
 *  for tools that draw or measure the smoothed curve. */
enum pk_stroke_event {
    PK_STROKE_EV_BEGIN = 0, /**< a kernel stroke starts; p = its first control point */
    PK_STROKE_EV_CTRL = 1,  /**< next control point pushed into the kernel */
    PK_STROKE_EV_END = 2    /**< the kernel stroke ended (p = its last control point) */
};
/** Observer callback (MAIN, called synchronously; must not call back into the
 *  machine). The scheme of the stroke is in pk_stroke.k.cfg. */
typedef void (*pk_stroke_observer)(void *ctx, uint8_t event, const pk_um_t p[PK_AXES]);

struct pk_stroke {
    struct pk_refine k;        /**< the kernel stream */
    uint8_t mode;              /**< enum pk_smooth_mode */
    uint8_t scheme, degree, fixed_depth;
    uint8_t axes;              /**< axes compared and smoothed (2..PK_AXES) */
    pk_um_t tol_um;            /**< TOLERANCE: T */
    pk_q30_t cos_sharp;        /**< a corner with cos(turn) below this stays sharp (Q1.30) */
    bool open;                 /**< a stroke is in progress */
    bool finishing;            /**< finish requested, draining */
    bool kernel_end;           /**< the kernel said PK_END: flushing */
    pk_um_t prev[PK_AXES];     /**< last vertex accepted */

    /* ---- OFF / FIXED ---- */
    bool have_out;             /**< OFF: out[] waits to be pulled */
    pk_um_t out[PK_AXES];
#if PK_STROKE_FIXED
    bool split_pending;        /**< FIXED: restart at prev2 with pend[] once drained */
    bool have_pend;            /**< pend[] waits to be pushed */
    uint32_t n_in;             /**< FIXED: vertices of the current kernel stroke */
    pk_um_t prev2[PK_AXES];
    pk_um_t pend[PK_AXES];
#endif

    /* ---- TOLERANCE: vertex look-ahead ---- */
    uint8_t nv;                /**< vertices held (1..3): v[0] is emitted up to itself */
    pk_um_t v[3][PK_AXES];
    pk_um_t err_in[3];         /**< chord error of the move arriving at v[i] */
    uint32_t cap[3];           /**< blend half-length capacity at v[i], µm (see pk_stroke.c) */
    uint32_t leg_q8[2];        /**< |v[i+1] - v[i]|, µm Q8, where leg_have bit i says so */
    pk_q30_t leg_u[2][PK_AXES]; /**< its unit vector, Q1.30, where leg_have bit i + 2 */
    uint8_t leg_have;          /**< which of the two legs' figures are known (pk_stroke.c
                                    "Legs") */
    uint8_t nq, q_head;        /**< control points queued for the kernel */
    pk_um_t q[4][PK_AXES];
    uint8_t q_corner;          /**< bit i: q[i] is the second copy of a corner kept sharp */
    uint8_t ncorner;           /**< vertices kept sharp, not yet out of the kernel */
    pk_um_t corner[3][PK_AXES];
    uint8_t by;                /**< straight run between sharp vertices (pk_stroke.c
                                    "Straight runs"): 0 the kernel runs, 1 it is
                                    finishing at the run's first vertex, 2 the run's
                                    vertices go out without it */
    bool by_restart;           /**< by == 2: restart the kernel at the anchor before
                                    the queued points (the run has ended) */
    bool by_again;             /**< restarted: the anchor's second copy is still to
                                    be pushed (the kernel takes one point at a time) */

    /* ---- cone decimator (XY; a change of Z ends a chord) ---- */
    bool have_anchor, have_cand, cone_full, cone_empty;
    pk_um_t anchor[PK_AXES];
    pk_um_t cand[PK_AXES];     /**< the chord's current far end */
    uint32_t cand_r_q8;        /**< |cand - anchor|, µm Q8 */
    int32_t cone_r[2], cone_l[2]; /**< right/left boundary directions, Q1.30 */
    uint8_t emit_n;            /**< points ready to return (0..2) */
    pk_um_t emit[2][PK_AXES];
    uint8_t emit_sharp[2];     /**< ... and whether each is a corner */
    bool out_sharp;            /**< the point pk_stroke_pull returned last is a corner
                                    of the executed path (a vertex kept sharp, a
                                    stroke's end, every vertex in OFF mode): the
                                    junction there is a programmed corner */

    struct pk_planner_dyn dyn; /**< TOLERANCE: the planner's junction model, to keep
                                    a corner sharp where its kink is faster than
                                    its blend (never slower than G61) */
    pk_stroke_observer observe; /**< NULL, or called for every control point */
    void *observe_ctx;
    uint8_t pull_budget;       /**< refined points one pull may consume before it
                                    yields (0: no limit; pk_stroke_set_pull_budget) */
};

/** pk_stroke_pull: the pull budget ran out before a point came out (pull
 *  again: the stroke resumes where it stopped). Only with a budget set. */
#define PK_STROKE_YIELD 3

/**
 * Initialise with a smoothing policy (validated by the caller: see
 * pk_stroke_check) for `axes` axes (2..PK_AXES). No stroke open.
 */
void pk_stroke_init(struct pk_stroke *st, const struct pk_smooth_cfg *s, uint8_t axes);

/** The planner's junction model (pk_planner_dyn), so that the tolerance mode
 *  blends a corner only where the blend is faster than the kink the exact
 *  path would take there. Zeroed by init (then every corner is blended). */
void pk_stroke_set_dyn(struct pk_stroke *st, const struct pk_planner_dyn *d);

/** Let one pk_stroke_pull consume at most n refined points of the kernel
 *  without a point coming out, then return PK_STROKE_YIELD (0: no limit, the
 *  default), so that a caller with other work due (the chunk preparation of
 *  an 8-bit board: one point of the path can cost the decimator 30 refined
 *  points) gets control back. The path is the same either way. */
void pk_stroke_set_pull_budget(struct pk_stroke *st, uint8_t n);

/** Validate a smoothing policy (and that this build's kernel can run it).
 *  @return 0 if valid, -1 if a value is out of range, -2 if the scheme is
 *  not built into this firmware (see pk_refine.h). */
int pk_stroke_check(const struct pk_smooth_cfg *s);

/** Replace the policy; only when no stroke is open. @return 0, or -1 if open. */
int pk_stroke_set(struct pk_stroke *st, const struct pk_smooth_cfg *s);

/** True while a stroke is open (begun and not fully pulled). */
bool pk_stroke_is_open(const struct pk_stroke *st);

/**
 * Open a stroke at start (the machine's planned position).
 * @return 0, or -1 if a stroke is already open.
 */
int pk_stroke_begin(struct pk_stroke *st, const pk_um_t start[PK_AXES]);

/**
 * Add the next vertex, reached by a move whose programmed geometry is within
 * chord_err_um of the straight segment (0 for a programmed line; the chord
 * error of a flattened arc or Bézier otherwise).
 * @retval PK_OK     accepted (a zero-length move is accepted and ignored)
 * @retval PK_EBUSY  the look-ahead is full: pull first
 * @retval PK_ESTATE no stroke open, or it is finishing
 */
int pk_stroke_add(struct pk_stroke *st, const pk_um_t p[PK_AXES], pk_um_t chord_err_um);

/** End the current stroke (idempotent). */
void pk_stroke_finish(struct pk_stroke *st);

/**
 * Next point of the executed path.
 * @retval PK_OK          *out is the next point
 * @retval PK_NEED_INPUT  add a vertex or finish
 * @retval PK_END         the stroke is complete and closed (no stroke open)
 * @retval PK_STROKE_YIELD the pull budget ran out (pk_stroke_set_pull_budget):
 *                        pull again
 * Negative: a kernel error (the stroke is dropped and closed).
 */
int pk_stroke_pull(struct pk_stroke *st, pk_um_t out[PK_AXES]);

/** Drop the stroke (reset). */
void pk_stroke_reset(struct pk_stroke *st);

/** TOLERANCE: the blend budget E (µm) at a vertex whose adjacent moves spent
 *  chord_err_um: T - T/4 (decimator) - PK_STROKE_ROUND_UM - chord_err_um,
 *  at least 0 (0: the vertex stays sharp). Exposed for tests. */
int32_t pk_stroke_blend_budget(pk_um_t tol_um, pk_um_t chord_err_um);

#endif
