/*
 * pk_gcode.h — plotkin's G-code line parser and block interpreter (contract).
 *
 * Two layers, both pure, allocation-free and float-free:
 *
 *  1. pk_gcode_parse(): one line of bytes -> struct pk_gc_block, or a specific
 *     error. Syntax and the rules that depend on the line alone: letters are
 *     case-insensitive; spaces and tabs may appear anywhere (even inside a
 *     number, as Grbl and LinuxCNC allow); "( ... )" comments anywhere and ";"
 *     to the end of the line; an optional leading "/" (block delete, ignored as
 *     Grbl does); a line holding only "%" is empty. N line numbers, repeated
 *     words, two commands from one modal group, unknown letters, missing or
 *     malformed numbers, numbers too large, control bytes and non-ASCII bytes
 *     are all errors. Nothing is stored outside *out.
 *
 *  2. pk_gcode_interp(): block + modal state (struct pk_gc_state) -> one
 *     struct pk_gc_cmd saying what to do, in machine micrometres, in the
 *     RS274/NGC order of execution. It applies units (G20/G21), distance mode
 *     (G90/G91), the G92 offset, checks the rules that depend on the modal state
 *     (undefined feed rate, missing axis words, unused words, G5/G5.1 rules,
 *     travel) and commits the new modal state only when the block is accepted:
 *     a rejected line changes nothing.
 *
 * Error numbers are Grbl 1.1's (doc/csv/error_codes_en_US.csv) so that a
 * sender prints the right message; see enum pk_gc_status.
 *
 * Fixed-point format of word values (pk_gc_u6_t): int64, decimal fixed point,
 * 1 LSB = 10^-6 of the word's own unit (mm, inch, seconds, mm/min, ...).
 * The parser keeps at most 9 integer digits and rounds to 6 decimals (ties
 * away from zero), so |v| <= PK_GC_U6_MAX < 2^50 and every later product by a
 * small constant (25.4 mm/inch) fits in int64.
 *
 * Calling context: main loop (or any thread); reentrant; no globals.
 */
#ifndef PLOTKIN_PK_GCODE_H
#define PLOTKIN_PK_GCODE_H

#include <stddef.h>
#include <stdint.h>
#include "pk_fixed.h"

/** Longest line (bytes, terminator excluded) the parser accepts. */
#define PK_GC_LINE_MAX 255u

/** Word value: decimal fixed point, 1 LSB = 1e-6 of the word's unit. */
typedef int64_t pk_gc_u6_t;
#define PK_GC_U6_ONE ((pk_gc_u6_t)1000000)
/** At most 9 integer digits: |v| <= 999999999.999999. */
#define PK_GC_U6_MAX ((pk_gc_u6_t)999999999999999LL)

/**
 * Status of parse/interp. Values equal Grbl 1.1's error numbers, so the
 * protocol prints "error:<value>".
 */
enum pk_gc_status {
    PK_GC_OK = 0,
    PK_GC_E_EXPECTED_LETTER = 1,  /**< a byte that is not a word letter: digits first, ')', '#', control or non-ASCII bytes */
    PK_GC_E_BAD_NUMBER = 2,       /**< missing value, malformed number, or more than 9 integer digits */
    PK_GC_E_NEGATIVE = 4,         /**< negative F, S, T or dwell P */
    PK_GC_E_LINE_OVERFLOW = 11,   /**< line longer than PK_GC_LINE_MAX */
    PK_GC_E_TRAVEL = 15,          /**< a target (or a G5/G5.1 control point) outside the machine travel */
    PK_GC_E_UNSUPPORTED = 20,     /**< unknown letter, G or M code not implemented */
    PK_GC_E_MODAL_GROUP = 21,     /**< two commands from one modal group */
    PK_GC_E_UNDEFINED_FEED = 22,  /**< G1/G5/G5.1 with no feed rate ever set (or F0) */
    PK_GC_E_NOT_INTEGER = 23,     /**< G/M code with a fraction it does not have (G1.5, M3.2) */
    PK_GC_E_AXIS_CONFLICT = 24,   /**< two commands that use axis words (G92 and G0/G1/G5...) */
    PK_GC_E_REPEATED_WORD = 25,   /**< the same letter twice (except G and M) */
    PK_GC_E_NO_AXIS_WORDS = 26,   /**< G92, or an explicit G0/G1 without any axis word */
    PK_GC_E_LINE_NUMBER = 27,     /**< N not an integer in 0..PK_GC_N_MAX */
    PK_GC_E_VALUE_MISSING = 28,   /**< G4 without P; G5 without both P and Q; only one of I/J; G5.1 without I/J */
    PK_GC_E_UNUSED_WORDS = 31,    /**< axis words with no command to use them (G80 in effect) */
    PK_GC_E_BAD_TARGET = 33,      /**< G5/G5.1 with a Z word or outside the G17 plane */
    PK_GC_E_UNUSED_VALUE = 36,    /**< value words (I J P Q R) nothing in the block uses */
    PK_GC_E_TOOL_NUMBER = 38      /**< T greater than 255 */
};

/** Largest N line number (Grbl 1.1h's MAX_LINE_NUMBER). */
#define PK_GC_N_MAX 9999999

/** Value words, indices into pk_gc_block.v and bits of pk_gc_block.words. */
enum pk_gc_word {
    PK_GC_W_F = 0, PK_GC_W_I, PK_GC_W_J, PK_GC_W_K, PK_GC_W_N, PK_GC_W_P, PK_GC_W_Q,
    PK_GC_W_R, PK_GC_W_S, PK_GC_W_T, PK_GC_W_X, PK_GC_W_Y, PK_GC_W_Z, PK_GC_W_COUNT
};
#define PK_GC_WBIT(w) ((uint16_t)(1u << (w)))
#define PK_GC_AXIS_WORDS (PK_GC_WBIT(PK_GC_W_X) | PK_GC_WBIT(PK_GC_W_Y) | PK_GC_WBIT(PK_GC_W_Z))

/** Modal groups present in a block: bits of pk_gc_block.groups. */
enum pk_gc_group {
    PK_GC_G_NONMODAL = 0, /**< G4, G92 */
    PK_GC_G_MOTION,       /**< G0 G1 G2 G3 G5 G5.1 G80 */
    PK_GC_G_PLANE,        /**< G17 (G18/G19 unsupported) */
    PK_GC_G_DISTANCE,     /**< G90 G91 */
    PK_GC_G_FEEDMODE,     /**< G94 (G93 unsupported) */
    PK_GC_G_UNITS,        /**< G20 G21 */
    PK_GC_G_CUTTER,       /**< G40 (accepted, no effect) */
    PK_GC_G_TLO,          /**< G49 (accepted, no effect) */
    PK_GC_G_WCS,          /**< G54 (accepted, no effect) */
    PK_GC_G_PATH,         /**< G61 G64 */
    PK_GC_G_STOP,         /**< M2 M30 */
    PK_GC_G_SPINDLE,      /**< M3 M5: pen down / pen up */
    PK_GC_G_COUNT
};
#define PK_GC_GBIT(g) ((uint16_t)(1u << (g)))

enum pk_gc_nonmodal { PK_GC_NM_NONE = 0, PK_GC_NM_DWELL, PK_GC_NM_SET_OFFSET };
enum pk_gc_motion {
    PK_GC_MOT_RAPID = 0,  /**< G0 */
    PK_GC_MOT_LINEAR,     /**< G1 */
    PK_GC_MOT_CW_ARC,     /**< G2 (parsed; the interpreter answers unsupported) */
    PK_GC_MOT_CCW_ARC,    /**< G3 (idem) */
    PK_GC_MOT_CUBIC,      /**< G5 */
    PK_GC_MOT_QUAD,       /**< G5.1 */
    PK_GC_MOT_NONE        /**< G80 */
};
enum pk_gc_distance { PK_GC_ABSOLUTE = 0, PK_GC_INCREMENTAL };
enum pk_gc_units { PK_GC_MM = 0, PK_GC_INCH };
enum pk_gc_path { PK_GC_PATH_EXACT = 0 /**< G61 */, PK_GC_PATH_BLEND /**< G64 */ };
enum pk_gc_stop { PK_GC_STOP_END = 2 /**< M2 */, PK_GC_STOP_END_RESET = 30 /**< M30 */ };
enum pk_gc_spindle { PK_GC_PEN_UP = 0 /**< M5 */, PK_GC_PEN_DOWN = 1 /**< M3 */ };

/**
 * One parsed line. Only the groups whose bit is set in `groups` and the words
 * whose bit is set in `words` are meaningful; everything else is zero.
 */
struct pk_gc_block {
    uint16_t words;                 /**< PK_GC_WBIT(w) for each value word present */
    uint16_t groups;                /**< PK_GC_GBIT(g) for each modal group commanded */
    pk_gc_u6_t v[PK_GC_W_COUNT];    /**< word values, as written (units not applied) */
    uint8_t nonmodal;               /**< enum pk_gc_nonmodal */
    uint8_t motion;                 /**< enum pk_gc_motion */
    uint8_t distance;               /**< enum pk_gc_distance */
    uint8_t units;                  /**< enum pk_gc_units */
    uint8_t path;                   /**< enum pk_gc_path */
    uint8_t stop;                   /**< enum pk_gc_stop */
    uint8_t spindle;                /**< enum pk_gc_spindle */
    uint8_t pad_;
};

/**
 * Parse one line.
 * @param line  the bytes of the line, without its terminator (CR/LF); need not
 *              be NUL-terminated; may be NULL when len is 0
 * @param len   number of bytes
 * @param out   receives the block (fully overwritten, also on error)
 * @return PK_GC_OK, or the first error found (enum pk_gc_status). A line that
 *         holds only whitespace, comments, "/" or "%" parses to an empty block.
 * Calling context: any; reentrant; reads only line[0..len).
 */
int pk_gcode_parse(const uint8_t *line, size_t len, struct pk_gc_block *out);

/* ------------------------------------------------------------------------- */
/* Interpreter                                                                */
/* ------------------------------------------------------------------------- */

/** Axes the interpreter handles (X Y Z). */
#define PK_GC_AXES 3

/** Feed rate in micrometres per minute. 0 means "not set". Range: F is at
 *  most PK_GC_U6_MAX in mm/min, the interpreter rejects more than
 *  PK_GC_FEED_MAX with PK_GC_E_BAD_NUMBER. */
typedef int32_t pk_gc_umpm_t;
#define PK_GC_FEED_MAX ((pk_gc_umpm_t)2000000000)

/** Machine limits the interpreter checks targets against. */
struct pk_gc_limits {
    pk_um_t min_um[PK_GC_AXES];  /**< lowest machine coordinate, >= -PK_UM_MAX */
    pk_um_t max_um[PK_GC_AXES];  /**< highest machine coordinate, <= PK_UM_MAX */
};

/**
 * Modal state of the G-code interpreter (one per machine; caller-owned).
 * Initialise with pk_gcode_state_init. Positions are the interpreter's idea of
 * where the program has commanded the tool (the end of the last accepted move,
 * not where the machine is right now).
 */
struct pk_gc_state {
    struct pk_gc_limits lim;
    pk_um_t pos_um[PK_GC_AXES];     /**< last commanded machine position */
    pk_um_t offset_um[PK_GC_AXES];  /**< G92 offset: program = machine - offset */
    pk_gc_umpm_t feed_umpm;         /**< current F, µm/min (0 = never set) */
    pk_um_t tol_um;                 /**< G64 P tolerance, µm (0 = machine default) */
    uint8_t motion;                 /**< enum pk_gc_motion */
    uint8_t distance;               /**< enum pk_gc_distance */
    uint8_t units;                  /**< enum pk_gc_units */
    uint8_t path;                   /**< enum pk_gc_path */
    uint8_t pen;                    /**< enum pk_gc_spindle */
    uint8_t cubic_prev;             /**< the last accepted move was a G5 (I/J may be omitted) */
    pk_um_t prev_pq_um[2];          /**< that G5's P,Q (µm), to continue tangentially */
};

/**
 * Reset the modal state to power-on defaults (G0 G17 G21 G90 G94 G64 M5, no
 * offset, feed unset) with the machine at pos_um.
 * @param lim  travel limits (copied)
 */
void pk_gcode_state_init(struct pk_gc_state *st, const struct pk_gc_limits *lim,
                         const pk_um_t pos_um[PK_GC_AXES]);

/** What a block asks for (flags of pk_gc_cmd.what), in execution order. */
#define PK_GC_DO_PEN      0x01u  /**< change pen to cmd.pen (M3/M5) */
#define PK_GC_DO_DWELL    0x02u  /**< wait cmd.dwell_ms after the queue drains (G4) */
#define PK_GC_DO_PATH     0x04u  /**< smoothing mode changed: cmd.path, cmd.tol_um */
#define PK_GC_DO_OFFSET   0x08u  /**< G92 applied (state only; no motion) */
#define PK_GC_DO_MOVE     0x10u  /**< a move: cmd.motion to cmd.target_um */
#define PK_GC_DO_STOP     0x20u  /**< M2/M30: end of program (after the move) */

/** One accepted block, ready to execute (all machine coordinates, µm). */
struct pk_gc_cmd {
    uint8_t what;                       /**< PK_GC_DO_* flags */
    uint8_t motion;                     /**< enum pk_gc_motion, with DO_MOVE */
    uint8_t pen;                        /**< enum pk_gc_spindle, with DO_PEN */
    uint8_t path;                       /**< enum pk_gc_path, with DO_PATH */
    pk_um_t tol_um;                     /**< with DO_PATH: G64 P in µm (0 = default) */
    uint32_t dwell_ms;                  /**< with DO_DWELL */
    pk_gc_umpm_t feed_umpm;             /**< feed in effect for the move (G0: 0 = rapid) */
    pk_um_t start_um[PK_GC_AXES];       /**< with DO_MOVE: where the move starts */
    pk_um_t target_um[PK_GC_AXES];      /**< with DO_MOVE: where it ends */
    pk_um_t ctrl_um[2][2];              /**< G5: two XY control points; G5.1: ctrl_um[0] */
    int32_t line_number;                /**< N, or -1 */
};

/**
 * Validate a parsed block against the modal state and turn it into a command.
 * On PK_GC_OK, *st is updated (modal state, position after the move) and *cmd
 * describes the actions. On error, *st is unchanged and *cmd is meaningless.
 * Calling context: main loop; reentrant.
 */
int pk_gcode_interp(struct pk_gc_state *st, const struct pk_gc_block *b, struct pk_gc_cmd *cmd);

/**
 * Convert a length word to micrometres, rounding to nearest (ties away).
 * @param v       word value as parsed (1e-6 of a mm or of an inch)
 * @param units   enum pk_gc_units
 * @return the length in µm (int64: the caller range-checks it)
 */
int64_t pk_gcode_len_um(pk_gc_u6_t v, uint8_t units);

/**
 * Parse a whole string as one number (same rules as a word value: sign,
 * digits, one point, spaces ignored, at most 9 integer digits).
 * @return PK_GC_OK with *out set, PK_GC_E_BAD_NUMBER, or
 *         PK_GC_E_EXPECTED_LETTER if something follows the number
 */
int pk_gcode_parse_number(const uint8_t *s, size_t len, pk_gc_u6_t *out);

#endif
