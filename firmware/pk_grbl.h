/*
 * pk_grbl.h — the Grbl 1.1 serial protocol engine of plotkin (contract).
 *
 * Speaks Grbl 1.1's protocol over a byte stream so that existing G-code
 * senders (UGS, bCNC, cncjs, ...) drive plotkin unchanged:
 *   - a greeting line on start and on every soft reset, naming plotkin:
 *       "Grbl 1.1h [plotkin 0.1 '$' for help]"
 *   - one "ok" or "error:N" per received line (N = Grbl's error number), sent
 *     once the line is parsed, validated and handed to the machine (not when
 *     it has been executed). A line ends at LF, CR, or CR LF (one line).
 *   - character counting: at most one accepted line is held back waiting for
 *     room in the machine's request queue; while it waits the engine reads no
 *     further byte from the stream, so the sender's unacknowledged bytes stay
 *     in the 128-byte receive ring (pk_uart) and nothing is ever lost.
 *   - realtime bytes, acted on at once and never buffered: '?' status report,
 *     '!' feed hold, '~' cycle start/resume, 0x18 soft reset. They are claimed
 *     by pk_grbl_rt_filter() in the receive interrupt (see pk_uart.h); if one
 *     reaches the line stream anyway it is handled the same way and dropped.
 *     0x85 jog cancel is acted on; Grbl's other extended realtime bytes (0x84,
 *     0x87, 0x90-0x9D, 0xA0-0xA1: door, overrides) are claimed and ignored;
 *     any other non-ASCII byte makes its line fail with error:1.
 *   - status "<Idle|MPos:x,y,z|Bf:blocks,rx|FS:feed,0>" (+"|WCO:x,y,z" when a
 *     G92 offset is set), states Idle, Run, Hold:0, Hold:1, Alarm, Check.
 *   - $ commands: $ (help), $$ (settings), $N=value, $X (unlock), $C (check
 *     mode), $I (build info, "[OPT:,blocks,128]"), $G (parser state), $#
 *     (offsets), $H (error:5, no homing), $J= (jog: G20/G21 G90/G91, axis
 *     words and F only; modal state untouched; travel checked, error:15;
 *     state "Jog"; 0x85 cancels with a controlled stop and flushes the
 *     remaining jog moves). See pk_grbl.c for the settings.
 *
 * The engine drives the machine through struct pk_grbl_machine_ops (a thin
 * adapter onto pk_motion.h in pk_grbl_motion.c; tests use a fake), and does
 * I/O through struct pk_grbl_stream (pk_uart on a board or in the simulator).
 * No float, no heap, no globals: everything lives in struct pk_grbl.
 *
 * Calling context: pk_grbl_rt_filter in the receive ISR; everything else in
 * the main loop.
 */
#ifndef PLOTKIN_PK_GRBL_H
#define PLOTKIN_PK_GRBL_H

#include <stddef.h>
#include <stdint.h>
#include "pk_bezier.h"
#include "pk_fixed.h"
#include "pk_gcode.h"

#define PK_GRBL_VERSION_STR "plotkin 0.1"
/** Receive buffer size advertised to character-counting senders ($I, Bf). */
#define PK_GRBL_RX_ADVERTISED 128u
/** Output staging buffer; every single response fits. */
#define PK_GRBL_OUT_SIZE 256u

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

/** Machine state as the engine sees it. */
enum pk_grbl_mstate {
    PK_GRBL_M_IDLE = 0, PK_GRBL_M_RUN, PK_GRBL_M_HOLDING, PK_GRBL_M_HOLD, PK_GRBL_M_ALARM
};
/** Request results of the machine ops. */
#define PK_GRBL_M_OK 0
#define PK_GRBL_M_FULL 1      /**< no room: nothing changed; retry after the next poll */
#define PK_GRBL_M_ERROR (-1)  /**< refused (alarm or range): the line fails */

/** Settings, by index (numbers in pk_grbl.c's table; values pk_gc_u6_t). */
enum pk_grbl_setting {
    PK_GRBL_S_STEP_PULSE_US = 0, /**< $0   step pulse, µs */
    PK_GRBL_S_JUNCTION_MM,       /**< $11  junction deviation, mm */
    PK_GRBL_S_TOLERANCE_MM,      /**< $12  smoothing tolerance (G64 default) and G5 flatness, mm */
    PK_GRBL_S_STEPS_X,           /**< $100 steps/mm */
    PK_GRBL_S_STEPS_Y,           /**< $101 */
    PK_GRBL_S_STEPS_Z,           /**< $102 */
    PK_GRBL_S_RATE_X,            /**< $110 max rate, mm/min */
    PK_GRBL_S_RATE_Y,            /**< $111 */
    PK_GRBL_S_RATE_Z,            /**< $112 */
    PK_GRBL_S_ACCEL_X,           /**< $120 acceleration, mm/s^2 */
    PK_GRBL_S_ACCEL_Y,           /**< $121 */
    PK_GRBL_S_ACCEL_Z,           /**< $122 */
    PK_GRBL_S_TRAVEL_X,          /**< $130 max travel, mm: X in [0, $130] */
    PK_GRBL_S_TRAVEL_Y,          /**< $131 Y in [0, $131] */
    PK_GRBL_S_TRAVEL_Z,          /**< $132 Z in [-$132, $132] */
    PK_GRBL_S_SMOOTH_MODE,       /**< $200 0 exact, 1 fixed scheme, 2 within tolerance */
    PK_GRBL_S_SCHEME,            /**< $201 0 B-spline, 1 DLG 4-point */
    PK_GRBL_S_DEGREE,            /**< $202 B-spline degree 1..7 */
    PK_GRBL_S_DEPTH,             /**< $203 subdivision depth (fixed mode) */
    PK_GRBL_S_CORNER_DEG,        /**< $204 corners turning more than this stay sharp */
    PK_GRBL_S_PEN_SETTLE_MS,     /**< $205 dwell after each pen change, ms */
    PK_GRBL_S_DIR_SETUP_US,      /**< $206 direction set-up before a step, µs */
    PK_GRBL_S_COUNT
};

struct pk_grbl_settings {
    pk_gc_u6_t v[PK_GRBL_S_COUNT]; /**< 1e-6 of the unit listed above */
};

/** Fill *s with the defaults. */
void pk_grbl_settings_default(struct pk_grbl_settings *s);

/**
 * What the engine needs from a machine. m is the ops' context. Request calls
 * (move/pen/dwell/smoothing/end) return PK_GRBL_M_OK, PK_GRBL_M_FULL or
 * PK_GRBL_M_ERROR and must not block.
 */
struct pk_grbl_machine_ops {
    int (*move)(void *m, const pk_um_t target[PK_GC_AXES], pk_gc_umpm_t feed_umpm, int rapid);
    int (*pen)(void *m, int down);
    int (*dwell)(void *m, uint32_t ms);
    /** exact = 1: G61; else G64 with tol_um (> 0). */
    int (*smoothing)(void *m, int exact, pk_um_t tol_um);
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
};

/** Counters for summaries and tests. */
struct pk_grbl_stats {
    uint32_t lines;       /**< lines answered */
    uint32_t ok;          /**< answered ok */
    uint32_t errors;      /**< answered error:N */
    uint32_t resets;      /**< soft resets handled */
    uint32_t rx_lost;     /**< overflow reports from the stream */
    uint32_t moves;       /**< move requests handed to the machine */
};

/** The engine. Caller-owned; members are private. */
struct pk_grbl {
    struct pk_grbl_stream io;
    struct pk_grbl_machine_ops mo; /* copied at init */
    void *m;
    struct pk_grbl_settings set;
    struct pk_gc_state gc;
    struct pk_grbl_stats stats;
    /* line assembly */
    uint8_t line[PK_GC_LINE_MAX];
    uint16_t len;
    uint8_t line_flags;   /* LF_* in pk_grbl.c */
    uint8_t last_cr;
    /* accepted command being handed to the machine */
    struct pk_gc_cmd cmd;
    uint8_t cmd_todo;     /* PK_GC_DO_* still to do; 0 = none pending */
    uint8_t bez_on;       /* curve iterator running */
    uint8_t pt_held;      /* pt holds a vertex the machine has not taken */
    uint8_t pen_now;      /* 0 up, 1 down, 2 unknown */
    pk_um_t pt[2];
    struct pk_bez bez;
    /* output */
    uint8_t out[PK_GRBL_OUT_SIZE];
    uint16_t out_len;
    uint8_t report;       /* multi-line report in progress (R_* in pk_grbl.c) */
    uint8_t report_i;
    uint8_t status_due;   /* a '?' is waiting for output room */
    uint8_t greet_due;
    uint8_t alarm;        /* Grbl alarm code latched (0 none): G-code locked */
    uint8_t check_mode;
    uint8_t m_alarm_seen;
    uint8_t jogging;      /* $J= moves handed over and not finished: state "Jog" */
    uint8_t jog_cancel;   /* 0x85 received: hold, then flush once stopped */
    /* realtime events from the ISR: SPSC ring + reset counter */
    volatile uint8_t rt_buf[16];
    volatile uint8_t rt_head;       /* ISR only */
    volatile uint8_t rt_tail;       /* main only */
    volatile uint8_t rt_resets;     /* ISR only */
    uint8_t rt_resets_seen;         /* main only */
};

/**
 * Initialise: settings (copied; NULL = defaults, which are also given to
 * mo->configure), modal state at the machine's current position, greeting
 * queued. Calling context: MAIN, before the receive ISR delivers bytes.
 * @return 0, or -1 if mo->configure refused the settings
 */
int pk_grbl_init(struct pk_grbl *g, const struct pk_grbl_stream *io,
                 const struct pk_grbl_machine_ops *mo, void *m,
                 const struct pk_grbl_settings *set);

/**
 * [ISR] Realtime filter for pk_uart (signature of pk_uart_rt_filter):
 * claims '?', '!', '~', 0x18 and Grbl's extended realtime bytes.
 * @return 1 if the byte was claimed (do not buffer it), else 0
 */
int pk_grbl_rt_filter(void *g, uint8_t byte);

/**
 * [MAIN] Do the protocol's work: act on realtime events, hand the pending
 * command to the machine as it has room, read and answer lines, flush output.
 * Bounded work per call; call it from the main loop as often as possible
 * (alongside the machine's own poll).
 */
void pk_grbl_poll(struct pk_grbl *g);

/** [MAIN] 1 when nothing is pending inside the engine (no held line, no
 *  unsent output). */
int pk_grbl_idle(const struct pk_grbl *g);

#endif
