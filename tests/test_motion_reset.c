/*
 * test_motion_reset.c — a reset is only a clean stop if it really lowered the
 * step lines (fuzz finding M1, tests/fuzz/README.md): otherwise a line left
 * high would hide the next pulse, so the machine must stay in ALARM until a
 * reset whose write succeeds.
 */
#include "motion_reset_fixture.h"

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
