/*
 * pk_gcode.h — plotkin's G-code line parser and block interpreter: Grbl
 * 1.1's G-code set with Grbl's error numbers and modal-group rules, plus
 * LinuxCNC's G5/G5.1 and G64 P (contract).
 *
 * Two layers, both pure, allocation-free and float-free:
 *
 *  1. pk_gcode_parse(): one line -> struct pk_gc_block, or Grbl's error for
 *     the first problem met, left to right, as Grbl's parser meets it (1 no
 *     letter, 2 bad number, 20 unknown G/M/letter, 23 G/M code with a
 *     fraction it does not have, 21 two commands of one modal group, 24 two
 *     commands that use axis words, 25 a repeated word, 4 negative F N P S T,
 *     38 T above 255). Lexical rules are Grbl's protocol.c ones: letters are
 *     case-insensitive; every byte <= ' ' is ignored (so spaces may sit inside
 *     a number: "X1 2.5" is X12.5); "( ... )" comments and ";" to the end of
 *     the line; '/' (block delete) is ignored wherever it is; a line of only
 *     "%" is empty (plotkin: Grbl answers error:1). Bytes >= 0x7f outside
 *     comments are error 1 (the Grbl engine takes bytes >= 0x80 off the
 *     stream before they reach a line).
 *
 *  2. pk_gcode_interp(): block + modal state -> one struct pk_gc_cmd, the
 *     actions in Grbl's order of execution, all in machine micrometres, after
 *     Grbl's checks in Grbl's order (gcode.c step 3); the state is committed
 *     only when the block is accepted: a rejected line changes nothing.
 *
 * Numbers (struct pk_gc_block): a word value is m * 10^-dec with m an int32
 * of at most 9 significant digits and dec <= 9. More digits are dropped
 * (truncation), which keeps the later rounding to the unit exact for Grbl's
 * round-half-away rule; more than 9 integer digits is error 2. Conversions
 * to µm, µm/min, ms are exact roundings (ties away from zero) in 32-bit
 * arithmetic for mm values; inch values (G20) take one 64-bit product.
 *
 * Axes: PK_GC_AXES = PK_AXES (pk_refine.h). A 2-axis build refuses Z words,
 * G18/G19 and G43.1 with error 20, as a Grbl built without the axis would.
 *
 * Calling context: main loop (or any thread); reentrant; no globals.
 */
#ifndef PLOTKIN_PK_GCODE_H
#define PLOTKIN_PK_GCODE_H

#include <stddef.h>
#include <stdint.h>
#include "pk_arc.h"
#include "pk_bezier.h"
#include "pk_fixed.h"
#include "pk_refine.h" /* PK_AXES */

/** Axes the interpreter handles (X Y, and Z in a 3-axis build). */
#define PK_GC_AXES PK_AXES

/** Build knobs of the interpreter (a small image leaves them out): 1 (the
 *  default) builds G2/G3 arcs (PK_BUILD_ARCS) and G5/G5.1 splines
 *  (PK_BUILD_G5); 0 refuses every such block with PK_GC_E_UNSUPPORTED
 *  (error:20, as Grbl answers a G-code it does not have). */
#ifndef PK_BUILD_ARCS
#define PK_BUILD_ARCS 1
#endif
#ifndef PK_BUILD_G5
#define PK_BUILD_G5 1
#endif

/** Longest line pk_gcode_parse accepts (bytes, terminator excluded). */
#define PK_GC_LINE_MAX 255u

/**
 * Status of parse/interp: Grbl 1.1's error numbers (doc/csv/error_codes_en_US.csv),
 * so that the protocol prints "error:<value>".
 */
enum pk_gc_status {
    PK_GC_OK = 0,
    PK_GC_E_EXPECTED_LETTER = 1,  /**< a byte that is not a word letter */
    PK_GC_E_BAD_NUMBER = 2,       /**< missing or malformed value; more than 9 integer digits;
                                       a value beyond what plotkin can run (a dwell over 24 h,
                                       F, S or a length beyond its int32 range) */
    PK_GC_E_NEGATIVE = 4,         /**< negative F, N, P, S or T */
    PK_GC_E_READ_FAIL = 7,        /**< stored coordinate data unreadable (NVM checksum) */
    PK_GC_E_LINE_OVERFLOW = 11,   /**< line longer than the buffer */
    PK_GC_E_TRAVEL = 15,          /**< a target beyond the machine's numeric range ±PK_UM_MAX */
    PK_GC_E_INVALID_JOG = 16,     /**< $J= with words or commands a jog may not have */
    PK_GC_E_UNSUPPORTED = 20,     /**< unknown letter, G or M code (also a Q nothing uses) */
    PK_GC_E_MODAL_GROUP = 21,     /**< two commands from one modal group */
    PK_GC_E_UNDEFINED_FEED = 22,  /**< a feed move without a feed rate (or below 1 mm/min) */
    PK_GC_E_NOT_INTEGER = 23,     /**< G/M code with a fraction it does not have */
    PK_GC_E_AXIS_CONFLICT = 24,   /**< two commands that use axis words */
    PK_GC_E_REPEATED_WORD = 25,   /**< the same letter twice (except G and M) */
    PK_GC_E_NO_AXIS_WORDS = 26,   /**< G10, G92, G2/G3, G38.x without axis words */
    PK_GC_E_LINE_NUMBER = 27,     /**< N above PK_GC_N_MAX */
    PK_GC_E_VALUE_MISSING = 28,   /**< G4 without P; G10 without L/P; G5/G5.1 words missing */
    PK_GC_E_G53_MOTION = 30,      /**< G53 with a motion mode other than G0/G1 */
    PK_GC_E_UNUSED_WORDS = 31,    /**< axis words while G80 is active */
    PK_GC_E_NO_AXIS_IN_PLANE = 32,/**< G2/G3 without an axis word of the plane */
    PK_GC_E_BAD_TARGET = 33,      /**< invalid target: arc radii, R arc to its own start,
                                       probe to the current position; G5 rules */
    PK_GC_E_ARC_RADIUS = 34,      /**< R arc with |R| below half the chord */
    PK_GC_E_NO_OFFSETS = 35,      /**< G2/G3 IJK form without an offset of the plane */
    PK_GC_E_UNUSED_VALUE = 36,    /**< value words nothing in the block uses */
    PK_GC_E_G43_AXIS = 37,        /**< G43.1 with axis words other than Z */
    PK_GC_E_TOOL_NUMBER = 38      /**< T greater than 255 */
};

/** Largest N line number (Grbl 1.1h's MAX_LINE_NUMBER; N above it is error 27). */
#define PK_GC_N_MAX 10000000

/** Value words, indices into pk_gc_block.m/dec and bits of pk_gc_block.words. */
enum pk_gc_word {
    PK_GC_W_F = 0, PK_GC_W_I, PK_GC_W_J, PK_GC_W_K, PK_GC_W_L, PK_GC_W_N, PK_GC_W_P,
    PK_GC_W_Q, PK_GC_W_R, PK_GC_W_S, PK_GC_W_T, PK_GC_W_X, PK_GC_W_Y, PK_GC_W_Z,
    PK_GC_W_COUNT
};
#define PK_GC_WBIT(w) ((uint16_t)(1u << (w)))
#define PK_GC_AXIS_WORDS (PK_GC_WBIT(PK_GC_W_X) | PK_GC_WBIT(PK_GC_W_Y) | PK_GC_WBIT(PK_GC_W_Z))

/** Modal groups (Grbl's gcode.h, plus plotkin's path group): bits of
 *  pk_gc_block.groups. */
enum pk_gc_group {
    PK_GC_G_NONMODAL = 0, /**< G4 G10 G28 G28.1 G30 G30.1 G53 G92 G92.1 */
    PK_GC_G_MOTION,       /**< G0 G1 G2 G3 G38.2-G38.5 G80, G5 G5.1 */
    PK_GC_G_PLANE,        /**< G17 G18 G19 */
    PK_GC_G_DISTANCE,     /**< G90 G91 */
    PK_GC_G_ARC_DISTANCE, /**< G91.1 (the only IJK mode; G90.1 is error 20) */
    PK_GC_G_FEEDMODE,     /**< G93 G94 */
    PK_GC_G_UNITS,        /**< G20 G21 */
    PK_GC_G_CUTTER,       /**< G40 */
    PK_GC_G_TLO,          /**< G43.1 G49 */
    PK_GC_G_WCS,          /**< G54 .. G59 */
    PK_GC_G_PATH,         /**< G61 (Grbl), G64 (plotkin) */
    PK_GC_G_STOP,         /**< M0 M1 M2 M30 */
    PK_GC_G_SPINDLE,      /**< M3 M4 M5 */
    PK_GC_G_COOLANT,      /**< M7 M8 M9 */
    PK_GC_G_OVERRIDE,     /**< M56 */
    PK_GC_G_COUNT
};
#define PK_GC_GBIT(g) ((uint16_t)(1u << (g)))

/** Non-modal commands (values as Grbl's gcode.h). */
enum pk_gc_nonmodal {
    PK_GC_NM_NONE = 0,
    PK_GC_NM_DWELL = 4,          /**< G4 */
    PK_GC_NM_SET_COORD = 10,     /**< G10 */
    PK_GC_NM_HOME0 = 28,         /**< G28 */
    PK_GC_NM_HOME1 = 30,         /**< G30 */
    PK_GC_NM_SET_HOME0 = 38,     /**< G28.1 */
    PK_GC_NM_SET_HOME1 = 40,     /**< G30.1 */
    PK_GC_NM_ABSOLUTE = 53,      /**< G53 */
    PK_GC_NM_SET_OFFSET = 92,    /**< G92 */
    PK_GC_NM_RESET_OFFSET = 102  /**< G92.1 */
};
enum pk_gc_motion {
    PK_GC_MOT_RAPID = 0,  /**< G0 */
    PK_GC_MOT_LINEAR,     /**< G1 */
    PK_GC_MOT_CW_ARC,     /**< G2 */
    PK_GC_MOT_CCW_ARC,    /**< G3 */
    PK_GC_MOT_CUBIC,      /**< G5 */
    PK_GC_MOT_QUAD,       /**< G5.1 */
    PK_GC_MOT_PROBE_TOWARD,          /**< G38.2 */
    PK_GC_MOT_PROBE_TOWARD_NO_ERROR, /**< G38.3 */
    PK_GC_MOT_PROBE_AWAY,            /**< G38.4 */
    PK_GC_MOT_PROBE_AWAY_NO_ERROR,   /**< G38.5 */
    PK_GC_MOT_NONE        /**< G80 */
};
enum pk_gc_plane { PK_GC_PLANE_XY = 0, PK_GC_PLANE_ZX, PK_GC_PLANE_YZ };
enum pk_gc_distance { PK_GC_ABSOLUTE = 0, PK_GC_INCREMENTAL };
enum pk_gc_feedmode { PK_GC_UNITS_PER_MIN = 0 /**< G94 */, PK_GC_INVERSE_TIME /**< G93 */ };
enum pk_gc_units { PK_GC_MM = 0, PK_GC_INCH };
enum pk_gc_path { PK_GC_PATH_EXACT = 0 /**< G61 */, PK_GC_PATH_BLEND /**< G64 */ };
enum pk_gc_stop {
    PK_GC_STOP_NONE = 0, PK_GC_STOP_OPTIONAL = 1 /**< M1 (ignored, as Grbl) */,
    PK_GC_STOP_END = 2 /**< M2 */, PK_GC_STOP_PAUSE = 3 /**< M0 */,
    PK_GC_STOP_END_RESET = 30 /**< M30 */
};
enum pk_gc_spindle { PK_GC_SPINDLE_OFF = 0 /**< M5 */, PK_GC_SPINDLE_CW = 3 /**< M3 */,
                     PK_GC_SPINDLE_CCW = 4 /**< M4 */ };
/** Coolant state bits (M7 mist, M8 flood; M9 clears both). */
#define PK_GC_COOLANT_MIST 0x01u
#define PK_GC_COOLANT_FLOOD 0x02u
enum pk_gc_tlo { PK_GC_TLO_CANCEL = 0 /**< G49 */, PK_GC_TLO_DYNAMIC /**< G43.1 */ };

/** Axis-word users in one block (Grbl's axis_command). */
enum { PK_GC_AXCMD_NONE = 0, PK_GC_AXCMD_NONMODAL, PK_GC_AXCMD_MOTION, PK_GC_AXCMD_TLO };

/**
 * One parsed line. Only the groups whose bit is set in `groups` and the words
 * whose bit is set in `words` are meaningful; everything else is zero.
 */
struct pk_gc_block {
    uint16_t words;                 /**< PK_GC_WBIT(w) for each value word present */
    uint16_t groups;                /**< PK_GC_GBIT(g) for each modal group commanded */
    int32_t m[PK_GC_W_COUNT];       /**< word value mantissa: value = m * 10^-dec[w] */
    uint8_t dec[PK_GC_W_COUNT];     /**< decimals, 0..9 */
    uint8_t nonmodal;               /**< enum pk_gc_nonmodal */
    uint8_t motion;                 /**< enum pk_gc_motion */
    uint8_t plane;                  /**< enum pk_gc_plane */
    uint8_t distance;               /**< enum pk_gc_distance */
    uint8_t feedmode;               /**< enum pk_gc_feedmode */
    uint8_t units;                  /**< enum pk_gc_units */
    uint8_t tlo;                    /**< enum pk_gc_tlo */
    uint8_t wcs;                    /**< 0..5: G54..G59 */
    uint8_t path;                   /**< enum pk_gc_path */
    uint8_t stop;                   /**< enum pk_gc_stop */
    uint8_t spindle;                /**< enum pk_gc_spindle */
    uint8_t coolant;                /**< 7, 8 or 9 */
    uint8_t axis_cmd;               /**< PK_GC_AXCMD_* */
};

/**
 * Parse one line.
 * @param line  the bytes of the line without its terminator (need not be
 *              NUL-terminated; may be NULL when len is 0)
 * @param len   number of bytes (more than PK_GC_LINE_MAX: error 11)
 * @param out   receives the block (words, groups and axis_cmd always set; a
 *              value or modal field is meaningful only under its words or
 *              groups bit, the others are left as they were)
 * @return PK_GC_OK or the first error (enum pk_gc_status). A line of only
 *         ignored bytes, comments or "%" parses to an empty block.
 * Calling context: any; reentrant; reads only line[0..len).
 */
int pk_gcode_parse(const uint8_t *line, size_t len, struct pk_gc_block *out);

/**
 * A word value scaled to `dec` decimals (e.g. 3: mm -> µm), rounded half
 * away from zero. 32-bit arithmetic.
 * @return PK_GC_OK, or PK_GC_E_BAD_NUMBER if the result leaves int32
 */
int pk_gcode_scaled(int32_t m, uint8_t m_dec, uint8_t dec, int32_t *out);

/**
 * Parse a whole string as one number (word-value rules).
 * @return PK_GC_OK with *m, *dec set; PK_GC_E_BAD_NUMBER; or
 *         PK_GC_E_EXPECTED_LETTER if something follows the number
 */
int pk_gcode_parse_number(const uint8_t *s, size_t len, int32_t *m, uint8_t *dec);

/* ------------------------------------------------------------------------- */
/* Interpreter                                                                */
/* ------------------------------------------------------------------------- */

/** Feed rate in micrometres per minute (0 = not set). */
typedef int32_t pk_gc_umpm_t;
/** Largest feed the interpreter accepts (µm/min); more is error 2. */
#define PK_GC_FEED_MAX ((pk_gc_umpm_t)2000000000)
/** Smallest feed (µm/min) a move may have: 1 mm/min (PK_UM_MIN_MIN of the
 *  machine); a slower G94 feed or G93 move is error 22. */
#define PK_GC_FEED_MIN ((pk_gc_umpm_t)1000)
/** Longest dwell (ms): 24 h (PK_DWELL_MS_MAX); longer is error 2. */
#define PK_GC_DWELL_MAX_MS 86400000u

/** Stored coordinate data: G54..G59 = 0..5, G28 = 6, G30 = 7 (Grbl's indices). */
#define PK_GC_COORD_G28 6u
#define PK_GC_COORD_G30 7u
#define PK_GC_COORD_COUNT 8u

/**
 * What the interpreter needs from its environment (the Grbl engine).
 * coord_read reads stored coordinate data idx (machine µm): 0 on success,
 * non-zero if the store is unreadable (the line fails with error 7).
 * tol_default_um is $12, the G64 tolerance when the block has no P (µm, >= 1).
 */
struct pk_gc_env {
    int (*coord_read)(void *ctx, unsigned idx, pk_um_t out[PK_GC_AXES]);
    void *ctx;
    pk_um_t tol_default_um;
};

/**
 * Modal state of the interpreter (one per machine; caller-owned). All
 * positions and offsets in machine µm. Work position = machine position -
 * wcs - g92 - (Z) tlo.
 */
struct pk_gc_state {
    pk_um_t pos_um[PK_GC_AXES];     /**< last commanded machine position */
    pk_um_t wcs_um[PK_GC_AXES];     /**< offset of the active coordinate system */
    pk_um_t g92_um[PK_GC_AXES];     /**< G92 offset */
    pk_um_t tlo_um;                 /**< G43.1 tool length offset (Z) */
    pk_gc_umpm_t feed;              /**< G94: µm/min; G93: 1/min * 1000 (0 = unset) */
    int32_t spindle_s;              /**< S, 1e-3 of the word's unit */
    pk_um_t tol_um;                 /**< G64 P, µm (0: $12) */
    uint8_t motion;                 /**< enum pk_gc_motion */
    uint8_t plane;
    uint8_t distance;
    uint8_t feedmode;
    uint8_t units;
    uint8_t tlo;
    uint8_t wcs;                    /**< 0..5 */
    uint8_t path;
    uint8_t spindle;                /**< enum pk_gc_spindle */
    uint8_t coolant;                /**< PK_GC_COOLANT_* bits */
    uint8_t parking_ovr;            /**< M56 state: 1 enabled (Grbl's default) */
    uint8_t tool;                   /**< T */
    uint8_t cubic_prev;             /**< the last move was a G5 (I/J may be omitted) */
    pk_um_t prev_pq_um[2];          /**< that G5's P,Q (µm) */
    int32_t line_number;            /**< N of the last block (0 if none) */
};

/**
 * Reset to power-on defaults (G0 G54 G17 G21 G90 G94 G64 M5 M9, no offsets,
 * feed and S unset, T0) with the machine at pos_um and G54's stored offset.
 */
void pk_gcode_state_init(struct pk_gc_state *st, const pk_um_t pos_um[PK_GC_AXES],
                         const pk_um_t g54_um[PK_GC_AXES]);

/** What a block does (flags of pk_gc_cmd.what), in execution order. */
#define PK_GC_DO_SPINDLE   0x0001u  /**< spindle state or S changed: cmd.spindle, spindle_s */
#define PK_GC_DO_COOLANT   0x0002u  /**< coolant changed: cmd.coolant */
#define PK_GC_DO_DWELL     0x0004u  /**< wait cmd.dwell_ms after the queue drains */
#define PK_GC_DO_COORD     0x0008u  /**< store coordinate data cmd.coord_idx := cmd.coord_um */
#define PK_GC_DO_WCO       0x0010u  /**< a work offset changed (G10 active, G54.., G92, G43.1) */
#define PK_GC_DO_PATH      0x0020u  /**< path mode changed: cmd.path, cmd.tol_um */
#define PK_GC_DO_VIA       0x0040u  /**< G28/G30: a rapid to cmd.via_um first */
#define PK_GC_DO_MOVE      0x0080u  /**< a move: cmd.motion from start_um to target_um */
#define PK_GC_DO_STOP      0x0100u  /**< M0/M2/M30: cmd.stop (after the move) */

/** One accepted block, ready to execute (machine coordinates, µm). */
struct pk_gc_cmd {
    uint16_t what;                      /**< PK_GC_DO_* */
    uint8_t motion;                     /**< enum pk_gc_motion, with DO_MOVE */
    uint8_t spindle;                    /**< with DO_SPINDLE */
    uint8_t spindle_state_changed;      /**< with DO_SPINDLE: M3/M4/M5 changed (else S only) */
    uint8_t coolant;                    /**< with DO_COOLANT */
    uint8_t path;                       /**< with DO_PATH */
    uint8_t stop;                       /**< with DO_STOP */
    uint8_t coord_idx;                  /**< with DO_COORD */
    uint8_t laser_off;                  /**< the move runs with a laser off (G0, G38, ...) */
    int32_t spindle_s;                  /**< S, 1e-3 units */
    pk_um_t tol_um;                     /**< with DO_PATH: G64 P in µm (0 = $12) */
    pk_um_t chord_tol_um;               /**< arcs, G5: chord tolerance (P/4 in G64, min($12,2 µm) in G61) */
    uint32_t dwell_ms;                  /**< with DO_DWELL */
    pk_gc_umpm_t feed_umpm;             /**< feed of the move (G0: 0 = rapid), µm/min */
    pk_um_t coord_um[PK_GC_AXES];       /**< with DO_COORD */
    pk_um_t via_um[PK_GC_AXES];         /**< with DO_VIA */
    pk_um_t start_um[PK_GC_AXES];       /**< with DO_MOVE: where the move starts */
    pk_um_t target_um[PK_GC_AXES];      /**< with DO_MOVE: where it ends */
    union { /* only the curves this build has: 117 B of RAM on an AVR without arcs */
#if PK_BUILD_ARCS
        struct pk_arc arc;              /**< G2/G3: planned (pk_arc_next gives the chords) */
#endif
#if PK_BUILD_G5
        struct pk_bez bez;              /**< G5/G5.1: ready (pk_bez_next); control points
                                             in bez.p[0..3] (G5.1: 0..2) */
#endif
        uint8_t none;                   /**< a build without arcs and G5: unused */
    } u;
    int32_t line_number;                /**< N, or -1 */
};

/**
 * Validate a parsed block against the modal state and turn it into a command.
 * On PK_GC_OK, *st is updated (modal state, position after the move) and *cmd
 * describes the actions. On error, *st is unchanged and *cmd is meaningless.
 * Calling context: main loop; reentrant.
 */
int pk_gcode_interp(struct pk_gc_state *st, const struct pk_gc_block *b,
                    const struct pk_gc_env *env, struct pk_gc_cmd *cmd);

/**
 * A `$J=` jog block (Grbl's jog rules): G20/G21, G90/G91 and G53 only (else
 * error 16), F required (error 22), axis words, N; the move is a G1 at F in
 * G94 from the current position; the modal state is not changed (st is
 * const; the caller updates the position). cmd->what is PK_GC_DO_MOVE, or 0
 * for a jog without axis words.
 */
int pk_gcode_jog(const struct pk_gc_state *st, const struct pk_gc_block *b, struct pk_gc_cmd *cmd);

/** Work offset (machine - work) on axis a: wcs + g92 (+ tlo on Z). */
pk_um_t pk_gcode_wco(const struct pk_gc_state *st, unsigned a);

/**
 * A length word in µm (units G21/G20), rounded half away.
 * @return PK_GC_OK or PK_GC_E_BAD_NUMBER (beyond int32)
 */
int pk_gcode_len_um(int32_t m, uint8_t dec, uint8_t units, int32_t *out);

#endif
