/*
 * pk_avr_servo16.c — the pen servo on a 16-bit timer's hardware PWM (the
 * RAMPS SERVO0 pin D11 is the Mega's OC1A): fast PWM with TOP = ICR, one
 * pulse per PK_BOARD_SERVO16_FRAME_US (20 ms, exactly 50 Hz at clk/8), width
 * in steps of 1 / PK_BOARD_SERVO16_COUNTS_PER_US (0.5 us). No interrupt.
 *
 * A new width is written to the compare register by the timer's overflow
 * interrupt, enabled for that one write, right after the counter wrapped:
 * the hardware double-buffers the register anyway, but simavr applies a
 * write at once, and a write in the middle of a period would make it draw a
 * pulse the chip never makes.
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"

/* OCR value for value_q16: high for (OCR + 1) counts. */
static uint16_t ocr_for(uint16_t value_q16)
{
    uint32_t span = PK_BOARD_SERVO_MAX_US - PK_BOARD_SERVO_MIN_US;
    uint32_t us = PK_BOARD_SERVO_MIN_US + ((span * value_q16 + 0x8000u) >> 16);
    return (uint16_t)(us * PK_BOARD_SERVO16_COUNTS_PER_US - 1u);
}

#if PK_BOARD_SERVO_MAX_US >= PK_BOARD_SERVO16_FRAME_US || PK_BOARD_SERVO16_FRAME_US * PK_BOARD_SERVO16_COUNTS_PER_US > 65536u
#error "servo frame or range does not fit the 16-bit timer"
#endif

void pk_avr_servo_init(struct pk_avr *a)
{
    a->servo_ocr = ocr_for(0u);
    PK_BOARD_SERVO16_TCCRB = 0u;
    PK_BOARD_SERVO16_ICR = (uint16_t)(PK_BOARD_SERVO16_FRAME_US * PK_BOARD_SERVO16_COUNTS_PER_US - 1u);
    PK_BOARD_SERVO16_OCR = ocr_for(0u);
    PK_BOARD_SERVO16_TCCRA = PK_BOARD_SERVO16_A;
    PK_BOARD_SERVO16_TCCRB = PK_BOARD_SERVO16_B;
}

int pk_avr_servo_write(void *ctx, uint16_t value_q16)
{
    struct pk_avr *a = ctx;
    uint16_t ocr = ocr_for(value_q16);
    uint8_t s = SREG;
    cli();
    a->servo_ocr = ocr;
    PK_BOARD_SERVO16_TIMSK = (uint8_t)(PK_BOARD_SERVO16_TIMSK | _BV(PK_BOARD_SERVO16_TOIE));
    SREG = s;
    return PK_HAL_OK;
}

ISR(PK_BOARD_SERVO16_OVF_vect)
{
    PK_BOARD_SERVO16_OCR = pk_avr_board.servo_ocr;
    PK_BOARD_SERVO16_TIMSK = (uint8_t)(PK_BOARD_SERVO16_TIMSK & (uint8_t)~_BV(PK_BOARD_SERVO16_TOIE));
}
