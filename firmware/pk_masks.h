/* TEMPORARY (lead's scratch, replaced by the generated table from branch masks) */
#ifndef PLOTKIN_PK_MASKS_H
#define PLOTKIN_PK_MASKS_H
#include <stdint.h>
#define PK_MASK_MAXLEN 8
struct pk_mask { int8_t first; uint8_t len; int32_t den; int32_t w[PK_MASK_MAXLEN]; };
struct pk_limit_rule {
    uint8_t edge_anchors, nend, drop_mask, min_n;
    struct pk_mask pos_uniform, tan_uniform;
    struct pk_mask pos_end[4], tan_end[4];
};
const struct pk_limit_rule *pk_limit_rule_get(unsigned scheme, unsigned degree, unsigned closed, unsigned ends);
const struct pk_mask *pk_limit_small_get(unsigned scheme, unsigned degree, unsigned ends, unsigned n, unsigned anchor, unsigned tangent);
#endif
