/*
 * sim_run.c — one complete simulated run (see sim_run.h).
 */
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include "sim_run.h"

double pk_sim_steps_to_um(const struct pk_sim_result *r, unsigned a, int64_t steps)
{
    return (double)steps * 1000.0 * 65536.0 / (double)r->mcfg.steps_per_mm_q16[a];
}

static double um_per_step(pk_spmm_q16_t q16) { return 1000.0 * 65536.0 / (double)q16; }

/* The steps/mm the machine uses now; a change starts new rate windows and
 * converts further steps at the new value. */
static void sync_scale(struct pk_sim_result *r)
{
    for (unsigned a = 0; a < PK_AXES; a++) {
        pk_spmm_q16_t q = r->m.cfg.steps_per_mm_q16[a];
        if (q == r->spmm_q16[a] || q == 0u)
            continue;
        r->base_um[a] = r->pos_um[a];
        r->base_steps[a] = r->pos[a];
        r->spmm_q16[a] = q;
        pk_rate_set_scale(&r->rate[a], um_per_step(q) / 1000.0);
    }
    /* the limits in force, mm/s and mm/s^2, for the estimators' counts */
    for (unsigned a = 0; a < PK_AXES; a++) {
        r->rate[a].cfg.v_limit = (double)r->m.cfg.max_rate[a] / 60000.0;
        r->rate[a].cfg.a_limit = (double)r->m.cfg.accel[a] / 1000.0;
    }
}

/* All steps of tick tick_t are in: one point of the executed path. */
static void flush_tick(struct pk_sim_result *r)
{
    if (r->tick_n == 0)
        return;
    sync_scale(r);
    int shared = r->tick_n > 1;
    for (int i = 0; i < r->tick_n; i++) {
        unsigned a = r->tick_axis[i];
        r->pos[a] += r->tick_dir[i];
        if (a < PK_AXES) {
            pk_rate_step(&r->rate[a], r->tick_t, r->tick_dir[i], shared);
            r->pos_um[a] = r->base_um[a] + (double)(r->pos[a] - r->base_steps[a]) * um_per_step(r->spmm_q16[a]);
        }
    }
    r->tick_n = 0;
    double pt[3] = { r->pos_um[0], r->pos_um[1], PK_AXES > 2 ? r->pos_um[2] : 0.0 };
    (void)pk_path_measure(&r->prog, pt, r->tick_t, NULL, NULL);
    if (r->ref_on)
        (void)pk_path_measure(&r->ref, pt, r->tick_t, NULL, NULL);
    if (r->opts.svg != NULL)
        pk_svg_exec_point(r->opts.svg, pt, pk_pen_exec_drawn(&r->pen, r->tick_pen, r->spindle_q16, pt[2]));
}

/* Every decoded step; the steps of one tick are one point of the path. */
static void on_step(void *arg, const struct pk_step_event *ev)
{
    struct pk_sim_result *r = arg;
    if (r->tick_n > 0 && ev->t != r->tick_t)
        flush_tick(r);
    if (r->tick_n >= (int)(sizeof r->tick_axis)) /* one pulse per axis per tick: cannot happen */
        flush_tick(r);
    r->tick_t = ev->t;
    r->tick_axis[r->tick_n] = ev->axis < PK_HAL_MAX_AXES ? ev->axis : 0u;
    r->tick_dir[r->tick_n] = ev->dir;
    r->tick_n++;
    r->tick_pen = ev->pen;
    r->last_step_tick = ev->t;
}

/*
 * The spindle / laser output (pk_hal_spindle_write) of the simulated board:
 * recorded, so that a laser's executed path shows where it fired. The
 * gpiod backend has no such output; its ctx is the struct pk_gpiod inside
 * our struct pk_sim_hw, which leads back to the run.
 */
static int sim_spindle_write(void *ctx, uint16_t value_q16)
{
    struct pk_sim_result *r = (struct pk_sim_result *)(void *)((char *)ctx - offsetof(struct pk_sim_result, hw.gpio));
    r->spindle_q16 = value_q16;
    r->spindle_writes++;
    return 0;
}

/* Every pin edge: decoder, and the CSV file if asked. */
static void on_edge(void *arg, const struct pk_trace_edge *e)
{
    struct pk_sim_result *r = arg;
    (void)pk_decoder_push(&r->decoder, e);
    if (r->opts.trace_csv != NULL)
        pk_trace_csv_row(r->opts.trace_csv, e, r->opts.cfg->tick_hz, r->shared_enable);
}

/* The job's observer: programmed primitives into the path and the drawing. */
static void on_prim(void *arg, const struct pk_path_prim *p)
{
    struct pk_sim_result *r = arg;
    pk_path_add(&r->prog, p);
    if (r->opts.svg != NULL)
        pk_svg_prim(r->opts.svg, p);
}

/* The engine's primitives, for the lower bound (sim_bound.h), with the
 * tolerance the machine applies to them. */
static void on_bound_prim(void *arg, const struct pk_grbl_prim *g)
{
    struct pk_sim_result *r = arg;
    const struct pk_sim_cfg *c = r->opts.cfg;
    struct pk_path_prim p;
    pk_sim_prim_from_grbl(g, &r->pen, &p);
    double tol;
    if (c->force_smoothing)
        tol = c->smooth_mode == 0u ? 0.0 : c->tolerance;
    else
        tol = g->exact ? 0.0 : (double)g->path_tol_um / 1000.0;
    double feed = g->kind == PK_GRBL_PRIM_RAPID ? 0.0 : (double)g->feed_umpm / 60000.0;
    pk_bound_prim(&r->bound, &p, feed, tol, g->tool_on != 0);
}

/*
 * Room in the programmed path's window. If there is none, the job waits and
 * the machine runs on, which releases primitives (sim_path.h). Should the
 * machine stand still for a whole simulated second with the window full
 * (it would wait for input that never comes), the job may go on and the
 * oldest primitive is dropped early (counted in forced_drops: the summary
 * then says that the deviation figures are upper bounds).
 */
static size_t path_room(void *arg)
{
    struct pk_sim_result *r = arg;
    if (pk_machine_state(&r->m) == PK_STATE_IDLE)
        pk_path_all_executed(&r->prog);
    size_t room = pk_path_room(&r->prog);
    if (room == 0u && r->hw.sched.now > r->last_step_tick + r->opts.cfg->tick_hz)
        return 1u;
    return room;
}

/* The firmware's main loop, then what the run learns from it. */
static int run_main(void *arg, uint64_t now)
{
    struct pk_sim_result *r = arg;
    int rc = r->opts.main_fn != NULL ? r->opts.main_fn(r->opts.main_arg, now) : pk_sim_job_main(&r->job, now);
    if (pk_machine_state(&r->m) == PK_STATE_IDLE) {
        pk_path_all_executed(&r->prog); /* everything requested has run */
        if (r->ref_on)
            pk_path_all_executed(&r->ref);
    }
    if (r->opts.input_read != NULL)
        r->opts.input_read(r->opts.input_arg, r->job.pos);
    return rc;
}

static double min_step_um(const struct pk_motion_cfg *c, unsigned axes)
{
    double s = INFINITY;
    for (unsigned a = 0; a < axes && a < PK_AXES; a++)
        s = fmin(s, um_per_step(c->steps_per_mm_q16[a]));
    return isfinite(s) ? s : 1.0;
}

int pk_sim_start(const struct pk_sim_opts *o, struct pk_sim_result *r)
{
    const struct pk_sim_cfg *c = o->cfg;

    memset(r, 0, sizeof *r);
    r->deviation_um = -1.0;
    r->ref_deviation_um = -1.0;
    r->opts = *o;
    if (pk_sim_cfg_motion(c, &r->mcfg, r->err, sizeof r->err) != 0) {
        r->setup_failed = 1;
        return -1;
    }
    unsigned dims = c->axes < 3u ? 2u : 3u;
    if (pk_path_init(&r->prog, dims, o->path_cap, min_step_um(&r->mcfg, c->axes)) != 0) {
        snprintf(r->err, sizeof r->err, "out of memory for the programmed path's window");
        r->setup_failed = 1;
        return -1;
    }
    pk_sim_cfg_pen(c, &r->pen);
    pk_sim_default_board(&r->board, o->chip, c->axes);
    r->shared_enable = r->board.enables == 1u;

    struct pk_decode_cfg dc;
    pk_sim_board_decode_cfg(&r->board, c->tick_hz, &o->lim, &dc);
    pk_decoder_init(&r->decoder, &dc, &r->dec, o->keep_events);
    r->decoder.on_step = on_step;
    r->decoder.on_step_arg = r;
    /* a step edge can be late by the timer's rounding (1 tick) and by the
     * direction set-up the step generator waits for before it ($206) */
    /* q_alone = 1/2: every axis is rounded to the block's events, also a
     * step alone on its tick (sim_rate.h, finding M6) */
    struct pk_rate_cfg rc = { .tick_hz = c->tick_hz, .tau_ticks = 1.0 + (double)r->mcfg.dir_setup_ticks,
                              .q_alone = 0.5 };
    for (unsigned a = 0; a < PK_AXES; a++)
        pk_rate_init(&r->rate[a], &rc);
    if (o->trace_csv != NULL)
        pk_trace_csv_header(o->trace_csv, c->tick_hz);

    struct pk_trace tpl;
    memset(&tpl, 0, sizeof tpl);
    tpl.keep = o->keep_trace;
    tpl.on_edge = on_edge;
    tpl.on_edge_arg = r;
    /* one main-loop pass every 100 µs of simulated time while running */
    uint32_t period = c->tick_hz / 10000u ? c->tick_hz / 10000u : 1u;
    if (pk_sim_hw_open_traced(&r->hw, &r->board, c->tick_hz, period, o->fault, &tpl, r->err,
                              sizeof r->err) != 0) {
        r->setup_failed = 1;
        return -1;
    }
    if (r->hw.hal.ctx == &r->hw.gpio && r->hw.hal.ops->spindle_write == NULL) {
        r->ops = *r->hw.hal.ops;
        r->ops.spindle_write = sim_spindle_write;
        r->hw.hal.ops = &r->ops;
    }
    int rc2 = pk_machine_init(&r->m, &r->mcfg, &r->hw.hal);
    if (rc2 != PK_MOTION_OK) {
        snprintf(r->err, sizeof r->err, "machine init failed (%d)%s%s", rc2,
                 *pk_hal_error_text(&r->hw.hal) ? ": " : "", pk_hal_error_text(&r->hw.hal));
        r->setup_failed = 1;
        return -1;
    }
    if (pk_sim_hw_inputs(&r->hw, o->inputs, o->n_inputs) != 0) {
        snprintf(r->err, sizeof r->err, "an input that the board does not have, or too many");
        r->setup_failed = 1;
        return -1;
    }
    if (o->hard_limits && pk_machine_set_hard_limits(&r->m, true) != PK_MOTION_OK) {
        snprintf(r->err, sizeof r->err, "hard limits: the board has no limit switch input");
        r->setup_failed = 1;
        return -1;
    }
    sync_scale(r);
    pk_sim_job_init(&r->job, &r->m, c, o->program, o->len);
    r->job.progress = o->progress;
    r->job.obs = (struct pk_sim_prim_obs){ on_prim, path_room, r };
    r->lower_bound_s = -1.0;
    if (o->lower_bound) {
        struct pk_bound_cfg bc;
        memset(&bc, 0, sizeof bc);
        bc.axes = c->axes < 3u ? c->axes : 3u;
        for (unsigned a = 0; a < 3u; a++) {
            bc.vmax_mm_s[a] = c->max_rate[a] / 60.0;
            bc.acc_mm_s2[a] = c->accel[a];
        }
        bc.junction_mm = c->junction_dev;
        bc.tool_stops = r->pen.mode == PK_PEN_TOOL;
        bc.settle_s = r->pen.mode == PK_PEN_TOOL ? c->pen_settle_ms / 1000.0 : 0.0;
        pk_bound_init(&r->bound, &bc);
        pk_sim_job_set_observer(&r->job, on_bound_prim, r);
    }
    r->run_status = -1;
    return 0;
}

int pk_sim_ref_point(struct pk_sim_result *r, const double p_um[3], int new_stroke, uint32_t line)
{
    if (!r->ref_on) {
        unsigned dims = r->opts.cfg->axes < 3u ? 2u : 3u;
        /* half the programmed path's window: both together stay well under 64 MB */
        if (pk_path_init(&r->ref, dims, PK_PATH_CAP_DEFAULT / 2u, min_step_um(&r->mcfg, r->opts.cfg->axes)) != 0) {
            pk_path_free(&r->ref);
            return -1;
        }
        r->ref_on = 1;
    }
    struct pk_path_prim p;
    const double *a = new_stroke || !r->ref_have_last ? p_um : r->ref_last;
    pk_path_line(&p, a, p_um);
    p.line = line;
    p.drawn = 1;
    pk_path_add(&r->ref, &p);
    memcpy(r->ref_last, p_um, sizeof r->ref_last);
    r->ref_have_last = 1;
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
    int st = pk_sim_sched_run(&r->hw.sched, run_main, r, slice);
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
    flush_tick(r);
    for (unsigned a = 0; a < c->axes && a < PK_AXES; a++) {
        r->max_speed_mm_s[a] = r->rate[a].speed16.vmax.v;
        r->max_speed2_mm_s[a] = r->rate[a].speed2.vmax.v;
        r->max_accel_mm_s2[a] = fabs(r->rate[a].accel.amax.a);
    }
    if (r->prog.st.points > 0u) {
        r->deviation_um = r->prog.st.max_um;
        r->deviation_p95_um = pk_path_quantile(&r->prog, 0.95);
    }
    if (r->ref_on && r->ref.st.points > 0u) {
        r->ref_deviation_um = r->ref.st.max_um;
        r->ref_deviation_p95_um = pk_path_quantile(&r->ref, 0.95);
    }
    if (r->opts.lower_bound)
        r->lower_bound_s = pk_bound_finish(&r->bound);
    if (r->decoder.oom || r->hw.trace.oom) {
        snprintf(r->err, sizeof r->err, "out of memory recording the run");
        return -1;
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
    /* Closing the hardware drives the lines idle: those edges are after the
     * run, and the consumers (decoder, CSV file) may be gone by now. */
    r->hw.trace.on_edge = NULL;
    r->opts.trace_csv = NULL;
    pk_sim_hw_close(&r->hw);
    pk_decoded_free(&r->dec);
    pk_sim_job_free(&r->job);
    pk_path_free(&r->prog);
    pk_bound_free(&r->bound);
    if (r->ref_on)
        pk_path_free(&r->ref);
    r->ref_on = 0;
}
