/*
 * serve_sim.c — the Grbl engine on `plotkin sim`'s simulated machine (see
 * serve_sim.h).
 */
#include "serve_sim.h"

#include <stdlib.h>
#include <string.h>

/* Every answer the engine writes goes through here on its way to the UART:
 * "ok" and "error:N" lines are counted so that the summary can list the
 * errors by line, as `plotkin sim` does for a file. */
static void scan_answers(struct pk_serve_sim *s, const uint8_t *b, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (b[i] == '\n' || b[i] == '\r') {
            s->ans[s->ans_n < sizeof s->ans ? s->ans_n : sizeof s->ans - 1u] = '\0';
            if (s->ans_n == 2u && !memcmp(s->ans, "ok", 2)) {
                s->answered++;
            } else if (s->ans_n > 6u && !memcmp(s->ans, "error:", 6)) {
                s->answered++;
                pk_sim_job_note_error(&s->r.job, s->answered, atoi(s->ans + 6));
            }
            s->ans_n = 0;
        } else if (s->ans_n < sizeof s->ans - 1u) {
            s->ans[s->ans_n++] = (char)b[i];
        } else {
            s->ans_n = (uint8_t)sizeof s->ans; /* too long: not an answer */
        }
    }
}

static int write_scanned(void *ctx, const uint8_t *buf, size_t len)
{
    struct pk_serve_sim *s = ctx;
    int n = pk_uart_write_cb(&s->uart, buf, len);
    if (n > 0)
        scan_answers(s, buf, (size_t)n);
    return n;
}

static int read_uart(void *ctx, uint8_t *buf, size_t len)
{
    return pk_uart_read_cb(&((struct pk_serve_sim *)ctx)->uart, buf, len);
}

static size_t rx_used(void *ctx) { return pk_uart_rx_used_cb(&((struct pk_serve_sim *)ctx)->uart); }

/* The engine's primitives into the simulator's programmed path, as `plotkin
 * sim` feeds them (sim_job.c), so that the summary has the deviation of the
 * session. The line is the session's (1 = the first line received). The
 * window is not waited for (a sender cannot be made to wait for it); should
 * it be full, the oldest primitive goes early and the summary says that the
 * figures are upper bounds (forced_drops). */
static void serve_observe(void *ctx, const struct pk_grbl_prim *g)
{
    struct pk_serve_sim *s = ctx;
    struct pk_sim_job *j = &s->r.job;
    if (j->obs.on_prim == NULL)
        return;
    struct pk_path_prim p;
    pk_sim_prim_from_grbl(g, &j->pen_cfg, &p);
    p.line = g->line;
    j->obs.on_prim(j->obs.arg, &p);
}

/* One main-loop iteration of the board's firmware: protocol, then motion. */
static int serve_main(void *arg, uint64_t now)
{
    struct pk_serve_sim *s = arg;
    struct pk_machine *m = &s->r.m;
    (void)now;
    pk_grbl_poll(&s->g);
    pk_sim_job_poll_machine(&s->r.job);
    int alarm = pk_machine_state(m) == PK_STATE_ALARM;
    if (alarm && !s->in_alarm) {
        if (s->r.job.alarms == 0u) {
            s->r.job.alarm = (int)pk_machine_alarm(m);
            snprintf(s->r.job.alarm_text, sizeof s->r.job.alarm_text, "%s", pk_hal_error_text(m->hal));
        }
        s->r.job.alarms++;
    }
    s->in_alarm = (uint8_t)alarm;
    int busy = s->r.hw.sched.armed || !pk_grbl_idle(&s->g) || pk_uart_rx_used(&s->uart) > 0u ||
               pk_machine_state(m) != PK_STATE_IDLE;
    return busy ? PK_SIM_BUSY : PK_SIM_IDLE;
}

int pk_serve_sim_start(struct pk_serve_sim *s, const char *chip, const struct pk_timing_limits *lim)
{
    return pk_serve_sim_start_nvm(s, chip, lim, NULL);
}

int pk_serve_sim_start_nvm(struct pk_serve_sim *s, const char *chip, const struct pk_timing_limits *lim,
                           const struct pk_grbl_nvm *nvm_in)
{
    return pk_serve_sim_start_in(s, chip, lim, nvm_in, NULL, 0);
}

int pk_serve_sim_start_in(struct pk_serve_sim *s, const char *chip, const struct pk_timing_limits *lim,
                          const struct pk_grbl_nvm *nvm_in, const struct pk_sim_input *in, size_t n_in)
{
    memset(s, 0, sizeof *s);
    pk_sim_cfg_default(&s->cfg);
    struct pk_sim_opts o = { .chip = chip, .cfg = &s->cfg, .program = "", .len = 0, .lim = *lim,
                             .max_ticks = UINT64_MAX / 2u, .main_fn = serve_main, .main_arg = s,
                             .inputs = in, .n_inputs = n_in };
    if (pk_sim_start(&o, &s->r) != 0)
        return -1;
    /* A server is never "stuck": it waits for its sender as long as it takes. */
    s->r.hw.sched.idle_limit = UINT64_MAX;
    /* pk_sim_start configured the machine from the same $N defaults
     * (pk_sim_cfg_motion = pk_grbl_motion_cfg); the engine's configure at init
     * reconfigures it in place rather than initialising it a second time. */
    s->gm.m = &s->r.m;
    s->gm.hal = &s->r.hw.hal;
    pk_grbl_settings_default(&s->gm.set);
    s->gm.ready = 1;
    pk_uart_init(&s->uart, pk_grbl_rt_filter, &s->g);
    struct pk_grbl_stream io = { read_uart, write_scanned, rx_used, s };
    struct pk_grbl_machine_ops ops;
    pk_grbl_motion_ops(&ops);
    struct pk_grbl_nvm nvm;
    struct pk_grbl_settings dflt, *set = NULL;
    if (nvm_in != NULL) {
        nvm = *nvm_in; /* settings: the store's (first time: restored to the defaults) */
    } else {
        /* a fresh store, as a board whose EEPROM holds the defaults */
        memset(s->nvm_buf, 0xff, sizeof s->nvm_buf);
        s->ram.buf = s->nvm_buf;
        s->ram.size = sizeof s->nvm_buf;
        pk_grbl_ram_nvm(&s->ram, &nvm);
        pk_grbl_settings_default(&dflt);
        set = &dflt;
    }
    if (pk_grbl_init(&s->g, &io, &ops, &s->gm, set, &nvm) != 0) {
        snprintf(s->r.err, sizeof s->r.err, "the Grbl engine could not configure the machine");
        return -1;
    }
    pk_grbl_set_observer(&s->g, serve_observe, s);
    return 0;
}

int pk_serve_sim_run(struct pk_serve_sim *s, uint64_t ticks)
{
    if (ticks == 0u)
        return 0;
    return pk_sim_advance(&s->r, ticks) ? -1 : 0;
}

uint64_t pk_serve_sim_now(const struct pk_serve_sim *s) { return s->r.hw.sched.now; }

void pk_serve_sim_wake(struct pk_serve_sim *s)
{
    if (s->r.hw.sched.main_due > s->r.hw.sched.now)
        s->r.hw.sched.main_due = s->r.hw.sched.now;
}

int pk_serve_sim_finish(struct pk_serve_sim *s)
{
    s->r.job.lines = s->g.stats.lines;
    s->r.job.move_requests = s->g.stats.moves;
    pk_sim_cfg_from_grbl(&s->cfg, &s->g.set);
    s->r.mcfg = s->r.m.cfg; /* steps/mm as set now, to convert the decoded steps */
    return pk_sim_finish(&s->r);
}

void pk_serve_sim_free(struct pk_serve_sim *s) { pk_sim_result_free(&s->r); }
