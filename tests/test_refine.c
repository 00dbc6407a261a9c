/*
 * test_refine.c — properties of the refinement kernel that users rely on.
 *
 * Freestanding (no libc: its own PRNG, no I/O but th_write) so that the same
 * file runs on the host and on an emulated Cortex-M. Exact values are checked
 * by test_vectors.c against rational references; this file checks structure
 * on random polygons: point counts per level, exact mirror and reverse
 * symmetry, affine invariance within the rounding bound, convex-hull
 * containment and variation diminishing (B-splines), interpolation (DLG),
 * periodicity of closed curves, limit points fixed by further refinement,
 * streaming with arbitrary pauses, the release bound, and range rejection.
 */
#include "pk_refine.h"
#include "refine_spec.h"
#include "th.h"

#define MAXOUT 6000
#define MAXIN 40

/* ---- deterministic PRNG (xorshift64*) ------------------------------------ */
static uint64_t rng_state;
static void rng_seed(uint64_t s) { rng_state = s ? s : 0x9E3779B97F4A7C15u; }
static uint32_t rng_u32(void)
{
    rng_state ^= rng_state >> 12;
    rng_state ^= rng_state << 25;
    rng_state ^= rng_state >> 27;
    return (uint32_t)((rng_state * 0x2545F4914F6CDD1Du) >> 32);
}
static int32_t rng_range(int32_t lo, int32_t hi) /* inclusive */
{
    return lo + (int32_t)(rng_u32() % (uint32_t)(hi - lo + 1));
}

/* ---- running the kernel ---------------------------------------------------- */
struct run {
    struct pk_refine_out o[MAXOUT];
    unsigned n;
    unsigned max_release;      /* most points pulled between two pushes or after finish */
    unsigned max_push_release; /* most points pulled after one push */
    int end_status;
};

static struct run RA, RB; /* static: too big for a small target stack */
static pk_um_t IN[MAXIN][PK_AXES], IN2[MAXIN][PK_AXES];

static int run_kernel(const struct pk_refine_cfg *cfg, pk_um_t (*in)[PK_AXES], unsigned m,
                      struct run *out, uint32_t pause_seed)
{
    struct pk_refine r;
    int st = pk_refine_init(&r, cfg);
    if (st != PK_OK)
        return st;
    out->n = 0;
    out->max_release = 0;
    out->max_push_release = 0;
    uint64_t ps = pause_seed;
    unsigned i = 0, since_push = 0;
    int finished = 0;
    for (;;) {
        /* Optionally stop pulling for a while: the consumer is "full". */
        if (pause_seed) {
            ps = ps * 6364136223846793005u + 1442695040888963407u;
            if (((ps >> 33) % 3u) == 0u) {
                if (i < m) {
                    int pr = pk_refine_push(&r, in[i]);
                    if (pr == PK_OK) {
                        i++;
                        since_push = 0;
                    } else if (pr != PK_EBUSY) {
                        return -100;
                    }
                }
                continue;
            }
        }
        struct pk_refine_out o;
        int pr = pk_refine_pull(&r, &o);
        if (pr == PK_OK) {
            if (out->n < MAXOUT)
                out->o[out->n++] = o;
            since_push++;
            if (since_push > out->max_release)
                out->max_release = since_push;
            if (!finished && since_push > out->max_push_release)
                out->max_push_release = since_push;
            continue;
        }
        if (pr == PK_END) {
            out->end_status = pr;
            return PK_OK;
        }
        if (pr != PK_NEED_INPUT)
            return -101;
        if (i < m) {
            if (pk_refine_push(&r, in[i]) != PK_OK)
                return -102;
            i++;
            since_push = 0;
        } else if (!finished) {
            pk_refine_finish(&r);
            finished = 1;
            since_push = 0;
        } else {
            return -103; /* NEED_INPUT after finish: must not happen */
        }
    }
}

static void random_polygon(unsigned m, unsigned dims, int32_t span)
{
    for (unsigned i = 0; i < m; i++)
        for (unsigned a = 0; a < PK_AXES; a++)
            IN[i][a] = a < dims ? rng_range(-span, span) : 0;
}

/* All the configurations the kernel supports (limit off). */
struct variant {
    uint8_t scheme, degree, closed, ends;
};
static unsigned variants(struct variant *v)
{
    unsigned n = 0;
    for (uint8_t c = 0; c < 2u; c++) {
        for (uint8_t d = 1; d <= 7u; d++) {
            if (c) {
                v[n++] = (struct variant){ PK_SCHEME_BSPLINE, d, 1, 0 };
                continue;
            }
            for (uint8_t e = PK_ENDS_CLAMPED; e <= PK_ENDS_NONE; e++)
                if (e != PK_ENDS_CLAMPED || d <= 3u)
                    v[n++] = (struct variant){ PK_SCHEME_BSPLINE, d, 0, e };
        }
        v[n++] = (struct variant){ PK_SCHEME_DLG, 0, c, 0 };
    }
    return n;
}

static struct pk_refine_cfg cfg_of(const struct variant *v, unsigned depth, unsigned dims)
{
    struct pk_refine_cfg c = { 0 };
    c.scheme = v->scheme;
    c.degree = v->degree;
    c.closed = v->closed;
    c.ends = v->ends;
    c.depth = (uint8_t)depth;
    c.dims = (uint8_t)dims;
    return c;
}

static int pt_eq(const struct pk_refine_out *a, const struct pk_refine_out *b, unsigned dims)
{
    for (unsigned k = 0; k < dims; k++)
        if (a->p[k] != b->p[k])
            return 0;
    return 1;
}

static int32_t iabs32(int32_t x) { return x < 0 ? -x : x; }

static int64_t isqrt64(uint64_t v)
{
    uint64_t r = 0, bit = (uint64_t)1 << 62;
    while (bit > v)
        bit >>= 2;
    for (; bit; bit >>= 2) {
        if (v >= r + bit) {
            v -= r + bit;
            r = (r >> 1) + bit;
        } else {
            r >>= 1;
        }
    }
    return (int64_t)r;
}

/* ---- tests ---------------------------------------------------------------- */

static void test_every_scheme_gives_the_specified_point_count_per_level(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(1);
    for (unsigned k = 0; k < nv; k++)
        for (unsigned depth = 0; depth <= 4u; depth++)
            for (unsigned m = 0; m <= 9u; m++) {
                uint32_t want = m;
                for (unsigned l = 0; l < depth; l++)
                    want = spec_level_count(v[k].scheme, v[k].degree, v[k].closed, v[k].ends, want);
                struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
                random_polygon(m, 2, 100000);
                TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
                if (RA.n != want) {
                    th_print("  scheme ");
                    th_print_i64(v[k].scheme);
                    th_print(" D=");
                    th_print_i64(v[k].degree);
                    th_print(" closed=");
                    th_print_i64(v[k].closed);
                    th_print(" ends=");
                    th_print_i64(v[k].ends);
                    th_print(" depth=");
                    th_print_i64(depth);
                    th_print(" m=");
                    th_print_i64(m);
                    th_print("\n");
                }
                TH_ASSERT_EQ(RA.n, want);
            }
}

static void test_zero_one_and_two_point_strokes_stay_as_they_are(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(2);
    for (unsigned k = 0; k < nv; k++)
        for (unsigned m = 0; m <= 2u; m++) {
            if (v[k].closed && m == 2u)
                continue; /* a closed 2-gon is a real (degenerate) loop */
            random_polygon(m, 3, 500000);
            struct pk_refine_cfg c = cfg_of(&v[k], 5, 3);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            TH_ASSERT_EQ(RA.n, m);
            for (unsigned i = 0; i < m; i++)
                for (unsigned a = 0; a < 3u; a++)
                    TH_ASSERT_EQ(RA.o[i].p[a], IN[i][a]);
        }
}

static void test_mirroring_the_input_mirrors_the_output_exactly(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(3);
    for (unsigned k = 0; k < nv; k++)
        for (unsigned trial = 0; trial < 3u; trial++) {
            unsigned m = (unsigned)rng_range(3, 12), depth = (unsigned)rng_range(1, 5);
            random_polygon(m, 3, PK_UM_MAX);
            struct pk_refine_cfg c = cfg_of(&v[k], depth, 3);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            unsigned axis = trial % 3u;
            for (unsigned i = 0; i < m; i++) {
                for (unsigned a = 0; a < 3u; a++)
                    IN2[i][a] = IN[i][a];
                IN2[i][axis] = -IN[i][axis];
            }
            TH_ASSERT_EQ(run_kernel(&c, IN2, m, &RB, 0), PK_OK);
            TH_ASSERT_EQ(RA.n, RB.n);
            for (unsigned i = 0; i < RA.n; i++)
                for (unsigned a = 0; a < 3u; a++)
                    TH_ASSERT_EQ(RB.o[i].p[a], a == axis ? -RA.o[i].p[a] : RA.o[i].p[a]);
        }
}

/* Closed outputs may start anywhere: find the rotation (and direction). */
static int same_cycle(const struct run *a, const struct run *b, unsigned dims, int reversed)
{
    if (a->n != b->n)
        return 0;
    unsigned n = a->n;
    if (n == 0u)
        return 1;
    for (unsigned s = 0; s < n; s++) {
        unsigned i;
        for (i = 0; i < n; i++) {
            unsigned j = reversed ? (s + n - i) % n : (s + i) % n;
            if (!pt_eq(&a->o[i], &b->o[j], dims))
                break;
        }
        if (i == n)
            return 1;
    }
    return 0;
}

static void test_reversing_the_input_reverses_the_output_exactly(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(4);
    for (unsigned k = 0; k < nv; k++)
        for (unsigned trial = 0; trial < 3u; trial++) {
            unsigned m = (unsigned)rng_range(2, 12), depth = (unsigned)rng_range(0, 4);
            random_polygon(m, 2, PK_UM_MAX);
            struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            for (unsigned i = 0; i < m; i++)
                for (unsigned a = 0; a < PK_AXES; a++)
                    IN2[i][a] = IN[m - 1u - i][a];
            TH_ASSERT_EQ(run_kernel(&c, IN2, m, &RB, 0), PK_OK);
            TH_ASSERT_EQ(RA.n, RB.n);
            if (v[k].closed) {
                TH_ASSERT(same_cycle(&RA, &RB, 2, 1));
            } else {
                for (unsigned i = 0; i < RA.n; i++)
                    TH_ASSERT(pt_eq(&RA.o[i], &RB.o[RA.n - 1u - i], 2));
            }
        }
}

static void test_rotating_a_closed_input_rotates_the_output_exactly(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(5);
    for (unsigned k = 0; k < nv; k++) {
        if (!v[k].closed)
            continue;
        unsigned m = (unsigned)rng_range(3, 10), depth = (unsigned)rng_range(1, 4);
        random_polygon(m, 2, PK_UM_MAX);
        struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
        TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
        unsigned s = (unsigned)rng_range(1, (int32_t)m - 1);
        for (unsigned i = 0; i < m; i++)
            for (unsigned a = 0; a < PK_AXES; a++)
                IN2[i][a] = IN[(i + s) % m][a];
        TH_ASSERT_EQ(run_kernel(&c, IN2, m, &RB, 0), PK_OK);
        TH_ASSERT(same_cycle(&RA, &RB, 2, 0));
    }
}

/* Translating by whole µm and rotating by 90 degrees commute with the kernel:
 * translation up to the final tie-breaking (<= 1 LSB), rotation exactly. */
static void test_translation_and_quarter_turns_commute_with_refinement(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(6);
    for (unsigned k = 0; k < nv; k++) {
        unsigned m = (unsigned)rng_range(3, 12), depth = (unsigned)rng_range(1, 5);
        random_polygon(m, 2, 1000000);
        int32_t tx = rng_range(-500000, 500000), ty = rng_range(-500000, 500000);
        struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
        TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
        for (unsigned i = 0; i < m; i++) {
            IN2[i][0] = IN[i][0] + tx;
            IN2[i][1] = IN[i][1] + ty;
        }
        TH_ASSERT_EQ(run_kernel(&c, IN2, m, &RB, 0), PK_OK);
        TH_ASSERT_EQ(RA.n, RB.n);
        for (unsigned i = 0; i < RA.n; i++) {
            TH_ASSERT(iabs32(RB.o[i].p[0] - (RA.o[i].p[0] + tx)) <= 1);
            TH_ASSERT(iabs32(RB.o[i].p[1] - (RA.o[i].p[1] + ty)) <= 1);
        }
        for (unsigned i = 0; i < m; i++) {
            IN2[i][0] = -IN[i][1];
            IN2[i][1] = IN[i][0];
        }
        TH_ASSERT_EQ(run_kernel(&c, IN2, m, &RB, 0), PK_OK);
        for (unsigned i = 0; i < RA.n; i++) {
            TH_ASSERT_EQ(RB.o[i].p[0], -RA.o[i].p[1]);
            TH_ASSERT_EQ(RB.o[i].p[1], RA.o[i].p[0]);
        }
    }
}

/* Scaling by an integer factor s: out(s*P) = s*out(P) within s*0.52+0.5 LSB. */
static void test_scaling_commutes_with_refinement_within_rounding(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(7);
    for (unsigned k = 0; k < nv; k++) {
        unsigned m = (unsigned)rng_range(3, 12), depth = (unsigned)rng_range(1, 5);
        random_polygon(m, 2, 200000);
        int32_t s = rng_range(2, 9);
        struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
        TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
        for (unsigned i = 0; i < m; i++)
            for (unsigned a = 0; a < 2u; a++)
                IN2[i][a] = IN[i][a] * s;
        TH_ASSERT_EQ(run_kernel(&c, IN2, m, &RB, 0), PK_OK);
        TH_ASSERT_EQ(RA.n, RB.n);
        for (unsigned i = 0; i < RA.n; i++)
            for (unsigned a = 0; a < 2u; a++)
                TH_ASSERT(2 * iabs32(RB.o[i].p[a] - s * RA.o[i].p[a]) <= s * 2 + 2);
    }
}

/* Convex hull of the input (monotone chain), counter-clockwise. */
static unsigned hull(pk_um_t (*p)[PK_AXES], unsigned m, int64_t (*h)[2])
{
    int64_t q[MAXIN][2];
    for (unsigned i = 0; i < m; i++) {
        q[i][0] = p[i][0];
        q[i][1] = p[i][1];
    }
    for (unsigned i = 1; i < m; i++) /* insertion sort by x, then y */
        for (unsigned j = i; j > 0 && (q[j][0] < q[j - 1][0] ||
                                       (q[j][0] == q[j - 1][0] && q[j][1] < q[j - 1][1]));
             j--) {
            int64_t t0 = q[j][0], t1 = q[j][1];
            q[j][0] = q[j - 1][0];
            q[j][1] = q[j - 1][1];
            q[j - 1][0] = t0;
            q[j - 1][1] = t1;
        }
    unsigned k = 0;
    for (int pass = 0; pass < 2; pass++) {
        unsigned start = k;
        for (unsigned ii = 0; ii < m; ii++) {
            unsigned i = pass ? m - 1u - ii : ii;
            while (k >= start + 2u) {
                int64_t cr = (h[k - 1][0] - h[k - 2][0]) * (q[i][1] - h[k - 2][1]) -
                             (h[k - 1][1] - h[k - 2][1]) * (q[i][0] - h[k - 2][0]);
                if (cr > 0)
                    break;
                k--;
            }
            h[k][0] = q[i][0];
            h[k][1] = q[i][1];
            k++;
        }
        k--;
    }
    return k;
}

static void test_bspline_output_stays_inside_the_convex_hull_of_the_input(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    int64_t h[2 * MAXIN + 2][2];
    rng_seed(8);
    for (unsigned k = 0; k < nv; k++) {
        if (v[k].scheme != PK_SCHEME_BSPLINE)
            continue;
        for (unsigned trial = 0; trial < 4u; trial++) {
            unsigned m = (unsigned)rng_range(3, 14), depth = (unsigned)rng_range(1, 5);
            random_polygon(m, 2, 1000000);
            struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            unsigned nh = hull(IN, m, h);
            for (unsigned i = 0; i < RA.n; i++)
                for (unsigned e = 0; e < nh; e++) {
                    const int64_t *A = h[e], *B = h[(e + 1u) % nh];
                    int64_t dx = B[0] - A[0], dy = B[1] - A[1];
                    int64_t cr = dx * (RA.o[i].p[1] - A[1]) - dy * (RA.o[i].p[0] - A[0]);
                    /* inside or within 1 LSB (rounding) of the edge's line:
                     * cross >= -|AB| * 1, checked as cr >= 0 || cr^2 <= |AB|^2 */
                    int ok = cr >= 0 || -cr <= isqrt64((uint64_t)(dx * dx + dy * dy)) + 1;
                    TH_ASSERT(ok);
                }
        }
    }
}

/* Sign changes of the signed distance to the line a*x + b*y = c along the
 * polygon (a closed one also across its closing span). Points within `tol`
 * of the line make the count unreliable: return -1 then. */
static int crossings(const struct pk_refine_out *o, pk_um_t (*p)[PK_AXES], unsigned n,
                     int64_t a, int64_t b, int64_t c, int closed, int64_t tol)
{
    int cnt = 0, prev = 0, first = 0;
    for (unsigned i = 0; i < n; i++) {
        int64_t x = o ? o[i].p[0] : p[i][0], y = o ? o[i].p[1] : p[i][1];
        int64_t d = a * x + b * y - c;
        if (d > -tol && d < tol)
            return -1;
        int sg = d > 0 ? 1 : -1;
        if (i == 0)
            first = sg;
        else if (sg != prev)
            cnt++;
        prev = sg;
    }
    if (closed && n > 1u && prev != first)
        cnt++;
    return cnt;
}

static void test_no_line_crosses_the_refined_bspline_more_often_than_the_input(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(9);
    unsigned checked = 0;
    for (unsigned k = 0; k < nv; k++) {
        if (v[k].scheme != PK_SCHEME_BSPLINE)
            continue;
        /* replace for D >= 3 swaps in an end point that is not on the cut
         * polygon, which can add a crossing: the property is not claimed. */
        if (!v[k].closed && v[k].ends == PK_ENDS_REPLACE && v[k].degree >= 3u)
            continue;
        for (unsigned trial = 0; trial < 6u; trial++) {
            unsigned m = (unsigned)rng_range(3, 14), depth = (unsigned)rng_range(1, 4);
            random_polygon(m, 2, 1000000);
            struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            for (unsigned l = 0; l < 20u; l++) {
                int64_t a = rng_range(-1000, 1000), b = rng_range(-1000, 1000);
                int64_t x0 = rng_range(-1000000, 1000000), y0 = rng_range(-1000000, 1000000);
                int64_t cc = a * x0 + b * y0;
                int64_t tol = 2 * (iabs32((int32_t)a) + iabs32((int32_t)b)) + 1;
                int before = crossings(0, IN, m, a, b, cc, v[k].closed, tol);
                int after = crossings(RA.o, 0, RA.n, a, b, cc, v[k].closed, tol);
                if (before < 0 || after < 0)
                    continue;
                TH_ASSERT(after <= before);
                checked++;
            }
        }
    }
    TH_ASSERT(checked > 1000u);
}

static void test_dlg_keeps_every_input_point_exactly(void)
{
    rng_seed(10);
    for (uint8_t closed = 0; closed < 2u; closed++)
        for (unsigned depth = 1; depth <= 6u; depth++) {
            unsigned m = (unsigned)rng_range(3, 12);
            random_polygon(m, 3, PK_UM_MAX / 2);
            struct variant v = { PK_SCHEME_DLG, 0, closed, 0 };
            struct pk_refine_cfg c = cfg_of(&v, depth, 3);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            unsigned step = 1u << depth;
            /* closed outputs start at P1 (first full stencil): find P0 */
            unsigned off = 0;
            if (closed)
                while (off < RA.n && !(RA.o[off].p[0] == IN[0][0] && RA.o[off].p[1] == IN[0][1]))
                    off++;
            TH_ASSERT(off < RA.n);
            for (unsigned i = 0; i < m; i++)
                for (unsigned a = 0; a < 3u; a++)
                    TH_ASSERT_EQ(RA.o[(off + i * step) % RA.n].p[a], IN[i][a]);
        }
}

static void test_pausing_the_consumer_anywhere_changes_nothing(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(11);
    for (unsigned k = 0; k < nv; k++)
        for (unsigned trial = 0; trial < 3u; trial++) {
            unsigned m = (unsigned)rng_range(0, 16), depth = (unsigned)rng_range(0, 5);
            random_polygon(m, 3, PK_UM_MAX);
            struct pk_refine_cfg c = cfg_of(&v[k], depth, 3);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RB, rng_u32() | 1u), PK_OK);
            TH_ASSERT_EQ(RA.n, RB.n);
            for (unsigned i = 0; i < RA.n; i++)
                TH_ASSERT(pt_eq(&RA.o[i], &RB.o[i], 3));
        }
}

static void test_one_push_never_releases_more_than_the_documented_bound(void)
{
    struct variant v[40];
    unsigned nv = variants(v);
    rng_seed(12);
    for (unsigned k = 0; k < nv; k++)
        for (unsigned depth = 0; depth <= 5u; depth++) {
            unsigned m = 30;
            random_polygon(m, 2, 100000);
            struct pk_refine_cfg c = cfg_of(&v[k], depth, 2);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            TH_ASSERT(RA.max_release <= pk_refine_max_release(&c));
            TH_ASSERT(RA.max_push_release <= (1u << depth));
        }
}

static void test_out_of_range_points_are_rejected_and_change_nothing(void)
{
    struct pk_refine_cfg c = { .scheme = PK_SCHEME_BSPLINE, .degree = 2, .depth = 3, .dims = 3 };
    struct pk_refine r;
    TH_ASSERT_EQ(pk_refine_init(&r, &c), PK_OK);
    pk_um_t ok[PK_AXES] = { 10, 20, 30 }, bad[PK_AXES] = { 0, PK_UM_MAX + 1, 0 };
    pk_um_t bad2[PK_AXES] = { -PK_UM_MAX - 1, 0, 0 }, bad3[PK_AXES] = { 0, 0, INT32_MIN };
    TH_ASSERT_EQ(pk_refine_push(&r, bad), PK_ERANGE);
    TH_ASSERT_EQ(pk_refine_push(&r, bad2), PK_ERANGE);
    TH_ASSERT_EQ(pk_refine_push(&r, bad3), PK_ERANGE);
    TH_ASSERT_EQ(pk_refine_push(&r, ok), PK_OK);
    TH_ASSERT_EQ(pk_refine_push(&r, ok), PK_EBUSY); /* the first is not consumed yet */
    pk_refine_finish(&r);
    TH_ASSERT_EQ(pk_refine_push(&r, ok), PK_ESTATE);
    struct pk_refine_out o;
    TH_ASSERT_EQ(pk_refine_pull(&r, &o), PK_OK);
    TH_ASSERT_EQ(o.p[0], 10);
    TH_ASSERT_EQ(o.p[2], 30);
    TH_ASSERT_EQ(pk_refine_pull(&r, &o), PK_END);
    /* the extreme accepted values refine without overflow */
    pk_um_t hi[PK_AXES] = { PK_UM_MAX, -PK_UM_MAX, PK_UM_MAX };
    pk_um_t lo[PK_AXES] = { -PK_UM_MAX, PK_UM_MAX, -PK_UM_MAX };
    struct variant v[40];
    unsigned nv = variants(v);
    for (unsigned k = 0; k < nv; k++) {
        for (unsigned i = 0; i < 12u; i++)
            for (unsigned a = 0; a < PK_AXES; a++)
                IN[i][a] = (i & 1u) ? hi[a] : lo[a];
        c = cfg_of(&v[k], PK_MAX_DEPTH, 3);
        TH_ASSERT_EQ(run_kernel(&c, IN, 12, &RA, 0), PK_OK);
        for (unsigned i = 0; i < RA.n; i++)
            for (unsigned a = 0; a < 3u; a++) /* DLG may overshoot the hull a little */
                TH_ASSERT(iabs32(RA.o[i].p[a]) <= PK_UM_MAX + PK_UM_MAX / 2);
    }
}

static void test_bad_configurations_are_refused(void)
{
    struct pk_refine r;
    struct pk_refine_cfg c = { .scheme = PK_SCHEME_BSPLINE, .degree = 0, .depth = 1 };
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_EINVAL);
    c.degree = 8;
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_EINVAL);
    c.degree = 2;
    c.depth = PK_MAX_DEPTH + 1;
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_EINVAL);
    c.depth = 2;
    c.dims = 4;
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_EINVAL);
    c.dims = 2;
    c.degree = 5;
    c.ends = PK_ENDS_CLAMPED;
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_ENOTSUP);
    c.ends = 9;
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_EINVAL);
    c.ends = PK_ENDS_DEFAULT;
    TH_EXPECT_EQ(pk_refine_init(&r, &c), PK_OK);
}

/* Limit points lie on the limit curve: refining one level more and taking the
 * limit again gives the same points (every other one), within rounding. */
static void test_limit_points_do_not_move_under_further_refinement(void)
{
    rng_seed(13);
    static const uint8_t degs[] = { 2, 3 };
    for (unsigned di = 0; di < 2u; di++)
        for (unsigned depth = 0; depth <= 4u; depth++) {
            unsigned m = (unsigned)rng_range(3, 9);
            random_polygon(m, 2, 1000000);
            struct pk_refine_cfg c = { .scheme = PK_SCHEME_BSPLINE, .degree = degs[di],
                                       .depth = (uint8_t)depth, .closed = 1, .limit = 1,
                                       .tangents = 1, .dims = 2 };
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RA, 0), PK_OK);
            c.depth = (uint8_t)(depth + 1u);
            TH_ASSERT_EQ(run_kernel(&c, IN, m, &RB, 0), PK_OK);
            TH_ASSERT_EQ(RB.n, 2u * RA.n);
            /* find the alignment: RA[0] equals some RB[j] */
            unsigned best = 0;
            int64_t bestd = INT64_MAX;
            for (unsigned j = 0; j < RB.n; j++) {
                int64_t d = iabs32(RB.o[j].p[0] - RA.o[0].p[0]) + iabs32(RB.o[j].p[1] - RA.o[0].p[1]);
                if (d < bestd) {
                    bestd = d;
                    best = j;
                }
            }
            for (unsigned i = 0; i < RA.n; i++) {
                const struct pk_refine_out *b = &RB.o[(best + 2u * i) % RB.n];
                TH_ASSERT(iabs32(b->p[0] - RA.o[i].p[0]) <= 1);
                TH_ASSERT(iabs32(b->p[1] - RA.o[i].p[1]) <= 1);
                /* same tangent: Q30 components within 2^-18 */
                TH_ASSERT(iabs32(b->t[0] - RA.o[i].t[0]) < (1 << 12));
                TH_ASSERT(iabs32(b->t[1] - RA.o[i].t[1]) < (1 << 12));
            }
        }
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_every_scheme_gives_the_specified_point_count_per_level),
        TH_CASE(test_zero_one_and_two_point_strokes_stay_as_they_are),
        TH_CASE(test_mirroring_the_input_mirrors_the_output_exactly),
        TH_CASE(test_reversing_the_input_reverses_the_output_exactly),
        TH_CASE(test_rotating_a_closed_input_rotates_the_output_exactly),
        TH_CASE(test_translation_and_quarter_turns_commute_with_refinement),
        TH_CASE(test_scaling_commutes_with_refinement_within_rounding),
        TH_CASE(test_bspline_output_stays_inside_the_convex_hull_of_the_input),
        TH_CASE(test_no_line_crosses_the_refined_bspline_more_often_than_the_input),
        TH_CASE(test_dlg_keeps_every_input_point_exactly),
        TH_CASE(test_pausing_the_consumer_anywhere_changes_nothing),
        TH_CASE(test_one_push_never_releases_more_than_the_documented_bound),
        TH_CASE(test_out_of_range_points_are_rejected_and_change_nothing),
        TH_CASE(test_bad_configurations_are_refused),
        TH_CASE(test_limit_points_do_not_move_under_further_refinement),
    };
    return th_run(cases, TH_COUNT(cases));
}
