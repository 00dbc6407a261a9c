/*
 * fuzz_realtime.c — libFuzzer target for the realtime byte path of the Grbl
 * protocol engine: bursts of realtime bytes (every one of them: '?', '!', '~',
 * Ctrl-X and every byte >= 0x80) mixed into a stream of G-code lines, through
 * the real byte intake (hal/pk_uart.c's receive ring with pk_grbl_rt_filter
 * in the receive path, as the RX interrupt calls it) into pk_grbl_poll.
 *
 * The sender is a well-behaved Grbl sender: it waits for the greeting (at
 * start and after each Ctrl-X), counts characters (never more than 128 bytes
 * of unanswered lines in flight; realtime bytes are not counted, as they
 * never enter the ring), and may inject a burst of realtime bytes at any
 * moment, also in the middle of a line it is sending. Every move line carries
 * a unique sequence number in its coordinates (X, Y in 0.1 mm), so the fake
 * machine knows which line each move came from. The input is a program of
 * events: send a line (a move, a rapid, $X, a dwell, an erroneous line or an
 * empty one; optionally with a burst inside), send a burst, run the main
 * loop, let the machine execute, change the transmitter's room. At the end
 * the sender resumes any hold, the machine drains, and everything is checked.
 *
 * Invariants checked (Grbl 1.1's behaviour):
 *   - the filter claims '?', '!', '~', 0x18 and every byte >= 0x80 (Grbl's
 *     receive interrupt drops unknown extended bytes); none of them is ever
 *     in the engine's line buffer; no byte is ever lost to an RX overflow
 *     (the sender counts characters).
 *   - a Ctrl-X always resets: the main loop run after it resets the machine
 *     exactly once (several in one batch count once, as Grbl's flag), and
 *     never without one; a greeting follows each reset; no line sent before
 *     the reset moves the machine after it.
 *   - a '!' is never lost, whatever else came with it (any number of '?' or
 *     other realtime bytes): a running machine is asked to hold by the next
 *     main loop run; a '~' resumes a held machine (unless a '!' came with
 *     it); no hold or resume without its byte.
 *   - a '?' gets a status report (unless a reset came with it), never more
 *     reports than '?' bytes, every report whole ("<...>").
 *   - the overrides follow Grbl's arithmetic: the override bytes (0x90-0x9D)
 *     delivered before a main loop run act as Grbl's flags, each kind once
 *     however often it came: feed and spindle reset to 100 %, then +10, -10,
 *     +1, -1, clamped to 10..200 %; rapid 100 %, then 50, then 25 (the last
 *     one of the batch in that order wins). A Ctrl-X in the batch drops them
 *     and restores 100 % everywhere. The engine's values and what it last
 *     handed to the machine (set_override) equal the model's after every run.
 *   - no accepted line is lost or duplicated: every line gets exactly one
 *     answer, in order (lines cut by a reset may go unanswered; an answer
 *     before the reset's greeting belongs to a line sent before it); a move
 *     line answered ok handed its move to the machine exactly once, one
 *     answered with an error none; moves reach the machine in the order of
 *     their lines, each once.
 *
 * No allowances: the findings R1 (a '!' behind 16 '?' lost) and R2 (bytes
 * >= 0x80 outside Grbl's list not claimed) were fixed by the engine rebuild;
 * their inputs are corpus/fuzz_realtime/regress-R*, their unit tests
 * tests/test_grbl_realtime.c.
 *
 * Cost: MAX_INPUT bytes (fuzz_realtime.options), at most MAX_EVENTS events.
 * FUZZ_REALTIME_VERBOSE=1 prints the conversation of an input.
 */
#include "fuzz_common.h"
#include "pk_grbl.h"
#include "pk_uart.h"


#define MAX_INPUT 512u
#define MAX_EVENTS 256u
#define MAXSEQ 1024u     /* move lines per input (sequence numbers) */
#define FIFO 256u        /* lines in flight (answered or cut ones leave it) */

static struct pk_grbl G;
static struct pk_uart U;
static int VERBOSE; /* FUZZ_REALTIME_VERBOSE set: print the conversation */

/* ---- the fake machine ---------------------------------------------------------- */
static struct {
    unsigned cap, q;
    int held, alarm;
    pk_um_t pos[PK_GC_AXES];
    unsigned holds, resumes, resets; /* calls */
    int last_seq;                    /* of the last move handed over (-1: none) */
    int min_seq;                     /* moves must be at least this (after a reset) */
} M;
static uint8_t moved[MAXSEQ];        /* moves handed over per sequence number */

static int seq_of(const pk_um_t t[PK_GC_AXES])
{
    if (t[0] < 0 || t[1] < 0 || t[0] % 100 != 0 || t[1] % 100 != 0 || t[0] >= 100000)
        return -1;
    int s = (int)(t[0] / 100 + 1000 * (t[1] / 100));
    return s < (int)MAXSEQ ? s : -1;
}

static int m_take(void)
{
    if (M.alarm)
        return PK_GRBL_M_ERROR;
    if (M.q >= M.cap)
        return PK_GRBL_M_FULL;
    M.q++;
    return PK_GRBL_M_OK;
}
static int m_move(void *m, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t f, int rapid)
{
    (void)m;
    (void)f;
    (void)rapid;
    int s = seq_of(t);
    FZ_CHECK(s >= 0, "every move is one the sender sent (its sequence number decodes)");
    int r = m_take();
    if (r != PK_GRBL_M_OK)
        return r;
    FZ_CHECK(s > M.last_seq, "moves reach the machine in the order of their lines, each once");
    FZ_CHECK(s >= M.min_seq, "no line sent before a reset moves the machine after it");
    M.last_seq = s;
    moved[s]++;
    if (VERBOSE)
        fprintf(stderr, "   machine: move of line #%d\n", s);
    memcpy(M.pos, t, sizeof M.pos);
    return r;
}
static int m_pen(void *m, int down) { (void)m; (void)down; return m_take(); }
static int m_dwell(void *m, uint32_t ms) { (void)m; (void)ms; return m_take(); }
static int m_smoothing(void *m, int exact, pk_um_t tol) { (void)m; (void)exact; (void)tol; return PK_GRBL_M_OK; }
static int m_end(void *m) { (void)m; return PK_GRBL_M_OK; }
static void m_hold(void *m) { (void)m; M.holds++; M.held = 1; }
static void m_resume(void *m) { (void)m; M.resumes++; M.held = 0; }
static int seq_next; /* the next sequence number the sender will use */
static void reset_acted(void);
static int m_reset(void *m)
{
    (void)m;
    int cut = M.q > 0 && !M.held;
    M.q = 0;
    M.held = 0;
    M.alarm = 0;
    M.resets++;
    M.min_seq = seq_next; /* everything sent so far is before the reset */
    reset_acted();
    if (VERBOSE)
        fprintf(stderr, "   machine: reset (%s)\n", cut ? "motion cut" : "stopped");
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

/* The overrides the machine was last given (set_override). */
static struct {
    unsigned feed, rapid, calls;
} MO;
static int m_override(void *m, uint16_t feed_pct, uint16_t rapid_pct)
{
    (void)m;
    FZ_CHECK(feed_pct >= 10u && feed_pct <= 200u && (rapid_pct == 25u || rapid_pct == 50u || rapid_pct == 100u),
             "the machine is given overrides within Grbl's ranges");
    MO.feed = feed_pct;
    MO.rapid = rapid_pct;
    MO.calls++;
    return 0;
}

static void m_run(unsigned n)
{
    if (!M.held && !M.alarm)
        M.q = n >= M.q ? 0u : M.q - n;
}

/* ---- the sender ------------------------------------------------------------------- */
enum { L_MOVE, L_RAPID, L_UNLOCK, L_DWELL, L_BAD, L_EMPTY, L_KINDS };
static struct {
    int seq[FIFO];      /* lines in flight, oldest first: sequence number or -1 */
    uint8_t kind[FIFO];
    unsigned len[FIFO]; /* bytes counted against the receive ring */
    unsigned epoch[FIFO]; /* resets acted on before it was sent */
    unsigned head, tail;
    unsigned inflight;  /* bytes of unanswered lines */
    unsigned sent_lines;
} S;

/* Resets, by where they fall in the output stream: everything the engine had
 * produced when it reset (sent, in the transmit ring, or in its own output
 * buffer) belongs before it; the engine never discards output (nor does
 * Grbl). A sender waits for a greeting that comes after its last reset. */
#define MAX_RESETS 512u
static struct {
    unsigned long pos[MAX_RESETS];
    unsigned n;        /* resets acted on */
    unsigned passed;   /* resets the output parse has gone past */
    unsigned greeted;  /* resets (+1: the start) followed by a greeting */
} R;

/* realtime bytes delivered since the last main loop run */
static struct {
    unsigned reset, hold, cycle, status, door, events;
    uint32_t ovr; /* override bytes seen: bit (byte - 0x90) */
} P;
/* The overrides Grbl would have now (%). */
static struct {
    int feed, rapid, spindle;
} OV;

static int clamp_pct(int v) { return v > 200 ? 200 : v < 10 ? 10 : v; }

/* Grbl 1.1's feed or spindle step on the flags f of one batch, its five
 * bytes from b0 (reset, +10, -10, +1, -1): each once, in that order, clamped. */
static int pct_model(int v, uint32_t f, unsigned b0)
{
    static const int step[5] = { 0, 10, -10, 1, -1 };
    for (unsigned k = 0; k < 5u; k++)
        if ((f >> (b0 - 0x90u + k)) & 1u)
            v = k == 0u ? 100 : v + step[k];
    return clamp_pct(v);
}

/* Grbl 1.1's protocol_exec_rt_system on the override flags of one batch. */
static void ovr_model(uint32_t f)
{
    OV.feed = pct_model(OV.feed, f, 0x90u);
    if ((f >> (0x95u - 0x90u)) & 1u) OV.rapid = 100;
    if ((f >> (0x96u - 0x90u)) & 1u) OV.rapid = 50;
    if ((f >> (0x97u - 0x90u)) & 1u) OV.rapid = 25;
    OV.spindle = pct_model(OV.spindle, f, 0x99u);
}
static unsigned long q_bytes, reports;
static int status_owed;

static int is_rt(uint8_t b) { return b == '?' || b == '!' || b == '~' || b == 0x18 || b >= 0x80; }

static void rx_byte(uint8_t b)
{
    int r = pk_uart_rx_push(&U, b);
    if (is_rt(b))
        FZ_CHECK(r == PK_UART_RX_REALTIME, "the filter claims every realtime byte (all >= 0x80)");
    if (b == '?' || b == '!' || b == '~' || b == 0x18)
        FZ_CHECK(r == PK_UART_RX_REALTIME, "the filter claims '?', '!', '~' and Ctrl-X");
    FZ_CHECK(r != PK_UART_RX_DROPPED, "a character-counting sender loses no byte");
    if (r != PK_UART_RX_REALTIME)
        return;
    P.reset += b == 0x18;
    P.hold += b == '!';
    P.cycle += b == '~';
    P.status += b == '?';
    P.door += b == 0x84;
    P.events += b == '?' || b == '!' || b == '~' || b == 0x85;
    if (b >= 0x90u && b <= 0x9Du)
        P.ovr |= 1u << (b - 0x90u);
    q_bytes += b == '?';
}

/* A burst of n realtime bytes, each chosen by one input byte. */
static void burst(struct fz_in *in, unsigned n)
{
    static const uint8_t common[] = { '?', '?', '?', '?', '!', '~', 0x85, 0x18 };
    for (unsigned k = 0; k < n; k++) {
        uint8_t v = fz_u8(in);
        uint8_t b = v < 0x80u ? common[v % sizeof common] : v;
        if (b == 0x18 && (v & 0x70u) != 0u)
            b = '?'; /* Ctrl-X: 1 in 8 of those */
        rx_byte(b);
    }
}

/* ---- the output ------------------------------------------------------------------- */
static struct {
    char line[512];
    unsigned n;
    unsigned long start;  /* stream position of line[0] */
    unsigned greetings;
    unsigned long popped;
    unsigned room; /* bytes the harness takes per main loop run */
} O;

static void reset_acted(void)
{
    FZ_CHECK(R.n < MAX_RESETS, "harness limit on resets");
    R.pos[R.n++] = O.popped + (PK_UART_TX_SIZE - pk_uart_tx_space(&U)) + G.out_len;
}

/* The sender waits for the greeting after its last reset. */
static int await_greeting(void) { return R.greeted < R.n + 1u; }

/* Output from stream position p on: the lines sent before the resets at or
 * before p are cut (unanswered), the sender stops waiting for them. */
static void pass_resets(unsigned long p)
{
    while (R.passed < R.n && R.pos[R.passed] <= p)
        R.passed++;
    while (S.head != S.tail && S.epoch[S.tail % FIFO] < R.passed) {
        S.inflight -= S.len[S.tail % FIFO];
        S.tail++;
    }
}

static void answer(int ok)
{
    FZ_CHECK(S.head != S.tail, "never more answers than lines (an answer after a reset is for a line sent after it)");
    unsigned i = S.tail++ % FIFO;
    S.inflight -= S.len[i];
    int s = S.seq[i];
    if (s >= 0 && ok)
        FZ_CHECK(moved[s] == 1u, "a move line answered ok handed its move over, once");
    if (s >= 0 && !ok)
        FZ_CHECK(moved[s] == 0u, "a line answered with an error moved nothing");
}

static void out_line(const char *s, unsigned n)
{
    if (VERBOSE)
        fprintf(stderr, "  <- %.*s\n", (int)(n ? n - 1u : 0u), s);
    FZ_CHECK(n >= 1u && s[n - 1] == '\r', "output lines end with CR LF");
    n--;
    if (n == 0)
        return;
    if (n == 2 && !memcmp(s, "ok", 2)) {
        answer(1);
        return;
    }
    if (n > 6 && !memcmp(s, "error:", 6)) {
        for (unsigned k = 6; k < n; k++)
            FZ_CHECK(s[k] >= '0' && s[k] <= '9', "error:N has a number");
        answer(0);
        return;
    }
    if (s[0] == '<') {
        FZ_CHECK(s[n - 1] == '>', "a status report is whole");
        reports++;
        status_owed = 0;
        FZ_CHECK(reports <= q_bytes, "never more status reports than '?' bytes");
        return;
    }
    if (n > 5 && !memcmp(s, "Grbl ", 5)) {
        O.greetings++;
        R.greeted = R.passed + 1u;
        return;
    }
    int known = s[0] == '[' || s[0] == '$' || s[0] == '>' || (n > 6 && !memcmp(s, "ALARM:", 6));
    if (!known)
        fprintf(stderr, "line: '%.*s'\n", (int)n, s);
    FZ_CHECK(known, "every output line is a known kind");
}

static void take_output(unsigned room)
{
    uint8_t b[64];
    size_t n;
    while (room > 0u && (n = pk_uart_tx_pop(&U, b, room < sizeof b ? room : sizeof b)) > 0u) {
        room -= (unsigned)n;
        O.popped += n;
        if (VERBOSE > 1)
            fprintf(stderr, "  (%zu bytes: '%.*s')\n", n, (int)n, (const char *)b);
        for (size_t k = 0; k < n; k++) {
            FZ_CHECK(O.n < sizeof O.line, "output lines are short");
            if (O.n == 0u) {
                O.start = O.popped - n + k;
                pass_resets(O.start);
            }
            O.line[O.n++] = (char)b[k];
            if (b[k] == '\n') {
                out_line(O.line, O.n - 1u);
                O.n = 0;
            }
        }
    }
}

/* ---- the main loop ------------------------------------------------------------------ */
static void main_loop(void)
{
    int running = M.q > 0u && !M.held && !M.alarm, held = M.held;
    unsigned holds = M.holds, resumes = M.resumes, resets = M.resets;
    if (VERBOSE && (P.reset | P.hold | P.cycle | P.status | P.events))
        fprintf(stderr, "main loop after Ctrl-X %u, '!' %u, '~' %u, '?' %u (%u ring events); machine %s\n",
                P.reset, P.hold, P.cycle, P.status, P.events, held ? "held" : running ? "running" : "idle");
    pk_grbl_poll(&G);
    for (unsigned i = 0; i < G.len; i++)
        FZ_CHECK(!is_rt(G.line[i]), "realtime bytes never enter the line buffer");
    FZ_CHECK(M.resets - resets == (P.reset ? 1u : 0u),
             "a Ctrl-X resets once by the next main loop run, and nothing else does");
    if (P.reset) {
        status_owed = 0; /* a report still waiting for room goes with the reset */
    } else {
        if (P.hold && running)
            FZ_CHECK(M.holds > holds, "a '!' holds a running machine by the next main loop run");
        if (P.cycle && held && !P.hold)
            FZ_CHECK(M.resumes > resumes, "a '~' resumes a held machine by the next main loop run");
        if (P.status)
            status_owed = 1;
    }
    if (M.holds > holds)
        FZ_CHECK(P.hold || P.door, "no hold without a '!' (or Grbl's safety door, 0x84)");
    if (M.resumes > resumes)
        FZ_CHECK(P.cycle, "no resume without a '~'");
    if (P.reset)
        OV.feed = OV.rapid = OV.spindle = 100;
    else
        ovr_model(P.ovr);
    FZ_CHECK(G.ovr_feed == OV.feed && G.ovr_rapid == OV.rapid && G.ovr_spindle == OV.spindle,
             "the overrides are Grbl's arithmetic on the override bytes of each batch");
    FZ_CHECK(MO.calls > 0u && MO.feed == (unsigned)OV.feed && MO.rapid == (unsigned)OV.rapid,
             "the machine runs under the overrides the engine has");
    memset(&P, 0, sizeof P);
    take_output(O.room);
}

/* Send one line (its bytes plus '\n'), maybe with a burst after byte `at`. */
static void send_line(struct fz_in *in, unsigned kind, unsigned at, unsigned nburst)
{
    char l[64];
    int seq = -1, n;
    switch (kind) {
    case L_MOVE:
    case L_RAPID:
        if (seq_next >= (int)MAXSEQ)
            return;
        seq = seq_next;
        n = snprintf(l, sizeof l, kind == L_MOVE ? "G1X%d.%dY%d.%dF6000\n" : "G0 X%d.%d Y%d.%d\n",
                     (seq % 1000) / 10, seq % 10, seq / 10000, (seq / 1000) % 10);
        break;
    case L_UNLOCK: n = snprintf(l, sizeof l, "$X\n"); break;
    case L_DWELL: n = snprintf(l, sizeof l, "G4P0\n"); break;
    case L_BAD: n = snprintf(l, sizeof l, "G1X\n"); break;
    default: n = snprintf(l, sizeof l, "\n"); break;
    }
    unsigned len = (unsigned)n;
    if (await_greeting() || S.inflight + len > PK_UART_RX_SIZE || S.head - S.tail >= FIFO)
        return; /* the sender waits (for the greeting, for room) */
    if (seq >= 0)
        seq_next++;
    unsigned i = S.head++ % FIFO;
    S.seq[i] = seq;
    S.kind[i] = (uint8_t)kind;
    S.len[i] = len;
    S.epoch[i] = R.n;
    S.inflight += len;
    S.sent_lines++;
    if (VERBOSE)
        fprintf(stderr, "-> %.*s%s\n", (int)len - 1, l, nburst ? " (with a burst)" : "");
    for (unsigned k = 0; k < len; k++) {
        rx_byte((uint8_t)l[k]);
        if (k == at % len && nburst)
            burst(in, nburst);
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    struct fz_in in = { data, size < MAX_INPUT ? size : MAX_INPUT, 0 };
    VERBOSE = getenv("FUZZ_REALTIME_VERBOSE") ? atoi(getenv("FUZZ_REALTIME_VERBOSE")) : 0;
    memset(&M, 0, sizeof M);
    memset(moved, 0, sizeof moved);
    memset(&S, 0, sizeof S);
    memset(&P, 0, sizeof P);
    memset(&O, 0, sizeof O);
    q_bytes = reports = 0;
    memset(&MO, 0, sizeof MO);
    OV.feed = OV.rapid = OV.spindle = 100;
    status_owed = 0;
    seq_next = 0;
    M.last_seq = -1;
    uint8_t cfg = fz_u8(&in);
    M.cap = 1u + (cfg & 7u);
    O.room = 64u;
    memset(&R, 0, sizeof R);

    static const struct pk_grbl_machine_ops mo = {
        .move = m_move, .pen = m_pen, .dwell = m_dwell, .smoothing = m_smoothing, .end = m_end,
        .hold = m_hold, .resume = m_resume, .reset = m_reset, .position_um = m_position,
        .state = m_state, .blocks_free = m_free, .blocks_total = m_total, .speed_umpm = m_speed,
        .configure = m_configure, .set_override = m_override,
    };
    struct pk_grbl_stream io = { pk_uart_read_cb, pk_uart_write_cb, pk_uart_rx_used_cb, &U };
    pk_uart_init(&U, pk_grbl_rt_filter, &G);
    FZ_CHECK(pk_grbl_init(&G, &io, &mo, &M, NULL, NULL) == 0, "init with default settings");

    unsigned events = 0;
    while (fz_more(&in) && events++ < MAX_EVENTS) {
        uint8_t ev = fz_u8(&in);
        switch (ev & 7u) {
        case 0: case 1: case 2: { /* a line, sometimes with a burst inside */
            unsigned kind = ((ev >> 3) & 7u) % L_KINDS; /* 6, 7: moves again */
            unsigned nb = (ev & 0x80u) ? 1u + (fz_u8(&in) & 31u) : 0u;
            unsigned at = nb ? fz_u8(&in) : 0u;
            send_line(&in, kind, at, nb);
            break;
        }
        case 3: /* a burst alone */
            burst(&in, 1u + (fz_u8(&in) & 63u));
            break;
        case 4: case 5: /* the main loop runs */
            for (unsigned k = 0; k < 1u + ((ev >> 3) & 3u); k++)
                main_loop();
            break;
        case 6: /* the machine executes */
            m_run((ev >> 3) & 7u);
            main_loop();
            break;
        default: /* the transmitter's room changes */
            O.room = fz_u8(&in);
            break;
        }
    }

    /* Drain: the sender resumes any hold and waits for every answer. */
    O.room = 4096u;
    unsigned spins = 0;
    for (; spins < 2000u; spins++) {
        if (M.held || spins % 16u == 15u)
            rx_byte('~'); /* cycle start: also an engine-level hold (0x84 or '!' while idle) */
        main_loop();
        m_run(8);
        if (!await_greeting() && S.head == S.tail && pk_grbl_idle(&G) && M.q == 0u && !M.held &&
            pk_uart_rx_used(&U) == 0u)
            break;
    }
    if (spins == 2000u)
        fprintf(stderr, "drain: %u lines in flight, await greeting %d, idle %d, q %u, held %d\n",
                S.head - S.tail, await_greeting(), pk_grbl_idle(&G), M.q, M.held);
    FZ_CHECK(spins < 2000u, "every line is answered and the engine ends idle");
    FZ_CHECK(O.n == 0u, "output ends with a complete line");
    FZ_CHECK(!status_owed, "every '?' got a status report");
    FZ_CHECK(O.greetings <= 1u + M.resets, "a greeting at start and after each reset, no more");
    FZ_CHECK(pk_uart_rx_dropped(&U) == 0u, "nothing lost to RX overflow");
    return 0;
}
