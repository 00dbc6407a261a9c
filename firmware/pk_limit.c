/*
 * pk_limit.c — the limit/tangent stage of the refinement kernel.
 *
 * After the last level, the control polygon L0..Ln-1 is still a polygon; the
 * curve the scheme converges to passes near it, not through it. This stage
 * replaces each "anchor" (a vertex for odd degree and DLG, an edge for even
 * degree) by the point the anchor converges to under infinite refinement,
 * and optionally the curve's unit tangent there. Both come from the
 * eigen-analysis of the local subdivision matrix: its left eigenvector for
 * eigenvalue 1 is the evaluation mask, the one for the subdominant eigenvalue
 * the tangent mask. Near the ends of open curves the end rules change the
 * local matrix, so the end anchors have masks of their own; those tables are
 * generated with exact arithmetic by tests/tools/derive_masks.py into
 * pk_masks.c (see the derivation there). Right-end masks are the mirror images
 * of the left-end ones: same weights, reversed polygon, tangent negated.
 *
 * Chaikin needs no tables, so its stage is written out: an anchor is an edge
 * of the level-K polygon, its limit point the edge's midpoint and its tangent
 * the edge itself; with clamped or replace ends the first and last anchors
 * are the stroke's end points, with the end edges' tangents. (These are the
 * table entries "chaikin ..." of pk_masks.h, which test_masks checks.)
 *
 * Streaming: an anchor is released as soon as all points of its stencil have
 * arrived and enough points follow it to be sure it is not one of the last
 * `nend` anchors; the rest are released when the stroke finishes. The window
 * holds PK_LWIN points, and setup rejects a rule that would need more.
 *
 * Exactness. The level-K points arrive exact (N / 2^F); a position is the
 * mask sum over them, formed exactly in int64 and rounded once to whole µm.
 * Where den * 2^(F + 22) would overflow (degrees 5..7 deep down) the points
 * first drop the excess fraction bits (pk_refine.h states the bound). A
 * tangent is formed from the exact edge vectors L(k+1) - L(k) (a tangent mask
 * sums to zero, so it is a combination of them), which stay small on dense
 * input: nothing is lost there to rounding.
 */
#include "pk_refine_internal.h"

#include <stddef.h>

#if PK_BUILD_LIMIT && !PK_CHAIKIN_ONLY /* (pk_refine_chaikin.c has its own) */

#if PK_LIMIT_TABLES
#include "pk_masks.h"

#endif

static const pk_umf_t *lim_at(const struct pk_limit_stage *ls, int back)
{
    return ls->w[PK_LWIN - 1 - back];
}

static int lim_fin(const struct pk_limit_stage *ls) { return (ls->st & LV_FIN) != 0u; }

static void lim_advance(struct pk_limit_stage *ls)
{
    if (ls->a < 255u)
        ls->a++;
    ls->lag--;
}

#if PK_LIMIT_TABLES
/* Index of the most significant set bit + 1 (0 for 0). */
static unsigned bits_of(uint64_t x)
{
    unsigned b = 0;
    while (x) {
        x >>= 1;
        b++;
    }
    return b;
}

static uint64_t mag64(int64_t x) { return x < 0 ? (uint64_t)0 - (uint64_t)x : (uint64_t)x; }
#endif

/* Round s / 2^F (s exact, F + sh fraction bits) to whole µm, ties away. */
static pk_um_t round_shift(int64_t s, unsigned f)
{
    return f ? (pk_um_t)pk_rshift_round64(s, f) : (pk_um_t)s;
}

/* ---- Chaikin, written out --------------------------------------------------- */

#if PK_LIMIT_TABLES
static int is_chaikin(const struct pk_refine *r) { return r->lim.rule == NULL; }
#endif

/* Anchor a (edge L(a) L(a+1)) may go: both points are in and, on an open
 * stroke, a further point shows it is not the last anchor (whose limit is
 * the end point) and the polygon has at least 3 points. */
static int ch_released(const struct pk_refine *r)
{
    const struct pk_limit_stage *ls = &r->lim;
    if (lim_fin(ls))
        return ls->n <= 2u ? ls->a < ls->n : ls->lag >= 1;
    if (r->cfg.closed || (r->ends == PK_ENDS_NONE && ls->n >= 3u))
        return ls->lag >= 1; /* no end anchors: only the 2-point rule waits */
    return ls->lag >= 2;
}

static void ch_emit(struct pk_refine *r, struct pk_refine_out *out)
{
    struct pk_limit_stage *ls = &r->lim;
    unsigned dims = r->cfg.dims;
    int64_t d[PK_AXES];
    const pk_umf_t *A, *B, *P = NULL;
    if (lim_fin(ls) && ls->n <= 2u) { /* 1 point: itself; 2: the straight stroke */
        A = lim_at(ls, (int)ls->n - 1);
        B = lim_at(ls, 0);
        P = lim_at(ls, (int)ls->n - 1 - (int)ls->a);
    } else {
        A = lim_at(ls, ls->lag);
        B = lim_at(ls, ls->lag - 1);
        if (!r->cfg.closed && r->ends != PK_ENDS_NONE) {
            if (ls->a == 0u)
                P = A; /* the stroke's first point */
            else if (lim_fin(ls) && ls->lag == 1)
                P = B; /* its last */
        }
    }
    for (unsigned a = 0; a < dims; a++) {
        out->p[a] = P ? pk_out_round(r, P[a]) : round_shift((int64_t)A[a] + B[a], r->F + 1u);
        d[a] = (int64_t)B[a] - A[a];
    }
    if (r->cfg.tangents)
        pk_unit_q30(d, dims, out->t);
    lim_advance(ls);
}

/* ---- table-driven ----------------------------------------------------------- */

#if PK_LIMIT_TABLES
static int mask_last(const struct pk_mask *m) { return m->first + (int)m->len - 1; }

/* Largest "last offset" over the masks an anchor may use before the end is
 * known (uniform and left-end), and smallest first offset. */
static void rule_reach(const struct pk_limit_stage *ls, int *hi, int *lo)
{
    struct pk_mask m;
    pk_limit_rule_mask(ls->rule, 0, &m);
    *hi = mask_last(&m);
    *lo = m.first;
    pk_limit_rule_mask(ls->rule, 1, &m);
    if (m.len && mask_last(&m) > *hi)
        *hi = mask_last(&m);
    if (m.len && m.first < *lo)
        *lo = m.first;
    for (unsigned d = 0; d < ls->nend && d < 4u; d++)
        for (unsigned w = 0; w < 2u; w++) {
            pk_limit_rule_mask(ls->rule, 2u + 4u * w + d, &m);
            if (m.len && mask_last(&m) > *hi)
                *hi = mask_last(&m);
        }
}

/* Anchors still to give after finish, counting dropped ones. */
static int lim_remaining(const struct pk_refine *r)
{
    const struct pk_limit_stage *ls = &r->lim;
    if (r->cfg.closed) {
        int k = ls->lag - (int)ls->thr + 1;
        return k > 0 ? k : 0;
    }
    if (ls->n <= 2u)
        return (int)ls->n - (int)ls->a;
    return ls->lag + 1 - (ls->edge ? 1 : 0);
}

/* Which masks the front anchor uses: 0 = dropped; mirror: right-end mask. */
static int anchor_masks(const struct pk_refine *r, struct pk_mask *pos, struct pk_mask *tan, int *mirror)
{
    const struct pk_limit_stage *ls = &r->lim;
    *mirror = 0;
    if (r->cfg.closed) {
        pk_limit_rule_mask(ls->rule, 0, pos);
        pk_limit_rule_mask(ls->rule, 1, tan);
        return 1;
    }
    if (lim_fin(ls) && ls->n < ls->min_n) { /* short polygon: per-n masks */
        unsigned ends = r->cfg.scheme == PK_SCHEME_DLG ? PK_ENDS_NONE : r->ends;
        if (!pk_limit_small_get(r->cfg.scheme, r->D, ends, ls->n, ls->a, 0, pos))
            return 0;
        if (!pk_limit_small_get(r->cfg.scheme, r->D, ends, ls->n, ls->a, 1, tan))
            tan->len = 0;
        return 1;
    }
    int d = -1;
    if (ls->a < ls->nend) {
        d = ls->a;
    } else if (lim_fin(ls)) {
        d = lim_remaining(r) - 1; /* distance of this anchor from the last one */
        if (d < (int)ls->nend)
            *mirror = 1;
        else
            d = -1;
    }
    if (d >= 0) {
        if ((ls->drop >> d) & 1u)
            return 0;
        pk_limit_rule_mask(ls->rule, 2u + (unsigned)d, pos);
        pk_limit_rule_mask(ls->rule, 6u + (unsigned)d, tan);
        return 1;
    }
    pk_limit_rule_mask(ls->rule, 0, pos);
    pk_limit_rule_mask(ls->rule, 1, tan);
    return 1;
}

/* The front anchor may be emitted (or skipped, if dropped) now. */
static int tab_released(const struct pk_refine *r)
{
    const struct pk_limit_stage *ls = &r->lim;
    if (lim_fin(ls))
        return lim_remaining(r) > 0;
    if (r->cfg.closed)
        return ls->lag >= (int)ls->thr;
    return ls->n >= ls->min_n && ls->n >= 3u && ls->lag >= (int)ls->thr;
}

/* Skip dropped anchors at the front, as far as they are decided. */
static void tab_settle(struct pk_refine *r)
{
    struct pk_limit_stage *ls = &r->lim;
    while (tab_released(r)) {
        if (lim_fin(ls) && !r->cfg.closed && ls->n <= 2u)
            return;
        struct pk_mask p, t;
        int mirror;
        if (anchor_masks(r, &p, &t, &mirror))
            return;
        lim_advance(ls);
    }
}

/* Polygon index k of mask m at the front anchor, as "back" from the newest
 * point. Left-end and uniform masks index points from the anchor: back =
 * lag - first - k. A right-end (mirrored) mask for the anchor md places from
 * the last one indexes the reversed polygon, whose point j is the real point
 * n-1-j, and at finish the newest point is L(n-1): back = md + first + k. */
static int mask_back(const struct pk_limit_stage *ls, const struct pk_mask *m, int md, unsigned k)
{
    return md >= 0 ? md + m->first + (int)k : ls->lag - m->first - (int)k;
}

static void tab_position(const struct pk_refine *r, const struct pk_mask *m, int md, pk_um_t *p)
{
    const struct pk_limit_stage *ls = &r->lim;
    unsigned dims = r->cfg.dims, F = r->F;
    /* |L| < 2^(22 + F) (DLG overshoots a little); keep den * that below 2^62 */
    uint64_t sabs = 0;
    for (unsigned k = 0; k < m->len; k++)
        sabs += mag64(pk_mask_w(m, k));
    unsigned need = 22u + F + bits_of(sabs), e = need > 62u ? need - 62u : 0u;
    int64_t acc[PK_AXES] = { 0 };
    for (unsigned k = 0; k < m->len; k++) {
        const pk_umf_t *L = lim_at(ls, mask_back(ls, m, md, k));
        int64_t w = pk_mask_w(m, k);
        for (unsigned a = 0; a < dims; a++)
            acc[a] += w * (e ? pk_rshift_round64(L[a], e) : (int64_t)L[a]);
    }
    unsigned f = F - e, s = 0;
    int pow2 = 0;
    for (s = 0; s < 31u; s++)
        if (m->den == ((int32_t)1 << s)) {
            pow2 = 1;
            break;
        }
    for (unsigned a = 0; a < dims; a++)
        p[a] = pow2 ? round_shift(acc[a], s + f)
                    : (pk_um_t)pk_div_round64(acc[a], (int64_t)m->den * ((int64_t)1 << f));
}

/* Tangents need differences of level-K points. A point is below
 * 2^(21 + F) in magnitude (PK_UM_MAX < 2^21 µm, F fraction bits), so the
 * difference of two fits int64 while F <= 41; the table schemes reach
 * F = D*K = 42 (degree 7, depth 6), where both points are halved first
 * (all alike: a tangent is a direction; 41 fraction bits remain). Chaikin
 * (written out, F = 2K + guard bits) never comes near. Finding K2. */
#define TAN_SHIFT(r) ((r)->F > 41u ? 1u : 0u)
static int64_t tan_diff(pk_umf_t b, pk_umf_t a, unsigned sh)
{
    return sh ? pk_rshift_round64(b, sh) - pk_rshift_round64(a, sh) : (int64_t)b - a;
}

/* sum_k w_k L_k = sum_k c_k (L(k+1) - L(k)), c_k = -(w_0 + ... + w_k). */
static void tab_tangent(const struct pk_refine *r, const struct pk_mask *m, int md, pk_q30_t *t)
{
    const struct pk_limit_stage *ls = &r->lim;
    unsigned dims = r->cfg.dims;
    int64_t d[PK_MASK_MAXLEN][PK_AXES], c[PK_MASK_MAXLEN];
    uint64_t dmax = 0, cabs = 0;
    int64_t run = 0;
    const unsigned sh = TAN_SHIFT(r);
    for (unsigned k = 0; k + 1u < m->len; k++) {
        const pk_umf_t *A = lim_at(ls, mask_back(ls, m, md, k));
        const pk_umf_t *B = lim_at(ls, mask_back(ls, m, md, k + 1u));
        run -= pk_mask_w(m, k);
        c[k] = run;
        cabs += mag64(run);
        for (unsigned a = 0; a < dims; a++) {
            d[k][a] = tan_diff(B[a], A[a], sh);
            if (mag64(d[k][a]) > dmax)
                dmax = mag64(d[k][a]);
        }
    }
    unsigned need = bits_of(dmax) + bits_of(cabs), e = need > 62u ? need - 62u : 0u;
    int64_t acc[PK_AXES] = { 0 };
    for (unsigned k = 0; k + 1u < m->len; k++)
        for (unsigned a = 0; a < dims; a++)
            acc[a] += c[k] * (e ? pk_rshift_round64(d[k][a], e) : d[k][a]);
    if (md >= 0)
        for (unsigned a = 0; a < dims; a++)
            acc[a] = -acc[a];
    pk_unit_q30(acc, dims, t);
}

static void tab_emit(struct pk_refine *r, struct pk_refine_out *out)
{
    struct pk_limit_stage *ls = &r->lim;
    unsigned dims = r->cfg.dims;
    if (!r->cfg.closed && lim_fin(ls) && ls->n <= 2u) {
        /* 1 point: itself; 2 points: the straight stroke, tangent along it */
        const pk_umf_t *p = lim_at(ls, (int)ls->n - 1 - (int)ls->a);
        int64_t d[PK_AXES];
        for (unsigned a = 0; a < dims; a++) {
            out->p[a] = pk_out_round(r, p[a]);
            d[a] = ls->n == 2u ? tan_diff(lim_at(ls, 0)[a], lim_at(ls, 1)[a], TAN_SHIFT(r)) : 0;
        }
        if (r->cfg.tangents)
            pk_unit_q30(d, dims, out->t);
        lim_advance(ls);
        return;
    }
    struct pk_mask pos, tan;
    int mirror;
    (void)anchor_masks(r, &pos, &tan, &mirror);
    int md = mirror ? lim_remaining(r) - 1 : -1;
    tab_position(r, &pos, md, out->p);
    if (r->cfg.tangents && tan.len != 0u)
        tab_tangent(r, &tan, md, out->t);
    lim_advance(ls);
    tab_settle(r);
}
#endif

/* ---- the stage ------------------------------------------------------------ */

int pk_limit_setup(struct pk_refine *r)
{
    struct pk_limit_stage *ls = &r->lim;
    ls->lag = -1;
    if (r->cfg.scheme == PK_SCHEME_BSPLINE && r->D == 2u) {
        ls->rule = NULL; /* Chaikin: written out */
        return PK_LWIN >= 3 ? PK_OK : PK_ENOTSUP;
    }
#if PK_LIMIT_TABLES
    unsigned ends = r->cfg.scheme == PK_SCHEME_DLG ? PK_ENDS_NONE : r->ends;
    const int32_t *ru = pk_limit_rule_get(r->cfg.scheme, r->D, r->cfg.closed, ends);
    if (ru == NULL)
        return PK_ENOTSUP;
    struct pk_rule_info info;
    pk_limit_rule_info(ru, &info);
    ls->rule = ru;
    ls->edge = info.edge_anchors;
    ls->nend = info.nend;
    ls->drop = info.drop_mask;
    ls->min_n = info.min_n;
    int hi, lo;
    rule_reach(ls, &hi, &lo);
    if (r->cfg.closed) {
        if (hi - lo > PK_LWIN - 1)
            return PK_ENOTSUP;
        /* closed: the replay must cover the stencil beyond the interior rule */
        if (hi - lo > (int)r->close_c)
            r->close_c = (uint8_t)(hi - lo);
        if (r->close_c > PK_CLOSE_MAX)
            return PK_ENOTSUP;
        ls->lag = (int8_t)(-1 + lo); /* first anchor: a0 = -lo */
        ls->thr = (uint8_t)hi;       /* a full stencil has arrived */
    } else {
        int t = (int)ls->nend + (ls->edge ? 1 : 0);
        int thr = hi > t ? hi : t;
        if (thr - lo > PK_LWIN - 1 || ls->min_n > PK_LWIN)
            return PK_ENOTSUP;
        ls->thr = (uint8_t)thr; /* ... and the anchor is not an end one */
    }
    return PK_OK;
#else
    return PK_ENOTSUP;
#endif
}

int pk_limit_ready(const struct pk_refine *r)
{
#if PK_LIMIT_TABLES
    if (!is_chaikin(r))
        return tab_released(r);
#endif
    return ch_released(r);
}

int pk_limit_exhausted(const struct pk_refine *r)
{
    return lim_fin(&r->lim) && !pk_limit_ready(r);
}

void pk_limit_feed(struct pk_refine *r, const pk_umf_t *p)
{
    struct pk_limit_stage *ls = &r->lim;
    for (unsigned k = 0; k + 1u < PK_LWIN; k++)
        for (unsigned a = 0; a < PK_AXES; a++)
            ls->w[k][a] = ls->w[k + 1u][a];
    for (unsigned a = 0; a < PK_AXES; a++)
        ls->w[PK_LWIN - 1u][a] = p[a];
    if (ls->n < 255u)
        ls->n++;
    if (ls->lag < 100)
        ls->lag++;
#if PK_LIMIT_TABLES
    if (!is_chaikin(r))
        tab_settle(r);
#endif
}

void pk_limit_finish(struct pk_refine *r)
{
    r->lim.st |= LV_FIN;
#if PK_LIMIT_TABLES
    if (!is_chaikin(r))
        tab_settle(r);
#endif
}

void pk_limit_emit(struct pk_refine *r, struct pk_refine_out *out)
{
#if PK_LIMIT_TABLES
    if (!is_chaikin(r)) {
        tab_emit(r, out);
        return;
    }
#endif
    ch_emit(r, out);
}

#endif /* PK_BUILD_LIMIT */
