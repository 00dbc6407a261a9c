/*
 * test_sim_svg.c — the drawing of a run (host-sim/sim_svg.h) is thinned
 * within its stated bound: every point given lies within eps of the polyline
 * drawn for its pen state, and every point of the drawn polylines within eps
 * of the points given (both checked by brute force on the SVG read back,
 * allowing for its 3-decimal millimetres); pen changes start new elements.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "th.h"
#include "sim_svg.h"

struct poly { double *x, *y; size_t n; int pen; };

/* The executed-path elements of an SVG written by pk_svg_close. */
static size_t read_exec(const char *path, struct poly *out, size_t max)
{
    FILE *f = fopen(path, "r");
    if (f == NULL)
        return 0;
    static char line[1 << 20];
    size_t np = 0;
    while (fgets(line, sizeof line, f) != NULL && np < max) {
        int pen;
        if (strstr(line, "class=\"es\"") != NULL)
            pen = 1;
        else if (strstr(line, "class=\"et\"") != NULL)
            pen = 0;
        else
            continue;
        char *d = strstr(line, " d=\"");
        if (d == NULL)
            continue;
        d += 4;
        struct poly *p = &out[np++];
        p->n = 0;
        p->pen = pen;
        p->x = malloc(4096 * sizeof(double));
        p->y = malloc(4096 * sizeof(double));
        while (*d == 'M' || *d == 'L' || *d == ' ') {
            if (*d == ' ') {
                d++;
                continue;
            }
            char *e;
            double x = strtod(d + 1, &e), y = strtod(e, &e);
            if (p->n < 4096) {
                p->x[p->n] = x * 1000.0;
                p->y[p->n] = -y * 1000.0;
                p->n++;
            }
            d = e;
        }
    }
    fclose(f);
    return np;
}

static double seg(double ax, double ay, double bx, double by, double px, double py)
{
    double dx = bx - ax, dy = by - ay, L2 = dx * dx + dy * dy;
    double t = L2 > 0 ? ((px - ax) * dx + (py - ay) * dy) / L2 : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return hypot(ax + t * dx - px, ay + t * dy - py);
}

static double to_polys(const struct poly *ps, size_t np, int pen, double x, double y)
{
    double best = INFINITY;
    for (size_t k = 0; k < np; k++) {
        if (ps[k].pen != pen)
            continue;
        for (size_t i = 0; i + 1 < ps[k].n; i++)
            best = fmin(best, seg(ps[k].x[i], ps[k].y[i], ps[k].x[i + 1], ps[k].y[i + 1], x, y));
        if (ps[k].n == 1)
            best = fmin(best, hypot(ps[k].x[0] - x, ps[k].y[0] - y));
    }
    return best;
}

static void test_the_executed_path_is_drawn_within_the_stated_bound(void)
{
    enum { N = 3000 };
    static double px[N], py[N];
    static int pen[N];
    static struct poly polys[512];
    const double eps = 10.0; /* µm */
    struct pk_svg s;
    TH_ASSERT_EQ(pk_svg_open(&s, eps), 0);
    /* a staircase of 12.5 µm steps along a wobbly curve, pen toggling now and then */
    double x = 0, y = 0, th = 0;
    uint64_t r = 99;
    for (int i = 0; i < N; i++) {
        r = r * 6364136223846793005ull + 1442695040888963407ull;
        th += ((double)(r >> 40) / 16777216.0 - 0.5) * 0.3;
        if (i % 700 == 350)
            th += 3.0; /* a near reversal */
        double ux = cos(th), uy = sin(th);
        if (fabs(ux) > 0.38)
            x += ux > 0 ? 12.5 : -12.5;
        if (fabs(uy) > 0.38)
            y += uy > 0 ? 12.5 : -12.5;
        px[i] = x;
        py[i] = y;
        pen[i] = (i / 400) % 2 == 0;
        double q[2] = { x, y };
        pk_svg_exec_point(&s, q, pen[i]);
    }
    TH_EXPECT(s.exec.points_out < s.exec.points_in / 3u); /* it did thin */
    char path[] = "/tmp/plotkin-test-svg-XXXXXX";
    int fd = mkstemp(path);
    TH_ASSERT(fd >= 0);
    close(fd);
    TH_ASSERT_EQ(pk_svg_close(&s, path, "test"), 0);
    size_t np = read_exec(path, polys, 512);
    TH_ASSERT(np >= 8u); /* one element per pen run at least */
    const double slack = 0.7072; /* coordinates printed to 1 µm: half of it per axis */
    unsigned far_in = 0, far_out = 0;
    for (int i = 0; i < N; i++)
        if (to_polys(polys, np, pen[i], px[i], py[i]) > eps + slack)
            far_in++;
    /* every drawn point, sampled along its segments, near the points given */
    for (size_t k = 0; k < np; k++)
        for (size_t i = 0; i + 1 < polys[k].n; i++)
            for (int j = 0; j <= 8; j++) {
                double qx = polys[k].x[i] + (polys[k].x[i + 1] - polys[k].x[i]) * j / 8.0;
                double qy = polys[k].y[i] + (polys[k].y[i + 1] - polys[k].y[i]) * j / 8.0;
                double best = INFINITY;
                for (int m = 0; m + 1 < N; m++)
                    if (pen[m] == polys[k].pen || pen[m + 1] == polys[k].pen)
                        best = fmin(best, seg(px[m], py[m], px[m + 1], py[m + 1], qx, qy));
                if (best > eps + slack)
                    far_out++;
            }
    TH_EXPECT_EQ(far_in, 0);
    TH_EXPECT_EQ(far_out, 0);
    for (size_t k = 0; k < np; k++) {
        free(polys[k].x);
        free(polys[k].y);
    }
    remove(path);
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_the_executed_path_is_drawn_within_the_stated_bound),
    };
    return th_run(cases, TH_COUNT(cases));
}
