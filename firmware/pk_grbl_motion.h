/*
 * pk_grbl_motion.h — adapter that lets the Grbl protocol engine (pk_grbl.h)
 * drive a real plotkin machine (pk_motion.h).
 *
 * It turns the engine's machine ops into pk_machine_* calls and the Grbl
 * settings into a struct pk_motion_cfg: steps/mm (1e-4 steps/mm) -> Q16.16,
 * rates mm/min -> µm/min, accelerations mm/s^2 -> µm/s^2, $0 / $206 µs ->
 * HAL ticks (at least 1), $11 mm -> µm, $12 mm -> tolerance µm, $200..$204
 * -> struct pk_smooth_cfg, $205 pen settle, $207 look-ahead wait.
 * The first settings initialise the machine (pk_machine_init); later ones go
 * through pk_machine_configure, which keeps the step position (the mm
 * position follows a new steps/mm, as in Grbl) and refuses while moving; a
 * steps/mm change that would put the current position beyond ±PK_UM_MAX is
 * refused here (never wrapped).
 * Moves map PK_MOTION_ETRAVEL (soft limits) to PK_GRBL_M_ETRAVEL. Inputs:
 * $5 / $6 invert the limit / probe inputs (pk_motion_cfg.input_invert);
 * G38.x runs pk_machine_probe; $H runs pk_home.h's cycle with $23-$27 and
 * $130..; $21 pk_machine_set_hard_limits; a board without the input answers
 * PK_GRBL_M_ENOTSUP.
 *
 * Usage:
 *     struct pk_grbl_motion gm = { &machine, &hal };
 *     struct pk_grbl_machine_ops ops;
 *     pk_grbl_motion_ops(&ops);
 *     pk_grbl_init(&g, &io, &ops, &gm, NULL, &nvm);
 * Calling context: MAIN (as the engine).
 */
#ifndef PLOTKIN_PK_GRBL_MOTION_H
#define PLOTKIN_PK_GRBL_MOTION_H

#include "hal.h"
#include "pk_grbl.h"
#include "pk_home.h"
#include "pk_motion.h"

struct pk_grbl_motion {
    struct pk_machine *m;        /**< storage for the machine (initialised by configure) */
    const struct pk_hal *hal;    /**< its HAL; must outlive the machine */
    pk_machine_yield_fn yield;   /**< set before the engine's init: given to the machine */
    void *yield_ctx;             /**< (pk_machine_set_yield), e.g. pk_grbl_wants_cpu */
    struct pk_grbl_settings set; /**< last settings applied (private) */
    int ready;                   /**< the machine has been initialised (private) */
#if PK_GRBL_INPUTS
    struct pk_home home;         /**< the $H cycle (private) */
#endif
};

/** Fill *ops with the adapter's machine ops (ctx = struct pk_grbl_motion).
 *  The engine copies the table at init, so *ops may be a local. */
void pk_grbl_motion_ops(struct pk_grbl_machine_ops *ops);

/** Build the motion configuration the settings describe (for tests and tools). */
void pk_grbl_motion_cfg(const struct pk_grbl_settings *s, uint32_t tick_hz,
                        struct pk_motion_cfg *cfg);

/** The engine's NVM callbacks onto the HAL's nvm_read/nvm_write (hal.h);
 *  size 0 (no store) if the HAL has none. hal must outlive the engine. */
void pk_grbl_motion_nvm(const struct pk_hal *hal, struct pk_grbl_nvm *nvm);

#endif
