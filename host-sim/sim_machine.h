/*
 * sim_machine.h — one simulated machine's hardware: a mock GPIO chip, the
 * real gpiod HAL backend on top of it, the simulated clock/scheduler, and the
 * pin trace recorder, wired together.
 *
 *   firmware --pk_hal--> gpiod backend --gpiod_*()--> gpiod_mock chip --edges--> trace
 *        \                  \--timer/clock--> sim scheduler <--clock-- mock
 *
 * Everything is in the struct (plus the trace's heap array), so a process can
 * hold several machines; each registers its own chip name.
 */
#ifndef PLOTKIN_SIM_MACHINE_H
#define PLOTKIN_SIM_MACHINE_H

#include <stddef.h>
#include <stdint.h>
#include "gpiod/pk_gpiod.h"
#include "gpiod_mock.h"
#include "sim_sched.h"
#include "sim_trace.h"

struct pk_sim_hw {
    struct pk_sim_sched sched;
    struct pk_gpiod_mock chip;
    struct pk_gpiod gpio;
    struct pk_trace trace;
    struct pk_hal base;   /**< the scheduler's timer/clock HAL */
    struct pk_hal hal;    /**< what the firmware uses: gpiod pins + sim timer */
    uint8_t registered, opened;
};

/**
 * The simulator's default wiring (like a Raspberry Pi plotter hat): chip
 * `chip_name`, step lines 0.., direction lines 4.., one shared active-low
 * enable line 8, pen line 9; `axes` 1..PK_HAL_MAX_AXES.
 */
void pk_sim_default_board(struct pk_gpiod_cfg *cfg, const char *chip_name, unsigned axes);

/**
 * Register a mock chip named cfg->chip, open the gpiod backend on it over a
 * fresh scheduler (tick_hz, main_period ticks) and start recording.
 * `fault`, if not NULL, is copied into the chip's fault plan before opening
 * (so open/request failures can be injected). On failure err holds the
 * backend's message and pk_sim_hw_close must still be called.
 * @retval 0 ok, or a negative PK_HAL_* code
 */
int pk_sim_hw_open(struct pk_sim_hw *w, const struct pk_gpiod_cfg *cfg, uint32_t tick_hz,
                   uint32_t main_period, const struct pk_gpiod_mock *fault, char *err, size_t errlen);

/**
 * The same with the trace's consumers set before the lines are requested (so
 * a streaming consumer sees the initial levels too): keep, on_edge and
 * on_edge_arg are copied from *tpl.
 */
int pk_sim_hw_open_traced(struct pk_sim_hw *w, const struct pk_gpiod_cfg *cfg, uint32_t tick_hz,
                          uint32_t main_period, const struct pk_gpiod_mock *fault,
                          const struct pk_trace *tpl, char *err, size_t errlen);

/** Decoder configuration for a board's wiring and polarity (as pk_gpiod_open
 *  sets up struct pk_hal), usable before the board is opened. */
void pk_sim_board_decode_cfg(const struct pk_gpiod_cfg *cfg, uint32_t tick_hz,
                             const struct pk_timing_limits *lim, struct pk_decode_cfg *out);

/** Close the backend (releases every line), unregister the chip, free the trace. */
void pk_sim_hw_close(struct pk_sim_hw *w);

/** Decoder configuration matching w's wiring and polarity, with limits lim. */
void pk_sim_hw_decode_cfg(const struct pk_sim_hw *w, const struct pk_timing_limits *lim,
                          struct pk_decode_cfg *out);

#endif
