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
    if (t->n == t->cap) {
        size_t cap = t->cap ? t->cap * 2u : 4096u;
        struct pk_trace_edge *e = realloc(t->e, cap * sizeof *e);
        if (e == NULL) {
            t->oom = 1;
            return -1;
        }
        t->e = e;
        t->cap = cap;
    }
    t->e[t->n++] = (struct pk_trace_edge){ tick, (uint8_t)kind, (uint8_t)axis, (uint8_t)(level != 0),
                                            (uint8_t)(initial != 0) };
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

int pk_trace_write_csv(const struct pk_trace *t, FILE *f, int shared_enable)
{
    char name[16];
    fprintf(f, "# plotkin pin trace, raw levels, tick_hz=%" PRIu32 "\n", t->tick_hz);
    fputs("tick,time_s,signal,level,initial\n", f);
    for (size_t i = 0; i < t->n; i++) {
        const struct pk_trace_edge *e = &t->e[i];
        /* time_s printed from integers: exact and identical on every host */
        uint64_t s = e->t / t->tick_hz, frac = e->t % t->tick_hz;
        uint64_t ns = frac * 1000000000u / t->tick_hz;
        fprintf(f, "%" PRIu64 ",%" PRIu64 ".%09" PRIu64 ",%s,%u,%u\n", e->t, s, ns,
                pk_trace_signal_name((enum pk_sig_kind)e->kind, e->axis, shared_enable, name, sizeof name),
                (unsigned)e->level, (unsigned)e->initial);
    }
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

int pk_decode(const struct pk_trace *t, const struct pk_decode_cfg *cfg, struct pk_decoded *out)
{
    /* Logical state per axis; "never" until the first change of each kind. */
    uint8_t step[PK_HAL_MAX_AXES] = { 0 }, dir[PK_HAL_MAX_AXES] = { 0 }, en[PK_HAL_MAX_AXES];
    uint64_t t_rise[PK_HAL_MAX_AXES], t_fall[PK_HAL_MAX_AXES], t_dir[PK_HAL_MAX_AXES];
    uint8_t pen = 0;
    const int shared_enable = cfg->shared_enable;
    size_t cap_ev = 0, cap_viol = 0;

    memset(out, 0, sizeof *out);
    for (unsigned a = 0; a < PK_HAL_MAX_AXES; a++) {
        t_rise[a] = t_fall[a] = t_dir[a] = NEVER;
        en[a] = 1;
    }
    /* ns between two ticks, rounded down: a limit is met only if truly met. */
    const uint64_t hz = cfg->tick_hz;
#define NS(dt) ((uint64_t)(dt) * 1000000000u / hz)

    for (size_t i = 0; i < t->n; i++) {
        const struct pk_trace_edge *e = &t->e[i];
        unsigned a = e->axis < PK_HAL_MAX_AXES ? e->axis : 0u;
        uint8_t lv;
        out->t_last = e->t;
        switch (e->kind) {
        case PK_SIG_STEP:
            lv = (uint8_t)(e->level ^ ((cfg->step_invert >> a) & 1u));
            if (e->initial || lv == step[a]) {
                step[a] = lv;
                break;
            }
            step[a] = lv;
            if (lv) { /* activation: one step */
                if (t_fall[a] != NEVER && NS(e->t - t_fall[a]) < cfg->lim.min_low_ns)
                    if (push_viol(out, &cap_viol, (struct pk_violation){ e->t, PK_VIOL_LOW, (uint8_t)a,
                                  NS(e->t - t_fall[a]), cfg->lim.min_low_ns }))
                        return -1;
                if (t_dir[a] != NEVER && NS(e->t - t_dir[a]) < cfg->lim.dir_setup_ns)
                    if (push_viol(out, &cap_viol, (struct pk_violation){ e->t, PK_VIOL_SETUP, (uint8_t)a,
                                  NS(e->t - t_dir[a]), cfg->lim.dir_setup_ns }))
                        return -1;
                t_rise[a] = e->t;
                int8_t d = dir[a] ? 1 : -1;
                out->pos[a] += d;
                out->steps[a]++;
                uint8_t ena = shared_enable ? en[0] : en[a];
                if (!ena)
                    out->steps_while_disabled++;
                if (push_ev(out, &cap_ev, (struct pk_step_event){ e->t, (uint8_t)a, d, pen, ena }))
                    return -1;
            } else {
                if (t_rise[a] != NEVER && NS(e->t - t_rise[a]) < cfg->lim.min_high_ns)
                    if (push_viol(out, &cap_viol, (struct pk_violation){ e->t, PK_VIOL_HIGH, (uint8_t)a,
                                  NS(e->t - t_rise[a]), cfg->lim.min_high_ns }))
                        return -1;
                t_fall[a] = e->t;
            }
            break;
        case PK_SIG_DIR:
            lv = (uint8_t)(e->level ^ ((cfg->dir_invert >> a) & 1u));
            if (e->initial || lv == dir[a]) {
                dir[a] = lv;
                break;
            }
            dir[a] = lv;
            if (t_rise[a] != NEVER && NS(e->t - t_rise[a]) < cfg->lim.dir_hold_ns)
                if (push_viol(out, &cap_viol, (struct pk_violation){ e->t, PK_VIOL_HOLD, (uint8_t)a,
                              NS(e->t - t_rise[a]), cfg->lim.dir_hold_ns }))
                    return -1;
            t_dir[a] = e->t;
            break;
        case PK_SIG_ENABLE:
            en[a] = (uint8_t)(e->level ^ ((cfg->enable_invert >> a) & 1u));
            break;
        case PK_SIG_PEN:
        default:
            pen = (uint8_t)(e->level ^ (cfg->pen_invert & 1u));
            break;
        }
    }
#undef NS
    out->pen = pen;
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

void pk_decode_axis_rates(const struct pk_decoded *d, unsigned axis, uint32_t tick_hz,
                          unsigned window, double *max_speed, double *max_accel)
{
    /* Per-axis (tick, position after the step) samples. */
    size_t n = 0;
    for (size_t i = 0; i < d->n_ev; i++)
        n += d->ev[i].axis == axis;
    *max_speed = 0.0;
    *max_accel = 0.0;
    if (window == 0u)
        window = 1u;
    if (n < 2u)
        return;
    uint64_t *tt = malloc(n * sizeof *tt);
    int64_t *pp = malloc(n * sizeof *pp);
    if (tt == NULL || pp == NULL) {
        free(tt);
        free(pp);
        return;
    }
    int64_t pos = 0;
    size_t k = 0;
    for (size_t i = 0; i < d->n_ev; i++) {
        if (d->ev[i].axis != axis)
            continue;
        pos += d->ev[i].dir;
        tt[k] = d->ev[i].t;
        pp[k] = pos;
        k++;
    }
    const double hz = (double)tick_hz;
    const uint64_t pause = tick_hz / 20u; /* 50 ms */
    size_t w = window < n ? window : n - 1u;
    for (size_t i = w; i < n; i++) {
        uint64_t dt = tt[i] - tt[i - w];
        if (dt == 0u || dt > pause * w)
            continue;
        double v = (double)(pp[i] - pp[i - w]) * hz / (double)dt;
        if (fabs(v) > *max_speed)
            *max_speed = fabs(v);
        if (i + w < n) {
            uint64_t dt2 = tt[i + w] - tt[i];
            if (dt2 == 0u || dt2 > pause * w)
                continue;
            double v2 = (double)(pp[i + w] - pp[i]) * hz / (double)dt2;
            double tc = ((double)tt[i + w] - (double)tt[i - w]) / 2.0 / hz;
            double acc = fabs(v2 - v) / tc;
            if (acc > *max_accel)
                *max_accel = acc;
        }
    }
    free(tt);
    free(pp);
}
