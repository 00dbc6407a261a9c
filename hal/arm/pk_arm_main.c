/*
 * pk_arm_main.c — main() of plotkin's Cortex-M images: the board, the
 * controller (hal/pk_app.h: Grbl engine + machine + UART rings) and the main
 * loop. The controller is the image's one static object besides the board's
 * backend instance. If it cannot start, the image says so on the serial line
 * and stops there with the drivers disabled.
 */
#include "pk_app.h"
#include "pk_arm.h"

static struct pk_app app;

static const char init_failed[] =
    "[MSG:plotkin: the machine refused its default settings or the HAL]\n";

static void tx_kick(void *ctx)
{
    (void)ctx;
    pk_board_uart_kick();
}

int main(void)
{
    const struct pk_hal *hal = pk_board_init();
    int rc = pk_app_init(&app, hal);
    pk_board_uart_start(&app.uart);
    pk_uart_set_tx_kick(&app.uart, tx_kick, NULL); /* answers leave at once */
    pk_arm_irq_enable();
    if (rc != 0) {
        (void)pk_hal_enable_write(hal, 0xFFu, 0u);
        const uint8_t *p = (const uint8_t *)init_failed;
        while (*p)
            if (pk_uart_write(&app.uart, p, 1u) == 1)
                p++;
            else
                pk_board_uart_kick();
        for (;;)
            pk_board_uart_kick();
    }
    for (;;) /* (each write starts the transmitter: pk_uart_set_tx_kick) */
        pk_app_poll(&app);
}
