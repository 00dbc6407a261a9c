/*
 * hal_selftest.c — a test image of an AVR board's backend alone (hal/avr/:
 * pins, step timer, serial line, pen servo), without the motion core, so that
 * a board whose full image does not fit its part yet is still exercised on
 * its real chip (tests/avr/wholechip.py runs it under `plotkin avrsim`).
 *
 * It speaks just enough of Grbl's line protocol for the avrsim sender: a
 * greeting, one "ok" per line once the line's work is done, and a status
 * report for '?' whose MPos is the X steps it emitted at 100 steps/mm:
 *   S<v>   servo value v (0..65535): the HAL's spindle_write, then its
 *          tool_write (pen down at v; up for 0), "ok" three servo frames later
 *   X<n>   n steps on X, positive direction, one every 500 us from the HAL
 *          step timer (10 us pulses), "ok" when the last one is done
 *   other  "ok" at once ($ settings, comments)
 * The test checks the steps, the pulse timing, the servo frames and widths
 * decoded from the pins.
 */
#include <stdint.h>
#include <avr/interrupt.h>
#include "pk_avr.h"
#include "pk_uart.h"

#define PULSE_TICKS 20u    /* 10 us at 2 MHz */
#define PERIOD_TICKS 1000u /* 500 us */

static struct pk_uart uart;
static volatile uint32_t steps_left, steps_done;
static volatile uint8_t high;
static uint32_t t_next;

static uint32_t step_cb(void *arg, uint32_t now)
{
    (void)arg;
    const struct pk_hal *h = &pk_avr_board.hal;
    if (high) {
        pk_hal_step_write(h, 1u, 0u);
        high = 0u;
        if (--steps_left == 0u)
            return PK_HAL_TIMER_STOP;
        t_next += PERIOD_TICKS;
        return (int32_t)(t_next - now) > 0 ? t_next - now : 1u;
    }
    pk_hal_step_write(h, 1u, 1u);
    high = 1u;
    steps_done++;
    return PULSE_TICKS;
}

/* A 32-bit value the step interrupt writes, read whole: with interrupts on,
 * the four byte loads can straddle a decrement (0x100 -> 0xFF reads as 0). */
static uint32_t read_isr_u32(const volatile uint32_t *v)
{
    uint8_t sreg = SREG;
    cli();
    uint32_t x = *v;
    SREG = sreg;
    return x;
}

static void say(const char *s)
{
    while (*s)
        if (pk_uart_write(&uart, (const uint8_t *)s, 1u) == 1)
            s++;
        else
            pk_avr_uart_kick(&pk_avr_board);
    pk_avr_uart_kick(&pk_avr_board);
}

static void say_u32(uint32_t v, uint8_t min_digits)
{
    char b[11];
    uint8_t n = 0;
    do {
        b[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v || n < min_digits);
    char o[12];
    for (uint8_t i = 0; i < n; i++)
        o[i] = b[n - 1u - i];
    o[n] = '\0';
    say(o);
}

static void status(void)
{
    uint32_t s = read_isr_u32(&steps_done); /* 100 steps/mm: 10 um per step */
    say(read_isr_u32(&steps_left) ? "<Run|MPos:" : "<Idle|MPos:");
    say_u32(s / 100u, 1);
    say(".");
    say_u32((s % 100u) * 10u, 3);
    say(",0.000,0.000|FS:0,0>\r\n");
}

static uint32_t parse_u32(const uint8_t *p, uint8_t n)
{
    uint32_t v = 0;
    for (uint8_t i = 0; i < n && p[i] >= '0' && p[i] <= '9'; i++)
        v = v * 10u + (uint32_t)(p[i] - '0');
    return v;
}

int main(void)
{
    cli();
    pk_avr_init(&pk_avr_board);
    const struct pk_hal *h = &pk_avr_board.hal;
    pk_uart_init(&uart, NULL, NULL);
    pk_avr_uart_start(&pk_avr_board, &uart);
    sei();
    (void)pk_hal_enable_write(h, 7u, 7u);
    (void)pk_hal_dir_write(h, 7u, 1u);
    say("Grbl 1.1h [plotkin HAL self-test '$' for help]\r\n");
    uint8_t line[40];
    uint8_t n = 0;
    for (;;) {
        uint8_t c;
        if (pk_uart_read(&uart, &c, 1u) != 1)
            continue;
        if (c == '?') {
            status();
            continue;
        }
        if (c != '\n') {
            if (n < sizeof line)
                line[n++] = c;
            continue;
        }
        if (n > 1 && line[0] == 'S') {
            /* the pen is the servo: down at the spindle value, up for 0 */
            uint16_t v = (uint16_t)parse_u32(line + 1, (uint8_t)(n - 1u));
            (void)pk_hal_spindle_write(h, v);
            (void)pk_hal_tool_write(h, v != 0u);
            uint64_t until = pk_avr_clock_ticks(&pk_avr_board) + 3u * 41000u; /* 3 frames */
            while (pk_avr_clock_ticks(&pk_avr_board) < until)
                ;
        } else if (n > 1 && line[0] == 'X') {
            uint32_t k = parse_u32(line + 1, (uint8_t)(n - 1u));
            if (k > 0u) {
                steps_left = k;
                uint64_t first = pk_avr_clock_ticks(&pk_avr_board) + PERIOD_TICKS;
                t_next = (uint32_t)first;
                (void)pk_avr_timer_start(&pk_avr_board, step_cb, NULL, first);
                while (read_isr_u32(&steps_left))
                    ;
            }
        }
        n = 0;
        say("ok\r\n");
    }
}
