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
 */
#ifndef PLOTKIN_HAL_H
#define PLOTKIN_HAL_H

#include <stddef.h>
#include <stdint.h>

#define PK_HAL_VERSION 1u
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
 * Timer callback: called by the backend at (or as soon as possible after) the
 * tick it was armed for, in interrupt context. Returns the absolute tick at
 * which it wants to run next, or 0 to stop the timer.
 */
typedef uint64_t (*pk_hal_timer_cb)(void *arg, uint64_t now_ticks);

struct pk_hal_ops {
    uint32_t version; /**< PK_HAL_VERSION; pk_hal_check() rejects a mismatch */

    /** [ISR] Write raw levels of the step lines: for every bit set in mask, line
     *  (axis) i takes bit i of levels. Several lines in one call where the
     *  hardware allows (one bulk request on libgpiod). */
    int (*step_write)(void *ctx, uint32_t mask, uint32_t levels);
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
     *  writes only). NULL: the board has no such output. */
    int (*spindle_write)(void *ctx, uint16_t value_q16);

    /** [MAIN] Start the step timer: cb(arg, now) is first called at tick
     *  first_tick; then at whatever tick each call returns. */
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
};

/** Validate an instance: version match and the mandatory members present. */
static inline int pk_hal_check(const struct pk_hal *h)
{
    if (h == NULL || h->ops == NULL || h->ops->version != PK_HAL_VERSION || h->tick_hz == 0u)
        return PK_HAL_EINVAL;
    if (h->ops->step_write == NULL || h->ops->dir_write == NULL || h->ops->clock_ticks == NULL)
        return PK_HAL_EINVAL;
    return PK_HAL_OK;
}

/* The one place where polarity is applied: callers pass LOGICAL levels
 * (1 = step pulse active, 1 = positive direction, 1 = driver enabled). */
static inline int pk_hal_step_write(const struct pk_hal *h, uint32_t mask, uint32_t logical)
{
    return h->ops->step_write(h->ctx, mask, (logical ^ h->step_invert) & mask);
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
