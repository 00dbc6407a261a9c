/*
 * pk_home.c — Grbl's homing cycle as a main-loop state machine over the
 * motion core's homing moves (see pk_home.h for the sequence and Grbl's
 * numbers). Every wait (a move, the $26 pause) returns to the caller; the
 * pause is timed on the HAL clock, so it needs no request of its own.
 */
#include <string.h>
#include "pk_home.h"

enum { STEP_START = 0, STEP_MOVING = 1, STEP_PAUSE = 2 };

/* Grbl: HOMING_AXIS_SEARCH_SCALAR 1.5, HOMING_AXIS_LOCATE_SCALAR 5.0 */
#define SEARCH_NUM 3
#define SEARCH_DEN 2
#define LOCATE_SCALE 5

static bool rate_ok(pk_um_min_t f) { return f >= PK_UM_MIN_MIN && f <= PK_UM_MIN_MAX; }

static int finish(struct pk_home *h, uint8_t status, uint8_t fail)
{
    (void)pk_machine_set_hard_limits(h->m, h->hard_was);
    h->status = status;
    h->fail = fail;
    return status;
}

int pk_home_start(struct pk_home *h, struct pk_machine *m, const struct pk_home_cfg *cfg,
                  uint8_t axes)
{
    uint32_t all = (1u << m->cfg.axes) - 1u;
    uint32_t have = m->hal->inputs & all;
    if (axes == 0u)
        axes = (uint8_t)have;
    if (axes == 0u || (axes & ~have) != 0u)
        return PK_MOTION_ENOINPUT;
    if (!rate_ok(cfg->feed) || !rate_ok(cfg->seek) || cfg->debounce_ms > 10000u
        || cfg->pulloff_um < 1 || cfg->pulloff_um > PK_UM_MAX / LOCATE_SCALE)
        return PK_MOTION_EINVAL;
    for (uint32_t i = 0; i < m->cfg.axes; i++)
        if ((axes & (1u << i)) != 0u && (cfg->travel_um[i] < 1 || cfg->travel_um[i] > PK_UM_MAX))
            return PK_MOTION_EINVAL;
    enum pk_machine_state st = pk_machine_state(m);
    if (st == PK_STATE_ALARM)
        return PK_MOTION_EALARM;
    if (st != PK_STATE_IDLE)
        return PK_MOTION_EBUSY;
    memset(h, 0, sizeof *h);
    h->cfg = *cfg;
    h->m = m;
    /* Grbl's default cycles: Z alone first (clear the work), then the rest */
    const uint8_t z = 1u << 2;
    if ((axes & z) != 0u && (axes & ~z) != 0u) {
        h->group[0] = z;
        h->group[1] = (uint8_t)(axes & ~z);
        h->n_groups = 2;
    } else {
        h->group[0] = axes;
        h->n_groups = 1;
    }
    h->hard_was = m->hard_limits;
    (void)pk_machine_set_hard_limits(m, false);
    h->status = PK_HOME_RUNNING;
    return PK_MOTION_OK;
}

/* Start the current pass's move: the group's axes at 0, diagonally at the
 * pass's rate times sqrt(axes) so that each axis moves at the rate. */
static int start_pass(struct pk_home *h)
{
    struct pk_machine *m = h->m;
    const uint8_t g = h->group[h->gi];
    pk_steps_t pos[PK_AXES];
    pk_um_t target[PK_AXES];
    pk_machine_position_steps(m, pos);
    uint32_t n = 0;
    pk_um_t travel = 0;
    for (uint32_t i = 0; i < m->cfg.axes; i++) {
        if ((g & (1u << i)) == 0u)
            continue;
        pos[i] = 0;
        n++;
        if (h->cfg.travel_um[i] > travel)
            travel = h->cfg.travel_um[i];
    }
    if (pk_machine_set_position(m, pos) != PK_MOTION_OK)
        return -1;
    pk_machine_position_um(m, target);
    bool approach = (h->pass & 1u) == 0u;
    int64_t dist = h->pass == 0 ? (int64_t)travel * SEARCH_NUM / SEARCH_DEN
                   : h->pass == 2 ? (int64_t)h->cfg.pulloff_um * LOCATE_SCALE
                                  : (int64_t)h->cfg.pulloff_um;
    if (dist > PK_UM_MAX)
        dist = PK_UM_MAX;
    for (uint32_t i = 0; i < m->cfg.axes; i++) {
        if ((g & (1u << i)) == 0u)
            continue;
        bool negative = ((h->cfg.dir_invert >> i) & 1u) != 0u;
        if (!approach)
            negative = !negative;
        target[i] = (pk_um_t)(negative ? -dist : dist);
    }
    uint64_t rate = h->pass == 2 ? h->cfg.feed : h->cfg.seek;
    uint64_t diag = pk_isqrt64(rate * rate * n);   /* rate <= 6e7: rate^2 * 4 < 2^54 */
    if (diag > PK_UM_MIN_MAX)
        diag = PK_UM_MIN_MAX;
    int rc = approach ? pk_machine_home_seek(m, g, target, (pk_um_min_t)diag)
                      : pk_machine_home_pulloff(m, target, (pk_um_min_t)diag);
    return rc == PK_MOTION_OK ? 0 : -1;
}

/* The group is homed: Grbl's machine position for each of its axes. */
static int set_homed(struct pk_home *h)
{
    struct pk_machine *m = h->m;
    const uint8_t g = h->group[h->gi];
    pk_steps_t pos[PK_AXES];
    pk_machine_position_steps(m, pos);
    for (uint32_t i = 0; i < m->cfg.axes; i++) {
        if ((g & (1u << i)) == 0u)
            continue;
        pk_um_t um = ((h->cfg.dir_invert >> i) & 1u) != 0u ? -h->cfg.travel_um[i] + h->cfg.pulloff_um
                                                           : -h->cfg.pulloff_um;
        pos[i] = pk_um_to_steps(um, m->cfg.steps_per_mm_q16[i]);
    }
    return pk_machine_set_position(m, pos);
}

static uint64_t now_ticks(const struct pk_home *h)
{
    return h->m->hal->ops->clock_ticks(h->m->hal->ctx);
}

int pk_home_poll(struct pk_home *h)
{
    if (h->status != PK_HOME_RUNNING)
        return h->status;
    struct pk_machine *m = h->m;
    /* at most one pass step advances per loop turn; 4 passes x 2 groups bound it */
    for (unsigned turn = 0; turn < 32u; turn++) {
        if (pk_machine_state(m) == PK_STATE_ALARM)
            return finish(h, PK_HOME_FAIL, PK_HOME_FAIL_RESET);
        if (h->step == STEP_START) {
            if (start_pass(h) != 0)
                return finish(h, PK_HOME_FAIL, PK_HOME_FAIL_RESET);
            h->step = STEP_MOVING;
            return PK_HOME_RUNNING;
        }
        if (h->step == STEP_MOVING) {
            uint8_t tripped = 0;
            enum pk_cycle_result r = pk_machine_cycle(m, NULL, &tripped);
            if (r == PK_CYCLE_RUNNING)
                return PK_HOME_RUNNING;
            if (r != PK_CYCLE_DONE && r != PK_CYCLE_MISSED)
                return finish(h, PK_HOME_FAIL, PK_HOME_FAIL_RESET);
            bool approach = (h->pass & 1u) == 0u;
            if (approach && r != PK_CYCLE_DONE)
                return finish(h, PK_HOME_FAIL, PK_HOME_FAIL_APPROACH);
            if (!approach && (pk_machine_inputs(m) & h->group[h->gi]) != 0u)
                return finish(h, PK_HOME_FAIL, PK_HOME_FAIL_PULLOFF);
            h->step = STEP_PAUSE;
            h->until = now_ticks(h) + (uint64_t)h->cfg.debounce_ms * m->hal->tick_hz / 1000u;
        }
        /* STEP_PAUSE */
        if (now_ticks(h) < h->until)
            return PK_HOME_RUNNING;
        h->step = STEP_START;
        if (++h->pass < 4u)
            continue;
        if (set_homed(h) != PK_MOTION_OK)
            return finish(h, PK_HOME_FAIL, PK_HOME_FAIL_RESET);
        h->pass = 0;
        if (++h->gi >= h->n_groups)
            return finish(h, PK_HOME_DONE, PK_HOME_FAIL_NONE);
    }
    return PK_HOME_RUNNING;
}

void pk_home_abort(struct pk_home *h, enum pk_home_fail fail)
{
    if (h->status != PK_HOME_RUNNING)
        return;
    (void)pk_machine_reset(h->m);
    (void)finish(h, PK_HOME_FAIL, (uint8_t)fail);
}

enum pk_home_fail pk_home_fail(const struct pk_home *h) { return (enum pk_home_fail)h->fail; }
