/*
 * pk_planner.c — look-ahead planner (see pk_planner.h for the contract).
 *
 * Why this shape (after Grbl's planner.c):
 *
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
 * works on squared speeds only (no square root while planning). Each block has
 * a ceiling (its nominal speed), an entry ceiling (the junction limit), and
 * the reverse pass pulls exit speeds down so each block can decelerate to the
 * next one's entry; the forward pass caps them by what acceleration from the
 * current speed can reach. Blocks are few (PK_MQ_CAP), so both passes simply
 * run over the whole queue each time a block is added.
 *
 * Fixed-point budget: len_q8 < 2^31 (|d| <= 2*PK_UM_MAX per axis, 3 axes:
 * sqrt(3) * 2^22 µm * 2^8 < 2^31), accel < 2^27, so 2*a*len in Q4 is
 * 2 * a * len_q8 / 16 < 2^55. Speeds^2 Q4 < 2^44.
 */
#include <string.h>
#include "pk_planner.h"

static pk_v2_q4_t v2_of(pk_um_s_t v) { return ((pk_v2_q4_t)v * v) << PK_V2_Q4_SHIFT; }

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

/* Nominal speed^2 of a line block under the overrides in force. */
static pk_v2_q4_t nominal_v2(const struct pk_planner *p, const struct pk_block *b)
{
    uint64_t v = b->rapid ? (uint64_t)b->v_lim * p->ovr_rapid_pct / 100u
                          : (uint64_t)b->v_req * p->ovr_feed_pct / 100u;
    if (v > b->v_lim)
        v = b->v_lim;
    if (v == 0)
        v = 1;
    return v2_of((pk_um_s_t)v);
}

void pk_planner_set_override(struct pk_planner *p, struct pk_mq *q, uint16_t feed_pct,
                             uint16_t rapid_pct)
{
    p->ovr_feed_pct = feed_pct;
    p->ovr_rapid_pct = rapid_pct;
    for (uint32_t k = 0; k < pk_mq_count(q); k++) {
        struct pk_block *b = pk_mq_at(q, k);
        if (b->type == PK_BLK_LINE)
            b->v2_nom = nominal_v2(p, b);
    }
}

void pk_planner_break(struct pk_planner *p) { p->have_prev = false; }

pk_v2_q4_t pk_planner_junction_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                  uint8_t axes, pk_um_s2_t a, pk_um_t delta)
{
    /* d = u1.u2 in Q30. The turn angle phi between the directions has
     * cos(phi) = d; Grbl's theta = pi - phi, so sin(theta/2) = cos(phi/2) and
     * 1 - sin(theta/2) = (1 - cos^2(phi/2)) / (1 + cos(phi/2))
     *                  = h / (1 + s),  h = (1 - d)/2 = sin^2(phi/2), s = cos(phi/2).
     * Hence v^2 = a*delta * s * (1 + s) / h, with h computed directly from d,
     * which keeps its precision for the small turns of dense polylines. */
    int64_t d = 0;
    for (unsigned i = 0; i < axes; i++)
        d += (int64_t)u1[i] * u2[i];
    d = pk_rshift_round64(d, 30);
    if (d > PK_Q30_ONE)
        d = PK_Q30_ONE;
    if (d < -PK_Q30_ONE)
        d = -PK_Q30_ONE;
    int64_t h = (PK_Q30_ONE - d) / 2;            /* Q30, 0..2^30 */
    if (h <= 0)
        return UINT64_MAX;                       /* straight on: no junction limit */
    uint64_t s2 = (uint64_t)(PK_Q30_ONE + d) / 2; /* cos^2(phi/2), Q30 */
    uint64_t s = pk_isqrt64(s2 << 30);           /* Q30 */
    if (s == 0 || delta == 0)
        return 0;                                /* full reversal or exact stop */
    uint64_t r = (s * (PK_Q30_ONE + s)) >> 30;   /* s(1+s), Q30, < 2^31 */
    uint64_t q = (r << 20) / (uint64_t)h;        /* s(1+s)/h, Q20 */
    uint64_t ad = (uint64_t)a * (uint64_t)delta; /* < 2^27 * 2^14 = 2^41 */
    /* v2 (Q4) = ad * q >> 16; saturate */
    if (q != 0 && ad > (UINT64_MAX >> 1) / q)
        return UINT64_MAX;
    return (ad * q) >> 16;
}

int pk_planner_add_line(struct pk_planner *p, struct pk_mq *q, const int32_t d_um[PK_AXES],
                        const pk_steps_t d_steps[PK_AXES], pk_um_s_t feed)
{
    const uint8_t axes = p->lim.axes;
    uint64_t ss = 0;
    uint32_t events = 0;
    for (unsigned i = 0; i < axes; i++) {
        int64_t d = d_um[i];
        ss += (uint64_t)(d * d);
        uint32_t st = (uint32_t)(d_steps[i] < 0 ? -d_steps[i] : d_steps[i]);
        if (st > events)
            events = st;
    }
    if (events == 0 || ss == 0)
        return 0;
    if (pk_mq_room(q) == 0)
        return -1;
    uint32_t len_q8 = pk_isqrt64(ss << 16);   /* ss < 3 * 2^44: << 16 < 2^62 */
    if (len_q8 == 0)
        len_q8 = 1;
    struct pk_block *b = pk_mq_push(q);
    b->type = PK_BLK_LINE;
    b->events = events;
    b->len_q8 = len_q8;
    uint64_t v_nom = PK_UM_S_MAX;
    uint64_t acc = PK_UM_S2_MAX;
    for (unsigned i = 0; i < axes; i++) {
        int64_t d = d_um[i];
        b->steps[i] = (uint32_t)(d_steps[i] < 0 ? -d_steps[i] : d_steps[i]);
        if (d_steps[i] > 0 || (d_steps[i] == 0 && d > 0))
            b->dir_mask = (uint8_t)(b->dir_mask | (1u << i));
        b->u[i] = (pk_q30_t)(((d < 0 ? -1 : 1) * (int64_t)(((uint64_t)(d < 0 ? -d : d) << 38) / len_q8)));
        if (d == 0)
            continue;
        uint64_t ad = (uint64_t)(d < 0 ? -d : d) << 8; /* |d| Q8 */
        /* axis speed = v * |d|/len <= max_rate  =>  v <= max_rate * len / |d| */
        uint64_t vl = (uint64_t)p->lim.max_rate[i] * len_q8 / ad;
        uint64_t al = (uint64_t)p->lim.accel[i] * len_q8 / ad;
        if (vl < v_nom)
            v_nom = vl;
        if (al < acc)
            acc = al;
    }
    if (v_nom == 0)
        v_nom = 1;
    if (acc == 0)
        acc = 1;
    b->accel = (pk_um_s2_t)acc;
    b->rapid = feed == 0u;
    b->v_lim = (pk_um_s_t)v_nom;
    b->v_req = feed;
    b->v2_nom = nominal_v2(p, b);
    pk_v2_q4_t vj = 0;
    if (p->have_prev) {
        pk_um_s2_t a = p->prev_accel < b->accel ? p->prev_accel : b->accel;
        vj = pk_planner_junction_v2(p->prev_u, b->u, axes, a, p->lim.junction_dev_um);
    }
    b->v2_junction = vj;
    b->v2_exit = 0;
    p->have_prev = true;
    memcpy(p->prev_u, b->u, sizeof p->prev_u);
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

/* Highest entry speed^2 of line block k (k > 0): the junction limit, and
 * neither neighbour's nominal speed (both may change with the overrides). */
static pk_v2_q4_t entry_ceiling(struct pk_mq *q, uint32_t k)
{
    const struct pk_block *b = pk_mq_at(q, k), *a = pk_mq_at(q, k - 1u);
    pk_v2_q4_t c = min64(b->v2_junction, b->v2_nom);
    if (a->type == PK_BLK_LINE)
        c = min64(c, a->v2_nom);
    return c;
}

void pk_planner_replan(struct pk_planner *p, struct pk_mq *q, pk_v2_q4_t v2_now, uint32_t rem_q8)
{
    (void)p;
    uint32_t n = pk_mq_count(q);
    if (n == 0)
        return;
    /* Reverse pass: the newest block ends at rest. next_entry = entry ceiling
     * of block i+1 as far as stopping allows. */
    pk_v2_q4_t next_entry = 0;
    for (uint32_t k = n; k-- > 0;) {
        struct pk_block *b = pk_mq_at(q, k);
        if (b->type != PK_BLK_LINE) {
            b->v2_exit = 0;
            next_entry = 0;
            continue;
        }
        b->v2_exit = next_entry;
        uint32_t len = (k == 0) ? rem_q8 : b->len_q8;
        pk_v2_q4_t entry = b->v2_exit + two_a_s(b->accel, len);
        pk_v2_q4_t ceil = (k == 0) ? v2_now : entry_ceiling(q, k);
        next_entry = min64(entry, ceil);
    }
    /* Forward pass: from the current speed, acceleration caps each exit. */
    pk_v2_q4_t entry = v2_now;
    for (uint32_t k = 0; k < n; k++) {
        struct pk_block *b = pk_mq_at(q, k);
        if (b->type != PK_BLK_LINE) {
            entry = 0;
            continue;
        }
        if (k > 0 && entry > entry_ceiling(q, k))
            entry = entry_ceiling(q, k);
        uint32_t len = (k == 0) ? rem_q8 : b->len_q8;
        pk_v2_q4_t reach = entry + two_a_s(b->accel, len);
        pk_v2_q4_t ex = min64(b->v2_exit, min64(reach, b->v2_nom));
        b->v2_exit = ex;
        entry = ex;
    }
}
