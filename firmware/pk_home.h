/*
 * pk_home.h — Grbl's homing cycle ($H) on the motion core's homing moves.
 *
 * The motion core moves axes into their switches and stops each one as its
 * switch closes (pk_machine_home_seek), and moves off them exempt from the
 * limits (pk_machine_home_pulloff). This module strings those into Grbl
 * 1.1's cycle (limits.c, limits_go_home), run without blocking from the main
 * loop (pk_home_poll):
 *
 *   for each group of axes (Z first, then the others, as Grbl's
 *   HOMING_CYCLE_0 / HOMING_CYCLE_1):
 *     seek    toward the switches, 1.5 x the group's largest travel, at $25
 *     pull-off  away, $27, at $25; every switch of the group must be open
 *     locate  toward the switches, 5 x $27, at $24
 *     pull-off  away, $27, at $25; every switch must be open again
 *     each move followed by a $26 ms pause; each starts with the group's
 *     axes at 0 and runs diagonally at rate x sqrt(axes), so every axis
 *     moves at the rate; the axes of a group stop one by one as their
 *     switches close (axis lock)
 *   then the group's axes are set to Grbl's machine position: -$27 for an
 *   axis homing toward positive (its switch is machine 0, the space is
 *   negative), -travel + $27 for one homing toward negative ($23 bit set).
 *
 * Hard limits are off for the whole cycle and restored after it, as Grbl
 * does. Failures carry Grbl's alarm numbers: 6 reset during the cycle, 7
 * door opened (pk_home_abort), 8 a switch still closed after a pull-off, 9
 * a switch not found within the search distance. After a failure the machine
 * is stopped and idle (or in the core's own ALARM); the caller raises the
 * Grbl alarm.
 *
 * No heap, no float: caller-owned struct pk_home. One cycle at a time per
 * machine. Calling context: MAIN for everything.
 */
#ifndef PLOTKIN_PK_HOME_H
#define PLOTKIN_PK_HOME_H

#include <stdbool.h>
#include <stdint.h>
#include "pk_motion.h"

/** Homing settings (Grbl $23-$27, $130-$133) in plotkin units. */
struct pk_home_cfg {
    uint8_t dir_invert;          /**< $23: bit i set: axis i homes toward negative */
    pk_um_min_t feed;            /**< $24 locate rate, µm/min (PK_UM_MIN_MIN..PK_UM_MIN_MAX) */
    pk_um_min_t seek;            /**< $25 seek rate, µm/min (same range) */
    uint16_t debounce_ms;        /**< $26 pause after each move, 0..10000 ms */
    pk_um_t pulloff_um;          /**< $27 pull-off, 1..PK_UM_MAX/5 µm */
    pk_um_t travel_um[PK_AXES];  /**< $130..: travel per axis, 1..PK_UM_MAX µm */
};

enum pk_home_status {
    PK_HOME_IDLE = 0,    /**< no cycle started */
    PK_HOME_RUNNING = 1, /**< call pk_home_poll again */
    PK_HOME_DONE = 2,    /**< every group homed, positions set */
    PK_HOME_FAIL = 3     /**< stopped; pk_home_fail says why */
};

/** Why a cycle failed: Grbl's alarm numbers. */
enum pk_home_fail {
    PK_HOME_FAIL_NONE = 0,
    PK_HOME_FAIL_RESET = 6,    /**< reset (or a machine alarm) during the cycle */
    PK_HOME_FAIL_DOOR = 7,     /**< safety door opened (pk_home_abort) */
    PK_HOME_FAIL_PULLOFF = 8,  /**< a switch still closed after a pull-off */
    PK_HOME_FAIL_APPROACH = 9  /**< a switch not found within the search distance */
};

/** A cycle (private members). */
struct pk_home {
    struct pk_home_cfg cfg;
    struct pk_machine *m;
    uint8_t group[2];        /**< axes of each group (Z first) */
    uint8_t n_groups, gi;    /**< groups, the one running */
    uint8_t pass;            /**< 0 seek, 1 pull-off, 2 locate, 3 pull-off */
    uint8_t step;            /**< within a pass: 0 start the move, 1 moving, 2 pausing */
    uint8_t status;          /**< enum pk_home_status */
    uint8_t fail;            /**< enum pk_home_fail */
    bool hard_was;           /**< hard limits before the cycle */
    uint64_t until;          /**< STEP_PAUSE: the pause ends at this tick */
};

/**
 * Check cfg and start a cycle on m (IDLE). axes: the axes to home (bit i =
 * axis i), 0 = every axis of the machine that has a limit input.
 * @retval PK_MOTION_OK        started (then call pk_home_poll)
 * @retval PK_MOTION_EINVAL    a setting out of range
 * @retval PK_MOTION_ENOINPUT  an axis to home has no limit input, or none has
 * @retval PK_MOTION_EBUSY     the machine is not IDLE
 * @retval PK_MOTION_EALARM    the machine is in ALARM
 */
int pk_home_start(struct pk_home *h, struct pk_machine *m, const struct pk_home_cfg *cfg,
                  uint8_t axes);

/** Drive the cycle: call from the main loop (after or before
 *  pk_machine_poll). Returns enum pk_home_status. */
int pk_home_poll(struct pk_home *h);

/** Stop a running cycle now (reset the machine) with reason `fail` (e.g.
 *  PK_HOME_FAIL_DOOR); no effect unless running. */
void pk_home_abort(struct pk_home *h, enum pk_home_fail fail);

/** Why the cycle failed (PK_HOME_FAIL_NONE unless PK_HOME_FAIL). */
enum pk_home_fail pk_home_fail(const struct pk_home *h);

#endif
