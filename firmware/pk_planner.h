/*
 * pk_planner.h — look-ahead planner over the motion queue (Grbl-style).
 *
 * For each new straight move the planner computes its geometry (length, unit
 * vector, axis-limited speed and acceleration) and the highest speed at which
 * it may be entered from the previous move (junction deviation):
 *
 *     v_j^2 = a * delta * sin(theta/2) / (1 - sin(theta/2))
 *
 * theta being the angle between the reversed previous direction and the new
 * one (theta = 180 deg for a straight continuation: no limit; theta -> 0 for a
 * reversal: v_j -> 0), a = min(accel of the two moves). Then a reverse pass
 * (newest to oldest, starting from exit speed 0 for the newest move, so the
 * machine can always stop within the queue) and a forward pass (from the speed
 * the step generator has reached now) set every block's exit speed. The speed
 * profile inside a block is a trapezoid (accelerate, cruise, decelerate) that
 * the step generator derives from entry, nominal and exit speed.
 *
 * All arithmetic is integer: speeds squared in pk_v2_q4_t, lengths in µm Q8,
 * unit vectors Q1.30, square roots by pk_isqrt64.
 *
 * Calling context: MAIN only.
 */
#ifndef PLOTKIN_PK_PLANNER_H
#define PLOTKIN_PK_PLANNER_H

#include <stdbool.h>
#include <stdint.h>
#include "pk_mq.h"

/** Limits the planner needs (copied from struct pk_motion_cfg at init). */
struct pk_planner_limits {
    uint8_t axes;
    pk_um_s_t max_rate[PK_AXES];   /**< µm/s per axis */
    pk_um_s2_t accel[PK_AXES];     /**< µm/s^2 per axis */
    pk_um_t junction_dev_um;       /**< Grbl $11 */
};

struct pk_planner {
    struct pk_planner_limits lim;
    uint16_t ovr_feed_pct, ovr_rapid_pct; /**< overrides (100 = none) */
    bool have_prev;               /**< the newest queued block is a LINE to join */
    pk_q30_t prev_u[PK_AXES];     /**< its unit vector */
    pk_um_s2_t prev_accel;
};

/** Initialise with limits (copied). */
void pk_planner_init(struct pk_planner *p, const struct pk_planner_limits *lim);

/** Forget the previous move: the next line starts from a stop. */
void pk_planner_break(struct pk_planner *p);

/**
 * Append a straight move to q.
 * @param d_um     displacement in µm (requested geometry; axes >= lim.axes ignored)
 * @param d_steps  displacement in steps (difference of rounded absolute positions)
 * @param feed     requested speed µm/s (0 = as fast as the axes allow: a rapid,
 *                 scaled by the rapid override; otherwise by the feed override)
 * @retval 1  a block was appended
 * @retval 0  the move has no steps (nothing appended; the geometry still counts
 *            as "previous" only if it had length)
 * @retval -1 q is full (nothing changed)
 * The caller replans (pk_planner_replan) after appending.
 */
int pk_planner_add_line(struct pk_planner *p, struct pk_mq *q, const int32_t d_um[PK_AXES],
                        const pk_steps_t d_steps[PK_AXES], pk_um_s_t feed);

/** Set the overrides (feed 10..200 %, rapid 1..100 %, validated by the caller)
 *  and recompute the nominal speed of every queued line block; the caller
 *  replans. */
void pk_planner_set_override(struct pk_planner *p, struct pk_mq *q, uint16_t feed_pct,
                             uint16_t rapid_pct);

/** Append a stop block (PK_BLK_PEN with tool level, PK_BLK_SPINDLE with value
 *  in `value`, or PK_BLK_DWELL) of wait_ms.
 *  @retval 1 appended, -1 full. Breaks the junction chain. */
int pk_planner_add_stop(struct pk_planner *p, struct pk_mq *q, uint8_t type, uint8_t tool,
                        uint16_t value, uint32_t wait_ms);

/**
 * Reverse + forward pass over every queued block.
 * @param v2_now     speed^2 at which the tail block is (or will be) entered from
 *                   where the step generator is now
 * @param rem_q8     remaining length of the tail block (its full length when
 *                   not started)
 * Postcondition: the newest block has v2_exit = 0; every block's exit speed is
 * reachable from its entry within its length and lets every later block stop.
 */
void pk_planner_replan(struct pk_planner *p, struct pk_mq *q, pk_v2_q4_t v2_now, uint32_t rem_q8);

/** The junction speed^2 limit (Q4) between unit vectors u1 (previous) and u2
 *  (next) for acceleration a and deviation delta (the formula above);
 *  UINT64_MAX when unlimited (straight continuation). Exposed for tests. */
pk_v2_q4_t pk_planner_junction_v2(const pk_q30_t u1[PK_AXES], const pk_q30_t u2[PK_AXES],
                                  uint8_t axes, pk_um_s2_t a, pk_um_t delta);

#endif
