/*
 * pk_motion.c — the machine: request FIFO -> strokes -> planner -> step
 * generator, plus the user-facing controls (see pk_motion.h for the contract).
 *
 * The main loop does all the thinking: pk_machine_poll drains the request
 * FIFO into strokes, pulls refined points into the motion queue while it has
 * room, replans, cuts chunks and arms the timer. The timer callback only
 * replays chunks. Every stroke-ending event (rapid, pen, dwell, feed or mode
 * change, end) first finishes the open stroke and waits until the kernel has
 * delivered all of it, so the order of the program is kept exactly.
 */
#include <string.h>
#include "pk_motion.h"
#include "pk_sg_div.h"

static void run_start(struct pk_machine *m);

enum { PK_REQ_MOVE = 0, PK_REQ_PEN, PK_REQ_DWELL, PK_REQ_SMOOTH, PK_REQ_END, PK_REQ_SPINDLE };

/** Input cycles (pk_machine.cycle): probing, homing into the switches,
 *  homing's pull-off (a move exempt from the limits). */
enum { CYC_NONE = 0, CYC_PROBE = 1, CYC_HOME = 2, CYC_PULL = 3 };

#if PK_MACHINE_INQ < 2
#error "PK_MACHINE_INQ must hold a move and its end (>= 2)"
#endif

/** Work items per poll (bounds the main-loop latency). */
#define POLL_BUDGET 64u
/* Refined points one stroke pull may consume without an output point before
 * it returns, so that the chunks of final blocks are cut in between
 * (prep_final): on the AVR a refined point costs the decimator ~15,000
 * cycles, and one output point can take 30 of them. */
#define PULL_BUDGET 4u
/* Stroke points one poll plans at most: with the chunks of final blocks cut
 * in between (prep_final), the queue no longer bounds the poll, and the
 * G-code intake and realtime commands wait for it. A queue's worth, what a
 * poll could plan before: fewer (4 was tried) and a main loop polled every
 * millisecond falls behind a dense stroke where it did not, so that the
 * starvation rule of pk_machine_poll cuts a block early and the output
 * depends on the loop's timing (test_motion_steps). */
#define POLL_POINTS PK_MQ_CAP

static int check_cfg(const struct pk_motion_cfg *c, uint32_t tick_hz)
{
    unsigned axes = c->axes ? c->axes : PK_AXES;
    if (axes < 2u || axes > PK_AXES || axes > PK_HAL_MAX_AXES)
        return -1;
    for (unsigned i = 0; i < axes; i++) {
        if (c->steps_per_mm_q16[i] < PK_SPMM_Q16_MIN || c->steps_per_mm_q16[i] > PK_SPMM_Q16_MAX)
            return -1;
        if (c->max_rate[i] < 1u || c->max_rate[i] > PK_UM_MIN_MAX)
            return -1;
        if (c->accel[i] < 1u || c->accel[i] > PK_UM_S2_MAX)
            return -1;
        /* the fastest step train must leave room for a pulse and a gap:
         * 2 sps pulse > tick_hz, with sps < 2^24 steps/s (the ranges above)
         * and 2 t > T <=> t > floor(T / 2) for integers (a saturated product
         * is beyond any tick rate too) */
        uint32_t sps = pk_muldiv_u32(c->max_rate[i], c->steps_per_mm_q16[i],
                                     (uint32_t)60000u << PK_SPMM_Q16_SHIFT);
        if (pk_mulshr_u32(sps, c->step_pulse_ticks ? c->step_pulse_ticks : 1u, 0) > tick_hz / 2u)
            return -1;
    }
    if (c->junction_dev_um < 0 || c->junction_dev_um > 10000)
        return -1;
    if (c->step_pulse_ticks < 1u || c->dir_setup_ticks > tick_hz)
        return -1;
    if (c->pen_settle_ms > 60000u || c->pen_down_level > 1u || c->lookahead_wait_ms > 60000u)
        return -1;
    if ((c->input_invert & ~(uint32_t)PK_IN_ALL) != 0u)
        return -1;
    if (pk_stroke_check(&c->smooth) != 0)
        return -1;
    return 0;
}

/* Does the step position fit the µm range with these steps/mm? (Grbl keeps
 * the steps when steps/mm change; the mm position follows, and must stay a
 * position the machine can represent.) */
static bool pos_fits(const pk_steps_t pos[PK_AXES], const struct pk_motion_cfg *c)
{
    unsigned axes = c->axes ? c->axes : PK_AXES;
    for (unsigned i = 0; i < axes; i++) {
        int64_t um = ((int64_t)pos[i] * ((int64_t)1000 << PK_SPMM_Q16_SHIFT)) / c->steps_per_mm_q16[i];
        if (um > PK_UM_MAX || um < -PK_UM_MAX)
            return false;
    }
    return true;
}

/* Build the modules from m->cfg (everything but the pins and the position). */
static void setup_modules(struct pk_machine *m)
{
    const struct pk_motion_cfg *cfg = &m->cfg;
    const struct pk_hal *hal = m->hal;
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = m->cfg.axes;
    for (unsigned i = 0; i < m->cfg.axes; i++) {
        lim.max_rate[i] = cfg->max_rate[i];
        lim.accel[i] = cfg->accel[i];
    }
    lim.junction_dev_um = cfg->junction_dev_um;
    lim.accel_min = cfg->accel[0];
    for (unsigned i = 1; i < m->cfg.axes; i++)
        if (cfg->accel[i] < lim.accel_min)
            lim.accel_min = cfg->accel[i];
    pk_planner_init(&m->planner, &lim);
    pk_mq_init(&m->mq);
    pk_stroke_init(&m->stroke, &cfg->smooth, m->cfg.axes);
    struct pk_planner_dyn dyn;
    pk_planner_dyn(&lim, &dyn);
    pk_stroke_set_dyn(&m->stroke, &dyn);
    pk_stroke_set_pull_budget(&m->stroke, PULL_BUDGET);
    m->stroke.observe = m->observe;
    m->stroke.observe_ctx = m->observe_ctx;
    pk_sg_init(&m->sg, m->cfg.axes, hal->tick_hz, cfg->step_pulse_ticks, cfg->dir_setup_ticks);
}

/* ----------------------------------------------------------- inputs */

/* The watches the step path applies: hard limits (except during homing),
 * and the cycle's own. */
static uint8_t watch_bits(const struct pk_machine *m, uint8_t cycle)
{
    uint8_t w = (m->hard_limits && cycle != CYC_HOME && cycle != CYC_PULL) ? PK_SGW_LIMITS : 0u;
    if (cycle == CYC_PROBE)
        w |= PK_SGW_PROBE;
    if (cycle == CYC_HOME)
        w |= PK_SGW_HOME;
    return w;
}

/* The HAL's edge callback: new raw levels (edge context, never concurrent
 * with the step timer callback: hal.h). */
static void input_edge(void *arg, uint32_t raw, uint64_t tick)
{
    struct pk_machine *m = arg;
    (void)tick;
    pk_sg_inputs(&m->sg, pk_hal_input_logical(m->hal, raw) ^ m->sg.in_flip, 0);
}

/* Read the inputs from MAIN and apply them (edge semantics). */
static int inputs_refresh(struct pk_machine *m)
{
    uint32_t lv;
    uint32_t tok = pk_hal_irq_save(m->hal);
    int r = pk_hal_input_read(m->hal, &lv);
    if (r == PK_HAL_OK)
        pk_sg_inputs(&m->sg, lv ^ m->sg.in_flip, 0);
    pk_hal_irq_restore(m->hal, tok);
    return r;
}

/* The step generator's input settings from cfg and the machine (after
 * pk_sg_init). */
static void inputs_setup(struct pk_machine *m)
{
    m->sg.in_flip = (uint16_t)(m->cfg.input_invert & m->hal->inputs);
    m->sg.poll_in = m->in_poll ? 1u : 0u;
    m->sg.watch = watch_bits(m, m->cycle);
}

int pk_machine_init(struct pk_machine *m, const struct pk_motion_cfg *cfg,
                    const struct pk_hal *hal)
{
    if (m == NULL || cfg == NULL)
        return PK_MOTION_EINVAL;
    if (pk_hal_check(hal) != PK_HAL_OK)
        return PK_MOTION_EHAL;
    if (hal->tick_hz > ((uint32_t)1 << 24) || check_cfg(cfg, hal->tick_hz) != 0)
        return PK_MOTION_EINVAL;
    memset(m, 0, sizeof *m);
    m->cfg = *cfg;
    if (m->cfg.axes == 0)
        m->cfg.axes = PK_AXES;
    m->hal = hal;
    m->ovr_feed_pct = 100u;
    m->ovr_rapid_pct = 100u;
    m->acc_policy = m->policy_applied = cfg->smooth;
    setup_modules(m);
    uint32_t all = (1u << m->cfg.axes) - 1u;
    if (pk_hal_step_write(hal, all, 0u) != 0 || pk_hal_dir_write(hal, all, 0u) != 0)
        return PK_MOTION_EHAL;
    int r = pk_hal_enable_write(hal, all, all);
    if (r != 0 && r != PK_HAL_ENOSYS)
        return PK_MOTION_EHAL;
    r = pk_hal_tool_write(hal, cfg->pen_down_level ^ 1u);
    if (r != 0 && r != PK_HAL_ENOSYS)
        return PK_MOTION_EHAL;
    if (hal->inputs != 0u) {
        inputs_setup(m);
        r = pk_hal_input_watch(hal, input_edge, m);
        if (r == PK_HAL_ENOSYS)
            m->in_poll = true;
        else if (r != 0)
            return PK_MOTION_EHAL;
        inputs_setup(m);
        if (inputs_refresh(m) != PK_HAL_OK)
            return PK_MOTION_EHAL;
        m->sg.in_rise = 0;
    }
    run_start(m); /* the run starts where the machine stands (finding M4) */
    return PK_MOTION_OK;
}

int pk_machine_configure(struct pk_machine *m, const struct pk_motion_cfg *cfg)
{
    if (cfg == NULL || check_cfg(cfg, m->hal->tick_hz) != 0)
        return PK_MOTION_EINVAL;
    enum pk_machine_state st = pk_machine_state(m);
    if ((st != PK_STATE_IDLE && st != PK_STATE_ALARM) || m->cycle != CYC_NONE)
        return PK_MOTION_EBUSY;
    if (st == PK_STATE_ALARM && (m->sg.busy || pk_sg_pending(&m->sg) > 0 || pk_mq_count(&m->mq) > 0
                                 || m->inq_count > 0 || pk_stroke_is_open(&m->stroke)))
        return PK_MOTION_EBUSY;
    pk_steps_t pos[PK_AXES];
    memcpy(pos, m->sg.pos, sizeof pos);
    if (!pos_fits(pos, cfg))
        return PK_MOTION_ERANGE;
    uint8_t dir = m->sg.dir_cur, alarm = m->sg.alarm;
    uint32_t lines = m->lines_planned;
    /* the edge callback writes the input state the re-init clears */
    uint32_t tok = pk_hal_irq_save(m->hal);
    uint8_t fired = m->sg.fired;
    uint16_t in_now = m->sg.in_now, in_rise = m->sg.in_rise;
    m->cfg = *cfg;
    if (m->cfg.axes == 0)
        m->cfg.axes = PK_AXES;
    setup_modules(m);
    m->sg.fired = fired;
    m->sg.in_now = in_now;
    m->sg.in_rise = in_rise;
    inputs_setup(m);
    pk_hal_irq_restore(m->hal, tok);
    for (unsigned i = 0; i < PK_AXES; i++) {
        m->sg.pos[i] = i < m->cfg.axes ? pos[i] : 0;
        m->target_steps[i] = m->sg.pos[i];
        m->target_um[i] = i < m->cfg.axes ? pk_steps_to_um(m->sg.pos[i], cfg->steps_per_mm_q16[i]) : 0;
        m->timed_um[i] = m->target_um[i];
    }
    m->sg.dir_cur = dir;
    m->sg.alarm = alarm;
    m->lines_planned = lines;
    pk_planner_set_override(&m->planner, m->ovr_feed_pct, m->ovr_rapid_pct);
    run_start(m);
    m->acc_policy = m->policy_applied = cfg->smooth;
    return PK_MOTION_OK;
}

/* ----------------------------------------------------------- requests */

static bool alarmed(const struct pk_machine *m)
{
    return (m->sg.alarm) != 0 || (m->sg.fired & PK_SGW_LIMITS) != 0u;
}

static struct pk_req *req_slot(struct pk_machine *m)
{
    if (m->inq_count >= PK_MACHINE_INQ || m->cycle != CYC_NONE)
        return NULL;
    struct pk_req *r = &m->inq[(m->inq_head + m->inq_count) % PK_MACHINE_INQ];
    memset(r, 0, sizeof *r);
    return r;
}

static int req_commit(struct pk_machine *m)
{
    m->inq_count++;
    return PK_MOTION_OK;
}

uint32_t pk_machine_room(const struct pk_machine *m)
{
    return alarmed(m) || m->cycle != CYC_NONE ? 0u : (uint32_t)PK_MACHINE_INQ - m->inq_count;
}

/* Does the smoothing policy requested last (the one later moves will get)
 * use a scheme that can leave the hull of its control points? Only DLG, and
 * only a build with DLG's window can run it (pk_stroke_check refuses it
 * otherwise). */
static bool policy_overshoots(const struct pk_smooth_cfg *s)
{
#if PK_MOTION_DLG
    return s->mode == PK_SMOOTH_FIXED && s->scheme == PK_SCHEME_DLG && s->depth > 0u;
#else
    (void)s;
    return false;
#endif
}

/* The box [lo, hi] the smoothed path of the current run (the feed moves since
 * the last other request) stays in once target joins it. Only DLG leaves the
 * hull of its control points: each level moves a new point by at most
 * (|D2[i]| + |D2[i+1]|)/16 off the edge midpoint, and the level's second
 * differences are at most half the previous ones (old points: (6D2[i] -
 * D2[i-1] - D2[i+1])/16, new ones: (D2[i] + D2[i+1])/8), so the whole path
 * stays within max|D2|/8 * (1 + 1/2 + 1/4 + ...) = max|D2|/4 of the control
 * polygon, per axis. B-splines stay in the hull. Returns the run box grown by
 * that bound (+1 µm for the kernel's rounding). All in 32 bits: coordinates
 * within ±PK_UM_MAX, so |D2| <= 4 PK_UM_MAX < 2^23 and the box within
 * ±(PK_UM_MAX + 2^21 + 1). */
static void run_box(const struct pk_machine *m, const pk_um_t t[PK_AXES], bool dlg,
                    int32_t lo[PK_AXES], int32_t hi[PK_AXES])
{
    for (unsigned i = 0; i < m->cfg.axes; i++) {
        int32_t a = t[i], b = t[i];
        if (m->acc_n > 0) {
            if (m->acc_lo[i] < a) a = m->acc_lo[i];
            if (m->acc_hi[i] > b) b = m->acc_hi[i];
        }
        int32_t g = 0;
#if PK_MOTION_DLG
        if (dlg) {
            uint32_t d2 = m->acc_n > 0 ? m->acc_d2[i] : 0u;
            if (m->acc_n >= 2) {
                int32_t d = t[i] - 2 * m->acc_last[i] + m->acc_prev[i];
                uint32_t ad = (uint32_t)(d < 0 ? -d : d);
                if (ad > d2) d2 = ad;
            }
            g = (int32_t)((d2 + 3u) / 4u) + 1;
        }
#else
        (void)dlg;
#endif
        lo[i] = a - g;
        hi[i] = b + g;
    }
}

static void run_add(struct pk_machine *m, const pk_um_t t[PK_AXES], bool feed)
{
    if (!feed) {
        /* a rapid starts a new run at its target */
        m->acc_n = 1;
        memcpy(m->acc_last, t, sizeof m->acc_last);
        memcpy(m->acc_lo, t, sizeof m->acc_lo);
        memcpy(m->acc_hi, t, sizeof m->acc_hi);
#if PK_MOTION_DLG
        memset(m->acc_d2, 0, sizeof m->acc_d2);
#endif
        return;
    }
    for (unsigned i = 0; i < m->cfg.axes; i++) {
        if (m->acc_n == 0) {
            m->acc_lo[i] = m->acc_hi[i] = t[i];
#if PK_MOTION_DLG
            m->acc_d2[i] = 0;
#endif
            continue;
        }
        if (t[i] < m->acc_lo[i]) m->acc_lo[i] = t[i];
        if (t[i] > m->acc_hi[i]) m->acc_hi[i] = t[i];
#if PK_MOTION_DLG
        if (m->acc_n >= 2) {
            int32_t d = t[i] - 2 * m->acc_last[i] + m->acc_prev[i]; /* |.| < 2^23 */
            uint32_t ad = (uint32_t)(d < 0 ? -d : d);
            if (ad > m->acc_d2[i]) m->acc_d2[i] = ad;
        }
#endif
    }
#if PK_MOTION_DLG
    memcpy(m->acc_prev, m->acc_last, sizeof m->acc_prev);
#endif
    memcpy(m->acc_last, t, sizeof m->acc_last);
    if (m->acc_n < 2)
        m->acc_n++;
}

/* A new run starts at the planned position (init, configure, reset, set
 * position): its first control point is where the machine stands, so the
 * envelope of a first feed move covers what DLG makes of it (finding M4:
 * DLG's first new point lay outside the box of the targets alone). */
/* Z's index (a 2-axis build has none: then unused, and in range) */
#define Z_AX (PK_AXES > 2 ? 2 : 0)

static void run_start(struct pk_machine *m)
{
    run_add(m, m->target_um, false);
    m->req_z_um = m->target_um[Z_AX];
}

/* A request other than a move ends the run (the stroke ends there). */
static void run_break(struct pk_machine *m)
{
    if (m->acc_n > 0)
        run_add(m, m->acc_last, false);
}

static int move_req(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed,
                    enum pk_move_kind kind, pk_um_t chord_err_um)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if (kind != PK_MOVE_FEED && kind != PK_MOVE_RAPID)
        return PK_MOTION_ERANGE;
    if (kind == PK_MOVE_FEED && (feed < PK_UM_MIN_MIN || feed > PK_UM_MIN_MAX))
        return PK_MOTION_ERANGE;
    for (unsigned i = 0; i < m->cfg.axes; i++)
        if (target[i] > PK_UM_MAX || target[i] < -PK_UM_MAX)
            return PK_MOTION_ERANGE;
    /* full: say so before the envelope below (a sender retries a refused
     * move on every poll until there is room) */
    if (m->inq_count >= PK_MACHINE_INQ)
        return PK_MOTION_EFULL;
    {
        int32_t lo[PK_AXES], hi[PK_AXES];
        bool dlg = kind == PK_MOVE_FEED && policy_overshoots(&m->acc_policy);
        if (kind == PK_MOVE_FEED) {
            run_box(m, target, dlg, lo, hi);
        } else {
            for (unsigned i = 0; i < m->cfg.axes; i++)
                lo[i] = hi[i] = target[i];
        }
        for (unsigned i = 0; i < m->cfg.axes; i++) {
            if (lo[i] < -PK_UM_MAX || hi[i] > PK_UM_MAX)
                return PK_MOTION_ERANGE;
            if (m->soft_on && (lo[i] < m->soft_lo[i] || hi[i] > m->soft_hi[i]))
                return PK_MOTION_ETRAVEL;
        }
    }
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    run_add(m, target, kind == PK_MOVE_FEED);
    r->type = PK_REQ_MOVE;
    r->kind = (uint8_t)kind;
    for (unsigned i = 0; i < PK_AXES; i++)
        r->p[i] = i < m->cfg.axes ? target[i] : 0;
    r->arg = kind == PK_MOVE_FEED ? feed : 0u;
    r->chord_err_um = chord_err_um;
    return req_commit(m);
}

int pk_machine_move(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed,
                    enum pk_move_kind kind)
{
    return move_req(m, target, feed, kind, 0);
}

int pk_machine_move_chord(struct pk_machine *m, const pk_um_t target[PK_AXES],
                          pk_um_min_t feed, pk_um_t chord_err_um)
{
    if (chord_err_um < 0 || chord_err_um > 10000)
        return alarmed(m) ? PK_MOTION_EALARM : PK_MOTION_ERANGE;
    return move_req(m, target, feed, PK_MOVE_FEED, chord_err_um);
}

int pk_machine_pen(struct pk_machine *m, bool down)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_PEN;
    run_break(m);
    r->kind = (uint8_t)(down ? m->cfg.pen_down_level : (m->cfg.pen_down_level ^ 1u));
    r->arg = m->cfg.pen_settle_ms;
    return req_commit(m);
}

int pk_machine_dwell(struct pk_machine *m, uint32_t ms)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if (ms > PK_DWELL_MS_MAX)
        return PK_MOTION_ERANGE;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_DWELL;
    run_break(m);
    r->arg = ms;
    return req_commit(m);
}

int pk_machine_set_smoothing(struct pk_machine *m, const struct pk_smooth_cfg *s)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if (pk_stroke_check(s) != 0)
        return PK_MOTION_EINVAL;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_SMOOTH;
    m->acc_policy = *s;
    run_break(m);
    r->smooth = *s;
    return req_commit(m);
}

int pk_machine_end(struct pk_machine *m)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_END;
    run_break(m);
    return req_commit(m);
}

int pk_machine_spindle(struct pk_machine *m, uint16_t value_q16, bool sync)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_SPINDLE;
    r->kind = sync ? 1u : 0u;
    r->arg = value_q16;
    run_break(m);
    return req_commit(m);
}

int pk_machine_set_override(struct pk_machine *m, uint16_t feed_pct, uint16_t rapid_pct)
{
    if (feed_pct < 10u || feed_pct > 200u || rapid_pct < 1u || rapid_pct > 100u)
        return PK_MOTION_ERANGE;
    m->ovr_feed_pct = feed_pct;
    m->ovr_rapid_pct = rapid_pct;
    pk_planner_set_override(&m->planner, feed_pct, rapid_pct);
    m->replan = true;
    m->plan_fresh = false; /* the nominal speeds change at the next replan */
    return PK_MOTION_OK;
}

int pk_machine_set_soft_limits(struct pk_machine *m, bool on, const pk_um_t lo[PK_AXES],
                               const pk_um_t hi[PK_AXES])
{
    if (on) {
        if (lo == NULL || hi == NULL)
            return PK_MOTION_ERANGE;
        for (unsigned i = 0; i < m->cfg.axes; i++)
            if (lo[i] > hi[i] || lo[i] < -PK_UM_MAX || hi[i] > PK_UM_MAX)
                return PK_MOTION_ERANGE;
        memcpy(m->soft_lo, lo, sizeof m->soft_lo);
        memcpy(m->soft_hi, hi, sizeof m->soft_hi);
    }
    m->soft_on = on;
    return PK_MOTION_OK;
}

/* ----------------------------------------------------------- main loop */

static void req_pop(struct pk_machine *m)
{
    m->inq_head = (uint8_t)((m->inq_head + 1u) % PK_MACHINE_INQ);
    m->inq_count--;
}

static struct pk_req *req_at(struct pk_machine *m, uint32_t i)
{
    return &m->inq[(m->inq_head + i) % PK_MACHINE_INQ];
}

/* ----------------------------------------------------------- planning */

/* PK_MOTION_SOFT_DIV=1 (by default on an 8-bit core that is not
 * flash-first: PK_SOFT_DIV, pk_munits.h): steps_to_um_q8 divides in 32-bit
 * words (pk_sg_div32_soft) instead of libgcc's 64-bit division, the same
 * results (tests/test_motion_divs.c sets it on the host). (um_conv's division
 * by 256000 so, as (a >> 11) / 125 in two words, cost more: ~1,200 cycles.) */
#ifndef PK_MOTION_SOFT_DIV
#define PK_MOTION_SOFT_DIV (PK_SOFT_DIV && !PK_FLASH_FIRST)
#endif
#if PK_MOTION_SOFT_DIV
/* floor((hi 2^32 + lo) / d), hi < d <= 2^31: pk_sg_div32_soft out of line
 * (inlined into plan_piece's large frame its loop ran from the stack, ~50
 * AVR cycles a bit against ~25). */
#if defined(__GNUC__) || defined(__clang__)
__attribute__((noinline))
#endif
static uint32_t motion_div32(uint32_t hi, uint32_t lo, uint32_t d) { return pk_sg_div32_soft(hi, lo, d); }
#endif

/* A coordinate's whole steps (pk_um_to_steps) and its ideal position in
 * steps Q8 (um * spmm_q16 / (1000 * 65536) * 256, rounded as
 * pk_div_round64 rounds) from ONE 64-bit division: on an 8-bit core each is
 * a libgcc call of ~1,000 cycles, and plan_piece needed four per moving
 * axis. Both round X = um spmm (|X| < 2^21 * 2^30 = 2^51) to nearest with
 * ties away from zero, so both are odd and X >= 0 suffices: with X + 128000
 * = 256000 q + r (0 <= r < 256000) the steps Q8 are q (< 2^34), and X +
 * 32768000 = 256000 (q + 127) + (r + 128000), so pk_um_to_steps =
 * floor((X + 32768000) / 65536000) = floor((q + 127 + [r >= 128000]) / 256)
 * (the rest, below 256000, never carries past a multiple of 256; < 2^26 in
 * magnitude). Checked against both on their range by
 * tests/test_motion_divs.c. */
static void um_conv(pk_um_t um, pk_spmm_q16_t spmm, struct pk_axconv *c)
{
    c->um = um;
    c->spmm = spmm;
#if PK_FLASH_FIRST /* (the two divisions: ~200 B less AVR code) */
    c->st = pk_um_to_steps(um, spmm);
    c->q8 = pk_div_round64((int64_t)um * (int64_t)spmm, 256000);
#else
    const uint32_t au = um < 0 ? 0u - (uint32_t)um : (uint32_t)um;
    const uint64_t a = (uint64_t)au * spmm + 128000u;
    const uint64_t q = a / 256000u;
    const uint32_t r = (uint32_t)a - (uint32_t)q * 256000u; /* (mod 2^32: r < 2^18) */
    const int32_t s = (int32_t)((q + 127u + (r >= 128000u)) >> 8);
    c->st = um < 0 ? -s : s;
    c->q8 = um < 0 ? -(int64_t)q : (int64_t)q;
#endif
}

/* um_conv of axis i's coordinate um, kept in m->conv: plan_piece converts
 * each block's start (the last block's end) and a still axis's end (its
 * start) again. */
static const struct pk_axconv *axis_conv(struct pk_machine *m, unsigned i, pk_um_t um)
{
    struct pk_axconv *c = &m->conv[i];
    const pk_spmm_q16_t spmm = m->cfg.steps_per_mm_q16[i];
    if (c->um != um || c->spmm != spmm)
        um_conv(um, spmm, c);
    return c;
}

/* The displacement of n steps in µm Q8: n * 1000 * 256 * 65536 / spmm,
 * rounded: the steps of a displacement within 2 PK_UM_MAX, so < 2^31. */
static int32_t steps_to_um_q8(pk_steps_t n, pk_spmm_q16_t spmm)
{
#if PK_MOTION_SOFT_DIV
    /* On an 8-bit core in 32-bit words (the 64-bit product and division
     * were ~900 AVR cycles a call): |n| <= PK_PLANNER_MAX_STEPS = 2^21, so
     * m = |n| 1000 < 2^32 and the dividend |n| 256000 2^16 = m 2^24 is
     * (m >> 8) 2^32 + (m << 24); plus floor(spmm / 2) (a carry into the high
     * word); spmm <= PK_SPMM_Q16_MAX < 2^31 and the quotient, a displacement
     * within 2 PK_UM_MAX in µm Q8 (above), is below 2^31, so
     * pk_sg_div32_soft gives the plain floor: the same rounding as
     * pk_div_round64, ties away from zero. */
    const uint32_t m = (n < 0 ? 0u - (uint32_t)n : (uint32_t)n) * 1000u;
    const uint32_t half = spmm / 2u;
    uint32_t hi = m >> 8, lo = m << 24;
    lo += half;
    if (lo < half)
        hi++;
    const int32_t q = (int32_t)motion_div32(hi, lo, spmm);
    return n < 0 ? -q : q;
#else
    return (int32_t)pk_div_round64((int64_t)n * ((int64_t)256000 << PK_SPMM_Q16_SHIFT), (int64_t)spmm);
#endif
}

/*
 * Plan the straight move from the planned position (target_um, exactly; its
 * whole steps target_steps) towards p, at most PK_PLANNER_MAX_STEPS steps of
 * it per block. Returns 1 when p is reached, 0 when a piece was planned and
 * more remain, -1 when the queue is full (nothing changed).
 *
 * In steps: each axis goes to round(p * steps/mm) (the position contract);
 * the block's length is that of its steps (pk_planner.h). A move with no
 * whole step adds no block and leaves target_steps as they are while the
 * exact position moves on (its steps are taken by a later block, whose time
 * covers them).
 *
 * Within a block the Bresenham starts from the EXACT position: with f the
 * fraction of a step the exact start lies off its whole step (|f| <= 1/2, in
 * the direction of motion) and D the exact displacement in steps, an axis is
 * at round(f + j D / M) after event j of M: within half a step of the
 * programmed segment at every event (plain Bresenham between rounded ends is
 * off by up to a whole step). The accumulator counts in 1/(256 M) steps:
 * start (256 f - 128) M, + 256 D per event, a step (and - 256 M) on reaching
 * 0. An axis that makes M steps moves by less than 1 + 1/M per event, every
 * other axis by less than 1, so one step per event always suffices; the start
 * is nudged within [256 n - 256 D - 128, 256 n - 256 D + 127] so that the
 * count is exactly the n steps the block owes (ties of the rounding).
 */
/* The whole steps st of p (and its steps Q8, q8), the steps n from the
 * planned position, and the largest |n|. */
static uint32_t piece_steps(struct pk_machine *m, const pk_um_t p[PK_AXES], pk_steps_t st[PK_AXES],
                            int64_t q8[PK_AXES], pk_steps_t n[PK_AXES])
{
    uint32_t mx = 0;
    for (unsigned i = 0; i < m->cfg.axes; i++) {
        const struct pk_axconv *c = axis_conv(m, i, p[i]);
        st[i] = c->st;
        q8[i] = c->q8;
        n[i] = st[i] - m->target_steps[i];
        uint32_t an = (uint32_t)(n[i] < 0 ? -n[i] : n[i]);
        if (an > mx)
            mx = an;
    }
    return mx;
}

static int plan_piece(struct pk_machine *m, const pk_um_t p_in[PK_AXES], pk_um_min_t feed)
{
    const unsigned axes = m->cfg.axes;
    pk_um_t p[PK_AXES];
    memcpy(p, p_in, sizeof p);
    pk_steps_t st[PK_AXES] = { 0 }, n[PK_AXES] = { 0 };
    /* the start's steps Q8 first: piece_steps keeps p's in m->conv */
    int64_t q8a[PK_AXES] = { 0 }, q8b[PK_AXES] = { 0 };
    for (unsigned i = 0; i < axes; i++)
        q8a[i] = axis_conv(m, i, m->target_um[i])->q8;
    uint32_t mx = piece_steps(m, p, st, q8b, n);
    int done = 1;
    if (mx > PK_PLANNER_MAX_STEPS) {
        /* a piece along the way (the rest follows in later blocks) */
        uint32_t k = (mx + PK_PLANNER_MAX_STEPS - 1u) / PK_PLANNER_MAX_STEPS;
        for (unsigned i = 0; i < axes; i++)
            p[i] = m->target_um[i] + (p_in[i] - m->target_um[i]) / (int32_t)k; /* |.| < 2^23 */
        done = 0;
        mx = piece_steps(m, p, st, q8b, n);
    }
    if (mx == 0) {
        memcpy(m->target_um, p, sizeof m->target_um);
        if (done && m->line_sharp)
            m->junction_sharp = true;  /* the corner moved to where the next block starts */
        return done;
    }
    int32_t d_q8[PK_AXES] = { 0 };
    for (unsigned i = 0; i < axes; i++) /* (no step, no way: skip the division) */
        d_q8[i] = n[i] == 0 ? 0 : steps_to_um_q8(n[i], m->cfg.steps_per_mm_q16[i]);
    int32_t d_um[PK_AXES] = { 0 };
    /* Moves with no whole step since the last block (target_um moved on
     * from timed_um) took no time, so a step right after one came as early
     * as its exact crossing while the time for the way there was never
     * given (finding M6: one interval at 1.2 times the axis's bound). Their
     * way is now the block's lead: the first lead_q8 of its length, run at
     * its speed with no event (none of them crosses a half step). The steps
     * follow the exact path from target_um after it, and the axes' limits
     * hold for that part (d_um, over its exact length: pk_planner.h). */
    uint32_t lead_q8 = 0;
    {
        uint64_t ss = 0;
        for (unsigned i = 0; i < axes; i++) {
            d_um[i] = p[i] - m->target_um[i];
            /* |skip| < 2^23 µm: squares < 2^46, in µm Q4 (times 2^8) < 2^54,
             * three of them < 2^56. The µm squares summed (a 32x32 product,
             * none for an axis with no skip, as nearly always: a 64x64 one
             * was ~400 AVR cycles an axis a block), then scaled once. */
            const int32_t sk = m->target_um[i] - m->timed_um[i];
            if (sk != 0) {
                const uint32_t a = sk < 0 ? 0u - (uint32_t)sk : (uint32_t)sk;
                ss += (uint64_t)a * a;
            }
        }
        if (ss != 0)
            lead_q8 = pk_isqrt64(ss << 8) << 4; /* (< 2^27 µm Q4 -> < 2^31 Q8) */
    }
    /* (a turn's acceleration share goes to this new block only, never to one
     * already queued, whose exit may be committed: findings M7, M8,
     * pk_planner.c) */
    uint8_t flags = m->junction_sharp ? PK_PLAN_SHARP : 0u;
    int r = pk_planner_add_line(&m->planner, &m->mq, d_q8, n, d_um, lead_q8, feed, flags);
    if (r < 0)
        return -1;
    struct pk_block *b = pk_mq_at(&m->mq, pk_mq_count(&m->mq) - 1u);
    b->spindle = m->spindle_q16;
    /* Each axis's exact start fraction f and distance d, 1/256 steps along
     * its direction. qa, qb: up to 2^21 µm * 10,000 steps/mm * 256 > 2^32,
     * but target_steps = round(qa / 256) (the position contract), so |f| <=
     * 128, and qb - 256 ts = 256 n + (qb - 256 st) is below 2^30 in
     * magnitude: 32 bits. */
    int32_t f_ax[PK_AXES] = { 0 }, d_ax[PK_AXES] = { 0 };
    uint32_t fine = 0; /* events the axes need: 2 per exact step (below) */
    for (unsigned i = 0; i < axes; i++) {
        if (n[i] == 0)
            continue;
        int32_t sgn = n[i] > 0 ? 1 : -1;
        /* relative to the whole step ts: in 32 bits for a ts within 2^22 steps
         * (the block's start, |n| <= PK_PLANNER_MAX_STEPS) */
        const int64_t ts256 = 256 * (int64_t)m->target_steps[i];
        const int32_t fa = (int32_t)(q8a[i] - ts256);
        const int32_t fb = (int32_t)(q8b[i] - ts256);
        f_ax[i] = fa * sgn;
        d_ax[i] = (fb - fa) * sgn;
        if (d_ax[i] < 0)
            d_ax[i] = 0;
        /* Every axis steps at the first event after its exact position
         * crosses a half step: up to one event late. Across a block boundary
         * the next block does not know, and steps on time, so one interval
         * of that axis can be an event short (finding M6: an axis stepped
         * at the end of a slow one-event block, then early in the next
         * block as its minor axis: 2.7 ms apart, its exact crossings 9.3 ms;
         * blocks of a few slow events ran axes at up to 6.6 times their
         * rate over one interval). With at least 2 events per exact step of
         * every axis the lag is at most half the axis's own interval, so one
         * interval is at least half of what the exact motion gives it, which
         * the planner keeps at or above 1 / max rate (pk_planner.h d_um):
         * over any 2 steps at most twice the rate (Grbl's AMASS idea: it
         * oversamples the Bresenham for the same reason). */
        uint32_t need = 2u * (((uint32_t)d_ax[i] + 255u) >> 8); /* 2 ceil(D) */
        if (need > fine)
            fine = need;
    }
    uint32_t ev = mx;
    if (fine > mx && pk_sg_fine_ok(mx, b->len_q8, b->v_req ? (b->v_req < b->v_lim ? b->v_req : b->v_lim) : b->v_lim))
        ev = fine > PK_SG_EVENTS_MAX ? PK_SG_EVENTS_MAX : fine; /* (>= mx: mx <= 2^21) */
    b->events = ev;
    for (unsigned i = 0; i < axes; i++) {
        if (n[i] == 0) {
            b->inc[i] = 0;
            b->acc0[i] = -1;
            continue;
        }
        /* (|d| <= 256 (|n| + 1) <= 2^30; f is clamped to [-384, 383] (d >=
         * 256 (|n| - 1)), so |(f - 128) * ev| <= 512 (2^22 - 1) < 2^31) */
        int32_t an = n[i] > 0 ? n[i] : -n[i];
        int32_t f = f_ax[i], d = d_ax[i];
        /* at most one step per event: an axis whose Q8 distance exceeds the
         * events (its ends rounded apart, e.g. -5.5 -> 269.5 steps for 274
         * whole ones) steps at every event; with inc > period its first
         * event could miss and the block would end a step short (M5) */
        if (d > (int32_t)(256u * ev))
            d = (int32_t)(256u * ev);
        int32_t lo = 256 * an - d - 128, hi = 256 * an - d + 127;
        f = f < lo ? lo : f > hi ? hi : f;
        b->inc[i] = (uint32_t)d;
        b->acc0[i] = (f - 128) * (int32_t)ev;
    }
    m->lines_planned++;
    m->replan = true;
    m->junction_sharp = done ? m->line_sharp : false; /* between pieces: straight on */
    memcpy(m->target_um, p, sizeof m->target_um);
    memcpy(m->timed_um, p, sizeof m->timed_um);
    memcpy(m->target_steps, st, sizeof m->target_steps);
    return done;
}

/* Plan the pending line (line_p) as far as the queue has room.
 * Returns true when nothing is pending any more. */
static bool flush_line(struct pk_machine *m)
{
    while (m->line_pending) {
        int r = plan_piece(m, m->line_p, m->line_feed);
        if (r < 0)
            return false;
        if (r > 0)
            m->line_pending = false;
    }
    return true;
}

/* Plan a straight move to p; sharp: p is a corner (the junction after it is
 * a programmed corner, not a vertex of a smoothed curve). */
static bool plan_line(struct pk_machine *m, const pk_um_t p[PK_AXES], pk_um_min_t feed, bool sharp)
{
    memcpy(m->line_p, p, sizeof m->line_p);
    m->line_feed = feed;
    m->line_sharp = sharp;
    m->line_pending = true;
    return flush_line(m);
}

/* Recompute the plan (pk_planner_replan: a function of the queue and of where
 * the step generator is, nothing else). */
static void replan_now(struct pk_machine *m)
{
    pk_v2_q4_t v2;
    uint32_t rem;
    pk_sg_plan_state(&m->sg, &m->mq, &v2, &rem);
    pk_planner_replan(&m->planner, &m->mq, v2, rem, m->flush);
    m->replan = false;
    m->plan_fresh = true;
}

/* Chunks wait and the step path is idle (not started, or the ring ran dry):
 * start the step timer. */
static void start_steps(struct pk_machine *m)
{
    if (pk_sg_pending(&m->sg) > 0 && !(m->sg.busy)) {
        m->sg.restart = true;
        m->sg.busy = true;
        uint64_t now = m->hal->ops->clock_ticks(m->hal->ctx);
        int r = m->hal->ops->timer_start
                    ? m->hal->ops->timer_start(m->hal->ctx, pk_machine_timer_cb, m, now + 1u)
                    : PK_HAL_ENOSYS;
        if (r != 0) {
            m->sg.busy = false;
            m->sg.alarm = PK_ALARM_TIMER;
        }
    }
}

/* Cut chunks from the blocks with a final plan while the ring has room,
 * between the pieces of work of one poll: smoothing and planning a stroke
 * can take longer than the ring lasts on an 8-bit core (tens of ms). When no
 * final block is left, or the plan is stale, it replans first (as the end of
 * the poll would: the plan is a function of the queue, so the blocks it makes
 * final, and their chunks, are those a later replan would give; appending
 * blocks changes no final plan, pk_planner.h). The rules that let more than
 * the final blocks run (a full queue, a hold, starvation) stay with the end
 * of the poll. */
static void prep_final(struct pk_machine *m)
{
    if (m->hold_req || m->cycle_stop || m->sg.alarm != 0u || PK_SG_CHUNKS - pk_sg_pending(&m->sg) < 3u)
        return; /* (an alarm latched by the step path is the end of the poll's business) */
    if (pk_planner_final(&m->planner) == 0u || !m->plan_fresh) {
        if (!m->replan)
            return;
        replan_now(m);
    }
    uint32_t fin = pk_planner_final(&m->planner);
    if (fin == 0u)
        return;
    uint32_t count = pk_mq_count(&m->mq);
    (void)pk_sg_prep(&m->sg, &m->mq, fin);
    uint32_t popped = count - pk_mq_count(&m->mq);
    m->planner.n_final = (uint8_t)(fin > popped ? fin - popped : 0u);
    start_steps(m); /* (had the ring run dry, the rest of the poll would keep it stopped) */
}

/* The caller has urgent work (pk_machine_set_yield): end this poll's
 * stroke work (as if POLL_POINTS had been planned). */
static bool yield_now(struct pk_machine *m)
{
    if (m->yield != NULL && m->yield(m->yield_ctx)) {
        m->poll_points = POLL_POINTS;
        return true;
    }
    return false;
}

void pk_machine_set_yield(struct pk_machine *m, pk_machine_yield_fn fn, void *ctx)
{
    m->yield = fn;
    m->yield_ctx = ctx;
}

/** Pull the open stroke into the motion queue while it has room.
 *  Returns false on a kernel error (alarm latched). */
static bool drain_stroke(struct pk_machine *m)
{
    /* (at most POLL_POINTS points a poll, fewer when the caller has urgent
     * work: pk_machine_set_yield; at least one piece of work, so that a
     * caller whose flag stays set still sees the machine go on) */
    while (flush_line(m) && pk_stroke_is_open(&m->stroke) && pk_mq_room(&m->mq) > 0
           && m->poll_points < POLL_POINTS) {
        pk_um_t p[PK_AXES];
        int r = pk_stroke_pull(&m->stroke, p);
        if (r == PK_OK) {
            m->poll_points++;
            (void)plan_line(m, p, m->stroke_feed, m->stroke.out_sharp);
        } else if (r != PK_STROKE_YIELD) {
            if (r < 0) {
                m->sg.alarm = PK_ALARM_INTERNAL;
                return false;
            }
            break;
        }
        /* (a point planned, or a pull budget spent without one) */
        prep_final(m);
        if (yield_now(m))
            break;
    }
    return true;
}

/* A request arrived: the stream is alive, the look-ahead waits for it. */
static void input_seen(struct pk_machine *m)
{
    m->flush = false;
    m->wait_since = 0;
}

static void take_requests(struct pk_machine *m)
{
    for (uint32_t it = 0; it < POLL_BUDGET; it++) {
        if (!drain_stroke(m))
            return;
        if (m->inq_count == 0 || m->poll_points >= POLL_POINTS)
            return; /* (POLL_POINTS stroke points planned: the rest next poll) */
        if (m->line_pending)
            return;
        struct pk_req *r = req_at(m, 0);
        input_seen(m);
        bool open = pk_stroke_is_open(&m->stroke);
        /* A feed move that changes Z goes to the planner as it is, like a
         * G61 move: the decimator keeps every refined point of a chord out
         * of the XY plane, so a smoothed helix or a ramp of CAM output became
         * thousands of micro-blocks whose look-ahead held the speed down
         * (3.3x slower than exact on a thread-milling helix). */
        bool z_move = r->type == PK_REQ_MOVE && r->kind == PK_MOVE_FEED && m->cfg.axes > 2u
                      && m->stroke.mode != PK_SMOOTH_OFF && r->p[Z_AX] != m->req_z_um;
        if (r->type == PK_REQ_MOVE && r->kind == PK_MOVE_FEED && !z_move) {
            if (open && (m->stroke.finishing || r->arg != m->stroke_feed)) {
                pk_stroke_finish(&m->stroke);
                if (pk_mq_room(&m->mq) == 0)
                    return;
                continue;
            }
            if (!open) {
                m->stroke_feed = r->arg;
                (void)pk_stroke_begin(&m->stroke, m->target_um);
            }
            int ar = pk_stroke_add(&m->stroke, r->p, r->chord_err_um);
            if (ar == PK_OK) {
                m->req_z_um = r->p[Z_AX];
                req_pop(m);
                continue;
            }
            if (ar == PK_EBUSY) {
                if (pk_mq_room(&m->mq) == 0)
                    return;
                continue; /* drain_stroke makes room in the kernel */
            }
            m->sg.alarm = PK_ALARM_INTERNAL;
            return;
        }
        if (open) {
            pk_stroke_finish(&m->stroke);
            if (pk_mq_room(&m->mq) == 0)
                return;
            continue;
        }
        if (pk_mq_room(&m->mq) == 0)
            return;
        switch (r->type) {
        case PK_REQ_MOVE: /* a rapid (arg 0), or a feed move that changes Z */
            m->req_z_um = r->p[Z_AX];
            (void)plan_line(m, r->p, r->arg, true);
            prep_final(m);
            break;
        case PK_REQ_PEN:
            (void)pk_planner_add_stop(&m->planner, &m->mq, PK_BLK_PEN, r->kind, 0u, r->arg);
            m->replan = true;
            break;
        case PK_REQ_DWELL:
            (void)pk_planner_add_stop(&m->planner, &m->mq, PK_BLK_DWELL, 0u, 0u, r->arg);
            m->replan = true;
            break;
        case PK_REQ_SPINDLE:
            m->spindle_q16 = (uint16_t)r->arg;
            if (r->kind) {
                (void)pk_planner_add_stop(&m->planner, &m->mq, PK_BLK_SPINDLE, 0u,
                                          (uint16_t)r->arg, m->cfg.pen_settle_ms);
                m->replan = true;
            }
            break;
        case PK_REQ_SMOOTH:
            (void)pk_stroke_set(&m->stroke, &r->smooth);
            m->policy_applied = r->smooth;
            break;
        case PK_REQ_END:
            m->flush = true; /* nothing follows: every stop planned is real */
            m->replan = true;
            break;
        default:
            break;
        }
        req_pop(m);
    }
}

/* The look-ahead waits for moves it has not seen. If none comes while the
 * machine has nothing to run (a sender that stopped mid-stroke, a lone line
 * typed at a terminal), end the stroke there and run what is planned, after
 * lookahead_wait_ms: the only place where arrival time changes the path, and
 * only once the machine stands still for lack of input. */
static void check_idle(struct pk_machine *m)
{
    bool waiting = m->inq_count == 0 && !m->flush && !m->line_pending
                   && (pk_stroke_is_open(&m->stroke) || pk_mq_count(&m->mq) > 0)
                   && !m->sg.busy && pk_sg_pending(&m->sg) == 0 && !m->hold_req;
    if (!waiting) {
        m->wait_since = 0;
        return;
    }
    uint64_t now = m->hal->ops->clock_ticks(m->hal->ctx);
    if (m->wait_since == 0) {
        m->wait_since = now ? now : 1u;
        return;
    }
    uint32_t ms = m->cfg.lookahead_wait_ms ? m->cfg.lookahead_wait_ms : PK_LOOKAHEAD_WAIT_MS_DEFAULT;
    /* ms <= 60,000 and tick_hz <= 2^24: the wait in ticks is below 2^30 */
    if (now - m->wait_since < pk_muldiv_u32(ms, m->hal->tick_hz, 1000u))
        return;
    pk_stroke_finish(&m->stroke);
    m->flush = true;
    m->replan = true;
    m->wait_since = 0;
}

/* Everything planned has been executed and nothing waits. */
static bool motion_idle(const struct pk_machine *m)
{
    return !m->sg.busy && pk_sg_pending(&m->sg) == 0 && pk_mq_count(&m->mq) == 0
           && m->inq_count == 0 && !pk_stroke_is_open(&m->stroke) && !m->line_pending;
}

/* A probing or homing move is over: keep its result, drop the rest of the
 * motion (a reset from where the machine stands). */
static void cycle_end(struct pk_machine *m, uint8_t result)
{
    pk_steps_t p[PK_AXES];
    uint32_t tok = pk_hal_irq_save(m->hal);
    const pk_steps_t *src = (m->cycle == CYC_PROBE && result == PK_CYCLE_DONE) ? m->sg.probe_pos
                                                                            : m->sg.pos;
    memcpy(p, src, sizeof p);
    uint8_t tripped = m->sg.lock;
    m->cycle = CYC_NONE;
    pk_hal_irq_restore(m->hal, tok);
    (void)pk_machine_reset(m);
    m->cycle_result = result;
    m->cycle_tripped = tripped;
    memcpy(m->cycle_pos, p, sizeof m->cycle_pos);
}

/* A probing move whose probe has fired: decelerate as a feed hold, then
 * drop the rest. */
static void probe_hold(struct pk_machine *m)
{
    if (m->cycle == CYC_PROBE && (m->sg.fired & PK_SGW_PROBE) != 0u && !m->cycle_stop) {
        m->cycle_stop = true;
        pk_sg_set_hold(&m->sg, true);
        m->replan = true;
        m->plan_fresh = false;
    }
}

/* Follow a running probing / homing move. */
static void cycle_poll(struct pk_machine *m)
{
    uint8_t f = m->sg.fired;
    if (m->cycle == CYC_PROBE) {
        probe_hold(m);
        if (m->cycle_stop) {
            if (m->sg.held && !m->sg.busy && pk_sg_pending(&m->sg) == 0)
                cycle_end(m, PK_CYCLE_DONE);
        } else if (motion_idle(m)) {
            cycle_end(m, PK_CYCLE_MISSED);
        }
    } else if (m->cycle == CYC_PULL) {
        if (motion_idle(m))
            cycle_end(m, PK_CYCLE_DONE);
    } else if ((f & PK_SGW_HOME) != 0u) {
        cycle_end(m, PK_CYCLE_DONE);   /* the step path has stopped, or stops now */
    } else if (motion_idle(m)) {
        cycle_end(m, PK_CYCLE_MISSED);
    }
}

/* In ALARM: a hard limit seen by the edge callback is latched once the step
 * path is idle (the step path latches it itself at its next event); a cycle
 * under way is aborted. */
static void alarm_poll(struct pk_machine *m)
{
    uint32_t tok = pk_hal_irq_save(m->hal);
    if (m->sg.alarm == 0u && !m->sg.busy)
        m->sg.alarm = PK_ALARM_HARD_LIMIT;
    pk_hal_irq_restore(m->hal, tok);
    if (m->cycle != CYC_NONE) {
        m->cycle = CYC_NONE;
        m->cycle_result = PK_CYCLE_ABORTED;
    }
}

void pk_machine_poll(struct pk_machine *m)
{
    if (m->in_poll && (m->sg.watch & PK_SGW_LIMITS) != 0u && !m->sg.busy
        && m->sg.alarm == 0u && inputs_refresh(m) != PK_HAL_OK)
        m->sg.alarm = PK_ALARM_INPUT_READ;   /* no edge reports: look for a limit while idle */
    if (alarmed(m)) {
        alarm_poll(m);
        return;
    }
    if (m->cycle != CYC_NONE)
        cycle_poll(m);
    m->poll_points = 0;
    take_requests(m);
    check_idle(m);
    if (!drain_stroke(m))
        return;
    bool full = pk_mq_room(&m->mq) == 0;
    if (full != m->was_full) {
        m->was_full = full;
        m->replan = true;
    }
    if (m->replan)
        replan_now(m);
    /* Which blocks may be cut into chunks: those whose plan is final; with a
     * full queue all but the newest (the same blocks whatever the sender's
     * timing, since a full queue holds the next PK_MQ_CAP blocks of the
     * program); everything when the input is known to end here; during a
     * hold everything (it decelerates regardless of the plan). */
    /* The probe may have fired since cycle_poll (its edge comes with the step
     * event that frees a ring slot): hold before refilling that slot, as if
     * the edge had come before this pass (what `plotkin sim` sees, and what
     * keeps the chip's steps from depending on where in this pass it came). */
    probe_hold(m);
    uint32_t count = pk_mq_count(&m->mq);
    uint32_t allowed = pk_planner_final(&m->planner);
    if (full && allowed < count - 1u)
        allowed = count - 1u;
    if (m->hold_req || m->cycle_stop)
        allowed = count;
    else if (allowed == 0 && count > 0 && m->sg.busy && pk_sg_pending(&m->sg) < 2u)
        allowed = 1; /* starved while moving: run the stop-safe plan rather than underrun */
    (void)pk_sg_prep(&m->sg, &m->mq, allowed);
    uint32_t popped = count - pk_mq_count(&m->mq);
    m->planner.n_final = (uint8_t)(m->planner.n_final > popped ? m->planner.n_final - popped : 0u);
    start_steps(m);
}

/* Nothing but the step generator's callback: the AVR boards run this very
 * body inline in their step interrupt (hal/avr/pk_avr_step.h), so anything
 * added here must be added there too. */
uint32_t pk_machine_timer_cb(void *arg, uint32_t now_ticks)
{
    struct pk_machine *m = arg;
    return pk_sg_isr(&m->sg, m->hal, now_ticks);
}

/* ----------------------------------------------------------- controls */

void pk_machine_hold(struct pk_machine *m)
{
    if (alarmed(m) || m->hold_req)
        return;
    if (pk_machine_state(m) != PK_STATE_RUN)
        return;
    m->hold_req = true;
    pk_sg_set_hold(&m->sg, true);
    m->replan = true;
    m->plan_fresh = false;
}

void pk_machine_resume(struct pk_machine *m)
{
    if (!m->hold_req || alarmed(m))
        return;
    m->hold_req = false;
    pk_sg_set_hold(&m->sg, m->cycle_stop);   /* a probe's stop goes on */
    m->replan = true;
    m->plan_fresh = false;
}

bool pk_machine_reset(struct pk_machine *m)
{
    const struct pk_hal *h = m->hal;
    /* Motion is cut (Grbl's ALARM 3) only if the axes may be moving: a
     * completed feed hold (HOLD: stopped, queue kept) or a machine that has
     * not started yet loses no position. */
    enum pk_machine_state st0 = pk_machine_state(m);
    bool interrupted = st0 == PK_STATE_HOLDING
                       || (st0 == PK_STATE_RUN && (m->sg.busy || pk_sg_pending(&m->sg) > 0));
    /* Stop the step timer, or, if a step pulse is high right now, let it end
     * that pulse after its full width and stop then (a runt pulse may be
     * missed by a driver while the core has counted the step: finding M2). */
    if (pk_sg_kill(&m->sg, h) == 0) {
        /* leave every step line low (also after an alarm: a line whose
         * lowering failed must not swallow the next edge). If that write
         * fails the line may still be high, so the next rising edge the core
         * counts might not be a pulse on the pin: stay in ALARM (the kill
         * flushed, which clears alarms) until a reset whose write succeeds. */
        int low_rc = pk_hal_step_write(h, (1u << m->cfg.axes) - 1u, 0u);
        if (low_rc != 0)
            m->sg.alarm = PK_ALARM_STEP_WRITE;
    }
    uint32_t tok = pk_hal_irq_save(h);
    m->sg.fired = 0;   /* a hard limit's alarm ends here too */
    m->sg.lock = 0;
    if (m->cycle != CYC_NONE)
        m->cycle_result = PK_CYCLE_ABORTED;
    m->cycle = CYC_NONE;
    m->cycle_stop = false;
    m->sg.watch = watch_bits(m, CYC_NONE);
    pk_hal_irq_restore(h, tok);
    pk_mq_init(&m->mq);
    pk_planner_break(&m->planner);
    m->planner.n_final = 0;
    m->plan_fresh = false;
    pk_stroke_reset(&m->stroke);
    m->inq_count = 0;
    m->inq_head = 0;
    m->hold_req = false;
    m->line_pending = false;
    m->flush = false;
    m->replan = false;
    m->was_full = false;
    m->wait_since = 0;
    run_start(m);
    m->acc_policy = m->policy_applied;
    for (unsigned i = 0; i < m->cfg.axes; i++) {
        m->target_steps[i] = m->sg.pos[i];
        m->target_um[i] = pk_steps_to_um(m->sg.pos[i], m->cfg.steps_per_mm_q16[i]);
        m->timed_um[i] = m->target_um[i];
    }
    return interrupted;
}

void pk_machine_set_observer(struct pk_machine *m, pk_stroke_observer fn, void *ctx)
{
    m->observe = fn;
    m->observe_ctx = ctx;
    m->stroke.observe = fn;
    m->stroke.observe_ctx = ctx;
}

/* ----------------------------------------------------------- queries */

void pk_machine_position_steps(const struct pk_machine *m, pk_steps_t out[PK_AXES])
{
    uint32_t tok = pk_hal_irq_save(m->hal);
    for (unsigned i = 0; i < PK_AXES; i++)
        out[i] = i < m->cfg.axes ? m->sg.pos[i] : 0;
    pk_hal_irq_restore(m->hal, tok);
}

void pk_machine_position_um(const struct pk_machine *m, pk_um_t out[PK_AXES])
{
    pk_steps_t s[PK_AXES];
    pk_machine_position_steps(m, s);
    for (unsigned i = 0; i < PK_AXES; i++)
        out[i] = i < m->cfg.axes ? pk_steps_to_um(s[i], m->cfg.steps_per_mm_q16[i]) : 0;
}

enum pk_machine_state pk_machine_state(const struct pk_machine *m)
{
    if (alarmed(m))
        return PK_STATE_ALARM;
    bool busy = (m->sg.busy);
    uint32_t pend = pk_sg_pending(&m->sg);
    if (m->hold_req)
        return (m->sg.held && !busy && pend == 0) ? PK_STATE_HOLD : PK_STATE_HOLDING;
    if (busy || pend > 0 || pk_mq_count(&m->mq) > 0 || m->inq_count > 0
        || pk_stroke_is_open(&m->stroke))
        return PK_STATE_RUN;
    return PK_STATE_IDLE;
}

enum pk_alarm pk_machine_alarm(const struct pk_machine *m)
{
    if (m->sg.alarm == 0u && (m->sg.fired & PK_SGW_LIMITS) != 0u)
        return PK_ALARM_HARD_LIMIT;
    return (enum pk_alarm)(m->sg.alarm);
}

uint32_t pk_machine_queue_fill(const struct pk_machine *m)
{
    uint32_t n = pk_mq_count(&m->mq);
    if (!m->sg.prep_active && (pk_sg_pending(&m->sg) > 0 || (m->sg.busy)))
        n++;
    return n;
}

uint32_t pk_machine_lines_planned(const struct pk_machine *m) { return m->lines_planned; }

pk_um_min_t pk_machine_speed(const struct pk_machine *m)
{
    return (pk_um_min_t)(m->sg.v_um_s) * 60u;
}

/* ----------------------------------------------------------- input cycles */

int pk_machine_set_hard_limits(struct pk_machine *m, bool on)
{
    if (on && (m->hal->inputs & PK_IN_LIMITS) == 0u)
        return PK_MOTION_ENOINPUT;
    uint32_t tok = pk_hal_irq_save(m->hal);
    /* a switch that already tripped (its edge reported, the alarm not yet
     * latched by a step event) stays tripped: turning the watch off must
     * not let the steps go on */
    if (!on && m->sg.alarm == 0u && (m->sg.fired & PK_SGW_LIMITS) != 0u)
        m->sg.alarm = PK_ALARM_HARD_LIMIT;
    m->hard_limits = on;
    m->sg.watch = watch_bits(m, m->cycle);
    pk_hal_irq_restore(m->hal, tok);
    return PK_MOTION_OK;
}

/* Arm the watches of a cycle, then look at the inputs (an edge after the
 * look is reported with the watch armed), then queue the move and its end. */
static int cycle_start(struct pk_machine *m, uint8_t kind, uint8_t axes, uint8_t probe_level,
                       const pk_um_t target[PK_AXES], pk_um_min_t feed)
{
    uint32_t lv = 0;
    uint32_t tok = pk_hal_irq_save(m->hal);
    m->sg.fired = 0;
    m->sg.lock = 0;
    m->sg.home_axes = axes;
    m->sg.probe_level = probe_level;
    m->sg.watch = watch_bits(m, kind);
    int rr = kind == CYC_PULL ? PK_HAL_OK : pk_hal_input_read(m->hal, &lv);
    if (rr == PK_HAL_OK && kind != CYC_PULL)
        pk_sg_inputs(&m->sg, lv ^ m->sg.in_flip, 1);
    uint8_t f = m->sg.fired;
    if (rr != PK_HAL_OK || (f & PK_SGW_PROBE) != 0u)
        m->sg.watch = watch_bits(m, CYC_NONE);
    pk_hal_irq_restore(m->hal, tok);
    if (rr != PK_HAL_OK)
        return PK_MOTION_EHAL;
    if ((f & PK_SGW_LIMITS) != 0u)
        return PK_MOTION_EALARM;   /* a limit closed: the alarm is latched */
    if ((f & PK_SGW_PROBE) != 0u) {
        m->sg.fired = 0;
        return PK_MOTION_ETRIGGERED;
    }
    bool soft = m->soft_on;
    if (kind == CYC_HOME || kind == CYC_PULL)
        m->soft_on = false;   /* homing runs past the travel box by design */
    int rc = move_req(m, target, feed, PK_MOVE_FEED, 0);
    m->soft_on = soft;
    if (rc == PK_MOTION_OK)
        rc = pk_machine_end(m);   /* run it to its end without waiting for more */
    if (rc != PK_MOTION_OK) {
        m->inq_count = 0;   /* nothing of it stays queued (the FIFO was empty: IDLE) */
        run_start(m);
        tok = pk_hal_irq_save(m->hal);
        m->sg.watch = watch_bits(m, CYC_NONE);
        m->sg.fired &= PK_SGW_LIMITS;
        m->sg.lock = 0;
        pk_hal_irq_restore(m->hal, tok);
        return rc;
    }
    m->cycle = kind;
    m->cycle_stop = false;
    m->cycle_result = PK_CYCLE_RUNNING;
    m->cycle_tripped = 0;
    return PK_MOTION_OK;
}

int pk_machine_probe(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed,
                     bool away)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if ((m->hal->inputs & (1u << PK_IN_PROBE)) == 0u)
        return PK_MOTION_ENOINPUT;
    if (m->cycle != CYC_NONE || pk_machine_state(m) != PK_STATE_IDLE)
        return PK_MOTION_EBUSY;
    return cycle_start(m, CYC_PROBE, 0u, away ? 0u : 1u, target, feed);
}

int pk_machine_home_seek(struct pk_machine *m, uint8_t axes, const pk_um_t target[PK_AXES],
                         pk_um_min_t feed)
{
    uint32_t all = (1u << m->cfg.axes) - 1u;
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if (axes == 0u || (axes & ~all) != 0u || (m->hal->inputs & axes) != axes)
        return PK_MOTION_ENOINPUT;
    if (m->cycle != CYC_NONE || pk_machine_state(m) != PK_STATE_IDLE)
        return PK_MOTION_EBUSY;
    return cycle_start(m, CYC_HOME, axes, 0u, target, feed);
}

int pk_machine_home_pulloff(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if (m->cycle != CYC_NONE || pk_machine_state(m) != PK_STATE_IDLE)
        return PK_MOTION_EBUSY;
    return cycle_start(m, CYC_PULL, 0u, 0u, target, feed);
}

enum pk_cycle_result pk_machine_cycle(const struct pk_machine *m, pk_steps_t pos[PK_AXES],
                                      uint8_t *tripped)
{
    if (pos != NULL)
        memcpy(pos, m->cycle_pos, sizeof m->cycle_pos);
    if (tripped != NULL)
        *tripped = m->cycle_tripped;
    return (enum pk_cycle_result)m->cycle_result;
}

int pk_machine_set_position(struct pk_machine *m, const pk_steps_t pos[PK_AXES])
{
    if (m->cycle != CYC_NONE || pk_machine_state(m) != PK_STATE_IDLE)
        return PK_MOTION_EBUSY;
    if (!pos_fits(pos, &m->cfg))
        return PK_MOTION_ERANGE;
    uint32_t tok = pk_hal_irq_save(m->hal);
    for (uint32_t i = 0; i < m->cfg.axes; i++)
        m->sg.pos[i] = pos[i];
    pk_hal_irq_restore(m->hal, tok);
    for (uint32_t i = 0; i < m->cfg.axes; i++) {
        m->target_steps[i] = pos[i];
        m->target_um[i] = pk_steps_to_um(pos[i], m->cfg.steps_per_mm_q16[i]);
        m->timed_um[i] = m->target_um[i];
    }
    run_start(m);
    return PK_MOTION_OK;
}

uint32_t pk_machine_inputs(struct pk_machine *m)
{
    uint32_t lv;
    if (pk_hal_input_read(m->hal, &lv) != PK_HAL_OK)
        return 0u;
    return lv ^ m->sg.in_flip;
}

uint32_t pk_machine_input_events(struct pk_machine *m)
{
    if (m->in_poll)
        (void)inputs_refresh(m);
    uint32_t tok = pk_hal_irq_save(m->hal);
    uint32_t ev = m->sg.in_rise;
    m->sg.in_rise = 0;
    pk_hal_irq_restore(m->hal, tok);
    return ev;
}
