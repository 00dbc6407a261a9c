/*
 * pk_gpiod_port.h — the libgpiod-version-specific half of the gpiod backend
 * (private to hal/gpiod/).
 *
 * pk_gpiod.c (version-neutral: configuration, shadow levels, polarity masks,
 * error reporting, forwarding to the base HAL) calls only these
 * functions. gpiod_v1.c implements them on the libgpiod 1.x API; a
 * gpiod_v2.c on the 2.x API (gpiod_chip_request_lines,
 * gpiod_line_request_set_values) can implement the same ones, and the build
 * links one of them (pick with `pkg-config --modversion libgpiod`).
 *
 * Every function returns 0 or a negative errno value (never -1 with errno):
 * the caller needs the reason, and errno may be clobbered before it looks.
 * Calling context: the caller's (main loop, or the step timer for set).
 */
#ifndef PLOTKIN_PK_GPIOD_PORT_H
#define PLOTKIN_PK_GPIOD_PORT_H

#include "pk_gpiod.h"

/** Open the chip named by desc (name, path, number or label). */
int pk_gpiod_port_open(struct pk_gpiod_port *p, const char *desc);

/**
 * Request n (1..PK_HAL_MAX_AXES) lines of the open chip as one group of
 * outputs owned by consumer, with initial raw levels initial[0..n-1] (0/1).
 * On failure the group stays unrequested.
 */
int pk_gpiod_port_request(struct pk_gpiod_port *p, enum pk_gpiod_group g,
                          const uint32_t *offsets, unsigned n,
                          const char *consumer, const int *initial);

/** Set all lines of a requested group at once: values[i] for line i. */
int pk_gpiod_port_set(struct pk_gpiod_port *p, enum pk_gpiod_group g, const int *values);

/** Bias of the input lines (pk_gpiod_cfg.input_bias). */
enum pk_gpiod_bias {
    PK_GPIOD_BIAS_AS_IS = 0,
    PK_GPIOD_BIAS_PULL_UP = 1,
    PK_GPIOD_BIAS_PULL_DOWN = 2,
    PK_GPIOD_BIAS_DISABLE = 3
};

/**
 * Request n (1..PK_IN_COUNT) lines of the open chip as inputs owned by
 * consumer, with bias (enum pk_gpiod_bias); edges = 1: with both-edge
 * events, 0: plain inputs. On failure nothing stays requested.
 */
int pk_gpiod_port_request_inputs(struct pk_gpiod_port *p, const uint32_t *offsets, unsigned n,
                                 const char *consumer, int bias, int edges);

/** Read the requested input lines: values[i] for line i (0/1). */
int pk_gpiod_port_get_inputs(struct pk_gpiod_port *p, int *values);

/** Take (and discard) the pending edge events of the input lines without
 *  blocking, at most max of them. Returns how many were taken (0: none), or
 *  a negative errno. */
int pk_gpiod_port_take_events(struct pk_gpiod_port *p, unsigned max);

/** Release every requested group and close the chip; idempotent. */
void pk_gpiod_port_close(struct pk_gpiod_port *p);

#endif
