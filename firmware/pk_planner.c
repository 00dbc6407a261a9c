/*
 * pk_planner.c — look-ahead planner (contract in pk_planner.h).
 *
 * Why this shape
 * --------------
 *   speed^2
 *     ^        ____                 ____
 *     |       /    \   junction    /    \
 *     |      /      \____/\_______/      \
 *     |     /                              \   newest block ends at 0
 *     +----|------|-----------|----------|--> distance
 *         blk0   blk1        blk2       blk3
 *
 * With constant acceleration, speed^2 is linear in distance (v^2 = v0^2 +
 * 2*a*s), so every limit is a straight line in this picture and the planner
 * works on squared speeds only (no square root while planning), as Grbl's
 * planner.c does. Each block has a ceiling (its nominal speed), an entry
 * ceiling, and the reverse pass pulls exit speeds down so each block can
 * decelerate to the next one's entry; the forward pass caps them by what
 * acceleration from the current speed can reach.
 *
 * Planned on the exact motion, stepped at its crossings. A block's length
 * (its time), its direction and its axes' limits are those of its exact
 * (requested) displacement; its whole steps only count the half-step
 * crossings that fall in it, and each axis steps at its exact position's
 * crossing (pk_motion.c), so the step times are those of the motion planned
 * here. A move with no whole step adds no block: its way is the next
 * block's lead, time without events, so no skipped distance is run in no
 * time (finding M3: the old planner gave a block the time of its own
 * micrometres and the steps of everything skipped before it). Timing blocks
 * by their whole steps instead (as from the M3 fix to M12) puts a length up
 * to a step per axis away from the motion the steps follow: at 1 step/mm a
 * straight line ran 6 times slower than its feed, and the direction of a
 * few whole steps is noise (a 78 µm chord at 80 steps/mm is 6 steps: up to
 * 0.16 rad off; one Y step then one X step reads as a 90 degree turn), which
 * slows a smooth curve to a crawl.
 *
 * Entry ceilings. At a vertex the velocity turns from v u1 to v u2. Grbl's
 * junction deviation allows the jump a circle of radius r, deviating by
 * delta from the corner, would take at acceleration a ($11). That is right
 * for a real corner but says nothing about a finely subdivided curve: there
 * every vertex turns a little, the jumps add up to a centripetal
 * acceleration v^2 kappa, and with kappa from the chords (turn / length) the
 * junction formula allows far more (the smoothed 40-gon ran at ~1,930 mm/s^2
 * against 1,000). So every junction is also capped by the curvature limit:
 * the axis velocities change by v |u2[i] - u1[i]| over the time the machine
 * takes from the middle of one block to the middle of the next,
 * (l1 + l2) / (2 v), so
 *
 *     v^2 <= accel[i] * (l1 + l2) / 2 / |u2[i] - u1[i]|     for every axis i,
 *
 * which is v^2 <= a / kappa on a polygon that follows a curve (kappa = the
 * turn over the chord). The sideways budget is isotropic, a share of the
 * smallest acceleration among the axes the two blocks move (an axis that
 * moves in neither gets no component of either acceleration: an XY curve
 * is not held to Z's limit) (PK_PLANNER_SIDE_Q15), and the blocks on either
 * side of a junction where it can bind accelerate along the path with the
 * complementary share (PK_PLANNER_ALONG_Q15) only: per axis a_t u_i + a_n
 * n_i, u and n orthogonal, stays within sqrt(a_t^2 + a_n^2) <= accel_min. Grbl's junction
 * deviation applies at programmed corners (it is Grbl's model: a velocity
 * jump of at most sqrt(8 a delta)); at vertices of a smoothed curve the jump
 * itself is capped (PK_PLANNER_KINK_MS) so that, over any such window, it
 * leaves room for the acceleration along the path: long chords cannot turn a
 * curve into a string of kicks the curvature formula would allow.
 *
 * Final plans. Appending a block can only raise exits that are limited by
 * the newest block's stop; an exit capped by a junction, a nominal speed or
 * the acceleration from the past can never change. The reverse pass marks
 * which exits depend on the queue's end; the forward pass counts the blocks
 * from the tail whose exits are final. The step generator cuts only those
 * into chunks (or all of them when the queue is full or the program's end is
 * known), so a program read from a file and the same program streamed line by
 * line give the same pin trace as long as the sender keeps the queue fed.
 *
 * Incremental replans. The same monotonicity makes replanning cheap: below
 * the last anchor (a stop block, or a line whose entry its ceiling capped)
 * the reverse pass hands down what it did however many blocks are appended,
 * and popping blocks off the tail changes no reverse value. A replan runs the
 * reverse pass from the newest block down to that anchor only, and the
 * forward pass from block 0 (when the step generator took blocks: the next
 * one starts at the speed it reached) until an exit comes out as before,
 * then from the anchor on. Exactly the plan a replan from scratch makes; on
 * an 8-bit core about half the cost (pk_planner_replan).
 *
 * Fixed-point budget: len_q8 < 2^31 (|d| <= 2*PK_UM_MAX per axis, 3 axes:
 * sqrt(3) * 2^22 µm * 2^8 < 2^31), accel < 2^27, so 2*a*len in Q4 is
 * 2 * a * len_q8 / 16 < 2^55. Speeds^2 Q4 < 2^44 (1 m/s).
 */
#include <string.h>
#include "pk_planner.h"
#include "pk_sg_div.h"

/** Speed^2 Q4 from µm/min: (v / 60)^2 * 16 = v^2 / 225, rounded (v < 2^26). */
static pk_v2_q4_t v2_of_um_min(uint32_t v)
{
#if PK_SOFT_DIV && !PK_FLASH_FIRST /* (a flash-first board keeps the division: smaller) */
    /* Without the 64-bit division (~1,600 AVR cycles; this: three 32 x
     * 32-bit products): v = 15 a + b (0 <= b < 15), so v^2 + 112 = 225 a^2
     * + 30 a b + b^2 + 112 and the quotient is a^2 + floor((30 a b + b^2 +
     * 112) / 225), whose numerator is below 2^31 (a < 2^26 / 15, b <= 14).
     * Both divisions by constants are products: floor(v / 15) = v M >> 35
     * with M = 0x88888889 for every v < 2^32 (M 15 - 2^35 = 7 <= 2^3), and
     * floor(y / 225) = y M' >> 39 with M' = 2,443,359,173 for every y <
     * 2^31 (M' 225 - 2^39 = 37 <= 2^8). */
    const uint32_t a = pk_hi32((uint64_t)v * 0x88888889u) >> 3;
    const uint32_t b = v - 15u * a;
    const uint32_t y = 30u * a * b + b * b + 112u;
    const uint32_t a2 = a; /* (a second name: avr-gcc then multiplies 32 x 32 -> 64, not 64 x 64) */
    return (uint64_t)a * a2 + (pk_hi32((uint64_t)y * 2443359173u) >> 7);
#else
    return ((uint64_t)v * v + 112u) / 225u;
#endif
}

/** 2 * a * len in Q4 speed^2 (len in µm Q8). */
static pk_v2_q4_t two_a_s(pk_um_s2_t a, uint32_t len_q8)
{
    return ((uint64_t)a * len_q8) >> 3; /* 2 * a * len_q8 / 256 * 16 */
}

static pk_v2_q4_t min64(pk_v2_q4_t a, pk_v2_q4_t b) { return a < b ? a : b; }

void pk_planner_init(struct pk_planner *p, const struct pk_planner_limits *lim)
{
    memset(p, 0, sizeof *p);
    p->lim = *lim;
    p->ovr_feed_pct = 100u;
    p->ovr_rapid_pct = 100u;
}

void pk_planner_break(struct pk_planner *p)
{
    p->have_prev = false;
    p->plan_valid = false; /* (the machine's reset empties the queue with it) */
}

pk_v2_q4_t pk_planner_nominal_v2(const struct pk_planner *p, const struct pk_block *b)
{
    /* v_lim, v_req <= PK_UM_MIN_MAX < 2^26, overrides <= 200 %: < 2^27 (at
     * 100 % the product and quotient give v itself: no 64-bit division) */
    const uint32_t v0 = b->rapid ? b->v_lim : b->v_req;
    const uint16_t pct = b->rapid ? p->ovr_rapid_pct : p->ovr_feed_pct;
    uint32_t v = pct == 100u ? v0 : pk_muldiv_u32(v0, pct, 100u);
    if (v > b->v_lim)
        v = b->v_lim;
    pk_v2_q4_t v2 = v2_of_um_min(v);
    return v2 == 0 ? 1u : v2;
}

void pk_planner_set_override(struct pk_planner *p, uint16_t feed_pct, uint16_t rapid_pct)
{
    if (feed_pct != p->ovr_feed_pct || rapid_pct != p->ovr_rapid_pct)
        p->nom_dirty = true; /* (the next replan recomputes every nominal) */
    p->ovr_feed_pct = feed_pct;
    p->ovr_rapid_pct = rapid_pct;
}

/* Whether x y (both > 0) stays below 2^63, from their bit lengths: 1 yes, 0
 * no, 2 undecided (x < 2^bx, y < 2^by and x >= 2^(bx-1), y >= 2^(by-1):
 * below 2^63 when bx + by <= 63, at least 2^64 when bx + by >= 65). The
 * exact test is a 64-bit division, ~1,400 cycles on an 8-bit core. */
static unsigned mul_fits63(uint64_t x, uint64_t y)
{
#if (defined(__GNUC__) || defined(__clang__)) && !PK_FLASH_FIRST /* (else ~120 B of AVR code) */
    const unsigned b = 128u - (unsigned)__builtin_clzll(x) - (unsigned)__builtin_clzll(y);
    return b <= 63u ? 1u : b >= 65u ? 0u : 2u;
#else
    (void)x;
    (void)y;
    return 2u;
#endif
}

/* The junction's cos(phi) = u1.u2 in Q30 (clamped to +-1) and h = (1 - d)/2
 * = sin^2(phi/2) in Q30 (0..2^30), as pk_planner_junction_v2 takes them. */
static uint32_t junction_h(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES], uint8_t axes, int32_t *d_out)
{
    int64_t dd = 0;
    for (unsigned i = 0; i < axes; i++)
        if (u1[i] != 0 && u2[i] != 0) /* (a still axis adds nothing) */
            dd += (int64_t)u1[i] * u2[i];
    dd = pk_rshift_round64(dd, 30);
    const int32_t d = dd > PK_Q30_ONE ? PK_Q30_ONE : dd < -PK_Q30_ONE ? -PK_Q30_ONE : (int32_t)dd;
    *d_out = d;
    return ((uint32_t)PK_Q30_ONE - (uint32_t)d) / 2u; /* Q30, 0..2^30 */
}

/* pk_planner_junction_v2 from its d and h (h > 0). */
static pk_v2_q4_t junction_of(int32_t d, uint32_t h, pk_um_s2_t a, pk_um_t delta)
{
    uint32_t s2 = ((uint32_t)PK_Q30_ONE + (uint32_t)d) / 2u; /* cos^2(phi/2), Q30 */
    uint32_t s = pk_isqrt64((uint64_t)s2 << 30);             /* Q30 */
    if (s == 0 || delta == 0)
        return 0;                                /* full reversal or exact stop */
    uint32_t r = pk_mulshr_u32(s, (uint32_t)PK_Q30_ONE + s, 30); /* s(1+s), Q30, <= 2^31 */
    uint64_t q = ((uint64_t)r << 20) / h;        /* s(1+s)/h, Q20 */
    uint64_t ad = (uint64_t)a * (uint64_t)delta; /* < 2^27 * 2^14 = 2^41 */
    /* v2 (Q4) = ad * q >> 16; saturate where ad q > 2^63 - 1 (that is ad >
     * floor((2^63 - 1) / q)) */
    if (q == 0 || ad == 0)
        return 0;
    switch (mul_fits63(ad, q)) {
    case 0:
        return UINT64_MAX;
    case 1:
        return (ad * q) >> 16;
    default:
        return ad > (UINT64_MAX >> 1) / q ? UINT64_MAX : (ad * q) >> 16;
    }
}

pk_v2_q4_t pk_planner_junction_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                  uint8_t axes, pk_um_s2_t a, pk_um_t delta)
{
    /* d = u1.u2 in Q30. The turn angle phi between the directions has
     * cos(phi) = d; Grbl's theta = pi - phi, so sin(theta/2) = cos(phi/2) and
     * 1 - sin(theta/2) = (1 - cos^2(phi/2)) / (1 + cos(phi/2))
     *                  = h / (1 + s),  h = (1 - d)/2 = sin^2(phi/2), s = cos(phi/2).
     * Hence v^2 = a*delta * s * (1 + s) / h, with h computed directly from d,
     * which keeps its precision for the small turns of dense polylines. */
    int32_t d;
    const uint32_t h = junction_h(u1, u2, axes, &d);
    if (h == 0)
        return UINT64_MAX; /* straight on: no junction limit */
    return junction_of(d, h, a, delta);
}

/* x >= m 2^e and x < (m + 1) 2^e with m < 2^8 (m >= 2^7 where x >= 2^7):
 * x's top 8 bits, for a product of several values bounded in 32 bits. (A
 * floor of a floor is the floor of the whole shift: 8- and 16-bit steps
 * first, register moves on an 8-bit core, then at most 8 one-bit steps of a
 * 16-bit word.) */
static uint8_t mant8(uint32_t w, uint8_t *e)
{
    uint8_t s = 0u;
    if (w >= ((uint32_t)1 << 24)) {
        w >>= 16;
        s = 16u;
    } else if (w >= ((uint32_t)1 << 16)) {
        w >>= 8;
        s = 8u;
    }
    uint16_t v = (uint16_t)w; /* < 2^16 */
    while (v >= 256u) {
        v = (uint16_t)(v >> 1);
        s++;
    }
    *e = s;
    return (uint8_t)v;
}

/* mant8 of a 64-bit value (e up to 56). */
static uint8_t mant8_64(uint64_t x, uint8_t *e)
{
    const uint32_t hi = pk_hi32(x), lo = (uint32_t)x;
    if (hi == 0u)
        return mant8(lo, e);
    uint8_t m;
    if (hi >= 256u) {
        m = mant8(hi, e);
        *e = (uint8_t)(*e + 32u);
    } else {
        m = mant8((hi << 24) | (lo >> 8), e); /* floor(x / 2^8) < 2^32 */
        *e = (uint8_t)(*e + 8u);
    }
    return m;
}

pk_v2_q4_t pk_planner_junction_min_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                      uint8_t axes, pk_um_s2_t a, pk_um_t delta, pk_v2_q4_t cap,
                                      bool *cap_below)
{
    int32_t d;
    const uint32_t h = junction_h(u1, u2, axes, &d);
    if (h == 0) {
        *cap_below = cap != UINT64_MAX;
        return cap;
    }
    /* A lower bound J_lb of the junction limit J (pk_planner_junction_v2):
     * when it is above cap, so is J, and the answer is cap without J's root
     * (~2,200 AVR cycles) and 64-bit division (~1,400). On the dense
     * drawings a turn that is not a blend's is a few degrees, and J is 4 to
     * 16 times the curvature limit it is compared with (bench: 4,400 of
     * 4,573 sharp vertices of the svg2gcode curves, 4,560 of 4,572 of the
     * policy's checks). For d >= 0 (a turn up to 90 degrees), k = 2^30 - s2
     * <= 2^29, s2 = (2^30 + d) / 2:
     *  - s = floor(sqrt(s2 2^30)) >= s2 (s2 <= 2^30), so r = floor(s (2^30 +
     *    s) / 2^30) >= s2 + floor(s2^2 / 2^30) >= 2^31 - 3k (s2^2 / 2^30 =
     *    2^30 - 2k + k^2 / 2^30): r_lb = 2^31 - 3k;
     *  - q = floor(r 2^20 / h) >= (r_lb 2^20 - h + 1) / h >= X / h with X =
     *    (r_lb - floor(h / 2^20) - 1) 2^20 (h < (floor(h / 2^20) + 1) 2^20);
     *  - J = floor(ad q / 2^16) (or saturated, larger): J > cap when
     *    ad X >= (cap + 1) 2^16 h, which 8-bit mantissas (x >= m 2^e,
     *    x < (m + 1) 2^e; each within 1/128 of x, 4 % over the whole test)
     *    decide in 32 bits: ma md mx 2^(ea + ed + ex + 20) >= (mc + 1) (mh +
     *    1) 2^(ec + eh + 16), the left product < 2^24, the right <= 2^16.
     * Exact either way: J itself is computed unless the bound decides. */
    /* (not on a flash-first board: there J is always computed) */
    if (!PK_FLASH_FIRST && d >= 0 && cap != UINT64_MAX && delta > 0 && a != 0) {
        const uint32_t k = (uint32_t)PK_Q30_ONE - ((uint32_t)PK_Q30_ONE + (uint32_t)d) / 2u;
        const uint32_t xm = ((uint32_t)1 << 31) - 3u * k - (h >> 20) - 1u; /* >= 2^29 - 2^10 - 1 */
        uint8_t ea, ed, ex, ec, eh;
        const uint8_t ma = mant8(a, &ea), md = mant8((uint32_t)delta, &ed), mx = mant8(xm, &ex);
        const uint16_t mc = (uint16_t)(mant8_64(cap + 1u, &ec) + 1u), mh = (uint16_t)(mant8(h, &eh) + 1u);
        const uint32_t lhs = (uint32_t)ma * md * mx, rhs = (uint32_t)mc * mh; /* (32-bit: ma md overflows a 16-bit int) */
        const int e = (int)ea + (int)ed + (int)ex + 20 - ((int)ec + (int)eh + 16);
        /* lhs 2^e >= rhs, in 32 bits: for e >= 0, lhs >= ceil(rhs / 2^e)
         * (beyond e = 16, lhs >= 1 > rhs / 2^e); for e < 0, floor(lhs /
         * 2^-e) >= rhs (the floor only lowers the side that must be larger;
         * beyond -e = 23 it is 0 < rhs) */
        bool above;
        if (e >= 0)
            above = e > 16 || lhs >= ((rhs + (((uint32_t)1 << e) - 1u)) >> e);
        else
            above = e > -24 && (lhs >> (unsigned)-e) >= rhs;
        if (above) {
            *cap_below = true;
            return cap;
        }
    }
    const pk_v2_q4_t j = junction_of(d, h, a, delta);
    *cap_below = cap < j;
    return cap < j ? cap : j;
}

/* |u2 - u1| in Q30, from the components' squares in Q56 (|d| <= 2^31:
 * each square >> 4 < 2^58, the sum < 3 * 2^58). */
static uint64_t turn_q30(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES], uint8_t axes)
{
    uint64_t ss = 0;
    for (unsigned i = 0; i < axes; i++) {
        /* |u2 - u1| < 2^32: its square as a 32 x 32-bit product (a still
         * axis adds nothing) */
        const uint32_t d = u2[i] >= u1[i] ? (uint32_t)u2[i] - (uint32_t)u1[i]
                                          : (uint32_t)u1[i] - (uint32_t)u2[i];
        if (d != 0)
            ss += ((uint64_t)d * d) >> 4;
    }
    return (uint64_t)pk_isqrt64(ss) << 2;
}

pk_v2_q4_t pk_planner_curvature_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                   uint8_t axes, uint32_t l1_q8, uint32_t l2_q8, pk_um_s2_t a)
{
    /* v^2 (Q4) = a * (l1 + l2)/2 / |du|: with l in µm Q8 and du in Q30,
     * v^2 = a * lsum_q8 / 512 * 2^30 / du  ->  Q4: a * lsum_q8 * 2^25 / du. */
    uint64_t du = turn_q30(u1, u2, axes); /* |u2 - u1|, Q30 */
    if (du == 0)
        return UINT64_MAX;
    /* the kink is spread over the shorter neighbour (twice its half): with
     * equal chords this is their mean, the turn over the chord of a curve;
     * next to a long segment the short one rules, so a long straight and a
     * blend's chord cannot hide a large kink behind the long one */
    uint64_t lmin = l1_q8 < l2_q8 ? l1_q8 : l2_q8;
    uint64_t num = (uint64_t)a * (2u * lmin);               /* < 2^27 * 2^32 */
    uint64_t qt;
#if PK_SOFT_DIV && !PK_FLASH_FIRST
    /* a few thousand at most (a ~2^20 µm/s^2, a chord of 2^16 µm Q8, a
     * turn of 2^25 in Q30): one step per quotient bit (pk_sg_div32_soft,
     * ~500 AVR cycles here) where the quotient fits 32 bits and du 2^31
     * (|u2 - u1| <= 2: du exceeds 2^31 only by the unit vectors' rounding),
     * libgcc's 64-bit division (~1,100) otherwise */
    if (du <= ((uint64_t)1 << 31) && pk_hi32(num) < (uint32_t)du)
        qt = pk_sg_div32_soft(pk_hi32(num), (uint32_t)num, (uint32_t)du);
    else
#endif
        qt = num / du;
    return qt > (UINT64_MAX >> 25) ? UINT64_MAX : qt << 25;
}

/* floor(a * share / 2^15) for a share <= 2^15 (Q1.15), in 32 bits: with a =
 * 2^15 h + l, a share = 2^15 h share + l share, so the floor is h share +
 * floor(l share / 2^15), h share < 2^17 * 2^15 and l share < 2^30: the 64-bit
 * product's result for any 32-bit a. */
static uint32_t share_q15(uint32_t a, uint32_t share)
{
    return (a >> 15) * share + (((a & 0x7FFFu) * share) >> 15);
}

/* The kink cap of pk_planner_dyn: (a_min - along) * KINK_MS / 1000 (< 2^27 * 2^16). */
static uint32_t jump_of(pk_um_s2_t a_min, pk_um_s2_t along)
{
    return (uint32_t)(((uint64_t)(a_min - along) * PK_PLANNER_KINK_MS) / 1000u);
}

static void dyn_of(pk_um_s2_t a_min, pk_um_t delta_um, struct pk_planner_dyn *d)
{
    d->a_min = a_min;
    d->a_side = share_q15(a_min, PK_PLANNER_SIDE_Q15);
    d->jump_um_s = jump_of(a_min, share_q15(a_min, PK_PLANNER_ALONG_Q15));
    d->delta_um = delta_um;
}

void pk_planner_dyn(const struct pk_planner_limits *lim, struct pk_planner_dyn *d)
{
    dyn_of(lim->accel_min, lim->junction_dev_um, d);
}

/* The smallest acceleration of the axes that either block moves. The turn's
 * velocity change (u2 - u1) and both blocks' acceleration along u1 or u2
 * have components on these axes only, so the isotropic budget needs no
 * share of a still axis's limit (an XY curve is not held to Z's). */
static pk_um_s2_t accel_min_moving(const struct pk_planner_limits *lim, const pk_q30_t u1[PK_AXES],
                                   const pk_q30_t u2[PK_AXES])
{
    pk_um_s2_t a = lim->accel_min;
    bool any = false;
    for (unsigned i = 0; i < lim->axes; i++) {
        if (u1[i] == 0 && u2[i] == 0)
            continue;
        if (!any || lim->accel[i] < a)
            a = lim->accel[i];
        any = true;
    }
    return a;
}

pk_v2_q4_t pk_planner_kink_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                              uint8_t axes, uint32_t jump_um_s)
{
    uint64_t du = turn_q30(u1, u2, axes);   /* |u2 - u1|, Q30 */
    if (du == 0)
        return UINT64_MAX;
    uint64_t v_q2 = ((uint64_t)jump_um_s << 32) / du; /* jump / du, µm/s x 4 */
    return v_q2 * v_q2;                            /* (µm/s)^2 x 16 = Q4 */
}

/* The k-th oldest block, k < count (pk_mq_at without its bounds check and
 * its call: a replan looks up every block it walks, ~290,000 calls over a
 * dense drawing on an 8-bit core). tail < PK_MQ_CAP and k < PK_MQ_CAP, so
 * one conditional subtraction wraps the index (no division by a capacity
 * that need not be a power of two). */
static inline struct pk_block *slot(struct pk_mq *q, uint32_t k)
{
    uint32_t i = q->tail + k;
    if (i >= PK_MQ_CAP)
        i -= PK_MQ_CAP;
    return &q->b[i];
}

/* Highest entry speed^2 of line block b after block a (NULL: none): the
 * junction limit, and neither neighbour's nominal speed (both may change
 * with the overrides: v2_ceil keeps it until they do). */
static pk_v2_q4_t entry_ceiling(const struct pk_block *a, const struct pk_block *b)
{
    pk_v2_q4_t c = min64(b->v2_junction, b->v2_nom);
    if (a != NULL && a->type == PK_BLK_LINE)
        c = min64(c, a->v2_nom);
    return c;
}

/* The smallest pk_muldiv_u32(lim[i], span, ad[i]) over the axes with ad[i]
 * != 0 (UINT32_MAX if none), by one division (see pk_planner_add_line); on
 * a board that needs the flash more (PK_FLASH_FIRST: the 64-bit
 * comparisons are ~250 B of AVR code) one per axis. */
static uint32_t min_ratio_muldiv(const uint32_t lim[PK_AXES], uint32_t span, const uint32_t ad[PK_AXES],
                                 uint8_t axes)
{
#if PK_FLASH_FIRST
    uint32_t m = UINT32_MAX;
    for (unsigned i = 0; i < axes; i++) {
        const uint32_t q = ad[i] != 0 ? pk_muldiv_u32(lim[i], span, ad[i]) : UINT32_MAX;
        if (q < m)
            m = q;
    }
    return m;
#else
    unsigned k = PK_AXES;
    for (unsigned i = 0; i < axes; i++)
        if (ad[i] != 0 && (k == PK_AXES || (uint64_t)lim[i] * ad[k] < (uint64_t)lim[k] * ad[i]))
            k = i;
    return k == PK_AXES ? UINT32_MAX : pk_muldiv_u32(lim[k], span, ad[k]);
#endif
}

int pk_planner_add_line(struct pk_planner *p, struct pk_mq *q, const int32_t d_q8[PK_AXES],
                        const pk_steps_t d_steps[PK_AXES], const int32_t d_um[PK_AXES],
                        uint32_t lead_q8, pk_um_min_t feed, uint8_t flags)
{
    const uint8_t axes = p->lim.axes;
    bool way = false; /* d_q8 is not zero (its square sum, below, is not) */
    uint32_t events = 0;
    for (unsigned i = 0; i < axes; i++) {
        way |= d_q8[i] != 0;
        uint32_t st = (uint32_t)(d_steps[i] < 0 ? -d_steps[i] : d_steps[i]);
        if (st > events)
            events = st;
    }
    if (events == 0 || !way)
        return 0;
    if (pk_mq_room(q) == 0)
        return -1;
    /* The block is planned on its EXACT displacement, not its whole steps:
     * an axis steps where its exact position crosses a half step
     * (pk_motion.c), so its steps' times are those of the exact motion, and
     * a block's whole steps only count the crossings inside it. At a coarse
     * steps/mm the two differ by up to a step per axis: X at 1 step/mm
     * moving 282 µm in a piece that makes one whole X step (1 mm), or one Y
     * step of 7 µm while X moves most of a millimetre. Timed and limited by
     * the steps, such blocks ran a straight line 6 times slower than its
     * feed (finding M12); limited by the steps over a length that was not
     * the exact one, an axis ran over its rate (M6, M11). e is the
     * displacement planned, µm Q8: its length is the block's (before the
     * lead), its direction the junction's, each axis's part the one its
     * limits hold for. (|d_um| < 2^23: |e| < 2^31, each square < 2^62, the
     * sum of three < 2^64. A block with a step has an exact displacement:
     * the steps' is only a fallback.) */
    int32_t e[PK_AXES] = { 0 };
    uint64_t se = 0;
    for (unsigned i = 0; i < axes; i++) {
        e[i] = d_um[i] * 256;
        se += (uint64_t)((int64_t)e[i] * e[i]);
    }
    if (se == 0) {
        memcpy(e, d_q8, sizeof e);
        for (unsigned i = 0; i < axes; i++) /* |d_q8| < 2^30: 3 * 2^60 < 2^62 */
            se += (uint64_t)((int64_t)d_q8[i] * d_q8[i]);
    }
    uint32_t span_q8 = pk_isqrt64(se);
    if (span_q8 == 0)
        span_q8 = 1;
    if (span_q8 > 0x7FFFFFFFu)
        span_q8 = 0x7FFFFFFFu;
    /* the block's length: the exact part and the lead before it (< 2^31) */
    if (lead_q8 > 0x7FFFFFFFu - span_q8)
        lead_q8 = 0x7FFFFFFFu - span_q8;
    const uint32_t len_q8 = span_q8 + lead_q8;
    struct pk_block *b = pk_mq_push(q);
    b->type = PK_BLK_LINE;
    b->events = events;
    b->len_q8 = len_q8;
    b->lead_q8 = lead_q8;
    uint32_t v_lim = PK_UM_MIN_MAX;
    uint32_t acc = PK_UM_S2_MAX;
    /* The direction of the exact displacement, for the junction and
     * curvature: the steps follow the exact position, so the axes'
     * velocities turn as it does. The whole steps' direction is that
     * quantised to a step (at 1 step/mm a piece of a straight line that
     * makes one Y step, then one that makes one X step, turned 90 degrees
     * and capped the speed at 1.4 mm/s: finding M12), and a µm is finer
     * than a step below 1,000 steps/mm. (|e| <= span_q8 < 2^31: |u| <=
     * 2^30, |e| << 30 < 2^61.) */
    pk_q30_t u[PK_AXES] = { 0 };
    /* |e| <= span < 2^31 (a clamped span is 2^31 - 1 > |e|): the quotient
     * e 2^30 / span in pk_frac_q30's range (a 32-bit division on 8-bit cores) */
    for (unsigned i = 0; i < axes; i++) /* (0 for a still axis: no division) */
        u[i] = e[i] == 0 ? 0 : pk_frac_q30_signed(e[i], span_q8);
    /* axis speed = v * |d|/len <= max_rate  =>  v <= max_rate * len / |d|
     * (saturated quotients: only their minimum with the caps counts), and
     * the same for the accelerations (over the exact part of the block: its
     * lead has no step, and the steps and their exact crossings all fall
     * after it). floor(max_rate span / |d|) and its saturation grow with
     * the ratio max_rate / |d|, so the smallest quotient is that of the
     * axis with the smallest ratio: found by comparing cross products
     * (< 2^32 * 2^32, exact), one 64-bit division for the block, not one
     * per moving axis. */
    uint32_t ad[PK_AXES] = { 0 };
    for (unsigned i = 0; i < axes; i++) {
        if (d_steps[i] > 0)
            b->dir_mask = (uint8_t)(b->dir_mask | (1u << i));
        ad[i] = (uint32_t)(e[i] < 0 ? -e[i] : e[i]);
    }
    const uint32_t vl = min_ratio_muldiv(p->lim.max_rate, span_q8, ad, axes);
    const uint32_t al = min_ratio_muldiv(p->lim.accel, span_q8, ad, axes);
    if (vl < v_lim)
        v_lim = vl;
    if (al < acc)
        acc = al;
    if (v_lim == 0)
        v_lim = 1;
    if (acc == 0)
        acc = 1;
    b->accel = acc;
    b->rapid = feed == 0u;
    b->v_lim = v_lim;
    b->v_req = feed;
    b->v2_nom = pk_planner_nominal_v2(p, b);
    pk_v2_q4_t vj = 0;
    const uint32_t nq = pk_mq_count(q);
    const struct pk_block *a0 = nq >= 2u ? slot(q, nq - 2u) : NULL; /* the block before */
    if (p->have_prev) {
        /* (pk_planner_dyn's shares; its kink cap only for a smoothed vertex) */
        const pk_um_s2_t a_turn = accel_min_moving(&p->lim, p->prev_u, u);
        const pk_um_s2_t side = share_q15(a_turn, PK_PLANNER_SIDE_Q15);
        const pk_um_s2_t along = share_q15(a_turn, PK_PLANNER_ALONG_Q15);
        pk_v2_q4_t curv = pk_planner_curvature_v2(p->prev_u, u, axes, p->prev_len_q8, span_q8, side);
        pk_v2_q4_t turn; /* the cap that comes from turning sideways */
        if (flags & PK_PLAN_SHARP) {
            pk_um_s2_t a = p->prev_accel < b->accel ? p->prev_accel : b->accel;
            bool curv_below;
            vj = pk_planner_junction_min_v2(p->prev_u, u, axes, a, p->lim.junction_dev_um, curv, &curv_below);
            turn = curv_below ? curv : UINT64_MAX; /* else Grbl's corner model rules */
        } else {
            vj = min64(curv, pk_planner_kink_v2(p->prev_u, u, axes, jump_of(a_turn, along)));
            turn = vj;
        }
        /* a turn that can limit the speed shares the acceleration with the
         * blocks on either side of it */
        pk_v2_q4_t nom = b->v2_nom;
        if (a0 != NULL && a0->type == PK_BLK_LINE && a0->v2_nom > nom)
            nom = a0->v2_nom;
        if (turn < nom) {
            /* the new block shares its acceleration with the turn, whichever
             * neighbour is shorter: the block before it may already have its
             * exit committed on its own acceleration (findings M7, M8) */
            b->curved = 1;
            if (b->accel > along)
                b->accel = along;
        } else if (turn != UINT64_MAX && !(flags & PK_PLAN_SHARP)) {
            /* A vertex of a smoothed curve that does not bind at the
             * nominal speed still turns: at v its jump is v |u2 - u1| and
             * its sideways acceleration v^2 kappa, the fraction r =
             * sqrt(nom / turn) of the budget at most (linear in v for the
             * jump, quadratic for the curvature: r bounds both). The block
             * keeps a - r (a - along) along the path: between (a, 0) and
             * (along, side) on a chord of the budget's circle, so within it
             * (finding M9: at full a, one axis's windowed acceleration was
             * up to 7 % over its limit in FIXED mode). (nom < 2^44: the
             * ratio in Q16 fits 64 bits; r in Q8 <= 256.) */
            uint64_t ratio = (nom << 16) / turn;
            uint32_t r_q8 = pk_isqrt64(ratio);
            if (r_q8 > 256u)
                r_q8 = 256u;
            const pk_um_s2_t a_full = b->accel;
            if (a_full > along) {
                const pk_um_s2_t cut = (pk_um_s2_t)(((uint64_t)(a_full - along) * r_q8) >> 8);
                b->accel = a_full - cut;
                if (cut != 0)
                    b->curved = 1;
            }
        }
    }
    b->v2_junction = vj;
    b->v2_exit = 0;
    /* what the replan takes from the block every time it walks it (the
     * block before it is the line a0, or a stop: its nominal stays until an
     * override change recomputes both; a block that is the queue's tail
     * has no entry ceiling, and stays the tail) */
    b->v2_acc = two_a_s(b->accel, len_q8);
    b->v2_ceil = entry_ceiling(a0, b);
    p->have_prev = true;
    memcpy(p->prev_u, u, sizeof p->prev_u);
    p->prev_len_q8 = span_q8;
    p->prev_accel = b->accel;
    return 1;
}

int pk_planner_add_stop(struct pk_planner *p, struct pk_mq *q, uint8_t type, uint8_t tool,
                        uint16_t value, uint32_t wait_ms)
{
    struct pk_block *b = pk_mq_push(q);
    if (b == NULL)
        return -1;
    b->type = type;
    b->tool = tool;
    b->spindle = value;
    b->wait_ms = wait_ms;
    p->have_prev = false;
    return 1;
}

void pk_planner_replan(struct pk_planner *p, struct pk_mq *q, pk_v2_q4_t v2_now, uint32_t rem_q8,
                       bool end_known)
{
    uint32_t n = pk_mq_count(q);
    p->n_final = 0;
    if (n == 0) {
        p->plan_valid = false;
        return;
    }
    /* Nominal speeds: a block gets its own when it is added (with the
     * overrides of that moment, pk_planner_add_line); all of them again only
     * when the overrides changed since (each is two 64-bit divisions, the
     * bulk of a replan on an 8-bit core: 16 blocks, ~50,000 cycles, redone
     * every replan before). The same values as recomputing them every time
     * (a block added after an override change is recomputed with the rest). A
     * LINE block pushed without pk_planner_add_line has v2_nom = 0 (never a
     * nominal: at least 1) and gets one here. */
    const bool ovr_changed = p->nom_dirty;
    /* (without an override change, the blocks the last replan saw have
     * theirs: only those appended since can lack one) */
    uint32_t k_nom = 0;
    if (p->plan_valid && !ovr_changed) {
        const uint32_t popped = (uint16_t)(q->pops - p->plan_pops);
        if (popped <= p->plan_count && n + popped >= p->plan_count)
            k_nom = p->plan_count - popped;
    }
    bool renom_prev = false; /* the block before got its nominal again */
    for (uint32_t k = k_nom; k < n; k++) {
        struct pk_block *b = slot(q, k);
        bool renom = false;
        if (b->type == PK_BLK_LINE) {
            renom = ovr_changed || b->v2_nom == 0u;
            if (b->v2_nom == 0u) /* (not added by pk_planner_add_line) */
                b->v2_acc = two_a_s(b->accel, b->len_q8);
            if (renom)
                b->v2_nom = pk_planner_nominal_v2(p, b);
            if (renom || renom_prev)
                b->v2_ceil = entry_ceiling(k > 0u ? slot(q, k - 1u) : NULL, b);
        }
        renom_prev = renom;
    }
    p->nom_dirty = false;
    /* Incremental (Grbl's planned pointer). Since the last replan the step
     * generator may have taken blocks off the tail (popped) and the machine
     * appended some. Appending only raises the entries the reverse pass
     * computes (the old newest block ended at rest, and v^2 -> min(ceiling,
     * v^2 + 2 a s) is monotone), so below the last anchor -- a stop block, or
     * a line whose entry its ceiling capped -- the reverse pass hands down
     * what it did: it runs from the newest block down to the anchor only (not
     * at all when nothing was appended: popping changes no reverse value).
     * The forward pass starts at block 0 when the start state changed
     * (a block was popped: the next one starts at the speed the step
     * generator reached), and stops redoing the old plan at the first block
     * whose exit comes out as before (every later exit depends only on it
     * and on unchanged reverse values) until the blocks the reverse pass
     * redid. The same plan as from scratch (tests/test_motion_planner.c). */
    uint32_t lo_rev = 0, lo_fwd = 0, anchor0 = 0;
    if (p->plan_valid && !ovr_changed && end_known == p->plan_end_known) {
        const uint32_t popped = (uint16_t)(q->pops - p->plan_pops);
        if (popped <= p->plan_count && n + popped >= p->plan_count) {
            const bool appended = n + popped > p->plan_count;
            anchor0 = p->plan_anchor >= popped ? p->plan_anchor - popped : 0u;
            lo_rev = appended ? anchor0 : n;
            lo_fwd = popped == 0u && v2_now == p->plan_v2_now && rem_q8 == p->plan_rem_q8 ? lo_rev : 0u;
        }
    }
    /* Reverse pass: the newest block ends at rest. next_entry = entry ceiling
     * of block k+1 as far as stopping allows; limited = it depends on the
     * queue's end (it was not capped by anything that stays). */
    pk_v2_q4_t next_entry = 0;
    bool limited = !end_known;
    uint32_t anchor = lo_rev < n ? 0u : anchor0;
    bool have_anchor = lo_rev >= n;
    for (uint32_t k = n; k-- > lo_rev;) {
        struct pk_block *b = slot(q, k);
        if (b->type != PK_BLK_LINE) {
            b->v2_exit = 0;
            next_entry = 0;
            limited = false;
            if (!have_anchor) {
                anchor = k;
                have_anchor = true;
            }
            continue;
        }
        b->v2_rev = next_entry;
        b->end_limited = limited;
        pk_v2_q4_t entry = b->v2_rev + (k == 0 ? two_a_s(b->accel, rem_q8) : b->v2_acc);
        pk_v2_q4_t ceil = (k == 0) ? v2_now : b->v2_ceil;
        if (ceil <= entry) {
            next_entry = ceil;
            limited = false;
            /* (not the newest block while the end is unknown: below it
             * everything is end-limited, see the next statement) */
            if (!have_anchor && k > 0u && !(k == n - 1u && !end_known)) {
                anchor = k;
                have_anchor = true;
            }
        } else {
            next_entry = entry;
        }
        /* the newest block's own acceleration is not settled until the next
         * junction is known (a curve after it takes its share): what
         * it allows is not final either */
        if (k == n - 1u && !end_known)
            limited = true;
    }
    if (!have_anchor)
        anchor = lo_rev; /* (the old anchor, capped again: see above) */
    /* Forward pass: from the current speed, acceleration caps each exit. */
    pk_v2_q4_t entry = v2_now;
    if (lo_fwd > 0)
        entry = slot(q, lo_fwd - 1u)->v2_exit; /* (0 for a stop block) */
    for (uint32_t k = lo_fwd; k < n; k++) {
        struct pk_block *b = slot(q, k);
        if (b->type != PK_BLK_LINE) {
            entry = 0;
            continue;
        }
        if (k > 0 && entry > b->v2_ceil)
            entry = b->v2_ceil;
        pk_v2_q4_t reach = entry + (k == 0 ? two_a_s(b->accel, rem_q8) : b->v2_acc);
        pk_v2_q4_t ex = min64(b->v2_rev, min64(reach, b->v2_nom));
        const bool same = ex == b->v2_exit;
        b->v2_exit = ex;
        entry = ex;
        if (same && k > 0u && k + 1u < lo_rev) {
            /* as before from here up to the blocks the reverse pass redid */
            k = lo_rev - 1u;
            entry = slot(q, k)->v2_exit;
        }
    }
    /* The final plans: the blocks from the tail up to the first end-limited
     * line (an exit capped here by the acceleration from the past is not
     * final if it is end-limited: the newest block's acceleration can still
     * drop when a curve follows it, lowering the reverse limit below this
     * cap). */
    uint32_t fin = 0;
    while (fin < n) {
        const struct pk_block *b = slot(q, fin);
        if (b->type == PK_BLK_LINE && b->end_limited)
            break;
        fin++;
    }
    p->n_final = (uint8_t)(fin > 255u ? 255u : fin);
    p->plan_valid = true;
    p->plan_pops = q->pops;
    p->plan_count = (uint16_t)n;
    p->plan_anchor = (uint16_t)anchor;
    p->plan_v2_now = v2_now;
    p->plan_rem_q8 = rem_q8;
    p->plan_end_known = end_known;
}

uint32_t pk_planner_final(const struct pk_planner *p) { return p->n_final; }
