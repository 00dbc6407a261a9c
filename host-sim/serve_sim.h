/*
 * serve_sim.h — the machine behind `plotkin serve` (host only): the Grbl
 * engine (firmware/pk_grbl.c) over the UART shim, driving the motion core on
 * the SAME simulated machine as `plotkin sim` (host-sim/sim_run.h: libgpiod
 * backend on the mock GPIO chip, simulated clock and scheduler, pin trace
 * decoded on the fly with the driver's timing checks). So the summary on exit
 * is `plotkin sim`'s (sim_report.h), measured from the pins the same way,
 * the path deviation included (the engine's observer feeds the programmed
 * path as in `plotkin sim`; lines are the session's, 1 = the first received).
 *
 * Memory stays flat however long the session: no pin edge, decoded step or
 * executed path is kept (the programmed path lives in its fixed window) (the decoder measures as the edges happen); only the
 * list of timing violations grows, by one entry per violation.
 *
 * Single-threaded. Storage is caller-owned and large (heap or static).
 */
#ifndef PLOTKIN_SERVE_SIM_H
#define PLOTKIN_SERVE_SIM_H

#include <stdint.h>
#include "pk_grbl.h"
#include "pk_grbl_motion.h"
#include "pk_uart.h"
#include "sim_run.h"

struct pk_serve_sim {
    struct pk_sim_cfg cfg;        /**< settings (the engine's, as `$N` values) */
    struct pk_sim_result r;       /**< the simulated machine and its measurements */
    struct pk_grbl_motion gm;
    struct pk_uart uart;          /**< bytes in with pk_uart_rx_push, out with pk_uart_tx_pop */
    struct pk_grbl g;
    uint8_t nvm_buf[PK_GRBL_NVM_BYTES]; /**< the RAM store used when start gets no nvm */
    struct pk_grbl_ram_nvm ram;
    uint8_t in_alarm;             /* private: alarm state seen at the last iteration */
    char ans[16];                 /* private: start of the answer line being sent */
    uint8_t ans_n;
    unsigned answered;            /* private: ok/error lines sent */
};

/**
 * Set up and start (the greeting is queued). chip: mock chip name, unique in
 * the process; lim: the driver timing limits checked. Returns 0, or -1 with
 * the reason in s->r.err (call pk_serve_sim_free in both cases).
 */
int pk_serve_sim_start(struct pk_serve_sim *s, const char *chip, const struct pk_timing_limits *lim);

/** The same with a given non-volatile store for the settings (e.g. a file,
 *  hal/posix/pk_nvm_file.h), or NULL for an erased RAM one. */
int pk_serve_sim_start_nvm(struct pk_serve_sim *s, const char *chip, const struct pk_timing_limits *lim,
                           const struct pk_grbl_nvm *nvm);

/** The same on a machine with input lines: scripted edges and switches
 *  along the axes (sim_machine.h; they must outlive s), as `plotkin sim
 *  --input/--switch` (NULL, 0: none). The Grbl settings then act on them
 *  ($21 hard limits, $H, G38.x, Pn:). */
int pk_serve_sim_start_in(struct pk_serve_sim *s, const char *chip, const struct pk_timing_limits *lim,
                          const struct pk_grbl_nvm *nvm, const struct pk_sim_input *in, size_t n_in);

/**
 * Run the firmware (engine main loop, machine poll, step-timer callbacks at
 * their exact ticks) for `ticks` more ticks of simulated time (> 0).
 * Returns 0, or -1 if the simulation broke down (s->r.run_status says how).
 */
int pk_serve_sim_run(struct pk_serve_sim *s, uint64_t ticks);

/** Simulated time now, ticks (tick rate s->cfg.tick_hz). */
uint64_t pk_serve_sim_now(const struct pk_serve_sim *s);

/** Run the engine's main loop once more at the current tick from the next
 *  slice on (call after bytes were pushed in, so it answers at once). */
void pk_serve_sim_wake(struct pk_serve_sim *s);

/**
 * End of the session: the figures of the summary (lines, moves, errors,
 * settings as they are now) into s->r and s->cfg, then pk_sim_finish.
 * Returns pk_sim_finish's result. Print with pk_sim_print_summary(f, &s->r,
 * s->cfg.axes, &s->cfg, driver).
 */
int pk_serve_sim_finish(struct pk_serve_sim *s);

void pk_serve_sim_free(struct pk_serve_sim *s);

#endif
