/*
 * grbl_sim.h — one complete simulated plotkin machine speaking Grbl (host
 * only): the protocol engine (pk_grbl) over the UART shim (pk_uart), driving
 * the motion core (pk_machine) through the adapter (pk_grbl_motion), on the
 * recording HAL with a simulated clock (hal_record, logging off so that a
 * long session uses constant memory).
 *
 * pk_grbl_sim_step() is one main-loop iteration followed by `ticks` of
 * simulated time in which the step-timer callbacks run at their exact ticks.
 * Bytes go in through pk_uart_rx_push(&s->uart, ...) (the receive "ISR",
 * realtime filter included) and come out through pk_uart_tx_pop; or attach a
 * pseudo-terminal with pk_serial_pump (see cmd_serve.c).
 *
 * Single-threaded and deterministic. Storage is caller-owned (it is large:
 * allocate it statically or on the heap, not on a small stack).
 */
#ifndef PLOTKIN_GRBL_SIM_H
#define PLOTKIN_GRBL_SIM_H

#include <stdint.h>
#include "hal_record.h"
#include "pk_grbl.h"
#include "pk_grbl_motion.h"
#include "pk_motion.h"
#include "pk_uart.h"

struct pk_grbl_sim {
    struct pk_rec rec;
    struct pk_machine m;
    struct pk_grbl_motion gm;
    struct pk_uart uart;
    struct pk_grbl g;
};

/** Build and start (greeting queued). tick_hz e.g. 1000000. 0 or -1. */
int pk_grbl_sim_init(struct pk_grbl_sim *s, uint32_t tick_hz, const struct pk_grbl_settings *set);

/** One main iteration (engine + machine poll), then advance `ticks`. */
void pk_grbl_sim_step(struct pk_grbl_sim *s, uint64_t ticks);

/** Release the recorder's memory. */
void pk_grbl_sim_free(struct pk_grbl_sim *s);

#endif
