/*
 * test_motion_planner.c — the planner and the integer helpers on their own:
 * the speed plan obeys every constraint it promises (checked pairwise on the
 * planned numbers, for random polylines), the square root is the exact floor,
 * and µm -> steps rounding agrees with a double reference.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>
#include "pk_motion.h"
#include "th.h"

int th_main(int argc, char **argv);

static uint64_t rng = 88172645463325252ull;
static uint64_t xr(void) { return th_xorshift64(&rng); }

static void test_isqrt64_is_the_exact_floor_everywhere(void)
{
    static const uint64_t edge[] = { 0, 1, 2, 3, 4, 15, 16, 17, UINT32_MAX, (uint64_t)UINT32_MAX * UINT32_MAX,
                                     (uint64_t)UINT32_MAX * UINT32_MAX - 1, UINT64_MAX };
    for (unsigned k = 0; k < TH_COUNT(edge); k++) {
        uint64_t x = edge[k], r = pk_isqrt64(x);
        TH_EXPECT(r * r <= x);
        TH_EXPECT((r + 1) * (r + 1) > x || r == UINT32_MAX);
    }
    unsigned bad = 0;
    for (int k = 0; k < 200000; k++) {
        uint64_t x = xr() >> (xr() % 64);
        uint64_t r = pk_isqrt64(x);
        if (!(r * r <= x && (r == UINT32_MAX || (r + 1) * (r + 1) > x)))
            bad++;
    }
    /* the squares and their neighbours, at every width (the byte and
     * 16/32/64-bit phase boundaries of the digit loop among them) */
    for (int k = 0; k < 100000; k++) {
        const uint64_t r = xr() >> (32 + xr() % 32); /* < 2^32 */
        const uint64_t sq = r * r;
        if (pk_isqrt64(sq) != r || (r > 0 && pk_isqrt64(sq - 1u) != r - 1u) ||
            pk_isqrt64(sq + 2u * r) != r)
            bad++;
    }
    TH_EXPECT_EQ(bad, 0);
}

/* pk_frac_q30 (the decimator's ratios, 32-bit shift and subtract on 8-bit
 * cores) is the floor of the 64-bit quotient for every x <= r < 2^31; its
 * soft form is checked here on the host, where pk_frac_q30 itself divides. */
static void test_frac_q30_is_the_exact_floor_of_the_64_bit_quotient(void)
{
    static const uint32_t er[] = { 1, 2, 3, 255, 256, 65535, 65536, 0x7FFFFFFEu, 0x7FFFFFFFu };
    unsigned bad = 0;
    for (unsigned k = 0; k < TH_COUNT(er); k++) {
        uint32_t r = er[k], xs[] = { 0, 1, r / 2u, r - 1u, r };
        for (unsigned j = 0; j < TH_COUNT(xs); j++) {
            uint32_t x = xs[j] > r ? r : xs[j];
            uint32_t want = (uint32_t)(((uint64_t)x << 30) / r);
            bad += pk_frac_q30_soft(x, r) != want || pk_frac_q30(x, r) != want;
        }
    }
    for (int k = 0; k < 1000000; k++) {
        uint32_t r = (uint32_t)(xr() >> (33 + xr() % 31)) | 1u;
        if (r > 0x7FFFFFFFu)
            r = 0x7FFFFFFFu;
        uint32_t x = (uint32_t)(xr() % ((uint64_t)r + 1u));
        uint32_t want = (uint32_t)(((uint64_t)x << 30) / r);
        bad += pk_frac_q30_soft(x, r) != want || pk_frac_q30(x, r) != want;
    }
    TH_EXPECT_EQ(bad, 0);
}

static void test_micrometres_round_to_the_nearest_step_like_a_double_reference(void)
{
    unsigned bad = 0;
    for (int k = 0; k < 200000; k++) {
        pk_um_t um = (pk_um_t)((int64_t)(xr() % (2u * PK_UM_MAX + 1)) - PK_UM_MAX);
        pk_spmm_q16_t s = PK_SPMM_Q16_MIN + (pk_spmm_q16_t)(xr() % (PK_SPMM_Q16_MAX - PK_SPMM_Q16_MIN));
        double exact = (double)um * (double)s / 65536.0 / 1000.0;
        long want = lround(exact);
        /* skip values within 1e-6 of a tie, where double itself is unsure */
        if (fabs(fabs(exact - trunc(exact)) - 0.5) < 1e-6)
            continue;
        bad += pk_um_to_steps(um, s) != want;
        /* and back: within half a step of the original */
        pk_um_t back = pk_steps_to_um((pk_steps_t)want, s);
        double step_um = 1000.0 * 65536.0 / s;
        bad += fabs((double)back - (double)um) > step_um / 2 + 1.0;
    }
    TH_EXPECT_EQ(bad, 0);
}

/* An XY move of d µm at 80 steps/mm, planned in steps. */
static void add_move(struct pk_planner *p, struct pk_mq *q, const int32_t d[PK_AXES], pk_um_min_t feed,
                     uint8_t flags)
{
    pk_steps_t st[PK_AXES] = { 0 };
    int32_t dq[PK_AXES] = { 0 };
    for (int i = 0; i < 2; i++) {
        st[i] = (pk_steps_t)(d[i] * 80 / 1000);
        dq[i] = (int32_t)((int64_t)st[i] * 1000 * 256 / 80);
    }
    (void)pk_planner_add_line(p, q, dq, st, d, 0u, feed, flags);
}

/* One random move (or, rarely, a dwell) at 80 steps/mm, planned in steps. */
static void add_random(struct pk_planner *p, struct pk_mq *q, int32_t d[PK_AXES])
{
    int mag = (xr() % 3 == 0) ? 20000 : 500;
    d[0] = (int32_t)(xr() % (2u * mag + 1)) - mag;
    d[1] = (int32_t)(xr() % (2u * mag + 1)) - mag;
    if (xr() % 17 == 0)
        (void)pk_planner_add_stop(p, q, PK_BLK_DWELL, 0, 0, 0);
    else
        add_move(p, q, d, (pk_um_min_t)(60u * (1000u + xr() % 120000u)), (uint8_t)(xr() % 2u ? PK_PLAN_SHARP : 0u));
}

/* Every planned block: exit <= nominal, exit <= next entry ceiling (junction),
 * exit reachable from entry within the length (accelerating) and the entry
 * reachable backwards (decelerating), newest exit 0. Checked in doubles. */
static void test_replanned_speeds_respect_every_constraint_on_random_polylines(void)
{
    static struct pk_mq q;
    static struct pk_planner p;
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = 2;
    lim.max_rate[0] = 6000000;   /* µm/min */
    lim.max_rate[1] = 4200000;
    lim.accel[0] = 1000000;
    lim.accel[1] = 500000;
    lim.junction_dev_um = 20;
    lim.accel_min = 500000;
    unsigned bad = 0, blocks = 0, stops_ok = 0;
    for (int run = 0; run < 200; run++) {
        pk_mq_init(&q);
        pk_planner_init(&p, &lim);
        int32_t pos[2] = { 0, 0 };
        int n = 2 + (int)(xr() % (PK_MQ_CAP - 2));
        for (int k = 0; k < n; k++) {
            int32_t d[PK_AXES] = { 0 };
            add_random(&p, &q, d);
            pos[0] += d[0];
            pos[1] += d[1];
        }
        pk_v2_q4_t v2_now = 0;
        pk_planner_replan(&p, &q, v2_now, pk_mq_count(&q) ? pk_mq_at(&q, 0)->len_q8 : 0, false);
        double entry = 0;
        uint32_t cnt = pk_mq_count(&q);
        for (uint32_t k = 0; k < cnt; k++) {
            struct pk_block *b = pk_mq_at(&q, k);
            blocks++;
            if (b->type != PK_BLK_LINE) {
                bad += b->v2_exit != 0;
                entry = 0;
                continue;
            }
            double ex = (double)b->v2_exit / 16, nom = (double)b->v2_nom / 16;
            double two_al = 2.0 * b->accel * (b->len_q8 / 256.0);
            if (k > 0)
                bad += entry > (double)b->v2_junction / 16 * (1 + 1e-9) + 1;
            bad += ex > nom + 1;
            bad += ex > entry + two_al * (1 + 1e-6) + 16;  /* reachable accelerating */
            bad += entry > ex + two_al * (1 + 1e-6) + 16;  /* and decelerating */
            entry = ex;
        }
        struct pk_block *last = pk_mq_at(&q, cnt - 1);
        stops_ok += last->v2_exit == 0;
    }
    TH_EXPECT_EQ(bad, 0);
    TH_EXPECT_EQ(stops_ok, 200); /* the newest block always ends at rest */
    TH_EXPECT(blocks > 1000);
}

/* The plan the step generator may execute must be the plan it would have
 * had with the whole program in view: exits marked final never change when
 * more blocks are appended. */
static void test_a_final_plan_never_changes_when_blocks_are_appended(void)
{
    static struct pk_mq q;
    static struct pk_planner p;
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = 2;
    lim.max_rate[0] = lim.max_rate[1] = 6000000;
    lim.accel[0] = lim.accel[1] = 1000000;
    lim.junction_dev_um = 10;
    lim.accel_min = 1000000;
    unsigned checked = 0, bad = 0, some_final = 0, all_when_known = 0;
    for (int run = 0; run < 400; run++) {
        pk_mq_init(&q);
        pk_planner_init(&p, &lim);
        int n = 1 + (int)(xr() % (PK_MQ_CAP / 2));
        int32_t d[PK_AXES];
        while (pk_mq_count(&q) < (uint32_t)n)
            add_random(&p, &q, d);
        uint32_t rem = pk_mq_at(&q, 0)->len_q8;
        pk_planner_replan(&p, &q, 0, rem, true);
        all_when_known += pk_planner_final(&p) == pk_mq_count(&q);
        pk_planner_replan(&p, &q, 0, rem, false);
        uint32_t f = pk_planner_final(&p);
        some_final += f > 0;
        pk_v2_q4_t ex[PK_MQ_CAP];
        for (uint32_t k = 0; k < f; k++)
            ex[k] = pk_mq_at(&q, k)->v2_exit;
        while (pk_mq_room(&q) > 0) {
            add_random(&p, &q, d);
            pk_planner_replan(&p, &q, 0, rem, false);
            for (uint32_t k = 0; k < f; k++, checked++)
                bad += pk_mq_at(&q, k)->v2_exit != ex[k];
            TH_EXPECT(pk_planner_final(&p) >= f);
        }
    }
    TH_EXPECT_EQ(bad, 0);
    TH_EXPECT(checked > 1000);
    TH_EXPECT(some_final > 100);       /* finality is not vacuous */
    TH_EXPECT_EQ(all_when_known, 400); /* a known end makes every plan final */
}

/* A short move turning a little from the last (a smoothed curve: the
 * reverse pass's limits then reach back over many blocks), at 80 steps/mm. */
static void add_curve(struct pk_planner *p, struct pk_mq *q, double *ang)
{
    *ang += ((double)(xr() % 2001u) - 1000.0) * 2e-4;   /* +-0.2 rad */
    double len = 100.0 + (double)(xr() % 1900u);          /* 0.1 - 2 mm */
    int32_t d[PK_AXES] = { 0 };
    d[0] = (int32_t)lround(len * cos(*ang));
    d[1] = (int32_t)lround(len * sin(*ang));
    add_move(p, q, d, (pk_um_min_t)(60u * (20000u + xr() % 80000u)), 0u);
}

/* The replan keeps what it computed (pk_planner_replan: the nominal speeds
 * until the overrides change; the plan below the last anchor while blocks
 * are only appended): over random sequences of appended blocks, override
 * changes, executed blocks and replans, every replan plans exactly what a
 * replan from scratch plans (a copy of the queue with every nominal cleared
 * and the planner's memory of its last plan dropped). */
static void test_a_replan_plans_what_a_replan_from_scratch_plans(void)
{
    static struct pk_mq q, q2;
    static struct pk_planner p, p2;
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = 2;
    lim.max_rate[0] = 6000000;
    lim.max_rate[1] = 4200000;
    lim.accel[0] = 1000000;
    lim.accel[1] = 500000;
    lim.junction_dev_um = 20;
    lim.accel_min = 500000;
    static const uint16_t feed[] = { 10, 50, 100, 100, 120, 200 }, rapid[] = { 25, 50, 100 };
    unsigned replans = 0, diff = 0, ovr_changes = 0, incremental = 0;
    for (int run = 0; run < 300; run++) {
        pk_mq_init(&q);
        pk_planner_init(&p, &lim);
        pk_v2_q4_t last_v2 = 0;
        uint32_t last_rem = 0;
        bool last_end = false, popped = true;
        double ang = 0.0;
        for (int op = 0; op < 60; op++) {
            unsigned r = (unsigned)(xr() % 8u);
            if (r < 4u && pk_mq_room(&q) > 0) {
                int32_t d[PK_AXES] = { 0 };
                if (run % 2 == 0)
                    add_curve(&p, &q, &ang);
                else
                    add_random(&p, &q, d);
            } else if (r == 4u) {
                pk_planner_set_override(&p, feed[xr() % TH_COUNT(feed)], rapid[xr() % TH_COUNT(rapid)]);
                ovr_changes++;
            } else if (r == 5u && pk_mq_count(&q) > 0) {
                pk_mq_pop(&q);
                popped = true;
            }
            if (pk_mq_count(&q) == 0 || xr() % 3u == 0u)
                continue;
            struct pk_block *b0 = pk_mq_at(&q, 0);
            uint32_t rem = b0->type == PK_BLK_LINE ? b0->len_q8 - (uint32_t)(xr() % (b0->len_q8 + 1u)) : 0u;
            pk_v2_q4_t v2_now = b0->type == PK_BLK_LINE ? (pk_v2_q4_t)(xr() % (b0->v2_nom + 1u)) : 0u;
            bool end_known = xr() % 4u == 0u;
            if (!popped && xr() % 4u != 0u) {
                /* the machine's case: the same block under way, the same end */
                v2_now = last_v2;
                rem = last_rem;
                end_known = last_end;
            }
            incremental += p.plan_valid && p.plan_anchor > 0 && !popped && v2_now == last_v2 && rem == last_rem
                           && end_known == last_end;
            last_v2 = v2_now;
            last_rem = rem;
            last_end = end_known;
            popped = false;
            q2 = q;
            p2 = p;
            p2.plan_valid = false;
            for (uint32_t k = 0; k < pk_mq_count(&q2); k++) {
                struct pk_block *c = pk_mq_at(&q2, k);
                if (c->type == PK_BLK_LINE)
                    c->v2_nom = 0u;
            }
            pk_planner_replan(&p, &q, v2_now, rem, end_known);
            pk_planner_replan(&p2, &q2, v2_now, rem, end_known);
            replans++;
            diff += pk_planner_final(&p) != pk_planner_final(&p2);
            for (uint32_t k = 0; k < pk_mq_count(&q); k++) {
                const struct pk_block *a = pk_mq_at(&q, k), *c = pk_mq_at(&q2, k);
                diff += a->v2_nom != c->v2_nom || a->v2_exit != c->v2_exit || a->end_limited != c->end_limited;
            }
        }
    }
    TH_EXPECT_EQ(diff, 0);
    TH_EXPECT(replans > 5000);
    TH_EXPECT(ovr_changes > 1000);
    TH_EXPECT(incremental > 1000); /* replans that started from an anchor above 0 */
}

/* A polygon with chords c on a circle of radius R turns by c/R per vertex:
 * the curvature limit is v^2 = a R for the worst-placed axis (the axis whose
 * velocity changes most at that vertex), independent of c. */
static void test_the_curvature_limit_is_a_times_the_radius(void)
{
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = 2;
    lim.accel[0] = lim.accel[1] = 1000000;  /* 1000 mm/s^2 */
    const double R = 10000.0;              /* 10 mm, in µm */
    for (double c = 50; c <= 2000; c *= 2) {
        double th = c / R;                 /* turn per vertex (chord ~ arc) */
        /* a vertex on the x axis of the circle: velocity turns about +y */
        pk_q30_t u1[PK_AXES] = { 0 }, u2[PK_AXES] = { 0 };
        u1[0] = (pk_q30_t)lround(sin(th / 2) * PK_Q30_ONE);
        u1[1] = (pk_q30_t)lround(cos(th / 2) * PK_Q30_ONE);
        u2[0] = -u1[0];
        u2[1] = u1[1];
        uint32_t l = (uint32_t)lround(2 * R * sin(th / 2) * 256);
        double v2 = (double)pk_planner_curvature_v2(u1, u2, 2, l, l, lim.accel[0]) / 16.0;
        double expect = 1000000.0 * (2 * R * sin(th / 2)) / (2 * sin(th / 2));  /* a * R */
        TH_EXPECT(fabs(v2 / expect - 1.0) < 0.01);
    }
}

static void test_a_straight_continuation_is_not_slowed_by_the_junction(void)
{
    pk_q30_t u[PK_AXES] = { 0 };
    u[0] = (pk_q30_t)lround(0.6 * PK_Q30_ONE);
    u[1] = (pk_q30_t)lround(0.8 * PK_Q30_ONE);
    TH_EXPECT_EQ(pk_planner_junction_v2(u, u, 2, 1000000, 20), UINT64_MAX);
    pk_q30_t r[PK_AXES] = { -u[0], -u[1] };
    TH_EXPECT_EQ(pk_planner_junction_v2(u, r, 2, 1000000, 20), 0); /* reversal */
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_isqrt64_is_the_exact_floor_everywhere),
        TH_CASE(test_micrometres_round_to_the_nearest_step_like_a_double_reference),
        TH_CASE(test_frac_q30_is_the_exact_floor_of_the_64_bit_quotient),
        TH_CASE(test_replanned_speeds_respect_every_constraint_on_random_polylines),
        TH_CASE(test_a_final_plan_never_changes_when_blocks_are_appended),
        TH_CASE(test_a_replan_plans_what_a_replan_from_scratch_plans),
        TH_CASE(test_the_curvature_limit_is_a_times_the_radius),
        TH_CASE(test_a_straight_continuation_is_not_slowed_by_the_junction),
    };
    return th_run(cases, TH_COUNT(cases));
}
