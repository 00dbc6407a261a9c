/*
 * hal_record.h — a recording HAL double on a simulated clock (host only).
 *
 * Implements struct pk_hal_ops by writing every pin change into a growing
 * log (tick, kind, mask, raw levels) and keeping the step timer as "armed
 * callback + next tick". pk_rec_advance() plays the timer forward on the
 * simulated clock, calling the callback exactly at the ticks it asks for, so
 * runs are repeatable and independent of the host's speed. Failures can be
 * injected per kind after a number of successful writes. Reusable by any
 * test or simulator that wants to look at the pulses a core emitted.
 */
#ifndef PLOTKIN_HAL_RECORD_H
#define PLOTKIN_HAL_RECORD_H

#include <stddef.h>
#include <stdint.h>
#include "hal.h"

enum pk_rec_kind { PK_REC_STEP = 0, PK_REC_DIR, PK_REC_ENABLE, PK_REC_TOOL, PK_REC_SPINDLE, PK_REC_KINDS };

struct pk_rec_event {
    uint64_t tick;
    uint8_t kind;      /* enum pk_rec_kind */
    uint32_t mask;     /* lines written */
    uint32_t levels;   /* raw levels of those lines */
};

struct pk_rec {
    struct pk_hal hal;            /* ready to pass to the core (ops/ctx filled in) */
    uint64_t now;                 /* simulated clock, ticks */
    pk_hal_timer_cb cb;           /* armed callback, or NULL */
    void *cb_arg;
    uint64_t next;                /* tick of the next callback */
    uint32_t raw[PK_REC_KINDS];   /* current raw levels per kind */
    struct pk_rec_event *ev;      /* log (malloc'd) */
    size_t n, cap;
    int record;                   /* 0: keep levels and counts but no log */
    long fail_after[PK_REC_KINDS];/* -1: never; else writes left before failing */
    uint64_t attempts[PK_REC_KINDS]; /* writes attempted (failed ones included) */
    uint64_t callbacks;           /* callbacks made */
    int reentered;                /* set if the callback was re-entered (bug) */
};

/** Initialise with tick_hz; all lines low, no failure, logging on. */
void pk_rec_init(struct pk_rec *r, uint32_t tick_hz);
/** Free the log. */
void pk_rec_free(struct pk_rec *r);
/** Run timer callbacks with tick <= until; the clock ends at until. */
void pk_rec_advance(struct pk_rec *r, uint64_t until);
/** True while the timer is armed. */
int pk_rec_armed(const struct pk_rec *r);

#endif
