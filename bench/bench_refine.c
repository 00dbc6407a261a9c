/*
 * bench_refine.c — host throughput of the subdivision kernel.
 *
 *   bench_refine N DEPTH [chaikin|cubic|dlg] [point|block|write]
 *
 * Streams N points of the shared random walk (bench_common.h) through one
 * pk_refine stream (open stroke, default end rule, 2 dims):
 *   point  one pk_refine_pull per output point, each consumed into a checksum,
 *          as the motion core's pull loop does (the default);
 *   block  pk_refine_pull_block, asking for up to BENCH_BLOCK points a call,
 *          into one output array that holds the whole result (allocated and
 *          touched before the clock starts);
 *   write  no kernel: the bound for "block", one memset of the same array
 *          (what merely writing the output to memory costs).
 * In point mode nothing is stored, so the memory does not depend on N; the
 * other two hold the output array (8 bytes per point).
 * Prints one line of key=value pairs: outputs, seconds (wall clock of
 * bench_kernel_run only), maxrss_kb, checksum. bench_kernel_run is also the
 * callgrind toggle (instructions counted there only). Host tool: libc allowed.
 */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "bench_common.h"
#include "pk_refine.h"

#define BENCH_BLOCK 4096

struct bench_result { uint64_t outputs; int64_t checksum; };

enum { MODE_POINT, MODE_BLOCK, MODE_WRITE };

__attribute__((noinline)) static struct bench_result bench_kernel_run(long n, unsigned depth, unsigned scheme,
                                                                      unsigned degree, int mode);

static pk_um_t *buf;      /* block/write: the output array */
static uint64_t buf_pts;  /* its size in points */
/* Called through a volatile pointer, so the compiler cannot drop the writes. */
static void *(*volatile bench_memset)(void *, int, size_t) = memset;

static void drain(struct pk_refine *r, int mode, struct bench_result *res)
{
    if (mode == MODE_POINT) {
        struct pk_refine_out out;
        while (pk_refine_pull(r, &out) == PK_OK) {
            res->checksum += out.p[0] ^ out.p[1];
            res->outputs++;
        }
        return;
    }
    uint32_t got;
    for (;;) {
        uint64_t room = buf_pts - res->outputs;
        pk_um_t *p = buf + 2 * res->outputs;
        if (pk_refine_pull_block(r, p, NULL, room < BENCH_BLOCK ? (uint32_t)room : BENCH_BLOCK, &got) != PK_OK)
            break;
        res->checksum += p[0] ^ p[2 * got - 1];
        res->outputs += got;
    }
}

static struct bench_result bench_kernel_run(long n, unsigned depth, unsigned scheme, unsigned degree, int mode)
{
    static struct pk_refine r;
    struct pk_refine_cfg cfg;
    struct bench_walk w;
    struct bench_result res = { 0, 0 };
    if (mode == MODE_WRITE) {
        bench_memset(buf, 0x5A, (size_t)buf_pts * 2 * sizeof buf[0]);
        res.checksum = buf[0] ^ buf[2 * buf_pts - 1];
        res.outputs = buf_pts;
        return res;
    }
    memset(&cfg, 0, sizeof cfg);
    cfg.scheme = (uint8_t)scheme;
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
        drain(&r, mode, &res);
    }
    pk_refine_finish(&r);
    drain(&r, mode, &res);
    return res;
}

int main(int argc, char **argv)
{
    if (argc < 3) {
        fprintf(stderr, "usage: bench_refine N DEPTH [chaikin|cubic|dlg] [point|block|write]\n");
        return 2;
    }
    long n = strtol(argv[1], NULL, 10);
    unsigned depth = (unsigned)strtoul(argv[2], NULL, 10);
    const char *sch = argc > 3 ? argv[3] : "chaikin", *md = argc > 4 ? argv[4] : "point";
    unsigned scheme = !strcmp(sch, "dlg") ? PK_SCHEME_DLG : PK_SCHEME_BSPLINE;
    unsigned degree = !strcmp(sch, "cubic") ? 3 : 2;
    int mode = !strcmp(md, "block") ? MODE_BLOCK : !strcmp(md, "write") ? MODE_WRITE : MODE_POINT;
    if (n < 2 || depth > PK_MAX_DEPTH) {
        fprintf(stderr, "bench_refine: N >= 2 and DEPTH <= %d\n", PK_MAX_DEPTH);
        return 2;
    }
    if (mode != MODE_POINT) {
        /* room for every output (at most 2^depth per input point, plus 2) */
        buf_pts = ((uint64_t)n << depth) + 2;
        buf = malloc((size_t)buf_pts * 2 * sizeof *buf);
        if (!buf) {
            fprintf(stderr, "bench_refine: out of memory\n");
            return 1;
        }
        memset(buf, 0, (size_t)buf_pts * 2 * sizeof *buf); /* fault the pages in now */
        if (mode == MODE_WRITE) /* exactly the bytes the block pull writes */
            buf_pts = ((uint64_t)(n - 2) << depth) + 2;
    }
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    struct bench_result res = bench_kernel_run(n, depth, scheme, degree, mode);
    clock_gettime(CLOCK_MONOTONIC, &t1);
    printf("outputs=%llu seconds=%.6f maxrss_kb=%ld checksum=%lld\n", (unsigned long long)res.outputs,
           (double)(t1.tv_sec - t0.tv_sec) + 1e-9 * (double)(t1.tv_nsec - t0.tv_nsec), bench_peak_rss_kb(),
           (long long)res.checksum);
    return 0;
}
