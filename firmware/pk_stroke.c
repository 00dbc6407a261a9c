/*
 * pk_stroke.c — stroke assembler and tolerance decimator (see pk_stroke.h for
 * the policy and the error bound).
 */
#include <string.h>
#include "pk_stroke.h"
#include "pk_motion.h"

/* cos(deg) in Q1.30 for 0..180 degrees, integer only: reduce to 0..90 and sum
 * the Taylor series to x^14 in Horner form (truncation < 1e-8 for x <= pi/2). */
static pk_q30_t cos_deg_q30(uint32_t deg)
{
    int neg = 0;
    if (deg > 90u) {
        deg = 180u - deg;
        neg = 1;
    }
    const int64_t one = PK_Q30_ONE;
    int64_t x = (int64_t)deg * 18740330; /* pi/180 in Q30 */
    int64_t x2 = (x * x) >> 30;
    static const int64_t den[7] = { 182, 132, 90, 56, 30, 12, 2 };
    int64_t t = one;
    for (unsigned i = 0; i < 7; i++)
        t = one - ((x2 * t) >> 30) / den[i];
    return (pk_q30_t)(neg ? -t : t);
}

int pk_stroke_check(const struct pk_smooth_cfg *s)
{
    if (s == NULL || s->mode > PK_SMOOTH_TOLERANCE || s->sharp_turn_deg > 180u)
        return -1;
    if (s->mode == PK_SMOOTH_FIXED) {
        if (s->scheme > PK_SCHEME_DLG || s->depth > PK_MAX_DEPTH)
            return -1;
        if (s->scheme == PK_SCHEME_BSPLINE && (s->degree < 1u || s->degree > 7u))
            return -1;
    }
    if (s->mode == PK_SMOOTH_TOLERANCE) {
        if (s->degree != 0u && s->degree != 2u && s->degree != 3u)
            return -1;
        if (s->tolerance_um < 1 || s->tolerance_um > 10000)
            return -1;
    }
    return 0;
}

static void apply(struct pk_stroke *st, const struct pk_smooth_cfg *s)
{
    st->mode = s->mode;
    st->scheme = s->scheme;
    st->degree = s->mode == PK_SMOOTH_TOLERANCE ? (s->degree ? s->degree : 3u) : s->degree;
    st->fixed_depth = s->depth;
    st->tol_um = s->tolerance_um;
    st->cos_sharp = cos_deg_q30(s->sharp_turn_deg ? s->sharp_turn_deg : 60u);
}

void pk_stroke_init(struct pk_stroke *st, const struct pk_smooth_cfg *s)
{
    memset(st, 0, sizeof *st);
    apply(st, s);
}

int pk_stroke_set(struct pk_stroke *st, const struct pk_smooth_cfg *s)
{
    if (st->open)
        return -1;
    apply(st, s);
    return 0;
}

bool pk_stroke_is_open(const struct pk_stroke *st) { return st->open; }

/* M/(2*4^k) <= T/2  <=>  M <= T*4^k: the largest M depth k covers */
static uint64_t cap_m(pk_um_t tol_um, uint8_t k) { return (uint64_t)tol_um << (2u * k); }

uint8_t pk_stroke_depth_for(uint32_t m_um, pk_um_t tol_um)
{
    if (tol_um < 1)
        tol_um = 1;
    uint8_t k = 0;
    while (k < PK_MAX_DEPTH && (uint64_t)m_um > cap_m(tol_um, k))
        k++;
    return k;
}

static void kernel_start(struct pk_stroke *st, const pk_um_t start[PK_AXES])
{
    struct pk_refine_cfg c;
    memset(&c, 0, sizeof c);
    if (st->mode == PK_SMOOTH_FIXED) {
        c.scheme = st->scheme;
        c.degree = st->degree;
        c.depth = st->fixed_depth;
    } else {
        c.scheme = PK_SCHEME_BSPLINE;
        c.degree = st->degree;
        c.depth = st->depth;
    }
    (void)pk_refine_init(&st->k, &c); /* validated by pk_stroke_check */
    (void)pk_refine_push(&st->k, start);
    st->have_anchor = true;
    memcpy(st->anchor, start, sizeof st->anchor);
    st->ncand = 0;
    st->kernel_end = false;
}

int pk_stroke_begin(struct pk_stroke *st, const pk_um_t start[PK_AXES], uint32_t d2_hint)
{
    if (st->open)
        return -1;
    st->open = true;
    st->finishing = false;
    st->split_pending = false;
    st->have_pend = false;
    st->have_out = false;
    st->emit_n = 0;
    st->n_in = 1;
    memcpy(st->prev, start, sizeof st->prev);
    memcpy(st->prev2, start, sizeof st->prev2);
    if (st->mode == PK_SMOOTH_TOLERANCE) {
        /* at least depth 2, so that gentle vertices arriving later rarely split */
        uint32_t m = d2_hint;
        uint32_t floor_m = (uint32_t)st->tol_um * 16u; /* = the depth-2 capacity */
        if (m < floor_m)
            m = floor_m;
        st->depth = pk_stroke_depth_for(m, st->tol_um);
        uint64_t cap = cap_m(st->tol_um, st->depth);   /* largest M this depth covers */
        st->d2_cap = cap * cap;                          /* compared with |D2|^2 */
    }
    if (st->mode != PK_SMOOTH_OFF)
        kernel_start(st, start);
    return 0;
}

/* |a| in µm Q8 */
static uint32_t len_q8(const int64_t a[PK_AXES])
{
    uint64_t ss = 0;
    for (unsigned i = 0; i < PK_AXES; i++)
        ss += (uint64_t)(a[i] * a[i]);
    return pk_isqrt64(ss << 16);
}

/* Does the vertex prev (between prev2 and q) have to stay sharp? */
static bool must_split(const struct pk_stroke *st, const pk_um_t q[PK_AXES])
{
    if (st->mode == PK_SMOOTH_OFF || st->n_in < 2)
        return false;
    int64_t a[PK_AXES], b[PK_AXES];
    int64_t dot = 0;
    uint64_t d2 = 0;
    for (unsigned i = 0; i < PK_AXES; i++) {
        a[i] = (int64_t)st->prev[i] - st->prev2[i];
        b[i] = (int64_t)q[i] - st->prev[i];
        dot += a[i] * b[i];
        int64_t dd = b[i] - a[i];
        d2 += (uint64_t)(dd * dd);
    }
    uint32_t la = len_q8(a), lb = len_q8(b);
    if (la == 0 || lb == 0)
        return false;
    int64_t y_q8 = (dot * 65536) / (int64_t)la;         /* dot/|a|, µm Q8 */
    int64_t cos_q30 = (y_q8 * PK_Q30_ONE) / (int64_t)lb; /* |y_q8| < 2^31 */
    if (cos_q30 < st->cos_sharp)
        return true;
    if (st->mode == PK_SMOOTH_TOLERANCE && d2 > st->d2_cap)
        return true;
    return false;
}

int pk_stroke_add(struct pk_stroke *st, const pk_um_t p[PK_AXES])
{
    if (!st->open || st->finishing)
        return PK_ESTATE;
    if (st->have_pend || st->have_out || st->split_pending)
        return PK_EBUSY;
    if (memcmp(p, st->prev, sizeof st->prev) == 0)
        return PK_OK; /* zero-length: nothing to draw, no vertex */
    if (st->mode == PK_SMOOTH_OFF) {
        memcpy(st->out, p, sizeof st->out);
        st->have_out = true;
    } else if (must_split(st, p)) {
        memcpy(st->pend, p, sizeof st->pend);
        st->have_pend = true;
        st->split_pending = true;
        pk_refine_finish(&st->k);
    } else {
        int r = pk_refine_push(&st->k, p);
        if (r == PK_EBUSY) {
            memcpy(st->pend, p, sizeof st->pend);
            st->have_pend = true;
        } else if (r != PK_OK) {
            return r;
        }
    }
    memcpy(st->prev2, st->prev, sizeof st->prev);
    memcpy(st->prev, p, sizeof st->prev);
    st->n_in++;
    return PK_OK;
}

void pk_stroke_finish(struct pk_stroke *st)
{
    if (!st->open || st->finishing)
        return;
    st->finishing = true;
    if (st->mode != PK_SMOOTH_OFF && !st->have_pend)
        pk_refine_finish(&st->k);
}

static void emit(struct pk_stroke *st, const pk_um_t p[PK_AXES])
{
    memcpy(st->emit[st->emit_n], p, sizeof st->emit[0]);
    st->emit_n++;
}

/* Distance test: is c within tol of segment a-q? (µm, 64-bit exact enough:
 * cross components are divided by |q-a| before squaring). */
static bool near_seg(const pk_um_t a[PK_AXES], const pk_um_t q[PK_AXES], uint32_t L,
                     const pk_um_t c[PK_AXES], pk_um_t tol)
{
    int64_t d[PK_AXES], v[PK_AXES];
    for (unsigned i = 0; i < PK_AXES; i++) {
        d[i] = (int64_t)q[i] - a[i];
        v[i] = (int64_t)c[i] - a[i];
    }
    uint64_t t2 = (uint64_t)tol * (uint64_t)tol << 16; /* (tol in Q8)^2 */
    int64_t dot = 0;
    for (unsigned i = 0; i < PK_AXES; i++)
        dot += d[i] * v[i];
    int64_t ll = 0;
    for (unsigned i = 0; i < PK_AXES; i++)
        ll += d[i] * d[i];
    if (L == 0 || dot <= 0 || dot >= ll) {
        /* beyond an end: distance to that end */
        const pk_um_t *e = (L == 0 || dot <= 0) ? a : q;
        uint64_t s = 0;
        for (unsigned i = 0; i < PK_AXES; i++) {
            int64_t w = ((int64_t)c[i] - e[i]) * 256;
            s += (uint64_t)(w * w);
        }
        return s <= t2;
    }
    /* |d x v| / |d|, component-wise, in µm Q8 */
    uint64_t s = 0;
    for (unsigned i = 0; i < PK_AXES; i++) {
        unsigned j = (i + 1u) % PK_AXES, k = (i + 2u) % PK_AXES;
        if (PK_AXES == 2 && i == 1)
            break;
        int64_t cr = (PK_AXES == 2) ? d[0] * v[1] - d[1] * v[0] : d[j] * v[k] - d[k] * v[j];
        int64_t w = (cr * 65536) / (int64_t)L; /* |cr| < 2^46 */
        s += (uint64_t)(w * w);
    }
    return s <= t2;
}

static void decimate(struct pk_stroke *st, const pk_um_t q[PK_AXES])
{
    pk_um_t half = st->tol_um / 2; /* T/2; at least 1 µm (points are whole µm) */
    if (half < 1)
        half = 1;
    bool ok = st->ncand < PK_STROKE_DEC;
    int64_t d[PK_AXES];
    for (unsigned i = 0; i < PK_AXES; i++)
        d[i] = (int64_t)q[i] - st->anchor[i];
    uint32_t L = len_q8(d); /* once per new point: the chord anchor -> q */
    for (unsigned j = 0; ok && j < st->ncand; j++)
        ok = near_seg(st->anchor, q, L, st->cand[j], half);
    if (!ok) {
        const pk_um_t *last = st->cand[st->ncand - 1u];
        emit(st, last);
        memcpy(st->anchor, last, sizeof st->anchor);
        st->ncand = 0;
    }
    memcpy(st->cand[st->ncand], q, sizeof st->cand[0]);
    st->ncand++;
}

void pk_stroke_reset(struct pk_stroke *st)
{
    if (st->mode != PK_SMOOTH_OFF)
        pk_refine_reset(&st->k);
    st->open = false;
    st->finishing = false;
    st->split_pending = false;
    st->have_pend = false;
    st->have_out = false;
    st->emit_n = 0;
    st->ncand = 0;
}

int pk_stroke_pull(struct pk_stroke *st, pk_um_t out[PK_AXES])
{
    for (;;) {
        if (st->emit_n > 0) {
            memcpy(out, st->emit[0], sizeof st->emit[0]);
            memmove(st->emit[0], st->emit[1], sizeof st->emit[0]);
            st->emit_n--;
            return PK_OK;
        }
        if (!st->open)
            return PK_END;
        if (st->mode == PK_SMOOTH_OFF) {
            if (st->have_out) {
                st->have_out = false;
                memcpy(out, st->out, sizeof st->out);
                return PK_OK;
            }
            if (st->finishing) {
                st->open = false;
                return PK_END;
            }
            return PK_NEED_INPUT;
        }
        if (st->kernel_end) {
            st->open = false;
            return PK_END;
        }
        struct pk_refine_out o;
        int r = pk_refine_pull(&st->k, &o);
        if (r == PK_OK) {
            if (st->mode == PK_SMOOTH_TOLERANCE)
                decimate(st, o.p);
            else
                emit(st, o.p);
            continue;
        }
        if (r == PK_NEED_INPUT) {
            if (st->have_pend && !st->split_pending) {
                int pr = pk_refine_push(&st->k, st->pend);
                if (pr == PK_OK) {
                    st->have_pend = false;
                    if (st->finishing)
                        pk_refine_finish(&st->k);
                    continue;
                }
                if (pr != PK_EBUSY) {
                    pk_stroke_reset(st);
                    return pr;
                }
            }
            if (st->finishing)
                pk_refine_finish(&st->k); /* idempotent safety */
            return PK_NEED_INPUT;
        }
        if (r == PK_END) {
            if (st->mode == PK_SMOOTH_TOLERANCE && st->ncand > 0) {
                emit(st, st->cand[st->ncand - 1u]);
                st->ncand = 0;
            }
            if (st->split_pending) {
                /* the stroke ended at the sharp vertex (prev2 now holds it) */
                st->split_pending = false;
                kernel_start(st, st->prev2);
                int pr = pk_refine_push(&st->k, st->pend);
                st->have_pend = (pr == PK_EBUSY);
                if (pr != PK_OK && pr != PK_EBUSY) {
                    pk_stroke_reset(st);
                    return pr;
                }
                st->n_in = 2;
                if (st->finishing && !st->have_pend)
                    pk_refine_finish(&st->k);
                continue;
            }
            st->kernel_end = true;
            continue;
        }
        pk_stroke_reset(st);
        return r;
    }
}
