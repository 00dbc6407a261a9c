/*
 * pk_avr_main.c — main() of plotkin's AVR images: the backend, the
 * controller (hal/pk_app.h: Grbl engine + machine + UART rings) and the main
 * loop. The controller is the image's one static object besides the backend
 * instance (pk_avr.h).
 *
 * If the controller cannot start (the machine refuses the default settings or
 * the HAL), the image says so on the serial line and stops there, with the
 * drivers disabled: a board that would otherwise run on half-initialised
 * state must not move.
 */
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/pgmspace.h>
#include "pk_app.h"
#include "pk_avr.h"

/* (external: a board whose step interrupt runs the step path inline reaches
 * the machine at its fixed address, pk_avr_step.h) */
struct pk_app app;

static const char init_failed[] PROGMEM =
    "[MSG:plotkin: the machine refused its default settings or the HAL]\n";

static void halt_with_message(const char *msg_P)
{
    (void)pk_hal_enable_write(&pk_avr_board.hal, 0xFFu, 0u);
    for (uint8_t c; (c = pgm_read_byte(msg_P)) != 0u; msg_P++)
        while (pk_uart_write(&app.uart, &c, 1u) == 0)
            pk_avr_uart_kick(&pk_avr_board);
    for (;;)
        pk_avr_uart_kick(&pk_avr_board);
}

static void tx_kick(void *ctx)
{
    pk_avr_uart_kick(ctx);
}

int main(void)
{
    cli();
    pk_avr_init(&pk_avr_board);
    int rc = pk_app_init(&app, &pk_avr_board.hal);
    pk_avr_uart_start(&pk_avr_board, &app.uart);
    pk_uart_set_tx_kick(&app.uart, tx_kick, &pk_avr_board); /* answers leave at once */
    sei();
    if (rc != 0)
        halt_with_message(init_failed);
    for (;;) /* (each write starts the transmitter: pk_uart_set_tx_kick) */
        pk_app_poll(&app);
}
