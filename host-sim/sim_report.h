/*
 * sim_report.h — the text summary of a simulated machine's run (host only):
 * smoothing policy, run status, lines, moves and executed segments, steps and
 * final position decoded from the pins, simulated time, per axis the max
 * speed over any 16 and any 2 steps and the acceleration (sim_rate.h: each
 * with the least value the step quantisation allows, and the axes proven
 * over their limits), the deviation from the programmed path and from the
 * smoothed curve if fed (sim_path.h: max, where, 95th percentile), timing
 * violations against the driver's limits, G-code errors and alarms.
 *
 * One printer for every command that runs the simulated machine: `plotkin
 * sim` after a program, `plotkin serve` when it stops (SIGINT/SIGTERM), so
 * both report the same figures measured the same way.
 */
#ifndef PLOTKIN_SIM_REPORT_H
#define PLOTKIN_SIM_REPORT_H

#include <stdio.h>
#include "sim_run.h"

/**
 * Print the summary lines of a finished run (after pk_sim_finish) to f, each
 * indented by two spaces (the caller prints the heading line). axes: the
 * axes to show; c: the settings to describe the smoothing with; driver: the
 * name of the timing limits that were checked.
 */
void pk_sim_print_summary(FILE *f, const struct pk_sim_result *r, unsigned axes,
                          const struct pk_sim_cfg *c, const char *driver);

/** "finished", "stuck: ...", ... for r->run_status (negative: still live). */
const char *pk_sim_run_status_name(int run_status);

/** Short name of an enum pk_alarm ("none" for 0). */
const char *pk_sim_alarm_name(int alarm);

#endif
