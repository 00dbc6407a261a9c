/*
 * pk_refine.h — plotkin's streaming subdivision kernel (public contract).
 *
 * Smooths a stream of 2- or 3-axis points by subdivision, in fixed point, in
 * caller-owned state of a size fixed at compile time that grows with the depth
 * only, never with the number of points. No heap, no float, no globals: one
 * struct pk_refine is one independent stream.
 *
 * Schemes (each open or closed, depth 0..PK_MAX_DEPTH):
 *   B-spline of degree D = 1..7 (Lane-Riesenfeld: split, then average D times).
 *     D = 2 is Chaikin's corner cutting, D = 3 the cubic B-spline.
 *   DLG: the Dyn-Levin-Gregory 4-point interpolating scheme.
 * Open-curve end rules: PK_ENDS_CLAMPED (knot insertion of the clamped
 * B-spline, interpolating both ends; D = 1, 2, 3; the default where it
 * exists), PK_ENDS_REPLACE (plain rule, first/last point replaced by the
 * stroke's ends; the default for D >= 4), PK_ENDS_NONE (plain rule; the curve
 * shrinks). DLG uses ghost points and ignores the end rule.
 *
 * Streaming protocol (pull-based):
 *
 *     pk_refine_init(&r, &cfg);
 *     for each input point p:
 *         while (pk_refine_push(&r, p) == PK_EBUSY)   // only if you stopped pulling
 *             ...pull...
 *         while (pk_refine_pull(&r, &out) == PK_OK)   // stop any time the consumer is full
 *             consume(out);
 *     pk_refine_finish(&r);
 *     while (pk_refine_pull(&r, &out) == PK_OK) consume(out);   // ... until PK_END
 *
 * The kernel never blocks and never needs the whole polyline. A push only
 * stores the point; the work happens lazily inside pull, one output point per
 * call, so a consumer that stops pulling (a full motion queue) simply pauses
 * the kernel, which resumes exactly where it stopped. After PK_END the same
 * struct takes the next stroke with the same configuration.
 *
 * Exactness: see pk_refine.c for the full argument. In short, points are
 * carried in pk_w8_t (8 guard bits below the micrometre) and every mask sum is
 * formed exactly and rounded once per level at 1/256 µm, then once more to
 * whole micrometres on output. Every output is within 0.5 + depth/512 LSB of
 * the exact rational result for the B-splines and 0.5 + (1.25^depth - 1)/128
 * LSB for DLG (tests/test_vectors.c checks exactly these bounds);
 * rounding is ties-away-from-zero, so mirroring the input about an axis
 * mirrors the output exactly and reversing it reverses the output exactly.
 */
#ifndef PLOTKIN_PK_REFINE_H
#define PLOTKIN_PK_REFINE_H

#include <stdint.h>
#include "pk_fixed.h"

/** Axes stored per point (compile-time; 2 halves the state of XY-only builds). */
#ifndef PK_AXES
#define PK_AXES 3
#endif
/** Deepest refinement supported. */
#ifndef PK_MAX_DEPTH
#define PK_MAX_DEPTH 8
#endif
/** Points of history kept per level: 2 is enough for Chaikin (any end rule),
 *  4 for the cubic and DLG, 5 for every degree up to 7. */
#ifndef PK_WIN
#define PK_WIN 5
#endif
/** Points kept by the limit/tangent stage (one per stream, not per level). */
#ifndef PK_LWIN
#define PK_LWIN 8
#endif
/** First points remembered to close a closed curve (D for B-splines, 5 for DLG). */
#ifndef PK_CLOSE_MAX
#define PK_CLOSE_MAX 7
#endif

#if PK_AXES < 2 || PK_AXES > 3
#error "PK_AXES must be 2 or 3"
#endif
#if PK_WIN < 2 || PK_WIN > 8 || PK_MAX_DEPTH < 0 || PK_MAX_DEPTH > 8
#error "PK_WIN must be 2..8 and PK_MAX_DEPTH 0..8"
#endif

/** Status codes. Non-negative values are normal outcomes, negative are errors. */
enum pk_status {
    PK_OK = 0,          /**< done / a point was written */
    PK_NEED_INPUT = 1,  /**< pull: push another point or finish the stroke */
    PK_END = 2,         /**< pull: the stroke is complete; ready for the next */
    PK_EBUSY = -1,      /**< push: the previous point is not consumed yet; pull first */
    PK_ERANGE = -2,     /**< push: a coordinate is outside ±PK_UM_MAX; nothing changed */
    PK_EINVAL = -3,     /**< init: bad configuration value */
    PK_ENOTSUP = -4,    /**< init: combination not built in (see PK_WIN, PK_LWIN) */
    PK_ESTATE = -5,     /**< push after finish, before PK_END */
    PK_ETOOLONG = -6    /**< push: a closed stroke longer than PK_CLOSED_MAX_POINTS */
};

enum pk_scheme { PK_SCHEME_BSPLINE = 0, PK_SCHEME_DLG = 1 };
enum pk_ends { PK_ENDS_DEFAULT = 0, PK_ENDS_CLAMPED, PK_ENDS_REPLACE, PK_ENDS_NONE };

/** Closed strokes count their points; this many keeps 2^depth * m in 32 bits. */
#define PK_CLOSED_MAX_POINTS ((uint32_t)1 << 23)

/** Configuration of one stream. Zero-initialise, then set what you need. */
struct pk_refine_cfg {
    uint8_t scheme;   /**< enum pk_scheme */
    uint8_t degree;   /**< B-spline degree 1..7 (2 = Chaikin); ignored for DLG */
    uint8_t depth;    /**< levels of refinement, 0..PK_MAX_DEPTH */
    uint8_t closed;   /**< 1: the stroke is a closed polygon (last point joins the first) */
    uint8_t ends;     /**< enum pk_ends, open strokes only */
    uint8_t limit;    /**< 1: push the output points onto the limit curve */
    uint8_t tangents; /**< 1: also give the unit tangent of the limit curve (implies limit) */
    uint8_t dims;     /**< 2 or 3 (<= PK_AXES); 0 means PK_AXES */
};

/** One output point. t is valid only with cfg.tangents (else zero). */
struct pk_refine_out {
    pk_um_t p[PK_AXES];   /**< position, µm */
    pk_q30_t t[PK_AXES];  /**< unit tangent, Q1.30; all zero where undefined */
};

/** Per-level state (private; exposed only so that callers can own the storage). */
struct pk_level {
    pk_w8_t w[PK_WIN][PK_AXES]; /**< the last inputs, w[0] oldest */
    uint8_t n;      /**< inputs seen, saturating at 255 (only "how many so far" matters) */
    uint8_t pend;   /**< outputs ready to emit */
    uint8_t ph;     /**< which output of the current batch comes next */
    uint8_t st;     /**< PK_LV_* state bits */
};

/** The limit/tangent stage (private). */
struct pk_limit_stage {
    pk_w8_t w[PK_LWIN][PK_AXES]; /**< the last inputs, w[PK_LWIN-1] newest */
    uint8_t n;      /**< inputs seen, saturating at 255 */
    int8_t lag;     /**< newest input index minus the next anchor's index */
    uint8_t a;      /**< index of the next anchor, saturating at 255 */
    uint8_t st;     /**< LV_FIN when finished */
};

/** One stream. Caller-owned; its size is fixed at compile time. */
struct pk_refine {
    struct pk_refine_cfg cfg;
    uint8_t D;             /**< effective degree (DLG: 0) */
    uint8_t ends;          /**< effective end rule */
    uint8_t nlev;          /**< stages in use: depth (+1 with limit) */
    uint8_t in_full;       /**< the input slot holds a point */
    uint8_t finishing;     /**< finish() was called */
    uint8_t close_c;       /**< closed: first points to replay */
    uint8_t close_i;       /**< closed: replay position */
    uint8_t kind;          /**< what every level does (derived from cfg at init) */
    uint8_t win;           /**< window points this scheme uses (<= PK_WIN) */
    uint8_t lim_thr;       /**< limit stage: lag at which the front anchor is released */
    uint8_t pad_[2];
    uint32_t m;            /**< points pushed in this stroke (closed: bounded) */
    uint32_t out_done;     /**< points delivered in this stroke (closed only needs it) */
    uint32_t out_left;     /**< closed: outputs still to give (2^depth * m), else UINT32_MAX */
    const void *lim_rule;  /**< limit stage: its mask table (pk_masks.h) */
    pk_w8_t in[PK_AXES];   /**< the input slot */
    pk_w8_t first[PK_CLOSE_MAX][PK_AXES]; /**< closed: the stroke's first points */
    struct pk_level lv[PK_MAX_DEPTH];
    struct pk_limit_stage lim;
};

/**
 * Initialise a stream.
 * @retval PK_OK       ready for the first point
 * @retval PK_EINVAL   degree, depth, dims or an enum is out of range
 * @retval PK_ENOTSUP  the scheme needs more history than PK_WIN/PK_LWIN/
 *                     PK_CLOSE_MAX were built with, or an end rule that does
 *                     not exist for that degree (clamped needs D <= 3)
 * Calling context: any; no side effects beyond *r.
 */
int pk_refine_init(struct pk_refine *r, const struct pk_refine_cfg *cfg);

/**
 * Offer the next input point (µm, each |coordinate| <= PK_UM_MAX; axes beyond
 * cfg.dims are ignored). Only stores it: the work happens in pk_refine_pull.
 * @retval PK_OK       accepted
 * @retval PK_EBUSY    the previous point is still waiting: pull until
 *                     PK_NEED_INPUT, then push again (nothing was lost)
 * @retval PK_ERANGE   a coordinate is out of range; the stream is unchanged
 * @retval PK_ESTATE   the stroke is finishing; pull until PK_END first
 * @retval PK_ETOOLONG closed stroke with more than PK_CLOSED_MAX_POINTS points
 * The checks come in the order listed (PK_ESTATE, then PK_EBUSY, then
 * PK_ERANGE): a bad point offered while the slot is busy gets PK_EBUSY
 * first. Every non-PK_OK answer leaves the stream unchanged.
 */
int pk_refine_push(struct pk_refine *r, const pk_um_t p[PK_AXES]);

/**
 * End the stroke: the remaining outputs (the curve's tail, the closing span of
 * a closed curve) become available to pull. Idempotent until PK_END.
 */
void pk_refine_finish(struct pk_refine *r);

/**
 * Take the next refined point.
 * @retval PK_OK          *out holds the next point
 * @retval PK_NEED_INPUT  nothing more until the next push (or finish)
 * @retval PK_END         the finished stroke is fully delivered; the stream
 *                        is reset and takes a new stroke
 * A point once returned is never returned again; stopping here loses nothing.
 */
int pk_refine_pull(struct pk_refine *r, struct pk_refine_out *out);

/** Drop the current stroke (e.g. on a soft reset); keeps the configuration. */
void pk_refine_reset(struct pk_refine *r);

/**
 * Upper bound on the points pk_refine_pull can deliver between one
 * PK_NEED_INPUT (or the start) and the next. After a push it is exactly
 * 2^depth in steady state (plus, with limit/tangents, one burst of at most
 * PK_LWIN once per stroke, when an open polygon first has enough points to
 * tell its ends); after pk_refine_finish it is at most 4 * 2^depth for open
 * strokes and (PK_CLOSE_MAX + 1) * 2^depth for closed ones (plus the same
 * PK_LWIN with limit). This returns the larger, so a consumer with this much
 * room never has to stop mid-stroke (stopping anyway is always safe).
 */
uint32_t pk_refine_max_release(const struct pk_refine_cfg *cfg);

/** Bytes of state one stream uses (sizeof(struct pk_refine)). */
#define PK_REFINE_STATE_BYTES ((uint32_t)sizeof(struct pk_refine))

#endif
