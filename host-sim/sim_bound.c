/*
 * sim_bound.c — the lower bound on motion time described in sim_bound.h:
 * programmed path, per-vertex speed caps from the tolerance tube, forward and
 * backward passes, trapezoid times.
 */
#include "sim_bound.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define CHORD_UM 0.5  /* flattening of arcs and curves for the bound */
#define EPS_MM 1e-9   /* shorter segments are merged into the next */

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

void pk_bound_init(struct pk_bound *b, const struct pk_bound_cfg *cfg)
{
    memset(b, 0, sizeof *b);
    b->cfg = *cfg;
    b->tool = -1;
    for (unsigned a = 0; a < cfg->axes && a < 3u; a++)
        b->acc_norm += cfg->acc_mm_s2[a] * cfg->acc_mm_s2[a];
    b->acc_norm = sqrt(b->acc_norm);
}

void pk_bound_free(struct pk_bound *b)
{
    free(b->v);
    b->v = NULL;
    b->n = b->cap = 0;
}

double pk_bound_trapezoid_s(double len, double v0, double v1, double vmax, double acc)
{
    if (len <= 0.0)
        return 0.0;
    /* the peak a triangle would reach */
    double vp2 = (v0 * v0 + v1 * v1 + 2.0 * acc * len) / 2.0;
    if (vp2 <= vmax * vmax) {
        double vp = sqrt(vp2);
        return (vp - v0) / acc + (vp - v1) / acc;
    }
    double d_acc = (vmax * vmax - v0 * v0) / (2.0 * acc), d_dec = (vmax * vmax - v1 * v1) / (2.0 * acc);
    return (vmax - v0) / acc + (vmax - v1) / acc + (len - d_acc - d_dec) / vmax;
}

double pk_bound_corner_radius_mm(double phi, double tol_mm, double l1, double l2)
{
    double h = phi / 2.0, c = cos(h);
    if (c >= 1.0)
        return INFINITY;
    double r = 2.0 * tol_mm / (1.0 - c);
    /* the circle reaches its tangent points r tan(phi/2) along each leg; a
     * shorter leg does not hold the path to its direction there */
    double reach = r * tan(h);
    return l1 >= reach && l2 >= reach ? r : INFINITY;
}

/* The limit along unit direction d of per-axis limits lim[]: min lim_a/|d_a|. */
static double dir_limit(const struct pk_bound_cfg *c, const double d[3], const double lim[3])
{
    double best = INFINITY;
    for (unsigned a = 0; a < c->axes && a < 3u; a++) {
        double s = fabs(d[a]);
        if (s > 1e-12 && lim[a] / s < best)
            best = lim[a] / s;
    }
    return best;
}

/* The cap of the vertex between the segment of direction t1 (unit), length
 * l1, squared speed cap f1_2 and the next one (t2, l2, f2_2): the tube
 * circle, or Grbl's junction rule when tol is 0. */
static double corner_cap2(const struct pk_bound *b, double tol, const double t1[3], double l1, double f1_2,
                          const double t2[3], double l2, double f2_2)
{
    double dot = t1[0] * t2[0] + t1[1] * t2[1] + t1[2] * t2[2];
    double cap = f1_2 < f2_2 ? f1_2 : f2_2; /* (mm/s)^2 */
    if (dot > 1.0 - 1e-15)
        return cap;
    double phi = acos(dot < -1.0 ? -1.0 : dot);
    double dv[3] = { t2[0] - t1[0], t2[1] - t1[1], t2[2] - t1[2] };
    double m = sqrt(dv[0] * dv[0] + dv[1] * dv[1] + dv[2] * dv[2]);
    for (int k = 0; k < 3; k++)
        dv[k] /= m;
    double ac = dir_limit(&b->cfg, dv, b->cfg.acc_mm_s2);
    double r;
    if (tol > 0.0) {
        r = pk_bound_corner_radius_mm(phi, tol, l1, l2);
    } else {
        double c = cos(phi / 2.0);
        r = c <= 0.0 ? 0.0 : b->cfg.junction_mm * c / (1.0 - c);
    }
    double v2 = ac * r;
    return v2 < cap ? v2 : cap;
}

/* The point at arc position s of the collected piece (clamped to it). */
static void point_at(const struct pk_bound_vtx *v, size_t n, double s, double q[3])
{
    size_t lo = 1, hi = n - 1; /* the first vertex j >= 1 with v[j].s >= s */
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (v[mid].s < s)
            lo = mid + 1;
        else
            hi = mid;
    }
    const struct pk_bound_vtx *e = &v[lo], *a = &v[lo - 1];
    double u = e->len > 0.0 ? (s - a->s) / e->len : 0.0;
    u = u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
    for (int k = 0; k < 3; k++)
        q[k] = a->p[k] + u * (e->p[k] - a->p[k]);
}

/*
 * The window rule (sim_bound.h) at vertex i with the points a and c at arc
 * distances h1 before and h2 after it: the cap of v_i^2 it implies, INFINITY
 * if none. P: the largest tolerance of the piece.
 */
static double window_cap2(const struct pk_bound *b, size_t i, double h1, double h2, double P)
{
    const struct pk_bound_vtx *v = b->v;
    double pa[3], pc[3], c1 = 0.0, c2 = 0.0, dot = 0.0;
    point_at(v, b->n, v[i].s - h1, pa);
    point_at(v, b->n, v[i].s + h2, pc);
    for (int k = 0; k < 3; k++) {
        double u1 = v[i].p[k] - pa[k], u2 = pc[k] - v[i].p[k];
        c1 += u1 * u1;
        c2 += u2 * u2;
        dot += u1 * u2;
    }
    c1 = sqrt(c1);
    c2 = sqrt(c2);
    if (c1 <= 2.0 * P || c2 <= 2.0 * P)
        return INFINITY;
    double cs = dot / (c1 * c2);
    double theta = acos(cs > 1.0 ? 1.0 : cs < -1.0 ? -1.0 : cs);
    /* the chords of the path: each end moved by up to P */
    theta -= asin(2.0 * P / c1) + asin(2.0 * P / c2);
    if (theta <= 0.0)
        return INFINITY;
    double l1 = h1 + 2.0 * P, l2 = h2 + 2.0 * P, lmax = l1 > l2 ? l1 : l2;
    double k1 = 2.0 * theta / (l1 + l2), k2 = M_PI / (2.0 * lmax);
    double kappa = k1 < k2 ? k1 : k2;
    return b->acc_norm / kappa + 2.0 * b->acc_norm * lmax;
}

/* The window rule over half-widths 4P, 8P, 16P, ... at vertex i, below cap2. */
static double windows_cap2(const struct pk_bound *b, size_t i, double P, double cap2)
{
    const struct pk_bound_vtx *v = b->v;
    double before = v[i].s, after = v[b->n - 1].s - v[i].s;
    for (double h = 4.0 * P;; h *= 2.0) {
        /* a window caps no lower than 2 A h: wider ones cannot help */
        if (2.0 * b->acc_norm * h >= cap2)
            break;
        double h1 = h < before ? h : before, h2 = h < after ? h : after;
        double w = window_cap2(b, i, h1, h2, P);
        if (w < cap2)
            cap2 = w;
        if (h >= before && h >= after)
            break;
    }
    return cap2;
}

/* The cap of the inner vertex i of the collected piece. */
static double vertex_cap2(const struct pk_bound *b, size_t i, double piece_tol)
{
    const struct pk_bound_vtx *v = b->v;
    double t1[3] = { 0, 0, 0 }, t2[3] = { 0, 0, 0 };
    for (unsigned a = 0; a < b->cfg.axes && a < 3u; a++) {
        t1[a] = (v[i].p[a] - v[i - 1].p[a]) / v[i].len;
        t2[a] = (v[i + 1].p[a] - v[i].p[a]) / v[i + 1].len;
    }
    double tol = v[i + 1].tol; /* in force for the move that turns */
    double cap2 = corner_cap2(b, tol, t1, v[i].len, v[i].f2, t2, v[i + 1].len, v[i + 1].f2);
    if (tol > 0.0)
        cap2 = windows_cap2(b, i, piece_tol, cap2);
    return cap2;
}

/* Bound of the collected piece, from rest to rest; the piece is then empty
 * except for its last vertex (the start of the next one). */
static void flush(struct pk_bound *b)
{
    struct pk_bound_vtx *v = b->v;
    size_t n = b->n;
    if (n >= 2) {
        double piece_tol = 0.0;
        for (size_t i = 1; i < n; i++)
            if (v[i].tol > piece_tol)
                piece_tol = v[i].tol;
        v[0].cap2 = 0.0;
        v[n - 1].cap2 = 0.0;
        for (size_t i = 1; i + 1 < n; i++)
            v[i].cap2 = vertex_cap2(b, i, piece_tol);
        /* forward, then backward: v^2 changes by at most 2 A L per segment */
        for (size_t i = 1; i < n; i++) {
            double w = v[i - 1].cap2 + 2.0 * v[i].acc * v[i].len;
            if (w < v[i].cap2)
                v[i].cap2 = w;
        }
        for (size_t i = n - 1; i-- > 0;) {
            double w = v[i + 1].cap2 + 2.0 * v[i + 1].acc * v[i + 1].len;
            if (w < v[i].cap2)
                v[i].cap2 = w;
        }
        for (size_t i = 1; i < n; i++)
            b->time_s += pk_bound_trapezoid_s(v[i].len, sqrt(v[i - 1].cap2), sqrt(v[i].cap2), sqrt(v[i].f2),
                                              v[i].acc);
    }
    if (n > 0) {
        v[0] = v[n - 1];
        v[0].s = 0.0;
        b->n = 1;
    }
}

static int push(struct pk_bound *b, const double p_mm[3], double feed_mm_s)
{
    if (b->n == 0) {
        if (b->cap == 0) {
            b->cap = 1024;
            b->v = malloc(b->cap * sizeof *b->v);
            if (b->v == NULL) {
                b->oom = 1;
                return -1;
            }
        }
        memset(&b->v[0], 0, sizeof b->v[0]);
        memcpy(b->v[0].p, p_mm, sizeof b->v[0].p);
        b->n = 1;
        return 0;
    }
    const struct pk_bound_vtx *last = &b->v[b->n - 1];
    double d[3] = { 0, 0, 0 }, len = 0.0;
    for (unsigned a = 0; a < b->cfg.axes && a < 3u; a++) {
        d[a] = p_mm[a] - last->p[a];
        len += d[a] * d[a];
    }
    len = sqrt(len);
    if (len < EPS_MM)
        return 0;
    for (int k = 0; k < 3; k++)
        d[k] /= len;
    double f = dir_limit(&b->cfg, d, b->cfg.vmax_mm_s);
    if (feed_mm_s > 0.0 && feed_mm_s < f)
        f = feed_mm_s;
    if (b->n == b->cap) {
        struct pk_bound_vtx *nv = realloc(b->v, 2 * b->cap * sizeof *nv);
        if (nv == NULL) {
            b->oom = 1;
            return -1;
        }
        b->v = nv;
        b->cap *= 2;
        last = &b->v[b->n - 1];
    }
    struct pk_bound_vtx *nv = &b->v[b->n++];
    memcpy(nv->p, p_mm, sizeof nv->p);
    nv->cap2 = f * f; /* the corner caps come at the flush */
    nv->f2 = f * f;
    nv->s = last->s + len;
    nv->tol = b->tol_mm;
    nv->acc = dir_limit(&b->cfg, d, b->cfg.acc_mm_s2);
    nv->len = len;
    b->vertices++;
    return 0;
}

void pk_bound_prim(struct pk_bound *b, const struct pk_path_prim *p, double feed_mm_s, double tol_mm,
                   int tool_on)
{
    if (b->oom)
        return;
    double s[3] = { p->p0[0] / 1000.0, p->p0[1] / 1000.0, p->p0[2] / 1000.0 };
    if (b->tool >= 0 && tool_on != b->tool) {
        if (b->cfg.tool_stops)
            flush(b);
        b->time_s += b->cfg.settle_s;
    }
    b->tool = tool_on;
    if (b->n > 0) {
        const struct pk_bound_vtx *last = &b->v[b->n - 1];
        double gap = 0.0;
        for (unsigned a = 0; a < b->cfg.axes && a < 3u; a++)
            gap += (s[a] - last->p[a]) * (s[a] - last->p[a]);
        if (gap > 1e-6) { /* a jump (a reset, G92 is not one: machine coordinates) */
            flush(b);
            b->n = 0;
        }
    }
    b->tol_mm = tol_mm;
    if (b->n == 0 && push(b, s, feed_mm_s) != 0)
        return;
    if (p->kind == PK_PATH_LINE) {
        double e[3] = { p->p1[0] / 1000.0, p->p1[1] / 1000.0, p->p1[2] / 1000.0 };
        (void)push(b, e, feed_mm_s);
        return;
    }
    unsigned n = pk_path_prim_flatten_n(p, CHORD_UM);
    for (unsigned i = 1; i <= n && !b->oom; i++) {
        double q[3];
        pk_path_prim_eval(p, (double)i / n, q);
        double e[3] = { q[0] / 1000.0, q[1] / 1000.0, q[2] / 1000.0 };
        (void)push(b, e, feed_mm_s);
    }
}

double pk_bound_finish(struct pk_bound *b)
{
    if (!b->oom)
        flush(b);
    b->n = 0;
    return b->oom ? -1.0 : b->time_s;
}
