/*
 * test_sim.c — the simulator's clock/scheduler, the pin trace and its decoder
 * with the driver timing checks, using a small scripted pulse generator that
 * drives the real gpiod backend over the libgpiod mock (the motion core is
 * tested end to end in tests/test_sim_e2e.c).
 */
#define _GNU_SOURCE 1 /* open_memstream is POSIX 2008; glibc wants this too */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "sim_machine.h"

/* ---- a scripted pulse generator: the firmware stand-in ----------------- */
struct toy_step { uint8_t axis; int8_t dir; };
struct toy {
    const struct pk_hal *hal;
    const struct toy_step *script;
    unsigned n, i;
    uint32_t high, low, setup; /* ticks */
    uint8_t phase;             /* 0: next step due, 1: pulse high */
    uint8_t dir;               /* logical dir bits as written */
    int hal_errors;
};

static uint64_t toy_cb(void *arg, uint64_t now)
{
    struct toy *t = arg;
    if (t->phase == 1) {
        t->hal_errors += pk_hal_step_write(t->hal, 0xFu, 0u) != 0;
        t->phase = 0;
        if (++t->i == t->n)
            return 0;
        return now + t->low;
    }
    const struct toy_step *s = &t->script[t->i];
    uint8_t want = (uint8_t)(s->dir > 0 ? t->dir | (1u << s->axis) : t->dir & ~(1u << s->axis));
    if (want != t->dir) {
        t->hal_errors += pk_hal_dir_write(t->hal, 0xFu, want) != 0;
        t->dir = want;
        return now + t->setup; /* step after the set-up time */
    }
    t->hal_errors += pk_hal_step_write(t->hal, 1u << s->axis, 1u << s->axis) != 0;
    t->phase = 1;
    return now + t->high;
}

static struct toy_step script[300];
static unsigned script_len;

static void make_script(void)
{
    script_len = 0;
    for (int i = 0; i < 100; i++)
        script[script_len++] = (struct toy_step){ 0, +1 };
    for (int i = 0; i < 30; i++)
        script[script_len++] = (struct toy_step){ 1, +1 };
    for (int i = 0; i < 40; i++)
        script[script_len++] = (struct toy_step){ 0, -1 };
}

static const struct pk_timing_limits drv8825 = PK_TIMING_DRV8825;

static int open_hw(struct pk_sim_hw *w, const char *name, uint32_t step_invert)
{
    struct pk_gpiod_cfg cfg;
    char err[160];
    pk_sim_default_board(&cfg, name, 2);
    cfg.step_invert = step_invert;
    return pk_sim_hw_open(w, &cfg, 1000000u, 50u, NULL, err, sizeof err);
}

static void run_toy(struct pk_sim_hw *w, struct toy *t, uint32_t high, uint32_t low)
{
    memset(t, 0, sizeof *t);
    t->hal = &w->hal;
    t->script = script;
    t->n = script_len;
    t->high = high;
    t->low = low;
    t->setup = 1;
    w->hal.ops->timer_start(w->hal.ctx, toy_cb, t, 100u);
    pk_sim_sched_advance(&w->sched, 1000000u);
}

/* ---- scheduler ----------------------------------------------------------- */
struct sched_log { uint64_t at[16]; unsigned n; uint64_t next[16]; struct pk_sim_sched *s; int stop_inside; };

static uint64_t log_cb(void *arg, uint64_t now)
{
    struct sched_log *l = arg;
    l->at[l->n] = now;
    uint64_t nx = l->next[l->n++];
    if (l->stop_inside && l->n == 2) {
        struct pk_hal h;
        pk_sim_sched_hal(l->s, &h);
        h.ops->timer_stop(h.ctx);
        return now + 5u; /* asks for more, but the stop must win */
    }
    return nx;
}

static void test_callbacks_run_at_exactly_the_ticks_they_ask_for(void)
{
    struct pk_sim_sched s;
    struct pk_hal h;
    struct sched_log l = { .next = { 250, 251, 251, 900, 0 } };
    pk_sim_sched_init(&s, 1000000u, 100u);
    pk_sim_sched_hal(&s, &h);
    TH_ASSERT_EQ(h.ops->timer_start(h.ctx, log_cb, &l, 7u), PK_HAL_OK);
    TH_ASSERT_EQ(pk_sim_sched_advance(&s, 10000u), PK_SIM_RUN_FINISHED);
    TH_ASSERT_EQ(l.n, 5);
    static const uint64_t want[] = { 7, 250, 251, 251, 900 };
    for (unsigned i = 0; i < 5; i++)
        TH_EXPECT_EQ(l.at[i], want[i]);
    TH_EXPECT_EQ(s.armed, 0);
    TH_EXPECT_EQ(s.now, 10000);
}

static void test_a_stop_inside_a_callback_sticks(void)
{
    struct pk_sim_sched s;
    struct pk_hal h;
    struct sched_log l = { .next = { 10, 20, 30, 40 }, .stop_inside = 1 };
    pk_sim_sched_init(&s, 1000000u, 100u);
    pk_sim_sched_hal(&s, &h);
    l.s = &s;
    h.ops->timer_start(h.ctx, log_cb, &l, 1u);
    pk_sim_sched_advance(&s, 1000u);
    TH_EXPECT_EQ(l.n, 2);
    TH_EXPECT_EQ(s.armed, 0);
}

static uint64_t stuck_cb(void *arg, uint64_t now)
{
    (void)arg;
    return now; /* never advances */
}

static void test_a_callback_that_never_advances_is_caught(void)
{
    struct pk_sim_sched s;
    struct pk_hal h;
    pk_sim_sched_init(&s, 1000000u, 100u);
    pk_sim_sched_hal(&s, &h);
    h.ops->timer_start(h.ctx, stuck_cb, NULL, 5u);
    TH_EXPECT_EQ(pk_sim_sched_advance(&s, 100u), PK_SIM_RUN_RUNAWAY);
    TH_EXPECT_EQ(s.armed, 0);
}

struct main_log { unsigned iters; uint64_t last; struct pk_hal *h; int started; unsigned cbs; };

static uint64_t count_cb(void *arg, uint64_t now)
{
    struct main_log *m = arg;
    m->cbs++;
    return m->cbs < 10u ? now + 1000u : 0u;
}

static int main_fn(void *arg, uint64_t now)
{
    struct main_log *m = arg;
    m->iters++;
    m->last = now;
    if (!m->started) {
        m->started = 1;
        m->h->ops->timer_start(m->h->ctx, count_cb, m, now + 1000u);
        return PK_SIM_BUSY;
    }
    return m->cbs < 10u ? PK_SIM_IDLE : PK_SIM_DONE;
}

static void test_an_idle_main_loop_sleeps_until_the_next_callback(void)
{
    struct pk_sim_sched s;
    struct pk_hal h;
    struct main_log m = { 0 };
    pk_sim_sched_init(&s, 1000000u, 100u);
    pk_sim_sched_hal(&s, &h);
    m.h = &h;
    TH_ASSERT_EQ(pk_sim_sched_run(&s, main_fn, &m, 0), PK_SIM_RUN_FINISHED);
    TH_EXPECT_EQ(m.cbs, 10);
    /* busy at 0, idle at 100 (one main period later), then one iteration
     * per callback: no polling in between */
    TH_EXPECT_EQ(m.iters, 12);
    TH_EXPECT_EQ(s.now, 10000);
}

static int never_done(void *arg, uint64_t now)
{
    (void)arg;
    (void)now;
    return PK_SIM_IDLE;
}

static void test_a_main_loop_that_waits_forever_is_reported_stuck(void)
{
    struct pk_sim_sched s;
    pk_sim_sched_init(&s, 1000u, 1u);
    TH_EXPECT_EQ(pk_sim_sched_run(&s, never_done, NULL, 0), PK_SIM_RUN_STUCK);
    TH_EXPECT_EQ(s.now, 10000); /* idle_limit: 10 s of 1 kHz ticks */
    pk_sim_sched_init(&s, 1000u, 1u);
    TH_EXPECT_EQ(pk_sim_sched_run(&s, never_done, NULL, 500u), PK_SIM_RUN_TIME_LIMIT);
    TH_EXPECT_EQ(s.now, 500);
}

/* ---- decoder ----------------------------------------------------------- */
static void test_decoded_steps_follow_step_and_dir_edges(void)
{
    static struct pk_sim_hw w;
    struct toy t;
    struct pk_decode_cfg dc;
    struct pk_decoded d;
    make_script();
    TH_ASSERT_EQ(open_hw(&w, "sim-dec", 0u), PK_HAL_OK);
    run_toy(&w, &t, 2u, 3u);
    TH_EXPECT_EQ(t.hal_errors, 0);
    pk_sim_hw_decode_cfg(&w, &drv8825, &dc);
    TH_ASSERT_EQ(pk_decode(&w.trace, &dc, &d), 0);
    TH_EXPECT_EQ(d.pos[0], 60);
    TH_EXPECT_EQ(d.pos[1], 30);
    TH_EXPECT_EQ(d.steps[0], 140);
    TH_EXPECT_EQ(d.steps[1], 30);
    TH_EXPECT_EQ(d.n_ev, 170);
    TH_EXPECT_EQ(d.n_viol, 0);
    pk_decoded_free(&d);
    pk_sim_hw_close(&w);
}

static void test_active_low_step_lines_decode_the_same(void)
{
    static struct pk_sim_hw w;
    struct toy t;
    struct pk_decode_cfg dc;
    struct pk_decoded d;
    make_script();
    TH_ASSERT_EQ(open_hw(&w, "sim-inv", 3u), PK_HAL_OK);
    TH_EXPECT_EQ(pk_gpiod_mock_value(&w.chip, 0), 1); /* idle high */
    run_toy(&w, &t, 2u, 3u);
    pk_sim_hw_decode_cfg(&w, &drv8825, &dc);
    TH_ASSERT_EQ(pk_decode(&w.trace, &dc, &d), 0);
    TH_EXPECT_EQ(d.pos[0], 60);
    TH_EXPECT_EQ(d.pos[1], 30);
    TH_EXPECT_EQ(d.n_viol, 0);
    pk_decoded_free(&d);
    pk_sim_hw_close(&w);
}

static void test_every_timing_violation_is_reported_with_its_measure(void)
{
    /* 10 MHz ticks: 1 tick = 100 ns. Hand-made trace on axis X. */
    struct pk_trace tr;
    struct pk_decode_cfg dc = { .tick_hz = 10000000u, .axes = 2, .lim = PK_TIMING_DRV8825 };
    struct pk_decoded d;
    pk_trace_init(&tr, dc.tick_hz);
    pk_trace_add(&tr, 0, PK_SIG_STEP, 0, 0, 1);
    pk_trace_add(&tr, 0, PK_SIG_DIR, 0, 1, 1);
    pk_trace_add(&tr, 100, PK_SIG_STEP, 0, 1, 0);  /* step 1 */
    pk_trace_add(&tr, 110, PK_SIG_STEP, 0, 0, 0);  /* high 1000 ns < 1900: HIGH */
    pk_trace_add(&tr, 125, PK_SIG_STEP, 0, 1, 0);  /* low 1500 ns < 1900: LOW; step 2 */
    pk_trace_add(&tr, 130, PK_SIG_DIR, 0, 0, 0);   /* 500 ns after the edge < 650: HOLD */
    pk_trace_add(&tr, 150, PK_SIG_STEP, 0, 0, 0);  /* high 2500: fine */
    pk_trace_add(&tr, 170, PK_SIG_STEP, 0, 1, 0);  /* 4000 ns after dir: fine; step 3 (back) */
    pk_trace_add(&tr, 200, PK_SIG_STEP, 0, 0, 0);
    pk_trace_add(&tr, 250, PK_SIG_DIR, 0, 1, 0);   /* dir change */
    pk_trace_add(&tr, 253, PK_SIG_STEP, 0, 1, 0);  /* 300 ns after dir < 650: SETUP; step 4 */
    pk_trace_add(&tr, 280, PK_SIG_STEP, 0, 0, 0);
    TH_ASSERT_EQ(pk_decode(&tr, &dc, &d), 0);
    TH_EXPECT_EQ(d.steps[0], 4);
    TH_EXPECT_EQ(d.pos[0], 1 + 1 - 1 + 1);
    TH_ASSERT_EQ(d.n_viol, 4);
    static const struct { uint8_t kind; uint64_t t, got; uint32_t lim; } want[] = {
        { PK_VIOL_HIGH, 110, 1000, 1900 },
        { PK_VIOL_LOW, 125, 1500, 1900 },
        { PK_VIOL_HOLD, 130, 500, 650 },
        { PK_VIOL_SETUP, 253, 300, 650 },
    };
    for (unsigned i = 0; i < 4; i++) {
        TH_EXPECT_EQ(d.viol[i].kind, want[i].kind);
        TH_EXPECT_EQ(d.viol[i].t, want[i].t);
        TH_EXPECT_EQ(d.viol[i].got_ns, want[i].got);
        TH_EXPECT_EQ(d.viol[i].limit_ns, want[i].lim);
        TH_EXPECT_EQ(d.viol[i].axis, 0);
    }
    pk_decoded_free(&d);
    pk_trace_free(&tr);
}

static void test_pulses_too_short_for_the_driver_are_all_caught(void)
{
    static struct pk_sim_hw w;
    struct toy t;
    struct pk_decode_cfg dc;
    struct pk_decoded d;
    make_script();
    TH_ASSERT_EQ(open_hw(&w, "sim-short", 0u), PK_HAL_OK);
    run_toy(&w, &t, 1u, 3u); /* 1 us high < 1.9 us */
    pk_sim_hw_decode_cfg(&w, &drv8825, &dc);
    TH_ASSERT_EQ(pk_decode(&w.trace, &dc, &d), 0);
    TH_EXPECT_EQ(d.n_viol, 170); /* every pulse, none forgotten */
    pk_decoded_free(&d);
    pk_sim_hw_close(&w);
}

static char *trace_text(struct pk_sim_hw *w, size_t *len)
{
    char *buf = NULL;
    FILE *f = open_memstream(&buf, len);
    if (f == NULL)
        return NULL;
    pk_trace_write_csv(&w->trace, f, 1);
    fclose(f);
    return buf;
}

static void test_the_same_run_gives_the_same_trace_byte_for_byte(void)
{
    static struct pk_sim_hw w;
    struct toy t;
    char *a, *b, *c;
    size_t na, nb, nc;
    make_script();
    TH_ASSERT_EQ(open_hw(&w, "sim-det", 0u), PK_HAL_OK);
    run_toy(&w, &t, 2u, 3u);
    a = trace_text(&w, &na);
    pk_sim_hw_close(&w);
    TH_ASSERT_EQ(open_hw(&w, "sim-det", 0u), PK_HAL_OK);
    run_toy(&w, &t, 2u, 3u);
    b = trace_text(&w, &nb);
    pk_sim_hw_close(&w);
    TH_ASSERT_EQ(open_hw(&w, "sim-det", 0u), PK_HAL_OK);
    run_toy(&w, &t, 2u, 4u); /* a different input must show */
    c = trace_text(&w, &nc);
    pk_sim_hw_close(&w);
    TH_ASSERT(a && b && c);
    TH_EXPECT(na > 1000u);
    TH_EXPECT(na == nb && memcmp(a, b, na) == 0);
    TH_EXPECT(!(na == nc && memcmp(a, c, na) == 0));
    /* the first step: dir at 100, step edge one set-up tick later */
    TH_EXPECT(strstr(a, "tick,time_s,signal,level,initial\n") != NULL);
    TH_EXPECT(strstr(a, "\n101,0.000101000,X.step,1,0\n") != NULL);
    free(a);
    free(b);
    free(c);
}

static void test_two_machines_in_one_process_do_not_disturb_each_other(void)
{
    static struct pk_sim_hw a, b;
    static struct toy_step sb[50];
    struct toy ta, tb;
    struct pk_decode_cfg dc;
    struct pk_decoded da, db;
    make_script();
    for (unsigned i = 0; i < 50; i++)
        sb[i] = (struct toy_step){ 1, -1 };
    TH_ASSERT_EQ(open_hw(&a, "sim-a", 0u), PK_HAL_OK);
    TH_ASSERT_EQ(open_hw(&b, "sim-b", 2u), PK_HAL_OK);
    memset(&ta, 0, sizeof ta);
    memset(&tb, 0, sizeof tb);
    ta = (struct toy){ .hal = &a.hal, .script = script, .n = script_len, .high = 2, .low = 3, .setup = 1 };
    tb = (struct toy){ .hal = &b.hal, .script = sb, .n = 50, .high = 3, .low = 7, .setup = 2 };
    a.hal.ops->timer_start(a.hal.ctx, toy_cb, &ta, 10u);
    b.hal.ops->timer_start(b.hal.ctx, toy_cb, &tb, 13u);
    b.chip.fail_set_nth = 31; /* machine B fails mid-run; A must not notice */
    for (uint64_t t = 0; t <= 5000u; t += 7u) { /* interleave the two clocks */
        pk_sim_sched_advance(&a.sched, t);
        pk_sim_sched_advance(&b.sched, t);
    }
    pk_sim_hw_decode_cfg(&a, &drv8825, &dc);
    TH_ASSERT_EQ(pk_decode(&a.trace, &dc, &da), 0);
    pk_sim_hw_decode_cfg(&b, &drv8825, &dc);
    TH_ASSERT_EQ(pk_decode(&b.trace, &dc, &db), 0);
    TH_EXPECT_EQ(ta.hal_errors, 0);
    TH_EXPECT_EQ(tb.hal_errors, 1);
    TH_EXPECT_EQ(da.pos[0], 60);
    TH_EXPECT_EQ(da.pos[1], 30);
    TH_EXPECT_EQ(db.pos[0], 0);
    /* the 31st write (lowering B's 15th pulse) failed: the line stayed
     * high, so B's 16th raise was no edge — one pulse fewer */
    TH_EXPECT_EQ(db.pos[1], -49);
    TH_EXPECT_EQ(a.chip.set_failures, 0);
    TH_EXPECT_EQ(b.chip.set_failures, 1);
    pk_decoded_free(&da);
    pk_decoded_free(&db);
    pk_sim_hw_close(&a);
    pk_sim_hw_close(&b);
}

int th_main(int argc, char **argv);
int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_callbacks_run_at_exactly_the_ticks_they_ask_for),
        TH_CASE(test_a_stop_inside_a_callback_sticks),
        TH_CASE(test_a_callback_that_never_advances_is_caught),
        TH_CASE(test_an_idle_main_loop_sleeps_until_the_next_callback),
        TH_CASE(test_a_main_loop_that_waits_forever_is_reported_stuck),
        TH_CASE(test_decoded_steps_follow_step_and_dir_edges),
        TH_CASE(test_active_low_step_lines_decode_the_same),
        TH_CASE(test_every_timing_violation_is_reported_with_its_measure),
        TH_CASE(test_pulses_too_short_for_the_driver_are_all_caught),
        TH_CASE(test_the_same_run_gives_the_same_trace_byte_for_byte),
        TH_CASE(test_two_machines_in_one_process_do_not_disturb_each_other),
    };
    return th_run(cases, TH_COUNT(cases));
}
