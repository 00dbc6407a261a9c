/*
 * bench_common.h — what the C benchmark programs share: the input and the
 * peak-memory probe.
 *
 * The input, identical in every implementation
 * (bench/peers.mjs computes the same sequence): a 2-D random walk in whole
 * micrometres, steps of -1000..+1000 µm per axis from xorshift32, reflected
 * at ±1 m. Generated point by point, so a streaming consumer never needs the
 * whole polyline in memory. Host-only.
 */
#ifndef PLOTKIN_BENCH_COMMON_H
#define PLOTKIN_BENCH_COMMON_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct bench_walk { uint32_t s; int32_t x, y; };

static inline void bench_walk_init(struct bench_walk *w) { w->s = 0x12345678u; w->x = 0; w->y = 0; }

static inline int32_t bench_walk_step(struct bench_walk *w, int32_t v)
{
    uint32_t s = w->s;
    s ^= s << 13;
    s ^= s >> 17;
    s ^= s << 5;
    w->s = s;
    v += (int32_t)(s % 2001u) - 1000;
    if (v > 1000000)
        v = 2000000 - v;
    if (v < -1000000)
        v = -2000000 - v;
    return v;
}

/** Next point of the walk (x then y each take one random number). */
static inline void bench_walk_next(struct bench_walk *w, int32_t *x, int32_t *y)
{
    w->x = bench_walk_step(w, w->x);
    w->y = bench_walk_step(w, w->y);
    *x = w->x;
    *y = w->y;
}

/**
 * Peak resident set of this process in kB (VmHWM). Not getrusage's
 * ru_maxrss: that survives execve, so a small program started by a big
 * parent (the Python driver) would report the parent's size.
 */
static inline long bench_peak_rss_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    if (!f)
        return -1;
    while (fgets(line, sizeof line, f))
        if (!strncmp(line, "VmHWM:", 6))
            kb = strtol(line + 6, NULL, 10);
    fclose(f);
    return kb;
}

#endif
