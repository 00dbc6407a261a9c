/*
 * sim_run.c — one complete simulated run (see sim_run.h).
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "sim_run.h"

double pk_sim_steps_to_um(const struct pk_sim_result *r, unsigned a, int64_t steps)
{
    return (double)steps * 1000.0 * 65536.0 / (double)r->mcfg.steps_per_mm_q16[a];
}

int pk_sim_start(const struct pk_sim_opts *o, struct pk_sim_result *r)
{
    struct pk_gpiod_cfg board;
    const struct pk_sim_cfg *c = o->cfg;

    memset(r, 0, sizeof *r);
    r->deviation_um = -1.0;
    r->opts = *o;
    if (pk_sim_cfg_motion(c, &r->mcfg, r->err, sizeof r->err) != 0) {
        r->setup_failed = 1;
        return -1;
    }
    pk_sim_default_board(&board, o->chip, c->axes);
    /* one main-loop pass every 100 µs of simulated time while running */
    uint32_t period = c->tick_hz / 10000u ? c->tick_hz / 10000u : 1u;
    if (pk_sim_hw_open(&r->hw, &board, c->tick_hz, period, o->fault, r->err, sizeof r->err) != 0) {
        r->setup_failed = 1;
        return -1;
    }
    int rc = pk_machine_init(&r->m, &r->mcfg, &r->hw.hal);
    if (rc != PK_MOTION_OK) {
        snprintf(r->err, sizeof r->err, "machine init failed (%d)%s%s", rc,
                 *pk_hal_error_text(&r->hw.hal) ? ": " : "", pk_hal_error_text(&r->hw.hal));
        r->setup_failed = 1;
        return -1;
    }
    pk_sim_job_init(&r->job, &r->m, c, o->program, o->len);
    r->job.progress = o->progress;
    r->run_status = -1;
    return 0;
}

int pk_sim_advance(struct pk_sim_result *r, uint64_t ticks)
{
    const struct pk_sim_cfg *c = r->opts.cfg;
    uint64_t limit = r->opts.max_ticks ? r->opts.max_ticks : (uint64_t)c->tick_hz * 86400u;
    if (r->setup_failed)
        return 1;
    if (r->run_status >= 0)
        return 1;
    uint64_t left = limit > r->hw.sched.now ? limit - r->hw.sched.now : 0u;
    uint64_t slice = ticks && ticks < left ? ticks : left;
    int st = pk_sim_sched_run(&r->hw.sched, pk_sim_job_main, &r->job, slice);
    if (st == PK_SIM_RUN_TIME_LIMIT && r->hw.sched.now < limit)
        return 0; /* slice over, run on */
    r->run_status = st;
    return 1;
}

int pk_sim_finish(struct pk_sim_result *r)
{
    const struct pk_sim_cfg *c = r->opts.cfg;
    if (r->setup_failed)
        return -1;
    if (r->opts.progress != NULL)
        fputs("\r\033[K", r->opts.progress);
    r->ticks = r->hw.sched.now;
    pk_machine_position_steps(&r->m, r->fw_steps);

    struct pk_decode_cfg dc;
    pk_sim_hw_decode_cfg(&r->hw, &r->opts.lim, &dc);
    if (pk_decode(&r->hw.trace, &dc, &r->dec) != 0) {
        snprintf(r->err, sizeof r->err, "out of memory decoding the trace");
        return -1;
    }
    unsigned win = r->opts.rate_window ? r->opts.rate_window : 16u;
    for (unsigned a = 0; a < c->axes && a < PK_AXES; a++) {
        double vs, as, spmm = (double)r->mcfg.steps_per_mm_q16[a] / 65536.0;
        pk_decode_axis_rates(&r->dec, a, c->tick_hz, win, &vs, &as);
        r->max_speed_mm_s[a] = vs / spmm;
        r->max_accel_mm_s2[a] = as / spmm;
    }
    /* executed path: the position after every step */
    if (r->dec.n_ev > 0u) {
        double *x = malloc(r->dec.n_ev * sizeof *x), *y = malloc(r->dec.n_ev * sizeof *y);
        if (x != NULL && y != NULL) {
            int64_t p[PK_HAL_MAX_AXES] = { 0 };
            for (size_t i = 0; i < r->dec.n_ev; i++) {
                p[r->dec.ev[i].axis] += r->dec.ev[i].dir;
                x[i] = pk_sim_steps_to_um(r, 0, p[0]);
                y[i] = pk_sim_steps_to_um(r, 1, p[1]);
            }
            r->deviation_um = pk_sim_job_deviation_um(&r->job, x, y, r->dec.n_ev);
        }
        free(x);
        free(y);
    }
    return 0;
}

int pk_sim_run(const struct pk_sim_opts *o, struct pk_sim_result *r)
{
    if (pk_sim_start(o, r) != 0)
        return -1;
    while (!pk_sim_advance(r, 0))
        ;
    return pk_sim_finish(r);
}

void pk_sim_result_free(struct pk_sim_result *r)
{
    pk_decoded_free(&r->dec);
    pk_sim_job_free(&r->job);
    pk_sim_hw_close(&r->hw);
}
