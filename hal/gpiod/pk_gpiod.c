/*
 * pk_gpiod.c — the version-neutral half of the libgpiod HAL backend.
 *
 * Implements struct pk_hal_ops for GPIO lines: keeps the raw level of every
 * line last written (a shadow per group) so that a masked write from the core
 * becomes one whole-group bulk write, skips writes that change nothing, turns
 * every port failure into PK_HAL_EIO and remembers why. Timer, clock,
 * critical sections and UART are forwarded to the base HAL. The libgpiod
 * calls themselves are in gpiod_v1.c (see pk_gpiod_port.h).
 */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include "pk_gpiod.h"
#include "pk_gpiod_port.h"
#include "pk_gpiod_servo.h"

enum { OP_NONE = 0, OP_CONFIG, OP_OPEN, OP_REQUEST, OP_SET, OP_GET, OP_EVENTS };
_Static_assert(OP_CONFIG == PK_GPIOD_ERR_TEXT, "the servo's failures report their own text");

static const char *const group_name[PK_GPIOD_GROUPS + 1] = { "step", "dir", "enable", "pen",
                                                             "input" };

static void set_failure(struct pk_gpiod *g, int op, int group, int neg_errno)
{
    g->err_op = (uint8_t)op;
    g->err_group = (uint8_t)group;
    g->err_errno = -neg_errno;
    g->failures++;
}

static uint32_t group_bits(const struct pk_gpiod *g, enum pk_gpiod_group grp)
{
    return ((uint32_t)1 << g->port.n[grp]) - 1u;
}

/* Masked write of a group: merge into the shadow, write the whole group once. */
static int group_write(struct pk_gpiod *g, enum pk_gpiod_group grp, uint32_t mask, uint32_t levels)
{
    int values[PK_HAL_MAX_AXES];
    unsigned n = g->port.n[grp];

    if (!g->opened)
        return PK_HAL_EINVAL;
    /* A step or a direction change on an axis the board wires no line for
     * (the Grbl engine speaks X Y Z; a plotter board wires X Y): refused, so
     * the machine alarms instead of counting moves no motor makes. */
    uint32_t unwired = (grp == PK_GPIOD_STEP || grp == PK_GPIOD_DIR) ? levels & mask & ~group_bits(g, grp)
                                                                     : 0u;
    if (unwired != 0u) {
        unsigned a = 0;
        while (((unwired >> a) & 1u) == 0u)
            a++;
        snprintf(g->err, sizeof g->err,
                 "gpiod: axis %c would move, but the board wires no %s line for it (%u axes)",
                 "XYZABCDEFGHIJKLMNOPQRSTUVW"[a < 26u ? a : 25u], group_name[grp], n);
        set_failure(g, OP_CONFIG, grp, -EINVAL);
        return PK_HAL_EINVAL;
    }
    if (n == 0u)
        return PK_HAL_OK; /* optional group not wired: nothing to drive */
    mask &= group_bits(g, grp);
    uint32_t next = (g->level[grp] & ~mask) | (levels & mask);
    if (next == g->level[grp])
        return PK_HAL_OK;
    for (unsigned i = 0; i < n; i++)
        values[i] = (int)((next >> i) & 1u);
    int rc = pk_gpiod_port_set(&g->port, grp, values);
    if (rc != 0) {
        set_failure(g, OP_SET, grp, rc);
        return PK_HAL_EIO;
    }
    g->level[grp] = next;
    return PK_HAL_OK;
}

static int op_step_write(void *ctx, uint32_t mask, uint32_t levels)
{
    return group_write(ctx, PK_GPIOD_STEP, mask, levels);
}

static int op_dir_write(void *ctx, uint32_t mask, uint32_t levels)
{
    return group_write(ctx, PK_GPIOD_DIR, mask, levels);
}

static int op_enable_write(void *ctx, uint32_t mask, uint32_t levels)
{
    struct pk_gpiod *g = ctx;
    if (g->port.n[PK_GPIOD_ENABLE] == 1u && mask != 0u) {
        /* One line shared by all axes: it follows the lowest axis in mask. */
        unsigned lo = 0;
        while (((mask >> lo) & 1u) == 0u)
            lo++;
        return group_write(g, PK_GPIOD_ENABLE, 1u, (levels >> lo) & 1u);
    }
    return group_write(g, PK_GPIOD_ENABLE, mask, levels);
}

static int op_tool_write(void *ctx, uint32_t level)
{
    struct pk_gpiod *g = ctx;
    if (g->servo_fd >= 0) { /* the pen is the servo, as on the AVR boards */
        g->pen_down = (uint8_t)(level & 1u);
        return pk_gpiod_servo_write(g, g->pen_down ? (g->pen_value ? g->pen_value : 0xFFFFu) : 0u);
    }
    return group_write(g, PK_GPIOD_PEN, 1u, level & 1u);
}

/* The servo pen's down position is the last spindle value (M3 S); one that
 * arrives while the pen is up waits for the next pen-down. */
static int op_spindle_write(void *ctx, uint16_t value_q16)
{
    struct pk_gpiod *g = ctx;
    g->pen_value = value_q16;
    return g->pen_down ? pk_gpiod_servo_write(g, value_q16 ? value_q16 : 0xFFFFu) : PK_HAL_OK;
}

static int op_input_read(void *ctx, uint32_t *raw)
{
    struct pk_gpiod *g = ctx;
    int values[PK_IN_COUNT];
    if (!g->opened || g->port.n_in == 0u)
        return PK_HAL_EINVAL;
    int rc = pk_gpiod_port_get_inputs(&g->port, values);
    if (rc != 0) {
        set_failure(g, OP_GET, PK_GPIOD_INPUT, rc);
        return PK_HAL_EIO;
    }
    uint32_t r = 0;
    for (unsigned i = 0; i < g->port.n_in; i++)
        if (values[i])
            r |= 1u << g->in_bit[i];
    *raw = r;
    return PK_HAL_OK;
}

static int op_input_watch(void *ctx, pk_hal_input_cb cb, void *arg)
{
    struct pk_gpiod *g = ctx;
    if (!g->opened || g->port.n_in == 0u || !g->port.in_edges)
        return PK_HAL_ENOSYS;
    g->in_cb = cb;
    g->in_arg = arg;
    return PK_HAL_OK;
}

int pk_gpiod_input_service(struct pk_gpiod *g)
{
    if (!g->opened || g->port.n_in == 0u || !g->port.in_edges)
        return 0;
    int n = pk_gpiod_port_take_events(&g->port, 64u);
    if (n < 0) {
        set_failure(g, OP_EVENTS, PK_GPIOD_INPUT, n);
        return PK_HAL_EIO;
    }
    if (n == 0)
        return 0;
    g->in_events += (uint32_t)n;
    if (g->in_cb == NULL)
        return n;
    uint32_t raw;
    if (op_input_read(g, &raw) != PK_HAL_OK)
        return PK_HAL_EIO;
    g->in_cb(g->in_arg, raw, g->base.ops->clock_ticks(g->base.ctx));
    return n;
}

static int op_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first_tick)
{
    struct pk_gpiod *g = ctx;
    if (g->base.ops->timer_start == NULL)
        return PK_HAL_ENOSYS;
    return g->base.ops->timer_start(g->base.ctx, cb, arg, first_tick);
}

static int op_timer_stop(void *ctx)
{
    struct pk_gpiod *g = ctx;
    if (g->base.ops->timer_stop == NULL)
        return PK_HAL_ENOSYS;
    return g->base.ops->timer_stop(g->base.ctx);
}

static uint64_t op_clock_ticks(void *ctx)
{
    struct pk_gpiod *g = ctx;
    return g->base.ops->clock_ticks(g->base.ctx);
}

static uint32_t op_irq_save(void *ctx)
{
    struct pk_gpiod *g = ctx;
    return pk_hal_irq_save(&g->base);
}

static void op_irq_restore(void *ctx, uint32_t token)
{
    struct pk_gpiod *g = ctx;
    pk_hal_irq_restore(&g->base, token);
}

static int op_uart_read(void *ctx, uint8_t *buf, size_t len)
{
    struct pk_gpiod *g = ctx;
    if (g->base.ops->uart_read == NULL)
        return PK_HAL_ENOSYS;
    return g->base.ops->uart_read(g->base.ctx, buf, len);
}

static int op_uart_write(void *ctx, const uint8_t *buf, size_t len)
{
    struct pk_gpiod *g = ctx;
    if (g->base.ops->uart_write == NULL)
        return PK_HAL_ENOSYS;
    return g->base.ops->uart_write(g->base.ctx, buf, len);
}

static const char *op_error_text(void *ctx)
{
    return pk_gpiod_error_text(ctx);
}

static const struct pk_hal_ops gpiod_ops = {
    .version = PK_HAL_VERSION,
    .step_write = op_step_write,
    .dir_write = op_dir_write,
    .enable_write = op_enable_write,
    .tool_write = op_tool_write,
    .input_read = op_input_read,
    .input_watch = op_input_watch,
    .timer_start = op_timer_start,
    .timer_stop = op_timer_stop,
    .clock_ticks = op_clock_ticks,
    .irq_save = op_irq_save,
    .irq_restore = op_irq_restore,
    .uart_read = op_uart_read,
    .uart_write = op_uart_write,
    .error_text = op_error_text,
};

/* The same with the pen servo's pulse width (spindle_write: M3 S). */
static const struct pk_hal_ops gpiod_servo_ops = {
    .version = PK_HAL_VERSION,
    .step_write = op_step_write,
    .dir_write = op_dir_write,
    .enable_write = op_enable_write,
    .tool_write = op_tool_write,
    .spindle_write = op_spindle_write,
    .input_read = op_input_read,
    .input_watch = op_input_watch,
    .timer_start = op_timer_start,
    .timer_stop = op_timer_stop,
    .clock_ticks = op_clock_ticks,
    .irq_save = op_irq_save,
    .irq_restore = op_irq_restore,
    .uart_read = op_uart_read,
    .uart_write = op_uart_write,
    .error_text = op_error_text,
};

/* The input lines in request order (input bit order); bits[i]: the input of line i. */
static unsigned input_offsets(const struct pk_gpiod_cfg *c, uint32_t *offs, uint8_t *bits)
{
    unsigned n = 0;
    for (unsigned b = 0; b < PK_IN_COUNT; b++) {
        if ((c->inputs >> b) & 1u) {
            offs[n] = c->input[b];
            if (bits != NULL)
                bits[n] = (uint8_t)b;
            n++;
        }
    }
    return n;
}

/* The lines of a group, in request order (offs: room for PK_IN_COUNT). */
static unsigned group_offsets(const struct pk_gpiod_cfg *c, enum pk_gpiod_group grp, uint32_t *offs)
{
    if ((int)grp == PK_GPIOD_INPUT)
        return input_offsets(c, offs, NULL);
    switch (grp) {
    case PK_GPIOD_STEP:
        memcpy(offs, c->step, sizeof c->step);
        return c->axes;
    case PK_GPIOD_DIR:
        memcpy(offs, c->dir, sizeof c->dir);
        return c->axes;
    case PK_GPIOD_ENABLE:
        memcpy(offs, c->enable, sizeof c->enable);
        return c->enables;
    case PK_GPIOD_PEN:
    default:
        offs[0] = c->pen;
        return c->has_pen ? 1u : 0u;
    }
}

/* Raw level of each group's lines when idle: step inactive, direction
 * logical 0, drivers disabled, pen up. */
static uint32_t idle_levels(const struct pk_gpiod_cfg *c, enum pk_gpiod_group grp)
{
    uint32_t axes = ((uint32_t)1 << c->axes) - 1u;
    switch (grp) {
    case PK_GPIOD_STEP:
        return c->step_invert & axes;
    case PK_GPIOD_DIR:
        return c->dir_invert & axes;
    case PK_GPIOD_ENABLE:
        return c->enables == 1u ? (c->enable_invert & 1u) : (c->enable_invert & axes);
    case PK_GPIOD_PEN:
    default:
        return c->pen_invert & 1u;
    }
}

int pk_gpiod_open(struct pk_gpiod *g, const struct pk_gpiod_cfg *cfg,
                  const struct pk_hal *base, struct pk_hal *out)
{
    memset(g, 0, sizeof *g);
    g->servo_fd = -1;
    g->cfg = *cfg;
    g->cfg.servo_pwm[PK_GPIOD_PATH_MAX - 1] = '\0';
    g->cfg.chip[PK_GPIOD_NAME_MAX - 1] = '\0';
    g->cfg.consumer[PK_GPIOD_NAME_MAX - 1] = '\0';
    if (pk_gpiod_cfg_check(&g->cfg, g->err, sizeof g->err) != PK_HAL_OK) {
        set_failure(g, OP_CONFIG, 0, -EINVAL);
        return PK_HAL_EINVAL;
    }
    if (base == NULL || base->ops == NULL || base->ops->clock_ticks == NULL || base->tick_hz == 0u) {
        snprintf(g->err, sizeof g->err, "gpiod: no timer/clock backend given");
        set_failure(g, OP_CONFIG, 0, -EINVAL);
        return PK_HAL_EINVAL;
    }
    g->base = *base;

    int rc = pk_gpiod_port_open(&g->port, g->cfg.chip);
    if (rc != 0) {
        set_failure(g, OP_OPEN, 0, rc);
        return PK_HAL_EIO;
    }
    for (int grp = 0; grp < PK_GPIOD_GROUPS; grp++) {
        uint32_t offs[PK_IN_COUNT];
        int init[PK_HAL_MAX_AXES];
        unsigned n = group_offsets(&g->cfg, (enum pk_gpiod_group)grp, offs);
        if (n == 0u)
            continue;
        uint32_t idle = idle_levels(&g->cfg, (enum pk_gpiod_group)grp);
        for (unsigned i = 0; i < n; i++)
            init[i] = (int)((idle >> i) & 1u);
        const char *consumer = g->cfg.consumer[0] ? g->cfg.consumer : "plotkin";
        rc = pk_gpiod_port_request(&g->port, (enum pk_gpiod_group)grp, offs, n, consumer, init);
        if (rc != 0) {
            set_failure(g, OP_REQUEST, grp, rc);
            pk_gpiod_port_close(&g->port);
            return PK_HAL_EIO;
        }
        g->level[grp] = idle;
    }
    if (g->cfg.inputs != 0u) {
        uint32_t offs[PK_IN_COUNT];
        unsigned n = input_offsets(&g->cfg, offs, g->in_bit);
        const char *consumer = g->cfg.consumer[0] ? g->cfg.consumer : "plotkin";
        rc = pk_gpiod_port_request_inputs(&g->port, offs, n, consumer, g->cfg.input_bias,
                                          !g->cfg.input_no_edges);
        if (rc != 0) {
            set_failure(g, OP_REQUEST, PK_GPIOD_INPUT, rc);
            pk_gpiod_port_close(&g->port);
            return PK_HAL_EIO;
        }
    }
    if (g->cfg.servo_pwm[0] != '\0' && pk_gpiod_servo_open(g) != PK_HAL_OK) {
        pk_gpiod_port_close(&g->port);
        return PK_HAL_EIO;
    }
    g->opened = 1;

    uint32_t axes = ((uint32_t)1 << g->cfg.axes) - 1u;
    out->ops = g->servo_fd >= 0 ? &gpiod_servo_ops : &gpiod_ops;
    out->ctx = g;
    out->tick_hz = base->tick_hz;
    out->step_invert = g->cfg.step_invert & axes;
    out->dir_invert = g->cfg.dir_invert & axes;
    /* A shared enable line follows the lowest axis of a write: invert all. */
    out->enable_invert = g->cfg.enables == 1u ? ((g->cfg.enable_invert & 1u) ? axes : 0u)
                                              : (g->cfg.enable_invert & axes);
    out->tool_invert = g->cfg.pen_invert & 1u;
    out->inputs = g->cfg.inputs;
    out->input_invert = g->cfg.input_invert & g->cfg.inputs;
    return PK_HAL_OK;
}

void pk_gpiod_close(struct pk_gpiod *g)
{
    if (g->opened) {
        for (int grp = 0; grp < PK_GPIOD_GROUPS; grp++) {
            uint32_t all = group_bits(g, (enum pk_gpiod_group)grp);
            uint32_t idle = idle_levels(&g->cfg, (enum pk_gpiod_group)grp);
            /* Best effort: a failure here is recorded but changes nothing. */
            (void)group_write(g, (enum pk_gpiod_group)grp, all, idle);
        }
    }
    if (g->opened)
        pk_gpiod_servo_close(g);
    pk_gpiod_port_close(&g->port);
    g->opened = 0;
}

const char *pk_gpiod_error_text(struct pk_gpiod *g)
{
    char lines[64];
    size_t k = 0;

    if (g->err_op == OP_NONE)
        return "";
    if (g->err_op == OP_CONFIG)
        return g->err;
    lines[0] = '\0';
    if (g->err_op != OP_OPEN) {
        uint32_t offs[PK_IN_COUNT];
        unsigned n = group_offsets(&g->cfg, (enum pk_gpiod_group)g->err_group, offs);
        for (unsigned i = 0; i < n && k < sizeof lines; i++) {
            int w = snprintf(lines + k, sizeof lines - k, "%s%u", i ? "," : " ", (unsigned)offs[i]);
            if (w < 0)
                break;
            k += (size_t)w;
        }
    }
    if (g->err_op == OP_OPEN) {
        snprintf(g->err, sizeof g->err, "gpiod: open chip %s: %s", g->cfg.chip,
                 strerror(g->err_errno));
    } else {
        static const char *const op_name[] = { "", "", "", "request", "set", "read",
                                               "take events of" };
        snprintf(g->err, sizeof g->err, "gpiod: %s %s lines%s on %s: %s",
                 op_name[g->err_op], group_name[g->err_group],
                 lines, g->cfg.chip, strerror(g->err_errno));
    }
    return g->err;
}
