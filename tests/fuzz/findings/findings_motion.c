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
#include <string.h>
#include "hal_record.h"
#include "motion_run.h"
#include "th.h"

int th_main(int argc, char **argv);

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
