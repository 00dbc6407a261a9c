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
 *
 * Inputs: the board's input lines start at their idle level; their changes
 * come from a script on the simulated clock (pk_sim_hw_input_at) or from
 * switches placed along an axis (pk_sim_hw_add_switch: active while the axis,
 * decoded from its step/dir lines as the chip sees them, is at or beyond a
 * step count). The chip queues an edge event per change and the scheduler
 * runs the gpiod backend's edge service (pk_gpiod_input_service) as an
 * interrupt at the change's tick, between step callbacks.
 */
#ifndef PLOTKIN_SIM_MACHINE_H
#define PLOTKIN_SIM_MACHINE_H

#include <stddef.h>
#include <stdint.h>
#include "gpiod/pk_gpiod.h"
#include "gpiod_mock.h"
#include "sim_sched.h"
#include "sim_trace.h"

/** One input change for a simulated machine: a scripted edge or a switch. */
struct pk_sim_input {
    uint8_t is_switch;  /**< 0: edge at tick; 1: switch along axis */
    uint8_t input;      /**< enum pk_hal_input */
    uint8_t active;     /**< edge: the logical level from tick on */
    uint8_t axis;       /**< switch: its axis */
    int8_t side;        /**< switch: +1 active while pos >= at_steps, -1 while <= */
    int32_t at_steps;   /**< switch: where it closes */
    uint64_t tick;      /**< edge: when */
};

#define PK_SIM_SWITCHES 8

struct pk_sim_hw {
    struct pk_sim_sched sched;
    struct pk_gpiod_mock chip;
    struct pk_gpiod gpio;
    struct pk_trace trace;
    struct pk_hal base;   /**< the scheduler's timer/clock HAL */
    struct pk_hal hal;    /**< what the firmware uses: gpiod pins + sim timer */
    uint8_t registered, opened;
    /* switches along the axes (pk_sim_hw_add_switch) */
    struct pk_sim_input sw[PK_SIM_SWITCHES];
    unsigned n_sw;
    int64_t sw_pos[PK_HAL_MAX_AXES];   /**< axis positions from the step/dir lines */
    uint32_t sw_step, sw_dir;          /**< their raw levels */
    int service_failed;                /**< the backend's edge service failed (see gpio's error) */
};

/**
 * The simulator's default wiring (like a Raspberry Pi plotter hat): chip
 * `chip_name`, step lines 0.., direction lines 4.., one shared active-low
 * enable line 8, pen line 9, limit switches 10.. (one per axis), probe 14,
 * door 15, hold 16, resume 17, reset 18 — every input active-low on a
 * pull-up, as on Grbl's boards; `axes` 1..PK_HAL_MAX_AXES.
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

/** Script an input: the logical level `active` of input `input` (enum
 *  pk_hal_input) from tick t on. 0, or -1 (not wired, script full, t earlier
 *  than the last). */
int pk_sim_hw_input_at(struct pk_sim_hw *w, uint64_t t, unsigned input, int active);

/** Place a switch on input `input` along axis `axis` (struct pk_sim_input);
 *  its line follows it from now on. 0, or -1 (not wired, too many). */
int pk_sim_hw_add_switch(struct pk_sim_hw *w, unsigned input, unsigned axis, int side, int32_t at_steps);

/** Apply a list of struct pk_sim_input. 0, or -1 at the first that fails. */
int pk_sim_hw_inputs(struct pk_sim_hw *w, const struct pk_sim_input *in, size_t n);

/** Close the backend (releases every line), unregister the chip, free the trace. */
void pk_sim_hw_close(struct pk_sim_hw *w);

/** Decoder configuration matching w's wiring and polarity, with limits lim. */
void pk_sim_hw_decode_cfg(const struct pk_sim_hw *w, const struct pk_timing_limits *lim,
                          struct pk_decode_cfg *out);

#endif
