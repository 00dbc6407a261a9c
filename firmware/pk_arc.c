/*
 * pk_arc.c — arc centres, chord counts and chord vertices (see pk_arc.h for
 * the curve, the error budget and the formats).
 *
 * Angles are binary (uint32, 2^32 per turn), so wrapping is free. Vertices
 * come from rotating the start direction (a Q30 unit vector, divided by the
 * CORDIC gain once at plan time) by the vertex's swept angle with a 30-step
 * CORDIC, then scaling by the interpolated radius: no error accumulates from
 * one vertex to the next. Swept angle, radius and linear axis advance by
 * exact integer division spread over the chords (quotient + remainder
 * accumulator), so vertex k sits exactly at floor(k * sweep / n).
 */
#include "pk_arc.h"
#include "pk_rom.h"

#include <string.h>

#define CORDIC_N 30
/* round(atan(2^-i) / 2pi * 2^32) */
static const uint32_t atan_tab[CORDIC_N] PK_ROM = {
    536870912u, 316933406u, 167458907u, 85004756u, 42667331u, 21354465u, 10679838u,
    5340245u,   2670163u,   1335087u,   667544u,   333772u,   166886u,   83443u,
    41722u,     20861u,     10430u,     5215u,     2608u,     1304u,     652u,
    326u,       163u,       81u,        41u,       20u,       10u,       5u,
    3u,         1u,
};
/* 1 / CORDIC gain after CORDIC_N steps, Q30 (0.60725293500888) */
#define KINV_Q30 652032874
/* Grbl's ARC_ANGULAR_TRAVEL_EPSILON, 5e-7 rad, in binary angle units */
#define SWEEP_EPS 342u
#define QUARTER 0x40000000u

static int32_t rs(int32_t x, unsigned i) { return i == 0 ? x : pk_rshift_round32(x, i); }

void pk_arc_rotate(int32_t v[2], uint32_t phi)
{
    int32_t x = v[0], y = v[1];
    /* Quarter turns exactly, the rest in [-45, 45) degrees for CORDIC. */
    uint32_t q = phi >> 30;
    uint32_t r = phi & (QUARTER - 1u);
    int32_t z;
    if (r >= QUARTER / 2u) {
        q++;
        z = (int32_t)r - (int32_t)QUARTER;
    } else {
        z = (int32_t)r;
    }
    for (q &= 3u; q > 0u; q--) {
        int32_t t = x;
        x = -y;
        y = t;
    }
    for (unsigned i = 0; i < CORDIC_N; i++) {
        int32_t dx = rs(y, i), dy = rs(x, i);
        if (z >= 0) {
            x -= dx;
            y += dy;
            z -= (int32_t)pk_rom_u32(&atan_tab[i]);
        } else {
            x += dx;
            y -= dy;
            z += (int32_t)pk_rom_u32(&atan_tab[i]);
        }
    }
    v[0] = x;
    v[1] = y;
}

static int64_t abs64(int64_t v) { return v < 0 ? -v : v; }

uint32_t pk_arc_atan2(int64_t y, int64_t x)
{
    if (x == 0 && y == 0)
        return 0;
    /* Scale so that the larger component is in [2^28, 2^29): the angle then
     * has the same precision for any length, and the CORDIC gain keeps it
     * below 2^31. */
    int64_t m = abs64(x) > abs64(y) ? abs64(x) : abs64(y);
    while (m >= ((int64_t)1 << 29)) {
        x /= 2;
        y /= 2;
        m /= 2;
    }
    while (m < ((int64_t)1 << 28)) {
        x *= 2;
        y *= 2;
        m *= 2;
    }
    int32_t xi = (int32_t)x, yi = (int32_t)y;
    uint32_t base = 0;
    if (xi < 0) {
        xi = -xi;
        yi = -yi;
        base = 0x80000000u;
    }
    int32_t z = 0;
    for (unsigned i = 0; i < CORDIC_N; i++) {
        int32_t dx = rs(yi, i), dy = rs(xi, i);
        if (yi > 0) {
            xi += dx;
            yi -= dy;
            z += (int32_t)pk_rom_u32(&atan_tab[i]);
        } else {
            xi -= dx;
            yi += dy;
            z -= (int32_t)pk_rom_u32(&atan_tab[i]);
        }
    }
    return base + (uint32_t)z;
}

static unsigned msb64(uint64_t v)
{
    unsigned b = 0;
    while (v >>= 1)
        b++;
    return b;
}

/* ceil(sqrt(v)) */
static uint64_t ceil_sqrt(uint64_t v)
{
    uint64_t s = pk_isqrt64(v);
    return s * s < v ? s + 1u : s;
}

static void geom_reset(struct pk_arc_geom *g)
{
    g->straight = 0;
    g->bulge_um = 0;
    g->centre_q8[0] = g->centre_q8[1] = 0;
}

int pk_arc_centre_ijk(struct pk_arc_geom *g, int32_t i, int32_t j)
{
    const int32_t lim = (int32_t)1 << 30;
    geom_reset(g);
    if (i > lim || i < -lim || j > lim || j < -lim)
        return PK_ARC_E_TARGET;
    int64_t cx = (int64_t)g->start[g->a0] + i, cy = (int64_t)g->start[g->a1] + j;
    int64_t ex = g->end[g->a0] - cx, ey = g->end[g->a1] - cy;
    uint64_t r0sq = (uint64_t)((int64_t)i * i + (int64_t)j * j);
    uint64_t r1sq = (uint64_t)(ex * ex + ey * ey);
    /* Grbl: |r1 - r0| > 0.005 mm and (> 0.5 mm or > 0.1 % of r0) is an
     * invalid target. Compared in Q8 µm where the squares allow, else in µm. */
    int64_t r0, r1, unit;
    if (r0sq < ((uint64_t)1 << 46) && r1sq < ((uint64_t)1 << 46)) {
        r0 = pk_isqrt64(r0sq << 16);
        r1 = pk_isqrt64(r1sq << 16);
        unit = 256;
    } else {
        r0 = pk_isqrt64(r0sq);
        r1 = pk_isqrt64(r1sq);
        unit = 1;
    }
    int64_t dr = r1 > r0 ? r1 - r0 : r0 - r1;
    if (dr > 5 * unit && (dr > 500 * unit || dr * 1000 > r0))
        return PK_ARC_E_TARGET;
    int64_t rmax_um = (r0 > r1 ? r0 : r1) / unit;
    if (rmax_um >= ((int64_t)1 << 22)) {
        /* Too large to flatten: only a short arc nearly straight may run,
         * as its chord. Short when the turn from S-C to E-C has the sign of
         * the direction: cross = (-i)*ey - (-j)*ex = j*ex - i*ey. */
        int64_t p1 = (int64_t)j * ex, p2 = (int64_t)i * ey;
        int short_arc = g->cw ? p1 < p2 : p1 > p2;
        if (!short_arc)
            return PK_ARC_E_TARGET;
        int64_t cx2 = (int64_t)g->end[g->a0] - g->start[g->a0];
        int64_t cy2 = (int64_t)g->end[g->a1] - g->start[g->a1];
        uint64_t c2 = (uint64_t)(cx2 * cx2 + cy2 * cy2);
        uint64_t den = 4u * (uint64_t)(r0 / unit);
        uint64_t bulge = (c2 + den - 1u) / den;
        g->straight = 1;
        g->bulge_um = bulge > 0xffffffffu ? 0xffffffffu : (uint32_t)bulge;
        return PK_ARC_OK;
    }
    g->centre_q8[0] = (int32_t)(cx * 256);
    g->centre_q8[1] = (int32_t)(cy * 256);
    return PK_ARC_OK;
}

int pk_arc_centre_r(struct pk_arc_geom *g, int32_t r)
{
    geom_reset(g);
    int64_t x = (int64_t)g->end[g->a0] - g->start[g->a0];
    int64_t y = (int64_t)g->end[g->a1] - g->start[g->a1];
    uint64_t d2 = (uint64_t)(x * x + y * y);
    if (d2 == 0)
        return PK_ARC_E_RADIUS;
    int64_t rr = r < 0 ? -(int64_t)r : r;
    uint64_t four_r2 = 4u * (uint64_t)rr * (uint64_t)rr;
    if (four_r2 < d2)
        return PK_ARC_E_RADIUS;
    if (rr >= ((int64_t)1 << 22)) {
        if (r < 0)
            return PK_ARC_E_TARGET;
        uint64_t den = 4u * (uint64_t)rr;
        uint64_t bulge = (d2 + den - 1u) / den;
        g->straight = 1;
        g->bulge_um = (uint32_t)bulge;
        return PK_ARC_OK;
    }
    /* Centre = midpoint + sigma * mu * (-y, x), mu = sqrt((4R^2 - d^2) / 4d^2)
     * (Grbl's h_x2_div_d / 2 with its signs: sigma = +1 for G3, -1 for G2,
     * negated for R < 0). mu is formed as a normalised integer ratio so that
     * it keeps 30 significant bits whatever the magnitudes. */
    int sigma = (g->cw ? -1 : 1) * (r < 0 ? -1 : 1);
    uint64_t num = four_r2 - d2;
    int64_t ox = 0, oy = 0;
    if (num != 0) {
        uint64_t den = 4u * d2;
        unsigned a = 62u - msb64(num);
        uint64_t nn = num << a;
        unsigned b = msb64(den) >= 31u ? msb64(den) - 31u : 0u;
        uint64_t dd = den >> b;
        uint64_t q = nn / dd;              /* = num/den * 2^(a+b) */
        int e = 62 - (int)msb64(q);
        if ((e + (int)a + (int)b) & 1)
            e--;
        uint64_t qq = e >= 0 ? q << e : q >> -e;
        int f = (e + (int)a + (int)b) / 2; /* mu = isqrt(qq) / 2^f */
        int64_t m = pk_isqrt64(qq);
        int sh = f - 8;                     /* to Q8 */
        int64_t px = -y * m, py = x * m;
        if (sh > 0) {
            ox = pk_rshift_round64(px, (unsigned)sh);
            oy = pk_rshift_round64(py, (unsigned)sh);
        } else {
            ox = px * ((int64_t)1 << -sh);
            oy = py * ((int64_t)1 << -sh);
        }
    }
    int64_t cx = ((int64_t)g->start[g->a0] + g->end[g->a0]) * 128 + sigma * ox;
    int64_t cy = ((int64_t)g->start[g->a1] + g->end[g->a1]) * 128 + sigma * oy;
    g->centre_q8[0] = (int32_t)cx;
    g->centre_q8[1] = (int32_t)cy;
    return PK_ARC_OK;
}

/* Spread d over n steps: q, r with d = q*n + r (d may be negative). */
static void spread32(int32_t d, uint32_t n, int32_t *q, int32_t *r)
{
    int64_t dq = (int64_t)d / (int64_t)n, dr = (int64_t)d % (int64_t)n;
    if (dr < 0) { /* floor division */
        dq--;
        dr += n;
    }
    *q = (int32_t)dq;
    *r = (int32_t)dr;
}

static void step32(int32_t *v, int32_t q, int32_t r, int32_t *acc, uint32_t n)
{
    *v += q;
    *acc += r;
    if ((uint32_t)*acc >= n) {
        *acc -= (int32_t)n;
        (*v)++;
    }
}

int pk_arc_plan(struct pk_arc *a, const struct pk_arc_geom *g, pk_um_t tol_um)
{
    memset(a, 0, sizeof *a);
    a->g = *g;
    a->k = 1;
    a->n = 1;
    if (tol_um < 1)
        tol_um = 1;
    if (g->straight)
        return (int64_t)g->bulge_um <= tol_um ? PK_ARC_OK : PK_ARC_E_TARGET;
    int64_t v0x = (int64_t)g->start[g->a0] * 256 - g->centre_q8[0];
    int64_t v0y = (int64_t)g->start[g->a1] * 256 - g->centre_q8[1];
    int64_t v1x = (int64_t)g->end[g->a0] * 256 - g->centre_q8[0];
    int64_t v1y = (int64_t)g->end[g->a1] * 256 - g->centre_q8[1];
    int64_t r0 = pk_isqrt64((uint64_t)(v0x * v0x + v0y * v0y));
    int64_t r1 = pk_isqrt64((uint64_t)(v1x * v1x + v1y * v1y));
    a->r0_q8 = (int32_t)r0;
    a->r1_q8 = (int32_t)r1;
    if (r0 == 0 || r1 == 0)
        return PK_ARC_OK; /* a point-sized circle: the chord to the end */
    uint32_t as = pk_arc_atan2(v0y, v0x), ae = pk_arc_atan2(v1y, v1x);
    a->a_start = as;
    uint64_t sweep = g->cw ? (uint32_t)(as - ae) : (uint32_t)(ae - as);
    if (sweep <= SWEEP_EPS)
        sweep += PK_ARC_TURN;
    a->sweep = sweep;

    /* Chord count (see pk_arc.h): the circle's sagitta plus the spiral term
     * |r1-r0| * sweep / (4 n^2) within s = T - vertex error. The spiral term
     * of the count found for the whole of s is taken off s and the count
     * found again: it can only grow, which only shrinks the spiral term. */
    int64_t s = (int64_t)tol_um * 256 - PK_ARC_VERTEX_ERR_Q8;
    if (s < 38)
        s = 38;
    int64_t dr = r1 - r0;
    uint64_t dra = (uint64_t)(dr < 0 ? -dr : dr);
    uint64_t bq = (sweep + 0xffffu) >> 16;                    /* sweep / 2^16, up */
    uint64_t rmax_um = ((uint64_t)(r0 > r1 ? r0 : r1) + 255u) >> 8;
    uint64_t n = 1;
    int64_t s_c = s;
    for (int pass = 0; pass < 2; pass++) {
        uint64_t den = ((uint64_t)1 << 25) * (uint64_t)s_c;
        n = ceil_sqrt((10u * bq * bq * rmax_um + den - 1u) / den);
        if (n < 1)
            n = 1;
        if (dra == 0)
            break;
        /* 2 pi < 6.3: spiral term <= 63 |dr| bq / (10 * 2^18 * n^2), Q8 */
        uint64_t den2 = 10u * ((uint64_t)1 << 18) * n * n;
        int64_t e_s = (int64_t)((63u * dra * bq + den2 - 1u) / den2);
        if (s - e_s >= s / 2) {
            if (pass == 1)
                break;
            s_c = s - e_s;
        } else {
            /* a large spiral term on a coarse count: give it half */
            uint64_t den3 = 10u * ((uint64_t)1 << 18) * (uint64_t)(s - s / 2);
            uint64_t ns = ceil_sqrt((63u * dra * bq + den3 - 1u) / den3);
            if (ns > n)
                n = ns;
            s_c = s / 2;
            den = ((uint64_t)1 << 25) * (uint64_t)s_c;
            uint64_t nc = ceil_sqrt((10u * bq * bq * rmax_um + den - 1u) / den);
            if (nc > n)
                n = nc;
            break;
        }
    }
    uint64_t nq = (sweep + QUARTER - 1u) / QUARTER; /* at most a quarter turn each */
    if (nq > n)
        n = nq;
    if (n < 1)
        n = 1;
    if (n > ((uint64_t)1 << 24))
        n = (uint64_t)1 << 24;
    a->n = (uint32_t)n;
    if (a->n > 1) {
        a->phi_q = (uint32_t)(sweep / n);
        a->phi_r = (uint32_t)(sweep % n);
    }
    a->rho = (int32_t)r0;
    spread32((int32_t)dr, a->n, &a->rho_q, &a->rho_r);
    if (g->al < PK_AXES) {
        a->lin = g->start[g->al];
        spread32(g->end[g->al] - g->start[g->al], a->n, &a->lin_q, &a->lin_r);
        a->lin_acc = (int32_t)(a->n / 2u); /* rounds to nearest */
    }
    /* Start direction: (S - C) / r0 in Q30, divided by the CORDIC gain. */
    int64_t ux = v0x * ((int64_t)1 << 30) / r0, uy = v0y * ((int64_t)1 << 30) / r0;
    a->u0[0] = (int32_t)pk_rshift_round64(ux * KINV_Q30, 30);
    a->u0[1] = (int32_t)pk_rshift_round64(uy * KINV_Q30, 30);
    return PK_ARC_OK;
}

int pk_arc_next(struct pk_arc *a, pk_um_t out[PK_AXES])
{
    if (a->k > a->n)
        return 0;
    if (a->k == a->n) {
        for (unsigned i = 0; i < PK_AXES; i++)
            out[i] = a->g.end[i];
        a->k++;
        return 1;
    }
    a->phi += a->phi_q;
    a->phi_acc += a->phi_r;
    if (a->phi_acc >= a->n) {
        a->phi_acc -= a->n;
        a->phi++;
    }
    step32(&a->rho, a->rho_q, a->rho_r, &a->rho_acc, a->n);
    int32_t v[2] = { a->u0[0], a->u0[1] };
    pk_arc_rotate(v, a->g.cw ? 0u - a->phi : a->phi);
    for (unsigned i = 0; i < PK_AXES; i++)
        out[i] = a->g.start[i];
    for (unsigned c = 0; c < 2; c++) {
        int64_t rel = pk_rshift_round64((int64_t)v[c] * a->rho, 30); /* Q8 */
        int64_t p = (int64_t)a->g.centre_q8[c] + rel;
        out[c == 0 ? a->g.a0 : a->g.a1] = (pk_um_t)pk_rshift_round64(p, 8);
    }
    if (a->g.al < PK_AXES) {
        step32(&a->lin, a->lin_q, a->lin_r, &a->lin_acc, a->n);
        out[a->g.al] = a->lin;
    }
    a->k++;
    return 1;
}

uint32_t pk_arc_length_um(const struct pk_arc *a)
{
    uint64_t plane;
    if (a->g.straight || a->sweep == 0) {
        int64_t dx = (int64_t)a->g.end[a->g.a0] - a->g.start[a->g.a0];
        int64_t dy = (int64_t)a->g.end[a->g.a1] - a->g.start[a->g.a1];
        plane = ceil_sqrt((uint64_t)(dx * dx + dy * dy));
    } else {
        /* mean radius (µm, up) * sweep (rad): 2 pi / 2^32 = 51472 / 2^33, up */
        uint64_t r_um = (((uint64_t)a->r0_q8 + (uint64_t)a->r1_q8) / 2u + 255u) >> 8;
        plane = (r_um * ((a->sweep + 4095u) >> 12) * 51472u + ((uint64_t)1 << 33) - 1u) >> 33;
    }
    uint64_t dz = 0;
    if (a->g.al < PK_AXES) {
        int64_t d = (int64_t)a->g.end[a->g.al] - a->g.start[a->g.al];
        dz = (uint64_t)(d < 0 ? -d : d);
    }
    uint64_t len = dz ? ceil_sqrt(plane * plane + dz * dz) : plane;
    return len > 0xffffffffu ? 0xffffffffu : (uint32_t)len;
}

static int64_t floor_div256(int64_t v) { return v >= 0 ? v / 256 : -((-v + 255) / 256); }
static int64_t ceil_div256(int64_t v) { return -floor_div256(-v); }

void pk_arc_bounds(const struct pk_arc *a, int32_t lo[PK_AXES], int32_t hi[PK_AXES])
{
    const struct pk_arc_geom *g = &a->g;
    for (unsigned i = 0; i < PK_AXES; i++) {
        lo[i] = g->start[i] < g->end[i] ? g->start[i] : g->end[i];
        hi[i] = g->start[i] > g->end[i] ? g->start[i] : g->end[i];
    }
    if (g->straight || a->sweep == 0)
        return;
    int64_t rmax = a->r0_q8 > a->r1_q8 ? a->r0_q8 : a->r1_q8;
    if (a->r0_q8 != a->r1_q8 && a->r0_q8 > 0 && a->r1_q8 > 0) {
        /* A spiral (end radius != start radius): a coordinate is r(t) u(t),
         * r between the two radii and u monotone between cardinal angles,
         * so besides the cardinal points below its extremes are at the
         * corners {rmin, rmax} x {start, end direction} (finding G1: a
         * spiral at the bottom of the range went 42 µm below its end
         * points, and out of the numeric range, inside this box). 1 µm of
         * margin for the vertices' rounding. */
        int64_t rmin = a->r0_q8 < a->r1_q8 ? a->r0_q8 : a->r1_q8;
        const pk_um_t *ends[2] = { g->start, g->end };
        const int64_t rr[2] = { a->r0_q8, a->r1_q8 };
        for (unsigned e = 0; e < 2u; e++)
            for (unsigned k = 0; k < 2u; k++) {
                int64_t rho = k ? rmax : rmin;
                for (unsigned j = 0; j < 2u; j++) {
                    unsigned ax = j ? g->a1 : g->a0;
                    int64_t cq = g->centre_q8[j];
                    int64_t d = (int64_t)ends[e][ax] * 256 - cq; /* |d| < 2^32: fits with rho < 2^31 */
                    int64_t v = cq + d / rr[e] * rho + (d % rr[e]) * rho / rr[e];
                    int64_t vl = floor_div256(v) - 1, vh = ceil_div256(v) + 1;
                    if (vl < lo[ax])
                        lo[ax] = (int32_t)vl;
                    if (vh > hi[ax])
                        hi[ax] = (int32_t)vh;
                }
            }
    }
    /* The curve reaches an axis extreme where its direction from the centre
     * is a cardinal one inside the swept range. */
    for (unsigned c = 0; c < 4; c++) {
        uint32_t beta = (uint32_t)c * QUARTER;
        uint32_t off = g->cw ? a->a_start - beta : beta - a->a_start;
        if ((uint64_t)off > a->sweep)
            continue;
        unsigned ax = (c & 1u) ? g->a1 : g->a0;
        int64_t cq = g->centre_q8[c & 1u];
        if (c < 2) {
            int64_t v = ceil_div256(cq + rmax);
            if (v > hi[ax])
                hi[ax] = (int32_t)v;
        } else {
            int64_t v = floor_div256(cq - rmax);
            if (v < lo[ax])
                lo[ax] = (int32_t)v;
        }
    }
}
