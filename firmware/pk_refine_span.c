/*
 * pk_refine_span.c — the closed-form span engine: B-spline degrees 1..3,
 * open with clamped ends or none, and closed curves (the open rule on the
 * replayed periodic sequence), at any depth K >= 1.
 *
 * Output j (0-based, at level K, n = 2^K) of span s (j in [n*s, n*s + n)) is
 * a polynomial of degree D in j whose coefficients are fixed combinations of
 * the span's input points Q0..QD = P(s)..P(s+D) (pk_refine.c explains why).
 * The engine keeps the next output V and its forward differences exactly
 * (s[0] = V, s[d] = Δ^d V, F fraction bits) and emits "runs": a number of
 * outputs produced by stepping. Between spans only s[D] changes; these are
 * the values it takes, per span, in units of 2^F (F = D*K; 3K + 1 for the
 * clamped cubic), derived and checked against exact refinement by
 * tests/tools/derive_spans.py:
 *
 *   no end rule, closed:  Δ^D (Q0..QD):  D=1 (-1, 1), D=2 (1, -2, 1),
 *                         D=3 (-1, 3, -3, 1)
 *   clamped, span s of L = m - D spans, a = min(s, D-1), b = min(L-1-s, D-1):
 *     D=2 (a,b) = (0,0) (2,-4,2)  (0,1) (2,-3,1)  (1,1) (1,-2,1)
 *     D=3 (0,0) (-12,36,-36,12)  (0,1) (-12,21,-12,3)  (0,2) (-12,21,-11,2)
 *         (1,1) (-3,7,-7,3)  (1,2) (-3,7,-6,2)  (2,2) (-2,6,-6,2)
 *     and (b,a) is (a,b) reversed, negated for odd D (the right end mirrors
 *     the left).
 *
 * The stroke's first state and the clamped ends' D - 1 points at each end
 * ("specials", whose knots are clamped together) have weights that are
 * products of n: they are written out below (first_state_*, special points).
 *
 * Schedule. Span s of a clamped stroke is a plain interior span only if
 * b = D - 1, i.e. if input point P(s + 2D - 1) exists; so the engine takes
 * input points only until it can start the next run, which keeps at most 2D
 * points (PK_SPAN_WIN) and releases one span (n outputs) per push. At the end
 * of the stroke it knows L and gives the last spans their end masks. The last
 * span of a clamped stroke has n + 1 outputs (j up to n*L), the D - 1 right
 * specials follow; an open stroke without end rule ends with the last span's
 * D further outputs (its polynomial is still valid there). Strokes of 0..2
 * points pass through; a clamped cubic stroke of 3 points has a quadratic
 * first level (the spec refines at the highest degree the points allow), so
 * it continues as the cubic on that level's 4 points.
 */
#include "pk_refine_internal.h"

#include <stddef.h>

#if PK_HAVE_SPAN

#include "pk_rom.h"

/* Which of the engine's two rules this build needs (pk_refine.h): the plain
 * rule serves degree 1, the no-end rule and closed curves; the clamped rule
 * degrees 2..3 with clamped ends. */
#define PK_SPAN_PLAIN ((PK_BUILD_DEGREES & 0x02) != 0 || (PK_BUILD_ENDS & 0x08) != 0 || PK_BUILD_CLOSED)
#define PK_SPAN_CLAMPED ((PK_BUILD_ENDS & 0x02) != 0 && (PK_BUILD_DEGREES & 0x0C) != 0)

/* Phases: which run comes next. */
enum {
    PH_START = 0, /* clamped: P0; otherwise the first span */
    PH_SP1,       /* clamped cubic: output 1 */
    PH_FIRST,     /* clamped: the first span */
    PH_SPANS,     /* the next span, or the end */
    PH_RIGHT,     /* clamped: the right specials (PH_RIGHT + k) */
    PH_PASS = 8,  /* short stroke: input point PH_PASS + i as it is */
    PH_DONE = 15
};

#if PK_SPAN_DMAX >= 3 && PK_SPAN_CLAMPED
/* Δ^D of a clamped cubic span, by (a, b) with a <= b (tables in the header). */
static const int8_t top3[6][4] PK_ROM = {
    { -12, 36, -36, 12 }, { -12, 21, -12, 3 }, { -12, 21, -11, 2 },
    { -3, 7, -7, 3 },     { -3, 7, -6, 2 },    { -2, 6, -6, 2 },
};
#endif

static int is_clamped(const struct pk_refine *r)
{
#if !PK_SPAN_CLAMPED
    (void)r;
    return 0;
#elif !PK_SPAN_PLAIN
    (void)r;
    return 1;
#else
    return !r->cfg.closed && r->ends == PK_ENDS_CLAMPED && r->e.sp.D >= 2u;
#endif
}

static pk_umf_t pow2(unsigned k) { return (pk_umf_t)1 << k; }

/* Input point P(i); i in [taken - PK_SPAN_WIN, taken). */
static const pk_um_t *pt(const struct pk_refine *r, uint32_t i)
{
    return r->e.sp.w[i & (PK_SPAN_WIN - 1u)];
}

/* Take the next input point into the ring (the slot's, directly). */
static void take(struct pk_refine *r)
{
    pk_um_t *w = r->e.sp.w[r->taken & (PK_SPAN_WIN - 1u)];
    if (r->in_full) {
        for (unsigned a = 0; a < PK_AXES; a++)
            w[a] = r->in[a];
        r->in_full = 0;
        r->taken++;
    } else {
        pk_in_take(r, w);
    }
    if (PK_UMF_BITS == 32 && r->e.sp.g) /* |P| * 2^g < 2^27 */
        for (unsigned a = 0; a < PK_AXES; a++)
            w[a] = (pk_um_t)((uint32_t)w[a] << r->e.sp.g);
}

/* A run of one fixed point: s[0] = p * 2^F, no differences. */
static void run_point(struct pk_refine *r, const pk_um_t *p)
{
    struct pk_span *sp = &r->e.sp;
    for (unsigned a = 0; a < PK_AXES; a++) {
        sp->s[0][a] = (pk_umf_t)p[a] * pow2(r->F - sp->g);
        for (unsigned d = 1; d <= PK_SPAN_DMAX; d++)
            sp->s[d][a] = 0;
    }
    sp->rem = 1;
}

#if PK_SPAN_DMAX >= 3 || PK_SPAN_PLAIN
/* s[D] = sum_i w[i] * Q_i, Q_i = P(s + i); mirrored: w reversed, and negated
 * for odd D (the D-th difference of a reversed sequence is (-1)^D times the
 * reversed one). w is read from flash. */
static void set_top(struct pk_refine *r, uint32_t s, const int8_t *w, int mirror)
{
    struct pk_span *sp = &r->e.sp;
    unsigned D = sp->D;
    for (unsigned a = 0; a < PK_AXES; a++) {
        pk_umf_t acc = 0;
        for (unsigned i = 0; i <= D; i++) {
            int wi = mirror ? PK_ROM_I8(&w[D - i]) : PK_ROM_I8(&w[i]);
            if (mirror && (D & 1u))
                wi = -wi;
            acc += (pk_umf_t)wi * pt(r, s + i)[a];
        }
        sp->s[D][a] = acc;
    }
}
#endif

#if PK_SPAN_DMAX >= 2
/* Chaikin's Δ² of span s: w0 Q0 - (w0 + w2) Q1 + w2 Q2, with w0 = 2 at the
 * left end (a = 0), w2 = 2 at the right end (b = 0), else 1 (the table in
 * the header, written out). */
static void set_top2(struct pk_refine *r, uint32_t s, unsigned w0, unsigned w2)
{
    struct pk_span *sp = &r->e.sp;
    const pk_um_t *q0 = pt(r, s), *q1 = pt(r, s + 1u), *q2 = pt(r, s + 2u);
    for (unsigned a = 0; a < PK_AXES; a++) { /* additions only (no multiplier on AVR) */
        pk_umf_t x0 = q0[a], x1 = q1[a], x2 = q2[a];
        pk_umf_t t = (x0 - x1) + (x2 - x1);
        if (w0 == 2u)
            t += x0 - x1;
        if (w2 == 2u)
            t += x2 - x1;
        sp->s[2][a] = t;
    }
}
#endif

/* The plain interior span's Δ^D: the binomial D-th difference, times 2 for
 * the clamped cubic's scale (its F has one bit more). Chaikin's, the hot
 * case, is written out. */
static void set_top_uniform(struct pk_refine *r, uint32_t s)
{
#if PK_SPAN_DMAX >= 3 || PK_SPAN_PLAIN
    static const int8_t plain[3][4] PK_ROM = { { -1, 1 }, { 1, -2, 1 }, { -1, 3, -3, 1 } };
#endif
    struct pk_span *sp = &r->e.sp;
#if PK_SPAN_DMAX >= 2
    if (PK_SPAN_ONE_D == 2 || sp->D == 2u) {
        set_top2(r, s, 1, 1);
        return;
    }
#endif
#if PK_SPAN_DMAX >= 3 && PK_SPAN_CLAMPED
    if (sp->D == 3u && is_clamped(r)) {
        set_top(r, s, top3[5], 0);
        return;
    }
#endif
#if PK_SPAN_DMAX >= 3 || PK_SPAN_PLAIN
    set_top(r, s, plain[sp->D - 1u], 0);
#endif
}

#if PK_SPAN_CLAMPED
static void set_top_clamped(struct pk_refine *r, uint32_t s, unsigned a, unsigned b)
{
#if PK_SPAN_DMAX >= 3
    if (r->e.sp.D == 3u) {
        int mirror = a > b;
        unsigned lo = mirror ? b : a, hi = mirror ? a : b;
        unsigned idx = lo == 0u ? hi : lo == 1u ? 2u + hi : 5u;
        set_top(r, s, top3[idx], mirror);
        return;
    }
#endif
    set_top2(r, s, a ? 1u : 2u, b ? 1u : 2u);
}
#endif

/* ---- first states (depth-dependent weights; n = 2^K) ------------------------ */

#if PK_SPAN_PLAIN
/* No end rule (and closed), span 0 at j = 0: V, Δ^1 .. Δ^(D-1). */
static void first_state_plain(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned K = r->e.sp.K;
    const pk_umf_t n = pow2(K);
    for (unsigned a = 0; a < PK_AXES; a++) {
        pk_umf_t q0 = pt(r, 0)[a];
        switch (sp->D) {
#if PK_SPAN_DMAX >= 3
        case 3: {
            pk_umf_t q1 = pt(r, 1)[a], q2 = pt(r, 2)[a];
            int32_t nn = (int32_t)n;
            int32_t c0 = nn * (nn + 1) * (nn + 2) / 6, c2 = nn * (nn - 1) * (nn - 2) / 6;
            int32_t c1 = nn * nn * nn - c0 - c2;
            sp->s[0][a] = c0 * q0 + c1 * q1 + c2 * q2;
            sp->s[1][a] = (pk_umf_t)(nn * (nn - 1) / 2) * (q2 - q1) + (pk_umf_t)(nn * (nn + 1) / 2) * (q1 - q0);
            sp->s[2][a] = n * (q0 - 2 * q1 + q2);
            break;
        }
#endif
#if PK_SPAN_DMAX >= 2
        case 2: { /* V = n/2 ((n+1) Q0 + (n-1) Q1), Δ = n (Q1 - Q0) */
            pk_umf_t q1 = pt(r, 1)[a];
            sp->s[0][a] = ((n + 1) * q0 + (n - 1) * q1) * pow2(K - 1u);
            sp->s[1][a] = (q1 - q0) * n;
            break;
        }
#endif
        default: /* D = 1: V = n Q0 */
            sp->s[0][a] = q0 * n;
            break;
        }
    }
}
#endif

#if PK_SPAN_CLAMPED
/* Clamped, span 0 at j = D - 1, for a stroke of L spans (only L <= D - 1
 * changes the weights). */
static void first_state_clamped(struct pk_refine *r, uint32_t L)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned K = r->e.sp.K;
    const pk_umf_t n = pow2(K);
    for (unsigned a = 0; a < PK_AXES; a++) {
        pk_umf_t q0 = pt(r, 0)[a], q1 = pt(r, 1)[a], q2 = pt(r, 2)[a];
#if PK_SPAN_DMAX >= 3
        if (sp->D == 3u) {
            pk_umf_t q3 = pt(r, 3)[a];
            int32_t nn = (int32_t)n;
            pk_umf_t v1 = L == 1u ? 6 * nn * nn - 8 * nn : 6 * nn * (nn - 1);
            sp->s[0][a] = (pk_umf_t)(2 * nn * (nn - 1) * (nn - 2)) * q0 + v1 * q1 + (L == 1u ? 4 : 2) * nn * q2;
            /* Δ^1 and Δ^2 rows (derive_spans.py), each summing to zero */
            int32_t d1_1 = L == 1u ? 6 * nn * nn - 36 * nn + 36 : 6 * nn * nn - 27 * nn + 21;
            int32_t d1_2 = L == 1u ? 18 * nn - 36 : L == 2u ? 9 * nn - 12 : 9 * nn - 11;
            int32_t d1_3 = L == 1u ? 12 : L == 2u ? 3 : 2;
            sp->s[1][a] = (pk_umf_t)(-6 * (nn - 1) * (nn - 2)) * q0 + (pk_umf_t)d1_1 * q1 +
                          (pk_umf_t)d1_2 * q2 + (pk_umf_t)d1_3 * q3;
            int32_t d2_1 = L == 1u ? 72 - 24 * nn : 42 - 18 * nn;
            int32_t d2_2 = L == 1u ? 12 * nn - 72 : L == 2u ? 6 * nn - 24 : 6 * nn - 22;
            int32_t d2_3 = L == 1u ? 24 : L == 2u ? 6 : 4;
            sp->s[2][a] = (pk_umf_t)(12 * nn - 24) * q0 + (pk_umf_t)d2_1 * q1 + (pk_umf_t)d2_2 * q2 +
                          (pk_umf_t)d2_3 * q3;
            continue;
        }
#endif
        /* D = 2, j = 1: V = n ((n-1) Q0 + Q1); Δ = 2(n-1)(Q1-Q0) + (Q2-Q1) [L = 1: 2(Q2-Q1)] */
        sp->s[0][a] = ((n - 1) * q0 + q1) * n;
        sp->s[1][a] = 2 * (n - 1) * (q1 - q0) + (L == 1u ? 2 : 1) * (q2 - q1);
    }
}

#if PK_SPAN_DMAX >= 3
/* (1 - h) A + h B, h = 2^-K, in units of 2^F (F = 3K + 1). */
static void run_lerp(struct pk_refine *r, const pk_um_t *A, const pk_um_t *B)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned K = sp->K;
    const pk_umf_t n = pow2(K);
    for (unsigned a = 0; a < PK_AXES; a++) {
        sp->s[0][a] = ((n - 1) * A[a] + B[a]) * pow2(r->F - K - sp->g);
        for (unsigned d = 1; d <= PK_SPAN_DMAX; d++)
            sp->s[d][a] = 0;
    }
    sp->rem = 1;
}
#endif
#endif

void pk_span_setup(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    sp->D = r->D;
    sp->K = r->cfg.depth;
    sp->ph = PH_START;
    unsigned f = sp->D * r->cfg.depth + (sp->D == 3u && is_clamped(r) ? 1u : 0u);
    /* 32-bit builds: up to F = 8, carry 8 fraction bits anyway (the input
     * points are stored times 2^g, g = 8 - F): the output rounding is then a
     * byte move on an 8-bit core instead of a shift loop. Exact all the same. */
    sp->g = (uint8_t)(PK_UMF_BITS == 32 && f < 8u && f > 0u ? 8u - f : 0u);
    r->F = (uint8_t)(f + sp->g);
}

/* A new span run: n outputs (clamped last span n + 1); closed fast streams
 * clip to what is left of the 2^K * m. */
static int start_run(struct pk_refine *r, uint32_t len)
{
    struct pk_span *sp = &r->e.sp;
    if (PK_BUILD_CLOSED && r->fast && r->cfg.closed) {
        if (len > r->out_left)
            len = r->out_left;
        if (r->out_left != UINT32_MAX)
            r->out_left -= len;
        r->out_done += len;
    }
    sp->rem = (uint16_t)len;
    return len > 0u;
}

/* Set up the next run from what has been taken. 1: run ready (or an empty
 * one to skip: call again), 0: one more input point needed, -1: done. */
static int span_try(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    const uint32_t T = r->taken, n = (uint32_t)1 << sp->K;
    const int end = pk_in_exhausted(r);
    const unsigned D = sp->D;

    if (r->cfg.closed && r->fast && r->out_left == 0u)
        return -1;
    if (sp->ph >= PH_PASS) { /* short stroke: its points as they are */
        uint32_t i = sp->ph - PH_PASS;
        if (sp->ph == PH_DONE || i >= T)
            return -1;
        run_point(r, pt(r, i));
        sp->ph++;
        start_run(r, 1);
        return 1;
    }
#if PK_SPAN_CLAMPED
    if (is_clamped(r)) {
        switch (sp->ph) {
        case PH_START:
            if (T < 1u)
                return end ? -1 : 0;
            if (end && T <= 2u) { /* 1 or 2 points: as they are */
                sp->ph = PH_PASS;
                return span_try(r);
            }
            run_point(r, pt(r, 0));
            sp->ph = D == 3u ? PH_SP1 : PH_FIRST;
            start_run(r, 1);
            return 1;
#if PK_SPAN_DMAX >= 3
        case PH_SP1:
            if (T < 3u) {
                if (!end)
                    return 0;
                sp->ph = T == 2u ? PH_PASS + 1 : PH_DONE; /* 2 points: P1 as it is */
                return span_try(r);
            }
            run_lerp(r, pt(r, 0), pt(r, 1));
            sp->ph = PH_FIRST;
            start_run(r, 1);
            return 1;
#endif
        case PH_FIRST: {
            if (T < 2u * D && !end)
                return 0;
            if (T < 3u) { /* ended at 2 points (D = 2): P1 as it is */
                sp->ph = T == 2u ? PH_PASS + 1 : PH_DONE;
                return span_try(r);
            }
            if (D == 3u && T == 3u) {
                /* 3 points: the first level is the clamped quadratic (P0, M0,
                 * M1, P2), the others the cubic on those 4 points: continue
                 * as a 4-point cubic stroke of depth K - 1. Its own F would
                 * be 3K - 2; the points are stored times 8 (integers with 3
                 * fraction bits) so that its values keep the stroke's
                 * F = 3K + 1 (the limit stage combines them with the ones
                 * already given). Outputs 0 and 1 are already right:
                 * (1 - 2h) P0 + 2h M0 = (1 - h) P0 + h P1. */
                pk_um_t q[4][PK_AXES];
                for (unsigned a = 0; a < PK_AXES; a++) {
                    q[0][a] = 8 * pt(r, 0)[a];
                    q[1][a] = 4 * (pt(r, 0)[a] + pt(r, 1)[a]);
                    q[2][a] = 4 * (pt(r, 1)[a] + pt(r, 2)[a]);
                    q[3][a] = 8 * pt(r, 2)[a];
                }
                for (unsigned i = 0; i < 4u; i++)
                    for (unsigned a = 0; a < PK_AXES; a++)
                        sp->w[i][a] = q[i][a];
                r->taken = 4;
                sp->K = (uint8_t)(sp->K - 1u);
                sp->g = (uint8_t)(sp->g + 3u);
                return span_try(r);
            }
            uint32_t L = end ? T - sp->D : 2u * D; /* L >= D when not known */
            first_state_clamped(r, L);
            if (L == 1u)
                set_top_clamped(r, 0, 0, 0);
            else
                set_top_clamped(r, 0, 0, L - 1u < sp->D - 1u ? L - 1u : sp->D - 1u);
            sp->blk = 0;
            sp->ph = PH_SPANS;
            /* span 0 runs from j = D - 1 to n - 1, or to n if it is the last */
            uint32_t len = n - (sp->D - 1u) + (L == 1u ? 1u : 0u);
            start_run(r, len);
            return 1;
        }
        case PH_SPANS: {
            /* differences of indices, so that they survive wrapping */
            uint32_t s = sp->blk + 1u, ahead = T - s;
            if (end && ahead <= sp->D) { /* s = L: the right specials */
                sp->ph = PH_RIGHT;
                return span_try(r);
            }
            if (ahead < 2u * sp->D && !end)
                return 0;
            uint32_t rest = end ? ahead - sp->D - 1u : sp->D - 1u; /* L - 1 - s */
            uint32_t b = rest < sp->D - 1u ? rest : sp->D - 1u;
            uint32_t a = sp->lft + 1u < sp->D - 1u ? sp->lft + 1u : sp->D - 1u;
            if (a == sp->D - 1u && b == sp->D - 1u)
                set_top_uniform(r, s);
            else
                set_top_clamped(r, s, a, b);
            sp->blk = s;
            if (sp->lft < 3u)
                sp->lft++;
            start_run(r, b == 0u ? n + 1u : n);
            return 1;
        }
        case PH_RIGHT: /* j = nL + 1: (1-h) P(m-1) + h P(m-2) (cubic), then P(m-1) */
#if PK_SPAN_DMAX >= 3
            if (sp->D == 3u) {
                run_lerp(r, pt(r, T - 1u), pt(r, T - 2u));
                sp->ph = PH_RIGHT + 1;
                start_run(r, 1);
                return 1;
            }
#endif
            /* fall through */
        case PH_RIGHT + 1:
            run_point(r, pt(r, T - 1u));
            sp->ph = PH_DONE;
            start_run(r, 1);
            return 1;
        default:
            return -1;
        }
    }
#endif
#if PK_SPAN_PLAIN
    /* no end rule, closed, and degree 1. Span s is released once P(s + D + 1)
     * is in (one span per push; an open stroke that ends at 2 points stays
     * as it is), or at the end once its points are. */
    if (sp->ph == PH_START || sp->ph == PH_SPANS) {
        uint32_t s = sp->ph == PH_START ? 0u : sp->blk + 1u;
        if (sp->ph == PH_START && end && !r->cfg.closed && T <= 2u) {
            sp->ph = PH_PASS;
            return span_try(r);
        }
        if (T - s >= D + 2u || (end && T - s >= D + 1u)) {
            if (sp->ph == PH_START)
                first_state_plain(r);
            set_top_uniform(r, s);
            sp->blk = s;
            sp->ph = PH_SPANS;
            start_run(r, n);
            return 1;
        }
        if (!end)
            return 0;
        if (sp->ph == PH_SPANS) { /* the last span's D further points */
            sp->ph = PH_DONE;
            start_run(r, D);
            return 1;
        }
#if PK_SPAN_DMAX >= 3
        if (T == 3u && D == 3u) { /* three points stay three at every level: span 0, P3 absent */
            first_state_plain(r);
            for (unsigned a = 0; a < PK_AXES; a++)
                sp->s[3][a] = 0;
            sp->ph = PH_DONE;
            start_run(r, D);
            return 1;
        }
#endif
        sp->ph = PH_PASS; /* closed: 0 points */
        return span_try(r);
    }
#endif
    (void)n;
    (void)D;
    return -1;
}

int pk_span_refill(struct pk_refine *r)
{
    struct pk_span *sp = &r->e.sp;
    while (sp->rem == 0u) {
        /* the hot case first: the next plain interior span, whose points
         * and lookahead are taken or waiting in the slot (no end in sight,
         * nothing to clip) */
        if (sp->ph == PH_SPANS && !(r->fast && r->cfg.closed)) {
            uint32_t s = sp->blk + 1u, D = sp->D, ahead = r->taken - s;
            int clamped = is_clamped(r);
            uint32_t need = clamped ? 2u * D : D + 2u;
            if (ahead < need && !r->in_full && !r->finishing)
                return PK_SRC_NEED; /* waiting for the next point: nothing else can move */
            if (ahead + r->in_full >= need && (!clamped || sp->lft + 1u >= D - 1u)) {
                if (ahead < need)
                    take(r);
                set_top_uniform(r, s);
                sp->blk = s;
                if (sp->lft < 3u)
                    sp->lft++;
                sp->rem = (uint16_t)(1u << sp->K);
                return PK_SRC_OK;
            }
        }
        int st = span_try(r);
        if (st > 0)
            continue;
        if (st < 0)
            return PK_SRC_END;
        if (!pk_in_ready(r))
            return PK_SRC_NEED;
        take(r);
    }
    return PK_SRC_OK;
}

static void step(struct pk_span *sp, unsigned dims)
{
    for (unsigned a = 0; a < dims; a++)
        for (unsigned d = 0; d < sp->D; d++)
            sp->s[d][a] += sp->s[d + 1u][a];
}

int pk_span_next(struct pk_refine *r, pk_umf_t v[PK_AXES])
{
    struct pk_span *sp = &r->e.sp;
    int st = pk_span_refill(r);
    if (st != PK_SRC_OK)
        return st;
    sp->rem--;
    for (unsigned a = 0; a < PK_AXES; a++)
        v[a] = sp->s[0][a];
    step(sp, PK_AXES);
    return PK_SRC_OK;
}

/* ---- the block pull's loop --------------------------------------------------
 * Scalar: round, step, per point. Where the compiler has SIMD vectors (GNU C
 * vector extensions on SSE2 or NEON) and the run's values fit 32 bits
 * (Chaikin to depth 5: F <= 10), four consecutive points are computed at
 * once: lane (t, a) holds V(j + t) of axis a and steps by the 4-step forward
 * differences of V(j + t), exact integers too. The lanes add modulo 2^32
 * (unsigned), which still gives every emitted value exactly because its
 * true value fits; afterwards the scalar state jumps ahead by the same
 * number of points in closed form.
 *
 * The loop around it (pk_span_pull_block) matters as much at depth 5, where
 * a span is only 32 points: a stream fed point by point asks twice per push
 * (one span, then "need input"), so the second answer is given before any
 * set-up, the next interior span is set up inline (the refill's hot case),
 * and open Chaikin on 2 axes has a loop of its own (pull_block_xy) whose
 * lanes are built by shifts and adds. Measured by callgrind on bench_refine
 * (1e4 points, depth 5): 26.9 -> 17.3 instructions per output point, input
 * generation and the caller's loop included. */

static PK_NOINLINE uint32_t emit_scalar(struct pk_span *sp, pk_um_t *p, uint32_t c, unsigned dims, unsigned f)
{
    const pk_umf_t half = (pk_umf_t)1 << (f - 1u);
    pk_umf_t(*s)[PK_AXES] = sp->s;
    /* the common cases with the state in registers */
#if PK_SPAN_DMAX >= 2
    if (sp->D == 2u && dims == 2u) {
        pk_umf_t x0 = s[0][0], x1 = s[1][0], x2 = s[2][0];
        pk_umf_t y0 = s[0][1], y1 = s[1][1], y2 = s[2][1];
        for (uint32_t i = 0; i < c; i++) {
            p[2 * i] = pk_umf_round(x0, f, half);
            p[2 * i + 1] = pk_umf_round(y0, f, half);
            x0 += x1;
            x1 += x2;
            y0 += y1;
            y1 += y2;
        }
        s[0][0] = x0;
        s[1][0] = x1;
        s[0][1] = y0;
        s[1][1] = y1;
        return c;
    }
#endif
#if PK_SPAN_DMAX >= 3
    if (sp->D == 3u && dims == 2u) {
        pk_umf_t x0 = s[0][0], x1 = s[1][0], x2 = s[2][0], x3 = s[3][0];
        pk_umf_t y0 = s[0][1], y1 = s[1][1], y2 = s[2][1], y3 = s[3][1];
        for (uint32_t i = 0; i < c; i++) {
            p[2 * i] = pk_umf_round(x0, f, half);
            p[2 * i + 1] = pk_umf_round(y0, f, half);
            x0 += x1;
            x1 += x2;
            x2 += x3;
            y0 += y1;
            y1 += y2;
            y2 += y3;
        }
        s[0][0] = x0;
        s[1][0] = x1;
        s[2][0] = x2;
        s[0][1] = y0;
        s[1][1] = y1;
        s[2][1] = y2;
        return c;
    }
#endif
    for (uint32_t i = 0; i < c; i++) {
        for (unsigned a = 0; a < dims; a++)
            p[(size_t)i * dims + a] = pk_umf_round(s[0][a], f, half);
        step(sp, dims);
    }
    return c;
}

#if defined(__GNUC__) && (defined(__SSE2__) || defined(__ARM_NEON)) && !defined(PK_NO_SIMD) && \
    PK_SPAN_DMAX >= 2
#define memcpy __builtin_memcpy /* GNU C here anyway; no libc header in firmware/ */


typedef uint32_t pk_v4u __attribute__((vector_size(16)));
typedef int32_t pk_v4s __attribute__((vector_size(16)));

/* Chaikin (D = 2), four points per step, dims vectors of lanes (t, a) with
 * t = l / dims, a = l % dims: V(j + t) = V + t Δ + C(t,2) Δ², its 4-step
 * difference E(j + t) = 4 Δ + (4t + 6) Δ², which grows by G = 16 Δ². */
static PK_NOINLINE uint32_t emit_lanes2(struct pk_span *sp, pk_um_t *p, uint32_t c, unsigned dims, unsigned f)
{
    const uint32_t iters = c / 4u, k = 4u * iters;
    const uint32_t h = (uint32_t)1 << (f - 1u);
    const pk_v4u hv = { h, h, h, h };
    pk_v4u V0, V1, V2, E0, E1, E2, G0, G1, G2;
    if (dims == 2u) {
        /* lanes (t, a) = (0,x) (0,y) (1,x) (1,y) | (2,x) (2,y) (3,x) (3,y) */
        const uint32_t vx = (uint32_t)sp->s[0][0], vy = (uint32_t)sp->s[0][1];
        const uint32_t ax = (uint32_t)sp->s[1][0], ay = (uint32_t)sp->s[1][1];
        const uint32_t bx = (uint32_t)sp->s[2][0], by = (uint32_t)sp->s[2][1];
        const pk_v4u B = { vx, vy, vx, vy }, A = { ax, ay, ax, ay }, C = { bx, by, bx, by };
        const pk_v4u t01 = { 0, 0, 1, 1 }, t23 = { 2, 2, 3, 3 }, c23 = { 1, 1, 3, 3 };
        const pk_v4u e01 = { 6, 6, 10, 10 }, e23 = { 14, 14, 18, 18 };
        V0 = B + t01 * A;
        V1 = B + t23 * A + c23 * C;
        E0 = 4u * A + e01 * C;
        E1 = 4u * A + e23 * C;
        G0 = 16u * C;
        for (uint32_t i = 0; i < iters; i++, p += 8) {
            pk_v4s o0 = (pk_v4s)(V0 + hv + (pk_v4u)((pk_v4s)V0 >> 31)) >> (int)f;
            pk_v4s o1 = (pk_v4s)(V1 + hv + (pk_v4u)((pk_v4s)V1 >> 31)) >> (int)f;
            memcpy(p, &o0, 16);
            memcpy(p + 4, &o1, 16);
            V0 += E0;
            V1 += E1;
            E0 += G0;
            E1 += G0;
        }
    } else {
        uint32_t lv[12] = { 0 }, le[12] = { 0 }, lg[12] = { 0 };
        for (unsigned a = 0; a < dims; a++) {
            pk_umf_t V = sp->s[0][a], d1 = sp->s[1][a], d2 = sp->s[2][a], e = 4 * d1 + 6 * d2;
            /* t = 0..3: V(j + t) and its 4-step difference */
            lv[a] = (uint32_t)V;
            lv[dims + a] = (uint32_t)(V + d1);
            lv[2 * dims + a] = (uint32_t)(V + 2 * d1 + d2);
            lv[3 * dims + a] = (uint32_t)(V + 3 * d1 + 3 * d2);
            le[a] = (uint32_t)e;
            le[dims + a] = (uint32_t)(e + 4 * d2);
            le[2 * dims + a] = (uint32_t)(e + 8 * d2);
            le[3 * dims + a] = (uint32_t)(e + 12 * d2);
            for (unsigned t = 0; t < 4u; t++)
                lg[t * dims + a] = (uint32_t)(16 * d2);
        }
        memcpy(&V0, lv, 16);
        memcpy(&V1, lv + 4, 16);
        memcpy(&V2, lv + 8, 16);
        memcpy(&E0, le, 16);
        memcpy(&E1, le + 4, 16);
        memcpy(&E2, le + 8, 16);
        memcpy(&G0, lg, 16);
        memcpy(&G1, lg + 4, 16);
        memcpy(&G2, lg + 8, 16);
        for (uint32_t i = 0; i < iters; i++, p += 12) {
            pk_v4s o0 = (pk_v4s)(V0 + hv + (pk_v4u)((pk_v4s)V0 >> 31)) >> (int)f;
            pk_v4s o1 = (pk_v4s)(V1 + hv + (pk_v4u)((pk_v4s)V1 >> 31)) >> (int)f;
            pk_v4s o2 = (pk_v4s)(V2 + hv + (pk_v4u)((pk_v4s)V2 >> 31)) >> (int)f;
            memcpy(p, &o0, 16);
            memcpy(p + 4, &o1, 16);
            memcpy(p + 8, &o2, 16);
            V0 += E0;
            V1 += E1;
            V2 += E2;
            E0 += G0;
            E1 += G1;
            E2 += G2;
        }
    }
    /* the scalar state k points on: V + k Δ + C(k,2) Δ², Δ + k Δ² */
    for (unsigned a = 0; a < dims; a++) {
        pk_umf_t d1 = sp->s[1][a], d2 = sp->s[2][a];
        sp->s[0][a] += (pk_umf_t)k * d1 + (pk_umf_t)((uint64_t)k * (k - 1u) / 2u) * d2;
        sp->s[1][a] = d1 + (pk_umf_t)k * d2;
    }
    return k;
}
#undef memcpy
#define PK_SPAN_LANES 1
#else
#define PK_SPAN_LANES 0
#endif

#if PK_SPAN_LANES
/* Chaikin on 2 axes (the hot case), four points per step as emit_lanes2,
 * with the lanes set up by scalar additions (SSE2 has no 32-bit vector
 * multiply: emit_lanes2's products cost more than a 32-point span's loop)
 * and c a multiple of 4. */
/* Four points (x, y): round, store, step (lanes hold W = V + h). */
static PK_INLINE void lanes_step(pk_v4s *W0, pk_v4s *W1, pk_v4u *E0, pk_v4u *E1, pk_v4u G, pk_v4s hs, unsigned f,
                                 pk_um_t *p)
{
    pk_v4s o0 = (*W0 + (pk_v4s)(hs > *W0)) >> (int)f;
    pk_v4s o1 = (*W1 + (pk_v4s)(hs > *W1)) >> (int)f;
    __builtin_memcpy(p, &o0, 16);
    __builtin_memcpy(p + 4, &o1, 16);
    *W0 = (pk_v4s)((pk_v4u)*W0 + *E0);
    *W1 = (pk_v4s)((pk_v4u)*W1 + *E1);
    *E0 += G;
    *E1 += G;
}

static PK_INLINE void emit_lanes_xy(struct pk_span *sp, pk_um_t *p, uint32_t c, unsigned f)
{
    const uint32_t h = (uint32_t)1 << (f - 1u);
    const pk_v4u hv = { h, h, h, h }, hi = { 0, 0, ~0u, ~0u };
    /* B, A, C: V, Δ, Δ² of x and y in lanes (x, y, x, y), low 32 bits */
#if PK_UMF_BITS == 64 && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
    pk_v4u B, A, C;
    __builtin_memcpy(&B, &sp->s[0][0], 16); /* x and y: two int64 */
    __builtin_memcpy(&A, &sp->s[1][0], 16);
    __builtin_memcpy(&C, &sp->s[2][0], 16);
    /* the low words (lanes 0 and 2) twice: x y x y */
#if defined(__clang__)
    B = __builtin_shufflevector(B, B, 0, 2, 0, 2);
    A = __builtin_shufflevector(A, A, 0, 2, 0, 2);
    C = __builtin_shufflevector(C, C, 0, 2, 0, 2);
#else
    const pk_v4u lo = { 0, 2, 0, 2 };
    B = __builtin_shuffle(B, lo);
    A = __builtin_shuffle(A, lo);
    C = __builtin_shuffle(C, lo);
#endif
#else
    const uint32_t vx = (uint32_t)sp->s[0][0], vy = (uint32_t)sp->s[0][1];
    const uint32_t ax = (uint32_t)sp->s[1][0], ay = (uint32_t)sp->s[1][1];
    const uint32_t bx = (uint32_t)sp->s[2][0], by = (uint32_t)sp->s[2][1];
    const pk_v4u B = { vx, vy, vx, vy }, A = { ax, ay, ax, ay }, C = { bx, by, bx, by };
#endif
    /* V(j + t) = V + t Δ + C(t,2) Δ², t = 0..3: V0 = (V, V + Δ), V1 = V0 +
     * (2Δ + Δ², 2Δ + 3Δ²); E(j + t) = 4 Δ + (4t + 6) Δ²: E0 = (4Δ + 6Δ², +
     * 4Δ²), E1 = E0 + 8Δ²; G = 16 Δ² (shifts and adds: SSE2 has no 32-bit
     * vector multiply) */
    const pk_v4u Ch = C & hi;
    pk_v4u V0 = B + (A & hi);
    pk_v4u V1 = V0 + (A << 1) + C + (Ch << 1);
    pk_v4u E0 = (A << 2) + (C << 2) + (C << 1) + (Ch << 2);
    pk_v4u E1 = E0 + (C << 3);
    const pk_v4u G = C << 4;
    /* The lanes hold W = V + h, so that rounding (ties away from zero) is
     * (W - [V < 0]) >> f, and V < 0 is h > W (W does not wrap: |V| < 2^31 - h) */
    const pk_v4s hs = (pk_v4s)hv;
    pk_v4s W0 = (pk_v4s)(V0 + hv), W1 = (pk_v4s)(V1 + hv);
    /* two 4-point steps per iteration (c / 4 odd: one first) */
    pk_um_t *end = p + 2u * c;
    if ((c & 4u) != 0u) {
        lanes_step(&W0, &W1, &E0, &E1, G, hs, f, p);
        p += 8;
    }
    for (; p != end; p += 16) {
        lanes_step(&W0, &W1, &E0, &E1, G, hs, f, p);
        lanes_step(&W0, &W1, &E0, &E1, G, hs, f, p + 8);
    }
    /* the scalar state c points on: V + c Δ + C(c,2) Δ², Δ + c Δ² */
    for (unsigned a = 0; a < 2u; a++) {
        pk_umf_t d1 = sp->s[1][a], d2 = sp->s[2][a];
        sp->s[0][a] += (pk_umf_t)c * d1 + (pk_umf_t)(c * (c - 1u) / 2u) * d2;
        sp->s[1][a] = d1 + (pk_umf_t)c * d2;
    }
}
#endif

/* Up to max points of the current run (rem > 0); returns the count. */
static PK_INLINE uint32_t emit_block(struct pk_span *sp, pk_um_t *p, uint32_t max, unsigned dims, unsigned f)
{
    uint32_t c = sp->rem < max ? sp->rem : max, done = 0;
#if PK_SPAN_LANES
    if (sp->D == 2u && f <= 10u && c >= 8u) {
        if (dims == 2u) {
            done = c & ~3u;
            emit_lanes_xy(sp, p, done, f);
        } else {
            done = emit_lanes2(sp, p, c, dims, f);
        }
    }
#endif
    if (done < c)
        done += emit_scalar(sp, p + (size_t)done * dims, c - done, dims, f);
    sp->rem = (uint16_t)(sp->rem - done);
    return done;
}

static int block_status(struct pk_refine *r, uint32_t k, int st);

static PK_NOINLINE int pull_block_run(struct pk_refine *r, pk_um_t *p, uint32_t max, uint32_t *got)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned dims = r->cfg.dims, f = r->F;
    /* Chaikin, open: the next interior span is the refill's hot case for
     * either rule (2D = D + 2 = 4 points ahead), taken here without a call */
    const int hot2 = PK_SPAN_DMAX >= 2 && sp->D == 2u && !r->cfg.closed;
    uint32_t k = 0;
    int st = PK_SRC_OK;
    while (k < max) {
        if (sp->rem == 0u) {
            uint32_t s = sp->blk + 1u, ahead = r->taken - s;
            if (hot2 && sp->ph == PH_SPANS && ahead + r->in_full >= 4u) {
                if (ahead < 4u)
                    take(r);
                if (dims == 2u) { /* Δ² = Q0 - 2 Q1 + Q2 (axes beyond dims hold 0) */
                    const pk_um_t *q0 = pt(r, s), *q1 = pt(r, s + 1u), *q2 = pt(r, s + 2u);
                    sp->s[2][0] = ((pk_umf_t)q0[0] - q1[0]) + ((pk_umf_t)q2[0] - q1[0]);
                    sp->s[2][1] = ((pk_umf_t)q0[1] - q1[1]) + ((pk_umf_t)q2[1] - q1[1]);
                } else {
#if PK_SPAN_DMAX >= 2
                    set_top2(r, s, 1, 1);
#endif
                }
                sp->blk = s;
                if (sp->lft < 3u)
                    sp->lft++;
                sp->rem = (uint16_t)(1u << sp->K);
            } else if (hot2 && sp->ph == PH_SPANS && !r->in_full && !r->finishing) {
                st = PK_SRC_NEED;
                break;
            } else if ((st = pk_span_refill(r)) != PK_SRC_OK) {
                break;
            }
        }
        k += emit_block(sp, p + (size_t)k * dims, max - k, dims, f);
    }
    *got = k;
    return block_status(r, k, st);
}

/* The answer pk_refine_pull_block gives for what a pull loop has found. */
static int block_status(struct pk_refine *r, uint32_t k, int st)
{
    if (k > 0u || st == PK_SRC_OK)
        return PK_OK;
    if (st == PK_SRC_END)
        pk_refine_reset(r);
    return st;
}

#if PK_SPAN_LANES
/* The slot's point into the ring (the refill's hot case: it is there). */
static PK_INLINE void take_slot(struct pk_refine *r)
{
    pk_um_t *w = r->e.sp.w[r->taken & (PK_SPAN_WIN - 1u)];
    for (unsigned a = 0; a < PK_AXES; a++)
        w[a] = PK_UMF_BITS == 32 ? (pk_um_t)((uint32_t)r->in[a] << r->e.sp.g) : r->in[a];
    r->in_full = 0;
    r->taken++;
}

/* The block pull of open Chaikin on 2 axes with F <= 10 (the motion core's
 * case, and the benchmark's): pull_block_run's loop with its hot refill and
 * the lanes written out for this case alone, so that a span costs its
 * points' stores and little else. */
static PK_NOINLINE int pull_block_xy(struct pk_refine *r, pk_um_t *p, uint32_t max, uint32_t *got)
{
    struct pk_span *sp = &r->e.sp;
    const unsigned f = r->F;
    uint32_t k = 0;
    int st = PK_SRC_OK;
    while (k < max) {
        if (sp->rem == 0u) {
            uint32_t s = sp->blk + 1u, ahead = r->taken - s;
            if (sp->ph == PH_SPANS && ahead + r->in_full >= 4u) { /* as pull_block_run's hot case */
                if (ahead < 4u)
                    take_slot(r);
                const pk_um_t *q0 = pt(r, s), *q1 = pt(r, s + 1u), *q2 = pt(r, s + 2u);
                sp->s[2][0] = ((pk_umf_t)q0[0] - q1[0]) + ((pk_umf_t)q2[0] - q1[0]);
                sp->s[2][1] = ((pk_umf_t)q0[1] - q1[1]) + ((pk_umf_t)q2[1] - q1[1]);
                sp->blk = s;
                if (sp->lft < 3u)
                    sp->lft++;
                sp->rem = (uint16_t)(1u << sp->K);
            } else if (sp->ph == PH_SPANS && !r->in_full && !r->finishing) {
                st = PK_SRC_NEED; /* the span is out: nothing until the next push */
                break;
            } else if ((st = pk_span_refill(r)) != PK_SRC_OK) {
                break;
            }
        }
        uint32_t c = sp->rem < max - k ? sp->rem : max - k, c4 = c >= 8u ? c & ~3u : 0u;
        if (c4 != 0u)
            emit_lanes_xy(sp, p + 2u * k, c4, f);
        if (c4 < c)
            emit_scalar(sp, p + 2u * (k + c4), c - c4, 2u, f);
        sp->rem = (uint16_t)(sp->rem - c);
        k += c;
    }
    *got = k;
    return block_status(r, k, st);
}
#endif

int pk_span_pull_block(struct pk_refine *r, pk_um_t *p, uint32_t max, uint32_t *got)
{
    const struct pk_span *sp = &r->e.sp;
    /* The answer to every second call of a Chaikin stream fed point by
     * point, before any set-up: nothing until the next push (what
     * pull_block_run's hot case would find). */
    if (sp->D == 2u && !r->cfg.closed) {
        if (sp->rem == 0u && !r->in_full && !r->finishing && sp->ph == PH_SPANS &&
            r->taken - (sp->blk + 1u) < 4u && max != 0u) {
            *got = 0;
            return PK_NEED_INPUT;
        }
#if PK_SPAN_LANES
        if (r->cfg.dims == 2u && r->F <= 10u)
            return pull_block_xy(r, p, max, got);
#endif
    }
    return pull_block_run(r, p, max, got);
}

#endif
