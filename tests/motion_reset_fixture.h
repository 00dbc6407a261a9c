/*
 * motion_reset_fixture.h — the machine and run-up shared by the reset tests
 * (tests/test_motion_reset.c) and the open finding M2
 * (tests/fuzz/findings/findings_motion.c): a 2-axis machine on the recording
 * HAL, run until a step pulse is high. Static definitions: include once per
 * test program.
 */
#ifndef PLOTKIN_MOTION_RESET_FIXTURE_H
#define PLOTKIN_MOTION_RESET_FIXTURE_H

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

#endif
