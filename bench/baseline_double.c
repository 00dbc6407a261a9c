/*
 * baseline_double.c — the implementation plotkin is measured against: the
 * straightforward way to write Chaikin's corner cutting in C. Doubles, the
 * whole polyline in memory, a new array per level (malloc) and the previous
 * one freed; the ends are kept, as chaikin-smooth and most libraries do.
 *
 *   baseline_double N DEPTH
 *
 * Same input (bench_common.h) and same output line as bench_refine
 * (outputs, seconds, maxrss_kb, checksum); baseline_chaikin is the callgrind
 * toggle and the timed region (the input array is built before it).
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "bench_common.h"

struct pt { double x, y; };

__attribute__((noinline)) static struct pt *baseline_chaikin(struct pt *in, size_t n, unsigned depth, size_t *n_out);

static struct pt *baseline_chaikin(struct pt *in, size_t n, unsigned depth, size_t *n_out)
{
    struct pt *cur = in;
    for (unsigned d = 0; d < depth; d++) {
        size_t m = 2 * (n - 1) + 2;
        struct pt *next = malloc(m * sizeof *next);
        if (!next) {
            fprintf(stderr, "baseline_double: out of memory\n");
            exit(1);
        }
        size_t k = 0;
        next[k++] = cur[0];
        for (size_t i = 0; i + 1 < n; i++) {
            next[k].x = 0.75 * cur[i].x + 0.25 * cur[i + 1].x;
            next[k].y = 0.75 * cur[i].y + 0.25 * cur[i + 1].y;
            k++;
            next[k].x = 0.25 * cur[i].x + 0.75 * cur[i + 1].x;
            next[k].y = 0.25 * cur[i].y + 0.75 * cur[i + 1].y;
            k++;
        }
        next[k++] = cur[n - 1];
        free(cur);
        cur = next;
        n = k;
    }
    *n_out = n;
    return cur;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: baseline_double N DEPTH\n");
        return 2;
    }
    size_t n = (size_t)strtol(argv[1], NULL, 10);
    unsigned depth = (unsigned)strtoul(argv[2], NULL, 10);
    struct pt *in = malloc(n * sizeof *in);
    struct bench_walk w;
    if (!in || n < 2)
        return 1;
    bench_walk_init(&w);
    for (size_t i = 0; i < n; i++) {
        int32_t x, y;
        bench_walk_next(&w, &x, &y);
        in[i].x = x;
        in[i].y = y;
    }
    struct timespec t0, t1;
    size_t m;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    struct pt *out = baseline_chaikin(in, n, depth, &m);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    int64_t sum = 0;
    for (size_t i = 0; i < m; i++)
        sum += (int64_t)out[i].x ^ (int64_t)out[i].y;
    free(out);
    printf("outputs=%zu seconds=%.6f maxrss_kb=%ld checksum=%lld\n", m,
           (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec), bench_peak_rss_kb(),
           (long long)sum);
    return 0;
}
