/*
 * pk_avr_uart.c — the serial line of the AVR backend: the USART's receive
 * interrupt feeds the RX ring (the realtime filter of the Grbl engine sees
 * every byte there, pk_uart.h), the data-register-empty interrupt drains the
 * TX ring. 8N1 at PK_BOARD_BAUD in double-speed mode (UBRR = 16 at 16 MHz
 * for 115200 baud: 117,647 baud, 2.1 % fast, as Grbl).
 *
 * A byte the hardware lost (data overrun: the receive interrupt came more
 * than a byte time late) or received broken (framing error) is reported to
 * the ring as lost (pk_uart_rx_lost), so the line it belonged to fails
 * instead of silently missing a character.
 */
#include "pk_avr.h"

#include <avr/interrupt.h>
#include <avr/io.h>
#include "board.h"

#define UBRR_VALUE ((F_CPU + 4u * PK_BOARD_BAUD) / (8u * PK_BOARD_BAUD) - 1u)

void pk_avr_uart_init(struct pk_avr *a)
{
    a->uart = NULL;
    PK_BOARD_UBRR = (uint16_t)UBRR_VALUE;
    PK_BOARD_UCSRA = (uint8_t)_BV(PK_BOARD_U2X);
    PK_BOARD_UCSRC = (uint8_t)(_BV(PK_BOARD_UCSZ1) | _BV(PK_BOARD_UCSZ0));
    PK_BOARD_UCSRB = (uint8_t)(_BV(PK_BOARD_RXEN) | _BV(PK_BOARD_TXEN));
}

void pk_avr_uart_start(struct pk_avr *a, struct pk_uart *u)
{
    uint8_t s = SREG;
    cli();
    a->uart = u;
    PK_BOARD_UCSRB = (uint8_t)(PK_BOARD_UCSRB | _BV(PK_BOARD_RXCIE));
    SREG = s;
}

void pk_avr_uart_kick(struct pk_avr *a)
{
    if (a->uart == NULL || pk_uart_tx_space(a->uart) == PK_UART_TX_SIZE)
        return;
    uint8_t s = SREG;
    cli();
    PK_BOARD_UCSRB = (uint8_t)(PK_BOARD_UCSRB | _BV(PK_BOARD_UDRIE));
    SREG = s;
}

ISR(PK_BOARD_UART_RX_vect)
{
    uint8_t status = PK_BOARD_UCSRA;
    uint8_t b = PK_BOARD_UDR;
    struct pk_uart *u = pk_avr_board.uart;
    if (status & (uint8_t)(_BV(PK_BOARD_DOR) | _BV(PK_BOARD_FE)))
        pk_uart_rx_lost(u);
    if (!(status & (uint8_t)_BV(PK_BOARD_FE)))
        (void)pk_uart_rx_push(u, b);
}

ISR(PK_BOARD_UART_UDRE_vect)
{
    uint8_t b;
    if (pk_uart_tx_pop(pk_avr_board.uart, &b, 1u) == 1u)
        PK_BOARD_UDR = b;
    else
        PK_BOARD_UCSRB = (uint8_t)(PK_BOARD_UCSRB & (uint8_t)~_BV(PK_BOARD_UDRIE));
}
