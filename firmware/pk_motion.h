/*
 * pk_motion.h — the machine-level API of plotkin's motion core (public contract).
 *
 * One struct pk_machine is one machine: the stroke assembler (which feeds
 * consecutive feed moves through the refinement kernel, pk_refine.h), the
 * motion queue of planned blocks (pk_mq.h), the look-ahead planner
 * (pk_planner.h) and the step generator (pk_stepgen.h). The caller owns the
 * storage (static, stack or inside a bigger struct); there is no heap and no
 * global state, so one process may run several machines side by side.
 *
 * Data flow and calling contexts:
 *
 *   producer (G-code, MAIN)            main loop (MAIN)               step timer (ISR)
 *   pk_machine_move/pen/dwell/...  ->  pk_machine_poll():             pk_machine_timer_cb():
 *     [request FIFO, PK_MACHINE_INQ]     strokes -> kernel -> planner   step/dir pulses,
 *                                        -> motion queue -> chunks  ->  integer adds only
 *
 * Every request call only appends to a small request FIFO and never blocks.
 * When the FIFO is full it returns PK_MOTION_EFULL and changes nothing: the
 * producer keeps the request (e.g. stops reading lines), calls
 * pk_machine_poll() and retries. pk_machine_room() says beforehand how many
 * requests would be accepted, so a line parser can check before it consumes
 * a line. Nothing is ever dropped: when the motion queue is full the kernel is
 * simply not pulled (it is pull-based) and the FIFO waits.
 *
 * Strokes. Consecutive feed moves form a stroke. A stroke ends at a rapid, a
 * pen change, a dwell, a feed-rate change, a smoothing-mode change, end of
 * program, at a corner sharper than pk_smooth_cfg.sharp_turn_deg (kept sharp),
 * and when nothing new has arrived while the motion queue is about to run dry
 * (so a sender that stops mid-stroke still sees its stroke completed).
 *
 * Units (all integer; formats named in the type, ranges checked at the API):
 *   pk_um_t         position, µm (pk_fixed.h), |v| <= PK_UM_MAX
 *   pk_um_min_t     speed, µm per minute: a G-code F word (mm/min) with three
 *                   decimals is exact; 1 .. PK_UM_MIN_MAX
 *   pk_um_s2_t      acceleration, µm/s^2: Grbl's $120 (mm/s^2) with three
 *                   decimals is exact; 1 .. PK_UM_S2_MAX
 *   pk_spmm_q16_t   steps per mm in unsigned Q16.16 (80 steps/mm = 80 << 16);
 *                   PK_SPMM_Q16_MIN .. PK_SPMM_Q16_MAX
 *   pk_steps_t      position in whole motor steps
 *   ticks           durations in HAL timer ticks (struct pk_hal.tick_hz)
 *
 * Position contract: the step position reported is exactly the number of step
 * pulses the HAL accepted (signed by direction). A commanded target in µm maps
 * to round(um * steps_per_mm / 1000) steps (ties away from zero), per axis,
 * absolute; every move is the difference of two such roundings, so the sum of
 * all moves never drifts, whatever the smoothing.
 *
 * Errors in the ISR (a HAL write returning non-zero) take one route: the
 * machine latches PK_STATE_ALARM with a reason, writes nothing more to the
 * step lines after the failing call (it does not even try to lower a step
 * line whose raise failed), stops the timer, and keeps the reported position
 * equal to the pulses actually emitted. Only pk_machine_reset() leaves ALARM.
 *
 * Inputs (hal.h: limit switches, probe, door, buttons), when the board has
 * them. The core registers an edge callback with the HAL at init (or, for a
 * board without edge reports, reads the inputs itself) and offers:
 *  - hard limits (pk_machine_set_hard_limits, Grbl $21): a limit switch that
 *    closes, or one found closed when a line block starts, stops the step
 *    output at the next step event (no pulse after it, no deceleration) and
 *    latches PK_ALARM_HARD_LIMIT; the position stays the pulses emitted;
 *  - a probing move (pk_machine_probe, G38.2-G38.5): at the contact the
 *    position is recorded exactly (the pulses emitted before it), the machine
 *    decelerates to a stop within its acceleration limits (a feed hold) and
 *    the rest of the move is dropped; no contact by the end of the move is
 *    reported as PK_CYCLE_MISSED (pk_machine_cycle);
 *  - a homing move (pk_machine_home_seek): axes run toward their switches,
 *    each stops at once when its switch closes (Grbl's axis lock), and the
 *    move ends when all have (the cycle of pull-offs and locate moves is
 *    pk_home.h's);
 *  - the input levels and the buttons pressed (pk_machine_inputs,
 *    pk_machine_input_events), for status reports and the Grbl buttons.
 * The step path costs one byte test per step event and per chunk while no
 * watch (hard limits, probe, homing) is armed.
 */
#ifndef PLOTKIN_PK_MOTION_H
#define PLOTKIN_PK_MOTION_H

#include <stdbool.h>
#include <stdint.h>
#include "hal.h"
#include "pk_fixed.h"
#include "pk_refine.h"
#include "pk_munits.h"
#include "pk_mq.h"
#include "pk_planner.h"
#include "pk_stepgen.h"
#include "pk_stroke.h"

/** 1 when this build's kernel can run DLG (built in, and PK_WIN >= 4 for its
 *  window), the only scheme whose path leaves the hull of its control points
 *  (the soft-limit check then bounds it, pk_motion.c). */
#define PK_MOTION_DLG (PK_BUILD_DLG && PK_WIN >= 4)

/** Requests (moves, pen, dwell, mode changes, end) buffered before poll. */
#ifndef PK_MACHINE_INQ
#define PK_MACHINE_INQ 8
#endif

/** Status codes of the machine API (distinct from enum pk_status). */
enum pk_motion_status {
    PK_MOTION_OK = 0,
    PK_MOTION_EFULL = -20,  /**< request FIFO full: nothing changed; poll, then retry */
    PK_MOTION_ERANGE = -21, /**< a value outside its documented range; nothing changed */
    PK_MOTION_EINVAL = -22, /**< bad configuration (init / set_smoothing) */
    PK_MOTION_EALARM = -23, /**< the machine is in ALARM: reset first; nothing changed */
    PK_MOTION_EHAL = -24,   /**< init: the HAL failed pk_hal_check() or a write failed */
    PK_MOTION_EBUSY = -25,  /**< configure: the machine is not idle; nothing changed */
    PK_MOTION_ETRAVEL = -26, /**< soft limits on: the move (or the smoothed path it
                                 makes) would leave the travel box; nothing changed */
    PK_MOTION_ENOINPUT = -27, /**< the board has no such input (probe, limit switch);
                                   nothing changed */
    PK_MOTION_ETRIGGERED = -28 /**< probe: already in the state the move waits for
                                    (Grbl ALARM:4); nothing changed */
};

/** Machine state as reported to the user (maps onto Grbl's Idle/Run/Hold/Alarm). */
enum pk_machine_state {
    PK_STATE_IDLE = 0,    /**< no motion executing and none planned */
    PK_STATE_RUN = 1,     /**< executing or about to (blocks queued, timer armed) */
    PK_STATE_HOLDING = 2, /**< feed hold requested, still decelerating (Grbl Hold:1) */
    PK_STATE_HOLD = 3,    /**< feed hold complete, stopped, queue kept (Grbl Hold:0) */
    PK_STATE_ALARM = 4    /**< a HAL write failed or a hard limit tripped; outputs
                               frozen until reset */
};

/** Why the machine is in ALARM. */
enum pk_alarm {
    PK_ALARM_NONE = 0,
    PK_ALARM_STEP_WRITE = 1,  /**< pk_hal_step_write returned non-zero */
    PK_ALARM_DIR_WRITE = 2,   /**< pk_hal_dir_write returned non-zero */
    PK_ALARM_TOOL_WRITE = 3,  /**< pk_hal_tool_write returned non-zero */
    PK_ALARM_TIMER = 4,       /**< timer_start failed */
    PK_ALARM_INTERNAL = 5,    /**< an invariant failed (a bug): motion stopped */
    PK_ALARM_SPINDLE_WRITE = 6, /**< pk_hal_spindle_write returned an error other than ENOSYS */
    PK_ALARM_HARD_LIMIT = 7,  /**< hard limits on and a limit switch closed (Grbl ALARM:1) */
    PK_ALARM_INPUT_READ = 8   /**< pk_hal_input_read failed while the inputs were watched */
};

/** Outcome of the last probing or homing move (pk_machine_cycle). */
enum pk_cycle_result {
    PK_CYCLE_NONE = 0,     /**< none since init */
    PK_CYCLE_RUNNING = 1,  /**< under way (the machine takes no other request) */
    PK_CYCLE_DONE = 2,     /**< probe: contact made; homing: every switch closed */
    PK_CYCLE_MISSED = 3,   /**< the move ended first (Grbl ALARM:5 / ALARM:9) */
    PK_CYCLE_ABORTED = 4   /**< pk_machine_reset or an alarm ended it */
};

/** Kind of a linear move. */
enum pk_move_kind {
    PK_MOVE_FEED = 0,  /**< G1: at the given feed, smoothed within a stroke */
    PK_MOVE_RAPID = 1  /**< G0: at the axes' max rates, never smoothed, ends the stroke */
};

/** Smoothing mode (per machine, changeable per program). */
enum pk_smooth_mode {
    PK_SMOOTH_OFF = 0,       /**< exact path (G61): the kernel is bypassed */
    PK_SMOOTH_FIXED = 1,     /**< fixed scheme, degree and depth */
    PK_SMOOTH_TOLERANCE = 2  /**< G64 P<T>: within T of the limit curve, fewest segments */
};

/** Smoothing policy. Zero-initialise, then set what you need. */
struct pk_smooth_cfg {
    uint8_t mode;            /**< enum pk_smooth_mode */
    uint8_t scheme;          /**< enum pk_scheme (FIXED; TOLERANCE uses B-spline only) */
    uint8_t degree;          /**< B-spline degree: FIXED 1..7; TOLERANCE 2 or 3 (0 = 3) */
    uint8_t depth;           /**< FIXED: 0..PK_MAX_DEPTH; TOLERANCE: ignored (chosen) */
    pk_um_t tolerance_um;    /**< TOLERANCE: 1 .. 10000 µm */
    uint16_t sharp_turn_deg; /**< a vertex whose direction turns by MORE than this
                                  many degrees (1..180) is kept sharp: the stroke is
                                  split there. 180 never splits. 0 means 60. */
};

/** Machine settings (Grbl $-settings in plotkin units). Zero-initialise, then fill. */
struct pk_motion_cfg {
    uint8_t axes;                             /**< axes driven, 2..PK_AXES (0 = PK_AXES) */
    pk_spmm_q16_t steps_per_mm_q16[PK_AXES];  /**< $100.. steps per mm, Q16.16 */
    pk_um_min_t max_rate[PK_AXES];            /**< $110.. per-axis max speed, µm/min */
    pk_um_s2_t accel[PK_AXES];                /**< $120.. per-axis acceleration, µm/s^2 */
    pk_um_t junction_dev_um;                  /**< $11 junction deviation, 0..10000 µm */
    uint32_t step_pulse_ticks;                /**< minimum step pulse width, >= 1 tick */
    uint32_t dir_setup_ticks;                 /**< direction set-up before a step edge, ticks */
    uint32_t pen_settle_ms;                   /**< dwell after each pen change, 0..60000 ms */
    uint8_t pen_down_level;                   /**< logical tool level meaning "pen down" (0/1) */
    uint16_t input_invert;                    /**< PK_IN_* bits whose sense is flipped on
                                                   top of the board's polarity (Grbl $5
                                                   limits, $6 probe); 0: as wired */
    uint16_t lookahead_wait_ms;               /**< $207: how long a stroke waits for its next
                                                   move once everything before it has been
                                                   executed, before it is ended there
                                                   (0 = PK_LOOKAHEAD_WAIT_MS_DEFAULT; see
                                                   pk_machine_poll) */
    struct pk_smooth_cfg smooth;              /**< initial smoothing policy */
};

/** One request waiting in the FIFO (private). */
struct pk_req {
    uint8_t type;              /**< PK_REQ_* (pk_motion.c) */
    uint8_t kind;              /**< move kind / pen level */
    union {                    /* (a smoothing request carries nothing else) */
        struct {
            pk_um_t p[PK_AXES];   /**< move target, µm */
            uint32_t arg;         /**< feed µm/min, dwell ms */
            pk_um_t chord_err_um; /**< feed move: chord error already spent (0: a programmed vertex) */
        };
        struct pk_smooth_cfg smooth; /**< PK_REQ_SMOOTH: the policy */
    };
};

/** The caller has urgent work (pk_machine_set_yield); MAIN, cheap, no call
 *  back into the machine. */
typedef bool (*pk_machine_yield_fn)(void *ctx);

/**
 * One machine. Caller-owned; all members are private (use the functions).
 * Lifetime: valid from pk_machine_init until the caller frees the storage;
 * the HAL instance passed to init must outlive it. Never copy a running one
 * (the timer holds its address).
 */
struct pk_machine {
    struct pk_motion_cfg cfg;
    const struct pk_hal *hal;
    struct pk_req inq[PK_MACHINE_INQ];   /**< request FIFO (MAIN only) */
    uint8_t inq_head, inq_count;
    struct pk_stroke stroke;             /**< stroke assembler + kernel */
    struct pk_mq mq;                     /**< planned blocks, shared with the ISR */
    struct pk_planner planner;           /**< look-ahead (MAIN) */
    struct pk_stepgen sg;                /**< chunk prep (MAIN) + pulse emission (ISR) */
    pk_steps_t target_steps[PK_AXES];    /**< last planned position, steps (MAIN) */
    pk_um_t target_um[PK_AXES];          /**< exact position the plan has reached, µm:
                                              where the next block starts (MAIN) */
    pk_um_t timed_um[PK_AXES];           /**< exact position the last planned block's
                                              time reaches: a move with no whole step
                                              adds no block, so target_um moves on
                                              without it; the next block's exact
                                              motion (its steps' placement and its
                                              axes' limits) starts here (finding M6) */
    struct pk_axconv {                   /* an axis's last coordinate converted to steps
                                              (plan_piece; MAIN): a block's start is the
                                              last one's end, a still axis's end its
                                              start; spmm 0 = none */
        pk_um_t um;
        pk_spmm_q16_t spmm;
        pk_steps_t st;                   /* pk_um_to_steps(um, spmm) */
        int64_t q8;                      /* um_to_q8steps(um, spmm), pk_motion.c */
    } conv[PK_AXES];
    pk_um_t req_z_um;                    /**< Z of the last move taken from the FIFO: a feed
                                              move that changes it bypasses smoothing (MAIN) */
    pk_um_min_t stroke_feed;             /**< feed of the open stroke, µm/min (MAIN) */
    bool line_pending;                   /**< a straight move is being planned in pieces */
    pk_um_t line_p[PK_AXES];             /**< its end (MAIN) */
    pk_um_min_t line_feed;
    bool line_sharp;                     /**< its end is a corner */
    bool junction_sharp;                 /**< the junction at target_um is a programmed corner */
    bool replan;                         /**< the plan must be recomputed (MAIN) */
    bool flush;                          /**< nothing follows what is queued (end of
                                              program, or the look-ahead waited
                                              lookahead_wait_ms for input) */
    bool was_full;                       /**< the queue was full at the last replan */
    uint16_t poll_points;                /**< stroke points planned in this poll (MAIN) */
    pk_machine_yield_fn yield;           /**< true: return from the poll early (pk_machine_set_yield) */
    void *yield_ctx;
    bool plan_fresh;                     /**< the plan of the blocks it made final still
                                              holds: only blocks were appended since
                                              the last replan (MAIN; prep_final) */
    uint64_t wait_since;                 /**< tick since which input is awaited (0: not) */
    pk_stroke_observer observe;          /**< see pk_machine_set_observer */
    void *observe_ctx;
    uint32_t lines_planned;              /**< line blocks planned since init (MAIN) */
    bool hold_req;                       /**< feed hold requested (MAIN) */
    uint16_t spindle_q16;                /**< spindle value for the next line blocks (MAIN) */
    uint16_t ovr_feed_pct, ovr_rapid_pct;/**< overrides in force (MAIN) */
    bool soft_on;                        /**< soft limits on (MAIN) */
    struct pk_smooth_cfg acc_policy;     /**< policy the next accepted moves will get (MAIN) */
    struct pk_smooth_cfg policy_applied; /**< policy of the stroke assembler now (MAIN) */
    pk_um_t soft_lo[PK_AXES], soft_hi[PK_AXES];
    /* acceptance-time bound of the smoothed path (DLG can leave the hull of its
     * control points by at most max|second difference|/4 per axis) */
    uint8_t acc_n;                       /**< feed targets in the run so far (0..2) */
    pk_um_t acc_last[PK_AXES];           /**< the last accepted position */
    pk_um_t acc_lo[PK_AXES], acc_hi[PK_AXES]; /**< box of the run's control points */
#if PK_MOTION_DLG
    pk_um_t acc_prev[PK_AXES];           /**< the accepted position before it */
    uint32_t acc_d2[PK_AXES];            /**< max |second difference| per axis in the run */
#endif
    /* inputs (MAIN) */
    bool in_poll;                        /**< the board reports no input edges */
    bool hard_limits;                    /**< hard limits on */
    uint8_t cycle;                       /**< probing / homing move running (pk_motion.c) */
    bool cycle_stop;                     /**< the probe made contact: stopping, then drop */
    uint8_t cycle_result;                /**< enum pk_cycle_result of the last one */
    uint8_t cycle_tripped;               /**< homing: axes whose switch closed */
    pk_steps_t cycle_pos[PK_AXES];       /**< probe: position at the contact (or the end) */
};

/**
 * Initialise a machine: validate cfg, check the HAL, write all direction lines
 * to logical 0, all step lines low, enable the drivers (if the HAL has
 * enable_write), pen up. Position = 0 steps on every axis.
 * @param m    storage to initialise (any previous content ignored)
 * @param cfg  settings, copied
 * @param hal  HAL instance; must outlive m
 * @retval PK_MOTION_OK      ready
 * @retval PK_MOTION_EINVAL  a setting is out of range (nothing else is valid then)
 * @retval PK_MOTION_EHAL    pk_hal_check failed or an initial write failed
 * Calling context: MAIN, timer not running.
 */
int pk_machine_init(struct pk_machine *m, const struct pk_motion_cfg *cfg,
                    const struct pk_hal *hal);

/**
 * Change the settings of an initialised machine without losing its position
 * (Grbl's $-settings): validated like init; the step position is kept (the
 * µm position follows the new steps/mm, as in Grbl); the pins are not
 * touched. Axes newly enabled by cfg->axes start at 0 steps.
 * @retval PK_MOTION_OK      applied
 * @retval PK_MOTION_EINVAL  a setting is out of range; nothing changed
 * @retval PK_MOTION_EBUSY   not IDLE or ALARM (motion, queue or requests
 *                           pending, or a probing / homing move); nothing changed
 * Calling context: MAIN.
 */
int pk_machine_configure(struct pk_machine *m, const struct pk_motion_cfg *cfg);

/**
 * Request a straight move to an absolute target (µm, axes beyond cfg.axes
 * ignored). FEED moves join the current stroke (a different feed ends it);
 * RAPID moves end the stroke and run at the axes' max rates (feed ignored).
 * @param feed  µm/min (PK_MOVE_FEED: PK_UM_MIN_MIN..PK_UM_MIN_MAX; clamped to
 *              the axes' max rates along the move's direction by the planner)
 * @retval PK_MOTION_OK      queued
 * @retval PK_MOTION_EFULL   the request FIFO is full; nothing changed
 * @retval PK_MOTION_ERANGE  a coordinate beyond ±PK_UM_MAX or feed out of range
 * @retval PK_MOTION_EALARM  machine in ALARM
 * Calling context: MAIN.
 */
int pk_machine_move(struct pk_machine *m, const pk_um_t target[PK_AXES],
                    pk_um_min_t feed, enum pk_move_kind kind);

/**
 * A feed move to a chord vertex of a flattened curve (an arc, a G5/G5.1
 * Bézier): the chords are within chord_err_um (0..10000) of the programmed
 * curve, so in tolerance mode the smoother spends only tolerance - chord_err_um
 * at the vertices next to this move, and the executed path stays within the
 * tolerance of the programmed curve. Otherwise as pk_machine_move(FEED).
 * @retval as pk_machine_move; PK_MOTION_ERANGE also for chord_err_um > 10000
 * Calling context: MAIN.
 */
int pk_machine_move_chord(struct pk_machine *m, const pk_um_t target[PK_AXES],
                          pk_um_min_t feed, pk_um_t chord_err_um);

/** Request pen down (down = true) or up: ends the stroke, brings the machine to
 *  a stop, switches the tool output (cfg.pen_down_level) and dwells
 *  cfg.pen_settle_ms. Returns as pk_machine_move. Calling context: MAIN. */
int pk_machine_pen(struct pk_machine *m, bool down);

/** Smallest feed accepted (µm/min): 1 mm/min. Slower feeds are refused with
 *  PK_MOTION_ERANGE rather than run at a rounded speed. */
#define PK_UM_MIN_MIN 1000u
/** Default of pk_motion_cfg.lookahead_wait_ms. */
#define PK_LOOKAHEAD_WAIT_MS_DEFAULT 100u

/** Request a dwell (G4) of ms milliseconds (0..PK_DWELL_MS_MAX) after a full
 *  stop. Returns as pk_machine_move. Calling context: MAIN. */
int pk_machine_dwell(struct pk_machine *m, uint32_t ms);
#define PK_DWELL_MS_MAX 86400000u /**< 24 h; longer dwells are refused (ERANGE) */

/** Request a new smoothing policy (G61 / G64 P<T>); ends the stroke; applies
 *  to the following moves. PK_MOTION_EINVAL if *s is invalid (nothing changed),
 *  else returns as pk_machine_move. Calling context: MAIN. */
int pk_machine_set_smoothing(struct pk_machine *m, const struct pk_smooth_cfg *s);

/**
 * Spindle / laser / servo output (HAL spindle_write, value in Q0.16 of full
 * scale, 0 = off). sync = true (M3/M4/M5 in normal mode, as Grbl): ends the
 * stroke, brings the machine to a stop, sets the output, then dwells
 * cfg.pen_settle_ms. sync = false (Grbl laser mode): the value applies from the
 * start of the next move without stopping (each planned block carries it).
 * Returns as pk_machine_move. A HAL without spindle_write: the request is
 * accepted and the write's PK_HAL_ENOSYS is ignored (the core has nothing to
 * drive), so a board decides whether it has the output. Calling context: MAIN.
 */
int pk_machine_spindle(struct pk_machine *m, uint16_t value_q16, bool sync);

/**
 * Feed and rapid overrides (Grbl 1.1 realtime 0x90-0x9D): feed_pct 10..200,
 * rapid_pct 1..100 (Grbl uses 25/50/100). Applies at once to every planned
 * block and every later one (queued blocks are replanned; the executing block
 * changes speed within the acceleration limits, from the next chunk on).
 * @retval PK_MOTION_OK / PK_MOTION_ERANGE (nothing changed). MAIN.
 */
int pk_machine_set_override(struct pk_machine *m, uint16_t feed_pct, uint16_t rapid_pct);

/**
 * Soft limits (Grbl $20): when on, every later move is checked before it is
 * queued: its target, and for smoothing schemes that can leave the hull of
 * their control points (DLG) a bound on how far the smoothed path can
 * overshoot, must lie inside [lo[i], hi[i]] µm on every axis, else the move
 * is refused with PK_MOTION_ETRAVEL (nothing changed). B-spline smoothing
 * (and the tolerance mode) stays inside the convex hull of the programmed
 * points by construction, so checking the targets is enough for them. The
 * kernel's own range (±PK_UM_MAX) is enforced the same way whether soft limits
 * are on or not. lo/hi may be NULL when on = false. MAIN, any state.
 * @retval PK_MOTION_OK / PK_MOTION_ERANGE (lo > hi, or beyond ±PK_UM_MAX)
 */
int pk_machine_set_soft_limits(struct pk_machine *m, bool on, const pk_um_t lo[PK_AXES],
                               const pk_um_t hi[PK_AXES]);

/** Request end of program (M2/M30): ends the stroke so that everything queued
 *  executes and the last move stops. Returns as pk_machine_move. MAIN. */
int pk_machine_end(struct pk_machine *m);

/** Requests that would be accepted right now (0 = full; call poll and retry).
 *  Calling context: MAIN. */
uint32_t pk_machine_room(const struct pk_machine *m);

/**
 * Main-loop work: take requests from the FIFO, feed strokes through the
 * kernel, pull refined points into the planner while the motion queue has
 * room, replan, prepare step chunks, and arm the HAL timer when there is motion
 * to run (timer_start with pk_machine_timer_cb and m).
 *
 * Bounded work per call (at most 64 requests taken). Call it often, every
 * millisecond or so (the tests run it every 10 µs to 1 ms). If it comes so
 * late that the timer used every prepared chunk mid-motion (an underrun), the
 * timer stops and the next poll restarts it: steps are delayed, never lost or
 * reordered (a speed discontinuity, the main loop's fault). timer_start may
 * come right after the callback returned 0, before a threaded backend has
 * acted on that 0: the backend must then keep the new arming. Harmless in
 * ALARM (does nothing).
 * Calling context: MAIN.
 */
void pk_machine_poll(struct pk_machine *m);

/**
 * The step timer callback (a pk_hal_timer_cb): arg is the struct pk_machine.
 * Emits step/dir edges through pk_hal_step_pulse or pk_hal_step_write /
 * pk_hal_dir_write (and the tool output for pen blocks) using 32-bit integer
 * adds and compares only, and returns the delay (ticks from now_ticks) after
 * which it must run next, or PK_HAL_TIMER_STOP when there is nothing left to
 * do (the timer stops; poll re-arms it).
 * Calling context: ISR (or the simulator's loop), never re-entered.
 */
uint32_t pk_machine_timer_cb(void *arg, uint32_t now_ticks);

/** Feed hold (Grbl '!'): decelerate along the path within the acceleration
 *  limits, stop, keep the remaining queue and the exact position.
 *  The deceleration starts after the chunks already handed to the timer (at
 *  most PK_SG_CHUNKS chunks, each at most one segment: 1/PK_SG_SEG_HZ, or up
 *  to 4 times that while cruising, and at most 2^14 ticks), so it begins
 *  within about PK_SG_CHUNKS such segments plus one poll period.
 *  State becomes HOLDING, then HOLD. No effect when idle or in ALARM. MAIN. */
void pk_machine_hold(struct pk_machine *m);

/** Cycle start / resume (Grbl '~') after a hold: accelerate from rest and
 *  continue the same path. No effect unless HOLDING/HOLD. MAIN. */
void pk_machine_resume(struct pk_machine *m);

/**
 * Reset (Grbl ctrl-X): stop the timer at once (no deceleration), lower the
 * step lines, drop every request, stroke, block and chunk, leave ALARM —
 * unless lowering the step lines fails: then the machine stays in ALARM
 * (PK_ALARM_STEP_WRITE), since a line left high would hide the next pulse.
 * The position stays exactly what was emitted; the next move starts there.
 * Known limit: a pulse that is high when the reset comes is cut short (it
 * was counted at its rising edge); see tests/fuzz/README.md, finding M2.
 * @return true if motion was interrupted (steps were still to be emitted):
 *         the position may be lost on a real machine (Grbl raises ALARM 3)
 * Calling context: MAIN.
 */
bool pk_machine_reset(struct pk_machine *m);

/**
 * Observe what the smoothing hands to the refinement kernel (strokes begin,
 * control points, end), e.g. to draw or measure the smoothed curve in the
 * simulator. fn is called from pk_machine_poll (MAIN) and must not call back
 * into the machine; NULL turns it off. Takes effect for the next stroke.
 */
void pk_machine_set_observer(struct pk_machine *m, pk_stroke_observer fn, void *ctx);

/**
 * Give the CPU back early when the caller has urgent work. One poll may
 * smooth and plan up to a queue's worth of stroke points, and on an 8-bit
 * core that can take hundreds of milliseconds (a refined point costs the
 * decimator ~15,000 cycles, an output point up to 30 of them), while a
 * realtime command ('!', '?', Ctrl-X) is acted on, and its answer written,
 * only between polls. While fn(ctx) is true, pk_machine_poll returns after
 * the piece of work it is on (one stroke point, or the few refined points of
 * a pull budget), with the chunks of final blocks cut as usual, and the next
 * poll goes on from there; a poll always does at least one piece, so a
 * caller that always says true still sees the machine go on. The steps do
 * not depend on where a poll returns (the plan is a function of the queue);
 * their times can shift by the polls the machine waits for work, as they do
 * with the main loop's timing. E.g. pk_grbl_wants_cpu.
 * @param fn  NULL (the default) never yields early
 */
void pk_machine_set_yield(struct pk_machine *m, pk_machine_yield_fn fn, void *ctx);

/**
 * Hard limits (Grbl $21). On: a limit input that becomes active, moving or
 * not, or one that is active when a line block starts or (on a board without
 * edge reports) at any step event, stops the step output before the next step
 * edge and latches PK_ALARM_HARD_LIMIT; the position is the pulses emitted.
 * Homing moves are exempt (they run into the switches).
 * @retval PK_MOTION_OK
 * @retval PK_MOTION_ENOINPUT  on, but the board has no limit input
 * MAIN, any state.
 */
int pk_machine_set_hard_limits(struct pk_machine *m, bool on);

/**
 * Probing move (G38.2-G38.5): a straight feed move to target (µm) at feed
 * that watches the probe input. away = false: for the contact (the probe
 * becoming active, G38.2/G38.3); away = true: for its loss (G38.4/G38.5).
 * At that change the position is recorded (the pulses emitted before it), the
 * machine decelerates along the move within its acceleration limits and the
 * rest of the move is dropped; then the machine is IDLE and pk_machine_cycle
 * says PK_CYCLE_DONE with the recorded position. The move ending first gives
 * PK_CYCLE_MISSED with the position at its end. While it runs the machine
 * takes no other request (they return PK_MOTION_EFULL: poll and retry);
 * hold, resume and reset work as for any move (a reset: PK_CYCLE_ABORTED).
 * Soft limits apply to target.
 * @retval PK_MOTION_OK          started
 * @retval PK_MOTION_EBUSY       not IDLE (Grbl waits for the queue to drain first)
 * @retval PK_MOTION_ENOINPUT    the board has no probe input
 * @retval PK_MOTION_ETRIGGERED  the probe already is in the state watched for
 *                               (Grbl ALARM:4); nothing moved
 * @retval PK_MOTION_EHAL        the inputs could not be read
 * @retval as pk_machine_move otherwise (ERANGE, ETRAVEL, EALARM)
 * MAIN.
 */
int pk_machine_probe(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed,
                     bool away);

/**
 * Homing move (the primitive of pk_home.h's cycle): a straight feed move to
 * target (µm) at feed, during which every axis of axes (bit i = axis i) stops
 * stepping at the first step event at which its limit input is active (Grbl's
 * axis lock: at once, no deceleration; the other axes go on along the same
 * line). Once all of them are locked the motion stops at once and the rest
 * is dropped: PK_CYCLE_DONE. The move ending first: PK_CYCLE_MISSED
 * (pk_machine_cycle's tripped says which axes did lock). Hard limits and soft
 * limits do not apply to it. While it runs the machine takes no other
 * request (PK_MOTION_EFULL); a reset aborts it.
 * @retval PK_MOTION_OK / EBUSY (not IDLE) / ENOINPUT (an axis of axes has no
 *         limit input, or axes names no axis) / EHAL / as pk_machine_move
 * MAIN.
 */
int pk_machine_home_seek(struct pk_machine *m, uint8_t axes, const pk_um_t target[PK_AXES],
                         pk_um_min_t feed);

/**
 * Homing's pull-off: a straight feed move to target (µm) at feed, exempt from
 * hard and soft limits (it starts on the switches), taking no other request
 * while it runs; PK_CYCLE_DONE at its end. Returns as pk_machine_home_seek
 * (no ENOINPUT). MAIN.
 */
int pk_machine_home_pulloff(struct pk_machine *m, const pk_um_t target[PK_AXES], pk_um_min_t feed);

/**
 * The last probing or homing move: its result, and (pointers may be NULL)
 * pos: probe: the position at the contact (DONE) or where the move ended;
 * homing: the position where it stopped; tripped: homing: the axes whose
 * switch closed. MAIN.
 */
enum pk_cycle_result pk_machine_cycle(const struct pk_machine *m, pk_steps_t pos[PK_AXES],
                                      uint8_t *tripped);

/**
 * Set the machine position (steps) without moving: homing's last step (Grbl
 * sets the homed axes to their switch positions). Axes beyond cfg.axes are
 * ignored. Every position must map into ±PK_UM_MAX µm.
 * @retval PK_MOTION_OK / PK_MOTION_EBUSY (not IDLE) / PK_MOTION_ERANGE
 * MAIN.
 */
int pk_machine_set_position(struct pk_machine *m, const pk_steps_t pos[PK_AXES]);

/** Logical levels of the inputs now (PK_IN_* bits, 1 = active; 0 for a board
 *  without inputs, or when the read fails). Reads the HAL. MAIN. */
uint32_t pk_machine_inputs(struct pk_machine *m);

/** Inputs that became active since the last call (PK_IN_* bits): a button
 *  press between two calls is not lost on a board with edge reports; without
 *  them, presses are seen at the calls and while the step path reads the
 *  inputs. MAIN. */
uint32_t pk_machine_input_events(struct pk_machine *m);

/** Position in steps actually emitted (consistent snapshot). MAIN. */
void pk_machine_position_steps(const struct pk_machine *m, pk_steps_t out[PK_AXES]);

/** The same converted to µm: round(steps * 1000 / steps_per_mm). MAIN. */
void pk_machine_position_um(const struct pk_machine *m, pk_um_t out[PK_AXES]);

/** Current state. MAIN. */
enum pk_machine_state pk_machine_state(const struct pk_machine *m);

/** Alarm reason (PK_ALARM_NONE unless in ALARM). MAIN. */
enum pk_alarm pk_machine_alarm(const struct pk_machine *m);

/** Planned blocks in the motion queue (including the one executing) and its
 *  capacity PK_MQ_CAP. MAIN. */
uint32_t pk_machine_queue_fill(const struct pk_machine *m);

/** Straight segments (line blocks with steps) planned since init: what the
 *  smoothing policy turned the program into. MAIN. */
uint32_t pk_machine_lines_planned(const struct pk_machine *m);

/** Path speed of the chunk being executed, µm/min (0 when stopped). MAIN. */
pk_um_min_t pk_machine_speed(const struct pk_machine *m);

#endif
