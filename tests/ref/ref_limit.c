/*
 * ref_limit.c — the limit/tangent stage of the refinement kernel.
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
 * ref_masks.c (see the derivation there). Right-end masks are the mirror images
 * of the left-end ones: same weights, reversed polygon, tangent negated.
 *
 * Streaming: an anchor is released as soon as all points of its stencil have
 * arrived and enough points follow it to be sure it is not one of the last
 * `nend` anchors; the rest are released when the stroke finishes. The window
 * holds REF_LWIN points, and setup rejects a rule that would need more.
 *
 * Rounding: the mask sum is exact in int64; the position is rounded once,
 * from Q.8 µm times the mask denominator to whole µm.
 */
#include "ref_masks.h"
#include "ref_refine_internal.h"

#include <stddef.h>

static const struct ref_limit_rule *rule_of(const struct ref_refine *r)
{
    return (const struct ref_limit_rule *)r->lim_rule;
}

static int mask_last(const struct ref_mask *m) { return m->first + (int)m->len - 1; }

/* Largest "last offset" over the masks an anchor may use before the end is
 * known (uniform and left-end), and smallest first offset. */
static void rule_reach(const struct ref_limit_rule *ru, int *hi, int *lo)
{
    *hi = mask_last(&ru->pos_uniform);
    *lo = ru->pos_uniform.first;
    if (mask_last(&ru->tan_uniform) > *hi)
        *hi = mask_last(&ru->tan_uniform);
    if (ru->tan_uniform.first < *lo)
        *lo = ru->tan_uniform.first;
    for (unsigned d = 0; d < ru->nend && d < 4u; d++) {
        int h1 = mask_last(&ru->pos_end[d]);
        int h2 = mask_last(&ru->tan_end[d]);
        if (h1 > *hi)
            *hi = h1;
        if (h2 > *hi)
            *hi = h2;
    }
}

/* Lag at which an open-curve anchor may be released before the end is known. */
static int open_threshold(const struct ref_limit_rule *ru)
{
    int hi, lo;
    rule_reach(ru, &hi, &lo);
    int t = (int)ru->nend + (ru->edge_anchors ? 1 : 0);
    return hi > t ? hi : t;
}

int ref_limit_setup(struct ref_refine *r)
{
    unsigned ends = r->cfg.scheme == REF_SCHEME_DLG ? REF_ENDS_NONE : r->ends;
    const struct ref_limit_rule *ru =
        ref_limit_rule_get(r->cfg.scheme, r->D, r->cfg.closed, ends);
    if (ru == NULL)
        return REF_ENOTSUP;
    int hi, lo;
    rule_reach(ru, &hi, &lo);
    struct ref_limit_stage *ls = &r->lim;
    if (r->cfg.closed) {
        if (hi - lo > REF_LWIN - 1)
            return REF_ENOTSUP;
        /* closed: the replay must cover the stencil beyond the interior rule */
        if (hi - lo > (int)r->close_c)
            r->close_c = (uint8_t)(hi - lo);
        if (r->close_c > REF_CLOSE_MAX)
            return REF_ENOTSUP;
        ls->lag = (int8_t)(-1 + lo); /* first anchor: a0 = -lo */
        r->lim_thr = (uint8_t)hi;      /* a full stencil has arrived */
    } else {
        int thr = open_threshold(ru);
        if (thr - lo > REF_LWIN - 1 || ru->min_n > REF_LWIN)
            return REF_ENOTSUP;
        ls->lag = -1;
        r->lim_thr = (uint8_t)thr;     /* ... and the anchor is not an end one */
    }
    r->lim_rule = ru;
    return REF_OK;
}

static const ref_w8_t *lim_at(const struct ref_limit_stage *ls, int back)
{
    return ls->w[REF_LWIN - 1 - back];
}

/* Which masks anchor (front) uses; NULL pos = dropped. */
struct anchor_masks {
    const struct ref_mask *pos, *tan;
    int mirror; /* 1: right-end mask, points indexed from the end */
};

static int lim_fin(const struct ref_limit_stage *ls) { return (ls->st & LV_FIN) != 0u; }

/* Anchors still to give after finish, counting dropped ones. */
static int lim_remaining(const struct ref_refine *r)
{
    const struct ref_limit_stage *ls = &r->lim;
    const struct ref_limit_rule *ru = rule_of(r);
    if (r->cfg.closed) {
        int k = ls->lag - (int)r->lim_thr + 1;
        return k > 0 ? k : 0;
    }
    if (ls->n <= 2u)
        return (int)ls->n - (int)ls->a;
    return ls->lag + 1 - (ru->edge_anchors ? 1 : 0);
}

static void anchor_masks_of(const struct ref_refine *r, struct anchor_masks *am)
{
    const struct ref_limit_stage *ls = &r->lim;
    const struct ref_limit_rule *ru = rule_of(r);
    am->mirror = 0;
    if (r->cfg.closed) {
        am->pos = &ru->pos_uniform;
        am->tan = &ru->tan_uniform;
        return;
    }
    if (lim_fin(ls) && ls->n < ru->min_n) { /* short polygon: per-n masks */
        unsigned ends = r->cfg.scheme == REF_SCHEME_DLG ? REF_ENDS_NONE : r->ends;
        am->pos = ref_limit_small_get(r->cfg.scheme, r->D, ends, ls->n, ls->a, 0);
        am->tan = ref_limit_small_get(r->cfg.scheme, r->D, ends, ls->n, ls->a, 1);
        return;
    }
    if (ls->a < ru->nend) {
        unsigned d = ls->a;
        am->pos = (ru->drop_mask >> d) & 1u ? NULL : &ru->pos_end[d];
        am->tan = &ru->tan_end[d];
        return;
    }
    if (lim_fin(ls)) {
        int d = lim_remaining(r) - 1; /* distance of this anchor from the last one */
        if (d < (int)ru->nend) {
            am->pos = (ru->drop_mask >> d) & 1u ? NULL : &ru->pos_end[d];
            am->tan = &ru->tan_end[d];
            am->mirror = 1;
            return;
        }
    }
    am->pos = &ru->pos_uniform;
    am->tan = &ru->tan_uniform;
}

/* The front anchor may be emitted (or skipped, if dropped) now. */
static int lim_released(const struct ref_refine *r)
{
    const struct ref_limit_stage *ls = &r->lim;
    const struct ref_limit_rule *ru = rule_of(r);
    if (lim_fin(ls))
        return lim_remaining(r) > 0;
    if (r->cfg.closed)
        return ls->lag >= (int)r->lim_thr;
    return ls->n >= ru->min_n && ls->n >= 3u && ls->lag >= (int)r->lim_thr;
}

static void lim_advance(struct ref_limit_stage *ls)
{
    if (ls->a < 255u)
        ls->a++;
    ls->lag--;
}

/* Skip dropped anchors at the front, as far as they are decided. */
static void lim_settle(struct ref_refine *r)
{
    struct ref_limit_stage *ls = &r->lim;
    while (lim_released(r)) {
        if (lim_fin(ls) && !r->cfg.closed && ls->n <= 2u)
            return;
        struct anchor_masks am;
        anchor_masks_of(r, &am);
        if (am.pos != NULL)
            return;
        lim_advance(ls);
    }
}

int ref_limit_ready(const struct ref_refine *r) { return lim_released(r); }

int ref_limit_exhausted(const struct ref_refine *r)
{
    return lim_fin(&r->lim) && !lim_released(r);
}

void ref_limit_feed(struct ref_refine *r, const ref_w8_t *p)
{
    struct ref_limit_stage *ls = &r->lim;
    for (unsigned k = 0; k + 1u < REF_LWIN; k++)
        for (unsigned a = 0; a < r->cfg.dims; a++)
            ls->w[k][a] = ls->w[k + 1u][a];
    for (unsigned a = 0; a < r->cfg.dims; a++)
        ls->w[REF_LWIN - 1u][a] = p[a];
    if (ls->n < 255u)
        ls->n++;
    if (ls->lag < 100)
        ls->lag++;
    lim_settle(r);
}

void ref_limit_finish(struct ref_refine *r)
{
    r->lim.st |= LV_FIN;
    lim_settle(r);
}

void ref_unit_q30(const int64_t *d, unsigned dims, ref_q30_t *t)
{
    uint64_t mx = 0;
    for (unsigned a = 0; a < dims; a++) {
        uint64_t m = d[a] < 0 ? (uint64_t)0 - (uint64_t)d[a] : (uint64_t)d[a];
        if (m > mx)
            mx = m;
    }
    for (unsigned a = 0; a < dims; a++)
        t[a] = 0;
    if (mx == 0u)
        return;
    /* Scale so that the largest component lies in [2^29, 2^30): enough bits
     * for a direction good to ~1e-9 rad, and d^2 sums fit in uint64. */
    int sh = 0;
    while ((mx >> sh) >= ((uint64_t)1 << 30))
        sh++;
    int up = 0;
    while ((mx << up) < ((uint64_t)1 << 29))
        up++;
    int64_t v[REF_AXES];
    uint64_t ss = 0;
    for (unsigned a = 0; a < dims; a++) {
        v[a] = sh ? ref_rshift_round64(d[a], (unsigned)sh) : d[a] * ((int64_t)1 << up);
        ss += (uint64_t)(v[a] < 0 ? -v[a] : v[a]) * (uint64_t)(v[a] < 0 ? -v[a] : v[a]);
    }
    int64_t len = (int64_t)ref_isqrt64(ss);
    if (len == 0)
        return;
    for (unsigned a = 0; a < dims; a++)
        t[a] = (ref_q30_t)ref_div_round64(v[a] * ((int64_t)1 << 30), len);
}

static int is_pow2(int32_t x, unsigned *s)
{
    for (unsigned k = 0; k < 31u; k++)
        if (x == ((int32_t)1 << k)) {
            *s = k;
            return 1;
        }
    return 0;
}

/* Sum of mask m over the polygon at the front anchor. Left-end and uniform
 * masks index points from the anchor: back = lag - first - k. A right-end
 * (mirrored) mask for the anchor d places from the last one indexes the
 * reversed polygon, whose point j is the real point n-1-j, and at finish the
 * newest point is L(n-1): back = d + first + k. */
static void apply_mask(const struct ref_limit_stage *ls, const struct ref_mask *m, int mirror_d,
                       unsigned dims, int64_t *acc)
{
    for (unsigned a = 0; a < dims; a++)
        acc[a] = 0;
    for (unsigned k = 0; k < m->len; k++) {
        int back = mirror_d >= 0 ? mirror_d + m->first + (int)k : ls->lag - m->first - (int)k;
        const ref_w8_t *p = lim_at(ls, back);
        for (unsigned a = 0; a < dims; a++)
            acc[a] += (int64_t)m->w[k] * p[a];
    }
}

void ref_limit_emit(struct ref_refine *r, struct ref_refine_out *out)
{
    struct ref_limit_stage *ls = &r->lim;
    unsigned dims = r->cfg.dims;
    int64_t acc[REF_AXES];

    if (!r->cfg.closed && lim_fin(ls) && ls->n <= 2u) {
        /* 1 point: itself; 2 points: the straight stroke, tangent along it */
        const ref_w8_t *p = lim_at(ls, (int)ls->n - 1 - (int)ls->a);
        for (unsigned a = 0; a < dims; a++) {
            out->p[a] = ref_rshift_round32(p[a], REF_W8_SHIFT);
            acc[a] = ls->n == 2u ? (int64_t)lim_at(ls, 0)[a] - lim_at(ls, 1)[a] : 0;
        }
        if (r->cfg.tangents)
            ref_unit_q30(acc, dims, out->t);
        lim_advance(ls);
        return;
    }

    struct anchor_masks am;
    anchor_masks_of(r, &am);
    int md = am.mirror ? lim_remaining(r) - 1 : -1;
    apply_mask(ls, am.pos, md, dims, acc);
    unsigned s;
    if (is_pow2(am.pos->den, &s)) {
        for (unsigned a = 0; a < dims; a++)
            out->p[a] = (ref_um_t)ref_rshift_round64(acc[a], s + REF_W8_SHIFT);
    } else {
        int64_t den = (int64_t)am.pos->den << REF_W8_SHIFT;
        for (unsigned a = 0; a < dims; a++)
            out->p[a] = (ref_um_t)ref_div_round64(acc[a], den);
    }
    if (r->cfg.tangents && am.tan != NULL) {
        apply_mask(ls, am.tan, md, dims, acc);
        if (md >= 0)
            for (unsigned a = 0; a < dims; a++)
                acc[a] = -acc[a];
        ref_unit_q30(acc, dims, out->t);
    }
    lim_advance(ls);
    lim_settle(r);
}
