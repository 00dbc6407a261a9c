/*
 * pk_avr_servo8.c — the pen servo on an 8-bit timer's hardware PWM (the Uno's
 * D11 is OC2A, an 8-bit Timer2 output), for boards whose 16-bit timer is the
 * step timer.
 *
 * Fast PWM at clk/256 gives 256 counts of PK_BOARD_SERVO8_US_PER_COUNT
 * (16 us) per period: 4.096 ms, too short a frame for a hobby servo, which
 * wants one pulse every ~20 ms. So the output is connected to the pin for one
 * period in five (a 20.48 ms frame, 48.8 Hz): the pulse edges are made by the
 * hardware (no jitter), and an interrupt at each period's compare match (the
 * end of the pulse, when the pin is low) steps a 5-phase counter:
 *
 *   phase 4 (the period before the pulse): connect the output. The compare
 *           latch is low, so the pin stays low until BOTTOM, where the next
 *           period (phase 0) sets it.
 *   phase 0: the compare match just ended the pulse: disconnect (the pin is
 *           then its PORT bit, low).
 *
 * A new width is written by the overflow interrupt at the start of phase 1
 * (enabled for that one write from phase 0), with the output disconnected,
 * and takes effect at the next pulse: the hardware double-buffers the
 * register anyway, but simavr applies a write at once and would match the
 * new value again in the period it was written in. Width resolution: 16 us
 * (62 steps over 1.0-2.0 ms).
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"

#define SERVO8_PHASES 5u

/* OCR value for a pulse of width_us: high for (OCR + 1) counts. */
static uint8_t ocr_for(uint16_t value_q16)
{
    uint32_t span = PK_BOARD_SERVO_MAX_US - PK_BOARD_SERVO_MIN_US;
    uint32_t us = PK_BOARD_SERVO_MIN_US + ((span * value_q16 + 0x8000u) >> 16);
    uint32_t counts = (us + PK_BOARD_SERVO8_US_PER_COUNT / 2u) / PK_BOARD_SERVO8_US_PER_COUNT;
    return (uint8_t)(counts - 1u);
}

#if PK_BOARD_SERVO_MAX_US / PK_BOARD_SERVO8_US_PER_COUNT > 200u || PK_BOARD_SERVO_MIN_US < 2u * PK_BOARD_SERVO8_US_PER_COUNT
#error "servo range outside what one 8-bit PWM period can hold with the pin low before BOTTOM"
#endif

void pk_avr_servo_init(struct pk_avr *a)
{
    a->servo_phase = 0u;
    a->servo_ocr = ocr_for(0u);
    PK_BOARD_SERVO8_OCR = (uint8_t)a->servo_ocr;
    PK_BOARD_SERVO8_TCCRA = PK_BOARD_SERVO8_WGM;
    PK_BOARD_SERVO8_TIMSK = (uint8_t)_BV(PK_BOARD_SERVO8_OCIE);
    PK_BOARD_SERVO8_TCCRB = PK_BOARD_SERVO8_CS;
}

int pk_avr_servo_write(void *ctx, uint16_t value_q16)
{
    ((struct pk_avr *)ctx)->servo_ocr = ocr_for(value_q16);
    return PK_HAL_OK;
}

ISR(PK_BOARD_SERVO8_OVF_vect)
{
    PK_BOARD_SERVO8_OCR = (uint8_t)pk_avr_board.servo_ocr;
    PK_BOARD_SERVO8_TIMSK = (uint8_t)_BV(PK_BOARD_SERVO8_OCIE);
}

ISR(PK_BOARD_SERVO8_COMP_vect)
{
    uint8_t p = (uint8_t)(pk_avr_board.servo_phase + 1u);
    if (p >= SERVO8_PHASES)
        p = 0u;
    pk_avr_board.servo_phase = p;
    if (p == SERVO8_PHASES - 1u)
        PK_BOARD_SERVO8_TCCRA = (uint8_t)(PK_BOARD_SERVO8_WGM | PK_BOARD_SERVO8_COM);
    else if (p == 0u) {
        PK_BOARD_SERVO8_TCCRA = PK_BOARD_SERVO8_WGM;
        if (PK_BOARD_SERVO8_OCR != (uint8_t)pk_avr_board.servo_ocr)
            PK_BOARD_SERVO8_TIMSK = (uint8_t)(_BV(PK_BOARD_SERVO8_OCIE) | _BV(PK_BOARD_SERVO8_TOIE));
    }
}
