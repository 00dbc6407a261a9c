/*
 * pk_gpiod.h — the Linux GPIO backend of the plotkin HAL (libgpiod).
 *
 * On a Linux board (a Raspberry Pi and the like) the step, direction, enable
 * and pen outputs are GPIO lines of one GPIO chip, reached through libgpiod.
 * This backend opens the chip, requests the lines as outputs under a consumer
 * name (so `gpioinfo` shows who owns them), writes each group of lines (all
 * step lines, all direction lines, ...) in one bulk call, and releases
 * everything on close.
 *
 * Inputs (limit switches, probe, door, hold/resume/reset buttons) are lines
 * of the same chip requested as inputs with both-edge events (or plain
 * inputs, `input_edges 0`), with the configured bias. input_read reads them
 * all in one bulk call; the edges are taken by pk_gpiod_input_service, which
 * the board's loop calls (the POSIX timer loop between step callbacks, the
 * simulator as an interrupt at the edge's tick): it drains the kernel's event
 * queues without blocking and, if there were events, calls the core's edge
 * callback once with the levels read after them. Every libgpiod failure becomes PK_HAL_EIO, and the
 * reason (which call, which lines, errno text) is kept for the firmware to
 * report through pk_hal_error_text().
 *
 * Which lines, which chip and which polarity come from a configuration
 * (struct pk_gpiod_cfg, usually parsed from a small text file by
 * pk_gpiod_cfg_parse), never from code.
 *
 * The backend drives pins only. Timer, clock, critical sections and UART are
 * forwarded to a "base" HAL given at open time: the POSIX timer loop on a real
 * board (hal/posix/), the simulated scheduler in the simulator (host-sim/).
 *
 * Version split: everything that depends on the libgpiod API version lives
 * in one small file behind pk_gpiod_port.h (gpiod_v1.c for libgpiod 1.x, the
 * v1 API Debian 12 and Raspberry Pi OS bookworm ship); a v2 file can sit
 * beside it and the build picks one. In the simulator the very same object
 * code is linked against host-sim/gpiod_mock.c instead of -lgpiod.
 *
 * No heap: struct pk_gpiod is caller-owned storage; several instances may
 * coexist (each its own chip). Not thread-safe; one instance per thread.
 */
#ifndef PLOTKIN_PK_GPIOD_H
#define PLOTKIN_PK_GPIOD_H

#include <stddef.h>
#include <stdint.h>
#include "hal.h"

/** Line groups; each is requested and written as one bulk. */
enum pk_gpiod_group {
    PK_GPIOD_STEP = 0,
    PK_GPIOD_DIR = 1,
    PK_GPIOD_ENABLE = 2,
    PK_GPIOD_PEN = 3,
    PK_GPIOD_GROUPS = 4,
    PK_GPIOD_INPUT = 4   /**< the input lines (requested apart, not an output group) */
};

#define PK_GPIOD_NAME_MAX 64     /**< chip descriptor and consumer, incl. NUL */
#define PK_GPIOD_ERR_MAX 160     /**< error text, incl. NUL */
#define PK_GPIOD_PATH_MAX 96     /**< servo PWM channel directory, incl. NUL */

/**
 * Board wiring. Offsets are line numbers on the chip (on a Raspberry Pi, the
 * BCM GPIO numbers on gpiochip0). Invert masks follow Grbl: bit i set means
 * axis i's line is active-low (step, enable) or inverted (direction).
 */
struct pk_gpiod_cfg {
    char chip[PK_GPIOD_NAME_MAX];     /**< "gpiochip0", "/dev/gpiochip0", "0" or a label */
    char consumer[PK_GPIOD_NAME_MAX]; /**< consumer name shown by gpioinfo; default "plotkin" */
    uint8_t axes;                     /**< axes with step+dir lines, 1..PK_HAL_MAX_AXES */
    uint8_t enables;                  /**< enable lines: 0 none, 1 shared by all axes, or == axes */
    uint8_t has_pen;                  /**< 1: a pen/tool output line is configured */
    uint32_t step[PK_HAL_MAX_AXES];   /**< step line offset per axis */
    uint32_t dir[PK_HAL_MAX_AXES];    /**< direction line offset per axis */
    uint32_t enable[PK_HAL_MAX_AXES]; /**< enable line offsets (enables of them) */
    uint32_t pen;                     /**< pen line offset (if has_pen) */
    uint32_t step_invert;             /**< axis mask: active-low step lines */
    uint32_t dir_invert;              /**< axis mask: inverted direction lines */
    uint32_t enable_invert;           /**< axis mask: active-low enable lines */
    uint32_t pen_invert;              /**< 1: the pen line is active-low */
    uint32_t input[PK_IN_COUNT];      /**< input line offset per enum pk_hal_input */
    uint32_t inputs;                  /**< PK_IN_* bits wired (input[] valid for these) */
    uint32_t input_invert;            /**< PK_IN_* bits whose line is active-low */
    uint8_t input_bias;               /**< enum pk_gpiod_bias (pk_gpiod_port.h): 0 as is */
    uint8_t input_no_edges;           /**< 1: plain inputs, no edge events (the core then
                                           reads them at every step while it watches) */
    char servo_pwm[PK_GPIOD_PATH_MAX];/**< pen servo on this sysfs PWM channel directory
                                           ("": none), e.g. /sys/class/pwm/pwmchip0/pwm0 */
    uint32_t servo_min_us;            /**< pulse at value 0 = pen up (default 1000) */
    uint32_t servo_max_us;            /**< pulse at full scale = pen down (default 2000) */
    uint32_t servo_frame_us;          /**< PWM period (default 20000: 50 Hz) */
};

/**
 * The instance. All members are private; it is in the header only so that the
 * caller can own the storage.
 */
struct pk_gpiod_port {
    void *chip;                                   /**< library chip handle */
    void *line[PK_GPIOD_GROUPS][PK_HAL_MAX_AXES]; /**< library line handles (v1: struct gpiod_line *) */
    uint8_t n[PK_GPIOD_GROUPS];                   /**< lines requested per group; 0 = not requested */
    void *in_line[PK_IN_COUNT];                   /**< input line handles, in request order */
    uint8_t n_in;                                 /**< input lines requested (0: none) */
    uint8_t in_edges;                             /**< 1: requested with edge events */
};

struct pk_gpiod {
    struct pk_gpiod_cfg cfg;
    struct pk_gpiod_port port;
    struct pk_hal base;               /**< timer/clock/irq/uart provider */
    uint32_t level[PK_GPIOD_GROUPS];  /**< raw levels last written successfully, bit per line */
    uint8_t opened;                   /**< 1 between a successful open and close */
    int err_errno;                    /**< errno of the last failure (0: none) */
    uint8_t err_op;                   /**< which operation failed (private enum) */
    uint8_t err_group;                /**< which group it concerned */
    uint32_t failures;                /**< libgpiod calls that failed since open */
    char err[PK_GPIOD_ERR_MAX];       /**< formatted by pk_gpiod_error_text */
    uint8_t in_bit[PK_IN_COUNT];      /**< input request position -> enum pk_hal_input */
    pk_hal_input_cb in_cb;            /**< the core's edge callback, or NULL */
    void *in_arg;
    uint32_t in_events;               /**< edge events taken since open */
    int servo_fd;                     /**< the servo channel's duty_cycle file (-1: none) */
    uint32_t servo_ns;                /**< pulse width last written, ns */
    uint16_t pen_value;               /**< servo pen: last spindle value (0: full scale) */
    uint8_t pen_down;                 /**< servo pen: last tool level */
};

/** Set cfg to "nothing configured": no axes, consumer "plotkin", chip "gpiochip0". */
void pk_gpiod_cfg_init(struct pk_gpiod_cfg *cfg);

/**
 * Parse a board description, one `key value...` per line (`key = value` also
 * accepted; `#` starts a comment). Keys:
 *
 *     chip gpiochip0          # name, /dev path, number or label
 *     consumer plotkin
 *     step 17 27              # one offset per axis, X Y [Z [A]]
 *     dir 22 23               # as many as step
 *     enable 4                # optional: one shared line, or one per axis
 *     pen 18                  # optional pen/tool output
 *     step_invert_mask 0      # Grbl-style axis masks ($2, $3)
 *     dir_invert_mask 0
 *     enable_invert 1         # 1: enable lines are active-low ($4)
 *     pen_invert 0
 *     limit 5 6               # optional limit switch inputs, one per axis X [Y [Z [A]]]
 *     probe 13                # optional inputs: probe, safety door, buttons
 *     door 19
 *     hold 20
 *     resume 21
 *     reset 16
 *     limit_invert_mask 3     # axis mask: active-low limit switches
 *     probe_invert 0          # 1: active-low probe
 *     door_invert 0
 *     button_invert 1         # 1: active-low hold/resume/reset buttons
 *     input_bias pull-up      # pull-up, pull-down, disable or as-is (default)
 *     input_edges 1           # 0: no edge events (polled inputs)
 *     servo_pwm /sys/class/pwm/pwmchip0/pwm0   # optional: the pen is a servo on
 *                             # this kernel PWM channel (exported if needed);
 *                             # M3 S / M5 and pen moves set its pulse width
 *     servo_min_us 1000       # pulse at pen up ($30/S0), at full scale, period
 *     servo_max_us 2000
 *     servo_frame_us 20000
 *
 * Keys not given keep their value in *cfg, so pk_gpiod_cfg_init first.
 * @param cfg   updated in place; on failure its content is unspecified
 * @param text  NUL-terminated text
 * @param err   receives "line N: reason" on failure (may be NULL)
 * @retval PK_HAL_OK      parsed, and the result passes pk_gpiod_cfg_check
 * @retval PK_HAL_EINVAL  syntax error, unknown key, bad number or bad wiring
 * Calling context: [MAIN], before open.
 */
int pk_gpiod_cfg_parse(struct pk_gpiod_cfg *cfg, const char *text, char *err, size_t errlen);

/**
 * Check a configuration: axes 1..PK_HAL_MAX_AXES, enables 0/1/axes, no line
 * used twice, masks within the axes. err as for pk_gpiod_cfg_parse.
 */
int pk_gpiod_cfg_check(const struct pk_gpiod_cfg *cfg, char *err, size_t errlen);

/**
 * Open the chip and request every configured line as an output, at its
 * inactive level (step inactive, direction "positive" logical 0, drivers
 * disabled, pen up). On failure nothing stays requested or open, and
 * pk_gpiod_error_text(g) says why.
 *
 * @param g     caller-owned storage, valid until pk_gpiod_close
 * @param cfg   copied
 * @param base  HAL providing timer, clock, critical sections and UART; its
 *              tick_hz is used; its pin members are never called; copied
 *              (base->ctx must outlive g)
 * @param out   on success: a HAL whose pin members drive the GPIO lines and
 *              whose other members forward to base; polarity masks from cfg
 * @retval PK_HAL_OK      all lines requested
 * @retval PK_HAL_EINVAL  bad configuration or base (text in error_text)
 * @retval PK_HAL_EIO     libgpiod failed (chip missing, line busy, ...)
 * Calling context: [MAIN].
 */
int pk_gpiod_open(struct pk_gpiod *g, const struct pk_gpiod_cfg *cfg,
                  const struct pk_hal *base, struct pk_hal *out);

/**
 * Release every line and close the chip. Lines are first driven to their
 * inactive level (step idle, drivers disabled, pen up) where possible.
 * Idempotent; safe after a failed open. Calling context: [MAIN].
 */
void pk_gpiod_close(struct pk_gpiod *g);

/**
 * Take the pending input edge events (without blocking) and, if there were
 * any, call the registered edge callback once with the levels read after
 * them. The board's edge context: the POSIX loop calls it between step
 * callbacks, the simulator at the tick of an edge; never while a step
 * callback runs. Returns the events taken (0: none), or PK_HAL_EIO (reason in
 * pk_gpiod_error_text): the inputs are then not watched any more, which the
 * caller must treat as an alarm.
 */
int pk_gpiod_input_service(struct pk_gpiod *g);

/**
 * Text describing the last failure ("" if none), e.g.
 * "gpiod: set step lines 17,27 on gpiochip0: Input/output error".
 * The pointer stays valid until the next call on g. Calling context: [MAIN].
 */
const char *pk_gpiod_error_text(struct pk_gpiod *g);

#endif
