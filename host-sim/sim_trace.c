/*
 * sim_trace.c — pin trace recording, CSV output, decoding and timing checks
 * (see sim_trace.h).
 */
#include <inttypes.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "sim_trace.h"

void pk_trace_init(struct pk_trace *t, uint32_t tick_hz)
{
    memset(t, 0, sizeof *t);
    t->tick_hz = tick_hz;
    t->keep = 1;
    for (size_t i = 0; i < sizeof t->map / sizeof t->map[0]; i++)
        t->map[i] = -1;
}

static void map_line(struct pk_trace *t, uint32_t offset, enum pk_sig_kind kind, unsigned axis)
{
    if (offset < sizeof t->map / sizeof t->map[0])
        t->map[offset] = (int16_t)(((unsigned)kind << 4) | axis);
}

void pk_trace_map_gpiod(struct pk_trace *t, const struct pk_gpiod_cfg *cfg)
{
    for (unsigned i = 0; i < cfg->axes; i++) {
        map_line(t, cfg->step[i], PK_SIG_STEP, i);
        map_line(t, cfg->dir[i], PK_SIG_DIR, i);
    }
    for (unsigned i = 0; i < cfg->enables; i++)
        map_line(t, cfg->enable[i], PK_SIG_ENABLE, i);
    if (cfg->has_pen)
        map_line(t, cfg->pen, PK_SIG_PEN, 0);
}

void pk_trace_free(struct pk_trace *t)
{
    free(t->e);
    t->e = NULL;
    t->n = t->cap = 0;
}

int pk_trace_add(struct pk_trace *t, uint64_t tick, enum pk_sig_kind kind, unsigned axis,
                 int level, int initial)
{
    const struct pk_trace_edge e = { tick, (uint8_t)kind, (uint8_t)axis, (uint8_t)(level != 0),
                                     (uint8_t)(initial != 0) };
    t->n++;
    if (t->on_edge != NULL)
        t->on_edge(t->on_edge_arg, &e);
    if (!t->keep)
        return 0;
    size_t kept = t->n - 1u;
    if (kept == t->cap) {
        size_t cap = t->cap ? t->cap * 2u : 4096u;
        struct pk_trace_edge *p = realloc(t->e, cap * sizeof *p);
        if (p == NULL) {
            t->oom = 1;
            t->n--;
            return -1;
        }
        t->e = p;
        t->cap = cap;
    }
    t->e[kept] = e;
    return 0;
}

void pk_trace_sink(void *arg, unsigned int offset, int value, uint64_t t, int initial)
{
    struct pk_trace *tr = arg;
    if (offset >= sizeof tr->map / sizeof tr->map[0] || tr->map[offset] < 0) {
        tr->unmapped++;
        return;
    }
    unsigned m = (unsigned)tr->map[offset];
    (void)pk_trace_add(tr, t, (enum pk_sig_kind)(m >> 4), m & 15u, value, initial);
}

const char *pk_trace_signal_name(enum pk_sig_kind kind, unsigned axis, int shared_enable,
                                 char *buf, size_t len)
{
    static const char axis_name[] = "XYZA";
    char a = axis < 4u ? axis_name[axis] : '?';
    switch (kind) {
    case PK_SIG_STEP:
        snprintf(buf, len, "%c.step", a);
        break;
    case PK_SIG_DIR:
        snprintf(buf, len, "%c.dir", a);
        break;
    case PK_SIG_ENABLE:
        if (shared_enable)
            snprintf(buf, len, "enable");
        else
            snprintf(buf, len, "%c.enable", a);
        break;
    case PK_SIG_PEN:
    default:
        snprintf(buf, len, "pen");
        break;
    }
    return buf;
}

void pk_trace_csv_header(FILE *f, uint32_t tick_hz)
{
    fprintf(f, "# plotkin pin trace, raw levels, tick_hz=%" PRIu32 "\n", tick_hz);
    fputs("tick,time_s,signal,level,initial\n", f);
}

void pk_trace_csv_row(FILE *f, const struct pk_trace_edge *e, uint32_t tick_hz, int shared_enable)
{
    char name[16];
    /* time_s printed from integers: exact and identical on every host */
    uint64_t s = e->t / tick_hz, frac = e->t % tick_hz;
    uint64_t ns = frac * 1000000000u / tick_hz;
    fprintf(f, "%" PRIu64 ",%" PRIu64 ".%09" PRIu64 ",%s,%u,%u\n", e->t, s, ns,
            pk_trace_signal_name((enum pk_sig_kind)e->kind, e->axis, shared_enable, name, sizeof name),
            (unsigned)e->level, (unsigned)e->initial);
}

int pk_trace_write_csv(const struct pk_trace *t, FILE *f, int shared_enable)
{
    pk_trace_csv_header(f, t->tick_hz);
    for (size_t i = 0; i < t->n && t->e != NULL; i++)
        pk_trace_csv_row(f, &t->e[i], t->tick_hz, shared_enable);
    return ferror(f) ? -1 : 0;
}

const char *pk_violation_name(enum pk_violation_kind k)
{
    switch (k) {
    case PK_VIOL_HIGH: return "min high";
    case PK_VIOL_LOW: return "min low";
    case PK_VIOL_SETUP: return "dir setup";
    case PK_VIOL_HOLD:
    default: return "dir hold";
    }
}

/* Growable arrays for the decoder. */
static int push_ev(struct pk_decoded *d, size_t *cap, struct pk_step_event ev)
{
    if (d->n_ev == *cap) {
        size_t c = *cap ? *cap * 2u : 4096u;
        struct pk_step_event *p = realloc(d->ev, c * sizeof *p);
        if (p == NULL)
            return -1;
        d->ev = p;
        *cap = c;
    }
    d->ev[d->n_ev++] = ev;
    return 0;
}

static int push_viol(struct pk_decoded *d, size_t *cap, struct pk_violation v)
{
    if (d->n_viol >= PK_VIOL_KEEP) {
        d->n_viol++; /* counted, not kept: memory stays bounded */
        return 0;
    }
    if (d->n_viol == *cap) {
        size_t c = *cap ? *cap * 2u : 64u;
        struct pk_violation *p = realloc(d->viol, c * sizeof *p);
        if (p == NULL)
            return -1;
        d->viol = p;
        *cap = c;
    }
    d->viol[d->n_viol++] = v;
    return 0;
}

#define NEVER UINT64_MAX

void pk_decoder_init(struct pk_decoder *d, const struct pk_decode_cfg *cfg, struct pk_decoded *out,
                     int keep_events)
{
    memset(d, 0, sizeof *d);
    memset(out, 0, sizeof *out);
    d->cfg = *cfg;
    d->out = out;
    d->keep_events = keep_events;
    for (unsigned a = 0; a < PK_HAL_MAX_AXES; a++) {
        d->t_rise[a] = d->t_fall[a] = d->t_dir[a] = NEVER;
        d->en[a] = 1;
    }
}

/* ns between two ticks, rounded down: a limit is met only if truly met. */
static uint64_t ns_of(const struct pk_decoder *d, uint64_t dt)
{
    return dt * 1000000000u / d->cfg.tick_hz;
}

static int violation(struct pk_decoder *d, uint64_t t, int kind, unsigned a, uint64_t dt, uint32_t lim)
{
    uint64_t ns = ns_of(d, dt);
    if (ns >= lim)
        return 0;
    if (push_viol(d->out, &d->cap_viol, (struct pk_violation){ t, (uint8_t)kind, (uint8_t)a, ns, lim })) {
        d->oom = 1;
        return -1;
    }
    return 0;
}

int pk_decoder_push(struct pk_decoder *d, const struct pk_trace_edge *e)
{
    const struct pk_decode_cfg *cfg = &d->cfg;
    struct pk_decoded *out = d->out;
    unsigned a = e->axis < PK_HAL_MAX_AXES ? e->axis : 0u;
    uint8_t lv;
    int rc = 0;

    out->t_last = e->t;
    switch (e->kind) {
    case PK_SIG_STEP:
        lv = (uint8_t)(e->level ^ ((cfg->step_invert >> a) & 1u));
        if (e->initial || lv == d->step[a]) {
            d->step[a] = lv;
            break;
        }
        d->step[a] = lv;
        if (lv) { /* activation: one step */
            if (d->t_fall[a] != NEVER)
                rc |= violation(d, e->t, PK_VIOL_LOW, a, e->t - d->t_fall[a], cfg->lim.min_low_ns);
            if (d->t_dir[a] != NEVER)
                rc |= violation(d, e->t, PK_VIOL_SETUP, a, e->t - d->t_dir[a], cfg->lim.dir_setup_ns);
            d->t_rise[a] = e->t;
            int8_t dir = d->dir[a] ? 1 : -1;
            out->pos[a] += dir;
            out->steps[a]++;
            uint8_t ena = cfg->shared_enable ? d->en[0] : d->en[a];
            if (!ena)
                out->steps_while_disabled++;
            struct pk_step_event ev = { e->t, (uint8_t)a, dir, d->pen, ena };
            if (d->on_step != NULL)
                d->on_step(d->on_step_arg, &ev);
            if (d->keep_events && push_ev(out, &d->cap_ev, ev)) {
                d->oom = 1;
                rc = -1;
            }
        } else {
            if (d->t_rise[a] != NEVER)
                rc |= violation(d, e->t, PK_VIOL_HIGH, a, e->t - d->t_rise[a], cfg->lim.min_high_ns);
            d->t_fall[a] = e->t;
        }
        break;
    case PK_SIG_DIR:
        lv = (uint8_t)(e->level ^ ((cfg->dir_invert >> a) & 1u));
        if (e->initial || lv == d->dir[a]) {
            d->dir[a] = lv;
            break;
        }
        d->dir[a] = lv;
        if (d->t_rise[a] != NEVER)
            rc |= violation(d, e->t, PK_VIOL_HOLD, a, e->t - d->t_rise[a], cfg->lim.dir_hold_ns);
        d->t_dir[a] = e->t;
        break;
    case PK_SIG_ENABLE:
        d->en[a] = (uint8_t)(e->level ^ ((cfg->enable_invert >> a) & 1u));
        break;
    case PK_SIG_PEN:
    default:
        d->pen = (uint8_t)(e->level ^ (cfg->pen_invert & 1u));
        break;
    }
    out->pen = d->pen;
    return rc ? -1 : 0;
}

void pk_decoder_edge(void *arg, const struct pk_trace_edge *e)
{
    (void)pk_decoder_push(arg, e);
}

int pk_decode(const struct pk_trace *t, const struct pk_decode_cfg *cfg, struct pk_decoded *out)
{
    struct pk_decoder d;
    pk_decoder_init(&d, cfg, out, 1);
    for (size_t i = 0; i < t->n && t->e != NULL; i++)
        if (pk_decoder_push(&d, &t->e[i]) != 0)
            return -1;
    return 0;
}

void pk_decoded_free(struct pk_decoded *d)
{
    free(d->ev);
    free(d->viol);
    d->ev = NULL;
    d->viol = NULL;
    d->n_ev = d->n_viol = 0;
}
