/*
 * kernel_image.c — the smallest useful program around the kernel, for the
 * size table of bench/kernel_sizes.py: one stream, configured from volatile
 * objects (so the compiler cannot specialise the kernel for one
 * configuration: what is measured is the kernel as a library, with whatever
 * the build carries), fed and drained the way the motion core does (push,
 * pull until PK_NEED_INPUT, finish, pull until PK_END). Linked with
 * --gc-sections for the Cortex-M0+ (with tests/targets/cm_start.c, as
 * th_main) and the ATmega328P (as main); never run. pk_size_refine exports
 * sizeof(struct pk_refine) in the target's ABI.
 */
#include <stdint.h>
#include "pk_refine.h"

int th_main(int argc, char **argv);
void th_write(const char *s);
int main(void);

extern const unsigned char pk_size_refine[sizeof(struct pk_refine)];
const unsigned char pk_size_refine[sizeof(struct pk_refine)] = { 1 };

static volatile uint8_t kimg_scheme, kimg_degree = 2, kimg_depth = 4, kimg_closed, kimg_ends, kimg_limit,
    kimg_tangents;
static volatile pk_um_t kimg_in[PK_AXES];
static volatile pk_um_t kimg_sink;
static const unsigned char *volatile kimg_size_ref; /* keeps pk_size_refine linked */
static struct pk_refine kimg_stream;

static void kimg_drain(struct pk_refine_out *out)
{
    while (pk_refine_pull(&kimg_stream, out) == PK_OK)
        kimg_sink = out->p[0] + out->t[0];
}

int th_main(int argc, char **argv)
{
    (void)argc;
    (void)argv;
    struct pk_refine_cfg cfg = { 0 };
    struct pk_refine_out out;
    cfg.scheme = kimg_scheme;
    cfg.degree = kimg_degree;
    cfg.depth = kimg_depth;
    cfg.closed = kimg_closed;
    cfg.ends = kimg_ends;
    cfg.limit = kimg_limit;
    cfg.tangents = kimg_tangents;
    if (pk_refine_init(&kimg_stream, &cfg) != PK_OK)
        return 1;
    for (int i = 0; i < 16; i++) {
        pk_um_t p[PK_AXES];
        for (int a = 0; a < PK_AXES; a++)
            p[a] = kimg_in[a];
        while (pk_refine_push(&kimg_stream, p) == PK_EBUSY)
            kimg_drain(&out);
        kimg_drain(&out);
    }
    pk_refine_finish(&kimg_stream);
    kimg_drain(&out);
    kimg_size_ref = pk_size_refine;
    return 0;
}

int main(void) { return th_main(0, 0); }
