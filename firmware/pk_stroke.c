/*
 * pk_stroke.c — the smoothing policy: how a run of programmed feed moves
 * becomes the path the machine executes (contract in pk_stroke.h).
 *
 * Why it is built this way
 * ------------------------
 * The user's promise (LinuxCNC's G64 P) is about the PROGRAMMED path: the
 * executed path stays within T of it. Smoothing the programmed vertices
 * themselves cannot keep that promise: a subdivision curve cuts a corner by
 * an amount that grows with the legs (a 100 mm zig-zag loses centimetres).
 * So the control polygon is built ON the programmed path instead, with extra
 * points along each leg that fix how much of the corner is blended:
 *
 *        A ---------- X ---- V                    X = V - 2a u1,  Y = V + 2b u2
 *                             \                   (u1, u2: unit leg directions)
 *                              Y
 *                               \
 *                                B
 *
 * For the quadratic B-spline (Chaikin's scheme, the kernel's degree 2) the
 * curve over the control points X, V, Y is the parabola (Bézier) from
 * V - a u1 to V + b u2 with control point V; wherever three consecutive
 * control points are collinear the curve is straight. Its distance to the two
 * legs (the lines through V): a curve point is V - (1-t)^2 a u1 + t^2 b u2,
 * at distance t^2 b sin(phi) from leg 1 and (1-t)^2 a sin(phi) from leg 2
 * (phi = the turn angle); inside the corner's wedge the distance to the
 * polyline is the smaller of the two, largest where they are equal:
 *
 *     dev(a, b) = a b sin(phi) / (sqrt(a) + sqrt(b))^2  <=  cap sin(phi) / 4
 *
 * when a, b <= cap (dev grows with a and b; dev(c, c) = c sin(phi) / 4). So a
 * vertex with blend budget E gets the capacity cap = 4 E / sin(phi): every
 * blend half-length at that vertex is at most cap. Per leg A -> B (length L):
 *
 *   - if L/2 <= cap(A) and L/2 <= cap(B): no point is added; the blends of A
 *     and B meet at the leg's midpoint (a = b = L/2: dense polylines from SVG
 *     flattening or CAM chords become the smooth quadratic spline through
 *     their chord midpoints, within T of the chords);
 *   - otherwise b = min(cap(A), L/4), a = min(cap(B), L/4), then each grows
 *     into what the other left, b + a <= L/2; the points A + 2b u and
 *     B - 2a u are added (one point if they coincide) and the leg between the
 *     blends stays exactly straight.
 *
 * A vertex turning by more than sharp_turn_deg (or a reversal), a vertex with
 * no budget, a corner whose exact kink the planner would take faster than
 * the blend (Grbl's junction deviation at a wide corner with long legs: the
 * smoothing is then never slower than G61), and both ends of the stroke are
 * given twice: a doubled control
 * point is passed through exactly, with a corner (the planner slows for it
 * as for any junction). Only the vertices V(j-1), V(j), V(j+1), V(j+2) decide
 * the points of leg j: two vertices of look-ahead, and nothing depends on when
 * the vertices arrive.
 *
 * The kernel refines this polygon (clamped Chaikin, PK_STROKE_TOL_DEPTH
 * levels). Chaikin is corner cutting: every level is inscribed in the one
 * before and circumscribes the curve, so near each corner the level-k polygon
 * lies between the parabola and the two legs. Inside the wedge, the set of
 * points within `dev` of the legs is bounded by two half-lines parallel to
 * the legs; its complement is convex and unbounded away from V, so a region
 * enclosed by the legs and a curve within `dev` of them lies entirely within
 * `dev` too. Hence EVERY level, at any depth, is within E of the programmed
 * path (the depth only decides how smooth the polygon is: at depth 3 it is
 * within E/64 of the curve for corners up to 120 degrees). Between blends the
 * polygon runs along the legs. Everything stays inside the convex hull of the
 * programmed points, so a travel box that holds the program holds the path.
 *
 * Finally the decimator keeps the fewest refined points such that every
 * refined point between two kept ones is within T/4 of their chord (a cone of
 * admissible directions from the last kept point, narrowed by each point's
 * tolerance disc, O(1) memory; the chord's far end never comes closer than an
 * earlier point, so each point projects inside the chord). Every refined point
 * within T/4 of the chord also puts the chord within T/4 of the refined
 * polygon (the polygon crosses every normal of the chord, within T/4 of it).
 * The budget therefore reads
 *
 *     T = E (blends) + T/4 (decimator) + 2 µm (whole-µm control points and
 *         kernel outputs: each within sqrt(3)/2 µm of exact)
 *
 * and a vertex next to a chord of a flattened curve spends its chord error
 * out of E. The step generator adds at most half a step per axis (its
 * Bresenham starts from the exact fractional position, pk_motion.c).
 *
 * Straight runs. A leg whose two vertices are both kept sharp (doubled) is
 * straight, and the refined path passes through both ends exactly: the kernel
 * would only cut the segment into 2^depth collinear points for the decimator
 * to merge back into one chord (dense SVG and CAM polylines are mostly such
 * legs: 4,397 of the 4,684 of bench-avr's dense drawing, where this work was
 * half of the 8-bit board's main loop). So at such a leg the kernel stroke is
 * finished at the first vertex and the run's vertices are emitted as they
 * come (each a corner), until a leg with a blend restarts the kernel at the
 * run's last vertex, doubled, as a stroke begins. A doubled control point
 * separates the Chaikin curve into independent parts at every level (the
 * pair V, V refines to V, V), and a clamped end at a doubled point refines
 * the same, so the points and chords are those the kernel and the decimator
 * would have produced, given that the refined points of the segment are
 * within the decimator's tolerance of it and move away from its start: they
 * are within sqrt(2)/2 µm of the segment after rounding, so runs are taken
 * only at T >= PK_STROKE_RUN_MIN_TOL_UM (T/4 >= 2 µm), on legs of at least
 * PK_STROKE_RUN_MIN_LEG_UM (refined points 2 µm or more apart), in the XY
 * plane (the decimator keeps every point of a leg out of it). The observer
 * sees the same control points either way.
 *
 * Z: the blends are built in 3-D (the corner's plane). The decimator works in
 * XY and ends a chord wherever Z changes, so 3-D curves are executed point by
 * point (correct, more segments).
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
    static const uint8_t den[7] = { 182, 132, 90, 56, 30, 12, 2 };
    int64_t t = one;
    for (unsigned i = 0; i < 7; i++)
        t = one - ((x2 * t) >> 30) / (int64_t)den[i];
    return (pk_q30_t)(neg ? -t : t);
}

/* The kernel configuration a policy runs with. */
static void kernel_cfg(const struct pk_smooth_cfg *s, uint8_t axes, struct pk_refine_cfg *c)
{
    memset(c, 0, sizeof *c);
    c->dims = axes;
    if (s->mode == PK_SMOOTH_FIXED) {
        c->scheme = s->scheme;
        c->degree = s->degree;
        c->depth = s->depth;
    } else {
        c->scheme = PK_SCHEME_BSPLINE;
        c->degree = 2;
        c->ends = PK_ENDS_CLAMPED;
        c->depth = PK_STROKE_TOL_DEPTH;
    }
}

int pk_stroke_check(const struct pk_smooth_cfg *s)
{
    if (s == NULL || s->mode > PK_SMOOTH_TOLERANCE || s->sharp_turn_deg > 180u)
        return -1;
    if (s->mode == PK_SMOOTH_FIXED) {
        if (!PK_STROKE_FIXED)
            return -2; /* the mode is not built into this firmware */
        if (s->scheme > PK_SCHEME_DLG || s->depth > PK_MAX_DEPTH)
            return -1;
        if (s->scheme == PK_SCHEME_BSPLINE && (s->degree < 1u || s->degree > 7u))
            return -1;
    }
    if (s->mode == PK_SMOOTH_TOLERANCE && (s->tolerance_um < 1 || s->tolerance_um > 10000))
        return -1;
    if (s->mode == PK_SMOOTH_OFF)
        return 0;
    /* Is the scheme built into this firmware? Ask the kernel itself. */
    struct pk_refine scratch;
    struct pk_refine_cfg c;
    kernel_cfg(s, 2, &c);
    int r = pk_refine_init(&scratch, &c);
    if (r == PK_ENOTSUP)
        return -2;
    return r == PK_OK ? 0 : -1;
}

static void apply(struct pk_stroke *st, const struct pk_smooth_cfg *s)
{
    st->mode = s->mode;
    st->scheme = s->scheme;
    st->degree = s->degree;
    st->fixed_depth = s->depth;
    st->tol_um = s->tolerance_um;
    st->cos_sharp = cos_deg_q30(s->sharp_turn_deg ? s->sharp_turn_deg : 60u);
}

void pk_stroke_set_dyn(struct pk_stroke *st, const struct pk_planner_dyn *d) { st->dyn = *d; }

void pk_stroke_set_pull_budget(struct pk_stroke *st, uint8_t n) { st->pull_budget = n; }

void pk_stroke_init(struct pk_stroke *st, const struct pk_smooth_cfg *s, uint8_t axes)
{
    memset(st, 0, sizeof *st);
    st->axes = axes < 2u ? 2u : axes > PK_AXES ? (uint8_t)PK_AXES : axes;
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

int32_t pk_stroke_blend_budget(pk_um_t tol_um, pk_um_t chord_err_um)
{
    int32_t e = tol_um - tol_um / 4 - PK_STROKE_ROUND_UM - chord_err_um;
    return e < 0 ? 0 : e;
}

/* ------------------------------------------------------------ geometry */

/* Differences of coordinates within ±PK_UM_MAX: |d[i]| < 2^23, 32 bits. */

/* |d| in µm Q8 (< 2^23 * sqrt(3) * 2^8 < 2^31). */
static uint32_t len_q8(const int32_t *d, unsigned n)
{
    uint64_t ss = 0;
    for (unsigned i = 0; i < n; i++)
        ss += (uint64_t)((int64_t)d[i] * d[i]);
    return pk_isqrt64(ss << 16); /* < 3 * 2^46 * 2^16 < 2^64 */
}

static void diff(const pk_um_t a[PK_AXES], const pk_um_t b[PK_AXES], int32_t d[PK_AXES])
{
    for (unsigned i = 0; i < PK_AXES; i++)
        d[i] = b[i] - a[i];
}

/* (a b + c d) / 2^30, rounded down: Q1.30 products summed in 64 bits (the
 * rotations of the decimator's cone; the result is a Q1.30 component). */
static int32_t mac2_q30(int32_t a, int32_t b, int32_t c, int32_t d)
{
    return (int32_t)(((int64_t)a * b + (int64_t)c * d) >> 30);
}

/* Legs. Every leg v[i] -> v[i + 1] of the vertex window has its length and
 * direction taken three times: as the second leg of one vertex's cap, as the
 * first leg of the next vertex's, and (its length) when it is queued. They
 * are kept for the two legs of the window (leg_q8, leg_u, leg_have) and move
 * with it in advance; any other change of the window forgets them. Each is a
 * function of its two vertices only (and of the axes, fixed at init), so the
 * kept figures are those a new computation would give: the same points out
 * (tests/test_stroke_runs.c compares with a build that computes them anew,
 * PK_STROKE_LEGS=0). On an 8-bit core a length is a 64-bit square root
 * (~1,300 AVR cycles) and a direction two or three ~600-cycle divisions. */
#ifndef PK_STROKE_LEGS
#define PK_STROKE_LEGS 1
#endif
#define LEG_LEN(i) (1u << (i))
#define LEG_DIR(i) (4u << (i))

/* The length of leg i (v[i] -> v[i + 1]) in µm Q8, and its difference d. */
static uint32_t leg_len(struct pk_stroke *st, unsigned i, int32_t d[PK_AXES])
{
    diff(st->v[i], st->v[i + 1], d);
    if (PK_STROKE_LEGS && (st->leg_have & LEG_LEN(i)))
        return st->leg_q8[i];
    uint32_t l = len_q8(d, st->axes);
    st->leg_q8[i] = l;
    st->leg_have |= (uint8_t)LEG_LEN(i);
    return l;
}

/* Forget the legs' figures (the window changed other than by advance). */
static void legs_forget(struct pk_stroke *st) { st->leg_have = 0; }

/* The window moved by one vertex: leg 1 becomes leg 0. */
static void legs_shift(struct pk_stroke *st)
{
    st->leg_q8[0] = st->leg_q8[1];
    memcpy(st->leg_u[0], st->leg_u[1], sizeof st->leg_u[0]);
    st->leg_have = (uint8_t)(((st->leg_have & LEG_LEN(1)) ? LEG_LEN(0) : 0u) |
                             ((st->leg_have & LEG_DIR(1)) ? LEG_DIR(0) : 0u));
}

/* Is the kink at a corner (the exact path: Grbl's junction deviation and the
 * curvature over its legs, as the planner will take it) slower than a blend of
 * half-length up to cap? The blend's radius at its apex is h cos^2(phi/2) /
 * sin(phi/2) (a symmetric parabola of half-length h, h = cap or half the
 * shorter leg), driven at the planner's sideways acceleration. A heuristic
 * choice only: either way the path is within the tolerance and the planner
 * keeps the limits. */
static bool kink_slower(const struct pk_stroke *st, const pk_q30_t u1[PK_AXES],
                        const pk_q30_t u2[PK_AXES], uint32_t l1_q8, uint32_t l2_q8, uint32_t cap,
                        int32_t cos_q30)
{
    /* the smaller of the junction and curvature limits (the junction's is
     * computed only where a bound does not put it above the other) */
    bool kc_below;
    const pk_v2_q4_t kc = pk_planner_curvature_v2(u1, u2, st->axes, l1_q8, l2_q8, st->dyn.a_side);
    const pk_v2_q4_t kink = pk_planner_junction_min_v2(u1, u2, st->axes, st->dyn.a_min, st->dyn.delta_um, kc,
                                                       &kc_below);
    /* h = min(cap << 8, lmin) without the 38-bit shift: cap << 8 > lmin
     * exactly when cap > lmin >> 8 (integers); either way h <= lmin < 2^31 */
    uint32_t lmin = (l1_q8 < l2_q8 ? l1_q8 : l2_q8) / 2u;
    uint32_t h_q8 = cap > (lmin >> 8) ? lmin : cap << 8;
    /* cos^2(phi/2) = (1 + cos)/2, sin(phi/2) = sqrt((1 - cos)/2), Q30. In 64
     * bits: the unit vectors' rounding can put cos a hair beyond ±2^30, and
     * the result must stay that of the 64-bit expressions there too. */
    uint64_t c2 = (uint64_t)((int64_t)PK_Q30_ONE + cos_q30) / 2u;
    uint32_t sh = pk_isqrt64(((uint64_t)((int64_t)PK_Q30_ONE - cos_q30) / 2u) << 30);
    if (sh == 0)
        return true;
    uint64_t r_q8 = ((uint64_t)h_q8 * (c2 >> 10)) / (sh >> 10); /* µm Q8 */
    /* v^2 (Q4) = a * r: a (µm/s^2) * r_q8 / 256 * 16 */
    pk_v2_q4_t blend = ((uint64_t)st->dyn.a_side * r_q8) >> 4;
    /* the blend must win clearly: its decimated chords are less regular
     * than the estimate assumes (and a tie keeps the exact corner) */
    return kink + kink / 4u < blend;
}

/* d 2^38 / r truncated towards zero, as the 64-bit division gave (|d| 256
 * <= r < 2^31: the signed Q30 ratio of d in µm Q8). */
static int32_t unit_q30(int32_t d, uint32_t r_q8) { return pk_frac_q30_signed(d * 256, r_q8); }

/** Blend capacity at vertex B between A and C (µm, saturating at CAP_INF):
 *  0 (keep sharp) for a turn beyond the threshold, a reversal or no budget. */
#define CAP_INF ((uint32_t)1 << 30)
/* The unit vector of leg i (length l_q8 > 0, difference d), Q1.30. */
static const pk_q30_t *leg_dir(struct pk_stroke *st, unsigned i, const int32_t d[PK_AXES], uint32_t l_q8)
{
    if (!PK_STROKE_LEGS || !(st->leg_have & LEG_DIR(i))) {
        /* |d[i]| << 8 <= l (l = floor(256 |d|)), so |u[i]| <= 2^30; l < 256
         * sqrt(3) 2^22 < 2^31 (|d[i]| < 2 PK_UM_MAX): unit_q30's ratio, the
         * 64-bit quotient d 2^38 / l (a 32-bit division on 8-bit cores) */
        memset(st->leg_u[i], 0, sizeof st->leg_u[i]);
        for (unsigned k = 0; k < st->axes; k++)
            st->leg_u[i][k] = unit_q30(d[k], l_q8);
        st->leg_have |= (uint8_t)LEG_DIR(i);
    }
    return st->leg_u[i];
}

/* The cap of v[1], between v[0] and v[2]. */
static uint32_t vertex_cap(struct pk_stroke *st, pk_um_t err)
{
    int32_t d1[PK_AXES], d2[PK_AXES];
    unsigned n = st->axes;
    uint32_t l1 = leg_len(st, 0, d1), l2 = leg_len(st, 1, d2);
    if (l1 == 0 || l2 == 0)
        return 0;
    const pk_q30_t *u1 = leg_dir(st, 0, d1, l1), *u2 = leg_dir(st, 1, d2, l2);
    /* |u| <= 2^30 (1 + 2^-12): the dot product and the cross products, Q30
     * after the shift, fit 32 bits */
    /* legs in the XY plane (a pen plotter's): the 3-axis sums below with
     * their Z terms 0, which are the 2-axis ones exactly (the same products
     * summed before the shift; the cross product's X and Y components 0) */
    const bool flat = PK_AXES == 2 || n == 2 || (u1[2] == 0 && u2[2] == 0);
    int32_t dot;
    if (flat) {                      /* (the same sum of two products) */
        dot = mac2_q30(u1[0], u2[0], u1[1], u2[1]);
    } else {
        int64_t dot64 = 0;
        for (unsigned i = 0; i < n; i++)
            dot64 += (int64_t)u1[i] * u2[i];
        dot = (int32_t)(dot64 >> 30);
    }
    if (dot < st->cos_sharp)
        return 0;
    uint64_t s2 = 0;                 /* |u1 x u2|^2 in Q60 */
    if (flat) {
        int32_t cr = mac2_q30(u1[0], u2[1], -u1[1], u2[0]);
        s2 = (uint64_t)((int64_t)cr * cr);
    } else {
        for (unsigned i = 0; i < 3; i++) {
            unsigned j = (i + 1u) % 3u, k = (i + 2u) % 3u;
            int32_t cr = mac2_q30(u1[j], u2[k], -u1[k], u2[j]);
            s2 += (uint64_t)((int64_t)cr * cr);
        }
    }
    uint32_t sin_q30 = pk_isqrt64(s2);
    int32_t e = pk_stroke_blend_budget(st->tol_um, err);
    if (e <= 0)
        return 0;
    if (sin_q30 == 0)
        return dot > 0 ? CAP_INF : 0;
    uint32_t cap = pk_muldiv_u32(4u * (uint32_t)e, (uint32_t)1 << 30, sin_q30); /* 4E < 2^16 */
    if (cap > CAP_INF)
        cap = CAP_INF;
    if (st->dyn.a_side > 0 && !kink_slower(st, u1, u2, l1, l2, cap, dot))
        return 0; /* the programmed corner is as fast: keep it exact */
    return cap;
}

/* ------------------------------------------------------------ kernel feed */

static void queue_pt_f(struct pk_stroke *st, const pk_um_t p[PK_AXES], bool corner)
{
    unsigned i = (st->q_head + st->nq) % 4u;
    memcpy(st->q[i], p, sizeof st->q[0]);
    st->q_corner = (uint8_t)(corner ? st->q_corner | (1u << i) : st->q_corner & ~(1u << i));
    st->nq++;
}

static void queue_pt(struct pk_stroke *st, const pk_um_t p[PK_AXES]) { queue_pt_f(st, p, false); }

/* p = a + d * num / den (rounded to nearest), per axis (num <= den < 2^31). */
static void along(const pk_um_t a[PK_AXES], const int32_t d[PK_AXES], uint32_t num, uint32_t den,
                  pk_um_t p[PK_AXES])
{
    for (unsigned i = 0; i < PK_AXES; i++)
        p[i] = (pk_um_t)(a[i] + pk_div_round64((int64_t)d[i] * num, (int64_t)den));
}

/* Queue the points added on leg v[0] -> v[1] (caps known for both ends). */
static void queue_leg(struct pk_stroke *st)
{
    const pk_um_t *a = st->v[0];
    int32_t d[PK_AXES];
    uint32_t lq = leg_len(st, 0, d);                  /* L, µm Q8, < 2^31 */
    /* the caps in µm Q8, each capped at L: every use below compares them
     * with L or less (up to CAP_INF << 8 = 2^38 otherwise) */
    uint32_t ca = st->cap[0] > (lq >> 8) ? lq : st->cap[0] << 8;
    uint32_t cb = st->cap[1] > (lq >> 8) ? lq : st->cap[1] << 8;
    if (lq == 0 || (2u * ca >= lq && 2u * cb >= lq))
        return;                                       /* blends meet at the midpoint */
    uint32_t half = lq / 2u, quarter = lq / 4u;
    uint32_t fb = ca < quarter ? ca : quarter;        /* blend at a, forward */
    uint32_t fa = cb < quarter ? cb : quarter;        /* blend at b, backward */
    fb = ca < half - fa ? ca : half - fa;
    fa = cb < half - fb ? cb : half - fb;
    pk_um_t y[PK_AXES], x[PK_AXES];
    bool have_y = fb > 0, have_x = fa > 0;
    if (have_y)
        along(a, d, 2u * fb, lq, y);                  /* a + 2 b u: 2b <= L, d*2b < 2^54 */
    if (have_x)
        along(a, d, lq - 2u * fa, lq, x);             /* b - 2 a u */
    if (have_y)
        queue_pt(st, y);
    if (have_x && !(have_y && memcmp(x, y, sizeof x) == 0))
        queue_pt(st, x);
}

/* Queue the vertex v[1] (twice where it must stay sharp; the second copy is
 * flagged, so that the decimator can be told when the kernel reaches it). */
static void queue_vertex(struct pk_stroke *st, bool twice)
{
    queue_pt(st, st->v[1]);
    if (twice)
        queue_pt_f(st, st->v[1], true);
}

/* Straight runs (see the essay): the tolerance and leg length from which the
 * kernel's points of a straight leg are all merged by the decimator. */
#ifndef PK_STROKE_RUNS
#define PK_STROKE_RUNS 1 /* 0: every leg through the kernel (tests/test_stroke_runs.c) */
#endif
#define PK_STROKE_RUN_MIN_TOL_UM 8
#define PK_STROKE_RUN_MIN_LEG_UM ((uint32_t)2 << PK_STROKE_TOL_DEPTH)

/* Is leg v[0] -> v[1] (caps decided) straight between two sharp vertices,
 * long enough and in the XY plane, so that it can go out without the kernel? */
static bool run_leg(const struct pk_stroke *st)
{
    if (!PK_STROKE_RUNS || st->cap[0] != 0 || st->cap[1] != 0 || st->tol_um < PK_STROKE_RUN_MIN_TOL_UM)
        return false;
    int32_t d[PK_AXES];
    diff(st->v[0], st->v[1], d);
    for (unsigned i = 2; i < st->axes && i < PK_AXES; i++)
        if (d[i] != 0)
            return false;
    /* |d| >= MIN in the plane: compare squares (|d| < 2^23, squares < 2^47) */
    uint64_t ss = (uint64_t)((int64_t)d[0] * d[0]) + (uint64_t)((int64_t)d[1] * d[1]);
    return ss >= (uint64_t)PK_STROKE_RUN_MIN_LEG_UM * PK_STROKE_RUN_MIN_LEG_UM;
}

/* Leg v[0] -> v[1] is about to be queued (caps decided; the queue is empty,
 * so the kernel has every point up to v[0], and no restart is pending): a
 * straight run starts or goes on (the kernel ends at v[0], doubled), or a
 * run ends (the kernel restarts at v[0] before this leg's points). */
static void run_decide(struct pk_stroke *st)
{
    if (run_leg(st)) {
        if (st->by == 0) {
            pk_refine_finish(&st->k);
            st->by = 1;
        }
    } else if (st->by != 0) {
        st->by_restart = true;
    }
}

/* With v[0..2] held: decide v[1]'s cap, queue leg 0 and v[1], shift. */
static void advance(struct pk_stroke *st)
{
    pk_um_t err = st->err_in[1] > st->err_in[2] ? st->err_in[1] : st->err_in[2];
    st->cap[1] = vertex_cap(st, err);
    run_decide(st);
    queue_leg(st);
    queue_vertex(st, st->cap[1] == 0);
    memmove(st->v[0], st->v[1], 2 * sizeof st->v[0]);
    legs_shift(st);
    memmove(&st->err_in[0], &st->err_in[1], 2 * sizeof st->err_in[0]);
    st->cap[0] = st->cap[1];
    st->nv = 2;
}

/* Finishing: the last held vertex is the stroke's end. */
static void advance_last(struct pk_stroke *st)
{
    if (st->nv == 2) {
        st->cap[1] = 0;
        run_decide(st);
        queue_leg(st);
        queue_vertex(st, true);
        memcpy(st->v[0], st->v[1], sizeof st->v[0]);
    }
    legs_forget(st);
    st->nv = 1;
}

static void observe(struct pk_stroke *st, uint8_t ev, const pk_um_t p[PK_AXES])
{
    if (st->observe)
        st->observe(st->observe_ctx, ev, p);
}

static void kernel_start_q(struct pk_stroke *st, const pk_um_t start[PK_AXES], bool quiet);
static void kernel_start(struct pk_stroke *st, const pk_um_t start[PK_AXES])
{
    kernel_start_q(st, start, false);
}

/* A straight run has ended (see the essay): the kernel starts again at its
 * last vertex (the anchor, emitted), doubled as at a stroke's start. The
 * observer saw these control points already: nothing to tell it. */
static void kernel_restart(struct pk_stroke *st)
{
    kernel_start_q(st, st->anchor, true);
    st->by = 0;
    st->by_restart = false;
    st->by_again = true; /* the second copy, once the kernel takes it (feed_kernel) */
}

static void kernel_start_q(struct pk_stroke *st, const pk_um_t start[PK_AXES], bool quiet)
{
    struct pk_refine_cfg c;
    struct pk_smooth_cfg s;
    memset(&s, 0, sizeof s);
    s.mode = st->mode;
    s.scheme = st->scheme;
    s.degree = st->degree;
    s.depth = st->fixed_depth;
    kernel_cfg(&s, st->axes, &c);
    (void)pk_refine_init(&st->k, &c); /* the policy passed pk_stroke_check */
    (void)pk_refine_push(&st->k, start);
    if (!quiet)
        observe(st, PK_STROKE_EV_BEGIN, start);
    st->kernel_end = false;
}

int pk_stroke_begin(struct pk_stroke *st, const pk_um_t start[PK_AXES])
{
    if (st->open)
        return -1;
    st->open = true;
    st->finishing = false;
#if PK_STROKE_FIXED
    st->split_pending = false;
    st->have_pend = false;
    st->n_in = 1;
    memcpy(st->prev2, start, sizeof st->prev2);
#endif
    st->have_out = false;
    st->emit_n = 0;
    st->nq = 0;
    st->q_head = 0;
    st->ncorner = 0;
    st->by = 0;
    st->by_restart = false;
    st->by_again = false;
    memcpy(st->prev, start, sizeof st->prev);
    if (st->mode == PK_SMOOTH_OFF)
        return 0;
    kernel_start(st, start);
    st->have_anchor = true;
    memcpy(st->anchor, start, sizeof st->anchor);
    st->have_cand = false;
    if (st->mode == PK_SMOOTH_TOLERANCE) {
        queue_pt(st, start);           /* the start is doubled: passed exactly */
        memcpy(st->v[0], start, sizeof st->v[0]);
        st->err_in[0] = 0;
        st->cap[0] = 0;
        st->nv = 1;
        legs_forget(st);
    }
    return 0;
}

#if PK_STROKE_FIXED
/* FIXED: does the vertex prev (between prev2 and q) have to stay sharp? */
static bool must_split(const struct pk_stroke *st, const pk_um_t q[PK_AXES])
{
    if (st->n_in < 2)
        return false;
    int32_t a[PK_AXES], b[PK_AXES];
    diff(st->prev2, st->prev, a);
    diff(st->prev, q, b);
    int64_t dot = 0;
    for (unsigned i = 0; i < PK_AXES; i++)
        dot += (int64_t)a[i] * b[i];
    uint32_t la = len_q8(a, PK_AXES), lb = len_q8(b, PK_AXES);
    if (la == 0 || lb == 0)
        return false;
    int64_t y_q8 = (dot * 65536) / (int64_t)la;         /* dot/|a|, µm Q8 */
    int64_t cos_q30 = (y_q8 * PK_Q30_ONE) / (int64_t)lb; /* |y_q8| < 2^31 */
    return cos_q30 < st->cos_sharp;
}

/* FIXED: the next vertex into the kernel (or held, at a split or a full kernel). */
static int fixed_add(struct pk_stroke *st, const pk_um_t p[PK_AXES])
{
    if (must_split(st, p)) {
        memcpy(st->pend, p, sizeof st->pend);
        st->have_pend = true;
        st->split_pending = true;
        pk_refine_finish(&st->k);
        return PK_OK;
    }
    int r = pk_refine_push(&st->k, p);
    if (r == PK_EBUSY) {
        memcpy(st->pend, p, sizeof st->pend);
        st->have_pend = true;
    } else if (r != PK_OK) {
        return r;
    } else {
        observe(st, PK_STROKE_EV_CTRL, p);
    }
    return PK_OK;
}
#endif

int pk_stroke_add(struct pk_stroke *st, const pk_um_t p[PK_AXES], pk_um_t chord_err_um)
{
    if (!st->open || st->finishing)
        return PK_ESTATE;
    if (st->have_out || st->nq > 0)
        return PK_EBUSY;
#if PK_STROKE_FIXED
    if (st->have_pend || st->split_pending)
        return PK_EBUSY;
#endif
    if (memcmp(p, st->prev, sizeof st->prev) == 0)
        return PK_OK; /* zero-length: nothing to draw, no vertex */
    if (st->mode == PK_SMOOTH_OFF) {
        memcpy(st->out, p, sizeof st->out);
        st->have_out = true;
    } else if (st->mode == PK_SMOOTH_TOLERANCE) {
        memcpy(st->v[st->nv], p, sizeof st->v[0]);
        st->err_in[st->nv] = chord_err_um;
        st->nv++;
        if (st->nv == 3)
            advance(st);
    } else {
#if PK_STROKE_FIXED
        int r = fixed_add(st, p);
        if (r != PK_OK)
            return r;
#endif
    }
#if PK_STROKE_FIXED
    memcpy(st->prev2, st->prev, sizeof st->prev);
    st->n_in++;
#endif
    memcpy(st->prev, p, sizeof st->prev);
    return PK_OK;
}

void pk_stroke_finish(struct pk_stroke *st)
{
    if (!st->open || st->finishing)
        return;
    st->finishing = true;
#if PK_STROKE_FIXED
    if (st->mode == PK_SMOOTH_FIXED && !st->have_pend)
        pk_refine_finish(&st->k);
#endif
    /* TOLERANCE: the last leg is queued once the queue has drained (pull) */
}

static void emit_f(struct pk_stroke *st, const pk_um_t p[PK_AXES], bool sharp)
{
    memcpy(st->emit[st->emit_n], p, sizeof st->emit[0]);
    st->emit_sharp[st->emit_n] = sharp;
    st->emit_n++;
}

static void emit(struct pk_stroke *st, const pk_um_t p[PK_AXES]) { emit_f(st, p, false); }

/* ------------------------------------------------------------ decimator */

/* The sign of a x b (b: a chord's difference, |b| < 2^23, or a Q1.30 direction). */
static int cross2(const int32_t a[2], int32_t bx, int32_t by)
{
    int64_t c = (int64_t)a[0] * by - (int64_t)a[1] * bx;
    return c > 0 ? 1 : c < 0 ? -1 : 0;
}


/* The two directions from the anchor tangent to the disc of radius tol around
 * a point at d (|d| = r > tol), Q1.30, clockwise one first. */
static void tangents(const int32_t d[2], uint32_t r_q8, uint32_t tol_q8, int32_t rt[2],
                     int32_t lt[2])
{
    /* |d[i]| << 8 <= r (r = floor(|d| 256)) and tol < r: every factor is
     * a ratio at most 1, within ±2^30 */
    int32_t ux = unit_q30(d[0], r_q8), uy = unit_q30(d[1], r_q8);
    uint64_t rr = (uint64_t)r_q8 * r_q8, tt = (uint64_t)tol_q8 * tol_q8;
    int32_t cb = (int32_t)pk_frac_q30(pk_isqrt64(rr - tt), r_q8); /* cos(beta) */
    int32_t sb = (int32_t)pk_frac_q30(tol_q8, r_q8);             /* sin(beta) */
    rt[0] = mac2_q30(ux, cb, uy, sb);
    rt[1] = mac2_q30(uy, cb, -ux, sb);
    lt[0] = mac2_q30(ux, cb, -uy, sb);
    lt[1] = mac2_q30(uy, cb, ux, sb);
}

/* tol for the decimator: T/4 (FIXED: PK_STROKE_FIXED_DEC_UM) in µm Q8, a
 * hair inside (rounding of the cone). */
static uint32_t dec_tol_q8(const struct pk_stroke *st)
{
    pk_um_t tol = st->mode == PK_SMOOTH_TOLERANCE ? st->tol_um / 4 : PK_STROKE_FIXED_DEC_UM;
    uint32_t t = (uint32_t)tol << 8;
    return t > 1u ? t - 1u : 0u;
}

/* Start a chord from the anchor to q. */
static void cand_start(struct pk_stroke *st, const pk_um_t q[PK_AXES])
{
    int32_t d[2] = { q[0] - st->anchor[0], q[1] - st->anchor[1] };
    uint32_t r = len_q8(d, 2), tol = dec_tol_q8(st);
    memcpy(st->cand, q, sizeof st->cand);
    st->cand_r_q8 = r;
    st->have_cand = true;
    st->cone_empty = false;
    st->cone_full = r <= tol;
    if (!st->cone_full)
        tangents(d, r, tol, st->cone_r, st->cone_l);
}

static void new_anchor_at_cand(struct pk_stroke *st)
{
    emit(st, st->cand);
    memcpy(st->anchor, st->cand, sizeof st->anchor);
    st->have_cand = false;
}

static void decimate_pt(struct pk_stroke *st, const pk_um_t q[PK_AXES]);

static void decimate(struct pk_stroke *st, const pk_um_t q[PK_AXES])
{
    decimate_pt(st, q);
    if (st->ncorner > 0 && memcmp(q, st->corner[0], sizeof st->corner[0]) == 0) {
        /* the corner: the chord ends here, and the planner treats the
         * junction as a programmed corner */
        if (st->have_cand && memcmp(st->cand, q, sizeof st->cand) == 0) {
            emit_f(st, st->cand, true);
            memcpy(st->anchor, st->cand, sizeof st->anchor);
            st->have_cand = false;
        }
        memmove(st->corner[0], st->corner[1], 2 * sizeof st->corner[0]);
        st->ncorner--;
    }
}

static void decimate_pt(struct pk_stroke *st, const pk_um_t q[PK_AXES])
{
    const pk_um_t *last = st->have_cand ? st->cand : st->anchor;
    if (memcmp(q, last, sizeof st->cand) == 0)
        return;
    if (st->axes > 2u) {
        for (unsigned i = 2; i < st->axes && i < PK_AXES; i++) {
            if (q[i] != st->anchor[i] || (st->have_cand && st->cand[i] != st->anchor[i])) {
                /* out of the XY plane of the chord: keep every point */
                if (st->have_cand)
                    new_anchor_at_cand(st);
                emit(st, q);
                memcpy(st->anchor, q, sizeof st->anchor);
                return;
            }
        }
    }
    if (!st->have_cand) {
        cand_start(st, q);
        return;
    }
    int32_t d[2] = { q[0] - st->anchor[0], q[1] - st->anchor[1] };
    uint32_t r = len_q8(d, 2);
    bool ok = !st->cone_empty && r >= st->cand_r_q8
              && (st->cone_full
                  || (cross2(st->cone_r, d[0], d[1]) >= 0 && cross2(st->cone_l, d[0], d[1]) <= 0));
    if (!ok) {
        new_anchor_at_cand(st);
        cand_start(st, q);
        return;
    }
    uint32_t tol = dec_tol_q8(st);
    if (r > tol) {
        int32_t rt[2], lt[2];
        tangents(d, r, tol, rt, lt);
        if (st->cone_full) {
            memcpy(st->cone_r, rt, sizeof rt);
            memcpy(st->cone_l, lt, sizeof lt);
            st->cone_full = false;
        } else {
            if (cross2(st->cone_r, rt[0], rt[1]) > 0)   /* rt is left of r: tighter */
                memcpy(st->cone_r, rt, sizeof rt);
            if (cross2(st->cone_l, lt[0], lt[1]) < 0)   /* lt is right of l: tighter */
                memcpy(st->cone_l, lt, sizeof lt);
            if (cross2(st->cone_r, st->cone_l[0], st->cone_l[1]) < 0)
                st->cone_empty = true;
        }
    }
    memcpy(st->cand, q, sizeof st->cand);
    st->cand_r_q8 = r;
}

/* ------------------------------------------------------------ pull */

void pk_stroke_reset(struct pk_stroke *st)
{
    if (st->mode != PK_SMOOTH_OFF)
        pk_refine_reset(&st->k);
    st->open = false;
    st->finishing = false;
#if PK_STROKE_FIXED
    st->split_pending = false;
    st->have_pend = false;
#endif
    st->have_out = false;
    st->emit_n = 0;
    st->nq = 0;
    st->nv = 0;
    legs_forget(st);
    st->ncorner = 0;
    st->by = 0;
    st->by_restart = false;
    st->by_again = false;
    st->have_cand = false;
}

static int pull_off(struct pk_stroke *st, pk_um_t out[PK_AXES])
{
    if (st->have_out) {
        st->have_out = false;
        memcpy(out, st->out, sizeof st->out);
        st->out_sharp = true;
        return PK_OK;
    }
    if (st->finishing) {
        st->open = false;
        return PK_END;
    }
    return PK_NEED_INPUT;
}

/* The kernel wants input: feed it what the policy has queued. Returns
 * PK_OK if something was pushed (pull again), PK_NEED_INPUT otherwise, or a
 * kernel error. */
static int feed_kernel(struct pk_stroke *st)
{
    if (st->mode == PK_SMOOTH_TOLERANCE) {
        if (st->nq == 0 && st->finishing && st->nv > 1)
            advance_last(st);
        if (st->by != 0)
            return PK_OK; /* the kernel was finished at a straight run: it drains */
        if (st->by_again) {
            int r = pk_refine_push(&st->k, st->anchor);
            if (r == PK_OK)
                st->by_again = false;
            return r == PK_OK ? PK_OK : r == PK_EBUSY ? PK_NEED_INPUT : r;
        }
        if (st->nq > 0) {
            const pk_um_t *p = st->q[st->q_head];
            int r = pk_refine_push(&st->k, p);
            if (r == PK_OK) {
                if (st->q_corner & (1u << st->q_head)) {
                    /* a corner kept sharp is in the kernel: the refined path
                     * passes through it exactly, a few points later; the
                     * decimator ends a chord there and flags it. The kernel
                     * holds at most a few control points, so three pending
                     * corners suffice (an overflow only makes the oldest a
                     * smooth vertex: slower, never out of the limits) */
                    if (st->ncorner == 3u) {
                        memmove(st->corner[0], st->corner[1], 2 * sizeof st->corner[0]);
                        st->ncorner = 2;
                    }
                    memcpy(st->corner[st->ncorner++], p, sizeof st->corner[0]);
                }
                observe(st, PK_STROKE_EV_CTRL, p);
                st->q_head = (uint8_t)((st->q_head + 1u) % 4u);
                st->nq--;
                return PK_OK;
            }
            return r == PK_EBUSY ? PK_NEED_INPUT : r;
        }
        if (st->finishing) {
            pk_refine_finish(&st->k);
            return PK_OK;
        }
        return PK_NEED_INPUT;
    }
#if PK_STROKE_FIXED
    if (st->have_pend && !st->split_pending) {
        int pr = pk_refine_push(&st->k, st->pend);
        if (pr == PK_OK) {
            observe(st, PK_STROKE_EV_CTRL, st->pend);
            st->have_pend = false;
            if (st->finishing)
                pk_refine_finish(&st->k);
            return PK_OK;
        }
        if (pr != PK_EBUSY)
            return pr;
    }
#endif
    return PK_NEED_INPUT;
}

/* A straight run (by == 2): the queued vertices go out without the kernel,
 * each where the decimator would have ended a chord at it (its corner copy);
 * the run ends at a leg with a blend (the kernel restarts) or with the stroke.
 * PK_OK to go on, PK_NEED_INPUT for more vertices. */
static int run_feed(struct pk_stroke *st)
{
    if (st->nq == 0 && st->finishing && st->nv > 1)
        advance_last(st);
    if (st->nq > 0 && st->by_restart) {
        kernel_restart(st);
        return PK_OK;
    }
    if (st->nq > 0) {
        const pk_um_t *p = st->q[st->q_head];
        const bool corner = (st->q_corner & (1u << st->q_head)) != 0u;
        observe(st, PK_STROKE_EV_CTRL, p);
        if (corner) {
            emit_f(st, p, true);
            memcpy(st->anchor, p, sizeof st->anchor);
            st->have_cand = false;
        }
        st->q_head = (uint8_t)((st->q_head + 1u) % 4u);
        st->nq--;
        return PK_OK;
    }
    if (st->finishing) {
        observe(st, PK_STROKE_EV_END, st->v[0]);
        st->kernel_end = true;
        return PK_OK;
    }
    return PK_NEED_INPUT;
}

int pk_stroke_pull(struct pk_stroke *st, pk_um_t out[PK_AXES])
{
    unsigned refined = 0;
    for (;;) {
        if (st->emit_n > 0) {
            memcpy(out, st->emit[0], sizeof st->emit[0]);
            st->out_sharp = st->emit_sharp[0];
            memmove(st->emit[0], st->emit[1], sizeof st->emit[0]);
            st->emit_sharp[0] = st->emit_sharp[1];
            st->emit_n--;
            return PK_OK;
        }
        if (!st->open)
            return PK_END;
        if (st->mode == PK_SMOOTH_OFF)
            return pull_off(st, out);
        if (st->kernel_end) {
            st->open = false;
            return PK_END;
        }
        if (st->by == 2) {
            if (run_feed(st) == PK_OK)
                continue;
            return PK_NEED_INPUT;
        }
        struct pk_refine_out o;
        int r = pk_refine_pull(&st->k, &o);
        if (r == PK_OK) {
            decimate(st, o.p);
            if (st->pull_budget != 0u && st->emit_n == 0u && ++refined >= st->pull_budget)
                return PK_STROKE_YIELD; /* (nothing is lost: the next pull goes on) */
            continue;
        }
        if (r == PK_NEED_INPUT) {
            int fr = feed_kernel(st);
            if (fr == PK_OK)
                continue;
            if (fr < 0) {
                pk_stroke_reset(st);
                return fr;
            }
            return PK_NEED_INPUT;
        }
        if (r == PK_END && st->by == 1) {
            /* the kernel ended at a straight run's first vertex (emitted as
             * the corner it is): the run goes on without it */
            if (st->have_cand) {
                emit_f(st, st->cand, true);
                memcpy(st->anchor, st->cand, sizeof st->anchor);
                st->have_cand = false;
            }
            st->by = 2;
            continue;
        }
        if (r == PK_END) {
#if PK_STROKE_FIXED
            observe(st, PK_STROKE_EV_END, st->mode == PK_SMOOTH_TOLERANCE ? st->v[0] : st->prev2);
#else
            observe(st, PK_STROKE_EV_END, st->v[0]);
#endif
            if (st->have_cand) {
                emit_f(st, st->cand, true); /* the stroke's end, or a split vertex */
                memcpy(st->anchor, st->cand, sizeof st->anchor);
                st->have_cand = false;
            }
#if PK_STROKE_FIXED
            if (st->split_pending) {
                /* FIXED: the stroke ended at the sharp vertex (prev2 holds it) */
                st->split_pending = false;
                kernel_start(st, st->prev2);
                int pr = pk_refine_push(&st->k, st->pend);
                st->have_pend = (pr == PK_EBUSY);
                if (pr != PK_OK && pr != PK_EBUSY) {
                    pk_stroke_reset(st);
                    return pr;
                }
                if (pr == PK_OK)
                    observe(st, PK_STROKE_EV_CTRL, st->pend);
                st->n_in = 2;
                if (st->finishing && !st->have_pend)
                    pk_refine_finish(&st->k);
                continue;
            }
#endif
            st->kernel_end = true;
            continue;
        }
        pk_stroke_reset(st);
        return r;
    }
}
