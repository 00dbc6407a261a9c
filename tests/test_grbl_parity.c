/*
 * test_grbl_parity.c — one test per row of the README's Grbl parity table
 * (command | Grbl 1.1h | plotkin): each row is a session script played into a
 * complete simulated machine (host-sim/grbl_sim.h: the engine, the UART shim,
 * the motion core on a simulated clock) and the transcript of what it
 * answered, compared byte for byte with the expected one.
 *
 * The expected transcripts are Grbl 1.1h's answers, taken from the real Grbl
 * (gnea/grbl 1.1h built as grbl-sim, driven with the same lines) wherever
 * plotkin behaves as Grbl; where the README lists a difference, the row
 * expects plotkin's documented answer and says so in a comment.
 *
 * Script lines (separated by '\n'):
 *   <line>            sent with '\n'; run until it is answered (ok/error:N)
 *   @raw <bytes>      the bytes as they are (realtime commands), then 100 ms
 *   @wait             run until the machine is idle and nothing is pending
 *   @ms <n>           run n ms of simulated time
 *   @repeat <n> <bytes>  the bytes n times, 5 ms apart (one key press each)
 *   @status <text>    send '?' and check that the status report contains text
 *   @nostatus <text>  send '?' and check that it does not
 *   @took <lo> <hi>   the last line's answer came lo..hi ms after it was sent
 *   @setting <text>   send "$$" and check that one of its lines is text (the
 *                     listing is left out of the transcript)
 *   @restart          power cycle (the settings store is kept)
 *   @inputs           (first line only) the machine has input lines: limit
 *                     switches X Y Z, probe, door, hold, resume, reset
 *   @switch <line> <axis> <side> <mm>  input line (enum pk_hal_input) active
 *                     while axis (0 X, 1 Y, 2 Z) is at mm or beyond (side +1:
 *                     above, -1: below), from now on
 *   @edge <ms> <line> <level>  input line takes level (0/1) ms from now
 * The transcript is every non-empty line the machine sent except status
 * reports, joined with '|'; the greeting shows as "Grbl". Every session
 * starts with one '?' whose report (the first one always carries WCO:) is
 * not checked, so that a row's first @status sees the steady schedule.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#define GRBL_FIXTURE_OUT_SIZE (1 << 16)
#include "grbl_sim_fixture.h"

int th_main(int argc, char **argv);

#define MS_STEPS 2u /* main-loop periods per simulated ms (STEP_TICKS = 0.5 ms) */

static char transcript[8192];
static size_t tn;
static size_t consumed;      /* bytes of out[] already split into lines */
static char last_status[256];
static long now_ms2;         /* simulated time in half milliseconds */
static long took_ms;         /* answer latency of the last plain line */

/* Move the complete lines of out[] into the transcript / last_status. */
static void collect(void)
{
    for (;;) {
        char *p = out + consumed, *e = strstr(p, "\r\n");
        if (e == NULL)
            return;
        size_t n = (size_t)(e - p);
        consumed += n + 2;
        if (n == 0)
            continue;
        if (p[0] == '<') {
            snprintf(last_status, sizeof last_status, "%.*s", (int)n, p);
            continue;
        }
        const char *item = p;
        size_t len = n;
        if (n >= 9 && memcmp(p, "Grbl 1.1h", 9) == 0) {
            item = "Grbl";
            len = 4;
        }
        if (tn + len + 2 < sizeof transcript) {
            if (tn > 0)
                transcript[tn++] = '|';
            memcpy(transcript + tn, item, len);
            tn += len;
            transcript[tn] = 0;
        }
    }
}

static void run(long steps)
{
    for (long i = 0; i < steps; i++) {
        step(1);
        now_ms2++;
    }
    collect();
}

/* Run until the answer to the line just sent (ok / error:N) has come. */
static int run_until_answer(void)
{
    size_t from = consumed;
    for (long i = 0; i < 120000L * MS_STEPS; i++) {
        run(1);
        for (const char *p = out + from; p < out + consumed;) {
            const char *e = strstr(p, "\r\n");
            if ((e - p == 2 && memcmp(p, "ok", 2) == 0) || strncmp(p, "error:", 6) == 0)
                return 1;
            p = e + 2;
        }
    }
    return 0;
}

#define ALL_INPUTS (((1u << PK_IN_COUNT) - 1u) & ~(1u << PK_IN_LIMIT_A))

static void start(uint32_t inputs)
{
    pk_grbl_sim_free(&S);
    memset(&S, 0, sizeof S);
    if (pk_grbl_sim_init_inputs(&S, 1000000, NULL, inputs, 1) != 0)
        th_fail(__FILE__, __LINE__, "grbl_sim_init");
    outn = 0;
    out[0] = 0;
    consumed = 0;
    run(20);
    tn = 0;
    transcript[0] = 0;
    last_status[0] = 0;
}

static int status_query(void)
{
    last_status[0] = 0;
    pk_uart_rx_push(&S.uart, '?');
    for (int i = 0; i < 200 && last_status[0] == 0; i++)
        run(1);
    return last_status[0] != 0;
}

static void send_line(const char *line)
{
    send(line);
    pk_uart_rx_push(&S.uart, '\n');
    if (!run_until_answer()) {
        th_print("  no answer to: ");
        th_print(line);
        th_print("\n");
        th_fail(__FILE__, __LINE__, "no answer");
    }
}

/* "$$": is text one of its lines? The listing ($-lines and its ok) leaves
 * the transcript; anything else that came meanwhile (a greeting) stays. */
static int setting_listed(const char *text)
{
    size_t keep = tn;
    send_line("$$");
    char got[sizeof transcript];
    memcpy(got, transcript + keep, tn - keep + 1);
    tn = keep;
    transcript[tn] = 0;
    int found = 0, ok_dropped = 0;
    for (char *item = got + (got[0] == '|'); *item;) {
        size_t n = strcspn(item, "|");
        int sep = item[n] == '|';
        item[n] = 0;
        if (strcmp(item, text) == 0)
            found = 1;
        if (item[0] != '$' && !(strcmp(item, "ok") == 0 && !ok_dropped && (ok_dropped = 1))) {
            if (tn > 0)
                transcript[tn++] = '|';
            memcpy(transcript + tn, item, n + 1);
            tn += n;
        }
        item += n + sep;
    }
    return found;
}

/* Play script; check the transcript equals expect. */
static void play(const char *script, const char *expect)
{
    int with_inputs = strncmp(script, "@inputs\n", 8) == 0;
    if (with_inputs)
        script += 8;
    start(with_inputs ? ALL_INPUTS : 0u);
    (void)status_query();
    char line[512];
    for (const char *p = script; *p;) {
        size_t n = strcspn(p, "\n");
        snprintf(line, sizeof line, "%.*s", (int)n, p);
        p += n + (p[n] == '\n');
        if (strncmp(line, "@raw ", 5) == 0) {
            for (const char *b = line + 5; *b; b++)
                pk_uart_rx_push(&S.uart, (uint8_t)*b);
            run(100 * MS_STEPS);
        } else if (strncmp(line, "@repeat ", 8) == 0) {
            char *rest = NULL;
            long times = strtol(line + 8, &rest, 10);
            for (long k = 0; k < times; k++) {
                for (const char *b = rest + 1; *b; b++)
                    pk_uart_rx_push(&S.uart, (uint8_t)*b);
                run(5 * MS_STEPS);
            }
        } else if (strncmp(line, "@setting ", 9) == 0) {
            if (!setting_listed(line + 9)) {
                th_print("  $$ lacks: ");
                th_print(line + 9);
                th_print("\n");
                th_fail(__FILE__, __LINE__, "setting");
            }
        } else if (strcmp(line, "@wait") == 0) {
            for (long i = 0; i < 600000L * MS_STEPS; i++) {
                if (pk_machine_state(&S.m) == PK_STATE_IDLE && pk_grbl_idle(&S.g))
                    break;
                run(1);
            }
            run(2);
        } else if (strncmp(line, "@ms ", 4) == 0) {
            run(atol(line + 4) * MS_STEPS);
        } else if (strncmp(line, "@status ", 8) == 0 || strncmp(line, "@nostatus ", 10) == 0) {
            int want = line[1] == 's';
            const char *text = line + (want ? 8 : 10);
            if (!status_query() || (strstr(last_status, text) != NULL) != want) {
                th_print(want ? "  status lacks: " : "  status has: ");
                th_print(text);
                th_print("\n  status: ");
                th_print(last_status);
                th_print("\n");
                th_fail(__FILE__, __LINE__, "status report");
            }
        } else if (strncmp(line, "@took ", 6) == 0) {
            long lo = 0, hi = 0;
            if (sscanf(line + 6, "%ld %ld", &lo, &hi) != 2 || took_ms < lo || took_ms > hi) {
                char msg[96];
                snprintf(msg, sizeof msg, "  answered after %ld ms, want %ld..%ld\n", took_ms, lo, hi);
                th_print(msg);
                th_fail(__FILE__, __LINE__, "answer time");
            }
        } else if (strncmp(line, "@switch ", 8) == 0) {
            unsigned in = 0, axis = 0;
            int side = 0;
            double mm = 0;
            if (sscanf(line + 8, "%u %u %d %lf", &in, &axis, &side, &mm) != 4 ||
                pk_rec_add_switch(&S.rec, in, axis, side, (int32_t)(mm * 80.0)) != 0)
                th_fail(__FILE__, __LINE__, "@switch");
        } else if (strncmp(line, "@edge ", 6) == 0) {
            long ms = 0;
            unsigned in = 0;
            int level = 0;
            if (sscanf(line + 6, "%ld %u %d", &ms, &in, &level) != 3 ||
                pk_rec_input_at(&S.rec, S.rec.now + (uint64_t)ms * 1000u, in, level) != 0)
                th_fail(__FILE__, __LINE__, "@edge");
        } else if (strcmp(line, "@restart") == 0) {
            if (pk_grbl_sim_restart(&S) != 0)
                th_fail(__FILE__, __LINE__, "restart");
            outn = 0;
            out[0] = 0;
            consumed = 0;
            run(20);
        } else {
            long t0 = now_ms2;
            send_line(line);
            took_ms = (now_ms2 - t0) / (long)MS_STEPS;
        }
    }
    run(20);
    if (strcmp(transcript, expect) != 0) {
        th_print("  got:  ");
        th_print(transcript);
        th_print("\n  want: ");
        th_print(expect);
        th_print("\n");
        th_fail(__FILE__, __LINE__, "transcript differs");
    }
}

#define ROW(name, script, expect) static void name(void) { play(script, expect); }

/* ---- G-code ----------------------------------------------------------------------- */

ROW(g0_g1_move_at_rapid_and_feed_and_need_a_feed_rate,
    "G1 X1\n"                       /* no feed rate yet */
    "G21 G90 G0 X10 Y5\n"
    "G1 X20 F600\n"
    "@wait\n@status MPos:20.000,5.000,0.000\n"
    "G1 X1 F0\n"
    "G1 X1 F0.5\n"                  /* plotkin: below 1 mm/min is refused; Grbl: ok */
    "G0 X1 Y2 Z3 A4\n"              /* no A axis */
    "G1 X1 X2\n",
    "error:22|ok|ok|error:22|error:22|error:20|error:25")

ROW(g2_g3_arcs_in_ijk_and_r_form_full_circles_and_helices,
    "G21 G90 G17 G0 X0 Y0\n"
    "G2 X10 Y0 I5 J0 F3000\n"       /* half circle */
    "G3 X0 Y0 R5\n"                 /* back, R form */
    "G2 X0 Y0 I5\n"                 /* full circle */
    "G3 X0 Y0 Z2 I5\n"              /* helix: a full turn rising 2 mm */
    "G2 X10 Y10 R-10\n"             /* R < 0: the long way round */
    "@wait\n@status MPos:10.000,10.000,2.000\n"
    "G2 X20 Y10 R4\n"               /* radius shorter than half the chord */
    "G2 X20 Y10 I4\n"               /* end not on the circle */
    "G2 X20 Y10\n"                  /* no centre */
    "G2 I5\n"                       /* no axis word */
    "G2 X20 I5 R5\n",               /* both forms: I unused */
    "ok|ok|ok|ok|ok|ok|error:34|error:33|error:35|error:26|error:36")

ROW(g2_g3_arcs_follow_the_plane_g17_g18_g19,
    "G21 G90 G0 X0 Y0 Z0\n"
    "G18 G2 X10 Z0 I5 F3000\n"      /* ZX plane: half circle in X-Z */
    "@wait\n@status MPos:10.000,0.000,0.000\n"
    "G19 G3 Y10 Z0 J5\n"            /* YZ plane */
    "@wait\n@status MPos:10.000,10.000,0.000\n"
    "G17 G2 Z5 K1\n"                /* no axis word in the XY plane: refused whole */
    "$G\n",                         /* plotkin lists its path mode (G64) too */
    "ok|ok|ok|error:32|[GC:G3 G54 G19 G21 G90 G94 G64 M5 M9 T0 F3000 S0]|ok")

ROW(g4_dwell_is_answered_after_the_queue_drains_and_the_dwell_ends,
    "G21 G90 G1 X10 F600\n"         /* 1 s of motion */
    "G4 P0.5\n"
    "@took 1400 1700\n"
    "G4 P0\n"
    "G4\n"
    "G4 P-1\n"
    "G4 P90000\n",                  /* plotkin: over 24 h is refused, never clamped; Grbl: ok */
    "ok|ok|ok|error:28|error:4|error:2")

ROW(g5_g5_1_splines_are_plotkin_extensions,
    "G21 G90 G0 X0 Y0\n"
    "G5 X10 Y10 I2 J0 P-2 Q0 F3000\n" /* Grbl: error:20 for both */
    "G5.1 X20 Y0 I5 J5\n"
    "@wait\n@status MPos:20.000,0.000,0.000\n"
    "G5 X1 Y1 I1 J1 P1 Q1 Z1\n",    /* splines are planar */
    "ok|ok|ok|error:33")

ROW(g10_l2_l20_set_coordinate_systems,
    "G21 G90\n"
    "G10 L2 P1 X1 Y2 Z3\n"
    "G10 L2 P2 X4\n"
    "G10 L20 P3 X10\n"
    "G0 X5 Y5\n"
    "G10 L20 P0 Y1\n"               /* P0: the active system */
    "G10 L2 P7 X1\n"
    "G10 L3 P1 X1\n"
    "G10 L2 X1\n"                   /* no P: P0 */
    "$#\n",
    "ok|ok|ok|ok|ok|ok|error:29|error:20|ok|"
    "[G54:1.000,6.000,3.000]|[G55:4.000,0.000,0.000]|[G56:-10.000,0.000,0.000]|"
    "[G57:0.000,0.000,0.000]|[G58:0.000,0.000,0.000]|[G59:0.000,0.000,0.000]|"
    "[G28:0.000,0.000,0.000]|[G30:0.000,0.000,0.000]|[G92:0.000,0.000,0.000]|"
    "[TLO:0.000]|[PRB:0.000,0.000,0.000:0]|ok")

ROW(g17_g18_g19_select_the_arc_plane,
    "G18\n$G\nG19\n$G\nG17\n$G\nG17 G18\n",
    "ok|[GC:G0 G54 G18 G21 G90 G94 G64 M5 M9 T0 F0 S0]|ok|"
    "ok|[GC:G0 G54 G19 G21 G90 G94 G64 M5 M9 T0 F0 S0]|ok|"
    "ok|[GC:G0 G54 G17 G21 G90 G94 G64 M5 M9 T0 F0 S0]|ok|error:21")

ROW(g20_g21_select_inches_or_millimetres,
    "G20 G90 G0 X1\n"
    "@wait\n@status MPos:25.400,0.000,0.000\n"
    "$G\nG21\n",
    "ok|[GC:G0 G54 G17 G20 G90 G94 G64 M5 M9 T0 F0 S0]|ok|ok")

ROW(g28_g30_go_to_stored_positions_through_an_intermediate_point,
    "G21 G90 G0 X3 Y4\n"
    "G28.1\n"
    "G0 X20 Y20\n"
    "G28 X10\n"                     /* via X10, then X (only) to the stored X3 */
    "@wait\n@status MPos:3.000,20.000,0.000\n"
    "G0 X7 Y8\n"
    "G30.1\n"
    "G0 X0 Y0\n"
    "G30\n"                         /* no axis word: straight there, all axes */
    "@wait\n@status MPos:7.000,8.000,0.000\n"
    "G28.2\n",
    "ok|ok|ok|ok|ok|ok|ok|ok|error:20")

ROW(g38_probing_is_refused_loudly_without_a_probe_input,
    "G21 G90\n"
    "G38.2 Z-5 F100\n"              /* Grbl: the cycle (ALARM:4 without contact) */
    "G38.3 Z-5 F100\n"
    "G38.2 Z-5\n"
    "G38.6 Z-5 F100\n",
    "ok|[MSG:No probe input: G38 is not supported by this machine]|error:20|"
    "[MSG:No probe input: G38 is not supported by this machine]|error:20|"
    "[MSG:No probe input: G38 is not supported by this machine]|error:20|error:20")

ROW(g38_probing_records_the_contact_and_raises_alarms_4_and_5,
    "@inputs\n"
    "@switch 4 2 -1 -5\n"           /* a touch plate: the probe closes at Z = -5 mm */
    "G21 G90 G38.2 Z-10 F100\n"
    "@status Pn:P\n"
    "G38.2 Z-20\n"                  /* already touching */
    "G0 Z0\n"
    "$X\n"
    "G0 Z0\n"
    "G38.2 Z-2\n"                   /* no contact: the last contact, :0 */
    "$X\n"
    "G38.3 Z-2\n"                   /* already there: error:33, as Grbl */
    "G38.3 Z-3\n"                   /* no contact, no error: where it ended */
    "@wait\n@status MPos:0.000,0.000,-3.000\n",
    "[PRB:0.000,0.000,-5.000:1]|ok|ALARM:4|ok|error:9|[MSG:Caution: Unlocked]|ok|ok|"
    "ALARM:5|[PRB:0.000,0.000,-5.000:0]|ok|[MSG:Caution: Unlocked]|ok|"
    "error:33|[PRB:0.000,0.000,-3.000:0]|ok")

ROW(g40_is_accepted_and_cutter_compensation_is_not,
    "G40\nG41\nG42 D1\n",
    "ok|error:20|error:20")

ROW(g43_1_g49_set_and_clear_the_dynamic_tool_length_offset,
    "G21 G90 G43.1 Z2\n"
    "G0 Z0\n"
    "@wait\n@status MPos:0.000,0.000,2.000\n"
    "G43.1 X1\n"
    "G49\n"
    "G0 Z0\n"
    "@wait\n@status MPos:0.000,0.000,0.000\n"
    "G43\n",
    "ok|ok|error:37|ok|ok|error:20")

ROW(g53_moves_in_machine_coordinates_for_one_block,
    "G21 G90 G92 X5\n"
    "G53 G0 X1\n"
    "@wait\n@status MPos:1.000,0.000,0.000\n"
    "G53 G2 X1 I1\n"
    "G53\n",
    "ok|ok|error:30|ok")

ROW(g54_g59_select_stored_work_coordinate_systems,
    "G21 G90 G10 L2 P2 X4 Y1\n"
    "G55 G0 X0 Y0\n"
    "@wait\n@status WCO:4.000,1.000,0.000\n"
    "@status MPos:4.000,1.000,0.000\n"
    "G59 G0 X0\n"
    "@wait\n@status MPos:0.000,1.000,0.000\n"
    "G59.1\n",
    "ok|ok|ok|error:23")

ROW(g61_exact_path_and_g64_p_tolerance_are_plotkin_path_modes,
    "G61\n$G\nG64 P0.05\n$G\nG64 P-1\nG61 P1\n",  /* Grbl: G61 only, no path word in $G */
    "ok|[GC:G0 G54 G17 G21 G90 G94 G61 M5 M9 T0 F0 S0]|ok|"
    "ok|[GC:G0 G54 G17 G21 G90 G94 G64 M5 M9 T0 F0 S0]|ok|error:4|error:36")

ROW(g80_cancels_the_motion_mode,
    "G21 G90 G1 X1 F600\n"
    "G80\n"
    "X5\n"                          /* no motion mode: axis words alone */
    "G80 X1\n"
    "G81 X1 R1 Z-1\n",
    "ok|ok|error:31|error:31|error:20")

ROW(g90_g91_distance_modes_and_g91_1,
    "G21 G91 G0 X1\n"
    "G0 X1\n"
    "@wait\n@status MPos:2.000,0.000,0.000\n"
    "G91.1\n"
    "G90.1\n"
    "G90 G0 X0\n"
    "@wait\n@status MPos:0.000,0.000,0.000\n",
    "ok|ok|ok|error:20|ok")

ROW(g92_sets_and_g92_1_clears_the_axis_offset,
    "G21 G90 G0 X5\n"
    "G92 X10\n"
    "@status WCO:-5.000,0.000,0.000\n"
    "G0 X0\n"
    "@wait\n@status MPos:-5.000,0.000,0.000\n"
    "G92.1\n"
    "@status WCO:0.000,0.000,0.000\n"
    "G92\n",
    "ok|ok|ok|ok|error:26")

ROW(g93_inverse_time_and_g94_feed_modes,
    "G21 G90 G93 G1 X10 F60\n"      /* the move in 1/60 min */
    "G4 P0\n"
    "@took 900 1200\n"
    "G1 X20\n"                      /* G93 needs F on every feed move */
    "G94 G1 X0 F1200\n"
    "$G\n",
    "ok|ok|error:22|ok|[GC:G1 G54 G17 G21 G90 G94 G64 M5 M9 T0 F1200 S0]|ok")

ROW(m0_pauses_m1_is_ignored_m2_m30_end_the_program,
    "G21 G90 G0 X1\n"
    "@wait\n"
    "@raw M0\r\n"                   /* answered after the resume */
    "@status Hold:0\n"
    "@raw ~\n"
    "@wait\n@status Idle\n"
    "M1\n"
    "G91 G1 X1 F500\n"
    "M2\n"
    "$G\n"
    "M30\n",
    "ok|ok|ok|ok|[MSG:Pgm End]|ok|[GC:G1 G54 G17 G21 G90 G94 G64 M5 M9 T0 F500 S0]|ok|"
    "[MSG:Pgm End]|ok")

ROW(m3_m4_m5_run_the_spindle_at_s,
    "M3 S1000\n"
    "@status A:S\n"
    "$G\n"
    "M4 S500\n"
    "@status A:C\n"
    "M5\n"
    "@nostatus A:\n"
    "M3 S-1\n"
    "M3 M5\n",
    "ok|[GC:G0 G54 G17 G21 G90 G94 G64 M3 M9 T0 F0 S1000]|ok|ok|ok|error:4|error:21")

ROW(m7_m8_m9_coolant_states_are_reported,
    "M8\n@status A:F\n"
    "M7\n@status A:FM\n"            /* Grbl's default build has no M7: error:20 */
    "M9\n@nostatus A:\n"
    "M7 M8\n",                      /* one modal group (Grbl with M7) */
    "ok|ok|ok|error:21")

ROW(m56_parking_override_is_accepted,
    "M56\nM56 P0\n",                /* Grbl's default build: error:20 */
    "ok|ok")

ROW(t_words_are_tracked_per_block_as_grbl_does,
    "T7\n$G\nG0\n$G\nT256\nT1.5\n",
    "ok|[GC:G0 G54 G17 G21 G90 G94 G64 M5 M9 T7 F0 S0]|ok|"
    "ok|[GC:G0 G54 G17 G21 G90 G94 G64 M5 M9 T0 F0 S0]|ok|error:38|ok")

ROW(line_syntax_numbers_comments_block_delete_and_case,
    "N10 G21 G90 (comment) g0 x1 ; rest\n"
    "/G0 X2\n"                      /* '/' is ignored, as Grbl */
    "N-1 G0 X1\n"
    "G0 X1 )\n"
    "%\n"                           /* plotkin: an empty line; Grbl: error:1 */
    "G1 X1(c)0.5 F100\n"
    "@wait\n@status MPos:10.500,0.000,0.000\n",
    "ok|ok|error:4|error:1|ok|ok")

ROW(number_format_errors_are_grbl_s,
    "G1 X\nG1 XY1\nG X1\nG1 X-\nG1 X.\nG1 X+-1\nG1 X1.2.3\nG1 X1-2\nM\nF\n#1\n12\nQ1\nG1.5 X1\nG100\n",
    "error:2|error:2|error:2|error:2|error:2|error:2|error:1|error:1|error:2|error:2|"
    "error:1|error:1|error:20|error:23|error:20")

/* ---- realtime commands --------------------------------------------------------------- */

ROW(realtime_hold_resume_and_reset_after_a_completed_hold_is_idle,
    "G21 G90 G1 X20 F300\n"
    "@ms 500\n"
    "@raw !\n"
    "@ms 500\n@status Hold:0\n"
    "@raw \x18\n"
    "@status Idle\n"
    "G1 X1 F3000\n"                 /* the next job runs */
    "@wait\n@status MPos:1.000,0.000,0.000\n",
    "ok|Grbl|ok")

ROW(realtime_reset_while_moving_is_alarm_3_and_x_unlocks,
    "G21 G90 G1 X20 F300\n"
    "@ms 300\n"
    "@raw \x18\n"
    "@status Alarm\n"
    "G0 X0\n"
    "$X\n"
    "G0 X0\n",
    "ok|ALARM:3|Grbl|[MSG:'$H'|'$X' to unlock]|error:9|[MSG:Caution: Unlocked]|ok|ok")

ROW(realtime_bytes_above_0x80_are_taken_off_the_stream,
    "@raw \xc2\x91\n"               /* cncjs: 0x91 as UTF-8 */
    "@status Ov:110,100,100\n"
    "@raw G\xb0\xfe" "0 X1\r\n"     /* unknown bytes vanish from the line */
    "@wait\n@status MPos:1.000,0.000,0.000\n",
    "ok")

ROW(feed_rapid_and_spindle_overrides_use_grbl_s_ranges_and_steps,
    "@repeat 2 \x91\n@repeat 1 \x93\n@repeat 1 \x96\n@repeat 1 \x9a\n"
    "@status Ov:121,50,110\n"
    "@raw \x90\x95\x99\n"
    "@status Ov:100,100,100\n"
    "@repeat 12 \x91\n"
    "@status Ov:200,100,100\n"
    "@repeat 25 \x92\n"
    "@status Ov:10,100,100\n"
    "@raw \x97\n"
    "@status Ov:10,25,100\n"
    "@repeat 12 \x9b\n"
    "@status Ov:10,25,10\n"
    "@repeat 3 \x9c\n"
    "@status Ov:10,25,13\n",
    "")

ROW(coolant_toggle_overrides_flip_the_accessory_state,
    "@raw \xa0\n@status A:F\n@raw \xa1\n@status A:FM\n@raw \xa0\n@raw \xa1\n@nostatus A:\n",
    "")

ROW(safety_door_0x84_is_a_feed_hold_on_a_machine_without_a_door,
    "G21 G90 G1 X20 F300\n"         /* Grbl: Door:N states and the tool cut */
    "@ms 300\n"
    "@raw \x84\n"
    "@ms 500\n@status Hold:0\n"
    "@raw ~\n"
    "@wait\n@status MPos:20.000,0.000,0.000\n",
    "ok|[MSG:No safety door: feed hold only, the tool stays as it is]")

ROW(safety_door_input_holds_and_blocks_resume_while_open,
    "@inputs\n"
    "G21 G90 G1 X20 F300\n"
    "@ms 300\n"
    "@edge 0 5 1\n"                 /* the door opens (Grbl: Door:N, tool cut) */
    "@ms 500\n@status <Hold:0|\n@status Pn:D\n"
    "@raw ~\n"                      /* no resume while it is open */
    "@status <Hold:0|\n"
    "@edge 0 5 0\n@ms 10\n"
    "@raw ~\n"
    "@wait\n@status MPos:20.000,0.000,0.000\n",
    "ok|[MSG:Door open: feed hold only, the tool stays as it is]")

ROW(buttons_hold_resume_and_reset_act_as_their_realtime_bytes,
    "@inputs\n"
    "G21 G90 G1 X20 F600\n"
    "@edge 300 6 1\n@edge 350 6 0\n" /* feed hold button */
    "@ms 900\n@status <Hold:0|\n"
    "@edge 0 7 1\n@edge 50 7 0\n"  /* cycle start button */
    "@ms 100\n@status <Run|\n"
    "@edge 0 8 1\n@edge 50 8 0\n"  /* reset button while moving */
    "@ms 100\n@status <Alarm|\n",
    "ok|ALARM:3|Grbl|[MSG:'$H'|'$X' to unlock]")

ROW(status_report_pn_lists_the_active_inputs_in_grbl_s_order,
    "@inputs\n"
    "@nostatus Pn:\n"
    "@edge 0 4 1\n@edge 0 1 1\n@edge 0 0 1\n@edge 0 7 1\n@ms 10\n"
    "@status |Pn:PXYS\n"
    "@edge 0 4 0\n@edge 0 1 0\n@edge 0 0 0\n@edge 0 7 0\n@ms 10\n"
    "@nostatus Pn:\n",
    "")

ROW(jog_cancel_0x85_stops_a_jog_and_flushes_it,
    "$J=G91 X50 F600\n"
    "@ms 500\n"
    "@status Jog\n"
    "@raw \x85\n"
    "@wait\n@status Idle\n"
    "@nostatus MPos:50.000\n"
    "$J=G91 X1 F600\n"
    "@wait\n",
    "ok|ok")

ROW(status_reports_refresh_wco_and_ov_on_grbl_s_schedule,
    "@status Ov:100,100,100\n"      /* the one after the first (WCO) report */
    "@nostatus WCO\n"
    "G92 X-1\n"
    "@status WCO:1.000,0.000,0.000\n" /* at once after a change */
    "$10=0\n"
    "@status WPos:-1.000,0.000,0.000\n"
    "$10=2\n"
    "@status Bf:\n"
    "$13=1\n"
    "@status WPos:-0.0394,0.0000,0.0000\n",
    "ok|ok|ok|ok")

/* ---- $ commands --------------------------------------------------------------------- */

ROW(dollar_settings_are_listed_set_and_range_checked,
    "$100=100\n@setting $100=100.000\n"
    "$100=-1\n$100\n$5=1\n@setting $5=1\n$999=1\n$12=0.01\n@setting $12=0.010\n",
    "ok|error:4|error:3|ok|error:3|ok")

ROW(dollar_hash_reports_offsets_probe_and_tool_length,
    "G21 G90 G10 L2 P1 X1\nG43.1 Z2\nG92 X3\n$#\n",
    "ok|ok|ok|"
    "[G54:1.000,0.000,0.000]|[G55:0.000,0.000,0.000]|[G56:0.000,0.000,0.000]|"
    "[G57:0.000,0.000,0.000]|[G58:0.000,0.000,0.000]|[G59:0.000,0.000,0.000]|"
    "[G28:0.000,0.000,0.000]|[G30:0.000,0.000,0.000]|[G92:-4.000,0.000,0.000]|"
    "[TLO:2.000]|[PRB:0.000,0.000,0.000:0]|ok")

ROW(dollar_g_reports_the_modal_state_with_f_s_and_t,
    "G1 G91 G20 G93 G55 M4 M8 T3 S250 F10\n$G\n",
    "ok|[GC:G1 G55 G17 G20 G91 G93 G64 M4 M8 T3 F10 S250]|ok")

ROW(dollar_i_reports_build_info_and_stores_a_line,
    "$I=my plotter\n$I\n",          /* Grbl: [VER:1.1h.20190830:..] [OPT:V,15,128] */
    "ok|[VER:1.1h.plotkin-0.1:MYPLOTTER]|[OPT:VM,32,128]|ok")

ROW(dollar_n_startup_lines_run_after_every_reset,
    "$N\n"
    "$N0=G20\n"
    "$N1=G0 X1\n"                   /* run once when stored, as Grbl */
    "@wait\n"
    "$N\n"
    "$N0=G4 P-1\n"                  /* checked before it is stored */
    "$N2=G21\n"                     /* Grbl writes past its two lines: ok */
    "@restart\n"
    "@wait\n@status MPos:25.400,0.000,0.000\n",
    "$N0=|$N1=|ok|ok|ok|$N0=G20|$N1=G0X1|ok|error:4|error:3|"
    "Grbl|>G20:ok|>G0X1:ok")

ROW(dollar_c_check_mode_parses_without_moving,
    "$C\n"
    "G21 G90 G0 X10\n"
    "G2 X1 R1 F100\n"
    "@wait\n@status Check\n"
    "@nostatus MPos:10\n"
    "$C\n"
    "@status Idle\n",
    "[MSG:Enabled]|ok|ok|error:34|[MSG:Disabled]|ok|Grbl")

ROW(dollar_x_unlocks_an_alarm,
    "$X\n"
    "@raw \x18\n"                   /* idle: no alarm */
    "$X\n",
    "ok|Grbl|ok")

ROW(dollar_h_homing_is_refused_loudly_without_limit_switches,
    "$H\n$22=1\n$H\n",              /* Grbl: the cycle (ALARM:9 without switches) */
    "error:5|[MSG:No limit switches: $H cannot run, $X unlocks]|ok|"
    "[MSG:No limit switches: $H is not supported by this machine]|error:5")

ROW(dollar_h_homing_runs_grbl_s_cycle_on_the_switches,
    "@inputs\n"
    "@switch 0 0 1 20\n@switch 1 1 1 10\n@switch 2 2 1 2\n" /* toward +: $23=0 */
    "$H\n"                          /* $22=0 */
    "$22=1\n"
    "$N0=G91\n"
    "$H\n"                          /* Z first, then X and Y; the startup lines, then ok */
    "@status <Idle|MPos:-1.000,-1.000,-1.000\n" /* machine 0 is the switch, -$27 */
    "$HX\n"                         /* no single-axis homing in Grbl's default build */
    "@restart\n"
    "G0 X0\n"                       /* $22=1 locks at power-on */
    "@switch 0 0 1 1000\n"          /* X's switch out of reach: 1.5 x $130 */
    "$H\n",
    "error:5|ok|ok|>G91:ok|ok|error:3|Grbl|[MSG:'$H'|'$X' to unlock]|error:9|"
    "ALARM:9|ok|Grbl|[MSG:'$H'|'$X' to unlock]")

ROW(dollar_j_jogs_with_grbl_s_rules,
    "$J=G91 X1 F600\n"
    "@wait\n@status MPos:1.000,0.000,0.000\n"
    "$J=X1\n"                       /* no feed */
    "$J=G1 X1 F100\n"               /* no motion word allowed */
    "$J=G53 X0 F600\n"
    "@wait\n@status MPos:0.000,0.000,0.000\n"
    "$J=M3 X1 F100\n",
    "ok|error:22|error:16|ok|error:16")

ROW(dollar_slp_sleeps_until_reset,
    "$SLP\n"
    "@status Sleep\n"
    "@raw G0 X1\r\n"                /* not read while asleep */
    "@raw \x18\n"
    "@status Alarm\n"
    "$X\n",
    "ok|[MSG:Sleeping]|Grbl|[MSG:'$H'|'$X' to unlock]|[MSG:Caution: Unlocked]|ok")

ROW(dollar_rst_restores_settings_offsets_or_everything,
    "$100=100\n"
    "G10 L2 P1 X5\n"
    "$RST=#\n"
    "@setting $100=100.000\n"
    "$#\n"
    "$RST=$\n"
    "@setting $100=80.000\n"
    "$RST=*\n"
    "$RST=x\n",
    "ok|ok|[MSG:Restoring defaults]|ok|Grbl|"
    "[G54:0.000,0.000,0.000]|[G55:0.000,0.000,0.000]|[G56:0.000,0.000,0.000]|"
    "[G57:0.000,0.000,0.000]|[G58:0.000,0.000,0.000]|[G59:0.000,0.000,0.000]|"
    "[G28:0.000,0.000,0.000]|[G30:0.000,0.000,0.000]|[G92:0.000,0.000,0.000]|"
    "[TLO:0.000]|[PRB:0.000,0.000,0.000:0]|ok|"
    "[MSG:Restoring defaults]|ok|Grbl|[MSG:Restoring defaults]|ok|Grbl|error:3")

ROW(settings_offsets_and_startup_lines_survive_a_restart,
    "$100=123.5\nG10 L2 P2 X7\n$N0=G91\n$I=kept\n"
    "@restart\n"
    "@setting $100=123.500\n"
    "$G\n$I\n",
    "ok|ok|ok|ok|Grbl|>G91:ok|[GC:G0 G54 G17 G21 G91 G94 G64 M5 M9 T0 F0 S0]|ok|"
    "[VER:1.1h.plotkin-0.1:KEPT]|[OPT:VM,32,128]|ok")

ROW(soft_limits_need_homing_and_alarm_2_on_a_move_out_of_travel,
    "$20=1\n"                       /* needs $22=1 */
    "$22=1\n$20=1\n"
    "G21 G90 G0 X-5\n"              /* Grbl's travel: -$130..0 */
    "@wait\n@status MPos:-5.000,0.000,0.000\n"
    "@raw G0 X10\r\n"
    "@ms 500\n"
    "@raw \x18\n"                   /* the line is answered at the reset */
    "G0 X-7\n"
    "$X\n"
    "$J=G91 X20 F600\n",            /* a jog out of travel is refused */
    "error:10|[MSG:No limit switches: $H cannot run, $X unlocks]|ok|ok|ok|"
    "ALARM:2|[MSG:Reset to continue]|ok|Grbl|[MSG:'$H'|'$X' to unlock]|error:9|"
    "[MSG:Caution: Unlocked]|ok|error:15")

ROW(negative_moves_run_with_soft_limits_off,
    "G21 G90 G0 X-5\n"
    "@wait\n"
    "$J=G91 X-10 F6000\n"
    "@wait\n@status MPos:-15.000,0.000,0.000\n"
    "G92 X10\nG0 X0\n"
    "@wait\n@status MPos:-25.000,0.000,0.000\n",
    "ok|ok|ok|ok")

ROW(hard_limits_are_refused_without_switches_homing_settings_stored,
    "$21=1\n$23=3\n$24=50\n$25=1000\n$26=100\n$27=2\n"   /* Grbl: $21=1 ok */
    "@setting $21=0\n@setting $23=3\n@setting $24=50.000\n@setting $25=1000.000\n"
    "@setting $26=100\n@setting $27=2.000\n",
    "[MSG:No limit switches: $21=1 refused]|error:3|ok|ok|ok|ok|ok")

ROW(hard_limits_21_a_switch_mid_move_is_alarm_1_until_reset,
    "@inputs\n"
    "@switch 0 0 1 40\n"           /* X's switch at 40 mm */
    "$21=1\n"
    "G21 G90 G1 X100 F3000\n"
    "@ms 1500\n"
    "@status <Alarm|MPos:40.000,0.000,0.000|FS:0,0|Pn:X\n" /* stopped on the step that closed it */
    "@raw G0 X0\r\n"               /* not read: only '?' and reset */
    "@raw \x18\n"
    "@status MPos:40.000,0.000,0.000\n"
    "G0 X0\n"
    "$X\n"
    "G0 X10\n"                      /* off the switch (Grbl trips on an edge only) */
    "@wait\n@status <Idle|MPos:10.000,0.000,0.000|FS:0,0|\n"
    "G0 X50\n"                      /* re-armed once the switch opened */
    "@wait\n@status <Alarm|MPos:40.000,0.000,0.000\n",
    "ok|ok|ALARM:1|[MSG:Reset to continue]|Grbl|[MSG:Check Limits]|[MSG:'$H'|'$X' to unlock]|"
    "error:9|[MSG:Caution: Unlocked]|ok|ok|ok|ALARM:1|[MSG:Reset to continue]")

ROW(laser_mode_32_runs_g1_at_s_and_g0_with_the_output_off,
    "$32=1\n"
    "G21 G90 M3 S500\n"
    "@nostatus A:\n"               /* G0 mode: the output is off, as Grbl's pin */
    "G1 X5 F600\n"
    "@wait\n"
    "$G\n",
    "ok|ok|ok|[GC:G1 G54 G17 G21 G90 G94 G64 M3 M9 T0 F600 S500]|ok")

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(g0_g1_move_at_rapid_and_feed_and_need_a_feed_rate),
        TH_CASE(g2_g3_arcs_in_ijk_and_r_form_full_circles_and_helices),
        TH_CASE(g2_g3_arcs_follow_the_plane_g17_g18_g19),
        TH_CASE(g4_dwell_is_answered_after_the_queue_drains_and_the_dwell_ends),
        TH_CASE(g5_g5_1_splines_are_plotkin_extensions),
        TH_CASE(g10_l2_l20_set_coordinate_systems),
        TH_CASE(g17_g18_g19_select_the_arc_plane),
        TH_CASE(g20_g21_select_inches_or_millimetres),
        TH_CASE(g28_g30_go_to_stored_positions_through_an_intermediate_point),
        TH_CASE(g38_probing_is_refused_loudly_without_a_probe_input),
        TH_CASE(g40_is_accepted_and_cutter_compensation_is_not),
        TH_CASE(g43_1_g49_set_and_clear_the_dynamic_tool_length_offset),
        TH_CASE(g53_moves_in_machine_coordinates_for_one_block),
        TH_CASE(g54_g59_select_stored_work_coordinate_systems),
        TH_CASE(g61_exact_path_and_g64_p_tolerance_are_plotkin_path_modes),
        TH_CASE(g80_cancels_the_motion_mode),
        TH_CASE(g90_g91_distance_modes_and_g91_1),
        TH_CASE(g92_sets_and_g92_1_clears_the_axis_offset),
        TH_CASE(g93_inverse_time_and_g94_feed_modes),
        TH_CASE(m0_pauses_m1_is_ignored_m2_m30_end_the_program),
        TH_CASE(m3_m4_m5_run_the_spindle_at_s),
        TH_CASE(m7_m8_m9_coolant_states_are_reported),
        TH_CASE(m56_parking_override_is_accepted),
        TH_CASE(t_words_are_tracked_per_block_as_grbl_does),
        TH_CASE(line_syntax_numbers_comments_block_delete_and_case),
        TH_CASE(number_format_errors_are_grbl_s),
        TH_CASE(realtime_hold_resume_and_reset_after_a_completed_hold_is_idle),
        TH_CASE(realtime_reset_while_moving_is_alarm_3_and_x_unlocks),
        TH_CASE(realtime_bytes_above_0x80_are_taken_off_the_stream),
        TH_CASE(feed_rapid_and_spindle_overrides_use_grbl_s_ranges_and_steps),
        TH_CASE(coolant_toggle_overrides_flip_the_accessory_state),
        TH_CASE(safety_door_0x84_is_a_feed_hold_on_a_machine_without_a_door),
        TH_CASE(jog_cancel_0x85_stops_a_jog_and_flushes_it),
        TH_CASE(status_reports_refresh_wco_and_ov_on_grbl_s_schedule),
        TH_CASE(dollar_settings_are_listed_set_and_range_checked),
        TH_CASE(dollar_hash_reports_offsets_probe_and_tool_length),
        TH_CASE(dollar_g_reports_the_modal_state_with_f_s_and_t),
        TH_CASE(dollar_i_reports_build_info_and_stores_a_line),
        TH_CASE(dollar_n_startup_lines_run_after_every_reset),
        TH_CASE(dollar_c_check_mode_parses_without_moving),
        TH_CASE(dollar_x_unlocks_an_alarm),
        TH_CASE(dollar_h_homing_is_refused_loudly_without_limit_switches),
        TH_CASE(dollar_j_jogs_with_grbl_s_rules),
        TH_CASE(dollar_slp_sleeps_until_reset),
        TH_CASE(dollar_rst_restores_settings_offsets_or_everything),
        TH_CASE(settings_offsets_and_startup_lines_survive_a_restart),
        TH_CASE(soft_limits_need_homing_and_alarm_2_on_a_move_out_of_travel),
        TH_CASE(negative_moves_run_with_soft_limits_off),
        TH_CASE(hard_limits_are_refused_without_switches_homing_settings_stored),
        TH_CASE(hard_limits_21_a_switch_mid_move_is_alarm_1_until_reset),
        TH_CASE(dollar_h_homing_runs_grbl_s_cycle_on_the_switches),
        TH_CASE(g38_probing_records_the_contact_and_raises_alarms_4_and_5),
        TH_CASE(safety_door_input_holds_and_blocks_resume_while_open),
        TH_CASE(buttons_hold_resume_and_reset_act_as_their_realtime_bytes),
        TH_CASE(status_report_pn_lists_the_active_inputs_in_grbl_s_order),
        TH_CASE(laser_mode_32_runs_g1_at_s_and_g0_with_the_output_off),
    };
    return th_run(cases, TH_COUNT(cases));
}
