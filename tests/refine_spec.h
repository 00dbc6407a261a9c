/*
 * refine_spec.h — the point count per level that issue 2 specifies, written
 * independently of the kernel, for the tests and the fuzz target that check
 * it (tests/test_refine.c, tests/fuzz/fuzz_refine.c). Freestanding, so it
 * also builds into the on-target test image.
 */
#ifndef PLOTKIN_REFINE_SPEC_H
#define PLOTKIN_REFINE_SPEC_H

#include <stdint.h>
#include "pk_refine.h"

/** Points after one level, from m points. `ends` is the effective open-end
 *  rule (PK_ENDS_DEFAULT already resolved); ignored for closed curves and DLG. */
static inline uint32_t spec_level_count(unsigned scheme, unsigned degree, unsigned closed,
                                        unsigned ends, uint32_t m)
{
    if (closed)
        return m <= 1u ? m : 2u * m;
    if (m <= 2u)
        return m; /* 0 -> nothing, 1 -> itself, an open 2-point stroke stays */
    if (scheme == PK_SCHEME_DLG)
        return 2u * m - 1u;
    int32_t D = (int32_t)degree, plain = 2 * (int32_t)m - D;
    switch (ends) {
    case PK_ENDS_CLAMPED:
        if (D == 1)
            return 2u * m - 1u;
        if (D == 2)
            return 2u * m - 2u;
        return m == 3u ? 4u : 2u * m - 3u; /* cubic; 3 points: quadratic */
    case PK_ENDS_REPLACE:
        return plain < 2 ? 2u : (uint32_t)plain;
    default:
        return plain < 0 ? 0u : (uint32_t)plain;
    }
}

#endif
