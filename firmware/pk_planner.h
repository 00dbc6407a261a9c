/*
 * pk_planner.h — look-ahead planner over the motion queue (contract; the
 * "why" is at the top of pk_planner.c).
 *
 * For each new straight move the planner computes its geometry from the
 * steps it will really make (length, unit vector, axis-limited speed and
 * acceleration) and the highest speed at which it may be entered from the
 * previous move: the smaller of Grbl's junction deviation and the speed at
 * which the change of direction is within every axis's acceleration over the
 * two moves (the curvature limit of the path the polygon approximates). A
 * reverse pass (the newest move ends at rest, so the machine can always stop
 * within the queue) and a forward pass (from the speed the step generator has
 * reached) set every block's exit speed, and say how many blocks from the
 * oldest have a FINAL plan: one that no later block can change. The step
 * generator only cuts final blocks into chunks (pk_motion.c), which makes the
 * motion a function of the program, not of when its lines arrived.
 *
 * All arithmetic is integer: speeds squared in pk_v2_q4_t, lengths in µm Q8,
 * unit vectors Q1.30, square roots by pk_isqrt64. Calling context: MAIN only.
 */
#ifndef PLOTKIN_PK_PLANNER_H
#define PLOTKIN_PK_PLANNER_H

#include <stdbool.h>
#include <stdint.h>
#include "pk_mq.h"

/** Limits the planner needs (copied from struct pk_motion_cfg at init). */
struct pk_planner_limits {
    uint8_t axes;
    pk_um_s2_t accel_min;          /**< smallest of accel[] (the curve budget is isotropic) */
    pk_um_min_t max_rate[PK_AXES]; /**< µm/min per axis */
    pk_um_s2_t accel[PK_AXES];     /**< µm/s^2 per axis */
    pk_um_t junction_dev_um;       /**< Grbl $11 */
};

struct pk_planner {
    struct pk_planner_limits lim;
    uint16_t ovr_feed_pct, ovr_rapid_pct; /**< overrides (100 = none) */
    bool nom_dirty;               /**< the overrides changed since the last replan: the
                                       queued blocks' v2_nom are recomputed at the next */
    bool have_prev;               /**< the newest queued block is a LINE to join */
    pk_q30_t prev_u[PK_AXES];     /**< its unit vector */
    uint32_t prev_len_q8;         /**< its requested length */
    pk_um_s2_t prev_accel;
    uint8_t n_final;              /**< blocks from the tail with a final plan (last replan) */
    /* The last replan, for the next one (incremental when only blocks were
     * appended since: pk_planner_replan) */
    bool plan_valid;              /**< the fields below describe the queue's current plan */
    bool plan_end_known;
    uint16_t plan_pops, plan_count; /**< the queue's pop count and block count then */
    uint16_t plan_anchor;         /**< the highest index whose reverse-pass value for the
                                       blocks before it did not depend on the blocks after it
                                       (0: none) */
    uint32_t plan_rem_q8;
    pk_v2_q4_t plan_v2_now;
};

/** Initialise with limits (copied). */
void pk_planner_init(struct pk_planner *p, const struct pk_planner_limits *lim);

/** Forget the previous move: the next line starts from a stop. */
void pk_planner_break(struct pk_planner *p);

/** Shares of the acceleration, Q1.15: a curve may use SIDE of the smallest
 *  axis acceleration sideways (centripetal), and the blocks next to a curved
 *  junction ALONG of it along the path; SIDE^2 + ALONG^2 <= 1, so that the two
 *  together never exceed it on any axis (|a_t u_i + a_n n_i| <=
 *  sqrt(a_t^2 + a_n^2), u and n orthogonal). */
#ifndef PK_PLANNER_SIDE_Q15
#define PK_PLANNER_SIDE_Q15 23170u   /* 1/sqrt(2) */
#endif
#ifndef PK_PLANNER_ALONG_Q15
#define PK_PLANNER_ALONG_Q15 23170u  /* 1/sqrt(2) */
#endif
#if (PK_PLANNER_SIDE_Q15 * PK_PLANNER_SIDE_Q15 + PK_PLANNER_ALONG_Q15 * PK_PLANNER_ALONG_Q15) > (1u << 30)
#error "PK_PLANNER_SIDE_Q15^2 + PK_PLANNER_ALONG_Q15^2 must not exceed 1"
#endif
/** A vertex of a smoothed curve is a velocity jump v |u2 - u1|; measured
 *  over any window of PK_PLANNER_KINK_MS it must leave room for the
 *  acceleration along the path: the jump is capped at (1 - ALONG) *
 *  accel_min * PK_PLANNER_KINK_MS (about Grbl's sqrt(8 a delta) at delta =
 *  0.01 mm). The trace checks measure accelerations over such windows. */
#ifndef PK_PLANNER_KINK_MS
#define PK_PLANNER_KINK_MS 40u
#endif

/** Largest |steps| of one line block (longer moves are split by the caller):
 *  keeps the step generator's Bresenham terms (256 x steps) within 2^30. */
#define PK_PLANNER_MAX_STEPS ((uint32_t)1 << 21)

/**
 * Append a straight move to q.
 * @param d_q8     the displacement the steps make, µm Q8 (d_steps[i] * 1000 /
 *                 steps_per_mm[i]; |d_q8[i]| < 2^31, as the steps reproduce
 *                 a displacement within 2 PK_UM_MAX): only a fallback for a
 *                 block without an exact displacement
 * @param d_steps  displacement in steps (|d_steps[i]| <= PK_PLANNER_MAX_STEPS):
 *                 the events and the direction bits
 * @param d_um     the exact displacement requested, µm (|d_um[i]| < 2^23):
 *                 the block is timed by its length and its direction, and
 *                 each axis's rate and acceleration limits hold for it,
 *                 since an axis's steps fall where its exact position
 *                 crosses each half step (pk_motion.c): the whole steps
 *                 only count those crossings, and at a coarse steps/mm they
 *                 can differ from the exact motion by up to a step per axis
 *                 either way (findings M6, M12)
 * @param lead_q8  way before the steps, µm Q8 (moves with no whole step since
 *                 the last block, which took no time): the block's length is
 *                 the exact length plus this, and no event falls in it; the
 *                 axes' limits hold over the exact length alone (M11)
 * @param feed     requested speed, µm/min (0 = a rapid: as fast as the axes
 *                 allow, scaled by the rapid override; else the feed override
 *                 applies)
 * @param flags    PK_PLAN_* bits
 * @retval 1  a block was appended (the newest in q; the caller fills in its
 *            Bresenham terms, pk_mq.h)
 * @retval 0  the move has no steps (nothing appended)
 * @retval -1 q is full (nothing changed)
 * The caller replans (pk_planner_replan) after appending.
 */
int pk_planner_add_line(struct pk_planner *p, struct pk_mq *q, const int32_t d_q8[PK_AXES],
                        const pk_steps_t d_steps[PK_AXES], const int32_t d_um[PK_AXES],
                        uint32_t lead_q8, pk_um_min_t feed, uint8_t flags);
/** pk_planner_add_line flags. */
enum {
    PK_PLAN_SHARP = 1       /**< the junction with the previous move is a programmed
                                 corner (Grbl's junction deviation applies); else it is
                                 a vertex of a smoothed curve (velocity jump capped) */
};

/** Append a stop block (PK_BLK_PEN with tool level, PK_BLK_SPINDLE with value
 *  in `value`, or PK_BLK_DWELL) of wait_ms.
 *  @retval 1 appended, -1 full. Breaks the junction chain. */
int pk_planner_add_stop(struct pk_planner *p, struct pk_mq *q, uint8_t type, uint8_t tool,
                        uint16_t value, uint32_t wait_ms);

/** Set the overrides (feed 10..200 %, rapid 1..100 %, validated by the caller);
 *  queued blocks take them at the next replan. */
void pk_planner_set_override(struct pk_planner *p, uint16_t feed_pct, uint16_t rapid_pct);

/**
 * Reverse + forward pass over every queued block.
 * @param v2_now     speed^2 at which the tail block is (or will be) entered from
 *                   where the step generator is now
 * @param rem_q8     remaining length of the tail block (its full length when
 *                   not started)
 * @param end_known  true if nothing will be appended behind the newest block
 *                   before it has run (end of program, a flushed stroke, a
 *                   full queue): its stop is then real, not a look-ahead limit
 * Postcondition: the newest block has v2_exit = 0; every block's exit speed is
 * reachable from its entry within its length and lets every later block stop;
 * pk_planner_final() blocks from the tail have exits no later block can change.
 */
void pk_planner_replan(struct pk_planner *p, struct pk_mq *q, pk_v2_q4_t v2_now, uint32_t rem_q8,
                       bool end_known);

/** Blocks from the tail whose plan is final (as of the last replan). */
uint32_t pk_planner_final(const struct pk_planner *p);

/** The kink cap (Q4): v^2 such that the velocity jump v |u2 - u1| is at most
 *  jump_um_s. UINT64_MAX for no turn. */
pk_v2_q4_t pk_planner_kink_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                              uint8_t axes, uint32_t jump_um_s);

/** The shares and caps the planner applies at a junction, for a policy that
 *  wants to compare a kink with a blend (pk_stroke.c). */
struct pk_planner_dyn {
    pk_um_s2_t a_min;      /**< smallest axis acceleration */
    pk_um_s2_t a_side;     /**< the sideways share of it (curvature) */
    uint32_t jump_um_s;    /**< the kink cap at vertices of smoothed curves */
    pk_um_t delta_um;      /**< Grbl's junction deviation at programmed corners */
};
void pk_planner_dyn(const struct pk_planner_limits *lim, struct pk_planner_dyn *d);

/** Nominal speed^2 of a line block under the overrides in force. */
pk_v2_q4_t pk_planner_nominal_v2(const struct pk_planner *p, const struct pk_block *b);

/** The junction speed^2 limit (Q4) between unit vectors u1 (previous) and u2
 *  (next) for acceleration a and deviation delta (Grbl's formula);
 *  UINT64_MAX when unlimited (straight continuation). Exposed for tests. */
pk_v2_q4_t pk_planner_junction_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                  uint8_t axes, pk_um_s2_t a, pk_um_t delta);

/** min(pk_planner_junction_v2(u1, u2, axes, a, delta), cap), the same value,
 *  and *cap_below = whether cap is below that junction limit. Cheaper when
 *  a bound shows the junction limit above cap: then it is not computed
 *  (its root and 64-bit division; the caller's cap, e.g. the curvature
 *  limit, rules). */
pk_v2_q4_t pk_planner_junction_min_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                      uint8_t axes, pk_um_s2_t a, pk_um_t delta, pk_v2_q4_t cap,
                                      bool *cap_below);

/** The curvature limit (Q4): the largest v^2 such that turning from u1 to u2
 *  over the shorter of two moves of lengths l1, l2 (µm Q8) needs at most the
 *  acceleration a sideways: v^2 <= a min(l1, l2) / |u2 - u1| (a polygon with
 *  chords l on a curve of radius r turns by l / r: v^2 <= a r). UINT64_MAX
 *  for no turn. Exposed for tests. */
pk_v2_q4_t pk_planner_curvature_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                   uint8_t axes, uint32_t l1_q8, uint32_t l2_q8, pk_um_s2_t a);

#endif
