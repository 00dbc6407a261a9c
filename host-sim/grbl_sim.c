/*
 * grbl_sim.c — a simulated machine speaking Grbl (see grbl_sim.h).
 */
#include "grbl_sim.h"

#include <string.h>

static int start(struct pk_grbl_sim *s, const struct pk_grbl_settings *set)
{
    pk_rec_init(&s->rec, s->tick_hz);
    s->rec.record = 0;
    if (s->inputs)
        pk_rec_inputs(&s->rec, s->inputs, 0, s->input_edges);
    memset(&s->m, 0, sizeof s->m);
    memset(&s->gm, 0, sizeof s->gm);
    s->gm.m = &s->m;
    s->gm.hal = &s->rec.hal;
    pk_uart_init(&s->uart, pk_grbl_rt_filter, &s->g);
    struct pk_grbl_stream io = { pk_uart_read_cb, pk_uart_write_cb, pk_uart_rx_used_cb, &s->uart };
    struct pk_grbl_machine_ops ops;
    pk_grbl_motion_ops(&ops);
    s->ram.buf = s->nvm_buf;
    s->ram.size = sizeof s->nvm_buf;
    struct pk_grbl_nvm nvm;
    pk_grbl_ram_nvm(&s->ram, &nvm);
    return pk_grbl_init(&s->g, &io, &ops, &s->gm, set, &nvm);
}

int pk_grbl_sim_init(struct pk_grbl_sim *s, uint32_t tick_hz, const struct pk_grbl_settings *set)
{
    memset(s, 0, sizeof *s);
    s->tick_hz = tick_hz;
    memset(s->nvm_buf, 0xff, sizeof s->nvm_buf); /* an erased EEPROM */
    return start(s, set);
}

int pk_grbl_sim_init_inputs(struct pk_grbl_sim *s, uint32_t tick_hz,
                            const struct pk_grbl_settings *set, uint32_t inputs, int edges)
{
    memset(s, 0, sizeof *s);
    s->tick_hz = tick_hz;
    s->inputs = inputs;
    s->input_edges = edges;
    memset(s->nvm_buf, 0xff, sizeof s->nvm_buf);
    return start(s, set);
}

int pk_grbl_sim_restart(struct pk_grbl_sim *s)
{
    pk_rec_free(&s->rec);
    return start(s, NULL);
}

void pk_grbl_sim_step(struct pk_grbl_sim *s, uint64_t ticks)
{
    pk_grbl_poll(&s->g);
    pk_machine_poll(&s->m);
    pk_rec_advance(&s->rec, s->rec.now + ticks);
}

void pk_grbl_sim_free(struct pk_grbl_sim *s) { pk_rec_free(&s->rec); }
