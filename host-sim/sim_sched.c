/*
 * sim_sched.c — simulated clock and single-thread scheduler (see sim_sched.h).
 */
#include <string.h>
#include "sim_sched.h"

/* A callback that returns a tick <= now runs again at now; this many runs at
 * one tick means it never advances. */
#define SAME_TICK_LIMIT 100000u

void pk_sim_sched_init(struct pk_sim_sched *s, uint32_t tick_hz, uint32_t main_period)
{
    memset(s, 0, sizeof *s);
    s->tick_hz = tick_hz;
    s->main_period = main_period ? main_period : 1u;
    s->idle_period = tick_hz / 1000u ? tick_hz / 1000u : 1u; /* 1 ms */
    s->idle_limit = (uint64_t)tick_hz * 10u;                 /* 10 s */
    s->idle_since = UINT64_MAX;
}

uint64_t pk_sim_sched_clock(void *arg)
{
    const struct pk_sim_sched *s = arg;
    return s->now;
}

static int op_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick)
{
    struct pk_sim_sched *s = ctx;
    if (cb == NULL)
        return PK_HAL_EINVAL;
    s->cb = cb;
    s->cb_arg = arg;
    s->due = first_tick > s->now ? first_tick : s->now;
    s->armed = 1;
    s->generation++;
    return PK_HAL_OK;
}

static int op_timer_stop(void *ctx)
{
    struct pk_sim_sched *s = ctx;
    s->armed = 0;
    s->generation++;
    return PK_HAL_OK;
}

static uint64_t op_clock_ticks(void *ctx)
{
    return pk_sim_sched_clock(ctx);
}

static uint32_t op_irq_save(void *ctx)
{
    struct pk_sim_sched *s = ctx;
    return s->irq_depth++;
}

static void op_irq_restore(void *ctx, uint32_t token)
{
    struct pk_sim_sched *s = ctx;
    s->irq_depth = token;
}

static const struct pk_hal_ops sched_ops = {
    .version = PK_HAL_VERSION,
    .timer_start = op_timer_start,
    .timer_stop = op_timer_stop,
    .clock_ticks = op_clock_ticks,
    .irq_save = op_irq_save,
    .irq_restore = op_irq_restore,
};

void pk_sim_sched_hal(struct pk_sim_sched *s, struct pk_hal *out)
{
    memset(out, 0, sizeof *out);
    out->ops = &sched_ops;
    out->ctx = s;
    out->tick_hz = s->tick_hz;
}

void pk_sim_sched_set_irq(struct pk_sim_sched *s, pk_sim_irq_due_fn due, pk_sim_irq_fn run, void *arg)
{
    s->irq_due = due;
    s->irq_run = run;
    s->irq_arg = arg;
}

/* Run the other source's interrupts due at or before min(until, the timer's
 * next tick). Returns 0, or -1 if it never stops asking at one tick. */
static int run_irqs(struct pk_sim_sched *s, uint64_t until)
{
    if (s->irq_due == NULL)
        return 0;
    uint64_t lim = s->armed && s->due < until ? s->due : until;
    for (uint32_t same = 0;; same++) {
        uint64_t at = s->irq_due(s->irq_arg, s->now);
        if (at > lim)
            return 0;
        if (same >= SAME_TICK_LIMIT)
            return -1;
        if (at > s->now)
            s->now = at;
        s->in_callback = 1;
        s->irq_run(s->irq_arg, s->now);
        s->in_callback = 0;
        s->irqs++;
    }
}

int pk_sim_sched_advance(struct pk_sim_sched *s, uint64_t until)
{
    uint32_t same = 0;
    uint64_t last = UINT64_MAX;

    for (;;) {
        if (run_irqs(s, until) != 0)
            return PK_SIM_RUN_RUNAWAY;
        if (!(s->armed && s->due <= until))
            break;
        s->now = s->due;
        same = s->now == last ? same + 1u : 0u;
        last = s->now;
        if (same >= SAME_TICK_LIMIT) {
            s->armed = 0;
            return PK_SIM_RUN_RUNAWAY;
        }
        uint32_t gen = s->generation;
        s->in_callback = 1;
        uint64_t next = s->cb(s->cb_arg, s->now);
        s->in_callback = 0;
        s->callbacks++;
        if (s->generation != gen)
            continue; /* stopped or restarted from inside the callback */
        if (next == 0u)
            s->armed = 0;
        else
            s->due = next > s->now ? next : s->now;
    }
    if (until > s->now)
        s->now = until;
    return PK_SIM_RUN_FINISHED;
}

int pk_sim_sched_run(struct pk_sim_sched *s, pk_sim_main_fn main_fn, void *arg, uint64_t max_ticks)
{
    uint64_t limit = max_ticks ? s->now + max_ticks : UINT64_MAX;

    for (;;) {
        if (s->now >= s->main_due) {
            uint32_t depth = s->irq_depth;
            int st = main_fn(arg, s->now);
            s->main_iterations++;
            if (s->irq_depth != depth)
                return PK_SIM_RUN_IRQ_IMBALANCE;
            if (st == PK_SIM_DONE && !s->armed)
                return PK_SIM_RUN_FINISHED;
            if (st == PK_SIM_BUSY) {
                s->main_due = s->now + s->main_period;
                s->idle_since = UINT64_MAX;
            } else if (s->armed) {
                /* Idle: sleep until the next callback (the "wfi" of the sim). */
                s->main_due = s->due > s->now ? s->due : s->now;
                s->idle_since = UINT64_MAX;
            } else {
                if (s->idle_since == UINT64_MAX)
                    s->idle_since = s->now;
                else if (s->now - s->idle_since >= s->idle_limit)
                    return PK_SIM_RUN_STUCK;
                s->main_due = s->now + s->idle_period;
            }
        }
        uint64_t target = s->main_due < limit ? s->main_due : limit;
        if (pk_sim_sched_advance(s, target) != PK_SIM_RUN_FINISHED)
            return PK_SIM_RUN_RUNAWAY;
        if (s->now >= limit)
            return PK_SIM_RUN_TIME_LIMIT;
    }
}
