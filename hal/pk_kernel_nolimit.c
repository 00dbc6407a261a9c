/*
 * pk_kernel_nolimit.c — link an image without the kernel's limit/tangent
 * stage (firmware/pk_limit.c and its mask tables, about 15 KB, which avr-gcc
 * copies into RAM). For boards only (hal/firmware.mk, BOARD_KERNEL_LIMIT = 0).
 *
 * The motion core never asks the kernel for limit points or tangents
 * (pk_stroke.c refines without them), but pk_refine_init references the
 * stage, so --gc-sections cannot drop it. Such an image is built without
 * pk_limit.c and pk_masks.c, and the stage's entry points are these instead
 * (plain definitions rather than -Wl,--wrap, which a link-time-optimised
 * link does not apply): setup refuses, so pk_refine_init answers PK_ENOTSUP
 * for any request that would need the stage (loudly, never a silently
 * different curve), and the other entry points are unreachable after a
 * refused setup. Everything the image does is unchanged. To be replaced by
 * the kernel's own per-build scheme selection when it exists.
 */
#include "pk_refine_internal.h"

int pk_limit_setup(struct pk_refine *r)
{
    (void)r;
    return PK_ENOTSUP;
}

/* Never reached (no stream has the stage); harmless answers if they were. */
int pk_limit_ready(const struct pk_refine *r)
{
    (void)r;
    return 0;
}

int pk_limit_exhausted(const struct pk_refine *r)
{
    (void)r;
    return 1;
}

void pk_limit_feed(struct pk_refine *r, const pk_w8_t *p)
{
    (void)r;
    (void)p;
}

void pk_limit_finish(struct pk_refine *r) { (void)r; }

void pk_limit_emit(struct pk_refine *r, struct pk_refine_out *out)
{
    (void)r;
    (void)out;
}
