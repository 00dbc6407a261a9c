/*
 * pk_refine_cascade.c — the exact level cascade: the replace end rule of
 * degrees 2..7, degrees 4..7 with any rule, closed or open, and DLG.
 *
 * One small stage per level, each holding only the last few points of its
 * own input (a "window"), driven from the output end: asking the last level
 * for a point makes it ask the level above only when it has nothing left to
 * give. A level-k point costs one mask evaluation; there are 2^(k-K) of them
 * per output point, summing to < 2, so the cost per point is O(1) amortised
 * and O(K) at worst.
 *
 *     input -> [level 0] -> [level 1] -> ... -> [level K-1] -> level-K point
 *               window        window               window
 *
 * Lookahead. Open curves treat their last span differently (the replace rule
 * swaps in the last point; a 2-point stroke stays straight), so a level must
 * know whether its newest input is the last one before it may release that
 * span. It needs no storage for that: the level above either has a point
 * ready (so more follows), or is finished and drained (so this was the
 * last), or must first be run — which the loop below does. A level in that
 * state is "deferred".
 *
 * Exactness. Values are exact: level k's points are N / 2^(F_k) with
 * F_k = k * b (b = D for Lane-Riesenfeld, 4 for DLG); every mask sum is
 * formed in int64 and scaled by the power of two that takes it to the next
 * level's F, without rounding. Only where b * K > 42 (degree 6 at depth 8,
 * degree 7 at depth 7..8) would N outgrow int64: those levels keep G = 42 - b
 * fraction bits and round the sum once (ties away from zero) — an error
 * below 2^-(G + 1) µm per level, stated in pk_refine.h.
 */
#include "pk_refine_internal.h"

#include <stddef.h>

#if PK_HAVE_CASCADE

#include "pk_rom.h"


/* What each level does (chosen at setup from scheme, degree, closed, ends). */
enum lv_kind {
    K_LR_INTERIOR, /* B-spline, no end rule, no deferral (closed curves) */
    K_LR_NONE,     /* B-spline, open, end rule "none" */
    K_LR_REPLACE,  /* B-spline, open, end rule "replace" */
    K_DLG_OPEN,    /* DLG with ghost points */
    K_DLG_INTERIOR /* DLG on the periodic sequence (closed) */
};

/* Lane-Riesenfeld masks: output j uses P[floor(j/2) + r], r = 0..len-1, with
 * weights lr_w[D][j & 1][r] summing to 2^D. Derived from binomial(D, t)
 * applied to the split sequence s[2i] = s[2i+1] = P[i]. */
static const uint8_t lr_w[8][2][5] PK_ROM = {
    { { 1 }, { 1 } },                              /* unused (D = 0) */
    { { 2, 0 }, { 1, 1 } },                        /* D=1: P, mid */
    { { 3, 1 }, { 1, 3 } },                        /* D=2: Q, R (Chaikin) */
    { { 4, 4, 0 }, { 1, 6, 1 } },                  /* D=3: edge, vertex */
    { { 5, 10, 1 }, { 1, 10, 5 } },                /* D=4 */
    { { 6, 20, 6, 0 }, { 1, 15, 15, 1 } },         /* D=5 */
    { { 7, 35, 21, 1 }, { 1, 21, 35, 7 } },        /* D=6 */
    { { 8, 56, 56, 8, 0 }, { 1, 28, 70, 28, 1 } }, /* D=7 */
};

static const int8_t dlg_mid[4] PK_ROM = { -1, 9, 9, -1 };
static const int8_t dlg_left[3] PK_ROM = { 7, 10, -1 };  /* ghost P-1 = 2P0 - P1 */
static const int8_t dlg_right[3] PK_ROM = { -1, 10, 7 }; /* ghost Pm = 2Pm-1 - Pm-2 */

/* Window a degree-D level needs: ceil(D/2) + 1 points (DLG: 4). */
static unsigned lr_window(unsigned D) { return (D + 1u) / 2u + 1u; }

static unsigned win_of(const struct pk_refine *r)
{
    return r->cfg.scheme == PK_SCHEME_DLG ? 4u : lr_window(r->D);
}

static unsigned kind_of(const struct pk_refine *r)
{
    if (r->cfg.scheme == PK_SCHEME_DLG)
        return r->cfg.closed ? K_DLG_INTERIOR : K_DLG_OPEN;
    if (r->cfg.closed)
        return K_LR_INTERIOR;
    return r->ends == PK_ENDS_REPLACE ? K_LR_REPLACE : K_LR_NONE;
}

/* Fraction bits of level k's inputs (k = 0: the input, whole µm). */
static unsigned frac_of(const struct pk_refine *r, unsigned k)
{
    unsigned b = r->cfg.scheme == PK_SCHEME_DLG ? 4u : r->D, f = k * b;
    return f < r->G ? f : r->G;
}

int pk_cascade_setup(struct pk_refine *r)
{
    if (win_of(r) > PK_WIN)
        return PK_ENOTSUP;
    unsigned b = r->cfg.scheme == PK_SCHEME_DLG ? 4u : r->D;
    r->G = (uint8_t)(b * r->cfg.depth <= 42u ? 42u : 42u - b);
    r->F = (uint8_t)frac_of(r, r->cfg.depth);
    return PK_OK;
}

static unsigned level_index(const struct pk_refine *r, const struct pk_level *lv)
{
    return (unsigned)(lv - r->e.lv);
}

/* Point P_x where x = (newest index) - back; back = 0 is the newest input. */
static const pk_umf_t *lv_at(const struct pk_level *lv, unsigned back)
{
    return lv->w[PK_WIN - 1u - back];
}

/* An exact sum at fraction bits `from`, as a value at fraction bits `to`. */
static pk_umf_t rescale(int64_t acc, unsigned from, unsigned to)
{
    if (from <= to)
        return acc * ((int64_t)1 << (to - from));
    return pk_rshift_round64(acc, from - to);
}

/* out = sum_r w[r] * P(back0 - r) / 2^s, as this level's output. */
static void lv_mask(const struct pk_refine *r, const struct pk_level *lv, unsigned back0,
                    const int8_t *w, unsigned len, unsigned s, pk_umf_t *out)
{
    unsigned k = level_index(r, lv), from = frac_of(r, k) + s, to = frac_of(r, k + 1u);
    for (unsigned a = 0; a < r->cfg.dims; a++) {
        int64_t acc = 0;
        for (unsigned i = 0; i < len; i++)
            acc += (int64_t)PK_ROM_I8(&w[i]) * lv_at(lv, back0 - i)[a];
        out[a] = rescale(acc, from, to);
    }
}

/* One of the level's inputs, unchanged, as this level's output. */
static void lv_copy(const struct pk_refine *r, const struct pk_level *lv, unsigned back,
                    pk_umf_t *out)
{
    unsigned k = level_index(r, lv);
    for (unsigned a = 0; a < r->cfg.dims; a++)
        out[a] = rescale(lv_at(lv, back)[a], frac_of(r, k), frac_of(r, k + 1u));
}

static uint8_t sat_inc8(uint8_t n) { return n < 255u ? (uint8_t)(n + 1u) : 255u; }

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

static void lv_feed(const struct pk_refine *r, struct pk_level *lv, unsigned kind, const pk_umf_t *p)
{
    for (unsigned k = PK_WIN - win_of(r); k + 1u < PK_WIN; k++)
        for (unsigned a = 0; a < PK_AXES; a++)
            lv->w[k][a] = lv->w[k + 1u][a];
    for (unsigned a = 0; a < PK_AXES; a++)
        lv->w[PK_WIN - 1u][a] = p[a];
    lv->n = sat_inc8(lv->n);
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
    case K_DLG_OPEN:
        lv->pend = n == 1u ? 1u : n == 2u ? 0u : 2u;
        break;
    default: /* K_DLG_INTERIOR */
        lv->pend = n < 3u ? 0u : n == 3u ? 1u : 2u;
        break;
    }
    /* A deferred level with nothing held has nothing to decide. */
    if ((lv->st & LV_DEFER) && lv->pend == 0u)
        lv->st &= (uint8_t)~LV_DEFER;
}

/* No more input: the current batch becomes the tail. */
static void lv_finish(const struct pk_refine *r, struct pk_level *lv, unsigned kind)
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
    default: /* K_DLG_OPEN */
        lv->pend = n <= 1u ? 0u : n == 2u ? 1u : 2u;
        break;
    }
}

/* ---- level: emit ------------------------------------------------------- */

static void emit_lr(const struct pk_refine *r, struct pk_level *lv, unsigned kind, pk_umf_t *out)
{
    unsigned n = lv->n, ph = lv->ph, D = r->D;
    if (lv->st & LV_FIN) {
        if (n <= 2u) { /* as is: the last `pend` inputs, oldest first */
            lv_copy(r, lv, lv->pend - 1u - ph, out);
            return;
        }
        if (kind == K_LR_REPLACE) {
            if (2 * (int32_t)n - (int32_t)D < 2) { /* P0, Pm-1 */
                lv_copy(r, lv, ph == 0u ? n - 1u : 0u, out);
                return;
            }
            if (ph + 1u == lv->pend) { /* the level's last point */
                lv_copy(r, lv, 0, out);
                return;
            }
        }
    }
    /* output j of the batch after input i = n - 1 */
    int32_t i = (int32_t)n - 1, lo = 2 * i - (int32_t)D;
    if (lo < 0)
        lo = 0;
    int32_t j = lo + (int32_t)ph;
    unsigned odd = (unsigned)(j & 1), back0 = (unsigned)(i - (j >> 1));
    if (kind == K_LR_REPLACE && back0 == n - 1u && !odd && (lv->st & LV_E0) == 0u) {
        lv_copy(r, lv, n - 1u, out); /* output 0 is P0 */
        return;
    }
    int8_t w[5];
    unsigned len = 0;
    for (unsigned t = 0; t < 5u; t++)
        if ((w[t] = (int8_t)PK_ROM_U8(&lr_w[D][odd][t])) != 0)
            len = t + 1u;
    unsigned k = level_index(r, lv), from = frac_of(r, k) + D, to = frac_of(r, k + 1u);
    for (unsigned a = 0; a < r->cfg.dims; a++) {
        int64_t acc = 0;
        for (unsigned t = 0; t < len; t++)
            acc += (int64_t)w[t] * lv_at(lv, back0 - t)[a];
        out[a] = rescale(acc, from, to);
    }
}

static void emit_dlg(const struct pk_refine *r, struct pk_level *lv, unsigned kind, pk_umf_t *out)
{
    if (PK_WIN < 4) /* never reached: setup refuses the scheme in such a build */
        return;
    unsigned n = lv->n, ph = lv->ph;
    if (kind == K_DLG_OPEN) {
        if (n == 1u) {
            lv_copy(r, lv, 0, out);
        } else if (lv->st & LV_FIN) {
            if (n == 2u || ph == 1u)
                lv_copy(r, lv, 0, out);
            else
                lv_mask(r, lv, 2, dlg_right, 3, 4, out); /* mid(m-2, m-1) */
        } else if (ph == 1u) {
            lv_copy(r, lv, 1, out); /* the old point P(n-2) */
        } else if (n == 3u) {
            lv_mask(r, lv, 2, dlg_left, 3, 4, out); /* mid(0, 1) */
        } else {
            lv_mask(r, lv, 3, dlg_mid, 4, 4, out);
        }
        return;
    }
    /* interior: n = 3 -> P1; n >= 4 -> mid(n-3, n-2), P(n-2) */
    if (n == 3u || ph == 1u)
        lv_copy(r, lv, 1, out);
    else
        lv_mask(r, lv, 3, dlg_mid, 4, 4, out);
}

static void lv_emit(const struct pk_refine *r, struct pk_level *lv, unsigned kind, pk_umf_t *out)
{
    for (unsigned a = 0; a < PK_AXES; a++)
        out[a] = 0;
    if (kind == K_DLG_OPEN || kind == K_DLG_INTERIOR)
        emit_dlg(r, lv, kind, out);
    else
        emit_lr(r, lv, kind, out);
    lv->st |= LV_E0;
    if (++lv->ph >= lv->pend) {
        lv->pend = 0;
        lv->ph = 0;
    }
}

/* ---- the cascade --------------------------------------------------------- */

static int lv_ready(const struct pk_level *lv)
{
    return lv->pend != 0u && (lv->st & LV_DEFER) == 0u;
}

int pk_cascade_next(struct pk_refine *r, pk_umf_t v[PK_AXES])
{
    const int top = (int)r->cfg.depth - 1;
    const unsigned kind = kind_of(r);
    struct pk_level *lv = r->e.lv;
    /* Walk from the output end towards the input until some stage can act,
     * then carry points back down. Each step moves one point one level down,
     * answers one level's lookahead question, finishes one level, or climbs
     * one level up: O(depth) steps per point delivered at worst, O(1) on
     * average (the last level gives 2 points for each point it takes). */
    int k = top;
    for (;;) {
        int ready = k < 0 ? pk_in_ready(r) : lv_ready(&lv[k]);
        if (ready) {
            if (k == top)
                break;
            if ((lv[k + 1].st & LV_DEFER) != 0u) {
                lv[k + 1].st &= (uint8_t)~LV_DEFER; /* more input follows: release */
            } else {
                pk_umf_t p[PK_AXES];
                if (k < 0) {
                    pk_um_t q[PK_AXES];
                    pk_in_take(r, q);
                    for (unsigned a = 0; a < PK_AXES; a++)
                        p[a] = q[a];
                } else {
                    lv_emit(r, &lv[k], kind, p);
                }
                lv_feed(r, &lv[k + 1], kind, p);
            }
            k++;
            continue;
        }
        int exhausted = k < 0 ? pk_in_exhausted(r) : (lv[k].st & LV_FIN) != 0u && lv[k].pend == 0u;
        if (exhausted) {
            if (k == top)
                return PK_SRC_END;
            lv_finish(r, &lv[k + 1], kind);
            k++;
            continue;
        }
        if (k < 0)
            return PK_SRC_NEED;
        k--;
    }
    lv_emit(r, &lv[top], kind, v);
    return PK_SRC_OK;
}

#endif
