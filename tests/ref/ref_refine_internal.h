/*
 * ref_refine_internal.h — private glue between the level cascade
 * (ref_refine.c) and the limit/tangent stage (ref_limit.c). Not for callers.
 */
#ifndef PLOTKIN_REF_REFINE_INTERNAL_H
#define PLOTKIN_REF_REFINE_INTERNAL_H

#include "ref_refine.h"

#define LV_DEFER 0x01u /* batch held until we know whether more input follows */
#define LV_FIN 0x02u   /* finished: the current batch is the tail */
#define LV_E0 0x04u    /* something has been emitted in this stroke */

int ref_limit_setup(struct ref_refine *r);
int ref_limit_ready(const struct ref_refine *r);
int ref_limit_exhausted(const struct ref_refine *r);
void ref_limit_feed(struct ref_refine *r, const ref_w8_t *p);
void ref_limit_finish(struct ref_refine *r);
void ref_limit_emit(struct ref_refine *r, struct ref_refine_out *out);

/** Unit vector (Q1.30) along d; all zero if d is zero. */
void ref_unit_q30(const int64_t *d, unsigned dims, ref_q30_t *t);

#endif
