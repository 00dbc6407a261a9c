/*
 * chaikin_image.c — the smallest useful program around the kernel: one
 * Chaikin stream with limit masks, fed and drained in a loop. Linked for the
 * Cortex-M0+ with --gc-sections by `make targets`, whose report reads the
 * linker map and gives the flash the kernel really costs in such a product.
 * The configuration is read through volatile objects so that the compiler
 * cannot specialise the kernel for it: what is measured is the kernel as a
 * library, with Chaikin+limit selected at run time. Never run.
 */
#include <stdint.h>
#include "pk_refine.h"

int th_main(int argc, char **argv);
void th_write(const char *s);

static volatile pk_um_t pk_img_in[PK_AXES];
static volatile pk_um_t pk_img_sink;
static volatile uint8_t pk_img_depth = 4;
static volatile uint8_t pk_img_closed = 1; /* open Chaikin+limit: PK_ENOTSUP in this kernel version */

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    struct pk_refine r;
    struct pk_refine_cfg cfg = { 0 };
    struct pk_refine_out out;
    cfg.scheme = PK_SCHEME_BSPLINE;
    cfg.degree = 2;
    cfg.depth = pk_img_depth;
    cfg.limit = 1;
    cfg.closed = pk_img_closed;
    if (pk_refine_init(&r, &cfg) != PK_OK)
        return 1;
    for (int i = 0; i < 16; i++) {
        pk_um_t p[PK_AXES];
        for (int a = 0; a < PK_AXES; a++)
            p[a] = pk_img_in[a];
        while (pk_refine_push(&r, p) == PK_EBUSY)
            while (pk_refine_pull(&r, &out) == PK_OK)
                pk_img_sink = out.p[0];
        while (pk_refine_pull(&r, &out) == PK_OK)
            pk_img_sink = out.p[0];
    }
    pk_refine_finish(&r);
    while (pk_refine_pull(&r, &out) == PK_OK)
        pk_img_sink = out.p[0];
    return 0;
}
