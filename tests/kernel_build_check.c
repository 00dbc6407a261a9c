/*
 * kernel_build_check.c — one kernel build (PK_BUILD_*, PK_AXES, PK_MAX_DEPTH
 * as compiled) against its contract; run by tests/e2e_kernel_builds.sh for
 * every build the README offers, each compiled from the firmware sources
 * with its own macros (so also the 32-bit working values, PK_UMF_BITS=32,
 * which the default host build never uses).
 *
 * For every configuration (scheme, degree, closed, end rule, limit/tangents,
 * depth 0..PK_MAX_DEPTH, dims 2..PK_AXES):
 *   - pk_refine_init returns PK_ENOTSUP exactly when the build leaves out
 *     what the configuration needs (the rules stated in pk_refine.h,
 *     re-derived here from the macros), PK_OK otherwise;
 *   - a supported configuration without the limit stage gives the exactly
 *     rounded rational on random polygons (tests/ref/exact_model.h), counts
 *     included, and the block pull the same points as the point pull;
 *   - every supported configuration prints one line "key hash" (FNV-1a over
 *     its outputs and tangents): the script checks that a restricted build's
 *     lines equal the full build's, so limit points and tangents agree too.
 * Prints "N passed, N failed" like the other tests. Host only (128 bits).
 */
#include <stdio.h>
#include <string.h>

#include "pk_refine.h"
#include "ref/exact_model.h"

#define MAXIN 24
#define MAXOUT 8192

static uint64_t rng = 0x9E3779B97F4A7C15u, rng_blocks = 1;
static uint32_t xorshift(uint64_t *st)
{
    *st ^= *st >> 12;
    *st ^= *st << 25;
    *st ^= *st >> 27;
    return (uint32_t)((*st * 0x2545F4914F6CDD1Du) >> 32);
}
/* inputs (the same in every build) and block sizes (whose number of draws
 * depends on how the build releases points) from separate generators */
static uint32_t rnd(void) { return xorshift(&rng); }
static uint32_t rnd_block(void) { return xorshift(&rng_blocks); }

static int32_t IN[MAXIN][3];
static struct pk_refine_out OUT[MAXOUT];
static pk_um_t BP[MAXOUT * 3];
static struct xm_poly XP[3];
static unsigned passed, failed;

static void check(int ok, const char *what, const struct pk_refine_cfg *c)
{
    if (ok) {
        passed++;
        return;
    }
    failed++;
    if (failed < 20)
        printf("not ok %s: scheme %u D=%u closed=%u ends=%u depth=%u dims=%u limit=%u\n", what,
               c->scheme, c->degree, c->closed, c->ends, c->depth, c->dims, c->tangents);
}

/* What pk_refine.h promises this build supports. */
static int expected_supported(const struct pk_refine_cfg *c)
{
    unsigned D = c->scheme == PK_SCHEME_DLG ? 0u : c->degree;
    unsigned ends = c->ends ? c->ends : (D <= 3u ? PK_ENDS_CLAMPED : PK_ENDS_REPLACE);
    if (c->scheme == PK_SCHEME_DLG ? !PK_BUILD_DLG : !(PK_BUILD_DEGREES & (1u << D)))
        return 0;
    if (c->closed ? !PK_BUILD_CLOSED : (c->scheme == PK_SCHEME_BSPLINE && !(PK_BUILD_ENDS & (1u << ends))))
        return 0;
    if (c->scheme == PK_SCHEME_BSPLINE && !c->closed && ends == PK_ENDS_CLAMPED && D > 3u)
        return 0;
    if ((c->limit || c->tangents) && !PK_BUILD_LIMIT)
        return 0;
    if (c->closed && (c->scheme == PK_SCHEME_DLG ? 5u : D < 2u ? 2u : D) > PK_CLOSE_MAX)
        return 0;
    /* the level cascade (DLG, degrees >= 4, the replace rule of 2..3) keeps
     * PK_WIN points per level: DLG needs 4, degree D (D + 1) / 2 + 1 */
    int cascade = c->depth > 0u && (c->scheme == PK_SCHEME_DLG || D >= 4u ||
                                    (D >= 2u && !c->closed && ends == PK_ENDS_REPLACE));
    if (cascade && (c->scheme == PK_SCHEME_DLG ? 4u : (D + 1u) / 2u + 1u) > PK_WIN)
        return 0;
    return 1;
}

static int run(const struct pk_refine_cfg *c, unsigned m, unsigned *n, int block)
{
    static struct pk_refine r;
    int st = pk_refine_init(&r, c);
    if (st != PK_OK)
        return st;
    *n = 0;
    for (unsigned i = 0; i <= m; i++) {
        if (i < m) {
            pk_um_t p[PK_AXES] = { 0 };
            for (unsigned a = 0; a < c->dims; a++)
                p[a] = IN[i][a];
            if (pk_refine_push(&r, p) != PK_OK)
                return -100;
        } else {
            pk_refine_finish(&r);
        }
        for (;;) {
            if (block) {
                uint32_t got = 0, want = 1u + rnd_block() % 40u;
                if (*n + want > MAXOUT)
                    return -101;
                st = pk_refine_pull_block(&r, BP + (size_t)*n * c->dims, NULL, want, &got);
                *n += got;
            } else {
                if (*n >= MAXOUT)
                    return -101;
                st = pk_refine_pull(&r, &OUT[*n]);
                if (st == PK_OK)
                    (*n)++;
            }
            if (st != PK_OK)
                break;
        }
        if (st != (i < m ? PK_NEED_INPUT : PK_END))
            return -102;
    }
    return PK_OK;
}

static uint64_t fnv(uint64_t h, int32_t v)
{
    for (int k = 0; k < 4; k++) {
        h ^= (uint8_t)((uint32_t)v >> (8 * k));
        h *= 0x100000001B3u;
    }
    return h;
}

static int exact_ok(const struct pk_refine_cfg *c, unsigned m, unsigned n)
{
    unsigned D = c->scheme == PK_SCHEME_DLG ? 0u : c->degree;
    int ends = c->ends ? c->ends : (D <= 3u ? PK_ENDS_CLAMPED : PK_ENDS_REPLACE);
    struct xm_cfg xc = { c->scheme == PK_SCHEME_DLG, (int)D, c->closed, c->scheme == PK_SCHEME_DLG ? 3 : ends };
    xm_refine(&xc, c->depth, (const int32_t(*)[3])IN, m, c->dims, XP);
    if (XP[0].n != n)
        return 0;
    int relaxed = D * c->depth > 42u; /* pk_refine.h: 0.5 + 2^-34 there */
    for (unsigned rot = 0; rot < (c->closed && n ? n : 1u); rot++) {
        unsigned i = 0;
        for (; i < n; i++) {
            unsigned a = 0;
            for (; a < c->dims; a++)
                if (relaxed ? !xm_within(OUT[i].p[a], XP[a].v[(i + rot) % n], XP[a].frac, ((xm_t)1 << 33) + 1, 34)
                            : OUT[i].p[a] != xm_round(XP[a].v[(i + rot) % n], XP[a].frac))
                    break;
            if (a < c->dims)
                break;
        }
        if (i == n)
            return 1;
    }
    return 0;
}

int main(void)
{
    unsigned configs = 0, supported = 0, tried = 0;
    for (unsigned scheme = 0; scheme <= 1u; scheme++)
        for (unsigned D = scheme ? 0u : 1u; D <= (scheme ? 0u : 7u); D++)
            for (unsigned closed = 0; closed <= 1u; closed++)
                for (unsigned ends = 0; ends <= (closed || scheme ? 0u : 3u); ends++)
                    for (unsigned lim = 0; lim <= 2u; lim++)
                        for (unsigned depth = 0; depth <= PK_MAX_DEPTH; depth++)
                            for (unsigned dims = 2; dims <= PK_AXES; dims++) {
                                struct pk_refine_cfg c = { 0 };
                                c.scheme = (uint8_t)scheme;
                                c.degree = (uint8_t)D;
                                c.closed = (uint8_t)closed;
                                c.ends = (uint8_t)ends;
                                c.limit = (uint8_t)(lim != 0);
                                c.tangents = (uint8_t)(lim == 2);
                                c.depth = (uint8_t)depth;
                                c.dims = (uint8_t)dims;
                                configs = (((((scheme * 8u + D) * 2u + closed) * 4u + ends) * 3u + lim) * 9u + depth) * 4u + dims;
                                static struct pk_refine r;
                                tried++;
                                int st = pk_refine_init(&r, &c);
                                int want = expected_supported(&c);
                                if (want && st == PK_ENOTSUP && c.limit) {
                                    /* a limit stencil wider than PK_LWIN (degree 7, replace):
                                     * refused in every build, which the script checks */
                                    printf("%u/%u/%u/%u/%u/%u/%u enotsup\n", scheme, D, closed, ends, lim, depth,
                                           dims);
                                    continue;
                                }
                                check(want ? st == PK_OK : st == PK_ENOTSUP, "init as the build promises", &c);
                                if (st != PK_OK)
                                    continue;
                                supported++;
                                uint64_t h = 0xCBF29CE484222325u;
                                /* the same polygons for this configuration in every build */
                                rng = 0x9E3779B97F4A7C15u ^ ((uint64_t)configs * 0x100000001B3u);
                                for (unsigned trial = 0; trial < 3u; trial++) {
                                    unsigned m = trial == 0 ? 3u : 1u + rnd() % (depth > 6u ? 9u : MAXIN - 1u);
                                    for (unsigned i = 0; i < m; i++)
                                        for (unsigned a = 0; a < 3u; a++)
                                            IN[i][a] = a < dims ? (int32_t)(rnd() % (2u * PK_UM_MAX + 1u)) - PK_UM_MAX
                                                                : 0;
                                    unsigned n = 0, nb = 0;
                                    int rs = run(&c, m, &n, 0);
                                    check(rs == PK_OK, "stroke runs to PK_END", &c);
                                    if (rs != PK_OK)
                                        continue;
                                    if (!c.limit)
                                        check(exact_ok(&c, m, n), "exactly rounded", &c);
                                    h = fnv(h, (int32_t)n);
                                    for (unsigned i = 0; i < n; i++)
                                        for (unsigned a = 0; a < dims; a++) {
                                            h = fnv(h, OUT[i].p[a]);
                                            h = fnv(h, OUT[i].t[a]);
                                        }
                                    int bs = run(&c, m, &nb, 1);
                                    int same = bs == PK_OK && nb == n;
                                    for (unsigned i = 0; same && i < n; i++)
                                        for (unsigned a = 0; a < dims; a++)
                                            same &= BP[(size_t)i * dims + a] == OUT[i].p[a];
                                    check(same, "block pull = point pull", &c);
                                }
                                printf("%u/%u/%u/%u/%u/%u/%u %016llx\n", scheme, D, closed, ends, lim, depth, dims,
                                       (unsigned long long)h);
                            }
    printf("# %u configurations, %u built (PK_BUILD_DEGREES=0x%02x DLG=%d ENDS=0x%02x CLOSED=%d LIMIT=%d "
           "PK_AXES=%d PK_MAX_DEPTH=%d PK_UMF_BITS=%d)\n",
           tried, supported, PK_BUILD_DEGREES, PK_BUILD_DLG, PK_BUILD_ENDS, PK_BUILD_CLOSED, PK_BUILD_LIMIT,
           PK_AXES, PK_MAX_DEPTH, PK_UMF_BITS);
    check(supported > 0, "the build supports something", &(struct pk_refine_cfg){ 0 });
    printf("%u passed, %u failed\n", passed, failed);
    return failed != 0;
}
