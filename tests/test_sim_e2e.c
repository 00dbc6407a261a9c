/*
 * test_sim_e2e.c — the whole firmware in the simulator, end to end: G-code
 * in (parser, kernel, planner, step generator, gpiod backend on the libgpiod
 * mock), decoded pin trace out. Also the fault paths through the mock, two
 * machines in one process, and the real-time board loop on a mock chip.
 *
 * References are independent of the code under test: targets are rounded to
 * steps here (round(mm * steps/mm)), circles are checked against the true
 * circle, squares against their edges.
 */
#define _GNU_SOURCE 1 /* open_memstream */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "posix/pk_posix_timer.h"
#include "sim_run.h"

static const struct pk_timing_limits drv8825 = PK_TIMING_DRV8825;

/* A 40 mm square (sharp corners), then a circle r = 20 mm as 200 segments,
 * then a move to an off-grid point: 3 strokes, pen up between them. */
static char *program(double end_x, double end_y)
{
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    fprintf(f, "G21 G90 G64 P0.02\nG0 X10 Y10\nM3\nG1 X50 Y10 F4000\nG1 X50 Y50\nG1 X10 Y50\nG1 X10 Y10\nM5\n");
    fprintf(f, "G0 X120 Y60\nM3\n");
    for (int i = 1; i <= 200; i++) {
        double t = 2 * M_PI * i / 200;
        fprintf(f, "G1 X%.3f Y%.3f F3000\n", 100 + 20 * cos(t), 60 + 20 * sin(t));
    }
    fprintf(f, "M5\nG0 X%.3f Y%.3f\nM2\n", end_x, end_y);
    fclose(f);
    return buf;
}

static void opts_for(struct pk_sim_opts *o, const char *chip, const struct pk_sim_cfg *cfg, const char *prog)
{
    memset(o, 0, sizeof *o);
    o->chip = chip;
    o->cfg = cfg;
    o->program = prog;
    o->len = strlen(prog);
    o->lim = drv8825;
    o->keep_trace = 1;  /* these tests read every edge and every step */
    o->keep_events = 1;
}

static int64_t round_steps(double mm, double spmm)
{
    return (int64_t)llround(mm * spmm);
}

static char *csv(const struct pk_sim_result *r, size_t *n)
{
    char *b = NULL;
    FILE *f = open_memstream(&b, n);
    pk_trace_write_csv(&r->hw.trace, f, 1);
    fclose(f);
    return b;
}

static void test_gcode_in_decoded_trace_out_ends_exactly_on_target(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    cfg.steps_per_mm[0] = 80.0;
    cfg.steps_per_mm[1] = 53.3; /* not a power of two, not an integer ratio */
    char *prog = program(33.3337, 21.0101);
    opts_for(&o, "e2e-exact", &cfg, prog);
    TH_ASSERT_EQ(pk_sim_run(&o, &r), 0);
    TH_EXPECT_EQ(r.run_status, PK_SIM_RUN_FINISHED);
    TH_EXPECT_EQ(r.job.errors, 0);
    TH_EXPECT_EQ(r.job.alarms, 0);
    TH_EXPECT_EQ(r.dec.n_viol, 0);
    /* final position: the pulses on the pins, and the firmware's own count */
    TH_EXPECT_EQ(r.dec.pos[0], round_steps(33.334, 80.0)); /* G-code to the µm: 33.334 */
    TH_EXPECT_EQ(r.dec.pos[1], round_steps(21.010, 53.3));
    TH_EXPECT_EQ(r.fw_steps[0], r.dec.pos[0]);
    TH_EXPECT_EQ(r.fw_steps[1], r.dec.pos[1]);
    TH_EXPECT_EQ(r.dec.pos[2], 0);
    pk_sim_result_free(&r);
    free(prog);
}

static void test_the_decoded_path_stays_within_half_a_step_plus_the_tolerance(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    char *prog = program(0, 0);
    opts_for(&o, "e2e-path", &cfg, prog);
    TH_ASSERT_EQ(pk_sim_run(&o, &r), 0);
    const double step_um = 1000.0 / 80.0, tol_um = 20.0;
    /* Intended path: the square's edges and the true circle. The 200-gon
     * itself lies within R(1 - cos(pi/200)) = 2.5 µm of the circle and its
     * cubic limit curve within R(1 - cos(2 pi/200))/3 = 3.3 µm. A decoded
     * position is off by at most half a step per axis: 0.5 * sqrt(2) steps. */
    const double poly_um = 20000.0 * (1 - cos(M_PI / 200)) + 20000.0 * (1 - cos(2 * M_PI / 200)) / 3;
    const double bound = tol_um + 0.5 * M_SQRT2 * step_um + poly_um;
    double worst_sq = 0, worst_circ = 0;
    int64_t p[PK_HAL_MAX_AXES] = { 0 };
    size_t drawn = 0;
    for (size_t i = 0; i < r.dec.n_ev; i++) {
        p[r.dec.ev[i].axis] += r.dec.ev[i].dir;
        if (i + 1 < r.dec.n_ev && r.dec.ev[i + 1].t == r.dec.ev[i].t)
            continue; /* several axes stepping on one tick: one diagonal step */
        if (!r.dec.ev[i].pen)
            continue; /* pen-up travel: no intended path */
        drawn++;
        double x = p[0] * step_um, y = p[1] * step_um;
        if (x < 75000) { /* the square 10..50 */
            double dx = fmin(fabs(x - 10000), fabs(x - 50000)), dy = fmin(fabs(y - 10000), fabs(y - 50000));
            double d = fmin(dx, dy);
            if (d > worst_sq)
                worst_sq = d;
        } else {
            double d = fabs(hypot(x - 100000, y - 60000) - 20000);
            if (d > worst_circ)
                worst_circ = d;
        }
    }
    TH_EXPECT(drawn > 10000u);
    TH_EXPECT(worst_sq <= 0.5 * M_SQRT2 * step_um); /* sharp corners: no smoothing */
    TH_EXPECT(worst_circ <= bound);
    if (getenv("PK_VERBOSE") || worst_circ > bound || worst_sq > 0.5 * M_SQRT2 * step_um) {
        printf("    square %.2f um, circle %.2f um (bound %.2f)\n", worst_sq, worst_circ, bound);
    }
    pk_sim_result_free(&r);
    free(prog);
}

static void test_with_smoothing_off_the_decoded_path_follows_the_polyline(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    cfg.smooth_mode = PK_SMOOTH_OFF;
    cfg.force_smoothing = 1; /* ignore the program's G64 */
    char *prog = program(0, 0);
    opts_for(&o, "e2e-exact-path", &cfg, prog);
    TH_ASSERT_EQ(pk_sim_run(&o, &r), 0);
    /* Reference: the commanded polyline (every move). Bound: the ends of
     * each move are rounded to steps (0.5 step per axis: 0.5 * sqrt(2)) and
     * the minor axis of a Bresenham line trails by at most half a step. */
    const double step_um = 1000.0 / 80.0, bound = (0.5 * M_SQRT2 + 0.5) * step_um;
    TH_EXPECT(r.deviation_um >= 0.0 && r.deviation_um <= bound);
    if (getenv("PK_VERBOSE") || r.deviation_um > bound)
        printf("    exact path: %.2f um (bound %.2f)\n", r.deviation_um, bound);
    TH_EXPECT_EQ(r.dec.n_viol, 0);
    pk_sim_result_free(&r);
    free(prog);
}

static void test_two_runs_give_byte_identical_traces(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result a, b;
    struct pk_sim_opts o;
    size_t na, nb;
    pk_sim_cfg_default(&cfg);
    char *prog = program(5, 5);
    opts_for(&o, "e2e-det", &cfg, prog);
    TH_ASSERT_EQ(pk_sim_run(&o, &a), 0);
    char *ta = csv(&a, &na);
    pk_sim_result_free(&a);
    TH_ASSERT_EQ(pk_sim_run(&o, &b), 0);
    char *tb = csv(&b, &nb);
    pk_sim_result_free(&b);
    TH_EXPECT(na > 100000u);
    TH_EXPECT(na == nb && memcmp(ta, tb, na) == 0);
    free(ta);
    free(tb);
    free(prog);
}

static void test_a_failing_line_request_is_a_clear_error_at_start(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    static struct pk_gpiod_mock fault;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    memset(&fault, 0, sizeof fault);
    fault.fail_request_nth = 2; /* the direction lines are taken by someone else */
    opts_for(&o, "e2e-req", &cfg, "G0 X10\n");
    o.fault = &fault;
    TH_EXPECT_EQ(pk_sim_run(&o, &r), -1);
    TH_EXPECT_EQ(r.setup_failed, 1);
    TH_EXPECT(strstr(r.err, "gpiod: request dir lines 4,5,6 on e2e-req") != NULL);
    TH_EXPECT(strstr(r.err, strerror(EBUSY)) != NULL);
    TH_EXPECT_EQ(r.hw.chip.requested, 0); /* nothing left half-requested */
    TH_EXPECT_EQ(r.hw.trace.n, 3);        /* only the step lines were ever driven */
    pk_sim_result_free(&r);
}

static void test_a_failing_write_during_motion_stops_with_an_alarm_and_no_more_pulses(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    static struct pk_gpiod_mock fault;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    memset(&fault, 0, sizeof fault);
    char *prog = program(0, 0);
    for (uint32_t nth = 3001; nth <= 3002; nth++) { /* a raise and a lowering */
        fault.fail_set_nth = nth;
        fault.fail_set_sticky = 0; /* the line would work again: the firmware must not retry */
        opts_for(&o, "e2e-set", &cfg, prog);
        o.fault = &fault;
        TH_ASSERT_EQ(pk_sim_run(&o, &r), 0);
        TH_EXPECT_EQ(r.job.alarms, 1);
        TH_EXPECT(r.job.alarm == PK_ALARM_STEP_WRITE || r.job.alarm == PK_ALARM_DIR_WRITE);
        TH_EXPECT(strstr(r.job.alarm_text, "gpiod: set ") != NULL);
        TH_EXPECT(strstr(r.job.alarm_text, strerror(EIO)) != NULL);
        TH_EXPECT_EQ(r.hw.chip.set_failures, 1);
        TH_EXPECT_EQ(pk_machine_state(&r.m), PK_STATE_ALARM);
        /* no pulse after the failure */
        uint64_t t_fail = r.hw.chip.first_failure_tick;
        size_t late = 0;
        for (size_t i = 0; i < r.hw.trace.n; i++)
            late += r.hw.trace.e[i].kind == PK_SIG_STEP && r.hw.trace.e[i].t > t_fail;
        TH_EXPECT_EQ(late, 0);
        for (size_t i = 0; i < r.dec.n_ev; i++)
            TH_EXPECT(r.dec.ev[i].t <= t_fail);
        /* the position reported is what the pins actually did */
        for (int a = 0; a < 3; a++)
            TH_EXPECT_EQ(r.fw_steps[a], r.dec.pos[a]);
        TH_EXPECT(r.dec.steps[0] + r.dec.steps[1] > 500u);
        TH_EXPECT(r.dec.steps[0] + r.dec.steps[1] < 20000u); /* stopped long before the end */
        pk_sim_result_free(&r);
    }
    free(prog);
}

static void test_bad_gcode_lines_are_counted_and_the_rest_still_runs(void)
{
    static struct pk_sim_cfg cfg;
    static struct pk_sim_result r;
    struct pk_sim_opts o;
    pk_sim_cfg_default(&cfg);
    opts_for(&o, "e2e-bad", &cfg, "G21 G90\nG1 X10 Y10 F1000\nG1 X20 Q5\nG7 X3\nG1 X12.5 Y7.25\nM2\n");
    TH_ASSERT_EQ(pk_sim_run(&o, &r), 0);
    TH_EXPECT_EQ(r.job.errors, 2);
    TH_EXPECT_EQ(r.job.err[0].line, 3);
    TH_EXPECT_EQ(r.job.err[1].line, 4);
    TH_EXPECT_EQ(r.dec.pos[0], 1000);
    TH_EXPECT_EQ(r.dec.pos[1], 580);
    TH_EXPECT_EQ(r.job.alarms, 0);
    pk_sim_result_free(&r);
}

static void test_two_machines_in_one_process_do_not_disturb_each_other(void)
{
    static struct pk_sim_cfg ca, cb;
    static struct pk_sim_result solo_a, solo_b, a, b;
    static struct pk_gpiod_mock fault;
    struct pk_sim_opts oa, ob;
    size_t n1, n2, n3, n4;
    pk_sim_cfg_default(&ca);
    pk_sim_cfg_default(&cb);
    cb.steps_per_mm[0] = 100.0;
    cb.accel[0] = 300.0;
    char *pa = program(1, 2), *pb = program(3, 4);
    opts_for(&oa, "e2e-a", &ca, pa);
    opts_for(&ob, "e2e-b", &cb, pb);
    memset(&fault, 0, sizeof fault);
    fault.fail_set_nth = 5000; /* B fails along the way; A must not notice */
    ob.fault = &fault;
    TH_ASSERT_EQ(pk_sim_run(&oa, &solo_a), 0);
    TH_ASSERT_EQ(pk_sim_run(&ob, &solo_b), 0);
    char *ta = csv(&solo_a, &n1), *tb = csv(&solo_b, &n2);
    TH_EXPECT_EQ(solo_b.job.alarms, 1);
    pk_sim_result_free(&solo_a); /* frees the chip names for the rerun */
    pk_sim_result_free(&solo_b);
    /* now both at once, interleaved 1 ms of simulated time at a time */
    TH_ASSERT_EQ(pk_sim_start(&oa, &a), 0);
    TH_ASSERT_EQ(pk_sim_start(&ob, &b), 0);
    int da = 0, db = 0;
    while (!da || !db) {
        if (!da)
            da = pk_sim_advance(&a, 1000u);
        if (!db)
            db = pk_sim_advance(&b, 1000u);
    }
    TH_ASSERT_EQ(pk_sim_finish(&a), 0);
    TH_ASSERT_EQ(pk_sim_finish(&b), 0);
    char *ia = csv(&a, &n3), *ib = csv(&b, &n4);
    TH_EXPECT(n1 == n3 && memcmp(ta, ia, n1) == 0);
    TH_EXPECT(n2 == n4 && memcmp(tb, ib, n2) == 0);
    TH_EXPECT_EQ(a.job.alarms, 0);
    TH_EXPECT_EQ(b.job.alarms, 1);
    TH_EXPECT_EQ(a.dec.pos[0], round_steps(1, 80));
    TH_EXPECT_EQ(a.dec.pos[1], round_steps(2, 80));
    free(ta);
    free(tb);
    free(ia);
    free(ib);
    pk_sim_result_free(&a);
    pk_sim_result_free(&b);
    free(pa);
    free(pb);
}

static void test_the_board_loop_runs_the_same_job_on_real_time(void)
{
    /* The board path of plotkin-gpiod: POSIX clock and loop, gpiod backend
     * (here on a mock chip stamped with the real clock), same job code. */
    static struct pk_posix_timer timer;
    static struct pk_gpiod_mock chip;
    static struct pk_gpiod gpio;
    static struct pk_machine m;
    static struct pk_sim_job job;
    static struct pk_sim_cfg cfg;
    static struct pk_trace tr;
    struct pk_gpiod_cfg board;
    struct pk_motion_cfg mc;
    struct pk_hal base, hal;
    char err[160];
    const char *prog = "G21 G90\nM3\nG1 X2 Y1.5 F1200\nG1 X0.5 Y3\nM5\nM2\n";

    pk_sim_cfg_default(&cfg);
    cfg.pen_settle_ms = 0;
    TH_ASSERT_EQ(pk_sim_cfg_motion(&cfg, &mc, err, sizeof err), 0);
    pk_posix_timer_init(&timer, cfg.tick_hz);
    pk_posix_timer_hal(&timer, &base);
    pk_sim_default_board(&board, "e2e-board", 3);
    pk_trace_init(&tr, cfg.tick_hz);
    pk_trace_map_gpiod(&tr, &board);
    pk_gpiod_mock_init(&chip, "e2e-board", 32); /* the default board has 19 lines */
    chip.clock = (pk_gpiod_mock_clock_fn)base.ops->clock_ticks;
    chip.clock_arg = &timer;
    chip.sink = pk_trace_sink;
    chip.sink_arg = &tr;
    TH_ASSERT_EQ(pk_gpiod_mock_register(&chip), 0);
    TH_ASSERT_EQ(pk_gpiod_open(&gpio, &board, &base, &hal), PK_HAL_OK);
    TH_ASSERT_EQ(pk_machine_init(&m, &mc, &hal), PK_MOTION_OK);
    pk_sim_job_init(&job, &m, &cfg, prog, strlen(prog));
    TH_EXPECT_EQ(pk_posix_run(&timer, pk_sim_job_main, &job, NULL), 0);
    pk_steps_t pos[PK_AXES];
    pk_machine_position_steps(&m, pos);
    TH_EXPECT_EQ(pos[0], 40);
    TH_EXPECT_EQ(pos[1], 240);
    struct pk_decode_cfg dc = { .tick_hz = cfg.tick_hz, .axes = 3, .enable_invert = hal.enable_invert,
                                .shared_enable = 1, .lim = { 0, 0, 0, 0 } };
    struct pk_decoded d;
    TH_ASSERT_EQ(pk_decode(&tr, &dc, &d), 0);
    TH_EXPECT_EQ(d.pos[0], 40);
    TH_EXPECT_EQ(d.pos[1], 240);
    pk_decoded_free(&d);
    pk_gpiod_close(&gpio);
    TH_EXPECT_EQ(chip.requested, 0);
    pk_gpiod_mock_unregister(&chip);
    pk_sim_job_free(&job);
    pk_trace_free(&tr);
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_gcode_in_decoded_trace_out_ends_exactly_on_target),
        TH_CASE(test_the_decoded_path_stays_within_half_a_step_plus_the_tolerance),
        TH_CASE(test_with_smoothing_off_the_decoded_path_follows_the_polyline),
        TH_CASE(test_two_runs_give_byte_identical_traces),
        TH_CASE(test_a_failing_line_request_is_a_clear_error_at_start),
        TH_CASE(test_a_failing_write_during_motion_stops_with_an_alarm_and_no_more_pulses),
        TH_CASE(test_bad_gcode_lines_are_counted_and_the_rest_still_runs),
        TH_CASE(test_two_machines_in_one_process_do_not_disturb_each_other),
        TH_CASE(test_the_board_loop_runs_the_same_job_on_real_time),
    };
    return th_run(cases, TH_COUNT(cases));
}
