/*
 * ref_kernel.h — the pre-issue-14 kernel (tests/ref/README.md), all in one
 * translation unit, renamed ref_* / REF_* so that it links beside the
 * current firmware kernel. Include from exactly one test file.
 */
#ifndef PLOTKIN_REF_KERNEL_H
#define PLOTKIN_REF_KERNEL_H

#include "ref/ref_fixed.c"
#include "ref/ref_masks.c"
#include "ref/ref_limit.c"
#include "ref/ref_refine.c"

#endif
