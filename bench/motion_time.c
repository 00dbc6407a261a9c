/*
 * motion_time.c — how much smoothing buys in motion time, and what it costs
 * in path deviation (prints a table; not a test).
 *
 * Paths: a circle of radius 20 mm as 200 segments (and, coarser, as 40
 * segments, where the corners start to limit the speed), and a text-like path
 * (letters with sharp corners, small round bowls and an S curve) drawn as one
 * pen-down program. Each runs on the real motion core and the recording HAL
 * (80 steps/mm, 1 MHz timer, 1000 mm/s^2, junction deviation 0.01 mm, feed
 * 3000 and 12000 mm/min, max rate 24000 mm/min) with smoothing off (G61) and
 * with tolerance 0.01 and 0.05 mm (G64 P0.01, P0.05); motion time is the tick
 * of the last step edge. "ideal" is a perfect trapezoid (accelerate at
 * 1000 mm/s^2, cruise at the feed, decelerate) over the polyline's length, as
 * if the path had no corners and no curvature at all. Deviation is the
 * Hausdorff distance between the executed polyline (the stroke assembler's
 * points, replayed with the machine's junction model, and checked to be the
 * machine's segments: a mismatch fails the bench) and the programmed polyline.
 *
 * Reading it: a tolerance equal to the junction deviation buys nothing (a
 * corner rounded within T by an arc allows the speed Grbl's junction model
 * gives that corner with delta = T, so the tolerance mode keeps it sharp);
 * the 40-segment circle at F12000 with T = 0.05 mm does.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "motion_run.h"

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

#define MAXP 200000
static uint32_t FEED = 3000000u; /* µm/min */
#define ACC 1000000u  /* µm/s^2 */
#define SHARP 60

struct poly {
    size_t n;
    double (*p)[2];
};

static void add(struct poly *q, double x, double y)
{
    if (q->n < MAXP) {
        q->p[q->n][0] = x;
        q->p[q->n][1] = y;
        q->n++;
    }
}

static double seg_dist(const double *a, const double *b, const double *p)
{
    double dx = b[0] - a[0], dy = b[1] - a[1], L = dx * dx + dy * dy;
    double t = L > 0 ? ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / L : 0;
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return hypot(a[0] + t * dx - p[0], a[1] + t * dy - p[1]);
}

static double one_sided(const struct poly *a, const struct poly *b)
{
    double *fa = malloc(sizeof(double) * (a->n + 1)), *fb = malloc(sizeof(double) * (b->n + 1));
    const struct poly *q[2] = { a, b };
    double *f[2] = { fa, fb };
    for (int s = 0; s < 2; s++) {
        double L = 0;
        f[s][0] = 0;
        for (size_t i = 1; i < q[s]->n; i++) {
            L += hypot(q[s]->p[i][0] - q[s]->p[i - 1][0], q[s]->p[i][1] - q[s]->p[i - 1][1]);
            f[s][i] = L;
        }
        for (size_t i = 0; i < q[s]->n; i++)
            f[s][i] = L > 0 ? f[s][i] / L : 0;
    }
    double worst = 0;
    size_t lo = 0;
    for (size_t i = 0; i < a->n; i++) {
        while (lo + 1 < b->n && fb[lo + 1] < fa[i] - 0.02)
            lo++;
        double best = 1e300;
        for (size_t j = lo; j + 1 < b->n && fb[j] <= fa[i] + 0.02; j++) {
            double d = seg_dist(b->p[j], b->p[j + 1], a->p[i]);
            if (d < best)
                best = d;
        }
        if (best > worst && best < 1e300)
            worst = best;
    }
    free(fa);
    free(fb);
    return worst;
}

/* The deviation is measured against the programmed polyline itself (the
 * tolerance mode's promise: within T of it). */
static void reference(const struct poly *in, struct poly *ref)
{
    ref->n = 0;
    for (size_t i = 0; i < in->n; i++)
        add(ref, in->p[i][0], in->p[i][1]);
}

static void circle(struct poly *q, int nseg)
{
    q->n = 0;
    for (int k = 0; k <= nseg; k++) {
        double a = M_PI + 2 * M_PI * k / nseg;
        add(q, lround(20000 + 20000 * cos(a)), lround(20000 * sin(a)));
    }
}

static void text(struct poly *q)
{
    q->n = 0;
    double x0 = 0;
    add(q, 0, 0);
    /* "N": up, diagonal down, up */
    add(q, x0, 10000);
    add(q, x0 + 6000, 0);
    add(q, x0 + 6000, 10000);
    x0 += 9000;
    /* "o": a bowl of radius 3 mm as 24 segments, entered from the top */
    add(q, x0 + 3000, 6000);
    for (int k = 1; k <= 24; k++) {
        double a = M_PI / 2 + 2 * M_PI * k / 24;
        add(q, lround(x0 + 3000 + 3000 * cos(a)), lround(3000 + 3000 * sin(a)));
    }
    x0 += 8000;
    /* "L" */
    add(q, x0, 10000);
    add(q, x0, 0);
    add(q, x0 + 5000, 0);
    x0 += 8000;
    /* "S": two half circles of radius 2.5 mm, 16 segments each */
    for (int k = 0; k <= 16; k++) {
        double a = -M_PI / 2 - M_PI * k / 16;
        add(q, lround(x0 + 2500 + 2500 * cos(a)), lround(2500 + 2500 * sin(a)) + 0);
    }
    for (int k = 1; k <= 16; k++) {
        double a = -M_PI / 2 + M_PI * k / 16;
        add(q, lround(x0 + 2500 + 2500 * cos(a + M_PI)), lround(7500 - 2500 * sin(a + M_PI)));
    }
    x0 += 8000;
    /* "W" zig-zag */
    add(q, x0, 0);
    add(q, x0 + 2000, 10000);
    add(q, x0 + 4000, 3000);
    add(q, x0 + 6000, 10000);
    add(q, x0 + 8000, 0);
}

static double length_mm(const struct poly *q)
{
    double L = 0;
    for (size_t i = 1; i < q->n; i++)
        L += hypot(q->p[i][0] - q->p[i - 1][0], q->p[i][1] - q->p[i - 1][1]);
    return L / 1000.0;
}

static double ideal_s(double L_mm)
{
    double v = FEED / 60000.0, a = ACC / 1000.0; /* mm/s, mm/s^2 */
    return L_mm >= v * v / a ? L_mm / v + v / a : 2.0 * sqrt(L_mm / a);
}

struct row {
    double t_s, dev_um;
    uint32_t segs;
};

static struct row run(const struct poly *in, uint8_t mode, pk_um_t tol_um)
{
    struct poly ref = { 0, malloc(sizeof(double[2]) * MAXP) };
    reference(in, &ref);
    static struct pk_machine m;
    struct pk_rec rec;
    pk_rec_init(&rec, 1000000);
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = 80u << 16;
        c.max_rate[i] = 24000000;
        c.accel[i] = ACC;
    }
    c.junction_dev_um = 10;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.smooth.mode = mode;
    c.smooth.degree = 3;
    c.smooth.tolerance_um = tol_um;
    c.smooth.sharp_turn_deg = SHARP;
    struct row r = { 0, 0, 0 };
    if (pk_machine_init(&m, &c, &rec.hal) != PK_MOTION_OK) {
        fprintf(stderr, "init failed\n");
        exit(1);
    }
    struct pk_mrun_op *ops = calloc(in->n, sizeof *ops);
    for (size_t i = 1; i < in->n; i++) {
        ops[i - 1].type = MR_FEED;
        ops[i - 1].p[0] = (pk_um_t)in->p[i][0];
        ops[i - 1].p[1] = (pk_um_t)in->p[i][1];
        ops[i - 1].arg = FEED;
    }
    ops[in->n - 1].type = MR_END;
    struct pk_mrun_result res = pk_mrun(&m, &rec, ops, in->n, NULL);
    if (res.timed_out)
        fprintf(stderr, "timed out\n");
    uint64_t last = 0;
    for (size_t k = 0; k < rec.n; k++)
        if (rec.ev[k].kind == PK_REC_STEP && rec.ev[k].levels)
            last = rec.ev[k].tick;
    r.t_s = (double)last / 1e6;
    r.segs = pk_machine_lines_planned(&m);
    /* executed path: the stroke assembler alone, same policy */
    static struct pk_stroke st;
    pk_stroke_init(&st, &c.smooth, 2);
    /* the machine's stroke knows the planner's junction model (it keeps a
     * vertex sharp where rounding it within the tolerance buys no speed) and
     * yields after a budget of pulls: the same here, or the replay is
     * another path than the one the machine ran (pk_motion.c setup_modules) */
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = c.axes;
    for (int i = 0; i < 2; i++) {
        lim.max_rate[i] = c.max_rate[i];
        lim.accel[i] = c.accel[i];
    }
    lim.junction_dev_um = c.junction_dev_um;
    lim.accel_min = ACC;
    struct pk_planner_dyn dyn;
    pk_planner_dyn(&lim, &dyn);
    pk_stroke_set_dyn(&st, &dyn);
    struct poly out = { 0, malloc(sizeof(double[2]) * MAXP) };
    pk_um_t p[PK_AXES] = { (pk_um_t)in->p[0][0], (pk_um_t)in->p[0][1] }, o[PK_AXES];
    add(&out, p[0], p[1]);
    pk_stroke_begin(&st, p);
    for (size_t i = 1; i < in->n; i++) {
        p[0] = (pk_um_t)in->p[i][0];
        p[1] = (pk_um_t)in->p[i][1];
        while (pk_stroke_add(&st, p, 0) == PK_EBUSY)
            while (pk_stroke_pull(&st, o) == PK_OK)
                add(&out, o[0], o[1]);
        while (pk_stroke_pull(&st, o) == PK_OK)
            add(&out, o[0], o[1]);
    }
    pk_stroke_finish(&st);
    while (pk_stroke_pull(&st, o) == PK_OK)
        add(&out, o[0], o[1]);
    r.dev_um = fmax(one_sided(&out, &ref), one_sided(&ref, &out));
    size_t moving = 0;
    for (size_t i = 1; i < out.n; i++)
        moving += lround(out.p[i][0] * 0.08) != lround(out.p[i - 1][0] * 0.08)
                  || lround(out.p[i][1] * 0.08) != lround(out.p[i - 1][1] * 0.08);
    if (moving != r.segs) {
        /* the deviation column would be that of another path: no figure */
        fprintf(stderr, "bench-motion: the stroke replay gave %zu segments, the machine planned %u: "
                "the deviation cannot be measured\n", moving, r.segs);
        exit(1);
    }
    free(out.p);
    free(ref.p);
    free(ops);
    pk_rec_free(&rec);
    return r;
}

int main(void)
{
    struct poly in = { 0, malloc(sizeof(double[2]) * MAXP) };
    printf("motion time, 80 steps/mm, accel 1000 mm/s^2, junction deviation 0.01 mm\n");
    printf("%-12s %6s %7s %9s | %-18s %9s %6s %9s\n", "path", "F", "inputs", "length", "mode", "time s",
           "segs", "dev um");
    for (int w = 0; w < 6; w++) {
        FEED = w < 3 ? 3000000u : 12000000u;
        if (w % 3 == 0)
            circle(&in, 200);
        else if (w % 3 == 1)
            circle(&in, 40);
        else
            text(&in);
        double L = length_mm(&in);
        const char *name = w % 3 == 0 ? "circle r=20" : w % 3 == 1 ? "circle r=20" : "text-like";
        struct row off = run(&in, PK_SMOOTH_OFF, 10);
        struct row tol = run(&in, PK_SMOOTH_TOLERANCE, 10);
        struct row tol5 = run(&in, PK_SMOOTH_TOLERANCE, 50);
        printf("%-12s %6u %7zu %7.2fmm | %-18s %9.3f %6u %9.2f\n", name, FEED / 1000u, in.n - 1, L,
               "off (G61)", off.t_s, off.segs, off.dev_um);
        printf("%-12s %6s %7s %9s | %-18s %9.3f %6u %9.2f\n", "", "", "", "", "tolerance 0.01mm",
               tol.t_s, tol.segs, tol.dev_um);
        printf("%-12s %6s %7s %9s | %-18s %9.3f %6u %9.2f\n", "", "", "", "", "tolerance 0.05mm",
               tol5.t_s, tol5.segs, tol5.dev_um);
        printf("%-12s %6s %7s %9s | %-18s %9.3f %6s %9s\n", "", "", "", "", "ideal trapezoid",
               ideal_s(L), "-", "-");
    }
    free(in.p);
    return 0;
}
