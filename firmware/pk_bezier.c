/*
 * pk_bezier.c — adaptive flattening of quadratic and cubic Bézier curves
 * (see pk_bezier.h for the method and the error bound).
 *
 * The traversal visits the dyadic intervals the recursive algorithm would
 * visit, in curve order: split an interval that is not flat (go to its left
 * half); after emitting a flat one, go to the next interval at the coarsest
 * level it starts (climb while the index is even).
 */
#include "pk_bezier.h"

#include <string.h>

/* Rounding of a curve point to whole µm: 0.5 * sqrt(2) = 0.7071 µm, Q8, up. */
#define VERTEX_ROUND_Q8 182

void pk_bez_init(struct pk_bez *b, const pk_um_t p[4][2], int quad, pk_um_t tol_um)
{
    memset(b, 0, sizeof *b);
    b->quad = quad ? 1u : 0u;
    for (int i = 0; i < (quad ? 3 : 4); i++)
        for (int a = 0; a < 2; a++)
            b->p[i][a] = p[i][a];
    for (int a = 0; a < 2; a++) {
        b->d[0][a] = b->p[0][a] - 2 * b->p[1][a] + b->p[2][a];
        b->d[1][a] = quad ? b->d[0][a] : b->p[1][a] - 2 * b->p[2][a] + b->p[3][a];
    }
    if (tol_um < 1)
        tol_um = 1;
    b->tolb_q8 = tol_um * 256 - VERTEX_ROUND_Q8;
}

static uint64_t uabs64(int64_t v) { return v < 0 ? (uint64_t)-v : (uint64_t)v; }

static unsigned msb64(uint64_t v)
{
    unsigned n = 0;
    while (v >>= 1)
        n++;
    return n;
}

/* Is the sub-curve's second difference V / 2^3L within the bound?
 * cubic: 3/4 |V| / 2^3L <= tolb; quadratic (V = 2^L D0): 1/4 |V| / 2^3L <= tolb. */
static int within(const struct pk_bez *b, int64_t vx, int64_t vy, unsigned lvl)
{
    /* W = k |V| in Q8 (k = 3 * 256 or 256), T = 4 tolb 2^(3L or 2L) */
    uint64_t k = b->quad ? 256u : 768u;
    uint64_t wx = uabs64(vx) * k, wy = uabs64(vy) * k;
    uint64_t t = (uint64_t)b->tolb_q8 * 4u << (3u * lvl);
    if (wx > t || wy > t)
        return 0;
    /* shift so that the squares fit, rounding W up and T down */
    unsigned s = msb64(t) > 30u ? msb64(t) - 30u : 0u;
    if (s) {
        uint64_t r = ((uint64_t)1 << s) - 1u;
        wx = (wx + r) >> s;
        wy = (wy + r) >> s;
        t >>= s;
    }
    return wx * wx + wy * wy <= t * t;
}

static int flat(const struct pk_bez *b, uint32_t m, unsigned lvl)
{
    int64_t one = (int64_t)1 << lvl;
    for (int e = 0; e < (b->quad ? 1 : 2); e++) {
        int64_t t = (int64_t)m + e; /* a = m/2^L, b = (m+1)/2^L */
        int64_t vx = (one - t) * b->d[0][0] + t * b->d[1][0];
        int64_t vy = (one - t) * b->d[0][1] + t * b->d[1][1];
        if (!within(b, vx, vy, lvl))
            return 0;
    }
    return 1;
}

/* The curve point at t = m / 2^L, rounded to whole µm (ties away). */
static void point(const struct pk_bez *b, uint32_t m, unsigned lvl, pk_um_t out[2])
{
    int64_t u = ((int64_t)1 << lvl) - (int64_t)m, t = m;
    for (int a = 0; a < 2; a++) {
        int64_t s;
        unsigned sh;
        if (b->quad) {
            s = u * u * b->p[0][a] + 2 * u * t * b->p[1][a] + t * t * b->p[2][a];
            sh = 2u * lvl;
        } else {
            s = u * u * u * b->p[0][a] + 3 * u * u * t * b->p[1][a] +
                3 * u * t * t * b->p[2][a] + t * t * t * b->p[3][a];
            sh = 3u * lvl;
        }
        out[a] = (pk_um_t)(sh ? pk_rshift_round64(s, sh) : s);
    }
}

int pk_bez_next(struct pk_bez *b, pk_um_t out[2])
{
    for (;;) {
        if (b->lvl == 0 && b->m >= 1u)
            return 0;
        if (b->lvl < PK_BEZ_MAX_DEPTH && !flat(b, b->m, b->lvl)) {
            b->m <<= 1;
            b->lvl++;
            continue;
        }
        point(b, b->m + 1u, b->lvl, out);
        b->m++;
        while (b->lvl > 0 && (b->m & 1u) == 0u) {
            b->m >>= 1;
            b->lvl--;
        }
        return 1;
    }
}
