/*
 * avr_step_cycles.c — cycles of the step timer callback per motor step on an
 * AVR at 16 MHz, measured cycle-exactly under simavr by bench/avr_cycles.
 *
 * A whole pk_machine (2 axes, small queues, smoothing off so that only the
 * step path runs) drives three feed moves through a HAL whose pin writes go
 * to PORTB/PORTC (one `out` each, as on a real board) and whose timer is
 * simulated here: the callback runs at each tick it asks for, the main-loop
 * work (pk_machine_poll) runs between callbacks and is not counted. Reported:
 * callback cycles per step (both edges, direction changes and chunk
 * switches included), and the worst single callback.
 *
 * Built for the ATmega1284P, not the 328P: the machine with the kernel's
 * constant tables does not fit 2 KB of RAM (see `make targets`, AVR .data).
 * The two parts share the AVR core and its instruction timings (16-bit
 * program counter, same call/ret cost), so the cycle counts carry over.
 */
#include <stdint.h>
#include <string.h>
#include <avr/interrupt.h>
#include <avr/sleep.h>
#include "avr_mcu_section.h"
#include "avr_mark.h"
#include "pk_motion.h"

AVR_MCU(F_CPU, "atmega1284p");

struct fake_hal { uint64_t now, next; uint8_t armed; };

static int f_step(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    PORTB = (uint8_t)((PORTB & (uint8_t)~mask) | (uint8_t)(levels & mask));
    return 0;
}
static int f_dir(void *ctx, uint32_t mask, uint32_t levels)
{
    (void)ctx;
    PORTC = (uint8_t)((PORTC & (uint8_t)~mask) | (uint8_t)(levels & mask));
    return 0;
}
static int f_tool(void *ctx, uint32_t level) { (void)ctx; PORTD = (uint8_t)level; return 0; }
static int f_timer_start(void *ctx, pk_hal_timer_cb cb, void *arg, uint64_t first)
{
    struct fake_hal *f = ctx;
    (void)cb;
    (void)arg;
    f->next = first;
    f->armed = 1;
    return 0;
}
static int f_timer_stop(void *ctx) { ((struct fake_hal *)ctx)->armed = 0; return 0; }
static uint64_t f_clock(void *ctx) { return ((struct fake_hal *)ctx)->now; }
static uint32_t f_irq_save(void *ctx) { (void)ctx; return 0; }
static void f_irq_restore(void *ctx, uint32_t t) { (void)ctx; (void)t; }

static const struct pk_hal_ops f_ops = {
    .version = PK_HAL_VERSION, .step_write = f_step, .dir_write = f_dir, .tool_write = f_tool,
    .timer_start = f_timer_start, .timer_stop = f_timer_stop, .clock_ticks = f_clock,
    .irq_save = f_irq_save, .irq_restore = f_irq_restore,
};

static struct pk_machine machine;
static struct fake_hal fake;

/* Three feed moves from the origin, µm (every axis moves, Y turns back). */
static const pk_um_t pts[3][PK_AXES] = { { 20000, 10000 }, { 30000, 30000 }, { 10000, 35000 } };
#define STEPS_PER_MM 80u

int main(void)
{
    DDRB = 0xFF;
    DDRC = 0xFF;
    struct pk_hal hal = { .ops = &f_ops, .ctx = &fake, .tick_hz = 2000000u };
    struct pk_motion_cfg cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.axes = 2;
    for (uint8_t a = 0; a < PK_AXES; a++) {
        cfg.steps_per_mm_q16[a] = (pk_spmm_q16_t)STEPS_PER_MM << 16;
        cfg.max_rate[a] = 5000000u; /* 5000 mm/min */
        cfg.accel[a] = 2000000u;    /* 2000 mm/s^2 */
    }
    cfg.junction_dev_um = 10;
    cfg.step_pulse_ticks = 4;
    cfg.dir_setup_ticks = 2;
    cfg.smooth.mode = PK_SMOOTH_OFF;
    uint32_t path_steps = 0;
    int32_t prev[PK_AXES] = { 0 };
    for (uint8_t i = 0; i < 3; i++)
        for (uint8_t a = 0; a < PK_AXES; a++) {
            int32_t d = pts[i][a] - prev[a];
            path_steps += (uint32_t)(d < 0 ? -d : d) / 1000u * STEPS_PER_MM;
            prev[a] = pts[i][a];
        }
    if (pk_machine_init(&machine, &cfg, &hal) == PK_MOTION_OK) {
        for (uint8_t i = 0; i < 3; i++)
            (void)pk_machine_move(&machine, pts[i], 3000000u, PK_MOVE_FEED);
        (void)pk_machine_end(&machine);
        avr_mark_label("step callback");
        for (uint32_t guard = 0; guard < 400000u; guard++) {
            pk_machine_poll(&machine); /* MAIN work: not counted */
            if (!fake.armed) {
                if (pk_machine_state(&machine) == PK_STATE_IDLE)
                    break;
                fake.now += 100;
                continue;
            }
            fake.now = fake.next;
            avr_mark_start();
            uint64_t next = pk_machine_timer_cb(&machine, fake.now);
            avr_mark_stop();
            if (next == 0)
                fake.armed = 0;
            else
                fake.next = next;
        }
    }
    avr_mark_report(path_steps);
    pk_steps_t pos[PK_AXES];
    pk_machine_position_steps(&machine, pos);
    avr_mark_label("= final X, steps");
    avr_mark_report((uint32_t)pos[0]);
    avr_mark_label("= final Y, steps");
    avr_mark_report((uint32_t)pos[1]);
    avr_mark_label("= machine state (0 idle, 4 alarm)");
    avr_mark_report((uint32_t)pk_machine_state(&machine));
    cli();
    sleep_mode();
    return 0;
}
