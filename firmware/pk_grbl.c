/*
 * pk_grbl.c — Grbl 1.1 protocol engine (see pk_grbl.h for the contract).
 *
 * Flow of one poll:
 *   1. realtime events (soft reset first, then '?', '!', '~' in arrival order)
 *   2. machine alarm detection
 *   3. pending output: greeting, status report, the rest of a multi-line
 *      report ($$, $#, $I, $G)
 *   4. the accepted command still being handed to the machine (pen, dwell,
 *      smoothing mode, the move or the vertices of a G5/G5.1 curve, end):
 *      while it is not all handed over, NO byte is read, so a sender's
 *      unacknowledged bytes wait in the receive ring and nothing is lost;
 *      its "ok" is sent once it is
 *   5. read bytes and answer lines until one needs to wait
 * Output is staged in g->out and flushed to the stream as it takes it; no new
 * line is read unless the staging buffer has room for the largest answer.
 */
#include "pk_grbl.h"

#include <string.h>

/* line_flags */
#define LF_OVERFLOW 0x01u  /* more than PK_GC_LINE_MAX bytes */
#define LF_LOST 0x02u      /* the stream reported lost bytes during this line */

/* multi-line reports */
enum { R_NONE = 0, R_SETTINGS, R_OFFSETS, R_INFO, R_GSTATE, R_HELP };

/* Largest single answer the engine emits at once (a status report or one
 * report line plus "ok"). */
#define ANSWER_MAX 160u

/* ---- settings table -------------------------------------------------------- */

#define U6(x) ((pk_gc_u6_t)(x) * 1000000)
#define U6M(x) ((pk_gc_u6_t)(x) * 1000)  /* x thousandths */

static const struct pk_grbl_setting_def settings_table[PK_GRBL_S_COUNT] = {
    [PK_GRBL_S_STEP_PULSE_US] = { 0, 1, U6(10), U6(1), U6(1000) },
    [PK_GRBL_S_JUNCTION_MM] = { 11, 0, U6M(10), 0, U6(10) },
    [PK_GRBL_S_TOLERANCE_MM] = { 12, 0, U6M(20), U6M(1), U6(10) },
    [PK_GRBL_S_STEPS_X] = { 100, 0, U6(80), U6(1), U6(10000) },
    [PK_GRBL_S_STEPS_Y] = { 101, 0, U6(80), U6(1), U6(10000) },
    [PK_GRBL_S_STEPS_Z] = { 102, 0, U6(80), U6(1), U6(10000) },
    [PK_GRBL_S_RATE_X] = { 110, 0, U6(6000), U6(1), U6(60000) },
    [PK_GRBL_S_RATE_Y] = { 111, 0, U6(6000), U6(1), U6(60000) },
    [PK_GRBL_S_RATE_Z] = { 112, 0, U6(1500), U6(1), U6(60000) },
    [PK_GRBL_S_ACCEL_X] = { 120, 0, U6(1000), U6(1), U6(100000) },
    [PK_GRBL_S_ACCEL_Y] = { 121, 0, U6(1000), U6(1), U6(100000) },
    [PK_GRBL_S_ACCEL_Z] = { 122, 0, U6(500), U6(1), U6(100000) },
    [PK_GRBL_S_TRAVEL_X] = { 130, 0, U6(300), U6(1), U6(2000) },
    [PK_GRBL_S_TRAVEL_Y] = { 131, 0, U6(300), U6(1), U6(2000) },
    [PK_GRBL_S_TRAVEL_Z] = { 132, 0, U6(50), U6(1), U6(2000) },
    [PK_GRBL_S_SMOOTH_MODE] = { 200, 1, U6(2), 0, U6(2) },
    [PK_GRBL_S_SCHEME] = { 201, 1, 0, 0, U6(1) },
    [PK_GRBL_S_DEGREE] = { 202, 1, U6(3), U6(1), U6(7) },
    [PK_GRBL_S_DEPTH] = { 203, 1, U6(3), 0, U6(8) },
    [PK_GRBL_S_CORNER_DEG] = { 204, 1, U6(60), U6(1), U6(180) },
    [PK_GRBL_S_PEN_SETTLE_MS] = { 205, 1, U6(50), 0, U6(60000) },
    [PK_GRBL_S_DIR_SETUP_US] = { 206, 1, U6(1), 0, U6(1000) },
};

const struct pk_grbl_setting_def *pk_grbl_setting_def(int idx)
{
    return idx >= 0 && idx < PK_GRBL_S_COUNT ? &settings_table[idx] : NULL;
}

int pk_grbl_setting_index(uint32_t num)
{
    for (int i = 0; i < PK_GRBL_S_COUNT; i++)
        if (settings_table[i].num == num)
            return i;
    return -1;
}

int pk_grbl_setting_parse(const uint8_t *s, size_t n, int *idx_out, pk_gc_u6_t *val_out)
{
    size_t eq = 0;
    while (eq < n && s[eq] != '=')
        eq++;
    if (eq == n || eq == 0)
        return 3;
    pk_gc_u6_t num, val;
    if (pk_gcode_parse_number(s, eq, &num) != PK_GC_OK || num < 0 || num % 1000000 != 0 ||
        num / 1000000 > UINT16_MAX)
        return 3;
    int rc = pk_gcode_parse_number(s + eq + 1, n - eq - 1, &val);
    if (rc != PK_GC_OK)
        return rc;
    int idx = pk_grbl_setting_index((uint32_t)(num / 1000000));
    if (idx < 0)
        return 3;
    const struct pk_grbl_setting_def *d = &settings_table[idx];
    if (val < 0)
        return 4;
    if (d->integer && val % 1000000 != 0)
        return 3;
    if (val < d->min || val > d->max)
        return 3;
    *idx_out = idx;
    *val_out = val;
    return 0;
}

void pk_grbl_settings_default(struct pk_grbl_settings *s)
{
    for (int i = 0; i < PK_GRBL_S_COUNT; i++)
        s->v[i] = settings_table[i].def;
}

static pk_um_t mm_setting_um(const struct pk_grbl_settings *s, int i)
{
    return (pk_um_t)pk_div_round64(s->v[i], 1000);
}

static void limits_from_settings(const struct pk_grbl_settings *s, struct pk_gc_limits *lim)
{
    lim->min_um[0] = 0;
    lim->max_um[0] = mm_setting_um(s, PK_GRBL_S_TRAVEL_X);
    lim->min_um[1] = 0;
    lim->max_um[1] = mm_setting_um(s, PK_GRBL_S_TRAVEL_Y);
    lim->max_um[2] = mm_setting_um(s, PK_GRBL_S_TRAVEL_Z);
    lim->min_um[2] = -lim->max_um[2];
}

/* ---- output ------------------------------------------------------------------- */

static size_t out_room(const struct pk_grbl *g) { return PK_GRBL_OUT_SIZE - g->out_len; }

/* Callers check out_room first; a write that does not fit is truncated
 * rather than overrunning (it cannot happen with the ANSWER_MAX checks). */
static void put(struct pk_grbl *g, const char *s, size_t n)
{
    if (n > out_room(g))
        n = out_room(g);
    memcpy(g->out + g->out_len, s, n);
    g->out_len = (uint16_t)(g->out_len + n);
}

static void puts_(struct pk_grbl *g, const char *s) { put(g, s, strlen(s)); }

static void put_u32(struct pk_grbl *g, uint32_t v)
{
    char b[10];
    int n = 0;
    do {
        b[n++] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0);
    char r[10];
    for (int i = 0; i < n; i++)
        r[i] = b[n - 1 - i];
    put(g, r, (size_t)n);
}

/* A value in 1e-6 units with `dec` decimals (0..6), rounded half away. */
static void put_u6(struct pk_grbl *g, pk_gc_u6_t v, int dec)
{
    int64_t div = 1;
    for (int i = dec; i < 6; i++)
        div *= 10;
    int64_t r = pk_div_round64(v, div); /* in 10^-dec units */
    if (r < 0) {
        puts_(g, "-");
        r = -r;
    }
    int64_t scale = 1;
    for (int i = 0; i < dec; i++)
        scale *= 10;
    put_u32(g, (uint32_t)(r / scale));
    if (dec > 0) {
        char f[6];
        int64_t frac = r % scale;
        for (int i = dec - 1; i >= 0; i--) {
            f[i] = (char)('0' + frac % 10);
            frac /= 10;
        }
        puts_(g, ".");
        put(g, f, (size_t)dec);
    }
}

/* µm as mm with 3 decimals. */
static void put_mm(struct pk_grbl *g, int64_t um) { put_u6(g, um * 1000, 3); }

static void put_xyz(struct pk_grbl *g, const pk_um_t v[PK_GC_AXES])
{
    for (int a = 0; a < PK_GC_AXES; a++) {
        if (a)
            puts_(g, ",");
        put_mm(g, v[a]);
    }
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

static void answer(struct pk_grbl *g, int status)
{
    g->stats.lines++;
    if (status == 0) {
        g->stats.ok++;
        puts_(g, "ok\r\n");
    } else {
        g->stats.errors++;
        puts_(g, "error:");
        put_u32(g, (uint32_t)status);
        puts_(g, "\r\n");
    }
}

/* ---- realtime ----------------------------------------------------------------- */

int pk_grbl_rt_filter(void *vg, uint8_t b)
{
    struct pk_grbl *g = vg;
    switch (b) {
    case '?':
    case '!':
    case '~':
    case 0x85: {
        uint8_t h = g->rt_head;
        if ((uint8_t)(h - g->rt_tail) < sizeof g->rt_buf) {
            g->rt_buf[h & (sizeof g->rt_buf - 1u)] = b;
            g->rt_head = (uint8_t)(h + 1u);
        }
        /* A full event ring means 16 unprocessed realtime bytes: further
         * duplicates carry no information the main loop will not act on. */
        return 1;
    }
    case 0x18:
        g->rt_resets = (uint8_t)(g->rt_resets + 1u);
        return 1;
    default:
        if (b == 0x84 || b == 0x87 || (b >= 0x90 && b <= 0x9D) || b == 0xA0 ||
            b == 0xA1)
            return 1; /* Grbl's extended realtime commands: claimed, not implemented */
        return 0;
    }
}

static int mstate(struct pk_grbl *g) { return g->mo.state(g->m); }

static void greet(struct pk_grbl *g)
{
    puts_(g, "\r\nGrbl 1.1h [" PK_GRBL_VERSION_STR " '$' for help]\r\n");
    if (g->alarm)
        puts_(g, "[MSG:'$H'|'$X' to unlock]\r\n");
}

static void status_report(struct pk_grbl *g)
{
    /* the state first: a machine that is stopped (Idle, Hold:0) when asked
     * is still stopped when its position is read after, so the two agree */
    int st = mstate(g);
    pk_um_t pos[PK_GC_AXES];
    g->mo.position_um(g->m, pos);
    puts_(g, "<");
    if (st == PK_GRBL_M_ALARM || g->alarm)
        puts_(g, "Alarm");
    else if (g->check_mode)
        puts_(g, "Check");
    else if (g->jogging && (st == PK_GRBL_M_RUN || g->cmd_todo))
        puts_(g, "Jog");
    else if (st == PK_GRBL_M_RUN)
        puts_(g, "Run");
    else if (st == PK_GRBL_M_HOLDING)
        puts_(g, "Hold:1");
    else if (st == PK_GRBL_M_HOLD)
        puts_(g, "Hold:0");
    else
        puts_(g, "Idle");
    puts_(g, "|MPos:");
    put_xyz(g, pos);
    puts_(g, "|Bf:");
    put_u32(g, g->mo.blocks_free(g->m));
    puts_(g, ",");
    size_t used = g->io.rx_used ? g->io.rx_used(g->io.ctx) : 0;
    put_u32(g, used >= PK_GRBL_RX_ADVERTISED ? 0u : (uint32_t)(PK_GRBL_RX_ADVERTISED - used));
    puts_(g, "|FS:");
    put_u32(g, (uint32_t)pk_div_round64(g->mo.speed_umpm(g->m), 1000));
    puts_(g, ",0");
    if (g->gc.offset_um[0] || g->gc.offset_um[1] || g->gc.offset_um[2]) {
        puts_(g, "|WCO:");
        put_xyz(g, g->gc.offset_um);
    }
    puts_(g, ">\r\n");
}

static void reset_gcode_state(struct pk_grbl *g)
{
    struct pk_gc_limits lim;
    pk_um_t pos[PK_GC_AXES];
    limits_from_settings(&g->set, &lim);
    g->mo.position_um(g->m, pos);
    pk_gcode_state_init(&g->gc, &lim, pos);
}

static void drop_input(struct pk_grbl *g)
{
    g->len = 0;
    g->line_flags = 0;
    g->last_cr = 0;
    g->cmd_todo = 0;
    g->bez_on = 0;
    g->pt_held = 0;
    g->report = R_NONE;
    g->jogging = 0;
    g->jog_cancel = 0;
}

static void soft_reset(struct pk_grbl *g)
{
    int cut = g->mo.reset(g->m);
    g->stats.resets++;
    drop_input(g);
    /* Like Grbl, forget what was received but not yet read: a sender
     * restarts its character count on reset. */
    uint8_t junk[32];
    for (int i = 0; i < 64 && g->io.read(g->io.ctx, junk, sizeof junk) != 0; i++) {
    }
    g->rt_tail = g->rt_head;
    g->status_due = 0;
    g->check_mode = 0;
    g->pen_now = 2;
    g->m_alarm_seen = 0;
    if (cut && !g->alarm)
        g->alarm = 3;
    reset_gcode_state(g);
    if (cut)
        puts_(g, "ALARM:3\r\n");
    g->greet_due = 1;
}

static void realtime(struct pk_grbl *g)
{
    if (g->rt_resets != g->rt_resets_seen) {
        g->rt_resets_seen = g->rt_resets;
        soft_reset(g);
    }
    while (g->rt_tail != g->rt_head) {
        uint8_t t = g->rt_tail;
        uint8_t b = g->rt_buf[t & (sizeof g->rt_buf - 1u)];
        g->rt_tail = (uint8_t)(t + 1u);
        if (b == '?') {
            g->status_due = 1;
        } else if (b == '!') {
            if (!g->check_mode)
                g->mo.hold(g->m);
        } else if (b == '~') {
            g->mo.resume(g->m);
        } else if (b == 0x85 && g->jogging) {
            g->mo.hold(g->m);
            g->jog_cancel = 1;
        }
    }
}

/* ---- $ commands ----------------------------------------------------------------- */

static const char *gstate_words(struct pk_grbl *g, int i)
{
    switch (i) {
    case 0:
        switch (g->gc.motion) {
        case PK_GC_MOT_RAPID: return "G0";
        case PK_GC_MOT_LINEAR: return "G1";
        case PK_GC_MOT_CUBIC: return "G5";
        case PK_GC_MOT_QUAD: return "G5.1";
        default: return "G80";
        }
    case 1: return "G54";
    case 2: return "G17";
    case 3: return g->gc.units == PK_GC_INCH ? "G20" : "G21";
    case 4: return g->gc.distance == PK_GC_INCREMENTAL ? "G91" : "G90";
    case 5: return "G94";
    case 6: return g->gc.path == PK_GC_PATH_EXACT ? "G61" : "G64";
    case 7: return g->gc.pen == PK_GC_PEN_DOWN ? "M3" : "M5";
    default: return "M9";
    }
}

/* Emit report lines while room allows; returns 1 when the report is done. */
static int continue_report(struct pk_grbl *g)
{
    while (out_room(g) >= ANSWER_MAX) {
        switch (g->report) {
        case R_SETTINGS:
            if (g->report_i >= PK_GRBL_S_COUNT)
                goto done;
            {
                const struct pk_grbl_setting_def *d = &settings_table[g->report_i];
                puts_(g, "$");
                put_u32(g, d->num);
                puts_(g, "=");
                put_u6(g, g->set.v[g->report_i], d->integer ? 0 : 3);
                puts_(g, "\r\n");
                g->report_i++;
            }
            break;
        case R_OFFSETS: {
            static const pk_um_t zero[PK_GC_AXES] = { 0, 0, 0 };
            puts_(g, "[G54:");
            put_xyz(g, zero);
            puts_(g, "]\r\n[G92:");
            put_xyz(g, g->gc.offset_um);
            puts_(g, "]\r\n");
            goto done;
        }
        case R_INFO:
            puts_(g, "[VER:1.1h.plotkin-0.1:]\r\n[OPT:,");
            put_u32(g, g->mo.blocks_total(g->m));
            puts_(g, ",");
            put_u32(g, PK_GRBL_RX_ADVERTISED);
            puts_(g, "]\r\n");
            goto done;
        case R_GSTATE:
            puts_(g, "[GC:");
            for (int i = 0; i < 9; i++) {
                if (i)
                    puts_(g, " ");
                puts_(g, gstate_words(g, i));
            }
            puts_(g, " T0 F");
            put_u6(g, g->gc.units == PK_GC_INCH ? (int64_t)g->gc.feed_umpm * 10000 / 254
                                                : (int64_t)g->gc.feed_umpm * 1000, 0);
            puts_(g, " S0]\r\n");
            goto done;
        case R_HELP:
            puts_(g, "[HLP:$$ $# $G $I $C $X $J=line $x=val ~ ! ? ctrl-x]\r\n");
            goto done;
        default:
            goto done;
        }
    }
    return 0;
done:
    g->report = R_NONE;
    answer(g, 0);
    return 1;
}

static int mstate_idle(struct pk_grbl *g)
{
    return mstate(g) == PK_GRBL_M_IDLE && g->cmd_todo == 0;
}

/* "$N=value": returns a Grbl status. */
static int set_setting(struct pk_grbl *g, const uint8_t *s, size_t n)
{
    int idx;
    pk_gc_u6_t val;
    int rc = pk_grbl_setting_parse(s, n, &idx, &val);
    if (rc != 0)
        return rc;
    if (!mstate_idle(g) || g->check_mode)
        return 8;
    struct pk_grbl_settings next = g->set;
    next.v[idx] = val;
    if (g->mo.configure(g->m, &next) != 0)
        return 3;
    g->set = next;
    /* New travel limits; the machine may also have restarted its position. */
    struct pk_gc_limits lim;
    limits_from_settings(&g->set, &lim);
    g->gc.lim = lim;
    g->mo.position_um(g->m, g->gc.pos_um);
    g->pen_now = 2;
    return 0;
}

static void run_pending(struct pk_grbl *g);

/* "$J=<words>": a jog move. Returns a Grbl status; on success the move is
 * the pending command (answered once handed to the machine). */
static int jog(struct pk_grbl *g, const uint8_t *s, size_t n)
{
    int st = mstate(g);
    if (g->alarm || st == PK_GRBL_M_ALARM)
        return 9;
    if (!(st == PK_GRBL_M_IDLE || (g->jogging && st == PK_GRBL_M_RUN)) || g->jog_cancel)
        return 8;
    struct pk_gc_block b;
    int rc = pk_gcode_parse(s, n, &b);
    if (rc != PK_GC_OK)
        return rc;
    const uint16_t groups_ok = PK_GC_GBIT(PK_GC_G_DISTANCE) | PK_GC_GBIT(PK_GC_G_UNITS);
    const uint16_t words_ok = PK_GC_AXIS_WORDS | PK_GC_WBIT(PK_GC_W_F) | PK_GC_WBIT(PK_GC_W_N);
    if ((b.groups & ~groups_ok) || (b.words & ~words_ok))
        return 16;
    if (!(b.words & PK_GC_WBIT(PK_GC_W_F)))
        return PK_GC_E_UNDEFINED_FEED;
    if (!(b.words & PK_GC_AXIS_WORDS))
        return PK_GC_E_NO_AXIS_WORDS;
    /* A jog changes the position, never the program's modal state. */
    struct pk_gc_state tmp = g->gc;
    b.groups |= PK_GC_GBIT(PK_GC_G_MOTION);
    b.motion = PK_GC_MOT_LINEAR;
    rc = pk_gcode_interp(&tmp, &b, &g->cmd);
    if (rc != PK_GC_OK)
        return rc;
    if (g->check_mode)
        return 0;
    for (int a = 0; a < PK_GC_AXES; a++)
        g->gc.pos_um[a] = tmp.pos_um[a];
    g->gc.cubic_prev = 0;
    g->jogging = 1;
    g->cmd_todo = PK_GC_DO_MOVE;
    return -1; /* pending */
}

/* A line starting with '$' (s excludes leading blanks). Answers it, or starts
 * a multi-line report. */
static void system_line(struct pk_grbl *g, const uint8_t *s, size_t n)
{
    /* Upper-case copy without blanks; values keep their spelling. */
    uint8_t c[PK_GC_LINE_MAX];
    size_t k = 0;
    for (size_t i = 1; i < n; i++) {
        uint8_t b = s[i];
        if (b == ' ' || b == '\t')
            continue;
        if (b >= 'a' && b <= 'z')
            b = (uint8_t)(b - 'a' + 'A');
        c[k++] = b;
    }
    int rc = 3;
    if (k == 0) {
        g->report = R_HELP;
        return;
    }
    if (k == 1 && c[0] == '$') {
        g->report = R_SETTINGS;
        g->report_i = 0;
        return;
    }
    if (k == 1 && c[0] == '#') {
        g->report = R_OFFSETS;
        return;
    }
    if (k == 1 && c[0] == 'I') {
        g->report = R_INFO;
        return;
    }
    if (k == 1 && c[0] == 'G') {
        g->report = R_GSTATE;
        return;
    }
    if (k == 1 && c[0] == 'X') {
        if (mstate(g) == PK_GRBL_M_ALARM) {
            g->mo.reset(g->m);
            reset_gcode_state(g);
            g->pen_now = 2;
        }
        if (g->alarm || mstate(g) == PK_GRBL_M_IDLE) {
            if (g->alarm)
                puts_(g, "[MSG:Caution: Unlocked]\r\n");
            g->alarm = 0;
            g->m_alarm_seen = 0;
        }
        rc = 0;
    } else if (k == 1 && c[0] == 'C') {
        if (!mstate_idle(g)) {
            rc = 8;
        } else if (g->check_mode) {
            puts_(g, "[MSG:Disabled]\r\n");
            answer(g, 0);
            /* Leaving check mode restarts like Grbl (soft reset). */
            soft_reset(g);
            return;
        } else {
            g->check_mode = 1;
            puts_(g, "[MSG:Enabled]\r\n");
            rc = 0;
        }
    } else if (k >= 2 && c[0] == 'J' && c[1] == '=') {
        size_t eq = 0;
        while (s[eq] != '=')
            eq++;
        rc = jog(g, s + eq + 1, n - eq - 1);
        if (rc < 0) {
            g->bez_on = 0;
            g->pt_held = 0;
            run_pending(g);
            return;
        }
    } else if (k == 1 && c[0] == 'H') {
        rc = 5; /* homing not enabled */
    } else if (k >= 2 && c[0] >= '0' && c[0] <= '9') {
        rc = set_setting(g, c, k);
    }
    answer(g, rc);
}

/* ---- executing an accepted command ------------------------------------------------ */

/* Hand as much of g->cmd to the machine as it takes. Returns 1 when done. */
static int advance(struct pk_grbl *g)
{
    const struct pk_gc_cmd *c = &g->cmd;
    int rc;
    if (g->cmd_todo & PK_GC_DO_PEN) {
        if (g->pen_now != c->pen) {
            rc = g->mo.pen(g->m, c->pen == PK_GC_PEN_DOWN);
            if (rc == PK_GRBL_M_FULL)
                return 0;
            if (rc != PK_GRBL_M_OK)
                return -1;
            g->pen_now = c->pen;
        }
        g->cmd_todo &= (uint8_t)~PK_GC_DO_PEN;
    }
    if (g->cmd_todo & PK_GC_DO_DWELL) {
        rc = g->mo.dwell(g->m, c->dwell_ms);
        if (rc == PK_GRBL_M_FULL)
            return 0;
        if (rc != PK_GRBL_M_OK)
            return -1;
        g->cmd_todo &= (uint8_t)~PK_GC_DO_DWELL;
    }
    if (g->cmd_todo & PK_GC_DO_PATH) {
        pk_um_t tol = c->tol_um > 0 ? c->tol_um : mm_setting_um(&g->set, PK_GRBL_S_TOLERANCE_MM);
        rc = g->mo.smoothing(g->m, c->path == PK_GC_PATH_EXACT, tol);
        if (rc == PK_GRBL_M_FULL)
            return 0;
        if (rc != PK_GRBL_M_OK)
            return -1;
        g->cmd_todo &= (uint8_t)~PK_GC_DO_PATH;
    }
    if (g->cmd_todo & PK_GC_DO_MOVE) {
        if (c->motion == PK_GC_MOT_CUBIC || c->motion == PK_GC_MOT_QUAD) {
            if (!g->bez_on) {
                pk_um_t p[4][2] = { { c->start_um[0], c->start_um[1] },
                                    { c->ctrl_um[0][0], c->ctrl_um[0][1] },
                                    { c->ctrl_um[1][0], c->ctrl_um[1][1] },
                                    { c->target_um[0], c->target_um[1] } };
                if (c->motion == PK_GC_MOT_QUAD) {
                    p[2][0] = c->target_um[0];
                    p[2][1] = c->target_um[1];
                }
                /* The curve is flattened within the smoothing tolerance in
                 * force: G64 P<tol> if one was given, else $12. */
                pk_bez_init(&g->bez, (const pk_um_t(*)[2])p, c->motion == PK_GC_MOT_QUAD,
                            g->gc.tol_um > 0 ? g->gc.tol_um
                                             : mm_setting_um(&g->set, PK_GRBL_S_TOLERANCE_MM));
                g->bez_on = 1;
                g->pt_held = 0;
            }
            for (;;) {
                if (!g->pt_held) {
                    if (!pk_bez_next(&g->bez, g->pt))
                        break;
                    g->pt_held = 1;
                }
                pk_um_t t[PK_GC_AXES] = { g->pt[0], g->pt[1], c->target_um[2] };
                rc = g->mo.move(g->m, t, c->feed_umpm, 0);
                if (rc == PK_GRBL_M_FULL)
                    return 0;
                if (rc != PK_GRBL_M_OK)
                    return -1;
                g->stats.moves++;
                g->pt_held = 0;
            }
            g->bez_on = 0;
        } else {
            rc = g->mo.move(g->m, c->target_um, c->feed_umpm, c->motion == PK_GC_MOT_RAPID);
            if (rc == PK_GRBL_M_FULL)
                return 0;
            if (rc != PK_GRBL_M_OK)
                return -1;
            g->stats.moves++;
        }
        g->cmd_todo &= (uint8_t)~PK_GC_DO_MOVE;
    }
    if (g->cmd_todo & PK_GC_DO_STOP) {
        if (g->pen_now != 0) {
            rc = g->mo.pen(g->m, 0);
            if (rc == PK_GRBL_M_FULL)
                return 0;
            if (rc != PK_GRBL_M_OK)
                return -1;
            g->pen_now = 0;
        }
        rc = g->mo.end(g->m);
        if (rc == PK_GRBL_M_FULL)
            return 0;
        if (rc != PK_GRBL_M_OK)
            return -1;
        g->cmd_todo &= (uint8_t)~PK_GC_DO_STOP;
    }
    g->cmd_todo = 0;
    return 1;
}

/* Keep handing over the pending command; answer its line when done. */
static void run_pending(struct pk_grbl *g)
{
    if (g->cmd_todo == 0)
        return;
    int r = advance(g);
    if (r == 0)
        return;
    g->cmd_todo = 0;
    g->bez_on = 0;
    g->pt_held = 0;
    /* The machine refused part of an accepted line: only an alarm does that. */
    answer(g, r > 0 ? 0 : 9);
}

/* ---- lines ------------------------------------------------------------------------- */

static void process_line(struct pk_grbl *g)
{
    const uint8_t *s = g->line;
    size_t n = g->len;
    uint8_t flags = g->line_flags;
    g->len = 0;
    g->line_flags = 0;
    if (flags & LF_LOST) {
        puts_(g, "[MSG:RX overflow: bytes of this line were lost]\r\n");
        answer(g, PK_GC_E_LINE_OVERFLOW);
        return;
    }
    if (flags & LF_OVERFLOW) {
        answer(g, PK_GC_E_LINE_OVERFLOW);
        return;
    }
    size_t i = 0;
    while (i < n && (s[i] == ' ' || s[i] == '\t'))
        i++;
    if (i < n && s[i] == '$') {
        system_line(g, s + i, n - i);
        return;
    }
    struct pk_gc_block b;
    int rc = pk_gcode_parse(s, n, &b);
    if (rc == PK_GC_OK && b.words == 0 && b.groups == 0) {
        answer(g, 0); /* empty or comment line: ok, as Grbl answers */
        return;
    }
    if (g->alarm || mstate(g) == PK_GRBL_M_ALARM || g->jogging) {
        answer(g, 9);
        return;
    }
    if (rc != PK_GC_OK) {
        answer(g, rc);
        return;
    }
    rc = pk_gcode_interp(&g->gc, &b, &g->cmd);
    if (rc != PK_GC_OK) {
        answer(g, rc);
        return;
    }
    if (g->check_mode || g->cmd.what == 0) {
        answer(g, 0);
        return;
    }
    g->cmd_todo = g->cmd.what;
    g->bez_on = 0;
    g->pt_held = 0;
    run_pending(g);
}

/* One received byte. */
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
     * act on it exactly as the ISR would, and keep it out of the line. */
    if (pk_grbl_rt_filter(g, b)) {
        realtime(g);
        return;
    }
    if (g->len < PK_GC_LINE_MAX)
        g->line[g->len++] = b;
    else
        g->line_flags |= LF_OVERFLOW;
}

/* ---- public ------------------------------------------------------------------------ */

int pk_grbl_init(struct pk_grbl *g, const struct pk_grbl_stream *io,
                 const struct pk_grbl_machine_ops *mo, void *m,
                 const struct pk_grbl_settings *set)
{
    memset(g, 0, sizeof *g);
    g->io = *io;
    g->mo = *mo;
    g->m = m;
    if (set)
        g->set = *set;
    else
        pk_grbl_settings_default(&g->set);
    if (mo->configure(m, &g->set) != 0)
        return -1;
    g->pen_now = 2;
    reset_gcode_state(g);
    g->greet_due = 1;
    return 0;
}

int pk_grbl_idle(const struct pk_grbl *g)
{
    return g->out_len == 0 && g->cmd_todo == 0 && g->report == R_NONE && !g->greet_due &&
           !g->status_due;
}

void pk_grbl_poll(struct pk_grbl *g)
{
    realtime(g);
    if (mstate(g) == PK_GRBL_M_ALARM && !g->m_alarm_seen && out_room(g) >= ANSWER_MAX) {
        /* A machine fault (a HAL write failed): position may be lost, as
         * after a hard limit, hence Grbl's ALARM:1. */
        g->m_alarm_seen = 1;
        g->alarm = 1;
        puts_(g, "ALARM:1\r\n");
        if (g->cmd_todo) {
            g->cmd_todo = 0;
            answer(g, 9);
        }
    }
    if (g->jogging) {
        int st = mstate(g);
        if (g->jog_cancel && (st == PK_GRBL_M_HOLD || st == PK_GRBL_M_IDLE)) {
            /* Stopped within the acceleration limit: now drop what is left
             * of the jog (no alarm: nothing was cut while moving). */
            g->mo.reset(g->m);
            g->pen_now = 2;
            g->mo.position_um(g->m, g->gc.pos_um);
            if (g->cmd_todo) {
                g->cmd_todo = 0;
                answer(g, 0);
            }
            g->jogging = 0;
            g->jog_cancel = 0;
        } else if (!g->jog_cancel && st == PK_GRBL_M_IDLE && g->cmd_todo == 0) {
            g->jogging = 0;
        }
    }
    flush(g);
    if (g->greet_due && out_room(g) >= ANSWER_MAX) {
        g->greet_due = 0;
        greet(g);
    }
    if (g->status_due && out_room(g) >= ANSWER_MAX) {
        g->status_due = 0;
        status_report(g);
    }
    /* Bounded: at most PK_GC_LINE_MAX + a few bytes per call. */
    for (int budget = PK_GC_LINE_MAX + 8; budget > 0; budget--) {
        if (g->greet_due)
            break;
        if (g->report != R_NONE && !continue_report(g))
            break;
        run_pending(g);
        if (g->cmd_todo != 0 || out_room(g) < ANSWER_MAX)
            break;
        uint8_t b;
        int n = g->io.read(g->io.ctx, &b, 1);
        if (n < 0) {
            g->stats.rx_lost++;
            g->line_flags |= LF_LOST;
            continue;
        }
        if (n == 0)
            break;
        take_byte(g, b);
        if (g->rt_resets != g->rt_resets_seen)
            realtime(g);
    }
    flush(g);
}
