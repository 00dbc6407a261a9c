/*
 * pk_refine_internal.h — private glue between the parts of the kernel:
 * the stream and its input (pk_refine.c), the closed-form span engine
 * (pk_refine_span.c), the exact level cascade (pk_refine_cascade.c) and the
 * limit/tangent stage (pk_limit.c). Not for callers.
 *
 * Every engine is a "source" of exact level-K points (pk_umf_t, F fraction
 * bits): pull asks it for the next one, then either rounds it to the output
 * or hands it to the limit stage.
 */
#ifndef PLOTKIN_PK_REFINE_INTERNAL_H
#define PLOTKIN_PK_REFINE_INTERNAL_H

#include "pk_refine.h"

/* A function the compiler must not inline (keeps a hot caller small). */
#if defined(__GNUC__)
#define PK_NOINLINE __attribute__((noinline))
#else
#define PK_NOINLINE
#endif

/* A function the compiler must inline (the hot path's helpers). */
#if defined(__GNUC__)
#define PK_INLINE inline __attribute__((always_inline))
#else
#define PK_INLINE inline
#endif

/* r->engine */
#define PK_ENG_PASS 0u    /* depth 0: the input itself */
#define PK_ENG_SPAN 1u    /* closed-form spans (pk_refine_span.c) */
#define PK_ENG_CASCADE 2u /* exact level cascade (pk_refine_cascade.c) */

/* cascade level and limit stage state bits */
#define LV_DEFER 0x01u /* batch held until we know whether more input follows */
#define LV_FIN 0x02u   /* finished: the current batch is the tail */
#define LV_E0 0x04u    /* something has been emitted in this stroke */

/* Answers of a source (same values as the public statuses). */
#define PK_SRC_OK PK_OK
#define PK_SRC_NEED PK_NEED_INPUT
#define PK_SRC_END PK_END

/* ---- the input stream (pk_refine.c) ------------------------------------ */
/** The next input point is there: the slot, or (closed, finishing) a replay. */
int pk_in_ready(const struct pk_refine *r);
/** No more input will come: finishing, and nothing left to take. */
int pk_in_exhausted(const struct pk_refine *r);
/** Take the next input point (pk_in_ready must hold); counts r->taken. */
void pk_in_take(struct pk_refine *r, pk_um_t p[PK_AXES]);

/* ---- the span engine ---------------------------------------------------- */
#if PK_HAVE_SPAN
/** Configure for r->cfg (D, ends, depth); sets r->F. */
void pk_span_setup(struct pk_refine *r);
/** Set up the next run once the current one is used up (rem == 0).
 *  @return PK_SRC_OK (sp.rem > 0 now), PK_SRC_NEED, PK_SRC_END */
int pk_span_refill(struct pk_refine *r);
/** The next level-K point (exact). @return PK_SRC_OK, PK_SRC_NEED, PK_SRC_END */
int pk_span_next(struct pk_refine *r, pk_umf_t v[PK_AXES]);
/** pk_refine_pull_block for a fast stream (span engine, no limit stage):
 *  up to max rounded outputs, dims coordinates each, into p, refilling runs
 *  as it goes; the count in *got. Same answers as pk_refine_pull_block
 *  (PK_END after the last point, on a call that gave none, and resets). */
int pk_span_pull_block(struct pk_refine *r, pk_um_t *p, uint32_t max, uint32_t *got);
#endif

/* ---- the cascade -------------------------------------------------------- */
#if PK_HAVE_CASCADE
/** Configure for r->cfg; sets r->F, r->G. @return PK_OK or PK_ENOTSUP */
int pk_cascade_setup(struct pk_refine *r);
/** The next level-K point (exact). @return PK_SRC_OK, PK_SRC_NEED, PK_SRC_END */
int pk_cascade_next(struct pk_refine *r, pk_umf_t v[PK_AXES]);
#endif

/* ---- the limit/tangent stage ------------------------------------------- */
#if PK_BUILD_LIMIT
/** @return PK_OK, or PK_ENOTSUP if the rule is not built / does not fit */
int pk_limit_setup(struct pk_refine *r);
int pk_limit_ready(const struct pk_refine *r);
int pk_limit_exhausted(const struct pk_refine *r);
void pk_limit_feed(struct pk_refine *r, const pk_umf_t *p);
void pk_limit_finish(struct pk_refine *r);
void pk_limit_emit(struct pk_refine *r, struct pk_refine_out *out);
#endif


/** Round an exact level-K value (r->F fraction bits) to whole µm. */
static inline pk_um_t pk_out_round(const struct pk_refine *r, pk_umf_t v)
{
    return r->F ? pk_umf_round(v, r->F, r->half) : (pk_um_t)v;
}

#endif
