/*
 * sim_path.c — reference paths and the streaming deviation of an executed
 * path from them (see sim_path.h for the definition, accuracy and bounds).
 */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "sim_path.h"

#define PI_D 3.14159265358979323846
#define TWO_PI (2.0 * PI_D)
/* Grbl's ARC_ANGULAR_TRAVEL_EPSILON: a start and end angle closer than this
 * make a full circle (plan_arc in Grbl's motion_control.c). */
#define ARC_EPS_RAD 5e-7
#define BLK_SHIFT 5u   /* 32 entries per block */
#define GRP_SHIFT 10u  /* 1024 entries per group */
#define SEQ_NONE UINT64_MAX

/* In-plane axes (u, v) and the linear axis w of each plane. */
static const unsigned plane_axes[3][3] = { { 0, 1, 2 }, { 2, 0, 1 }, { 1, 2, 0 } };

/* ---- small vector helpers (dims axes) ------------------------------------ */
static double dist2_pts(const double *a, const double *b, unsigned dims)
{
    double s = 0.0;
    for (unsigned i = 0; i < dims; i++) {
        double d = a[i] - b[i];
        s += d * d;
    }
    return s;
}

/* Distance from p to segment ab; *t receives the parameter of the nearest point. */
static double seg_dist(const double *a, const double *b, const double *p, unsigned dims, double *t)
{
    double ab2 = 0.0, ap_ab = 0.0;
    for (unsigned i = 0; i < dims; i++) {
        double d = b[i] - a[i];
        ab2 += d * d;
        ap_ab += (p[i] - a[i]) * d;
    }
    double u = ab2 > 0.0 ? ap_ab / ab2 : 0.0;
    u = u < 0.0 ? 0.0 : u > 1.0 ? 1.0 : u;
    double s = 0.0;
    for (unsigned i = 0; i < dims; i++) {
        double d = a[i] + u * (b[i] - a[i]) - p[i];
        s += d * d;
    }
    if (t != NULL)
        *t = u;
    return sqrt(s);
}

/* ---- primitives ------------------------------------------------------------ */
void pk_path_line(struct pk_path_prim *out, const double a[3], const double b[3])
{
    memset(out, 0, sizeof *out);
    out->kind = PK_PATH_LINE;
    memcpy(out->p0, a, sizeof out->p0);
    memcpy(out->p1, b, sizeof out->p1);
}

int pk_path_arc(struct pk_path_prim *out, const double start[3], const double end[3],
                const double centre[2], enum pk_path_plane plane, int cw, unsigned turns)
{
    const unsigned *ax = plane_axes[plane];
    memset(out, 0, sizeof *out);
    out->kind = PK_PATH_ARC;
    out->plane = (uint8_t)plane;
    memcpy(out->p0, start, sizeof out->p0);
    memcpy(out->p1, end, sizeof out->p1);
    out->centre[0] = centre[0];
    out->centre[1] = centre[1];
    double su = start[ax[0]] - centre[0], sv = start[ax[1]] - centre[1];
    double eu = end[ax[0]] - centre[0], ev = end[ax[1]] - centre[1];
    out->r0 = hypot(su, sv);
    out->r1 = hypot(eu, ev);
    if (!(out->r0 > 0.0) || !(out->r1 > 0.0))
        return -1;
    out->a0 = atan2(sv, su);
    /* Grbl's angular travel: the angle between the two radius vectors. */
    double travel = atan2(su * ev - sv * eu, su * eu + sv * ev);
    if (cw) {
        if (travel >= -ARC_EPS_RAD)
            travel -= TWO_PI;
    } else if (travel <= ARC_EPS_RAD) {
        travel += TWO_PI;
    }
    out->sweep = travel + (cw ? -TWO_PI : TWO_PI) * (double)turns;
    return 0;
}

/* Point of an arc at fraction t of its sweep. */
static void arc_eval(const struct pk_path_prim *p, double t, double *out)
{
    const unsigned *ax = plane_axes[p->plane];
    double th = p->a0 + p->sweep * t, r = p->r0 + (p->r1 - p->r0) * t;
    out[ax[0]] = p->centre[0] + r * cos(th);
    out[ax[1]] = p->centre[1] + r * sin(th);
    out[ax[2]] = p->p0[ax[2]] + (p->p1[ax[2]] - p->p0[ax[2]]) * t;
}

void pk_path_prim_eval(const struct pk_path_prim *p, double t, double out[3])
{
    double s = 1.0 - t;
    switch (p->kind) {
    case PK_PATH_ARC:
        if (t <= 0.0)
            memcpy(out, p->p0, 3 * sizeof(double));
        else if (t >= 1.0 && p->r0 == p->r1)
            memcpy(out, p->p1, 3 * sizeof(double));
        else
            arc_eval(p, t, out);
        return;
    case PK_PATH_QUAD:
        for (int i = 0; i < 3; i++)
            out[i] = s * s * p->p0[i] + 2.0 * s * t * p->c[0][i] + t * t * p->p1[i];
        return;
    case PK_PATH_CUBIC:
        for (int i = 0; i < 3; i++)
            out[i] = s * s * s * p->p0[i] + 3.0 * s * s * t * p->c[0][i] + 3.0 * s * t * t * p->c[1][i] +
                     t * t * t * p->p1[i];
        return;
    case PK_PATH_LINE:
    default:
        for (int i = 0; i < 3; i++)
            out[i] = p->p0[i] + t * (p->p1[i] - p->p0[i]);
        return;
    }
}

/* Is angle phi within the sweep of arc p? */
static int arc_covers(const struct pk_path_prim *p, double phi, double *frac)
{
    double sw = fabs(p->sweep);
    double off = p->sweep > 0.0 ? phi - p->a0 : p->a0 - phi;
    off = fmod(off, TWO_PI);
    if (off < 0.0)
        off += TWO_PI;
    if (sw >= TWO_PI) {
        *frac = off / sw;
        return 1;
    }
    if (off <= sw) {
        *frac = off / sw;
        return 1;
    }
    return 0;
}

/* Closed form for a circular arc whose w is constant or not measured. */
static double arc_dist_planar(const struct pk_path_prim *p, const double *pt, unsigned dims, double *t)
{
    const unsigned *ax = plane_axes[p->plane];
    double pu = pt[ax[0]] - p->centre[0], pv = pt[ax[1]] - p->centre[1];
    double dw = ax[2] < dims ? pt[ax[2]] - p->p0[ax[2]] : 0.0;
    double rho = hypot(pu, pv), frac = 0.0;
    double best;
    if (rho > 0.0 && arc_covers(p, atan2(pv, pu), &frac)) {
        best = hypot(rho - p->r0, dw);
    } else if (rho == 0.0) {
        best = hypot(p->r0, dw); /* every point of the arc is at r */
        frac = 0.0;
    } else {
        double e0[3], e1[3];
        memcpy(e0, p->p0, sizeof e0);
        arc_eval(p, 1.0, e1);
        double d0 = dist2_pts(pt, e0, dims), d1 = dist2_pts(pt, e1, dims);
        best = sqrt(d0 <= d1 ? d0 : d1);
        frac = d0 <= d1 ? 0.0 : 1.0;
    }
    if (t != NULL)
        *t = frac;
    return best;
}

/* Bound on |c''(t)| over t in [0, 1] (dims axes). */
static double second_deriv_bound(const struct pk_path_prim *p, unsigned dims)
{
    double m = 0.0;
    if (p->kind == PK_PATH_QUAD) {
        double s = 0.0;
        for (unsigned i = 0; i < dims; i++) {
            double d = p->p0[i] - 2.0 * p->c[0][i] + p->p1[i];
            s += d * d;
        }
        m = 2.0 * sqrt(s);
    } else if (p->kind == PK_PATH_CUBIC) {
        double s0 = 0.0, s1 = 0.0;
        for (unsigned i = 0; i < dims; i++) {
            double d0 = p->p0[i] - 2.0 * p->c[0][i] + p->c[1][i];
            double d1 = p->c[0][i] - 2.0 * p->c[1][i] + p->p1[i];
            s0 += d0 * d0;
            s1 += d1 * d1;
        }
        m = 6.0 * sqrt(s0 > s1 ? s0 : s1);
    } else if (p->kind == PK_PATH_ARC) {
        double sw = fabs(p->sweep), rmax = p->r0 > p->r1 ? p->r0 : p->r1;
        m = sw * (sw * rmax + 2.0 * fabs(p->r1 - p->r0));
    }
    /* floating evaluation error of c(t): a few ulps of the coordinates */
    return m * (1.0 + 1e-12);
}

unsigned pk_path_prim_flatten_n(const struct pk_path_prim *p, double tol_um)
{
    if (p->kind == PK_PATH_LINE)
        return 1u;
    /* a piece of parameter length h is within M h^2 / 8 of its chord */
    double M = second_deriv_bound(p, 3u), n = ceil(sqrt(M / (8.0 * tol_um)));
    return n < 1.0 ? 1u : n > 1e6 ? 1000000u : (unsigned)n;
}

struct piece { double ta, tb, a[3], b[3]; };

/*
 * Branch and bound over the parameter: a piece [ta, tb] lies within
 * f = M (tb - ta)^2 / 8 of its chord (M bounds |c''|), so its points are at
 * least dist(P, chord) - f from P; the chord point nearest P has a curve point
 * within f. Pieces whose lower bound cannot beat the best curve point by more
 * than the accuracy are dropped, the others halved. Iterative, with a fixed
 * stack: depth-first, the nearer half first.
 */
#define BB_STACK 128
static double curve_dist(const struct pk_path_prim *p, const double *pt, unsigned dims, double *t_out)
{
    const double M = second_deriv_bound(p, dims), eps = PK_PATH_EPS_UM;
    struct piece st[BB_STACK];
    unsigned n = 0;
    double best2, best_t;
    /* initial pieces: at most 45 degrees of an arc each, 8 for a Bézier */
    unsigned k0 = 8;
    if (p->kind == PK_PATH_ARC) {
        double q = ceil(fabs(p->sweep) / (PI_D / 4.0));
        k0 = q < 1.0 ? 1u : q > 64.0 ? 64u : (unsigned)q;
    }
    double e0[3];
    pk_path_prim_eval(p, 0.0, e0);
    best2 = dist2_pts(pt, e0, dims);
    best_t = 0.0;
    /* push the initial pieces, last first, so that they run in order */
    double prev[3];
    struct piece init[64];
    memcpy(prev, e0, sizeof prev);
    for (unsigned i = 0; i < k0; i++) {
        struct piece *q = &init[i];
        q->ta = (double)i / k0;
        q->tb = (double)(i + 1u) / k0;
        memcpy(q->a, prev, sizeof prev);
        pk_path_prim_eval(p, q->tb, q->b);
        memcpy(prev, q->b, sizeof prev);
        double d2 = dist2_pts(pt, q->b, dims);
        if (d2 < best2) {
            best2 = d2;
            best_t = q->tb;
        }
    }
    for (unsigned i = k0; i-- > 0;)
        st[n++] = init[i];
    while (n > 0) {
        struct piece q = st[--n];
        double h = q.tb - q.ta, f = M * h * h / 8.0, u;
        double dc = seg_dist(q.a, q.b, pt, dims, &u);
        double best = sqrt(best2);
        if (dc - f >= best - eps)
            continue; /* cannot improve by more than eps */
        double tm = q.ta + u * h, cm[3];
        pk_path_prim_eval(p, tm, cm);
        double d2 = dist2_pts(pt, cm, dims);
        if (d2 < best2) {
            best2 = d2;
            best_t = tm;
        }
        if (2.0 * f <= eps || n + 2u > BB_STACK || h < 1e-15)
            continue; /* leaf: its points are within 2f of this one */
        double mid = 0.5 * (q.ta + q.tb), cmid[3];
        pk_path_prim_eval(p, mid, cmid);
        d2 = dist2_pts(pt, cmid, dims);
        if (d2 < best2) {
            best2 = d2;
            best_t = mid;
        }
        struct piece l = { q.ta, mid, { 0 }, { 0 } }, r = { mid, q.tb, { 0 }, { 0 } };
        memcpy(l.a, q.a, sizeof l.a);
        memcpy(l.b, cmid, sizeof l.b);
        memcpy(r.a, cmid, sizeof r.a);
        memcpy(r.b, q.b, sizeof r.b);
        double dl = seg_dist(l.a, l.b, pt, dims, NULL), dr = seg_dist(r.a, r.b, pt, dims, NULL);
        if (dl <= dr) {
            st[n++] = r;
            st[n++] = l;
        } else {
            st[n++] = l;
            st[n++] = r;
        }
    }
    if (t_out != NULL)
        *t_out = best_t;
    return sqrt(best2);
}

double pk_path_prim_dist(const struct pk_path_prim *p, const double pt[3], unsigned dims, double *t_out)
{
    switch (p->kind) {
    case PK_PATH_LINE:
        return seg_dist(p->p0, p->p1, pt, dims, t_out);
    case PK_PATH_ARC: {
        const unsigned w = plane_axes[p->plane][2];
        int planar_w = w >= dims || p->p0[w] == p->p1[w];
        int inplane = dims == 3 || p->plane == PK_PLANE_XY;
        if (p->r0 == p->r1 && planar_w && inplane)
            return arc_dist_planar(p, pt, dims, t_out);
        return curve_dist(p, pt, dims, t_out);
    }
    default:
        return curve_dist(p, pt, dims, t_out);
    }
}

/* ---- bounding boxes --------------------------------------------------------- */
static void box_empty(double lo[3], double hi[3])
{
    for (int i = 0; i < 3; i++) {
        lo[i] = INFINITY;
        hi[i] = -INFINITY;
    }
}

static void box_add(double lo[3], double hi[3], const double *q)
{
    for (int i = 0; i < 3; i++) {
        if (q[i] < lo[i])
            lo[i] = q[i];
        if (q[i] > hi[i])
            hi[i] = q[i];
    }
}

static void prim_box(const struct pk_path_prim *p, double lo[3], double hi[3])
{
    box_empty(lo, hi);
    box_add(lo, hi, p->p0);
    box_add(lo, hi, p->p1);
    if (p->kind == PK_PATH_QUAD || p->kind == PK_PATH_CUBIC) {
        box_add(lo, hi, p->c[0]); /* convex hull of the control points */
        if (p->kind == PK_PATH_CUBIC)
            box_add(lo, hi, p->c[1]);
    } else if (p->kind == PK_PATH_ARC) {
        const unsigned *ax = plane_axes[p->plane];
        double e1[3];
        arc_eval(p, 1.0, e1);
        box_add(lo, hi, e1);
        if (p->r0 == p->r1 && fabs(p->sweep) < TWO_PI) {
            /* a circular arc: its ends and the axis extremes it passes */
            for (int k = 0; k < 4; k++) {
                double phi = k * (PI_D / 2.0), frac, q[3];
                if (arc_covers(p, phi, &frac)) {
                    memcpy(q, p->p0, sizeof q);
                    q[ax[0]] = p->centre[0] + p->r0 * cos(phi);
                    q[ax[1]] = p->centre[1] + p->r0 * sin(phi);
                    box_add(lo, hi, q);
                }
            }
        } else {
            double r = p->r0 > p->r1 ? p->r0 : p->r1;
            lo[ax[0]] = fmin(lo[ax[0]], p->centre[0] - r);
            hi[ax[0]] = fmax(hi[ax[0]], p->centre[0] + r);
            lo[ax[1]] = fmin(lo[ax[1]], p->centre[1] - r);
            hi[ax[1]] = fmax(hi[ax[1]], p->centre[1] + r);
        }
        /* rounding of cos/sin: widen by a hair */
        for (int i = 0; i < 3; i++) {
            double w = 1e-9 * (fabs(lo[i]) + fabs(hi[i])) + 1e-9;
            lo[i] -= w;
            hi[i] += w;
        }
    }
}

/* Distance from q to a box (0 inside), dims axes. */
static double box_dist(const double *lo, const double *hi, const double *q, unsigned dims)
{
    double s = 0.0;
    for (unsigned i = 0; i < dims; i++) {
        double d = q[i] < lo[i] ? lo[i] - q[i] : q[i] > hi[i] ? q[i] - hi[i] : 0.0;
        s += d * d;
    }
    return sqrt(s);
}

static double ent_box_dist(const struct pk_path_ent *e, const double *q, unsigned dims)
{
    double lo[3] = { e->lo[0], e->lo[1], e->lo[2] }, hi[3] = { e->hi[0], e->hi[1], e->hi[2] };
    return box_dist(lo, hi, q, dims);
}

/* ---- the window ---------------------------------------------------------------- */
/* Block and group boxes: one slot more than the window can fill, so the
 * (at most) cap/32 + 1 blocks a window of cap entries spans never share one. */
static uint32_t nblk(const struct pk_path *pa) { return (pa->cap >> BLK_SHIFT) + 1u; }
static uint32_t ngrp(const struct pk_path *pa) { return (pa->cap >> GRP_SHIFT) + 1u; }
static struct pk_path_box *blk_of(const struct pk_path *pa, uint64_t seq)
{
    return &pa->blk[(seq >> BLK_SHIFT) % nblk(pa)];
}
static struct pk_path_box *grp_of(const struct pk_path *pa, uint64_t seq)
{
    return &pa->grp[(seq >> GRP_SHIFT) % ngrp(pa)];
}
static struct pk_path_ent *ent(const struct pk_path *pa, uint64_t seq)
{
    return &pa->ring[seq & (pa->cap - 1u)];
}

int pk_path_init(struct pk_path *pa, unsigned dims, uint32_t cap, double step_um)
{
    memset(pa, 0, sizeof *pa);
    uint32_t c = 1024u;
    if (cap == 0u)
        cap = PK_PATH_CAP_DEFAULT;
    while (c < cap && c < (1u << 30))
        c <<= 1;
    pa->dims = dims == 2u ? 2u : 3u;
    pa->cap = c;
    pa->ring = calloc(c, sizeof *pa->ring);
    pa->blk = calloc(nblk(pa), sizeof *pa->blk);
    pa->grp = calloc(ngrp(pa), sizeof *pa->grp);
    pa->hist = calloc(PK_PATH_HIST_BINS, sizeof *pa->hist);
    pa->dup = calloc(2u * (size_t)c, sizeof *pa->dup);
    pa->edge = malloc((PK_PATH_HIST_BINS + 1u) * sizeof *pa->edge);
    pa->gslot = calloc(PK_PATH_GRID_SLOTS, sizeof *pa->gslot);
    pa->gnode = malloc(PK_PATH_GRID_NODES * sizeof *pa->gnode);
    pa->longl = malloc(PK_PATH_LONG_MAX * sizeof *pa->longl);
    if (pa->ring == NULL || pa->blk == NULL || pa->grp == NULL || pa->hist == NULL || pa->dup == NULL ||
        pa->edge == NULL || pa->gslot == NULL || pa->gnode == NULL || pa->longl == NULL)
        return -1;
    for (unsigned k = 0; k <= PK_PATH_HIST_BINS; k++)
        pa->edge[k] = PK_PATH_HIST_MIN_UM * pow(1.0 + PK_PATH_HIST_REL, (double)k);
    pa->m_min_um = step_um > 0.0 ? step_um / 2.0 : 1.0;
    pa->m_um = 4.0 * pa->m_min_um;
    pa->cursor = SEQ_NONE;
    pa->lag_min_cur = pa->lag_min_prev = SEQ_NONE;
    return 0;
}

void pk_path_free(struct pk_path *pa)
{
    free(pa->ring);
    free(pa->blk);
    free(pa->grp);
    free(pa->hist);
    free(pa->dup);
    free(pa->edge);
    free(pa->gslot);
    free(pa->gnode);
    free(pa->longl);
    pa->gslot = NULL;
    pa->gnode = NULL;
    pa->longl = NULL;
    pa->dup = NULL;
    pa->edge = NULL;
    pa->ring = NULL;
    pa->blk = pa->grp = NULL;
    pa->hist = NULL;
}

size_t pk_path_room(const struct pk_path *pa)
{
    uint64_t held = pa->head - pa->tail;
    uint64_t rel = pa->released > pa->tail ? pa->released - pa->tail : 0u;
    if (rel > held)
        rel = held;
    return (size_t)(pa->cap - held + rel);
}

void pk_path_all_executed(struct pk_path *pa)
{
    uint64_t r = pa->head > PK_PATH_BACK ? pa->head - PK_PATH_BACK : 0u;
    if (r > pa->released)
        pa->released = r;
}

/* Keep the candidate list sorted by distance to the anchor, then by seq. */
static void cand_insert(struct pk_path *pa, uint64_t seq, double d)
{
    if (pa->n_cand >= PK_PATH_CAND_MAX) {
        pa->anchor_ok = 0; /* too many: rebuild with a smaller radius */
        return;
    }
    unsigned i = pa->n_cand++;
    while (i > 0 && (pa->cand[i - 1].d_anchor > d ||
                     (pa->cand[i - 1].d_anchor == d && pa->cand[i - 1].seq > seq))) {
        pa->cand[i] = pa->cand[i - 1];
        i--;
    }
    pa->cand[i] = (struct pk_path_cand){ seq, d };
}

static double xy_len(const struct pk_path_prim *p);

static void drop_oldest(struct pk_path *pa)
{
    uint64_t s = pa->tail++;
    pa->win_len_um -= xy_len(&ent(pa, s)->p);
    if (s < pa->released)
        pa->st.dropped++;
    else
        pa->st.forced_drops++;
    if (pa->anchor_ok) {
        for (unsigned i = 0; i < pa->n_cand; i++)
            if (pa->cand[i].seq == s) {
                pa->anchor_ok = 0; /* the list no longer proves anything */
                break;
            }
    }
}

/* ---- the grid ------------------------------------------------------------------ */
#define GRID_MIN_ENTRIES 1024u /* below this the hierarchy alone is cheap */
#define GRID_CELLS_MAX 256u    /* cells an entry may take, else the long list */
#define GRID_QUERY_CELLS 8.0   /* radius (in cells) above which the hierarchy is used */
#define GRID_MIN_CELL_UM 20.0
#define GRID_MAX_CELL_UM 1e6

static int64_t gkey(int64_t ix, int64_t iy) { return (int64_t)((uint64_t)ix << 32) ^ (int64_t)(uint32_t)iy; }
static uint32_t ghash(int64_t k)
{
    uint64_t h = (uint64_t)k * 0x9E3779B97F4A7C15ull;
    return (uint32_t)(h >> 32) ^ (uint32_t)h;
}

/* The slot of a cell; create: make it if missing (NULL if the table is too full). */
static struct pk_path_gslot *gslot_of(struct pk_path *pa, int64_t key, int create)
{
    const uint32_t mask = PK_PATH_GRID_SLOTS - 1u;
    uint32_t i = ghash(key) & mask;
    for (uint32_t n = 0; n < PK_PATH_GRID_SLOTS; n++, i = (i + 1u) & mask) {
        struct pk_path_gslot *sl = &pa->gslot[i];
        if (!sl->used) {
            if (!create || pa->g_slots_used >= PK_PATH_GRID_SLOTS / 4u * 3u)
                return NULL;
            sl->used = 1;
            sl->key = key;
            sl->head = 0;
            pa->g_slots_used++;
            return sl;
        }
        if (sl->key == key)
            return sl;
    }
    return NULL;
}

struct gcells { int64_t c[8][2]; unsigned n; };

/* Register seq in cell (ix, iy), unless it was one of the last few. 0, or -1 (full). */
static int grid_put(struct pk_path *pa, uint64_t seq, int64_t ix, int64_t iy, struct gcells *recent)
{
    for (unsigned k = 0; k < recent->n; k++)
        if (recent->c[k][0] == ix && recent->c[k][1] == iy)
            return 0;
    recent->c[recent->n % 8u][0] = ix;
    recent->c[recent->n % 8u][1] = iy;
    if (recent->n < 8u)
        recent->n++;
    if (pa->g_nodes >= PK_PATH_GRID_NODES)
        return -1;
    struct pk_path_gslot *sl = gslot_of(pa, gkey(ix, iy), 1);
    if (sl == NULL)
        return -1;
    struct pk_path_gnode *nd = &pa->gnode[pa->g_nodes];
    nd->seq = (uint32_t)seq;
    nd->next = sl->head;
    sl->head = ++pa->g_nodes;
    return 0;
}

/* Every cell of the box [x0, x1] x [y0, y1] (at most 2 x 2 for the pieces used). */
static int grid_box(struct pk_path *pa, uint64_t seq, double x0, double y0, double x1, double y1,
                    struct gcells *recent)
{
    const double c = pa->cell_um;
    int64_t i0 = (int64_t)floor(x0 / c), i1 = (int64_t)floor(x1 / c);
    int64_t j0 = (int64_t)floor(y0 / c), j1 = (int64_t)floor(y1 / c);
    for (int64_t i = i0; i <= i1; i++)
        for (int64_t j = j0; j <= j1; j++)
            if (grid_put(pa, seq, i, j, recent) != 0)
                return -1;
    return 0;
}

/* Register the cells a straight piece a-b passes through, padded by pad. */
static int grid_piece(struct pk_path *pa, uint64_t seq, const double *a, const double *b, double pad0)
{
    const double c = pa->cell_um;
    struct gcells recent = { { { 0 } }, 0 };
    unsigned n = (unsigned)ceil(hypot(b[0] - a[0], b[1] - a[1]) / c);
    n = n < 1u ? 1u : n;
    for (unsigned k = 0; k < n; k++) {
        double t0 = (double)k / n, t1 = (double)(k + 1u) / n;
        double x0 = a[0] + (b[0] - a[0]) * t0, y0 = a[1] + (b[1] - a[1]) * t0;
        double x1 = a[0] + (b[0] - a[0]) * t1, y1 = a[1] + (b[1] - a[1]) * t1;
        double pad = pad0 + 1e-9 * (fabs(x0) + fabs(y0) + fabs(x1) + fabs(y1)) + 1e-9;
        if (grid_box(pa, seq, fmin(x0, x1) - pad, fmin(y0, y1) - pad, fmax(x0, x1) + pad, fmax(y0, y1) + pad,
                     &recent) != 0)
            return -1;
    }
    return 0;
}

/* Length of a primitive in X, Y (its control polygon for curves, an upper bound). */
static double xy_len(const struct pk_path_prim *p)
{
    if (p->kind == PK_PATH_LINE)
        return hypot(p->p1[0] - p->p0[0], p->p1[1] - p->p0[1]);
    if (p->kind == PK_PATH_ARC)
        return fabs(p->sweep) * fmax(p->r0, p->r1) + fabs(p->r1 - p->r0) + fabs(p->p1[2] - p->p0[2]);
    double len = hypot(p->c[0][0] - p->p0[0], p->c[0][1] - p->p0[1]);
    if (p->kind == PK_PATH_QUAD)
        return len + hypot(p->p1[0] - p->c[0][0], p->p1[1] - p->c[0][1]);
    return len + hypot(p->c[1][0] - p->c[0][0], p->c[1][1] - p->c[0][1]) +
           hypot(p->p1[0] - p->c[1][0], p->p1[1] - p->c[1][1]);
}

/*
 * Register entry seq in every cell it passes through: the curve is cut into
 * pieces no longer than a cell (chords within a quarter cell of the curve,
 * which pads each piece's box), and each piece's box names at most 2 x 2
 * cells. An entry that would take more than GRID_CELLS_MAX cells, or that
 * lies out of the grid's index range, goes to the long list.
 * @return 0, or -1 if the pool, the table or the long list is full
 */
static int grid_add(struct pk_path *pa, uint64_t seq)
{
    struct pk_path_ent *e = ent(pa, seq);
    const struct pk_path_prim *p = &e->p;
    const double c = pa->cell_um;
    double len = xy_len(p);
    int big = len / c > GRID_CELLS_MAX / 4.0;
    for (int i = 0; i < 2 && !big; i++)
        big = fabs(e->lo[i]) / c > 1e9 || fabs(e->hi[i]) / c > 1e9;
    if (big) {
        if (pa->n_long >= PK_PATH_LONG_MAX)
            return -1;
        pa->longl[pa->n_long++] = seq;
        e->in_grid = 0;
        return 0;
    }
    e->in_grid = 1;
    struct gcells recent = { { { 0 } }, 0 };
    if (p->kind == PK_PATH_LINE) /* padded: a run that grows within the merge distance stays covered */
        return grid_piece(pa, seq, p->p0, p->p1, PK_PATH_MERGE_UM);
    /* curves: chords within c/4 of the curve, each cut to pieces of <= c */
    unsigned n = pk_path_prim_flatten_n(p, c / 4.0);
    double a[3];
    pk_path_prim_eval(p, 0.0, a);
    for (unsigned k = 1; k <= n; k++) {
        double b[3];
        pk_path_prim_eval(p, (double)k / n, b);
        double cl = hypot(b[0] - a[0], b[1] - a[1]);
        unsigned m = (unsigned)ceil(cl / c);
        m = m < 1u ? 1u : m;
        for (unsigned j = 0; j < m; j++) {
            double t0 = (double)j / m, t1 = (double)(j + 1u) / m;
            double x0 = a[0] + (b[0] - a[0]) * t0, y0 = a[1] + (b[1] - a[1]) * t0;
            double x1 = a[0] + (b[0] - a[0]) * t1, y1 = a[1] + (b[1] - a[1]) * t1;
            double pad = c / 4.0 + 1e-9 * (fabs(x0) + fabs(y0)) + 1e-9;
            if (grid_box(pa, seq, fmin(x0, x1) - pad, fmin(y0, y1) - pad, fmax(x0, x1) + pad, fmax(y0, y1) + pad,
                         &recent) != 0)
                return -1;
        }
        memcpy(a, b, sizeof a);
    }
    return 0;
}

/*
 * Start the grid again from the live entries with the smallest cell that
 * leaves half the pool free: an entry of length L takes about 3 (L / c + 1)
 * nodes, so c >= sum L / (nodes / 6 - live); doubled until they fit.
 */
static void grid_rebuild(struct pk_path *pa)
{
    double sum = 0.0;
    uint64_t live = 0;
    for (uint64_t s = pa->tail; s < pa->head; s++)
        if (!ent(pa, s)->dead) {
            sum += xy_len(&ent(pa, s)->p);
            live++;
        }
    double room = (double)PK_PATH_GRID_NODES / 6.0 - (double)live;
    double c = room > 0.0 ? sum / room : GRID_MAX_CELL_UM;
    c = c < GRID_MIN_CELL_UM ? GRID_MIN_CELL_UM : c;
    pa->grid_rebuilds++;
    for (; c <= GRID_MAX_CELL_UM; c *= 2.0) {
        memset(pa->gslot, 0, PK_PATH_GRID_SLOTS * sizeof *pa->gslot);
        pa->g_nodes = pa->g_slots_used = 0;
        pa->n_long = 0;
        pa->cell_um = c;
        int ok = 1;
        for (uint64_t s = pa->tail; s < pa->head && ok; s++)
            if (!ent(pa, s)->dead)
                ok = grid_add(pa, s) == 0;
        /* room to grow before the next rebuild */
        if (ok && pa->g_nodes <= PK_PATH_GRID_NODES / 2u && pa->g_slots_used <= PK_PATH_GRID_SLOTS / 2u &&
            pa->n_long <= PK_PATH_LONG_MAX / 2u) {
            pa->grid_on = 1;
            return;
        }
    }
    pa->grid_on = 0; /* nothing fits: the hierarchy alone */
}

/* A new entry: into the grid, rebuilding it when full (or building it once
 * the window is big enough to need it). */
static void grid_insert(struct pk_path *pa, uint64_t seq)
{
    if (!pa->grid_on) {
        if (pa->head - pa->tail >= GRID_MIN_ENTRIES && pa->gslot != NULL && pa->grid_rebuilds == 0u)
            grid_rebuild(pa);
        return;
    }
    if (grid_add(pa, seq) != 0)
        grid_rebuild(pa); /* includes seq */
}

typedef void (*visit_fn)(struct pk_path *pa, uint64_t seq, double *lim, const double *q, void *arg);

/* Visit the entries registered in the cells within *lim of q (each once).
 * Returns 0, or -1 if the grid cannot answer (off, or the radius too big). */
static int grid_visit(struct pk_path *pa, const double *q, double *lim, visit_fn fn, void *arg)
{
    const double c = pa->cell_um, R = *lim;
    if (!pa->grid_on || !(R <= GRID_QUERY_CELLS * c))
        return -1;
    if (++pa->stamp == 0u) { /* wrapped: forget every stamp */
        for (uint32_t i = 0; i < pa->cap; i++)
            pa->ring[i].stamp = 0;
        pa->stamp = 1;
    }
    const uint32_t st = pa->stamp;
    int64_t i0 = (int64_t)floor((q[0] - R) / c), i1 = (int64_t)floor((q[0] + R) / c);
    int64_t j0 = (int64_t)floor((q[1] - R) / c), j1 = (int64_t)floor((q[1] + R) / c);
    for (int64_t i = i0; i <= i1; i++)
        for (int64_t j = j0; j <= j1; j++) {
            const struct pk_path_gslot *sl = gslot_of(pa, gkey(i, j), 0);
            for (uint32_t nd = sl != NULL ? sl->head : 0u; nd != 0u; nd = pa->gnode[nd - 1u].next) {
                uint32_t back = (uint32_t)pa->head - pa->gnode[nd - 1u].seq; /* the window is < 2^32 */
                if (back == 0u || back > pa->head - pa->tail)
                    continue; /* dropped since */
                uint64_t s = pa->head - back;
                struct pk_path_ent *e = ent(pa, s);
                if (e->dead || e->stamp == st)
                    continue;
                e->stamp = st;
                if (ent_box_dist(e, q, pa->dims) <= *lim)
                    fn(pa, s, lim, q, arg);
            }
        }
    for (uint32_t k = 0; k < pa->n_long; k++) {
        uint64_t s = pa->longl[k];
        if (s < pa->tail || s >= pa->head)
            continue;
        struct pk_path_ent *e = ent(pa, s);
        if (e->dead || e->stamp == st)
            continue;
        e->stamp = st;
        if (ent_box_dist(e, q, pa->dims) <= *lim)
            fn(pa, s, lim, q, arg);
    }
    return 0;
}


/* ---- repeated strokes ------------------------------------------------------------ */
/* Same point set? Lines either way round; curves as given. */
static int same_set(const struct pk_path_prim *a, const struct pk_path_prim *b)
{
    if (a->kind != b->kind)
        return 0;
    int fwd = memcmp(a->p0, b->p0, sizeof a->p0) == 0 && memcmp(a->p1, b->p1, sizeof a->p1) == 0;
    if (a->kind == PK_PATH_LINE)
        return fwd || (memcmp(a->p0, b->p1, sizeof a->p0) == 0 && memcmp(a->p1, b->p0, sizeof a->p1) == 0);
    if (!fwd)
        return 0;
    if (a->kind == PK_PATH_ARC)
        return a->plane == b->plane && a->centre[0] == b->centre[0] && a->centre[1] == b->centre[1] &&
               a->r0 == b->r0 && a->r1 == b->r1 && a->a0 == b->a0 && a->sweep == b->sweep;
    return memcmp(a->c, b->c, sizeof a->c) == 0;
}

static uint64_t mix(uint64_t h, double v)
{
    uint64_t u;
    v = v == 0.0 ? 0.0 : v; /* -0 and +0 alike */
    memcpy(&u, &v, sizeof u);
    h ^= u + 0x9E3779B97F4A7C15ull + (h << 6) + (h >> 2);
    return h * 0xff51afd7ed558ccdull;
}

/* A hash that does not depend on a line's direction. */
static uint64_t geo_hash(const struct pk_path_prim *p)
{
    uint64_t ha = 0x12345u, hb = 0x6789u;
    for (int i = 0; i < 3; i++) {
        ha = mix(ha, p->p0[i]);
        hb = mix(hb, p->p1[i]);
    }
    uint64_t h = (ha ^ hb) + (ha + hb) * 31u + p->kind;
    if (p->kind != PK_PATH_LINE)
        for (int i = 0; i < 3; i++)
            h = mix(h, p->c[0][i] + p->centre[0] * (i == 0) + p->sweep * (i == 1));
    return h ^ (h >> 29);
}

static uint64_t dup_replace(struct pk_path *pa, uint64_t seq);

/* After cap insertions the table may hold up to cap stale slots: start it
 * again from the live entries of the window (O(1) per insertion overall). */
static void dup_rebuild(struct pk_path *pa)
{
    memset(pa->dup, 0, 2u * (size_t)pa->cap * sizeof *pa->dup);
    for (uint64_t s = pa->tail; s < pa->head; s++)
        if (!ent(pa, s)->dead)
            (void)dup_replace(pa, s);
    pa->dup_inserts = 0;
}

/* Enter seq; a live entry with the same point set is marked dead (returned), or SEQ_NONE. */
static uint64_t dup_replace(struct pk_path *pa, uint64_t seq)
{
    const struct pk_path_prim *p = &ent(pa, seq)->p;
    const size_t mask = 2u * (size_t)pa->cap - 1u;
    size_t i = (size_t)geo_hash(p) & mask, free_slot = SIZE_MAX;
    for (size_t probes = 0; probes <= mask; probes++, i = (i + 1u) & mask) {
        uint64_t v = pa->dup[i];
        if (v == 0u)
            break;
        uint64_t s = v - 1u;
        if (s < pa->tail || ent(pa, s)->dead) {
            if (free_slot == SIZE_MAX)
                free_slot = i;
            continue;
        }
        if (same_set(&ent(pa, s)->p, p)) {
            ent(pa, s)->dead = 1;
            pa->dup[i] = seq + 1u;
            return s;
        }
    }
    if (free_slot == SIZE_MAX)
        free_slot = i;
    pa->dup[free_slot] = seq + 1u;
    return SEQ_NONE;
}


/* ---- runs of lines ----------------------------------------------------------- */
/* A line entry's cone: the directions (from its start, in X-Y) its end may
 * take with every vertex of its run within PK_PATH_MERGE_UM of the segment. */
static void cone_start(struct pk_path_ent *e)
{
    double dx = e->p.p1[0] - e->p.p0[0], dy = e->p.p1[1] - e->p.p0[1], r = hypot(dx, dy);
    e->cone_ref = atan2(dy, dx);
    double half = r > PK_PATH_MERGE_UM ? asin(PK_PATH_MERGE_UM / r) : PI_D;
    e->cone_lo = -half;
    e->cone_hi = half;
}

static double wrap_pi(double a)
{
    while (a > PI_D)
        a -= TWO_PI;
    while (a <= -PI_D)
        a += TWO_PI;
    return a;
}

static int grid_piece(struct pk_path *pa, uint64_t seq, const double *a, const double *b, double pad);

/*
 * Extend the newest entry by q (masked to dims) if q continues it: exactly
 * (collinear, same direction, from its end), or, while the window is short
 * of room, within PK_PATH_MERGE_UM (the cone rule: the new end's direction
 * within every earlier vertex's allowance, asin(d / r), and no nearer to the
 * start than the old end, so every vertex projects inside the segment).
 * Returns 1 if merged.
 */
static int try_merge(struct pk_path *pa, const struct pk_path_prim *q)
{
    if (q->kind != PK_PATH_LINE || pa->head == pa->tail)
        return 0;
    const uint64_t seq = pa->head - 1u;
    struct pk_path_ent *e = ent(pa, seq);
    if (e->dead || e->p.kind != PK_PATH_LINE || e->p.drawn != q->drawn || e->p.rapid != q->rapid ||
        memcmp(q->p0, e->p.p1, sizeof q->p0) != 0)
        return 0;
    const double *S = e->p.p0, *M = e->p.p1, *E = q->p1;
    double d1[3], d2[3];
    for (int i = 0; i < 3; i++) {
        d1[i] = M[i] - S[i];
        d2[i] = E[i] - M[i];
    }
    double cx = d1[1] * d2[2] - d1[2] * d2[1], cy = d1[2] * d2[0] - d1[0] * d2[2], cz = d1[0] * d2[1] - d1[1] * d2[0];
    double dot = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2];
    int exact = cx == 0.0 && cy == 0.0 && cz == 0.0 && dot > 0.0;
    double rx = E[0] - S[0], ry = E[1] - S[1], r = hypot(rx, ry);
    double delta = wrap_pi(atan2(ry, rx) - e->cone_ref);
    if (!exact) {
        int flat = S[2] == M[2] && M[2] == E[2];
        size_t room = pk_path_room(pa);
        if (!flat || room >= pa->cap / 4u || hypot(d1[0], d1[1]) <= PK_PATH_MERGE_UM ||
            r < hypot(d1[0], d1[1]) || delta < e->cone_lo || delta > e->cone_hi)
            return 0;
    }
    /* extend */
    double old[3];
    memcpy(old, M, sizeof old);
    memcpy(e->p.p1, E, sizeof e->p.p1);
    e->line_last = q->line;
    if (r > PK_PATH_MERGE_UM) {
        double half = asin(PK_PATH_MERGE_UM / r);
        e->cone_lo = fmax(e->cone_lo, delta - half);
        e->cone_hi = fmin(e->cone_hi, delta + half);
    }
    if (exact) {
        pa->st.merged++;
    } else {
        pa->st.merged_approx++;
        pa->st.approx_um = PK_PATH_MERGE_UM;
    }
    for (int i = 0; i < 3; i++) {
        e->lo[i] = fminf(e->lo[i], nextafterf((float)E[i], -INFINITY));
        e->hi[i] = fmaxf(e->hi[i], nextafterf((float)E[i], INFINITY));
    }
    double elo[3] = { e->lo[0], e->lo[1], e->lo[2] }, ehi[3] = { e->hi[0], e->hi[1], e->hi[2] };
    box_add(blk_of(pa, seq)->lo, blk_of(pa, seq)->hi, elo);
    box_add(blk_of(pa, seq)->lo, blk_of(pa, seq)->hi, ehi);
    box_add(grp_of(pa, seq)->lo, grp_of(pa, seq)->hi, elo);
    box_add(grp_of(pa, seq)->lo, grp_of(pa, seq)->hi, ehi);
    pa->win_len_um += hypot(E[0] - old[0], E[1] - old[1]);
    /* the grid: the new piece, padded by the merge distance (the segment now
     * lies within it of the pieces registered) */
    if (pa->grid_on && e->in_grid && grid_piece(pa, seq, old, E, PK_PATH_MERGE_UM) != 0)
        grid_rebuild(pa);
    /* the candidate list */
    if (pa->anchor_ok) {
        for (unsigned i = 0; i < pa->n_cand; i++)
            if (pa->cand[i].seq == seq)
                pa->anchor_ok = 0; /* its distance changed */
        if (pa->anchor_ok && ent_box_dist(e, pa->anchor, pa->dims) <= pa->r_um) {
            double d = pk_path_prim_dist(&e->p, pa->anchor, pa->dims, NULL);
            if (d <= pa->r_um)
                cand_insert(pa, seq, d);
        }
    }
    memcpy(pa->last_end, E, sizeof pa->last_end);
    return 1;
}

void pk_path_add(struct pk_path *pa, const struct pk_path_prim *p_in)
{
    struct pk_path_prim pm = *p_in;
    const struct pk_path_prim *p = &pm;
    pa->st.prims++;
    if (pa->dims == 2u) {
        /* the third axis is not measured: keep it out of every computation */
        pm.p0[2] = pm.p1[2] = pm.c[0][2] = pm.c[1][2] = 0.0;
        if (p_in->plane != PK_PLANE_XY && p_in->kind == PK_PATH_ARC) {
            /* an arc out of the XY plane projects onto a line or an ellipse:
             * keep its exact 3-D definition and measure in 2-D (curve_dist) */
            pm.p0[2] = p_in->p0[2];
            pm.p1[2] = p_in->p1[2];
        }
    }
    if (p->kind == PK_PATH_LINE && pa->has_last && memcmp(p->p0, p->p1, sizeof p->p0) == 0 &&
        memcmp(p->p0, pa->last_end, sizeof p->p0) == 0)
        return; /* a repeated point: already on the path */
    if (try_merge(pa, p))
        return;
    if (pa->head - pa->tail == pa->cap)
        drop_oldest(pa);
    while (pa->win_len_um > PK_PATH_LEN_MAX && pa->tail < pa->released && pa->tail < pa->head)
        drop_oldest(pa); /* a long window of released strokes: let them go now */
    if (pa->dup_inserts >= pa->cap)
        dup_rebuild(pa); /* before the new entry exists */
    uint64_t seq = pa->head++;
    struct pk_path_ent *e = ent(pa, seq);
    double lo[3], hi[3];
    e->p = *p;
    e->line_last = p->line;
    if (p->kind == PK_PATH_LINE)
        cone_start(e);
    prim_box(&e->p, lo, hi);
    for (int i = 0; i < 3; i++) {
        e->lo[i] = nextafterf((float)lo[i], -INFINITY);
        e->hi[i] = nextafterf((float)hi[i], INFINITY);
    }
    /* block and group boxes */
    struct pk_path_box *b = blk_of(pa, seq);
    if ((seq & ((1u << BLK_SHIFT) - 1u)) == 0u || b->seq0 != (seq >> BLK_SHIFT << BLK_SHIFT)) {
        box_empty(b->lo, b->hi);
        b->seq0 = seq >> BLK_SHIFT << BLK_SHIFT;
    }
    struct pk_path_box *g = grp_of(pa, seq);
    if ((seq & ((1u << GRP_SHIFT) - 1u)) == 0u || g->seq0 != (seq >> GRP_SHIFT << GRP_SHIFT)) {
        box_empty(g->lo, g->hi);
        g->seq0 = seq >> GRP_SHIFT << GRP_SHIFT;
    }
    double elo[3] = { e->lo[0], e->lo[1], e->lo[2] }, ehi[3] = { e->hi[0], e->hi[1], e->hi[2] };
    box_add(b->lo, b->hi, elo);
    box_add(b->lo, b->hi, ehi);
    box_add(g->lo, g->hi, elo);
    box_add(g->lo, g->hi, ehi);
    pa->st.stored++;
    pa->win_len_um += xy_len(&e->p);
    e->dead = 0;
    e->stamp = 0;
    e->in_grid = 0;
    uint64_t old = dup_replace(pa, seq);
    pa->dup_inserts++;
    if (old != SEQ_NONE) {
        pa->st.repeats++;
        for (unsigned i = 0; i < pa->n_cand; i++)
            if (pa->cand[i].seq == old) { /* the new entry takes its place (same distance) */
                memmove(&pa->cand[i], &pa->cand[i + 1], (pa->n_cand - i - 1u) * sizeof pa->cand[0]);
                pa->n_cand--;
                break;
            }
    }
    grid_insert(pa, seq);
    memcpy(pa->last_end, p->p1, sizeof pa->last_end);
    if (p->kind == PK_PATH_ARC)
        arc_eval(p, 1.0, pa->last_end);
    pa->has_last = 1;
    /* a new primitive near the anchor joins the candidate list */
    if (pa->anchor_ok && ent_box_dist(e, pa->anchor, pa->dims) <= pa->r_um) {
        double d = pk_path_prim_dist(&e->p, pa->anchor, pa->dims, NULL);
        if (d <= pa->r_um)
            cand_insert(pa, seq, d);
    }
}


/*
 * Visit every entry of the window whose box lies within *lim of q (block and
 * group boxes first), in seq order. fn may lower *lim (nearest search) or
 * leave it (radius search).
 */
static void visit(struct pk_path *pa, const double *q, double *lim, visit_fn fn, void *arg)
{
    const unsigned dims = pa->dims;
    if (grid_visit(pa, q, lim, fn, arg) == 0)
        return;
    uint64_t s = pa->tail;
    while (s < pa->head) {
        uint64_t g0 = s >> GRP_SHIFT << GRP_SHIFT, g1 = g0 + (1u << GRP_SHIFT);
        const struct pk_path_box *g = grp_of(pa, s);
        if (box_dist(g->lo, g->hi, q, dims) > *lim) {
            s = g1;
            continue;
        }
        uint64_t gend = g1 < pa->head ? g1 : pa->head;
        while (s < gend) {
            uint64_t b0 = s >> BLK_SHIFT << BLK_SHIFT, b1 = b0 + (1u << BLK_SHIFT);
            const struct pk_path_box *b = blk_of(pa, s);
            uint64_t bend = b1 < gend ? b1 : gend;
            if (box_dist(b->lo, b->hi, q, dims) <= *lim) {
                for (; s < bend; s++) {
                    const struct pk_path_ent *e = ent(pa, s);
                    if (!e->dead && ent_box_dist(e, q, dims) <= *lim)
                        fn(pa, s, lim, q, arg);
                }
            }
            s = bend;
        }
    }
}

struct nearest { double d; uint64_t seq; };

static void visit_nearest(struct pk_path *pa, uint64_t seq, double *lim, const double *q, void *arg)
{
    struct nearest *n = arg;
    double d = pk_path_prim_dist(&ent(pa, seq)->p, q, pa->dims, NULL);
    if (d < n->d || (d == n->d && seq < n->seq)) {
        n->d = d;
        n->seq = seq;
        if (d < *lim)
            *lim = d;
    }
}

/* Exact nearest entry of the window to q (seq SEQ_NONE if empty). */
static struct nearest nearest(struct pk_path *pa, const double *q)
{
    struct nearest n = { INFINITY, SEQ_NONE };
    /* a good first bound: the last match and its neighbours */
    if (pa->cursor != SEQ_NONE) {
        uint64_t c0 = pa->cursor >= pa->tail + 2u ? pa->cursor - 2u : pa->tail;
        for (uint64_t s = c0; s < pa->head && s <= pa->cursor + 2u; s++) {
            if (ent(pa, s)->dead)
                continue;
            double d = pk_path_prim_dist(&ent(pa, s)->p, q, pa->dims, NULL);
            if (d < n.d || (d == n.d && s < n.seq)) {
                n.d = d;
                n.seq = s;
            }
        }
    }
    double lim = n.d;
    visit(pa, q, &lim, visit_nearest, &n);
    return n;
}

struct collect { struct pk_path_cand *buf; unsigned n, cap; int overflow; };

static void visit_collect(struct pk_path *pa, uint64_t seq, double *lim, const double *q, void *arg)
{
    struct collect *c = arg;
    double d = pk_path_prim_dist(&ent(pa, seq)->p, q, pa->dims, NULL);
    if (d > *lim)
        return;
    if (c->n < c->cap)
        c->buf[c->n++] = (struct pk_path_cand){ seq, d };
    else
        c->overflow = 1;
}

static int cand_cmp(const void *a, const void *b)
{
    const struct pk_path_cand *x = a, *y = b;
    if (x->d_anchor != y->d_anchor)
        return x->d_anchor < y->d_anchor ? -1 : 1;
    return x->seq < y->seq ? -1 : x->seq > y->seq;
}

/*
 * New anchor at q: the nearest distance d0 and every entry within
 * R = d0 + 2m. If more than PK_PATH_CAND_MAX lie within R, R shrinks to the
 * distance of the first one left out (every entry not listed is then at
 * least R from the anchor, which is all the proof needs) and m with it. If
 * even half the smallest step is too much, the list is left invalid and the
 * point is measured by a full search.
 */
#define COLLECT_MAX 1024u
static void rebuild(struct pk_path *pa, const double *q, struct nearest n0)
{
    struct pk_path_cand buf[COLLECT_MAX];
    pa->st.rebuilds++;
    pa->anchor_ok = 0;
    for (int tries = 0; tries < 4; tries++) {
        double R = n0.d + 2.0 * pa->m_um;
        struct collect c = { buf, 0, COLLECT_MAX, 0 };
        visit(pa, q, &R, visit_collect, &c);
        if (c.overflow) {
            pa->m_um = fmax(pa->m_min_um, pa->m_um / 8.0);
            if (pa->m_um == pa->m_min_um && tries >= 2)
                break;
            continue;
        }
        qsort(buf, c.n, sizeof buf[0], cand_cmp);
        double m = pa->m_um;
        unsigned keep = c.n;
        if (c.n > PK_PATH_CAND_MAX) {
            keep = PK_PATH_CAND_MAX;
            while (keep > 0 && buf[keep - 1].d_anchor == buf[keep].d_anchor)
                keep--; /* never split a tie: the left-out must be strictly farther... */
            double r_out = buf[keep].d_anchor; /* ...than r_out, or at it */
            m = (r_out - n0.d) / 2.0;
            if (keep == 0 || m < pa->m_min_um) {
                pa->m_um = pa->m_min_um;
                break; /* too dense: full searches for now */
            }
            R = r_out;
        }
        memcpy(pa->cand, buf, keep * sizeof buf[0]);
        pa->n_cand = keep;
        memcpy(pa->anchor, q, sizeof pa->anchor);
        pa->anchor_d = n0.d;
        pa->r_um = R;
        pa->anchor_ok = 1;
        double m_used = m;
        /* adapt for next time: about 4..32 candidates */
        if (keep <= 4u)
            pa->m_um = fmin(pa->m_um * 2.0, 2000.0);
        else if (keep >= 32u)
            pa->m_um = fmax(pa->m_min_um, pa->m_um / 2.0);
        pa->m_valid_um = m_used;
        return;
    }
}

double pk_path_window_dist(const struct pk_path *pa, const double pt[3])
{
    if (pa->head == pa->tail)
        return -1.0;
    double best = INFINITY;
    for (uint64_t s = pa->tail; s < pa->head; s++) {
        if (ent(pa, s)->dead)
            continue; /* a later entry is the same point set */
        double d = pk_path_prim_dist(&ent(pa, s)->p, pt, pa->dims, NULL);
        if (d < best)
            best = d;
    }
    return best;
}

/* ---- histogram ------------------------------------------------------------------ */
static void hist_add(struct pk_path *pa, double d)
{
    if (!(d >= PK_PATH_HIST_MIN_UM)) {
        pa->hist_zero++;
        return;
    }
    double kf = floor(log(d / PK_PATH_HIST_MIN_UM) / log1p(PK_PATH_HIST_REL));
    unsigned k = kf < 0.0 ? 0u : kf >= (double)(PK_PATH_HIST_BINS - 1u) ? PK_PATH_HIST_BINS - 1u : (unsigned)kf;
    /* the rounding of log: settle the bin with the same edges quantile uses */
    while (k > 0u && pa->edge[k] > d)
        k--;
    while (k + 1u < PK_PATH_HIST_BINS && pa->edge[k + 1u] <= d)
        k++;
    pa->hist[k]++;
}

double pk_path_quantile(const struct pk_path *pa, double q)
{
    uint64_t n = pa->st.points;
    if (n == 0u)
        return 0.0;
    double rank_f = ceil(q * (double)n);
    uint64_t rank = rank_f < 1.0 ? 1u : rank_f > (double)n ? n : (uint64_t)rank_f;
    uint64_t acc = pa->hist_zero;
    if (acc >= rank)
        return fmin(PK_PATH_HIST_MIN_UM, pa->st.max_um);
    for (unsigned k = 0; k < PK_PATH_HIST_BINS; k++) {
        acc += pa->hist[k];
        if (acc >= rank)
            return fmin(k + 1u < PK_PATH_HIST_BINS ? pa->edge[k + 1u] : INFINITY, pa->st.max_um);
    }
    return pa->st.max_um;
}

/* ---- measuring -------------------------------------------------------------------- */
static void note_match(struct pk_path *pa, uint64_t seq, const double *q)
{
    pa->cursor = seq;
    if (seq < pa->lag_min_cur)
        pa->lag_min_cur = seq;
    if (pa->lag_n == 0u)
        memcpy(pa->lag_from, q, sizeof pa->lag_from);
    ++pa->lag_n;
    if (pa->lag_n >= PK_PATH_LAG_POINTS ||
        (pa->lag_n >= 16u && dist2_pts(q, pa->lag_from, pa->dims) >= 1000.0 * 1000.0)) {
        uint64_t m = pa->lag_min_cur < pa->lag_min_prev ? pa->lag_min_cur : pa->lag_min_prev;
        uint64_t r = m > PK_PATH_BACK ? m - PK_PATH_BACK : 0u;
        if (m != SEQ_NONE && r > pa->released)
            pa->released = r;
        pa->lag_min_prev = pa->lag_min_cur;
        pa->lag_min_cur = SEQ_NONE;
        pa->lag_n = 0;
    }
}

double pk_path_measure(struct pk_path *pa, const double pt[3], uint64_t tick, uint32_t *line,
                       uint8_t *drawn)
{
    double q[3] = { pt[0], pt[1], pa->dims == 3u ? pt[2] : 0.0 };
    if (pa->head == pa->tail) {
        pa->st.unmatched++;
        return -1.0;
    }
    struct nearest best = { INFINITY, SEQ_NONE };
    double delta = pa->anchor_ok ? sqrt(dist2_pts(q, pa->anchor, pa->dims)) : INFINITY;
    if (!pa->anchor_ok || delta > pa->m_valid_um) {
        best = nearest(pa, q);
        if (pa->dense_skip > 0u) {
            pa->dense_skip--; /* a dense spot: full searches for a while */
        } else {
            rebuild(pa, q, best);
            if (!pa->anchor_ok)
                pa->dense_skip = 64u;
        }
    } else {
        for (unsigned i = 0; i < pa->n_cand; i++) {
            const struct pk_path_cand *c = &pa->cand[i];
            if (c->d_anchor - delta > best.d)
                break; /* sorted: no later candidate can be nearer */
            double d = pk_path_prim_dist(&ent(pa, c->seq)->p, q, pa->dims, NULL);
            if (d < best.d || (d == best.d && c->seq < best.seq)) {
                best.d = d;
                best.seq = c->seq;
            }
        }
    }
    const struct pk_path_ent *e = ent(pa, best.seq);
    note_match(pa, best.seq, q);
    pa->st.points++;
    hist_add(pa, best.d);
    if (best.d > pa->st.max_um || pa->st.points == 1u) {
        pa->st.max_um = best.d;
        memcpy(pa->st.max_at_um, q, sizeof q);
        pa->st.max_tick = tick;
        pa->st.max_line = e->p.line;
        pa->st.max_line_last = e->line_last;
        pa->st.max_drawn = e->p.drawn;
    }
    if (line != NULL)
        *line = e->p.line;
    if (drawn != NULL)
        *drawn = e->p.drawn;
    return best.d;
}
