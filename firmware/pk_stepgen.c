/*
 * pk_stepgen.c — chunk preparation (main loop) and pulse emission (timer
 * callback). See pk_stepgen.h for the scheme; the kinematics are below.
 *
 * Segments of constant time. The main loop cuts the tail block into
 * segments of seg_ticks (1/PK_SG_SEG_HZ: 2 ms by default, at most 2^14 ticks), like Grbl's segment
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
#include <stddef.h>
#include <string.h>
#include "pk_stepgen.h"
#include "pk_motion.h"
#define PK_SG_PULSE_BODIES /* the out-of-line pulse paths of a PK_SG_HW_PULSE build */
#include "pk_sg_step.h"
#include "pk_sg_div.h"

#define SG_MASK (PK_SG_CHUNKS - 1u)

/* PK_FLASH_FIRST=1 (pk_munits.h; the Uno): the chunk
 * preparation's helpers stay out of line although this file is compiled for
 * speed (its step path is): each is called from a few places per segment, so
 * inlining them copies their 64-bit sequences into every caller for a few
 * calls' worth of cycles. The results are the same either way. */
#if PK_FLASH_FIRST && (defined(__GNUC__) || defined(__clang__))
#define SG_PREP __attribute__((noinline))
#else
#define SG_PREP
#endif

/* ------------------------------------------------------------------ prep */

/* x >> b (b a constant, 0 < b < 32) as a byte move and a shift of the word
 * or byte that holds the bits kept: an 8-bit core's shift of a 32-bit word
 * by a constant is otherwise a loop of b 4-byte steps (~7 cycles a bit, at
 * -Os and -O2 alike), ~100 cycles for the >> 14 of a Q30 product. Exact for
 * every x; on a flash-first board the plain shift (the loop is smaller). */
static inline uint32_t shr32(uint32_t x, unsigned b)
{
#if PK_FLASH_FIRST
    return x >> b;
#else
    if (b > 24u)
        return (uint32_t)((uint8_t)(x >> 24) >> (b - 24u));
    if (b > 16u)
        return (uint32_t)((uint16_t)(x >> 16) >> (b - 16u));
    if (b > 8u && b < 16u)
        return ((x >> 16) << (16u - b)) | (uint32_t)((uint8_t)(x >> 8) >> (b - 8u));
    return x >> b;
#endif
}

/* Squares of speeds, (µm/s)^2 Q8. */
static SG_PREP uint64_t sq64(uint32_t v) { return (uint64_t)v * v; }

/* The speed^2 lines, one helper per 64-bit form (each called from several
 * places: out of line on a flash-first board, where every 64-bit operation
 * inlined costs tens of bytes): base + a b, and base - a b at least 0
 * (base < 2^55, a b < 2^62: pk_munits.h). */
static SG_PREP uint64_t mac64(uint64_t base, uint32_t a, uint32_t b)
{
    return base + (uint64_t)a * b;
}

static SG_PREP uint64_t msub64(uint64_t base, uint32_t a, uint32_t b)
{
    const uint64_t ab = (uint64_t)a * b;
    return base > ab ? base - ab : 0u;
}

/* floor((hi 2^32 + lo) / d) for 0 < d <= 2^31, UINT32_MAX where it does not
 * fit 32 bits: shift and subtract on an 8-bit core (pk_sg_div.h: a bit a
 * step, ~850 AVR cycles at most against ~1,900-2,500 for libgcc's 64-bit
 * division), the C division elsewhere. */
static SG_PREP uint32_t div32_sat(uint32_t hi, uint32_t lo, uint32_t d)
{
#if PK_SOFT_DIV
    return pk_sg_div32_soft(hi, lo, d);
#else
    const uint64_t q = (((uint64_t)hi << 32) | lo) / d;
    return q > UINT32_MAX ? UINT32_MAX : (uint32_t)q;
#endif
}

/* floor(num / den) (0 < den <= 2^31), at most lim (a quotient of 2^32 or
 * more is above every lim). */
static SG_PREP uint32_t div64_max(uint64_t num, uint32_t den, uint32_t lim)
{
    const uint32_t q = div32_sat((uint32_t)(num >> 32), (uint32_t)num, den);
    return q > lim ? lim : q;
}

/* a b / 2^24 rounded to nearest (a segment's length from its speed sum:
 * below 2^32 since a segment spans at most 2^14 ticks at < 2^20 µm/s). */
static SG_PREP uint32_t mul_q24_round(uint32_t a, uint32_t b)
{
    return (uint32_t)(((uint64_t)a * b + 0x800000u) >> 24);
}

/* A segment's clock: the time (ticks Q16) to cover d (µm Q8) at the mean
 * speed vsum / 2 (µm/s Q4) is d num / vsum, num = tick_hz 2^13 (< 2^37,
 * tick_hz <= 2^24). One division per segment (none while cruising: the
 * clock is kept while vsum stays) gives the factor as a 32-bit mantissa kq
 * and a byte shift ks in {0, 8, 16, 24}, so every time in the segment is one
 * 32x32 product and a byte shift: (d kq) >> ks. ks is the largest that
 * keeps kq below 2^32, so kq has at least 24 significant bits wherever
 * num / vsum >= 1 (speeds below 8 km/s). (d kq) >> ks is the time of d, and
 * every d here is within one segment: the product stays below 2^56. */
static SG_PREP void clock_set(struct pk_stepgen *sg, uint32_t vsum)
{
    if (vsum == sg->ck_vsum)
        return;
    sg->ck_vsum = vsum;
    /* kq = tick_hz 2^(13 + ks) / vsum < 2^32 <=> vsum > tick_hz 2^(ks - 19),
     * i.e. vsum > hi below (f 2^5 < 2^29, and 2^k v > f <=> v > floor(f / 2^k)) */
    const uint32_t f = sg->tick_hz;
    /* f 2^(13 + ks) = hi 2^32 + lo, divided in 32-bit words (vsum < 2^25:
     * two speeds < 2^24); from ks = 24 down, (hi, lo) shifted a byte at a
     * time (byte moves on an 8-bit core, where f << 29 was a 29-step loop);
     * the quotient saturates only at ks = 0, for vsum < 2^13 (below 0.5 mm/min) */
    uint8_t ks = 24u;
    uint32_t hi = f << 5, lo = 0u;
    while (ks > 0u && vsum <= hi) {
        lo = (lo >> 8) | (hi << 24);
        hi >>= 8;
        ks = (uint8_t)(ks - 8u);
    }
    sg->ck_kq = div32_sat(hi, lo, vsum);
    sg->ck_ks = ks;
}

static SG_PREP uint64_t clock_time(const struct pk_stepgen *sg, uint32_t d_q8)
{
    uint64_t p = (uint64_t)d_q8 * sg->ck_kq;
    switch (sg->ck_ks) {
    case 24: return p >> 24;
    case 16: return p >> 16;
    case 8: return p >> 8;
    default: return p;
    }
}

/* When a segment of T whole ticks (invT_q30 = 2^30 / T) that covers its
 * distance at the mean speed vseg reaches a point that the mean speed reaches
 * at tau (ticks Q16). The segment really accelerates (or decelerates)
 * uniformly from v0 to v1, which puts the point later (earlier) by
 *     eps = a tau (T - tau) / (2 v(tau)),   a = (v1 - v0) / T,
 * i.e. with r = |v1 - v0| / vseg and u = tau / T:
 *     eps = r T u (1 - u) / 2 . vseg / v(tau),
 * and vseg / v(tau) = 1 -+ r (2u - 1) / 2 to first order (the rest is
 * second order in r, the speed's relative change over one segment: a few
 * percent). Without it the events next to a segment boundary are off by up
 * to r T / 8 against the interval ramp inside the segment: a jolt at every
 * boundary.
 * All in 32-bit products (an 8-bit chip's 64-bit multiply costs ~430
 * cycles): t < T < 2^15 + 2^14, so t invT_q30 = 2^30 t / T < 2^30 and
 * u_q16 < 2^16; u (1 - u) <= 1/4: w_q16 <= 2^14; r_q15 <= 2^16 (clamped
 * below 2^16 where a product needs it), so r w <= 2^30 and (r w / 2^14) T
 * < 2^31; eps < r T / 8 <= 2^28 (Q16). */
static SG_PREP uint64_t at_time(uint64_t tau64, uint32_t T, uint32_t invT_q30, uint32_t r_q15, bool accel)
{
    /* ((tau64 >> 16) >= T, with the 64-bit shift only above 2^32: on an
     * 8-bit core a 64-bit shift is a library loop) */
    if (T == 0 || r_q15 == 0)
        return tau64;
    if (tau64 > UINT32_MAX ? T < 0x10000u || (tau64 >> 16) >= T : ((uint32_t)tau64 >> 16) >= T)
        return tau64;
    /* from here tau < T 2^16 < 3 2^30 (T below): 32 bits, and so is the
     * result (eps < 2^28) */
    const uint32_t tau = (uint32_t)tau64, t = tau >> 16;
    if (r_q15 > 0xFFFFu)
        r_q15 = 0xFFFFu;
    /* (r_q15 < 2^16 and w_q16 < 2^16: a 16x16 product) */
    uint32_t u_q16 = shr32(t * invT_q30, 14u);
    uint32_t w_q16 = (uint32_t)(uint16_t)u_q16 * (uint16_t)(0x10000u - u_q16) >> 16;
    uint32_t eps = (shr32((uint32_t)(uint16_t)r_q15 * (uint16_t)w_q16, 14u) * T) >> 2;
    /* first-order term: eps r |2u - 1| / 2 = (eps / 2^12) (r m / 2^20),
     * m_q16 = |2u - 1| */
    uint32_t m_q16 = 2u * u_q16 > 0x10000u ? 2u * u_q16 - 0x10000u : 0x10000u - 2u * u_q16;
    if (m_q16 > 0xFFFFu)
        m_q16 = 0xFFFFu;
    uint32_t k = shr32((uint32_t)(uint16_t)r_q15 * (uint16_t)m_q16, 20u);   /* Q11 */
    uint32_t fix = shr32(eps, 12u) * k;
    if ((2u * u_q16 > 0x10000u) == accel)
        eps = eps > fix ? eps - fix : 0u;
    else
        eps += fix;
    if (accel)
        return (uint64_t)(tau + eps);
    return tau > eps ? tau - eps : 0u;
}

/* The times of the first and the last event of a segment (d_first, d_last
 * µm Q8 into it): at_time of their times at the mean speed, within the
 * segment's time seg_q16 and in order. */
static SG_PREP void ev_span(const struct pk_stepgen *sg, uint32_t d_first, uint32_t d_last,
                            uint64_t seg_q16, uint32_t T, uint32_t invT_q30, uint32_t r_q15,
                            bool accel, uint64_t t[2])
{
    uint64_t t_first = at_time(clock_time(sg, d_first), T, invT_q30, r_q15, accel);
    uint64_t t_last = at_time(clock_time(sg, d_last), T, invT_q30, r_q15, accel);
    if (t_last > seg_q16)
        t_last = seg_q16;
    if (t_first > t_last)
        t_first = t_last;
    t[0] = t_first;
    t[1] = t_last;
}

/* 2^30 / T, T whole ticks (>= 1). */
static SG_PREP uint32_t inv_q30(uint32_t T) { return ((uint32_t)1 << 30) / (T ? T : 1u); }

/* |dv| / (vsum / 2) in Q15, for 0 <= dv <= vsum: both scaled to 16 bits
 * so that the division is 32-bit (dv <= vsum < 2^16 after it: a 16-step
 * division of 16-bit words on an 8-bit core, ~250 AVR cycles against ~650
 * for libgcc's 32-bit one; a flash-first board keeps the library's, already
 * linked). */
static SG_PREP uint32_t ratio_q15(uint32_t dv, uint32_t vsum)
{
    while (vsum >= 65536u) {
        vsum >>= 1;
        dv >>= 1;
    }
    if (vsum == 0u)
        vsum = 1u;
#if PK_SOFT_DIV && !PK_FLASH_FIRST
    if (dv <= vsum)
        return pk_sg_frac_q16_soft((uint16_t)dv, (uint16_t)vsum);
#endif
    return (dv << 16) / vsum;
}

/* The block's cached speeds (isqrt only when the plan changed them). */
static SG_PREP bool blk_speeds(struct pk_stepgen *sg, const struct pk_block *b)
{
    bool nom = b->v2_nom != sg->c_v2_nom;
    if (nom) {
        sg->c_v2_nom = b->v2_nom;
        sg->vn_q4 = pk_isqrt64(b->v2_nom << 4);   /* Q4 speed^2 * 16 = (v Q4)^2 */
    }
    if (b->v2_exit != sg->c_v2_exit) {
        sg->c_v2_exit = b->v2_exit;
        sg->ve_q4 = pk_isqrt64(b->v2_exit << 4);
        sg->ve_sq = sq64(sg->ve_q4);
    }
    return nom;
}

void pk_sg_init(struct pk_stepgen *sg, uint8_t axes, uint32_t tick_hz, uint32_t pulse_ticks,
                uint32_t dir_setup_ticks)
{
    memset(sg, 0, sizeof *sg);
    sg->axes = axes;
    sg->bres = (uint8_t)((1u << axes) - 1u); /* (until the first block: every axis, as the sums say) */
    sg->tick_hz = tick_hz;
    sg->pulse_ticks = pulse_ticks ? pulse_ticks : 1u;
    sg->dir_setup_ticks = dir_setup_ticks;
    sg->seg_max = tick_hz / PK_SG_SEG_HZ; /* 2 ms by default */
    if (sg->seg_max > PK_SG_CHUNK_TICKS_MAX)
        sg->seg_max = PK_SG_CHUNK_TICKS_MAX;
    if (sg->seg_max < 16u)
        sg->seg_max = 16u;
    sg->seg_cap = tick_hz / PK_SG_SEG_CAP_HZ; /* 8 ms by default */
    if (sg->seg_cap > PK_SG_CHUNK_TICKS_MAX)
        sg->seg_cap = PK_SG_CHUNK_TICKS_MAX;
    if (sg->seg_cap < sg->seg_max)
        sg->seg_cap = sg->seg_max;
    /* per block with full-length segments: ds = vsum g, dv = accel kdv */
    /* (seg_max <= max(tick_hz / 50, 16): both quotients are below 2^32, so
     * the saturating helper gives the plain quotient) */
    sg->g_max_q24 = pk_muldiv_u32(8u * sg->seg_max, (uint32_t)1 << 24, tick_hz);
    sg->kdv_q24 = pk_muldiv_u32(16u * sg->seg_max, (uint32_t)1 << 24, tick_hz);
    sg->invT_max_q30 = inv_q30(sg->seg_max);
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

static SG_PREP struct pk_sg_chunk *ring_slot(struct pk_stepgen *sg)
{
    if (pk_sg_pending(sg) >= PK_SG_CHUNKS)
        return NULL;
    /* (not cleared: every writer sets all the fields the step path reads
     * for its kind (STEPS: n, u.st, v_um_s; SLOW: n, u.ticks, v_um_s;
     * BLOCK: arg, n, spindle, u.blk; TOOL, SPINDLE, WAIT: arg, spindle,
     * u.ticks), and nothing else reads the ring: the 30-byte memset was
     * ~250 AVR cycles a chunk) */
    uint8_t h = sg->head;
    return &sg->ring[h & SG_MASK];
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
 * recurrence's range; each goes on where the last one stopped. All or
 * nothing: the slots are written beyond the head and published together,
 * so a segment that does not fit leaves the ring as it was (returns false)
 * and is cut again, whole, once there is room. (Published one by one, a
 * segment that ran out of room half way had its first chunks out while the
 * caller kept its state: the next preparation sent them again, and again,
 * and the axis ran on past its target.) */
static SG_PREP bool emit_events(struct pk_stepgen *sg, uint32_t n, uint64_t first, int32_t c1, int32_t A,
                        uint32_t v_um_s)
{
    const uint8_t h = sg->head;
    const uint32_t room = PK_SG_CHUNKS - pk_sg_pending(sg);
    uint32_t used = 0;
    while (n > 0) {
        if (used == room)
            return false;  /* (nothing published) */
        struct pk_sg_chunk *c = &sg->ring[(uint8_t)(h + used) & SG_MASK];
        used++;
        c->v_um_s = v_um_s;
        if (first >= ((uint64_t)1 << 30)) {
            /* one event after a long interval: whole ticks + Q16 fraction */
            c->kind = PK_SGC_SLOW;
            uint64_t t = first >> 16;
            c->u.ticks = (uint32_t)(t > UINT32_MAX ? UINT32_MAX : t);
            c->n = (uint16_t)(first & 0xffffu);
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
        n -= k;
        c1 += (int32_t)k * A;
        first = (uint64_t)(int64_t)c1;
    }
    PK_BARRIER(); /* the chunks are written before they are published */
    sg->head = (uint8_t)(h + used);
    return true;
}

static SG_PREP void seg_setup(struct pk_stepgen *sg, const struct pk_block *b);

/* A LINE block's first segment: the block's own slot (directions,
 * spindle, Bresenham), then its segment length and speed steps. Returns false
 * if the ring has no room for the slot. */
static SG_PREP bool blk_start(struct pk_stepgen *sg, struct pk_block *b)
{
    /* the block's own slot first: directions, spindle, Bresenham */
    struct pk_sg_chunk *c = ring_slot(sg);
    if (c == NULL)
        return false;
    c->kind = PK_SGC_BLOCK;
    c->arg = b->dir_mask;
    c->spindle = b->spindle;
    memcpy(c->u.blk.inc, b->inc, sizeof c->u.blk.inc);
    memcpy(c->u.blk.acc0, b->acc0, sizeof c->u.blk.acc0);
    c->u.blk.period = 256u * b->events;   /* the Bresenham period (M <= 2^21) */
    /* the axes whose Bresenham step can fire (struct pk_stepgen.bres),
     * worked out here so that the block's switch in the ISR only copies */
    uint8_t bres = 0u;
    for (unsigned i = 0; i < sg->axes; i++)
        if (b->inc[i] != 0u || b->acc0[i] >= 0)
            bres |= (uint8_t)(1u << i);
    c->n = bres;
    ring_commit(sg);
    sg->blk_sent = true;
    sg->v2_blk = sg->v2;
    sg->off_plan = sg->hold;
    /* event k lies at lead + floor(k (L - lead) / M): stepped incrementally
     * below (the lead: moves without a whole step before the block, run
     * at its speed, no event in them; lead < L) */
    const uint32_t span = b->len_q8 - b->lead_q8;
    sg->ev_q = span / b->events;
    sg->ev_r = span - sg->ev_q * b->events; /* (one division, not two) */
    sg->ev_next = b->lead_q8 + sg->ev_q;
    sg->ev_rem = sg->ev_r;
    blk_speeds(sg, b);
    seg_setup(sg, b);
    return true;
}

/* The block's segment length and its speed step per segment, for the
 * nominal speed in force: at block start, and again when an override
 * changes the nominal inside the block (cut for the old one, a rise from
 * 10 % to 200 % put 20 times the events into a segment: more than the ring
 * could take at once, test_motion_steps). */
static SG_PREP void seg_setup(struct pk_stepgen *sg, const struct pk_block *b)
{
    /* The segment: seg_max (2 ms by default), or shorter so that at twice
     * the nominal speed (or at the speed it runs at now, if that is higher:
     * an override was lowered) a segment holds at most PK_SG_MAX_EVENTS
     * events: vtop seg_t <= PK_SG_MAX_EVENTS L / M, i.e. seg_t <=
     * 4 ev_q tick_hz / (vtop + 1) ticks with PK_SG_MAX_EVENTS = 64 (an
     * event spans at most 1 mm sqrt(3) at 1 step/mm: ev_q < 2^19, so the
     * products stay below 2^50). */
    uint32_t seg = sg->seg_max;
    /* room >= seg' (vtop + 1) <=> lim >= seg' for integers, lim = floor(room
     * / (vtop + 1)) (saturated: every seg' compared is below 2^17) */
    const uint64_t room = (uint64_t)sg->ev_q * (PK_SG_MAX_EVENTS / 16u) * sg->tick_hz;
    const uint32_t v2n = 2u * sg->vn_q4, vtop = sg->v_q4 > v2n ? sg->v_q4 : v2n;
    const uint32_t lim = div64_max(room, vtop + 1u, UINT32_MAX); /* v < 2^24 */
    if (lim < seg) {
        seg = lim < 16u ? 16u : lim;
        /* ds_q8 = (v0 + v1)_q4 * 8 seg / tick_hz (Q24); speed change per
         * segment a (µm/s^2) seg / tick_hz, Q4 */
        /* (seg <= seg_max: both quotients are far below 2^32, so the
         * saturating helpers give the plain quotients) */
        sg->g_q24 = pk_muldiv_u32(8u * seg, (uint32_t)1 << 24, sg->tick_hz);
        sg->dv_q4 = pk_muldiv_u32(b->accel, 16u * seg, sg->tick_hz);
    } else {
        sg->g_q24 = sg->g_max_q24;
        sg->dv_q4 = pk_mulshr_u32(b->accel, sg->kdv_q24, 24u);
    }
    if (sg->dv_q4 == 0)
        sg->dv_q4 = 1;
    sg->seg_ticks = seg;
    sg->invT_q30 = seg == sg->seg_max ? sg->invT_max_q30 : inv_q30(seg);
    /* longer segments (x2, x4) where the event limit and the recurrence's
     * range allow: see seg_level */
    uint8_t lv = 0;
    while (lv < PK_SG_SEG_LEVELS && (seg << (lv + 1u)) <= sg->seg_cap
           && lim >= (sg->seg_max << (lv + 1u)))
        lv++;
    sg->lvl_max = lv;
}

/* One segment of the tail LINE block, between its speed phase (seg_speeds)
 * and its events (seg_events): separate functions so that each keeps a small
 * stack frame (on an 8-bit core a frame beyond 64 bytes costs an address
 * adjustment at every access). */
struct sg_seg {
    uint32_t s0, v0, v1, ds;
    uint64_t v12;   /* v1^2 once known (0: not yet) */
    uint8_t lv;     /* segment length level */
    bool full;      /* a whole segment of seg_ticks (else a phase ends inside) */
};

/* The speed phase of the next segment: its level, end speed and length.
 * Returns false when a hold has come to rest (held). */
static SG_PREP bool seg_speeds(struct pk_stepgen *sg, const struct pk_block *b, struct sg_seg *sp)
{
    const uint32_t L = b->len_q8, s0 = sg->s_q8, v0 = sg->v_q4;
    const uint32_t two_a = 2u * (uint32_t)b->accel;     /* (µm/s)^2 Q8 per µm Q8, < 2^31 */
    const uint32_t ve = sg->hold ? 0u : sg->ve_q4;
    const uint64_t v02 = sg->v_sq, ve2 = sg->hold ? 0u : sg->ve_sq;
    /* the speed^2 the end of the block allows here: the line
     * v^2 = v_exit^2 + 2a(L - s) (a hold: v^2 = 0 + 2a(s_stop - s), i.e. decelerate now) */
    const uint64_t line0 = mac64(ve2, two_a, L - s0);
    /* the segment's length: the base one, doubled while the speed changes
     * by at most 1/2^PK_SG_RAMP_SHIFT of itself over it (the interval ramp
     * is a first-order model of the acceleration: its error grows as the
     * square of that change), and always at the longest while cruising */
    const bool cruise = !sg->hold && v0 == sg->vn_q4 && v02 < line0;
    uint8_t lv = sg->lvl_max;
    if (!cruise)
        while (lv > 0 && v0 < (sg->dv_q4 << (lv + PK_SG_RAMP_SHIFT)))
            lv--;
    const uint32_t dv = sg->dv_q4 << lv, g_q24 = sg->g_q24 << lv;
    uint32_t v1, ds;
    uint64_t v12 = 0;      /* v1^2 once known (0: not yet) */
    bool full = true;   /* a whole segment of seg_ticks (else a phase ends inside) */
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
            /* (rounded to nearest, here and below: rounding down would
             * bias every segment's acceleration up, rounding up would let a
             * long deceleration drift above its braking line) */
            ds = mul_q24_round(v0 + v1, g_q24);
        } else {
            v1 = vt;
            ds = div64_max(v02 - sq64(vt), two_a ? two_a : 1u, L - s0);
            full = false;
        }
    } else {
        /* below the line: accelerate towards the nominal, or cruise; a
         * segment that would end above the line ends on it instead */
        v1 = v0 + dv < sg->vn_q4 ? v0 + dv : sg->vn_q4;
        if (v1 == 0)
            v1 = dv; /* at rest with a zero nominal: cannot happen, but move */
        ds = mul_q24_round(v0 + v1, g_q24);
        if (ds == 0)
            ds = 1;
        uint32_t se = s0 + ds < L ? s0 + ds : L;
        v12 = sq64(v1);
        if (mac64(v12, two_a, se - s0) > line0) {
            /* where v^2 = v0^2 + 2a(s - s0) (or v0^2 if cruising) meets the
             * line: accelerate (or cruise) until there: the two lines
             * meet, or cruise meets the line ((line0 - v0^2) / 4a as
             * floor(floor(x / 2) / 2a), a divisor below 2^31) */
            const uint64_t gap = line0 - v02;
            ds = div64_max(v1 > v0 ? gap >> 1 : gap, two_a ? two_a : 1u, L - s0);
            if (ds == 0)
                ds = 1;
            v1 = v1 > v0 ? pk_isqrt64(mac64(v02, two_a, ds)) : v0;
            if (v1 > sg->vn_q4)
                v1 = sg->vn_q4;
            v12 = 0;
            full = false;
        }
    }
    if (s0 + ds >= L) {
        /* the block ends inside this segment: end exactly there, at the speed
         * the constant acceleration reaches there */
        ds = L - s0;
        /* (cruising, v1 = v0 and v0^2 is v_sq: the root is v0; when v1^2
         * is known and the square reaches it, the root is clamped to v1) */
        if (v1 != v0) {
            const uint64_t e2 = v1 > v0 ? mac64(v02, two_a, ds) : msub64(v02, two_a, ds);
            /* The root only where the clamp to v1 does not decide it:
             * accelerating, isqrt(e2) >= v1 <=> e2 >= v1^2; decelerating,
             * isqrt(e2) <= v1 <=> e2 < (v1 + 1)^2 (v1 < v0 < 2^24: no
             * overflow). Either way v1 stays (a square is ~150 AVR cycles,
             * the root ~1,400). */
            const uint64_t v1sq = v12 != 0u ? v12 : sq64(v1);
            const bool at_v1 = v1 > v0 ? e2 >= v1sq : e2 < v1sq + 2u * (uint64_t)v1 + 1u;
            if (!at_v1) {
                uint32_t vl = pk_isqrt64(e2);
                if (v1 > v0 && vl > v1)
                    vl = v1;
                if (v1 < v0 && vl < v1)
                    vl = v1;
                if (vl != v1)
                    v12 = 0;
                v1 = vl;
            }
        }
        full = false;
    }
    if (v12 == 0u && v1 == v0)
        v12 = v02; /* (cruising: the square is kept) */
    sp->s0 = s0;
    sp->v0 = v0;
    sp->v1 = v1;
    sp->ds = ds;
    sp->v12 = v12;
    sp->lv = lv;
    sp->full = full;
    return true;
}

/* Step the event positions (pos, with the Bresenham remainder prem < M of
 * r/M per event) over the events at or before s1, at most 0xFFFF of them;
 * returns how many. Out of line, with a 16-bit count: its loop keeps its
 * values in registers (inside seg_events an 8-bit core spilled them to the
 * stack, ~110 cycles an event; here ~30). */
struct ev_cursor {
    uint32_t pos, prem;
};
#if defined(__GNUC__) || defined(__clang__)
__attribute__((noinline))
#endif
static uint16_t ev_walk(struct ev_cursor *c, uint32_t s1, uint32_t q, uint32_t r, uint32_t M)
{
    uint32_t pos = c->pos, prem = c->prem;
    uint16_t n = 0;
    while (pos <= s1 && n != 0xFFFFu) {
        n++;
        pos += q;
        prem += r;
        if (prem >= M) {
            prem -= M;
            pos++;
        }
    }
    c->pos = pos;
    c->prem = prem;
    return n;
}

/* The events of the segment sp, and the state it leaves. Returns false if
 * the ring had no room (the caller checked it). */
static SG_PREP bool seg_events(struct pk_stepgen *sg, const struct pk_block *b, const struct sg_seg *sp)
{
    const uint32_t s0 = sp->s0, v0 = sp->v0, v1 = sp->v1, ds = sp->ds;
    const uint64_t v12 = sp->v12;
    const uint8_t lv = sp->lv;
    const bool full = sp->full;
    /* The segment's duration from its length (not the nominal seg_ticks: ds
     * is rounded down, and the time must be the time of the distance, or
     * the carry would put the rounding into the interval across the next
     * boundary). */
    const uint32_t vsum = (v0 + v1) ? v0 + v1 : 1u;
    clock_set(sg, vsum);
    const uint64_t seg_q16 = clock_time(sg, ds);
    const uint32_t s1 = s0 + ds;
    /* the events in (s0, s1], stepped from the last one prepared (exact:
     * event k at lead + q k + floor(r k / M) with L - lead = q M + r; event
     * M is at L, and
     * the one after it beyond any s1 <= L, since q >= 1: a step is longer
     * than 1/256 µm) */
    struct ev_cursor cur = { sg->ev_next, sg->ev_rem };
    const uint32_t M = b->events, p_first = cur.pos, q_ev = sg->ev_q, r_ev = sg->ev_r;
    uint32_t n = 0;
    uint16_t k;
    do {
        k = ev_walk(&cur, s1, q_ev, r_ev, M);
        n += k;
    } while (k == 0xFFFFu);
    const uint32_t pos = cur.pos, prem = cur.prem;
    /* the last event: one step back from pos (that step carried iff prem <
     * r, since prem < M before it and r < M) */
    const uint32_t p_last = n > 0u ? pos - q_ev - (prem < r_ev ? 1u : 0u) : p_first;
    const uint32_t e = sg->e + n;
    uint32_t vrep = (v1 + 8u) >> 4;   /* v1 < 2^24 */
    uint64_t carry = sg->carry_q16 + seg_q16;
    if (n > 0) {
        /* r = |v1 - v0| / vseg, Q15 (<= 2^16: the speed at most doubles or
         * halves around the mean) */
        /* (the 64-bit shift only above 2^32) */
        const uint32_t T = full                     ? sg->seg_ticks << lv
                           : seg_q16 > UINT32_MAX ? (uint32_t)(seg_q16 >> 16)
                                                  : (uint32_t)seg_q16 >> 16;
        const uint32_t invT = full ? sg->invT_q30 >> lv : inv_q30(T);
        const uint32_t r_q15 = v0 == v1 ? 0u : ratio_q15(v0 > v1 ? v0 - v1 : v1 - v0, vsum);
        uint64_t tt[2];
        ev_span(sg, p_first - s0, p_last - s0, seg_q16, T, invT, r_q15, v1 > v0, tt);
        const uint64_t t_first = tt[0], t_last = tt[1];
        /* The n - 1 intervals after the first: their mean is span / (n - 1);
         * they ramp with the speed, the interval being inversely
         * proportional to it: from the mean, the change across the segment
         * is about mean (v0 - v1) / vseg (at most the mean either way, so
         * that every interval stays positive); the segment holds T / mean
         * intervals (a fraction: not n, which counts whole events), so
         * A = change mean / T per event. c1 is rounded so that the ramp
         * never sums to more than the span; what is left goes to the carry,
         * so time stays exact. (span < 2^31: one segment, Q16.) */
        int32_t c1 = 0, A = 0;
        uint32_t rem = 0;
        if (n > 1) {
            uint32_t span = (uint32_t)(t_last - t_first);
            uint32_t mean = span / (n - 1u);
            if (n > 2 && v0 != v1) {
                /* ch = mean r (Q16), per = mean / T (Q16), a = ch per: in
                 * 16x16 products (mean < 2^31, r_q15 <= 2^16 - 1, per <= 2^16) */
                const uint32_t r16 = r_q15 > 0xFFFFu ? 0xFFFFu : r_q15;
                uint32_t ch = ((mean >> 16) * r16 << 1)
                              + shr32((uint32_t)(uint16_t)mean * (uint16_t)r16, 15u);
                if (ch > mean)
                    ch = mean;
                uint32_t per = shr32((mean >> 16) * invT, 14u);
                if (per > 0x10000u)
                    per = 0x10000u;
                int32_t a = (int32_t)((ch >> 16) * per + (((ch & 0xFFFFu) * per) >> 16));
                A = v1 > v0 ? -a : a;
            }
            /* c1 = mean - ceil(A n / 2); the ramp's sum is within n of span
             * (< 2^31), so it is computed modulo 2^32 */
            int32_t an = A * (int32_t)n;
            /* (halved as unsigned: the signed division by 2 was a library
             * call on an 8-bit core) */
            int32_t q = an >= 0 ? (int32_t)((uint32_t)(an + 1) >> 1)
                                : -(int32_t)((0u - (uint32_t)an) >> 1);
            c1 = (int32_t)mean - q;
            uint32_t sum = (n - 1u) * (uint32_t)c1 + (uint32_t)A * ((n * (n - 1u)) / 2u);
            rem = span - sum;
        }
        if (!emit_events(sg, n, sg->carry_q16 + t_first, c1, A, vrep))
            return false;
        carry = seg_q16 - t_last + rem;
    }
    sg->carry_q16 = carry;
    sg->ev_next = pos;
    sg->ev_rem = prem;
    sg->v_q4 = v1;
    sg->v_sq = v12 ? v12 : sq64(v1);
    sg->v2 = sg->v_sq >> 4;   /* Q4 speed^2 for the planner */
    sg->e = e;
    sg->s_q8 = s1;
    if (sg->hold && v1 == 0)
        sg->held = true;
    return true;
}

/* Cut the next segment of the tail LINE block b. Returns false if none
 * (held, or the ring has no room for it). */
static SG_PREP bool prep_line(struct pk_stepgen *sg, struct pk_block *b)
{
    if (!sg->blk_sent && !blk_start(sg, b))
        return false;
    /* room for the segment's events: a slot per PK_SG_MAX_EVENTS, and one
     * for a long first interval; a segment holds at most PK_SG_MAX_EVENTS + 1
     * (seg_setup: cut for twice the nominal, or the speed now if higher, and
     * cut again when an override changes the nominal). emit_events checks
     * the room again, all or nothing. */
    if (PK_SG_CHUNKS - pk_sg_pending(sg) < 3u)
        return false;
    /* A probe that has fired holds from here on (the machine sets the same
     * hold when it sees it): read after the room, so that a slot freed by
     * the step event that closed the probe is never refilled without it
     * (its edge is taken before the main loop runs again). On the chip the
     * main loop otherwise saw the edge before or after this point as its
     * timing fell, and ran one step more than `plotkin sim` now and then. */
    if ((sg->watch & sg->fired & PK_SGW_PROBE) != 0u && !sg->hold)
        pk_sg_set_hold(sg, true);
    if (blk_speeds(sg, b))
        seg_setup(sg, b); /* an override changed the nominal */
    struct sg_seg sp;
    if (!seg_speeds(sg, b, &sp))
        return false;
    return seg_events(sg, b, &sp);
}

/* The preparation at rest (after a stop block, or emptied). */
static SG_PREP void prep_at_rest(struct pk_stepgen *sg)
{
    sg->v2 = 0;
    sg->v_sq = 0;
    sg->v_q4 = 0;
    sg->carry_q16 = 0;
}

/* No block being cut, no hold, at rest. */
static SG_PREP void prep_clear(struct pk_stepgen *sg)
{
    sg->prep_active = false;
    sg->blk_sent = false;
    sg->hold = false;
    sg->held = false;
    sg->e = 0;
    sg->s_q8 = 0;
    prep_at_rest(sg);
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
            c->u.ticks = pk_muldiv_u32(b->wait_ms, sg->tick_hz, 1000u); /* saturated */
            ring_commit(sg);
            pk_mq_pop(q);
            max_blocks--;
            prep_at_rest(sg);
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
        prep_clear(sg);
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
    prep_clear(sg);
    sg->phase = PK_SGP_GAP;
    sg->left = 0;
    sg->mask_due = 0;
    sg->busy = false;
    sg->kill = 0;
    sg->alarm = 0;
    sg->v_um_s = 0u;
}

/* ------------------------------------------------------------------ ISR */

SG_COLD uint32_t pk_sgi_alarm(struct pk_stepgen *sg, uint8_t why)
{
    sg->alarm = why;
    sg->v_um_s = 0u;
    sg->busy = false;
    return PK_HAL_TIMER_STOP;
}

/* ------------------------------------------------------------ inputs */

void pk_sg_inputs(struct pk_stepgen *sg, uint32_t lv, int level)
{
    uint32_t old = sg->in_now;
    sg->in_now = (uint16_t)lv;
    sg->in_rise = (uint16_t)(sg->in_rise | (lv & ~old));
    uint8_t w = sg->watch;
    if (w == 0u)
        return;
    if ((w & PK_SGW_LIMITS) != 0u && ((level ? lv : lv & ~old) & PK_IN_LIMITS) != 0u)
        sg->fired |= PK_SGW_LIMITS;
    if ((w & PK_SGW_PROBE) != 0u && (sg->fired & PK_SGW_PROBE) == 0u
        && ((lv >> PK_IN_PROBE) & 1u) == sg->probe_level) {
        for (unsigned i = 0; i < PK_AXES; i++)
            sg->probe_pos[i] = sg->pos[i];
        sg->fired |= PK_SGW_PROBE;
    }
    if ((w & PK_SGW_HOME) != 0u) {
        sg->lock |= (uint8_t)(lv & sg->home_axes);
        if ((sg->lock & sg->home_axes) == sg->home_axes)
            sg->fired |= PK_SGW_HOME;
    }
}

/* A watch is armed and the inputs must be read (a board without edge
 * reports, or a line block's start: a switch already active when a move
 * starts): read them into the watches. 0, or -1 if the read failed (alarm
 * latched). */
static int watch_read(struct pk_stepgen *sg, const struct pk_hal *hal)
{
    uint32_t lv;
    if (pk_hal_input_read(hal, &lv) != 0) {
        sg->alarm = PK_ALARM_INPUT_READ;
        return -1;
    }
    pk_sg_inputs(sg, lv ^ sg->in_flip, 1);
    return 0;
}

/* The watches that stop the output at once have fired. */
#define WATCH_STOP(sg) (((sg)->fired & (PK_SGW_LIMITS | PK_SGW_HOME)) != 0u)


/* A step event with a watch armed: the axes still to step (homing's locked
 * ones dropped), or -1: stop before this event. */
SG_COLD int32_t pk_sgi_watch_event(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t mask)
{
    if ((sg->poll_in && watch_read(sg, hal) != 0) || WATCH_STOP(sg))
        return -1;
    return (int32_t)(mask & ~(uint32_t)sg->lock);
}

/* A chunk about to run with a watch armed (kind: its enum pk_sg_chunk_kind):
 * 1 = stop before it. */
static SG_COLD int watch_chunk(struct pk_stepgen *sg, const struct pk_hal *hal, uint8_t kind)
{
    return ((sg->poll_in || kind == PK_SGC_BLOCK) && watch_read(sg, hal) != 0) || WATCH_STOP(sg);
}

/* Stop at once for a watch: nothing more is emitted; a hard limit latches
 * its alarm, a completed homing move only stops (MAIN drops the rest). */
SG_COLD uint32_t pk_sgi_watch_stop(struct pk_stepgen *sg)
{
    if (sg->alarm == 0u && (sg->fired & PK_SGW_LIMITS) != 0u)
        sg->alarm = PK_ALARM_HARD_LIMIT;
    sg->v_um_s = 0u;
    sg->busy = false;
    return PK_HAL_TIMER_STOP;
}


/* The time of the pending event: whole ticks (32 bits, wrapping, as the
 * HAL's timer callback sees them) and a Q16 fraction; d_q16 is a time in
 * ticks Q16 (|d_q16| < 2^31). No 64-bit arithmetic on the step path. */
static inline SG_INLINE void t_add(struct pk_stepgen *sg, int32_t d_q16)
{
    /* the fraction in 16 bits, its carry out (the sum wrapped) into the ticks */
    const uint16_t lo = (uint16_t)d_q16;
    const uint16_t f = (uint16_t)(sg->next_f + lo);
    sg->next_t += (uint32_t)(d_q16 >> 16) + (f < lo ? 1u : 0u);
    sg->next_f = f;
}

/* A SLOW chunk's interval is cut into waits of this many ticks while it is
 * longer than twice that, so every time the ISR compares stays within 2^31
 * ticks of now. */
#define SG_SLOW_SPLIT ((uint32_t)1 << 29)

/* Write the spindle value v (a board without one: fine); 1 with *ret set if
 * the write failed (alarm latched), else 0. */
static SG_COLD int isr_spindle(struct pk_stepgen *sg, const struct pk_hal *hal, uint16_t v, uint32_t *ret)
{
    int r = pk_hal_spindle_write(hal, v);
    if (r != 0 && r != PK_HAL_ENOSYS) {
        *ret = pk_sgi_alarm(sg, PK_ALARM_SPINDLE_WRITE);
        return 1;
    }
    sg->spindle_cur = v;
    return 0;
}

/* A STEPS chunk starts (c, n events): first interval c0, then c1 changing
 * by c2 per event; the difference c0 - c1 (|c0 - c1| < 2^30) is added once
 * here, so that every event is the same two adds. */
static inline SG_INLINE void isr_steps_start(struct pk_stepgen *sg, const struct pk_sg_chunk *c)
{
    sg->left = c->n;
    t_add(sg, (int32_t)((uint32_t)c->u.st.c0 - (uint32_t)c->u.st.c1));
    sg->I = c->u.st.c1;
    sg->A = c->u.st.c2;
    sg->v_um_s = c->v_um_s;
}

/* One chunk of the ring's tail (c, at index t) that is not a plain STEPS
 * chunk with no watch armed (isr_chunks takes those itself): a line
 * block's set-up, tool, spindle, waits, SLOW events, or any chunk while a
 * watch is armed. Returns 1 with *ret = what the callback returns (the tail
 * moved or not as the chunk needs), or 0 once the chunk is done (the caller
 * moves the tail). sg->earliest: no step edge before it (moved by a
 * direction change). Out of line and cold: its registers stay off the
 * STEPS path. */
static SG_COLD int isr_chunk(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now,
                             struct pk_sg_chunk *c, uint8_t t, uint32_t *ret)
{
    uint32_t *earliest = &sg->earliest;
    if (sg->watch != 0u && watch_chunk(sg, hal, c->kind)) {
        *ret = pk_sgi_watch_stop(sg);
        return 1;
    }
    switch (c->kind) {
    case PK_SGC_BLOCK:
        if (c->arg != sg->dir_cur) {
            uint32_t w;
            if (pulse_state(sg, now, &w) == 1u) {
                /* the last step's pulse is still high: change the
                 * directions once it has ended (this chunk again) */
                *ret = w;
                return 1;
            }
        }
        if (c->spindle != sg->spindle_cur && isr_spindle(sg, hal, c->spindle, ret))
            return 1;
        /* the Bresenham terms as blk_start prepared them: plain copies
         * (every PK_AXES entry: those of axes not driven are never read,
         * bres leaves them out) */
        for (unsigned i = 0; i < PK_AXES; i++) {
            sg->inc[i] = c->u.blk.inc[i];
            sg->acc[i] = c->u.blk.acc0[i];
        }
        sg->bres = (uint8_t)c->n;
        sg->period = c->u.blk.period;
        if (c->arg != sg->dir_cur) {
            const uint32_t all = (1u << sg->axes) - 1u;
            if (pk_hal_dir_write(hal, all, c->arg) != 0) {
                *ret = pk_sgi_alarm(sg, PK_ALARM_DIR_WRITE);
                return 1;
            }
            sg->dir_cur = c->arg;
            uint32_t e = now + sg->dir_setup_ticks;
            if ((int32_t)(e - *earliest) > 0)
                *earliest = e;
        }
        return 0;
    case PK_SGC_STEPS:
        isr_steps_start(sg, c);
        return 0;
    case PK_SGC_SLOW: {
        /* one event after a long interval: whole ticks + Q16 fraction
         * (no ramp); a very long one is waited out in parts first */
        uint32_t tk = c->u.ticks;
        if (tk >= 2u * SG_SLOW_SPLIT) {
            c->u.ticks = tk - SG_SLOW_SPLIT; /* the ISR's slot until the tail moves */
            sg->next_t += SG_SLOW_SPLIT;
            sg->v_um_s = c->v_um_s;
            *ret = sg->next_t - now;
            return 1;
        }
        sg->left = 1;
        sg->next_t += tk;
        t_add(sg, (int32_t)c->n);
        sg->I = 0;
        sg->A = 0;
        sg->v_um_s = c->v_um_s;
        return 0;
    }
    default: {
        if (c->kind == PK_SGC_TOOL && pk_hal_tool_write(hal, c->arg) != 0) {
            *ret = pk_sgi_alarm(sg, PK_ALARM_TOOL_WRITE);
            return 1;
        }
        if (c->kind == PK_SGC_SPINDLE && isr_spindle(sg, hal, c->spindle, ret))
            return 1;
        uint32_t w = c->u.ticks;
        if (w == 0u)
            w = 1u;
        if (w == PK_HAL_TIMER_STOP)
            w--;
        sg->v_um_s = 0u;
        PK_BARRIER();
        sg->tail = (uint8_t)(t + 1u);
        sg->next_t = now + w;
        sg->next_f = 0u;
        *ret = w;
        return 1;
    }
    }
}

/* The ring's tail chunks once the current one is done (left == 0): run the
 * ones that are not steps (isr_chunk) and set up the next chunk of events.
 * Returns with an event set up (left > 0; the result is then unused), or
 * with left == 0 and what the callback returns. Once per chunk: out of line,
 * so that the step path does not pay for its registers. A STEPS chunk with
 * no watch armed (nearly all of them) is set up here, without isr_chunk's
 * frame, also the one right after a line block's set-up (the longest step
 * interrupt: it once went through a first-chunk wrapper, this loop and
 * isr_chunk twice, three register saves deep). */
SG_NOINLINE uint32_t pk_sgi_chunks(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now)
{
    for (;;) {
        uint8_t t = sg->tail;
        uint8_t h = sg->head;
        PK_BARRIER(); /* read the chunk only after seeing it published */
        if (t == h) {
            sg->v_um_s = 0u;
            sg->busy = false;
            return PK_HAL_TIMER_STOP;
        }
        struct pk_sg_chunk *c = &sg->ring[t & SG_MASK];
        uint32_t ret;
        if (c->kind == PK_SGC_STEPS && sg->watch == 0u)
            isr_steps_start(sg, c); /* (isr_chunk's case, without its frame:
                                       the steps after a line block's set-up) */
        else if (isr_chunk(sg, hal, now, c, t, &ret))
            return ret;
        PK_BARRIER(); /* done reading the slot before handing it back */
        sg->tail = (uint8_t)(t + 1u);
        if (sg->left != 0u)
            return 0u;
    }
}

/* The first call after (re)arming: the schedule ended at or before the stop
 * (a dwell cut short by a reset: after it), restart it from now. */
SG_COLD void pk_sgi_restart(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now)
{
    sg->restart = false;
    sg->hw_pulse = hal->ops->step_pulse != NULL;
    if (sg->next_t != now) {
        sg->next_t = now;
        sg->next_f = 0u;
    }
}

/* The step path's fields within the first 64 bytes (struct pk_stepgen). */
_Static_assert(offsetof(struct pk_stepgen, pos) + sizeof(((struct pk_stepgen *)0)->pos) <= 64u,
               "the step path's state must stay within the first 64 bytes of struct pk_stepgen");

uint32_t pk_sg_isr(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now)
{
    return pk_sg_isr_inline(sg, hal, now);
}
