/*
 * exact_model.h — an exact, deliberately naive model of the refinement
 * specification, for tests only (host: 128-bit integers).
 *
 * Every level is computed on the whole polygon, one coordinate at a time,
 * exactly as the specification states it (the rules in tests/vectors and
 * tests/tools/derive_masks.py, refine1): Lane-Riesenfeld split-and-average
 * (open without end rule, replace, closed cyclically), the clamped quadratic
 * and cubic level rules (knot insertion, written out), DLG with ghost points
 * or cyclically; 0 and 1 points stay, an open 2-point stroke stays. Values are
 * numerators over 2^(8k) after k levels (8 fraction bits per level cover every
 * mask denominator), no rounding anywhere. It shares no code with the kernel:
 * it knows nothing of spans, windows, streaming or pk_umf_t.
 */
#ifndef PLOTKIN_EXACT_MODEL_H
#define PLOTKIN_EXACT_MODEL_H

#include <stdint.h>
#include <string.h>

typedef __int128 xm_t;

#define XM_MAX 20000
#define XM_FRAC 8 /* fraction bits added per level */

struct xm_poly {
    unsigned n;
    unsigned frac; /* values are v / 2^frac */
    xm_t v[XM_MAX];
};

struct xm_cfg {
    int dlg, degree, closed, ends; /* ends: 1 clamped, 2 replace, 3 none (resolved) */
};

/* One coordinate, one level: x[0..m) at scale 2^f -> y at scale 2^(f + 8). */
static inline unsigned xm_level1(const struct xm_cfg *c, const xm_t *x, unsigned m, xm_t *y)
{
    const xm_t U = (xm_t)1 << XM_FRAC; /* one, at the added scale */
    static xm_t s[2 * XM_MAX + 2];
    if (m <= 1u || (m == 2u && !c->closed)) {
        for (unsigned i = 0; i < m; i++)
            y[i] = x[i] * U;
        return m;
    }
    if (c->dlg) {
        unsigned k = 0;
        if (c->closed) {
            for (unsigned i = 0; i < m; i++) {
                xm_t a = x[(i + m - 1) % m], b = x[i], cc = x[(i + 1) % m], d = x[(i + 2) % m];
                y[k++] = b * U;
                y[k++] = (-a + 9 * b + 9 * cc - d) * (U / 16);
            }
            return k;
        }
        for (unsigned i = 0; i + 1u < m; i++) {
            xm_t a = i == 0 ? 2 * x[0] - x[1] : x[i - 1], b = x[i], cc = x[i + 1];
            xm_t d = i + 2u == m ? 2 * x[m - 1] - x[m - 2] : x[i + 2];
            y[k++] = b * U;
            y[k++] = (-a + 9 * b + 9 * cc - d) * (U / 16);
        }
        y[k++] = x[m - 1] * U;
        return k;
    }
    unsigned D = (unsigned)c->degree;
    if (!c->closed && c->ends == 1 && D >= 2u) {
        unsigned d = D < m - 1u ? D : m - 1u, k = 0;
        if (d == 1u) /* cannot happen for m >= 3 */
            return 0;
        if (d == 2u) { /* P0, M0, Q1, R1, ..., Q(m-3), R(m-3), M(m-2), P(m-1) */
            y[k++] = x[0] * U;
            y[k++] = (x[0] + x[1]) * (U / 2);
            for (unsigned i = 1; i + 2u < m; i++) {
                y[k++] = (3 * x[i] + x[i + 1]) * (U / 4);
                y[k++] = (x[i] + 3 * x[i + 1]) * (U / 4);
            }
            y[k++] = (x[m - 2] + x[m - 1]) * (U / 2);
            y[k++] = x[m - 1] * U;
            return k;
        }
        /* d = 3 */
        y[k++] = x[0] * U;
        y[k++] = (x[0] + x[1]) * (U / 2);
        if (m == 4u) { /* the single Bezier span: midpoints */
            y[k++] = (x[1] + x[2]) * (U / 2);
            y[k++] = (x[2] + x[3]) * (U / 2);
            y[k++] = x[3] * U;
            return k;
        }
        y[k++] = (3 * x[1] + x[2]) * (U / 4);
        for (unsigned i = 2; i + 3u <= m; i++) {
            xm_t wl = i == 2u ? 3 : 2, wr = i == m - 3u ? 3 : 2;
            y[k++] = (wl * x[i - 1] + (16 - wl - wr) * x[i] + wr * x[i + 1]) * (U / 16);
            if (i + 3u < m)
                y[k++] = (x[i] + x[i + 1]) * (U / 2);
        }
        y[k++] = (x[m - 3] + 3 * x[m - 2]) * (U / 4);
        y[k++] = (x[m - 2] + x[m - 1]) * (U / 2);
        y[k++] = x[m - 1] * U;
        return k;
    }
    /* Lane-Riesenfeld: split, then D averages (each doubles the scale) */
    unsigned L = 2u * m;
    for (unsigned i = 0; i < m; i++)
        s[2 * i] = s[2 * i + 1] = x[i];
    for (unsigned t = 0; t < D; t++) {
        if (c->closed) {
            xm_t first = s[0];
            for (unsigned i = 0; i + 1u < L; i++)
                s[i] = s[i] + s[i + 1];
            s[L - 1] = s[L - 1] + first;
        } else {
            for (unsigned i = 0; i + 1u < L; i++)
                s[i] = s[i] + s[i + 1];
            L = L > 0u ? L - 1u : 0u;
        }
        if (L == 0u)
            break;
    }
    xm_t scale = U >> D; /* from 2^D to 2^8 */
    if (!c->closed && c->ends == 2) {
        if (L < 2u) {
            y[0] = x[0] * U;
            y[1] = x[m - 1] * U;
            return 2;
        }
        for (unsigned i = 0; i < L; i++)
            y[i] = s[i] * scale;
        y[0] = x[0] * U;
        y[L - 1] = x[m - 1] * U;
        return L;
    }
    for (unsigned i = 0; i < L; i++)
        y[i] = s[i] * scale;
    return L;
}

/* The whole refinement: in[m][dims] (µm) -> *out (numerators over 2^out->frac). */
static inline void xm_refine(const struct xm_cfg *c, unsigned depth, const int32_t (*in)[3], unsigned m,
                      unsigned dims, struct xm_poly out[3])
{
    static struct xm_poly tmp[3];
    for (unsigned a = 0; a < dims; a++) {
        out[a].n = m;
        out[a].frac = 0;
        for (unsigned i = 0; i < m; i++)
            out[a].v[i] = in[i][a];
        for (unsigned k = 0; k < depth; k++) {
            tmp[a].n = xm_level1(c, out[a].v, out[a].n, tmp[a].v);
            tmp[a].frac = out[a].frac + XM_FRAC;
            out[a].n = tmp[a].n;
            out[a].frac = tmp[a].frac;
            memcpy(out[a].v, tmp[a].v, sizeof(xm_t) * tmp[a].n);
        }
    }
}

/* round(v / 2^f), ties away from zero. */
static inline int64_t xm_round(xm_t v, unsigned f)
{
    if (f == 0u)
        return (int64_t)v;
    xm_t half = (xm_t)1 << (f - 1u);
    return v >= 0 ? (int64_t)((v + half) >> f) : -(int64_t)((-v + half) >> f);
}

/* |out - v / 2^f| <= num / 2^den_log2, exactly. */
static inline int xm_within(int64_t out, xm_t v, unsigned f, xm_t num, unsigned den_log2)
{
    xm_t d = (xm_t)out * ((xm_t)1 << f) - v; /* error * 2^f */
    if (d < 0)
        d = -d;
    /* d / 2^f <= num / 2^den_log2  <=>  d * 2^den_log2 <= num * 2^f */
    return d * ((xm_t)1 << den_log2) <= num * ((xm_t)1 << f);
}

#endif
