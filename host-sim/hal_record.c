/*
 * hal_record.c — recording HAL double (see hal_record.h).
 */
#include <stdlib.h>
#include <string.h>
#include "hal_record.h"

/* Logical level of every switch-driven line, as raw levels; other lines keep theirs. */
static void switches_update(struct pk_rec *r)
{
    uint32_t lines = 0, active = 0;
    for (size_t k = 0; k < r->n_sw; k++) {
        const struct pk_rec_switch *w = &r->sw[k];
        int64_t p = r->pos[w->axis];
        lines |= 1u << w->line;
        if (w->side > 0 ? p >= w->at_steps : p <= w->at_steps)
            active |= 1u << w->line;
    }
    uint32_t raw = (r->in_raw & ~lines) | ((active ^ r->hal.input_invert) & lines);
    if (raw != r->in_raw) {
        r->in_raw = raw;
        r->in_pending = 1;
    }
}

/* Step lines: each logical rising edge moves its axis by the direction shown. */
static void track_steps(struct pk_rec *r, uint32_t old_raw, uint32_t new_raw)
{
    uint32_t rise = (new_raw ^ r->hal.step_invert) & ~(old_raw ^ r->hal.step_invert);
    uint32_t dir = r->raw[PK_REC_DIR] ^ r->hal.dir_invert;
    for (unsigned i = 0; i < PK_HAL_MAX_AXES; i++)
        if ((rise >> i) & 1u)
            r->pos[i] += ((dir >> i) & 1u) ? 1 : -1;
    if (rise != 0u && r->n_sw > 0u)
        switches_update(r);
}

static void log_ev(struct pk_rec *r, uint8_t kind, uint32_t mask, uint32_t levels)
{
    uint32_t old = r->raw[kind];
    r->raw[kind] = (r->raw[kind] & ~mask) | (levels & mask);
    if (kind == PK_REC_STEP)
        track_steps(r, old, r->raw[kind]);
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

static int in_read(void *c, uint32_t *raw)
{
    struct pk_rec *r = c;
    r->input_reads++;
    if (r->in_fail_after == 0)
        return PK_HAL_EIO;
    if (r->in_fail_after > 0)
        r->in_fail_after--;
    *raw = r->in_raw;
    return PK_HAL_OK;
}

static int in_watch(void *c, pk_hal_input_cb cb, void *arg)
{
    struct pk_rec *r = c;
    if (!r->in_edges)
        return PK_HAL_ENOSYS; /* a board that cannot report edges */
    r->in_cb = cb;
    r->in_arg = arg;
    return PK_HAL_OK;
}
static uint32_t irq_save(void *c) { (void)c; return 0; }
static void irq_restore(void *c, uint32_t t) { (void)c; (void)t; }

static const struct pk_hal_ops rec_ops = {
    .version = PK_HAL_VERSION,
    .step_write = step_w,
    .dir_write = dir_w,
    .enable_write = en_w,
    .tool_write = tool_w,
    .spindle_write = spindle_w,
    .input_read = in_read,
    .input_watch = in_watch,
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
    r->in_fail_after = -1;
}

void pk_rec_inputs(struct pk_rec *r, uint32_t inputs, uint32_t invert, int edges)
{
    r->in_edges = edges != 0;
    r->hal.inputs = inputs;
    r->hal.input_invert = invert;
    r->in_raw = invert & inputs;
}

int pk_rec_input_at(struct pk_rec *r, uint64_t t, unsigned line, int active)
{
    if (r->n_script >= PK_REC_IN_EDGES || line >= PK_IN_COUNT
        || (r->n_script > 0u && t < r->in_script[r->n_script - 1u].tick))
        return -1;
    uint8_t raw = (uint8_t)(((active ? 1u : 0u) ^ (r->hal.input_invert >> line)) & 1u);
    r->in_script[r->n_script++] = (struct pk_rec_in_edge){ t, (uint8_t)line, raw };
    return 0;
}

int pk_rec_add_switch(struct pk_rec *r, unsigned line, unsigned axis, int side, int32_t at_steps)
{
    if (r->n_sw >= PK_REC_SWITCHES || line >= PK_IN_COUNT || axis >= PK_HAL_MAX_AXES)
        return -1;
    r->sw[r->n_sw++] = (struct pk_rec_switch){ (uint8_t)line, (uint8_t)axis,
                                               (int8_t)(side < 0 ? -1 : 1), at_steps };
    r->in_pending = 0;
    switches_update(r);
    r->in_pending = 0;  /* the level it starts at is no edge */
    return 0;
}

/* Deliver a pending input change to the edge callback (a pin-change
 * interrupt between two timer callbacks). */
static void in_deliver(struct pk_rec *r)
{
    if (!r->in_pending)
        return;
    r->in_pending = 0;
    if (r->in_cb != NULL) {
        r->input_reports++;
        r->in_cb(r->in_arg, r->in_raw, r->now);
    }
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
    for (;;) {
        in_deliver(r);
        if (r->i_script < r->n_script) {
            const struct pk_rec_in_edge *e = &r->in_script[r->i_script];
            if (e->tick <= until && (r->cb == NULL || e->tick <= r->next)) {
                if (e->tick > r->now)
                    r->now = e->tick;
                uint32_t raw = (r->in_raw & ~(1u << e->line)) | ((uint32_t)e->level << e->line);
                r->i_script++;
                if (raw != r->in_raw) {
                    r->in_raw = raw;
                    r->in_pending = 1;
                }
                continue;
            }
        }
        if (r->cb == NULL || r->next > until)
            break;
        if (r->next > r->now)
            r->now = r->next;
        pk_hal_timer_cb cb = r->cb;
        r->callbacks++;
        uint64_t nx = cb(r->cb_arg, r->now);
        if (nx == 0) {
            r->cb = NULL;
            continue;   /* input changes may still be due before until */
        }
        r->next = nx < r->now ? r->now : nx;
    }
    in_deliver(r);
    if (until > r->now)
        r->now = until;
}
