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

static void line_free(struct gpiod_line *l)
{
    l->handle = 0;
    l->consumer[0] = '\0';
    l->is_input = 0;
    l->events = 0;
    l->evq_n = 0;
}

static void release_all(struct pk_gpiod_mock *m)
{
    for (unsigned int i = 0; i < PK_GPIOD_MOCK_LINES; i++)
        line_free(&m->line[i]);
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

/* A request of the lines of bulk (outputs with default_vals, or inputs with
 * or without events): the common checks and bookkeeping. */
static int request_lines(struct gpiod_line_bulk *bulk, const char *consumer, const int *default_vals,
                         int input, int events)
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
        l->is_input = (uint8_t)input;
        l->events = (uint8_t)events;
        l->evq_n = 0;
        m->requested++;
        if (input)
            continue; /* it keeps the level the outside drives; not an output edge */
        l->value = default_vals ? !!default_vals[i] : 0;
        if (m->sink)
            m->sink(m->sink_arg, l->offset, l->value, t, 1);
    }
    return 0;
}

int gpiod_line_request_bulk_output(struct gpiod_line_bulk *bulk, const char *consumer,
                                   const int *default_vals)
{
    return request_lines(bulk, consumer, default_vals, 0, 0);
}

int gpiod_line_request_bulk_input_flags(struct gpiod_line_bulk *bulk, const char *consumer, int flags)
{
    (void)flags; /* bias: the simulated outside world drives the level */
    return request_lines(bulk, consumer, NULL, 1, 0);
}

int gpiod_line_request_bulk_both_edges_events_flags(struct gpiod_line_bulk *bulk,
                                                    const char *consumer, int flags)
{
    (void)flags;
    return request_lines(bulk, consumer, NULL, 1, 1);
}

/* Exactly the lines of one request, in request order (as for set). */
static int whole_request(const struct pk_gpiod_mock *m, const struct gpiod_line_bulk *bulk)
{
    unsigned int h = bulk->lines[0]->handle, n = 0;
    if (h == 0u)
        return EPERM;
    for (unsigned int i = 0; i < bulk->num_lines; i++)
        if (bulk->lines[i]->handle != h || bulk->lines[i]->pos != i)
            return EINVAL;
    for (unsigned int i = 0; i < m->num_lines; i++)
        n += m->line[i].handle == h;
    return n == bulk->num_lines ? 0 : EINVAL;
}

int gpiod_line_get_value_bulk(struct gpiod_line_bulk *bulk, int *values)
{
    struct pk_gpiod_mock *m = bulk_mock(bulk);
    if (m == NULL)
        return fail(EINVAL);
    m->calls.get++;
    if (m->fail_get_errno != 0)
        return fail(m->fail_get_errno);
    int e = whole_request(m, bulk);
    if (e != 0)
        return fail(e);
    for (unsigned int i = 0; i < bulk->num_lines; i++)
        values[i] = bulk->lines[i]->value;
    return 0;
}

int gpiod_line_event_wait_bulk(struct gpiod_line_bulk *bulk, const struct timespec *timeout,
                               struct gpiod_line_bulk *event_bulk)
{
    (void)timeout; /* never blocks: see gpiod_mock.h */
    struct pk_gpiod_mock *m = bulk_mock(bulk);
    if (m == NULL)
        return fail(EINVAL);
    m->calls.wait++;
    if (m->fail_wait_errno != 0)
        return fail(m->fail_wait_errno);
    for (unsigned int i = 0; i < bulk->num_lines; i++)
        if (bulk->lines[i]->handle == 0u || !bulk->lines[i]->events)
            return fail(EPERM);
    if (event_bulk != NULL)
        gpiod_line_bulk_init(event_bulk);
    int any = 0;
    for (unsigned int i = 0; i < bulk->num_lines; i++) {
        if (bulk->lines[i]->evq_n == 0u)
            continue;
        any = 1;
        if (event_bulk != NULL)
            gpiod_line_bulk_add(event_bulk, bulk->lines[i]);
    }
    return any;
}

int gpiod_line_event_read(struct gpiod_line *line, struct gpiod_line_event *event)
{
    struct pk_gpiod_mock *m = line->chip->mock;
    m->calls.read++;
    if (line->handle == 0u || !line->events)
        return fail(EPERM);
    if (line->evq_n == 0u)
        return fail(EAGAIN);
    event->event_type = line->evq_type[0];
    event->ts.tv_sec = (time_t)(line->evq_t[0] / 1000000000u);
    event->ts.tv_nsec = (long)(line->evq_t[0] % 1000000000u);
    line->evq_n--;
    memmove(line->evq_type, line->evq_type + 1, line->evq_n);
    memmove(line->evq_t, line->evq_t + 1, line->evq_n * sizeof line->evq_t[0]);
    return 0;
}

int pk_gpiod_mock_input_set(struct pk_gpiod_mock *m, unsigned int offset, int level)
{
    if (offset >= m->num_lines)
        return -1;
    struct gpiod_line *l = &m->line[offset];
    if (l->handle != 0u && !l->is_input)
        return -1;
    int v = !!level;
    if (v == l->value)
        return 0;
    l->value = v;
    if (l->handle != 0u && l->events) {
        if (l->evq_n < PK_GPIOD_MOCK_EVQ) {
            l->evq_type[l->evq_n] = (uint8_t)(v ? GPIOD_LINE_EVENT_RISING_EDGE : GPIOD_LINE_EVENT_FALLING_EDGE);
            l->evq_t[l->evq_n] = mock_now(m);
            l->evq_n++;
            m->events_queued++;
        } else {
            m->events_dropped++;
        }
    }
    return 0;
}

int pk_gpiod_mock_input_at(struct pk_gpiod_mock *m, uint64_t t, unsigned int offset, int level)
{
    if (m->n_script >= PK_GPIOD_MOCK_SCRIPT || offset >= m->num_lines
        || (m->n_script > 0u && t < m->script[m->n_script - 1u].t))
        return -1;
    m->script[m->n_script++] = (struct pk_gpiod_mock_in_edge){ t, (uint8_t)offset, (uint8_t)!!level };
    return 0;
}

void pk_gpiod_mock_input_advance(struct pk_gpiod_mock *m, uint64_t now)
{
    while (m->i_script < m->n_script && m->script[m->i_script].t <= now) {
        const struct pk_gpiod_mock_in_edge *e = &m->script[m->i_script++];
        (void)pk_gpiod_mock_input_set(m, e->offset, e->level);
    }
}

uint64_t pk_gpiod_mock_input_next(const struct pk_gpiod_mock *m)
{
    return m->i_script < m->n_script ? m->script[m->i_script].t : UINT64_MAX;
}

uint32_t pk_gpiod_mock_events_pending(const struct pk_gpiod_mock *m)
{
    uint32_t n = 0;
    for (unsigned int i = 0; i < m->num_lines; i++)
        n += m->line[i].evq_n;
    return n;
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
        if (bulk->lines[i]->handle == 0u || bulk->lines[i]->is_input)
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
            line_free(bulk->lines[i]);
            m->requested--;
        }
    }
}
