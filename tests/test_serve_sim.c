/*
 * test_serve_sim.c — the machine behind `plotkin serve` (host-sim/serve_sim.h)
 * is `plotkin sim`'s: a program sent line by line to the Grbl engine ends on
 * exactly the steps `plotkin sim` decodes for the same program, with the
 * same timing checks, and the summary's counters (lines, errors by line,
 * alarms) come from the session. Deterministic: simulated time only.
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
    TH_ASSERT_EQ(s.r.prog.st.stored, 0u); /* the engine hands no path to the simulator yet */
    pk_sim_result_free(&ref);
    pk_serve_sim_free(&s);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_program_sent_to_serve_ends_on_the_steps_plotkin_sim_decodes),
    };
    return th_run(cases, TH_COUNT(cases));
}
