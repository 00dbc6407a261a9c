/*
 * pk_grbl.c — Grbl 1.1 protocol engine: realtime commands, line assembly,
 * the `$` commands, and the execution of accepted G-code blocks (see
 * pk_grbl.h for the contract; printing is in pk_grbl_report.c, settings and
 * the store layout in pk_grbl_settings.c).
 *
 * Flow of one poll:
 *   1. realtime flags (reset first, then status, hold, cycle start, jog
 *      cancel, overrides, coolant toggles), as Grbl's protocol_exec_rt_system
 *   2. machine alarm detection; jog end/cancel; soft-limit stop and sleep
 *   3. pending output: greeting, status report, messages, multi-line reports
 *   4. the accepted command still being handed to the machine (each PK_GC_DO_*
 *      step in Grbl's order, waiting for an empty queue where Grbl syncs):
 *      while it is not done, NO byte is read, so a sender's unacknowledged
 *      bytes wait in the receive ring; its "ok" is sent when it is done
 *   5. read bytes and answer lines until one needs to wait, and not while the
 *      machine is held (Grbl's suspend) or the engine is locked
 * Output is staged in g->out and flushed as the stream takes it; nothing is
 * read unless the staging buffer has room for the largest answer.
 */
#include "pk_grbl_internal.h"

/* A counter of pk_grbl.stats (PK_GRBL_STATS; else nothing). */
#if PK_GRBL_STATS
#define STAT_INC(g, field) ((g)->stats.field++)
#else
#define STAT_INC(g, field) ((void)(g))
#endif

#include <string.h>

/* line_flags */
#define LF_OVERFLOW 0x01u
#define LF_LOST 0x02u
#define LF_PAREN 0x04u
#define LF_SEMI 0x08u

/* Grbl states the $ commands are allowed in */
enum { GS_IDLE, GS_RUN, GS_HOLD, GS_JOG, GS_ALARM, GS_CHECK, GS_SLEEP };

/* alarm code latched without an ALARM:n line (homing lock at start, sleep) */
#define ALARM_LOCK 255u

/* chords handed over per poll at most (keeps realtime handling prompt) */
#define CHORDS_PER_POLL 32

static void soft_reset(struct pk_grbl *g);
static void run_pending(struct pk_grbl *g);
static void home_failed(struct pk_grbl *g, int alarm);

int pk_grbl_mstate(const struct pk_grbl *g) { return g->mo.state(g->m); }

static int gstate(const struct pk_grbl *g)
{
    int st = pk_grbl_mstate(g);
    if (g->mode == MODE_SLEEP || g->mode == MODE_SLEEP_REQ)
        return GS_SLEEP;
    if (g->alarm || st == PK_GRBL_M_ALARM || g->mode == MODE_CRITICAL || g->mode == MODE_SOFTLIMIT)
        return GS_ALARM;
    if (g->check_mode)
        return GS_CHECK;
    if (g->jogging)
        return GS_JOG;
    if (st == PK_GRBL_M_HOLD || st == PK_GRBL_M_HOLDING || g->mode == MODE_IDLE_HOLD)
        return GS_HOLD;
    if (st == PK_GRBL_M_RUN || g->todo)
        return GS_RUN;
    return GS_IDLE;
}

/* ---- answers --------------------------------------------------------------------- */

static void answer(struct pk_grbl *g, int status)
{
    if (!g->line_src) /* answers to the stream's lines only */
        STAT_INC(g, lines);
    if (g->line_src) { /* a startup line: ">line:ok" */
        uint8_t buf[PK_GRBL_LINE_MAX];
        unsigned n = pk_grbl_nvm_line_read(g, g->line_src - 1u, buf);
        PK_GRBL_PUTS(g, ">");
        pk_grbl_put(g, (const char *)buf, n);
        PK_GRBL_PUTS(g, ":");
    }
    if (status == 0) {
        if (!g->line_src)
            STAT_INC(g, ok);
        PK_GRBL_PUTS(g, "ok\r\n");
    } else {
        if (!g->line_src)
            STAT_INC(g, errors);
        PK_GRBL_PUTS(g, "error:");
        pk_grbl_put_u32(g, (uint32_t)status);
        PK_GRBL_PUTS(g, "\r\n");
    }
    g->line_src = 0;
}

static void flush(struct pk_grbl *g)
{
    while (g->out_len > 0) {
        int n = g->io.write(g->io.ctx, g->out, g->out_len);
        if (n <= 0)
            return;
        memmove(g->out, g->out + n, (size_t)(g->out_len - (uint16_t)n));
        g->out_len = (uint16_t)(g->out_len - (uint16_t)n);
    }
}

/* ---- realtime ---------------------------------------------------------------- */

int pk_grbl_rt_filter(void *vg, uint8_t b)
{
    struct pk_grbl *g = vg;
    int f;
    switch (b) {
    case 0x18: f = PK_GRBL_RT_RESET; break;
    case '?': f = PK_GRBL_RT_STATUS; break;
    case '!': f = PK_GRBL_RT_HOLD; break;
    case '~': f = PK_GRBL_RT_CYCLE; break;
    case 0x84: f = PK_GRBL_RT_DOOR; break;
    case 0x85: f = PK_GRBL_RT_JOG_CANCEL; break;
    case 0x90: f = PK_GRBL_RT_FEED_RESET; break;
    case 0x91: f = PK_GRBL_RT_FEED_PLUS10; break;
    case 0x92: f = PK_GRBL_RT_FEED_MINUS10; break;
    case 0x93: f = PK_GRBL_RT_FEED_PLUS1; break;
    case 0x94: f = PK_GRBL_RT_FEED_MINUS1; break;
    case 0x95: f = PK_GRBL_RT_RAPID_RESET; break;
    case 0x96: f = PK_GRBL_RT_RAPID_50; break;
    case 0x97: f = PK_GRBL_RT_RAPID_25; break;
    case 0x99: f = PK_GRBL_RT_SPINDLE_RESET; break;
    case 0x9A: f = PK_GRBL_RT_SPINDLE_PLUS10; break;
    case 0x9B: f = PK_GRBL_RT_SPINDLE_MINUS10; break;
    case 0x9C: f = PK_GRBL_RT_SPINDLE_PLUS1; break;
    case 0x9D: f = PK_GRBL_RT_SPINDLE_MINUS1; break;
    case 0x9E: f = PK_GRBL_RT_SPINDLE_STOP; break;
    case 0xA0: f = PK_GRBL_RT_FLOOD; break;
    case 0xA1: f = PK_GRBL_RT_MIST; break;
    default:
        /* Grbl: every other byte >= 0x80 is thrown away */
        return b >= 0x80 ? 1 : 0;
    }
    g->rt[f] = 1;
    g->rt_any = 1;
    return 1;
}

bool pk_grbl_wants_cpu(void *vg)
{
    const struct pk_grbl *g = vg;
    return g->rt_any != 0u || g->out_len > 0u || g->status_due || g->greet_due || g->msg_due;
}

/* Take a flag: the ISR may set it again right after; it is then acted on at
 * the next poll (never lost). */
static int take(struct pk_grbl *g, int f)
{
    if (!g->rt[f])
        return 0;
    g->rt[f] = 0;
    return 1;
}

static void apply_overrides(struct pk_grbl *g)
{
    if (g->mo.set_override)
        (void)g->mo.set_override(g->m, g->ovr_feed, g->ovr_rapid);
}

static void overrides(struct pk_grbl *g)
{
    int f = g->ovr_feed, r = g->ovr_rapid, s = g->ovr_spindle;
    /* Grbl: reset, then coarse +/-, then fine +/-, clamped 10..200 */
    if (take(g, PK_GRBL_RT_FEED_RESET)) f = 100;
    if (take(g, PK_GRBL_RT_FEED_PLUS10)) f += 10;
    if (take(g, PK_GRBL_RT_FEED_MINUS10)) f -= 10;
    if (take(g, PK_GRBL_RT_FEED_PLUS1)) f += 1;
    if (take(g, PK_GRBL_RT_FEED_MINUS1)) f -= 1;
    f = f > 200 ? 200 : f < 10 ? 10 : f;
    if (take(g, PK_GRBL_RT_RAPID_RESET)) r = 100;
    if (take(g, PK_GRBL_RT_RAPID_50)) r = 50;
    if (take(g, PK_GRBL_RT_RAPID_25)) r = 25;
    if (f != g->ovr_feed || r != g->ovr_rapid) {
        g->ovr_feed = (uint8_t)f;
        g->ovr_rapid = (uint8_t)r;
        g->ovr_counter = 0;
        apply_overrides(g);
    }
    if (take(g, PK_GRBL_RT_SPINDLE_RESET)) s = 100;
    if (take(g, PK_GRBL_RT_SPINDLE_PLUS10)) s += 10;
    if (take(g, PK_GRBL_RT_SPINDLE_MINUS10)) s -= 10;
    if (take(g, PK_GRBL_RT_SPINDLE_PLUS1)) s += 1;
    if (take(g, PK_GRBL_RT_SPINDLE_MINUS1)) s -= 1;
    s = s > 200 ? 200 : s < 10 ? 10 : s;
    if (s != g->ovr_spindle) {
        g->ovr_spindle = (uint8_t)s;
        g->ovr_counter = 0;
        if (g->gc.spindle != PK_GC_SPINDLE_OFF)
            g->spindle_due = 1;
    }
    if (take(g, PK_GRBL_RT_SPINDLE_STOP) && gstate(g) == GS_HOLD)
        g->msg_due = MSG_NO_SPINDLE_STOP; /* no way to cut the output of a held queue */
    int flood = take(g, PK_GRBL_RT_FLOOD), mist = take(g, PK_GRBL_RT_MIST);
    if (flood || mist) {
        int gs = gstate(g);
        if (gs == GS_IDLE || gs == GS_RUN || gs == GS_HOLD || gs == GS_JOG) {
            if (flood)
                g->gc.coolant ^= PK_GC_COOLANT_FLOOD;
            if (mist)
                g->gc.coolant ^= PK_GC_COOLANT_MIST;
            g->ovr_counter = 0;
        }
    }
}

/* The buttons and the door input: Grbl's control pins set the same flags
 * as their realtime bytes (reset, feed hold, cycle start, safety door). */
static void input_events(struct pk_grbl *g)
{
    if (!PK_GRBL_INPUTS || !g->mo.inputs)
        return;
    uint32_t ev = g->mo.inputs(g->m, PK_GRBL_IN_EVENTS);
    if (ev & PK_GRBL_IN_RESET)
        g->rt[PK_GRBL_RT_RESET] = 1;
    if (ev & PK_GRBL_IN_HOLD)
        g->rt[PK_GRBL_RT_HOLD] = 1;
    if (ev & PK_GRBL_IN_RESUME)
        g->rt[PK_GRBL_RT_CYCLE] = 1;
    if (ev & PK_GRBL_IN_DOOR)
        g->rt[PK_GRBL_RT_DOOR] = 1;
}

/* The door input is open now (Grbl's system_check_safety_door_ajar). */
static int door_ajar(struct pk_grbl *g)
{
    return PK_GRBL_INPUTS && g->mo.inputs &&
           (g->mo.inputs(g->m, PK_GRBL_IN_LEVELS) & PK_GRBL_IN_DOOR) != 0u;
}

static void realtime(struct pk_grbl *g)
{
    g->rt_any = 0; /* (before the flags are taken: one set after this is seen next time) */
    input_events(g);
    if (take(g, PK_GRBL_RT_RESET)) {
        if (PK_GRBL_INPUTS && g->mode == MODE_HOMING) { /* Grbl: ALARM:6, $H answered, reset */
            g->mo.home_abort(g->m, 6);
            home_failed(g, 6);
        } else {
            soft_reset(g);
        }
        return;
    }
    if (PK_GRBL_INPUTS && g->mode == MODE_HOMING) { /* only '?' and the door act now */
        if (take(g, PK_GRBL_RT_STATUS))
            g->status_due = 1;
        if (take(g, PK_GRBL_RT_DOOR)) {
            g->mo.home_abort(g->m, 7);
            home_failed(g, 7);
        }
        return;
    }
    if (take(g, PK_GRBL_RT_STATUS))
        g->status_due = 1;
    int gs = gstate(g);
    /* 0x84 safety door: no door input and no way to cut the tool output of a
     * held queue, so it is a feed hold, and the sender is told so */
    int door = take(g, PK_GRBL_RT_DOOR);
    if (door)
        g->msg_due = PK_GRBL_INPUTS && g->mo.inputs &&
                             (g->mo.inputs(g->m, PK_GRBL_IN_HAVE) & PK_GRBL_IN_DOOR)
                         ? MSG_DOOR_OPEN : MSG_DOOR_HOLD;
    if ((take(g, PK_GRBL_RT_HOLD) || door) && gs != GS_ALARM && gs != GS_CHECK && gs != GS_SLEEP) {
        if (g->jogging) {
            g->mo.hold(g->m);
            g->jog_cancel = 1;
        } else if (pk_grbl_mstate(g) == PK_GRBL_M_RUN) {
            g->mo.hold(g->m);
        } else if (g->mode == MODE_RUN) {
            g->mode = MODE_IDLE_HOLD; /* Grbl: a hold while idle is complete at once */
        }
    }
    if (take(g, PK_GRBL_RT_CYCLE) && !door_ajar(g)) { /* Grbl: no resume while the door is open */
        if (g->mode == MODE_IDLE_HOLD && pk_grbl_mstate(g) == PK_GRBL_M_IDLE) {
            g->mode = MODE_RUN;
        } else if (pk_grbl_mstate(g) == PK_GRBL_M_HOLD && !g->jog_cancel) {
            g->mo.resume(g->m); /* only a completed hold resumes (Hold:0) */
        }
    }
    if (take(g, PK_GRBL_RT_JOG_CANCEL) && g->jogging && !g->jog_cancel) {
        g->mo.hold(g->m);
        g->jog_cancel = 1;
    }
    overrides(g);
}

/* ---- modal state and the machine ------------------------------------------------- */

static int coord_read_cb(void *ctx, unsigned idx, pk_um_t out[PK_GC_AXES])
{
    return pk_grbl_nvm_coord_read(ctx, idx, out);
}

static struct pk_gc_env make_env(struct pk_grbl *g)
{
    struct pk_gc_env e = { coord_read_cb, g, pk_grbl_setting_scaled(&g->set, PK_GRBL_S_TOLERANCE_MM, 3) };
    return e;
}

static void reset_gcode_state(struct pk_grbl *g)
{
    pk_um_t pos[PK_GC_AXES], g54[PK_GC_AXES];
    g->mo.position_um(g->m, pos);
    (void)pk_grbl_nvm_coord_read(g, 0, g54);
    pk_gcode_state_init(&g->gc, pos, g54);
}

static void soft_limits_apply(struct pk_grbl *g)
{
    if (!g->mo.set_soft_limits)
        return;
    pk_um_t lo[PK_GC_AXES], hi[PK_GC_AXES];
    for (int a = 0; a < PK_GC_AXES; a++) {
        lo[a] = -pk_grbl_setting_scaled(&g->set, PK_GRBL_S_TRAVEL_X + a, 3);
        hi[a] = 0;
    }
    (void)g->mo.set_soft_limits(g->m, g->set.v[PK_GRBL_S_SOFT_LIMITS] != 0, lo, hi);
}

/* Grbl's soft limits: machine position within [-$13x, 0] on every axis. */
static int soft_ok(const struct pk_grbl *g, const pk_um_t t[PK_GC_AXES])
{
    if (!g->set.v[PK_GRBL_S_SOFT_LIMITS])
        return 1;
    for (int a = 0; a < PK_GC_AXES; a++)
        if (t[a] > 0 || t[a] < -pk_grbl_setting_scaled(&g->set, PK_GRBL_S_TRAVEL_X + a, 3))
            return 0;
    return 1;
}

/* Spindle output for S (1e-3 units) with the override: Grbl's linear map of
 * $31..$30 onto the smallest..full output, 0 for S0 (Q0.16). */
static uint16_t spindle_q16(const struct pk_grbl *g, int32_t s_milli)
{
    uint32_t s;
    int k = pk_grbl_spindle_span(g, s_milli, &s);
    if (k != PK_GRBL_SPAN_INSIDE)
        return k == PK_GRBL_SPAN_ZERO ? 0u : k == PK_GRBL_SPAN_MAX ? 65535u : 1u;
    uint32_t mx = (uint32_t)g->set.v[PK_GRBL_S_SPINDLE_MAX];
    uint32_t mn = (uint32_t)g->set.v[PK_GRBL_S_SPINDLE_MIN];
    /* 1 + floor(x * 65534 / d), x = s - mn < d = mx - mn < 2^31: the long
     * division gives q = floor(x * 2^16 / d) and its remainder; then
     * x * 65534 = q * d + rem - 2x takes off 0, 1 or 2 */
    uint32_t d = mx - mn, x = s - mn, rem = x, q = 0;
    for (int i = 0; i < 16; i++) {
        rem <<= 1;
        q <<= 1;
        if (rem >= d) {
            rem -= d;
            q |= 1u;
        }
    }
    uint32_t twox = 2u * x;
    q -= rem >= twox ? 0u : rem + d >= twox ? 1u : 2u;
    return (uint16_t)(1u + q);
}

static int laser_mode(const struct pk_grbl *g) { return g->set.v[PK_GRBL_S_LASER] != 0; }

/* Map a machine-op result: 1 done, 0 retry later, < 0 error. */
static int op_rc(int rc)
{
    if (rc == PK_GRBL_M_OK)
        return 1;
    if (rc == PK_GRBL_M_FULL)
        return 0;
    return rc;
}

static int send_spindle(struct pk_grbl *g, uint16_t v, int sync)
{
    if (!g->mo.spindle || g->laser_sent == v)
        return 1;
    int r = op_rc(g->mo.spindle(g->m, v, sync));
    if (r == 1)
        g->laser_sent = v;
    return r;
}

static int send_pen(struct pk_grbl *g, int on)
{
    if (g->pen_now == on)
        return 1;
    int r = op_rc(g->mo.pen(g->m, on));
    if (r == 1)
        g->pen_now = (uint8_t)on;
    return r;
}

/* Wait for the queue to drain (Grbl's protocol_buffer_synchronize): end the
 * open stroke once, then wait for Idle. */
static int sync_wait(struct pk_grbl *g)
{
    if (g->step == 0) {
        if (g->check_mode || pk_grbl_mstate(g) == PK_GRBL_M_IDLE)
            return 1; /* nothing queued: nothing to wait for */
        int r = op_rc(g->mo.end(g->m));
        if (r <= 0)
            return r;
        g->step = 1;
    }
    return pk_grbl_mstate(g) == PK_GRBL_M_IDLE ? 1 : 0;
}

/* The laser value a move of this kind runs at (laser mode). */
static uint16_t laser_value(const struct pk_grbl *g, int laser_off)
{
    if (laser_off || g->gc.spindle == PK_GC_SPINDLE_OFF)
        return 0;
    return spindle_q16(g, g->gc.spindle_s);
}

/* The primitive to the observer (PK_GRBL_OBSERVER; else nothing). */
static void observe(struct pk_grbl *g, uint8_t kind, const pk_um_t start[PK_GC_AXES],
                    const pk_um_t end[PK_GC_AXES])
{
#if !PK_GRBL_OBSERVER
    (void)g;
    (void)kind;
    (void)start;
    (void)end;
}
#else
    if (!g->obs || g->check_mode)
        return;
    const struct pk_gc_cmd *c = &g->cmd;
    struct pk_grbl_prim p;
    memset(&p, 0, sizeof p);
    p.kind = kind;
    p.jog = g->jogging;
    p.tool_on = g->gc.spindle != PK_GC_SPINDLE_OFF &&
                (!laser_mode(g) || (kind != PK_GRBL_PRIM_RAPID && !c->laser_off));
    p.exact = g->gc.path == PK_GC_PATH_EXACT;
    p.line = g->line_src ? 0u : g->line_no;
    p.n = c->line_number;
    p.spindle_s = g->gc.spindle_s;
    p.feed_umpm = kind == PK_GRBL_PRIM_RAPID ? 0 : c->feed_umpm;
    p.path_tol_um = g->gc.tol_um > 0 ? g->gc.tol_um : pk_grbl_setting_scaled(&g->set, PK_GRBL_S_TOLERANCE_MM, 3);
    p.chord_tol_um = c->chord_tol_um;
    memcpy(p.start, start, sizeof p.start);
    memcpy(p.end, end, sizeof p.end);
#if PK_BUILD_ARCS
    if (kind == PK_GRBL_PRIM_ARC) {
        const struct pk_arc *a = &c->u.arc;
        p.centre_q8[0] = a->g.centre_q8[0];
        p.centre_q8[1] = a->g.centre_q8[1];
        p.a0 = a->g.a0;
        p.a1 = a->g.a1;
        p.al = a->g.al;
        p.cw = a->g.cw;
        p.sweep = a->sweep;
        p.r0_q8 = a->r0_q8;
        p.r1_q8 = a->r1_q8;
    }
#endif
#if PK_BUILD_G5
    if (kind == PK_GRBL_PRIM_CUBIC || kind == PK_GRBL_PRIM_QUAD) {
        for (int k = 0; k < 2; k++)
            for (int a = 0; a < 2; a++)
                p.ctrl[k][a] = c->u.bez.p[1 + k][a];
    }
#endif
    g->obs(g->obs_ctx, &p);
}
#endif

/* ---- executing an accepted command --------------------------------------------- */

/* codes advance() returns besides 1 (done) and 0 (later) */
#define ADV_SOFTLIMIT (-100)

static int do_spindle(struct pk_grbl *g)
{
    const struct pk_gc_cmd *c = &g->cmd;
    if (g->check_mode)
        return 1;
    int on = c->spindle != PK_GC_SPINDLE_OFF;
    int r;
    if (laser_mode(g)) {
        /* state changes sync (Grbl); the power rides on the moves */
        if (c->spindle_state_changed) {
            if (g->step == 0) {
                if ((r = send_pen(g, on)) <= 0)
                    return r;
                g->step = 1;
            }
            if (!on)
                return send_spindle(g, 0, 0);
        }
        return 1;
    }
    uint16_t v = on ? spindle_q16(g, c->spindle_s) : 0;
    if (g->step == 0) { /* on: value first, then enable; off: disable first */
        r = on ? send_spindle(g, v, 1) : send_pen(g, 0);
        if (r <= 0)
            return r;
        g->step = 1;
    }
    return on ? send_pen(g, 1) : send_spindle(g, 0, 1);
}

/* One straight move (rapid or feed) with the soft-limit check and, in laser
 * mode, the laser value first. */
static int do_line(struct pk_grbl *g, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, int rapid,
                   int laser_off, int chord)
{
    if (!g->jogging && !soft_ok(g, t))
        return ADV_SOFTLIMIT;
    if (g->check_mode)
        return 1;
    if (laser_mode(g)) {
        int r = send_spindle(g, laser_value(g, rapid || laser_off), 0);
        if (r <= 0)
            return r;
    }
    int rc;
    if (chord && g->mo.move_chord)
        rc = g->mo.move_chord(g->m, t, feed, g->cmd.chord_tol_um);
    else
        rc = g->mo.move(g->m, t, feed, rapid);
    if (rc == PK_GRBL_M_ETRAVEL)
        return ADV_SOFTLIMIT;
    int r = op_rc(rc);
    if (r == 1)
        STAT_INC(g, moves);
    return r;
}

/* Vertices of an arc or a G5: as many as the machine takes this poll. */
static int do_curve(struct pk_grbl *g)
{
    struct pk_gc_cmd *c = &g->cmd;
    int is_arc = c->motion == PK_GC_MOT_CW_ARC || c->motion == PK_GC_MOT_CCW_ARC;
    for (int budget = CHORDS_PER_POLL; budget > 0; budget--) {
        if (!g->pt_held) {
            if (is_arc) {
#if PK_BUILD_ARCS
                if (!pk_arc_next(&c->u.arc, g->pt))
#endif
                    return 1; /* (not built: pk_gcode_interp refuses it) */
            } else {
#if PK_BUILD_G5
                pk_um_t xy[2];
                if (!pk_bez_next(&c->u.bez, xy))
                    return 1;
                memcpy(g->pt, c->target_um, sizeof g->pt);
                g->pt[0] = xy[0];
                g->pt[1] = xy[1];
#else
                return 1; /* not built: pk_gcode_interp refuses it */
#endif
            }
            g->pt_held = 1;
        }
        int r = do_line(g, g->pt, c->feed_umpm, 0, 0, 1);
        if (r <= 0)
            return r;
        g->pt_held = 0;
    }
    return 0;
}

/* "[PRB:x,y,z:ok]" (machine position, Grbl's report_probe_parameters). */
static void put_prb(struct pk_grbl *g)
{
    PK_GRBL_PUTS(g, "[PRB:");
    pk_grbl_put_axes(g, g->prb_um);
    pk_grbl_puts_rom(g, g->probe_ok ? PK_ROM_STR(":1]\r\n") : PK_ROM_STR(":0]\r\n"));
}

/* A non-critical alarm raised by a line (ALARM:4, ALARM:5): the G-code lock
 * until $X; the line itself is answered "ok", as Grbl. */
static void raise_alarm(struct pk_grbl *g, uint8_t code)
{
    g->alarm = code;
    PK_GRBL_PUTS(g, "ALARM:");
    pk_grbl_put_u32(g, code);
    PK_GRBL_PUTS(g, "\r\n");
}

/* G38.2-G38.5, as Grbl's mc_probe_cycle: sync, fail at once if the probe
 * already is in the state waited for (ALARM:4), run the move, then record
 * the contact (or the end for G38.3/.5; ALARM:5 for G38.2/.4), report
 * [PRB:] and continue from where the machine stopped. */
static int do_probe(struct pk_grbl *g)
{
    struct pk_gc_cmd *c = &g->cmd;
    if (g->check_mode)
        return 1;
    unsigned away = c->motion >= PK_GC_MOT_PROBE_AWAY ? 1u : 0u;
    unsigned no_error = ((c->motion - PK_GC_MOT_PROBE_TOWARD) & 1u) ? 1u : 0u;
    if (!PK_GRBL_INPUTS || !g->mo.probe) {
        PK_GRBL_PUTS(g, "[MSG:No probe input: G38 is not supported by this machine]\r\n");
        return -PK_GC_E_UNSUPPORTED;
    }
    if (g->step < 2) {
        int r = sync_wait(g);
        if (r <= 0)
            return r;
        g->step = 2;
    }
    if (pk_grbl_out_room(g) < 64u)
        return 0; /* room for the alarm and [PRB:] */
    if (g->step == 2) {
        int rc = g->mo.probe(g->m, c->target_um, c->feed_umpm, away | (no_error << 1));
        if (rc == PK_GRBL_M_ENOTSUP) {
            PK_GRBL_PUTS(g, "[MSG:No probe input: G38 is not supported by this machine]\r\n");
            return -PK_GC_E_UNSUPPORTED;
        }
        if (rc == PK_GRBL_M_ETRIGGERED) {
            g->probe_ok = 0;
            raise_alarm(g, 4);
            g->mo.position_um(g->m, g->gc.pos_um);
            return 1;
        }
        int r = op_rc(rc);
        if (r <= 0)
            return r;
        g->step = 3;
    }
    pk_um_t pos[PK_GC_AXES];
    int res = g->mo.probe_result(g->m, pos);
    if (res == PK_GRBL_PRB_RUNNING)
        return 0;
    g->probe_ok = res == PK_GRBL_PRB_CONTACT;
    if (res == PK_GRBL_PRB_CONTACT || (res == PK_GRBL_PRB_MISSED && no_error))
        memcpy(g->prb_um, pos, sizeof g->prb_um);
    else if (res == PK_GRBL_PRB_MISSED)
        raise_alarm(g, 5);
    if (res != PK_GRBL_PRB_ABORTED)
        put_prb(g);
    g->mo.position_um(g->m, g->gc.pos_um); /* Grbl: gc_sync_position */
    g->gc.cubic_prev = 0;
    return 1;
}

static int do_move(struct pk_grbl *g)
{
    struct pk_gc_cmd *c = &g->cmd;
    switch (c->motion) {
    case PK_GC_MOT_RAPID:
    case PK_GC_MOT_LINEAR:
        if (g->step == 0) {
            observe(g, c->motion == PK_GC_MOT_RAPID ? PK_GRBL_PRIM_RAPID : PK_GRBL_PRIM_LINE,
                    c->start_um, c->target_um);
            g->step = 1;
        }
        return do_line(g, c->target_um, c->feed_umpm, c->motion == PK_GC_MOT_RAPID, c->laser_off, 0);
    case PK_GC_MOT_CW_ARC:
    case PK_GC_MOT_CCW_ARC:
    case PK_GC_MOT_CUBIC:
    case PK_GC_MOT_QUAD:
        if (g->step == 0) {
            uint8_t kind = c->motion == PK_GC_MOT_CUBIC ? PK_GRBL_PRIM_CUBIC
                           : c->motion == PK_GC_MOT_QUAD ? PK_GRBL_PRIM_QUAD
#if PK_BUILD_ARCS
                           : c->u.arc.g.straight ? PK_GRBL_PRIM_LINE : PK_GRBL_PRIM_ARC;
#else
                           : PK_GRBL_PRIM_LINE;
#endif
            observe(g, kind, c->start_um, c->target_um);
            g->step = 1;
            g->pt_held = 0;
        }
        return do_curve(g);
    default:
        return do_probe(g);
    }
}

static int do_stop(struct pk_grbl *g)
{
    const struct pk_gc_cmd *c = &g->cmd;
    if (g->step <= 1) { /* Grbl: sync first */
        int r = sync_wait(g);
        if (r <= 0)
            return r;
        g->step = 2;
    }
    if (c->stop == PK_GC_STOP_PAUSE) {
        if (g->check_mode)
            return 1;
        if (g->step == 2) {
            g->mode = MODE_IDLE_HOLD; /* Hold:0 until '~' */
            g->step = 3;
        }
        return g->mode == MODE_RUN ? 1 : 0;
    }
    /* M2/M30: spindle and coolant off, overrides back to 100 % */
    if (g->step == 2) {
        if (!g->check_mode) {
            int r = send_pen(g, 0);
            if (r <= 0)
                return r;
        }
        g->step = 3;
    }
    if (g->step == 3) {
        if (!g->check_mode) {
            int r = send_spindle(g, 0, !laser_mode(g));
            if (r <= 0)
                return r;
        }
        g->step = 4;
    }
    if (g->ovr_feed != 100 || g->ovr_rapid != 100 || g->ovr_spindle != 100) {
        g->ovr_feed = g->ovr_rapid = g->ovr_spindle = 100;
        g->ovr_counter = 0;
        apply_overrides(g);
    }
    PK_GRBL_PUTS(g, "[MSG:Pgm End]\r\n");
    return 1;
}

/* Hand over as much of g->cmd as the machine takes: 1 done, 0 later, < 0 a
 * Grbl error (negated) or ADV_SOFTLIMIT. */
static int advance(struct pk_grbl *g)
{
    struct pk_gc_cmd *c = &g->cmd;
    int r = 1;
    while (g->todo) {
        uint16_t item = (uint16_t)(g->todo & (uint16_t)(~g->todo + 1u)); /* lowest bit */
        switch (item) {
        case PK_GC_DO_SPINDLE:
            r = do_spindle(g);
            if (r == 1 && c->spindle_state_changed)
                g->ovr_counter = 0; /* Grbl: an accessory change shows in the next report */
            break;
        case PK_GC_DO_COOLANT: /* no coolant outputs: the state shows in A: and $G */
            g->ovr_counter = 0;
            r = 1;
            break;
        case PK_GC_DO_DWELL:
            if (g->step == 0) {
                if (!g->check_mode) {
                    r = op_rc(g->mo.dwell(g->m, c->dwell_ms));
                    if (r <= 0)
                        break;
                }
                g->step = 1;
            }
            /* answered once the queue has drained and the dwell has run */
            r = g->check_mode || pk_grbl_mstate(g) == PK_GRBL_M_IDLE ? 1 : 0;
            break;
        case PK_GC_DO_COORD:
            r = sync_wait(g);
            if (r == 1 && !g->check_mode && pk_grbl_nvm_coord_write(g, c->coord_idx, c->coord_um) != 0)
                r = -7; /* no store, or it failed */
            break;
        case PK_GC_DO_WCO:
            r = sync_wait(g);
            if (r == 1)
                g->wco_counter = 0;
            break;
        case PK_GC_DO_PATH: {
            if (g->check_mode) {
                r = 1;
                break;
            }
            pk_um_t tol = c->tol_um > 0 ? c->tol_um : pk_grbl_setting_scaled(&g->set, PK_GRBL_S_TOLERANCE_MM, 3);
            r = op_rc(g->mo.smoothing(g->m, c->path == PK_GC_PATH_EXACT, tol));
            break;
        }
        case PK_GC_DO_VIA:
            if (g->step == 0) {
                observe(g, PK_GRBL_PRIM_RAPID, c->start_um, c->via_um);
                g->step = 1;
            }
            r = do_line(g, c->via_um, 0, 1, 1, 0);
            break;
        case PK_GC_DO_MOVE:
            r = do_move(g);
            break;
        case PK_GC_DO_STOP:
            r = do_stop(g);
            break;
        default:
            r = 1;
            break;
        }
        if (r <= 0)
            return r;
        g->todo &= (uint16_t)~item;
        g->step = 0;
    }
    return 1;
}

static void start_softlimit(struct pk_grbl *g)
{
    g->mode = MODE_SOFTLIMIT;
    g->owed = 1; /* the line that tripped it is answered at the reset (Grbl) */
    if (pk_grbl_mstate(g) == PK_GRBL_M_RUN)
        g->mo.hold(g->m);
}

/* Keep handing over the pending command; answer its line when done. */
static void run_pending(struct pk_grbl *g)
{
    if (g->todo == 0 || g->mode == MODE_SOFTLIMIT || g->mode == MODE_CRITICAL)
        return;
    int r = advance(g);
    if (r == 0)
        return;
    if (r == ADV_SOFTLIMIT) {
        g->todo = 0; /* the line is answered when the alarm is reset (Grbl) */
        g->step = 0;
        start_softlimit(g);
        return;
    }
    g->todo = 0;
    g->step = 0;
    g->pt_held = 0;
    /* the machine refused part of an accepted line: an alarm or an error */
    answer(g, r > 0 ? 0 : r == PK_GRBL_M_ERROR ? 9 : -r);
}

/* ---- G-code lines ------------------------------------------------------------------ */

static void gcode_line(struct pk_grbl *g, const uint8_t *s, size_t n)
{
    struct pk_gc_block b;
    int rc = pk_gcode_parse(s, n, &b);
    if (rc != PK_GC_OK) {
        answer(g, rc);
        return;
    }
    if (b.words == 0 && b.groups == 0) {
        answer(g, 0);
        return;
    }
    struct pk_gc_env env = make_env(g);
    rc = pk_gcode_interp(&g->gc, &b, &env, &g->cmd);
    if (rc != PK_GC_OK) {
        answer(g, rc);
        return;
    }
    if (g->cmd.what == 0) {
        answer(g, 0);
        return;
    }
    g->todo = g->cmd.what;
    g->step = 0;
    g->pt_held = 0;
    run_pending(g);
}

/* ---- $ commands ----------------------------------------------------------------------- */

/* The machine has at least one limit switch input. */
static int has_limits(struct pk_grbl *g)
{
    return PK_GRBL_INPUTS && g->mo.inputs && g->mo.set_hard_limits &&
           (g->mo.inputs(g->m, PK_GRBL_IN_HAVE) & PK_GRBL_IN_LIMITS) != 0u;
}

static int set_setting(struct pk_grbl *g, const uint8_t *s, size_t n)
{
    int idx;
    int32_t val;
    int rc = pk_grbl_setting_parse(s, n, &idx, &val);
    if (rc != 0)
        return rc;
    struct pk_grbl_settings next = g->set;
    rc = pk_grbl_setting_store(&next, idx, val);
    if (rc != 0)
        return rc;
    if (pk_grbl_mstate(g) != PK_GRBL_M_IDLE && pk_grbl_mstate(g) != PK_GRBL_M_ALARM)
        return 8;
    if (idx == PK_GRBL_S_HARD_LIMITS && val && !has_limits(g)) {
        PK_GRBL_PUTS(g, "[MSG:No limit switches: $21=1 refused]\r\n");
        return 3;
    }
    if (g->mo.configure(g->m, &next) != 0) {
        PK_GRBL_PUTS(g, "[MSG:Setting refused by the machine]\r\n");
        return 3;
    }
    g->set = next;
    (void)pk_grbl_nvm_save_settings(g);
    soft_limits_apply(g);
    /* steps/mm changes move the mm position (Grbl keeps the steps) */
    g->mo.position_um(g->m, g->gc.pos_um);
    if (idx == PK_GRBL_S_REPORT_INCHES)
        g->wco_counter = 0;
    /* $22=1 without switches still enables soft limits ($20); say $H cannot run */
    if (val && !has_limits(g) && idx == PK_GRBL_S_HOMING)
        PK_GRBL_PUTS(g, "[MSG:No limit switches: $H cannot run, $X unlocks]\r\n");
    return 0;
}

static int jog(struct pk_grbl *g, const uint8_t *s, size_t n)
{
    struct pk_gc_block b;
    int rc = pk_gcode_parse(s, n, &b);
    if (rc != PK_GC_OK)
        return rc;
    rc = pk_gcode_jog(&g->gc, &b, &g->cmd);
    if (rc != PK_GC_OK)
        return rc;
    if (g->cmd.what == 0)
        return 0;
    if (!soft_ok(g, g->cmd.target_um))
        return PK_GC_E_TRAVEL;
    memcpy(g->gc.pos_um, g->cmd.target_um, sizeof g->gc.pos_um);
    g->gc.cubic_prev = 0;
    g->jogging = 1;
    g->todo = PK_GC_DO_MOVE;
    g->step = 0;
    return -1; /* pending */
}

static int is_idle_or_alarm(int gs) { return gs == GS_IDLE || gs == GS_ALARM; }

/* A line starting with '$' (already stripped and upper-cased), as Grbl's
 * system_execute_line. Answers it, starts a report, or starts a jog. */
static void system_line(struct pk_grbl *g, const uint8_t *c, size_t k)
{
    int gs = gstate(g);
    int rc = 0;
    c++; /* after '$' */
    k--;
    if (k == 0) {
        g->report = R_HELP;
        return;
    }
    switch (c[0]) {
    case 'J':
        if (gs != GS_IDLE && gs != GS_JOG)
            rc = 8;
        else if (k < 2 || c[1] != '=')
            rc = 3;
        else if ((rc = jog(g, c + 2, k - 2)) < 0) {
            run_pending(g);
            return;
        }
        break;
    case '$': case 'G': case 'C': case 'X':
        if (k != 1) {
            rc = 3;
            break;
        }
        if (c[0] == '$') {
            if (gs == GS_RUN || gs == GS_HOLD)
                rc = 8;
            else {
                g->report = R_SETTINGS;
                g->report_i = 0;
                return;
            }
        } else if (c[0] == 'G') {
            g->report = R_GSTATE;
            return;
        } else if (c[0] == 'C') {
            if (gs == GS_CHECK) {
                PK_GRBL_PUTS(g, "[MSG:Disabled]\r\n");
                answer(g, 0);
                soft_reset(g); /* leaving check mode restarts, as Grbl */
                return;
            }
            if (gs != GS_IDLE) {
                rc = 8;
            } else {
                g->check_mode = 1;
                PK_GRBL_PUTS(g, "[MSG:Enabled]\r\n");
            }
        } else if (gs == GS_ALARM && door_ajar(g)) {
            rc = 13; /* Grbl: $X is refused while the door is open */
        } else { /* X */
            if (pk_grbl_mstate(g) == PK_GRBL_M_ALARM) {
                /* a machine fault: clear it (reset) before unlocking */
                (void)g->mo.reset(g->m);
                reset_gcode_state(g);
                g->pen_now = 2;
                g->laser_sent = -1;
            }
            if (g->alarm) {
                PK_GRBL_PUTS(g, "[MSG:Caution: Unlocked]\r\n");
                g->alarm = 0;
                g->m_alarm_seen = 0;
            }
        }
        break;
    default:
        if (!is_idle_or_alarm(gs)) {
            rc = 8;
            break;
        }
        switch (c[0]) {
        case '#':
            if (k != 1) {
                rc = 3;
            } else {
                g->report = R_OFFSETS;
                g->report_i = 0;
                return;
            }
            break;
        case 'H': /* Grbl 1.1h default build: no $HX single-axis commands */
            if (!g->set.v[PK_GRBL_S_HOMING])
                rc = 5;
            else if (door_ajar(g))
                rc = 13;
            else if (k != 1)
                rc = 3;
            else if (!g->mo.home || !has_limits(g) ||
                     (rc = g->mo.home(g->m, (1u << PK_GC_AXES) - 1u)) == PK_GRBL_M_ENOTSUP) {
                PK_GRBL_PUTS(g, "[MSG:No limit switches: $H is not supported by this machine]\r\n");
                rc = 5;
            } else if (rc != PK_GRBL_M_OK) {
                rc = 9; /* the machine refused (in its own alarm, a setting out of range) */
            } else {
                g->mode = MODE_HOMING; /* answered when the cycle ends */
                return;
            }
            break;
        case 'S':
            if (k != 3 || c[1] != 'L' || c[2] != 'P') {
                rc = 3;
            } else {
                g->mode = MODE_SLEEP_REQ;
                if (pk_grbl_mstate(g) == PK_GRBL_M_RUN)
                    g->mo.hold(g->m);
            }
            break;
        case 'I':
            if (k == 1) {
                g->report = R_INFO;
                g->report_i = 0;
                return;
            }
            if (c[1] != '=')
                rc = 3;
            else if (pk_grbl_nvm_line_write(g, PK_GRBL_N_STARTUP, c + 2, (unsigned)(k - 2)) != 0)
                rc = 7; /* no store, or it failed */
            break;
        case 'R':
            if (k != 5 || c[1] != 'S' || c[2] != 'T' || c[3] != '=') {
                rc = 3;
            } else if (c[4] == '$' || c[4] == '#' || c[4] == '*') {
                unsigned what = c[4] == '$' ? 1u : c[4] == '#' ? 2u : 15u;
                pk_grbl_nvm_restore(g, what);
                if (what & 1u) {
                    (void)g->mo.configure(g->m, &g->set);
                    soft_limits_apply(g);
                }
                PK_GRBL_PUTS(g, "[MSG:Restoring defaults]\r\n");
                answer(g, 0);
                soft_reset(g); /* Grbl: a reset to take the settings in */
                return;
            } else {
                rc = 3;
            }
            break;
        case 'N':
            if (k == 1) {
                g->report = R_STARTUP;
                g->report_i = 0;
                return;
            }
            if (gs != GS_IDLE) {
                rc = 8;
                break;
            }
            {
                size_t eq = 1;
                while (eq < k && c[eq] != '=')
                    eq++;
                int32_t m;
                uint8_t d;
                if (pk_gcode_parse_number(c + 1, eq - 1, &m, &d) != PK_GC_OK) {
                    rc = PK_GC_E_BAD_NUMBER;
                    break;
                }
                if (eq == k) {
                    rc = 3;
                    break;
                }
                uint32_t slot = m < 0 ? 99u : (uint32_t)m;
                for (; d > 0; d--)
                    slot /= 10u;
                if (slot >= PK_GRBL_N_STARTUP) {
                    rc = 3;
                    break;
                }
                /* Grbl checks the line by executing it, then stores it */
                const uint8_t *gl = c + eq + 1;
                size_t gn = k - eq - 1;
                struct pk_gc_block b;
                rc = pk_gcode_parse(gl, gn, &b);
                if (rc == PK_GC_OK) {
                    struct pk_gc_env env = make_env(g);
                    rc = pk_gcode_interp(&g->gc, &b, &env, &g->cmd);
                }
                if (rc != PK_GC_OK)
                    break;
                if (pk_grbl_nvm_line_write(g, slot, gl, (unsigned)gn) != 0) {
                    rc = 7;
                    break;
                }
                if (g->cmd.what) {
                    g->todo = g->cmd.what;
                    g->step = 0;
                    run_pending(g);
                    return;
                }
            }
            break;
        default:
            rc = set_setting(g, c, k);
            break;
        }
    }
    answer(g, rc);
}

/* ---- lines -------------------------------------------------------------------------- */

static void process_line(struct pk_grbl *g)
{
    const uint8_t *s = g->line;
    size_t n = g->len;
    uint8_t flags = g->line_flags;
    g->len = 0;
    g->line_flags = 0;
    if (!g->line_src)
        g->line_no++;
    if (flags & LF_LOST) {
        PK_GRBL_PUTS(g, "[MSG:RX overflow: bytes of this line were lost]\r\n");
        answer(g, PK_GC_E_LINE_OVERFLOW);
        return;
    }
    if (flags & LF_OVERFLOW) {
        answer(g, PK_GC_E_LINE_OVERFLOW);
        return;
    }
    if (n == 0) {
        answer(g, 0); /* empty or comment line: ok, as Grbl */
        return;
    }
    if (s[0] == '$') {
        system_line(g, s, n);
        return;
    }
    int gs = gstate(g);
    if (gs == GS_ALARM || gs == GS_JOG) {
        answer(g, 9);
        return;
    }
    gcode_line(g, s, n);
}

/* One received byte, with Grbl's line assembly (protocol.c). */
static void take_byte(struct pk_grbl *g, uint8_t b)
{
    if (b == '\n' && g->last_cr) {
        g->last_cr = 0; /* CR LF is one line end */
        return;
    }
    g->last_cr = b == '\r';
    if (b == '\n' || b == '\r') {
        process_line(g);
        return;
    }
    /* A realtime byte that reached the line stream (no filter installed):
     * act on it as the ISR would, and keep it out of the line. */
    if (pk_grbl_rt_filter(g, b)) {
        realtime(g);
        return;
    }
    if (g->line_flags & (LF_PAREN | LF_SEMI | LF_OVERFLOW)) {
        if (b == ')' && (g->line_flags & LF_PAREN))
            g->line_flags &= (uint8_t)~LF_PAREN;
        return;
    }
    if (b <= ' ' || b == '/')
        return;
    if (b == '(') {
        g->line_flags |= LF_PAREN;
    } else if (b == ';') {
        g->line_flags |= LF_SEMI;
    } else if (g->len >= PK_GRBL_LINE_MAX) {
        g->line_flags |= LF_OVERFLOW;
    } else {
        g->line[g->len++] = b >= 'a' && b <= 'z' ? (uint8_t)(b - 'a' + 'A') : b;
    }
}

/* Run the next stored startup line, if any (after a greeting, unless locked). */
static int startup_line(struct pk_grbl *g)
{
    while (g->startup_next < PK_GRBL_N_STARTUP) {
        unsigned k = g->startup_next++;
        uint8_t buf[PK_GRBL_LINE_MAX];
        unsigned n = pk_grbl_nvm_line_read(g, k, buf);
        if (n == 0)
            continue;
        memcpy(g->line, buf, n);
        g->len = (uint8_t)n;
        g->line_src = (uint8_t)(1u + k);
        g->line_flags = 0;
        process_line(g);
        return 1;
    }
    return 0;
}

/* ---- reset and the engine's own modes --------------------------------------------- */

static void greet(struct pk_grbl *g)
{
    PK_GRBL_PUTS(g, "\r\nGrbl 1.1h [" PK_GRBL_VERSION_STR " '$' for help]\r\n");
    if (PK_GRBL_INPUTS && g->set.v[PK_GRBL_S_HARD_LIMITS] && g->mo.inputs) {
        /* Grbl's CHECK_LIMITS_AT_INIT */
        if (g->mo.inputs(g->m, PK_GRBL_IN_LEVELS) & PK_GRBL_IN_LIMITS) {
            if (!g->alarm)
                g->alarm = ALARM_LOCK;
            PK_GRBL_PUTS(g, "[MSG:Check Limits]\r\n");
        }
    }
    if (g->set.v[PK_GRBL_S_HARD_LIMITS] && !has_limits(g))
        PK_GRBL_PUTS(g, "[MSG:No limit switches: $21=1 has no effect]\r\n");
    if (g->alarm)
        PK_GRBL_PUTS(g, "[MSG:'$H'|'$X' to unlock]\r\n");
    g->startup_next = g->alarm ? PK_GRBL_N_STARTUP : 0u;
}

static void soft_reset(struct pk_grbl *g)
{
    /* Grbl answers the line that tripped a soft (or hard) limit when the
     * reset comes */
    if (g->owed)
        answer(g, 0);
    g->owed = 0;
    g->home_ok_due = 0;
    int cut = g->mo.reset(g->m);
    STAT_INC(g, resets);
    g->len = 0;
    g->line_flags = 0;
    g->last_cr = 0;
    g->line_src = 0;
    g->todo = 0;
    g->step = 0;
    g->pt_held = 0;
    g->report = R_NONE;
    g->jogging = 0;
    g->jog_cancel = 0;
    /* Like Grbl, forget what was received but not yet read: a sender
     * restarts its character count on reset. */
    uint8_t junk[32];
    for (int i = 0; i < 64 && g->io.read(g->io.ctx, junk, sizeof junk) != 0; i++) {
    }
    for (int f = 0; f < PK_GRBL_RT_COUNT; f++)
        g->rt[f] = 0;
    g->status_due = 0;
    g->check_mode = 0;
    /* Grbl kills spindle and coolant on a reset: the outputs go off (a
     * request the reset dropped leaves them unknown: off again) */
    (void)send_pen(g, 0);
    (void)send_spindle(g, 0, 1);
    g->spindle_due = 0;
    g->m_alarm_seen = 0;
    if (g->mode == MODE_SLEEP || g->mode == MODE_SLEEP_REQ) {
        if (!g->alarm)
            g->alarm = ALARM_LOCK; /* Grbl: out of sleep into the alarm lock */
    }
    g->mode = MODE_RUN;
    if (cut && !g->alarm) { /* after an alarm (a hard limit) nothing more is reported */
        g->alarm = 3;
        PK_GRBL_PUTS(g, "ALARM:3\r\n");
    }
    g->ovr_feed = g->ovr_rapid = g->ovr_spindle = 100;
    apply_overrides(g);
    g->wco_counter = g->ovr_counter = 0;
    reset_gcode_state(g);
    g->greet_due = 1;
}

/* Soft-limit stop and sleep: wait for the machine to stand still. */
static void modes(struct pk_grbl *g)
{
    int st = pk_grbl_mstate(g);
    if ((g->mode == MODE_SOFTLIMIT || g->mode == MODE_SLEEP_REQ) &&
        (st == PK_GRBL_M_HOLD || st == PK_GRBL_M_IDLE || st == PK_GRBL_M_ALARM) &&
        pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX) {
        (void)g->mo.reset(g->m); /* stopped within the acceleration: no position lost */
        reset_gcode_state(g);
        g->pen_now = 2;
        g->laser_sent = -1;
        /* Grbl's mc_reset: spindle (and coolant) off */
        (void)send_pen(g, 0);
        (void)send_spindle(g, 0, 1);
        if (g->mode == MODE_SOFTLIMIT) {
            g->alarm = 2;
            g->mode = MODE_CRITICAL;
            PK_GRBL_PUTS(g, "ALARM:2\r\n[MSG:Reset to continue]\r\n");
        } else {
            g->mode = MODE_SLEEP;
            PK_GRBL_PUTS(g, "[MSG:Sleeping]\r\n");
        }
    }
    if (g->jogging) {
        if (g->jog_cancel && (st == PK_GRBL_M_HOLD || st == PK_GRBL_M_IDLE)) {
            /* stopped within the acceleration limit: drop the rest of the jog
             * (no alarm: nothing was cut while moving) */
            (void)g->mo.reset(g->m);
            g->pen_now = 2;
            g->laser_sent = -1;
            g->mo.position_um(g->m, g->gc.pos_um);
            if (g->todo) {
                g->todo = 0;
                g->step = 0;
                answer(g, 0);
            }
            g->jogging = 0;
            g->jog_cancel = 0;
        } else if (!g->jog_cancel && st == PK_GRBL_M_IDLE && g->todo == 0) {
            g->jogging = 0;
        }
    }
    if (g->spindle_due) {
        /* a spindle override: in laser mode the next feed move takes the new
         * power; otherwise the output changes from the next block (at once,
         * with a stop, when idle) */
        if (laser_mode(g) || g->check_mode || g->gc.spindle == PK_GC_SPINDLE_OFF ||
            send_spindle(g, spindle_q16(g, g->gc.spindle_s), st == PK_GRBL_M_IDLE) != 0)
            g->spindle_due = 0;
    }
}

/* ---- public ---------------------------------------------------------------------- */

int pk_grbl_init(struct pk_grbl *g, const struct pk_grbl_stream *io,
                 const struct pk_grbl_machine_ops *mo, void *m,
                 const struct pk_grbl_settings *set, const struct pk_grbl_nvm *nvm)
{
    memset(g, 0, sizeof *g);
    g->io = *io;
    g->mo = *mo;
    g->m = m;
    if (nvm && nvm->size >= pk_grbl_nvm_bytes())
        g->nvm = *nvm;
    if (pk_grbl_nvm_load_settings(g) != 0) {
        /* nothing valid stored: Grbl restores everything */
        pk_grbl_nvm_restore(g, 15u);
        if (g->nvm.size && !set)
            g->msg_due = MSG_RESTORING;
    }
    if (set) {
        g->set = *set;
        (void)pk_grbl_nvm_save_settings(g);
    }
    if (mo->configure(m, &g->set) != 0)
        return -1;
    g->hard_now = 2;    /* hard limits: set at the first poll */
    g->pen_now = 0;     /* the machine starts pen up, spindle output 0 */
    g->laser_sent = 0;
    g->ovr_feed = g->ovr_rapid = g->ovr_spindle = 100;
    apply_overrides(g);
    soft_limits_apply(g);
    reset_gcode_state(g);
    if (g->set.v[PK_GRBL_S_HOMING])
        g->alarm = ALARM_LOCK; /* Grbl's HOMING_INIT_LOCK */
    g->greet_due = 1;
    return 0;
}

#if PK_GRBL_OBSERVER
void pk_grbl_set_observer(struct pk_grbl *g, pk_grbl_observer_fn fn, void *ctx)
{
    g->obs = fn;
    g->obs_ctx = ctx;
}
#endif

int pk_grbl_idle(const struct pk_grbl *g)
{
    return g->out_len == 0 && g->todo == 0 && g->report == R_NONE && !g->greet_due &&
           !g->status_due && g->startup_next >= PK_GRBL_N_STARTUP && !g->msg_due &&
           g->mode != MODE_SOFTLIMIT && g->mode != MODE_SLEEP_REQ && g->mode != MODE_HOMING &&
           !g->home_ok_due;
}

void pk_grbl_drop_partial_line(struct pk_grbl *g)
{
    g->len = 0;
    g->line_flags = 0;
    g->last_cr = 0;
}

static void messages(struct pk_grbl *g)
{
    switch (g->msg_due) {
    case MSG_RESTORING:
        PK_GRBL_PUTS(g, "[MSG:Restoring defaults]\r\n");
        break;
    case MSG_NO_SPINDLE_STOP:
        PK_GRBL_PUTS(g, "[MSG:Spindle stop override is not supported]\r\n");
        break;
    case MSG_DOOR_HOLD:
        PK_GRBL_PUTS(g, "[MSG:No safety door: feed hold only, the tool stays as it is]\r\n");
        break;
    case MSG_DOOR_OPEN:
        PK_GRBL_PUTS(g, "[MSG:Door open: feed hold only, the tool stays as it is]\r\n");
        break;
    default:
        break;
    }
    g->msg_due = MSG_NONE;
}

/* $H failed (ALARM:6-9): as Grbl, the alarm, the $H line's "ok", then a
 * reset into the alarm lock. */
static void home_failed(struct pk_grbl *g, int alarm)
{
    g->mode = MODE_RUN;
    raise_alarm(g, (uint8_t)alarm);
    answer(g, 0);
    soft_reset(g);
}

/* Drive a running $H. */
static void homing(struct pk_grbl *g)
{
    if (!PK_GRBL_INPUTS || g->mode != MODE_HOMING || pk_grbl_out_room(g) < PK_GRBL_ANSWER_MAX)
        return;
    int r = g->mo.home_poll(g->m);
    if (r == 0)
        return;
    if (r != 1) {
        home_failed(g, r);
        return;
    }
    g->mode = MODE_RUN;
    g->alarm = 0;
    g->m_alarm_seen = 0;
    g->mo.position_um(g->m, g->gc.pos_um); /* Grbl: gc_sync_position */
    g->gc.cubic_prev = 0;
    g->wco_counter = 0;
    g->startup_next = 0; /* Grbl runs the startup lines, then answers $H */
    g->home_ok_due = 1;
}

/* Hard limits on the machine as $21 says, except in an alarm (Grbl ignores
 * the switches there, so that a machine on its switch can be unlocked and
 * moved) and during $H (pk_home switches them itself). */
static void hard_apply(struct pk_grbl *g)
{
    if (!PK_GRBL_INPUTS || !g->mo.set_hard_limits || g->mode == MODE_HOMING ||
        pk_grbl_mstate(g) == PK_GRBL_M_ALARM)
        return; /* a tripped machine stays as it is until the reset */
    uint8_t want = g->set.v[PK_GRBL_S_HARD_LIMITS] && !g->alarm && g->mode != MODE_CRITICAL;
    if (want == g->hard_now)
        return;
    /* Grbl's limit interrupt trips on an edge: a switch still closed when
     * the limits are armed (after $X, at power-on) does not trip; the core
     * trips on a closed switch, so arm once every switch is open. */
    if (want && g->mo.inputs && (g->mo.inputs(g->m, PK_GRBL_IN_LEVELS) & PK_GRBL_IN_LIMITS) != 0u)
        return;
    (void)g->mo.set_hard_limits(g->m, want); /* ENOTSUP: refused when set, told at the greeting */
    g->hard_now = want;
}

void pk_grbl_poll(struct pk_grbl *g)
{
    realtime(g);
    if (PK_GRBL_INPUTS && pk_grbl_mstate(g) == PK_GRBL_M_ALARM && !g->m_alarm_seen &&
        g->mo.alarm_is_limit &&
        g->mo.alarm_is_limit(g->m) && pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX) {
        /* Grbl's hard limit: a critical event. Only '?' and a reset from
         * here; a line being handed over is answered at the reset. */
        g->m_alarm_seen = 1;
        g->alarm = 1;
        g->mode = MODE_CRITICAL;
        g->jogging = 0;
        g->jog_cancel = 0;
        if (g->todo) {
            g->todo = 0;
            g->step = 0;
            g->owed = 1;
        }
        PK_GRBL_PUTS(g, "ALARM:1\r\n[MSG:Reset to continue]\r\n");
    }
    if (pk_grbl_mstate(g) == PK_GRBL_M_ALARM && !g->m_alarm_seen && g->mode != MODE_HOMING &&
        pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX) {
        /* A machine fault (a HAL write failed): position may be lost, as
         * after a hard limit, hence Grbl's ALARM:1. */
        g->m_alarm_seen = 1;
        PK_GRBL_PUTS(g, "ALARM:1\r\n");
        if (g->mode == MODE_SOFTLIMIT || g->mode == MODE_CRITICAL) {
            /* already on the way to (or in) a critical alarm: that lock
             * stays, only a reset leaves it, and the line that tripped the
             * soft limit keeps its answer owed until then (finding P3: this
             * fault unlocked it and the sender's count lost that line) */
        } else {
            g->alarm = 1;
            g->mode = MODE_RUN;
        }
        if (g->todo) {
            g->todo = 0;
            g->step = 0;
            answer(g, 9);
        }
    }
    modes(g);
    homing(g);
    hard_apply(g);
    flush(g);
    if (g->greet_due && pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX) {
        g->greet_due = 0;
        greet(g);
    }
    if (g->status_due && pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX) {
        g->status_due = 0;
        pk_grbl_status_report(g);
    }
    if (g->msg_due && pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX)
        messages(g);
    /* Bounded: at most a line's worth of bytes per call. */
    for (int budget = PK_GRBL_LINE_MAX + 8; budget > 0; budget--) {
        if (g->greet_due)
            break;
        if (g->report != R_NONE) {
            if (!pk_grbl_report_step(g))
                break;
            answer(g, 0);
        }
        if (g->todo != 0) /* (its own first test: no call frame per byte read) */
            run_pending(g);
        if (g->todo != 0 || pk_grbl_out_room(g) < PK_GRBL_ANSWER_MAX)
            break;
        if (g->mode != MODE_RUN)
            break; /* held, locked by a soft limit, asleep: no line is read */
        int st = pk_grbl_mstate(g);
        if ((st == PK_GRBL_M_HOLD || st == PK_GRBL_M_HOLDING) && !g->jogging)
            break; /* Grbl's suspend: no line processing while held */
        if (g->startup_next < PK_GRBL_N_STARTUP) {
            if (startup_line(g))
                continue;
        }
        if (g->home_ok_due) {
            g->home_ok_due = 0;
            answer(g, 0);
            continue;
        }
        uint8_t b;
        int n = g->io.read(g->io.ctx, &b, 1);
        if (n < 0) {
            STAT_INC(g, rx_lost);
            g->line_flags |= LF_LOST;
            continue;
        }
        if (n == 0)
            break;
        take_byte(g, b);
        if (g->rt[PK_GRBL_RT_RESET])
            realtime(g);
    }
    flush(g);
}
