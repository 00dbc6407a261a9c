/*
 * isr_inputs.c — what watching the inputs costs the step path: one workload
 * (a 40 mm square, 2 axes, 80 steps/mm, 3000 mm/min, smoothing off) through
 * the whole motion core on the recording HAL, with the inputs in one of
 * these modes (argv[1]):
 *
 *   noinputs      a board without inputs (the HAL of before the inputs)
 *   none          inputs and edge reports, nothing watched
 *   limits-edges  hard limits on, the HAL reports edges
 *   limits-poll   hard limits on, no edge reports (an input read per step)
 *
 * It prints the timer callbacks and motor steps it made; run under
 * `valgrind --tool=callgrind --toggle-collect=pk_sg_isr` (bench/isr_inputs.sh)
 * the instructions inside the step callback per call and per step follow.
 * The mode must not change the pulses: the program checks that the end
 * position is the square's and exits non-zero otherwise.
 */
#include <stdio.h>
#include <string.h>
#include "hal_record.h"
#include "pk_motion.h"

static struct pk_machine M;
static struct pk_rec R;

int main(int argc, char **argv)
{
    const char *mode = argc > 1 ? argv[1] : "none";
    pk_rec_init(&R, 1000000u);
    R.record = 0;
#if PK_HAL_VERSION >= 2
    const uint32_t inputs = (1u << PK_IN_LIMIT_X) | (1u << PK_IN_LIMIT_Y) | (1u << PK_IN_PROBE);
    if (strcmp(mode, "noinputs") != 0)
        pk_rec_inputs(&R, inputs, 0, strcmp(mode, "limits-poll") != 0);
#else
    if (strcmp(mode, "noinputs") != 0) {
        fprintf(stderr, "isr_inputs: this HAL has no inputs: only 'noinputs'\n");
        return 2;
    }
#endif
    struct pk_motion_cfg c;
    memset(&c, 0, sizeof c);
    c.axes = 2;
    for (int i = 0; i < 2; i++) {
        c.steps_per_mm_q16[i] = 80u << 16;
        c.max_rate[i] = 6000000;
        c.accel[i] = 1000000;
    }
    c.junction_dev_um = 20;
    c.step_pulse_ticks = 2;
    c.dir_setup_ticks = 1;
    c.smooth.mode = PK_SMOOTH_OFF;
    if (pk_machine_init(&M, &c, &R.hal) != PK_MOTION_OK)
        return 2;
#if PK_HAL_VERSION >= 2
    if (strncmp(mode, "limits", 6) == 0 && pk_machine_set_hard_limits(&M, true) != PK_MOTION_OK)
        return 2;
#endif
    static const pk_um_t sq[5][2] = { { 40000, 0 }, { 40000, 40000 }, { 0, 40000 }, { 0, 0 }, { 40000, 0 } };
    unsigned next = 0;
    for (unsigned long it = 0; it < 100000000ul; it++) {
        while (next < 5) {
            pk_um_t p[PK_AXES] = { 0 };
            p[0] = sq[next][0];
            p[1] = sq[next][1];
            if (pk_machine_move(&M, p, 3000000, PK_MOVE_FEED) != PK_MOTION_OK)
                break;
            next++;
        }
        if (next == 5) {
            (void)pk_machine_end(&M);
            next = 6;
        }
        pk_machine_poll(&M);
        if (next == 6 && pk_machine_state(&M) == PK_STATE_IDLE && !pk_rec_armed(&R))
            break;
        if (pk_machine_state(&M) == PK_STATE_ALARM)
            return 1;
        pk_rec_advance(&R, R.now + 100);
    }
    pk_steps_t pos[PK_AXES];
    pk_machine_position_steps(&M, pos);
    long steps = 5L * 40 * 80; /* |dx| + |dy| of the square, per axis summed */
    printf("mode %s callbacks %llu steps %ld\n", mode, (unsigned long long)R.callbacks, steps);
    pk_rec_free(&R);
    return pos[0] == 3200 && pos[1] == 0 ? 0 : 1;
}
