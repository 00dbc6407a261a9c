/*
 * bench_refine.c — host throughput of the subdivision kernel.
 *
 *   bench_refine N DEPTH [chaikin|cubic]
 *
 * Streams N points of the shared random walk (bench_common.h) through one
 * pk_refine stream (open stroke, default end rule, 2 dims) and consumes each
 * output into a checksum, as a motion queue would: nothing is stored, so the
 * memory does not depend on N. Prints one line of key=value pairs: outputs,
 * seconds (wall clock of bench_kernel_run only), maxrss_kb, checksum.
 * bench_kernel_run is also the callgrind toggle (instructions counted there
 * only). Host tool: libc allowed.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "bench_common.h"
#include "pk_refine.h"

struct bench_result { uint64_t outputs; int64_t checksum; };

__attribute__((noinline)) static struct bench_result bench_kernel_run(long n, unsigned depth, unsigned degree);

static struct bench_result bench_kernel_run(long n, unsigned depth, unsigned degree)
{
    static struct pk_refine r;
    struct pk_refine_cfg cfg;
    struct pk_refine_out out;
    struct bench_walk w;
    struct bench_result res = { 0, 0 };
    memset(&cfg, 0, sizeof cfg);
    cfg.scheme = PK_SCHEME_BSPLINE;
    cfg.degree = (uint8_t)degree;
    cfg.depth = (uint8_t)depth;
    cfg.dims = 2;
    if (pk_refine_init(&r, &cfg) != PK_OK) {
        fprintf(stderr, "bench_refine: init failed\n");
        exit(1);
    }
    bench_walk_init(&w);
    for (long i = 0; i < n; i++) {
        pk_um_t p[PK_AXES] = { 0 };
        bench_walk_next(&w, &p[0], &p[1]);
        if (pk_refine_push(&r, p) != PK_OK) {
            fprintf(stderr, "bench_refine: push refused\n");
            exit(1);
        }
        while (pk_refine_pull(&r, &out) == PK_OK) {
            res.checksum += out.p[0] ^ out.p[1];
            res.outputs++;
        }
    }
    pk_refine_finish(&r);
    while (pk_refine_pull(&r, &out) == PK_OK) {
        res.checksum += out.p[0] ^ out.p[1];
        res.outputs++;
    }
    return res;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: bench_refine N DEPTH [chaikin|cubic]\n");
        return 2;
    }
    long n = strtol(argv[1], NULL, 10);
    unsigned depth = (unsigned)strtoul(argv[2], NULL, 10);
    unsigned degree = (argc > 3 && !strcmp(argv[3], "cubic")) ? 3 : 2;
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    struct bench_result res = bench_kernel_run(n, depth, degree);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    printf("outputs=%llu seconds=%.6f maxrss_kb=%ld checksum=%lld\n", (unsigned long long)res.outputs,
           (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec), bench_peak_rss_kb(),
           (long long)res.checksum);
    return 0;
}
