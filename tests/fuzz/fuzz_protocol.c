/*
 * fuzz_protocol.c — libFuzzer target for the Grbl 1.1 protocol engine
 * (pk_grbl.h) over a simulated UART, with faults.
 *
 * The harness plays three parts:
 *   - the receive ISR: each incoming byte first goes through
 *     pk_grbl_rt_filter (unless the input switched the filter off, as on a
 *     build without it), then into a 128-byte receive ring; a byte that finds
 *     the ring full is lost and the next read reports it (RX overflow).
 *   - the transmitter: accepts 0..255 bytes per write (back-pressure).
 *   - a fake machine with a 1..8 entry request queue, drained as the input
 *     says; it can be put into alarm (a HAL fault) and can refuse requests.
 * The input is a program of events: deliver a run of bytes, poll the engine,
 * let the machine run, change the transmitter's room, inject a fault.
 * At the end the harness resumes any hold, lets everything drain, and
 * checks the totals.
 *
 * Invariants checked:
 *   - realtime bytes ('?', '!', '~', 0x18 and the extended ones) never
 *     enter the line buffer, whether the filter claimed them or not.
 *   - exactly one "ok" or "error:N" per complete line the engine read
 *     (LF, CR or CR LF), except a line still being handed to the machine
 *     (or whose $$-style report was still being written) when a soft reset
 *     cut it (Grbl's own rule: the sender restarts its
 *     count after a reset); never more answers than lines.
 *   - no move accepted for a line that is answered with an error, except
 *     error:9 when the machine refused part of the line (alarm).
 *   - every output line is well formed (ok, error:N, <status>, [msg],
 *     $n=v, ALARM:n, the greeting, or blank), and the engine ends idle.
 */
#include "fuzz_common.h"
#include "pk_grbl.h"

#include <string.h>

#define RX_SIZE 128u
#define MAXLINES 20000u
#define OUT_MAX (1u << 20)
/* Bytes of input used (tests/fuzz/fuzz_protocol.options passes the same -max_len). */
#define MAX_INPUT 1024u

static struct pk_grbl G;

/* ---- the UART ------------------------------------------------------------- */
static struct {
    uint8_t ring[RX_SIZE];
    unsigned head, tail; /* free-running */
    int lost;            /* bytes were dropped since the last read */
    int filter;          /* pass bytes through pk_grbl_rt_filter first */
    unsigned tx_room;
    size_t out_len;
    /* the harness's own count of line ends the engine read */
    unsigned lines_read;
    int last_cr;
    uint32_t resets_seen;
    char out[OUT_MAX]; /* last: not cleared between inputs (out_len says what is valid) */
} U;

static void isr_byte(uint8_t b)
{
    if (U.filter && pk_grbl_rt_filter(&G, b))
        return;
    if (U.head - U.tail >= RX_SIZE) {
        U.lost = 1;
        return;
    }
    U.ring[U.head++ % RX_SIZE] = b;
}

static int u_read(void *ctx, uint8_t *buf, size_t len)
{
    (void)ctx;
    if (U.lost) {
        U.lost = 0;
        return -1;
    }
    size_t n = 0;
    while (n < len && U.tail != U.head)
        buf[n++] = U.ring[U.tail++ % RX_SIZE];
    if (len == 1u && n == 1u) {
        /* a byte the engine reads into a line (bulk reads are the reset's
         * flush of unread input, which Grbl discards) */
        if (G.stats.resets != U.resets_seen) {
            U.resets_seen = G.stats.resets;
            U.last_cr = 0;
        }
        uint8_t b = buf[0];
        if (b == '\n' && U.last_cr) {
            U.last_cr = 0;
        } else {
            U.last_cr = b == '\r';
            if (b == '\n' || b == '\r')
                U.lines_read++;
        }
        if (!U.filter && b == 0x18)
            U.last_cr = 0;
    }
    return (int)n;
}

static int u_write(void *ctx, const uint8_t *buf, size_t len)
{
    (void)ctx;
    size_t n = len < U.tx_room ? len : U.tx_room;
    if (U.out_len + n > OUT_MAX)
        n = OUT_MAX - U.out_len;
    memcpy(U.out + U.out_len, buf, n);
    U.out_len += n;
    return (int)n;
}

static size_t u_rx_used(void *ctx)
{
    (void)ctx;
    return U.head - U.tail;
}

/* ---- the fake machine ------------------------------------------------------ */
static struct {
    unsigned cap, q;
    int held, alarm, refuse;
    pk_um_t pos[PK_GC_AXES];
    /* last: cleared between inputs only below lines_hw */
    unsigned moves_for[MAXLINES]; /* moves accepted while line #i was pending */
    int refused_for[MAXLINES];    /* the machine refused part of line #i */
} M;
static unsigned lines_hw; /* every moves_for/refused_for entry from here on is zero */

static unsigned cur_line(void)
{
    unsigned l = G.stats.lines < MAXLINES ? G.stats.lines : MAXLINES - 1u;
    if (l >= lines_hw)
        lines_hw = l + 1u;
    return l;
}

/* A clean harness for the next input without clearing megabytes: the fields
 * before the big arrays, and the arrays' entries the last inputs touched.
 * Every 256th input (and the first) checks that the arrays are all zero. */
static void harness_reset(void)
{
    static unsigned long runs;
    memset(&U, 0, (size_t)((char *)U.out - (char *)&U));
    memset(&M, 0, (size_t)((char *)M.moves_for - (char *)&M));
    memset(M.moves_for, 0, lines_hw * sizeof M.moves_for[0]);
    memset(M.refused_for, 0, lines_hw * sizeof M.refused_for[0]);
    lines_hw = 0;
    if ((runs++ & 255u) == 0u)
        for (unsigned i = 0; i < MAXLINES; i++)
            FZ_CHECK(M.moves_for[i] == 0u && M.refused_for[i] == 0, "the harness reset clears every line's record");
}

static int m_take(void)
{
    if (M.alarm || M.refuse) {
        M.refused_for[cur_line()] = 1;
        return PK_GRBL_M_ERROR;
    }
    if (M.q >= M.cap)
        return PK_GRBL_M_FULL;
    M.q++;
    return PK_GRBL_M_OK;
}
static int m_move(void *m, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t f, int rapid)
{
    (void)m;
    (void)rapid;
    FZ_CHECK(f >= 0, "feed handed to the machine is not negative");
    int r = m_take();
    if (r == PK_GRBL_M_OK) {
        memcpy(M.pos, t, sizeof M.pos);
        M.moves_for[cur_line()]++;
    }
    return r;
}
static int m_pen(void *m, int down) { (void)m; (void)down; return m_take(); }
static int m_dwell(void *m, uint32_t ms) { (void)m; (void)ms; return m_take(); }
static int m_smoothing(void *m, int exact, pk_um_t tol)
{
    (void)m;
    (void)exact;
    FZ_CHECK(exact || tol > 0, "G64 hands a positive tolerance");
    return PK_GRBL_M_OK;
}
static int m_end(void *m) { (void)m; return PK_GRBL_M_OK; }
static void m_hold(void *m) { (void)m; M.held = 1; }
static void m_resume(void *m) { (void)m; M.held = 0; }
static int m_reset(void *m)
{
    (void)m;
    int cut = M.q > 0 && !M.held;
    M.q = 0;
    M.held = 0;
    M.alarm = 0;
    return cut;
}
static void m_position(void *m, pk_um_t out[PK_GC_AXES]) { (void)m; memcpy(out, M.pos, sizeof M.pos); }
static int m_state(void *m)
{
    (void)m;
    return M.alarm ? PK_GRBL_M_ALARM : M.held ? PK_GRBL_M_HOLD : M.q ? PK_GRBL_M_RUN : PK_GRBL_M_IDLE;
}
static uint32_t m_free(void *m) { (void)m; return M.cap - M.q; }
static uint32_t m_total(void *m) { (void)m; return M.cap; }
static pk_gc_umpm_t m_speed(void *m) { (void)m; return M.q ? 1000000 : 0; }
static int m_configure(void *m, const struct pk_grbl_settings *s) { (void)m; (void)s; return 0; }

static void m_run(unsigned n)
{
    if (M.held || M.alarm)
        return;
    M.q = n >= M.q ? 0u : M.q - n;
}

/* ---- checks ----------------------------------------------------------------- */
static int is_rt(uint8_t b)
{
    return b == '?' || b == '!' || b == '~' || b == 0x18 || b >= 0x80; /* Grbl: all >= 0x80 */
}

static unsigned dropped; /* lines cut by a soft reset while being handed over */

static void poll_engine(void)
{
    /* A reset the ISR flagged is acted on first thing in the poll: a line
     * still being handed to the machine, or whose multi-line report ($$, $#,
     * ...) is still being written, then goes unanswered: the reset ends the
     * conversation and the sender restarts its count (Grbl's rule). */
    if (G.rt[PK_GRBL_RT_RESET] && (G.todo != 0u || G.report != 0u)) {
        dropped++;
        M.moves_for[cur_line()] = 0;
        M.refused_for[cur_line()] = 0;
    }
    pk_grbl_poll(&G);
    for (unsigned i = 0; i < G.len; i++)
        FZ_CHECK(!is_rt(G.line[i]), "realtime bytes never enter the line buffer");
}

static void check_output(void)
{
    unsigned answers = 0;
    size_t i = 0;
    while (i < U.out_len) {
        const char *s = U.out + i;
        const char *e = memchr(s, '\n', U.out_len - i);
        FZ_CHECK(e != NULL, "output ends with a complete line");
        size_t n = (size_t)(e - s);
        FZ_CHECK(n >= 1 && s[n - 1] == '\r', "output lines end with CR LF");
        n--;
        i += n + 2u;
        if (n == 0)
            continue;
        if (n == 2 && !memcmp(s, "ok", 2)) {
            answers++;
            continue;
        }
        if (n > 6 && !memcmp(s, "error:", 6)) {
            unsigned code = 0;
            for (size_t k = 6; k < n; k++) {
                FZ_CHECK(s[k] >= '0' && s[k] <= '9', "error:N has a number");
                code = code * 10u + (unsigned)(s[k] - '0');
            }
            unsigned L = answers < MAXLINES ? answers : MAXLINES - 1u;
            if ((code != 9u || !M.refused_for[L]) && M.moves_for[L] != 0u)
                fprintf(stderr, "answer #%u error:%u after %u accepted moves\n%.*s\n", L, code,
                        M.moves_for[L], (int)U.out_len, U.out);
            if (code != 9u || !M.refused_for[L])
                FZ_CHECK(M.moves_for[L] == 0u, "no move accepted for a line answered with an error");
            answers++;
            continue;
        }
        int known = s[0] == '<' || s[0] == '[' || s[0] == '$' || s[0] == '>' ||
                    (n > 6 && !memcmp(s, "ALARM:", 6)) || (n > 5 && !memcmp(s, "Grbl ", 5));
        if (!known)
            fprintf(stderr, "line: '%.*s'\n", (int)n, s);
        FZ_CHECK(known, "every output line is a known kind");
        if (s[0] == '<')
            FZ_CHECK(s[n - 1] == '>', "a status report is whole");
    }
    FZ_CHECK(answers == G.stats.lines, "every answer counted is on the wire");
    if (answers + dropped != U.lines_read)
        fprintf(stderr, "answers %u dropped %u lines read %u resets %u\n%.*s\n", answers, dropped,
                U.lines_read, (unsigned)G.stats.resets, (int)U.out_len, U.out);
    FZ_CHECK(answers + dropped == U.lines_read, "exactly one ok/error per complete line");
}

/* Let the engine and the machine run until both are idle and every byte is
 * read, as an operator would: cycle start now and then (after an M0 read
 * while draining), a reset if locked. Returns the spins used (100000: not
 * drained). */
static unsigned drain(void)
{
    unsigned spins = 0;
    for (; spins < 100000u; spins++) {
        if (U.filter == 0 && M.held)
            m_resume(&M); /* without the filter '~' may sit behind a held line */
        if (spins % 64u == 63u) { /* an operator: cycle start after an M0 read while draining */
            if (U.filter)
                isr_byte('~');
            else /* the rebuilt engine reads no input while held: '~' would queue behind it */
                (void)pk_grbl_rt_filter(&G, '~');
        }
        if (spins == 50000u && (pk_grbl_state(&G) == PK_GRBL_ALARM || pk_grbl_state(&G) == PK_GRBL_SLEEP)) {
            /* locked (a soft limit, $SLP): only a reset goes on. Without the
             * filter it must come out of band too: a locked engine reads no
             * input (pk_grbl.h), so a ctrl-X behind unread bytes would wait
             * for ever (finding P1, campaign of 2026-12-01: 5,984,017 runs) */
            if (U.filter)
                isr_byte(0x18);
            else
                (void)pk_grbl_rt_filter(&G, 0x18);
        }
        poll_engine();
        m_run(8);
        if (pk_grbl_idle(&G) && U.head == U.tail && !U.lost && M.q == 0u) {
            /* locked by a critical alarm with the line that tripped it owed
             * its "ok" until a reset (Grbl): the operator resets, out of
             * band (finding P2: drained "idle" with that answer missing) */
            if (G.owed && (pk_grbl_state(&G) == PK_GRBL_ALARM || pk_grbl_state(&G) == PK_GRBL_SLEEP)) {
                if (U.filter)
                    isr_byte(0x18);
                else
                    (void)pk_grbl_rt_filter(&G, 0x18);
                continue;
            }
            break;
        }
    }
    return spins;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    struct fz_in in = { data, size < MAX_INPUT ? size : MAX_INPUT, 0 };
    harness_reset();
    dropped = 0;
    uint8_t cfg = fz_u8(&in);
    U.filter = (cfg & 0x80u) == 0u;
    U.tx_room = 256;
    M.cap = 1u + (cfg & 7u);
    M.pos[2] = 0;
    struct pk_grbl_stream io = { u_read, u_write, u_rx_used, 0 };
    static const struct pk_grbl_machine_ops mo = {
        .move = m_move, .pen = m_pen, .dwell = m_dwell, .smoothing = m_smoothing, .end = m_end,
        .hold = m_hold, .resume = m_resume, .reset = m_reset, .position_um = m_position,
        .state = m_state, .blocks_free = m_free, .blocks_total = m_total, .speed_umpm = m_speed,
        .configure = m_configure,
    };
    FZ_CHECK(pk_grbl_init(&G, &io, &mo, &M, NULL, NULL) == 0, "init with default settings");

    unsigned steps = 0;
    while (fz_more(&in) && steps++ < 20000u) {
        uint8_t ev = fz_u8(&in);
        if (ev < 0xF0u) { /* the common case: deliver bytes; ev itself is the first */
            isr_byte(ev);
            unsigned n = fz_u8(&in) & 15u;
            for (unsigned k = 0; k < n && fz_more(&in); k++)
                isr_byte(fz_u8(&in));
            poll_engine();
            m_run(1);
            continue;
        }
        switch (ev & 15u) {
        case 0: case 1: case 2: /* several polls without the machine moving */
            for (unsigned k = 0; k < 1u + (ev & 3u); k++)
                poll_engine();
            break;
        case 3: case 4: /* the machine runs a while */
            m_run(fz_u8(&in) & 7u);
            poll_engine();
            break;
        case 5: case 6: /* the transmitter's room changes */
            U.tx_room = fz_u8(&in);
            break;
        case 7: /* a HAL fault puts the machine in alarm */
            M.alarm = 1;
            M.q = 0; /* a faulted machine stops and drops its queue */
            M.refused_for[cur_line()] = 1; /* a line being handed over may fail with error:9 */
            poll_engine();
            break;
        case 8: /* the machine refuses requests for a while */
            M.refuse = !M.refuse;
            break;
        case 9: /* a soft reset from the ISR, at any moment */
            isr_byte(0x18);
            poll_engine();
            break;
        default: /* a burst faster than the engine reads: overflow */
            for (unsigned k = 0; k < 200u; k++)
                isr_byte((uint8_t)('0' + k % 10u));
            isr_byte('\n');
            break;
        }
    }

    /* Drain: resume, stop refusing, full transmitter, let everything finish. */
    M.refuse = 0;
    U.tx_room = 256;
    isr_byte('~');
    FZ_CHECK(drain() < 100000u, "the engine drains and ends idle");
    if (G.len != 0u || G.line_flags != 0u) {
        /* an unterminated last line is not a complete line: end it now (it may
         * be an M0, answered after the operator's cycle start, as in Grbl) */
        isr_byte('\n');
        FZ_CHECK(drain() < 100000u, "the engine drains a last line and ends idle");
    }
    check_output();
    return 0;
}
