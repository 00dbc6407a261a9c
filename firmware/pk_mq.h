/*
 * pk_mq.h — the motion queue: a fixed-capacity ring of planned blocks.
 *
 * A block is one straight move in steps (with the geometry the planner needs)
 * or a stop-type action (pen change, dwell). The stroke assembler appends at
 * the head; the planner rewrites the speeds of queued blocks; the step
 * generator's chunk preparation consumes from the tail. All three run in the
 * main loop: the interrupt never touches this ring. What crosses to the step
 * timer is the chunk ring of pk_stepgen.h (single producer, single consumer,
 * C11 atomics), so a full queue here simply means "do not pull the kernel".
 */
#ifndef PLOTKIN_PK_MQ_H
#define PLOTKIN_PK_MQ_H

#include <stdbool.h>
#include <stdint.h>
#include "pk_munits.h"
#include "pk_refine.h"

/** Blocks of look-ahead. More blocks: higher speeds on dense polylines. */
#ifndef PK_MQ_CAP
#define PK_MQ_CAP 32
#endif

enum pk_block_type {
    PK_BLK_LINE = 0,  /**< straight move */
    PK_BLK_PEN = 1,   /**< set the tool output, then wait (stop point) */
    PK_BLK_DWELL = 2, /**< wait (stop point) */
    PK_BLK_SPINDLE = 3 /**< set the spindle output (wait_ms after), stop point */
};

/** One planned block. Geometry is fixed at push; the planner owns the speeds. */
struct pk_block {
    uint8_t type;              /**< enum pk_block_type */
    uint8_t dir_mask;          /**< LINE: logical direction per axis, 1 = positive */
    uint8_t tool;              /**< PEN: logical tool level */
    uint8_t rapid;             /**< LINE: a rapid (rapid override applies, not feed) */
    uint16_t spindle;          /**< LINE: spindle value while it runs; SPINDLE: the value */
    uint8_t end_limited;       /**< LINE: planner-private: the exit is limited by the
                                    queue's end (may rise when blocks are appended) */
    uint8_t curved;            /**< LINE: next to a curved junction (acceleration along
                                    the path shared with the turn) */
    union {                    /* (a block is a line or a stop, never both) */
        uint32_t events;       /**< LINE: Bresenham events M = max |steps| (>= 1) */
        uint32_t wait_ms;      /**< PEN/DWELL/SPINDLE: wait */
    };
    uint32_t inc[PK_AXES];     /**< LINE: per event each axis's accumulator grows by
                                    its exact displacement in 1/256 steps ... */
    int32_t acc0[PK_AXES];     /**< ... from this start value, which encodes the exact
                                    fractional start position (pk_motion.c): the axis
                                    steps when its accumulator reaches 0, then drops
                                    by the period, 256 M */
    uint32_t len_q8;           /**< LINE: path length, µm Q8 (< 2^31): the lead, then
                                    the exact displacement's length (pk_planner.h) */
    uint32_t lead_q8;          /**< LINE: the way before the first event, µm Q8 (moves
                                    without a whole step since the block before:
                                    pk_planner.h) */
    pk_um_s2_t accel;          /**< LINE: accel along the move, axis-limited, µm/s^2 */
    pk_um_min_t v_req;         /**< LINE: requested speed before override, µm/min (0: rapid) */
    pk_um_min_t v_lim;         /**< LINE: the axes' limit along the move, µm/min */
    pk_v2_q4_t v2_nom;         /**< LINE: nominal speed^2 (override applied at replan) */
    pk_v2_q4_t v2_junction;    /**< LINE: max entry speed^2 from the junction geometry
                                    (the replan also caps it by both nominals) */
    pk_v2_q4_t v2_exit;        /**< planned exit speed^2 (0 for stop blocks) */
    pk_v2_q4_t v2_rev;         /**< LINE: planner-private: the exit the reverse pass
                                    allows (kept for the next, incremental replan) */
    pk_v2_q4_t v2_ceil;        /**< LINE: planner-private: the entry ceiling, v2_junction
                                    capped by this block's and the line before's
                                    nominal (set whenever a nominal is) */
    pk_v2_q4_t v2_acc;         /**< LINE: planner-private: 2 accel len_q8 in speed^2 Q4,
                                    what the whole block adds to a speed^2 (set when
                                    the block is added) */
};

/** The ring (MAIN only). */
struct pk_mq {
    struct pk_block b[PK_MQ_CAP];
    uint16_t tail;   /**< oldest block */
    uint16_t count;  /**< blocks queued */
    uint16_t pops;   /**< blocks popped since pk_mq_init, modulo 2^16 (the planner
                          tells what changed since its last replan) */
};

/** Empty the queue. */
void pk_mq_init(struct pk_mq *q);
/** Free slots. */
uint32_t pk_mq_room(const struct pk_mq *q);
/** Blocks queued. */
uint32_t pk_mq_count(const struct pk_mq *q);
/** The i-th oldest block (0 = tail), i < count; NULL otherwise. */
struct pk_block *pk_mq_at(struct pk_mq *q, uint32_t i);
/** Reserve the next slot at the head (zeroed) and count it; NULL if full. */
struct pk_block *pk_mq_push(struct pk_mq *q);
/** Drop the tail block (no-op when empty). */
void pk_mq_pop(struct pk_mq *q);

#endif
