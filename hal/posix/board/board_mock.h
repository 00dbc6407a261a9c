/*
 * board_mock.h — the mock GPIO chip of the board binary's test variant,
 * build/plotkin-gpiod-mock (hal/module.mk; never the board binary itself).
 *
 * That variant is hal/posix/board/plotkin_gpiod.c compiled with
 * -DPLOTKIN_GPIOD_MOCK and linked with host-sim/gpiod_mock.c instead of
 * -lgpiod: the same gpiod backend object code, the same POSIX real-time loop
 * and the same Grbl engine as on a Raspberry Pi, with a link-time libgpiod
 * whose chip (named as the board file's `chip`) exists only in memory. Every
 * line change is recorded with the REAL time it was written
 * (CLOCK_MONOTONIC, ns since the loop's tick 0) and, for a change written by
 * a step-timer callback, the time that callback was scheduled for (its tick
 * in ns): the pair is the step timing error the benchmark reports, and the
 * edges are what the serve test decodes into steps.
 *
 * Trace file (text, written at the end so no I/O runs in the step loop):
 *     # plotkin-gpiod mock trace v1: t_ns due_ns line level initial
 *     <t_ns> <due_ns or -1 outside a callback> <line offset> <0|1> <1: level at request>
 * Host only (heap, stdio). One per process; caller-owned struct.
 */
#ifndef PLOTKIN_BOARD_MOCK_H
#define PLOTKIN_BOARD_MOCK_H

#include <stddef.h>
#include <stdint.h>
#include "gpiod/pk_gpiod.h"
#include "gpiod_mock.h"
#include "posix/pk_posix_timer.h"

struct pk_board_mock_edge {
    uint64_t t_ns;    /**< written, real clock */
    int64_t due_ns;   /**< scheduled time of the callback that wrote it; -1 outside one */
    uint8_t line, level, initial;
};

struct pk_board_mock {
    struct pk_gpiod_mock chip;
    const struct pk_posix_timer *timer;
    struct pk_board_mock_edge *e; /**< heap */
    size_t n, cap;
    size_t lost;                  /**< edges not recorded (out of memory): the trace is void */
};

/**
 * Register a mock chip named cfg->chip with 64 lines, recording on t's clock.
 * Call before pk_gpiod_open, after pk_posix_timer_init. 0, or -1 with err.
 */
int pk_board_mock_attach(struct pk_board_mock *b, const struct pk_gpiod_cfg *cfg,
                         const struct pk_posix_timer *t, char *err, size_t errlen);

/**
 * Write the trace to path (if not NULL), unregister, free. 0, or -1 with
 * err (write failure, or edges lost for memory: the trace would lie).
 */
int pk_board_mock_finish(struct pk_board_mock *b, const char *path, char *err, size_t errlen);

#endif
