/*
 * pk_avr_servo16.c — the pen servo on a 16-bit timer's hardware PWM (the
 * RAMPS SERVO0 pin D11 is the Mega's OC1A): fast PWM with TOP = ICR, one
 * pulse per PK_BOARD_SERVO16_FRAME_US (20 ms, exactly 50 Hz at clk/8), width
 * in steps of 1 / PK_BOARD_SERVO16_COUNTS_PER_US (0.5 us). No interrupt.
 *
 * The compare register is double-buffered (taken at BOTTOM), so a new width
 * never cuts a pulse; a 16-bit register write goes through the timer's TEMP
 * byte, so it is done with interrupts off (an ISR may also write it).
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
    (void)a;
    PK_BOARD_SERVO16_TCCRB = 0u;
    PK_BOARD_SERVO16_ICR = (uint16_t)(PK_BOARD_SERVO16_FRAME_US * PK_BOARD_SERVO16_COUNTS_PER_US - 1u);
    PK_BOARD_SERVO16_OCR = ocr_for(0u);
    PK_BOARD_SERVO16_TCCRA = PK_BOARD_SERVO16_A;
    PK_BOARD_SERVO16_TCCRB = PK_BOARD_SERVO16_B;
}

int pk_avr_servo_write(void *ctx, uint16_t value_q16)
{
    (void)ctx;
    uint16_t ocr = ocr_for(value_q16);
    uint8_t s = SREG;
    cli();
    PK_BOARD_SERVO16_OCR = ocr;
    SREG = s;
    return PK_HAL_OK;
}
