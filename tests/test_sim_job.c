/*
 * test_sim_job.c — what `plotkin sim`'s job (host-sim/sim_job.c) hands to the
 * programmed path: every accepted primitive exactly as programmed (lines,
 * arcs with their centre and sweep, G5/G5.1 control points), with the
 * source line it came from and its pen state, and no line read while the
 * observer has no room. The job runs the firmware's Grbl engine on the
 * recording HAL; the expected values come from the G-code text.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>
#include "th.h"
#include "hal_record.h"
#include "sim_job.h"

int th_main(int argc, char **argv);

static struct pk_rec rec;
static struct pk_machine m;
static struct pk_sim_job job;
static struct pk_sim_cfg cfg;

struct capture {
    struct pk_path_prim p[64];
    int n;
    size_t room;
};
static struct capture cap;

static void on_prim(void *arg, const struct pk_path_prim *p)
{
    struct capture *c = arg;
    if (c->n < 64)
        c->p[c->n++] = *p;
    if (c->room > 0)
        c->room--;
}
static size_t room(void *arg) { return ((struct capture *)arg)->room; }

static int start(const char *prog, size_t room0)
{
    memset(&cap, 0, sizeof cap);
    cap.room = room0;
    pk_rec_free(&rec);
    pk_rec_init(&rec, 1000000u);
    rec.record = 0;
    pk_sim_cfg_default(&cfg);
    struct pk_motion_cfg mc;
    char err[200];
    if (pk_sim_cfg_motion(&cfg, &mc, err, sizeof err) != 0)
        return -1;
    memset(&m, 0, sizeof m);
    if (pk_machine_init(&m, &mc, &rec.hal) != PK_MOTION_OK)
        return -1;
    pk_sim_job_init(&job, &m, &cfg, prog, strlen(prog));
    job.obs = (struct pk_sim_prim_obs){ on_prim, room, &cap };
    return 0;
}

/* Run up to max_ms of simulated time; 1 if the job finished. */
static int run(long max_ms)
{
    for (long i = 0; i < max_ms * 10; i++) {
        if (pk_sim_job_main(&job, rec.now) < 0)
            return 1;
        pk_rec_advance(&rec, rec.now + 100u);
    }
    return 0;
}

#define PI 3.14159265358979323846
static int near(double a, double b) { return fabs(a - b) < 1e-6; }

static void test_each_primitive_comes_exact_with_its_source_line_and_pen_state(void)
{
    static const char prog[] =
        "G21 G90\r\n"                       /* 1 (CR LF) */
        "\r\n"                              /* 2 */
        "(a comment)\n"                     /* 3 */
        "G0 X10 Y0\n"                       /* 4 */
        "M3\n"                              /* 5 */
        "G2 X30 Y0 I10 J0 F3000\n"          /* 6: half a circle, clockwise */
        "; a comment\n"                     /* 7 */
        "G3 X10 Y0 R10\n"                   /* 8: back, counter-clockwise */
        "G5 X20 Y10 I1 J1 P-1 Q1\n"         /* 9 */
        "G5.1 X30 Y0 I5 J5\n"               /* 10 */
        "G2 X30 Y0 I-5\n"                   /* 11: a full circle */
        "M5\n"                              /* 12 */
        "G0 X0\n";                          /* 13 */
    TH_ASSERT_EQ(start(prog, 1000), 0);
    TH_ASSERT(run(60000));
    TH_EXPECT_EQ(job.errors, 0);
    TH_ASSERT_EQ(cap.n, 7);
    const struct pk_path_prim *p = cap.p;
    TH_EXPECT(p[0].kind == PK_PATH_LINE && p[0].rapid && !p[0].drawn && p[0].line == 4u);
    TH_EXPECT(near(p[0].p1[0], 10000) && near(p[0].p1[1], 0));
    /* G2: centre (20, 0) mm, half a turn clockwise */
    TH_EXPECT(p[1].kind == PK_PATH_ARC && p[1].drawn && !p[1].rapid && p[1].line == 6u);
    TH_EXPECT(p[1].plane == PK_PLANE_XY && near(p[1].centre[0], 20000) && near(p[1].centre[1], 0));
    TH_EXPECT(near(p[1].sweep, -PI) && near(p[1].r0, 10000) && near(p[1].r1, 10000));
    TH_EXPECT(p[2].kind == PK_PATH_ARC && p[2].line == 8u && near(p[2].sweep, PI));
    TH_EXPECT(near(p[2].p1[0], 10000) && near(p[2].p1[1], 0));
    /* G5: start + (I, J), end + (P, Q) */
    TH_EXPECT(p[3].kind == PK_PATH_CUBIC && p[3].line == 9u && p[3].drawn);
    TH_EXPECT(near(p[3].c[0][0], 11000) && near(p[3].c[0][1], 1000));
    TH_EXPECT(near(p[3].c[1][0], 19000) && near(p[3].c[1][1], 11000));
    TH_EXPECT(p[4].kind == PK_PATH_QUAD && p[4].line == 10u);
    TH_EXPECT(near(p[4].c[0][0], 25000) && near(p[4].c[0][1], 15000));
    TH_EXPECT(p[5].kind == PK_PATH_ARC && p[5].line == 11u && near(p[5].sweep, -2.0 * PI));
    TH_EXPECT(near(p[5].centre[0], 25000) && near(p[5].centre[1], 0));
    TH_EXPECT(p[6].rapid && !p[6].drawn && p[6].line == 13u);
    pk_sim_job_free(&job);
}

static void test_no_line_is_read_while_the_observer_has_no_room(void)
{
    static const char prog[] = "G21 G90\nG0 X5\nG0 X10\nG0 X15\n";
    TH_ASSERT_EQ(start(prog, 0), 0);
    TH_EXPECT(!run(200));
    TH_EXPECT_EQ(cap.n, 0);
    TH_EXPECT(job.lines <= 1u);                     /* held before the first move */
    cap.room = 1;
    TH_EXPECT(!run(200));
    TH_EXPECT_EQ(cap.n, 1);                         /* one more line, one more primitive */
    cap.room = 100;
    TH_EXPECT(run(5000));
    TH_EXPECT_EQ(cap.n, 3);
    TH_EXPECT(near(cap.p[2].p1[0], 15000));
    pk_sim_job_free(&job);
}

/* Answers after a longer line (the greeting, a message) keep their own code. */
static void test_errors_are_listed_with_their_line_and_grbl_code(void)
{
    static const char prog[] = "G1 Z#1\nG21\nG1 X1 X2\nG1 Z1\nG4 P-1\n%\nG1 X1\n";
    TH_ASSERT_EQ(start(prog, 1000), 0);
    TH_ASSERT(run(2000));
    static const struct { unsigned line; int code; } want[] = {
        { 1, 2 }, { 3, 25 }, { 4, 22 }, { 5, 4 }, { 7, 22 },
    };
    TH_ASSERT_EQ(job.errors, TH_COUNT(want));
    for (unsigned i = 0; i < TH_COUNT(want); i++) {
        TH_EXPECT_EQ(job.err[i].line, want[i].line);
        TH_EXPECT_EQ(job.err[i].code, want[i].code);
    }
    pk_sim_job_free(&job);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_each_primitive_comes_exact_with_its_source_line_and_pen_state),
        TH_CASE(test_no_line_is_read_while_the_observer_has_no_room),
        TH_CASE(test_errors_are_listed_with_their_line_and_grbl_code),
    };
    int r = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&rec);
    return r;
}
