/*
 * findings_motion.c — unit tests of their own for the motion-core findings
 * M2 of tests/fuzz/README.md (M1 is fixed: tests/test_motion_reset.c) (found by fuzz_motion), on the recording
 * HAL (host-sim/hal_record.c), deterministic and minimal.
 *
 * They state the behaviour a user needs and FAIL while the finding is open,
 * so they are not part of `make test` (which must pass); `make fuzz-findings`
 * builds and runs them. When pk_motion.c is fixed, move this file to
 * tests/test_motion_findings.c so the fix stays fixed.
 */
#include "motion_reset_fixture.h"

int th_main(int argc, char **argv);

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
    pk_machine_reset(&M);
    /* run on a little: a fixed firmware may lower the line from the timer */
    pk_rec_advance(&R, R.now + 100u);
    uint64_t fall = 0;
    for (size_t k = 0; k < R.n; k++)
        if (R.ev[k].kind == PK_REC_STEP && R.ev[k].tick >= rise && R.ev[k].levels == 0u) {
            fall = R.ev[k].tick;
            break;
        }
    TH_EXPECT(fall >= rise + 40u);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_reset_never_shortens_a_step_pulse),
    };
    int f = th_run(cases, TH_COUNT(cases));
    pk_rec_free(&R);
    return f;
}
