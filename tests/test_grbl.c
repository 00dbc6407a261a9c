/*
 * test_grbl.c — the Grbl 1.1 protocol engine (firmware/pk_grbl.c) over the
 * real UART shim (hal/pk_uart.c, realtime filter in the receive path) and a
 * fake machine that records every request and executes one per step, so the
 * tests control exactly when the machine has room.
 *
 * Expected values come from the G-code text and Grbl's published protocol
 * (error numbers, message formats), never from the engine's output.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "pk_grbl.h"
#include "pk_uart.h"

int th_main(int argc, char **argv);

/* ---- fake machine ------------------------------------------------------------ */

enum { REQ_MOVE = 1, REQ_RAPID, REQ_PEN, REQ_DWELL, REQ_SMOOTH, REQ_END, REQ_SPINDLE };

struct req {
    int type;
    pk_um_t p[3];
    int32_t arg;
};

#define LOG_MAX 20000
struct fake {
    int room;                 /* requests it can hold */
    struct req q[64];
    int qn;
    struct req log[LOG_MAX];  /* everything ever accepted, in order */
    int logn;
    pk_um_t pos[3];           /* position after the last executed move */
    int held;
    int resets;
    int configured;
    struct pk_grbl_settings set;
    int ovr_feed, ovr_rapid;
};

static int f_push(struct fake *f, struct req r)
{
    if (f->qn >= f->room)
        return PK_GRBL_M_FULL;
    f->q[f->qn++] = r;
    if (f->logn < LOG_MAX)
        f->log[f->logn++] = r;
    return PK_GRBL_M_OK;
}
static int f_move(void *m, const pk_um_t t[3], pk_gc_umpm_t feed, int rapid)
{
    struct req r = { rapid ? REQ_RAPID : REQ_MOVE, { t[0], t[1], t[2] }, feed };
    return f_push(m, r);
}
static int f_chord(void *m, const pk_um_t t[3], pk_gc_umpm_t feed, pk_um_t err)
{
    struct req r = { REQ_MOVE, { t[0], t[1], t[2] }, feed };
    (void)err;
    return f_push(m, r);
}
static int f_pen(void *m, int down) { return f_push(m, (struct req){ REQ_PEN, { 0 }, down }); }
static int f_spindle(void *m, uint16_t v, int sync)
{
    return f_push(m, (struct req){ REQ_SPINDLE, { sync, 0, 0 }, v });
}
static int f_override(void *m, uint16_t feed, uint16_t rapid)
{
    struct fake *f = m;
    f->ovr_feed = feed;
    f->ovr_rapid = rapid;
    return PK_GRBL_M_OK;
}
static int f_dwell(void *m, uint32_t ms) { return f_push(m, (struct req){ REQ_DWELL, { 0 }, (int32_t)ms }); }
static int f_smooth(void *m, int exact, pk_um_t tol)
{
    return f_push(m, (struct req){ REQ_SMOOTH, { exact, 0, 0 }, tol });
}
static int f_end(void *m) { return f_push(m, (struct req){ REQ_END, { 0 }, 0 }); }
/* A hold decelerates (HOLDING) until the next executed step, then stops (HOLD). */
static void f_hold(void *m) { struct fake *f = m; if (f->qn) f->held = 2; }
static void f_resume(void *m) { ((struct fake *)m)->held = 0; }
static int f_reset(void *m)
{
    struct fake *f = m;
    int cut = f->qn > 0 && f->held != 1; /* a completed hold loses nothing */
    f->qn = 0;
    f->held = 0;
    f->resets++;
    return cut;
}
static void f_pos(void *m, pk_um_t out[3]) { memcpy(out, ((struct fake *)m)->pos, sizeof ((struct fake *)m)->pos); }
static int f_state(void *m)
{
    struct fake *f = m;
    return f->held == 2 ? PK_GRBL_M_HOLDING : f->held ? PK_GRBL_M_HOLD
           : f->qn ? PK_GRBL_M_RUN : PK_GRBL_M_IDLE;
}
static uint32_t f_free(void *m) { struct fake *f = m; return (uint32_t)(f->room - f->qn); }
static uint32_t f_total(void *m) { return (uint32_t)((struct fake *)m)->room; }
static pk_gc_umpm_t f_speed(void *m) { struct fake *f = m; return f->qn && !f->held ? f->q[0].arg : 0; }
static int f_conf(void *m, const struct pk_grbl_settings *s)
{
    struct fake *f = m;
    f->set = *s;
    f->configured++;
    return 0;
}
static const struct pk_grbl_machine_ops fake_ops = {
    .move = f_move, .move_chord = f_chord, .pen = f_pen, .spindle = f_spindle,
    .dwell = f_dwell, .smoothing = f_smooth, .end = f_end, .hold = f_hold, .resume = f_resume,
    .reset = f_reset, .position_um = f_pos, .state = f_state, .blocks_free = f_free,
    .blocks_total = f_total, .speed_umpm = f_speed, .configure = f_conf,
    .set_override = f_override,
};

/* Execute one queued request (unless held). */
static void f_step(struct fake *f)
{
    if (f->held == 2)
        f->held = 1;
    if (f->held || f->qn == 0)
        return;
    struct req r = f->q[0];
    if (r.type == REQ_MOVE || r.type == REQ_RAPID)
        memcpy(f->pos, r.p, sizeof f->pos);
    memmove(f->q, f->q + 1, sizeof f->q[0] * (size_t)(f->qn - 1));
    f->qn--;
}

/* ---- rig: engine + UART + fake -------------------------------------------------- */

struct rig {
    struct pk_uart u;
    struct pk_grbl g;
    struct fake f;
    uint8_t nvm_buf[PK_GRBL_NVM_BYTES];
    struct pk_grbl_ram_nvm ram;
    char out[65536];
    size_t outn;
};

static struct rig R;

/* Start the engine on the fake with the store as it is (keep = 1: a restart
 * with the same "EEPROM"; else an erased one). */
static void rig_start(int room, int keep, const struct pk_grbl_machine_ops *ops)
{
    static uint8_t saved[PK_GRBL_NVM_BYTES];
    if (keep)
        memcpy(saved, R.nvm_buf, sizeof saved);
    memset(&R, 0, sizeof R);
    if (keep)
        memcpy(R.nvm_buf, saved, sizeof saved);
    else
        memset(R.nvm_buf, 0xff, sizeof R.nvm_buf);
    R.f.room = room;
    R.ram.buf = R.nvm_buf;
    R.ram.size = sizeof R.nvm_buf;
    struct pk_grbl_nvm nvm;
    pk_grbl_ram_nvm(&R.ram, &nvm);
    pk_uart_init(&R.u, pk_grbl_rt_filter, &R.g);
    struct pk_grbl_stream io = { pk_uart_read_cb, pk_uart_write_cb, pk_uart_rx_used_cb, &R.u };
    TH_EXPECT_EQ(pk_grbl_init(&R.g, &io, ops ? ops : &fake_ops, &R.f, NULL, &nvm), 0);
}

static void rig_init(int room) { rig_start(room, 0, NULL); }

static void drain_tx(void)
{
    uint8_t b[128];
    size_t n;
    while ((n = pk_uart_tx_pop(&R.u, b, sizeof b)) > 0) {
        if (R.outn + n < sizeof R.out) {
            memcpy(R.out + R.outn, b, n);
            R.outn += n;
            R.out[R.outn] = 0;
        }
    }
}

static void poll_n(int n, int step)
{
    for (int i = 0; i < n; i++) {
        pk_grbl_poll(&R.g);
        drain_tx();
        if (step)
            f_step(&R.f);
    }
}

/* Push bytes as the RX interrupt would (realtime filter first). Returns the
 * number stored or claimed (stops when the ring is full). */
static size_t rx(const char *s, size_t n)
{
    size_t i = 0;
    for (; i < n; i++) {
        int rt = s[i] == '?' || s[i] == '!' || s[i] == '~' || s[i] == 0x18 || (unsigned char)s[i] >= 0x80;
        if (pk_uart_rx_space(&R.u) == 0 && !rt)
            break;
        pk_uart_rx_push(&R.u, (uint8_t)s[i]);
    }
    return i;
}
static void rxs(const char *s) { TH_EXPECT_EQ(rx(s, strlen(s)), strlen(s)); }

static int count(const char *hay, const char *needle)
{
    int c = 0;
    for (const char *p = hay; (p = strstr(p, needle)) != NULL; p += strlen(needle))
        c++;
    return c;
}

/* Answers (ok / error:N) in order, from the captured output. */
static int answers(int *codes, int max)
{
    int n = 0;
    const char *p = R.out;
    while (*p && n < max) {
        const char *e = strstr(p, "\r\n");
        if (!e)
            break;
        if (e - p == 2 && !strncmp(p, "ok", 2))
            codes[n++] = 0;
        else if (!strncmp(p, "error:", 6))
            codes[n++] = atoi(p + 6);
        p = e + 2;
    }
    return n;
}

/* ---- tests ----------------------------------------------------------------------- */

static void test_the_greeting_names_grbl_1_1_and_plotkin(void)
{
    rig_init(8);
    poll_n(2, 0);
    TH_EXPECT(strncmp(R.out, "\r\nGrbl 1.1h [plotkin", 20) == 0);
    TH_EXPECT(count(R.out, "'$' for help]\r\n") == 1);
    TH_EXPECT_EQ(R.f.configured, 1);
}

static void test_character_counted_stream_is_acked_once_per_line_in_order(void)
{
    rig_init(4);
    poll_n(2, 0);
    R.outn = 0;
    enum { N = 500 };
    static char lines[N][40];
    for (int i = 0; i < N; i++)
        snprintf(lines[i], sizeof lines[i], "G1 X%d.%03d Y%d F3000\n", i % 250, (i * 7) % 1000,
                 (i * 3) % 200);
    int sent = 0, acked = 0, released = 0;
    size_t inflight[N];
    size_t budget_used = 0;
    for (int spins = 0; spins < 200000 && acked < N; spins++) {
        /* Character counting: never more than 128 unacknowledged bytes. */
        while (sent < N && budget_used + strlen(lines[sent]) <= 128) {
            rxs(lines[sent]);
            inflight[sent] = strlen(lines[sent]);
            budget_used += inflight[sent];
            sent++;
        }
        size_t before = R.outn;
        poll_n(1, 1);
        acked += count(R.out + before, "ok\r\n");
        TH_ASSERT(count(R.out + before, "error") == 0);
        while (released < acked) /* an ok frees its line's bytes */
            budget_used -= inflight[released++];
    }
    TH_ASSERT_EQ(acked, N);
    TH_EXPECT_EQ(pk_uart_rx_dropped(&R.u), 0);
    poll_n(100, 1);
    /* Every move reached the machine once, in order, at the right target. */
    int k = 0;
    for (int i = 0; i < R.f.logn; i++) {
        if (R.f.log[i].type != REQ_MOVE)
            continue;
        int32_t x = (k % 250) * 1000 + (k * 7) % 1000;
        TH_EXPECT_EQ(R.f.log[i].p[0], x);
        TH_EXPECT_EQ(R.f.log[i].p[1], ((k * 3) % 200) * 1000);
        TH_EXPECT_EQ(R.f.log[i].arg, 3000000);
        k++;
    }
    TH_EXPECT_EQ(k, N);
    TH_EXPECT_EQ(R.g.stats.ok, N);
}

static void test_a_full_machine_stops_reading_so_nothing_is_lost(void)
{
    rig_init(2);
    poll_n(2, 0);
    R.outn = 0;
    const char *prog = "G0 X1\nG0 X2\nG0 X3\nG0 X4\nG0 X5\nG0 X6\n";
    rxs(prog);
    poll_n(20, 0); /* the machine never executes */
    /* Two moves fit, the third line waits unacknowledged, the rest stay in
     * the receive ring untouched. */
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 2);
    TH_EXPECT_EQ(R.f.logn, 2);
    TH_EXPECT_EQ(pk_uart_rx_used(&R.u), strlen("G0 X4\nG0 X5\nG0 X6\n"));
    poll_n(40, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 6);
    TH_ASSERT_EQ(R.f.logn, 6);
    for (int i = 0; i < 6; i++)
        TH_EXPECT_EQ(R.f.log[i].p[0], (i + 1) * 1000);
}

static void test_status_mid_line_reports_and_leaves_the_line_intact(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    rxs("G1 X1?0 Y?2 F6?00\n");
    poll_n(3, 0);
    TH_EXPECT_EQ(count(R.out, "<"), 1); /* three '?' before a poll: one report is enough */
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 1);
    TH_ASSERT_EQ(R.f.logn, 1);
    TH_EXPECT_EQ(R.f.log[0].p[0], 10000);
    TH_EXPECT_EQ(R.f.log[0].p[1], 2000);
    TH_EXPECT_EQ(R.f.log[0].arg, 600000);
    R.outn = 0;
    rxs("?");
    poll_n(1, 0);
    TH_EXPECT(strcmp(R.out, "<Run|MPos:0.000,0.000,0.000|FS:600,0|Ov:100,100,100>\r\n") == 0);
    poll_n(2, 1);
    R.outn = 0;
    rxs("?");
    poll_n(1, 0);
    TH_EXPECT(strcmp(R.out, "<Idle|MPos:10.000,2.000,0.000|FS:0,0>\r\n") == 0);
}

static void test_hold_and_resume_act_at_once_even_mid_line(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("G1 X5 F100\nG1 X6\n");
    poll_n(2, 0);
    R.outn = 0;
    rxs("G1 X!7");     /* '!' inside a line that is still being typed */
    poll_n(1, 0);
    TH_EXPECT(R.f.held);
    rxs("?");
    poll_n(1, 0);
    TH_EXPECT(strstr(R.out, "<Hold:1|") != NULL); /* still decelerating */
    poll_n(1, 1);
    rxs("?");
    poll_n(2, 1);
    TH_EXPECT(strstr(R.out, "<Hold:0|") != NULL);
    TH_EXPECT(R.f.pos[0] == 0); /* nothing executed while held */
    rxs("~\n");
    poll_n(10, 1);
    TH_EXPECT(!R.f.held);
    TH_EXPECT_EQ(R.f.pos[0], 7000);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 1);
}

static void test_soft_reset_in_motion_clears_the_queue_and_locks_until_unlock(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("G1 X5 F100\nG1 X6\nG1 X7\n");
    poll_n(2, 0);
    TH_ASSERT(R.f.qn == 3);
    R.outn = 0;
    rxs("G1 X8\x18");
    poll_n(2, 0);
    TH_EXPECT_EQ(R.f.qn, 0);
    TH_EXPECT_EQ(R.f.resets, 1);
    TH_EXPECT(strstr(R.out, "ALARM:3\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "Grbl 1.1h [plotkin") != NULL);
    TH_EXPECT(strstr(R.out, "[MSG:'$H'|'$X' to unlock]") != NULL);
    rxs("?");
    R.outn = 0;
    poll_n(1, 0);
    TH_EXPECT(strncmp(R.out, "<Alarm|", 7) == 0);
    R.outn = 0;
    rxs("G0 X1\n(comment only)\n$X\nG0 X1\n");
    poll_n(5, 0);
    int c[8];
    TH_ASSERT_EQ(answers(c, 8), 4);
    TH_EXPECT_EQ(c[0], 9);
    TH_EXPECT_EQ(c[1], 0);
    TH_EXPECT_EQ(c[2], 0);
    TH_EXPECT_EQ(c[3], 0);
    TH_EXPECT(strstr(R.out, "[MSG:Caution: Unlocked]") != NULL);
    TH_EXPECT_EQ(R.f.qn, 1); /* only the move after the unlock */
}

static void test_soft_reset_when_idle_does_not_alarm(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    rxs("\x18");
    poll_n(2, 0);
    TH_EXPECT(strstr(R.out, "ALARM") == NULL);
    TH_EXPECT(strstr(R.out, "Grbl 1.1h") != NULL);
    rxs("G0 X1\n");
    poll_n(2, 0);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 1);
}

/* Bad lines on the wire, each followed by a valid move that must execute. */
static const struct { const char *line; int err; } wire_bad[] = {
    { "G1 X1 X2\n", 25 },
    { "G1 A5\n", 20 },
    { "G1 X\n", 2 },
    { "G1 X12345678901\n", 2 },
    { "G0 X3000\n", 15 },
    { "G53 G0 Y-2098\n", 15 },
    { "G1 X1 F-5\n", 4 },
    { "G0 G1 X1\n", 24 },
    { "G90 G91\n", 21 },
    { "G1.5 X1\n", 23 },
    { "G4\n", 28 },
    { "N99999999 G0 X1\n", 27 },
    { "\x01\x02\x03garbage\n", 2 },
    { "G1 X1 \xfe\xff\n", 22 },
    { "X1 )\n", 1 },
    { "$Q\n", 2 },
    { "$SLX\n", 3 },
    { "$100=abc\n", 2 },
    { "$100=-1\n", 4 },
    { "$999=1\n", 3 },
    { "$H\n", 5 },
};

static void test_every_bad_line_gets_its_error_and_later_lines_still_run(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    int expect[64], ne = 0;
    for (unsigned i = 0; i < TH_COUNT(wire_bad); i++) {
        char good[32];
        snprintf(good, sizeof good, "G0 X%u\n", i + 1);
        rxs(wire_bad[i].line);
        expect[ne++] = wire_bad[i].err;
        rxs(good);
        expect[ne++] = 0;
        poll_n(4, 1);
    }
    int got[64];
    int n = answers(got, 64);
    TH_ASSERT_EQ(n, ne);
    for (int i = 0; i < n; i++) {
        if (got[i] != expect[i]) {
            th_print("  bad line: ");
            th_print(wire_bad[i / 2].line);
        }
        TH_EXPECT_EQ(got[i], expect[i]);
    }
    /* Exactly the good moves reached the machine. */
    TH_ASSERT_EQ(R.f.logn, (int)TH_COUNT(wire_bad));
    for (int i = 0; i < R.f.logn; i++)
        TH_EXPECT_EQ(R.f.log[i].p[0], (i + 1) * 1000);
}

static void test_line_ends_long_lines_and_overflow_follow_grbl(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    /* CR, LF and CR LF each end one line; a lone CR or LF is an empty line. */
    rxs("G0 X1\rG0 X2\nG0 X3\r\n\n\r");
    poll_n(6, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 5);
    TH_EXPECT_EQ(R.f.logn, 3);
    /* A 300-byte line: error:11, nothing of it runs; the next line does. */
    R.outn = 0;
    char longl[302];
    memset(longl, '0', sizeof longl); /* Grbl counts kept bytes: no blanks, no comments */
    memcpy(longl, "G0 X9", 5);
    longl[300] = '\n';
    longl[301] = 0;
    size_t off = 0;
    while (off < 301) {
        off += rx(longl + off, 301 - off);
        poll_n(1, 1);
    }
    rxs("G0 X4\n");
    poll_n(4, 1);
    int c[4];
    TH_ASSERT_EQ(answers(c, 4), 2);
    TH_EXPECT_EQ(c[0], 11);
    TH_EXPECT_EQ(c[1], 0);
    TH_EXPECT_EQ(R.f.logn, 4);
    TH_EXPECT_EQ(R.f.log[3].p[0], 4000);
    /* Bytes lost to a full ring fail the line they belonged to. */
    R.outn = 0;
    char flood[200];
    memset(flood, 'X', sizeof flood);
    for (size_t i = 0; i < sizeof flood; i++)
        pk_uart_rx_push(&R.u, (uint8_t)flood[i]); /* 72 bytes dropped */
    poll_n(2, 1);
    rxs("\nG0 X5\n");
    poll_n(6, 1);
    TH_EXPECT(pk_uart_rx_dropped(&R.u) > 0);
    TH_ASSERT_EQ(answers(c, 4), 2);
    TH_EXPECT_EQ(c[0], 11);
    TH_EXPECT_EQ(c[1], 0);
    TH_EXPECT(strstr(R.out, "[MSG:RX overflow") != NULL);
    TH_EXPECT_EQ(R.f.log[R.f.logn - 1].p[0], 5000);
}

static void test_settings_list_set_and_reach_the_machine(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    rxs("$$\n");
    poll_n(30, 0);
    TH_EXPECT(strstr(R.out, "$0=10\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$11=0.010\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$100=80.000\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$130=300.000\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$204=60\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$12=0.020\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$30=1000\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$32=0\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "$207=0\r\n") != NULL);
    TH_EXPECT_EQ(count(R.out, "$"), PK_GRBL_S_COUNT);
    TH_EXPECT(strstr(R.out, "ok\r\n") == R.out + R.outn - 4);
    R.outn = 0;
    rxs("$100 = 157.5\n$130=100\n$202=1.5\n$I\n$100=78.74016\nG0 X150\nG0 X100\n");
    poll_n(8, 1);
    int c[8];
    TH_ASSERT_EQ(answers(c, 8), 7);
    for (int i = 0; i < 7; i++)
        TH_EXPECT_EQ(c[i], 0); /* $202=1.5: truncated as Grbl; X150: $20=0, no travel check */
    TH_EXPECT_EQ(R.f.set.v[PK_GRBL_S_DEGREE], 1);
    TH_EXPECT_EQ(R.f.set.v[PK_GRBL_S_STEPS_X], 787402); /* 4 decimals kept */
    TH_EXPECT(strstr(R.out, "[OPT:VM,8,128]") != NULL);
    poll_n(4, 1);
    R.outn = 0;
    rxs("$$\n");
    poll_n(30, 0);
    TH_EXPECT(strstr(R.out, "$100=78.7402\r\n") != NULL);
    /* Not while moving: error 8. */
    rxs("G1 X10 F10\n$100=80\n");
    poll_n(2, 0);
    TH_EXPECT(strstr(R.out, "error:8\r\n") != NULL);
}

static void test_check_mode_parses_without_moving(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    rxs("$C\nG0 X10\nG0 X3000\n");
    poll_n(4, 1);
    rxs("?");
    poll_n(1, 1);
    int c[4];
    TH_ASSERT_EQ(answers(c, 4), 3);
    TH_EXPECT(c[0] == 0 && c[1] == 0 && c[2] == 15);
    TH_EXPECT_EQ(R.f.logn, 0);
    TH_EXPECT(strstr(R.out, "<Check|") != NULL);
    rxs("$C\n");
    poll_n(3, 1);
    TH_EXPECT(strstr(R.out, "[MSG:Disabled]") != NULL);
    TH_EXPECT_EQ(count(R.out, "Grbl 1.1h"), 1); /* restarts like Grbl */
}

static void test_pen_dwell_smoothing_and_end_reach_the_machine_in_order(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("M3\nM3\nG4 P0.5\nG61\nG64 P0.2\nG64\nG1 X1 F100\nM2\n");
    poll_n(20, 1);
    static const int want[] = { REQ_PEN, REQ_DWELL, REQ_SMOOTH, REQ_SMOOTH, REQ_SMOOTH,
                                REQ_MOVE, REQ_END, REQ_PEN };
    TH_ASSERT_EQ(R.f.logn, (int)TH_COUNT(want));
    for (unsigned i = 0; i < TH_COUNT(want); i++)
        TH_EXPECT_EQ(R.f.log[i].type, want[i]);
    TH_EXPECT_EQ(R.f.log[0].arg, 1);          /* M3 = pen down (the second M3 adds nothing) */
    TH_EXPECT_EQ(R.f.log[1].arg, 500);        /* ms */
    TH_EXPECT_EQ(R.f.log[2].p[0], 1);         /* G61 exact */
    TH_EXPECT_EQ(R.f.log[3].arg, 200);        /* G64 P0.2 = 200 µm */
    TH_EXPECT_EQ(R.f.log[4].arg, 20);         /* G64 alone: $12 = 0.020 mm */
    TH_EXPECT_EQ(R.f.log[7].arg, 0);          /* M2 lifts the pen once all has run */
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 8);
}

static void test_a_g5_curve_streams_through_a_tiny_queue_and_ends_exactly(void)
{
    rig_init(2);
    poll_n(2, 0);
    rxs("G0 X10 Y10\nG5 X60 Y10 I0 J40 P0 Q40 F2000\nG5.1 X100 Y50 I40 J0\n");
    poll_n(400, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 3);
    TH_ASSERT(R.f.logn > 10);
    TH_EXPECT_EQ(R.f.pos[0], 100000);
    TH_EXPECT_EQ(R.f.pos[1], 50000);
    /* The cubic's vertices stay inside its control polygon's box. */
    int cubic_end = -1;
    for (int i = 1; i < R.f.logn; i++) {
        TH_EXPECT(R.f.log[i].type == REQ_MOVE);
        TH_EXPECT(R.f.log[i].p[1] >= 10000 && R.f.log[i].p[1] <= 50000);
        if (R.f.log[i].p[0] == 60000 && R.f.log[i].p[1] == 10000)
            cubic_end = i;
    }
    TH_EXPECT(cubic_end > 2);
}

static void test_g64_p_also_sets_how_finely_g5_curves_are_flattened(void)
{
    int n[2];
    for (int k = 0; k < 2; k++) {
        rig_init(64);
        poll_n(2, 0);
        rxs(k == 0 ? "G64 P0.1\n" : "G64 P0.001\n");
        rxs("G0 X10 Y10\nG5 X60 Y10 I0 J40 P0 Q40 F2000\n");
        poll_n(200, 1);
        n[k] = R.f.logn;
    }
    /* chord tolerance P/4: 25 µm and 1 µm (0.29 after the vertex rounding):
     * about sqrt(25) = 5 to 9 times more chords */
    TH_EXPECT(n[1] > 3 * n[0]);
}

static void test_offsets_show_in_status_and_g_state(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("G0 X10 Y20\n");
    poll_n(3, 1);
    rxs("G92 X0 Y0\nG20 G91 G1 F10\n$G\n$#\n");
    poll_n(4, 1);
    R.outn = 0;
    rxs("?");
    poll_n(1, 0);
    TH_EXPECT(strstr(R.out, "|WCO:10.000,20.000,0.000>") != NULL);
    TH_EXPECT(strstr(R.out, "MPos:10.000,20.000,0.000") != NULL);
    rxs("$G\n");
    R.outn = 0;
    poll_n(2, 0);
    TH_EXPECT(strstr(R.out, "[GC:G1 G54 G17 G20 G91 G94 G64 M5 M9 T0 F254 S0]") != NULL);
}

static void test_jog_moves_without_touching_modal_state_and_cancels_cleanly(void)
{
    rig_init(8);
    poll_n(2, 0);
    R.outn = 0;
    rxs("G91\n$J=G90 G21 X10 Y5 F1000\n$J=X1 F500\n$J=G91 X-2 F500\n");
    poll_n(3, 0);
    int c[16];
    TH_ASSERT_EQ(answers(c, 16), 4);
    TH_EXPECT(c[0] == 0 && c[1] == 0 && c[2] == 0 && c[3] == 0);
    TH_ASSERT_EQ(R.f.logn, 3);
    TH_EXPECT(R.f.log[0].p[0] == 10000 && R.f.log[0].p[1] == 5000 && R.f.log[0].arg == 1000000);
    /* "$J=X1" with the program in G91: jogs default to the modal distance mode. */
    TH_EXPECT_EQ(R.f.log[1].p[0], 11000);
    TH_EXPECT_EQ(R.f.log[2].p[0], 9000);
    R.outn = 0;
    rxs("?");
    poll_n(1, 0);
    TH_EXPECT(strncmp(R.out, "<Jog|", 5) == 0);
    /* G-code is locked while jogging; bad jogs get their errors. */
    rxs("G0 X1\n$J=X1\n$J=G1 X1 F10\n$J=X1 M3 F10\n$J=X3000 F10\n$J=F10\n");
    poll_n(4, 0);
    TH_ASSERT_EQ(answers(c, 16), 6);
    TH_EXPECT_EQ(c[0], 9);
    TH_EXPECT_EQ(c[1], 22);
    TH_EXPECT_EQ(c[2], 16);
    TH_EXPECT_EQ(c[3], 16);
    TH_EXPECT_EQ(c[4], 15);
    TH_EXPECT_EQ(c[5], 0); /* Grbl: a jog without axis words is no move, ok */
    /* Jog cancel: a controlled stop (hold), then the rest is flushed. */
    rxs("\x85");
    poll_n(3, 0);
    TH_EXPECT_EQ(R.f.held, 2);
    TH_EXPECT_EQ(R.f.resets, 0); /* never cut while still decelerating */
    poll_n(2, 1);
    TH_EXPECT_EQ(R.f.qn, 0);
    TH_EXPECT_EQ(R.f.resets, 1);
    R.outn = 0;
    rxs("?");
    poll_n(1, 0);
    TH_EXPECT(strncmp(R.out, "<Idle|", 6) == 0);
    TH_EXPECT(strstr(R.out, "ALARM") == NULL);
    /* The program's modes survived: still G91, so X1 is relative. */
    rxs("G0 X1\n");
    poll_n(2, 0);
    TH_EXPECT_EQ(R.f.log[R.f.logn - 1].p[0], R.f.pos[0] + 1000);
}

/* Property: whatever bytes arrive (short of a soft reset), every line end
 * gets exactly one answer, and the engine never stalls for good. */
static void test_random_traffic_gets_exactly_one_answer_per_line(void)
{
    static const char alpha[] = "GMXYZFNPQIJST0123456789.-+ ()%;/$=\r\n\n?!~\x01\xff\x80G1X";
    static char stream[200000];
    uint64_t seed = 0x1234567u;
    for (int round = 0; round < 20; round++) {
        rig_init(1 + round % 6);
        poll_n(2, 0);
        size_t n = 0;
        for (; n < 8000; n++) {
            seed = seed * 6364136223846793005ull + 1442695040888963407ull;
            stream[n] = alpha[(seed >> 33) % (sizeof alpha - 1)];
        }
        stream[n++] = '~';
        stream[n++] = '\n';
        /* Expected answers: line ends once realtime bytes are taken out. */
        int expect = 0;
        char prev = 0;
        for (size_t i = 0; i < n; i++) {
            char c = stream[i];
            if (c == '?' || c == '!' || c == '~' || (unsigned char)c >= 0x80)
                continue;
            if (c == '\r' || (c == '\n' && prev != '\r'))
                expect++;
            prev = c;
        }
        R.outn = 0;
        size_t off = 0;
        for (int spins = 0; spins < 200000 && off < n; spins++) {
            off += rx(stream + off, n - off);
            poll_n(1, 1);
            if (spins % 50 == 0)
                rx("~", 1); /* keep feed holds from parking the run forever */
        }
        TH_ASSERT_EQ(off, n);
        poll_n(2000, 1);
        int codes[12000];
        TH_ASSERT_EQ(answers(codes, 12000), expect);
        TH_EXPECT_EQ(R.g.stats.lines, (uint32_t)expect);
    }
}

static int fake_fault;
static int f_state_faulty(void *m) { return fake_fault ? PK_GRBL_M_ALARM : f_state(m); }

static void test_a_machine_fault_raises_alarm_1_and_locks_g_code(void)
{
    struct pk_grbl_machine_ops ops = fake_ops;
    ops.state = f_state_faulty;
    rig_start(8, 0, &ops);
    fake_fault = 0;
    poll_n(2, 0);
    R.outn = 0;
    fake_fault = 1;
    rxs("G0 X1\n?");
    poll_n(2, 0);
    TH_EXPECT(strstr(R.out, "ALARM:1\r\n") != NULL);
    TH_EXPECT(strstr(R.out, "<Alarm|") != NULL);
    TH_EXPECT(strstr(R.out, "error:9\r\n") != NULL);
    TH_EXPECT_EQ(R.f.logn, 0);
    fake_fault = 0; /* $X resets the machine and unlocks */
    rxs("$X\nG0 X1\n");
    poll_n(3, 0);
    TH_EXPECT_EQ(R.f.logn, 1);
}

/* Requests of one type in the log, from index `from`. */
static int log_of(int type, int from, struct req *out, int max)
{
    int n = 0;
    for (int i = from; i < R.f.logn && n < max; i++)
        if (R.f.log[i].type == type)
            out[n++] = R.f.log[i];
    return n;
}

/* The Q0.16 value for S of full scale smax (no minimum), within 1 LSB of
 * the exact S / smax * 65535. */
static int q16_near(int32_t got, double s, double smax)
{
    double want = s / smax * 65535.0;
    return got >= want - 1.0 && got <= want + 1.0;
}

static void test_spindle_s_scales_to_30_with_the_override_and_stops_the_machine_first(void)
{
    rig_init(16);
    poll_n(2, 0);
    rxs("$30=2000\nM3 S500\n");
    poll_n(20, 1);
    rxs("\x9a"); /* spindle +10 % */
    poll_n(5, 1);
    rxs("S1000\nS2000\nS9000\n");
    poll_n(20, 1);
    struct req sp[8];
    int n = log_of(REQ_SPINDLE, 0, sp, 8);
    TH_ASSERT_EQ(n, 4); /* S9000 gives the same full scale as S2000: nothing sent */
    TH_EXPECT(q16_near(sp[0].arg, 500, 2000));
    TH_EXPECT(q16_near(sp[1].arg, 550, 2000));  /* the override applies at once */
    TH_EXPECT(q16_near(sp[2].arg, 1100, 2000));
    TH_EXPECT_EQ(sp[3].arg, 65535);             /* beyond $30: clamped, as Grbl */
    for (int i = 0; i < n; i++)
        TH_EXPECT_EQ(sp[i].p[0], 1); /* sync: S changes stop the machine (not laser mode) */
}

static void test_laser_mode_runs_feed_moves_at_s_and_rapids_at_zero_without_stopping(void)
{
    rig_init(32);
    poll_n(2, 0);
    rxs("$32=1\nM3 S500\nG0 X1\nG1 X2 F100\nG1 X3\nG0 X4\nG1 X5 S250\nG2 X7 I1\nM5\n");
    poll_n(60, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 9);
    /* the value each move runs at: the last spindle request before it */
    int32_t value = 0, at[6] = { -1, -1, -1, -1, -1, -1 };
    int moves = 0;
    for (int i = 0; i < R.f.logn; i++) {
        const struct req *q = &R.f.log[i];
        if (q->type == REQ_SPINDLE) {
            TH_EXPECT_EQ(q->p[0], 0); /* never a stop for a power change */
            value = q->arg;
        } else if ((q->type == REQ_MOVE || q->type == REQ_RAPID) && moves < 6 &&
                   (moves == 5 || q->p[0] == (moves + 1) * 1000)) {
            at[moves++] = value;
        }
    }
    TH_ASSERT_EQ(moves, 6);
    TH_EXPECT_EQ(at[0], 0);                 /* G0: off */
    TH_EXPECT(q16_near(at[1], 500, 1000));  /* G1 at S */
    TH_EXPECT(q16_near(at[2], 500, 1000));
    TH_EXPECT_EQ(at[3], 0);
    TH_EXPECT(q16_near(at[4], 250, 1000));  /* a new S rides on the move */
    TH_EXPECT(q16_near(at[5], 250, 1000));  /* arc chords too */
    TH_EXPECT_EQ(value, 0);                 /* M5: off */
}

static void test_realtime_commands_are_flags_a_burst_cannot_lose(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("G1 X50 F100\n");
    poll_n(3, 0);
    R.outn = 0;
    R.out[0] = 0;
    /* 300 status requests then a hold, all before the main loop runs */
    for (int i = 0; i < 300; i++)
        rxs("?");
    rxs("!");
    poll_n(3, 1);
    TH_EXPECT_EQ(count(R.out, "<"), 1);     /* repeats before the loop runs count once */
    R.outn = 0;
    rxs("?");
    poll_n(2, 1);
    TH_EXPECT(strstr(R.out, "<Hold:0|") != NULL);
    /* 256 resets in one burst: one reset */
    int before = R.f.resets;
    for (int i = 0; i < 256; i++)
        rxs("\x18");
    poll_n(5, 1);
    TH_EXPECT_EQ(R.f.resets - before, 1);
    TH_EXPECT_EQ(count(R.out, "Grbl 1.1h"), 1);
    TH_EXPECT(strstr(R.out, "ALARM") == NULL); /* the hold had completed */
}

static void test_settings_offsets_and_lines_survive_a_restart_and_a_bad_store_is_reset(void)
{
    rig_init(8);
    poll_n(2, 0);
    TH_EXPECT(strstr(R.out, "[MSG:Restoring defaults]") != NULL); /* erased store */
    rxs("$100=123.25\nG10 L2 P3 X-4.5\n$N1=G91\n");
    poll_n(10, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 3);
    rig_start(8, 1, NULL);                  /* power cycle, same store */
    poll_n(5, 1);
    TH_EXPECT(strstr(R.out, "[MSG:Restoring defaults]") == NULL);
    TH_EXPECT(strstr(R.out, ">G91:ok") != NULL);
    TH_EXPECT_EQ(R.f.set.v[PK_GRBL_S_STEPS_X], 1232500); /* reached the machine */
    R.outn = 0;
    rxs("$#\n");
    poll_n(10, 1);
    TH_EXPECT(strstr(R.out, "[G56:-4.500,0.000,0.000]") != NULL);
    /* one flipped bit in the settings record: its checksum fails */
    R.nvm_buf[10] ^= 0x04;
    rig_start(8, 1, NULL);
    poll_n(5, 1);
    TH_EXPECT(strstr(R.out, "[MSG:Restoring defaults]") != NULL);
    TH_EXPECT(R.f.set.v[PK_GRBL_S_STEPS_X] != 1232500);
}

static void test_m0_and_g4_are_answered_only_when_done(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("G1 X10 F100\nG4 P1\n");
    poll_n(1, 0);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 1);  /* G4 waits for the queue */
    poll_n(10, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 2);
    R.outn = 0;
    R.out[0] = 0;
    rxs("M0\n");
    poll_n(10, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 0);  /* paused: Hold:0 until '~' */
    rxs("?");
    poll_n(2, 1);
    TH_EXPECT(strstr(R.out, "<Hold:0|") != NULL);
    rxs("~");
    poll_n(3, 1);
    TH_EXPECT_EQ(count(R.out, "ok\r\n"), 1);
}

static void test_door_is_a_feed_hold_with_a_message_without_a_door_input(void)
{
    rig_init(8);
    poll_n(2, 0);
    rxs("G1 X10 F100\n");
    poll_n(2, 0);
    rxs("\x84");
    poll_n(3, 1);
    TH_EXPECT(R.f.held != 0);
    TH_EXPECT(strstr(R.out, "[MSG:No safety door: feed hold only") != NULL);
}

struct obs_log {
    struct pk_grbl_prim p[16];
    int n;
};
static void obs_fn(void *ctx, const struct pk_grbl_prim *p)
{
    struct obs_log *o = ctx;
    if (o->n < 16)
        o->p[o->n++] = *p;
}

static void test_the_observer_sees_each_programmed_primitive_before_flattening(void)
{
    static struct obs_log o;
    memset(&o, 0, sizeof o);
    rig_init(64);
    pk_grbl_set_observer(&R.g, obs_fn, &o);
    poll_n(2, 0);
    rxs("G92 X-1\nG0 X0 Y0\nM3\nN7 G1 X10 F600\nG18 G3 X0 Z0 I-5 K0\n"
        "G17 G5 X20 Y0 I1 J2 P-3 Q4\nG5.1 X30 Y5 I2 J2\n");
    poll_n(300, 1);
    rxs("$J=G91 Y1 F100\n"); /* a jog needs the machine idle */
    poll_n(20, 1);
    TH_ASSERT_EQ(o.n, 6);
    TH_EXPECT_EQ(o.p[0].kind, PK_GRBL_PRIM_RAPID);
    TH_EXPECT_EQ(o.p[0].end[0], 1000);       /* machine coordinates: X0 is MPos 1 */
    TH_EXPECT_EQ(o.p[0].tool_on, 0);
    TH_EXPECT_EQ(o.p[0].line, 2u);
    TH_EXPECT_EQ(o.p[1].kind, PK_GRBL_PRIM_LINE);
    TH_EXPECT_EQ(o.p[1].n, 7);
    TH_EXPECT_EQ(o.p[1].tool_on, 1);
    TH_EXPECT_EQ(o.p[1].feed_umpm, 600000);
    TH_EXPECT_EQ(o.p[1].start[0], 1000);
    TH_EXPECT_EQ(o.p[1].end[0], 11000);
    const struct pk_grbl_prim *a = &o.p[2];
    TH_EXPECT_EQ(a->kind, PK_GRBL_PRIM_ARC);
    TH_EXPECT_EQ(a->a0, 2);                  /* G18: the plane is Z, X */
    TH_EXPECT_EQ(a->a1, 0);
    TH_EXPECT_EQ(a->al, 1);                  /* Y is the linear axis */
    TH_EXPECT_EQ(a->cw, 0);
    TH_EXPECT_EQ(a->centre_q8[0], 0);        /* centre (Z, X) = (0, 6 mm) */
    TH_EXPECT_EQ(a->centre_q8[1], 6000 * 256);
    TH_EXPECT_EQ(a->r0_q8, 5000 * 256);
    TH_EXPECT_EQ(a->r1_q8, 5000 * 256);
    TH_EXPECT(a->sweep == (1ull << 31));     /* half a turn */
    TH_EXPECT_EQ(a->end[0], 1000);
    TH_EXPECT(a->chord_tol_um > 0 && a->chord_tol_um <= 5); /* G64 $12/4 */
    TH_EXPECT_EQ(o.p[3].kind, PK_GRBL_PRIM_CUBIC);
    TH_EXPECT_EQ(o.p[3].ctrl[0][0], 1000 + 1000);  /* start + (I, J) */
    TH_EXPECT_EQ(o.p[3].ctrl[0][1], 2000);
    TH_EXPECT_EQ(o.p[3].ctrl[1][0], 21000 - 3000); /* end + (P, Q) */
    TH_EXPECT_EQ(o.p[3].ctrl[1][1], 4000);
    TH_EXPECT_EQ(o.p[4].kind, PK_GRBL_PRIM_QUAD);
    TH_EXPECT_EQ(o.p[4].ctrl[0][0], 21000 + 2000);
    TH_EXPECT_EQ(o.p[4].ctrl[0][1], 2000);
    TH_EXPECT_EQ(o.p[5].kind, PK_GRBL_PRIM_LINE);
    TH_EXPECT_EQ(o.p[5].jog, 1);
    TH_EXPECT_EQ(o.p[5].end[1], 6000);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_the_greeting_names_grbl_1_1_and_plotkin),
        TH_CASE(test_character_counted_stream_is_acked_once_per_line_in_order),
        TH_CASE(test_a_full_machine_stops_reading_so_nothing_is_lost),
        TH_CASE(test_status_mid_line_reports_and_leaves_the_line_intact),
        TH_CASE(test_hold_and_resume_act_at_once_even_mid_line),
        TH_CASE(test_soft_reset_in_motion_clears_the_queue_and_locks_until_unlock),
        TH_CASE(test_soft_reset_when_idle_does_not_alarm),
        TH_CASE(test_every_bad_line_gets_its_error_and_later_lines_still_run),
        TH_CASE(test_line_ends_long_lines_and_overflow_follow_grbl),
        TH_CASE(test_settings_list_set_and_reach_the_machine),
        TH_CASE(test_check_mode_parses_without_moving),
        TH_CASE(test_pen_dwell_smoothing_and_end_reach_the_machine_in_order),
        TH_CASE(test_a_g5_curve_streams_through_a_tiny_queue_and_ends_exactly),
        TH_CASE(test_offsets_show_in_status_and_g_state),
        TH_CASE(test_g64_p_also_sets_how_finely_g5_curves_are_flattened),
        TH_CASE(test_jog_moves_without_touching_modal_state_and_cancels_cleanly),
        TH_CASE(test_a_machine_fault_raises_alarm_1_and_locks_g_code),
        TH_CASE(test_random_traffic_gets_exactly_one_answer_per_line),
        TH_CASE(test_spindle_s_scales_to_30_with_the_override_and_stops_the_machine_first),
        TH_CASE(test_laser_mode_runs_feed_moves_at_s_and_rapids_at_zero_without_stopping),
        TH_CASE(test_realtime_commands_are_flags_a_burst_cannot_lose),
        TH_CASE(test_settings_offsets_and_lines_survive_a_restart_and_a_bad_store_is_reset),
        TH_CASE(test_m0_and_g4_are_answered_only_when_done),
        TH_CASE(test_door_is_a_feed_hold_with_a_message_without_a_door_input),
        TH_CASE(test_the_observer_sees_each_programmed_primitive_before_flattening),
    };
    return th_run(cases, TH_COUNT(cases));
}
