/*
 * pk_refine_internal.h — private glue between the level cascade
 * (pk_refine.c) and the limit/tangent stage (pk_limit.c). Not for callers.
 */
#ifndef PLOTKIN_PK_REFINE_INTERNAL_H
#define PLOTKIN_PK_REFINE_INTERNAL_H

#include "pk_refine.h"

#define LV_DEFER 0x01u /* batch held until we know whether more input follows */
#define LV_FIN 0x02u   /* finished: the current batch is the tail */
#define LV_E0 0x04u    /* something has been emitted in this stroke */

int pk_limit_setup(struct pk_refine *r);
int pk_limit_ready(const struct pk_refine *r);
int pk_limit_exhausted(const struct pk_refine *r);
void pk_limit_feed(struct pk_refine *r, const pk_w8_t *p);
void pk_limit_finish(struct pk_refine *r);
void pk_limit_emit(struct pk_refine *r, struct pk_refine_out *out);

/** Unit vector (Q1.30) along d; all zero if d is zero. */
void pk_unit_q30(const int64_t *d, unsigned dims, pk_q30_t *t);

#endif
