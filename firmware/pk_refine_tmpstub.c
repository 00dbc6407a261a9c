/*
 * pk_refine_tmpstub.c — TEMPORARY depth-0 pass-through of the kernel API so
 * the motion branch links before the real pk_refine.c lands on main. Deleted
 * when main is merged. Not part of the deliverable.
 */
#include <string.h>
#include "pk_refine.h"

int pk_refine_init(struct pk_refine *r, const struct pk_refine_cfg *cfg)
{
    memset(r, 0, sizeof *r);
    r->cfg = *cfg;
    return PK_OK;
}

int pk_refine_push(struct pk_refine *r, const pk_um_t p[PK_AXES])
{
    if (r->finishing)
        return PK_ESTATE;
    if (r->in_full)
        return PK_EBUSY;
    for (unsigned i = 0; i < PK_AXES; i++)
        r->in[i] = p[i];
    r->in_full = 1;
    return PK_OK;
}

void pk_refine_finish(struct pk_refine *r) { r->finishing = 1; }

int pk_refine_pull(struct pk_refine *r, struct pk_refine_out *out)
{
    if (r->in_full) {
        memset(out, 0, sizeof *out);
        for (unsigned i = 0; i < PK_AXES; i++)
            out->p[i] = r->in[i];
        r->in_full = 0;
        return PK_OK;
    }
    if (r->finishing) {
        r->finishing = 0;
        return PK_END;
    }
    return PK_NEED_INPUT;
}

void pk_refine_reset(struct pk_refine *r)
{
    r->in_full = 0;
    r->finishing = 0;
}

uint32_t pk_refine_max_release(const struct pk_refine_cfg *cfg)
{
    (void)cfg;
    return 1;
}
