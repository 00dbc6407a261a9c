/*
 * pk_app.h — the controller a board runs: one machine (pk_motion.h) driven by
 * the Grbl 1.1 protocol engine (pk_grbl.h, through the adapter of
 * pk_grbl_motion.h) over the UART rings (pk_uart.h), on the board's HAL.
 *
 * This is the board-independent part of every firmware image (Klipper's
 * src/generic/): a board's main() sets up its HAL instance, calls
 * pk_app_init once, enables its receive interrupt (which hands every byte to
 * pk_uart_rx_push(&app->uart, byte)) and then calls pk_app_poll forever,
 * starting its transmitter whenever pk_uart_tx_space shows queued bytes. The
 * host simulator runs the same pieces (host-sim/grbl_sim.c, serve_sim.c), so
 * what a board runs is what the tests run.
 *
 * Memory: one struct pk_app, owned by the caller (a board: its one static
 * object). No heap, no globals. Calling context: MAIN, except where the
 * members say otherwise (the UART's receive side is the RX interrupt).
 */
#ifndef PLOTKIN_PK_APP_H
#define PLOTKIN_PK_APP_H

#include "hal.h"
#include "pk_grbl.h"
#include "pk_grbl_motion.h"
#include "pk_motion.h"
#include "pk_uart.h"

struct pk_app {
    struct pk_machine m;       /**< the motion core */
    struct pk_grbl_motion gm;  /**< the engine's view of m */
    struct pk_uart uart;       /**< RX: the receive ISR pushes; TX: the board drains */
    struct pk_grbl g;          /**< the protocol engine */
};

/**
 * Set everything up on hal (which must outlive app): the UART rings with the
 * engine's realtime filter, the machine initialised from the engine's default
 * settings, the greeting queued.
 * @retval 0   ready: enable the receive interrupt, then call pk_app_poll
 * @retval -1  the machine refused the default settings or the HAL (see
 *             pk_machine_init: a HAL failing pk_hal_check, a failing write)
 * Calling context: MAIN, interrupts that reach app not yet enabled.
 */
int pk_app_init(struct pk_app *app, const struct pk_hal *hal);

/**
 * pk_app_init with the machine's `$N` settings (copied; NULL: the engine's
 * defaults): for a board that has them from somewhere other than the engine's
 * defaults (the Linux board's --config file). Same returns and context; -1
 * also when the machine refuses these settings.
 */
int pk_app_init_settings(struct pk_app *app, const struct pk_hal *hal,
                         const struct pk_grbl_settings *set);

/**
 * One main-loop iteration: the engine (realtime events, lines, answers), then
 * the machine (strokes, planner, step chunks, timer arming). Bounded work.
 * Calling context: MAIN, as often as possible.
 */
void pk_app_poll(struct pk_app *app);

#endif
