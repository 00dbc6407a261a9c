/*
 * ref_refine.h — plotkin's streaming subdivision kernel (public contract).
 *
 * Smooths a stream of 2- or 3-axis points by subdivision, in fixed point, in
 * caller-owned state of a size fixed at compile time that grows with the depth
 * only, never with the number of points. No heap, no float, no globals: one
 * struct ref_refine is one independent stream.
 *
 * Schemes (each open or closed, depth 0..REF_MAX_DEPTH):
 *   B-spline of degree D = 1..7 (Lane-Riesenfeld: split, then average D times).
 *     D = 2 is Chaikin's corner cutting, D = 3 the cubic B-spline.
 *   DLG: the Dyn-Levin-Gregory 4-point interpolating scheme.
 * Open-curve end rules: REF_ENDS_CLAMPED (knot insertion of the clamped
 * B-spline, interpolating both ends; D = 1, 2, 3; the default where it
 * exists), REF_ENDS_REPLACE (plain rule, first/last point replaced by the
 * stroke's ends; the default for D >= 4), REF_ENDS_NONE (plain rule; the curve
 * shrinks). DLG uses ghost points and ignores the end rule.
 *
 * Streaming protocol (pull-based):
 *
 *     ref_refine_init(&r, &cfg);
 *     for each input point p:
 *         while (ref_refine_push(&r, p) == REF_EBUSY)   // only if you stopped pulling
 *             ...pull...
 *         while (ref_refine_pull(&r, &out) == REF_OK)   // stop any time the consumer is full
 *             consume(out);
 *     ref_refine_finish(&r);
 *     while (ref_refine_pull(&r, &out) == REF_OK) consume(out);   // ... until REF_END
 *
 * The kernel never blocks and never needs the whole polyline. A push only
 * stores the point; the work happens lazily inside pull, one output point per
 * call, so a consumer that stops pulling (a full motion queue) simply pauses
 * the kernel, which resumes exactly where it stopped. After REF_END the same
 * struct takes the next stroke with the same configuration.
 *
 * Exactness: see ref_refine.c for the full argument. In short, points are
 * carried in ref_w8_t (8 guard bits below the micrometre) and every mask sum is
 * formed exactly and rounded once per level at 1/256 µm, then once more to
 * whole micrometres on output. Every output is within 0.5 + depth/512 LSB of
 * the exact rational result for the B-splines and 0.5 + (1.25^depth - 1)/128
 * LSB for DLG (tests/test_vectors.c checks exactly these bounds);
 * rounding is ties-away-from-zero, so mirroring the input about an axis
 * mirrors the output exactly and reversing it reverses the output exactly.
 */
#ifndef PLOTKIN_REF_REFINE_H
#define PLOTKIN_REF_REFINE_H

#include <stdint.h>
#include "ref_fixed.h"

/** Axes stored per point (compile-time; 2 halves the state of XY-only builds). */
#ifndef REF_AXES
#define REF_AXES 3
#endif
/** Deepest refinement supported. */
#ifndef REF_MAX_DEPTH
#define REF_MAX_DEPTH 8
#endif
/** Points of history kept per level: 2 is enough for Chaikin (any end rule),
 *  4 for the cubic and DLG, 5 for every degree up to 7. */
#ifndef REF_WIN
#define REF_WIN 5
#endif
/** Points kept by the limit/tangent stage (one per stream, not per level). */
#ifndef REF_LWIN
#define REF_LWIN 8
#endif
/** First points remembered to close a closed curve (D for B-splines, 5 for DLG). */
#ifndef REF_CLOSE_MAX
#define REF_CLOSE_MAX 7
#endif

#if REF_AXES < 2 || REF_AXES > 3
#error "REF_AXES must be 2 or 3"
#endif
#if REF_WIN < 2 || REF_WIN > 8 || REF_MAX_DEPTH < 0 || REF_MAX_DEPTH > 8
#error "REF_WIN must be 2..8 and REF_MAX_DEPTH 0..8"
#endif

/** Status codes. Non-negative values are normal outcomes, negative are errors. */
enum ref_status {
    REF_OK = 0,          /**< done / a point was written */
    REF_NEED_INPUT = 1,  /**< pull: push another point or finish the stroke */
    REF_END = 2,         /**< pull: the stroke is complete; ready for the next */
    REF_EBUSY = -1,      /**< push: the previous point is not consumed yet; pull first */
    REF_ERANGE = -2,     /**< push: a coordinate is outside ±REF_UM_MAX; nothing changed */
    REF_EINVAL = -3,     /**< init: bad configuration value */
    REF_ENOTSUP = -4,    /**< init: combination not built in (see REF_WIN, REF_LWIN) */
    REF_ESTATE = -5,     /**< push after finish, before REF_END */
    REF_ETOOLONG = -6    /**< push: a closed stroke longer than REF_CLOSED_MAX_POINTS */
};

enum ref_scheme { REF_SCHEME_BSPLINE = 0, REF_SCHEME_DLG = 1 };
enum ref_ends { REF_ENDS_DEFAULT = 0, REF_ENDS_CLAMPED, REF_ENDS_REPLACE, REF_ENDS_NONE };

/** Closed strokes count their points; this many keeps 2^depth * m in 32 bits. */
#define REF_CLOSED_MAX_POINTS ((uint32_t)1 << 23)

/** Configuration of one stream. Zero-initialise, then set what you need. */
struct ref_refine_cfg {
    uint8_t scheme;   /**< enum ref_scheme */
    uint8_t degree;   /**< B-spline degree 1..7 (2 = Chaikin); ignored for DLG */
    uint8_t depth;    /**< levels of refinement, 0..REF_MAX_DEPTH */
    uint8_t closed;   /**< 1: the stroke is a closed polygon (last point joins the first) */
    uint8_t ends;     /**< enum ref_ends, open strokes only */
    uint8_t limit;    /**< 1: push the output points onto the limit curve */
    uint8_t tangents; /**< 1: also give the unit tangent of the limit curve (implies limit) */
    uint8_t dims;     /**< 2 or 3 (<= REF_AXES); 0 means REF_AXES */
};

/** One output point. t is valid only with cfg.tangents (else zero). */
struct ref_refine_out {
    ref_um_t p[REF_AXES];   /**< position, µm */
    ref_q30_t t[REF_AXES];  /**< unit tangent, Q1.30; all zero where undefined */
};

/** Per-level state (private; exposed only so that callers can own the storage). */
struct ref_level {
    ref_w8_t w[REF_WIN][REF_AXES]; /**< the last inputs, w[0] oldest */
    uint8_t n;      /**< inputs seen, saturating at 255 (only "how many so far" matters) */
    uint8_t pend;   /**< outputs ready to emit */
    uint8_t ph;     /**< which output of the current batch comes next */
    uint8_t st;     /**< REF_LV_* state bits */
};

/** The limit/tangent stage (private). */
struct ref_limit_stage {
    ref_w8_t w[REF_LWIN][REF_AXES]; /**< the last inputs, w[REF_LWIN-1] newest */
    uint8_t n;      /**< inputs seen, saturating at 255 */
    int8_t lag;     /**< newest input index minus the next anchor's index */
    uint8_t a;      /**< index of the next anchor, saturating at 255 */
    uint8_t st;     /**< LV_FIN when finished */
};

/** One stream. Caller-owned; its size is fixed at compile time. */
struct ref_refine {
    struct ref_refine_cfg cfg;
    uint8_t D;             /**< effective degree (DLG: 0) */
    uint8_t ends;          /**< effective end rule */
    uint8_t nlev;          /**< stages in use: depth (+1 with limit) */
    uint8_t in_full;       /**< the input slot holds a point */
    uint8_t finishing;     /**< finish() was called */
    uint8_t close_c;       /**< closed: first points to replay */
    uint8_t close_i;       /**< closed: replay position */
    uint8_t kind;          /**< what every level does (derived from cfg at init) */
    uint8_t win;           /**< window points this scheme uses (<= REF_WIN) */
    uint8_t lim_thr;       /**< limit stage: lag at which the front anchor is released */
    uint8_t pad_[2];
    uint32_t m;            /**< points pushed in this stroke (closed: bounded) */
    uint32_t out_done;     /**< points delivered in this stroke (closed only needs it) */
    uint32_t out_left;     /**< closed: outputs still to give (2^depth * m), else UINT32_MAX */
    const void *lim_rule;  /**< limit stage: its mask table (ref_masks.h) */
    ref_w8_t in[REF_AXES];   /**< the input slot */
    ref_w8_t first[REF_CLOSE_MAX][REF_AXES]; /**< closed: the stroke's first points */
    struct ref_level lv[REF_MAX_DEPTH];
    struct ref_limit_stage lim;
};

/**
 * Initialise a stream.
 * @retval REF_OK       ready for the first point
 * @retval REF_EINVAL   degree, depth, dims or an enum is out of range
 * @retval REF_ENOTSUP  the scheme needs more history than REF_WIN/REF_LWIN/
 *                     REF_CLOSE_MAX were built with, or an end rule that does
 *                     not exist for that degree (clamped needs D <= 3)
 * Calling context: any; no side effects beyond *r.
 */
int ref_refine_init(struct ref_refine *r, const struct ref_refine_cfg *cfg);

/**
 * Offer the next input point (µm, each |coordinate| <= REF_UM_MAX; axes beyond
 * cfg.dims are ignored). Only stores it: the work happens in ref_refine_pull.
 * @retval REF_OK       accepted
 * @retval REF_EBUSY    the previous point is still waiting: pull until
 *                     REF_NEED_INPUT, then push again (nothing was lost)
 * @retval REF_ERANGE   a coordinate is out of range; the stream is unchanged
 * @retval REF_ESTATE   the stroke is finishing; pull until REF_END first
 * @retval REF_ETOOLONG closed stroke with more than REF_CLOSED_MAX_POINTS points
 * The checks come in the order listed (REF_ESTATE, then REF_EBUSY, then
 * REF_ERANGE): a bad point offered while the slot is busy gets REF_EBUSY
 * first. Every non-REF_OK answer leaves the stream unchanged.
 */
int ref_refine_push(struct ref_refine *r, const ref_um_t p[REF_AXES]);

/**
 * End the stroke: the remaining outputs (the curve's tail, the closing span of
 * a closed curve) become available to pull. Idempotent until REF_END.
 */
void ref_refine_finish(struct ref_refine *r);

/**
 * Take the next refined point.
 * @retval REF_OK          *out holds the next point
 * @retval REF_NEED_INPUT  nothing more until the next push (or finish)
 * @retval REF_END         the finished stroke is fully delivered; the stream
 *                        is reset and takes a new stroke
 * A point once returned is never returned again; stopping here loses nothing.
 */
int ref_refine_pull(struct ref_refine *r, struct ref_refine_out *out);

/** Drop the current stroke (e.g. on a soft reset); keeps the configuration. */
void ref_refine_reset(struct ref_refine *r);

/**
 * Upper bound on the points ref_refine_pull can deliver between one
 * REF_NEED_INPUT (or the start) and the next. After a push it is exactly
 * 2^depth in steady state (plus, with limit/tangents, one burst of at most
 * REF_LWIN once per stroke, when an open polygon first has enough points to
 * tell its ends); after ref_refine_finish it is at most 4 * 2^depth for open
 * strokes and (REF_CLOSE_MAX + 1) * 2^depth for closed ones (plus the same
 * REF_LWIN with limit). This returns the larger, so a consumer with this much
 * room never has to stop mid-stroke (stopping anyway is always safe).
 */
uint32_t ref_refine_max_release(const struct ref_refine_cfg *cfg);

/** Bytes of state one stream uses (sizeof(struct ref_refine)). */
#define REF_REFINE_STATE_BYTES ((uint32_t)sizeof(struct ref_refine))

#endif
