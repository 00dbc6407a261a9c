/*
 * pk_stepgen.h — step generator: planned blocks -> chunks (main loop) ->
 * step/dir pulses (timer callback, integer adds only).
 *
 * Main loop (pk_sg_prep): takes the tail block of the motion queue and cuts
 * its trapezoidal speed profile into segments of constant time (1/PK_SG_SEG_HZ, 2 ms by default, or
 * less) of constant acceleration (like Grbl's segment buffer, but with the
 * step intervals ramping inside a segment instead of one speed per segment;
 * the details are at the top of pk_stepgen.c). A segment's events (one event = one step
 * of the block's dominant axis) go to the ring as a chunk of the recurrence
 *
 *     t += I;  I += A;                 (ticks in Q16, 32-bit terms)
 *
 * (the first interval, then a linear ramp of intervals that follows the
 * segment's acceleration). Time is carried exactly from
 * segment to segment, so timing never drifts, and the step counts are exact
 * by construction (Bresenham over the block's event count).
 *
 * Timer callback (pk_sg_isr): pops chunks from a single-producer /
 * single-consumer ring (the head is written only by the main loop, the tail
 * only by the callback; both are single bytes, so every read and write of
 * them is atomic even on 8-bit targets, and PK_BARRIER orders the chunk
 * data against the index that publishes it), raises the step lines of the axes due
 * at an event, lowers them step_pulse_ticks later (or has the HAL do it:
 * step_pulse, one callback per event), writes a direction change
 * at least dir_setup_ticks before the next step edge. A failing HAL write
 * latches an alarm; nothing more is written to the step lines and the
 * position counts only the pulses the HAL accepted.
 *
 * Input watches (pk_motion.h: hard limits, probing, homing): while one is
 * armed (watch != 0), the callback applies the inputs at every step event,
 * before the step's edge: hard limits stop the output there with an alarm,
 * homing drops the steps of the axes whose switch has tripped (axis lock)
 * and stops once all have, probing records the position at the contact.
 * The levels come from the backend's edge reports (pk_sg_inputs, from the
 * core's edge callback) or, for a backend without them, from an input read
 * at each step event; every line block's start also reads them, so a switch
 * already active when a move starts trips before its first step. With no
 * watch armed the step path pays one byte test per step event and per chunk.
 */
#ifndef PLOTKIN_PK_STEPGEN_H
#define PLOTKIN_PK_STEPGEN_H

#include <stdbool.h>
#include <stdint.h>
#include "hal.h"
#include "pk_mq.h"

/** Base segments per second: a block's speed profile is cut into segments
 * of 1/PK_SG_SEG_HZ s (default 2 ms; never longer than 2^14 ticks, never
 * shorter than 16, whatever the timer's rate: every range argument of the
 * preparation is stated for at most 2^14 ticks). Each segment costs the main
 * loop one preparation (a few 64-bit products, a division where the speed
 * changes), whatever its length: a chip whose main loop cannot keep the ring
 * filled at speed takes longer segments (the AVR boards: 250, i.e. 4 ms,
 * still 2.5 times finer than Grbl's 10 ms, and with the interval ramp inside
 * each segment that Grbl's constant-speed segments do not have). */
#ifndef PK_SG_SEG_HZ
#define PK_SG_SEG_HZ 500u
#endif
#if PK_SG_SEG_HZ < 50 || PK_SG_SEG_HZ > 5000
#error "PK_SG_SEG_HZ must be 50..5000 segments per second"
#endif
/** Base segments may be doubled this many times (2 ms -> 8 ms) while the
 * speed changes slowly enough (PK_SG_RAMP_SHIFT) or not at all, up to
 * 1/PK_SG_SEG_CAP_HZ s and 2^14 ticks: fewer segments to prepare per second
 * at speed. The cap is a time, so that the segments (and the step events
 * they place) are the same at any timer rate: `plotkin sim` at 1 MHz and an
 * AVR at 2 MHz cut the same segments (the chunks of prepared events ahead of
 * the timer, which a fired probe runs out before it stops, are the same). */
#ifndef PK_SG_SEG_LEVELS
#define PK_SG_SEG_LEVELS 2u
#endif
/** A segment is doubled only while its speed change is at most 2^-this of
 * the speed (the interval ramp's model error is second order in it). */
#ifndef PK_SG_SEG_CAP_HZ
#define PK_SG_SEG_CAP_HZ 125u
#endif
#if PK_SG_SEG_CAP_HZ < 50 || PK_SG_SEG_CAP_HZ > PK_SG_SEG_HZ
#error "PK_SG_SEG_CAP_HZ must be 50..PK_SG_SEG_HZ"
#endif
#ifndef PK_SG_RAMP_SHIFT
#define PK_SG_RAMP_SHIFT 4u
#endif

/** Chunks buffered ahead of the timer (power of two). */
#ifndef PK_SG_CHUNKS
#define PK_SG_CHUNKS 16
#endif
#if PK_SG_CHUNKS > 128 || (PK_SG_CHUNKS & (PK_SG_CHUNKS - 1)) != 0
#error "PK_SG_CHUNKS must be a power of two <= 128"
#endif
/** Most events in one chunk. */
#ifndef PK_SG_MAX_EVENTS
#define PK_SG_MAX_EVENTS 64
#endif
#if PK_SG_MAX_EVENTS < 2 || PK_SG_MAX_EVENTS > 1024
#error "PK_SG_MAX_EVENTS must be 2..1024"
#endif
/** Most events in one block (pk_mq.h events): 256 times it and 512 times
 *  it stay below 2^31 (the Bresenham period and start values, pk_motion.c). */
#define PK_SG_EVENTS_MAX (((uint32_t)1 << 22) - 1u)

/**
 * Fine events (finding M6). A block gets 2 events per exact step of every
 * axis it moves, so that no step lags its exact crossing by more than half
 * the axis's own interval (pk_motion.c plan_piece has the argument). That
 * costs timer callbacks with no step; a board whose callback cannot afford
 * them at speed sets PK_SG_FINE_HZ: blocks whose dominant axis steps faster
 * than this at their nominal speed (steps/s, before overrides) keep one
 * event per dominant step, and their axes lag by up to one event
 * (1/PK_SG_FINE_HZ at most). 0 (the default): fine events at every speed.
 */
#ifndef PK_SG_FINE_HZ
#define PK_SG_FINE_HZ 0u
#endif

/** Whether a block of mx dominant steps over len_q8 (µm Q8) at v (µm/min)
 *  gets fine events (PK_SG_FINE_HZ). MAIN. */
static inline bool pk_sg_fine_ok(uint32_t mx, uint32_t len_q8, uint32_t v_um_min)
{
#if PK_SG_FINE_HZ == 0
    (void)mx;
    (void)len_q8;
    (void)v_um_min;
    return true;
#else
    /* steps/s = mx v 256 / (60 len): compare mx v 256 <= HZ 60 len (64-bit:
     * mx < 2^22, v < 2^32) */
    return (uint64_t)mx * v_um_min * 256u <= (uint64_t)PK_SG_FINE_HZ * 60u * len_q8;
#endif
}

/** Longest chunk, ticks: keeps every interval of a chunk of several events
 *  below 2^14 ticks, so the recurrence fits 32 bits in Q16. */
#define PK_SG_CHUNK_TICKS_MAX 16384u

enum pk_sg_chunk_kind {
    PK_SGC_STEPS = 0,   /**< n events on the quadratic recurrence */
    PK_SGC_TOOL = 1,    /**< set the tool line, wait */
    PK_SGC_WAIT = 2,    /**< wait */
    PK_SGC_SPINDLE = 3, /**< set the spindle output, wait */
    PK_SGC_BLOCK = 4,   /**< a line block starts: directions, spindle, Bresenham terms */
    PK_SGC_SLOW = 5     /**< one event after a long interval (beyond the recurrence's range) */
};

/** One ring slot (private). Compact: the ISR-side arithmetic is 32-bit
 *  except the absolute time. */
struct pk_sg_chunk {
    uint8_t kind;              /**< enum pk_sg_chunk_kind */
    uint8_t arg;               /**< TOOL: logical level; BLOCK: logical directions */
    uint16_t n;                /**< STEPS: events (1..PK_SG_MAX_EVENTS); SLOW: the
                                    interval's fraction of a tick, Q16; BLOCK: the
                                    axes whose Bresenham step can fire (bres) */
    union {
        struct { int32_t c0, c1, c2; } st; /**< STEPS: the first interval c0, then the
                                              k-th after it c1 + k c2 (k = 1..n-1);
                                              ticks Q16 */
        uint32_t ticks;        /**< TOOL/WAIT/SPINDLE: wait; SLOW: whole ticks */
        struct {
            uint32_t inc[PK_AXES];  /**< Bresenham increments (pk_mq.h) */
            int32_t acc0[PK_AXES];  /**< Bresenham start values */
            uint32_t period;        /**< Bresenham period */
        } blk;                 /**< BLOCK */
    } u;
    uint16_t spindle;          /**< BLOCK / SPINDLE: spindle value (Q0.16) */
    uint32_t v_um_s;           /**< STEPS/SLOW: speed at the chunk's end (reports) */
};

/** Input watches (struct pk_stepgen.watch / .fired bits). */
enum pk_sg_watch {
    PK_SGW_LIMITS = 1, /**< hard limits: a limit input active -> stop at once, alarm */
    PK_SGW_PROBE = 2,  /**< probing: the probe at probe_level -> record the position */
    PK_SGW_HOME = 4    /**< homing: an axis of home_axes whose limit is active steps no
                            more; once all of them are -> stop at once, no alarm */
};

/** Timer-side phase (private). */
enum pk_sg_phase { PK_SGP_GAP = 0, PK_SGP_STEP_DUE = 1, PK_SGP_PULSE = 2 };

/** Step generator state (private members; use the functions). */
struct pk_stepgen {
    /* ---- the step path's state (ISR only, except as noted). First in the
     *      struct, in the order the step path uses it: an AVR reaches the
     *      first 64 bytes through its pointer with one displacement load or
     *      store (ldd/std Z+q, q <= 63), and for 3 axes everything a step
     *      event touches is there (pos[2] is bytes 60..63) ---- */
    uint8_t phase;             /**< enum pk_sg_phase */
    uint8_t dir_cur;           /**< direction lines as last written (logical) */
    uint8_t hw_pulse;          /**< the HAL ends step pulses itself (step_pulse):
                                    one callback per step event */
    uint8_t pulse_hot;         /**< hw_pulse: a pulse raised at low_until - 2 pulse_ticks
                                    may still be high or in its low time */
    volatile uint8_t alarm;    /**< enum pk_alarm latched by the ISR (MAIN reads) */
    bool restart;              /**< ISR: first call after (re)arming: rebase time */
    volatile uint8_t watch;    /**< enum pk_sg_watch bits armed (see below) */
    uint8_t bres;              /**< axes whose Bresenham step can fire in the block
                                    running: of the axes driven, those with an
                                    increment or an accumulator >= 0 (the others keep
                                    theirs, below 0, to the block's end) */
    uint16_t next_f;           /**< fraction of a tick of next_t, Q16 */
    uint16_t left;             /**< events left in the current chunk */
    uint32_t next_t;           /**< tick of the last scheduled event (the HAL
                                    callback's 32-bit wrapping ticks) */
    int32_t I, A;              /**< interval and its change per event, ticks Q16
                                    (chunks are at most PK_SG_CHUNK_TICKS_MAX long,
                                    so |I| < 2^30) */
    uint32_t period;           /**< Bresenham period of the block running */
    int32_t acc[PK_AXES];      /**< Bresenham accumulators: an axis steps at an
                                    event when its accumulator reaches 0 */
    uint32_t inc[PK_AXES];     /**< Bresenham increments of the block running */
    pk_steps_t pos[PK_AXES];   /**< emitted steps (MAIN reads under irq_save) */
    uint32_t pulse_ticks;      /**< configuration: step pulse width, ticks (>= 1) */
    uint32_t low_until;        /**< hw_pulse: no step edge before this tick */
    uint32_t earliest;         /**< isr_chunks: no step edge before this tick */

    /* ---- configuration (set at init, read-only afterwards) ---- */
    uint8_t axes;              /**< axes driven */
    uint32_t tick_hz;
    uint32_t dir_setup_ticks;

    /* ---- timer-side state the step path does not touch ---- */
    uint16_t spindle_cur;      /**< spindle value as last written */
    uint8_t mask_due;          /**< axes to step at the pending edge */
    volatile uint8_t busy;     /**< 1 from timer_start until the ISR stops the timer */
    volatile uint8_t kill;     /**< reset came during a pulse: the ISR ends it on
                                    time, then stops (finding M2) */
    volatile uint16_t late;    /**< events that found their time passed by more than their
                                    interval and moved the schedule (ISR counts; a
                                    diagnostic: 0 whenever the main loop keeps up) */
    volatile uint32_t v_um_s;  /**< speed of the chunk executing (MAIN reads; a
                                    torn read on 8-bit targets only skews a report) */
    uint32_t seg_max;          /**< prep: base segment, ticks (1/PK_SG_SEG_HZ s, 16..2^14) */
    uint32_t seg_cap;          /**< prep: longest segment, ticks (1/PK_SG_SEG_CAP_HZ s, seg_max..2^14) */
    uint32_t ck_vsum, ck_kq;   /**< the segment clock: for this speed sum, the time of */
    uint8_t ck_ks;             /**< d is (d ck_kq) >> ck_ks (ticks Q16, d µm Q8) */
    uint32_t g_max_q24;        /**< g_q24 of a seg_max segment */
    uint32_t kdv_q24;          /**< seg_max * 16 / tick_hz, Q24: dv_q4 = accel * this */
    uint32_t invT_max_q30;     /**< 2^30 / seg_max (a block's invT_q30 at full length) */

    /* ---- input watches (MAIN arms and clears them under irq_save; the ISR
     *      and the edge callback read them and set fired / lock) ---- */
    volatile uint8_t fired;    /**< watch bits that have fired since armed */
    volatile uint8_t lock;     /**< HOME: axes whose switch has tripped (they step no more) */
    uint8_t home_axes;         /**< HOME: the axes homed */
    uint8_t probe_level;       /**< PROBE: logical probe level that fires (1 touch, 0 leave) */
    uint8_t poll_in;           /**< 1: the board reports no edges: read the inputs at
                                    every step event while a watch is armed */
    uint16_t in_flip;          /**< PK_IN_* bits flipped on top of the board's polarity
                                    (Grbl $5 / $6) */
    volatile uint16_t in_now;  /**< logical input levels last seen */
    volatile uint16_t in_rise; /**< inputs that became active since MAIN last took them */
    pk_steps_t probe_pos[PK_AXES]; /**< PROBE: position when it fired */

    /* ---- main-loop preparation state ---- */
    bool prep_active;          /**< the mq tail block is being cut into chunks */
    bool blk_sent;             /**< its BLOCK slot is in the ring */
    bool hold;                 /**< decelerate to a stop, ignoring the plan */
    bool held;                 /**< hold reached speed 0: no more chunks until resume */
    uint32_t e;                /**< events already prepared in the tail block */
    uint32_t s_q8;             /**< prepared distance into the tail block, µm Q8 */
    uint32_t v_q4;             /**< speed there, µm/s Q4 */
    pk_v2_q4_t v2;             /**< the same squared, Q4 */
    uint64_t v_sq;             /**< v_q4 squared ((µm/s)^2 Q8) */
    uint64_t ve_sq;            /**< ve_q4 squared */
    pk_v2_q4_t v2_blk;         /**< speed^2 at the tail block's start (what the planner sees) */
    bool off_plan;             /**< a hold came during the tail block: the planner sees
                                    the real position instead */
    uint64_t carry_q16;        /**< time from the last prepared event to s_q8, ticks Q16 */
    uint32_t seg_ticks;        /**< the tail block's segment duration, ticks */
    uint32_t g_q24;            /**< a segment's distance per unit of speed sum (µm Q8
                                    per µm/s Q4, Q24) */
    uint32_t dv_q4;            /**< speed change per segment at the block's accel, Q4 */
    uint32_t invT_q30;         /**< 2^30 / seg_ticks */
    uint8_t lvl_max;           /**< the block's segments may be seg_ticks << 0..this */
    uint32_t ev_q, ev_r;       /**< the block's event spacing L / M: quotient, remainder */
    uint32_t ev_next, ev_rem;  /**< position of the next event (µm Q8) and its remainder */
    uint32_t vn_q4, ve_q4;     /**< the block's nominal and exit speed, Q4 ... */
    pk_v2_q4_t c_v2_nom, c_v2_exit; /**< ... cached for these planned squares */

    /* ---- ring (head: MAIN writes; tail: ISR writes) ---- */
    struct pk_sg_chunk ring[PK_SG_CHUNKS];
    volatile uint8_t head;     /**< chunks published (mod 256) */
    volatile uint8_t tail;     /**< chunks consumed (mod 256) */
};

/**
 * New logical input levels (PK_IN_* bits, polarity applied): from the core's
 * edge callback, or read by the ISR or by MAIN (under irq_save). Updates the
 * levels seen, latches rising inputs, and applies the armed watches: HOME
 * locks the axes whose switch is active, PROBE fires at probe_level (position
 * recorded), LIMITS fires on a limit input that rises, or with level = 1 on
 * any limit input that is active (the step path's checks). Calling context:
 * ISR, edge context or MAIN with the timer callback held off; never two at a
 * time (hal.h).
 */
void pk_sg_inputs(struct pk_stepgen *sg, uint32_t logical, int level);

/** Initialise (empty ring, position 0, dir lines assumed logical 0). */
void pk_sg_init(struct pk_stepgen *sg, uint8_t axes, uint32_t tick_hz, uint32_t pulse_ticks,
                uint32_t dir_setup_ticks);

/**
 * Prepare chunks from the tail of q while the ring has room, from at most the
 * first max_blocks blocks (those whose plan is final, see pk_planner.h). Pops
 * a block from q once all its chunks are in the ring. MAIN.
 * @return true if at least one chunk was added
 */
bool pk_sg_prep(struct pk_stepgen *sg, struct pk_mq *q, uint32_t max_blocks);

/** Speed^2 and remaining length of the tail block as the planner must see
 *  them (entry fixed at the prepared state). MAIN. */
void pk_sg_plan_state(const struct pk_stepgen *sg, struct pk_mq *q, pk_v2_q4_t *v2_now,
                      uint32_t *rem_q8);

/** Request / cancel a feed hold (MAIN). Cancel only after the ring drained. */
void pk_sg_set_hold(struct pk_stepgen *sg, bool hold);

/** Chunks waiting in the ring (MAIN or ISR). */
uint32_t pk_sg_pending(const struct pk_stepgen *sg);

/**
 * The timer work (a pk_hal_timer_cb's body, see the file comment): now is the
 * HAL's 32-bit tick of the call; returns the delay to the next call, or
 * PK_HAL_TIMER_STOP. Every step event is one call if the HAL has step_pulse
 * (it ends the pulse; the next edge comes at least 2 pulse widths after the
 * raising one, a direction change after the pulse has ended), else two (the
 * second lowers the lines pulse_ticks later; an event with no step is one
 * call either way). 32-bit arithmetic only. ISR.
 */
uint32_t pk_sg_isr(struct pk_stepgen *sg, const struct pk_hal *hal, uint32_t now);

/** Drop everything queued and the timer-side state, keep the position. Call
 *  only with the timer stopped. MAIN. */
void pk_sg_flush(struct pk_stepgen *sg);

/** Reset while the timer may still run: if a step pulse is high, leave the
 *  timer armed so that the callback lowers it after the full pulse width and
 *  then stops (returns 1); otherwise stop the timer and flush (returns 0).
 *  Either way nothing queued runs any more and the position is kept. MAIN,
 *  with interrupts enabled (it masks them itself through the HAL). */
int pk_sg_kill(struct pk_stepgen *sg, const struct pk_hal *hal);

#endif
