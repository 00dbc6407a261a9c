/*
 * gpiod_mock.h — a link-time stand-in for libgpiod 1.x, for the simulator
 * and the tests.
 *
 * gpiod_mock.c defines exactly the gpiod_* functions the gpiod backend
 * (hal/gpiod/gpiod_v1.c) calls, against the real <gpiod.h>, so the compiler
 * checks every prototype. The backend's object code is the same one that is
 * linked with -lgpiod on a real board.
 *
 * A mock chip is caller-owned storage (struct pk_gpiod_mock) registered under
 * a name; gpiod_chip_open_lookup(name) finds it. Each chip keeps its own
 * lines, counters and fault plan, so several simulated machines (one chip
 * each) run side by side in one process without cross-talk. The registry of
 * chips is the only process-wide state (a list of caller-owned chips).
 *
 * Faithful where it matters: setting an unrequested line fails with EPERM,
 * requesting a requested line with EBUSY, an unknown chip with ENOENT, a bad
 * offset with EINVAL. Stricter than the library in one respect: a bulk write
 * must be exactly the lines of one request in request order (EINVAL
 * otherwise), because v1 silently applies the values to the request's lines
 * by position — a backend relying on anything else would drive wrong pins.
 *
 * Observation: every line value change (and the level each line takes when
 * requested) goes to a sink with the time read from a clock callback — the
 * simulated clock in the simulator. Single-threaded use only.
 *
 * Inputs: the outside world drives a line with pk_gpiod_mock_input_set (a
 * switch, a probe) or by a script on the clock (pk_gpiod_mock_input_at, "at
 * tick T line L goes to level V", applied by pk_gpiod_mock_input_advance). A
 * line requested with edge events queues one event per change (at most 16
 * per line, as the kernel's FIFO; more are dropped and counted), read with
 * gpiod_line_event_wait_bulk / gpiod_line_event_read. Unlike the library,
 * those never block: a wait with nothing queued returns 0 at once, a read
 * with nothing queued fails with EAGAIN (the simulator has nothing that
 * could change a line while it waits). An event's ts holds the clock's tick
 * as nanoseconds. Writing an input line fails with EPERM.
 */
#ifndef PLOTKIN_GPIOD_MOCK_H
#define PLOTKIN_GPIOD_MOCK_H

#include <stdint.h>
#include <gpiod.h>

#define PK_GPIOD_MOCK_LINES 64

/* libgpiod v1 declares these without a body; the mock gives them one. */
#define PK_GPIOD_MOCK_EVQ 16

struct gpiod_line {
    struct gpiod_chip *chip;
    unsigned int offset;
    int value;              /**< last level driven (0 before any request); for an
                                 input, the level the outside world drives */
    unsigned int handle;    /**< request id; 0 = not requested */
    unsigned int pos;       /**< position within its request */
    char consumer[32];
    uint8_t is_input;       /**< requested as an input */
    uint8_t events;         /**< requested with both-edge events */
    uint8_t evq_n;          /**< events queued */
    uint8_t evq_type[PK_GPIOD_MOCK_EVQ];  /**< GPIOD_LINE_EVENT_* */
    uint64_t evq_t[PK_GPIOD_MOCK_EVQ];    /**< tick */
};
struct gpiod_chip {
    struct pk_gpiod_mock *mock;
};

/** Simulated time source: returns the current tick. */
typedef uint64_t (*pk_gpiod_mock_clock_fn)(void *arg);

/** Event sink: line `offset` took `value` at tick t. `initial` is 1 for the
 *  level a line takes when requested (reported even if unchanged), 0 for a
 *  change by a write. */
typedef void (*pk_gpiod_mock_sink_fn)(void *arg, unsigned int offset, int value, uint64_t t,
                                      int initial);

/** Calls seen, failed ones included. */
struct pk_gpiod_mock_calls {
    uint32_t open, get_lines, request, set, release, close, get, wait, read;
};

/** A scripted input change. */
struct pk_gpiod_mock_in_edge {
    uint64_t t;
    uint8_t offset;
    uint8_t level;
};
#define PK_GPIOD_MOCK_SCRIPT 64

struct pk_gpiod_mock {
    /* -- set by pk_gpiod_mock_init, may be changed before registering -- */
    char name[32];              /**< chip name for gpiod_chip_open_lookup */
    unsigned int num_lines;     /**< <= PK_GPIOD_MOCK_LINES */
    pk_gpiod_mock_clock_fn clock;
    void *clock_arg;
    pk_gpiod_mock_sink_fn sink;
    void *sink_arg;

    /* -- fault plan (0 = never); may be changed at any time -- */
    int fail_open_errno;        /**< opening this chip fails with this errno */
    uint32_t fail_request_nth;  /**< the Nth request call (1-based) fails */
    int fail_request_errno;     /**< errno for it (0: EBUSY) */
    uint32_t fail_set_nth;      /**< the Nth set call (1-based) fails */
    int fail_set_errno;         /**< errno for it (0: EIO) */
    uint8_t fail_set_sticky;    /**< 1: every set call from the Nth on fails */
    int fail_get_errno;         /**< while non-zero: every get (input read) fails with it */
    int fail_wait_errno;        /**< while non-zero: every event wait fails with it */

    /* -- observation (read-only for users) -- */
    struct pk_gpiod_mock_calls calls;
    uint32_t set_failures;      /**< set calls that failed (any reason) */
    uint32_t sets_ok;           /**< set calls that succeeded */
    uint32_t sets_ok_after_failure; /**< successful sets after the first failed one */
    uint64_t first_failure_tick;    /**< clock at the first failed set */
    uint32_t changes;           /**< line value changes by writes */
    uint32_t requested;         /**< lines currently requested */
    uint32_t events_queued;     /**< input edge events queued since init */
    uint32_t events_dropped;    /**< ... and dropped for a full queue */
    uint8_t is_open;

    /* -- private -- */
    unsigned int next_handle;
    struct gpiod_chip chip;
    struct gpiod_line line[PK_GPIOD_MOCK_LINES];
    struct pk_gpiod_mock_in_edge script[PK_GPIOD_MOCK_SCRIPT];
    unsigned int n_script, i_script;
    struct pk_gpiod_mock *next;
};

/** Reset *m to a closed chip of num_lines lines named name (truncated to 31),
 *  no clock, no sink, no faults. Does not register it. */
void pk_gpiod_mock_init(struct pk_gpiod_mock *m, const char *name, unsigned int num_lines);

/** Make m findable by gpiod_chip_open_lookup(name). Returns 0, or -1 if a chip
 *  of that name is already registered. m must stay valid until unregistered. */
int pk_gpiod_mock_register(struct pk_gpiod_mock *m);

/** Remove m from the registry (closing it first if open). Idempotent. */
void pk_gpiod_mock_unregister(struct pk_gpiod_mock *m);

/** Level last driven on a line (0 if never requested); -1 if out of range. */
int pk_gpiod_mock_value(const struct pk_gpiod_mock *m, unsigned int offset);

/** Consumer name of a requested line, NULL if not requested. */
const char *pk_gpiod_mock_consumer(const struct pk_gpiod_mock *m, unsigned int offset);

/** Drive line `offset` from outside to `level` now (clock): an input line
 *  requested with events queues an edge event if the level changes. A line
 *  requested as an output is not driven from outside: -1. 0 otherwise. */
int pk_gpiod_mock_input_set(struct pk_gpiod_mock *m, unsigned int offset, int level);

/** Script a change: at tick t line `offset` goes to `level` (t must not
 *  decrease from call to call). 0, or -1 if the script is full or t decreases. */
int pk_gpiod_mock_input_at(struct pk_gpiod_mock *m, uint64_t t, unsigned int offset, int level);

/** Apply every scripted change due at or before now (in order). */
void pk_gpiod_mock_input_advance(struct pk_gpiod_mock *m, uint64_t now);

/** Tick of the next scripted change, UINT64_MAX if none. */
uint64_t pk_gpiod_mock_input_next(const struct pk_gpiod_mock *m);

/** Edge events queued on the chip's lines and not yet read. */
uint32_t pk_gpiod_mock_events_pending(const struct pk_gpiod_mock *m);

#endif
