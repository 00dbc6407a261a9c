/*
 * sim_run.c — one complete simulated run (see sim_run.h).
 */
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "sim_run.h"

double pk_sim_steps_to_um(const struct pk_sim_result *r, unsigned a, int64_t steps)
{
    return (double)steps * 1000.0 * 65536.0 / (double)r->mcfg.steps_per_mm_q16[a];
}

static void path_add(struct pk_sim_result *r, double x, double y, int pen)
{
    if (r->n_path == r->cap_path) {
        size_t cap = r->cap_path ? r->cap_path * 2u : 4096u;
        struct pk_sim_path_pt *p = realloc(r->path, cap * sizeof *p);
        if (p == NULL)
            return;
        r->path = p;
        r->cap_path = cap;
    }
    r->path[r->n_path++] = (struct pk_sim_path_pt){ x, y, (uint8_t)pen };
}

/* Path deviation at the current position (all steps of one tick applied). */
static void measure(struct pk_sim_result *r)
{
    double x = pk_sim_steps_to_um(r, 0, r->pos[0]), y = pk_sim_steps_to_um(r, 1, r->pos[1]);
    double d = pk_sim_job_point_deviation(&r->job, &r->dev_k, x, y);
    if (d > r->deviation_um)
        r->deviation_um = d;
}

/* Every decoded step: speeds, path deviation, the thinned path. Steps of
 * several axes on the same tick are one diagonal move: the deviation is
 * measured once they have all been applied. */
static void on_step(void *arg, const struct pk_step_event *ev)
{
    struct pk_sim_result *r = arg;
    if (r->step_pending && ev->t != r->step_t)
        measure(r);
    r->step_pending = 1;
    r->step_t = ev->t;
    if (ev->axis < PK_AXES)
        pk_rate_step(&r->rate[ev->axis], ev->t, ev->dir);
    r->pos[ev->axis] += ev->dir;
    if (r->opts.no_path)
        return;
    double x = pk_sim_steps_to_um(r, 0, r->pos[0]), y = pk_sim_steps_to_um(r, 1, r->pos[1]);
    if (ev->pen != r->last_pen) {
        if (r->n_path > 0u)
            path_add(r, r->last_x, r->last_y, r->last_pen);
        path_add(r, r->last_x, r->last_y, ev->pen);
        r->last_pen = ev->pen;
    }
    if (r->n_path == 0u) {
        path_add(r, r->last_x, r->last_y, ev->pen);
    } else {
        const struct pk_sim_path_pt *lp = &r->path[r->n_path - 1u];
        if (hypot(x - lp->x_um, y - lp->y_um) >= 100.0)
            path_add(r, x, y, ev->pen);
    }
    r->last_x = x;
    r->last_y = y;
}

/* Every pin edge: decoder, and the CSV file if asked. */
static void on_edge(void *arg, const struct pk_trace_edge *e)
{
    struct pk_sim_result *r = arg;
    (void)pk_decoder_push(&r->decoder, e);
    if (r->opts.trace_csv != NULL)
        pk_trace_csv_row(r->opts.trace_csv, e, r->opts.cfg->tick_hz, r->shared_enable);
}

int pk_sim_start(const struct pk_sim_opts *o, struct pk_sim_result *r)
{
    const struct pk_sim_cfg *c = o->cfg;

    memset(r, 0, sizeof *r);
    r->deviation_um = -1.0;
    r->last_pen = -1;
    r->opts = *o;
    if (pk_sim_cfg_motion(c, &r->mcfg, r->err, sizeof r->err) != 0) {
        r->setup_failed = 1;
        return -1;
    }
    pk_sim_default_board(&r->board, o->chip, c->axes);
    r->shared_enable = r->board.enables == 1u;

    struct pk_decode_cfg dc;
    pk_sim_board_decode_cfg(&r->board, c->tick_hz, &o->lim, &dc);
    pk_decoder_init(&r->decoder, &dc, &r->dec, o->keep_events);
    r->decoder.on_step = on_step;
    r->decoder.on_step_arg = r;
    unsigned win = o->rate_window ? o->rate_window : 16u;
    for (unsigned a = 0; a < PK_AXES; a++)
        pk_rate_init(&r->rate[a], c->tick_hz, win);
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
    int rc = pk_machine_init(&r->m, &r->mcfg, &r->hw.hal);
    if (rc != PK_MOTION_OK) {
        snprintf(r->err, sizeof r->err, "machine init failed (%d)%s%s", rc,
                 *pk_hal_error_text(&r->hw.hal) ? ": " : "", pk_hal_error_text(&r->hw.hal));
        r->setup_failed = 1;
        return -1;
    }
    if (o->program_file != NULL) {
        if (pk_sim_job_init_file(&r->job, &r->m, c, o->program_file) != 0) {
            snprintf(r->err, sizeof r->err, "cannot read the program: %s", strerror(errno));
            r->setup_failed = 1;
            return -1;
        }
    } else {
        pk_sim_job_init(&r->job, &r->m, c, o->program, o->len);
    }
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
    int st = r->opts.main_fn != NULL ? pk_sim_sched_run(&r->hw.sched, r->opts.main_fn, r->opts.main_arg, slice)
                                     : pk_sim_sched_run(&r->hw.sched, pk_sim_job_main, &r->job, slice);
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
    if (r->step_pending)
        measure(r);
    r->step_pending = 0;
    if (r->n_path > 0u)
        path_add(r, r->last_x, r->last_y, r->last_pen);
    for (unsigned a = 0; a < c->axes && a < PK_AXES; a++) {
        double spmm = (double)r->mcfg.steps_per_mm_q16[a] / 65536.0;
        r->max_speed_mm_s[a] = r->rate[a].max_speed / spmm;
        r->max_accel_mm_s2[a] = r->rate[a].max_accel / spmm;
    }
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
    free(r->path);
    r->path = NULL;
    r->n_path = r->cap_path = 0;
    pk_decoded_free(&r->dec);
    pk_sim_job_free(&r->job);
}
