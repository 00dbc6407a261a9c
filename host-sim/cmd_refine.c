/*
 * cmd_refine.c — `plotkin refine`: the subdivision kernel on the command line.
 *
 * Reads one point per line (`x y` or `x y z`) from stdin, smooths it with the
 * very same firmware kernel, writes the result the same way. Units are decimal
 * millimetres (parsed exactly to whole micrometres, the kernel's pk_um_t), or
 * with --raw the kernel's own integers, unchanged, for bit-exact comparisons.
 * A blank line ends a stroke: each stroke is refined on its own and the output
 * strokes are separated by blank lines too. Lines starting with '#' are
 * comments. The whole input is checked before anything is written, so a bad
 * line gives an error naming it, exit status 2, and no partial output.
 */
#include <errno.h>
#include <inttypes.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "commands.h"
#include "pk_refine.h"

struct pts {
    pk_um_t (*p)[3];
    unsigned char *brk; /* 1: a stroke ends after this point */
    size_t n, cap;
};

static int pts_add(struct pts *v, const pk_um_t q[3])
{
    if (v->n == v->cap) {
        size_t cap = v->cap ? v->cap * 2 : 1024;
        void *a = realloc(v->p, cap * sizeof *v->p);
        if (!a)
            return -1;
        v->p = a;
        void *b = realloc(v->brk, cap);
        if (!b)
            return -1;
        v->brk = b;
        v->cap = cap;
    }
    memcpy(v->p[v->n], q, sizeof v->p[0]);
    v->brk[v->n] = 0;
    v->n++;
    return 0;
}

/* Parse a decimal millimetre value to whole µm, rounding half away from zero
 * at the fourth decimal. Returns 0 on success. */
static int parse_mm(const char *s, const char **end, pk_um_t *out)
{
    int neg = 0;
    int64_t ip = 0, frac = 0;
    int nd = 0, digits = 0, round_up = 0;
    if (*s == '+' || *s == '-')
        neg = *s++ == '-';
    while (*s >= '0' && *s <= '9') {
        ip = ip * 10 + (*s++ - '0');
        digits++;
        if (ip > 100000000)
            return -1;
    }
    if (*s == '.') {
        s++;
        while (*s >= '0' && *s <= '9') {
            if (nd < 3)
                frac = frac * 10 + (*s - '0');
            else if (nd == 3)
                round_up = *s >= '5';
            nd++;
            digits++;
            s++;
        }
    }
    if (digits == 0)
        return -1;
    while (nd < 3) {
        frac *= 10;
        nd++;
    }
    int64_t um = ip * 1000 + frac + round_up;
    if (um > PK_UM_MAX)
        return -2;
    *out = (pk_um_t)(neg ? -um : um);
    *end = s;
    return 0;
}

static int parse_raw(const char *s, const char **end, pk_um_t *out)
{
    char *e;
    errno = 0;
    long long v = strtoll(s, &e, 10);
    if (e == s || errno)
        return -1;
    if (v > PK_UM_MAX || v < -PK_UM_MAX)
        return -2;
    *out = (pk_um_t)v;
    *end = e;
    return 0;
}

static void print_mm(FILE *f, int64_t um)
{
    int64_t a = um < 0 ? -um : um;
    fprintf(f, "%s%" PRId64 ".%03" PRId64, um < 0 ? "-" : "", a / 1000, a % 1000);
}

static void usage(FILE *f)
{
    fputs("usage: plotkin refine [--scheme chaikin|bspline:D|dlg] [--depth K] [--closed]\n"
          "                      [--limit] [--tangents] [--ends clamped|replace|none] [--raw]\n"
          "                      [--svg OUT.svg] < points\n"
          "Reads `x y` or `x y z` per line (mm; --raw: the kernel's integer µm), writes the\n"
          "smoothed points the same way. --tangents appends the unit tangent (tx ty [tz];\n"
          "--raw: Q1.30 integers). A blank line separates strokes. Defaults: chaikin,\n"
          "depth 3, open, clamped ends.\n",
          f);
}

static void svg_poly(FILE *f, const pk_um_t (*p)[3], size_t n, const char *style, double minx,
                     double maxy, double scale)
{
    fprintf(f, "<polyline style=\"%s\" points=\"", style);
    for (size_t i = 0; i < n; i++)
        fprintf(f, "%.3f,%.3f ", (p[i][0] / 1000.0 - minx) * scale + 10,
                (maxy - p[i][1] / 1000.0) * scale + 10);
    fputs("\"/>\n", f);
}

int cmd_refine(int argc, char **argv)
{
    struct pk_refine_cfg cfg = { .scheme = PK_SCHEME_BSPLINE, .degree = 2, .depth = 3 };
    int raw = 0;
    const char *svg = NULL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        const char *v = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--scheme") && v) {
            i++;
            if (!strcmp(v, "chaikin")) {
                cfg.scheme = PK_SCHEME_BSPLINE;
                cfg.degree = 2;
            } else if (!strcmp(v, "dlg")) {
                cfg.scheme = PK_SCHEME_DLG;
            } else if (!strncmp(v, "bspline:", 8) && v[8] >= '1' && v[8] <= '7' && !v[9]) {
                cfg.scheme = PK_SCHEME_BSPLINE;
                cfg.degree = (uint8_t)(v[8] - '0');
            } else {
                fprintf(stderr, "plotkin refine: unknown scheme '%s' (chaikin, bspline:1..7, dlg)\n", v);
                return 2;
            }
        } else if (!strcmp(a, "--depth") && v) {
            i++;
            char *e;
            long d = strtol(v, &e, 10);
            if (*e || d < 0 || d > PK_MAX_DEPTH) {
                fprintf(stderr, "plotkin refine: --depth must be 0..%d\n", PK_MAX_DEPTH);
                return 2;
            }
            cfg.depth = (uint8_t)d;
        } else if (!strcmp(a, "--ends") && v) {
            i++;
            if (!strcmp(v, "clamped"))
                cfg.ends = PK_ENDS_CLAMPED;
            else if (!strcmp(v, "replace"))
                cfg.ends = PK_ENDS_REPLACE;
            else if (!strcmp(v, "none"))
                cfg.ends = PK_ENDS_NONE;
            else {
                fprintf(stderr, "plotkin refine: --ends must be clamped, replace or none\n");
                return 2;
            }
        } else if (!strcmp(a, "--closed")) {
            cfg.closed = 1;
        } else if (!strcmp(a, "--limit")) {
            cfg.limit = 1;
        } else if (!strcmp(a, "--tangents")) {
            cfg.tangents = 1;
        } else if (!strcmp(a, "--raw")) {
            raw = 1;
        } else if (!strcmp(a, "--svg") && v) {
            i++;
            svg = v;
        } else if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else {
            fprintf(stderr, "plotkin refine: unknown or incomplete option '%s'\n", a);
            usage(stderr);
            return 2;
        }
    }

    /* Read and check everything first: no partial output on bad input. */
    struct pts in = { 0 };
    char line[4096];
    unsigned long lineno = 0;
    int dims = 0, rc = 0;
    while (fgets(line, sizeof line, stdin)) {
        lineno++;
        size_t len = strlen(line);
        if (len == sizeof line - 1 && line[len - 1] != '\n') {
            fprintf(stderr, "plotkin refine: line %lu: too long\n", lineno);
            rc = 2;
            break;
        }
        const char *s = line;
        while (*s == ' ' || *s == '\t')
            s++;
        if (*s == '#')
            continue;
        if (*s == '\n' || *s == '\r' || *s == '\0') {
            if (in.n)
                in.brk[in.n - 1] = 1;
            continue;
        }
        pk_um_t q[3] = { 0, 0, 0 };
        int k = 0;
        while (*s && *s != '\n' && *s != '\r') {
            if (k == 3) {
                k = 4;
                break;
            }
            const char *e;
            int pr = raw ? parse_raw(s, &e, &q[k]) : parse_mm(s, &e, &q[k]);
            if (pr == -2) {
                fprintf(stderr, "plotkin refine: line %lu: coordinate out of range (|v| <= %s%d)\n",
                        lineno, raw ? "" : "2097.151 mm, i.e. ", PK_UM_MAX);
                rc = 2;
                break;
            }
            if (pr != 0 || (*e && *e != ' ' && *e != '\t' && *e != '\n' && *e != '\r')) {
                fprintf(stderr, "plotkin refine: line %lu: not a number: '%.40s'\n", lineno, s);
                rc = 2;
                break;
            }
            k++;
            s = e;
            while (*s == ' ' || *s == '\t')
                s++;
        }
        if (rc)
            break;
        if (k < 2 || k > 3) {
            fprintf(stderr, "plotkin refine: line %lu: expected 2 or 3 numbers (x y [z])\n", lineno);
            rc = 2;
            break;
        }
        if (dims && k != dims) {
            fprintf(stderr, "plotkin refine: line %lu: %d numbers, but earlier lines had %d\n",
                    lineno, k, dims);
            rc = 2;
            break;
        }
        dims = k;
        if (pts_add(&in, q)) {
            fprintf(stderr, "plotkin refine: out of memory\n");
            rc = 1;
            break;
        }
    }
    if (rc) {
        free(in.p);
        free(in.brk);
        return rc;
    }
    if (in.n)
        in.brk[in.n - 1] = 1;
    cfg.dims = (uint8_t)(dims ? dims : 2);
    if (cfg.dims > PK_AXES) {
        fprintf(stderr, "plotkin refine: this build has %d axes\n", PK_AXES);
        return 2;
    }

    struct pk_refine r;
    int st = pk_refine_init(&r, &cfg);
    if (st != PK_OK) {
        fprintf(stderr, "plotkin refine: %s\n",
                st == PK_ENOTSUP ? "this scheme/end rule/limit combination is not supported"
                                 : "invalid configuration");
        free(in.p);
        free(in.brk);
        return 2;
    }

    struct pts out = { 0 };
    for (size_t i = 0; i < in.n; i++) {
        pk_um_t q[PK_AXES] = { 0 };
        for (int a = 0; a < cfg.dims; a++)
            q[a] = in.p[i][a];
        if (pk_refine_push(&r, q) != PK_OK) { /* cannot happen: we always drain */
            fprintf(stderr, "plotkin refine: kernel refused point %zu\n", i + 1);
            return 1;
        }
        if (in.brk[i])
            pk_refine_finish(&r);
        /* the block pull: up to 256 points per call into our own arrays */
        pk_um_t bp[256 * PK_AXES];
        pk_q30_t bt[256 * PK_AXES];
        uint32_t got = 0;
        int pr;
        while ((pr = pk_refine_pull_block(&r, bp, cfg.tangents ? bt : NULL, 256, &got)) == PK_OK)
            for (uint32_t k = 0; k < got; k++) {
                struct pk_refine_out o = { { 0 }, { 0 } };
                for (int a = 0; a < cfg.dims; a++) {
                    o.p[a] = bp[k * cfg.dims + (uint32_t)a];
                    o.t[a] = cfg.tangents ? bt[k * cfg.dims + (uint32_t)a] : 0;
                }
                if (raw)
                    printf("%" PRId32 " %" PRId32, o.p[0], o.p[1]);
                else {
                    print_mm(stdout, o.p[0]);
                    putchar(' ');
                    print_mm(stdout, o.p[1]);
                }
                if (cfg.dims == 3) {
                    putchar(' ');
                    if (raw)
                        printf("%" PRId32, o.p[2]);
                    else
                        print_mm(stdout, o.p[2]);
                }
                if (cfg.tangents)
                    for (int a = 0; a < cfg.dims; a++) {
                        if (raw)
                            printf(" %" PRId32, o.t[a]);
                        else
                            printf(" %.9f", o.t[a] / (double)PK_Q30_ONE);
                    }
                putchar('\n');
                if (svg) {
                    pk_um_t q3[3] = { o.p[0], o.p[1], cfg.dims == 3 ? o.p[2] : 0 };
                    if (pts_add(&out, q3))
                        return 1;
                }
            }
        if (pr == PK_END) {
            if (i + 1 < in.n)
                putchar('\n');
            if (svg && out.n)
                out.brk[out.n - 1] = 1;
        }
    }

    if (svg) {
        FILE *f = fopen(svg, "w");
        if (!f) {
            fprintf(stderr, "plotkin refine: cannot write %s: %s\n", svg, strerror(errno));
            return 1;
        }
        double minx = 1e9, maxx = -1e9, miny = 1e9, maxy = -1e9;
        for (size_t i = 0; i < in.n; i++) {
            double x = in.p[i][0] / 1000.0, y = in.p[i][1] / 1000.0;
            minx = x < minx ? x : minx;
            maxx = x > maxx ? x : maxx;
            miny = y < miny ? y : miny;
            maxy = y > maxy ? y : maxy;
        }
        double w = maxx - minx, h = maxy - miny, span = w > h ? w : h;
        double scale = span > 0 ? 600.0 / span : 1.0;
        fprintf(f, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\">\n"
                   "<rect width=\"100%%\" height=\"100%%\" fill=\"white\"/>\n",
                w * scale + 20, h * scale + 20);
        const char *in_style = "fill:none;stroke:#bbb;stroke-width:1.5;stroke-dasharray:4 3";
        const char *out_style = "fill:none;stroke:#000;stroke-width:1.2";
        for (int pass = 0; pass < 2; pass++) {
            const struct pts *v = pass ? &out : &in;
            size_t s0 = 0;
            for (size_t i = 0; i < v->n; i++)
                if (v->brk[i]) {
                    size_t n = i + 1 - s0;
                    if (cfg.closed && n) { /* draw the closing span too */
                        svg_poly(f, (const pk_um_t(*)[3])v->p + s0, n, pass ? out_style : in_style,
                                 minx, maxy, scale);
                        pk_um_t seg[2][3];
                        memcpy(seg[0], v->p[i], sizeof seg[0]);
                        memcpy(seg[1], v->p[s0], sizeof seg[1]);
                        svg_poly(f, (const pk_um_t(*)[3])seg, 2, pass ? out_style : in_style, minx,
                                 maxy, scale);
                    } else {
                        svg_poly(f, (const pk_um_t(*)[3])v->p + s0, n, pass ? out_style : in_style,
                                 minx, maxy, scale);
                    }
                    s0 = i + 1;
                }
        }
        fputs("</svg>\n", f);
        fclose(f);
    }
    free(in.p);
    free(in.brk);
    free(out.p);
    free(out.brk);
    return 0;
}
