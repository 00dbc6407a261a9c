/*
 * test_motion_reset.c — a reset is only a clean stop if it really lowered the
 * step lines (fuzz finding M1, tests/fuzz/README.md): otherwise a line left
 * high would hide the next pulse, so the machine must stay in ALARM until a
 * reset whose write succeeds. And a reset never cuts a step pulse short
 * (finding M2): a pulse that is high when the reset comes is lowered by the
 * timer after its full width.
 */
#include "motion_reset_fixture.h"

/* M1: a reset whose own step-line write fails must not look like a clean stop. */
static void test_a_reset_whose_step_write_fails_raises_an_alarm(void)
{
    setup(4);
    TH_ASSERT(run_until_pulse_high());
    R.fail_after[PK_REC_STEP] = 0; /* the reset's write of the step lines fails */
    pk_machine_reset(&M);
    pk_rec_advance(&R, R.now + 4u);   /* the pulse ends (its lowering fails) */
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
    pk_rec_advance(&R, R.now + 4u);
    TH_ASSERT_EQ(pk_machine_state(&M), PK_STATE_ALARM);
    R.fail_after[PK_REC_STEP] = -1;
    pk_machine_reset(&M);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    TH_EXPECT_EQ(R.raw[PK_REC_STEP], 0u); /* every step line is low */
}


/* M2: a reset must not cut a step pulse shorter than step_pulse_ticks (the
 * step is already counted; a driver may not see a runt pulse). */
static void test_a_reset_never_shortens_a_step_pulse(void)
{
    setup(40);
    TH_ASSERT(run_until_pulse_high());
    uint64_t rise = R.now; /* the pulse went high at this tick (we stop right after) */
    for (size_t k = R.n; k-- > 0;)
        if (R.ev[k].kind == PK_REC_STEP && R.ev[k].levels != 0u) {
            rise = R.ev[k].tick;
            break;
        }
    pk_steps_t before[PK_AXES], after[PK_AXES];
    pk_machine_position_steps(&M, before);
    TH_EXPECT(pk_machine_reset(&M));
    /* run on a little: the timer lowers the line once the pulse is complete */
    pk_rec_advance(&R, R.now + 100u);
    uint64_t fall = 0;
    for (size_t k = 0; k < R.n; k++)
        if (R.ev[k].kind == PK_REC_STEP && R.ev[k].tick >= rise && R.ev[k].levels == 0u) {
            fall = R.ev[k].tick;
            break;
        }
    TH_EXPECT(fall >= rise + 40u);
    TH_EXPECT_EQ(R.raw[PK_REC_STEP], 0u);
    TH_EXPECT_EQ(pk_machine_state(&M), PK_STATE_IDLE);
    pk_machine_position_steps(&M, after);  /* and nothing more was emitted */
    TH_EXPECT_EQ(after[0], before[0]);
    TH_EXPECT_EQ(after[1], before[1]);
    /* the next move starts from there */
    pk_um_t t[PK_AXES] = { 0, 0, 0 };
    TH_ASSERT_EQ(pk_machine_move(&M, t, 3000000, PK_MOVE_FEED), PK_MOTION_OK);
    TH_ASSERT_EQ(pk_machine_end(&M), PK_MOTION_OK);
    for (uint64_t k = 0; k < 4000000u && pk_machine_state(&M) != PK_STATE_IDLE; k++) {
        if ((k % 20u) == 0u)
            pk_machine_poll(&M);
        pk_rec_advance(&R, R.now + 1u);
    }
    pk_machine_position_steps(&M, after);
    TH_EXPECT_EQ(after[0], 0);
    TH_EXPECT_EQ(after[1], 0);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_reset_whose_step_write_fails_raises_an_alarm),
        TH_CASE(test_a_successful_reset_after_that_clears_the_alarm),
        TH_CASE(test_a_reset_never_shortens_a_step_pulse),
    };
    int f = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return f;
}
