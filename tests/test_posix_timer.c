/*
 * test_posix_timer.c — the Linux board's real-time loop (hal/posix/
 * pk_posix_timer.h) on the real clock: the invariants a step generator
 * relies on, which hold however loaded the machine is (no timing threshold):
 *   - a callback is told the tick it really runs at, never one before its
 *     scheduled tick (a late step still gets its full pulse width);
 *   - after any callback, the next one starts at least min_gap_ticks after
 *     the previous one returned, even when it asked to run at once (a late
 *     pulse's fall is never followed at once by the next rise);
 *   - the loop ends when the main function is done and the timer stopped,
 *     or when the stop flag is raised; it counts starts and callbacks.
 */
#include <stdint.h>
#include <string.h>
#include "posix/pk_posix_timer.h"
#include "th.h"

#define CALLS 200

struct rec {
    const struct pk_hal *hal;
    const struct pk_posix_timer *p;
    unsigned n;
    uint64_t now_arg[CALLS], due[CALLS], enter[CALLS], leave[CALLS];
};

/* Asks to run again at a tick already past (as a late step generator's
 * schedule does), CALLS times. */
static uint64_t cb_asap(void *arg, uint64_t now)
{
    struct rec *r = arg;
    unsigned k = r->n++;
    r->enter[k] = r->hal->ops->clock_ticks(r->hal->ctx);
    r->now_arg[k] = now;
    r->due[k] = r->p->running_due;
    r->leave[k] = r->hal->ops->clock_ticks(r->hal->ctx);
    return r->n < CALLS ? (now > 5u ? now - 5u : 1u) : 0u;
}

static int main_done(void *arg, uint64_t now)
{
    (void)arg;
    (void)now;
    return -1;
}

static void run_asap(struct pk_posix_timer *p, struct rec *r, uint64_t gap)
{
    struct pk_hal hal;
    pk_posix_timer_init(p, 1000000u);
    pk_posix_timer_hal(p, &hal);
    p->min_gap_ticks = gap;
    memset(r, 0, sizeof *r);
    r->hal = &hal;
    r->p = p;
    TH_ASSERT_EQ(hal.ops->timer_start(hal.ctx, cb_asap, r, hal.ops->clock_ticks(hal.ctx) + 10u), PK_HAL_OK);
    TH_ASSERT_EQ(pk_posix_run(p, main_done, NULL, NULL), 0);
}

static void test_a_callback_gets_the_tick_it_runs_at_never_before_its_own(void)
{
    static struct pk_posix_timer p;
    static struct rec r;
    run_asap(&p, &r, 0u);
    TH_ASSERT_EQ(r.n, CALLS);
    unsigned bad = 0;
    for (unsigned k = 0; k < CALLS; k++)
        bad += r.now_arg[k] < r.due[k] || r.now_arg[k] > r.enter[k] ||
               (k > 0 && r.now_arg[k] < r.leave[k - 1]); /* time never runs back */
    TH_EXPECT_EQ(bad, 0);
    TH_EXPECT_EQ(p.starts, 1);
    TH_EXPECT_EQ(p.callbacks, CALLS);
    TH_EXPECT(!p.armed && !p.in_cb);
}

static void test_callbacks_keep_the_minimum_gap_after_the_previous_return(void)
{
    static struct pk_posix_timer p;
    static struct rec r;
    run_asap(&p, &r, 50u);
    TH_ASSERT_EQ(r.n, CALLS);
    unsigned bad = 0;
    for (unsigned k = 1; k < CALLS; k++)
        bad += r.enter[k] < r.leave[k - 1] + 50u;
    TH_EXPECT_EQ(bad, 0);
    /* CALLS - 1 gaps of at least 50 ticks: the run cannot be shorter. */
    TH_EXPECT(r.enter[CALLS - 1] - r.enter[0] >= (uint64_t)(CALLS - 1) * 50u);
}

static uint64_t cb_forever(void *arg, uint64_t now)
{
    (void)arg;
    return now + 100u;
}

static int main_stops(void *arg, uint64_t now)
{
    volatile int *stop = arg;
    if (now > 20000u) /* 20 ms */
        *stop = 1;
    return 0;
}

static void test_the_stop_flag_ends_the_loop_with_the_timer_still_armed(void)
{
    static struct pk_posix_timer p;
    struct pk_hal hal;
    pk_posix_timer_init(&p, 1000000u);
    pk_posix_timer_hal(&p, &hal);
    static volatile int stop;
    stop = 0;
    TH_ASSERT_EQ(hal.ops->timer_start(hal.ctx, cb_forever, NULL, 1u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_posix_run(&p, main_stops, (void *)&stop, &stop), 1);
    TH_EXPECT(p.armed);
    TH_EXPECT(p.callbacks > 0u);
    TH_EXPECT(pk_posix_timer_ns(&p) >= 20000000u);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_callback_gets_the_tick_it_runs_at_never_before_its_own),
        TH_CASE(test_callbacks_keep_the_minimum_gap_after_the_previous_return),
        TH_CASE(test_the_stop_flag_ends_the_loop_with_the_timer_still_armed),
    };
    return th_run(cases, TH_COUNT(cases));
}
