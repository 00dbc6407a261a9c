/*
 * test_determinism.c — the kernel's output depends on its input only: not on
 * what else runs in the process, not on the stream's history, not on the
 * order in which several streams are driven.
 *
 * Each check hashes (FNV-1a, 64 bit) every output point and tangent of a
 * stroke and compares hashes of runs that must agree: a lone run, the same
 * stroke again on the same (reused) instance, and two instances driven in
 * lock-step with different strokes in one process. The simulator's own
 * determinism (same trace byte for byte, two machines side by side) is in
 * tests/test_sim.c; the bundled examples' golden trace hashes are checked by
 * tests/e2e_determinism.sh.
 */
#include "pk_refine.h"
#include "th.h"

#define NPTS 24

static uint64_t fnv(uint64_t h, int32_t v)
{
    uint32_t u = (uint32_t)v;
    for (unsigned k = 0; k < 4u; k++) {
        h ^= (u >> (8u * k)) & 0xFFu;
        h *= 0x100000001B3u;
    }
    return h;
}

static uint64_t hash_out(uint64_t h, const struct pk_refine_out *o)
{
    for (unsigned a = 0; a < PK_AXES; a++) {
        h = fnv(h, o->p[a]);
        h = fnv(h, o->t[a]);
    }
    return h;
}

/* A deterministic polygon from a seed (LCG), within ±1 m. */
static void polygon(uint32_t seed, pk_um_t (*p)[PK_AXES])
{
    for (unsigned i = 0; i < NPTS; i++)
        for (unsigned a = 0; a < PK_AXES; a++) {
            seed = seed * 1664525u + 1013904223u;
            p[i][a] = (pk_um_t)(seed >> 12) % 2000001 - 1000000;
        }
}

/* Stream driver: one step of push-or-pull; returns 1 once PK_END is seen. */
struct drv {
    struct pk_refine r;
    const pk_um_t (*p)[PK_AXES];
    unsigned i;
    int finished;
    uint64_t h;
    unsigned n;
};

static int drv_step(struct drv *d)
{
    struct pk_refine_out o;
    int st = pk_refine_pull(&d->r, &o);
    if (st == PK_OK) {
        d->h = hash_out(d->h, &o);
        d->n++;
        return 0;
    }
    if (st == PK_END)
        return 1;
    if (d->i < NPTS) {
        if (pk_refine_push(&d->r, d->p[d->i]) == PK_OK)
            d->i++;
    } else if (!d->finished) {
        pk_refine_finish(&d->r);
        d->finished = 1;
    }
    return 0;
}

static void drv_start(struct drv *d, const pk_um_t (*p)[PK_AXES])
{
    d->p = p;
    d->i = 0;
    d->finished = 0;
    d->h = 0xCBF29CE484222325u;
    d->n = 0;
}

static uint64_t lone_run(const struct pk_refine_cfg *c, const pk_um_t (*p)[PK_AXES], unsigned *n)
{
    static struct drv d;
    *n = 0;
    if (pk_refine_init(&d.r, c) != PK_OK)
        return 0;
    drv_start(&d, p);
    for (unsigned guard = 0; guard < 1000000u && !drv_step(&d); guard++) {
    }
    *n = d.n;
    return d.h;
}

static struct pk_refine_cfg cfg_k(unsigned k)
{
    /* walk every scheme, degree, end rule, open/closed, limit/tangents */
    struct pk_refine_cfg c = { 0 };
    c.scheme = (k % 8u) == 7u ? PK_SCHEME_DLG : PK_SCHEME_BSPLINE;
    c.degree = (uint8_t)(1u + k % 7u);
    c.closed = (uint8_t)((k / 8u) & 1u);
    c.ends = (uint8_t)(c.degree <= 3u ? (k / 16u) % 4u : 2u + (k / 16u) % 2u);
    c.limit = (uint8_t)((k / 64u) & 1u);
    c.tangents = c.limit;
    c.depth = (uint8_t)(k % 5u);
    c.dims = 3;
    return c;
}

static void test_a_reused_stream_gives_the_same_stroke_again(void)
{
    static pk_um_t P[NPTS][PK_AXES];
    static struct drv d;
    unsigned checked = 0;
    for (unsigned k = 0; k < 128u; k++) {
        struct pk_refine_cfg c = cfg_k(k);
        if (pk_refine_init(&d.r, &c) != PK_OK)
            continue;
        polygon(k + 1u, P);
        uint64_t h[3];
        for (unsigned run = 0; run < 3u; run++) { /* the same struct, stroke after stroke */
            drv_start(&d, (const pk_um_t(*)[PK_AXES])P);
            unsigned guard = 0;
            while (!drv_step(&d) && ++guard < 1000000u) {
            }
            h[run] = d.h;
            TH_ASSERT(d.n > 0u);
        }
        TH_ASSERT_EQ(h[0], h[1]);
        TH_ASSERT_EQ(h[0], h[2]);
        unsigned n;
        TH_ASSERT_EQ(lone_run(&c, (const pk_um_t(*)[PK_AXES])P, &n), h[0]);
        checked++;
    }
    TH_ASSERT(checked >= 72u); /* the valid ones among the 128 (limit stage: fewer rules) */
}

static void test_two_streams_driven_together_match_their_lone_runs(void)
{
    static pk_um_t P[NPTS][PK_AXES], Q[NPTS][PK_AXES];
    static struct drv a, b;
    unsigned checked = 0;
    for (unsigned k = 0; k < 128u; k++) {
        struct pk_refine_cfg ca = cfg_k(k), cb;
        if (pk_refine_init(&a.r, &ca) != PK_OK)
            continue;
        /* b: the next valid configuration after a's */
        unsigned j = k;
        do {
            j = (j + 1u) % 128u;
            cb = cfg_k(j);
        } while (pk_refine_init(&b.r, &cb) != PK_OK);
        polygon(3u * k + 7u, P);
        polygon(5u * k + 11u, Q);
        drv_start(&a, (const pk_um_t(*)[PK_AXES])P);
        drv_start(&b, (const pk_um_t(*)[PK_AXES])Q);
        int ea = 0, eb = 0;
        /* lock-step with an irregular rhythm: a runs 1 or 2 steps per b step */
        for (unsigned s = 0; s < 2000000u && !(ea && eb); s++) {
            if (!ea)
                ea = drv_step(&a);
            if (!ea && (s % 3u) == 0u)
                ea = drv_step(&a);
            if (!eb)
                eb = drv_step(&b);
        }
        TH_ASSERT(ea && eb);
        unsigned na = 0, nb = 0;
        TH_ASSERT_EQ(a.h, lone_run(&ca, (const pk_um_t(*)[PK_AXES])P, &na));
        TH_ASSERT_EQ(a.n, na);
        TH_ASSERT_EQ(b.h, lone_run(&cb, (const pk_um_t(*)[PK_AXES])Q, &nb));
        TH_ASSERT_EQ(b.n, nb);
        checked++;
    }
    TH_ASSERT(checked >= 72u); /* the valid ones among the 128 (limit stage: fewer rules) */
}

static void test_a_different_input_gives_a_different_hash(void)
{
    /* guards the two tests above against a hash that ignores its input */
    static pk_um_t P[NPTS][PK_AXES];
    struct pk_refine_cfg c = cfg_k(3);
    polygon(42, P);
    unsigned n;
    uint64_t h1 = lone_run(&c, (const pk_um_t(*)[PK_AXES])P, &n);
    P[NPTS / 2][0] += 1;
    uint64_t h2 = lone_run(&c, (const pk_um_t(*)[PK_AXES])P, &n);
    TH_EXPECT(h1 != h2);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_reused_stream_gives_the_same_stroke_again),
        TH_CASE(test_two_streams_driven_together_match_their_lone_runs),
        TH_CASE(test_a_different_input_gives_a_different_hash),
    };
    return th_run(cases, TH_COUNT(cases));
}
