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
#include <string.h>
#include <sanitizer/asan_interface.h> /* no-op macros without ASan */

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


/** Longest copy fz_exact makes (the targets cap their inputs below it). */
#define FZ_EXACT_MAX 4096u
#define FZ_EXACT_PAD 64u

/**
 * An exact-length copy of s[0..n) without the heap: in static storage, slot
 * 0..3, valid until the next fz_exact with that slot. Under ASan every byte
 * around the copy is poisoned, so reading one byte before or past it is
 * reported as an overflow, as for an exact-size malloc (the copy starts
 * 8-aligned and ASan marks the end of a region exactly). n > FZ_EXACT_MAX is
 * a harness bug and aborts.
 */
static inline uint8_t *fz_exact(unsigned slot, const uint8_t *s, size_t n)
{
    static _Alignas(64) uint8_t pool[4][FZ_EXACT_PAD + FZ_EXACT_MAX + FZ_EXACT_PAD];
    if (slot >= 4u || n > FZ_EXACT_MAX) {
        fprintf(stderr, "fz_exact: slot %u, %zu bytes: harness limit\n", slot, n);
        abort();
    }
    uint8_t *b = pool[slot];
    ASAN_UNPOISON_MEMORY_REGION(b + FZ_EXACT_PAD, n);
    ASAN_POISON_MEMORY_REGION(b, FZ_EXACT_PAD);
    ASAN_POISON_MEMORY_REGION(b + FZ_EXACT_PAD + n, FZ_EXACT_MAX + FZ_EXACT_PAD - n);
    if (n)
        memcpy(b + FZ_EXACT_PAD, s, n);
    return b + FZ_EXACT_PAD;
}

#endif
