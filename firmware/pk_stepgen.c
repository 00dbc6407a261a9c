/*
 * pk_stepgen.c — chunk preparation (main loop) and pulse emission (timer
 * callback). See pk_stepgen.h for the scheme; the kinematics are below.
 *
 * Segments of constant time. The main loop cuts the tail block into
 * segments of seg_ticks (2 ms, at most 2^14 ticks), like Grbl's segment
 * buffer: over one segment the speed goes from v0 to v1 = v0 +- a seg_t
 * (accelerate towards the nominal, cruise, or decelerate towards the
 * exit), so the segment covers ds = (v0 + v1)/2 seg_t. Its events are placed
 * as under that constant acceleration: the first and last from the time at
 * the mean speed corrected for the acceleration (at_time), the ones between
 * by a linear ramp of the step interval, so the step rate changes smoothly
 * inside a segment and across its boundaries (Grbl runs each segment at one
 * speed: a jump every segment). With that choice v1^2 = v0^2 +-
 * 2 a ds exactly, so the segment ends lie on the block's speed^2 lines: a
 * segment that would cross the braking line v^2 = v_exit^2 + 2a(L - s) is
 * shortened to end on it, and from there the segments decelerate along it,
 * so the block is left at most at its planned exit speed, never above it. A block's last segment ends exactly at the block's end (its
 * time follows from its length). Time is kept exactly in ticks Q16: the time
 * from the last prepared event to the prepared position is carried to the
 * next event, so no rounding accumulates.
 *
 * Arithmetic: speeds in µm/s Q4 (< 2^24), lengths in µm Q8, squares of
 * speeds in (µm/s)^2 Q8 (64-bit), time in ticks Q16. Per segment the main
 * loop needs a few 32x32->64 products and 64/32 divisions, and a square root
 * only where a phase ends inside the segment (the nominal and exit speeds are
 * cached per block): this is what lets an 8-bit chip keep the queue fed.
 */
#include <string.h>
#include "pk_stepgen.h"
#include "pk_motion.h"

#define SG_MASK (PK_SG_CHUNKS - 1u)

/* ------------------------------------------------------------------ prep */

/* 64/32 division, rounded down, saturating at UINT32_MAX. */
static uint32_t div64_32(uint64_t n, uint32_t d)
{
    if (d == 0)
        return UINT32_MAX;
    uint64_t q = n / d;
    return q > UINT32_MAX ? UINT32_MAX : (uint32_t)q;
}

static uint64_t sq64(uint32_t v) { return (uint64_t)v * v; }

/* Distance (µm Q8) of event k of block b from its start: floor(k L / M). */
static uint32_t ev_s(const struct pk_block *b, uint32_t k)
{
    return (uint32_t)(((uint64_t)k * b->len_q8) / b->events);
}

/* Events of b at or before distance s: the largest k with ev_s(k) <= s. */
static uint32_t ev_upto(const struct pk_block *b, uint32_t s_q8)
{
    if (s_q8 >= b->len_q8)
        return b->events;
    uint64_t k = (((uint64_t)s_q8 + 1u) * b->events - 1u) / b->len_q8;
    return k > b->events ? b->events : (uint32_t)k;
}

/* Time (ticks Q16) to cover ds (µm Q8) at the speed v (µm/s Q4):
 * ds / 256 / (v / 16) s = ds * 2^-4 / v s -> * tick_hz * 2^16. */
static uint64_t time_q16(const struct pk_stepgen *sg, uint32_t ds_q8, uint32_t v_q4)
{
    if (v_q4 == 0)
        return UINT64_MAX;
    return ((uint64_t)ds_q8 * sg->tick_q12) / v_q4;
}

/* When a segment of duration T (ticks Q16) that covers its distance at the
 * mean speed vseg = vsum / 2 reaches the point d (µm Q8) from its start. At constant
 * speed: tau = d / vseg. The segment really accelerates (or decelerates)
 * uniformly from v0 to v1, which puts the point later (earlier) by
 *     eps = a tau (T - tau) / (2 v)  ~  r tau (T - tau) / (2 T),
 * r = |v1 - v0| / vseg (the error of using vseg for v is second order).
 * Without it the events next to a segment boundary are off by up to
 * r T / 8 against the ramp inside the segment, a jolt at every boundary. */
static uint64_t at_time(const struct pk_stepgen *sg, uint32_t d_q8, uint32_t vsum,
                        uint64_t T_q16, uint32_t r_q15, bool accel)
{
    uint64_t tau = time_q16(sg, 2u * d_q8, vsum);
    uint32_t T = (uint32_t)(T_q16 >> 16), t = (uint32_t)(tau >> 16);
    if (T == 0 || t >= T || r_q15 == 0)
        return tau;
    /* r_q15 t (T - t) / T in Q16: r_q15 * 2^-15 * t (T - t) / (2T) * 2^16
     * (t (T - t) <= 2^26 for T < 2^14 ticks, times r_q15 <= 2^16: < 2^42) */
    uint64_t eps = ((uint64_t)r_q15 * t * (T - t)) / T;
    /* and v is v(tau) = vseg (1 +- r (tau/T - 1/2)): eps /= that, to first
     * order eps -= eps r (2 tau - T) / 2T (eps < 2^26, r_q15 <= 2^16) */
    uint64_t k = (eps * r_q15) >> 15;
    uint64_t fix = (k * (uint32_t)(2u * t > T ? 2u * t - T : T - 2u * t)) / (2u * T);
    if ((2u * t > T) == accel)
        eps = eps > fix ? eps - fix : 0;
    else
        eps += fix;
    if (accel)
        return tau + eps;
    return tau > eps ? tau - eps : 0;
}

/* The block's cached speeds (isqrt only when the plan changed them). */
static void blk_speeds(struct pk_stepgen *sg, const struct pk_block *b)
{
    if (b->v2_nom != sg->c_v2_nom) {
        sg->c_v2_nom = b->v2_nom;
        sg->vn_q4 = pk_isqrt64(b->v2_nom << 4);   /* Q4 speed^2 * 16 = (v Q4)^2 */
    }
    if (b->v2_exit != sg->c_v2_exit) {
        sg->c_v2_exit = b->v2_exit;
        sg->ve_q4 = pk_isqrt64(b->v2_exit << 4);
    }
}

void pk_sg_init(struct pk_stepgen *sg, uint8_t axes, uint32_t tick_hz, uint32_t pulse_ticks,
                uint32_t dir_setup_ticks)
{
    memset(sg, 0, sizeof *sg);
    sg->axes = axes;
    sg->tick_hz = tick_hz;
    sg->pulse_ticks = pulse_ticks ? pulse_ticks : 1u;
    sg->dir_setup_ticks = dir_setup_ticks;
    sg->seg_max = tick_hz / 500u; /* 2 ms */
    if (sg->seg_max > PK_SG_CHUNK_TICKS_MAX)
        sg->seg_max = PK_SG_CHUNK_TICKS_MAX;
    if (sg->seg_max < 16u)
        sg->seg_max = 16u;
    sg->tick_q12 = (uint64_t)tick_hz << 12;
    sg->head = 0u;
    sg->tail = 0u;
    sg->busy = false;
    sg->alarm = 0;
    sg->v_um_s = 0u;
}

uint32_t pk_sg_pending(const struct pk_stepgen *sg)
{
    uint8_t h = sg->head;
    uint8_t t = sg->tail;
    return (uint8_t)(h - t);
}

static struct pk_sg_chunk *ring_slot(struct pk_stepgen *sg)
{
    if (pk_sg_pending(sg) >= PK_SG_CHUNKS)
        return NULL;
    uint8_t h = sg->head;
    struct pk_sg_chunk *c = &sg->ring[h & SG_MASK];
    memset(c, 0, sizeof *c);
    return c;
}

static void ring_commit(struct pk_stepgen *sg)
{
    uint8_t h = sg->head;
    PK_BARRIER(); /* the chunk is written before it is published */
    sg->head = (uint8_t)(h + 1u);
}

void pk_sg_set_hold(struct pk_stepgen *sg, bool hold)
{
    sg->hold = hold;
    if (hold)
        sg->off_plan = true;
    if (!hold)
        sg->held = false;
}

void pk_sg_plan_state(const struct pk_stepgen *sg, struct pk_mq *q, pk_v2_q4_t *v2_now,
                      uint32_t *rem_q8)
{
    struct pk_block *b = pk_mq_at(q, 0);
    *rem_q8 = 0;
    if (b == NULL || b->type != PK_BLK_LINE) {
        *v2_now = sg->v2;
        return;
    }
    if (sg->prep_active && sg->off_plan) {
        /* a hold stopped or slowed it inside the block: plan from where it is */
        *v2_now = sg->v2;
        *rem_q8 = b->len_q8 - sg->s_q8;
        return;
    }
    /* Following the plan: report the block's start, not the position the
     * main loop happens to have reached. The segments round their speeds and
     * lengths, so the forward pass from a mid-block point would give exits a
     * few LSB apart depending on when the replan ran, and the output would
     * depend on the sender's timing. */
    *v2_now = sg->prep_active ? sg->v2_blk : sg->v2;
    *rem_q8 = b->len_q8;
}

/* Publish n events: the first `first` ticks Q16 after the previous event,
 * then the intervals c1 + A, c1 + 2A, ... (the ramp of one segment). Several
 * slots when n exceeds PK_SG_MAX_EVENTS or the first interval exceeds the
 * recurrence's range; each goes on where the last one stopped. */
static bool emit_events(struct pk_stepgen *sg, uint32_t n, uint64_t first, int32_t c1, int32_t A,
                        uint32_t v_um_s)
{
    while (n > 0) {
        struct pk_sg_chunk *c = ring_slot(sg);
        if (c == NULL)
            return false;  /* (the caller checked the room) */
        c->v_um_s = v_um_s;
        if (first >= ((uint64_t)1 << 30)) {
            /* one event after a long interval: whole ticks + Q16 fraction */
            c->kind = PK_SGC_SLOW;
            uint64_t t = first >> 16;
            c->u.ticks = (uint32_t)(t > UINT32_MAX ? UINT32_MAX : t);
            c->n = (uint16_t)(first & 0xffffu);
            ring_commit(sg);
            n--;
            c1 += A;
            first = (uint64_t)(int64_t)c1;
            continue;
        }
        uint32_t k = n > PK_SG_MAX_EVENTS ? PK_SG_MAX_EVENTS : n;
        c->kind = PK_SGC_STEPS;
        c->n = (uint16_t)k;
        c->u.st.c0 = (int32_t)first;
        c->u.st.c1 = c1;
        c->u.st.c2 = A;
        ring_commit(sg);
        n -= k;
        c1 += (int32_t)k * A;
        first = (uint64_t)(int64_t)c1;
    }
    return true;
}

/* Cut the next segment of the tail LINE block b. Returns false if none
 * (held, or the ring has no room for it). */
static bool prep_line(struct pk_stepgen *sg, struct pk_block *b)
{
    if (!sg->blk_sent) {
        /* the block's own slot first: directions, spindle, Bresenham */
        struct pk_sg_chunk *c = ring_slot(sg);
        if (c == NULL)
            return false;
        c->kind = PK_SGC_BLOCK;
        c->arg = b->dir_mask;
        c->spindle = b->spindle;
        memcpy(c->u.blk.inc, b->inc, sizeof c->u.blk.inc);
        memcpy(c->u.blk.acc0, b->acc0, sizeof c->u.blk.acc0);
        c->u.blk.period = b->period;
        ring_commit(sg);
        sg->blk_sent = true;
        sg->v2_blk = sg->v2;
        sg->off_plan = sg->hold;
        /* The segment: 2 ms, or shorter so that at twice the nominal speed
         * (the highest override) a segment holds at most PK_SG_MAX_EVENTS
         * events: 2 v_nom seg_t <= PK_SG_MAX_EVENTS L / M. */
        blk_speeds(sg, b);
        uint32_t seg = sg->seg_max;
        /* (an event is one step of the dominant axis, at most 1 mm * sqrt(3)
         * at 1 step/mm: d64 < 2^29 µm Q8, and d64 * tick_hz < 2^61) */
        uint64_t d64 = ((uint64_t)PK_SG_MAX_EVENTS * b->len_q8) / b->events;
        uint64_t lim = (d64 * sg->tick_hz) / (16u * (2u * (uint64_t)sg->vn_q4 + 1u));
        if (lim < seg)
            seg = lim < 16u ? 16u : (uint32_t)lim;
        sg->seg_ticks = seg;
        /* ds_q8 = (v0 + v1)_q4 * 8 seg / tick_hz: g in Q16 */
        sg->g_q24 = (uint32_t)(((uint64_t)8u * seg << 24) / sg->tick_hz); /* < 2^41 / 1 MHz */
        /* speed change per segment: a (µm/s^2) * seg / tick_hz, Q4 */
        sg->dv_q4 = (uint32_t)(((uint64_t)b->accel * seg * 16u) / sg->tick_hz);
        if (sg->dv_q4 == 0)
            sg->dv_q4 = 1;
    }
    /* room for the segment's events: at most a few slots */
    if (PK_SG_CHUNKS - pk_sg_pending(sg) < 3u)
        return false;
    blk_speeds(sg, b);
    const uint32_t L = b->len_q8, s0 = sg->s_q8, v0 = sg->v_q4, dv = sg->dv_q4;
    const uint64_t two_a = 2u * (uint64_t)b->accel;     /* (µm/s)^2 Q8 per µm Q8 */
    const uint32_t ve = sg->hold ? 0u : sg->ve_q4;
    const uint64_t v02 = sq64(v0), ve2 = sq64(ve);
    /* the speed^2 the end of the block allows here: the line
     * v^2 = v_exit^2 + 2a(L - s) (a hold: v^2 = 0 + 2a(s_stop - s), i.e. decelerate now) */
    const uint64_t line0 = ve2 + two_a * (L - s0);
    uint32_t v1, ds;
    if (sg->hold || (v02 >= line0 && v0 > ve) || v0 > sg->vn_q4) {
        /* decelerate: towards the exit (on the line), the nominal (an
         * override lowered it) or rest (a hold). A whole segment, or the
         * part of one that reaches the target speed: from v0 to vt at a,
         * (v0^2 - vt^2) / 2a, in (v0 - vt) / a. */
        uint32_t vt = sg->hold ? 0u : (v0 > sg->vn_q4 && !(v02 >= line0) ? sg->vn_q4 : ve);
        if (sg->hold && v0 == 0) {
            sg->held = true;
            return false;
        }
        if (v0 > vt + dv) {
            v1 = v0 - dv;
            ds = (uint32_t)(((uint64_t)(v0 + v1) * sg->g_q24) >> 24);
        } else {
            v1 = vt;
            uint64_t d = (v02 - sq64(vt)) / (two_a ? two_a : 1u);
            ds = d > L - s0 ? L - s0 : (uint32_t)d;
        }
    } else {
        /* below the line: accelerate towards the nominal, or cruise; a
         * segment that would end above the line ends on it instead */
        v1 = v0 + dv < sg->vn_q4 ? v0 + dv : sg->vn_q4;
        if (v1 == 0)
            v1 = dv; /* at rest with a zero nominal: cannot happen, but move */
        ds = (uint32_t)(((uint64_t)(v0 + v1) * sg->g_q24) >> 24);
        if (ds == 0)
            ds = 1;
        uint32_t se = s0 + ds < L ? s0 + ds : L;
        if (sq64(v1) > ve2 + two_a * (L - se)) {
            /* where v^2 = v0^2 + 2a(s - s0) (or v0^2 if cruising) meets the
             * line: accelerate (or cruise) until there */
            uint64_t d;
            if (v1 > v0)
                d = (line0 - v02) / (2u * two_a);               /* the two lines meet */
            else
                d = (line0 - v02) / (two_a ? two_a : 1u);       /* cruise meets the line */
            if (d > L - s0)
                d = L - s0;
            ds = (uint32_t)d;
            if (ds == 0)
                ds = 1;
            v1 = v1 > v0 ? pk_isqrt64(v02 + two_a * ds) : v0;
            if (v1 > sg->vn_q4)
                v1 = sg->vn_q4;
        }
    }
    if (s0 + ds >= L) {
        /* the block ends inside this segment: end exactly there, at the speed
         * the constant acceleration reaches there */
        ds = L - s0;
        uint64_t e2 = v02;
        if (v1 > v0)
            e2 += two_a * ds;
        else if (v1 < v0)
            e2 = e2 > two_a * ds ? e2 - two_a * ds : 0;
        uint32_t vl = pk_isqrt64(e2);
        if (v1 > v0 && vl > v1)
            vl = v1;
        if (v1 < v0 && vl < v1)
            vl = v1;
        v1 = vl;
    }
    /* The segment's duration from its length (not the nominal seg_ticks: ds
     * is rounded down, and the time must be the time of the distance, or
     * the carry would put the rounding into the interval across the next
     * boundary). Every ds here is at most one segment's travel, < 2^20 µm
     * Q8, so 2 ds tick_q12 < 2^57. */
    const uint32_t vsum = (v0 + v1) ? v0 + v1 : 1u;
    const uint64_t seg_q16 = time_q16(sg, 2u * ds, vsum);
    uint32_t s1 = s0 + ds;
    /* the events in (s0, s1] at the segment's constant speed */
    uint32_t e0 = sg->e, e1 = ev_upto(b, s1);
    uint32_t n = e1 > e0 ? e1 - e0 : 0;
    uint32_t vrep = (uint32_t)(((uint64_t)v1 + 8u) >> 4);
    if (n > 0) {
        /* r = |v1 - v0| / vseg, Q15 (<= 2^16: the speed at most doubles or
         * halves around the mean) */
        const uint32_t dv_abs = v0 > v1 ? v0 - v1 : v1 - v0;
        const uint32_t r_q15 = div64_32((uint64_t)dv_abs << 16, vsum);
        uint64_t t_first = at_time(sg, ev_s(b, e0 + 1u) - s0, vsum, seg_q16, r_q15, v1 > v0);
        uint64_t t_last = at_time(sg, ev_s(b, e1) - s0, vsum, seg_q16, r_q15, v1 > v0);
        if (t_last > seg_q16)
            t_last = seg_q16;
        if (t_first > t_last)
            t_first = t_last;
        /* The n - 1 intervals after the first: their mean is span / (n - 1);
         * they ramp with the speed, the interval being inversely
         * proportional to it: from the mean, the change across the segment
         * is about mean (v0 - v1) / vseg (at most the mean either way, so
         * that every interval stays positive); the segment holds T / mean
         * intervals (a fraction: not n, which counts whole events), so
         * A = change mean / T per event. c1 is rounded so that the ramp never sums to more than the
         * span; what is left goes to the carry, so time stays exact. */
        int32_t c1 = 0, A = 0;
        uint64_t rem = 0;
        if (n > 1) {
            uint64_t span = t_last - t_first;
            uint32_t mean = div64_32(span, n - 1u);
            if (n > 2 && v0 != v1) {
                uint32_t ch = (uint32_t)(((uint64_t)mean * r_q15) >> 15);
                if (ch > mean)
                    ch = mean;
                int32_t a = (int32_t)div64_32((uint64_t)ch * mean, (uint32_t)seg_q16 | 1u);
                A = v1 > v0 ? -a : a;
            }
            /* c1 = mean - ceil(A n / 2) */
            int64_t an = (int64_t)A * (int64_t)n;
            int64_t q = an >= 0 ? (an + 1) / 2 : -((-an) / 2);
            c1 = (int32_t)((int64_t)mean - q);
            int64_t sum = (int64_t)(n - 1u) * c1 + (int64_t)A * (int64_t)((n * (n - 1u)) / 2u);
            rem = span - (uint64_t)sum;
        }
        if (!emit_events(sg, n, sg->carry_q16 + t_first, c1, A, vrep))
            return false;
        sg->carry_q16 = seg_q16 - t_last + rem;
    } else {
        sg->carry_q16 += seg_q16;
    }
    sg->v_q4 = v1;
    sg->v2 = sq64(v1) >> 4;   /* Q4 speed^2 for the planner */
    sg->e = e1;
    sg->s_q8 = s1;
    if (sg->hold && v1 == 0)
        sg->held = true;
    return true;
}

bool pk_sg_prep(struct pk_stepgen *sg, struct pk_mq *q, uint32_t max_blocks)
{
    bool added = false;
    for (;;) {
        if (sg->held)
            return added;
        struct pk_block *b = pk_mq_at(q, 0);
        if (b != NULL && max_blocks == 0)
            return added; /* waiting for a final plan */
        if (b == NULL) {
            if (sg->hold)
                sg->held = true; /* nothing left: the queue already ends at rest */
            return added;
        }
        if (b->type != PK_BLK_LINE) {
            struct pk_sg_chunk *c = ring_slot(sg);
            if (c == NULL)
                return added;
            if (sg->hold) {
                sg->held = true; /* a stop block: we are at rest here */
                return added;
            }
            c->kind = b->type == PK_BLK_PEN       ? PK_SGC_TOOL
                      : b->type == PK_BLK_SPINDLE ? PK_SGC_SPINDLE
                                                  : PK_SGC_WAIT;
            c->arg = b->tool;
            c->spindle = b->spindle;
            uint64_t w = (uint64_t)b->wait_ms * sg->tick_hz / 1000u; /* < 2^27 * 2^24 */
            c->u.ticks = (uint32_t)(w > UINT32_MAX ? UINT32_MAX : w);
            ring_commit(sg);
            pk_mq_pop(q);
            max_blocks--;
            sg->v2 = 0;
            sg->v_q4 = 0;
            sg->carry_q16 = 0;
            added = true;
            continue;
        }
        sg->prep_active = true;
        if (!prep_line(sg, b))
            return added;
        added = true;
        if (sg->e >= b->events) {
            pk_mq_pop(q);
            max_blocks--;
            sg->prep_active = false;
            sg->blk_sent = false;
            sg->e = 0;
            sg->s_q8 = 0;
        }
    }
}

int pk_sg_kill(struct pk_stepgen *sg, const struct pk_hal *hal)
{
    uint32_t tok = pk_hal_irq_save(hal);
    int pulse = sg->busy && sg->phase == PK_SGP_PULSE && sg->alarm == 0;
    if (pulse) {
        /* empty the ring and end the chunk under way: after the pulse the
         * callback stops (kill), so nothing more is emitted */
        sg->kill = 1;
        sg->left = 0;
        sg->tail = sg->head;
    }
    pk_hal_irq_restore(hal, tok);
    if (pulse) {
        sg->prep_active = false;
        sg->blk_sent = false;
        sg->hold = false;
        sg->held = false;
        sg->e = 0;
        sg->s_q8 = 0;
        sg->v2 = 0;
        sg->v_q4 = 0;
        sg->carry_q16 = 0;
        return 1;
    }
    if (hal->ops->timer_stop)
        (void)hal->ops->timer_stop(hal->ctx);
    pk_sg_flush(sg);
    return 0;
}

void pk_sg_flush(struct pk_stepgen *sg)
{
    sg->head = 0u;
    sg->tail = 0u;
    sg->prep_active = false;
    sg->blk_sent = false;
    sg->hold = false;
    sg->held = false;
    sg->e = 0;
    sg->s_q8 = 0;
    sg->v2 = 0;
    sg->v_q4 = 0;
    sg->carry_q16 = 0;
    sg->phase = PK_SGP_GAP;
    sg->left = 0;
    sg->mask_due = 0;
    sg->busy = false;
    sg->kill = 0;
    sg->alarm = 0;
    sg->v_um_s = 0u;
}

/* ------------------------------------------------------------------ ISR */

static uint64_t isr_alarm(struct pk_stepgen *sg, uint8_t why)
{
    sg->alarm = why;
    sg->v_um_s = 0u;
    sg->busy = false;
    return 0;
}

uint64_t pk_sg_isr(struct pk_stepgen *sg, const struct pk_hal *hal, uint64_t now)
{
    const uint32_t all = (1u << sg->axes) - 1u;
    if ((sg->alarm) != 0)
        return isr_alarm(sg, sg->alarm);
    if (sg->restart) {
        sg->restart = false;
        if (sg->next_q16 < (now << 16))
            sg->next_q16 = now << 16;
    }
    if (sg->phase == PK_SGP_STEP_DUE) {
        uint32_t mask = 0;
        for (unsigned i = 0; i < sg->axes; i++) {
            sg->acc[i] += (int32_t)sg->inc[i];
            if (sg->acc[i] >= 0) {
                sg->acc[i] -= (int32_t)sg->period;
                mask |= 1u << i;
            }
        }
        if (pk_hal_step_write(hal, all, mask) != 0)
            return isr_alarm(sg, PK_ALARM_STEP_WRITE);
        for (unsigned i = 0; i < sg->axes; i++)
            if (mask & (1u << i))
                sg->pos[i] += (sg->dir_cur & (1u << i)) ? 1 : -1;
        sg->phase = PK_SGP_PULSE;
        return now + sg->pulse_ticks;
    }
    if (sg->phase == PK_SGP_PULSE) {
        if (pk_hal_step_write(hal, all, 0u) != 0)
            return isr_alarm(sg, PK_ALARM_STEP_WRITE);
        sg->phase = PK_SGP_GAP;
        if (sg->kill) {
            /* a reset came while this pulse was high: it has had its full
             * width, the line is low, stop here */
            sg->kill = 0;
            sg->v_um_s = 0u;
            sg->busy = false;
            return 0;
        }
    }
    uint64_t earliest = now;
    while (sg->left == 0) {
        uint8_t t = sg->tail;
        uint8_t h = sg->head;
        PK_BARRIER(); /* read the chunk only after seeing it published */
        if (t == h) {
            sg->v_um_s = 0u;
            sg->busy = false;
            return 0;
        }
        const struct pk_sg_chunk *c = &sg->ring[t & SG_MASK];
        switch (c->kind) {
        case PK_SGC_BLOCK:
            if (c->spindle != sg->spindle_cur) {
                int r = pk_hal_spindle_write(hal, c->spindle);
                if (r != 0 && r != PK_HAL_ENOSYS)
                    return isr_alarm(sg, PK_ALARM_SPINDLE_WRITE);
                sg->spindle_cur = c->spindle;
            }
            for (unsigned i = 0; i < sg->axes; i++) {
                sg->inc[i] = c->u.blk.inc[i];
                sg->acc[i] = c->u.blk.acc0[i];
            }
            sg->period = c->u.blk.period;
            if (c->arg != sg->dir_cur) {
                if (pk_hal_dir_write(hal, all, c->arg) != 0)
                    return isr_alarm(sg, PK_ALARM_DIR_WRITE);
                sg->dir_cur = c->arg;
                earliest = now + sg->dir_setup_ticks;
            }
            break;
        case PK_SGC_STEPS:
            /* first interval c0, then c1 changing by c2 per event: the
             * difference c0 - c1 is added once here, so that every event
             * below is the same two adds */
            sg->left = c->n;
            sg->next_q16 += (uint64_t)((int64_t)c->u.st.c0 - c->u.st.c1);
            sg->I = c->u.st.c1;
            sg->A = c->u.st.c2;
            sg->v_um_s = c->v_um_s;
            break;
        case PK_SGC_SLOW:
            /* one event after a long interval: the recurrence's first term
             * is added as whole ticks + fraction (no A, B) */
            sg->left = 1;
            sg->next_q16 += ((uint64_t)c->u.ticks << 16) | c->n;
            sg->I = 0;
            sg->A = 0;
            sg->v_um_s = c->v_um_s;
            break;
        default: {
            if (c->kind == PK_SGC_TOOL && pk_hal_tool_write(hal, c->arg) != 0)
                return isr_alarm(sg, PK_ALARM_TOOL_WRITE);
            if (c->kind == PK_SGC_SPINDLE) {
                int r = pk_hal_spindle_write(hal, c->spindle);
                if (r != 0 && r != PK_HAL_ENOSYS)
                    return isr_alarm(sg, PK_ALARM_SPINDLE_WRITE);
                sg->spindle_cur = c->spindle;
            }
            uint64_t until = now + c->u.ticks;
            sg->v_um_s = 0u;
            PK_BARRIER();
            sg->tail = (uint8_t)(t + 1u);
            sg->next_q16 = until << 16;
            return until > now ? until : now + 1u;
        }
        }
        PK_BARRIER(); /* done reading the slot before handing it back */
        sg->tail = (uint8_t)(t + 1u);
    }
    sg->next_q16 += (uint64_t)(int64_t)sg->I;
    sg->I += sg->A;
    sg->left--;
    uint64_t at = (sg->next_q16 + 0x8000u) >> 16;
    if (at < earliest)
        at = earliest;
    if (at == 0)
        at = 1;
    sg->phase = PK_SGP_STEP_DUE;
    return at;
}
