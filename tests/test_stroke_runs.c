/*
 * test_stroke_runs.c — the smoothing policy's straight runs (pk_stroke.c,
 * "Straight runs"): a leg between two vertices kept sharp goes out without
 * the kernel and the decimator. Claim: the executed path is the one the
 * kernel and the decimator give. Checked differentially: this file compiles
 * pk_stroke.c a second time with PK_STROKE_RUNS=0 (every leg through the
 * kernel, and PK_STROKE_LEGS=0: every leg's length and direction computed
 * anew, not kept from the previous vertex; its public functions renamed
 * ref_*), and random strokes — dense
 * nearly straight polylines as SVG tools write them, sharp corners, long
 * legs, legs out of the XY plane, tolerances on both sides of the runs'
 * threshold, with and without a pull budget — must give both versions the
 * same points, the same corner flags and the same observer events. The runs
 * must actually be taken (counted), or the comparison proves nothing.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"

#define PK_STROKE_RUNS 0
#define PK_STROKE_LEGS 0 /* nor the kept leg figures: computed anew */
#define pk_stroke_check ref_stroke_check
#define pk_stroke_set_dyn ref_stroke_set_dyn
#define pk_stroke_set_pull_budget ref_stroke_set_pull_budget
#define pk_stroke_init ref_stroke_init
#define pk_stroke_set ref_stroke_set
#define pk_stroke_is_open ref_stroke_is_open
#define pk_stroke_blend_budget ref_stroke_blend_budget
#define pk_stroke_begin ref_stroke_begin
#define pk_stroke_add ref_stroke_add
#define pk_stroke_finish ref_stroke_finish
#define pk_stroke_reset ref_stroke_reset
#define pk_stroke_pull ref_stroke_pull
/* (pk_stroke.h, first included here, declares them under the new names) */
#include "../firmware/pk_stroke.c"
#undef pk_stroke_check
#undef pk_stroke_set_dyn
#undef pk_stroke_set_pull_budget
#undef pk_stroke_init
#undef pk_stroke_set
#undef pk_stroke_is_open
#undef pk_stroke_blend_budget
#undef pk_stroke_begin
#undef pk_stroke_add
#undef pk_stroke_finish
#undef pk_stroke_reset
#undef pk_stroke_pull
void pk_stroke_init(struct pk_stroke *st, const struct pk_smooth_cfg *s, uint8_t axes);
void pk_stroke_set_dyn(struct pk_stroke *st, const struct pk_planner_dyn *d);
void pk_stroke_set_pull_budget(struct pk_stroke *st, uint8_t n);
int pk_stroke_begin(struct pk_stroke *st, const pk_um_t start[PK_AXES]);
int pk_stroke_add(struct pk_stroke *st, const pk_um_t p[PK_AXES], pk_um_t chord_err_um);
void pk_stroke_finish(struct pk_stroke *st);
int pk_stroke_pull(struct pk_stroke *st, pk_um_t out[PK_AXES]);

int th_main(int argc, char **argv);

#define MAXOUT 200000
struct rec {
    size_t n;
    pk_um_t p[MAXOUT][PK_AXES];
    uint8_t sharp[MAXOUT];
    size_t nev;
    uint32_t ev_hash;
};
static struct rec A, B;

static void on_ev(void *ctx, uint8_t ev, const pk_um_t p[PK_AXES])
{
    struct rec *r = ctx;

    uint32_t h = r->ev_hash * 16777619u ^ ev;
    for (unsigned i = 0; i < PK_AXES; i++)
        h = h * 16777619u ^ (uint32_t)p[i];
    r->ev_hash = h;
    r->nev++;
}

static uint64_t rng = 88172645463325252ull;
static uint32_t rnd(void) { return (uint32_t)(th_xorshift64(&rng) >> 16); }
static int32_t rr(int32_t lo, int32_t hi) { return lo + (int32_t)(rnd() % (uint32_t)(hi - lo + 1)); }

/* A stroke of n vertices from the origin: mostly short legs turning a little
 * (dense curves), now and then a sharp turn, a long leg or a Z change. */
static size_t gen(pk_um_t pts[][PK_AXES], size_t n, unsigned axes)
{
    double ang = (rnd() % 6283) / 1000.0;
    pk_um_t x = 0, y = 0, z = 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t k = rnd() % 100u;
        double len = k < 70 ? rr(20, 500) : k < 85 ? rr(1, 40) : rr(500, 20000);
        if (k % 7u == 0u)
            ang += (rr(65, 175) * 3.14159265 / 180.0) * (rnd() & 1u ? 1 : -1); /* sharp */
        else
            ang += rr(-300, 300) / 10000.0;                                     /* gentle */
        const double c = cos(ang), s = sin(ang);
        x += (pk_um_t)(len * c);
        y += (pk_um_t)(len * s);
        if (axes > 2 && rnd() % 23u == 0u)
            z += rr(-300, 300);
        pts[i][0] = x;
        pts[i][1] = y;
        if (PK_AXES > 2)
            pts[i][PK_AXES - 1] = axes > 2 ? z : 0;
    }
    return n;
}

typedef int (*add_fn)(struct pk_stroke *, const pk_um_t *, pk_um_t);
typedef int (*pull_fn)(struct pk_stroke *, pk_um_t *);

static void drain(struct pk_stroke *st, pull_fn pull, struct rec *r, unsigned *runs)
{
    pk_um_t o[PK_AXES];
    for (;;) {
        int q = pull(st, o);
        if (runs && st->by == 2)
            (*runs)++;
        if (q == PK_STROKE_YIELD)
            continue;
        if (q != PK_OK)
            return;
        if (r->n < MAXOUT) {
            memcpy(r->p[r->n], o, sizeof o);
            r->sharp[r->n] = st->out_sharp;
            r->n++;
        }
    }
}

static void run(struct pk_stroke *st, int ref, const pk_um_t (*pts)[PK_AXES], size_t n, struct rec *r,
                unsigned *runs)
{
    static const pk_um_t zero[PK_AXES] = { 0 };
    add_fn add = ref ? ref_stroke_add : pk_stroke_add;
    pull_fn pull = ref ? ref_stroke_pull : pk_stroke_pull;
    if (ref)
        (void)ref_stroke_begin(st, zero);
    else
        (void)pk_stroke_begin(st, zero);
    for (size_t i = 0; i < n; i++) {
        pk_um_t err = rnd() % 11u == 0u ? (pk_um_t)rr(0, 6) : 0;
        for (int guard = 0; guard < 1000; guard++) {
            int a = add(st, pts[i], err);
            if (a == PK_OK)
                break;
            drain(st, pull, r, runs);
        }
    }
    if (ref)
        ref_stroke_finish(st);
    else
        pk_stroke_finish(st);
    drain(st, pull, r, runs);
}

static pk_um_t PTS[4000][PK_AXES];

static void test_straight_runs_give_the_path_of_the_kernel_and_the_decimator(void)
{
    static const pk_um_t tols[] = { 1, 5, 7, 8, 10, 20, 50, 200 };
    static struct pk_stroke sa, sb;
    unsigned runs_total = 0, cases = 0, diffs = 0;
    for (unsigned c = 0; c < 400; c++) {
        unsigned axes = (PK_AXES > 2 && c % 3u == 2u) ? 3u : 2u;
        struct pk_smooth_cfg s;
        memset(&s, 0, sizeof s);
        s.mode = PK_SMOOTH_TOLERANCE;
        s.degree = 2;
        s.tolerance_um = tols[c % (sizeof tols / sizeof tols[0])];
        s.sharp_turn_deg = (uint16_t)(c % 5u == 0u ? 30u : 60u);
        struct pk_planner_limits lim;
        memset(&lim, 0, sizeof lim);
        lim.axes = (uint8_t)axes;
        for (unsigned i = 0; i < axes; i++) {
            lim.max_rate[i] = (pk_um_min_t)rr(1000000, 24000000);
            lim.accel[i] = (pk_um_s2_t)rr(100000, 3000000);
        }
        lim.junction_dev_um = (pk_um_t)rr(1, 100);
        lim.accel_min = lim.accel[0];
        for (unsigned i = 1; i < axes; i++)
            if (lim.accel[i] < lim.accel_min)
                lim.accel_min = lim.accel[i];
        struct pk_planner_dyn dyn;
        pk_planner_dyn(&lim, &dyn);
        size_t n = gen(PTS, 200u + rnd() % 1500u, axes);
        uint8_t budget = (uint8_t)(c % 4u == 0u ? 4u : 0u);
        uint64_t seed = rng;
        ref_stroke_init(&sa, &s, (uint8_t)axes);
        ref_stroke_set_dyn(&sa, &dyn);
        ref_stroke_set_pull_budget(&sa, budget);
        pk_stroke_init(&sb, &s, (uint8_t)axes);
        pk_stroke_set_dyn(&sb, &dyn);
        pk_stroke_set_pull_budget(&sb, budget);
        memset(&A, 0, sizeof A);
        memset(&B, 0, sizeof B);
        sa.observe = on_ev;
        sa.observe_ctx = &A;
        sb.observe = on_ev;
        sb.observe_ctx = &B;
        rng = seed; /* the same chord errors for both */
        run(&sa, 1, (const pk_um_t (*)[PK_AXES])PTS, n, &A, NULL);
        rng = seed;
        unsigned runs = 0;
        run(&sb, 0, (const pk_um_t (*)[PK_AXES])PTS, n, &B, &runs);
        runs_total += runs;
        cases++;
        int same = A.n == B.n && memcmp(A.p, B.p, A.n * sizeof A.p[0]) == 0 &&
                   memcmp(A.sharp, B.sharp, A.n) == 0 && A.nev == B.nev && A.ev_hash == B.ev_hash;
        if (!same) {
            diffs++;
            if (diffs <= 3) {
                size_t k = 0;
                while (k < A.n && k < B.n && memcmp(A.p[k], B.p[k], sizeof A.p[0]) == 0 && A.sharp[k] == B.sharp[k])
                    k++;
                printf("  case %u (tol %d, axes %u): %zu/%zu points, first difference at %zu; events %zu/%zu\n",
                       c, (int)s.tolerance_um, axes, A.n, B.n, k, A.nev, B.nev);
            }
        }
    }
    /* with straight runs: the same points, corners and observer events as
     * through the kernel; and the random strokes take runs (else the
     * comparison proves nothing) */
    TH_EXPECT_EQ(diffs, 0);
    TH_EXPECT(runs_total > 1000u);
    printf("# %u cases, %u pulls inside straight runs\n", cases, runs_total);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_straight_runs_give_the_path_of_the_kernel_and_the_decimator),
    };
    return th_run(cases, TH_COUNT(cases));
}
