/* TEMPORARY scratch table: closed chaikin and cubic only */
#include "pk_masks.h"
#include <stddef.h>
static const struct pk_limit_rule ch_closed = { 1, 0, 0, 3, { 0, 2, 2, { 1, 1 } }, { 0, 2, 1, { -1, 1 } }, {{0}}, {{0}} };
static const struct pk_limit_rule cu_closed = { 0, 0, 0, 3, { -1, 3, 6, { 1, 4, 1 } }, { -1, 3, 1, { -1, 0, 1 } }, {{0}}, {{0}} };
const struct pk_limit_rule *pk_limit_rule_get(unsigned scheme, unsigned degree, unsigned closed, unsigned ends)
{
    (void)ends;
    if (scheme == 0 && closed && degree == 2) return &ch_closed;
    if (scheme == 0 && closed && degree == 3) return &cu_closed;
    return NULL;
}
const struct pk_mask *pk_limit_small_get(unsigned scheme, unsigned degree, unsigned ends, unsigned n, unsigned anchor, unsigned tangent)
{
    (void)scheme; (void)degree; (void)ends; (void)n; (void)anchor; (void)tangent;
    return NULL;
}
