/*
 * pk_stepgen.c — chunk preparation (main loop) and pulse emission (timer
 * callback). See pk_stepgen.h for the scheme; the kinematics are below.
 *
 * Speed profile inside a block, as speed^2 against distance s (µm Q8) from
 * the block start, anchored at the prepared state (s0, v2_0):
 *
 *   normal:  v2(s) = min(v2_0 + 2a(s - s0),  v2_nom,  v2_exit + 2a(L - s))
 *   hold:    v2(s) = max(0, v2_0 - 2a(s - s0))
 *
 * Each piece is linear in s, i.e. constant acceleration, for which the time
 * over [sa, sb] is exactly 2 (sb - sa) / (va + vb). The time between two
 * events is summed over the pieces between them (breakpoints included), with
 * one integer square root per point. Units: v in µm/s Q2 (sqrt of the Q4
 * square), time in ticks Q16:
 *
 *   dt_q16 = ds_q8 * tick_hz * 2^11 / (va_q2 + vb_q2)
 *
 * ds_q8 of one chunk <= 64 events * (sqrt(3) mm / 1 step) < 2^25 at the
 * minimum 1 step/mm, tick_hz <= 2^25 (validated at init): product < 2^61.
 */
#include <string.h>
#include "pk_stepgen.h"
#include "pk_motion.h"

#define SG_MASK (PK_SG_CHUNKS - 1u)

/* ------------------------------------------------------------------ prep */

struct profile {
    uint32_t s0, L;            /* µm Q8 */
    pk_v2_q4_t v2_0, v2_nom, v2_exit;
    uint32_t a;
    bool hold;
};

/* 2a * ds in Q4 (ds in µm Q8) */
static pk_v2_q4_t two_a(uint32_t a, uint64_t ds_q8) { return ((uint64_t)a * ds_q8) >> 3; }
/* ds (µm Q8) over which speed^2 changes by dv2 (Q4) at accel a */
static uint64_t ds_for(uint32_t a, pk_v2_q4_t dv2) { return (dv2 << 3) / a; }

static pk_v2_q4_t prof_v2(const struct profile *p, uint32_t s)
{
    uint64_t ds = s - p->s0;
    if (p->hold) {
        pk_v2_q4_t d = two_a(p->a, ds);
        return d >= p->v2_0 ? 0 : p->v2_0 - d;
    }
    pk_v2_q4_t v;
    if (p->v2_0 > p->v2_nom) {
        /* above the nominal (an override lowered it): decelerate down to it */
        pk_v2_q4_t d = two_a(p->a, ds);
        v = d >= p->v2_0 - p->v2_nom ? p->v2_nom : p->v2_0 - d;
    } else {
        v = p->v2_0 + two_a(p->a, ds);
        if (p->v2_nom < v)
            v = p->v2_nom;
    }
    pk_v2_q4_t dec = p->v2_exit + two_a(p->a, (uint64_t)(p->L - s));
    return dec < v ? dec : v;
}

/* Breakpoints of the profile after s0 (ascending, < L); returns count (<= 2). */
static unsigned prof_breaks(const struct profile *p, uint32_t bp[2])
{
    unsigned n = 0;
    if (p->hold) {
        uint64_t st = p->s0 + ds_for(p->a, p->v2_0);
        if (st < p->L)
            bp[n++] = (uint32_t)st;
        return n;
    }
    /* accel (or, above the nominal, decel) line meets the nominal, decel line leaves it */
    uint64_t s1 = p->s0 + (p->v2_nom > p->v2_0   ? ds_for(p->a, p->v2_nom - p->v2_0)
                           : p->v2_0 > p->v2_nom ? ds_for(p->a, p->v2_0 - p->v2_nom)
                                                 : 0);
    uint64_t dd = p->v2_nom > p->v2_exit ? ds_for(p->a, p->v2_nom - p->v2_exit) : 0;
    uint64_t s2 = dd < (uint64_t)p->L - p->s0 ? p->L - dd : p->s0;
    if (s1 <= s2) {
        if (s1 > p->s0 && s1 < p->L)
            bp[n++] = (uint32_t)s1;
        if (s2 > s1 && s2 < p->L)
            bp[n++] = (uint32_t)s2;
    } else if (p->v2_0 > p->v2_nom) {
        /* still above the nominal where the final deceleration starts: both
         * lines have slope -2a, so the lower one rules throughout: no corner */
    } else {
        /* triangle: v2_0 + 2a(x - s0) = v2_exit + 2a(L - x) */
        int64_t num = (int64_t)ds_for(p->a, p->v2_exit) - (int64_t)ds_for(p->a, p->v2_0)
                      + (int64_t)p->L + (int64_t)p->s0;
        int64_t x = num / 2;
        if (x > (int64_t)p->s0 && x < (int64_t)p->L)
            bp[n++] = (uint32_t)x;
    }
    return n;
}

static uint32_t v_q2(pk_v2_q4_t v2) { return pk_isqrt64(v2); }

static int64_t piece_q16(uint32_t tick_hz, uint32_t sa, uint32_t sb, uint32_t va, uint32_t vb)
{
    uint64_t vs = (uint64_t)va + vb;
    if (vs == 0)
        vs = 1;
    return (int64_t)(((uint64_t)(sb - sa) * tick_hz * 2048u) / vs);
}

/* Exact (to rounding) time from sa to sb, ticks Q16. */
static int64_t prof_time(const struct profile *p, uint32_t tick_hz, uint32_t sa, uint32_t sb)
{
    uint32_t bp[2];
    unsigned nb = prof_breaks(p, bp);
    int64_t t = 0;
    uint32_t s = sa, v = v_q2(prof_v2(p, sa));
    for (unsigned i = 0; i < nb; i++) {
        if (bp[i] <= sa || bp[i] >= sb)
            continue;
        uint32_t vb = v_q2(prof_v2(p, bp[i]));
        t += piece_q16(tick_hz, s, bp[i], v, vb);
        s = bp[i];
        v = vb;
    }
    t += piece_q16(tick_hz, s, sb, v, v_q2(prof_v2(p, sb)));
    return t;
}

static uint32_t ev_s(const struct pk_block *b, uint32_t k)
{
    return (uint32_t)(((uint64_t)k * b->len_q8) / b->events);
}

void pk_sg_init(struct pk_stepgen *sg, uint8_t axes, uint32_t tick_hz, uint32_t pulse_ticks,
                uint32_t dir_setup_ticks)
{
    memset(sg, 0, sizeof *sg);
    sg->axes = axes;
    sg->tick_hz = tick_hz;
    sg->pulse_ticks = pulse_ticks ? pulse_ticks : 1u;
    sg->dir_setup_ticks = dir_setup_ticks;
    sg->chunk_ticks_max = tick_hz / 500u; /* 2 ms */
    if (sg->chunk_ticks_max > PK_SG_CHUNK_TICKS_MAX)
        sg->chunk_ticks_max = PK_SG_CHUNK_TICKS_MAX;
    if (sg->chunk_ticks_max == 0)
        sg->chunk_ticks_max = 1;
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
    if (!hold)
        sg->held = false;
}

void pk_sg_plan_state(const struct pk_stepgen *sg, struct pk_mq *q, pk_v2_q4_t *v2_now,
                      uint32_t *rem_q8)
{
    struct pk_block *b = pk_mq_at(q, 0);
    *v2_now = sg->v2;
    *rem_q8 = 0;
    if (b != NULL && b->type == PK_BLK_LINE)
        *rem_q8 = b->len_q8 - (sg->prep_active ? sg->s_q8 : 0u);
}

/* Fit I, A, B to first interval e1, last en and total S over n events
 * (ticks Q16; every interval of a chunk of two or more events is below
 * PK_SG_CHUNK_TICKS_MAX ticks, so all three fit 32 bits). */
struct fit3 { int64_t c0, c1, c2; };

static void fit(struct fit3 *c, uint32_t n, int64_t e1, int64_t en, int64_t S)
{
    int64_t N = n;
    c->c0 = c->c1 = c->c2 = 0;
    if (e1 < 1)
        e1 = 1;
    if (n == 1) {
        c->c0 = S < 1 ? 1 : S;
        return;
    }
    c->c0 = e1;
    if (n == 2) {
        c->c1 = S - 2 * e1;
        return;
    }
    int64_t X = en - e1, Y = S - N * e1;
    int64_t den = N * (N - 1) * (N - 2);
    c->c2 = pk_div_round64(6 * N * X - 12 * Y, den);
    c->c1 = pk_div_round64(X - c->c2 * (N - 1) * (N - 2) / 2, N - 1);
    /* Re-verify: every interval of the recurrence must be positive (the
     * chunk sizing keeps the speed change within ~6%, so the quadratic is
     * nearly flat; this only guards against a pathological fit). Otherwise
     * fall back to the linear fit (first interval and total). */
    int64_t I = c->c0, A = c->c1;
    for (uint32_t j = 0; j < n; j++) {
        if (I < 1) {
            c->c2 = 0;
            c->c1 = (2 * (S - N * e1)) / (N * (N - 1));
            return;
        }
        I += A;
        A += c->c2;
    }
}

static int64_t fit_sum(const struct fit3 *c, uint32_t n)
{
    int64_t N = n;
    return N * c->c0 + c->c1 * (N * (N - 1) / 2) + c->c2 * (N * (N - 1) * (N - 2) / 6);
}

/* Cut the next chunk of the tail LINE block b. Returns false if none (held). */
static bool prep_line(struct pk_stepgen *sg, struct pk_block *b, struct pk_sg_chunk *c)
{
    if (sg->e == 0 && !sg->blk_sent) {
        /* the block's own slot first: directions, spindle, Bresenham */
        c->kind = PK_SGC_BLOCK;
        c->arg = b->dir_mask;
        c->spindle = b->spindle;
        memcpy(c->u.blk.inc, b->inc, sizeof c->u.blk.inc);
        memcpy(c->u.blk.acc0, b->acc0, sizeof c->u.blk.acc0);
        c->u.blk.period = b->period;
        sg->blk_sent = true;
        return true;
    }
    struct profile p;
    p.s0 = sg->s_q8;
    p.L = b->len_q8;
    p.v2_0 = sg->v2;
    p.v2_nom = b->v2_nom;
    p.v2_exit = b->v2_exit;
    p.a = b->accel;
    p.hold = sg->hold;
    const uint32_t N = b->events, e = sg->e;

    uint32_t n_max = N - e;
    if (n_max > PK_SG_MAX_EVENTS)
        n_max = PK_SG_MAX_EVENTS;
    if (p.hold) {
        uint64_t st = p.s0 + ds_for(p.a, p.v2_0);
        if (st < p.L) {
            /* last event at or before the stop point */
            uint64_t kst = (st * N) / p.L;
            while (kst > e && ev_s(b, (uint32_t)kst) > st)
                kst--;
            if (kst <= e) {
                sg->v2 = 0;
                sg->held = true;
                return false;
            }
            if (kst - e < n_max)
                n_max = (uint32_t)(kst - e);
        }
    }
    /* stay inside one phase: up to the first breakpoint after s0 */
    uint32_t bp[2];
    unsigned nb = prof_breaks(&p, bp);
    uint32_t n = n_max;
    for (unsigned i = 0; i < nb; i++) {
        if (bp[i] <= p.s0)
            continue;
        uint64_t kb = ((uint64_t)bp[i] * N) / p.L;
        uint32_t nk = kb > e ? (uint32_t)(kb - e) : 1u;
        if (nk < n)
            n = nk;
        break;
    }
    /* speed may change by at most ~6% (v^2 by 1/8) within a chunk */
    pk_v2_q4_t v2_here = prof_v2(&p, p.s0);
    pk_v2_q4_t v2_next = prof_v2(&p, ev_s(b, e + 1));
    if (v2_next != v2_here) {
        uint64_t ds = ds_for(p.a, v2_here / 8u);
        uint64_t nk = (ds * N) / p.L;
        if (nk < 1)
            nk = 1;
        if (nk < n)
            n = (uint32_t)nk;
    }
    /* and last at most chunk_ticks_max (approximately) */
    uint32_t vq = v_q2(v2_next > v2_here ? v2_next : v2_here);
    {
        /* events in T ticks at speed v: T * v / (tick_hz * d); d = L/N */
        uint64_t num = (uint64_t)sg->chunk_ticks_max * vq * N;       /* < 2^16*2^22*2^25 */
        uint64_t den = (uint64_t)sg->tick_hz * 4u * ((uint64_t)p.L >> 8 ? (uint64_t)p.L >> 8 : 1u);
        uint64_t nk = num / den;
        if (nk < 1)
            nk = 1;
        if (nk < n)
            n = (uint32_t)nk;
    }
    if (n < 1)
        n = 1;

    uint32_t sa = p.s0, s1 = ev_s(b, e + 1), sl = ev_s(b, e + n - 1), sb = ev_s(b, e + n);
    int64_t e1 = prof_time(&p, sg->tick_hz, sa, s1);
    if (n > 1 && e1 >= ((int64_t)PK_SG_CHUNK_TICKS_MAX << 16)) {
        /* the estimate said several events, the exact time says one is long
         * already: cut at one (the slow path below) */
        n = 1;
        sl = sa;
        sb = s1;
    }
    int64_t en = n > 1 ? prof_time(&p, sg->tick_hz, sl, sb) : e1;
    int64_t S = n > 1 ? prof_time(&p, sg->tick_hz, sa, sb) : e1;
    struct fit3 f;
    fit(&f, n, e1 - sg->lag_q16, en, S - sg->lag_q16);
    if (n == 1 && f.c0 >= ((int64_t)1 << 30)) {
        /* one event after a long interval: whole ticks + a Q16 fraction */
        c->kind = PK_SGC_SLOW;
        c->u.ticks = (uint32_t)(f.c0 >> 16 > UINT32_MAX ? UINT32_MAX : f.c0 >> 16);
        c->n = (uint16_t)(f.c0 & 0xffff);
        sg->lag_q16 += (((int64_t)c->u.ticks << 16) | c->n) - S;
    } else {
        c->kind = PK_SGC_STEPS;
        c->n = (uint16_t)n;
        c->u.st.c0 = (int32_t)f.c0;
        c->u.st.c1 = (int32_t)f.c1;
        c->u.st.c2 = (int32_t)f.c2;
        sg->lag_q16 += fit_sum(&f, n) - S;
    }
    sg->v2 = prof_v2(&p, sb);
    c->v_um_s = v_q2(sg->v2) / 4u;
    sg->e = e + n;
    sg->s_q8 = sb;
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
        struct pk_sg_chunk *c = ring_slot(sg);
        if (c == NULL)
            return added;
        if (b->type != PK_BLK_LINE) {
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
            sg->lag_q16 = 0;
            added = true;
            continue;
        }
        sg->prep_active = true;
        if (!prep_line(sg, b, c))
            return added;
        ring_commit(sg);
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
        sg->lag_q16 = 0;
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
    sg->lag_q16 = 0;
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
            sg->left = c->n;
            sg->I = c->u.st.c0;
            sg->A = c->u.st.c1;
            sg->B = c->u.st.c2;
            sg->v_um_s = c->v_um_s;
            break;
        case PK_SGC_SLOW:
            /* one event after a long interval: the recurrence's first term
             * is added as whole ticks + fraction (no A, B) */
            sg->left = 1;
            sg->next_q16 += ((uint64_t)c->u.ticks << 16) | c->n;
            sg->I = 0;
            sg->A = 0;
            sg->B = 0;
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
    sg->A += sg->B;
    sg->left--;
    uint64_t at = (sg->next_q16 + 0x8000u) >> 16;
    if (at < earliest)
        at = earliest;
    if (at == 0)
        at = 1;
    sg->phase = PK_SGP_STEP_DUE;
    return at;
}
