/*
 * board.h — Arduino Uno (ATmega328P, 16 MHz) with a CNC shield V3, wired as
 * Grbl 1.1 wires it (its cpu_map for the 328P with VARIABLE_SPINDLE, the
 * default). This file is the only place of the image that names pins, timers
 * and interrupt vectors; the shared AVR code in hal/avr/ uses the names below.
 *
 *   signal            Uno pin   port   notes
 *   X / Y / Z step    D2 D3 D4  PD2-4  this build drives X and Y (PK_AXES=2);
 *                                      Z is configured as an output, held low
 *   X / Y / Z dir     D5 D6 D7  PD5-7
 *   steppers enable   D8        PB0    one line for all drivers, active low
 *   pen servo         D11       PB3    OC2A, Timer2 hardware PWM (Grbl's
 *                                      spindle PWM pin): 48.8 Hz frames, pulse
 *                                      width PK_BOARD_SERVO_MIN_US (value 0,
 *                                      pen up) .. PK_BOARD_SERVO_MAX_US
 *   limit X / Y / Z   D9 D10 D12 PB1 PB2 PB4  inputs with pull-ups (Grbl's map
 *                                      with the Z limit moved to D12); not
 *                                      read yet (no homing in this phase)
 *   spindle dir       D13       PB5    unused (output low)
 *   reset/hold/start  A0 A1 A2  PC0-2  Grbl's control inputs: pull-ups, not read
 *   probe             A5        PC5    pull-up, not read
 *   serial            D0 D1     PD0-1  USART0, 115200 baud 8N1 (U2X, 2.1 % fast,
 *                                      as Grbl)
 *
 * Timers: Timer1 (16-bit, clk/8 = 2 MHz, free running) is the step timer:
 * compare A schedules the callback, compare B ends the step pulses, overflow
 * extends the count to 48 bits.
 * Timer2 (8-bit) makes the servo pulses; Timer0 is unused.
 */
#ifndef PLOTKIN_BOARD_UNO_CNC_SHIELD_H
#define PLOTKIN_BOARD_UNO_CNC_SHIELD_H

#include <stdint.h>
#include <avr/io.h>

#define PK_BOARD_NAME "uno-cnc-shield"
#define PK_BOARD_AXES_WIRED 3u  /* step/dir pairs on the shield */

/* ---- step timer: Timer1, normal mode, clk/8 ------------------------------ */
#define PK_BOARD_TICK_HZ (F_CPU / 8u)
#define PK_BOARD_STEP_TCCRA TCCR1A
#define PK_BOARD_STEP_TCCRB TCCR1B
#define PK_BOARD_STEP_CS ((uint8_t)_BV(CS11))
#define PK_BOARD_STEP_TCNT TCNT1
#define PK_BOARD_STEP_OCR OCR1A
#define PK_BOARD_STEP_TIMSK TIMSK1
#define PK_BOARD_STEP_TIFR TIFR1
#define PK_BOARD_STEP_OCIE OCIE1A
#define PK_BOARD_STEP_OCF OCF1A
#define PK_BOARD_STEP_TOIE TOIE1
#define PK_BOARD_STEP_TOV TOV1
#define PK_BOARD_STEP_COMP_vect TIMER1_COMPA_vect
#define PK_BOARD_STEP_OVF_vect TIMER1_OVF_vect
/* compare B (same timer) ends the step pulses; OC1B's pin (D10, a limit
 * input) is not driven */
#define PK_BOARD_PULSE_OCR OCR1B
#define PK_BOARD_PULSE_OCIE OCIE1B
#define PK_BOARD_PULSE_OCF OCF1B
#define PK_BOARD_PULSE_COMP_vect TIMER1_COMPB_vect

/* ---- serial: USART0 ----------------------------------------------------- */
#define PK_BOARD_BAUD 115200ul
#define PK_BOARD_UBRR UBRR0
#define PK_BOARD_UCSRA UCSR0A
#define PK_BOARD_UCSRB UCSR0B
#define PK_BOARD_UCSRC UCSR0C
#define PK_BOARD_UDR UDR0
#define PK_BOARD_U2X U2X0
#define PK_BOARD_DOR DOR0
#define PK_BOARD_FE FE0
#define PK_BOARD_RXEN RXEN0
#define PK_BOARD_TXEN TXEN0
#define PK_BOARD_RXCIE RXCIE0
#define PK_BOARD_UDRIE UDRIE0
#define PK_BOARD_UCSZ0 UCSZ00
#define PK_BOARD_UCSZ1 UCSZ01
#define PK_BOARD_UART_RX_vect USART_RX_vect
#define PK_BOARD_UART_UDRE_vect USART_UDRE_vect

/* ---- pen servo: Timer2 fast PWM on OC2A (PB3 = D11), clk/256 -------------
 * One 8-bit period is 256 counts of 16 us = 4.096 ms; the pulse is let
 * through every 5th period (hal/avr/pk_avr_servo8.c), a 20.48 ms frame. */
#define PK_BOARD_SERVO_MIN_US 1000u  /* value 0: pen up */
#define PK_BOARD_SERVO_MAX_US 2000u  /* value 65535: pen fully down */
#define PK_BOARD_SERVO8_US_PER_COUNT 16u
#define PK_BOARD_SERVO8_TCCRA TCCR2A
#define PK_BOARD_SERVO8_TCCRB TCCR2B
#define PK_BOARD_SERVO8_WGM ((uint8_t)(_BV(WGM21) | _BV(WGM20)))
#define PK_BOARD_SERVO8_COM ((uint8_t)_BV(COM2A1))
#define PK_BOARD_SERVO8_CS ((uint8_t)(_BV(CS22) | _BV(CS21)))
#define PK_BOARD_SERVO8_OCR OCR2A
#define PK_BOARD_SERVO8_TIMSK TIMSK2
#define PK_BOARD_SERVO8_OCIE OCIE2A
#define PK_BOARD_SERVO8_TOIE TOIE2
#define PK_BOARD_SERVO8_COMP_vect TIMER2_COMPA_vect
#define PK_BOARD_SERVO8_OVF_vect TIMER2_OVF_vect

/* ---- pins ------------------------------------------------------------------ */
/** Outputs and inputs (pull-ups) to their initial state: step, dir low,
 *  drivers disabled (enable high), servo pin low, limits/controls pulled up. */
static inline void pk_board_pins_init(void)
{
    PORTD = (uint8_t)(PORTD & 0x03u);            /* PD2-7 low, leave the USART pins */
    DDRD = (uint8_t)(DDRD | 0xFCu);
    PORTB = (uint8_t)(_BV(PB0) | _BV(PB1) | _BV(PB2) | _BV(PB4));
    DDRB = (uint8_t)(_BV(PB0) | _BV(PB3) | _BV(PB5));
    PORTC = (uint8_t)(_BV(PC0) | _BV(PC1) | _BV(PC2) | _BV(PC5));
    DDRC = 0u;
}

/** [ISR] Step lines: bit i of mask/levels is axis i (X PD2, Y PD3, Z PD4). */
static inline __attribute__((always_inline)) void pk_board_step_write(uint8_t mask, uint8_t levels)
{
    uint8_t m = (uint8_t)((mask & 0x07u) << 2);
    PORTD = (uint8_t)((PORTD & (uint8_t)~m) | ((uint8_t)(levels << 2) & m));
}

/* The step lines' port as the pulse end writes it (pk_avr_pulse.h,
 * pk_avr_timer.c's compare B vector, in assembly; in the I/O space: in/out),
 * pk_board_step_bits0 its bits for the axes of a mask (one port: no
 * PK_BOARD_STEP_PORT1). */
#define PK_BOARD_STEP_PORT0 PORTD
static inline __attribute__((always_inline)) uint8_t pk_board_step_bits0(uint8_t mask)
{
    return (uint8_t)((mask & 0x07u) << 2);
}

/** [ISR] Direction lines: X PD5, Y PD6, Z PD7. */
static inline void pk_board_dir_write(uint8_t mask, uint8_t levels)
{
    uint8_t m = (uint8_t)((mask & 0x07u) << 5);
    PORTD = (uint8_t)((PORTD & (uint8_t)~m) | ((uint8_t)(levels << 5) & m));
}

/** [MAIN, interrupts off] The shared enable line PB0: any axis in mask sets
 *  it from that axis' level (all drivers share it). */
static inline void pk_board_enable_write(uint8_t mask, uint8_t levels)
{
    if (mask & 0x07u) {
        if (levels & mask)
            PORTB = (uint8_t)(PORTB | _BV(PB0));
        else
            PORTB = (uint8_t)(PORTB & (uint8_t)~_BV(PB0));
    }
}

#endif
