/*
 * board.h — Arduino Mega 2560 (ATmega2560, 16 MHz) with a RAMPS 1.4, wired as
 * RAMPS wires its X, Y and Z driver sockets (Marlin's pins_RAMPS.h names the
 * same Arduino pins). This file is the only place of the image that names
 * pins, timers and interrupt vectors; the shared AVR code in hal/avr/ uses
 * the names below.
 *
 *   signal      Mega pin  port   notes
 *   X step/dir  D54 D55   PF0 PF1
 *   X enable    D38       PD7    active low
 *   Y step/dir  D60 D61   PF6 PF7
 *   Y enable    D56       PF2    active low
 *   Z step/dir  D46 D48   PL3 PL1
 *   Z enable    D62       PK0    active low
 *   pen servo   D11       PB5    SERVO0 header, OC1A: Timer1 hardware PWM,
 *                                exactly 50 Hz, 0.5 us resolution, pulse
 *                                PK_BOARD_SERVO_MIN_US (value 0, pen up) ..
 *                                PK_BOARD_SERVO_MAX_US
 *   X min/max   D3 D2     PE5 PE4  end stops, inputs with pull-ups, switches to
 *   Y min/max   D14 D15   PJ1 PJ0  ground (active low). The MIN stops are the
 *   Z min/max   D18 D19   PD3 PD2  limit switches (hard limits, homing); the
 *                                  Z MAX stop (D19) is the probe input (G38.x)
 *                                  as RAMPS users wire a touch plate; X/Y MAX
 *                                  are pulled up and not read. Edges: X min
 *                                  INT5, Z min INT3, probe INT2 (any change),
 *                                  Y min PCINT10 (pin-change group 1).
 *   serial      D0 D1     PE0 PE1  USART0 (the USB serial), 115200 8N1, U2X
 *
 * Timers: Timer3 (16-bit, clk/8 = 2 MHz, free running) is the step timer:
 * compare A schedules the callback, compare B ends the step pulses, overflow
 * extends the count to 48 bits.
 * Timer1 makes the servo pulses (the SERVO0 pin is its OC1A).
 */
#ifndef PLOTKIN_BOARD_MEGA_RAMPS_H
#define PLOTKIN_BOARD_MEGA_RAMPS_H

#include <stdint.h>
#include <avr/io.h>
#include "hal.h"

#define PK_BOARD_NAME "mega-ramps"
#define PK_BOARD_AXES_WIRED 3u

/* ---- step timer: Timer3, normal mode, clk/8 ------------------------------ */
#define PK_BOARD_TICK_HZ (F_CPU / 8u)
#define PK_BOARD_STEP_TCCRA TCCR3A
#define PK_BOARD_STEP_TCCRB TCCR3B
#define PK_BOARD_STEP_CS ((uint8_t)_BV(CS31))
#define PK_BOARD_STEP_TCNT TCNT3
#define PK_BOARD_STEP_OCR OCR3A
#define PK_BOARD_STEP_TIMSK TIMSK3
#define PK_BOARD_STEP_TIFR TIFR3
#define PK_BOARD_STEP_OCIE OCIE3A
#define PK_BOARD_STEP_OCF OCF3A
#define PK_BOARD_STEP_TOIE TOIE3
#define PK_BOARD_STEP_TOV TOV3
#define PK_BOARD_STEP_COMP_vect TIMER3_COMPA_vect
#define PK_BOARD_STEP_OVF_vect TIMER3_OVF_vect
/* compare B (same timer) ends the step pulses; OC3B's pin is not driven */
#define PK_BOARD_PULSE_OCR OCR3B
#define PK_BOARD_PULSE_OCIE OCIE3B
#define PK_BOARD_PULSE_OCF OCF3B
#define PK_BOARD_PULSE_COMP_vect TIMER3_COMPB_vect

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
#define PK_BOARD_UART_RX_vect USART0_RX_vect
#define PK_BOARD_UART_UDRE_vect USART0_UDRE_vect

/* ---- pen servo: Timer1 mode 14 (fast PWM, TOP = ICR1), clk/8, OC1A ------- */
#define PK_BOARD_SERVO_MIN_US 1000u  /* value 0: pen up */
#define PK_BOARD_SERVO_MAX_US 2000u  /* value 65535: pen fully down */
#define PK_BOARD_SERVO16_COUNTS_PER_US 2u
#define PK_BOARD_SERVO16_FRAME_US 20000u
#define PK_BOARD_SERVO16_TCCRA TCCR1A
#define PK_BOARD_SERVO16_TCCRB TCCR1B
#define PK_BOARD_SERVO16_A ((uint8_t)(_BV(COM1A1) | _BV(WGM11)))
#define PK_BOARD_SERVO16_B ((uint8_t)(_BV(WGM13) | _BV(WGM12) | _BV(CS11)))
#define PK_BOARD_SERVO16_ICR ICR1
#define PK_BOARD_SERVO16_OCR OCR1A
#define PK_BOARD_SERVO16_TIMSK TIMSK1
#define PK_BOARD_SERVO16_TOIE TOIE1
#define PK_BOARD_SERVO16_OVF_vect TIMER1_OVF_vect

/* ---- pins ------------------------------------------------------------------ */
/** Outputs and inputs (pull-ups) to their initial state: step, dir low,
 *  drivers disabled (enable high), servo pin low, end stops pulled up. */
static inline void pk_board_pins_init(void)
{
    PORTF = (uint8_t)(PORTF & (uint8_t)~(_BV(PF0) | _BV(PF1) | _BV(PF6) | _BV(PF7)));
    PORTF = (uint8_t)(PORTF | _BV(PF2));
    DDRF = (uint8_t)(DDRF | _BV(PF0) | _BV(PF1) | _BV(PF2) | _BV(PF6) | _BV(PF7));
    PORTL = (uint8_t)(PORTL & (uint8_t)~(_BV(PL3) | _BV(PL1)));
    DDRL = (uint8_t)(DDRL | _BV(PL3) | _BV(PL1));
    PORTD = (uint8_t)(PORTD | _BV(PD7) | _BV(PD3) | _BV(PD2));
    DDRD = (uint8_t)(DDRD | _BV(PD7));
    PORTK = (uint8_t)(PORTK | _BV(PK0));
    DDRK = (uint8_t)(DDRK | _BV(PK0));
    PORTB = (uint8_t)(PORTB & (uint8_t)~_BV(PB5));
    DDRB = (uint8_t)(DDRB | _BV(PB5));
    PORTE = (uint8_t)(PORTE | _BV(PE5) | _BV(PE4));
    PORTJ = (uint8_t)(PORTJ | _BV(PJ1) | _BV(PJ0));
}

/** [ISR] Step lines: bit 0 X (PF0), bit 1 Y (PF6), bit 2 Z (PL3). */
static inline __attribute__((always_inline)) void pk_board_step_write(uint8_t mask, uint8_t levels)
{
    uint8_t mf = (uint8_t)(((mask & 1u) ? _BV(PF0) : 0u) | ((mask & 2u) ? _BV(PF6) : 0u));
    uint8_t vf = (uint8_t)(((levels & 1u) ? _BV(PF0) : 0u) | ((levels & 2u) ? _BV(PF6) : 0u));
    if (mf)
        PORTF = (uint8_t)((PORTF & (uint8_t)~mf) | (vf & mf));
    if (mask & 4u)
        PORTL = (uint8_t)((levels & 4u) ? (PORTL | _BV(PL3)) : (PORTL & (uint8_t)~_BV(PL3)));
}

/* The step lines' ports as the pulse end writes them (pk_avr_pulse.h,
 * pk_avr_timer.c's compare B vector, in assembly): port 0 in the I/O space
 * (in/out), port 1 (optional) anywhere (lds/sts); pk_board_step_bits0/1 the
 * bits of each for the axes of a mask, as pk_board_step_write places them. */
#define PK_BOARD_STEP_PORT0 PORTF
#define PK_BOARD_STEP_PORT1 PORTL
static inline __attribute__((always_inline)) uint8_t pk_board_step_bits0(uint8_t mask)
{
    /* bit 0 -> PF0, bit 1 -> PF6 (shifts: fewer instructions than tests) */
    return (uint8_t)((mask & 1u) | (uint8_t)((uint8_t)(mask & 2u) << (PF6 - 1)));
}
static inline __attribute__((always_inline)) uint8_t pk_board_step_bits1(uint8_t mask)
{
    return (uint8_t)((uint8_t)(mask & 4u) << (PL3 - 2)); /* bit 2 -> PL3 */
}

/** [ISR] Direction lines: X PF1, Y PF7, Z PL1. */
static inline void pk_board_dir_write(uint8_t mask, uint8_t levels)
{
    uint8_t mf = (uint8_t)(((mask & 1u) ? _BV(PF1) : 0u) | ((mask & 2u) ? _BV(PF7) : 0u));
    uint8_t vf = (uint8_t)(((levels & 1u) ? _BV(PF1) : 0u) | ((levels & 2u) ? _BV(PF7) : 0u));
    if (mf)
        PORTF = (uint8_t)((PORTF & (uint8_t)~mf) | (vf & mf));
    if (mask & 4u)
        PORTL = (uint8_t)((levels & 4u) ? (PORTL | _BV(PL1)) : (PORTL & (uint8_t)~_BV(PL1)));
}

/** [MAIN, interrupts off] Enable lines: X PD7, Y PF2, Z PK0 (raw levels). */
static inline void pk_board_enable_write(uint8_t mask, uint8_t levels)
{
    if (mask & 1u)
        PORTD = (uint8_t)((levels & 1u) ? (PORTD | _BV(PD7)) : (PORTD & (uint8_t)~_BV(PD7)));
    if (mask & 2u)
        PORTF = (uint8_t)((levels & 2u) ? (PORTF | _BV(PF2)) : (PORTF & (uint8_t)~_BV(PF2)));
    if (mask & 4u)
        PORTK = (uint8_t)((levels & 4u) ? (PORTK | _BV(PK0)) : (PORTK & (uint8_t)~_BV(PK0)));
}

/* ---- inputs: RAMPS min end stops = limits, Z max = probe -------------------- */
#define PK_BOARD_INPUTS ((1u << PK_IN_LIMIT_X) | (1u << PK_IN_LIMIT_Y) | (1u << PK_IN_LIMIT_Z) | \
                         (1u << PK_IN_PROBE))
#define PK_BOARD_INPUT_INVERT PK_BOARD_INPUTS /* pull-ups, switches to ground */
#define PK_BOARD_INPUT_VECT0 INT5_vect   /* X min, PE5 */
#define PK_BOARD_INPUT_VECT1 PCINT1_vect /* Y min, PJ1 = PCINT10 */
#define PK_BOARD_INPUT_VECT2 INT3_vect   /* Z min, PD3 */
#define PK_BOARD_INPUT_VECT3 INT2_vect   /* probe, PD2 */
#define PK_BOARD_INPUT_EIMSK ((uint8_t)(_BV(INT5) | _BV(INT3) | _BV(INT2)))
#define PK_BOARD_INPUT_PCIE ((uint8_t)_BV(PCIE1))

/** [ISR][MAIN] Raw levels of the input lines, bits of enum pk_hal_input. */
static inline uint32_t pk_board_input_read(void)
{
    uint8_t d = PIND, e = PINE, j = PINJ;
    return ((e & _BV(PE5)) ? 1u << PK_IN_LIMIT_X : 0u) | ((j & _BV(PJ1)) ? 1u << PK_IN_LIMIT_Y : 0u) |
           ((d & _BV(PD3)) ? 1u << PK_IN_LIMIT_Z : 0u) | ((d & _BV(PD2)) ? 1u << PK_IN_PROBE : 0u);
}

/** [MAIN, interrupts off] Edge interrupts on (any change) or off. */
static inline void pk_board_input_edges(uint8_t on)
{
    EIMSK = (uint8_t)(EIMSK & (uint8_t)~PK_BOARD_INPUT_EIMSK);
    PCICR = (uint8_t)(PCICR & (uint8_t)~PK_BOARD_INPUT_PCIE);
    if (!on)
        return;
    /* ISCn1:ISCn0 = 01: any logical change */
    EICRA = (uint8_t)((EICRA & (uint8_t)~(_BV(ISC31) | _BV(ISC30) | _BV(ISC21) | _BV(ISC20))) |
                      _BV(ISC30) | _BV(ISC20));
    EICRB = (uint8_t)((EICRB & (uint8_t)~(_BV(ISC51) | _BV(ISC50))) | _BV(ISC50));
    PCMSK1 = (uint8_t)(PCMSK1 | _BV(PCINT10));
    EIFR = PK_BOARD_INPUT_EIMSK; /* drop edges from before: the core reads the levels */
    PCIFR = PK_BOARD_INPUT_PCIE;
    EIMSK = (uint8_t)(EIMSK | PK_BOARD_INPUT_EIMSK);
    PCICR = (uint8_t)(PCICR | PK_BOARD_INPUT_PCIE);
}

#endif
