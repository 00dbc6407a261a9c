/*
 * test_inputs.c — limit switches, probe and homing in the motion core, on the
 * recording HAL with scripted input edges and switches placed along the axes
 * (host-sim/hal_record.h), checked against the step pulses the HAL received:
 *
 *   - hard limits: the output stops before the first step event after the
 *     switch closes (compared with the same move run without the switch),
 *     the alarm is latched, and the position reported is the pulses emitted;
 *   - probing: the position recorded is exactly the pulses emitted before
 *     the contact; the machine then decelerates within its acceleration
 *     limit (windowed velocities from the pulse times) and drops the rest;
 *   - homing moves stop each axis exactly on the step that closed its
 *     switch; the whole cycle (pk_home.h) leaves the axes at Grbl's machine
 *     position, the same distance from the switch as the pulses say.
 *
 * Every case runs twice: with a HAL that reports edges (the core's edge
 * callback) and with one that does not (the core reads the inputs at every
 * step event): both must behave the same.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "motion_run.h"
#include "pk_home.h"
#include "th.h"

int th_main(int argc, char **argv);

#define TICK_HZ 1000000u
#define POLL_TICKS 20u

static struct pk_machine M;
static struct pk_rec R;
static int EDGES = 1;   /* the HAL of the case reports edges */

/* The inputs a typical board has: limits X Y (active-low switches to ground
 * on pull-ups, as on Grbl boards), a probe (active-high), door, buttons. */
#define BOARD_INPUTS ((1u << PK_IN_LIMIT_X) | (1u << PK_IN_LIMIT_Y) | (1u << PK_IN_PROBE) \
                      | (1u << PK_IN_DOOR) | (1u << PK_IN_HOLD) | (1u << PK_IN_RESUME) \
                      | (1u << PK_IN_RESET))
#define BOARD_INVERT ((1u << PK_IN_LIMIT_X) | (1u << PK_IN_LIMIT_Y))

static const double SPMM[2] = { 80.0, 100.0 };

static struct pk_motion_cfg cfg_default(void)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = (pk_spmm_q16_t)llround(SPMM[i] * 65536.0);
        c.max_rate[i] = 6000000;   /* 100 mm/s */
        c.accel[i] = 1000000;      /* 1000 mm/s^2 */
    }
    c.junction_dev_um = 20;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.pen_settle_ms = 0;
    c.pen_down_level = 1;
    c.smooth.mode = PK_SMOOTH_OFF;
    return c;
}

static void setup_cfg(const struct pk_motion_cfg *c)
{
    pk_rec_free(&R);
    pk_rec_init(&R, TICK_HZ);
    pk_rec_inputs(&R, BOARD_INPUTS, BOARD_INVERT, EDGES);
    TH_EXPECT_EQ(pk_machine_init(&M, c, &R.hal), PK_MOTION_OK);
}

static void setup(void)
{
    struct pk_motion_cfg c = cfg_default();
    setup_cfg(&c);
}

/* Main loop: poll, advance POLL_TICKS, until done(m) or max_s seconds. */
typedef int (*done_fn)(void);
static int run_until(done_fn done, double max_s)
{
    uint64_t end = R.now + (uint64_t)(max_s * TICK_HZ);
    while (R.now < end) {
        pk_machine_poll(&M);
        if (done())
            return 1;
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    return 0;
}

static int idle_or_alarm(void)
{
    enum pk_machine_state s = pk_machine_state(&M);
    return (s == PK_STATE_IDLE || s == PK_STATE_ALARM) && !pk_rec_armed(&R);
}

static int cycle_over(void)
{
    return pk_machine_cycle(&M, NULL, NULL) != PK_CYCLE_RUNNING && idle_or_alarm();
}

static void move_to(double x_mm, double y_mm, double f_mm_min)
{
    pk_um_t p[PK_AXES] = { 0 };
    p[0] = (pk_um_t)llround(x_mm * 1000.0);
    p[1] = (pk_um_t)llround(y_mm * 1000.0);
    TH_EXPECT_EQ(pk_machine_move(&M, p, (pk_um_min_t)llround(f_mm_min * 1000.0), PK_MOVE_FEED), PK_MOTION_OK);
    TH_EXPECT_EQ(pk_machine_end(&M), PK_MOTION_OK);
}

/* The decoded pulses of an axis: count (signed) and their ticks. */
struct pulses {
    uint64_t *t;
    int8_t *d;
    size_t n;
    long sum;
};
static struct pulses pulses_of(unsigned axis)
{
    struct pulses p;
    p.n = pk_mrun_edges(&R, axis, &p.t, &p.d);
    p.sum = 0;
    for (size_t k = 0; k < p.n; k++)
        p.sum += p.d[k];
    return p;
}
static void pulses_free(struct pulses *p)
{
    free(p->t);
    free(p->d);
}

static long decoded_sum(unsigned axis)
{
    struct pulses p = pulses_of(axis);
    long s = p.sum;
    pulses_free(&p);
    return s;
}

static pk_steps_t pos_steps(unsigned axis)
{
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&M, p);
    return p[axis];
}

/* ------------------------------------------------------------ hard limits */

/* The step ticks of the move without any switch (the reference). */
static struct pulses reference_x_move(double x_mm, double f)
{
    setup();
    move_to(x_mm, 0, f);
    TH_EXPECT(run_until(idle_or_alarm, 30.0));
    return pulses_of(0);
}

static void hard_limit_mid_move_stops_within_one_step_event(void)
{
    struct pulses ref = reference_x_move(50.0, 3000.0);
    const uint64_t T = 300000; /* 0.3 s: cruising at 50 mm/s */
    size_t before = 0;
    while (before < ref.n && ref.t[before] < T)
        before++;
    TH_ASSERT(before > 100 && before < ref.n);

    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_rec_input_at(&R, T, PK_IN_LIMIT_X, 1), 0);
    move_to(50.0, 0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 30.0));
    struct pulses got = pulses_of(0);
    /* exactly the pulses due before the switch closed, none after it */
    TH_EXPECT_EQ(got.n, before);
    for (size_t k = 0; k < got.n; k++)
        TH_EXPECT(got.t[k] == ref.t[k]);
    TH_EXPECT(got.n == 0 || got.t[got.n - 1] < T);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
    /* the reported position is the decoded pin position, in steps and µm */
    TH_EXPECT_EQ(pos_steps(0), got.sum);
    TH_EXPECT_EQ(R.pos[0], got.sum);
    pk_um_t um[PK_AXES];
    pk_machine_position_um(&M, um);
    TH_EXPECT_EQ(um[0], llround((double)got.sum * 1000.0 / SPMM[0]));
    /* the step line was left low, the timer stopped */
    TH_EXPECT_EQ(R.raw[PK_REC_STEP] & 1u, 0);
    TH_EXPECT(!pk_rec_armed(&R));
    /* nothing is accepted until a reset */
    pk_um_t p[PK_AXES] = { 0 };
    TH_EXPECT_EQ(pk_machine_move(&M, p, 1000000, PK_MOVE_FEED), PK_MOTION_EALARM);
    pulses_free(&ref);
    pulses_free(&got);
}

static void hard_limit_alarm_shows_at_once_not_at_the_next_step(void)
{
    /* a slow move (1 step per 7.5 ms): the state is ALARM right after the
     * switch closes when the HAL reports edges; without edges, by the next
     * step event */
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    const uint64_t T = 500000;
    TH_ASSERT_EQ(pk_rec_input_at(&R, T, PK_IN_LIMIT_X, 1), 0);
    move_to(10.0, 0, 100.0);
    while (R.now < T + POLL_TICKS) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    pk_machine_poll(&M);
    if (EDGES)
        TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_ASSERT(run_until(idle_or_alarm, 5.0));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    struct pulses got = pulses_of(0);
    TH_EXPECT(got.n > 0 && got.t[got.n - 1] < T);
    TH_EXPECT_EQ(pos_steps(0), got.sum);
    pulses_free(&got);
}

static void turning_hard_limits_off_after_a_trip_does_not_resume_the_steps(void)
{
    /* the switch closes at T; before the alarm is seen by a poll (with
     * edges) or a step event (without), hard limits are switched off: the
     * trip stands, no step after T */
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    const uint64_t T = 500000;
    TH_ASSERT_EQ(pk_rec_input_at(&R, T, PK_IN_LIMIT_X, 1), 0);
    move_to(10.0, 0, 100.0);
    while (R.now < T) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, false), PK_MOTION_OK);
    TH_ASSERT(run_until(idle_or_alarm, 10.0)); /* without edges the move runs on: 6 s */
    struct pulses got = pulses_of(0);
    if (EDGES) {
        TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
        TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
        TH_EXPECT(got.n > 0 && got.t[got.n - 1] < T);
    }
    TH_EXPECT_EQ(pos_steps(0), got.sum);
    pulses_free(&got);
}

static void a_switch_reached_by_the_move_stops_it_on_that_step(void)
{
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    /* X's switch closes when X reaches 20 mm (step 1600) */
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_X, 0, +1, 1600), 0);
    move_to(40.0, 10.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 30.0));
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
    struct pulses x = pulses_of(0), y = pulses_of(1);
    TH_EXPECT_EQ(x.sum, 1600);
    TH_EXPECT_EQ(pos_steps(0), 1600);
    TH_EXPECT_EQ(pos_steps(1), y.sum);
    /* Y stopped with X: it made the steps of the line up to there (Bresenham
     * from the exact start: round(1600 * (10*100) / (40*80)) = 500) */
    TH_EXPECT_EQ(y.sum, 500);
    pulses_free(&x);
    pulses_free(&y);
}

static void a_switch_closed_before_the_move_lets_no_step_out(void)
{
    setup();
    TH_ASSERT_EQ(pk_rec_input_at(&R, 0, PK_IN_LIMIT_Y, 1), 0);
    pk_rec_advance(&R, 10);
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    move_to(5.0, 5.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 5.0));
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
    struct pulses x = pulses_of(0), y = pulses_of(1);
    TH_EXPECT_EQ(x.n + y.n, 0);
    pulses_free(&x);
    pulses_free(&y);
    /* a reset leaves ALARM; the switch still closed trips the next move too,
     * before its first step */
    pk_machine_reset(&M);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    move_to(1.0, 0.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 5.0));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    x = pulses_of(0);
    TH_EXPECT_EQ(x.n, 0);
    pulses_free(&x);
    /* released, reset: moves run again */
    TH_ASSERT_EQ(pk_rec_input_at(&R, R.now + 1, PK_IN_LIMIT_Y, 0), 0);
    pk_rec_advance(&R, R.now + 10);
    pk_machine_reset(&M);
    move_to(1.0, 0.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 5.0));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    TH_EXPECT_EQ(pos_steps(0), 80);
}

static void hard_limits_off_ignore_the_switches(void)
{
    setup();
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_X, 0, +1, 800), 0);
    move_to(20.0, 0.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 10.0));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    TH_EXPECT_EQ(pos_steps(0), 1600);
    /* on again while the switch is closed (X is at 20 mm, past it): the
     * next move trips at its start */
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    move_to(25.0, 0.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 10.0));
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
    TH_EXPECT_EQ(pos_steps(0), 1600);
}

static void a_limit_closing_while_idle_raises_the_alarm(void)
{
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_rec_input_at(&R, 1000, PK_IN_LIMIT_X, 1), 0);
    for (int k = 0; k < 100; k++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_HARD_LIMIT);
}

static void hard_limits_need_a_limit_input(void)
{
    pk_rec_free(&R);
    pk_rec_init(&R, TICK_HZ);
    pk_rec_inputs(&R, 1u << PK_IN_PROBE, 0, EDGES);
    struct pk_motion_cfg c = cfg_default();
    TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
    TH_EXPECT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_ENOINPUT);
    TH_EXPECT_EQ(pk_machine_set_hard_limits(&M, false), PK_MOTION_OK);
    pk_um_t p[PK_AXES] = { 1000, 0 };
    TH_EXPECT_EQ(pk_machine_home_seek(&M, 1u, p, 100000), PK_MOTION_ENOINPUT);
    /* and no input at all: no probe either */
    pk_rec_free(&R);
    pk_rec_init(&R, TICK_HZ);
    TH_ASSERT_EQ(pk_machine_init(&M, &c, &R.hal), PK_MOTION_OK);
    TH_EXPECT_EQ(pk_machine_probe(&M, p, 100000, false), PK_MOTION_ENOINPUT);
    TH_EXPECT_EQ(pk_machine_inputs(&M), 0);
}

static void a_failing_input_read_while_watching_is_an_alarm(void)
{
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    move_to(10.0, 0.0, 3000.0);
    /* with edges only the block start reads the inputs; without, every step does */
    R.in_fail_after = EDGES ? 0 : 3;
    TH_ASSERT(run_until(idle_or_alarm, 10.0));
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_INPUT_READ);
    TH_EXPECT_EQ(pos_steps(0), decoded_sum(0));
}

/* ------------------------------------------------------------------ probe */

/* Windowed acceleration of an axis (steps/s^2) against its limit, as
 * test_motion_limits.c derives the quantisation allowance: windows of >= 8
 * steps and >= 4 ms; returns the worst measured / allowed. */
static double accel_ratio(const struct pulses *p, double a_max)
{
    double worst = 0, pv = 0, pT = 0, ptau = 0;
    int have = 0;
    size_t w0 = 0;
    for (size_t k = 1; k < p->n; k++) {
        double T = (double)(p->t[k] - p->t[w0]) / TICK_HZ;
        if (k - w0 < 8 || T < 0.004)
            continue;
        double v = (double)(k - w0) / T;
        double tau = 1e300;
        for (size_t j = w0 + 1; j <= k; j++)
            tau = fmin(tau, (double)(p->t[j] - p->t[j - 1]) / TICK_HZ);
        if (have) {
            double Tc = (pT + T) / 2.0;
            double acc = fabs(v - pv) / Tc;
            double q = (pv * ptau / pT + v * tau / T) / Tc;
            double r = acc / (a_max * 1.05 + q);
            if (r > worst)
                worst = r;
        }
        pv = v;
        pT = T;
        ptau = tau;
        have = 1;
        w0 = k;
    }
    return worst;
}

static int probe_cfg_accel_mm_s2 = 200;

static void setup_probe(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.accel[0] = c.accel[1] = (pk_um_s2_t)probe_cfg_accel_mm_s2 * 1000u;
    setup_cfg(&c);
}

static void probe_records_the_contact_exactly_then_stops_within_the_acceleration(void)
{
    setup_probe();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    /* the probe touches when X reaches 10 mm (step 800) and stays touching */
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_PROBE, 0, +1, 800), 0);
    pk_um_t target[PK_AXES] = { 30000, 0 };
    TH_ASSERT_EQ(pk_machine_probe(&M, target, 1200000, false), PK_MOTION_OK);
    TH_EXPECT_EQ(pk_machine_cycle(&M, NULL, NULL), PK_CYCLE_RUNNING);
    /* no other request while it runs */
    TH_EXPECT_EQ(pk_machine_room(&M), 0);
    TH_EXPECT_EQ(pk_machine_move(&M, target, 1000000, PK_MOVE_FEED), PK_MOTION_EFULL);
    TH_ASSERT(run_until(cycle_over, 30.0));
    pk_steps_t at[PK_AXES];
    TH_EXPECT_EQ(pk_machine_cycle(&M, at, NULL), PK_CYCLE_DONE);
    TH_EXPECT_EQ(at[0], 800);
    TH_EXPECT_EQ(at[1], 0);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    struct pulses x = pulses_of(0);
    /* it went on past the contact only to decelerate: 20 mm/s at 200 mm/s^2
     * needs 1 mm (80 steps), after what was already prepared when the
     * contact came (the hold starts after the ring: at most PK_SG_CHUNKS
     * segments of 2 ms << PK_SG_SEG_LEVELS at 20 mm/s, 80 steps/mm) */
    double prepared = PK_SG_CHUNKS * 0.002 * (double)(1u << PK_SG_SEG_LEVELS) * 20.0 * 80.0;
    if (getenv("PK_DEBUG"))
        fprintf(stderr, "probe: stopped %ld steps past the contact (bound %.0f)\n", x.sum - 800,
                80 + prepared + 4);
    TH_EXPECT(x.sum > 800 + 60 && x.sum < 800 + 80 + prepared + 4);
    TH_EXPECT_EQ(pos_steps(0), x.sum);
    TH_EXPECT(accel_ratio(&x, probe_cfg_accel_mm_s2 * SPMM[0]) <= 1.0);
    /* the last intervals are long: it came to rest, it was not cut */
    TH_ASSERT(x.n > 2);
    TH_EXPECT(x.t[x.n - 1] - x.t[x.n - 2] > 3000);
    /* the rest was dropped: the machine takes moves from where it stands */
    pk_steps_t stood = pos_steps(0);
    move_to(0.0, 0.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 30.0));
    TH_EXPECT_EQ(pos_steps(0), 0);
    struct pulses back = pulses_of(0);
    TH_EXPECT_EQ(back.n, x.n + (size_t)stood);
    pulses_free(&x);
    pulses_free(&back);
}

static void probe_contact_at_a_scripted_tick_records_the_pulses_before_it(void)
{
    setup_probe();
    const uint64_t T = 123457;
    TH_ASSERT_EQ(pk_rec_input_at(&R, T, PK_IN_PROBE, 1), 0);
    pk_um_t target[PK_AXES] = { 20000, 15000 };
    TH_ASSERT_EQ(pk_machine_probe(&M, target, 600000, false), PK_MOTION_OK);
    TH_ASSERT(run_until(cycle_over, 30.0));
    pk_steps_t at[PK_AXES];
    TH_EXPECT_EQ(pk_machine_cycle(&M, at, NULL), PK_CYCLE_DONE);
    for (unsigned a = 0; a < 2; a++) {
        struct pulses p = pulses_of(a);
        long before = 0;
        for (size_t k = 0; k < p.n && p.t[k] < T; k++)
            before += p.d[k];
        TH_EXPECT_EQ(at[a], before);
        TH_EXPECT(p.sum > before);
        TH_EXPECT_EQ(pos_steps(a), p.sum);
        pulses_free(&p);
    }
}

static void probe_missing_the_contact_says_so_at_the_end_of_the_move(void)
{
    setup_probe();
    pk_um_t target[PK_AXES] = { 5000, -2500 };
    TH_ASSERT_EQ(pk_machine_probe(&M, target, 600000, false), PK_MOTION_OK);
    TH_ASSERT(run_until(cycle_over, 30.0));
    pk_steps_t at[PK_AXES];
    TH_EXPECT_EQ(pk_machine_cycle(&M, at, NULL), PK_CYCLE_MISSED);
    TH_EXPECT_EQ(at[0], 400);
    TH_EXPECT_EQ(at[1], -250);
    TH_EXPECT_EQ(pos_steps(0), 400);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    /* the machine takes requests again */
    TH_EXPECT(pk_machine_room(&M) > 0);
}

static void probe_already_touching_is_refused_without_moving(void)
{
    setup_probe();
    TH_ASSERT_EQ(pk_rec_input_at(&R, 0, PK_IN_PROBE, 1), 0);
    pk_rec_advance(&R, 10);
    pk_um_t target[PK_AXES] = { 5000, 0 };
    TH_EXPECT_EQ(pk_machine_probe(&M, target, 600000, false), PK_MOTION_ETRIGGERED);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    TH_EXPECT(pk_machine_room(&M) > 0);
    /* probing away from it (G38.4) is what fits: it fires when contact is lost */
    TH_ASSERT_EQ(pk_rec_input_at(&R, R.now + 50000, PK_IN_PROBE, 0), 0);
    uint64_t t_loss = R.now + 50000;
    TH_ASSERT_EQ(pk_machine_probe(&M, target, 600000, true), PK_MOTION_OK);
    TH_ASSERT(run_until(cycle_over, 30.0));
    pk_steps_t at[PK_AXES];
    TH_EXPECT_EQ(pk_machine_cycle(&M, at, NULL), PK_CYCLE_DONE);
    struct pulses p = pulses_of(0);
    long before = 0;
    for (size_t k = 0; k < p.n && p.t[k] < t_loss; k++)
        before += p.d[k];
    TH_EXPECT(before > 0);
    TH_EXPECT_EQ(at[0], before);
    pulses_free(&p);
    /* and away while not touching is refused the same way */
    TH_EXPECT_EQ(pk_machine_probe(&M, target, 600000, true), PK_MOTION_ETRIGGERED);
}

static void a_reset_during_a_probe_aborts_it(void)
{
    setup_probe();
    pk_um_t target[PK_AXES] = { 50000, 0 };
    TH_ASSERT_EQ(pk_machine_probe(&M, target, 600000, false), PK_MOTION_OK);
    for (int k = 0; k < 2000; k++) {
        pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    (void)pk_machine_reset(&M);
    TH_EXPECT_EQ(pk_machine_cycle(&M, NULL, NULL), PK_CYCLE_ABORTED);
    TH_EXPECT(pk_machine_room(&M) > 0);
    pk_rec_advance(&R, R.now + 1000);
    TH_EXPECT_EQ(pos_steps(0), decoded_sum(0));
}

/* ----------------------------------------------------------------- homing */

static void homing_move_stops_each_axis_on_the_step_its_switch_closes(void)
{
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    /* X's switch at +7 mm (560 steps), Y's at +12 mm (1200 steps) */
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_X, 0, +1, 560), 0);
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_Y, 1, +1, 1200), 0);
    pk_um_t target[PK_AXES] = { 30000, 30000 };
    TH_ASSERT_EQ(pk_machine_home_seek(&M, 3u, target, 1000000), PK_MOTION_OK);
    TH_ASSERT(run_until(cycle_over, 30.0));
    uint8_t tripped = 0;
    TH_EXPECT_EQ(pk_machine_cycle(&M, NULL, &tripped), PK_CYCLE_DONE);
    TH_EXPECT_EQ(tripped, 3);
    struct pulses x = pulses_of(0), y = pulses_of(1);
    TH_EXPECT_EQ(x.sum, 560);
    TH_EXPECT_EQ(y.sum, 1200);
    TH_EXPECT_EQ(pos_steps(0), 560);
    TH_EXPECT_EQ(pos_steps(1), 1200);
    /* X stopped first and Y went on alone (its pulses after X's last one) */
    TH_ASSERT(x.n == 560 && y.n == 1200);
    size_t y_after = 0;
    for (size_t k = 0; k < y.n; k++)
        y_after += y.t[k] > x.t[x.n - 1];
    TH_EXPECT(y_after >= 499 && y_after <= 500);
    /* no hard-limit alarm although the switches closed: homing is exempt */
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    pulses_free(&x);
    pulses_free(&y);
}

static void homing_move_that_never_reaches_a_switch_is_missed(void)
{
    setup();
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_X, 0, +1, 400), 0);
    pk_um_t target[PK_AXES] = { 10000, 10000 };
    TH_ASSERT_EQ(pk_machine_home_seek(&M, 3u, target, 1000000), PK_MOTION_OK);
    TH_ASSERT(run_until(cycle_over, 30.0));
    uint8_t tripped = 0;
    TH_EXPECT_EQ(pk_machine_cycle(&M, NULL, &tripped), PK_CYCLE_MISSED);
    TH_EXPECT_EQ(tripped, 1);
    TH_EXPECT_EQ(pos_steps(0), 400);
    TH_EXPECT_EQ(pos_steps(1), 1000);
}

static struct pk_home H;
static int home_over(void)
{
    return pk_home_poll(&H) != PK_HOME_RUNNING && idle_or_alarm();
}

static struct pk_home_cfg home_cfg(void)
{
    struct pk_home_cfg hc;
    memset(&hc, 0, sizeof hc);
    hc.dir_invert = 2;        /* Y homes toward negative */
    hc.feed = 25000;          /* $24 25 mm/min */
    hc.seek = 500000;         /* $25 500 mm/min */
    hc.debounce_ms = 250;     /* $26 */
    hc.pulloff_um = 1000;     /* $27 1 mm */
    hc.travel_um[0] = 200000; /* $130 */
    hc.travel_um[1] = 150000; /* $131 */
    return hc;
}

static void homing_cycle_leaves_the_axes_at_grbls_machine_position(void)
{
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    /* The machine stands somewhere unknown: X's switch is 37.5 mm ahead of
     * it at the positive end, Y's 52.37 mm behind it at the negative end. */
    const int32_t x_sw = 3000, y_sw = -5237;
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_X, 0, +1, x_sw), 0);
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_Y, 1, -1, y_sw), 0);
    struct pk_home_cfg hc = home_cfg();
    TH_ASSERT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_OK);
    TH_ASSERT(run_until(home_over, 120.0));
    TH_ASSERT_EQ(pk_home_poll(&H), PK_HOME_DONE);
    /* Grbl: X homed toward positive is at -$27; Y homed toward negative at
     * -$131 + $27 */
    TH_EXPECT_EQ(pos_steps(0), -80);
    TH_EXPECT_EQ(pos_steps(1), (-150000 + 1000) / 10);
    /* the pulses: each axis ended $27 off the step where its switch closed */
    struct pulses x = pulses_of(0), y = pulses_of(1);
    TH_EXPECT_EQ(x.sum, x_sw - 80);
    TH_EXPECT_EQ(y.sum, y_sw + 100);
    TH_EXPECT_EQ(R.pos[0], x.sum);
    /* both switches open, hard limits back on, the machine idle */
    TH_EXPECT_EQ(pk_machine_inputs(&M) & 3u, 0);
    TH_EXPECT(M.hard_limits);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    /* the locate pass ran at $24: X's last approach pulses came at 25 mm/min
     * (80 steps/mm: 30 ms apart on average; Y, dominant at 100 steps/mm,
     * sets the events, so single intervals are 24 or 48 ms) */
    TH_ASSERT(x.n > 10);
    size_t k = x.n - 1;
    while (k > 0 && x.d[k] < 0)
        k--;
    TH_ASSERT(k > 8);
    double mean = (double)(x.t[k] - x.t[k - 8]) / 8.0;
    TH_EXPECT(mean > 29000.0 && mean < 31000.0);
    /* the machine position now maps to the physical one: a move to machine
     * X = -10 mm goes 10 mm - $27 further from the switch */
    move_to(-10.0, -100.0, 3000.0);
    TH_ASSERT(run_until(idle_or_alarm, 60.0));
    TH_EXPECT_EQ(pos_steps(0), -800);
    TH_EXPECT_EQ(R.pos[0], x_sw - 800);
    TH_EXPECT_EQ(R.pos[1], y_sw + (-100000 + 150000) / 10);
    pulses_free(&x);
    pulses_free(&y);
}

static void homing_fails_with_grbls_alarm_numbers(void)
{
    struct pk_home_cfg hc = home_cfg();
    /* 9: no switch within 1.5 x travel */
    setup();
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_Y, 1, -1, -1000), 0);
    hc.travel_um[0] = 10000;
    TH_ASSERT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_OK);
    TH_ASSERT(run_until(home_over, 120.0));
    TH_EXPECT_EQ(pk_home_poll(&H), PK_HOME_FAIL);
    TH_EXPECT_EQ(pk_home_fail(&H), PK_HOME_FAIL_APPROACH);
    /* 8: a switch that does not open after the pull-off (stuck closed from
     * the moment it is reached) */
    hc = home_cfg();
    setup();
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_X, 0, +1, 500), 0);
    TH_ASSERT_EQ(pk_rec_add_switch(&R, PK_IN_LIMIT_Y, 1, +1, -100000), 0); /* always closed */
    TH_ASSERT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_OK);
    TH_ASSERT(run_until(home_over, 120.0));
    TH_EXPECT_EQ(pk_home_fail(&H), PK_HOME_FAIL_PULLOFF);
    /* 6: a reset during the cycle; the caller aborts it */
    hc = home_cfg();
    setup();
    TH_ASSERT_EQ(pk_machine_set_hard_limits(&M, true), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_OK);
    for (int k = 0; k < 3000; k++) {
        pk_machine_poll(&M);
        (void)pk_home_poll(&H);
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    TH_EXPECT_EQ(pk_home_poll(&H), PK_HOME_RUNNING);
    pk_home_abort(&H, PK_HOME_FAIL_RESET);
    TH_EXPECT_EQ(pk_home_poll(&H), PK_HOME_FAIL);
    TH_EXPECT_EQ(pk_home_fail(&H), PK_HOME_FAIL_RESET);
    TH_EXPECT(M.hard_limits);
    pk_rec_advance(&R, R.now + 1000);
    TH_EXPECT_EQ(pos_steps(0), decoded_sum(0));
    /* a machine reset seen by the cycle (a move aborted) is 6 too */
    setup();
    TH_ASSERT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_OK);
    for (int k = 0; k < 3000; k++) {
        pk_machine_poll(&M);
        (void)pk_home_poll(&H);
        pk_rec_advance(&R, R.now + POLL_TICKS);
    }
    (void)pk_machine_reset(&M);
    TH_EXPECT_EQ(pk_home_poll(&H), PK_HOME_FAIL);
    TH_EXPECT_EQ(pk_home_fail(&H), PK_HOME_FAIL_RESET);
    /* settings out of range and axes without switches are refused */
    hc = home_cfg();
    hc.pulloff_um = 0;
    TH_EXPECT_EQ(pk_home_start(&H, &M, &hc, 0), PK_MOTION_EINVAL);
    hc = home_cfg();
    TH_EXPECT_EQ(pk_home_start(&H, &M, &hc, 4u), PK_MOTION_ENOINPUT);
}

/* ---------------------------------------------------------------- buttons */

static void button_presses_and_levels_are_reported_with_polarity(void)
{
    struct pk_motion_cfg c = cfg_default();
    c.input_invert = 1u << PK_IN_PROBE;   /* Grbl $6: the probe is normally closed */
    setup_cfg(&c);
    uint32_t lv = pk_machine_inputs(&M);
    /* nothing pressed; the probe reads active-high raw 0 -> flipped: touching */
    TH_EXPECT_EQ(lv, 1u << PK_IN_PROBE);
    TH_EXPECT_EQ(pk_machine_input_events(&M), 0);
    /* the hold button pressed and released between two looks */
    TH_ASSERT_EQ(pk_rec_input_at(&R, 100, PK_IN_HOLD, 1), 0);
    TH_ASSERT_EQ(pk_rec_input_at(&R, 200, PK_IN_HOLD, 0), 0);
    TH_ASSERT_EQ(pk_rec_input_at(&R, 300, PK_IN_LIMIT_X, 1), 0);
    pk_rec_advance(&R, 1000);
    uint32_t ev = pk_machine_input_events(&M);
    if (EDGES)
        TH_EXPECT_EQ(ev, (1u << PK_IN_HOLD) | (1u << PK_IN_LIMIT_X));
    else
        TH_EXPECT_EQ(ev, 1u << PK_IN_LIMIT_X);   /* without edges a press is seen when looked at */
    TH_EXPECT_EQ(pk_machine_input_events(&M), 0);
    TH_EXPECT_EQ(pk_machine_inputs(&M), (1u << PK_IN_PROBE) | (1u << PK_IN_LIMIT_X));
    /* a bad flip mask is a bad configuration */
    c.input_invert = 1u << PK_IN_COUNT;
    TH_EXPECT_EQ(pk_machine_configure(&M, &c), PK_MOTION_EINVAL);
}

/* ------------------------------------------------------------------ cases */

#define BOTH(fn)                                                                                   \
    static void fn##_with_edges(void) { EDGES = 1; fn(); }                                         \
    static void fn##_without_edges(void) { EDGES = 0; fn(); }
BOTH(hard_limit_mid_move_stops_within_one_step_event)
BOTH(hard_limit_alarm_shows_at_once_not_at_the_next_step)
BOTH(turning_hard_limits_off_after_a_trip_does_not_resume_the_steps)
BOTH(a_switch_reached_by_the_move_stops_it_on_that_step)
BOTH(a_switch_closed_before_the_move_lets_no_step_out)
BOTH(hard_limits_off_ignore_the_switches)
BOTH(a_limit_closing_while_idle_raises_the_alarm)
BOTH(hard_limits_need_a_limit_input)
BOTH(a_failing_input_read_while_watching_is_an_alarm)
BOTH(probe_records_the_contact_exactly_then_stops_within_the_acceleration)
BOTH(probe_contact_at_a_scripted_tick_records_the_pulses_before_it)
BOTH(probe_missing_the_contact_says_so_at_the_end_of_the_move)
BOTH(probe_already_touching_is_refused_without_moving)
BOTH(a_reset_during_a_probe_aborts_it)
BOTH(homing_move_stops_each_axis_on_the_step_its_switch_closes)
BOTH(homing_move_that_never_reaches_a_switch_is_missed)
BOTH(homing_cycle_leaves_the_axes_at_grbls_machine_position)
BOTH(homing_fails_with_grbls_alarm_numbers)
BOTH(button_presses_and_levels_are_reported_with_polarity)

#define CASES(fn) TH_CASE(fn##_with_edges), TH_CASE(fn##_without_edges)

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        CASES(hard_limit_mid_move_stops_within_one_step_event),
        CASES(hard_limit_alarm_shows_at_once_not_at_the_next_step),
        CASES(turning_hard_limits_off_after_a_trip_does_not_resume_the_steps),
        CASES(a_switch_reached_by_the_move_stops_it_on_that_step),
        CASES(a_switch_closed_before_the_move_lets_no_step_out),
        CASES(hard_limits_off_ignore_the_switches),
        CASES(a_limit_closing_while_idle_raises_the_alarm),
        CASES(hard_limits_need_a_limit_input),
        CASES(a_failing_input_read_while_watching_is_an_alarm),
        CASES(probe_records_the_contact_exactly_then_stops_within_the_acceleration),
        CASES(probe_contact_at_a_scripted_tick_records_the_pulses_before_it),
        CASES(probe_missing_the_contact_says_so_at_the_end_of_the_move),
        CASES(probe_already_touching_is_refused_without_moving),
        CASES(a_reset_during_a_probe_aborts_it),
        CASES(homing_move_stops_each_axis_on_the_step_its_switch_closes),
        CASES(homing_move_that_never_reaches_a_switch_is_missed),
        CASES(homing_cycle_leaves_the_axes_at_grbls_machine_position),
        CASES(homing_fails_with_grbls_alarm_numbers),
        CASES(button_presses_and_levels_are_reported_with_polarity),
    };
    int failed = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return failed;
}
