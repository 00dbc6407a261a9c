/*
 * hal.h — the hardware boundary of plotkin.
 *
 * The portable core (firmware/) reaches pins, timers and the UART only through
 * this interface: a const ops table plus a context pointer per instance, so one
 * process can hold several machines (the simulator does). Backends fill in the
 * ops: hal/gpiod/ (Linux boards through libgpiod), bare-metal boards, and the
 * simulator's recording doubles in host-sim/.
 *
 * Levels: backends write RAW pin levels. The core applies pin polarity in one
 * place (pk_hal_step_write and friends below, using the invert masks), so a
 * backend never needs to know which lines are active-low.
 *
 * Calling context is stated per member: [ISR] may be called from the step
 * timer callback (must not block, must be bounded); [MAIN] only from the main
 * loop. Optional members may be NULL; the inline wrappers then return
 * PK_HAL_ENOSYS.
 *
 * Inputs (limit switches, probe, door and the three buttons) are read the
 * same way: the backend reports RAW levels, one bit per enum pk_hal_input,
 * and pk_hal_input_read() / pk_hal_input_logical() turn them into logical
 * levels (1 = switch pressed, probe touching, door open, button pressed)
 * with struct pk_hal.input_invert, masked to the lines the board has
 * (struct pk_hal.inputs). See "What an input backend must do" below.
 */
#ifndef PLOTKIN_HAL_H
#define PLOTKIN_HAL_H

#include <stddef.h>
#include <stdint.h>

#define PK_HAL_VERSION 3u /**< 2: input_read, input_watch, inputs, input_invert;
                                3: 32-bit timer callback (delay), step_pulse */
#define PK_HAL_MAX_AXES 4

/** HAL status codes: 0 on success, negative errno-style values on failure. */
enum pk_hal_status {
    PK_HAL_OK = 0,
    PK_HAL_EIO = -5,      /**< the hardware (or libgpiod) reported a failure */
    PK_HAL_EAGAIN = -11,  /**< would block (UART full/empty) */
    PK_HAL_EINVAL = -22,  /**< bad argument */
    PK_HAL_ENOSYS = -38   /**< member not provided by this backend */
};

/**
 * Input lines: bit numbers of the input masks (struct pk_hal.inputs,
 * input_invert, the levels of input_read and of the edge callback).
 * Grbl's wiring: one limit switch per axis (at either end of its travel, or
 * two in series), a probe, a safety door and the feed-hold, cycle-start and
 * reset buttons.
 */
enum pk_hal_input {
    PK_IN_LIMIT_X = 0, /**< limit switch of axis 0; axis i uses bit i */
    PK_IN_LIMIT_Y = 1,
    PK_IN_LIMIT_Z = 2,
    PK_IN_LIMIT_A = 3,
    PK_IN_PROBE = 4,   /**< probe (touch plate, tool setter) */
    PK_IN_DOOR = 5,    /**< safety door: active = open */
    PK_IN_HOLD = 6,    /**< feed-hold button (Grbl '!') */
    PK_IN_RESUME = 7,  /**< cycle-start / resume button (Grbl '~') */
    PK_IN_RESET = 8,   /**< reset / abort button (Grbl ctrl-X) */
    PK_IN_COUNT = 9
};
_Static_assert(PK_IN_LIMIT_A == PK_HAL_MAX_AXES - 1, "one limit input per HAL axis");
/** Mask of the limit inputs of axes 0..PK_HAL_MAX_AXES-1. */
#define PK_IN_LIMITS ((1u << PK_HAL_MAX_AXES) - 1u)
/** Mask of every input bit. */
#define PK_IN_ALL ((1u << PK_IN_COUNT) - 1u)

/**
 * Input edge callback, registered by the core with input_watch. raw_levels:
 * the raw levels of every input line after the change (bits as in enum
 * pk_hal_input); tick: when the change happened, as well as the backend knows
 * (clock_ticks units). Runs in the backend's edge context (see below); must
 * not block; bounded.
 */
typedef void (*pk_hal_input_cb)(void *arg, uint32_t raw_levels, uint64_t tick);

/** What a timer callback returns to stop the timer (no delay is this long). */
#define PK_HAL_TIMER_STOP 0xFFFFFFFFu

/**
 * Timer callback: called by the backend in interrupt context at (or as soon
 * as possible after) the tick it asked for; never re-entered.
 *
 * now_ticks: the low 32 bits of the clock (clock_ticks) at this call -- the
 * tick it runs at, or the tick it was due at (a backend that runs callbacks
 * behind the clock may pass that instead; never a tick
 * before it was due).
 * Returns the delay in ticks from now_ticks to the next call: the backend
 * runs it at now_ticks + delay (0: at once, as soon as it can), or
 * PK_HAL_TIMER_STOP to stop the timer. The schedule stays absolute because
 * the callback computes the delay from the now_ticks it was given, so a late
 * call does not move the ones after it.
 *
 * 32 bits, wrapping (71 minutes at 1 MHz, 4 minutes at the 2^24 Hz that
 * pk_machine_init allows): a small target keeps the step time in single
 * words, with no 64-bit arithmetic in the interrupt. The callback keeps
 * every time it compares within 2^31 ticks of now_ticks; a delay may be
 * anything up to 2^32 - 2.
 */
typedef uint32_t (*pk_hal_timer_cb)(void *arg, uint32_t now_ticks);

struct pk_hal_ops {
    uint32_t version; /**< PK_HAL_VERSION; pk_hal_check() rejects a mismatch */

    /** [ISR] Write raw levels of the step lines: for every bit set in mask, line
     *  (axis) i takes bit i of levels. Several lines in one call where the
     *  hardware allows (one bulk request on libgpiod). */
    int (*step_write)(void *ctx, uint32_t mask, uint32_t levels);
    /** [ISR] Optional: one step pulse. Write the raw levels `levels` to the
     *  step lines of mask (their active level) now, and their complement (the
     *  idle level) at least width_ticks later, by itself (hardware, or an
     *  interrupt of its own), so the core needs no timer callback to end it.
     *  Contract: before the backend runs a timer callback due at or after
     *  the pulse's end (now_ticks of the call that raised it + width_ticks),
     *  the pulse has ended; the core calls step_pulse or step_write again only
     *  after the pulse has ended (it keeps the line low at least width_ticks
     *  too). Bounded (register writes). NULL: the core ends each pulse itself
     *  with step_write from a second timer callback. */
    int (*step_pulse)(void *ctx, uint32_t mask, uint32_t levels, uint32_t width_ticks);
    /** [ISR] Same for the direction lines. */
    int (*dir_write)(void *ctx, uint32_t mask, uint32_t levels);
    /** [MAIN] Same for the driver-enable lines. */
    int (*enable_write)(void *ctx, uint32_t mask, uint32_t levels);
    /** [ISR] Pen / tool output (raw level). */
    int (*tool_write)(void *ctx, uint32_t level);
    /** [ISR] Optional: spindle / laser PWM / pen-servo output. value is the
     *  fraction of full scale in Q0.16 (0 = off, or the servo's "up" end,
     *  65535 = full scale); the board maps it to a PWM duty cycle or to a servo
     *  pulse width between its configured limits. Must be bounded (register
     *  writes only). NULL: the board has no such output. A board whose pen IS
     *  the servo (the AVR boards, a gpiod `servo_pwm`) puts it, on tool level
     *  1, at the last value written here (M3 S; full scale while that is 0)
     *  and on level 0 at the up end; a value written while the pen is up
     *  waits for the next pen-down. */
    int (*spindle_write)(void *ctx, uint16_t value_q16);

    /** [ISR][MAIN] Optional: read the raw levels of every input line into
     *  *raw_levels (bit per enum pk_hal_input; lines the board does not have
     *  read 0). Bounded: port register reads on a microcontroller, one ioctl
     *  per line on Linux. PK_HAL_OK or PK_HAL_EIO (*raw_levels unspecified).
     *  NULL: the board has no inputs (struct pk_hal.inputs must be 0). */
    int (*input_read)(void *ctx, uint32_t *raw_levels);
    /** [MAIN] Optional: report input edges. From the return on, the backend
     *  calls cb(arg, raw_levels, tick) from its edge context after every
     *  change of one or more input lines; cb NULL stops the reports (none
     *  runs after the call returns). One callback at a time: a new one
     *  replaces the old. NULL member: the board cannot report edges; the
     *  core then reads the inputs with input_read at every step while it
     *  watches them (limits, probe, homing), and once per main-loop pass for
     *  the buttons. PK_HAL_OK, or PK_HAL_EIO if the edge source failed. */
    int (*input_watch)(void *ctx, pk_hal_input_cb cb, void *arg);

    /** [MAIN] Start the step timer: cb(arg, now) is first called at tick
     *  first_tick (clock_ticks units; at once if that has passed), then
     *  after the delay each call returns (see pk_hal_timer_cb). */
    int (*timer_start)(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick);
    /** [ISR][MAIN] Stop the step timer; no callback runs after it returns. */
    int (*timer_stop)(void *ctx);
    /** [ISR][MAIN] Monotonic time in timer ticks (see struct pk_hal.tick_hz). */
    uint64_t (*clock_ticks)(void *ctx);

    /** [MAIN] Enter/leave a critical section against the timer callback.
     *  enter returns a token to give back to leave (nesting is allowed). */
    uint32_t (*irq_save)(void *ctx);
    void (*irq_restore)(void *ctx, uint32_t token);

    /** [MAIN] UART: non-blocking. read returns bytes read (0 if none) or an
     *  error; write returns bytes accepted (may be fewer than len). */
    int (*uart_read)(void *ctx, uint8_t *buf, size_t len);
    int (*uart_write)(void *ctx, const uint8_t *buf, size_t len);

    /** [MAIN] Optional: text describing the backend's last failure (the one
     *  that made a member return PK_HAL_EIO), "" if none. Valid until the
     *  next call on the instance. For alarms and `[MSG:...]` reports. */
    const char *(*error_text)(void *ctx);

    /** [MAIN] Optional non-volatile store (EEPROM on a board, a file on a
     *  host) for settings and offsets that must survive a restart.
     *  nvm_size: bytes available. nvm_read/nvm_write: len bytes at offset
     *  (offset + len <= nvm_size), blocking until done; PK_HAL_OK, or
     *  PK_HAL_EINVAL (out of range) / PK_HAL_EIO. Written only while the
     *  machine is idle (the Grbl engine syncs first, as Grbl does). */
    uint32_t (*nvm_size)(void *ctx);
    int (*nvm_read)(void *ctx, uint32_t offset, uint8_t *buf, size_t len);
    int (*nvm_write)(void *ctx, uint32_t offset, const uint8_t *buf, size_t len);
};

/** One HAL instance: ops + context + the board's static facts. */
struct pk_hal {
    const struct pk_hal_ops *ops;
    void *ctx;
    uint32_t tick_hz;          /**< timer/clock frequency, e.g. 1000000 */
    uint32_t step_invert;      /**< axis bits whose step line is active-low */
    uint32_t dir_invert;       /**< axis bits whose direction line is inverted */
    uint32_t enable_invert;    /**< axis bits whose enable line is active-low */
    uint32_t tool_invert;      /**< 1 if the tool output is active-low */
    uint32_t inputs;           /**< PK_IN_* bits of the input lines the board has
                                    (0: none; then input_read may be NULL) */
    uint32_t input_invert;     /**< PK_IN_* bits whose line is active-low (a switch
                                    to ground on a pull-up, a normally-closed switch) */
};

/*
 * What an input backend must do (libgpiod: hal/gpiod/; AVR: pin-change
 * interrupts, hal/avr/):
 *  - Fill struct pk_hal.inputs with the bits of the lines it has and
 *    input_invert with their polarity (pull-ups and switches to ground:
 *    active-low). Never report a line it does not have.
 *  - input_read returns the raw levels of all its input lines at once, and
 *    is safe to call from the step timer callback (a few register reads; it
 *    may not block or wait for a debounce).
 *  - If it can, input_watch: enable the edge sources (AVR: PCMSKn bits of
 *    the input pins and PCICR; Linux: both-edge events) and, on every change,
 *    call the callback with the levels read AFTER the change (read the port
 *    in the pin-change ISR; several lines changing at once give one call; a
 *    change that comes back before the ISR runs may give a call with
 *    unchanged levels, which is harmless).
 *  - Edge context vs the step timer: the callback and the step timer
 *    callback never run at the same time (two interrupts of one priority
 *    level that do not nest, as on an AVR where the ISRs run with interrupts
 *    off; or one thread), and irq_save() also holds the callback off. The
 *    core relies on this: the callback reads the step position the timer
 *    callback writes.
 *  - Latency: the sooner the callback runs after the edge, the sooner the
 *    core acts on it; its effect on the step output is at the next step
 *    event. A backend without edges loses nothing but costs an input_read
 *    per step while the core watches.
 *  - No debouncing in the backend: the core acts on the first edge (a hard
 *    limit, a probe contact); Grbl's $26 is a delay the homing cycle waits
 *    after each of its moves, not a filter.
 */

/** Validate an instance: version match and the mandatory members present. */
static inline int pk_hal_check(const struct pk_hal *h)
{
    if (h == NULL || h->ops == NULL || h->ops->version != PK_HAL_VERSION || h->tick_hz == 0u)
        return PK_HAL_EINVAL;
    if (h->ops->step_write == NULL || h->ops->dir_write == NULL || h->ops->clock_ticks == NULL)
        return PK_HAL_EINVAL;
    if ((h->inputs & ~PK_IN_ALL) != 0u || (h->inputs != 0u && h->ops->input_read == NULL))
        return PK_HAL_EINVAL;
    return PK_HAL_OK;
}

/* The one place where polarity is applied: callers pass LOGICAL levels
 * (1 = step pulse active, 1 = positive direction, 1 = driver enabled). */
static inline int pk_hal_step_write(const struct pk_hal *h, uint32_t mask, uint32_t logical)
{
    return h->ops->step_write(h->ctx, mask, (logical ^ h->step_invert) & mask);
}
/** A step pulse on the axes of mask (logical: active), ended by the backend
 *  after width_ticks; PK_HAL_ENOSYS if it cannot (use step_write). [ISR] */
static inline int pk_hal_step_pulse(const struct pk_hal *h, uint32_t mask, uint32_t width_ticks)
{
    if (h->ops->step_pulse == NULL)
        return PK_HAL_ENOSYS;
    return h->ops->step_pulse(h->ctx, mask, (mask ^ h->step_invert) & mask, width_ticks);
}
static inline int pk_hal_dir_write(const struct pk_hal *h, uint32_t mask, uint32_t logical)
{
    return h->ops->dir_write(h->ctx, mask, (logical ^ h->dir_invert) & mask);
}
static inline int pk_hal_enable_write(const struct pk_hal *h, uint32_t mask, uint32_t logical)
{
    if (h->ops->enable_write == NULL)
        return PK_HAL_ENOSYS;
    return h->ops->enable_write(h->ctx, mask, (logical ^ h->enable_invert) & mask);
}
static inline int pk_hal_tool_write(const struct pk_hal *h, uint32_t logical)
{
    if (h->ops->tool_write == NULL)
        return PK_HAL_ENOSYS;
    return h->ops->tool_write(h->ctx, (logical ^ h->tool_invert) & 1u);
}
static inline int pk_hal_spindle_write(const struct pk_hal *h, uint16_t value_q16)
{
    if (h->ops->spindle_write == NULL)
        return PK_HAL_ENOSYS;
    return h->ops->spindle_write(h->ctx, value_q16);
}
/** Logical levels (1 = active) of raw input levels: polarity applied, masked
 *  to the lines the board has. */
static inline uint32_t pk_hal_input_logical(const struct pk_hal *h, uint32_t raw)
{
    return (raw ^ h->input_invert) & h->inputs;
}
/** Read every input line as logical levels. PK_HAL_ENOSYS if the board has
 *  none; *logical is 0 on any failure. [ISR][MAIN] */
static inline int pk_hal_input_read(const struct pk_hal *h, uint32_t *logical)
{
    uint32_t raw = 0;
    *logical = 0;
    if (h->ops->input_read == NULL || h->inputs == 0u)
        return PK_HAL_ENOSYS;
    int r = h->ops->input_read(h->ctx, &raw);
    if (r != 0)
        return r;
    *logical = pk_hal_input_logical(h, raw);
    return PK_HAL_OK;
}
/** Register (cb != NULL) or remove the edge callback; PK_HAL_ENOSYS if the
 *  board cannot report edges. [MAIN] */
static inline int pk_hal_input_watch(const struct pk_hal *h, pk_hal_input_cb cb, void *arg)
{
    if (h->ops->input_watch == NULL || h->inputs == 0u)
        return PK_HAL_ENOSYS;
    return h->ops->input_watch(h->ctx, cb, arg);
}
static inline uint32_t pk_hal_irq_save(const struct pk_hal *h)
{
    return h->ops->irq_save ? h->ops->irq_save(h->ctx) : 0u;
}
/** Bytes of non-volatile store the backend has (0: none). */
static inline uint32_t pk_hal_nvm_size(const struct pk_hal *h)
{
    return h->ops->nvm_size && h->ops->nvm_read && h->ops->nvm_write ? h->ops->nvm_size(h->ctx) : 0u;
}
/** The backend's last failure as text; "" if none or not provided. */
static inline const char *pk_hal_error_text(const struct pk_hal *h)
{
    const char *s = h->ops->error_text ? h->ops->error_text(h->ctx) : NULL;
    return s ? s : "";
}
static inline void pk_hal_irq_restore(const struct pk_hal *h, uint32_t token)
{
    if (h->ops->irq_restore)
        h->ops->irq_restore(h->ctx, token);
}

#endif
