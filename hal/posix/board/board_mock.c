/*
 * board_mock.c — the recording mock GPIO chip of plotkin-gpiod-mock (see
 * board_mock.h).
 */
#include "board_mock.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static uint64_t real_clock(void *arg) { return pk_posix_timer_ns(arg); }

static void record(void *arg, unsigned int offset, int value, uint64_t t, int initial)
{
    struct pk_board_mock *b = arg;
    if (b->n == b->cap) {
        size_t cap = b->cap ? b->cap * 2u : 1u << 18;
        struct pk_board_mock_edge *e = realloc(b->e, cap * sizeof *e);
        if (e == NULL) {
            b->lost++;
            return;
        }
        b->e = e;
        b->cap = cap;
    }
    const struct pk_posix_timer *p = b->timer;
    int64_t due = -1;
    if (p->in_cb)
        due = (int64_t)(p->running_due / p->tick_hz * 1000000000u +
                        p->running_due % p->tick_hz * 1000000000u / p->tick_hz);
    b->e[b->n++] = (struct pk_board_mock_edge){ t, due, (uint8_t)offset, (uint8_t)value,
                                                (uint8_t)initial };
}

int pk_board_mock_attach(struct pk_board_mock *b, const struct pk_gpiod_cfg *cfg,
                         const struct pk_posix_timer *t, char *err, size_t errlen)
{
    memset(b, 0, sizeof *b);
    b->timer = t;
    const char *name = strncmp(cfg->chip, "/dev/", 5) == 0 ? cfg->chip + 5 : cfg->chip;
    pk_gpiod_mock_init(&b->chip, name, PK_GPIOD_MOCK_LINES);
    b->chip.clock = real_clock;
    b->chip.clock_arg = (void *)t;
    b->chip.sink = record;
    b->chip.sink_arg = b;
    /* Reserve now: no allocation in the step loop unless a run is long. */
    b->cap = 1u << 18;
    b->e = malloc(b->cap * sizeof *b->e);
    if (b->e == NULL || pk_gpiod_mock_register(&b->chip) != 0) {
        snprintf(err, errlen, "mock chip '%s': %s", name, b->e ? "name taken" : strerror(ENOMEM));
        free(b->e);
        b->e = NULL;
        return -1;
    }
    return 0;
}

int pk_board_mock_finish(struct pk_board_mock *b, const char *path, char *err, size_t errlen)
{
    int rc = 0;
    pk_gpiod_mock_unregister(&b->chip);
    if (b->lost) {
        snprintf(err, errlen, "mock trace: %zu edges not recorded (out of memory)", b->lost);
        rc = -1;
    } else if (path != NULL) {
        FILE *f = fopen(path, "w");
        if (f == NULL) {
            snprintf(err, errlen, "%s: %s", path, strerror(errno));
            rc = -1;
        } else {
            fprintf(f, "# plotkin-gpiod mock trace v1: t_ns due_ns line level initial\n");
            for (size_t i = 0; i < b->n; i++)
                fprintf(f, "%llu %lld %u %u %u\n", (unsigned long long)b->e[i].t_ns,
                        (long long)b->e[i].due_ns, b->e[i].line, b->e[i].level, b->e[i].initial);
            if (fclose(f) != 0) {
                snprintf(err, errlen, "%s: %s", path, strerror(errno));
                rc = -1;
            }
        }
    }
    free(b->e);
    b->e = NULL;
    return rc;
}
