/*
 * motion_run.c — simulated main loop for the motion core (see motion_run.h).
 */
#include <stdlib.h>
#include <string.h>
#include "motion_run.h"

static int offer(struct pk_machine *m, const struct pk_mrun_op *op)
{
    switch (op->type) {
    case MR_FEED: return pk_machine_move(m, op->p, op->arg, PK_MOVE_FEED);
    case MR_RAPID: return pk_machine_move(m, op->p, 0, PK_MOVE_RAPID);
    case MR_PEN_DOWN: return pk_machine_pen(m, true);
    case MR_PEN_UP: return pk_machine_pen(m, false);
    case MR_DWELL: return pk_machine_dwell(m, op->arg);
    case MR_SMOOTH: return pk_machine_set_smoothing(m, &op->smooth);
    default: return pk_machine_end(m);
    }
}

struct yflag {
    bool on;
};

static bool yflag_get(void *ctx)
{
    return ((const struct yflag *)ctx)->on;
}

struct pk_mrun_result pk_mrun(struct pk_machine *m, struct pk_rec *rec,
                              const struct pk_mrun_op *ops, size_t n,
                              const struct pk_mrun_opts *o)
{
    struct pk_mrun_result res;
    memset(&res, 0, sizeof res);
    uint64_t tick_hz = rec->hal.tick_hz;
    uint64_t poll = o && o->poll_ticks ? o->poll_ticks : tick_hz / 50000u;
    uint32_t every = o && o->feed_every ? o->feed_every : 1u;
    size_t limit = o && o->stop_after ? o->stop_after : n;
    uint64_t maxt = rec->now + (o && o->max_ticks ? o->max_ticks : tick_hz * 600u);
    uint64_t hold_at = o ? o->hold_at : 0, resume_at = o ? o->resume_at : 0;
    uint64_t ovr_at = o ? o->ovr_at : 0;
    if (poll == 0)
        poll = 1;
    uint32_t yield_every = o ? o->yield_every : 0;
    struct yflag yf = { 0 };
    if (yield_every)
        pk_machine_set_yield(m, yflag_get, &yf);
    size_t i = 0;
    for (uint64_t k = 0;; k++) {
        if (hold_at && rec->now >= hold_at) {
            pk_machine_hold(m);
            hold_at = 0;
        }
        if (resume_at && !hold_at && rec->now >= resume_at) {
            pk_machine_resume(m);
            resume_at = 0;
        }
        if (ovr_at && rec->now >= ovr_at) {
            (void)pk_machine_set_override(m, o->ovr_feed_pct, o->ovr_rapid_pct);
            ovr_at = 0;
        }
        if (k % every == 0) {
            while (i < limit) {
                int r = offer(m, &ops[i]);
                if (r == PK_MOTION_EFULL) {
                    res.efull++;
                    break;
                }
                i++;
            }
        }
        if (yield_every)
            yf.on = k % yield_every == 0;
        uint32_t lp = pk_machine_lines_planned(m);
        pk_machine_poll(m);
        res.polls++;
        lp = pk_machine_lines_planned(m) - lp;
        if (lp > res.most_planned)
            res.most_planned = lp;
        enum pk_machine_state st = pk_machine_state(m);
        if (i >= limit && st == PK_STATE_IDLE && !pk_rec_armed(rec) && !resume_at)
            break;
        if (st == PK_STATE_ALARM && !pk_rec_armed(rec))
            break;
        if (rec->now >= maxt) {
            res.timed_out = 1;
            break;
        }
        pk_rec_advance(rec, rec->now + poll);
    }
    if (yield_every)
        pk_machine_set_yield(m, NULL, NULL); /* (yf goes out of scope) */
    res.end_tick = rec->now;
    res.sent = i;
    return res;
}

size_t pk_mrun_edges(const struct pk_rec *rec, unsigned axis, uint64_t **t, int8_t **dir)
{
    size_t cap = 1024, n = 0;
    *t = malloc(cap * sizeof **t);
    *dir = malloc(cap * sizeof **dir);
    uint32_t bit = 1u << axis;
    uint32_t step_raw = 0, dir_raw = 0;
    for (size_t k = 0; k < rec->n; k++) {
        const struct pk_rec_event *e = &rec->ev[k];
        if (e->kind == PK_REC_DIR && (e->mask & bit))
            dir_raw = (dir_raw & ~bit) | (e->levels & bit);
        if (e->kind != PK_REC_STEP || !(e->mask & bit))
            continue;
        uint32_t was = (step_raw ^ rec->hal.step_invert) & bit;
        step_raw = (step_raw & ~bit) | (e->levels & bit);
        uint32_t is = (step_raw ^ rec->hal.step_invert) & bit;
        if (!was && is) {
            if (n == cap) {
                cap *= 2;
                *t = realloc(*t, cap * sizeof **t);
                *dir = realloc(*dir, cap * sizeof **dir);
            }
            (*t)[n] = e->tick;
            (*dir)[n] = ((dir_raw ^ rec->hal.dir_invert) & bit) ? 1 : -1;
            n++;
        }
    }
    return n;
}
