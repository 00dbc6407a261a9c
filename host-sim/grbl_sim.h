/*
 * grbl_sim.h — one complete simulated plotkin machine speaking Grbl (host
 * only): the protocol engine (pk_grbl) over the UART shim (pk_uart), driving
 * the motion core (pk_machine) through the adapter (pk_grbl_motion), on the
 * recording HAL with a simulated clock (hal_record, logging off so that a
 * long session uses constant memory), with a RAM store for the settings
 * (pk_grbl_ram_nvm) that survives pk_grbl_sim_restart like an EEPROM.
 *
 * pk_grbl_sim_step() is one main-loop iteration followed by `ticks` of
 * simulated time in which the step-timer callbacks run at their exact ticks.
 * Bytes go in through pk_uart_rx_push(&s->uart, ...) (the receive "ISR",
 * realtime filter included) and come out through pk_uart_tx_pop; or attach a
 * pseudo-terminal with pk_serial_pump. `plotkin serve` runs the same engine on
 * the pin-level simulator instead (serve_sim.h); this lighter machine serves
 * the protocol tests (test_grbl_motion, test_settings_paths).
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
    uint8_t nvm_buf[PK_GRBL_NVM_BYTES]; /**< the "EEPROM" (kept by restart) */
    struct pk_grbl_ram_nvm ram;
    uint32_t tick_hz;
    uint32_t inputs;      /**< input lines of the HAL (PK_IN_* bits; 0: none) */
    int input_edges;      /**< 1: the HAL reports edges; 0: the core reads */
};

/** Build and start (greeting queued) with an erased store. set: the settings
 *  (NULL: the store's, i.e. the defaults). tick_hz e.g. 1000000. 0 or -1. */
int pk_grbl_sim_init(struct pk_grbl_sim *s, uint32_t tick_hz, const struct pk_grbl_settings *set);

/** As pk_grbl_sim_init, on a HAL with input lines `inputs` (PK_IN_* bits,
 *  active high, all inactive; edges as pk_rec_inputs). Script them on s->rec
 *  with pk_rec_input_at / pk_rec_add_switch. Restart keeps the lines (not
 *  the script). 0 or -1. */
int pk_grbl_sim_init_inputs(struct pk_grbl_sim *s, uint32_t tick_hz,
                            const struct pk_grbl_settings *set, uint32_t inputs, int edges);

/** Power-cycle: a new machine at position 0 and a new engine, the store kept
 *  (settings come from it). 0 or -1. */
int pk_grbl_sim_restart(struct pk_grbl_sim *s);

/** One main iteration (engine + machine poll), then advance `ticks`. */
void pk_grbl_sim_step(struct pk_grbl_sim *s, uint64_t ticks);

/** Release the recorder's memory. */
void pk_grbl_sim_free(struct pk_grbl_sim *s);

#endif
