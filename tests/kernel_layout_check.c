/*
 * kernel_layout_check.c — every translation unit of a build sees the same
 * struct pk_refine, whichever kernel header it includes first. Compiled
 * twice by tests/e2e_kernel_builds.sh with one build's knobs: once with
 * LAYOUT_FIXED_FIRST=1 (pk_fixed.h before pk_refine.h, as pk_motion.h
 * does), once with 0 (pk_refine.h alone, as the kernel's own files do); the
 * second copy has main() and compares the two views. A unit that fell back
 * to another width of pk_umf_t (64-bit where the kernel has 32) saw another
 * layout of the kernel's state and of every struct holding one (the Uno's
 * PK_MAX_DEPTH = 5 stall: pk_motion.c read the stroke's flags from inside
 * the kernel).
 */
#if LAYOUT_FIXED_FIRST
#include "pk_fixed.h"
#include "pk_refine.h"
#else
#include "pk_refine.h"
#include <stdio.h>
#endif
#include <stddef.h>

#if LAYOUT_FIXED_FIRST
#define LAYOUT_FN layout_fixed_first
#else
#define LAYOUT_FN layout_refine_first
#endif

void LAYOUT_FN(size_t v[4]);
void LAYOUT_FN(size_t v[4])
{
    v[0] = sizeof(pk_umf_t);
    v[1] = sizeof(struct pk_refine);
    v[2] = offsetof(struct pk_refine, e);
    v[3] = PK_UMF_BITS;
}

#if !LAYOUT_FIXED_FIRST
void layout_fixed_first(size_t v[4]);
int main(void)
{
    size_t a[4], b[4];
    layout_fixed_first(a);
    layout_refine_first(b);
    int same = 1;
    for (int i = 0; i < 4; i++)
        same &= a[i] == b[i];
    printf("pk_umf_t %zu/%zu bytes, struct pk_refine %zu/%zu bytes (pk_fixed.h first / pk_refine.h first)\n",
           a[0], b[0], a[1], b[1]);
    return same && b[3] == 8u * b[0] ? 0 : 1;
}
#endif
