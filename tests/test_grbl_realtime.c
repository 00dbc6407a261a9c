/*
 * test_grbl_realtime.c — regression tests of the findings R1 and R2 in the
 * Grbl engine's realtime byte path (firmware/pk_grbl.c), found by
 * tests/fuzz/fuzz_realtime.c (its inputs, kept fixed by make test:
 * tests/fuzz/corpus/fuzz_realtime/regress-R*) and fixed by the engine
 * rebuild: a '!' behind 16 '?' in one burst was lost (a 16-entry event
 * ring), and bytes >= 0x80 outside Grbl's list reached the line.
 *
 * The rig is the real byte intake: hal/pk_uart.c's receive ring with
 * pk_grbl_rt_filter in its receive path (as the RX interrupt calls it), the
 * engine polled as the main loop does, and a fake machine that counts the
 * engine's hold requests and keeps one move queued (it never executes, so the
 * machine is running throughout). Expected behaviour: Grbl 1.1's
 * (serial.c: every realtime byte sets a flag in the receive interrupt, and
 * any other byte >= 0x80 is thrown away there).
 */
#include <stdint.h>
#include <string.h>
#include "th.h"
#include "pk_grbl.h"
#include "pk_uart.h"

int th_main(int argc, char **argv);

static struct {
    unsigned q, holds, moves;
    pk_um_t pos[PK_GC_AXES];
} F;

static int f_move(void *m, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t f, int rapid)
{
    (void)m; (void)f; (void)rapid;
    if (F.q >= 4u)
        return PK_GRBL_M_FULL;
    F.q++;
    F.moves++;
    memcpy(F.pos, t, sizeof F.pos);
    return PK_GRBL_M_OK;
}
static int f_ok(void *m) { (void)m; return PK_GRBL_M_OK; }
static int f_pen(void *m, int down) { (void)down; return f_ok(m); }
static int f_dwell(void *m, uint32_t ms) { (void)ms; return f_ok(m); }
static int f_smooth(void *m, int exact, pk_um_t tol) { (void)exact; (void)tol; return f_ok(m); }
static void f_hold(void *m) { (void)m; F.holds++; }
static void f_resume(void *m) { (void)m; }
static int f_reset(void *m) { (void)m; F.q = 0; return 0; }
static void f_pos(void *m, pk_um_t out[PK_GC_AXES]) { (void)m; memcpy(out, F.pos, sizeof F.pos); }
static int f_state(void *m) { (void)m; return F.q ? PK_GRBL_M_RUN : PK_GRBL_M_IDLE; }
static uint32_t f_free(void *m) { (void)m; return 4u - F.q; }
static uint32_t f_total(void *m) { (void)m; return 4u; }
static pk_gc_umpm_t f_speed(void *m) { (void)m; return 0; }
static int f_conf(void *m, const struct pk_grbl_settings *s) { (void)m; (void)s; return 0; }

static const struct pk_grbl_machine_ops OPS = {
    .move = f_move, .pen = f_pen, .dwell = f_dwell, .smoothing = f_smooth, .end = f_ok,
    .hold = f_hold, .resume = f_resume, .reset = f_reset, .position_um = f_pos,
    .state = f_state, .blocks_free = f_free, .blocks_total = f_total, .speed_umpm = f_speed,
    .configure = f_conf,
};

static struct pk_uart U;
static struct pk_grbl G;
static char OUT[4096];
static size_t outn;

/* One main-loop pass, then a reader takes up to `most` bytes of output
 * (SIZE_MAX: all of it). */
static void poll_once(size_t most)
{
    pk_grbl_poll(&G);
    size_t k;
    uint8_t b[64];
    while (most > 0 && (k = pk_uart_tx_pop(&U, b, most < sizeof b ? most : sizeof b)) > 0) {
        most -= k;
        if (outn + k < sizeof OUT) {
            memcpy(OUT + outn, b, k);
            outn += k;
            OUT[outn] = 0;
        }
    }
}

static void poll_n(int n)
{
    for (int i = 0; i < n; i++)
        poll_once(SIZE_MAX);
}

static void rx(const char *s, size_t n)
{
    for (size_t i = 0; i < n; i++)
        (void)pk_uart_rx_push(&U, (uint8_t)s[i]);
}

/* The engine greeted, one move line was accepted: the machine runs. */
static void rig_running(void)
{
    memset(&F, 0, sizeof F);
    outn = 0;
    OUT[0] = 0;
    pk_uart_init(&U, pk_grbl_rt_filter, &G);
    struct pk_grbl_stream io = { pk_uart_read_cb, pk_uart_write_cb, pk_uart_rx_used_cb, &U };
    TH_EXPECT_EQ(pk_grbl_init(&G, &io, &OPS, &F, NULL, NULL), 0);
    poll_n(2);
    rx("G1X1F600\n", 9);
    poll_n(3);
    TH_EXPECT_EQ(F.moves, 1);
}

/* R1: '!' after 16 '?' in one burst (faster than one main-loop period: 17
 * bytes are 1.5 ms at 115200 baud) is dropped: the engine's 16-entry event
 * ring is full. Grbl keeps one flag per command, so the hold happens. */
static void test_a_feed_hold_behind_sixteen_status_queries_is_not_lost(void)
{
    rig_running();
    char b[17];
    memset(b, '?', 16);
    b[16] = '!';
    rx(b, sizeof b);
    poll_n(1);
    TH_EXPECT_EQ(F.holds, 1);
}

/* R2: a byte >= 0x80 outside the list the filter knows (here 0x80, and
 * cncjs's UTF-8 lead byte 0xC2 before 0x91) reaches the line, which fails
 * with error:1 and does not move. Grbl drops every such byte in the
 * receive interrupt: the line runs. */
static void test_unknown_bytes_over_0x7f_are_dropped_and_the_line_runs(void)
{
    rig_running();
    for (unsigned b = 0x80; b < 0x100; b++)
        TH_EXPECT(pk_grbl_rt_filter(&G, (uint8_t)b) != 0);
    rig_running();
    rx("G1X2\x80" "F600\n", 10);
    rx("G1X3\xC2\x91" "F600\n", 11);
    poll_n(4);
    TH_EXPECT_EQ(F.moves, 3);
    TH_EXPECT(strstr(OUT, "error") == NULL);
}

/* pk_grbl_wants_cpu (what ends a long machine poll, pk_machine_set_yield):
 * true from the moment a realtime byte is claimed in the receive path until
 * the engine has taken it and its answer has left the staging buffer, false
 * while the engine has nothing to do. */
static void test_the_engine_wants_the_cpu_while_a_realtime_command_or_its_answer_waits(void)
{
    rig_running();
    poll_n(3);
    TH_EXPECT(!pk_grbl_wants_cpu(&G));
    rx("?", 1);
    TH_EXPECT(pk_grbl_wants_cpu(&G));      /* claimed, not yet taken */
    pk_grbl_poll(&G);                      /* taken; the report is handed to the ring */
    TH_EXPECT(!pk_grbl_wants_cpu(&G));
    poll_n(1);
    TH_EXPECT(strstr(OUT, "<Run|") != NULL);
    /* output that does not fit the ring stays staged: wanted until it left */
    F.q = 0; /* the fake machine is idle: $$ is answered */
    poll_n(2);
    outn = 0;
    rx("$$\n", 3);
    bool wanted = false;
    for (int i = 0; i < 200; i++) {
        poll_once(8); /* a slow reader: 8 bytes a main loop run */
        wanted |= pk_grbl_wants_cpu(&G);
    }
    TH_EXPECT(wanted);
    TH_EXPECT(strstr(OUT, "$0=") != NULL);
    rig_running();
    poll_n(3);
    /* a line is not urgent, a hold is */
    rx("G1X2F600\n", 9);
    TH_EXPECT(!pk_grbl_wants_cpu(&G));
    rx("!", 1);
    TH_EXPECT(pk_grbl_wants_cpu(&G));
    poll_n(2);
    TH_EXPECT_EQ(F.holds, 1);
    TH_EXPECT(!pk_grbl_wants_cpu(&G));
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_a_feed_hold_behind_sixteen_status_queries_is_not_lost),
        TH_CASE(test_unknown_bytes_over_0x7f_are_dropped_and_the_line_runs),
        TH_CASE(test_the_engine_wants_the_cpu_while_a_realtime_command_or_its_answer_waits),
    };
    return th_run(cases, TH_COUNT(cases));
}
