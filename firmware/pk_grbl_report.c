/*
 * pk_grbl_report.c — everything the Grbl engine prints: numbers (fixed
 * point, no printf), the realtime status report with Grbl 1.1h's fields and
 * refresh schedule (report.c), and the multi-line reports $$ $# $G $I $N and
 * the help line, emitted a line at a time as the output buffer has room.
 */
#include "pk_grbl_internal.h"

#include <string.h>

/* Grbl's config.h refresh counts */
#define OVR_BUSY 20u
#define OVR_IDLE 10u
#define WCO_BUSY 30u
#define WCO_IDLE 10u

size_t pk_grbl_out_room(const struct pk_grbl *g) { return PK_GRBL_OUT_SIZE - g->out_len; }

/* Callers check the room first (PK_GRBL_ANSWER_MAX per piece); a write that
 * does not fit is cut rather than overrunning. */
void pk_grbl_put(struct pk_grbl *g, const char *s, size_t n)
{
    size_t room = pk_grbl_out_room(g);
    if (n > room)
        n = room;
    memcpy(g->out + g->out_len, s, n);
    g->out_len = (uint16_t)(g->out_len + n);
}

void pk_grbl_puts(struct pk_grbl *g, const char *s) { pk_grbl_put(g, s, strlen(s)); }

void pk_grbl_put_u32(struct pk_grbl *g, uint32_t v)
{
    char b[10];
    int n = 10;
    do {
        b[--n] = (char)('0' + v % 10u);
        v /= 10u;
    } while (v != 0);
    pk_grbl_put(g, b + n, (size_t)(10 - n));
}

void pk_grbl_put_fixed(struct pk_grbl *g, int64_t v, unsigned dec, unsigned pdec)
{
    if (v < 0) {
        pk_grbl_puts(g, "-");
        v = -v;
    }
    uint64_t u = (uint64_t)v, p = 1;
    for (unsigned i = 0; i < dec; i++)
        p *= 10u;
    uint64_t ip = u / p, fp = u % p;
    /* a 64-bit integer part only for out-of-range values: print its low
     * 32 bits' worth honestly by splitting */
    if (ip > 0xffffffffu) {
        pk_grbl_put_u32(g, (uint32_t)(ip / 1000000000u));
        char z[9];
        uint32_t lo = (uint32_t)(ip % 1000000000u);
        for (int i = 8; i >= 0; i--) {
            z[i] = (char)('0' + lo % 10u);
            lo /= 10u;
        }
        pk_grbl_put(g, z, 9);
    } else {
        pk_grbl_put_u32(g, (uint32_t)ip);
    }
    unsigned nd = dec;
    while (nd > pdec && fp % 10u == 0u) {
        fp /= 10u;
        nd--;
    }
    if (nd == 0 && pdec == 0)
        return;
    char f[12];
    unsigned total = nd > pdec ? nd : pdec;
    for (unsigned i = nd; i < total; i++)
        f[i] = '0';
    for (unsigned i = nd; i > 0; i--) {
        f[i - 1] = (char)('0' + fp % 10u);
        fp /= 10u;
    }
    pk_grbl_puts(g, ".");
    pk_grbl_put(g, f, total);
}

static int inches(const struct pk_grbl *g) { return g->set.v[PK_GRBL_S_REPORT_INCHES] != 0; }

static int64_t div_round(int64_t x, int64_t d) { return x >= 0 ? (x + d / 2) / d : -((-x + d / 2) / d); }

void pk_grbl_put_len(struct pk_grbl *g, int64_t um)
{
    if (inches(g))
        pk_grbl_put_fixed(g, div_round(um * 100, 254), 4, 4); /* 1e-4 inch */
    else
        pk_grbl_put_fixed(g, um, 3, 3);
}

void pk_grbl_put_axes(struct pk_grbl *g, const pk_um_t v[PK_GC_AXES])
{
    for (int a = 0; a < PK_GC_AXES; a++) {
        if (a)
            pk_grbl_puts(g, ",");
        pk_grbl_put_len(g, v[a]);
    }
}

void pk_grbl_put_rate(struct pk_grbl *g, int64_t um_min)
{
    if (inches(g))
        pk_grbl_put_fixed(g, div_round(um_min, 2540), 1, 1); /* 0.1 in/min */
    else
        pk_grbl_put_fixed(g, div_round(um_min, 1000), 0, 0);
}

int32_t pk_grbl_spindle_rpm_milli(const struct pk_grbl *g)
{
    if (g->gc.spindle == PK_GC_SPINDLE_OFF)
        return 0;
    int64_t s = (int64_t)g->gc.spindle_s * g->ovr_spindle / 100;
    int32_t mx = g->set.v[PK_GRBL_S_SPINDLE_MAX], mn = g->set.v[PK_GRBL_S_SPINDLE_MIN];
    if (s == 0)
        return 0;
    if (mn >= mx || s >= mx)
        return mx;
    if (s <= mn)
        return mn;
    return (int32_t)s;
}

int pk_grbl_state(const struct pk_grbl *g)
{
    int st = pk_grbl_mstate(g);
    if (g->mode == MODE_SLEEP)
        return PK_GRBL_SLEEP;
    if (st == PK_GRBL_M_ALARM || g->alarm)
        return PK_GRBL_ALARM;
    if (g->check_mode)
        return PK_GRBL_CHECK;
    if (g->jogging)
        return PK_GRBL_JOG;
    if (st == PK_GRBL_M_HOLDING)
        return PK_GRBL_HOLD1;
    if (st == PK_GRBL_M_HOLD || g->mode == MODE_IDLE_HOLD)
        return PK_GRBL_HOLD0;
    if (st == PK_GRBL_M_RUN)
        return PK_GRBL_RUN;
    return PK_GRBL_IDLE;
}

/* (switches, not tables of pointers: those would be relocated, writable data) */
static const char *state_name(struct pk_grbl *g, int *busy)
{
    int s = pk_grbl_state(g);
    /* Grbl's "busy" states refresh WCO/Ov more slowly */
    *busy = s == PK_GRBL_RUN || s == PK_GRBL_HOLD0 || s == PK_GRBL_HOLD1 || s == PK_GRBL_JOG;
    switch (s) {
    case PK_GRBL_RUN: return "Run";
    case PK_GRBL_HOLD0: return "Hold:0";
    case PK_GRBL_HOLD1: return "Hold:1";
    case PK_GRBL_JOG: return "Jog";
    case PK_GRBL_ALARM: return "Alarm";
    case PK_GRBL_CHECK: return "Check";
    case PK_GRBL_SLEEP: return "Sleep";
    default: return "Idle";
    }
}

static const char *motion_word(uint8_t m)
{
    switch (m) {
    case PK_GC_MOT_RAPID: return "G0";
    case PK_GC_MOT_LINEAR: return "G1";
    case PK_GC_MOT_CW_ARC: return "G2";
    case PK_GC_MOT_CCW_ARC: return "G3";
    case PK_GC_MOT_CUBIC: return "G5";
    case PK_GC_MOT_QUAD: return "G5.1";
    case PK_GC_MOT_PROBE_TOWARD: return "G38.2";
    case PK_GC_MOT_PROBE_TOWARD_NO_ERROR: return "G38.3";
    case PK_GC_MOT_PROBE_AWAY: return "G38.4";
    case PK_GC_MOT_PROBE_AWAY_NO_ERROR: return "G38.5";
    default: return "G80";
    }
}

void pk_grbl_status_report(struct pk_grbl *g)
{
    pk_um_t pos[PK_GC_AXES], wco[PK_GC_AXES];
    g->mo.position_um(g->m, pos);
    for (unsigned a = 0; a < PK_GC_AXES; a++)
        wco[a] = pk_gcode_wco(&g->gc, a);
    int busy;
    const char *name = state_name(g, &busy);
    pk_grbl_puts(g, "<");
    pk_grbl_puts(g, name);
    int32_t mask = g->set.v[PK_GRBL_S_REPORT_MASK];
    if (mask & 1) {
        pk_grbl_puts(g, "|MPos:");
    } else {
        pk_grbl_puts(g, "|WPos:");
        for (unsigned a = 0; a < PK_GC_AXES; a++)
            pos[a] -= wco[a];
    }
    pk_grbl_put_axes(g, pos);
    if (mask & 2) {
        pk_grbl_puts(g, "|Bf:");
        pk_grbl_put_u32(g, g->mo.blocks_free(g->m));
        pk_grbl_puts(g, ",");
        size_t used = g->io.rx_used ? g->io.rx_used(g->io.ctx) : 0;
        pk_grbl_put_u32(g, used >= PK_GRBL_RX_ADVERTISED ? 0u : (uint32_t)(PK_GRBL_RX_ADVERTISED - used));
    }
    pk_grbl_puts(g, "|FS:");
    pk_grbl_put_rate(g, g->mo.speed_umpm(g->m));
    pk_grbl_puts(g, ",");
    pk_grbl_put_fixed(g, pk_grbl_spindle_rpm_milli(g), 3, 0);
    /* Grbl's schedule (report.c): WCO when its counter runs out, then Ov on
     * the next report; both at once after a change (counter set to 0). */
    if (g->wco_counter > 0) {
        g->wco_counter--;
    } else {
        g->wco_counter = (uint8_t)((busy ? WCO_BUSY : WCO_IDLE) - 1u);
        if (g->ovr_counter == 0)
            g->ovr_counter = 1;
        pk_grbl_puts(g, "|WCO:");
        pk_grbl_put_axes(g, wco);
    }
    if (g->ovr_counter > 0) {
        g->ovr_counter--;
    } else {
        g->ovr_counter = (uint8_t)((busy ? OVR_BUSY : OVR_IDLE) - 1u);
        pk_grbl_puts(g, "|Ov:");
        pk_grbl_put_u32(g, g->ovr_feed);
        pk_grbl_puts(g, ",");
        pk_grbl_put_u32(g, g->ovr_rapid);
        pk_grbl_puts(g, ",");
        pk_grbl_put_u32(g, g->ovr_spindle);
        /* the output, as Grbl reads its pin: in laser mode it is off while
         * the last value sent (G0, or S0) is 0 */
        int sp = g->gc.spindle != PK_GC_SPINDLE_OFF &&
                 !(g->set.v[PK_GRBL_S_LASER] && g->laser_sent <= 0);
        if (sp || g->gc.coolant) {
            pk_grbl_puts(g, "|A:");
            if (sp)
                pk_grbl_puts(g, g->gc.spindle == PK_GC_SPINDLE_CCW ? "C" : "S");
            if (g->gc.coolant & PK_GC_COOLANT_FLOOD)
                pk_grbl_puts(g, "F");
            if (g->gc.coolant & PK_GC_COOLANT_MIST)
                pk_grbl_puts(g, "M");
        }
    }
    pk_grbl_puts(g, ">\r\n");
}

/* ---- multi-line reports ---------------------------------------------------------- */

static void gstate(struct pk_grbl *g)
{
    const struct pk_gc_state *s = &g->gc;
    pk_grbl_puts(g, "[GC:");
    pk_grbl_puts(g, motion_word(s->motion));
    pk_grbl_puts(g, " G");
    pk_grbl_put_u32(g, 54u + s->wcs);
    pk_grbl_puts(g, " G");
    pk_grbl_put_u32(g, 17u + s->plane);
    pk_grbl_puts(g, s->units == PK_GC_INCH ? " G20" : " G21");
    pk_grbl_puts(g, s->distance == PK_GC_INCREMENTAL ? " G91" : " G90");
    pk_grbl_puts(g, s->feedmode == PK_GC_INVERSE_TIME ? " G93" : " G94");
    pk_grbl_puts(g, s->path == PK_GC_PATH_EXACT ? " G61" : " G64");
    pk_grbl_puts(g, s->spindle == PK_GC_SPINDLE_CW ? " M3" : s->spindle == PK_GC_SPINDLE_CCW ? " M4" : " M5");
    if (s->coolant) {
        if (s->coolant & PK_GC_COOLANT_MIST)
            pk_grbl_puts(g, " M7");
        if (s->coolant & PK_GC_COOLANT_FLOOD)
            pk_grbl_puts(g, " M8");
    } else {
        pk_grbl_puts(g, " M9");
    }
    pk_grbl_puts(g, " T");
    pk_grbl_put_u32(g, s->tool);
    pk_grbl_puts(g, " F");
    if (s->feedmode == PK_GC_INVERSE_TIME)
        pk_grbl_put_fixed(g, div_round(s->feed, 1000), 0, 0);
    else
        pk_grbl_put_rate(g, s->feed);
    pk_grbl_puts(g, " S");
    pk_grbl_put_fixed(g, div_round(s->spindle_s, 1000), 0, 0);
    pk_grbl_puts(g, "]\r\n");
}

/* One piece of a report; returns 1 when the report is complete. */
static int report_piece(struct pk_grbl *g)
{
    switch (g->report) {
    case R_SETTINGS: {
        if (g->report_i >= PK_GRBL_S_COUNT)
            return 1;
        const struct pk_grbl_setting_def *d = pk_grbl_setting_def(g->report_i);
        pk_grbl_puts(g, "$");
        pk_grbl_put_u32(g, d->num);
        pk_grbl_puts(g, "=");
        pk_grbl_put_fixed(g, g->set.v[g->report_i], d->dec, d->pdec);
        pk_grbl_puts(g, "\r\n");
        g->report_i++;
        return 0;
    }
    case R_OFFSETS: {
        unsigned i = g->report_i++;
        pk_um_t v[PK_GC_AXES];
        if (i < PK_GC_COORD_COUNT) {
            (void)pk_grbl_nvm_coord_read(g, i, v);
            pk_grbl_puts(g, "[G");
            pk_grbl_put_u32(g, i == PK_GC_COORD_G28 ? 28u : i == PK_GC_COORD_G30 ? 30u : 54u + i);
            pk_grbl_puts(g, ":");
            pk_grbl_put_axes(g, v);
            pk_grbl_puts(g, "]\r\n");
        } else if (i == PK_GC_COORD_COUNT) {
            pk_grbl_puts(g, "[G92:");
            pk_grbl_put_axes(g, g->gc.g92_um);
            pk_grbl_puts(g, "]\r\n[TLO:");
            pk_grbl_put_len(g, g->gc.tlo_um);
            pk_grbl_puts(g, "]\r\n");
        } else {
            static const pk_um_t zero[PK_GC_AXES];
            pk_grbl_puts(g, "[PRB:");
            pk_grbl_put_axes(g, zero);
            pk_grbl_puts(g, ":0]\r\n");
            return 1;
        }
        return 0;
    }
    case R_INFO: {
        uint8_t buf[PK_GRBL_LINE_MAX];
        if (g->report_i++ == 0) {
            unsigned n = pk_grbl_nvm_line_read(g, PK_GRBL_N_STARTUP, buf);
            pk_grbl_puts(g, "[VER:1.1h.plotkin-0.1:");
            pk_grbl_put(g, (const char *)buf, n);
            pk_grbl_puts(g, "]\r\n");
            return 0;
        }
        pk_grbl_puts(g, "[OPT:VM,");
        pk_grbl_put_u32(g, g->mo.blocks_total(g->m));
        pk_grbl_puts(g, ",");
        pk_grbl_put_u32(g, PK_GRBL_RX_ADVERTISED);
        pk_grbl_puts(g, "]\r\n");
        return 1;
    }
    case R_STARTUP: {
        uint8_t buf[PK_GRBL_LINE_MAX];
        unsigned k = g->report_i++;
        unsigned n = pk_grbl_nvm_line_read(g, k, buf);
        pk_grbl_puts(g, "$N");
        pk_grbl_put_u32(g, k);
        pk_grbl_puts(g, "=");
        pk_grbl_put(g, (const char *)buf, n);
        pk_grbl_puts(g, "\r\n");
        return g->report_i >= PK_GRBL_N_STARTUP;
    }
    case R_GSTATE:
        gstate(g);
        return 1;
    case R_HELP:
        pk_grbl_puts(g, "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]\r\n");
        return 1;
    default:
        return 1;
    }
}

int pk_grbl_report_step(struct pk_grbl *g)
{
    while (pk_grbl_out_room(g) >= PK_GRBL_ANSWER_MAX) {
        if (report_piece(g)) {
            g->report = R_NONE;
            return 1;
        }
    }
    return 0;
}
