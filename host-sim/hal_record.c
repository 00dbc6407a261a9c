/*
 * hal_record.c — recording HAL double (see hal_record.h).
 */
#include <stdlib.h>
#include <string.h>
#include "hal_record.h"

static void log_ev(struct pk_rec *r, uint8_t kind, uint32_t mask, uint32_t levels)
{
    r->raw[kind] = (r->raw[kind] & ~mask) | (levels & mask);
    if (!r->record)
        return;
    if (r->n == r->cap) {
        size_t nc = r->cap ? r->cap * 2 : 4096;
        struct pk_rec_event *e = realloc(r->ev, nc * sizeof *e);
        if (e == NULL)
            abort();
        r->ev = e;
        r->cap = nc;
    }
    r->ev[r->n++] = (struct pk_rec_event){ r->now, kind, mask, levels };
}

static int wr(struct pk_rec *r, uint8_t kind, uint32_t mask, uint32_t levels)
{
    r->attempts[kind]++;
    if (r->fail_after[kind] == 0)
        return PK_HAL_EIO;
    if (r->fail_after[kind] > 0)
        r->fail_after[kind]--;
    log_ev(r, kind, mask, levels);
    return PK_HAL_OK;
}

static int step_w(void *c, uint32_t m, uint32_t l) { return wr(c, PK_REC_STEP, m, l); }
static int dir_w(void *c, uint32_t m, uint32_t l) { return wr(c, PK_REC_DIR, m, l); }
static int en_w(void *c, uint32_t m, uint32_t l) { return wr(c, PK_REC_ENABLE, m, l); }
static int tool_w(void *c, uint32_t l) { return wr(c, PK_REC_TOOL, 1u, l); }
static int spindle_w(void *c, uint16_t v) { return wr(c, PK_REC_SPINDLE, 0xffffu, v); }

static int t_start(void *c, pk_hal_timer_cb cb, void *arg, uint64_t first)
{
    struct pk_rec *r = c;
    r->cb = cb;
    r->cb_arg = arg;
    r->next = first < r->now ? r->now : first;
    return PK_HAL_OK;
}

static int t_stop(void *c)
{
    struct pk_rec *r = c;
    r->cb = NULL;
    return PK_HAL_OK;
}

static uint64_t clk(void *c) { return ((struct pk_rec *)c)->now; }
static uint32_t irq_save(void *c) { (void)c; return 0; }
static void irq_restore(void *c, uint32_t t) { (void)c; (void)t; }

static const struct pk_hal_ops rec_ops = {
    .version = PK_HAL_VERSION,
    .step_write = step_w,
    .dir_write = dir_w,
    .enable_write = en_w,
    .tool_write = tool_w,
    .spindle_write = spindle_w,
    .timer_start = t_start,
    .timer_stop = t_stop,
    .clock_ticks = clk,
    .irq_save = irq_save,
    .irq_restore = irq_restore,
};

void pk_rec_init(struct pk_rec *r, uint32_t tick_hz)
{
    memset(r, 0, sizeof *r);
    r->hal.ops = &rec_ops;
    r->hal.ctx = r;
    r->hal.tick_hz = tick_hz;
    r->record = 1;
    for (int k = 0; k < PK_REC_KINDS; k++)
        r->fail_after[k] = -1;
}

void pk_rec_free(struct pk_rec *r)
{
    free(r->ev);
    r->ev = NULL;
    r->n = r->cap = 0;
}

int pk_rec_armed(const struct pk_rec *r) { return r->cb != NULL; }

void pk_rec_advance(struct pk_rec *r, uint64_t until)
{
    while (r->cb != NULL && r->next <= until) {
        if (r->next > r->now)
            r->now = r->next;
        pk_hal_timer_cb cb = r->cb;
        r->callbacks++;
        uint64_t nx = cb(r->cb_arg, r->now);
        if (nx == 0) {
            r->cb = NULL;
            break;
        }
        r->next = nx < r->now ? r->now : nx;
    }
    if (until > r->now)
        r->now = until;
}
