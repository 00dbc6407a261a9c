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
 *
 * Inputs (pk_rec_inputs): input lines whose raw levels follow a script of
 * edges on the simulated clock ("at tick T line L goes to level V") or
 * switches at a position along an axis (a limit switch or a probe that is
 * active while the axis, as decoded from the step/dir writes, is at or
 * beyond a step count). Changes are reported through the registered edge
 * callback as a pin-change interrupt would: a scripted edge at its tick
 * (before a timer callback due at the same tick), a switch right after the
 * timer callback whose step moved it (never inside it). Without edges
 * (edges = 0) input_watch answers PK_HAL_ENOSYS and the core reads the levels.
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

/** A scripted raw level change of an input line. */
struct pk_rec_in_edge {
    uint64_t tick;
    uint8_t line;      /* enum pk_hal_input */
    uint8_t level;     /* raw level from then on */
};

/** A switch along an axis: active while the axis is at or beyond at_steps
 *  (side +1: pos >= at_steps; side -1: pos <= at_steps). */
struct pk_rec_switch {
    uint8_t line;      /* enum pk_hal_input */
    uint8_t axis;
    int8_t side;
    int32_t at_steps;
};

#define PK_REC_SWITCHES 8
#define PK_REC_IN_EDGES 64

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
    /* inputs (pk_rec_inputs) */
    int64_t pos[PK_HAL_MAX_AXES]; /* axis positions decoded from the step/dir writes */
    uint32_t in_raw;              /* raw input levels now */
    int in_edges;                 /* input_watch works (else it answers PK_HAL_ENOSYS) */
    pk_hal_input_cb in_cb;        /* registered edge callback, or NULL */
    void *in_arg;
    int in_pending;               /* a switch changed inside a timer callback */
    struct pk_rec_in_edge in_script[PK_REC_IN_EDGES]; /* in tick order */
    size_t n_script, i_script;
    struct pk_rec_switch sw[PK_REC_SWITCHES];
    size_t n_sw;
    uint64_t input_reads;         /* input_read calls */
    uint64_t input_reports;       /* edge callbacks made */
    long in_fail_after;           /* -1: never; else input reads left before failing */
};

/** Initialise with tick_hz; all lines low, no failure, logging on. */
void pk_rec_init(struct pk_rec *r, uint32_t tick_hz);
/** Free the log. */
void pk_rec_free(struct pk_rec *r);
/** Run timer callbacks with tick <= until; the clock ends at until. */
void pk_rec_advance(struct pk_rec *r, uint64_t until);
/** True while the timer is armed. */
int pk_rec_armed(const struct pk_rec *r);

/** Give the HAL input lines: inputs / invert as struct pk_hal.inputs and
 *  .input_invert, every line inactive; edges = 1: with input_watch (edge
 *  reports), 0: without (the core reads). Call before pk_machine_init. */
void pk_rec_inputs(struct pk_rec *r, uint32_t inputs, uint32_t invert, int edges);
/** Script input line `line` to take LOGICAL level `active` at tick t (ticks
 *  must not decrease from call to call). Returns 0, or -1 if the script is full. */
int pk_rec_input_at(struct pk_rec *r, uint64_t t, unsigned line, int active);
/** Add a switch (see struct pk_rec_switch); its line's level follows it
 *  from now on. Returns 0, or -1 if full. */
int pk_rec_add_switch(struct pk_rec *r, unsigned line, unsigned axis, int side, int32_t at_steps);

#endif
