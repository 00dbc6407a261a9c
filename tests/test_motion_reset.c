/*
 * test_motion_reset.c — a reset is only a clean stop if it really lowered the
 * step lines (fuzz finding M1, tests/fuzz/README.md): otherwise a line left
 * high would hide the next pulse, so the machine must stay in ALARM until a
 * reset whose write succeeds.
 */
#include <string.h>
#include "hal_record.h"
#include "motion_run.h"
#include "th.h"


static struct pk_machine M;
static struct pk_rec R;

static void setup(uint32_t pulse_ticks)
{
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = 80u << 16;
        c.max_rate[i] = 6000000;
        c.accel[i] = 1000000;
    }
    c.junction_dev_um = 20;
    c.step_pulse_ticks = pulse_ticks;
    c.dir_setup_ticks = 1;
    c.pen_down_level = 1;
    pk_rec_free(&R);
    pk_rec_init(&R, 1000000u);
    pk_machine_init(&M, &c, &R.hal);
}

/* Run the main loop and timer until a step line is high (a pulse is on). */
static int run_until_pulse_high(void)
{
    pk_um_t t[PK_AXES] = { 20000, 10000, 0 };
    if (pk_machine_move(&M, t, 3000000, PK_MOVE_FEED) != PK_MOTION_OK)
        return 0;
    pk_machine_end(&M);
    for (uint64_t k = 0; k < 2000000u; k++) {
        if ((k % 20u) == 0u)
            pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 1u);
        if (R.raw[PK_REC_STEP] != 0u && R.now > 100000u)
            return 1;
    }
    return 0;
}

/* M1: a reset whose own step-line write fails must not look like a clean stop. */
static void test_a_reset_whose_step_write_fails_raises_an_alarm(void)
{
    setup(4);
    TH_ASSERT(run_until_pulse_high());
    R.fail_after[PK_REC_STEP] = 0; /* the reset's write of the step lines fails */
    pk_machine_reset(&M);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    TH_EXPECT_EQ(pk_machine_alarm(&M), PK_ALARM_STEP_WRITE);
}

/* ... and the next reset, whose write succeeds, is a clean stop again. */
static void test_a_successful_reset_after_that_clears_the_alarm(void)
{
    setup(4);
    TH_ASSERT(run_until_pulse_high());
    R.fail_after[PK_REC_STEP] = 0;
    pk_machine_reset(&M);
    TH_ASSERT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    R.fail_after[PK_REC_STEP] = -1;
    pk_machine_reset(&M);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    TH_EXPECT_EQ(R.raw[PK_REC_STEP], 0u); /* every step line is low */
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_reset_whose_step_write_fails_raises_an_alarm),
        TH_CASE(test_a_successful_reset_after_that_clears_the_alarm),
    };
    int f = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return f;
}
