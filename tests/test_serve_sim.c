/*
 * test_serve_sim.c — the machine behind `plotkin serve` (host-sim/serve_sim.h)
 * is `plotkin sim`'s: a program sent line by line to the Grbl engine ends on
 * exactly the steps `plotkin sim` decodes for the same program, with the
 * same timing checks and the same path deviation, and the summary's counters
 * (lines, errors by line, alarms) come from the session. Deterministic: simulated time only.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "serve_sim.h"

int th_main(int argc, char **argv);

static const char prog[] = "G21 G90\n"
                           "G64 P0.02\n"
                           "M3\n"
                           "G1 X10 Y0 F3000\n"
                           "G1 X12.5 Y5 Q3\n" /* Q outside G5: error, nothing of it runs */
                           "G1 X12.5 Y5\n"
                           "G5 I2 J0 P-2 Q0 X20 Y7.25\n"
                           "M5\n"
                           "G0 X30.0125 Y7.25\n";

static void send_all(struct pk_serve_sim *s, const char *text)
{
    for (const char *p = text; *p; p++) {
        for (int spins = 0; pk_uart_rx_space(&s->uart) == 0 && spins < 100000; spins++)
            TH_ASSERT_EQ(pk_serve_sim_run(s, 1000), 0);
        pk_uart_rx_push(&s->uart, (uint8_t)*p);
        pk_serve_sim_wake(s);
    }
}

static void test_a_program_sent_to_serve_ends_on_the_steps_plotkin_sim_decodes(void)
{
    static struct pk_serve_sim s;
    static struct pk_sim_result ref;
    const struct pk_timing_limits lim = PK_TIMING_DRV8825;

    TH_ASSERT_EQ(pk_serve_sim_start(&s, "test-serve0", &lim), 0);
    send_all(&s, prog);
    /* run until the engine has answered every line and the machine is idle
     * (at most 60 s simulated) */
    for (int i = 0; i < 60000; i++) {
        TH_ASSERT_EQ(pk_serve_sim_run(&s, 1000), 0);
        uint8_t b[64];
        while (pk_uart_tx_pop(&s.uart, b, sizeof b) > 0)
            ;
        if (s.g.stats.lines == 9u && pk_machine_state(&s.r.m) == PK_STATE_IDLE && !s.r.hw.sched.armed)
            break;
    }
    TH_ASSERT_EQ(s.g.stats.lines, 9u);
    TH_ASSERT_EQ(pk_serve_sim_finish(&s), 0);

    struct pk_sim_cfg cfg;
    pk_sim_cfg_default(&cfg);
    struct pk_sim_opts o = { .chip = "test-serve-ref", .cfg = &cfg, .program = prog,
                             .len = strlen(prog), .lim = lim };
    TH_ASSERT_EQ(pk_sim_run(&o, &ref), 0);

    /* Independent end point: 80 steps/mm (the default $100/$101). */
    TH_ASSERT_EQ(s.r.dec.pos[0], 2401); /* 30.0125 mm * 80 = 2401 */
    TH_ASSERT_EQ(s.r.dec.pos[1], 580);  /* 7.25 mm * 80 */
    for (int a = 0; a < PK_AXES; a++)
        TH_ASSERT_EQ(s.r.dec.pos[a], ref.dec.pos[a]);
    TH_ASSERT_EQ(s.r.dec.n_viol, 0u);
    TH_ASSERT_EQ(ref.dec.n_viol, 0u);
    /* the session's counters */
    TH_ASSERT_EQ(s.r.job.lines, 9ul);
    TH_ASSERT_EQ(s.r.job.errors, 1ul);
    TH_ASSERT_EQ(s.r.job.err[0].line, 5u);
    TH_ASSERT_EQ(s.r.job.err[0].code, 20); /* Grbl: Q is no word of its own (error 20) */
    TH_ASSERT_EQ(ref.job.errors, 1ul);
    TH_ASSERT_EQ(ref.job.err[0].line, 5u);
    TH_ASSERT_EQ(s.r.job.alarms, 0ul);
    TH_EXPECT(s.r.max_speed_mm_s[0] > 0.0);
    /* nothing of the pin trace is kept: memory stays flat */
    TH_EXPECT(s.r.hw.trace.n > 1000u); /* edges seen ... */
    TH_ASSERT_EQ(s.r.hw.trace.cap, 0u); /* ... none kept */
    TH_ASSERT_EQ(s.r.dec.n_ev, 0u);
    /* the path deviation: the same programmed path as `plotkin sim`'s, the
     * same executed steps, hence the same figures, bit for bit; the corners
     * rounded within G64 P0.02 give a deviation that is not 0 */
    TH_EXPECT(s.r.prog.st.points > 0u);
    TH_EXPECT(s.r.deviation_um > 0.0 && s.r.deviation_um <= 20.0 + 1.0);
    TH_EXPECT(s.r.deviation_um == ref.deviation_um);
    TH_EXPECT(s.r.deviation_p95_um == ref.deviation_p95_um);
    TH_EXPECT_EQ(s.r.prog.st.forced_drops, 0u);
    TH_EXPECT_EQ(s.r.prog.st.max_line, ref.prog.st.max_line);
    pk_sim_result_free(&ref);
    pk_serve_sim_free(&s);
}

/* Everything the engine sent since the last call, appended to buf. */
static void collect(struct pk_serve_sim *s, char *buf, size_t cap, size_t *n)
{
    uint8_t b[64];
    size_t k;
    while ((k = pk_uart_tx_pop(&s->uart, b, sizeof b)) > 0) {
        if (*n + k + 1 < cap) {
            memcpy(buf + *n, b, k);
            *n += k;
            buf[*n] = 0;
        }
    }
}

/* Run (1 ms slices) until text has come after from, at most ms. */
static int run_for(struct pk_serve_sim *s, char *buf, size_t cap, size_t *n, size_t from,
                   const char *text, int ms)
{
    for (int i = 0; i < ms; i++) {
        if (strstr(buf + from, text) != NULL)
            return 1;
        if (pk_serve_sim_run(s, 1000) != 0)
            return 0;
        collect(s, buf, cap, n);
    }
    return strstr(buf + from, text) != NULL;
}

static void test_hard_limit_and_probe_through_the_gpiod_backend_on_the_mock_chip(void)
{
    static struct pk_serve_sim s;
    static char buf[1 << 14];
    size_t n = 0, from;
    const struct pk_timing_limits lim = PK_TIMING_DRV8825;
    /* X's limit switch at 40 mm, a touch plate under Z at -2 mm (80 steps/mm) */
    static const struct pk_sim_input in[] = {
        { .is_switch = 1, .input = PK_IN_LIMIT_X, .axis = 0, .side = +1, .at_steps = 3200 },
        { .is_switch = 1, .input = PK_IN_PROBE, .axis = 2, .side = -1, .at_steps = -160 },
    };
    TH_ASSERT_EQ(pk_serve_sim_start_in(&s, "test-serve-in", &lim, NULL, in, 2), 0);
    send_all(&s, "$21=1\nG21 G90 G38.2 Z-5 F100\n");
    from = n;
    TH_ASSERT(run_for(&s, buf, sizeof buf, &n, 0, ":1]\r\nok\r\n", 20000));
    TH_EXPECT(strstr(buf, "[PRB:0.000,0.000,-2.000:1]\r\nok\r\n") != NULL);
    send_all(&s, "G0 Z0\nG1 X100 Y20 F3000\n");
    from = n;
    TH_ASSERT(run_for(&s, buf, sizeof buf, &n, from, "[MSG:Reset to continue]\r\n", 20000));
    TH_EXPECT(strstr(buf + from, "ALARM:1\r\n[MSG:Reset to continue]\r\n") != NULL);
    for (int i = 0; i < 500; i++)
        TH_ASSERT_EQ(pk_serve_sim_run(&s, 1000), 0);
    /* the pins (decoded from the mock chip's trace) stopped on the switch */
    TH_EXPECT_EQ(s.r.dec.pos[0], 3200);
    TH_EXPECT_EQ(s.r.dec.pos[1], 640);
    from = n;
    send_all(&s, "?");
    TH_ASSERT(run_for(&s, buf, sizeof buf, &n, from, ">\r\n", 100));
    char want[64];
    snprintf(want, sizeof want, "<Alarm|MPos:%.3f,%.3f,%.3f|", s.r.dec.pos[0] / 80.0,
             s.r.dec.pos[1] / 80.0, s.r.dec.pos[2] / 80.0);
    TH_EXPECT(strstr(buf + from, want) != NULL);
    TH_EXPECT(strstr(buf + from, "Pn:X") != NULL);
    TH_ASSERT_EQ(pk_serve_sim_finish(&s), 0);
    TH_EXPECT_EQ(s.r.job.alarms, 1ul);
    pk_serve_sim_free(&s);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_program_sent_to_serve_ends_on_the_steps_plotkin_sim_decodes),
        TH_CASE(test_hard_limit_and_probe_through_the_gpiod_backend_on_the_mock_chip),
    };
    return th_run(cases, TH_COUNT(cases));
}
