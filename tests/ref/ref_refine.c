/*
 * ref_refine.c — the streaming subdivision kernel.
 *
 * WHY IT IS BUILT THIS WAY
 * ========================
 * A plotter's sender streams G-code line by line; a microcontroller cannot hold
 * the polyline, let alone 2^8 times its length. So the kernel is a cascade of
 * small, identical stages, one per level of refinement, each holding only the
 * last few points of its own input (a "window"), and it is driven from the
 * OUTPUT end: asking the last stage for a point makes it ask the stage above
 * only when it has nothing left to give. Work happens only when a point is
 * pulled, and a consumer that stops pulling (full motion queue) leaves every
 * stage exactly where it was. Nothing is buffered beyond the windows, so the
 * state is O(depth) and the per-point cost is O(depth) worst case, O(1)
 * amortised (a level-k point costs one mask evaluation; there are 2^(k-K) of
 * them per output point, summing to < 2).
 *
 *     push -> [slot] -> [level 0] -> [level 1] -> ... -> [level K-1] -> [limit] -> pull
 *                        window       window               window        window
 *
 * Lookahead. Open curves treat their last span differently (a clamped spline
 * ends on the last point; the replace rule swaps in the last point; a 2-point
 * stroke stays straight), so a stage must know whether its newest input is
 * the last one before it may release that span. It needs no storage for that:
 * the stage above either has a point ready (so more follows), or is finished
 * and drained (so this was the last), or must first be run — which the pull
 * loop below does. A stage in that state is "deferred".
 *
 * Closed curves. Every closed scheme here is stationary and local, so the
 * closed level-K polygon is a window of the open ("interior rule") refinement
 * of the periodic sequence P0..Pm-1, P0, P1, ..., Pc-1 (c = the rule's reach,
 * plus the limit stencil's). The kernel keeps the stroke's first c points (not
 * per level: once), replays them after the last point, and stops after
 * exactly 2^K * m outputs. The outputs are those of the closed scheme, rotated
 * to start where the first full stencil lies (for Chaikin that is Q0, as in
 * the usual statement of the scheme).
 *
 * Exactness. Points travel as ref_w8_t (µm in Q.8). Each output of a level is a
 * mask sum formed EXACTLY in integers, then divided by the mask's power of two
 * with a single round-to-nearest (ties away from zero) at 1/256 µm; the final
 * output is rounded once more to whole µm. The guard bits keep the level-wise
 * rounding far below the output LSB: with per-level error e_k <= 2^-9 µm and
 * every B-spline mask a convex combination (norm 1), the output is within
 * 0.5 + K * 2^-9 µm of the exact rational value (DLG's masks have norm 5/4
 * per level: 0.5 + 2^-9 * sum (5/4)^j, still < 0.6 µm at K = 8). For Chaikin
 * up to depth 4 and the cubic up to depth 2 all intermediate values are exact
 * (2 and 3 fractional bits per level fit in 8), so the output is the exactly
 * rounded rational: rounding happens once.
 * Ties-away-from-zero is odd-symmetric, so negating any coordinate of the
 * input negates the output bit for bit; the masks are palindromic and the end
 * rules mirror each other, so reversing the input reverses the output.
 *
 * Ranges. |input| <= REF_UM_MAX = 2^21 - 1 µm, so |w8| < 2^29. B-spline
 * masks are convex combinations, so every level stays inside that range; the
 * Chaikin fast path forms 3a + b in int32 (|3a + b| < 4 * 2^29 = 2^31), every
 * other mask sum is formed in int64. DLG overshoots the input hull: the
 * infinity norm of its composite subdivision matrix, computed exactly for
 * open (ghost points) and closed polygons of 3..8 points over 1..8 levels,
 * never exceeds 1.2517, so its values stay below 1.26 * 2^29 — inside int32
 * with room to spare — and its rounding error grows by at most that factor.
 */
#include "ref_refine.h"
#include "ref_refine_internal.h"

#include <stddef.h>

/* What each level does (chosen at init from scheme, degree, closed, ends). */
enum lv_kind {
    K_LR_INTERIOR,   /* B-spline, no end rule, no deferral (closed curves) */
    K_LR_NONE,       /* B-spline, open, end rule "none" */
    K_LR_REPLACE,    /* B-spline, open, end rule "replace" */
    K_CH_CLAMPED,    /* Chaikin, open, clamped (default) */
    K_CUBIC_CLAMPED, /* cubic B-spline, open, clamped */
    K_DLG_OPEN,      /* DLG with ghost points */
    K_DLG_INTERIOR   /* DLG on the periodic sequence (closed) */
};

/* Lane-Riesenfeld masks: output j uses P[floor(j/2) + r], r = 0..len-1, with
 * weights lr_w[D][j & 1][r] summing to 2^D. Derived from binomial(D, t)
 * applied to the split sequence s[2i] = s[2i+1] = P[i]. */
static const uint8_t lr_w[8][2][5] = {
    { { 1 }, { 1 } },                                   /* unused (D = 0) */
    { { 2, 0 }, { 1, 1 } },                             /* D=1: P, mid */
    { { 3, 1 }, { 1, 3 } },                             /* D=2: Q, R (Chaikin) */
    { { 4, 4, 0 }, { 1, 6, 1 } },                       /* D=3: edge, vertex */
    { { 5, 10, 1 }, { 1, 10, 5 } },                     /* D=4 */
    { { 6, 20, 6, 0 }, { 1, 15, 15, 1 } },              /* D=5 */
    { { 7, 35, 21, 1 }, { 1, 21, 35, 7 } },             /* D=6 */
    { { 8, 56, 56, 8, 0 }, { 1, 28, 70, 28, 1 } },      /* D=7 */
};

/* Window a degree-D level needs: ceil(D/2) + 1 points (DLG and the clamped
 * cubic: 4). */
static unsigned lr_window(unsigned D) { return (D + 1u) / 2u + 1u; }

static int32_t sat_inc8(uint8_t n) { return n < 255u ? n + 1 : 255; }

/* ---- small vector helpers (dims = r->cfg.dims) --------------------------- */

static void pt_copy(ref_w8_t *dst, const ref_w8_t *src, unsigned dims)
{
    dst[0] = src[0];
    dst[1] = src[1];
#if REF_AXES > 2
    if (dims > 2u)
        dst[2] = src[2];
#else
    (void)dims;
#endif
}

/* Point P_x where x = (newest index) - back; back = 0 is the newest input. */
static const ref_w8_t *lv_at(const struct ref_level *lv, unsigned back)
{
    return lv->w[REF_WIN - 1u - back];
}

/* out = round(sum_r w[r] * P(back0 - r)) / 2^s), back0 = how far back the
 * first weight's point is. Weights are signed. Sums in int64. */
static void lv_mask(const struct ref_level *lv, unsigned dims, unsigned back0, const int8_t *w,
                    unsigned len, unsigned s, ref_w8_t *out)
{
    for (unsigned a = 0; a < dims; a++) {
        int64_t acc = 0;
        for (unsigned r = 0; r < len; r++)
            acc += (int64_t)w[r] * lv_at(lv, back0 - r)[a];
        out[a] = (ref_w8_t)ref_rshift_round64(acc, s);
    }
}

/* Two-point combinations in int32 — the Chaikin fast path. The weights are
 * 1 or 3, formed by additions (no multiply: an AVR has no 32-bit multiplier,
 * and the helper call cost a fifth of its cycles). |A|,|B| < 2^29 keeps the
 * sums below 2^31. */
static int32_t sum31(int32_t a, int32_t b) { return a + a + a + b; }

static void mix_q(const ref_w8_t *A, const ref_w8_t *B, unsigned dims, ref_w8_t *out)
{
    for (unsigned a = 0; a < dims; a++)
        out[a] = ref_rshift_round32(sum31(A[a], B[a]), 2);
}
static void mix_r(const ref_w8_t *A, const ref_w8_t *B, unsigned dims, ref_w8_t *out)
{
    for (unsigned a = 0; a < dims; a++)
        out[a] = ref_rshift_round32(sum31(B[a], A[a]), 2);
}
static void mix_mid(const ref_w8_t *A, const ref_w8_t *B, unsigned dims, ref_w8_t *out)
{
    for (unsigned a = 0; a < dims; a++)
        out[a] = ref_rshift_round32(A[a] + B[a], 1);
}

/* ---- level: feed ------------------------------------------------------- */

/* Outputs released by LR after input i (0-based): j in [max(0,2i-D), 2i+1-D]. */
static unsigned lr_batch(unsigned D, uint32_t n)
{
    int32_t i = (int32_t)n - 1;
    int32_t hi = 2 * i + 1 - (int32_t)D;
    int32_t lo = 2 * i - (int32_t)D;
    if (lo < 0)
        lo = 0;
    return hi < 0 ? 0u : (unsigned)(hi - lo + 1);
}

static void lv_feed(const struct ref_refine *r, struct ref_level *lv, unsigned kind,
                    const ref_w8_t *p)
{
    unsigned dims = r->cfg.dims;
    for (unsigned k = REF_WIN - r->win; k + 1u < REF_WIN; k++)
        pt_copy(lv->w[k], lv->w[k + 1u], dims);
    pt_copy(lv->w[REF_WIN - 1u], p, dims);
    lv->n = (uint8_t)sat_inc8(lv->n);
    lv->ph = 0;
    unsigned n = lv->n;

    switch (kind) {
    case K_LR_INTERIOR:
        lv->pend = (uint8_t)lr_batch(r->D, n);
        break;
    case K_LR_NONE:
    case K_LR_REPLACE:
        lv->pend = (uint8_t)lr_batch(r->D, n);
        lv->st |= LV_DEFER; /* last span and the 2-point rule need lookahead */
        break;
    case K_CH_CLAMPED:
        lv->pend = n == 1u ? 1u : 0u; /* P0 now; each later edge waits */
        if (n >= 2u)
            lv->st |= LV_DEFER;
        break;
    case K_CUBIC_CLAMPED:
        lv->pend = n == 1u ? 1u : 0u;
        if (n >= 2u)
            lv->st |= LV_DEFER;
        break;
    case K_DLG_OPEN:
        lv->pend = n == 1u ? 1u : n == 2u ? 0u : 2u;
        break;
    case K_DLG_INTERIOR:
        lv->pend = n < 3u ? 0u : n == 3u ? 1u : 2u;
        break;
    default:
        break;
    }
    /* A deferred level with nothing held has nothing to decide. */
    if ((lv->st & LV_DEFER) && kind != K_CH_CLAMPED && kind != K_CUBIC_CLAMPED && lv->pend == 0u)
        lv->st &= (uint8_t)~LV_DEFER;
}

/* More input follows: release the held batch (its "not last" form). */
static void lv_more(const struct ref_refine *r, struct ref_level *lv, unsigned kind)
{
    (void)r;
    lv->st &= (uint8_t)~LV_DEFER;
    unsigned n = lv->n;
    switch (kind) {
    case K_CH_CLAMPED:
        lv->pend = n == 2u ? 1u : 2u; /* M0, or Qi Ri */
        break;
    case K_CUBIC_CLAMPED:
        lv->pend = n == 2u ? 1u : n == 3u ? 0u : n == 4u ? 1u : 2u;
        break;
    default: /* LR none/replace: the batch computed at feed */
        break;
    }
}

/* No more input: the current batch becomes the tail. */
static void lv_finish(const struct ref_refine *r, struct ref_level *lv, unsigned kind)
{
    unsigned n = lv->n;
    lv->st = (uint8_t)((lv->st & (uint8_t)~LV_DEFER) | LV_FIN);
    lv->ph = 0;
    switch (kind) {
    case K_LR_INTERIOR:
    case K_DLG_INTERIOR:
        lv->pend = 0;
        break;
    case K_LR_NONE:
    case K_LR_REPLACE:
        if (n <= 2u) {
            /* 0 -> nothing, 1 -> P0, 2 -> P0 P1 (minus what is already out) */
            lv->pend = (uint8_t)(n - ((lv->st & LV_E0) && n > 0u ? 1u : 0u));
        } else if (kind == K_LR_REPLACE && 2 * (int32_t)n - (int32_t)r->D < 2) {
            lv->pend = 2; /* too short: just P0, Pm-1 */
        } else {
            lv->pend = (uint8_t)lr_batch(r->D, n);
        }
        break;
    case K_CH_CLAMPED:
        lv->pend = n == 0u ? 0u : n == 1u ? 0u : n == 2u ? 1u : 2u;
        break;
    case K_CUBIC_CLAMPED:
        lv->pend = n <= 1u ? 0u : n == 2u ? 1u : n == 3u ? 2u : n == 4u ? 3u : 4u;
        break;
    case K_DLG_OPEN:
        lv->pend = n <= 1u ? 0u : n == 2u ? 1u : 2u;
        break;
    default:
        break;
    }
}

/* ---- level: emit ------------------------------------------------------- */

/* Offset, relative to the newest input, of output ph of the current LR batch:
 * returns "back" of the mask's first point and the parity of j. */
static void lr_locate(unsigned D, uint32_t n, unsigned ph, unsigned *back0, unsigned *odd)
{
    int32_t i = (int32_t)n - 1;
    int32_t lo = 2 * i - (int32_t)D;
    if (lo < 0)
        lo = 0;
    int32_t j = lo + (int32_t)ph;
    *odd = (unsigned)(j & 1);
    *back0 = (unsigned)(i - (j >> 1)); /* j >= 0 */
}

static void lr_eval(const struct ref_refine *r, const struct ref_level *lv, unsigned back0,
                    unsigned odd, ref_w8_t *out)
{
    unsigned D = r->D, dims = r->cfg.dims;
    if (D == 2u) { /* Chaikin fast path */
        const ref_w8_t *A = lv_at(lv, back0), *B = lv_at(lv, back0 - 1u);
        if (odd)
            mix_r(A, B, dims, out);
        else
            mix_q(A, B, dims, out);
        return;
    }
    int8_t w[5];
    unsigned len = 0;
    for (unsigned t = 0; t < 5u; t++)
        if ((w[t] = (int8_t)lr_w[D][odd][t]) != 0)
            len = t + 1u;
    /* the first weight may be 0 only for D = 1 odd ... keep simple: all from t=0 */
    lv_mask(lv, dims, back0, w, len, D, out);
}

static void emit_lr(const struct ref_refine *r, struct ref_level *lv, unsigned kind, ref_w8_t *out)
{
    unsigned dims = r->cfg.dims, n = lv->n, ph = lv->ph;
    if (lv->st & LV_FIN) {
        if (n <= 2u) { /* as is: the last `pend` inputs, oldest first */
            pt_copy(out, lv_at(lv, lv->pend - 1u - ph), dims);
            return;
        }
        if (kind == K_LR_REPLACE) {
            if (2 * (int32_t)n - (int32_t)r->D < 2) { /* P0, Pm-1 */
                pt_copy(out, lv_at(lv, ph == 0u ? n - 1u : 0u), dims);
                return;
            }
            if (ph + 1u == lv->pend) { /* the level's last point */
                pt_copy(out, lv_at(lv, 0), dims);
                return;
            }
        }
    }
    unsigned back0, odd;
    lr_locate(r->D, n, ph, &back0, &odd);
    if (kind == K_LR_REPLACE && back0 == n - 1u && !odd && (lv->st & LV_E0) == 0u) {
        pt_copy(out, lv_at(lv, n - 1u), dims); /* output 0 is P0 */
        return;
    }
    lr_eval(r, lv, back0, odd, out);
}

static void emit_ch_clamped(const struct ref_refine *r, struct ref_level *lv, ref_w8_t *out)
{
    unsigned dims = r->cfg.dims, n = lv->n, ph = lv->ph;
    const ref_w8_t *A = lv_at(lv, 1), *B = lv_at(lv, 0); /* the newest edge */
    if (n == 1u) {
        pt_copy(out, B, dims); /* P0 */
    } else if (lv->st & LV_FIN) {
        if (n == 2u || ph == 1u)
            pt_copy(out, B, dims); /* Pm-1 */
        else
            mix_mid(A, B, dims, out); /* M(m-2) */
    } else if (n == 2u) {
        mix_mid(A, B, dims, out); /* M0 */
    } else {
        if (ph)
            mix_r(A, B, dims, out); /* Ri */
        else
            mix_q(A, B, dims, out); /* Qi */
    }
}

/* Clamped cubic (knot insertion of the open-uniform cubic B-spline):
 *   P0 | E01 | T12 | V2 E23 | V3 E34 | ... | V(m-3) | T'(m-3,m-2) | E(m-2,m-1) | Pm-1
 * with T12 = (3P1+P2)/4, T' its mirror, Vi = (1,6,1)/8 except next to the
 * ends: (3,11,2)/16 for V2, (2,11,3)/16 for V(m-3), (3,10,3)/16 if both.
 * m = 3 falls back to the clamped quadratic, m = 4 is the Bezier split. */
static void emit_cubic_clamped(const struct ref_refine *r, struct ref_level *lv, ref_w8_t *out)
{
    if (REF_WIN < 4) /* never reached: init refuses the scheme in such a build */
        return;
    unsigned dims = r->cfg.dims, n = lv->n, ph = lv->ph;
    int fin = (lv->st & LV_FIN) != 0;
    if (n == 1u) {
        pt_copy(out, lv_at(lv, 0), dims);
        return;
    }
    if (n == 2u) { /* more: E01; last: P1 */
        if (fin)
            pt_copy(out, lv_at(lv, 0), dims);
        else
            mix_mid(lv_at(lv, 1), lv_at(lv, 0), dims, out);
        return;
    }
    if (n == 3u) { /* only on finish: M1, P2 */
        if (ph == 0u)
            mix_mid(lv_at(lv, 1), lv_at(lv, 0), dims, out);
        else
            pt_copy(out, lv_at(lv, 0), dims);
        return;
    }
    if (n == 4u) {
        if (!fin) { /* T12 */
            mix_q(lv_at(lv, 2), lv_at(lv, 1), dims, out);
        } else if (ph == 0u) { /* E12 */
            mix_mid(lv_at(lv, 2), lv_at(lv, 1), dims, out);
        } else if (ph == 1u) { /* E23 */
            mix_mid(lv_at(lv, 1), lv_at(lv, 0), dims, out);
        } else {
            pt_copy(out, lv_at(lv, 0), dims);
        }
        return;
    }
    /* n = i + 3 >= 5: window P(i-1), P(i), P(i+1), P(i+2) at back 3..0 */
    if (ph == 0u) {
        int8_t w[3];
        w[0] = (int8_t)(2 + (n == 5u ? 1 : 0));
        w[2] = (int8_t)(2 + (fin ? 1 : 0));
        w[1] = (int8_t)(16 - w[0] - w[2]);
        lv_mask(lv, dims, 3, w, 3, 4, out);
    } else if (!fin) { /* E(i, i+1) */
        mix_mid(lv_at(lv, 2), lv_at(lv, 1), dims, out);
    } else if (ph == 1u) { /* T'(i, i+1) */
        mix_r(lv_at(lv, 2), lv_at(lv, 1), dims, out);
    } else if (ph == 2u) { /* E(i+1, i+2) */
        mix_mid(lv_at(lv, 1), lv_at(lv, 0), dims, out);
    } else {
        pt_copy(out, lv_at(lv, 0), dims);
    }
}

static const int8_t dlg_mid[4] = { -1, 9, 9, -1 };
static const int8_t dlg_left[3] = { 7, 10, -1 };  /* ghost P-1 = 2P0 - P1 */
static const int8_t dlg_right[3] = { -1, 10, 7 }; /* ghost Pm = 2Pm-1 - Pm-2 */

static void emit_dlg(const struct ref_refine *r, struct ref_level *lv, unsigned kind, ref_w8_t *out)
{
    if (REF_WIN < 4) /* never reached: init refuses the scheme in such a build */
        return;
    unsigned dims = r->cfg.dims, n = lv->n, ph = lv->ph;
    if (kind == K_DLG_OPEN) {
        if (n == 1u) {
            pt_copy(out, lv_at(lv, 0), dims);
        } else if (lv->st & LV_FIN) {
            if (n == 2u || ph == 1u)
                pt_copy(out, lv_at(lv, 0), dims);
            else
                lv_mask(lv, dims, 2, dlg_right, 3, 4, out); /* mid(m-2, m-1) */
        } else if (ph == 1u) {
            pt_copy(out, lv_at(lv, 1), dims); /* the old point P(n-2) */
        } else if (n == 3u) {
            lv_mask(lv, dims, 2, dlg_left, 3, 4, out); /* mid(0, 1) */
        } else {
            lv_mask(lv, dims, 3, dlg_mid, 4, 4, out);
        }
        return;
    }
    /* interior: n = 3 -> P1; n >= 4 -> mid(n-3, n-2), P(n-2) */
    if (n == 3u || ph == 1u)
        pt_copy(out, lv_at(lv, 1), dims);
    else
        lv_mask(lv, dims, 3, dlg_mid, 4, 4, out);
}

static void lv_emit(const struct ref_refine *r, struct ref_level *lv, unsigned kind, ref_w8_t *out)
{
    switch (kind) {
    case K_CH_CLAMPED:
        emit_ch_clamped(r, lv, out);
        break;
    case K_CUBIC_CLAMPED:
        emit_cubic_clamped(r, lv, out);
        break;
    case K_DLG_OPEN:
    case K_DLG_INTERIOR:
        emit_dlg(r, lv, kind, out);
        break;
    default:
        emit_lr(r, lv, kind, out);
        break;
    }
    lv->st |= LV_E0;
    if (++lv->ph >= lv->pend) {
        lv->pend = 0;
        lv->ph = 0;
    }
}

/* ---- the cascade ------------------------------------------------------- */

static unsigned lv_kind_of(const struct ref_refine *r)
{
    if (r->cfg.scheme == REF_SCHEME_DLG)
        return r->cfg.closed ? K_DLG_INTERIOR : K_DLG_OPEN;
    if (r->cfg.closed)
        return K_LR_INTERIOR;
    switch (r->ends) {
    case REF_ENDS_CLAMPED:
        return r->D == 1u ? K_LR_NONE : r->D == 2u ? K_CH_CLAMPED : K_CUBIC_CLAMPED;
    case REF_ENDS_REPLACE:
        return K_LR_REPLACE;
    default:
        return K_LR_NONE;
    }
}

/* How many of the stroke's first points a closed curve must replay: the
 * reach of the interior rule (D for B-splines, 5 for DLG) plus what the limit
 * stage's stencil needs beyond that. */
static unsigned close_count(const struct ref_refine *r)
{
    return r->cfg.scheme == REF_SCHEME_DLG ? 5u : r->D < 2u ? 2u : r->D;
}

static unsigned needed_window(const struct ref_refine *r)
{
    if (r->cfg.scheme == REF_SCHEME_DLG)
        return 4u;
    if (!r->cfg.closed && r->ends == REF_ENDS_CLAMPED && r->D == 3u)
        return 4u;
    return lr_window(r->D);
}

int ref_refine_init(struct ref_refine *r, const struct ref_refine_cfg *cfg)
{
    if (r == NULL || cfg == NULL)
        return REF_EINVAL;
    struct ref_refine_cfg c = *cfg;
    if (c.dims == 0u)
        c.dims = REF_AXES;
    if (c.scheme > REF_SCHEME_DLG || c.depth > REF_MAX_DEPTH || c.dims < 2u || c.dims > REF_AXES ||
        c.ends > REF_ENDS_NONE || c.closed > 1u || c.limit > 1u || c.tangents > 1u)
        return REF_EINVAL;
    if (c.scheme == REF_SCHEME_BSPLINE && (c.degree < 1u || c.degree > 7u))
        return REF_EINVAL;
    if (c.tangents)
        c.limit = 1;

    /* Zero everything: no stale window contents can ever leak into a mask. */
    unsigned char *b = (unsigned char *)r;
    for (size_t i = 0; i < sizeof *r; i++)
        b[i] = 0;
    r->cfg = c;
    r->D = c.scheme == REF_SCHEME_DLG ? 0u : c.degree;
    if (c.scheme == REF_SCHEME_DLG)
        r->ends = REF_ENDS_NONE;
    else if (c.ends != REF_ENDS_DEFAULT)
        r->ends = c.ends;
    else
        r->ends = r->D <= 3u ? REF_ENDS_CLAMPED : REF_ENDS_REPLACE;
    if (c.scheme == REF_SCHEME_BSPLINE && r->ends == REF_ENDS_CLAMPED && r->D > 3u)
        return REF_ENOTSUP;
    if (needed_window(r) > REF_WIN && c.depth > 0u)
        return REF_ENOTSUP;
    r->close_c = (uint8_t)close_count(r);
    if (c.closed && r->close_c > REF_CLOSE_MAX)
        return REF_ENOTSUP;
    if (c.limit && ref_limit_setup(r) != REF_OK)
        return REF_ENOTSUP;
    r->nlev = (uint8_t)(c.depth + (c.limit ? 1u : 0u));
    r->kind = (uint8_t)lv_kind_of(r);
    r->win = (uint8_t)needed_window(r);
    r->out_left = UINT32_MAX;
    return REF_OK;
}

void ref_refine_reset(struct ref_refine *r)
{
    struct ref_refine_cfg c = r->cfg;
    (void)ref_refine_init(r, &c);
}

int ref_refine_push(struct ref_refine *r, const ref_um_t p[REF_AXES])
{
    if (r->finishing)
        return REF_ESTATE;
    if (r->in_full)
        return REF_EBUSY;
    for (unsigned a = 0; a < r->cfg.dims; a++)
        if (p[a] > REF_UM_MAX || p[a] < -REF_UM_MAX)
            return REF_ERANGE;
    if (r->cfg.closed && r->m >= REF_CLOSED_MAX_POINTS)
        return REF_ETOOLONG;
    for (unsigned a = 0; a < r->cfg.dims; a++)
        r->in[a] = p[a] * REF_W8_ONE_UM; /* exact: |p| < 2^21 */
    if (r->cfg.closed && r->m < r->close_c)
        pt_copy(r->first[r->m], r->in, r->cfg.dims);
    r->m++;
    r->in_full = 1;
    return REF_OK;
}

void ref_refine_finish(struct ref_refine *r)
{
    if (r->finishing)
        return;
    r->finishing = 1;
    if (r->cfg.closed) {
        uint32_t target = r->m <= 1u ? r->m : r->m << r->cfg.depth;
        r->out_left = target - r->out_done;
    }
}

/* Stage k (-1 = the input slot) has a point ready for stage k+1. */
static int st_ready(const struct ref_refine *r, int k)
{
    if (k < 0)
        return r->in_full || (r->finishing && r->cfg.closed && r->m >= 1u && r->close_i < r->close_c);
    if ((unsigned)k == r->cfg.depth)
        return ref_limit_ready(r);
    const struct ref_level *lv = &r->lv[k];
    return lv->pend != 0u && (lv->st & LV_DEFER) == 0u;
}

/* Stage k is finished and has given everything. */
static int st_exhausted(const struct ref_refine *r, int k)
{
    if (k < 0)
        return r->finishing && !st_ready(r, -1);
    if ((unsigned)k == r->cfg.depth)
        return ref_limit_exhausted(r);
    const struct ref_level *lv = &r->lv[k];
    return (lv->st & LV_FIN) != 0u && lv->pend == 0u;
}

static void st_take(struct ref_refine *r, int k, ref_w8_t *p)
{
    if (k < 0) {
        if (r->in_full) {
            pt_copy(p, r->in, r->cfg.dims);
            r->in_full = 0;
        } else { /* closed: replay the first points, cyclically */
            unsigned i = r->close_i++;
            pt_copy(p, r->first[r->m < r->close_c ? i % r->m : i], r->cfg.dims);
        }
        return;
    }
    lv_emit(r, &r->lv[k], r->kind, p);
}

static void st_feed(struct ref_refine *r, int k, const ref_w8_t *p)
{
    if ((unsigned)k == r->cfg.depth)
        ref_limit_feed(r, p);
    else
        lv_feed(r, &r->lv[k], r->kind, p);
}

static void st_finish(struct ref_refine *r, int k)
{
    if ((unsigned)k == r->cfg.depth)
        ref_limit_finish(r);
    else
        lv_finish(r, &r->lv[k], r->kind);
}

static int lv_ready(const struct ref_level *lv)
{
    return lv->pend != 0u && (lv->st & LV_DEFER) == 0u;
}

int ref_refine_pull(struct ref_refine *r, struct ref_refine_out *out)
{
    const int top = (int)r->nlev - 1; /* -1: depth 0 without limit: pass through */

    if (r->cfg.closed && r->out_left == 0u) {
        ref_refine_reset(r);
        return REF_END;
    }
    /* Walk from the output end towards the input until some stage can act,
     * then carry points back down. Each step moves one point one stage down,
     * answers one stage's lookahead question, finishes one stage, or climbs
     * one stage up: O(depth) steps per point delivered at worst, O(1) on
     * average (the last level gives 2 points for each point it takes). */
    const int lim = r->cfg.limit ? (int)r->cfg.depth : -2;
    int k = top;
    for (;;) {
        int ready = (k >= 0 && k != lim) ? lv_ready(&r->lv[k]) : st_ready(r, k);
        if (ready) {
            if (k == top)
                break;
            if (k + 1 != lim && (r->lv[k + 1].st & LV_DEFER) != 0u) {
                lv_more(r, &r->lv[k + 1], r->kind);
            } else {
                ref_w8_t p[REF_AXES];
                st_take(r, k, p);
                st_feed(r, k + 1, p);
            }
            k++;
            continue;
        }
        if (st_exhausted(r, k)) {
            if (k == top) {
                ref_refine_reset(r);
                return REF_END;
            }
            st_finish(r, k + 1);
            k++;
            continue;
        }
        if (k < 0)
            return REF_NEED_INPUT;
        k--;
    }

    if (top == (int)r->cfg.depth && r->cfg.limit) {
        for (unsigned a = 0; a < REF_AXES; a++)
            out->t[a] = 0;
        out->p[REF_AXES - 1] = 0;
        ref_limit_emit(r, out);
    } else {
        ref_w8_t p[REF_AXES] = { 0 };
        st_take(r, top, p);
        for (unsigned a = 0; a < REF_AXES; a++) {
            out->p[a] = ref_rshift_round32(p[a], REF_W8_SHIFT);
            out->t[a] = 0;
        }
    }
    r->out_done++;
    if (r->out_left != UINT32_MAX)
        r->out_left--;
    return REF_OK;
}

uint32_t ref_refine_max_release(const struct ref_refine_cfg *cfg)
{
    /* In steady state every level turns one input into two outputs, so a push
     * releases exactly 2^depth points (fewer while the stroke starts). A
     * finish releases each level's tail: at most 4 points per level for open
     * strokes (the clamped cubic's V, T', E, P), and for closed strokes the
     * replayed first points, at most REF_CLOSE_MAX, each refined 2^depth-fold.
     * The limit stage adds at most one burst of REF_LWIN anchors per stroke
     * (when an open polygon first has enough points to tell its ends).
     * Measured maxima are at or below these (tests/test_refine.c, fuzz_refine). */
    unsigned d = cfg->depth > REF_MAX_DEPTH ? REF_MAX_DEPTH : cfg->depth;
    uint32_t burst = (cfg->limit || cfg->tangents) ? (uint32_t)REF_LWIN : 0u;
    return ((cfg->closed ? (uint32_t)(REF_CLOSE_MAX + 1) : 4u) << d) + burst;
}
