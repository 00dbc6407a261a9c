/*
 * sim_machine.c — wiring of one simulated machine's hardware (see sim_machine.h).
 */
#include <stdio.h>
#include <string.h>
#include "sim_machine.h"

void pk_sim_default_board(struct pk_gpiod_cfg *cfg, const char *chip_name, unsigned axes)
{
    pk_gpiod_cfg_init(cfg);
    snprintf(cfg->chip, sizeof cfg->chip, "%s", chip_name);
    if (axes < 1u || axes > PK_HAL_MAX_AXES)
        axes = 3;
    cfg->axes = (uint8_t)axes;
    for (unsigned i = 0; i < axes; i++) {
        cfg->step[i] = i;
        cfg->dir[i] = 4u + i;
    }
    cfg->enables = 1;
    cfg->enable[0] = 8;
    cfg->enable_invert = ((uint32_t)1 << PK_HAL_MAX_AXES) - 1u;
    cfg->has_pen = 1;
    cfg->pen = 9;
    for (unsigned i = 0; i < axes; i++)
        cfg->input[PK_IN_LIMIT_X + i] = 10u + i;
    for (unsigned b = PK_IN_PROBE; b < PK_IN_COUNT; b++)
        cfg->input[b] = 14u + (b - PK_IN_PROBE);
    cfg->inputs = (((1u << axes) - 1u) << PK_IN_LIMIT_X) | (PK_IN_ALL & ~(uint32_t)PK_IN_LIMITS);
    cfg->input_invert = cfg->inputs;
    cfg->input_bias = 1; /* pull-up */
}

/* The raw level an input's line shows for a logical level. */
static int input_raw(const struct pk_sim_hw *w, unsigned input, int active)
{
    return (int)(((active ? 1u : 0u) ^ (w->gpio.cfg.input_invert >> input)) & 1u);
}

static void switches_update(struct pk_sim_hw *w)
{
    uint32_t lines = 0, active = 0;
    for (unsigned k = 0; k < w->n_sw; k++) {
        const struct pk_sim_input *s = &w->sw[k];
        int64_t p = w->sw_pos[s->axis];
        lines |= 1u << s->input;
        if (s->side > 0 ? p >= s->at_steps : p <= s->at_steps)
            active |= 1u << s->input;
    }
    for (unsigned b = 0; b < PK_IN_COUNT; b++)
        if ((lines >> b) & 1u)
            (void)pk_gpiod_mock_input_set(&w->chip, w->gpio.cfg.input[b],
                                          input_raw(w, b, (int)((active >> b) & 1u)));
}

/* The chip's sink: the trace, and the axis positions the switches follow. */
static void hw_sink(void *arg, unsigned int offset, int value, uint64_t t, int initial)
{
    struct pk_sim_hw *w = arg;
    pk_trace_sink(&w->trace, offset, value, t, initial);
    const struct pk_gpiod_cfg *c = &w->gpio.cfg;
    for (unsigned i = 0; i < c->axes; i++) {
        uint32_t bit = 1u << i;
        if (offset == c->dir[i]) {
            w->sw_dir = value ? (w->sw_dir | bit) : (w->sw_dir & ~bit);
        } else if (offset == c->step[i]) {
            uint32_t was = ((w->sw_step ^ c->step_invert) & bit) != 0u;
            w->sw_step = value ? (w->sw_step | bit) : (w->sw_step & ~bit);
            uint32_t is = ((w->sw_step ^ c->step_invert) & bit) != 0u;
            if (!was && is && !initial) {
                w->sw_pos[i] += ((w->sw_dir ^ c->dir_invert) & bit) ? 1 : -1;
                if (w->n_sw > 0u)
                    switches_update(w);
            }
        }
    }
}

/* The chip as an interrupt source: scripted changes at their tick, then the
 * backend's edge service while events are queued. */
static uint64_t hw_irq_due(void *arg, uint64_t now)
{
    struct pk_sim_hw *w = arg;
    if (w->opened && !w->service_failed && pk_gpiod_mock_events_pending(&w->chip) > 0u)
        return now;
    return pk_gpiod_mock_input_next(&w->chip);
}

static void hw_irq_run(void *arg, uint64_t now)
{
    struct pk_sim_hw *w = arg;
    pk_gpiod_mock_input_advance(&w->chip, now);
    if (w->opened && !w->service_failed && pk_gpiod_mock_events_pending(&w->chip) > 0u
        && pk_gpiod_input_service(&w->gpio) < 0)
        w->service_failed = 1;
}

int pk_sim_hw_input_at(struct pk_sim_hw *w, uint64_t t, unsigned input, int active)
{
    if (input >= PK_IN_COUNT || ((w->gpio.cfg.inputs >> input) & 1u) == 0u)
        return -1;
    return pk_gpiod_mock_input_at(&w->chip, t, w->gpio.cfg.input[input], input_raw(w, input, active));
}

int pk_sim_hw_add_switch(struct pk_sim_hw *w, unsigned input, unsigned axis, int side, int32_t at_steps)
{
    if (input >= PK_IN_COUNT || ((w->gpio.cfg.inputs >> input) & 1u) == 0u
        || axis >= PK_HAL_MAX_AXES || w->n_sw >= PK_SIM_SWITCHES)
        return -1;
    w->sw[w->n_sw++] = (struct pk_sim_input){ 1u, (uint8_t)input, 0u, (uint8_t)axis,
                                              (int8_t)(side < 0 ? -1 : 1), at_steps, 0u };
    switches_update(w);
    return 0;
}

int pk_sim_hw_inputs(struct pk_sim_hw *w, const struct pk_sim_input *in, size_t n)
{
    for (size_t k = 0; k < n; k++) {
        int r = in[k].is_switch ? pk_sim_hw_add_switch(w, in[k].input, in[k].axis, in[k].side, in[k].at_steps)
                                : pk_sim_hw_input_at(w, in[k].tick, in[k].input, in[k].active);
        if (r != 0)
            return -1;
    }
    return 0;
}

int pk_sim_hw_open(struct pk_sim_hw *w, const struct pk_gpiod_cfg *cfg, uint32_t tick_hz,
                   uint32_t main_period, const struct pk_gpiod_mock *fault, char *err, size_t errlen)
{
    return pk_sim_hw_open_traced(w, cfg, tick_hz, main_period, fault, NULL, err, errlen);
}

int pk_sim_hw_open_traced(struct pk_sim_hw *w, const struct pk_gpiod_cfg *cfg, uint32_t tick_hz,
                          uint32_t main_period, const struct pk_gpiod_mock *fault,
                          const struct pk_trace *tpl, char *err, size_t errlen)
{
    memset(w, 0, sizeof *w);
    pk_sim_sched_init(&w->sched, tick_hz, main_period);
    pk_sim_sched_hal(&w->sched, &w->base);
    pk_trace_init(&w->trace, tick_hz);
    pk_trace_map_gpiod(&w->trace, cfg);
    if (tpl != NULL) {
        w->trace.keep = tpl->keep;
        w->trace.on_edge = tpl->on_edge;
        w->trace.on_edge_arg = tpl->on_edge_arg;
    }

    const char *name = strncmp(cfg->chip, "/dev/", 5) == 0 ? cfg->chip + 5 : cfg->chip;
    pk_gpiod_mock_init(&w->chip, name, 32);
    w->chip.clock = pk_sim_sched_clock;
    w->chip.clock_arg = &w->sched;
    w->chip.sink = hw_sink;
    w->chip.sink_arg = w;
    if (fault != NULL) {
        w->chip.fail_open_errno = fault->fail_open_errno;
        w->chip.fail_request_nth = fault->fail_request_nth;
        w->chip.fail_request_errno = fault->fail_request_errno;
        w->chip.fail_set_nth = fault->fail_set_nth;
        w->chip.fail_set_errno = fault->fail_set_errno;
        w->chip.fail_set_sticky = fault->fail_set_sticky;
    }
    if (pk_gpiod_mock_register(&w->chip) != 0) {
        snprintf(err, errlen, "sim: a chip named '%s' already exists", name);
        return PK_HAL_EINVAL;
    }
    w->registered = 1;
    /* the outside world holds every input line at its idle level */
    for (unsigned b = 0; b < PK_IN_COUNT; b++)
        if ((cfg->inputs >> b) & 1u)
            (void)pk_gpiod_mock_input_set(&w->chip, cfg->input[b], (int)((cfg->input_invert >> b) & 1u));
    int rc = pk_gpiod_open(&w->gpio, cfg, &w->base, &w->hal);
    if (rc != PK_HAL_OK) {
        snprintf(err, errlen, "%s", pk_gpiod_error_text(&w->gpio));
        return rc;
    }
    w->opened = 1;
    pk_sim_sched_set_irq(&w->sched, hw_irq_due, hw_irq_run, w);
    return PK_HAL_OK;
}

void pk_sim_hw_close(struct pk_sim_hw *w)
{
    if (w->opened)
        pk_gpiod_close(&w->gpio);
    w->opened = 0;
    if (w->registered)
        pk_gpiod_mock_unregister(&w->chip);
    w->registered = 0;
    pk_trace_free(&w->trace);
}

void pk_sim_board_decode_cfg(const struct pk_gpiod_cfg *cfg, uint32_t tick_hz,
                             const struct pk_timing_limits *lim, struct pk_decode_cfg *out)
{
    uint32_t axes = ((uint32_t)1 << cfg->axes) - 1u;
    memset(out, 0, sizeof *out);
    out->tick_hz = tick_hz;
    out->axes = cfg->axes;
    out->step_invert = cfg->step_invert & axes;
    out->dir_invert = cfg->dir_invert & axes;
    /* the trace records a shared enable line as axis 0 */
    out->enable_invert = cfg->enable_invert & axes;
    out->pen_invert = cfg->pen_invert & 1u;
    out->shared_enable = cfg->enables == 1u;
    out->lim = *lim;
}

void pk_sim_hw_decode_cfg(const struct pk_sim_hw *w, const struct pk_timing_limits *lim,
                          struct pk_decode_cfg *out)
{
    pk_sim_board_decode_cfg(&w->gpio.cfg, w->sched.tick_hz, lim, out);
}
