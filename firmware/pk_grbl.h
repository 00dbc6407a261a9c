/*
 * pk_grbl.h — the Grbl 1.1 serial protocol engine of plotkin (contract).
 *
 * Speaks Grbl 1.1h's protocol over a byte stream so that G-code senders
 * (UGS, bCNC, cncjs, Grbl's stream.py, ...) drive plotkin unchanged. The
 * README's parity table lists every command with Grbl's and plotkin's
 * behaviour; in short:
 *   - greeting "Grbl 1.1h [plotkin 0.1 '$' for help]" at start and on every
 *     soft reset, then the startup lines ($N0, $N1) as ">line:ok";
 *   - one "ok" or "error:N" per line (Grbl's numbers), sent when the line is
 *     parsed, validated and handed to the machine; lines that must wait for
 *     the machine are answered when done, as in Grbl: G4 (after the queue has
 *     drained and the dwell has run), M0 (after the resume), M2/M30, G10,
 *     G28.1/G30.1, G92/G92.1, G43.1/G49, G54..G59 (after the queue drains);
 *   - lines assembled as Grbl does (bytes <= ' ' and comments dropped, letters
 *     upper-cased, '/' ignored) into a PK_GRBL_LINE_MAX buffer; longer lines
 *     are error:11; a line ends at LF, CR or CR LF;
 *   - character counting: while a line's command is being handed over (or
 *     waits), no further byte is read, so the sender's unacknowledged bytes
 *     stay in the 128-byte receive ring (pk_uart) and nothing is lost;
 *   - realtime bytes: '?' '!' '~' 0x18 and every byte >= 0x80 are taken off
 *     the stream by pk_grbl_rt_filter (in the receive ISR; if one reaches the
 *     line stream it is handled the same way — but a held, locked or sleeping
 *     engine reads no line bytes, so an integration must pass realtime bytes
 *     through pk_grbl_rt_filter for '~' and ctrl-X to reach it then, as
 *     pk_app, serve and the simulators do): 0x84 door (no door input:
 *     a feed hold and a message), 0x85 jog cancel, 0x90-0x97 feed and rapid overrides, 0x99-0x9E
 *     spindle overrides, 0xA0/0xA1 coolant toggles, anything else discarded
 *     (cncjs sends 0x91 as UTF-8 C2 91: the C2 vanishes). Each realtime
 *     command is a flag that stays set until the main loop acts on it, so no
 *     number of other realtime bytes can make one be lost, and repeats before
 *     the main loop runs count once (as Grbl's flags);
 *   - status "<State|MPos:..|Bf:..|FS:..|WCO:..>" with Grbl's fields and
 *     schedule: $10 bit 0 MPos/WPos, bit 1 Bf; WCO every 10 reports (30 while
 *     busy) and at once after any change; Ov:feed,rapid,spindle (+ A:SCFM
 *     accessories) on the report after each WCO one, every 10/20 reports, and
 *     at once after an override or accessory change; $13 inches;
 *   - reset (Ctrl-X): Idle again unless motion was cut (then ALARM:3 and the
 *     G-code lock until $X), as Grbl: a reset after a completed hold is Idle;
 *   - $ commands: $ $$ $# $G $I $I= $N $Nx= $x= $C $X $H $J= $SLP, $RST= with $ # or *;
 *   - inputs (when the machine has them, pk_grbl_machine_ops.inputs): $21
 *     hard limits (a switch closing: "ALARM:1", "[MSG:Reset to continue]",
 *     nothing but '?' and reset until a reset; refused on a board without
 *     limit switches), $H homing with $22-$27 (ALARM:6-9 on failure, then a
 *     reset, as Grbl), G38.2-G38.5 probing (ALARM:4/5, "[PRB:...:1]", $#),
 *     Pn: in the status (P X Y Z D R H S), the hold/resume/reset buttons as
 *     '!' '~' Ctrl-X and the door input as 0x84.
 *
 * Settings, coordinate data (G54..G59, G28, G30), startup lines and the
 * build-info line live in a non-volatile store (struct pk_grbl_nvm: EEPROM on
 * a board, a file or RAM on a host) in Grbl's record-with-checksum layout, so
 * they survive a restart.
 *
 * The engine drives the machine through struct pk_grbl_machine_ops (an
 * adapter onto pk_motion.h in pk_grbl_motion.c; tests use fakes) and does
 * I/O through struct pk_grbl_stream. No float, no heap, no globals: all state
 * is in struct pk_grbl, whose buffers have compile-time sizes below.
 *
 * Calling context: pk_grbl_rt_filter in the receive ISR; everything else in
 * the main loop.
 */
#ifndef PLOTKIN_PK_GRBL_H
#define PLOTKIN_PK_GRBL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "pk_fixed.h"
#include "pk_gcode.h"

#define PK_GRBL_VERSION_STR "plotkin 0.1"

/** Line buffer: significant bytes kept of one line (Grbl's LINE_BUFFER_SIZE
 *  - 1: 79 on the ATmega328P); a line with more is error:11. 2..PK_GC_LINE_MAX. */
#ifndef PK_GRBL_LINE_MAX
#define PK_GRBL_LINE_MAX 255u
#endif
/** Longest single piece of output the engine emits at once: a status report
 *  (under 150 bytes), or a stored line with its prefix. */
#define PK_GRBL_ANSWER_MAX (PK_GRBL_LINE_MAX + 32u > 150u ? PK_GRBL_LINE_MAX + 32u : 150u)
/** Output staging buffer: at least PK_GRBL_ANSWER_MAX; more lets long
 *  reports go out in fewer polls. */
#ifndef PK_GRBL_OUT_SIZE
#define PK_GRBL_OUT_SIZE (PK_GRBL_ANSWER_MAX + 64u)
#endif
/** Build knob: 1 the engine drives the machine's inputs (hard limits, $H,
 *  G38.x, Pn:, the buttons and the door input; about 3.7 KB on a Cortex-M3,
 *  6.6 KB on AVR); 0 leaves them out (then $21=1 is refused and $H / G38.x
 *  answer as on a machine without switches or probe). Default: 1 in a hosted
 *  build (simulators, `plotkin serve`, the libgpiod build), 0 in a board
 *  image (freestanding), whose HAL has no input lines yet: a board that gets
 *  them sets -DPK_GRBL_INPUTS=1 in its board.mk. */
#ifndef PK_GRBL_INPUTS
#if defined(__STDC_HOSTED__) && __STDC_HOSTED__
#define PK_GRBL_INPUTS 1
#else
#define PK_GRBL_INPUTS 0
#endif
#endif
/** Build knob: 1 the engine reports every programmed primitive to an
 *  observer (pk_grbl_set_observer: the simulators' SVG and trace); 0 leaves
 *  the observer out (about 0.55 KB of flash on AVR, 4 B of RAM), and
 *  pk_grbl_set_observer is then not declared, so a caller fails to build.
 *  Default: 1 in a hosted build, 0 in a board image (freestanding). */
#ifndef PK_GRBL_OBSERVER
#if defined(__STDC_HOSTED__) && __STDC_HOSTED__
#define PK_GRBL_OBSERVER 1
#else
#define PK_GRBL_OBSERVER 0
#endif
#endif
/** Build knob: 1 the engine counts lines, answers, resets, moves and
 *  receive overflows (struct pk_grbl_stats: the simulators' and the board
 *  binary's summaries); 0 leaves the counters out (24 B of RAM and about
 *  0.3 KB of flash on AVR), and pk_grbl.stats is then not a member, so a
 *  reader fails to build. Default: 1 in a hosted build, 0 in a board image. */
#ifndef PK_GRBL_STATS
#if defined(__STDC_HOSTED__) && __STDC_HOSTED__
#define PK_GRBL_STATS 1
#else
#define PK_GRBL_STATS 0
#endif
#endif
/** Startup lines ($N0, $N1), as Grbl. */
#define PK_GRBL_N_STARTUP 2u
/** Receive buffer size advertised to character-counting senders ($I, Bf). */
#define PK_GRBL_RX_ADVERTISED 128u

#if PK_GRBL_LINE_MAX < 2 || PK_GRBL_LINE_MAX > PK_GC_LINE_MAX
#error "PK_GRBL_LINE_MAX must be 2..PK_GC_LINE_MAX"
#endif
#if PK_GRBL_OUT_SIZE < PK_GRBL_ANSWER_MAX
#error "PK_GRBL_OUT_SIZE must hold the longest answer"
#endif

/** Byte stream (uart_read / uart_write semantics of hal.h). */
struct pk_grbl_stream {
    /** Non-blocking read: bytes read (0 if none), or a negative value once
     *  after bytes were lost (RX overflow). */
    int (*read)(void *ctx, uint8_t *buf, size_t len);
    /** Non-blocking write: bytes accepted (may be fewer than len). */
    int (*write)(void *ctx, const uint8_t *buf, size_t len);
    /** Optional: bytes waiting in the receive buffer (for Bf). May be NULL. */
    size_t (*rx_used)(void *ctx);
    void *ctx;
};

/**
 * Non-volatile store (optional: without one, settings and offsets live in
 * RAM only and start from the defaults). read/write return 0 on success.
 * Calling context: MAIN; writes happen only while the machine is idle (Grbl
 * syncs before every EEPROM write).
 */
struct pk_grbl_nvm {
    int (*read)(void *ctx, uint32_t offset, uint8_t *buf, size_t len);
    int (*write)(void *ctx, uint32_t offset, const uint8_t *buf, size_t len);
    void *ctx;
    uint32_t size; /**< bytes available; at least pk_grbl_nvm_bytes() */
};

/** Bytes of non-volatile store the engine uses (this build's layout, see
 *  pk_grbl_settings.c): header, settings, 8 coordinate records, 3 lines. */
#define PK_GRBL_NVM_BYTES (5u + (4u * PK_GRBL_S_COUNT + 1u) + 8u * (4u * PK_GC_AXES + 1u) + \
                           (PK_GRBL_N_STARTUP + 1u) * (PK_GRBL_LINE_MAX + 2u))
uint32_t pk_grbl_nvm_bytes(void);

/** Machine state as the engine sees it. */
enum pk_grbl_mstate {
    PK_GRBL_M_IDLE = 0, PK_GRBL_M_RUN, PK_GRBL_M_HOLDING, PK_GRBL_M_HOLD, PK_GRBL_M_ALARM
};
/** Request results of the machine ops. */
#define PK_GRBL_M_OK 0
#define PK_GRBL_M_FULL 1        /**< no room: nothing changed; retry after the next poll */
#define PK_GRBL_M_ERROR (-1)    /**< refused (alarm or range): the line fails */
#define PK_GRBL_M_ENOTSUP (-2)  /**< this machine cannot do it (no probe input, no switches) */
#define PK_GRBL_M_ETRAVEL (-3)  /**< soft limits: the move would leave the travel */
#define PK_GRBL_M_ETRIGGERED (-4) /**< probe: already in the state waited for (ALARM:4) */

/** Input lines (bits of pk_grbl_machine_ops.inputs; the layout of hal.h's
 *  enum pk_hal_input): limit switch of axis i = bit i, then these. */
#define PK_GRBL_IN_LIMITS 0x0Fu
#define PK_GRBL_IN_PROBE 0x10u
#define PK_GRBL_IN_DOOR 0x20u
#define PK_GRBL_IN_HOLD 0x40u
#define PK_GRBL_IN_RESUME 0x80u
#define PK_GRBL_IN_RESET 0x100u
/** What pk_grbl_machine_ops.inputs reports. */
enum { PK_GRBL_IN_HAVE = 0, PK_GRBL_IN_LEVELS = 1, PK_GRBL_IN_EVENTS = 2 };
/** Results of pk_grbl_machine_ops.probe_result. */
enum { PK_GRBL_PRB_RUNNING = 0, PK_GRBL_PRB_CONTACT = 1, PK_GRBL_PRB_MISSED = 2,
       PK_GRBL_PRB_ABORTED = 3 };

/* ---- settings ------------------------------------------------------------ */

/** Settings, by index. Values are int32 in 10^-dec of the unit (dec from the
 *  table, see pk_grbl_setting_def). */
enum pk_grbl_setting {
    PK_GRBL_S_STEP_PULSE_US = 0, /**< $0   step pulse, µs (1..1000; below 1: error 6, Grbl's 3) */
    PK_GRBL_S_IDLE_DELAY_MS,     /**< $1   step idle delay, ms (stored; drivers stay enabled) */
    PK_GRBL_S_STEP_INVERT,       /**< $2   step port invert mask (0: set in the board configuration) */
    PK_GRBL_S_DIR_INVERT,        /**< $3   direction invert mask (0: idem) */
    PK_GRBL_S_ENABLE_INVERT,     /**< $4   enable invert (0: idem) */
    PK_GRBL_S_LIMIT_INVERT,      /**< $5   limit pins invert (stored for the inputs) */
    PK_GRBL_S_PROBE_INVERT,      /**< $6   probe pin invert (stored) */
    PK_GRBL_S_REPORT_MASK,       /**< $10  status report: bit 0 MPos (else WPos), bit 1 Bf */
    PK_GRBL_S_JUNCTION_MM,       /**< $11  junction deviation, mm */
    PK_GRBL_S_TOLERANCE_MM,      /**< $12  smoothing tolerance (G64 default), mm; arcs: see pk_gcode.h */
    PK_GRBL_S_REPORT_INCHES,     /**< $13  report in inches */
    PK_GRBL_S_SOFT_LIMITS,       /**< $20  soft limits (needs $22: error 10) */
    PK_GRBL_S_HARD_LIMITS,       /**< $21  hard limits (stored for the inputs) */
    PK_GRBL_S_HOMING,            /**< $22  homing cycle enable ($22=0 also clears $20) */
    PK_GRBL_S_HOMING_DIR,        /**< $23  homing direction invert mask */
    PK_GRBL_S_HOMING_FEED,       /**< $24  homing locate feed, mm/min */
    PK_GRBL_S_HOMING_SEEK,       /**< $25  homing search seek, mm/min */
    PK_GRBL_S_HOMING_DEBOUNCE,   /**< $26  homing switch debounce, ms */
    PK_GRBL_S_HOMING_PULLOFF,    /**< $27  homing pull-off, mm */
    PK_GRBL_S_SPINDLE_MAX,       /**< $30  S at full output (rpm) */
    PK_GRBL_S_SPINDLE_MIN,       /**< $31  S at the smallest non-zero output */
    PK_GRBL_S_LASER,             /**< $32  laser mode */
    PK_GRBL_S_STEPS_X,           /**< $100.. steps/mm, one per axis */
    PK_GRBL_S_RATE_X = PK_GRBL_S_STEPS_X + PK_GC_AXES,   /**< $110.. max rate, mm/min */
    PK_GRBL_S_ACCEL_X = PK_GRBL_S_RATE_X + PK_GC_AXES,   /**< $120.. acceleration, mm/s^2 */
    PK_GRBL_S_TRAVEL_X = PK_GRBL_S_ACCEL_X + PK_GC_AXES, /**< $130.. max travel, mm (soft limits:
                                                              [-travel, 0], as Grbl after homing) */
    PK_GRBL_S_SMOOTH_MODE = PK_GRBL_S_TRAVEL_X + PK_GC_AXES, /**< $200 0 exact, 1 fixed, 2 tolerance */
    PK_GRBL_S_SCHEME,            /**< $201 0 B-spline, 1 DLG 4-point */
    PK_GRBL_S_DEGREE,            /**< $202 B-spline degree 1..7 */
    PK_GRBL_S_DEPTH,             /**< $203 subdivision depth (fixed mode) */
    PK_GRBL_S_CORNER_DEG,        /**< $204 corners turning more than this stay sharp */
    PK_GRBL_S_PEN_SETTLE_MS,     /**< $205 dwell after each pen/spindle change, ms */
    PK_GRBL_S_DIR_SETUP_US,      /**< $206 direction set-up before a step, µs */
    PK_GRBL_S_LOOKAHEAD_MS,      /**< $207 look-ahead wait, ms (0 = 100 ms) */
    PK_GRBL_S_COUNT
};
#define PK_GRBL_S_STEPS_Y (PK_GRBL_S_STEPS_X + 1)
#define PK_GRBL_S_RATE_Y (PK_GRBL_S_RATE_X + 1)
#define PK_GRBL_S_ACCEL_Y (PK_GRBL_S_ACCEL_X + 1)
#define PK_GRBL_S_TRAVEL_Y (PK_GRBL_S_TRAVEL_X + 1)
#if PK_GC_AXES >= 3
#define PK_GRBL_S_STEPS_Z (PK_GRBL_S_STEPS_X + 2)
#define PK_GRBL_S_RATE_Z (PK_GRBL_S_RATE_X + 2)
#define PK_GRBL_S_ACCEL_Z (PK_GRBL_S_ACCEL_X + 2)
#define PK_GRBL_S_TRAVEL_Z (PK_GRBL_S_TRAVEL_X + 2)
#endif

struct pk_grbl_settings {
    int32_t v[PK_GRBL_S_COUNT]; /**< 10^-dec of the unit listed above */
};

/** One `$N` setting of the table (the one table of the settings: the engine
 *  and the simulator's `--config` loader both use it). */
struct pk_grbl_setting_def {
    uint8_t num;        /**< the N of `$N` (axis settings: 100 + 10 k + axis) */
    uint8_t dec;        /**< stored decimals (0: whole values only) */
    uint8_t pdec;       /**< decimals `$$` prints at least (Grbl's; more if set) */
    int32_t def, min, max;
};

/** Copy the table entry of setting idx into *out (the table may live in
 *  program memory, pk_rom.h). 0, or -1 if idx is out of range. */
int pk_grbl_setting_def(int idx, struct pk_grbl_setting_def *out);

/** Index of setting `$num`, or -1 if there is none. */
int pk_grbl_setting_index(uint32_t num);

/**
 * Parse the text after '$' of a `$N=value` line (upper-case, no blanks)
 * against the table: 0 with *idx and *val set, or a Grbl error: 2 (bad
 * number), 3 (no '=', unknown setting, out of range, not a whole number where
 * one is needed), 4 (negative), 6 ($0 below 3 µs). Pure function.
 */
int pk_grbl_setting_parse(const uint8_t *s, size_t n, int *idx, int32_t *val);

/**
 * Store val into s->v[idx] with Grbl's cross rules: 10 for $20=1 while $22=0;
 * $22=0 clears $20. 0 or the error (nothing changed).
 */
int pk_grbl_setting_store(struct pk_grbl_settings *s, int idx, int32_t val);

/** Apply one "$N=value" text (the leading '$' optional) to *s: 0 or the Grbl
 *  error of pk_grbl_setting_parse / _store. For tools and tests. */
int pk_grbl_settings_apply(struct pk_grbl_settings *s, const char *assignment);

/** Fill *s with the defaults. */
void pk_grbl_settings_default(struct pk_grbl_settings *s);

/** Setting idx in 10^-k units (k <= 9), rounded half away (e.g. mm -> µm: 3). */
int32_t pk_grbl_setting_scaled(const struct pk_grbl_settings *s, int idx, unsigned k);

/* ---- the machine --------------------------------------------------------- */

/**
 * What the engine needs from a machine (m is the ops' context). Request calls
 * return PK_GRBL_M_OK, PK_GRBL_M_FULL or an error and never block. Members
 * marked optional may be NULL.
 */
struct pk_grbl_machine_ops {
    /** Straight move (rapid: at the axes' max rates, feed ignored). */
    int (*move)(void *m, const pk_um_t target[PK_GC_AXES], pk_gc_umpm_t feed_umpm, int rapid);
    /** Optional: a feed move to a chord vertex of a flattened arc or G5
     *  within chord_err_um of the curve (pk_machine_move_chord); NULL: move. */
    int (*move_chord)(void *m, const pk_um_t target[PK_GC_AXES], pk_gc_umpm_t feed_umpm,
                      pk_um_t chord_err_um);
    /** Pen / tool output (M3 M4 on, M5 off): stop, switch, settle. */
    int (*pen)(void *m, int down);
    /** Optional: spindle/laser value (Q0.16 of full scale; sync: stop first). */
    int (*spindle)(void *m, uint16_t value_q16, int sync);
    int (*dwell)(void *m, uint32_t ms);
    /** exact = 1: G61; else G64 with tol_um (> 0). */
    int (*smoothing)(void *m, int exact, pk_um_t tol_um);
    /** End of a stroke/program: everything queued runs and stops. */
    int (*end)(void *m);
    void (*hold)(void *m);
    void (*resume)(void *m);
    /** Soft reset: stop now, drop everything. Returns 1 if motion was cut. */
    int (*reset)(void *m);
    void (*position_um)(void *m, pk_um_t out[PK_GC_AXES]);
    int (*state)(void *m); /**< enum pk_grbl_mstate */
    uint32_t (*blocks_free)(void *m);
    uint32_t (*blocks_total)(void *m);
    pk_gc_umpm_t (*speed_umpm)(void *m);
    /** Apply settings (only called while idle). 0, or -1 if refused. */
    int (*configure)(void *m, const struct pk_grbl_settings *s);
    /** Optional: feed 10..200 %, rapid 1..100 % (Grbl 25/50/100). */
    int (*set_override)(void *m, uint16_t feed_pct, uint16_t rapid_pct);
    /** Optional: soft limits box (machine µm) on/off. */
    int (*set_soft_limits)(void *m, int on, const pk_um_t lo[PK_GC_AXES], const pk_um_t hi[PK_GC_AXES]);
    /** Optional (NULL = PK_GRBL_M_ENOTSUP): start a G38.x probing move
     *  toward target (called while idle); flags bit 0 away (G38.4/.5), bit 1
     *  no error on a miss. OK started, ETRIGGERED (probe already in the state
     *  waited for: nothing moved), ENOTSUP (no probe input), ERROR. */
    int (*probe)(void *m, const pk_um_t target[PK_GC_AXES], pk_gc_umpm_t feed_umpm, unsigned flags);
    /** Optional (with probe): the probing move's outcome (PK_GRBL_PRB_*);
     *  pos (µm): CONTACT: the position at the contact; MISSED: at the end. */
    int (*probe_result)(void *m, pk_um_t pos[PK_GC_AXES]);
    /** Optional (NULL = PK_GRBL_M_ENOTSUP): start the homing cycle ($H) of
     *  the axes of axes_mask that have switches (called while idle) with the
     *  settings last configured ($23-$27, $130..). OK, ENOTSUP, ERROR. */
    int (*home)(void *m, unsigned axes_mask);
    /** Optional (with home): drive the cycle: 0 running, 1 done (positions
     *  set), else Grbl's alarm 6-9 (the machine is stopped). */
    int (*home_poll)(void *m);
    /** Optional (with home): stop a running cycle now, reason alarm (6 reset,
     *  7 door). */
    void (*home_abort)(void *m, int alarm);
    /** Optional: hard limits on/off (OK, or ENOTSUP: no limit input). */
    int (*set_hard_limits)(void *m, int on);
    /** Optional (NULL: no inputs): PK_GRBL_IN_* bits: what = PK_GRBL_IN_HAVE
     *  the lines the board has, _LEVELS the active ones now, _EVENTS the
     *  ones that became active since the last such call. */
    uint32_t (*inputs)(void *m, unsigned what);
    /** Optional: 1 if the machine's ALARM state is a hard limit (Grbl's
     *  critical ALARM:1), 0 for other faults. */
    int (*alarm_is_limit)(void *m);
};

/* ---- the observer -------------------------------------------------------- */

/** Kinds of programmed motion primitive (pk_grbl_prim.kind). */
enum pk_grbl_prim_kind {
    PK_GRBL_PRIM_RAPID = 0, /**< G0, G28/G30 moves: straight, at the rapid rate */
    PK_GRBL_PRIM_LINE,      /**< G1 (and $J= jogs, with .jog = 1) */
    PK_GRBL_PRIM_ARC,       /**< G2/G3 (see pk_arc.h for the curve) */
    PK_GRBL_PRIM_CUBIC,     /**< G5 */
    PK_GRBL_PRIM_QUAD       /**< G5.1 */
};

/**
 * One programmed motion primitive as the program states it, in machine
 * coordinates (µm), before any flattening or smoothing. An arc whose radius is
 * beyond 4194 mm runs as one chord and is reported as a LINE.
 */
struct pk_grbl_prim {
    uint8_t kind;                   /**< enum pk_grbl_prim_kind */
    uint8_t jog;                    /**< 1: a $J= jog */
    uint8_t tool_on;                /**< spindle/pen on while it runs (M3/M4; laser mode: and
                                         the laser fires on this kind of move) */
    uint8_t exact;                  /**< 1: G61 (exact path), 0: G64 (smoothed) */
    uint32_t line;                  /**< stream line (1 = first line received since init) */
    int32_t n;                      /**< its N word, or -1 */
    int32_t spindle_s;              /**< S in force (1e-3 units) */
    pk_gc_umpm_t feed_umpm;         /**< programmed feed (0 for rapids), before overrides */
    pk_um_t path_tol_um;            /**< G64 tolerance in force (µm) */
    pk_um_t chord_tol_um;           /**< ARC, CUBIC, QUAD: chord tolerance of the flattening */
    pk_um_t start[PK_GC_AXES];
    pk_um_t end[PK_GC_AXES];
    /* ARC */
    int32_t centre_q8[2];           /**< centre in (a0, a1), Q8 µm */
    uint8_t a0, a1, al;             /**< plane axes, linear axis (PK_AXES: none) */
    uint8_t cw;                     /**< G2 */
    uint64_t sweep;                 /**< swept angle, binary (PK_ARC_TURN = 2^32 = one turn) */
    int32_t r0_q8, r1_q8;           /**< radius at start and end, Q8 µm */
    /* CUBIC, QUAD: XY control points (QUAD: ctrl[0]) */
    pk_um_t ctrl[2][2];
};

/** Observer: called once per accepted primitive, when its execution starts,
 *  in program order, from within pk_grbl_poll (MAIN). *p is valid only
 *  during the call. Not called in check mode. */
typedef void (*pk_grbl_observer_fn)(void *ctx, const struct pk_grbl_prim *p);

/* ---- the engine ---------------------------------------------------------- */

/** Counters for summaries and tests. */
struct pk_grbl_stats {
    uint32_t lines;       /**< lines answered (ok/error) */
    uint32_t ok;          /**< answered ok */
    uint32_t errors;      /**< answered error:N */
    uint32_t resets;      /**< soft resets handled */
    uint32_t rx_lost;     /**< overflow reports from the stream */
    uint32_t moves;       /**< move requests handed to the machine (chords included) */
};

/** Realtime flags (indices of pk_grbl.rt), set by the ISR, cleared by MAIN. */
enum {
    PK_GRBL_RT_RESET = 0, PK_GRBL_RT_STATUS, PK_GRBL_RT_HOLD, PK_GRBL_RT_CYCLE,
    PK_GRBL_RT_JOG_CANCEL, PK_GRBL_RT_DOOR,
    PK_GRBL_RT_FEED_RESET, PK_GRBL_RT_FEED_PLUS10, PK_GRBL_RT_FEED_MINUS10,
    PK_GRBL_RT_FEED_PLUS1, PK_GRBL_RT_FEED_MINUS1,
    PK_GRBL_RT_RAPID_RESET, PK_GRBL_RT_RAPID_50, PK_GRBL_RT_RAPID_25,
    PK_GRBL_RT_SPINDLE_RESET, PK_GRBL_RT_SPINDLE_PLUS10, PK_GRBL_RT_SPINDLE_MINUS10,
    PK_GRBL_RT_SPINDLE_PLUS1, PK_GRBL_RT_SPINDLE_MINUS1, PK_GRBL_RT_SPINDLE_STOP,
    PK_GRBL_RT_FLOOD, PK_GRBL_RT_MIST,
    PK_GRBL_RT_COUNT
};

/** The engine. Caller-owned; members are private (use the functions). */
struct pk_grbl {
    struct pk_grbl_stream io;
    struct pk_grbl_machine_ops mo;  /* copied at init */
    void *m;
    struct pk_grbl_nvm nvm;         /* size 0: none */
#if PK_GRBL_OBSERVER
    pk_grbl_observer_fn obs;
    void *obs_ctx;
#endif
    struct pk_grbl_settings set;
    struct pk_gc_state gc;
#if PK_GRBL_STATS
    struct pk_grbl_stats stats;
#endif
    /* realtime flags: one byte each, the ISR writes 1, MAIN writes 0 */
    volatile uint8_t rt[PK_GRBL_RT_COUNT];
    volatile uint8_t rt_any; /* a flag was set since the engine last took them */
    /* line assembly */
    uint8_t line[PK_GRBL_LINE_MAX];
    uint8_t len;
    uint8_t line_flags;   /* LF_* in pk_grbl.c */
    uint8_t last_cr;
    uint8_t line_src;     /* 0: stream; 1 + k: startup line k */
    uint32_t line_no;     /* lines received from the stream since init */
    /* the accepted command being handed to the machine */
    struct pk_gc_cmd cmd;
    uint16_t todo;        /* PK_GC_DO_* still to do; 0 = none pending */
    uint8_t step;         /* progress inside the current todo item (pk_grbl.c) */
    uint8_t pt_held;      /* pt holds a vertex the machine has not taken */
    pk_um_t pt[PK_GC_AXES];
    uint8_t startup_next; /* next startup line to run after a greeting (N_STARTUP: none) */
    /* machine-side state sent */
    uint8_t pen_now;      /* 0 off, 1 on, 2 unknown */
    int32_t laser_sent;   /* spindle value last sent (Q16), -1 unknown */
    uint8_t spindle_due;  /* an override changed the spindle output: resend */
    uint8_t ovr_feed, ovr_rapid, ovr_spindle; /* percent */
    uint8_t wco_counter, ovr_counter;         /* Grbl's report refresh counters */
    /* output */
    uint8_t out[PK_GRBL_OUT_SIZE];
    uint16_t out_len;
    uint8_t report;       /* multi-line report in progress (R_* in pk_grbl.c) */
    uint8_t report_i;
    uint8_t status_due;
    uint8_t greet_due;
    uint8_t mode;         /* engine-level state (MODE_* in pk_grbl.c) */
    uint8_t alarm;        /* Grbl alarm code latched (0 none): G-code locked */
    uint8_t check_mode;
    uint8_t m_alarm_seen;
    uint8_t jogging;      /* $J= moves handed over and not finished: state "Jog" */
    uint8_t jog_cancel;   /* cancel requested: hold, then flush once stopped */
    uint8_t msg_due;      /* a one-line [MSG:...] waiting for output room (MSG_*) */
    /* inputs: hard limits, homing, probing */
    uint8_t owed;         /* a line is answered "ok" at the next reset (Grbl, critical alarms) */
    uint8_t hard_now;     /* hard limits as last set on the machine (2: unknown) */
    uint8_t home_ok_due;  /* $H done: answer it after the startup lines */
    uint8_t probe_ok;     /* Grbl's sys.probe_succeeded */
    pk_um_t prb_um[PK_GC_AXES]; /* Grbl's sys_probe_position (machine µm) */
};

/**
 * Initialise. Settings: *set if given (written to the store), else the
 * store's if it holds valid ones, else the defaults (written to the store,
 * "[MSG:Restoring defaults]" queued). The settings are given to
 * mo->configure; modal state at the machine's current position; greeting
 * queued. nvm may be NULL. Calling context: MAIN, before the receive ISR
 * delivers bytes.
 * @return 0, or -1 if mo->configure refused the settings
 */
int pk_grbl_init(struct pk_grbl *g, const struct pk_grbl_stream *io,
                 const struct pk_grbl_machine_ops *mo, void *m,
                 const struct pk_grbl_settings *set, const struct pk_grbl_nvm *nvm);

#if PK_GRBL_OBSERVER
/** [MAIN] Install (or remove, fn = NULL) the motion observer. */
void pk_grbl_set_observer(struct pk_grbl *g, pk_grbl_observer_fn fn, void *ctx);
#endif

/**
 * [ISR] Realtime filter for pk_uart (signature of pk_uart_rt_filter):
 * claims '?', '!', '~', 0x18 and every byte >= 0x80.
 * @return 1 if the byte was claimed (do not buffer it), else 0
 */
int pk_grbl_rt_filter(void *g, uint8_t byte);

/**
 * [MAIN] The engine has work that should not wait for a long machine poll:
 * a realtime command since it last took them (the filter sets a byte after
 * the command's flag; the engine clears it before it takes the flags, so
 * none is missed), or output not yet handed to the stream (a status
 * report, answers). For pk_machine_set_yield (ctx = the engine): a feed
 * hold, a status report or a reset then waits for one piece of the
 * machine's work, not for a whole poll.
 */
bool pk_grbl_wants_cpu(void *g);

/**
 * [MAIN] Do the protocol's work: act on realtime flags, hand the pending
 * command to the machine as it has room, read and answer lines, flush output.
 * Bounded work per call; call it from the main loop as often as possible
 * (alongside the machine's own poll).
 */
void pk_grbl_poll(struct pk_grbl *g);

/** [MAIN] 1 when nothing is pending inside the engine (no held line, no
 *  unsent output, no wait). */
int pk_grbl_idle(const struct pk_grbl *g);

/** The state the status report names. */
enum pk_grbl_state {
    PK_GRBL_IDLE = 0, PK_GRBL_RUN, PK_GRBL_HOLD0, PK_GRBL_HOLD1, PK_GRBL_JOG,
    PK_GRBL_ALARM, PK_GRBL_CHECK, PK_GRBL_SLEEP, PK_GRBL_HOME
};
/** [MAIN] The engine's state now (enum pk_grbl_state). */
int pk_grbl_state(const struct pk_grbl *g);

/**
 * [MAIN] The client went away mid-line (a serial port closed, a socket
 * dropped): drop the partial line assembled so far without answering it, so
 * that a later client's first bytes are not glued to it. A complete line
 * already being executed is not affected.
 */
void pk_grbl_drop_partial_line(struct pk_grbl *g);

/* ---- a RAM non-volatile store (caller-owned; for simulators and tests) --- */

struct pk_grbl_ram_nvm {
    uint8_t *buf;   /**< caller's buffer, >= pk_grbl_nvm_bytes(), any content */
    uint32_t size;
};
/** Fill *nvm with callbacks onto r (which must outlive it). */
void pk_grbl_ram_nvm(struct pk_grbl_ram_nvm *r, struct pk_grbl_nvm *nvm);

#endif
