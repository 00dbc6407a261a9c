/*
 * test_grbl_inputs.c — the Grbl engine's inputs on the real motion core
 * (host-sim/grbl_sim.h: engine + UART shim + pk_machine on the recording HAL
 * with input lines): hard limits ($21, ALARM:1), the homing cycle ($H with
 * $22-$27, ALARM:6/9), probing (G38.2-G38.5, ALARM:4/5, [PRB:]) and the
 * status report's Pn: and the buttons, with switches placed along the axes
 * and edges scripted on the simulated clock.
 *
 * Every position the engine reports is checked against the position decoded
 * from the step and direction pins by the recording HAL (rec.pos), at 100
 * steps/mm so that one step is exactly 10 µm and a report prints it without
 * rounding: the report must be the pins' position, in the frame the test
 * computes from where the switches are.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#define GRBL_FIXTURE_OUT_SIZE (1 << 18)
#include "grbl_sim_fixture.h"

int th_main(int argc, char **argv);

#define MS 2L /* main-loop periods per simulated ms */
#define SPMM 100 /* steps/mm of every axis in these tests */
#define ALL_INPUTS ((1u << PK_IN_LIMIT_X) | (1u << PK_IN_LIMIT_Y) | (1u << PK_IN_PROBE) | \
                    (1u << PK_IN_DOOR) | (1u << PK_IN_HOLD) | (1u << PK_IN_RESUME) | (1u << PK_IN_RESET))

static size_t mark; /* out[] offset where the current exchange starts */

static void start(uint32_t inputs)
{
    pk_grbl_sim_free(&S);
    memset(&S, 0, sizeof S);
    struct pk_grbl_settings set;
    pk_grbl_settings_default(&set);
    for (int a = 0; a < PK_GC_AXES; a++)
        set.v[PK_GRBL_S_STEPS_X + a] = SPMM * 10000;
    set.v[PK_GRBL_S_TRAVEL_X] = 50000;  /* 50 mm: the search of $H is 75 mm */
    set.v[PK_GRBL_S_TRAVEL_Y] = 50000;
    if (pk_grbl_sim_init_inputs(&S, 1000000, &set, inputs, 1) != 0)
        th_fail(__FILE__, __LINE__, "grbl_sim_init_inputs");
    outn = 0;
    out[0] = 0;
    step(20 * MS);
    mark = outn;
}

/* Run until text appears after mark (at most ms simulated ms); 1 if it did. */
static int run_until(const char *text, long ms)
{
    for (long i = 0; i < ms * MS; i++) {
        if (strstr(out + mark, text) != NULL)
            return 1;
        step(1);
    }
    return strstr(out + mark, text) != NULL;
}

/* Send a line and wait for its answer; returns what came meanwhile. */
static const char *line(const char *l, long ms)
{
    mark = outn;
    send(l);
    send("\n");
    for (long i = 0; i < ms * MS; i++) {
        if (strstr(out + mark, "ok\r\n") || strstr(out + mark, "error:"))
            break;
        step(1);
    }
    return out + mark;
}

static int expect_text(const char *hay, const char *want, int line_no)
{
    if (strstr(hay, want) != NULL)
        return 1;
    char msg[160];
    snprintf(msg, sizeof msg, "  line %d: missing \"%s\" in:\n", line_no, want);
    th_print(msg);
    th_print(hay);
    th_print("\n");
    th_check(0, __FILE__, line_no, "text present");
    return 0;
}
#define HAS(hay, want) expect_text((hay), (want), __LINE__)

/* The status report now. */
static const char *status(void)
{
    mark = outn;
    pk_uart_rx_push(&S.uart, '?');
    (void)run_until(">\r\n", 100);
    return strstr(out + mark, "<") ? strstr(out + mark, "<") : "";
}

/* "MPos:x,y,z" as the pins say, steps -> mm (exact at 100 steps/mm), with
 * the machine frame's origin at steps org[]. */
static void pins_mpos(char *buf, size_t n, const long org[3])
{
    snprintf(buf, n, "MPos:%.3f,%.3f,%.3f", (double)(S.rec.pos[0] - org[0]) / SPMM,
             (double)(S.rec.pos[1] - org[1]) / SPMM, (double)(S.rec.pos[2] - org[2]) / SPMM);
}

static void wait_idle(long ms)
{
    for (long i = 0; i < ms * MS; i++) {
        if (pk_machine_state(&S.m) == PK_STATE_IDLE && pk_grbl_idle(&S.g))
            break;
        step(1);
    }
    step(4);
}

/* ------------------------------------------------------------ hard limits */

static void hard_limit_mid_move_is_alarm_1_at_the_exact_position(void)
{
    start(ALL_INPUTS);
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_LIMIT_X, 0, +1, 40 * SPMM) == 0);
    HAS(line("$21=1", 100), "ok");
    HAS(line("G21 G90 G1 X100 Y20 F3000", 100), "ok");
    mark = outn;
    TH_ASSERT(run_until("ALARM:1\r\n", 10000));
    HAS(out + mark, "ALARM:1\r\n[MSG:Reset to continue]\r\n");
    long x = (long)S.rec.pos[0], y = (long)S.rec.pos[1];
    /* stopped on the step that reached the switch, without deceleration */
    TH_EXPECT_EQ(x, 40 * SPMM);
    TH_EXPECT_EQ(y, 8 * SPMM);
    step(1000 * MS);
    TH_EXPECT_EQ((long)S.rec.pos[0], x); /* no step after the alarm */
    const long org[3] = { 0, 0, 0 };
    char want[96];
    pins_mpos(want, sizeof want, org);
    const char *st = status();
    HAS(st, "<Alarm|");
    HAS(st, want);
    HAS(st, "Pn:X");
    /* nothing but '?' and reset: a line waits unread */
    mark = outn;
    send("$X\n");
    step(200 * MS);
    TH_EXPECT(strstr(out + mark, "ok") == NULL);
    /* the reset: Grbl's greeting, the switch still closed, the lock; the
     * pending $X is dropped with the receive buffer; no ALARM:3 */
    mark = outn;
    pk_uart_rx_push(&S.uart, 0x18);
    TH_ASSERT(run_until("unlock]\r\n", 200));
    HAS(out + mark, "Grbl 1.1h");
    HAS(out + mark, "[MSG:Check Limits]\r\n[MSG:'$H'|'$X' to unlock]\r\n");
    TH_EXPECT(strstr(out + mark, "ALARM:3") == NULL);
    HAS(status(), want); /* the reset keeps the position */
    HAS(line("G0 X0", 100), "error:9");
    /* unlocked, the machine moves off its switch (Grbl: the limits trip on
     * an edge only), and the limits are armed again once it is open */
    HAS(line("$X", 100), "[MSG:Caution: Unlocked]\r\nok");
    HAS(line("G0 X10", 100), "ok");
    wait_idle(5000);
    TH_EXPECT_EQ((long)S.rec.pos[0], 10 * SPMM);
    TH_EXPECT(strstr(status(), "Pn:") == NULL);
    HAS(line("G1 X60 F3000", 100), "ok");
    mark = outn;
    TH_ASSERT(run_until("ALARM:1\r\n", 10000));
    TH_EXPECT_EQ((long)S.rec.pos[0], 40 * SPMM);
}

static void a_switch_closing_while_idle_trips_and_21_needs_switches(void)
{
    start(ALL_INPUTS);
    HAS(line("$21=1", 100), "ok");
    TH_ASSERT(pk_rec_input_at(&S.rec, S.rec.now + 50000, PK_IN_LIMIT_Y, 1) == 0);
    mark = outn;
    TH_ASSERT(run_until("ALARM:1\r\n[MSG:Reset to continue]\r\n", 500));
    HAS(status(), "<Alarm|MPos:0.000,0.000,0.000");
    /* a board without limit switches refuses $21=1 */
    start(0);
    HAS(line("$21=1", 100), "[MSG:No limit switches: $21=1 refused]\r\nerror:3");
    HAS(line("$21=0", 100), "ok");
}

/* ----------------------------------------------------------------- homing */

static void homing_sets_the_machine_position_from_the_switches(void)
{
    start(ALL_INPUTS);
    /* switches (toward +, Grbl's default $23=0) at X = 20 mm, Y = 10 mm */
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_LIMIT_X, 0, +1, 20 * SPMM) == 0);
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_LIMIT_Y, 1, +1, 10 * SPMM) == 0);
    HAS(line("$22=1", 100), "ok");
    HAS(line("$21=1", 100), "ok");
    HAS(line("$N0=G91", 100), "ok");
    mark = outn;
    send("$H\n");
    step(100 * MS);
    HAS(status(), "<Home|");
    mark = outn;
    TH_ASSERT(run_until("ok\r\n", 60000));
    /* the startup lines run after a cycle, then $H is answered (Grbl) */
    HAS(out + mark, ">G91:ok\r\nok\r\n");
    /* each axis located its switch exactly, then pulled off $27 = 1 mm */
    TH_EXPECT_EQ((long)S.rec.pos[0], 20 * SPMM - SPMM);
    TH_EXPECT_EQ((long)S.rec.pos[1], 10 * SPMM - SPMM);
    /* machine 0 is the switch: MPos = -$27 */
    const long org[3] = { 20 * SPMM, 10 * SPMM, 0 };
    char want[96];
    pins_mpos(want, sizeof want, org);
    HAS(want, "MPos:-1.000,-1.000,0.000");
    const char *st = status();
    HAS(st, "<Idle|");
    HAS(st, want);
    /* the frame is right: a move to machine (-5, -5) lands 5 mm before each switch */
    HAS(line("G90 G53 G0 X-5 Y-5", 100), "ok");
    wait_idle(10000);
    TH_EXPECT_EQ((long)S.rec.pos[0], 15 * SPMM);
    TH_EXPECT_EQ((long)S.rec.pos[1], 5 * SPMM);
    /* $HX: Grbl 1.1h's default build has no single-axis homing */
    HAS(line("$HX", 100), "error:3");
    /* with $22=1 a restart locks until $H or $X */
    mark = outn;
    TH_ASSERT(pk_grbl_sim_restart(&S) == 0);
    step(20 * MS);
    HAS(out + mark, "[MSG:'$H'|'$X' to unlock]\r\n");
    HAS(line("G0 X1", 100), "error:9");
}

static void homing_without_a_switch_in_reach_is_alarm_9_then_a_reset(void)
{
    start(ALL_INPUTS);
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_LIMIT_X, 0, +1, 100 * SPMM) == 0); /* beyond 1.5 x 50 mm */
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_LIMIT_Y, 1, +1, 5 * SPMM) == 0);
    HAS(line("$22=1", 100), "ok");
    mark = outn;
    send("$H\n");
    TH_ASSERT(run_until("unlock]\r\n", 120000));
    HAS(out + mark, "ALARM:9\r\nok\r\n\r\nGrbl 1.1h");
    HAS(out + mark, "[MSG:'$H'|'$X' to unlock]\r\n");
    HAS(status(), "<Alarm|");
    /* a reset during the cycle: ALARM:6, the $H answered, the reset */
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_LIMIT_X, 0, +1, 0) == 0);
    mark = outn;
    send("$H\n");
    step(300 * MS);
    HAS(status(), "<Home|");
    mark = outn;
    pk_uart_rx_push(&S.uart, 0x18);
    TH_ASSERT(run_until("unlock]\r\n", 500));
    HAS(out + mark, "ALARM:6\r\nok\r\n\r\nGrbl 1.1h");
    /* the door opening during the cycle: ALARM:7 */
    mark = outn;
    send("$H\n");
    step(300 * MS);
    HAS(status(), "<Home|");
    TH_ASSERT(pk_rec_input_at(&S.rec, S.rec.now + 1000, PK_IN_DOOR, 1) == 0);
    mark = outn;
    TH_ASSERT(run_until("unlock]\r\n", 500));
    HAS(out + mark, "ALARM:7\r\nok\r\n\r\nGrbl 1.1h");
    TH_ASSERT(pk_rec_input_at(&S.rec, S.rec.now + 1000, PK_IN_DOOR, 0) == 0);
    /* no switches at all: $H is refused loudly */
    start(0);
    HAS(line("$22=1", 100), "[MSG:No limit switches: $H cannot run, $X unlocks]\r\nok");
    HAS(line("$H", 100), "[MSG:No limit switches: $H is not supported by this machine]\r\nerror:5");
}

/* ---------------------------------------------------------------- probing */

static void probing_records_the_contact_and_follows_grbl_s_alarms(void)
{
    start(ALL_INPUTS);
    /* a touch plate: the probe is active while Z is at -5 mm or below */
    TH_ASSERT(pk_rec_add_switch(&S.rec, PK_IN_PROBE, 2, -1, -5 * SPMM) == 0);
    HAS(line("G21 G90 G38.2 Z-10 F100", 30000), "[PRB:0.000,0.000,-5.000:1]\r\nok");
    /* it decelerated past the contact and goes on from where it stopped */
    long z = (long)S.rec.pos[2];
    TH_EXPECT(z <= -5 * SPMM && z > -6 * SPMM);
    const long org[3] = { 0, 0, 0 };
    char want[96];
    pins_mpos(want, sizeof want, org);
    const char *st = status();
    HAS(st, want);
    HAS(st, "Pn:P");
    HAS(line("$#", 100), "[PRB:0.000,0.000,-5.000:1]\r\nok");
    /* already touching: ALARM:4, nothing moves, the line is answered */
    HAS(line("G38.2 Z-20", 100), "ALARM:4\r\nok");
    TH_EXPECT_EQ((long)S.rec.pos[2], z);
    HAS(line("G0 Z0", 100), "error:9");
    HAS(line("$X", 100), "ok");
    /* away from the plate: the contact is lost one step above -5 mm */
    HAS(line("G38.4 Z0 F100", 30000), "[PRB:0.000,0.000,-4.990:1]\r\nok");
    /* G38.2 with no contact: ALARM:5, [PRB:] keeps the last contact, :0 */
    HAS(line("G38.2 Z-1", 30000), "ALARM:5\r\n[PRB:0.000,0.000,-4.990:0]\r\nok");
    HAS(line("$X", 100), "ok");
    /* G38.3: no contact is no error; [PRB:] is where the move ended */
    HAS(line("G38.3 Z0", 30000), "[PRB:0.000,0.000,0.000:0]\r\nok");
    TH_EXPECT(strstr(out + mark, "ALARM") == NULL);
    TH_EXPECT_EQ((long)S.rec.pos[2], 0);
    /* no probe input on the board: G38 is refused loudly */
    start(0);
    HAS(line("G38.2 Z-1 F100", 100),
        "[MSG:No probe input: G38 is not supported by this machine]\r\nerror:20");
}

/* ---------------------------------------------------- Pn: and the buttons */

static void pn_reports_the_inputs_and_the_buttons_act_as_realtime_bytes(void)
{
    start(ALL_INPUTS);
    uint64_t t = S.rec.now;
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 10000, PK_IN_PROBE, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 10000, PK_IN_LIMIT_Y, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 10000, PK_IN_DOOR, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 10000, PK_IN_RESUME, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 30000, PK_IN_PROBE, 0) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 30000, PK_IN_LIMIT_Y, 0) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 30000, PK_IN_DOOR, 0) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 30000, PK_IN_RESUME, 0) == 0);
    step(20 * MS);
    HAS(status(), "|Pn:PYDS");
    step(20 * MS);
    TH_EXPECT(strstr(status(), "Pn:") == NULL);
    /* the door opening held the idle machine (the resume pressed while it
     * was open did nothing); it is closed now: resume */
    HAS(status(), "<Hold:0|");
    pk_uart_rx_push(&S.uart, '~');
    step(10 * MS);
    HAS(status(), "<Idle|");
    /* the hold button holds a move, the cycle-start button resumes it */
    HAS(line("G21 G90 G1 X30 F600", 100), "ok"); /* 3 s */
    t = S.rec.now;
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 500000, PK_IN_HOLD, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 550000, PK_IN_HOLD, 0) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 2000000, PK_IN_RESUME, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 2050000, PK_IN_RESUME, 0) == 0);
    step(1500 * MS);
    HAS(status(), "<Hold:0|");
    long held = (long)S.rec.pos[0];
    step(400 * MS);
    TH_EXPECT_EQ((long)S.rec.pos[0], held);
    step(200 * MS);
    HAS(status(), "<Run|");
    /* the reset button is Ctrl-X: the move is cut, ALARM:3 */
    t = S.rec.now;
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 10000, PK_IN_RESET, 1) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 60000, PK_IN_RESET, 0) == 0);
    mark = outn;
    TH_ASSERT(run_until("unlock]\r\n", 500));
    HAS(out + mark, "ALARM:3\r\n");
    HAS(out + mark, "Grbl 1.1h");
    /* the door input: a feed hold (no parking), and $X waits for it to close */
    HAS(line("$X", 100), "ok");
    HAS(line("G1 X0 F600", 100), "ok");
    t = S.rec.now;
    TH_ASSERT(pk_rec_input_at(&S.rec, t + 300000, PK_IN_DOOR, 1) == 0);
    step(1500 * MS);
    const char *st = status();
    HAS(st, "<Hold:0|");
    HAS(st, "Pn:D");
    pk_uart_rx_push(&S.uart, 0x18); /* after a completed hold: Idle, no alarm */
    step(100 * MS);
    HAS(status(), "<Idle|");
    HAS(line("$H", 100), "error:5"); /* $22=0 comes first, as Grbl */
    HAS(line("$22=1", 100), "ok");
    HAS(line("$H", 100), "error:13"); /* the door is open */
    /* in the alarm lock, $X waits for the door too */
    TH_ASSERT(pk_grbl_sim_restart(&S) == 0);
    TH_ASSERT(pk_rec_input_at(&S.rec, S.rec.now, PK_IN_DOOR, 1) == 0);
    step(20 * MS);
    HAS(status(), "<Alarm|");
    HAS(line("$X", 100), "error:13");
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(hard_limit_mid_move_is_alarm_1_at_the_exact_position),
        TH_CASE(a_switch_closing_while_idle_trips_and_21_needs_switches),
        TH_CASE(homing_sets_the_machine_position_from_the_switches),
        TH_CASE(homing_without_a_switch_in_reach_is_alarm_9_then_a_reset),
        TH_CASE(probing_records_the_contact_and_follows_grbl_s_alarms),
        TH_CASE(pn_reports_the_inputs_and_the_buttons_act_as_realtime_bytes),
    };
    int rc = th_run(cases, TH_COUNT(cases));
    pk_grbl_sim_free(&S);
    return rc;
}
