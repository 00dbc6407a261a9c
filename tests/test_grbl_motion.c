/*
 * test_grbl_motion.c — the Grbl engine driving the REAL motion core on the
 * recording HAL with a simulated clock (host-sim/grbl_sim.c): what a sender
 * sees end to end, without a pseudo-terminal in between (tests/e2e_serve.sh
 * repeats the key cases over a real pty).
 *
 * $100..$102 are set to 1000 steps/mm so one step is one micrometre and the
 * expected final positions are exactly the programmed ones.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#define GRBL_FIXTURE_OUT_SIZE (1 << 20)
#include "grbl_sim_fixture.h"

int th_main(int argc, char **argv);

static int machine_idle(void)
{
    return pk_machine_state(&S.m) == PK_STATE_IDLE && pk_grbl_idle(&S.g) &&
           pk_uart_rx_used(&S.uart) == 0;
}

/* Run until idle (bounded by max simulated seconds). */
static int run_idle(int max_s)
{
    for (long i = 0; i < (long)max_s * 2000; i++) {
        step(1);
        if (machine_idle())
            return 1;
    }
    return 0;
}

static void start(void)
{
    struct pk_grbl_settings set;
    pk_grbl_settings_default(&set);
    (void)pk_grbl_settings_apply(&set, "$100=1000");
    (void)pk_grbl_settings_apply(&set, "$101=1000");
    (void)pk_grbl_settings_apply(&set, "$102=1000");
    (void)pk_grbl_settings_apply(&set, "$205=0");
    (void)pk_grbl_settings_apply(&set, "$0=3"); /* 100 k steps/s needs short pulses */
    (void)pk_grbl_settings_apply(&set, "$110=4000"); /* at 2000 steps/mm too: 133 k steps/s */
    (void)pk_grbl_settings_apply(&set, "$111=4000");
    pk_grbl_sim_free(&S);
    TH_ASSERT_EQ(pk_grbl_sim_init(&S, 1000000, &set), 0);
    outn = 0;
    out[0] = 0;
    step(2);
}

static void final_status(char *buf, size_t n)
{
    outn = 0;
    send("?");
    step(2);
    size_t m = outn < n - 1 ? outn : n - 1;
    memcpy(buf, out, m);
    buf[m] = 0;
}

static void test_a_streamed_program_ends_exactly_where_it_was_sent(void)
{
    start();
    static char prog[1 << 16];
    size_t k = 0;
    int lines = 0;
    k += (size_t)snprintf(prog + k, sizeof prog - k, "G21 G90 G64 P0.05\nM3\n");
    lines += 2;
    for (int i = 0; i < 120; i++) {
        k += (size_t)snprintf(prog + k, sizeof prog - k, "G1 X%d.%03d Y%d.%03d F%d\n",
                              10 + (i * 37) % 80, (i * 123) % 1000, 10 + (i * 53) % 70,
                              (i * 311) % 1000, 3000 + (i % 3) * 1000);
        lines++;
    }
    k += (size_t)snprintf(prog + k, sizeof prog - k,
                          "G5 X50 Y50 I10 J0 P0 Q-10\nG5.1 X20 Y40 I-5 J5\nM5\nG0 X12.345 Y6.789\n");
    lines += 4;
    send(prog);
    TH_ASSERT(run_idle(600));
    TH_EXPECT_EQ(count(out, "ok\r\n"), lines);
    TH_EXPECT_EQ(count(out, "error"), 0);
    char st[256];
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:12.345,6.789,0.000|", 30) == 0);
    if (strncmp(st, "<Idle|MPos:12.345,6.789,0.000|", 30) != 0)
        th_print(st);
}

/* A long smoothed zigzag; hold in the middle of it, then resume. */
static void test_hold_then_resume_mid_stroke_finishes_at_the_exact_end(void)
{
    start();
    send("G64 P0.02\nG1 X1 Y1 F6000\n");
    char buf[64];
    for (int i = 0; i < 40; i++) {
        snprintf(buf, sizeof buf, "X%d Y%d\n", 5 + i * 5, (i & 1) ? 30 : 1);
        send(buf);
    }
    send("X250.5 Y100.25\n");
    step(600); /* 0.3 s in: well inside the stroke */
    TH_ASSERT(pk_machine_state(&S.m) == PK_STATE_RUN);
    send("!");
    int held = 0;
    for (int i = 0; i < 4000 && !held; i++) {
        step(1);
        held = pk_machine_state(&S.m) == PK_STATE_HOLD;
    }
    TH_ASSERT(held);
    pk_um_t p1[PK_AXES], p2[PK_AXES];
    pk_machine_position_um(&S.m, p1);
    step(400); /* stays put while held */
    pk_machine_position_um(&S.m, p2);
    TH_EXPECT(memcmp(p1, p2, sizeof p1) == 0);
    char st[256];
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Hold:0|", 8) == 0);
    send("~");
    TH_ASSERT(run_idle(120));
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:250.500,100.250,0.000|", 33) == 0);
    if (strncmp(st, "<Idle|MPos:250.500,100.250,0.000|", 33) != 0)
        th_print(st);
}

static void test_soft_reset_during_motion_leaves_no_queued_move(void)
{
    start();
    send("G1 X100 F3000\nG1 Y100\nG1 X0\nG1 Y0\n");
    step(400);
    TH_ASSERT(pk_machine_state(&S.m) == PK_STATE_RUN);
    outn = 0;
    send("\x18");
    step(2);
    TH_EXPECT_EQ(pk_machine_queue_fill(&S.m), 0);
    TH_EXPECT(strstr(out, "ALARM:3") != NULL);
    pk_um_t p1[PK_AXES], p2[PK_AXES];
    pk_machine_position_um(&S.m, p1);
    step(4000); /* two simulated seconds: nothing moves */
    pk_machine_position_um(&S.m, p2);
    TH_EXPECT(memcmp(p1, p2, sizeof p1) == 0);
    TH_EXPECT(pk_machine_state(&S.m) != PK_STATE_RUN);
    /* Locked until $X; then it moves again from where it stopped. */
    outn = 0;
    send("G0 X1\n$X\nG0 X1 Y2\n");
    TH_ASSERT(run_idle(60));
    TH_EXPECT(strstr(out, "error:9\r\n") != NULL);
    char st[256];
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:1.000,2.000,0.000|", 29) == 0);
}

static void test_jog_cancel_stops_short_without_alarm_and_g_code_runs_after(void)
{
    start();
    send("$J=G91 X100 F1200\n");
    step(1000); /* 0.5 s: about 10 mm into the jog */
    char st[256];
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Jog|", 5) == 0);
    outn = 0;
    send("\x85");
    int idle = 0;
    for (int i = 0; i < 4000 && !idle; i++) {
        step(1);
        idle = machine_idle();
    }
    TH_ASSERT(idle);
    TH_EXPECT(strstr(out, "ALARM") == NULL);
    pk_um_t p[PK_AXES];
    pk_machine_position_um(&S.m, p);
    TH_EXPECT(p[0] > 5000 && p[0] < 50000); /* stopped well short of 100 mm */
    send("G90 G0 X1 Y1\n");
    TH_ASSERT(run_idle(30));
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:1.000,1.000,0.000|", 29) == 0);
}

static void test_a_steps_per_mm_change_keeps_the_step_position_like_grbl(void)
{
    start();
    send("G0 X10 Y4\n");
    TH_ASSERT(run_idle(30));
    send("$100=2000\n");
    TH_ASSERT(run_idle(5));
    char st[256];
    final_status(st, sizeof st);
    /* 10000 steps at 2000 steps/mm: the same place, now reported as 5 mm. */
    TH_EXPECT(strncmp(st, "<Idle|MPos:5.000,4.000,0.000|", 29) == 0);
    outn = 0;
    send("G1 X20 F600\n$100=1000\n");
    TH_ASSERT(run_idle(30));
    TH_EXPECT_EQ(count(out, "error:8"), 1); /* refused while the X20 move runs */
    send("G91 G0 X1\n");
    TH_ASSERT(run_idle(30));
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:21.000,4.000,0.000|", 30) == 0);
}

/* The case: a steps/mm change that would put the position beyond
 * the representable range is refused (never wrapped), and the next move runs
 * at the configured rate, from where the machine really is. */
static void test_a_steps_per_mm_change_that_cannot_keep_the_position_is_refused(void)
{
    start();
    send("$110=600\n$100=10000\n");           /* 600 mm/min at 10000 steps/mm: 100 k steps/s */
    TH_ASSERT(run_idle(5));
    send("G21 G90 G0 X300\n");                /* 3,000,000 steps */
    TH_ASSERT(run_idle(40));
    outn = 0;
    out[0] = 0;
    send("$100=1\n");                         /* would be 3,000,000 mm */
    TH_ASSERT(run_idle(5));
    TH_EXPECT(strstr(out, "error:3") != NULL);
    char st[256];
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:300.000,0.000,0.000|", 31) == 0);
    /* 10 mm back at 600 mm/min: 1 s plus the ramps, never faster */
    long t0 = 0;
    send("G0 X290\n");
    for (; t0 < 10 * 2000 && !machine_idle(); t0++)
        step(1);
    step(1);
    for (; t0 < 10 * 2000 && !machine_idle(); t0++)
        step(1);
    TH_EXPECT(t0 >= 2000);                    /* >= 1 s simulated (0.5 ms per step) */
    final_status(st, sizeof st);
    TH_EXPECT(strncmp(st, "<Idle|MPos:290.000,0.000,0.000|", 31) == 0);
}

/* An arc program on the real machine ends exactly at the programmed point. */
static void test_arcs_end_exactly_at_their_programmed_end(void)
{
    start();
    send("G21 G90 G64 P0.02 G0 X50 Y50\nM3\n"
         "G2 X60 Y50 I5 J0 F3000\nG3 X50 Y50 R5\nG2 X50 Y50 I-7.5 J2.25\n"
         "G3 X43.21 Y58.765 Z1.5 R-9\nG18 G2 X50 Z0 I3.395 K-0.75\nG17 G91 G2 X-3 Y0 R1.5\n");
    TH_ASSERT(run_idle(60));
    TH_EXPECT_EQ(count(out, "error"), 0);
    char st[256];
    final_status(st, sizeof st);
    /* Z: the G18 arc's end is its start mirrored across the centre's Z */
    TH_EXPECT(strstr(st, "MPos:47.000,58.765,0.000") != NULL || (th_print(st), 0));
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_streamed_program_ends_exactly_where_it_was_sent),
        TH_CASE(test_hold_then_resume_mid_stroke_finishes_at_the_exact_end),
        TH_CASE(test_soft_reset_during_motion_leaves_no_queued_move),
        TH_CASE(test_jog_cancel_stops_short_without_alarm_and_g_code_runs_after),
        TH_CASE(test_a_steps_per_mm_change_keeps_the_step_position_like_grbl),
        TH_CASE(test_a_steps_per_mm_change_that_cannot_keep_the_position_is_refused),
        TH_CASE(test_arcs_end_exactly_at_their_programmed_end),
    };
    int r = th_run(cases, TH_COUNT(cases));
    pk_grbl_sim_free(&S);
    return r;
}
