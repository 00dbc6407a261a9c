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

enum { PK_REQ_MOVE = 0, PK_REQ_PEN, PK_REQ_DWELL, PK_REQ_SMOOTH, PK_REQ_END };

/** Work items per poll (bounds the main-loop latency). */
#define POLL_BUDGET 64u

static uint32_t axes_of(const struct pk_machine *m) { return m->cfg.axes; }

static int check_cfg(const struct pk_motion_cfg *c, uint32_t tick_hz)
{
    uint32_t axes = c->axes ? c->axes : PK_AXES;
    if (axes < 2u || axes > PK_AXES || axes > PK_HAL_MAX_AXES)
        return -1;
    for (uint32_t i = 0; i < axes; i++) {
        if (c->steps_per_mm_q16[i] < PK_SPMM_Q16_MIN || c->steps_per_mm_q16[i] > PK_SPMM_Q16_MAX)
            return -1;
        if (c->max_rate[i] < 1u || c->max_rate[i] > PK_UM_MIN_MAX)
            return -1;
        if (c->accel[i] < 1u || c->accel[i] > PK_UM_S2_MAX)
            return -1;
        /* the fastest step train must leave room for a pulse and a gap */
        uint64_t sps = ((uint64_t)c->max_rate[i] * c->steps_per_mm_q16[i])
                       / (60000ull << PK_SPMM_Q16_SHIFT);
        if (sps * 2u * (uint64_t)(c->step_pulse_ticks ? c->step_pulse_ticks : 1u) > tick_hz)
            return -1;
    }
    if (c->junction_dev_um < 0 || c->junction_dev_um > 10000)
        return -1;
    if (c->step_pulse_ticks < 1u || c->dir_setup_ticks > tick_hz)
        return -1;
    if (c->pen_settle_ms > 60000u || c->pen_down_level > 1u)
        return -1;
    if (pk_stroke_check(&c->smooth) != 0)
        return -1;
    return 0;
}

/* Build the modules from m->cfg (everything but the pins and the position). */
static void setup_modules(struct pk_machine *m)
{
    const struct pk_motion_cfg *cfg = &m->cfg;
    const struct pk_hal *hal = m->hal;
    struct pk_planner_limits lim;
    memset(&lim, 0, sizeof lim);
    lim.axes = m->cfg.axes;
    for (uint32_t i = 0; i < axes_of(m); i++) {
        lim.max_rate[i] = pk_um_min_to_um_s(cfg->max_rate[i]);
        lim.accel[i] = cfg->accel[i];
    }
    lim.junction_dev_um = cfg->junction_dev_um;
    pk_planner_init(&m->planner, &lim);
    pk_mq_init(&m->mq);
    pk_stroke_init(&m->stroke, &cfg->smooth);
    pk_sg_init(&m->sg, m->cfg.axes, hal->tick_hz, cfg->step_pulse_ticks, cfg->dir_setup_ticks);
}

int pk_machine_init(struct pk_machine *m, const struct pk_motion_cfg *cfg,
                    const struct pk_hal *hal)
{
    if (m == NULL || cfg == NULL)
        return PK_MOTION_EINVAL;
    if (pk_hal_check(hal) != PK_HAL_OK)
        return PK_MOTION_EHAL;
    if (hal->tick_hz > ((uint32_t)1 << 25) || check_cfg(cfg, hal->tick_hz) != 0)
        return PK_MOTION_EINVAL;
    memset(m, 0, sizeof *m);
    m->cfg = *cfg;
    if (m->cfg.axes == 0)
        m->cfg.axes = PK_AXES;
    m->hal = hal;
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
    return PK_MOTION_OK;
}

int pk_machine_configure(struct pk_machine *m, const struct pk_motion_cfg *cfg)
{
    if (cfg == NULL || check_cfg(cfg, m->hal->tick_hz) != 0)
        return PK_MOTION_EINVAL;
    enum pk_machine_state st = pk_machine_state(m);
    if (st != PK_STATE_IDLE && st != PK_STATE_ALARM)
        return PK_MOTION_EBUSY;
    if (st == PK_STATE_ALARM && (m->sg.busy || pk_sg_pending(&m->sg) > 0 || pk_mq_count(&m->mq) > 0
                                 || m->inq_count > 0 || pk_stroke_is_open(&m->stroke)))
        return PK_MOTION_EBUSY;
    pk_steps_t pos[PK_AXES];
    memcpy(pos, m->sg.pos, sizeof pos);
    uint8_t dir = m->sg.dir_cur, alarm = m->sg.alarm;
    uint32_t lines = m->lines_planned;
    m->cfg = *cfg;
    if (m->cfg.axes == 0)
        m->cfg.axes = PK_AXES;
    setup_modules(m);
    for (uint32_t i = 0; i < PK_AXES; i++) {
        m->sg.pos[i] = i < axes_of(m) ? pos[i] : 0;
        m->target_steps[i] = m->sg.pos[i];
        m->target_um[i] = i < axes_of(m) ? pk_steps_to_um(m->sg.pos[i], cfg->steps_per_mm_q16[i]) : 0;
    }
    m->sg.dir_cur = dir;
    m->sg.alarm = alarm;
    m->lines_planned = lines;
    return PK_MOTION_OK;
}

/* ----------------------------------------------------------- requests */

static bool alarmed(const struct pk_machine *m)
{
    return (m->sg.alarm) != 0;
}

static struct pk_req *req_slot(struct pk_machine *m)
{
    if (m->inq_count >= PK_MACHINE_INQ)
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
    return alarmed(m) ? 0u : (uint32_t)PK_MACHINE_INQ - m->inq_count;
}

int pk_machine_move(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed,
                    enum pk_move_kind kind)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    if (kind != PK_MOVE_FEED && kind != PK_MOVE_RAPID)
        return PK_MOTION_ERANGE;
    if (kind == PK_MOVE_FEED && (feed < 1u || feed > PK_UM_MIN_MAX))
        return PK_MOTION_ERANGE;
    for (uint32_t i = 0; i < axes_of(m); i++)
        if (target[i] > PK_UM_MAX || target[i] < -PK_UM_MAX)
            return PK_MOTION_ERANGE;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_MOVE;
    r->kind = (uint8_t)kind;
    for (uint32_t i = 0; i < PK_AXES; i++)
        r->p[i] = i < axes_of(m) ? target[i] : 0;
    r->arg = kind == PK_MOVE_FEED ? feed : 0u;
    return req_commit(m);
}

int pk_machine_pen(struct pk_machine *m, bool down)
{
    if (alarmed(m))
        return PK_MOTION_EALARM;
    struct pk_req *r = req_slot(m);
    if (r == NULL)
        return PK_MOTION_EFULL;
    r->type = PK_REQ_PEN;
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
    return req_commit(m);
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

/** Plan a straight line from the planned position to p (µm). */
static bool plan_line(struct pk_machine *m, const pk_um_t p[PK_AXES], pk_um_s_t feed)
{
    int32_t d_um[PK_AXES];
    pk_steps_t d_steps[PK_AXES], st[PK_AXES];
    memset(d_um, 0, sizeof d_um);
    memset(d_steps, 0, sizeof d_steps);
    memset(st, 0, sizeof st);
    for (uint32_t i = 0; i < axes_of(m); i++) {
        st[i] = pk_um_to_steps(p[i], m->cfg.steps_per_mm_q16[i]);
        d_um[i] = p[i] - m->target_um[i];
        d_steps[i] = st[i] - m->target_steps[i];
    }
    int r = pk_planner_add_line(&m->planner, &m->mq, d_um, d_steps, feed);
    if (r < 0)
        return false;
    if (r > 0)
        m->lines_planned++;
    memcpy(m->target_um, p, sizeof m->target_um);
    memcpy(m->target_steps, st, sizeof m->target_steps);
    return true;
}

/** Largest |second difference| (µm) over the feed moves at this feed visible
 *  in the FIFO, starting from the planned position. */
static uint32_t d2_hint(struct pk_machine *m, uint32_t feed)
{
    pk_um_t a[PK_AXES], b[PK_AXES];
    uint32_t n = 1;
    uint64_t best = 0;
    memcpy(b, m->target_um, sizeof b);
    memcpy(a, b, sizeof a);
    for (uint32_t k = 0; k < m->inq_count; k++) {
        const struct pk_req *r = req_at(m, k);
        if (r->type != PK_REQ_MOVE || r->kind != PK_MOVE_FEED || r->arg != feed)
            break;
        if (n >= 2) {
            uint64_t s = 0;
            for (uint32_t i = 0; i < axes_of(m); i++) {
                int64_t d = (int64_t)r->p[i] - 2 * (int64_t)b[i] + a[i];
                s += (uint64_t)(d * d);
            }
            if (s > best)
                best = s;
        }
        memcpy(a, b, sizeof a);
        memcpy(b, r->p, sizeof b);
        n++;
    }
    return pk_isqrt64(best);
}

/** Pull the open stroke into the motion queue while it has room.
 *  Returns false on a kernel error (alarm latched). */
static bool drain_stroke(struct pk_machine *m)
{
    while (pk_stroke_is_open(&m->stroke) && pk_mq_room(&m->mq) > 0) {
        pk_um_t p[PK_AXES];
        int r = pk_stroke_pull(&m->stroke, p);
        if (r == PK_OK) {
            (void)plan_line(m, p, m->stroke_feed);
            continue;
        }
        if (r < 0) {
            m->sg.alarm = PK_ALARM_INTERNAL;
            return false;
        }
        break;
    }
    return true;
}

static void take_requests(struct pk_machine *m)
{
    for (uint32_t it = 0; it < POLL_BUDGET; it++) {
        if (!drain_stroke(m))
            return;
        if (m->inq_count == 0)
            return;
        struct pk_req *r = req_at(m, 0);
        bool open = pk_stroke_is_open(&m->stroke);
        if (r->type == PK_REQ_MOVE && r->kind == PK_MOVE_FEED) {
            pk_um_s_t f = pk_um_min_to_um_s(r->arg);
            if (open && (m->stroke.finishing || f != m->stroke_feed)) {
                pk_stroke_finish(&m->stroke);
                if (pk_mq_room(&m->mq) == 0)
                    return;
                continue;
            }
            if (!open) {
                m->stroke_feed = f;
                (void)pk_stroke_begin(&m->stroke, m->target_um, d2_hint(m, r->arg));
            }
            int ar = pk_stroke_add(&m->stroke, r->p);
            if (ar == PK_OK) {
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
        case PK_REQ_MOVE:
            (void)plan_line(m, r->p, 0u);
            break;
        case PK_REQ_PEN:
            (void)pk_planner_add_stop(&m->planner, &m->mq, PK_BLK_PEN, r->kind, r->arg);
            break;
        case PK_REQ_DWELL:
            (void)pk_planner_add_stop(&m->planner, &m->mq, PK_BLK_DWELL, 0u, r->arg);
            break;
        case PK_REQ_SMOOTH:
            (void)pk_stroke_set(&m->stroke, &r->smooth);
            break;
        default:
            break;
        }
        req_pop(m);
    }
}

void pk_machine_poll(struct pk_machine *m)
{
    if (alarmed(m))
        return;
    take_requests(m);
    /* A sender that stopped mid-stroke: nothing waiting, and the planned
     * blocks are all handed to the step generator: finish the stroke so the
     * kernel releases its tail instead of leaving it waiting forever. */
    if (m->inq_count == 0 && pk_stroke_is_open(&m->stroke) && !m->stroke.finishing
        && pk_mq_count(&m->mq) == 0) {
        pk_stroke_finish(&m->stroke);
        if (!drain_stroke(m))
            return;
    }
    pk_v2_q4_t v2;
    uint32_t rem;
    pk_sg_plan_state(&m->sg, &m->mq, &v2, &rem);
    pk_planner_replan(&m->planner, &m->mq, v2, rem);
    (void)pk_sg_prep(&m->sg, &m->mq);
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

uint64_t pk_machine_timer_cb(void *arg, uint64_t now_ticks)
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
}

void pk_machine_resume(struct pk_machine *m)
{
    if (!m->hold_req || alarmed(m))
        return;
    m->hold_req = false;
    pk_sg_set_hold(&m->sg, false);
}

bool pk_machine_reset(struct pk_machine *m)
{
    const struct pk_hal *h = m->hal;
    if (h->ops->timer_stop)
        (void)h->ops->timer_stop(h->ctx);
    bool busy = (m->sg.busy);
    bool interrupted = !alarmed(m) && (busy || pk_sg_pending(&m->sg) > 0 || pk_mq_count(&m->mq) > 0
                                       || m->sg.prep_active || pk_stroke_is_open(&m->stroke));
    /* leave every step line low (also after an alarm: a line whose lowering
     * failed must not swallow the next edge) */
    (void)pk_hal_step_write(h, (1u << m->cfg.axes) - 1u, 0u);
    pk_sg_flush(&m->sg);
    pk_mq_init(&m->mq);
    pk_planner_break(&m->planner);
    pk_stroke_reset(&m->stroke);
    m->inq_count = 0;
    m->inq_head = 0;
    m->hold_req = false;
    for (uint32_t i = 0; i < axes_of(m); i++) {
        m->target_steps[i] = m->sg.pos[i];
        m->target_um[i] = pk_steps_to_um(m->sg.pos[i], m->cfg.steps_per_mm_q16[i]);
    }
    return interrupted;
}

/* ----------------------------------------------------------- queries */

void pk_machine_position_steps(const struct pk_machine *m, pk_steps_t out[PK_AXES])
{
    uint32_t tok = pk_hal_irq_save(m->hal);
    for (uint32_t i = 0; i < PK_AXES; i++)
        out[i] = i < axes_of(m) ? m->sg.pos[i] : 0;
    pk_hal_irq_restore(m->hal, tok);
}

void pk_machine_position_um(const struct pk_machine *m, pk_um_t out[PK_AXES])
{
    pk_steps_t s[PK_AXES];
    pk_machine_position_steps(m, s);
    for (uint32_t i = 0; i < PK_AXES; i++)
        out[i] = i < axes_of(m) ? pk_steps_to_um(s[i], m->cfg.steps_per_mm_q16[i]) : 0;
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
