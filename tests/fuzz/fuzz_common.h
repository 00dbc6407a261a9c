/*
 * fuzz_common.h — shared helpers of plotkin's fuzz targets (tests/fuzz/).
 *
 * Every target is a libFuzzer entry point, LLVMFuzzerTestOneInput, that
 * decodes the fuzzer's bytes into a sequence of API calls and checks the
 * module's documented invariants after each, not only "no crash". A broken
 * invariant prints what and where, then aborts, which libFuzzer reports as a
 * crash and saves as an artifact; the same input, kept in
 * tests/fuzz/corpus/<target>/, then replays in `make test` through
 * replay_main.c (built with the ordinary compiler, plain and sanitized).
 *
 * Host-only test code: libc and stdio are fine here.
 */
#ifndef PLOTKIN_FUZZ_COMMON_H
#define PLOTKIN_FUZZ_COMMON_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

/** Break an invariant: report it and abort (libFuzzer saves the input). */
#define FZ_CHECK(cond, what)                                                              \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: invariant broken: %s (%s)\n", __FILE__, __LINE__,     \
                    (what), #cond);                                                       \
            abort();                                                                      \
        }                                                                                 \
    } while (0)

/** The fuzzer's bytes as a stream; reading past the end gives zeros. */
struct fz_in {
    const uint8_t *p;
    size_t n, i;
};

static inline int fz_more(const struct fz_in *in) { return in->i < in->n; }

static inline uint8_t fz_u8(struct fz_in *in) { return in->i < in->n ? in->p[in->i++] : 0u; }

static inline uint16_t fz_u16(struct fz_in *in)
{
    uint16_t lo = fz_u8(in);
    return (uint16_t)(lo | (uint16_t)(fz_u8(in) << 8));
}

static inline uint32_t fz_u32(struct fz_in *in)
{
    uint32_t lo = fz_u16(in);
    return lo | ((uint32_t)fz_u16(in) << 16);
}

#endif
