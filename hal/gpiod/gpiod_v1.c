/*
 * gpiod_v1.c — the libgpiod 1.x (v1 API) implementation of pk_gpiod_port.h.
 *
 * The only file of the backend that names libgpiod functions. v1 facts that
 * shape it:
 *  - gpiod_line_set_value_bulk() writes through the request handle of the
 *    bulk's first line, and the kernel applies values[i] to the i-th line of
 *    that REQUEST. A bulk must therefore be exactly the lines of one request,
 *    in request order — so each group is requested as one bulk and always
 *    written whole (the caller keeps shadow levels for masked writes).
 *  - The line handles belong to the chip object: gpiod_chip_close() frees
 *    them, so we release the requests first and forget the handles after.
 *  - struct gpiod_line_bulk is a 520-byte value type with static inline
 *    helpers; we keep only the line pointers and rebuild a bulk on the stack
 *    per call (a handful of stores), which keeps pk_gpiod_port version-neutral.
 */
#include <errno.h>
#include <gpiod.h>
#include "pk_gpiod_port.h"

/* errno after a failed libgpiod call, as a negative value; never 0. */
static int fail_errno(void)
{
    int e = errno;
    return e > 0 ? -e : -EIO;
}

static void lines_bulk(void *const *lines, unsigned n, struct gpiod_line_bulk *bulk)
{
    gpiod_line_bulk_init(bulk);
    for (unsigned i = 0; i < n; i++)
        gpiod_line_bulk_add(bulk, (struct gpiod_line *)lines[i]);
}

static void group_bulk(const struct pk_gpiod_port *p, enum pk_gpiod_group g,
                       struct gpiod_line_bulk *bulk)
{
    lines_bulk(p->line[g], p->n[g], bulk);
}

int pk_gpiod_port_open(struct pk_gpiod_port *p, const char *desc)
{
    errno = 0;
    struct gpiod_chip *chip = gpiod_chip_open_lookup(desc);
    if (chip == NULL)
        return fail_errno();
    p->chip = chip;
    return 0;
}

int pk_gpiod_port_request(struct pk_gpiod_port *p, enum pk_gpiod_group g,
                          const uint32_t *offsets, unsigned n,
                          const char *consumer, const int *initial)
{
    struct gpiod_line_bulk bulk;
    unsigned int offs[PK_HAL_MAX_AXES];

    if (p->chip == NULL || n == 0u || n > PK_HAL_MAX_AXES || p->n[g] != 0u)
        return -EINVAL;
    for (unsigned i = 0; i < n; i++)
        offs[i] = offsets[i];
    errno = 0;
    if (gpiod_chip_get_lines((struct gpiod_chip *)p->chip, offs, n, &bulk) != 0)
        return fail_errno();
    errno = 0;
    if (gpiod_line_request_bulk_output(&bulk, consumer, initial) != 0)
        return fail_errno();
    for (unsigned i = 0; i < n; i++)
        p->line[g][i] = gpiod_line_bulk_get_line(&bulk, i);
    p->n[g] = (uint8_t)n;
    return 0;
}

int pk_gpiod_port_set(struct pk_gpiod_port *p, enum pk_gpiod_group g, const int *values)
{
    struct gpiod_line_bulk bulk;

    if (p->n[g] == 0u)
        return -EINVAL;
    group_bulk(p, g, &bulk);
    errno = 0;
    if (gpiod_line_set_value_bulk(&bulk, values) != 0)
        return fail_errno();
    return 0;
}

static void input_bulk(const struct pk_gpiod_port *p, struct gpiod_line_bulk *bulk)
{
    lines_bulk(p->in_line, p->n_in, bulk);
}

int pk_gpiod_port_request_inputs(struct pk_gpiod_port *p, const uint32_t *offsets, unsigned n,
                                 const char *consumer, int bias, int edges)
{
    struct gpiod_line_bulk bulk;
    unsigned int offs[PK_IN_COUNT];
    static const int bias_flag[4] = { 0, GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_UP,
                                      GPIOD_LINE_REQUEST_FLAG_BIAS_PULL_DOWN,
                                      GPIOD_LINE_REQUEST_FLAG_BIAS_DISABLE };

    if (p->chip == NULL || n == 0u || n > PK_IN_COUNT || p->n_in != 0u || bias < 0 || bias > 3)
        return -EINVAL;
    for (unsigned i = 0; i < n; i++)
        offs[i] = offsets[i];
    errno = 0;
    if (gpiod_chip_get_lines((struct gpiod_chip *)p->chip, offs, n, &bulk) != 0)
        return fail_errno();
    errno = 0;
    int rc = edges ? gpiod_line_request_bulk_both_edges_events_flags(&bulk, consumer, bias_flag[bias])
                   : gpiod_line_request_bulk_input_flags(&bulk, consumer, bias_flag[bias]);
    if (rc != 0)
        return fail_errno();
    for (unsigned i = 0; i < n; i++)
        p->in_line[i] = gpiod_line_bulk_get_line(&bulk, i);
    p->n_in = (uint8_t)n;
    p->in_edges = edges ? 1u : 0u;
    return 0;
}

int pk_gpiod_port_get_inputs(struct pk_gpiod_port *p, int *values)
{
    struct gpiod_line_bulk bulk;

    if (p->n_in == 0u)
        return -EINVAL;
    input_bulk(p, &bulk);
    errno = 0;
    if (gpiod_line_get_value_bulk(&bulk, values) != 0)
        return fail_errno();
    return 0;
}

int pk_gpiod_port_take_events(struct pk_gpiod_port *p, unsigned max)
{
    struct gpiod_line_bulk bulk, ev;
    const struct timespec now = { 0, 0 };
    unsigned taken = 0;

    if (p->n_in == 0u || !p->in_edges)
        return 0;
    input_bulk(p, &bulk);
    while (taken < max) {
        errno = 0;
        int w = gpiod_line_event_wait_bulk(&bulk, &now, &ev);
        if (w < 0)
            return fail_errno();
        if (w == 0)
            break;
        for (unsigned i = 0; i < ev.num_lines && taken < max; i++) {
            struct gpiod_line_event e;
            errno = 0;
            if (gpiod_line_event_read(ev.lines[i], &e) != 0)
                return fail_errno();
            taken++;
        }
    }
    return (int)taken;
}

void pk_gpiod_port_close(struct pk_gpiod_port *p)
{
    struct gpiod_line_bulk bulk;

    if (p->n_in != 0u) {
        input_bulk(p, &bulk);
        gpiod_line_release_bulk(&bulk);
    }
    p->n_in = 0;
    p->in_edges = 0;
    for (int i = 0; i < PK_IN_COUNT; i++)
        p->in_line[i] = NULL;

    for (int g = 0; g < PK_GPIOD_GROUPS; g++) {
        if (p->n[g] != 0u) {
            group_bulk(p, (enum pk_gpiod_group)g, &bulk);
            gpiod_line_release_bulk(&bulk);
        }
        p->n[g] = 0;
        for (int i = 0; i < PK_HAL_MAX_AXES; i++)
            p->line[g][i] = NULL;
    }
    if (p->chip != NULL)
        gpiod_chip_close((struct gpiod_chip *)p->chip);
    p->chip = NULL;
}
