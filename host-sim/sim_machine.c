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
    w->chip.sink = pk_trace_sink;
    w->chip.sink_arg = &w->trace;
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
    int rc = pk_gpiod_open(&w->gpio, cfg, &w->base, &w->hal);
    if (rc != PK_HAL_OK) {
        snprintf(err, errlen, "%s", pk_gpiod_error_text(&w->gpio));
        return rc;
    }
    w->opened = 1;
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
