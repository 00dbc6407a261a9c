/*
 * gpiod_mock.c — the libgpiod 1.x functions the gpiod backend calls,
 * implemented on caller-owned mock chips (see gpiod_mock.h for the contract).
 */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include "gpiod_mock.h"

/* Registry of caller-owned chips: the only process-wide state. */
static struct pk_gpiod_mock *mock_registry;

void pk_gpiod_mock_init(struct pk_gpiod_mock *m, const char *name, unsigned int num_lines)
{
    memset(m, 0, sizeof *m);
    snprintf(m->name, sizeof m->name, "%s", name);
    m->num_lines = num_lines > PK_GPIOD_MOCK_LINES ? PK_GPIOD_MOCK_LINES : num_lines;
    m->chip.mock = m;
    m->next_handle = 1;
    for (unsigned int i = 0; i < PK_GPIOD_MOCK_LINES; i++) {
        m->line[i].chip = &m->chip;
        m->line[i].offset = i;
    }
}

int pk_gpiod_mock_register(struct pk_gpiod_mock *m)
{
    for (struct pk_gpiod_mock *p = mock_registry; p != NULL; p = p->next)
        if (p == m || strcmp(p->name, m->name) == 0)
            return -1;
    m->next = mock_registry;
    mock_registry = m;
    return 0;
}

static void release_all(struct pk_gpiod_mock *m)
{
    for (unsigned int i = 0; i < PK_GPIOD_MOCK_LINES; i++) {
        m->line[i].handle = 0;
        m->line[i].consumer[0] = '\0';
    }
    m->requested = 0;
}

void pk_gpiod_mock_unregister(struct pk_gpiod_mock *m)
{
    for (struct pk_gpiod_mock **pp = &mock_registry; *pp != NULL; pp = &(*pp)->next) {
        if (*pp == m) {
            *pp = m->next;
            break;
        }
    }
    m->next = NULL;
    release_all(m);
    m->is_open = 0;
}

int pk_gpiod_mock_value(const struct pk_gpiod_mock *m, unsigned int offset)
{
    return offset < m->num_lines ? m->line[offset].value : -1;
}

const char *pk_gpiod_mock_consumer(const struct pk_gpiod_mock *m, unsigned int offset)
{
    if (offset >= m->num_lines || m->line[offset].handle == 0u)
        return NULL;
    return m->line[offset].consumer;
}

static uint64_t mock_now(const struct pk_gpiod_mock *m)
{
    return m->clock ? m->clock(m->clock_arg) : 0u;
}

static int fail(int e)
{
    errno = e;
    return -1;
}

/* All lines of a non-empty bulk on one chip: that chip's mock, else NULL. */
static struct pk_gpiod_mock *bulk_mock(const struct gpiod_line_bulk *bulk)
{
    if (bulk == NULL || bulk->num_lines == 0u || bulk->num_lines > GPIOD_LINE_BULK_MAX_LINES)
        return NULL;
    struct gpiod_chip *chip = bulk->lines[0] ? bulk->lines[0]->chip : NULL;
    for (unsigned int i = 0; i < bulk->num_lines; i++)
        if (bulk->lines[i] == NULL || bulk->lines[i]->chip != chip)
            return NULL;
    return chip ? chip->mock : NULL;
}

struct gpiod_chip *gpiod_chip_open_lookup(const char *descr)
{
    if (descr == NULL) {
        errno = EINVAL;
        return NULL;
    }
    const char *name = strncmp(descr, "/dev/", 5) == 0 ? descr + 5 : descr;
    for (struct pk_gpiod_mock *m = mock_registry; m != NULL; m = m->next) {
        if (strcmp(m->name, name) != 0)
            continue;
        m->calls.open++;
        if (m->fail_open_errno != 0) {
            errno = m->fail_open_errno;
            return NULL;
        }
        if (m->is_open) { /* the mock hands out one handle per chip */
            errno = EBUSY;
            return NULL;
        }
        m->is_open = 1;
        return &m->chip;
    }
    errno = ENOENT;
    return NULL;
}

void gpiod_chip_close(struct gpiod_chip *chip)
{
    struct pk_gpiod_mock *m = chip->mock;
    m->calls.close++;
    release_all(m); /* closing the chip frees its lines and their requests */
    m->is_open = 0;
}

int gpiod_chip_get_lines(struct gpiod_chip *chip, unsigned int *offsets,
                         unsigned int num_offsets, struct gpiod_line_bulk *bulk)
{
    struct pk_gpiod_mock *m = chip->mock;
    m->calls.get_lines++;
    if (!m->is_open || num_offsets > GPIOD_LINE_BULK_MAX_LINES)
        return fail(EINVAL);
    gpiod_line_bulk_init(bulk);
    for (unsigned int i = 0; i < num_offsets; i++) {
        if (offsets[i] >= m->num_lines)
            return fail(EINVAL);
        gpiod_line_bulk_add(bulk, &m->line[offsets[i]]);
    }
    return 0;
}

int gpiod_line_request_bulk_output(struct gpiod_line_bulk *bulk, const char *consumer,
                                   const int *default_vals)
{
    struct pk_gpiod_mock *m = bulk_mock(bulk);
    if (m == NULL)
        return fail(EINVAL);
    m->calls.request++;
    if (m->fail_request_nth != 0u && m->calls.request == m->fail_request_nth)
        return fail(m->fail_request_errno ? m->fail_request_errno : EBUSY);
    for (unsigned int i = 0; i < bulk->num_lines; i++)
        if (bulk->lines[i]->handle != 0u)
            return fail(EBUSY);
    for (unsigned int i = 0; i < bulk->num_lines; i++)
        for (unsigned int j = i + 1; j < bulk->num_lines; j++)
            if (bulk->lines[i] == bulk->lines[j])
                return fail(EBUSY);
    unsigned int h = m->next_handle++;
    uint64_t t = mock_now(m);
    for (unsigned int i = 0; i < bulk->num_lines; i++) {
        struct gpiod_line *l = bulk->lines[i];
        l->handle = h;
        l->pos = i;
        snprintf(l->consumer, sizeof l->consumer, "%s", consumer ? consumer : "");
        l->value = default_vals ? !!default_vals[i] : 0;
        m->requested++;
        if (m->sink)
            m->sink(m->sink_arg, l->offset, l->value, t, 1);
    }
    return 0;
}

int gpiod_line_set_value_bulk(struct gpiod_line_bulk *bulk, const int *values)
{
    struct pk_gpiod_mock *m = bulk_mock(bulk);
    if (m == NULL)
        return fail(EINVAL);
    m->calls.set++;
    int e = 0;
    if (m->fail_set_nth != 0u &&
        (m->calls.set == m->fail_set_nth || (m->fail_set_sticky && m->calls.set > m->fail_set_nth)))
        e = m->fail_set_errno ? m->fail_set_errno : EIO;
    for (unsigned int i = 0; i < bulk->num_lines && e == 0; i++)
        if (bulk->lines[i]->handle == 0u)
            e = EPERM;
    if (e == 0) {
        /* Exactly the lines of one request, in order (see gpiod_mock.h). */
        unsigned int h = bulk->lines[0]->handle, n = 0;
        for (unsigned int i = 0; i < bulk->num_lines; i++)
            if (bulk->lines[i]->handle != h || bulk->lines[i]->pos != i)
                e = EINVAL;
        for (unsigned int i = 0; i < m->num_lines; i++)
            n += m->line[i].handle == h;
        if (n != bulk->num_lines)
            e = EINVAL;
    }
    if (e != 0) {
        if (m->set_failures++ == 0u)
            m->first_failure_tick = mock_now(m);
        return fail(e);
    }
    m->sets_ok++;
    if (m->set_failures != 0u)
        m->sets_ok_after_failure++;
    uint64_t t = mock_now(m);
    for (unsigned int i = 0; i < bulk->num_lines; i++) {
        struct gpiod_line *l = bulk->lines[i];
        int v = values ? !!values[i] : 0;
        if (v != l->value) {
            l->value = v;
            m->changes++;
            if (m->sink)
                m->sink(m->sink_arg, l->offset, v, t, 0);
        }
    }
    return 0;
}

void gpiod_line_release_bulk(struct gpiod_line_bulk *bulk)
{
    struct pk_gpiod_mock *m = bulk_mock(bulk);
    if (m == NULL)
        return;
    m->calls.release++;
    for (unsigned int i = 0; i < bulk->num_lines; i++) {
        if (bulk->lines[i]->handle != 0u) {
            bulk->lines[i]->handle = 0;
            bulk->lines[i]->consumer[0] = '\0';
            m->requested--;
        }
    }
}
