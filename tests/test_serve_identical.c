/*
 * test_serve_identical.c — motion is a function of the program and the
 * settings, never of when the lines arrive (issue 10, item 3): the same
 * program read whole by `plotkin sim`, streamed to `plotkin serve`'s machine
 * with Grbl's character counting, and streamed send-and-wait (each line
 * after the previous one's ok, with a sender's turnaround), gives the same
 * pin trace: every step, direction, enable and pen edge, in the same order,
 * at the same tick counted from the first edge of motion (a step, direction
 * or pen edge; the drivers' enable before it is left out).
 *
 * This holds while the sender keeps up within the look-ahead wait ($207,
 * 100 ms by default: a stroke waits that long for its next move before it
 * plans to a stop); a sender that pauses longer changes the trace, as it
 * must (tried: 200 ms per line differs at the first corner).
 *
 * The program has what made smoothing depend on timing before: a G64 P
 * after a dwell, a polygon whose corners are blended, a long-legged
 * corner, pen lifts between strokes.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "th.h"
#include "serve_sim.h"

int th_main(int argc, char **argv);

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

static char prog[32 * 1024];

static void make_prog(void)
{
    size_t k = 0;
#define ADD(...) (k += (size_t)snprintf(prog + k, sizeof prog - k, __VA_ARGS__))
    ADD("G21 G90\n");
    ADD("G4 P0.2\n");
    ADD("G64 P0.05\n");
    ADD("G0 X10 Y10\nM3\n");
    ADD("G1 X110 Y10 F6000\nG1 X210 Y50\n"); /* the 21.8-degree corner */
    ADD("M5\nG0 X60 Y40\nM3\n");
    for (int i = 1; i <= 40; i++) /* a 40-gon, fast enough for its corners to matter */
        ADD("G1 X%.4f Y%.4f F12000\n", 40 + 20 * cos(2 * M_PI * i / 40), 40 + 20 * sin(2 * M_PI * i / 40));
    ADD("M5\nG0 X0 Y0\n");
#undef ADD
}

/* Edges of motion (initial levels left out), as (tick from the first, kind,
 * axis, level) — the trace a logic analyser on the pins would show. */
struct edges {
    size_t n;
    uint64_t *t;
    uint32_t *what;
};

static void take_edges(const struct pk_trace *tr, struct edges *out)
{
    out->n = 0;
    out->t = malloc(sizeof *out->t * (tr->n + 1));
    out->what = malloc(sizeof *out->what * (tr->n + 1));
    uint64_t t0 = 0;
    int have0 = 0;
    for (size_t i = 0; i < tr->n && out->t && out->what; i++) {
        const struct pk_trace_edge *e = &tr->e[i];
        if (e->initial)
            continue;
        /* the drivers are enabled when the machine starts, which is before
         * the hook is in place on a serve machine: motion starts the trace */
        if (!have0 && e->kind == PK_SIG_ENABLE)
            continue;
        if (!have0) {
            t0 = e->t;
            have0 = 1;
        }
        out->t[out->n] = e->t - t0;
        out->what[out->n] = (uint32_t)e->kind << 16 | (uint32_t)e->axis << 8 | e->level;
        out->n++;
    }
}

static void free_edges(struct edges *e)
{
    free(e->t);
    free(e->what);
}

enum sender { CHAR_COUNT, SEND_WAIT };

/* The serve machine keeps no trace (flat memory): its edges are recorded
 * here on their way to the decoder. */
static struct pk_trace rec;
static pk_trace_edge_fn rec_next;
static void *rec_next_arg;

static void rec_edge(void *arg, const struct pk_trace_edge *e)
{
    (void)arg;
    if (rec.n == rec.cap) {
        size_t cap = rec.cap ? rec.cap * 2 : 65536;
        struct pk_trace_edge *ne = realloc(rec.e, cap * sizeof *ne);
        if (ne == NULL) {
            rec.oom = 1;
            return;
        }
        rec.e = ne;
        rec.cap = cap;
    }
    rec.e[rec.n++] = *e;
    if (rec_next != NULL)
        rec_next(rec_next_arg, e);
}

/* Stream prog to a serve machine as a sender would; the edges it made. */
static int stream(enum sender how, const char *chip, struct edges *out)
{
    static struct pk_serve_sim s;
    const struct pk_timing_limits lim = PK_TIMING_DRV8825;
    if (pk_serve_sim_start(&s, chip, &lim) != 0) {
        th_fail(__FILE__, __LINE__, s.r.err);
        pk_serve_sim_free(&s);
        return -1;
    }
    memset(&rec, 0, sizeof rec);
    rec_next = s.r.hw.trace.on_edge;
    rec_next_arg = s.r.hw.trace.on_edge_arg;
    s.r.hw.trace.on_edge = rec_edge;
    const uint64_t turnaround = s.cfg.tick_hz / 500u; /* send-and-wait: 2 ms per line */
    const char *p = prog;
    size_t inflight[256], nin = 0, used = 0;  /* character counting: lengths sent, not yet answered */
    unsigned sent = 0, answered = 0;
    uint64_t next_send = 0;
    char line[64];
    size_t ll = 0;
    int rc = 0;
    for (long it = 0; it < 4000000L; it++) {
        /* send what the sender's rule allows */
        while (*p) {
            size_t n = strcspn(p, "\n") + 1;
            if (how == CHAR_COUNT && (used + n > 128u || nin == 256u))
                break;
            if (how == SEND_WAIT && (answered < sent || pk_serve_sim_now(&s) < next_send))
                break;
            if (pk_uart_rx_space(&s.uart) < n)
                break;
            for (size_t i = 0; i < n; i++)
                pk_uart_rx_push(&s.uart, (uint8_t)p[i]);
            pk_serve_sim_wake(&s);
            inflight[nin++] = n;
            used += n;
            sent++;
            p += n;
        }
        if (pk_serve_sim_run(&s, 100) != 0) {
            th_fail(__FILE__, __LINE__, "the simulation broke down");
            rc = -1;
            break;
        }
        uint8_t b[64];
        size_t got;
        while ((got = pk_uart_tx_pop(&s.uart, b, sizeof b)) > 0) {
            for (size_t i = 0; i < got; i++) {
                if (b[i] != '\n') {
                    if (ll < sizeof line - 1)
                        line[ll++] = (char)b[i];
                    continue;
                }
                line[ll] = '\0';
                ll = 0;
                if (!strncmp(line, "ok", 2) || !strncmp(line, "error", 5)) {
                    if (!strncmp(line, "error", 5))
                        th_fail(__FILE__, __LINE__, line);
                    if (nin > 0) {
                        used -= inflight[0];
                        memmove(inflight, inflight + 1, (nin - 1) * sizeof inflight[0]);
                        nin--;
                    }
                    answered++;
                    next_send = pk_serve_sim_now(&s) + turnaround;
                }
            }
        }
        if (!*p && answered == sent && pk_machine_state(&s.r.m) == PK_STATE_IDLE && !s.r.hw.sched.armed)
            break;
    }
    TH_EXPECT_EQ(answered, sent);
    TH_EXPECT(!rec.oom);
    if (rc == 0)
        take_edges(&rec, out);
    free(rec.e);
    rec.e = NULL;
    (void)pk_serve_sim_finish(&s);
    TH_EXPECT_EQ(s.r.dec.n_viol, 0u);
    pk_serve_sim_free(&s);
    return rc;
}

static void expect_same(const struct edges *a, const struct edges *b, const char *what)
{
    char msg[200];
    size_t n = a->n < b->n ? a->n : b->n;
    if (a->n != b->n) {
        snprintf(msg, sizeof msg, "%s: %zu edges against %zu", what, b->n, a->n);
        th_fail(__FILE__, __LINE__, msg);
    }
    for (size_t i = 0; i < n; i++) {
        if (a->t[i] != b->t[i] || a->what[i] != b->what[i]) {
            snprintf(msg, sizeof msg, "%s: edge %zu differs (tick %llu kind/axis/level %06x against %llu %06x)",
                     what, i, (unsigned long long)b->t[i], (unsigned)b->what[i], (unsigned long long)a->t[i],
                     (unsigned)a->what[i]);
            th_fail(__FILE__, __LINE__, msg);
            return;
        }
    }
}

static void test_sim_character_counting_and_send_and_wait_give_the_same_pin_trace(void)
{
    make_prog();
    static struct pk_sim_result ref;
    struct pk_sim_cfg cfg;
    pk_sim_cfg_default(&cfg);
    struct pk_sim_opts o = { .chip = "ident-sim", .cfg = &cfg, .program = prog, .len = strlen(prog),
                             .lim = PK_TIMING_DRV8825, .keep_trace = 1 };
    TH_ASSERT_EQ(pk_sim_run(&o, &ref), 0);
    TH_ASSERT_EQ(ref.run_status, PK_SIM_RUN_FINISHED);
    TH_ASSERT_EQ(ref.job.errors, 0ul);
    struct edges e_sim, e_cc = { 0 }, e_sw = { 0 };
    take_edges(&ref.hw.trace, &e_sim);
    TH_EXPECT(e_sim.n > 20000u); /* the program moved (about 30,000 steps) */
    /* the stroke of short chords was smoothed: more segments than moves */
    TH_EXPECT(ref.job.segments > ref.job.move_requests);
    pk_sim_result_free(&ref);
    if (stream(CHAR_COUNT, "ident-cc", &e_cc) == 0)
        expect_same(&e_sim, &e_cc, "character counting vs plotkin sim");
    if (stream(SEND_WAIT, "ident-sw", &e_sw) == 0)
        expect_same(&e_sim, &e_sw, "send-and-wait vs plotkin sim");
    free_edges(&e_sim);
    free_edges(&e_cc);
    free_edges(&e_sw);
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    static const struct th_case cases[] = {
        TH_CASE(test_sim_character_counting_and_send_and_wait_give_the_same_pin_trace),
    };
    return th_run(cases, TH_COUNT(cases));
}
