/*
 * sim_svg.c — the drawing of a run, streamed and thinned within a stated
 * bound (see sim_svg.h).
 */
#include <errno.h>
#include <math.h>
#include <string.h>
#include "sim_svg.h"

#define PI_D 3.14159265358979323846
#define ELEM_POINTS 2000u /* points per <path> element, to keep lines short */

static void stream_init(struct pk_svg_stream *st, double eps)
{
    memset(st, 0, sizeof *st);
    st->eps = eps;
    st->pen = -1;
}

/* class names: programmed / executed, stroke / travel */
static const char *elem_class(const struct pk_svg_stream *st, const struct pk_svg *s, int pen)
{
    if (st == &s->prog)
        return pen ? "ps" : "pt";
    return pen ? "es" : "et";
}

static void emit_vertex(struct pk_svg *s, struct pk_svg_stream *st, const double q[2])
{
    if (!st->open) {
        /* the dash pattern is scaled by the style sheet; the attribute marks a travel */
        fprintf(st->f[st->pen > 0], "<path class=\"%s\"%s d=\"M%.3f %.3f", elem_class(st, s, st->pen),
                st->pen ? "" : " stroke-dasharray=\"1 1\"", q[0] / 1000.0 + 0.0, -q[1] / 1000.0 + 0.0);
        st->open = 1;
        st->in_elem = 1;
    } else {
        fprintf(st->f[st->pen > 0], " L%.3f %.3f", q[0] / 1000.0 + 0.0, -q[1] / 1000.0 + 0.0);
        st->in_elem++;
    }
    st->points_out++;
    if (st->in_elem >= ELEM_POINTS) {
        fputs("\"/>\n", st->f[st->pen > 0]);
        st->open = 0;
        fprintf(st->f[st->pen > 0], "<path class=\"%s\"%s d=\"M%.3f %.3f", elem_class(st, s, st->pen),
                st->pen ? "" : " stroke-dasharray=\"1 1\"", q[0] / 1000.0 + 0.0, -q[1] / 1000.0 + 0.0);
        st->open = 1;
        st->in_elem = 1;
    }
}

static void cone_reset(struct pk_svg_stream *st)
{
    st->have_l = 0;
    st->have_ref = 0;
    st->rmax = 0.0;
}

/* Keep the last accepted point as a vertex and start a new run from it. */
static void cut(struct pk_svg *s, struct pk_svg_stream *st)
{
    if (st->have_l) {
        emit_vertex(s, st, st->l);
        st->s[0] = st->l[0];
        st->s[1] = st->l[1];
    }
    cone_reset(st);
}

/*
 * The cone simplifier. From the last kept point S, a run of points can be
 * replaced by the segment from S to its last point E as long as every point
 * of the run is within eps of that segment. A point P at distance r > eps
 * from S allows the directions within asin(eps / r) of its own; the run goes
 * on while the direction of each new point lies in the intersection of the
 * earlier points' allowances and the distance from S never decreases (so
 * every point projects inside the segment).
 */
static void simplify_add(struct pk_svg *s, struct pk_svg_stream *st, const double p[2])
{
    st->points_in++;
    if (!st->have_s) {
        st->s[0] = p[0];
        st->s[1] = p[1];
        st->have_s = 1;
        emit_vertex(s, st, p);
        cone_reset(st);
        return;
    }
    for (int pass = 0; pass < 2; pass++) {
        double dx = p[0] - st->s[0], dy = p[1] - st->s[1], r = hypot(dx, dy);
        if (st->have_l && r < st->rmax) {
            cut(s, st);
            continue;
        }
        if (r <= st->eps) {
            st->l[0] = p[0];
            st->l[1] = p[1];
            st->have_l = 1;
            return;
        }
        double th = atan2(dy, dx), half = asin(st->eps / r);
        if (!st->have_ref) {
            st->ref = th;
            st->lo = -half;
            st->hi = half;
        } else {
            double d = th - st->ref;
            while (d > PI_D)
                d -= 2.0 * PI_D;
            while (d <= -PI_D)
                d += 2.0 * PI_D;
            if (d < st->lo || d > st->hi) {
                cut(s, st);
                continue;
            }
            if (d - half > st->lo)
                st->lo = d - half;
            if (d + half < st->hi)
                st->hi = d + half;
        }
        st->have_ref = 1;
        st->l[0] = p[0];
        st->l[1] = p[1];
        st->have_l = 1;
        st->rmax = r;
        return;
    }
    /* a second cut right after the first cannot happen (the run is empty);
     * keep the point as a vertex all the same */
    emit_vertex(s, st, p);
    st->s[0] = p[0];
    st->s[1] = p[1];
    cone_reset(st);
}

static void close_elem(struct pk_svg_stream *st)
{
    if (st->open)
        fputs("\"/>\n", st->f[st->pen > 0]);
    st->open = 0;
}

/* A pen change or a jump: finish the element at the last point. */
static void restart_at(struct pk_svg *s, struct pk_svg_stream *st, int pen)
{
    double last[2] = { 0, 0 };
    int had = st->have_s;
    if (st->have_l) {
        last[0] = st->l[0];
        last[1] = st->l[1];
    } else if (had) {
        last[0] = st->s[0];
        last[1] = st->s[1];
    }
    cut(s, st);
    close_elem(st);
    st->pen = pen;
    st->have_s = 0;
    if (had)
        simplify_add(s, st, last);
}

static void bbox(struct pk_svg *s, const double p[2])
{
    for (int i = 0; i < 2; i++) {
        if (p[i] < s->lo[i])
            s->lo[i] = p[i];
        if (p[i] > s->hi[i])
            s->hi[i] = p[i];
    }
}

static void stream_point(struct pk_svg *s, struct pk_svg_stream *st, const double p[2], int pen)
{
    bbox(s, p);
    if (pen != st->pen)
        restart_at(s, st, pen);
    simplify_add(s, st, p);
}

int pk_svg_open(struct pk_svg *s, double eps_um)
{
    memset(s, 0, sizeof *s);
    s->eps_um = eps_um > 0.0 ? eps_um : 20.0;
    stream_init(&s->prog, s->eps_um / 2.0);
    stream_init(&s->exec, s->eps_um);
    s->lo[0] = s->lo[1] = INFINITY;
    s->hi[0] = s->hi[1] = -INFINITY;
    int ok = 1;
    for (int i = 0; i < 2; i++) {
        s->prog.f[i] = tmpfile();
        s->exec.f[i] = tmpfile();
        ok = ok && s->prog.f[i] != NULL && s->exec.f[i] != NULL;
    }
    if (!ok) {
        pk_svg_discard(s);
        return -1;
    }
    return 0;
}

void pk_svg_prim(struct pk_svg *s, const struct pk_path_prim *p)
{
    struct pk_svg_stream *st = &s->prog;
    double a[2] = { p->p0[0], p->p0[1] };
    int jump = 1;
    if (st->have_l)
        jump = st->l[0] != a[0] || st->l[1] != a[1];
    else if (st->have_s)
        jump = st->s[0] != a[0] || st->s[1] != a[1];
    if (jump) {
        /* not where the stream is: a new element from the primitive's start */
        cut(s, st);
        close_elem(st);
        st->have_s = 0;
        st->pen = p->drawn;
        stream_point(s, st, a, p->drawn);
    } else if (p->drawn != st->pen) {
        restart_at(s, st, p->drawn);
    }
    /* chords within eps/2 of the curve, then the simplifier's eps/2 */
    unsigned n = pk_path_prim_flatten_n(p, s->eps_um / 2.0);
    for (unsigned i = 1; i <= n; i++) {
        double q[3];
        if (i == n && p->kind != PK_PATH_ARC)
            memcpy(q, p->p1, sizeof q);
        else
            pk_path_prim_eval(p, (double)i / n, q);
        stream_point(s, st, q, p->drawn);
    }
}

void pk_svg_exec_point(struct pk_svg *s, const double xy_um[2], int drawn)
{
    stream_point(s, &s->exec, xy_um, drawn != 0);
}

static int copy_body(FILE *out, FILE *in)
{
    char buf[65536];
    size_t n;
    if (fflush(in) != 0 || fseek(in, 0, SEEK_SET) != 0)
        return -1;
    while ((n = fread(buf, 1, sizeof buf, in)) > 0)
        if (fwrite(buf, 1, n, out) != n)
            return -1;
    return ferror(in) ? -1 : 0;
}

static void finish_stream(struct pk_svg *s, struct pk_svg_stream *st)
{
    cut(s, st);
    close_elem(st);
}

int pk_svg_close(struct pk_svg *s, const char *path, const char *title)
{
    finish_stream(s, &s->prog);
    finish_stream(s, &s->exec);
    if (ferror(s->prog.f[0]) || ferror(s->prog.f[1]) || ferror(s->exec.f[0]) || ferror(s->exec.f[1])) {
        pk_svg_discard(s);
        errno = EIO;
        return -1;
    }
    double x0 = s->lo[0] / 1000.0, y0 = s->lo[1] / 1000.0, x1 = s->hi[0] / 1000.0, y1 = s->hi[1] / 1000.0;
    if (!(x1 >= x0 && y1 >= y0)) {
        x0 = y0 = 0.0;
        x1 = y1 = 10.0;
    }
    double m = 0.05 * fmax(x1 - x0, y1 - y0) + 2.0;
    double w = x1 - x0 + 2 * m, h = y1 - y0 + 2 * m;
    double sw = fmax(w, h) / 400.0; /* stroke width scale */
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        int e = errno;
        pk_svg_discard(s);
        errno = e;
        return -1;
    }
    fprintf(f, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0fmm\" height=\"%.0fmm\" "
               "viewBox=\"%.3f %.3f %.3f %.3f\">\n",
            fmin(w, 300.0), fmin(w, 300.0) * (h + 3 * sw * 6) / w, x0 - m, -(y1 + m), w, h + 3 * sw * 6);
    fprintf(f, "<title>%s</title>\n", title);
    fprintf(f, "<desc>programmed path (light; travels dashed) and the executed path decoded from the "
               "step pulses (dark; travels dotted); each drawn within %.4f mm of the path it shows</desc>\n",
            s->eps_um / 1000.0);
    fprintf(f, "<style>\npath { fill: none; stroke-linecap: round; stroke-linejoin: round; }\n"
               ".ps { stroke: #8ab4f8; stroke-width: %.4f; }\n"
               ".pt { stroke: #aecbfa; stroke-width: %.4f; stroke-dasharray: %.4f %.4f; }\n"
               ".es { stroke: #202124; stroke-width: %.4f; }\n"
               ".et { stroke: #9aa0a6; stroke-width: %.4f; stroke-dasharray: %.4f %.4f; }\n</style>\n",
            3 * sw, 2 * sw, 4 * sw, 3 * sw, sw, sw, sw, 1.5 * sw);
    fprintf(f, "<rect x=\"%.3f\" y=\"%.3f\" width=\"%.3f\" height=\"%.3f\" fill=\"white\"/>\n", x0 - m,
            -(y1 + m), w, h + 3 * sw * 6);
    fputs("<g id=\"programmed\">\n", f);
    int rc = copy_body(f, s->prog.f[0]);
    if (rc == 0)
        rc = copy_body(f, s->prog.f[1]);
    fputs("</g>\n<g id=\"executed\">\n", f);
    if (rc == 0)
        rc = copy_body(f, s->exec.f[0]);
    if (rc == 0)
        rc = copy_body(f, s->exec.f[1]);
    fputs("</g>\n", f);
    fprintf(f, "<text x=\"%.3f\" y=\"%.3f\" font-family=\"sans-serif\" font-size=\"%.3f\" fill=\"#5f6368\">"
               "%s: programmed (light) vs executed from decoded steps (dark); travels dashed</text>\n",
            x0 - m + sw * 4, -(y0 - m) + sw * 12, sw * 8, title);
    fputs("</svg>\n", f);
    int e = 0;
    if (rc != 0 || ferror(f))
        e = EIO;
    if (fclose(f) != 0 && e == 0)
        e = errno;
    pk_svg_discard(s);
    if (e != 0) {
        errno = e;
        return -1;
    }
    return 0;
}

void pk_svg_discard(struct pk_svg *s)
{
    for (int i = 0; i < 2; i++) {
        if (s->prog.f[i] != NULL)
            fclose(s->prog.f[i]);
        if (s->exec.f[i] != NULL)
            fclose(s->exec.f[i]);
        s->prog.f[i] = s->exec.f[i] = NULL;
    }
}
