/*
 * pk_app.c — the board-independent controller: Grbl engine + machine + UART
 * rings (see pk_app.h).
 */
#include "pk_app.h"

#include <string.h>

int pk_app_init(struct pk_app *app, const struct pk_hal *hal)
{
    return pk_app_init_settings(app, hal, NULL);
}

int pk_app_init_settings(struct pk_app *app, const struct pk_hal *hal,
                         const struct pk_grbl_settings *set)
{
    memset(app, 0, sizeof *app);
    app->gm.m = &app->m;
    app->gm.hal = hal;
    app->gm.yield = pk_grbl_wants_cpu; /* realtime commands and output end a long poll */
    app->gm.yield_ctx = &app->g;
    pk_uart_init(&app->uart, pk_grbl_rt_filter, &app->g);
    struct pk_grbl_stream io = { pk_uart_read_cb, pk_uart_write_cb, pk_uart_rx_used_cb,
                                 &app->uart };
    struct pk_grbl_machine_ops ops;
    pk_grbl_motion_ops(&ops);
    struct pk_grbl_nvm nvm; /* the HAL's EEPROM/flash store, if it has one */
    pk_grbl_motion_nvm(hal, &nvm);
    return pk_grbl_init(&app->g, &io, &ops, &app->gm, set, &nvm) == 0 ? 0 : -1;
}

void pk_app_poll(struct pk_app *app)
{
    pk_grbl_poll(&app->g);
    pk_machine_poll(&app->m);
}
