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
 * pk_refine_pull_block does the same for up to N points at a time into the
 * caller's arrays. The kernel never blocks and never needs the whole
 * polyline. A push only stores the point; the work happens lazily inside
 * pull, so a consumer that stops pulling (a full motion queue) simply pauses
 * the kernel, which resumes exactly where it stopped. After PK_END the same
 * struct takes the next stroke with the same configuration.
 *
 * Exactness: see pk_refine.c for the argument. Every output coordinate is
 * the exact rational result of the specified refinement (and limit mask),
 * rounded once to the nearest micrometre, ties away from zero: the error is
 * at most 0.5 LSB. Intermediate values are exact dyadic rationals N / 2^F
 * (pk_umf_t); nothing is rounded before the output. Two exceptions, where N
 * would need more than 63 bits: B-spline degree 6 at depth 8 and degree 7 at
 * depths 7..8 keep 36 and 35 fraction bits in their last levels (error at
 * most 0.5 + 2^-34 LSB), and limit positions of degrees 5..7 drop the
 * fraction bits a mask sum could not hold (at most 0.5 + 2^-26 LSB). All
 * bounds hold over the whole input range (tests/test_vectors.c checks them
 * exactly). Ties-away-from-zero is odd-symmetric, so mirroring the input
 * about an axis mirrors the output exactly and reversing it reverses the
 * output exactly. Unit tangents come from the exact (unrounded) polygon.
 *
 * Builds carry only what they use. The PK_BUILD_* macros below choose the
 * schemes, end rules, closed curves and the limit/tangent stage at compile
 * time; pk_refine_init refuses anything not built with PK_ENOTSUP. Mask
 * tables are linked only for what is built, and a Chaikin-only build needs
 * none: its limit stage is written out (edge midpoints, end points, edge
 * vectors). See the README's kernel section for the build and state tables.
 */
#ifndef PLOTKIN_PK_REFINE_H
#define PLOTKIN_PK_REFINE_H

#include <stdint.h>

#include "pk_refine_build.h"

#include "pk_fixed.h"

/** Points of history kept per cascade level: DLG needs 4, degree D
 *  (D + 1) / 2 + 1, so 5 covers every degree up to 7; pk_refine_init answers
 *  PK_ENOTSUP for a scheme that needs more. Only the cascade (DLG, degrees
 *  >= 4, the replace rule of degrees 2..3) uses it: builds without one (e.g.
 *  Chaikin or the cubic with clamped ends) ignore it. */
#ifndef PK_WIN
#define PK_WIN 5
#endif
/** The limit stage needs mask tables (pk_masks.c) only for schemes other
 *  than Chaikin, whose limit stage is written out. */
#define PK_LIMIT_TABLES (PK_BUILD_LIMIT && (PK_BUILD_DLG || (PK_BUILD_DEGREES & ~0x04) != 0))
/** Points kept by the limit/tangent stage (one per stream): 8 for the
 *  widest table-driven stencils, 3 for Chaikin's. */
#ifndef PK_LWIN
#define PK_LWIN (PK_LIMIT_TABLES ? 8 : 3)
#endif
/** First points remembered to close a closed curve (D for B-splines, 5 for
 *  DLG, more for wide limit stencils). */
#ifndef PK_CLOSE_MAX
#define PK_CLOSE_MAX 7
#endif

#if PK_AXES < 2 || PK_AXES > 3
#error "PK_AXES must be 2 or 3"
#endif
#if PK_WIN < 2 || PK_WIN > 8 || PK_MAX_DEPTH < 0 || PK_MAX_DEPTH > 8
#error "PK_WIN must be 2..8 and PK_MAX_DEPTH 0..8"
#endif
#if (PK_BUILD_DEGREES & ~0xFE) != 0 || (PK_BUILD_ENDS & ~0x0E) != 0
#error "PK_BUILD_DEGREES takes bits 1..7, PK_BUILD_ENDS bits 1..3"
#endif
#if PK_BUILD_DEGREES == 0 && !PK_BUILD_DLG
#error "build at least one scheme"
#endif
#if !PK_BUILD_DLG && !PK_BUILD_CLOSED && PK_BUILD_ENDS == 0x02 && (PK_BUILD_DEGREES & 0x0E) == 0
#error "clamped ends exist for degrees 1..3 only: this build would support nothing"
#endif
#if PK_UMF_BITS == 32 && (PK_HAVE_CASCADE || PK_F_MAX_SPAN > 10)
#error "PK_UMF_BITS=32 needs a build without the cascade and with at most 10 fraction bits"
#endif

/** Status codes. Non-negative values are normal outcomes, negative are errors. */
enum pk_status {
    PK_OK = 0,          /**< done / a point was written */
    PK_NEED_INPUT = 1,  /**< pull: push another point or finish the stroke */
    PK_END = 2,         /**< pull: the stroke is complete; ready for the next */
    PK_EBUSY = -1,      /**< push: the previous point is not consumed yet; pull first */
    PK_ERANGE = -2,     /**< push: a coordinate is outside ±PK_UM_MAX; nothing changed */
    PK_EINVAL = -3,     /**< init: bad configuration value */
    PK_ENOTSUP = -4,    /**< init: valid, but not built in (PK_BUILD_*, PK_WIN, ...) */
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
    pk_um_t p[PK_AXES];   /**< position, µm (axes beyond cfg.dims are 0) */
    pk_q30_t t[PK_AXES];  /**< unit tangent, Q1.30; all zero where undefined */
};

/* ---- private state (exposed only so that callers can own the storage) ---- */

#if PK_HAVE_SPAN || PK_CHAIKIN_ONLY
/** The closed-form span engine: one polynomial run at a time. */
struct pk_span {
    pk_umf_t s[PK_SPAN_DMAX + 1][PK_AXES]; /**< s[0] the next level-K point, s[d] its d-th
                                              forward difference (s[D] constant in a span) */
    pk_um_t w[PK_SPAN_WIN][PK_AXES];       /**< the last input points taken: P(i) in w[i % PK_SPAN_WIN] */
    uint16_t rem;    /**< outputs left in the current run (<= 2^depth + 3) */
    uint16_t pad0_;
    uint32_t blk;    /**< span index of the current run (modulo 2^32) */
    uint8_t ph;      /**< phase: which run comes next (pk_refine.c) */
    uint8_t D;       /**< degree */
    uint8_t K;       /**< depth in use for this stroke (a 3-point clamped cubic: one less) */
    uint8_t g;       /**< fraction bits of the points in w (32-bit builds: up to 8 - F;
                          a 3-point clamped cubic: 3 more) */
    uint8_t lft;     /**< spans since the first, saturating at 3 (clamped left ends) */
    uint8_t pad_[3];
};
#endif

#if PK_HAVE_CASCADE
/** One level of the exact cascade. */
struct pk_level {
    pk_umf_t w[PK_WIN][PK_AXES]; /**< the last inputs (exact, this level's scale), w[0] oldest */
    uint8_t n;      /**< inputs seen, saturating at 255 (only "how many so far" matters) */
    uint8_t pend;   /**< outputs ready to emit */
    uint8_t ph;     /**< which output of the current batch comes next */
    uint8_t st;     /**< PK_LV_* state bits */
};
#endif

#if PK_BUILD_LIMIT && !PK_CHAIKIN_ONLY
/** The limit/tangent stage (one per stream). */
struct pk_limit_stage {
    pk_umf_t w[PK_LWIN][PK_AXES]; /**< the last level-K points, w[PK_LWIN-1] newest */
    uint8_t n;      /**< inputs seen, saturating at 255 */
    int8_t lag;     /**< newest input index minus the next anchor's index */
    uint8_t a;      /**< index of the next anchor, saturating at 255 */
    uint8_t st;     /**< LV_FIN when finished */
    uint8_t thr;    /**< lag at which the front anchor is released */
    uint8_t edge;   /**< the rule's anchors are edges (even degree) */
    uint8_t nend;   /**< anchors 0..nend-1 from each end have masks of their own */
    uint8_t drop;   /**< bit a: end anchor a is dropped */
    uint8_t min_n;  /**< shorter polygons use per-size masks */
    uint8_t pad_[3];
    const int32_t *rule; /**< table-driven stage: its rule (pk_masks.h); NULL: Chaikin's */
};
#endif

/** One stream. Caller-owned; its size is fixed at compile time. */
struct pk_refine {
    struct pk_refine_cfg cfg;
    uint8_t D;             /**< effective degree (DLG: 0) */
    uint8_t ends;          /**< effective end rule */
    uint8_t engine;        /**< which engine serves this configuration (pk_refine.c) */
    uint8_t fast;          /**< pull may take the span engine's run directly */
    uint8_t in_full;       /**< the input slot holds a point */
    uint8_t finishing;     /**< finish() was called */
    uint8_t close_c;       /**< closed: first points to replay */
    uint8_t close_i;       /**< closed: replay position */
    uint8_t F;             /**< fraction bits of the level-K values */
    uint8_t G;             /**< cascade: most fraction bits a level keeps */
    uint8_t pad_[2];
    pk_umf_t half;         /**< 2^(F-1): the output rounding's half unit (0 if F = 0) */
    uint32_t m;            /**< points pushed in this stroke (saturating) */
    uint32_t taken;        /**< points the engine has taken from the input (modulo 2^32) */
    uint32_t out_done;     /**< closed: outputs delivered or committed to a run */
    uint32_t out_left;     /**< closed: outputs still to give (2^depth * m), else UINT32_MAX */
    pk_um_t in[PK_AXES];   /**< the input slot */
#if PK_BUILD_CLOSED
    pk_um_t first[PK_CLOSE_MAX][PK_AXES]; /**< closed: the stroke's first points */
#endif
    union {
#if PK_HAVE_SPAN || PK_CHAIKIN_ONLY
        struct pk_span sp;
#endif
#if PK_HAVE_CASCADE
        struct pk_level lv[PK_MAX_DEPTH > 0 ? PK_MAX_DEPTH : 1];
#endif
        uint8_t none_;
    } e;
#if PK_BUILD_LIMIT && !PK_CHAIKIN_ONLY
    struct pk_limit_stage lim;
#endif
};

/**
 * Initialise a stream.
 * @retval PK_OK       ready for the first point
 * @retval PK_EINVAL   degree, depth, dims or an enum is out of range
 * @retval PK_ENOTSUP  the configuration is valid but not in this build: a
 *                     scheme, degree, end rule, closed curves or the limit
 *                     stage left out by PK_BUILD_*, more history than
 *                     PK_WIN/PK_LWIN/PK_CLOSE_MAX allow, or an end rule that
 *                     does not exist for that degree (clamped needs D <= 3)
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
 * Calling context: MAIN (same context as pull).
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
 * Calling context: MAIN. Bounded work per call: O(depth) at worst.
 */
int pk_refine_pull(struct pk_refine *r, struct pk_refine_out *out);

/**
 * Take up to max_points refined points at once: exactly what as many calls
 * of pk_refine_pull would give, written densely into the caller's arrays.
 * @param p   cfg.dims coordinates per point (x, y[, z], x, y[, z], ...), µm;
 *            room for max_points points
 * @param t   NULL, or (with cfg.tangents) room for cfg.dims Q1.30 tangent
 *            components per point
 * @param got set to the number of points written
 * @retval PK_OK          *got >= 1 points were written (fewer than max_points
 *                        only where pk_refine_pull would next say
 *                        PK_NEED_INPUT or PK_END; the next call says so)
 * @retval PK_NEED_INPUT, PK_END   as pk_refine_pull, with *got = 0
 * max_points = 0 writes nothing and returns PK_OK with *got = 0.
 * Calling context: MAIN. Work is proportional to the points written.
 */
int pk_refine_pull_block(struct pk_refine *r, pk_um_t *p, pk_q30_t *t, uint32_t max_points,
                         uint32_t *got);

/** Drop the current stroke (e.g. on a soft reset); keeps the configuration. */
void pk_refine_reset(struct pk_refine *r);

/**
 * Upper bound on the points pk_refine_pull can deliver between one
 * PK_NEED_INPUT (or the start) and the next. After a push it is at most
 * 2^depth (plus, with limit/tangents, one burst of at most PK_LWIN once per
 * stroke, when an open polygon first has enough points to tell its ends);
 * after pk_refine_finish it is at most 4 * 2^depth for open strokes and
 * (PK_CLOSE_MAX + 1) * 2^depth for closed ones (plus the same PK_LWIN with
 * limit). This returns the larger, so a consumer with this much room never
 * has to stop mid-stroke (stopping anyway is always safe).
 */
uint32_t pk_refine_max_release(const struct pk_refine_cfg *cfg);

/** Bytes of state one stream uses (sizeof(struct pk_refine)). */
#define PK_REFINE_STATE_BYTES ((uint32_t)sizeof(struct pk_refine))

#endif
