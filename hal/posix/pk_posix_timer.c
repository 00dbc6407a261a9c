/*
 * pk_posix_timer.c — clock, one-shot timer and main loop on POSIX (see
 * pk_posix_timer.h).
 */
#include <errno.h>
#include <sched.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include "pk_posix_timer.h"

static uint64_t mono_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (uint64_t)ts.tv_sec * 1000000000u + (uint64_t)ts.tv_nsec;
}

void pk_posix_timer_init(struct pk_posix_timer *p, uint32_t tick_hz)
{
    memset(p, 0, sizeof *p);
    p->tick_hz = tick_hz ? tick_hz : 1000000u;
    p->origin_ns = mono_ns();
}

static uint64_t op_clock_ticks(void *ctx)
{
    struct pk_posix_timer *p = ctx;
    uint64_t ns = mono_ns() - p->origin_ns;
    /* ticks = ns * hz / 1e9, split to stay inside 64 bits for years */
    return ns / 1000000000u * p->tick_hz + ns % 1000000000u * p->tick_hz / 1000000000u;
}

static int op_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick)
{
    struct pk_posix_timer *p = ctx;
    if (cb == NULL)
        return PK_HAL_EINVAL;
    p->cb = cb;
    p->cb_arg = arg;
    p->due = first_tick;
    p->armed = 1;
    p->generation++;
    p->starts++;
    return PK_HAL_OK;
}

static int op_timer_stop(void *ctx)
{
    struct pk_posix_timer *p = ctx;
    p->armed = 0;
    p->generation++;
    return PK_HAL_OK;
}

static uint32_t op_irq_save(void *ctx)
{
    struct pk_posix_timer *p = ctx;
    return p->irq_depth++;
}

static void op_irq_restore(void *ctx, uint32_t token)
{
    struct pk_posix_timer *p = ctx;
    p->irq_depth = token;
}

static const struct pk_hal_ops posix_ops = {
    .version = PK_HAL_VERSION,
    .timer_start = op_timer_start,
    .timer_stop = op_timer_stop,
    .clock_ticks = op_clock_ticks,
    .irq_save = op_irq_save,
    .irq_restore = op_irq_restore,
};

void pk_posix_timer_hal(struct pk_posix_timer *p, struct pk_hal *out)
{
    memset(out, 0, sizeof *out);
    out->ops = &posix_ops;
    out->ctx = p;
    out->tick_hz = p->tick_hz;
}

int pk_posix_run(struct pk_posix_timer *p, pk_posix_main_fn main_fn, void *arg,
                 volatile int *stop)
{
    const uint64_t ms = p->tick_hz / 1000u ? p->tick_hz / 1000u : 1u;
    const uint64_t spin = p->tick_hz / 10000u ? p->tick_hz / 10000u : 1u; /* 100 us */
    for (;;) {
        if (stop != NULL && *stop)
            return 1;
        if (p->irq_poll != NULL)
            p->irq_poll(p->irq_arg);
        uint64_t t_main = op_clock_ticks(p);
        int st = main_fn(arg, t_main);
        t_main = op_clock_ticks(p) - t_main;
        if (t_main > p->main_max)
            p->main_max = t_main; /* a callback due meanwhile waited this long */
        if (st < 0 && !p->armed)
            return 0;
        /* Run every callback that is due; give the main loop a turn at least
         * every millisecond. */
        uint64_t now = op_clock_ticks(p), until = now + ms;
        while (p->armed && now < until) {
            if (p->irq_poll != NULL)
                p->irq_poll(p->irq_arg);
            /* Never closer than min_gap_ticks to the previous callback: after
             * a late one, the next edge keeps the driver's minimum spacing. */
            uint64_t at = p->due;
            if (p->min_gap_ticks != 0u && p->ran_at + p->min_gap_ticks > at)
                at = p->ran_at + p->min_gap_ticks;
            if (at > now) {
                if (st <= 0 && at - now > spin) {
                    /* Sleep until `spin` before it, then spin the rest: a
                     * SCHED_FIFO loop that only spun would use 100% of its
                     * core and be throttled by the kernel (sched_rt_runtime_us:
                     * 50 ms stalls every second, measured by bench-gpiod). */
                    uint64_t wake = at - spin < until ? at - spin : until;
                    uint64_t ns = p->origin_ns + wake / p->tick_hz * 1000000000u +
                                  wake % p->tick_hz * 1000000000u / p->tick_hz;
                    struct timespec ts = { (time_t)(ns / 1000000000u), (long)(ns % 1000000000u) };
                    clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
                }
                now = op_clock_ticks(p);
                if (at > now && st > 0)
                    break; /* main has work: do it, come back */
                continue;
            }
            if (now - p->due > p->late_max)
                p->late_max = now - p->due;
            uint32_t gen = p->generation;
            p->running_due = p->due;
            p->in_cb = 1;
            p->callbacks++;
            /* The callback gets the tick it really runs at (as the AVR and
             * Cortex-M timers pass theirs): a late step then still gets its
             * full pulse width and the step generator moves its schedule
             * rather than firing the missed steps back to back. */
            uint64_t next = p->cb(p->cb_arg, now);
            p->in_cb = 0;
            if (p->generation == gen) {
                if (next == 0u)
                    p->armed = 0;
                else
                    p->due = next;
            }
            /* After the callback: its edges are written by now, even if the
             * process was preempted inside it. */
            now = op_clock_ticks(p);
            p->ran_at = now;
        }
        if (!p->armed && st == 0) {
            struct timespec nap = { 0, 500000 }; /* nothing scheduled: 0.5 ms */
            nanosleep(&nap, NULL);
        }
    }
}

uint64_t pk_posix_timer_ns(const struct pk_posix_timer *p) { return mono_ns() - p->origin_ns; }

int pk_posix_realtime(int *sched_err, int *lock_err)
{
    struct sched_param sp;
    memset(&sp, 0, sizeof sp);
    sp.sched_priority = sched_get_priority_max(SCHED_FIFO) / 2;
    *sched_err = sched_setscheduler(0, SCHED_FIFO, &sp) != 0 ? errno : 0;
    *lock_err = mlockall(MCL_CURRENT | MCL_FUTURE) != 0 ? errno : 0;
    return *sched_err == 0 && *lock_err == 0 ? 0 : -1;
}
