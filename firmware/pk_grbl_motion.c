/*
 * pk_grbl_motion.c — the Grbl engine's machine ops on top of pk_motion.h
 * (see pk_grbl_motion.h).
 */
#include "pk_grbl_motion.h"

#include <string.h>

static int map_rc(int rc)
{
    switch (rc) {
    case PK_MOTION_OK: return PK_GRBL_M_OK;
    case PK_MOTION_EFULL: return PK_GRBL_M_FULL;
    case PK_MOTION_ETRAVEL: return PK_GRBL_M_ETRAVEL;
    default: return PK_GRBL_M_ERROR;
    }
}

static struct pk_machine *mach(void *ctx) { return ((struct pk_grbl_motion *)ctx)->m; }

static uint32_t ival(const struct pk_grbl_settings *s, int i) { return (uint32_t)s->v[i]; }

static void smooth_cfg(const struct pk_grbl_settings *s, int exact, pk_um_t tol_um,
                       struct pk_smooth_cfg *c)
{
    memset(c, 0, sizeof *c);
    c->sharp_turn_deg = (uint16_t)ival(s, PK_GRBL_S_CORNER_DEG);
    c->scheme = (uint8_t)ival(s, PK_GRBL_S_SCHEME);
    c->degree = (uint8_t)ival(s, PK_GRBL_S_DEGREE);
    c->depth = (uint8_t)ival(s, PK_GRBL_S_DEPTH);
    uint32_t mode = ival(s, PK_GRBL_S_SMOOTH_MODE);
    if (exact || mode == 0) {
        c->mode = PK_SMOOTH_OFF;
    } else if (mode == 1) {
        c->mode = PK_SMOOTH_FIXED;
    } else {
        c->mode = PK_SMOOTH_TOLERANCE;
        c->scheme = PK_SCHEME_BSPLINE;
        if (c->degree != 2 && c->degree != 3)
            c->degree = 3;
        c->tolerance_um = tol_um < 1 ? 1 : tol_um > 10000 ? 10000 : tol_um;
    }
}

/* µs -> ticks (at least one): us * tick_hz / 10^6, rounded. */
static uint32_t us_ticks(uint32_t us, uint32_t tick_hz)
{
    uint64_t t = ((uint64_t)us * tick_hz + 500000u) / 1000000u;
    return t > 0xffffffffu ? 0xffffffffu : (uint32_t)t;
}

void pk_grbl_motion_cfg(const struct pk_grbl_settings *s, uint32_t tick_hz,
                        struct pk_motion_cfg *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->axes = PK_AXES;
    for (int a = 0; a < PK_AXES && a < PK_GC_AXES; a++) {
        /* 1e-4 steps/mm -> Q16.16: v * 65536 / 10^4, rounded */
        cfg->steps_per_mm_q16[a] =
            (pk_spmm_q16_t)(((uint64_t)ival(s, PK_GRBL_S_STEPS_X + a) * 65536u + 5000u) / 10000u);
        /* 1e-3 mm/min is µm/min; 1e-3 mm/s^2 is µm/s^2 */
        cfg->max_rate[a] = ival(s, PK_GRBL_S_RATE_X + a);
        cfg->accel[a] = ival(s, PK_GRBL_S_ACCEL_X + a);
    }
    cfg->junction_dev_um = (pk_um_t)ival(s, PK_GRBL_S_JUNCTION_MM);
    uint32_t pulse = us_ticks(ival(s, PK_GRBL_S_STEP_PULSE_US), tick_hz);
    cfg->step_pulse_ticks = pulse < 1u ? 1u : pulse;
    cfg->dir_setup_ticks = us_ticks(ival(s, PK_GRBL_S_DIR_SETUP_US), tick_hz);
    cfg->pen_settle_ms = ival(s, PK_GRBL_S_PEN_SETTLE_MS);
    cfg->pen_down_level = 1;
    cfg->lookahead_wait_ms = (uint16_t)ival(s, PK_GRBL_S_LOOKAHEAD_MS);
    /* Grbl $5 / $6: invert the limit / probe pins */
    cfg->input_invert = (uint16_t)((ival(s, PK_GRBL_S_LIMIT_INVERT) ? PK_IN_LIMITS : 0u) |
                                   (ival(s, PK_GRBL_S_PROBE_INVERT) ? 1u << PK_IN_PROBE : 0u));
    smooth_cfg(s, 0, (pk_um_t)ival(s, PK_GRBL_S_TOLERANCE_MM), &cfg->smooth);
}

static void to_machine(const pk_um_t t[PK_GC_AXES], pk_um_t p[PK_AXES])
{
    memset(p, 0, sizeof(pk_um_t) * PK_AXES);
    for (int a = 0; a < PK_AXES && a < PK_GC_AXES; a++)
        p[a] = t[a];
}

static pk_um_min_t feed_of(pk_gc_umpm_t feed)
{
    /* the interpreter refuses feeds below 1 mm/min; above 60 m/min is beyond
     * every axis' max rate ($11x <= 60000), so the planner's clamp is the same */
    return feed <= 0 ? 0u : (uint32_t)feed > PK_UM_MIN_MAX ? PK_UM_MIN_MAX : (pk_um_min_t)feed;
}

static int op_move(void *ctx, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, int rapid)
{
    pk_um_t p[PK_AXES];
    to_machine(t, p);
    return map_rc(pk_machine_move(mach(ctx), p, rapid ? PK_UM_MIN_MAX : feed_of(feed),
                                  rapid ? PK_MOVE_RAPID : PK_MOVE_FEED));
}

static int op_move_chord(void *ctx, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, pk_um_t err)
{
    pk_um_t p[PK_AXES];
    to_machine(t, p);
    return map_rc(pk_machine_move_chord(mach(ctx), p, feed_of(feed), err > 10000 ? 10000 : err));
}

static int op_pen(void *ctx, int down) { return map_rc(pk_machine_pen(mach(ctx), down != 0)); }

static int op_spindle(void *ctx, uint16_t v, int sync)
{
    return map_rc(pk_machine_spindle(mach(ctx), v, sync != 0));
}

static int op_dwell(void *ctx, uint32_t ms) { return map_rc(pk_machine_dwell(mach(ctx), ms)); }

static int op_smoothing(void *ctx, int exact, pk_um_t tol_um)
{
    struct pk_grbl_motion *gm = ctx;
    struct pk_smooth_cfg c;
    smooth_cfg(&gm->set, exact, tol_um, &c);
    return map_rc(pk_machine_set_smoothing(gm->m, &c));
}

static int op_end(void *ctx) { return map_rc(pk_machine_end(mach(ctx))); }
static void op_hold(void *ctx) { pk_machine_hold(mach(ctx)); }
static void op_resume(void *ctx) { pk_machine_resume(mach(ctx)); }
static int op_reset(void *ctx) { return pk_machine_reset(mach(ctx)) ? 1 : 0; }

static void op_position(void *ctx, pk_um_t out[PK_GC_AXES])
{
    pk_um_t p[PK_AXES];
    pk_machine_position_um(mach(ctx), p);
    for (int a = 0; a < PK_GC_AXES; a++)
        out[a] = a < PK_AXES ? p[a] : 0;
}

static int op_state(void *ctx)
{
    switch (pk_machine_state(mach(ctx))) {
    case PK_STATE_RUN: return PK_GRBL_M_RUN;
    case PK_STATE_HOLDING: return PK_GRBL_M_HOLDING;
    case PK_STATE_HOLD: return PK_GRBL_M_HOLD;
    case PK_STATE_ALARM: return PK_GRBL_M_ALARM;
    default: return PK_GRBL_M_IDLE;
    }
}

static uint32_t op_blocks_free(void *ctx)
{
    uint32_t fill = pk_machine_queue_fill(mach(ctx));
    return fill >= PK_MQ_CAP ? 0u : PK_MQ_CAP - fill;
}

static uint32_t op_blocks_total(void *ctx)
{
    (void)ctx;
    return PK_MQ_CAP;
}

static pk_gc_umpm_t op_speed(void *ctx)
{
    pk_um_min_t v = pk_machine_speed(mach(ctx));
    return v > (pk_um_min_t)PK_GC_FEED_MAX ? PK_GC_FEED_MAX : (pk_gc_umpm_t)v;
}

static int op_configure(void *ctx, const struct pk_grbl_settings *s)
{
    struct pk_grbl_motion *gm = ctx;
    struct pk_motion_cfg cfg;
    pk_grbl_motion_cfg(s, gm->hal->tick_hz, &cfg);
    if (gm->ready) {
        /* The step position stays; its mm value follows the new steps/mm, as
         * in Grbl. Refuse a change that would put it beyond ±PK_UM_MAX. */
        pk_steps_t st[PK_AXES];
        pk_machine_position_steps(gm->m, st);
        for (int a = 0; a < PK_AXES && a < (int)cfg.axes; a++) {
            int64_t um = (int64_t)st[a] * 1000 * 65536 / (int64_t)cfg.steps_per_mm_q16[a];
            if (um > PK_UM_MAX || um < -PK_UM_MAX)
                return -1;
        }
    }
    /* First time: initialise. Afterwards: reconfigure, which keeps the step
     * position and changes nothing if it refuses (not idle, out of range). */
    int rc = gm->ready ? pk_machine_configure(gm->m, &cfg) : pk_machine_init(gm->m, &cfg, gm->hal);
    if (rc != PK_MOTION_OK)
        return -1;
    if (!gm->ready)
        pk_machine_set_yield(gm->m, gm->yield, gm->yield_ctx);
    gm->set = *s;
    gm->ready = 1;
    return 0;
}

static int op_set_override(void *ctx, uint16_t feed_pct, uint16_t rapid_pct)
{
    return map_rc(pk_machine_set_override(mach(ctx), feed_pct, rapid_pct));
}

static int op_set_soft_limits(void *ctx, int on, const pk_um_t lo[PK_GC_AXES], const pk_um_t hi[PK_GC_AXES])
{
    pk_um_t l[PK_AXES], h[PK_AXES];
    to_machine(lo, l);
    to_machine(hi, h);
    return map_rc(pk_machine_set_soft_limits(mach(ctx), on != 0, l, h));
}

/* ---- inputs (PK_GRBL_INPUTS) ---- */
#if PK_GRBL_INPUTS

_Static_assert(PK_GRBL_IN_LIMITS == PK_IN_LIMITS && PK_GRBL_IN_PROBE == 1u << PK_IN_PROBE &&
               PK_GRBL_IN_DOOR == 1u << PK_IN_DOOR && PK_GRBL_IN_HOLD == 1u << PK_IN_HOLD &&
               PK_GRBL_IN_RESUME == 1u << PK_IN_RESUME && PK_GRBL_IN_RESET == 1u << PK_IN_RESET,
               "the engine's input bits are hal.h's");

static int op_probe(void *ctx, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, unsigned flags)
{
    pk_um_t p[PK_AXES];
    to_machine(t, p);
    int rc = pk_machine_probe(mach(ctx), p, feed_of(feed), (flags & 1u) != 0u);
    if (rc == PK_MOTION_ENOINPUT)
        return PK_GRBL_M_ENOTSUP;
    if (rc == PK_MOTION_ETRIGGERED)
        return PK_GRBL_M_ETRIGGERED;
    return map_rc(rc);
}

static int op_probe_result(void *ctx, pk_um_t pos[PK_GC_AXES])
{
    struct pk_machine *m = mach(ctx);
    pk_steps_t st[PK_AXES];
    enum pk_cycle_result r = pk_machine_cycle(m, st, NULL);
    for (int a = 0; a < PK_GC_AXES; a++)
        pos[a] = a < PK_AXES ? pk_steps_to_um(st[a], m->cfg.steps_per_mm_q16[a]) : 0;
    switch (r) {
    case PK_CYCLE_RUNNING: return PK_GRBL_PRB_RUNNING;
    case PK_CYCLE_DONE: return PK_GRBL_PRB_CONTACT;
    case PK_CYCLE_MISSED: return PK_GRBL_PRB_MISSED;
    default: return PK_GRBL_PRB_ABORTED;
    }
}

static int op_home(void *ctx, unsigned axes)
{
    struct pk_grbl_motion *gm = ctx;
    const struct pk_grbl_settings *s = &gm->set;
    struct pk_home_cfg c;
    memset(&c, 0, sizeof c);
    c.dir_invert = (uint8_t)ival(s, PK_GRBL_S_HOMING_DIR);
    c.feed = ival(s, PK_GRBL_S_HOMING_FEED);   /* 1e-3 mm/min = µm/min */
    c.seek = ival(s, PK_GRBL_S_HOMING_SEEK);
    c.debounce_ms = (uint16_t)ival(s, PK_GRBL_S_HOMING_DEBOUNCE);
    c.pulloff_um = (pk_um_t)ival(s, PK_GRBL_S_HOMING_PULLOFF);
    for (int a = 0; a < PK_AXES && a < PK_GC_AXES; a++)
        c.travel_um[a] = (pk_um_t)ival(s, PK_GRBL_S_TRAVEL_X + a);
    /* the axes asked for that have a switch (Grbl homes what its cycles name) */
    uint32_t have = gm->hal->inputs & PK_IN_LIMITS & axes;
    if (have == 0u)
        return PK_GRBL_M_ENOTSUP;
    int rc = pk_home_start(&gm->home, gm->m, &c, (uint8_t)have);
    return rc == PK_MOTION_ENOINPUT ? PK_GRBL_M_ENOTSUP : map_rc(rc);
}

static int op_home_poll(void *ctx)
{
    struct pk_grbl_motion *gm = ctx;
    int st = pk_home_poll(&gm->home);
    if (st == PK_HOME_RUNNING)
        return 0;
    if (st == PK_HOME_DONE)
        return 1;
    int f = (int)pk_home_fail(&gm->home);
    return f == 0 ? PK_HOME_FAIL_RESET : f;
}

static void op_home_abort(void *ctx, int alarm)
{
    pk_home_abort(&((struct pk_grbl_motion *)ctx)->home, (enum pk_home_fail)alarm);
}

static int op_set_hard_limits(void *ctx, int on)
{
    int rc = pk_machine_set_hard_limits(mach(ctx), on != 0);
    return rc == PK_MOTION_ENOINPUT ? PK_GRBL_M_ENOTSUP : map_rc(rc);
}

static uint32_t op_inputs(void *ctx, unsigned what)
{
    struct pk_grbl_motion *gm = ctx;
    if (what == PK_GRBL_IN_HAVE)
        return gm->hal->inputs;
    if (gm->hal->inputs == 0u)
        return 0u;
    return what == PK_GRBL_IN_LEVELS ? pk_machine_inputs(gm->m) : pk_machine_input_events(gm->m);
}

static int op_alarm_is_limit(void *ctx)
{
    return pk_machine_alarm(mach(ctx)) == PK_ALARM_HARD_LIMIT;
}
#endif

/* A function rather than a const table: a table of pointers would be
 * writable (relocated) data, which the firmware never holds. */
void pk_grbl_motion_ops(struct pk_grbl_machine_ops *o)
{
    memset(o, 0, sizeof *o);
    o->move = op_move;
    o->move_chord = op_move_chord;
    o->pen = op_pen;
    o->spindle = op_spindle;
    o->dwell = op_dwell;
    o->smoothing = op_smoothing;
    o->end = op_end;
    o->hold = op_hold;
    o->resume = op_resume;
    o->reset = op_reset;
    o->position_um = op_position;
    o->state = op_state;
    o->blocks_free = op_blocks_free;
    o->blocks_total = op_blocks_total;
    o->speed_umpm = op_speed;
    o->configure = op_configure;
    o->set_override = op_set_override;
    o->set_soft_limits = op_set_soft_limits;
#if PK_GRBL_INPUTS /* else NULL: no switches, no probe, no buttons */
    o->probe = op_probe;
    o->probe_result = op_probe_result;
    o->home = op_home;
    o->home_poll = op_home_poll;
    o->home_abort = op_home_abort;
    o->set_hard_limits = op_set_hard_limits;
    o->inputs = op_inputs;
    o->alarm_is_limit = op_alarm_is_limit;
#endif
}

/* ---- the HAL's store ---- */

static int nvm_rd(void *ctx, uint32_t off, uint8_t *buf, size_t len)
{
    const struct pk_hal *h = ctx;
    return h->ops->nvm_read(h->ctx, off, buf, len) == PK_HAL_OK ? 0 : -1;
}

static int nvm_wr(void *ctx, uint32_t off, const uint8_t *buf, size_t len)
{
    const struct pk_hal *h = ctx;
    return h->ops->nvm_write(h->ctx, off, buf, len) == PK_HAL_OK ? 0 : -1;
}

void pk_grbl_motion_nvm(const struct pk_hal *hal, struct pk_grbl_nvm *nvm)
{
    memset(nvm, 0, sizeof *nvm);
    uint32_t n = pk_hal_nvm_size(hal);
    if (n == 0)
        return;
    nvm->read = nvm_rd;
    nvm->write = nvm_wr;
    nvm->ctx = (void *)(uintptr_t)hal; /* read-only use of the instance */
    nvm->size = n;
}
