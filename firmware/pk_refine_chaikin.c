/*
 * pk_refine_chaikin.c — the whole kernel for builds that carry Chaikin with
 * clamped ends only (PK_CHAIKIN_ONLY: PK_BUILD_DEGREES=0x04, PK_BUILD_DLG=0,
 * PK_BUILD_ENDS=0x02, PK_BUILD_CLOSED=0), written out for size: the
 * smallest chips (ATmega328P, Cortex-M0+) run exactly this. In every other
 * build pk_refine.c and its engines are compiled instead and this file is
 * empty. tests/e2e_kernel_builds.sh checks that it gives, bit for bit, what
 * the general kernel gives for the same configurations.
 *
 * The closed form is pk_refine_span.c's, for D = 2 and the clamped rule
 * only (the argument is in pk_refine.c): with n = 2^K, outputs j = 1 .. nL
 * (L = m - 2 spans) are the steps of V, Δ V, Δ² V, where Δ² changes per
 * span to w0 Q0 - (w0 + w2) Q1 + w2 Q2 (w0 = 2 on the first span, w2 = 2 on
 * the last, else 1), framed by P0 and P(m-1). 0..2 points pass through.
 *
 * The limit stage is written out from the same state: the anchors are the
 * edges L(j) L(j+1) of the level-K polygon, j = 0 .. nL; edge j's limit
 * point is its midpoint (2V + ΔV) / 2, its tangent the edge itself, ΔV —
 * except the first and last edges, whose limit points are the stroke's end
 * points P0 and P(m-1) (pk_masks.h, "chaikin clamped").
 */
#include "pk_refine_internal.h"

#include <stddef.h>

#if PK_CHAIKIN_ONLY

/* The hot paths (the one-point pull's, the refill's next interior span):
 * not in builds with the limit stage, which are built for flash first
 * (Cortex-M0+, 2 KB), nor with PK_REFINE_FAST_PULL=0. */
#define PK_REFINE_HOT (!PK_BUILD_LIMIT && PK_REFINE_FAST_PULL)

/* Phases: which run comes next. */
enum { PH_P0 = 0, PH_FIRST, PH_SPANS, PH_LAST, PH_PASS, PH_DONE = 7 };

static pk_umf_t pow2(unsigned k) { return (pk_umf_t)1 << k; }

/* x * 2^k for an exact x * 2^k (it fits pk_umf_t): a shift of the unsigned
 * bits, so no multiply (a library call on AVR and Cortex-M0+ for 64 bits)
 * and no left shift of a negative value. */
#if PK_UMF_BITS == 64
typedef uint64_t umf_bits_t;
#else
typedef uint32_t umf_bits_t;
#endif
static pk_umf_t shl(pk_umf_t x, unsigned k) { return (pk_umf_t)((umf_bits_t)x << k); }

static const pk_um_t *pt(const struct pk_refine *r, uint32_t i)
{
    return r->e.sp.w[i & (PK_SPAN_WIN - 1u)];
}

int pk_refine_init(struct pk_refine *r, const struct pk_refine_cfg *cfg)
{
    if (r == NULL || cfg == NULL)
        return PK_EINVAL;
    struct pk_refine_cfg c = *cfg;
    if (c.dims == 0u)
        c.dims = PK_AXES;
    if (c.scheme > PK_SCHEME_DLG || c.depth > PK_MAX_DEPTH || c.dims < 2u || c.dims > PK_AXES ||
        c.ends > PK_ENDS_NONE || c.closed > 1u || c.limit > 1u || c.tangents > 1u)
        return PK_EINVAL;
    if (c.scheme == PK_SCHEME_BSPLINE && (c.degree < 1u || c.degree > 7u))
        return PK_EINVAL;
    if (c.tangents)
        c.limit = 1;
    unsigned char *b = (unsigned char *)r;
    for (size_t i = 0; i < sizeof *r; i++)
        b[i] = 0;
    if (c.scheme != PK_SCHEME_BSPLINE || c.degree != 2u || c.closed ||
        (c.ends != PK_ENDS_DEFAULT && c.ends != PK_ENDS_CLAMPED) || (c.limit && !PK_BUILD_LIMIT))
        return PK_ENOTSUP;
    r->cfg = c;
    r->D = 2;
    r->ends = PK_ENDS_CLAMPED;
    r->engine = PK_ENG_SPAN;
    /* F = 2K; at least 8 in 32-bit builds (a byte move rounds), at least 1
     * in the others (so that depth 0 rounds as the rest): the input points
     * are stored times 2^g */
    unsigned f = 2u * c.depth, g = PK_UMF_BITS == 32 ? (f < 8u ? 8u - f : 0u) : (f ? 0u : 1u);
    r->e.sp.g = (uint8_t)g;
    r->e.sp.K = c.depth;
    r->F = (uint8_t)(f + g);
    r->half = pow2(r->F - 1u);
    r->out_left = UINT32_MAX;
    return PK_OK;
}

void pk_refine_reset(struct pk_refine *r)
{
    struct pk_refine_cfg c = r->cfg;
    (void)pk_refine_init(r, &c);
}

int pk_refine_push(struct pk_refine *r, const pk_um_t p[PK_AXES])
{
    if (r->finishing)
        return PK_ESTATE;
    if (r->in_full)
        return PK_EBUSY;
    for (unsigned a = 0; a < r->cfg.dims; a++)
        if (p[a] > PK_UM_MAX || p[a] < -PK_UM_MAX)
            return PK_ERANGE;
    for (unsigned a = 0; a < PK_AXES; a++)
        r->in[a] = a < r->cfg.dims ? p[a] : 0;
    if (r->m < UINT32_MAX)
        r->m++;
    r->in_full = 1;
    return PK_OK;
}

void pk_refine_finish(struct pk_refine *r) { r->finishing = 1; }

/* A run of one fixed point P * 2^F (w holds P * 2^g). */
static void run_point(struct pk_refine *r, const pk_um_t *p)
{
    struct pk_span *sp = &r->e.sp;
    for (unsigned a = 0; a < PK_AXES; a++) {
        sp->s[0][a] = shl(p[a], r->F - sp->g);
        sp->s[1][a] = 0;
        sp->s[2][a] = 0;
    }
    sp->rem = 1;
}

/* Δ² of span s: w0 Q0 - (w0 + w2) Q1 + w2 Q2, additions only. */
static void set_top(struct pk_refine *r, uint32_t s, int left, int right)
{
    struct pk_span *sp = &r->e.sp;
    for (unsigned a = 0; a < PK_AXES; a++) {
        pk_umf_t x0 = pt(r, s)[a], x1 = pt(r, s + 1u)[a], x2 = pt(r, s + 2u)[a];
        pk_umf_t t = (x0 - x1) + (x2 - x1);
        if (left)
            t += x0 - x1;
        if (right)
            t += x2 - x1;
        sp->s[2][a] = t;
    }
}

/* Set up the next run from what has been taken: 1 run ready, 0 need a
 * point, -1 done. */
static int next_run(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    const uint32_t T = r->taken, n = (uint32_t)1 << sp->K;
    const int end = r->finishing && !r->in_full, lim = PK_BUILD_LIMIT && r->cfg.limit;
    switch (sp->ph) {
    case PH_P0:
        if (T < (lim ? 2u : 1u) && !end)
            return 0;
        if (T == 0u)
            return -1;
        if (end && T <= 2u) { /* 1 or 2 points: as they are */
            sp->ph = PH_PASS;
            return next_run(r);
        }
        sp->ph = PH_FIRST;
        run_point(r, pt(r, 0));
        goto first_point;
    case PH_FIRST: {
        if (T < 4u && !end)
            return 0;
        if (T < 3u) { /* ended at 2 points: P1 as it is */
            sp->ph = PH_PASS + 1;
            return next_run(r);
        }
        uint32_t L = end ? T - 2u : 2u; /* 1, or more */
        for (unsigned a = 0; a < PK_AXES; a++) {
            pk_umf_t q0 = pt(r, 0)[a], q1 = pt(r, 1)[a], q2 = pt(r, 2)[a];
            /* j = 1: V = n ((n-1) Q0 + Q1); Δ = 2(n-1)(Q1 - Q0) + (Q2 - Q1) [L = 1: 2(Q2 - Q1)] */
            pk_umf_t d01 = q1 - q0, d12 = q2 - q1;
            sp->s[0][a] = shl(shl(q0, sp->K) - q0 + q1, sp->K);
            sp->s[1][a] = shl(d01, sp->K + 1u) - 2 * d01 + d12 + (L == 1u ? d12 : 0);
        }
        set_top(r, 0, 1, L == 1u);
        sp->blk = 0;
        sp->ph = L == 1u ? PH_LAST : PH_SPANS;
        /* j = 1 .. n - 1, or .. n if this is the last span (limit: the
         * anchors stop one point before it, at the last edge's start) */
        sp->rem = (uint16_t)(n - 1u + (L == 1u && !lim ? 1u : 0u));
        return 1;
    }
    case PH_SPANS: {
        uint32_t s = sp->blk + 1u, ahead = T - s;
        if (ahead < 4u && !end)
            return 0;
        int last = end && ahead == 3u;
        set_top(r, s, 0, last);
        sp->blk = s;
        sp->ph = last ? PH_LAST : PH_SPANS;
        sp->rem = (uint16_t)(n + (last && !lim ? 1u : 0u));
        return 1;
    }
    case PH_LAST: { /* P(m-1); limit: with the last edge, from L(nL) (the state) to it */
        for (unsigned a = 0; a < PK_AXES; a++) {
            pk_umf_t p = shl(pt(r, T - 1u)[a], r->F - sp->g);
            sp->s[1][a] = lim ? p - sp->s[0][a] : 0;
            sp->s[0][a] = p;
            sp->s[2][a] = 0;
        }
        sp->rem = 1;
        sp->ph = PH_DONE;
        return 1;
    }
    case PH_PASS:
    case PH_PASS + 1: {
        uint32_t i = (uint32_t)(sp->ph - PH_PASS);
        if (i >= T)
            return -1;
        sp->ph++;
        run_point(r, pt(r, i));
    first_point:
        /* P0 (and a 2-point stroke's points): the tangent along P1 - P0, the
         * first edge's direction (L1 - L0 is a power-of-2 multiple of it,
         * which gives the same unit vector) */
        if (lim && T >= 2u)
            for (unsigned a = 0; a < PK_AXES; a++)
                sp->s[1][a] = (pk_umf_t)pt(r, 1)[a] - pt(r, 0)[a];
        return 1;
    }
    default:
        return -1;
    }
}

/* Take the point waiting in the slot into the ring (times 2^g). */
static void take_in(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    pk_um_t *w = sp->w[r->taken & (PK_SPAN_WIN - 1u)];
    for (unsigned a = 0; a < PK_AXES; a++)
        w[a] = (pk_um_t)((uint32_t)r->in[a] << sp->g);
    r->in_full = 0;
    r->taken++;
}

/* Take points until a run is ready: every case. */
#if PK_REFINE_HOT
#define REFILL_ANY_ATTR PK_NOINLINE
#else
#define REFILL_ANY_ATTR
#endif
static REFILL_ANY_ATTR int refill_any(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    while (sp->rem == 0u) {
        int st = next_run(r);
        if (st > 0)
            continue;
        if (st < 0)
            return PK_END;
        if (!r->in_full)
            return PK_NEED_INPUT;
        take_in(r);
    }
    return PK_OK;
}

/* Take points until a run is ready. */
static int refill(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    /* The hot case first: the next interior span while the stroke goes on
     * (next_run's PH_SPANS without an end in sight: its 4 points ahead, the
     * last of them perhaps still in the slot). */
    if (PK_REFINE_HOT && sp->ph == PH_SPANS && !r->finishing) {
        uint32_t s = sp->blk + 1u;
        if (r->taken - s < 4u) {
            if (!r->in_full)
                return PK_NEED_INPUT;
            take_in(r);
        }
        if (r->taken - s >= 4u) {
            set_top(r, s, 0, 0);
            sp->blk = s;
            sp->rem = (uint16_t)(1u << sp->K);
            return PK_OK;
        }
    }
    return refill_any(r);
}

#if !PK_BUILD_LIMIT && PK_UMF_BITS == 32 && PK_REFINE_FAST_PULL
/* The next point of the run, rounded into p[0 .. PK_AXES-1], and one step
 * of the differences: V += ΔV, ΔV += Δ²V. Values are read once into locals
 * (p may not alias the state, but the compiler cannot know: with the state
 * read back after each store the AVR loop was a third longer). */
static PK_INLINE void step_axis(pk_umf_t *s, unsigned f, pk_umf_t half, pk_um_t *p)
{
    pk_umf_t v = s[0], dv = s[PK_AXES];
    s[0] = v + dv;
    s[PK_AXES] = dv + s[2 * PK_AXES];
    *p = pk_umf_round(v, f, half);
}

static PK_INLINE void step_point(struct pk_span *sp, unsigned f, pk_umf_t half, pk_um_t *p)
{
    step_axis(&sp->s[0][0], f, half, &p[0]);
    step_axis(&sp->s[0][1], f, half, &p[1]);
#if PK_AXES > 2
    step_axis(&sp->s[0][2], f, half, &p[2]);
#endif
}
#endif

#if !PK_BUILD_LIMIT
/* n >= 1 points of one axis of the current run (no limit stage) into q, q +
 * dims, ...: V, ΔV, Δ²V stay in registers over the whole block (on AVR a
 * point costs the adds, the rounding and one store, not the state's loads
 * and stores and a call). The F = 8 copy rounds with a byte move. */
static PK_INLINE void emit_axis_run(pk_umf_t *s, pk_um_t *q, uint16_t n, unsigned dims, unsigned f,
                                     pk_umf_t half)
{
    pk_umf_t v = s[0], dv = s[PK_AXES];
    const pk_umf_t d2 = s[2 * PK_AXES];
    do {
        *q = pk_umf_round(v, f, half);
        q += dims;
        v += dv;
        dv += d2;
    } while (--n);
    s[0] = v;
    s[PK_AXES] = dv;
}

#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("no-tree-scev-cprop")))
#endif
static PK_NOINLINE void emit_axis(pk_umf_t *s, pk_um_t *q, uint16_t n, unsigned dims, unsigned f, pk_umf_t half)
{
    emit_axis_run(s, q, n, dims, f, half);
}
#endif

/* The general pull: a refill when the run is used up, any F, the limit
 * stage. */
#if PK_REFINE_FAST_PULL
#define PULL_ANY_ATTR PK_NOINLINE
#else
#define PULL_ANY_ATTR
#endif
static PULL_ANY_ATTR int pull_any(struct pk_refine *r, struct pk_refine_out *out)
{
    struct pk_span *sp = &r->e.sp;
    if (sp->rem == 0u) {
        int st = refill(r);
        if (st != PK_OK) {
            if (st == PK_END)
                pk_refine_reset(r);
            return st;
        }
    }
    sp->rem--;
#if PK_BUILD_LIMIT
    pk_umf_t(*s)[PK_AXES] = sp->s;
    const unsigned f = r->F;
    const int lim = r->cfg.limit;
    /* limit: an edge, its midpoint (2 L(j) + ΔV) / 2^(F+1), or (first and
     * last anchors, ph tells) the end point in s[0]; its tangent s[1] */
    const int endpoint = sp->ph == PH_FIRST || sp->ph == PH_DONE || sp->ph > PH_PASS;
    int64_t d[PK_AXES];
    for (unsigned a = 0; a < PK_AXES; a++) {
        out->t[a] = 0;
        d[a] = s[1][a];
        out->p[a] = lim ? (pk_um_t)pk_rshift_round64(2 * (int64_t)s[0][a] + (endpoint ? 0 : s[1][a]), f + 1u)
                        : pk_umf_round(s[0][a], f, r->half);
        s[0][a] += s[1][a];
        s[1][a] += s[2][a];
    }
    if (r->cfg.tangents)
        pk_unit_q30(d, r->cfg.dims, out->t);
#elif PK_UMF_BITS == 32 && PK_REFINE_FAST_PULL
    step_point(sp, r->F, r->half, out->p);
    for (unsigned a = 0; a < PK_AXES; a++)
        out->t[a] = 0;
#else
    pk_umf_t(*s)[PK_AXES] = sp->s;
    const unsigned f = r->F;
    const pk_umf_t half = r->half;
    for (unsigned a = 0; a < PK_AXES; a++) {
        out->t[a] = 0;
        out->p[a] = pk_umf_round(s[0][a], f, half);
        s[0][a] += s[1][a];
        s[1][a] += s[2][a];
    }
#endif
    return PK_OK;
}

int pk_refine_pull(struct pk_refine *r, struct pk_refine_out *out)
{
#if !PK_BUILD_LIMIT && PK_UMF_BITS == 32 && PK_REFINE_FAST_PULL
    /* The hot path of the smallest builds: inside a run, F = 8 (every depth
     * <= 4 of a 32-bit build), so a byte move rounds; few registers, so
     * little to save (on AVR the general path's prologue alone was a fifth
     * of a point's cycles). */
    struct pk_span *sp = &r->e.sp;
    if (sp->rem != 0u && r->F == 8u) {
        sp->rem--;
        step_point(sp, 8u, 128, out->p);
        for (unsigned a = 0; a < PK_AXES; a++)
            out->t[a] = 0;
        return PK_OK;
    }
#endif
    return pull_any(r, out);
}

#if !PK_BUILD_LIMIT && PK_UMF_BITS == 32 && defined(__AVR__)
/* (-Os would keep dv's start for a closed-form end value (a 32-bit
 * multiply) and spill q to the stack inside the loop.) */
#if defined(__GNUC__) && !defined(__clang__)
__attribute__((optimize("O2", "no-tree-scev-cprop")))
#endif
static PK_NOINLINE void emit_axis8(pk_umf_t *s, pk_um_t *q, uint16_t n, unsigned dims)
{
    emit_axis_run(s, q, n, dims, 8u, 128);
}
#endif

#if !PK_BUILD_LIMIT
/* Up to n >= 1 points of the current run, axis by axis. Axes beyond dims
 * hold zero and stay so. */
static uint16_t emit_run(struct pk_refine *r, pk_um_t *p, uint16_t n)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned dims = r->cfg.dims;
    for (unsigned a = 0; a < dims; a++) {
#if PK_UMF_BITS == 32 && defined(__AVR__)
        if (r->F == 8u) {
            emit_axis8(&sp->s[0][a], p + a, n, dims);
            continue;
        }
#endif
        emit_axis(&sp->s[0][a], p + a, n, dims, r->F, r->half);
    }
    sp->rem = (uint16_t)(sp->rem - n);
    return n;
}
#endif

int pk_refine_pull_block(struct pk_refine *r, pk_um_t *p, pk_q30_t *t, uint32_t max_points,
                         uint32_t *got)
{
    uint32_t k = 0;
    int st = PK_OK;
    const unsigned dims = r->cfg.dims;
    struct pk_span *sp = &r->e.sp;
    struct pk_refine_out o;
    while (k < max_points) {
        /* never past the end: PK_END resets, and must wait for the next call */
        if (sp->rem == 0u && (st = refill(r)) != PK_OK)
            break;
#if !PK_BUILD_LIMIT
        {
            uint32_t left = max_points - k;
            uint16_t n = left < sp->rem ? (uint16_t)left : sp->rem;
            k += emit_run(r, p + (size_t)k * dims, n);
            continue;
        }
#endif
        (void)pull_any(r, &o);
        for (unsigned a = 0; a < dims; a++) {
            p[(size_t)k * dims + a] = o.p[a];
            if (t != NULL && r->cfg.tangents)
                t[(size_t)k * dims + a] = o.t[a];
        }
        k++;
    }
    *got = k;
    if (k > 0u || max_points == 0u)
        return PK_OK;
    if (st == PK_END)
        pk_refine_reset(r);
    return st;
}

uint32_t pk_refine_max_release(const struct pk_refine_cfg *cfg)
{
    unsigned d = cfg->depth > PK_MAX_DEPTH ? PK_MAX_DEPTH : cfg->depth;
    uint32_t burst = (cfg->limit || cfg->tangents) ? (uint32_t)PK_LWIN : 0u;
    return ((cfg->closed ? (uint32_t)(PK_CLOSE_MAX + 1) : 4u) << d) + burst;
}

#endif
