/*
 * pk_refine.c — the streaming subdivision kernel: configuration, the input
 * stream, and the pull loop that joins an engine to the output.
 *
 * WHY IT IS BUILT THIS WAY
 * ========================
 * A plotter's sender streams G-code line by line; a microcontroller cannot
 * hold the polyline, let alone 2^8 times its length. So the kernel is driven
 * from the OUTPUT end: asking for a point does exactly the work that point
 * needs, with state of a few input points plus a few numbers per axis. A
 * consumer that stops pulling (full motion queue) leaves everything where it
 * was; a push only stores the point in a one-point slot.
 *
 * Closed form instead of a cascade. K levels of a stationary B-spline scheme
 * are one linear map: every level-K point is a fixed combination of D + 1
 * consecutive input points (D = degree). Group the level-K points by the
 * span of the B-spline curve their knots fall in — with n = 2^K they come in
 * runs of n, output j in span s = j / n — and inside one span the weights are
 * polynomials of degree D in j (the refined control points are the curve
 * segment's blossom evaluated at D consecutive fine knots, and the blossom is
 * multi-affine). So the D-th forward difference of the output sequence is
 * constant within a span, and a span's n points cost D additions per axis
 * each: keep V = the next point and its differences Δ^1 V .. Δ^D V, emit V,
 * then V += Δ^1, Δ^1 += Δ^2, ... This is pk_refine_span.c.
 *
 * Better still, the polynomial of span s is valid a further D points into
 * span s + 1 (those points' knots still touch span s), so when a span ends,
 * V .. Δ^(D-1) already hold the right values for the next span and only
 * Δ^D changes: to the D-th difference of the next span's D + 1 input points,
 * times a constant. The constants (tables in pk_refine_span.c) are small
 * integers that do not depend on the depth; only the stroke's first state
 * and the D - 1 end points of a clamped stroke need depth-dependent weights,
 * products of n = 2^K, i.e. shifts. Clamped ends are just spans whose knots
 * are clamped, so they run through the same loop with their own Δ^D. Per
 * interior output point that is D adds per axis and one rounding, and the
 * block pull's inner loop (pk_refine_pull_block) is nothing else: for
 * Chaikin with 32-bit values it even runs four points at once in SIMD lanes,
 * each lane stepping by the 4-step differences, exact integers as well.
 *
 * Where the closed form is not used: the replace end rule of degrees 2..3
 * (it overwrites each level's end point, which is not a polynomial in j),
 * DLG (interpolating, not piecewise polynomial) and degrees >= 4 (not worth
 * their tables) run through pk_refine_cascade.c: the classic cascade of
 * one small window per level, pulled from the output end, now with exact
 * values. Depth 0 passes the input through.
 *
 * Exactness. Every level-K point of every scheme here is a dyadic rational:
 * each level's masks have power-of-two denominators (2^D for Lane-
 * Riesenfeld, 4 for Chaikin's clamped end, 16 for the clamped cubic's and
 * DLG's). The kernel carries N = point * 2^F exactly in pk_umf_t (F = D*K,
 * 3K + 1 for the clamped cubic, 4K for DLG) and rounds once, at the output,
 * to the nearest micrometre with ties away from zero. Forward differences
 * are integer combinations of such N, so they are exact integers too: the
 * closed form computes precisely the same rationals as refining level by
 * level, and nothing accumulates. The output is the exactly rounded rational:
 * error <= 0.5 LSB, tested against an exact 128-bit model of the
 * specification (tests/test_kernel_exact.c). The limit stage applies its
 * masks to the same exact values and rounds once; tangents are taken from
 * the exact polygon too, so tiny level-K edges no longer lose their
 * direction to rounding (the old kernel's 1.4 degrees on dense input).
 * Ties-away-from-zero is odd-symmetric, so negating a coordinate of the input
 * negates the output bit for bit; the masks are palindromic and the end rules
 * mirror each other, so reversing the input reverses the output.
 *
 * Why correctly rounded rather than the old kernel's bits: the kernel this
 * replaced rounded every level to 1/256 µm, so its outputs depended on the
 * order of the cascade's roundings, which a closed form does not perform;
 * reproducing them would have meant keeping the cascade. The rational result
 * is the specification (the team's exact vectors are computed from it), and
 * rounding it once is both cheaper and better: 0.5 LSB instead of 0.5 +
 * depth/512, and identical to the old bits wherever the old kernel rounded
 * only once (Chaikin to depth 4, the cubic to depth 2: checked against the
 * frozen old kernel in tests/ref). The one-point pull's protocol, counts,
 * closed-curve rotation and release bound are unchanged.
 *
 * Builds. Everything above is selected at compile time (PK_BUILD_* in
 * pk_refine.h); pk_refine_init refuses what a build lacks with PK_ENOTSUP
 * and references nothing it does not carry (the limit tables only with the
 * limit stage and a scheme that needs them). A build of Chaikin with clamped
 * ends only is pk_refine_chaikin.c alone: the same closed form written out
 * for D = 2 (each span's Δ² with the clamped end weights, framed by the
 * stroke's end points) and a limit stage without tables (the quadratic
 * limit points are edge midpoints and the two end points; its tangents are
 * edge directions), about 2 KB on a Cortex-M0+.
 *
 * Ranges. |input| <= PK_UM_MAX = 2^21 - 1 µm. B-spline points are convex
 * combinations, so |N| < 2^(21 + F); F <= 25 for the span engine (the clamped
 * cubic at depth 8), so N, and its differences (bounded by (K + 2) bits more
 * than the input differences times n^(D-1)), fit int64 with room to spare; a
 * Chaikin-only build with PK_MAX_DEPTH <= 5 has F <= 10 and fits int32
 * (PK_UMF_BITS). The cascade needs F = D*K bits: up to 42 fits int64 (degree
 * 5 at depth 8 needs 40, DLG 32 plus its 1.26 overshoot); degree 6 at depth 8
 * and degree 7 at depth 7..8 would need more, so their last levels keep 42 - D
 * fraction bits (rounded, error below 2^-34 LSB). Mask sums are formed before
 * any division and never exceed 2^62.
 *
 * Closed curves. Every closed scheme here is stationary and local, so the
 * closed level-K polygon is a window of the open ("no end rule") refinement
 * of the periodic sequence P0..Pm-1, P0, P1, ..., Pc-1 (c = the rule's reach,
 * plus the limit stencil's). The kernel keeps the stroke's first c points
 * (once), replays them after the last point, and stops after exactly 2^K * m
 * outputs, starting where the first full stencil lies (for Chaikin Q0).
 */
#include "pk_refine.h"
#include "pk_refine_internal.h"

#include <stddef.h>

#if !PK_CHAIKIN_ONLY /* else pk_refine_chaikin.c is the kernel */

_Static_assert((-3 >> 1) == -2, "the kernel needs arithmetic right shifts of negative values");

/* ---- configuration -------------------------------------------------------- */

static int built(const struct pk_refine *r)
{
    const struct pk_refine_cfg *c = &r->cfg;
    if (c->scheme == PK_SCHEME_DLG) {
        if (!PK_BUILD_DLG)
            return 0;
    } else {
        if (((unsigned)PK_BUILD_DEGREES & (1u << r->D)) == 0u)
            return 0;
        if (!c->closed && ((unsigned)PK_BUILD_ENDS & (1u << r->ends)) == 0u)
            return 0;
    }
    if (c->closed && !PK_BUILD_CLOSED)
        return 0;
    if (c->limit && !PK_BUILD_LIMIT)
        return 0;
    return 1;
}

static unsigned engine_of(const struct pk_refine *r)
{
    if (r->cfg.depth == 0u)
        return PK_ENG_PASS;
    if (r->cfg.scheme == PK_SCHEME_BSPLINE && r->D <= 3u &&
        (r->D == 1u || r->cfg.closed || r->ends != PK_ENDS_REPLACE))
        return PK_ENG_SPAN;
    return PK_ENG_CASCADE;
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

    /* Zero everything: no stale state can leak into a stroke. */
    unsigned char *b = (unsigned char *)r;
    for (size_t i = 0; i < sizeof *r; i++)
        b[i] = 0;
    r->cfg = c;
    r->D = c.scheme == PK_SCHEME_DLG ? 0u : c.degree;
    if (c.scheme == PK_SCHEME_DLG)
        r->ends = PK_ENDS_NONE;
    else if (c.ends != PK_ENDS_DEFAULT)
        r->ends = c.ends;
    else
        r->ends = r->D <= 3u ? PK_ENDS_CLAMPED : PK_ENDS_REPLACE;
    if (c.scheme == PK_SCHEME_BSPLINE && r->ends == PK_ENDS_CLAMPED && r->D > 3u)
        return PK_ENOTSUP;
    if (!built(r))
        return PK_ENOTSUP;
    r->close_c = (uint8_t)(c.scheme == PK_SCHEME_DLG ? 5u : r->D < 2u ? 2u : r->D);
    if (c.closed && r->close_c > PK_CLOSE_MAX)
        return PK_ENOTSUP;
    r->engine = (uint8_t)engine_of(r);
    switch (r->engine) {
    case PK_ENG_PASS:
        r->F = 0;
        break;
#if PK_HAVE_SPAN
    case PK_ENG_SPAN:
        pk_span_setup(r);
        break;
#endif
#if PK_HAVE_CASCADE
    case PK_ENG_CASCADE:
        if (pk_cascade_setup(r) != PK_OK)
            return PK_ENOTSUP;
        break;
#endif
    default:
        return PK_ENOTSUP; /* the engine this needs is not built */
    }
#if PK_BUILD_LIMIT
    if (c.limit && pk_limit_setup(r) != PK_OK)
        return PK_ENOTSUP;
#endif
    r->half = r->F ? (pk_umf_t)1 << (r->F - 1u) : 0;
    r->fast = (uint8_t)(r->engine == PK_ENG_SPAN && !c.limit);
    r->out_left = UINT32_MAX;
    return PK_OK;
}

void pk_refine_reset(struct pk_refine *r)
{
    struct pk_refine_cfg c = r->cfg;
    (void)pk_refine_init(r, &c);
}

/* ---- the input stream ----------------------------------------------------- */

int pk_refine_push(struct pk_refine *r, const pk_um_t p[PK_AXES])
{
    if (r->finishing)
        return PK_ESTATE;
    if (r->in_full)
        return PK_EBUSY;
    for (unsigned a = 0; a < r->cfg.dims; a++)
        if (p[a] > PK_UM_MAX || p[a] < -PK_UM_MAX)
            return PK_ERANGE;
    if (r->cfg.closed && r->m >= PK_CLOSED_MAX_POINTS)
        return PK_ETOOLONG;
    for (unsigned a = 0; a < PK_AXES; a++)
        r->in[a] = a < r->cfg.dims ? p[a] : 0;
#if PK_BUILD_CLOSED
    if (r->cfg.closed && r->m < r->close_c)
        for (unsigned a = 0; a < PK_AXES; a++)
            r->first[r->m][a] = r->in[a];
#endif
    if (r->m < UINT32_MAX)
        r->m++;
    r->in_full = 1;
    return PK_OK;
}

void pk_refine_finish(struct pk_refine *r)
{
    if (r->finishing)
        return;
    r->finishing = 1;
    if (r->cfg.closed) {
        uint32_t target = r->m <= 1u ? r->m : r->m << r->cfg.depth;
        r->out_left = target - r->out_done;
    }
}

int pk_in_ready(const struct pk_refine *r)
{
    if (r->in_full)
        return 1;
#if PK_BUILD_CLOSED
    return r->finishing && r->cfg.closed && r->m >= 1u && r->close_i < r->close_c;
#else
    return 0;
#endif
}

int pk_in_exhausted(const struct pk_refine *r)
{
    return r->finishing && !pk_in_ready(r);
}

void pk_in_take(struct pk_refine *r, pk_um_t p[PK_AXES])
{
    const pk_um_t *src = r->in;
    if (r->in_full) {
        r->in_full = 0;
    } else {
#if PK_BUILD_CLOSED
        unsigned i = r->close_i++; /* closed: replay the first points, cyclically */
        src = r->first[r->m < r->close_c ? i % r->m : i];
#endif
    }
    for (unsigned a = 0; a < PK_AXES; a++)
        p[a] = src[a];
    r->taken++; /* modulo 2^32: the span engine uses differences only */
}

/* ---- pulling -------------------------------------------------------------- */

/* The next exact level-K point from whichever engine serves the stream. */
static int source_next(struct pk_refine *r, pk_umf_t v[PK_AXES])
{
    switch (r->engine) {
#if PK_HAVE_SPAN
    case PK_ENG_SPAN:
        return pk_span_next(r, v);
#endif
#if PK_HAVE_CASCADE
    case PK_ENG_CASCADE:
        return pk_cascade_next(r, v);
#endif
    default: {
        if (!pk_in_ready(r))
            return r->finishing ? PK_SRC_END : PK_SRC_NEED;
        pk_um_t p[PK_AXES];
        pk_in_take(r, p);
        for (unsigned a = 0; a < PK_AXES; a++)
            v[a] = p[a];
        return PK_SRC_OK;
    }
    }
}

/* One point through the general path (limit stage, cascade, depth 0), or the
 * status that stops the stream; never resets, so asking again after PK_END
 * says PK_END again (pk_refine_pull_block relies on that). */
static int pull_one(struct pk_refine *r, struct pk_refine_out *out)
{
    if (r->cfg.closed && r->out_left == 0u)
        return PK_END;
    for (unsigned a = 0; a < PK_AXES; a++) {
        out->p[a] = 0;
        out->t[a] = 0;
    }
#if PK_BUILD_LIMIT
    if (r->cfg.limit) {
        for (;;) {
            if (pk_limit_ready(r)) {
                pk_limit_emit(r, out);
                break;
            }
            if (pk_limit_exhausted(r))
                return PK_END;
            pk_umf_t v[PK_AXES];
            int st = source_next(r, v);
            if (st == PK_SRC_OK)
                pk_limit_feed(r, v);
            else if (st == PK_SRC_END)
                pk_limit_finish(r);
            else
                return PK_NEED_INPUT;
        }
    } else
#endif
    {
        pk_umf_t v[PK_AXES];
        int st = source_next(r, v);
        if (st != PK_SRC_OK)
            return st;
        for (unsigned a = 0; a < r->cfg.dims; a++)
            out->p[a] = pk_out_round(r, v[a]);
    }
    if (r->cfg.closed) {
        r->out_done++;
        r->out_left--;
    }
    return PK_OK;
}

#if PK_HAVE_SPAN
/* The span engine's current run, one point: round, then step the forward
 * differences (s[d] += s[d+1], lowest first, so each adds the old value).
 * Straight-line code for the common cases: this is the motion core's loop. */
static PK_INLINE void span_emit1(struct pk_refine *r, struct pk_refine_out *out)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned f = r->F;
    const pk_umf_t half = r->half;
    pk_umf_t(*s)[PK_AXES] = sp->s;
#if PK_AXES == 2
    const unsigned dims = 2;
#else
    const unsigned dims = r->cfg.dims;
    out->p[2] = 0;
    out->t[2] = 0;
#endif
    const unsigned D = PK_SPAN_ONE_D ? PK_SPAN_ONE_D : sp->D;
    out->t[0] = 0;
    out->t[1] = 0;
#if defined(__AVR__)
    /* one axis at a time: fewer registers to save on an 8-bit core */
    for (unsigned a = 0; a < dims; a++) {
        out->p[a] = pk_umf_round(s[0][a], f, half);
        for (unsigned d = 0; d < D; d++)
            s[d][a] += s[d + 1u][a];
    }
#else
    out->p[0] = pk_umf_round(s[0][0], f, half);
    out->p[1] = pk_umf_round(s[0][1], f, half);
#if PK_SPAN_DMAX >= 2
    if (D == 2u) {
        s[0][0] += s[1][0];
        s[1][0] += s[2][0];
        s[0][1] += s[1][1];
        s[1][1] += s[2][1];
        if (dims > 2u) {
            out->p[PK_AXES - 1] = pk_umf_round(s[0][PK_AXES - 1], f, half);
            s[0][PK_AXES - 1] += s[1][PK_AXES - 1];
            s[1][PK_AXES - 1] += s[2][PK_AXES - 1];
        }
        return;
    }
#endif
#if PK_SPAN_DMAX >= 3
    if (D == 3u && dims == 2u) {
        s[0][0] += s[1][0];
        s[1][0] += s[2][0];
        s[2][0] += s[3][0];
        s[0][1] += s[1][1];
        s[1][1] += s[2][1];
        s[2][1] += s[3][1];
        return;
    }
#endif
    for (unsigned a = 2; a < dims; a++)
        out->p[a] = pk_umf_round(s[0][a], f, half);
    for (unsigned a = 0; a < dims; a++)
        for (unsigned d = 0; d < D; d++)
            s[d][a] += s[d + 1u][a];
#endif
}

/* Everything but the fast path's common case, out of line so that the fast
 * path stays small. */
PK_NOINLINE static int pull_more(struct pk_refine *r, struct pk_refine_out *out);
#else
#define pull_more pull_general
#endif

static int pull_general(struct pk_refine *r, struct pk_refine_out *out)
{
    int st = pull_one(r, out);
    if (st == PK_END)
        pk_refine_reset(r);
    return st;
}

#if PK_HAVE_SPAN
static int pull_more(struct pk_refine *r, struct pk_refine_out *out)
{
    if (!r->fast)
        return pull_general(r, out);
    int st = pk_span_refill(r);
    if (st != PK_SRC_OK) {
        if (st == PK_SRC_END)
            pk_refine_reset(r);
        return st;
    }
    r->e.sp.rem--;
    span_emit1(r, out);
    return PK_OK;
}
#endif

int pk_refine_pull(struct pk_refine *r, struct pk_refine_out *out)
{
#if PK_HAVE_SPAN
    if (r->fast && r->e.sp.rem != 0u) {
        r->e.sp.rem--;
        span_emit1(r, out);
        return PK_OK;
    }
#endif
    return pull_more(r, out);
}

/* The block pull through the general path (limit stage, cascade, depth 0):
 * point by point. Out of line, so that the fast streams' dispatch below
 * stays a jump. */
static PK_NOINLINE int pull_block_general(struct pk_refine *r, pk_um_t *p, pk_q30_t *t, uint32_t max_points,
                                          uint32_t *got)
{
    uint32_t k = 0;
    int st = PK_OK;
    const unsigned dims = r->cfg.dims;
    *got = 0;
    if (max_points == 0u)
        return PK_OK;
    while (k < max_points) {
        struct pk_refine_out o;
        if ((st = pull_one(r, &o)) != PK_OK)
            break;
        for (unsigned a = 0; a < dims; a++) {
            p[(size_t)k * dims + a] = o.p[a];
            if (t != NULL && r->cfg.tangents)
                t[(size_t)k * dims + a] = o.t[a];
        }
        k++;
    }
    *got = k;
    if (k > 0u)
        return PK_OK;
    if (st == PK_END)
        pk_refine_reset(r);
    return st;
}

int pk_refine_pull_block(struct pk_refine *r, pk_um_t *p, pk_q30_t *t, uint32_t max_points,
                         uint32_t *got)
{
#if PK_HAVE_SPAN
    if (r->fast) /* the span engine's own loop (pk_refine_span.c) */
        return pk_span_pull_block(r, p, max_points, got);
#endif
    return pull_block_general(r, p, t, max_points, got);
}

uint32_t pk_refine_max_release(const struct pk_refine_cfg *cfg)
{
    /* In steady state a push lets one more span (2^depth points) through:
     * every engine releases at most that. A finish releases the stroke's
     * last spans: at most 4 * 2^depth for open strokes (the clamped cubic's
     * last two spans and its end points; the cascade's per-level tails), and
     * for closed strokes the replayed first points, at most PK_CLOSE_MAX,
     * each refined 2^depth-fold. The limit stage adds at most one burst of
     * PK_LWIN anchors per stroke (when an open polygon first has enough
     * points to tell its ends). Measured maxima are at or below these
     * (tests/test_refine.c, fuzz_refine). */
    unsigned d = cfg->depth > PK_MAX_DEPTH ? PK_MAX_DEPTH : cfg->depth;
    uint32_t burst = (cfg->limit || cfg->tangents) ? (uint32_t)PK_LWIN : 0u;
    return ((cfg->closed ? (uint32_t)(PK_CLOSE_MAX + 1) : 4u) << d) + burst;
}

#endif /* !PK_CHAIKIN_ONLY */
