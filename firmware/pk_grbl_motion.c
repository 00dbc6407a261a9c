/*
 * pk_grbl_motion.c — the Grbl engine's machine ops on top of pk_motion.h
 * (see pk_grbl_motion.h).
 */
#include "pk_grbl_motion.h"

#include <string.h>

static int map_rc(int rc)
{
    if (rc == PK_MOTION_OK)
        return PK_GRBL_M_OK;
    if (rc == PK_MOTION_EFULL)
        return PK_GRBL_M_FULL;
    return PK_GRBL_M_ERROR;
}

static struct pk_machine *mach(void *ctx) { return ((struct pk_grbl_motion *)ctx)->m; }

static uint32_t u6_div(pk_gc_u6_t v, int64_t d) { return (uint32_t)pk_div_round64(v, d); }

static void smooth_cfg(const struct pk_grbl_settings *s, int exact, pk_um_t tol_um,
                       struct pk_smooth_cfg *c)
{
    memset(c, 0, sizeof *c);
    c->sharp_turn_deg = (uint16_t)u6_div(s->v[PK_GRBL_S_CORNER_DEG], 1000000);
    c->scheme = (uint8_t)u6_div(s->v[PK_GRBL_S_SCHEME], 1000000);
    c->degree = (uint8_t)u6_div(s->v[PK_GRBL_S_DEGREE], 1000000);
    c->depth = (uint8_t)u6_div(s->v[PK_GRBL_S_DEPTH], 1000000);
    uint32_t mode = u6_div(s->v[PK_GRBL_S_SMOOTH_MODE], 1000000);
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

void pk_grbl_motion_cfg(const struct pk_grbl_settings *s, uint32_t tick_hz,
                        struct pk_motion_cfg *cfg)
{
    memset(cfg, 0, sizeof *cfg);
    cfg->axes = PK_AXES;
    for (int a = 0; a < PK_AXES && a < 3; a++) {
        /* 1e-6 steps/mm -> Q16.16: v * 65536 / 1e6 (v <= 1e10: fits int64) */
        cfg->steps_per_mm_q16[a] =
            (pk_spmm_q16_t)pk_div_round64(s->v[PK_GRBL_S_STEPS_X + a] * 65536, 1000000);
        cfg->max_rate[a] = u6_div(s->v[PK_GRBL_S_RATE_X + a], 1000);
        cfg->accel[a] = u6_div(s->v[PK_GRBL_S_ACCEL_X + a], 1000);
    }
    cfg->junction_dev_um = (pk_um_t)u6_div(s->v[PK_GRBL_S_JUNCTION_MM], 1000);
    /* µs (1e-6 µs units) -> ticks: v * tick_hz / 1e12, at least one tick */
    uint64_t pulse = (uint64_t)pk_div_round64(s->v[PK_GRBL_S_STEP_PULSE_US] / 1000 * (int64_t)tick_hz,
                                              1000000000);
    uint64_t setup = (uint64_t)pk_div_round64(s->v[PK_GRBL_S_DIR_SETUP_US] / 1000 * (int64_t)tick_hz,
                                              1000000000);
    cfg->step_pulse_ticks = pulse < 1 ? 1u : (uint32_t)pulse;
    cfg->dir_setup_ticks = (uint32_t)setup;
    cfg->pen_settle_ms = u6_div(s->v[PK_GRBL_S_PEN_SETTLE_MS], 1000000);
    cfg->pen_down_level = 1;
    smooth_cfg(s, 0, (pk_um_t)u6_div(s->v[PK_GRBL_S_TOLERANCE_MM], 1000), &cfg->smooth);
}

static int op_move(void *ctx, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, int rapid)
{
    pk_um_t p[PK_AXES];
    memset(p, 0, sizeof p);
    for (int a = 0; a < PK_AXES && a < PK_GC_AXES; a++)
        p[a] = t[a];
    pk_um_min_t f = rapid ? PK_UM_MIN_MAX
                    : feed < 1 ? 1u
                    : (uint32_t)feed > PK_UM_MIN_MAX ? PK_UM_MIN_MAX
                                                     : (pk_um_min_t)feed;
    return map_rc(pk_machine_move(mach(ctx), p, f, rapid ? PK_MOVE_RAPID : PK_MOVE_FEED));
}

static int op_pen(void *ctx, int down) { return map_rc(pk_machine_pen(mach(ctx), down != 0)); }

static int op_dwell(void *ctx, uint32_t ms)
{
    return map_rc(pk_machine_dwell(mach(ctx), ms > PK_DWELL_MS_MAX ? PK_DWELL_MS_MAX : ms));
}

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
    /* First time: initialise. Afterwards: reconfigure, which keeps the step
     * position and changes nothing if it refuses (not idle, out of range). */
    int rc = gm->ready ? pk_machine_configure(gm->m, &cfg) : pk_machine_init(gm->m, &cfg, gm->hal);
    if (rc != PK_MOTION_OK)
        return -1;
    gm->set = *s;
    gm->ready = 1;
    return 0;
}

/* A function rather than a const table: a table of pointers would be
 * writable (relocated) data, which the firmware never holds. */
void pk_grbl_motion_ops(struct pk_grbl_machine_ops *o)
{
    o->move = op_move;
    o->pen = op_pen;
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
}
