/*
 * sim_inputs.h — the input options of `plotkin sim`: scripted input edges and
 * switches along the axes, from the command line into the simulated
 * machine's struct pk_sim_input list (sim_machine.h).
 *
 *   --input T:NAME=V     at T seconds the input NAME takes logical level V (0/1)
 *   --switch NAME:AXIS:MM[:-]
 *                        NAME is active while AXIS is at MM or beyond it
 *                        (beyond = above; with ":-", below)
 *   NAME: limit-x limit-y limit-z limit-a probe door hold resume reset
 *
 * Host-only code.
 */
#ifndef PLOTKIN_SIM_INPUTS_H
#define PLOTKIN_SIM_INPUTS_H

#include <stddef.h>
#include <stdint.h>
#include "sim_machine.h"

#define PK_SIM_INPUTS_MAX 64

/** The options as given (positions in mm until resolved). */
struct pk_sim_inputs {
    struct pk_sim_input in[PK_SIM_INPUTS_MAX];
    double t_s[PK_SIM_INPUTS_MAX];   /**< edge: seconds */
    double at_mm[PK_SIM_INPUTS_MAX]; /**< switch: position, mm */
    size_t n;
};

/** Usage lines for the two options. */
extern const char pk_sim_inputs_usage[];

/** Input number of a name ("limit-x", "probe", ...), or -1. */
int pk_sim_input_by_name(const char *name);

/**
 * Add one option: opt is "--input" or "--switch", val its argument. Returns
 * 0, or -1 with the reason in err (a bad name, axis, number or too many).
 */
int pk_sim_inputs_add(struct pk_sim_inputs *s, const char *opt, const char *val, char *err,
                      size_t errlen);

/** Turn seconds into ticks and mm into steps (round half away from zero). */
void pk_sim_inputs_resolve(struct pk_sim_inputs *s, uint32_t tick_hz, const double steps_per_mm[3]);

#endif
