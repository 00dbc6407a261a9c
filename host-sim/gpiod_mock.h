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
 */
#ifndef PLOTKIN_GPIOD_MOCK_H
#define PLOTKIN_GPIOD_MOCK_H

#include <stdint.h>
#include <gpiod.h>

#define PK_GPIOD_MOCK_LINES 64

/* libgpiod v1 declares these without a body; the mock gives them one. */
struct gpiod_line {
    struct gpiod_chip *chip;
    unsigned int offset;
    int value;              /**< last level driven (0 before any request) */
    unsigned int handle;    /**< request id; 0 = not requested */
    unsigned int pos;       /**< position within its request */
    char consumer[32];
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
    uint32_t open, get_lines, request, set, release, close;
};

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

    /* -- observation (read-only for users) -- */
    struct pk_gpiod_mock_calls calls;
    uint32_t set_failures;      /**< set calls that failed (any reason) */
    uint32_t sets_ok;           /**< set calls that succeeded */
    uint32_t sets_ok_after_failure; /**< successful sets after the first failed one */
    uint64_t first_failure_tick;    /**< clock at the first failed set */
    uint32_t changes;           /**< line value changes by writes */
    uint32_t requested;         /**< lines currently requested */
    uint8_t is_open;

    /* -- private -- */
    unsigned int next_handle;
    struct gpiod_chip chip;
    struct gpiod_line line[PK_GPIOD_MOCK_LINES];
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

#endif
