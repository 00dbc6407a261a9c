/*
 * th — plotkin's tiny test harness.
 *
 * Needs no libc: output goes through th_write(), which each platform supplies
 * (tests/th_host.c on the host, a semihosting stub on the Cortex-M target), so
 * the very same test sources run on the PC and on an emulated microcontroller.
 * A test program lists its cases and calls th_run(); the closing line is always
 * "N passed, N failed". A case passes when none of its checks fails.
 *
 * Test names are sentences: say what a user relies on.
 */
#ifndef PLOTKIN_TH_H
#define PLOTKIN_TH_H

#include <stdint.h>

typedef void (*th_fn)(void);
struct th_case { const char *name; th_fn fn; };
#define TH_CASE(fn) { #fn, fn }

/** Platform hook: write a NUL-terminated string. */
void th_write(const char *s);

/** Each test program defines this; the platform's main() calls it. */
int th_main(int argc, char **argv);

/** Run the cases; returns the number of failed cases. */
int th_run(const struct th_case *cases, unsigned n);

/* Low-level reporting (use the macros below). Each returns cond. */
int th_check(int cond, const char *file, int line, const char *expr);
int th_check_i64(int64_t a, int64_t b, const char *file, int line, const char *ea, const char *eb);
void th_fail(const char *file, int line, const char *msg);
/** Print helpers for diagnostics. */
void th_print_i64(int64_t v);
void th_print(const char *s);

#define TH_ASSERT(c) do { if (!th_check(!!(c), __FILE__, __LINE__, #c)) return; } while (0)
#define TH_EXPECT(c) ((void)th_check(!!(c), __FILE__, __LINE__, #c))
#define TH_ASSERT_EQ(a, b) do { if (!th_check_i64((int64_t)(a), (int64_t)(b), __FILE__, __LINE__, #a, #b)) return; } while (0)
#define TH_EXPECT_EQ(a, b) ((void)th_check_i64((int64_t)(a), (int64_t)(b), __FILE__, __LINE__, #a, #b))

#define TH_COUNT(a) ((unsigned)(sizeof(a) / sizeof((a)[0])))

/** Marsaglia's xorshift64 (13, 7, 17): the tests' reproducible pseudo-random
 *  operands. Advances *state (never 0) and returns it. */
static inline uint64_t th_xorshift64(uint64_t *state)
{
    uint64_t x = *state;
    x ^= x << 13;
    x ^= x >> 7;
    x ^= x << 17;
    return *state = x;
}

#endif
