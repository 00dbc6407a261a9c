/*
 * test_masks.c — the generated limit/tangent mask tables (firmware/pk_masks.c).
 *
 * Checks the tables' invariants (affine position masks, translation-free
 * tangent masks, bounds), and applies them, exactly as the kernel's limit
 * stage must (tests/vectors/README.md), to every depth-0 reference vector in
 * tests/vectors/cases (and the shared limit vectors when present). The
 * vectors were computed independently of the tables (de Boor evaluation of
 * the B-spline, exact fixed points, deep refinement for DLG and replace-end
 * tangents). Bounds: positions must be exact (rational cross-multiplication
 * in 128-bit integers); exact tangents must be exactly parallel; decimal
 * tangents (irrational masks rounded to 2^-24) within 1e-4 degrees.
 */
#include "th.h"
#include "pk_masks.h"

#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

typedef __int128 i128;

struct rat { int64_t p, q; };

#define MAXPTS 64
struct vcase {
    unsigned scheme, degree, closed, ends, depth, dim, dec;
    unsigned nin, nout;
    int64_t in[MAXPTS][3];
    struct rat out[MAXPTS][3];
    struct rat tan[MAXPTS][3];
    double tdec[MAXPTS][3];
};

static int parse_rat(const char *s, struct rat *r)
{
    char *end;
    r->p = strtoll(s, &end, 10);
    r->q = 1;
    if (*end == '/')
        r->q = strtoll(end + 1, &end, 10);
    return r->q > 0;
}

static int load_case(const char *path, struct vcase *c)
{
    FILE *f = fopen(path, "r");
    char line[1024];
    memset(c, 0, sizeof *c);
    if (!f)
        return 0;
    while (fgets(line, sizeof line, f)) {
        char key[32], a[64];
        unsigned v;
        if (sscanf(line, "%31s %63s", key, a) < 1)
            continue;
        if (!strcmp(key, "scheme")) {
            if (!strcmp(a, "dlg")) c->scheme = 1, c->degree = 0;
            else if (!strcmp(a, "chaikin")) c->scheme = 0, c->degree = 2;
            else c->scheme = 0, c->degree = (unsigned)atoi(a + 8);
        } else if (!strcmp(key, "ends")) {
            c->ends = !strcmp(a, "clamped") ? 1u : !strcmp(a, "replace") ? 2u : 3u;
        } else if (sscanf(line, "closed %u", &v) == 1) c->closed = v;
        else if (sscanf(line, "depth %u", &v) == 1) c->depth = v;
        else if (sscanf(line, "dim %u", &v) == 1) c->dim = v;
        else if (sscanf(line, "tangent_decimal %u", &v) == 1) c->dec = v;
        else if (sscanf(line, "input %u", &v) == 1) {
            c->nin = v;
            for (unsigned i = 0; i < v && i < MAXPTS; i++) {
                long long x[3] = {0, 0, 0};
                if (!fgets(line, sizeof line, f) || sscanf(line, "%lld %lld %lld", &x[0], &x[1], &x[2]) < 2)
                    goto bad;
                for (unsigned k = 0; k < 3; k++) c->in[i][k] = x[k];
            }
        } else if (sscanf(line, "output %u", &v) == 1) {
            c->nout = v;
            for (unsigned i = 0; i < v && i < MAXPTS; i++) {
                char t[6][96];
                int got;
                if (!fgets(line, sizeof line, f))
                    goto bad;
                got = sscanf(line, "%95s %95s %95s %95s %95s %95s", t[0], t[1], t[2], t[3], t[4], t[5]);
                if (got != (int)(2 * c->dim))
                    goto bad;
                for (unsigned k = 0; k < c->dim; k++) {
                    if (!parse_rat(t[k], &c->out[i][k]))
                        goto bad;
                    if (c->dec) c->tdec[i][k] = strtod(t[c->dim + k], NULL);
                    else if (!parse_rat(t[c->dim + k], &c->tan[i][k])) goto bad;
                }
            }
        }
    }
    fclose(f);
    return c->nin <= MAXPTS && c->nout <= MAXPTS;
bad:
    fclose(f);
    return 0;
}

/* A rule as a plain struct, read through the table API (pk_masks.h). */
struct rule_view {
    struct pk_rule_info info;
    struct pk_mask pos_uniform, tan_uniform, pos_end[4], tan_end[4];
};

static int rule_load(unsigned scheme, unsigned degree, unsigned closed, unsigned ends, struct rule_view *v)
{
    const int32_t *r = pk_limit_rule_get(scheme, degree, closed, ends);
    if (r == NULL)
        return 0;
    pk_limit_rule_info(r, &v->info);
    pk_limit_rule_mask(r, 0, &v->pos_uniform);
    pk_limit_rule_mask(r, 1, &v->tan_uniform);
    for (unsigned a = 0; a < 4u; a++) {
        pk_limit_rule_mask(r, 2u + a, &v->pos_end[a]);
        pk_limit_rule_mask(r, 6u + a, &v->tan_end[a]);
    }
    return 1;
}

/* One limit-stage output computed from the tables: value = num[k] / den. */
struct lout { i128 num[3]; int64_t den; int has_t; i128 t[3]; };

static void apply(const struct pk_mask *m, const int64_t L[][3], unsigned n, unsigned dim, int anchor,
                  int right, int closed, i128 *num, int64_t *den)
{
    for (unsigned k = 0; k < dim; k++) num[k] = 0;
    for (unsigned r = 0; r < m->len; r++) {
        long i = (long)anchor + m->first + (long)r;
        if (closed) i = ((i % (long)n) + (long)n) % (long)n;
        else if (right) i = (long)n - 1 - i;
        for (unsigned k = 0; k < dim; k++) num[k] += (i128)pk_mask_w(m, r) * L[i][k];
    }
    if (den) *den = m->den;
}

/* The limit stage, as tests/vectors/README.md specifies it. Returns the count. */
static unsigned limit_stage(const struct vcase *c, const int64_t L[][3], unsigned n, struct lout *o)
{
    struct rule_view rv;
    const struct rule_view *rule = &rv;
    unsigned cnt = 0;
    if (!rule_load(c->scheme, c->degree, c->closed, c->ends, &rv) || n == 0)
        return 0;
    if (c->closed) {
        for (unsigned a = 0; a < n; a++, cnt++) {
            apply(&rule->pos_uniform, L, n, c->dim, (int)a, 0, 1, o[cnt].num, &o[cnt].den);
            o[cnt].has_t = rule->tan_uniform.len > 0;
            apply(&rule->tan_uniform, L, n, c->dim, (int)a, 0, 1, o[cnt].t, NULL);
        }
        return cnt;
    }
    if (n < rule->info.min_n) {
        unsigned slots = (rule->info.edge_anchors && n > 2) ? n - 1 : n;
        for (unsigned a = 0; a < slots; a++) {
            struct pk_mask p, t;
            if (!pk_limit_small_get(c->scheme, c->degree, c->ends, n, a, 0, &p))
                continue;
            int has_t = pk_limit_small_get(c->scheme, c->degree, c->ends, n, a, 1, &t);
            apply(&p, L, n, c->dim, (int)a, 0, 0, o[cnt].num, &o[cnt].den);
            o[cnt].has_t = has_t && t.len > 0;
            if (o[cnt].has_t) apply(&t, L, n, c->dim, (int)a, 0, 0, o[cnt].t, NULL);
            cnt++;
        }
        return cnt;
    }
    unsigned A = rule->info.edge_anchors ? n - 1 : n;
    for (unsigned a = 0; a < A; a++) {
        const struct pk_mask *p, *t;
        int right = 0, at = (int)a;
        if (a < rule->info.nend) {
            if (rule->info.drop_mask & (1u << a)) continue;
            p = &rule->pos_end[a]; t = &rule->tan_end[a];
        } else if (A - 1 - a < rule->info.nend) {
            unsigned b = A - 1 - a;
            if (rule->info.drop_mask & (1u << b)) continue;
            p = &rule->pos_end[b]; t = &rule->tan_end[b]; right = 1; at = (int)b;
        } else {
            p = &rule->pos_uniform; t = &rule->tan_uniform;
        }
        apply(p, L, n, c->dim, at, right, 0, o[cnt].num, &o[cnt].den);
        o[cnt].has_t = t->len > 0;
        apply(t, L, n, c->dim, at, right, 0, o[cnt].t, NULL);
        if (right)
            for (unsigned k = 0; k < c->dim; k++) o[cnt].t[k] = -o[cnt].t[k];
        cnt++;
    }
    return cnt;
}

static int same_point(const struct lout *o, const struct rat *r, unsigned dim)
{
    for (unsigned k = 0; k < dim; k++)
        if (o->num[k] * r[k].q != (i128)r[k].p * o->den)
            return 0;
    return 1;
}

static double tangent_error_deg(const struct vcase *c, const struct lout *o, unsigned i)
{
    double u[3] = {0, 0, 0}, v[3] = {0, 0, 0}, nu = 0, nv = 0, dot = 0, cr;
    for (unsigned k = 0; k < c->dim; k++) {
        u[k] = (double)o->t[k];
        v[k] = c->dec ? c->tdec[i][k] : (double)c->tan[i][k].p / (double)c->tan[i][k].q;
        nu += u[k] * u[k]; nv += v[k] * v[k]; dot += u[k] * v[k];
    }
    if (nu == 0 || nv == 0)
        return (nu == 0 && nv == 0) ? 0.0 : 180.0;
    cr = sqrt((u[1] * v[2] - u[2] * v[1]) * (u[1] * v[2] - u[2] * v[1]) +
              (u[2] * v[0] - u[0] * v[2]) * (u[2] * v[0] - u[0] * v[2]) +
              (u[0] * v[1] - u[1] * v[0]) * (u[0] * v[1] - u[1] * v[0]));
    return atan2(cr, dot) * 180.0 / 3.14159265358979323846;
}

static int exact_parallel(const struct vcase *c, const struct lout *o, unsigned i)
{
    /* t_mask = o->t (integers), t_ref[k] = p_k / q_k: cross products vanish, dot > 0 */
    i128 a[3], dotsgn = 0;
    int any = 0;
    for (unsigned k = 0; k < c->dim; k++) {
        a[k] = o->t[k];
        any |= a[k] != 0 || c->tan[i][k].p != 0;
    }
    if (!any) return 1;
    for (unsigned j = 0; j < c->dim; j++)
        for (unsigned k = j + 1; k < c->dim; k++)
            if (a[j] * c->tan[i][k].p * c->tan[i][j].q != a[k] * c->tan[i][j].p * c->tan[i][k].q)
                return 0;
    for (unsigned k = 0; k < c->dim; k++)
        dotsgn += (a[k] > 0 ? 1 : a[k] < 0 ? -1 : 0) * (c->tan[i][k].p > 0 ? 1 : c->tan[i][k].p < 0 ? -1 : 0);
    return dotsgn > 0;
}

static unsigned run_dir(const char *dir, unsigned *bad, double *worst)
{
    DIR *d = opendir(dir);
    struct dirent *e;
    unsigned checked = 0;
    static struct vcase c;
    static struct lout o[MAXPTS];
    if (!d)
        return 0;
    while ((e = readdir(d)) != NULL) {
        char path[1024];
        unsigned n, cnt, rot, ok = 0;
        if (strncmp(e->d_name, "limit_", 6) != 0 || !strstr(e->d_name, "_d0.txt"))
            continue;
        snprintf(path, sizeof path, "%s/%s", dir, e->d_name);
        if (!load_case(path, &c)) {
            th_print("unreadable vector "); th_print(path); th_print("\n");
            (*bad)++;
            continue;
        }
        n = c.nin;
        cnt = limit_stage(&c, c.in, n, o);
        /* closed: compare up to a rotation */
        for (rot = 0; rot < (c.closed ? cnt : 1u) && !ok; rot++) {
            unsigned i;
            if (cnt != c.nout)
                break;
            for (i = 0; i < cnt; i++) {
                const struct lout *oi = &o[(i + rot) % cnt];
                if (!same_point(oi, c.out[i], c.dim))
                    break;
                if (c.dec) {
                    double err = tangent_error_deg(&c, oi, i);
                    if (err > *worst) *worst = err;
                    if (!(err < 1e-4)) break;
                } else if (!oi->has_t) {
                    unsigned k, zero = 1;
                    for (k = 0; k < c.dim; k++) zero &= c.tan[i][k].p == 0;
                    if (!zero) break;
                } else if (!exact_parallel(&c, oi, i)) {
                    break;
                }
            }
            ok = i == cnt;
        }
        if (!ok) {
            th_print("limit masks disagree with "); th_print(path); th_print("\n");
            (*bad)++;
        }
        checked++;
    }
    closedir(d);
    return checked;
}

static void test_limit_points_and_tangents_match_the_independent_exact_vectors(void)
{
    unsigned bad = 0, n;
    double worst = 0;
    const char *dir = getenv("PLOTKIN_LIMIT_VECTORS");
    n = run_dir(dir ? dir : "tests/vectors/cases", &bad, &worst);
    TH_EXPECT(n >= 35);
    TH_EXPECT(run_dir("tests/vectors/exact", &bad, &worst) >= 8); /* the closed limit cases */
    TH_EXPECT_EQ(bad, 0);
    TH_EXPECT(worst < 1e-4);
}

static const unsigned combos[][4] = {
    /* scheme, degree, closed, ends */
    {0, 1, 1, 0}, {0, 2, 1, 0}, {0, 3, 1, 0}, {0, 4, 1, 0}, {0, 5, 1, 0}, {0, 6, 1, 0}, {0, 7, 1, 0},
    {1, 0, 1, 0},
    {0, 1, 0, 3}, {0, 2, 0, 3}, {0, 3, 0, 3}, {0, 4, 0, 3}, {0, 5, 0, 3}, {0, 6, 0, 3}, {0, 7, 0, 3},
    {0, 1, 0, 2}, {0, 2, 0, 2}, {0, 3, 0, 2}, {0, 4, 0, 2}, {0, 5, 0, 2}, {0, 6, 0, 2}, {0, 7, 0, 2},
    {0, 1, 0, 1}, {0, 2, 0, 1}, {0, 3, 0, 1}, {1, 0, 0, 1},
};

static int mask_ok(const struct pk_mask *m, int position)
{
    int64_t s = 0, a = 0;
    if (m->len > PK_MASK_MAXLEN || m->den <= 0)
        return 0;
    for (unsigned r = 0; r < m->len; r++) {
        int64_t w = pk_mask_w(m, r);
        s += w;
        a += w < 0 ? -w : w;
    }
    if (a > PK_MASK_ABS_SUM_MAX)
        return 0;
    return position ? s == m->den : s == 0;
}

static void test_every_scheme_and_end_rule_has_valid_masks(void)
{
    for (unsigned i = 0; i < TH_COUNT(combos); i++) {
        struct rule_view rv;
        const struct rule_view *r = &rv;
        TH_ASSERT(rule_load(combos[i][0], combos[i][1], combos[i][2], combos[i][3], &rv));
        TH_EXPECT(r->info.nend <= 4);
        TH_EXPECT(mask_ok(&r->pos_uniform, 1));
        TH_EXPECT(r->tan_uniform.len == 0 || mask_ok(&r->tan_uniform, 0));
        for (unsigned a = 0; a < r->info.nend; a++) {
            if (r->info.drop_mask & (1u << a)) continue;
            TH_EXPECT(mask_ok(&r->pos_end[a], 1));
            TH_EXPECT(r->tan_end[a].len == 0 || mask_ok(&r->tan_end[a], 0));
        }
        TH_EXPECT(r->info.min_n >= 1 && r->info.min_n <= 9);
        if (!combos[i][2]) {
            for (unsigned n = 1; n < r->info.min_n; n++) {
                unsigned found = 0;
                for (unsigned a = 0; a < n; a++) {
                    struct pk_mask p, t;
                    if (!pk_limit_small_get(combos[i][0], combos[i][1], combos[i][3], n, a, 0, &p)) continue;
                    found++;
                    TH_EXPECT(mask_ok(&p, 1));
                    TH_EXPECT(pk_limit_small_get(combos[i][0], combos[i][1], combos[i][3], n, a, 1, &t) &&
                              (t.len == 0 || mask_ok(&t, 0)));
                    /* every weight lies inside the short polygon */
                    TH_EXPECT((int)a + p.first >= 0 && (int)a + p.first + (int)p.len <= (int)n);
                }
                /* only `none` can refine a short polygon away completely (2m-D <= 0) */
                TH_EXPECT(found >= 1 || combos[i][3] == 3);
            }
        }
    }
}

static void test_combinations_that_do_not_exist_have_no_rule(void)
{
    TH_EXPECT(pk_limit_rule_get(0, 4, 0, 1) == NULL);   /* clamped only up to degree 3 */
    TH_EXPECT(pk_limit_rule_get(0, 8, 1, 0) == NULL);
    TH_EXPECT(pk_limit_rule_get(0, 0, 0, 3) == NULL);
    TH_EXPECT(pk_limit_rule_get(2, 3, 0, 3) == NULL);
    TH_EXPECT(pk_limit_rule_get(1, 5, 0, 2) != NULL);   /* DLG ignores degree and ends */
    struct pk_mask m;
    TH_EXPECT(!pk_limit_small_get(0, 3, 2, 1, 1, 0, &m)); /* slot beyond n */
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc; (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_every_scheme_and_end_rule_has_valid_masks),
        TH_CASE(test_combinations_that_do_not_exist_have_no_rule),
        TH_CASE(test_limit_points_and_tangents_match_the_independent_exact_vectors),
    };
    return th_run(cases, TH_COUNT(cases));
}
