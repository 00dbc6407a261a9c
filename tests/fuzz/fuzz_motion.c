/*
 * fuzz_motion.c — libFuzzer target for the motion core (pk_motion.h):
 * stroke assembler + kernel + planner + step generator, fed random requests
 * on a simulated clock, with HAL faults, resets and holds at random moments.
 *
 * The harness has its own HAL: a 1 MHz simulated timer and step/dir/tool
 * outputs that it decodes itself (rising step edges, signed by the direction
 * level at that moment), independently of the code under test. The input
 * chooses the machine settings (axes, steps/mm with fractions, max rates,
 * accelerations, junction deviation, pulse and set-up times, smoothing
 * policy) and then a program: feed and rapid moves, pen changes, dwells,
 * smoothing changes, end of program, simulated time passing, feed hold,
 * resume, reset, and a HAL write that fails after k more writes.
 *
 * Invariants checked:
 *   - the reported step position always equals the steps decoded from the
 *     pins (so after a fault or a reset it is the pulses really emitted).
 *   - when the program has run out and the machine is idle, every axis is
 *     exactly at round(target_um * steps_per_mm / 1000) (ties away from
 *     zero, computed here in exact integers) of the last accepted target.
 *   - a failing HAL write puts the machine in ALARM, which refuses moves
 *     with PK_MOTION_EALARM; reset leaves it; EFULL/ERANGE change nothing.
 *   - speed: any 32 consecutive steps of an axis (31 intervals) take at
 *     least as long as 29 steps at the axis's max rate, less 2 ticks: whole
 *     steps at segment ends (round(um * steps/mm)) and the edge phase allow
 *     2 steps more than max_rate * duration in any window, no more.
 *   - driver timing: a step pulse lasts at least step_pulse_ticks; a
 *     direction change comes at least dir_setup_ticks before the next rising
 *     step edge of that axis; no edge is ever written at a time earlier than
 *     the previous one.
 *   - the machine finishes: with holds resumed, everything drains within a
 *     simulated-time budget derived from the program.
 *   - soft limits (armed when switched on while the machine is idle inside
 *     the box): a move with its target outside is refused with ETRAVEL, and
 *     the position on the pins never leaves the box, whatever the smoothing
 *     (to the step within half a step of the path: [ceil(lo - 1/2),
 *     floor(hi + 1/2)] in steps).
 *   - overrides: 10..200 % feed and 1..100 % rapid accepted, others ERANGE;
 *     the axis rates stay within their max rates whatever the override.
 *   - a pen change dwells: no step edge within pen_settle_ms after the tool
 *     output was written (until a reset ends the dwell).
 *
 * Cost per input (the campaign's rate): the work is one timer callback per
 * step edge and one main-loop poll per simulated millisecond, so each input
 * gets a work budget: at most WORK_STEPS commanded steps (all axes) and
 * WORK_MS simulated milliseconds of estimated motion, dwell and waiting. An
 * op that would exceed either is skipped (its bytes are still consumed), so
 * every program the harness issues still runs to its end and is checked
 * exactly. Inputs are capped at MAX_INPUT bytes (tests/fuzz/fuzz_motion.options
 * passes the same -max_len) and MAX_OPS ops.
 */
#include "fuzz_common.h"
#include "pk_motion.h"

#include <math.h>
#include <string.h>

#ifndef FZ_STRICT
#define FZ_STRICT 0
#endif

#define TICK_HZ 1000000u
#define RING 32u
#define MAX_INPUT 256u
#define MAX_OPS 64u
#define WORK_STEPS 600u
#define WORK_MS 1000u

static int VERBOSE; /* FUZZ_MOTION_VERBOSE set: print the program as it runs */

/* ---- the harness's HAL ------------------------------------------------------ */
static struct {
    uint64_t now;
    pk_hal_timer_cb cb;
    void *arg;
    uint64_t next;
    uint32_t step_raw, dir_raw;
    long fail_after;           /* -1 never; else writes left before one fails */
    int failed;
    int in_reset;              /* pk_machine_reset is running (MAIN context) */
    int failed_in_reset;       /* the failing write was the reset's own */
    int64_t pos[PK_AXES];      /* decoded from the pins */
    uint64_t rise[PK_AXES], dir_change[PK_AXES];
    uint64_t hist[PK_AXES][RING];
    unsigned nh[PK_AXES];
    double max_sps[PK_AXES];
    uint32_t pulse_ticks, setup_ticks;
    uint64_t last_write;
    uint64_t edges;
    uint64_t reset_until;      /* a reset caught a pulse: idle from then on (0: none) */
    int soft_armed;            /* soft limits on, machine inside: check every step */
    int64_t slo[PK_AXES], shi[PK_AXES]; /* the box in steps */
    uint64_t settle_until;     /* a pen change: no step edge before (0: none) */
    uint32_t settle_ticks;
} H;

static int h_fault(void)
{
    if (H.fail_after == 0) {
        if (VERBOSE)
            fprintf(stderr, "t=%.6f s: a HAL write fails (injected)\n", (double)H.now / TICK_HZ);
        H.failed = 1;
        H.failed_in_reset = H.in_reset;
        H.fail_after = -1; /* one injected failure at a time */
        return PK_HAL_EIO;
    }
    if (H.fail_after > 0)
        H.fail_after--;
    FZ_CHECK(H.now >= H.last_write, "pin writes never go back in time");
    H.last_write = H.now;
    return PK_HAL_OK;
}

static int h_step(void *c, uint32_t mask, uint32_t levels)
{
    (void)c;
    if (h_fault())
        return PK_HAL_EIO;
    for (unsigned a = 0; a < PK_AXES; a++) {
        uint32_t bit = 1u << a;
        if (!(mask & bit))
            continue;
        int was = (H.step_raw & bit) != 0, is = (levels & bit) != 0;
        if (!was && is) { /* rising edge: one step */
            FZ_CHECK(H.now >= H.dir_change[a] + H.setup_ticks || H.dir_change[a] == 0,
                     "direction set up before the step edge");
            H.pos[a] += (H.dir_raw & bit) ? 1 : -1;
            H.rise[a] = H.now;
            if (H.now < H.settle_until)
                fprintf(stderr, "axis %u steps at t=%llu, %llu ticks into the %u-tick dwell after a pen change\n", a,
                        (unsigned long long)H.now, (unsigned long long)(H.now - (H.settle_until - H.settle_ticks)),
                        (unsigned)H.settle_ticks);
            FZ_CHECK(H.now >= H.settle_until, "no step during the dwell after a pen change");
            if (H.soft_armed && (H.pos[a] < H.slo[a] || H.pos[a] > H.shi[a]))
                fprintf(stderr, "axis %u at %lld steps, soft limits [%lld, %lld]\n", a,
                        (long long)H.pos[a], (long long)H.slo[a], (long long)H.shi[a]);
            FZ_CHECK(!H.soft_armed || (H.pos[a] >= H.slo[a] && H.pos[a] <= H.shi[a]),
                     "the executed path stays inside the soft limits");
            H.edges++;
            /* rate over the last RING steps of this axis */
            unsigned k = H.nh[a]++;
            H.hist[a][k % RING] = H.now;
            if (k >= RING) {
                double span = (double)(H.now - H.hist[a][(k + 1u) % RING]);
                /* Steps are whole: each segment's end is round(um * steps/mm),
                 * so the steps in a window can exceed max_rate * duration by
                 * the rounding at the window's two ends (1 step) plus the
                 * edge phase (1 step), whatever the segment lengths inside.
                 * Hence the count minus 2, over the span +-2 ticks. */
                double rate = (RING - 3u) * (double)TICK_HZ / (span > 2 ? span - 2 : 0.5);
                /* Finding M3 (fixed: the planner plans in steps) once let an
                 * axis run over its max rate at coarse steps/mm; no allowance. */
                double allowed = H.max_sps[a];
                if (rate > allowed) {
                    fprintf(stderr, "axis %u: %.1f steps/s over %u steps, limit %.1f; intervals:", a,
                            rate, RING - 1u, H.max_sps[a]);
                    for (unsigned j = 1; j < RING; j++)
                        fprintf(stderr, " %llu", (unsigned long long)(H.hist[a][(k + 1u + j) % RING] -
                                                                      H.hist[a][(k + j) % RING]));
                    fprintf(stderr, "\n");
                }
                FZ_CHECK(rate <= allowed, "axis rate within its max rate");
            }
        }
        /* Every pulse lasts step_pulse_ticks, also across a reset (finding
         * M2, fixed: the timer ends a pulse the reset caught). */
        if (was && !is)
            FZ_CHECK(H.now >= H.rise[a] + H.pulse_ticks, "step pulse lasts step_pulse_ticks");
    }
    H.step_raw = (H.step_raw & ~mask) | (levels & mask);
    return PK_HAL_OK;
}

static int h_dir(void *c, uint32_t mask, uint32_t levels)
{
    (void)c;
    if (h_fault())
        return PK_HAL_EIO;
    for (unsigned a = 0; a < PK_AXES; a++) {
        uint32_t bit = 1u << a;
        if ((mask & bit) && ((H.dir_raw ^ levels) & bit)) {
            H.dir_change[a] = H.now;
            H.nh[a] = 0; /* a reversal happens at rest: restart the rate window */
        }
    }
    H.dir_raw = (H.dir_raw & ~mask) | (levels & mask);
    return PK_HAL_OK;
}

static int h_enable(void *c, uint32_t mask, uint32_t levels)
{
    (void)c;
    (void)mask;
    (void)levels;
    return h_fault();
}

static int h_tool(void *c, uint32_t level)
{
    (void)c;
    (void)level;
    int r = h_fault();
    if (r == PK_HAL_OK)
        H.settle_until = H.now + H.settle_ticks;
    return r;
}

static int h_spindle(void *c, uint16_t value_q16)
{
    (void)c;
    (void)value_q16;
    return h_fault();
}

static int h_tstart(void *c, pk_hal_timer_cb cb, void *arg, uint64_t first)
{
    (void)c;
    H.cb = cb;
    H.arg = arg;
    H.next = first < H.now ? H.now : first;
    return PK_HAL_OK;
}

static int h_tstop(void *c)
{
    (void)c;
    H.cb = NULL;
    return PK_HAL_OK;
}

static uint64_t h_clock(void *c) { (void)c; return H.now; }

static const struct pk_hal_ops H_OPS = {
    .version = PK_HAL_VERSION,
    .step_write = h_step,
    .dir_write = h_dir,
    .enable_write = h_enable,
    .tool_write = h_tool,
    .spindle_write = h_spindle,
    .timer_start = h_tstart,
    .timer_stop = h_tstop,
    .clock_ticks = h_clock,
};

/* Run the timer up to `until`. */
static void advance(uint64_t until)
{
    while (H.cb != NULL && H.next <= until) {
        if (H.next > H.now)
            H.now = H.next;
        uint64_t nx = H.cb(H.arg, H.now);
        if (nx == 0) {
            H.cb = NULL;
            break;
        }
        FZ_CHECK(nx > H.now, "the step timer asks for a later tick");
        H.next = nx;
    }
    if (until > H.now)
        H.now = until;
}

/* ---- oracle ----------------------------------------------------------------------- */
static int64_t oracle_steps(pk_um_t um, pk_spmm_q16_t s)
{
    int64_t num = (int64_t)um * (int64_t)s, den = (int64_t)1000 << 16;
    return num >= 0 ? (num + den / 2) / den : -((-num + den / 2) / den);
}

static struct pk_machine MACH;
static struct pk_motion_cfg CFG;

/* The soft-limit box in steps: a path point within [lo, hi] um, stepped to
 * within half a step, is on a step in [ceil(lo*s - 1/2), floor(hi*s + 1/2)]. */
static int64_t soft_steps(pk_um_t um, pk_spmm_q16_t s, int upper)
{
    const int64_t D = (int64_t)1000 << 16; /* um * s / D = steps */
    int64_t n2 = 2 * (int64_t)um * s + (upper ? D : -D), d2 = 2 * D; /* (um*s -+ D/2) / D */
    int64_t q = n2 / d2, r = n2 % d2;      /* truncated toward zero */
    if (upper)
        return r < 0 ? q - 1 : q;          /* floor */
    return r > 0 ? q + 1 : q;              /* ceil */
}

static struct {
    int on;
    pk_um_t lo[PK_AXES], hi[PK_AXES];
} SOFT;

/* A move the machine answered r: with soft limits on, a target outside the box is refused. */
static void soft_check_move(const pk_um_t *p, int r)
{
    if (!SOFT.on)
        return;
    int out = 0;
    for (unsigned a = 0; a < CFG.axes; a++)
        out |= p[a] < SOFT.lo[a] || p[a] > SOFT.hi[a];
    /* (a target inside may be refused too: the smoothed run through earlier
     * points, or DLG's overshoot, could leave the box) */
    if (out)
        FZ_CHECK(r == PK_MOTION_ETRAVEL || r == PK_MOTION_EFULL || r == PK_MOTION_EALARM,
                 "soft limits refuse a target outside the box (ETRAVEL)");
}

/* ---- work budget -------------------------------------------------------------------- */
static struct {
    uint64_t steps; /* steps commanded so far (all axes) */
    double ms;      /* simulated ms the program needs, estimated */
    unsigned min_pct; /* slowest override set so far (feed or rapid): times scale by 100/it */
} W;

/* Take the cost of an op from the budget; 0 (and nothing taken) if it does not fit. */
static int work_take(uint64_t steps, double ms)
{
    if (W.steps + steps > WORK_STEPS || W.ms + ms > WORK_MS)
        return 0;
    W.steps += steps;
    W.ms += ms;
    return 1;
}

/* A move's steps and an upper estimate of its time, ms (feed 0: rapid): the
 * length at the feed clamped to every axis's max rate, plus a full stop and
 * start at the slowest axis's acceleration. */
static int work_take_move(const pk_um_t *from, const pk_um_t *to, pk_um_min_t feed)
{
    uint64_t steps = 0;
    double d2 = 0, v = feed ? feed / 60.0 : 1e12, acc = 1e12; /* um/s, um/s^2 */
    for (unsigned a = 0; a < CFG.axes; a++) {
        int64_t ds = oracle_steps(to[a], CFG.steps_per_mm_q16[a]) - oracle_steps(from[a], CFG.steps_per_mm_q16[a]);
        steps += (uint64_t)(ds < 0 ? -ds : ds);
        d2 += ((double)to[a] - from[a]) * ((double)to[a] - from[a]);
    }
    double d = sqrt(d2);
    for (unsigned a = 0; a < CFG.axes; a++) {
        double da = fabs((double)to[a] - from[a]);
        if (da == 0)
            continue;
        double va = CFG.max_rate[a] / 60.0 * d / da;
        if (va < v)
            v = va;
        if (CFG.accel[a] < acc)
            acc = CFG.accel[a];
    }
    return work_take(steps, d > 0 ? 1000.0 * (d / v + v / acc) * 100.0 / W.min_pct : 0.0);
}

static void check_position(void)
{
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&MACH, p);
    for (unsigned a = 0; a < PK_AXES; a++)
        FZ_CHECK(p[a] == H.pos[a], "reported position equals the steps on the pins");
}

/* A reset whose own step-line write fails leaves the machine in ALARM
 * (finding M1, fixed): H.failed stays set, as for any failing write. */
static void do_reset(void)
{
    H.in_reset = 1;
    pk_machine_reset(&MACH);
    H.in_reset = 0;
    H.settle_until = 0; /* a reset drops the dwell */
}

static void poll_for(uint64_t ticks)
{
    uint64_t end = H.now + ticks;
    while (H.now < end) {
        pk_machine_poll(&MACH);
        uint64_t t = H.now + 1000u; /* the main loop runs every millisecond */
        advance(t < end ? t : end);
        check_position();
        if (H.reset_until != 0u && H.now >= H.reset_until) {
            if (VERBOSE)
                fprintf(stderr, "t=%.6f s: %llu ticks after a reset caught a pulse: state %d, step lines %#x, timer %s\n",
                        (double)H.now / TICK_HZ, (unsigned long long)(H.now - H.reset_until),
                        (int)pk_machine_state(&MACH), (unsigned)H.step_raw, H.cb ? "armed" : "stopped");
            FZ_CHECK(H.failed || (pk_machine_state(&MACH) == PK_STATE_IDLE && H.step_raw == 0u),
                     "after the pulse a reset caught, the machine is idle, step lines low");
            H.reset_until = 0;
        }
    }
}

/* A request after a reset may start new motion (or hold it): the reset's own check ends. */
static void requested(void) { H.reset_until = 0; }

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    struct fz_in in = { data, size < MAX_INPUT ? size : MAX_INPUT, 0 };
    VERBOSE = getenv("FUZZ_MOTION_VERBOSE") != NULL;
    memset(&H, 0, sizeof H);
    memset(&W, 0, sizeof W);
    W.min_pct = 100u;
    memset(&SOFT, 0, sizeof SOFT);
    H.fail_after = -1;
    memset(&CFG, 0, sizeof CFG);
    uint8_t b = fz_u8(&in);
    CFG.axes = (b & 1u) ? 3u : 2u;
    for (unsigned a = 0; a < PK_AXES; a++) {
        /* 1/16 .. ~200 steps/mm, with a fraction (rounding matters) */
        uint32_t s = PK_SPMM_Q16_MIN + fz_u32(&in) % (200u << 16);
        CFG.steps_per_mm_q16[a] = s;
        CFG.max_rate[a] = 600000u + (uint32_t)fz_u8(&in) * 40000u;   /* 600..10800 mm/min */
        CFG.accel[a] = 50000u + (uint32_t)fz_u8(&in) * 20000u;       /* 50..5150 mm/s^2 */
        H.max_sps[a] = (double)CFG.max_rate[a] / 60000.0 * (double)s / 65536.0;
    }
    uint8_t c = fz_u8(&in);
    CFG.junction_dev_um = (pk_um_t)(c & 63u) * 10;
    CFG.step_pulse_ticks = 1u + ((c >> 6) & 3u);
    CFG.dir_setup_ticks = (uint32_t)fz_u8(&in) & 7u;
    CFG.pen_settle_ms = fz_u8(&in) & 15u;
    CFG.pen_down_level = 1;
    uint8_t sm = fz_u8(&in);
    CFG.smooth.mode = sm % 3u;
    CFG.smooth.scheme = (sm >> 2) & 1u;
    CFG.smooth.degree = CFG.smooth.mode == PK_SMOOTH_TOLERANCE ? 2u + ((sm >> 3) & 1u) : 1u + ((sm >> 3) & 3u);
    CFG.smooth.depth = (sm >> 5) & 3u;
    CFG.smooth.tolerance_um = 1 + fz_u8(&in) * 20;
    CFG.smooth.sharp_turn_deg = (uint16_t)(fz_u8(&in) % 181u);
    H.pulse_ticks = CFG.step_pulse_ticks;
    H.setup_ticks = CFG.dir_setup_ticks;
    H.settle_ticks = CFG.pen_settle_ms * (TICK_HZ / 1000u);

    if (VERBOSE)
        fprintf(stderr, "axes %u, steps/mm %.4f %.4f %.4f, smoothing mode %u scheme %u degree %u depth %u tol %d um\n",
                CFG.axes, CFG.steps_per_mm_q16[0] / 65536.0, CFG.steps_per_mm_q16[1] / 65536.0,
                CFG.steps_per_mm_q16[2] / 65536.0, CFG.smooth.mode, CFG.smooth.scheme, CFG.smooth.degree,
                CFG.smooth.depth, (int)CFG.smooth.tolerance_um);
    struct pk_hal hal = { .ops = &H_OPS, .ctx = NULL, .tick_hz = TICK_HZ };
    int rc = pk_machine_init(&MACH, &CFG, &hal);
    if (rc != PK_MOTION_OK) {
        if (VERBOSE)
            fprintf(stderr, "init refused: %d\n", rc);
        FZ_CHECK(rc == PK_MOTION_EINVAL, "init refuses only with EINVAL here");
        return 0;
    }
    check_position();
    H.settle_until = 0; /* init's pen-up write is no pen change: no dwell promised */

    pk_um_t target[PK_AXES] = { 0, 0, 0 }; /* last accepted target */
    pk_um_t cur[PK_AXES] = { 0, 0, 0 };
    unsigned ops = 0;
    uint64_t budget = 0; /* simulated time the program may need */
    while (fz_more(&in) && ops++ < MAX_OPS) {
        uint8_t op = fz_u8(&in);
        int r = PK_MOTION_OK;
        if (VERBOSE)
            fprintf(stderr, "t=%.6f s: op %u, state %d\n", (double)H.now / TICK_HZ, op & 15u,
                    (int)pk_machine_state(&MACH));
        switch (op & 15u) {
        case 0: case 1: case 2: case 3: case 4: { /* feed move, a few mm at most */
            pk_um_t p[PK_AXES];
            for (unsigned a = 0; a < PK_AXES; a++) {
                int32_t v = cur[a] + (int8_t)fz_u8(&in) * 40;
                p[a] = v > 20000 ? 20000 : v < -20000 ? -20000 : v;
            }
            pk_um_min_t f = 300000u + (uint32_t)fz_u8(&in) * 24000u; /* 300..6420 mm/min */
            if (!work_take_move(cur, p, f))
                break;
            requested();
            r = pk_machine_move(&MACH, p, f, PK_MOVE_FEED);
            if (VERBOSE)
                fprintf(stderr, "  feed move to %d %d %d um at %u um/min\n", (int)p[0], (int)p[1], (int)p[2], (unsigned)f);
            soft_check_move(p, r);
            if (r == PK_MOTION_OK) {
                double d2 = 0;
                for (unsigned a = 0; a < PK_AXES; a++)
                    d2 += ((double)p[a] - cur[a]) * ((double)p[a] - cur[a]);
                /* generous: twice the time at the feed, plus a stop and a start */
                budget += (uint64_t)(2.0 * sqrt(d2) / (f / 60.0) * TICK_HZ * 100.0 / W.min_pct) + TICK_HZ / 2u;
                memcpy(target, p, sizeof p);
                memcpy(cur, p, sizeof p);
            }
            break;
        }
        case 5: { /* rapid */
            pk_um_t p[PK_AXES];
            for (unsigned a = 0; a < PK_AXES; a++)
                p[a] = (pk_um_t)((int16_t)fz_u16(&in) % 20001);
            if (!work_take_move(cur, p, 0))
                break;
            requested();
            r = pk_machine_move(&MACH, p, 0, PK_MOVE_RAPID);
            if (VERBOSE)
                fprintf(stderr, "  rapid to %d %d %d um\n", (int)p[0], (int)p[1], (int)p[2]);
            soft_check_move(p, r);
            if (r == PK_MOTION_OK) {
                memcpy(target, p, sizeof p);
                memcpy(cur, p, sizeof p);
                budget += 2u * TICK_HZ * 100u / W.min_pct;
            }
            break;
        }
        case 6: /* out-of-range move: refused, nothing changes */
        {
            pk_um_t p[PK_AXES] = { PK_UM_MAX + 1, 0, 0 };
            r = pk_machine_move(&MACH, p, 1000u, PK_MOVE_FEED);
            FZ_CHECK(r == PK_MOTION_ERANGE || r == PK_MOTION_EALARM || r == PK_MOTION_EFULL,
                     "an out-of-range target is refused");
            r = pk_machine_move(&MACH, cur, 0u, PK_MOVE_FEED); /* feed 0: out of range */
            FZ_CHECK(r == PK_MOTION_ERANGE || r == PK_MOTION_EALARM || r == PK_MOTION_EFULL,
                     "a zero feed is refused");
            r = PK_MOTION_OK;
            break;
        }
        case 7:
            if (!work_take(0, CFG.pen_settle_ms + 1.0))
                break;
            requested();
            r = pk_machine_pen(&MACH, (op >> 4) & 1u);
            budget += TICK_HZ / 10u;
            break;
        case 8: {
            uint32_t ms = fz_u8(&in) & 31u;
            if (!work_take(0, ms + 1.0))
                break;
            requested();
            r = pk_machine_dwell(&MACH, ms);
            budget += TICK_HZ / 10u;
            break;
        }
        case 9: {
            struct pk_smooth_cfg s = CFG.smooth;
            uint8_t x = fz_u8(&in);
            s.mode = x % 3u;
            s.depth = (x >> 2) & 3u;
            s.tolerance_um = 1 + (x >> 4) * 50;
            requested();
            r = pk_machine_set_smoothing(&MACH, &s);
            if (r == PK_MOTION_EINVAL)
                r = PK_MOTION_OK;
            break;
        }
        case 10:
            requested();
            r = pk_machine_end(&MACH);
            break;
        case 11: { /* time passes */
            uint64_t ms = (uint64_t)fz_u8(&in) + 1u;
            if (work_take(0, (double)ms))
                poll_for(ms * 1000u);
            break;
        }
        case 12: {
            uint64_t ms = (uint64_t)fz_u8(&in) & 63u;
            if (!work_take(0, (double)ms))
                break;
            requested(); /* a hold in the tail of a reset's pulse may stop there (HOLD) */
            pk_machine_hold(&MACH);
            poll_for(ms * 1000u);
            pk_machine_resume(&MACH);
            break;
        }
        case 13: { /* reset at this moment */
            do_reset();
            check_position();
            pk_steps_t p[PK_AXES];
            pk_machine_position_steps(&MACH, p);
            if (!H.failed && pk_machine_state(&MACH) != PK_STATE_IDLE) {
                /* finding M2's fix: a step pulse high at the reset ends after
                 * its full width (checked in h_step), then the timer stops */
                uint64_t end = 0;
                for (unsigned a = 0; a < PK_AXES; a++)
                    if ((H.step_raw >> a) & 1u && H.rise[a] + H.pulse_ticks > end)
                        end = H.rise[a] + H.pulse_ticks;
                FZ_CHECK(H.step_raw != 0u && H.cb != NULL && H.next <= end,
                         "a reset leaves an idle machine, or one ending a step pulse on time");
                H.reset_until = end;
            }
            /* the next moves start where the machine really is */
            pk_machine_position_um(&MACH, cur);
            memcpy(target, cur, sizeof cur);
            for (unsigned a = 0; a < PK_AXES; a++) /* target = the steps we are on */
                if (oracle_steps(cur[a], CFG.steps_per_mm_q16[a]) != p[a])
                    target[a] = PK_UM_MAX + 1; /* not representable: compare steps below */
            break;
        }
        case 14: /* a HAL write fails after k more writes */
            H.fail_after = fz_u8(&in);
            break;
        default: /* 15: the main loop runs once; or the machine API's other requests */
            switch (op >> 4) {
            case 8: case 9: { /* feed and rapid overrides, valid or not */
                unsigned fp = 5u + fz_u8(&in), rp = fz_u8(&in) & 127u;
                int valid = fp >= 10u && fp <= 200u && rp >= 1u && rp <= 100u;
                unsigned m = valid && fp < W.min_pct ? fp : W.min_pct;
                m = valid && rp < m ? rp : m;
                if (W.ms * W.min_pct / m > WORK_MS)
                    break; /* queued motion would run too long */
                r = pk_machine_set_override(&MACH, (uint16_t)fp, (uint16_t)rp);
                FZ_CHECK(valid ? r == PK_MOTION_OK : r == PK_MOTION_ERANGE,
                         "overrides: feed 10..200 %, rapid 1..100 %, others ERANGE");
                if (r == PK_MOTION_OK && m < W.min_pct) {
                    W.ms = W.ms * W.min_pct / m;
                    budget = budget * W.min_pct / m;
                    W.min_pct = m;
                }
                r = PK_MOTION_OK;
                break;
            }
            case 10: { /* soft limits on: a box around the commanded position (or a bad one) */
                pk_um_t lo[PK_AXES], hi[PK_AXES];
                uint8_t k = fz_u8(&in);
                for (unsigned a = 0; a < PK_AXES; a++) {
                    lo[a] = cur[a] - (pk_um_t)fz_u8(&in) * 50;
                    hi[a] = cur[a] + (pk_um_t)fz_u8(&in) * 50;
                }
                if ((k & 7u) == 0u)
                    hi[k >> 6 < PK_AXES ? k >> 6 : 0] = lo[0] - 1; /* lo > hi: refused */
                int valid = 1;
                for (unsigned a = 0; a < CFG.axes; a++) /* axes beyond are ignored */
                    valid &= lo[a] <= hi[a];
                r = pk_machine_set_soft_limits(&MACH, true, lo, hi);
                if (VERBOSE)
                    fprintf(stderr, "  soft limits on: X [%d, %d] Y [%d, %d] Z [%d, %d] um -> %d\n", (int)lo[0],
                            (int)hi[0], (int)lo[1], (int)hi[1], (int)lo[2], (int)hi[2], r);
                FZ_CHECK(valid ? r == PK_MOTION_OK : r == PK_MOTION_ERANGE, "soft limits: lo <= hi, else ERANGE");
                if (r == PK_MOTION_OK) {
                    SOFT.on = 1;
                    memcpy(SOFT.lo, lo, sizeof lo);
                    memcpy(SOFT.hi, hi, sizeof hi);
                    /* armed if nothing is queued or moving and the machine is inside */
                    int idle = pk_machine_state(&MACH) == PK_STATE_IDLE && H.cb == NULL &&
                               pk_machine_room(&MACH) == PK_MACHINE_INQ && pk_machine_queue_fill(&MACH) == 0u;
                    H.soft_armed = idle;
                    for (unsigned a = 0; a < CFG.axes; a++) {
                        H.slo[a] = soft_steps(lo[a], CFG.steps_per_mm_q16[a], 0);
                        H.shi[a] = soft_steps(hi[a], CFG.steps_per_mm_q16[a], 1);
                        if (H.pos[a] < H.slo[a] || H.pos[a] > H.shi[a])
                            H.soft_armed = 0;
                    }
                    for (unsigned a = CFG.axes; a < PK_AXES; a++) {
                        H.slo[a] = INT64_MIN;
                        H.shi[a] = INT64_MAX;
                    }
                }
                r = PK_MOTION_OK;
                break;
            }
            case 11: /* soft limits off */
                r = pk_machine_set_soft_limits(&MACH, false, NULL, NULL);
                FZ_CHECK(r == PK_MOTION_OK, "soft limits off");
                SOFT.on = 0;
                H.soft_armed = 0;
                break;
            case 12: case 13: { /* spindle / laser output, synchronous or per block */
                uint16_t v = fz_u16(&in);
                if (!work_take(0, CFG.pen_settle_ms + 1.0))
                    break;
                requested();
                r = pk_machine_spindle(&MACH, v, (op >> 4) == 12u);
                budget += TICK_HZ / 10u;
                break;
            }
            case 14: { /* a feed move to a chord vertex, chord error 0..10200 um (> 10000 refused) */
                pk_um_t p[PK_AXES];
                for (unsigned a = 0; a < PK_AXES; a++) {
                    int32_t v = cur[a] + (int8_t)fz_u8(&in) * 20;
                    p[a] = v > 20000 ? 20000 : v < -20000 ? -20000 : v;
                }
                pk_um_t err = (pk_um_t)fz_u8(&in) * 40;
                pk_um_min_t f = 300000u + (uint32_t)fz_u8(&in) * 24000u;
                if (!work_take_move(cur, p, f))
                    break;
                requested();
                r = pk_machine_move_chord(&MACH, p, f, err);
                if (err > 10000)
                    FZ_CHECK(r == PK_MOTION_ERANGE || r == PK_MOTION_EALARM || r == PK_MOTION_EFULL,
                             "a chord error over 10 mm is refused");
                else
                    soft_check_move(p, r);
                if (r == PK_MOTION_OK) {
                    double d2 = 0;
                    for (unsigned a = 0; a < PK_AXES; a++)
                        d2 += ((double)p[a] - cur[a]) * ((double)p[a] - cur[a]);
                    budget += (uint64_t)(2.0 * sqrt(d2) / (f / 60.0) * TICK_HZ * 100.0 / W.min_pct) + TICK_HZ / 2u;
                    memcpy(target, p, sizeof p);
                    memcpy(cur, p, sizeof p);
                }
                break;
            }
            default:
                poll_for(1000u);
                break;
            }
            break;
        }
        if (VERBOSE && r != PK_MOTION_OK)
            fprintf(stderr, "  -> %d\n", r);
        if (r == PK_MOTION_EFULL)
            poll_for(1000u); /* nothing changed: the producer waits */
        if (pk_machine_state(&MACH) == PK_STATE_ALARM) {
            FZ_CHECK(H.failed, "ALARM only after a failing HAL write");
            check_position();
            pk_um_t p[PK_AXES] = { 0, 0, 0 };
            FZ_CHECK(pk_machine_move(&MACH, p, 1000u, PK_MOVE_FEED) == PK_MOTION_EALARM,
                     "ALARM refuses moves");
        }
        if (H.failed) { /* the fault happened: run to ALARM, then reset as a user would */
            poll_for(2000u);
            FZ_CHECK(pk_machine_state(&MACH) == PK_STATE_ALARM, "a failed write ends in ALARM");
            check_position();
            H.fail_after = -1;
            H.failed = 0;
            do_reset();
            pk_steps_t p[PK_AXES];
            pk_machine_position_steps(&MACH, p);
            pk_machine_position_um(&MACH, cur);
            memcpy(target, cur, sizeof cur);
            for (unsigned a = 0; a < PK_AXES; a++)
                if (oracle_steps(cur[a], CFG.steps_per_mm_q16[a]) != p[a])
                    target[a] = PK_UM_MAX + 1;
        }
    }
    /* Finish: end the program, no more faults, run until idle. */
    H.fail_after = -1;
    pk_machine_resume(&MACH);
    while (pk_machine_end(&MACH) == PK_MOTION_EFULL)
        poll_for(1000u);
    uint64_t limit = H.now + budget + 5u * TICK_HZ;
    while (H.now < limit) {
        poll_for(1000u);
        if (pk_machine_state(&MACH) == PK_STATE_IDLE && H.cb == NULL && pk_machine_room(&MACH) == PK_MACHINE_INQ)
            break;
    }
    if (pk_machine_state(&MACH) != PK_STATE_IDLE)
        fprintf(stderr, "after %.3f s (budget %.3f s): state %d alarm %d, queue %u, room %u, timer %s\n",
                (double)H.now / TICK_HZ, (double)budget / TICK_HZ, (int)pk_machine_state(&MACH),
                (int)pk_machine_alarm(&MACH), (unsigned)pk_machine_queue_fill(&MACH),
                (unsigned)pk_machine_room(&MACH), H.cb ? "armed" : "stopped");
    FZ_CHECK(pk_machine_state(&MACH) == PK_STATE_IDLE, "the machine finishes the program");
    check_position();
    pk_steps_t p[PK_AXES];
    pk_machine_position_steps(&MACH, p);
    for (unsigned a = 0; a < CFG.axes; a++)
        if (target[a] <= PK_UM_MAX) {
            if (p[a] != oracle_steps(target[a], CFG.steps_per_mm_q16[a]))
                fprintf(stderr, "axis %u: at %d steps, commanded %d um = %lld steps\n", a, (int)p[a],
                        (int)target[a], (long long)oracle_steps(target[a], CFG.steps_per_mm_q16[a]));
            int64_t off = p[a] - oracle_steps(target[a], CFG.steps_per_mm_q16[a]);
            FZ_CHECK(off == 0,
                     "the final position is exactly the commanded one, in steps");
        }
    if (VERBOSE)
        fprintf(stderr, "axes %u: %llu step edges, %.3f s simulated, position %d %d %d steps\n",
                CFG.axes, (unsigned long long)H.edges, (double)H.now / TICK_HZ, (int)p[0], (int)p[1],
                (int)p[2]);
    return 0;
}
