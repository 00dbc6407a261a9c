/*
 * pk_avr_hal.c — the ops table of the AVR backend: pin writes through the
 * board's inline functions, critical sections on SREG, the pen as a servo
 * (see pk_avr.h).
 *
 * Polarity: the CNC shield and RAMPS drivers (A4988/DRV8825) step on a rising
 * edge, take direction as wired, and are enabled by a low ENABLE line; the
 * pen tool output is the servo (tool level 1 = pen down = the far end of the
 * servo range). Inputs (pk_avr_inputs.c) where board.h defines PK_BOARD_INPUTS;
 * the settings store is the EEPROM (pk_avr_nvm.c). The UART is not in the table: the controller (hal/pk_app.h)
 * reads and writes the rings of pk_uart.h directly.
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"

struct pk_avr pk_avr_board;

static int avr_step_write(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    pk_board_step_write((uint8_t)mask, (uint8_t)levels);
    return PK_HAL_OK;
}

static int avr_dir_write(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    pk_board_dir_write((uint8_t)mask, (uint8_t)levels);
    return PK_HAL_OK;
}

static int avr_enable_write(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    uint8_t s = SREG;
    cli();
    pk_board_enable_write((uint8_t)mask, (uint8_t)levels);
    SREG = s;
    return PK_HAL_OK;
}

/* The pen is the servo: up is the start of its range; down is the last
 * spindle value (M3 S, within $30), or the far end while that is 0. A spindle
 * value that arrives while the pen is up waits for the next pen-down. */
static uint16_t pen_down_value(const struct pk_avr *a) { return a->pen_value ? a->pen_value : 0xFFFFu; }

static int avr_tool_write(void *ctx, uint32_t level)
{
    struct pk_avr *a = ctx;
    a->pen_down = (uint8_t)(level & 1u);
    return pk_avr_servo_write(a, a->pen_down ? pen_down_value(a) : 0u);
}

static int avr_spindle_write(void *ctx, uint16_t value_q16)
{
    struct pk_avr *a = ctx;
    a->pen_value = value_q16;
    return a->pen_down ? pk_avr_servo_write(a, pen_down_value(a)) : PK_HAL_OK;
}

static uint32_t avr_irq_save(void *ctx)
{
    (void)ctx;
    uint8_t s = SREG;
    cli();
    return s;
}

static void avr_irq_restore(void *ctx, uint32_t token)
{
    (void)ctx;
    SREG = (uint8_t)token;
}

static const struct pk_hal_ops avr_ops = {
    .version = PK_HAL_VERSION,
    .step_write = avr_step_write,
    .step_pulse = pk_avr_step_pulse,
    .dir_write = avr_dir_write,
    .enable_write = avr_enable_write,
    .tool_write = avr_tool_write,
    .spindle_write = avr_spindle_write,
    .timer_start = pk_avr_timer_start,
    .timer_stop = pk_avr_timer_stop,
    .clock_ticks = pk_avr_clock_ticks,
    .irq_save = avr_irq_save,
    .irq_restore = avr_irq_restore,
#ifdef PK_BOARD_INPUTS
    .input_read = pk_avr_input_read,
    .input_watch = pk_avr_input_watch,
#endif
    .nvm_size = pk_avr_nvm_size,
    .nvm_read = pk_avr_nvm_read,
    .nvm_write = pk_avr_nvm_write,
};

void pk_avr_init(struct pk_avr *a)
{
    a->hal.ops = &avr_ops;
    a->hal.ctx = a;
    a->hal.tick_hz = PK_BOARD_TICK_HZ;
    a->hal.step_invert = 0u;
    a->hal.dir_invert = 0u;
    a->hal.enable_invert = (1u << PK_BOARD_AXES_WIRED) - 1u;
    a->hal.tool_invert = 0u;
#ifdef PK_BOARD_INPUTS
    a->hal.inputs = PK_BOARD_INPUTS;
    a->hal.input_invert = PK_BOARD_INPUT_INVERT;
#endif
    pk_board_pins_init();
    pk_avr_timer_init(a);
    pk_avr_servo_init(a);
    pk_avr_uart_init(a);
}
