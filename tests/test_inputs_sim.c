/*
 * test_inputs_sim.c — inputs through the real libgpiod backend on the mock
 * chip, in the simulator (host-sim/sim_machine.h): the board file's input
 * keys, input reads and edge events with polarity and failures, and the
 * motion core's hard limits, probing and homing with switch edges scripted
 * on the simulated clock or switches placed along the axes — every position
 * checked against the step pulses decoded from the chip's pin trace.
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "pk_home.h"
#include "pk_motion.h"
#include "sim_machine.h"
#include "th.h"

int th_main(int argc, char **argv);

#define TICK_HZ 1000000u

/* ------------------------------------------------------------ board file */

static int parse(struct pk_gpiod_cfg *c, const char *text, char *err, size_t n)
{
    pk_gpiod_cfg_init(c);
    return pk_gpiod_cfg_parse(c, text, err, n);
}

static void board_file_input_keys_give_the_input_wiring(void)
{
    struct pk_gpiod_cfg c;
    char err[160] = "";
    const char *text = "step 17 27 12\ndir 22 23 8\n"
                       "limit 5 6\nprobe 13\ndoor 19\nhold 20\nresume 21\nreset 16\n"
                       "limit_invert_mask 3\nbutton_invert 1\nprobe_invert 0\n"
                       "input_bias pull-up\n";
    TH_ASSERT_EQ(parse(&c, text, err, sizeof err), PK_HAL_OK);
    TH_EXPECT_EQ(c.inputs, PK_IN_ALL & ~(1u << PK_IN_LIMIT_Z) & ~(1u << PK_IN_LIMIT_A));
    TH_EXPECT_EQ(c.input[PK_IN_LIMIT_X], 5);
    TH_EXPECT_EQ(c.input[PK_IN_LIMIT_Y], 6);
    TH_EXPECT_EQ(c.input[PK_IN_PROBE], 13);
    TH_EXPECT_EQ(c.input[PK_IN_DOOR], 19);
    TH_EXPECT_EQ(c.input[PK_IN_RESET], 16);
    TH_EXPECT_EQ(c.input_invert, 3u | (1u << PK_IN_HOLD) | (1u << PK_IN_RESUME) | (1u << PK_IN_RESET));
    TH_EXPECT_EQ(c.input_bias, 1);
    TH_EXPECT_EQ(c.input_no_edges, 0);
    TH_ASSERT_EQ(parse(&c, "step 1\ndir 2\nprobe 3\ninput_edges 0\n", err, sizeof err), PK_HAL_OK);
    TH_EXPECT_EQ(c.input_no_edges, 1);
    static const struct { const char *text, *want; } bad[] = {
        { "step 1 2\ndir 3 4\nprobe 3\n", "line 3 is used twice" },
        { "step 1\ndir 2\nlimit 5 6\n", "limit input for an axis without lines" },
        { "step 1\ndir 2\nlimit 5 6 7 8 9\n", "'limit': at most 4" },
        { "step 1\ndir 2\ninput_bias up\n", "line 3: 'input_bias' is pull-up" },
        { "step 1\ndir 2\nlimit 5\nlimit_invert_mask 2\n", "input invert names an input" },
        { "step 1\ndir 2\nprobe_invert 2\n", "'probe_invert' is 0 or 1" },
        { "step 1\ndir 2\nprobe 3 4\n", "'probe' takes one value" },
    };
    for (unsigned i = 0; i < TH_COUNT(bad); i++) {
        err[0] = '\0';
        TH_EXPECT_EQ(parse(&c, bad[i].text, err, sizeof err), PK_HAL_EINVAL);
        TH_EXPECT(strstr(err, bad[i].want) != NULL);
        if (strstr(err, bad[i].want) == NULL) {
            th_print("    got: ");
            th_print(err);
            th_print("\n");
        }
    }
}

/* ---------------------------------------------------- backend on the mock */

static struct pk_sim_hw W;
static uint32_t cb_levels, cb_calls;
static uint64_t cb_tick;
static void edge_cb(void *arg, uint32_t raw, uint64_t tick)
{
    (void)arg;
    cb_levels = raw;
    cb_tick = tick;
    cb_calls++;
}

static int open_board(struct pk_gpiod_cfg *board, const char *chip, unsigned axes)
{
    char err[200];
    pk_sim_default_board(board, chip, axes);
    return pk_sim_hw_open(&W, board, TICK_HZ, 100u, NULL, err, sizeof err);
}

static void inputs_read_back_with_polarity_and_edges_reach_the_callback(void)
{
    struct pk_gpiod_cfg board;
    TH_ASSERT_EQ(open_board(&board, "pk-in-a", 2), 0);
    /* every input idle: raw levels high (active-low on pull-ups), logical 0 */
    uint32_t lv = 99;
    TH_EXPECT_EQ(pk_hal_input_read(&W.hal, &lv), PK_HAL_OK);
    TH_EXPECT_EQ(lv, 0);
    TH_EXPECT_EQ(W.hal.inputs, (1u << PK_IN_LIMIT_X) | (1u << PK_IN_LIMIT_Y) | (PK_IN_ALL & ~PK_IN_LIMITS));
    TH_EXPECT(strcmp(pk_gpiod_mock_consumer(&W.chip, 14), "plotkin") == 0);
    TH_ASSERT_EQ(pk_hal_input_watch(&W.hal, edge_cb, NULL), PK_HAL_OK);
    cb_calls = 0;
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, 500, PK_IN_PROBE, 1), 0);
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, 700, PK_IN_LIMIT_Y, 1), 0);
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, 700, PK_IN_DOOR, 1), 0);
    TH_EXPECT_EQ(pk_sim_sched_advance(&W.sched, 600), PK_SIM_RUN_FINISHED);
    TH_EXPECT_EQ(cb_calls, 1);
    TH_EXPECT_EQ(cb_tick, 500);
    TH_EXPECT_EQ(pk_hal_input_logical(&W.hal, cb_levels), 1u << PK_IN_PROBE);
    /* two lines changing at one tick: one report with both */
    TH_EXPECT_EQ(pk_sim_sched_advance(&W.sched, 1000), PK_SIM_RUN_FINISHED);
    TH_EXPECT_EQ(cb_calls, 2);
    TH_EXPECT_EQ(cb_tick, 700);
    TH_EXPECT_EQ(pk_hal_input_logical(&W.hal, cb_levels),
                 (1u << PK_IN_PROBE) | (1u << PK_IN_LIMIT_Y) | (1u << PK_IN_DOOR));
    TH_EXPECT_EQ(pk_hal_input_read(&W.hal, &lv), PK_HAL_OK);
    TH_EXPECT_EQ(lv, (1u << PK_IN_PROBE) | (1u << PK_IN_LIMIT_Y) | (1u << PK_IN_DOOR));
    TH_EXPECT_EQ(W.gpio.in_events, 3);
    /* a failing read is an error that names the input lines */
    W.chip.fail_get_errno = EIO;
    TH_EXPECT_EQ(pk_hal_input_read(&W.hal, &lv), PK_HAL_EIO);
    TH_EXPECT_EQ(lv, 0);
    TH_EXPECT(strstr(pk_hal_error_text(&W.hal), "read input lines 10,11,14,15,16,17,18") != NULL);
    W.chip.fail_get_errno = 0;
    /* a failing event read: the service says so and the simulator stops serving */
    W.chip.fail_wait_errno = EIO;
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, 1100, PK_IN_HOLD, 1), 0);
    TH_EXPECT_EQ(pk_sim_sched_advance(&W.sched, 1200), PK_SIM_RUN_FINISHED);
    TH_EXPECT(W.service_failed);
    TH_EXPECT(strstr(pk_hal_error_text(&W.hal), "take events of input lines") != NULL);
    pk_sim_hw_close(&W);
    /* without edge events the backend has no edge reports: the core polls */
    pk_sim_default_board(&board, "pk-in-b", 2);
    board.input_no_edges = 1;
    char err[200];
    TH_ASSERT_EQ(pk_sim_hw_open(&W, &board, TICK_HZ, 100u, NULL, err, sizeof err), 0);
    TH_EXPECT_EQ(pk_hal_input_watch(&W.hal, edge_cb, NULL), PK_HAL_ENOSYS);
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, 10, PK_IN_RESET, 1), 0);
    TH_EXPECT_EQ(pk_sim_sched_advance(&W.sched, 20), PK_SIM_RUN_FINISHED);
    TH_EXPECT_EQ(pk_hal_input_read(&W.hal, &lv), PK_HAL_OK);
    TH_EXPECT_EQ(lv, 1u << PK_IN_RESET);
    pk_sim_hw_close(&W);
    /* the input lines are released on close */
    TH_EXPECT(pk_gpiod_mock_consumer(&W.chip, 14) == NULL);
}

static void a_failing_input_request_is_a_clear_error_at_open(void)
{
    struct pk_gpiod_cfg board;
    struct pk_gpiod_mock fault;
    char err[200] = "";
    memset(&fault, 0, sizeof fault);
    fault.fail_request_nth = 5; /* step, dir, enable, pen, then the inputs */
    pk_sim_default_board(&board, "pk-in-c", 2);
    TH_EXPECT_EQ(pk_sim_hw_open(&W, &board, TICK_HZ, 100u, &fault, err, sizeof err), PK_HAL_EIO);
    TH_EXPECT(strstr(err, "request input lines 10,11,14") != NULL);
    TH_EXPECT_EQ(W.chip.requested, 0);
    pk_sim_hw_close(&W);
}

/* ------------------------------------------ the machine on the simulator */

static struct pk_machine M;
static struct pk_home H;
static int homing;
static int (*stop_when)(void);

static int main_fn(void *arg, uint64_t now)
{
    (void)arg;
    (void)now;
    pk_machine_poll(&M);
    if (homing)
        (void)pk_home_poll(&H);
    return stop_when() ? PK_SIM_DONE : PK_SIM_BUSY;
}

static int idle_or_alarm(void)
{
    enum pk_machine_state s = pk_machine_state(&M);
    return (s == PK_STATE_IDLE || s == PK_STATE_ALARM) && !W.sched.armed
           && pk_machine_cycle(&M, NULL, NULL) != PK_CYCLE_RUNNING
           && (!homing || pk_home_poll(&H) != PK_HOME_RUNNING);
}

static struct pk_motion_cfg mcfg(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    c.steps_per_mm_q16[0] = 80u << 16;
    c.steps_per_mm_q16[1] = 100u << 16;
    for (int i = 0; i < 2; i++) {
        c.max_rate[i] = 6000000;
        c.accel[i] = 500000;
    }
    c.junction_dev_um = 20;
    c.step_pulse_ticks = 4;
    c.dir_setup_ticks = 2;
    c.smooth.mode = PK_SMOOTH_OFF;
    return c;
}

static int sim_open(const char *chip)
{
    struct pk_gpiod_cfg board;
    if (open_board(&board, chip, 2) != 0)
        return -1;
    struct pk_motion_cfg c = mcfg();
    homing = 0;
    return pk_machine_init(&M, &c, &W.hal) == PK_MOTION_OK ? 0 : -1;
}

static int sim_run(double max_s)
{
    stop_when = idle_or_alarm;
    return pk_sim_sched_run(&W.sched, main_fn, NULL, (uint64_t)(max_s * TICK_HZ));
}

/* The pin trace decoded (the chip's own record, independent of the core). */
static void decode(struct pk_decoded *d)
{
    struct pk_decode_cfg dc;
    struct pk_timing_limits lim = PK_TIMING_DRV8825;
    pk_sim_hw_decode_cfg(&W, &lim, &dc);
    TH_EXPECT_EQ(pk_decode(&W.trace, &dc, d), 0);
}

static long decoded_before(const struct pk_decoded *d, unsigned axis, uint64_t t)
{
    long s = 0;
    for (size_t k = 0; k < d->n_ev && d->ev[k].t < t; k++)
        if (d->ev[k].axis == axis)
            s += d->ev[k].dir;
    return s;
}

static pk_steps_t pos_of(unsigned axis)
{
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    return p[axis];
}

static void move_to(pk_um_t x, pk_um_t y, pk_um_min_t f)
{
    pk_um_t p[PK_AXES] = { 0 };
    p[0] = x;
    p[1] = y;
    TH_EXPECT_EQ(pk_machine_move(&M, p, f, PK_MOVE_FEED), PK_MOTION_OK);
    TH_EXPECT_EQ(pk_machine_end(&M), PK_MOTION_OK);
}

static void a_limit_tripping_mid_move_stops_the_pins_and_reports_their_position(void)
{
    TH_ASSERT_EQ(sim_open("pk-in-hard"), 0);
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    const uint64_t T = 400000; /* 0.4 s into a 60 mm diagonal at 3000 mm/min */
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, T, PK_IN_LIMIT_Y, 1), 0);
    move_to(60000, 45000, 3000000);
    TH_ASSERT_EQ(sim_run(60.0), PK_SIM_RUN_FINISHED);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
    struct pk_decoded d;
    decode(&d);
    TH_EXPECT_EQ(d.n_viol, 0);
    TH_ASSERT(d.n_ev > 1000);
    /* no pulse at or after the switch closed; the last one within one step
     * event before it (the dominant X axis steps every 375 µs at 50 mm/s
     * along the diagonal: 0.8 * 50 mm/s * 80 steps/mm = 3200 steps/s) */
    TH_EXPECT(d.ev[d.n_ev - 1].t < T);
    TH_EXPECT(T - d.ev[d.n_ev - 1].t <= 320);
    for (unsigned a = 0; a < 2; a++) {
        TH_EXPECT_EQ(d.pos[a], pos_of(a));
        TH_EXPECT_EQ(decoded_before(&d, a, T), pos_of(a));
    }
    pk_um_t um[PK_AXES];
    pk_machine_position_um(&M, um);
    TH_EXPECT_EQ(um[0], (pk_um_t)llround((double)d.pos[0] * 1000.0 / 80.0)); /* round(steps / steps-per-µm) */
    TH_EXPECT_EQ(um[1], (pk_um_t)(d.pos[1] * 10));
    pk_decoded_free(&d);
    pk_sim_hw_close(&W);
}

static void homing_in_the_simulator_leaves_grbls_machine_position(void)
{
    TH_ASSERT_EQ(sim_open("pk-in-home"), 0);
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    /* switches at the positive ends: X 61.25 mm and Y 23.4 mm ahead */
    TH_ASSERT_EQ(pk_sim_hw_add_switch(&W, PK_IN_LIMIT_X, 0, +1, 4900), 0);
    TH_ASSERT_EQ(pk_sim_hw_add_switch(&W, PK_IN_LIMIT_Y, 1, +1, 2340), 0);
    struct pk_home_cfg hc;
    memset(&hc, 0, sizeof hc);
    hc.feed = 50000;       /* $24 = 50 mm/min */
    hc.seek = 1000000;     /* $25 = 1000 mm/min */
    hc.debounce_ms = 100;  /* $26 */
    hc.pulloff_um = 2000;  /* $27 = 2 mm */
    hc.travel_um[0] = 300000;
    hc.travel_um[1] = 200000;
    TH_ASSERT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_OK);
    homing = 1;
    TH_ASSERT_EQ(sim_run(120.0), PK_SIM_RUN_FINISHED);
    TH_ASSERT_EQ(pk_home_poll(&H), PK_HOME_DONE);
    /* Grbl: homed toward positive, the switch is machine 0, the axis ends
     * $27 short of it */
    TH_EXPECT_EQ(pos_of(0), -160);
    TH_EXPECT_EQ(pos_of(1), -200);
    struct pk_decoded d;
    decode(&d);
    TH_EXPECT_EQ(d.n_viol, 0);
    TH_EXPECT_EQ(d.pos[0], 4900 - 160);
    TH_EXPECT_EQ(d.pos[1], 2340 - 200);
    pk_decoded_free(&d);
    /* a move to machine X=-10, Y=-5 lands 10 mm and 5 mm off the switches */
    homing = 0;
    move_to(-10000, -5000, 3000000);
    TH_ASSERT_EQ(sim_run(60.0), PK_SIM_RUN_FINISHED);
    decode(&d);
    TH_EXPECT_EQ(d.pos[0], 4900 - 800);
    TH_EXPECT_EQ(d.pos[1], 2340 - 500);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    pk_decoded_free(&d);
    pk_sim_hw_close(&W);
}

static void a_probe_contact_in_the_simulator_is_recorded_at_the_pulse_position(void)
{
    TH_ASSERT_EQ(sim_open("pk-in-probe"), 0);
    const uint64_t T = 250001;
    TH_ASSERT_EQ(pk_sim_hw_input_at(&W, T, PK_IN_PROBE, 1), 0);
    pk_um_t target[PK_AXES] = { -20000, 30000 };
    TH_ASSERT_EQ(pk_machine_probe(&M, target, 600000, false), PK_MOTION_OK);
    TH_ASSERT_EQ(sim_run(60.0), PK_SIM_RUN_FINISHED);
    pk_steps_t at[PK_AXES];
    TH_EXPECT_EQ(pk_machine_cycle(&M, at, NULL), PK_CYCLE_DONE);
    struct pk_decoded d;
    decode(&d);
    for (unsigned a = 0; a < 2; a++) {
        TH_EXPECT_EQ(at[a], decoded_before(&d, a, T));
        TH_EXPECT_EQ(d.pos[a], pos_of(a));
    }
    /* it stopped past the contact but well short of the target */
    TH_EXPECT(d.pos[1] > at[1] && d.pos[1] < 3000);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    pk_decoded_free(&d);
    pk_sim_hw_close(&W);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(board_file_input_keys_give_the_input_wiring),
        TH_CASE(inputs_read_back_with_polarity_and_edges_reach_the_callback),
        TH_CASE(a_failing_input_request_is_a_clear_error_at_open),
        TH_CASE(a_limit_tripping_mid_move_stops_the_pins_and_reports_their_position),
        TH_CASE(homing_in_the_simulator_leaves_grbls_machine_position),
        TH_CASE(a_probe_contact_in_the_simulator_is_recorded_at_the_pulse_position),
    };
    return th_run(cases, TH_COUNT(cases));
}
