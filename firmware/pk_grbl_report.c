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

void pk_grbl_puts_rom(struct pk_grbl *g, const char *rom_s)
{
    size_t room = pk_grbl_out_room(g);
    for (uint8_t c; room > 0 && (c = pk_rom_u8(rom_s)) != 0u; rom_s++, room--)
        g->out[g->out_len++] = c;
}

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

/* Reports are 32-bit throughout (no 64-bit helpers on AVR): every value
 * printed is an int32 setting, a position within +-2 * PK_UM_MAX, a rate or
 * a spindle speed. */
void pk_grbl_put_fixed(struct pk_grbl *g, int32_t v, unsigned dec, unsigned pdec)
{
    uint32_t u = (uint32_t)v;
    if (v < 0) {
        PK_GRBL_PUTS(g, "-");
        u = 0u - u;
    }
    uint32_t p = 1;
    for (unsigned i = 0; i < dec; i++)
        p *= 10u;
    uint32_t fp = u % p;
    pk_grbl_put_u32(g, u / p);
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
    PK_GRBL_PUTS(g, ".");
    pk_grbl_put(g, f, total);
}

static int inches(const struct pk_grbl *g) { return g->set.v[PK_GRBL_S_REPORT_INCHES] != 0; }

/* x / d rounded half away from zero; d > 0 */
static int32_t div_round(int32_t x, int32_t d)
{
    return x >= 0 ? (int32_t)(((uint32_t)x + (uint32_t)d / 2u) / (uint32_t)d)
                  : -(int32_t)(((0u - (uint32_t)x) + (uint32_t)d / 2u) / (uint32_t)d);
}

void pk_grbl_put_len(struct pk_grbl *g, int32_t um)
{
    if (inches(g)) {
        /* 1e-4 inch = um * 50 / 127; |um| <= 2 * PK_UM_MAX keeps um * 50 in range */
        if (um > 40000000 || um < -40000000)
            um = um > 0 ? 40000000 : -40000000;
        pk_grbl_put_fixed(g, div_round(um * 50, 127), 4, 4);
    } else {
        pk_grbl_put_fixed(g, um, 3, 3);
    }
}

void pk_grbl_put_axes(struct pk_grbl *g, const pk_um_t v[PK_GC_AXES])
{
    for (int a = 0; a < PK_GC_AXES; a++) {
        if (a)
            PK_GRBL_PUTS(g, ",");
        pk_grbl_put_len(g, v[a]);
    }
}

void pk_grbl_put_rate(struct pk_grbl *g, int32_t um_min)
{
    if (inches(g))
        pk_grbl_put_fixed(g, div_round(um_min, 2540), 1, 1); /* 0.1 in/min */
    else
        pk_grbl_put_fixed(g, div_round(um_min, 1000), 0, 0);
}

int pk_grbl_spindle_span(const struct pk_grbl *g, int32_t s_milli, uint32_t *s_out)
{
    /* 32-bit only (it runs per move in laser mode): s_milli / 100 * 200 and
     * the remainder term stay below 2^32 for every int32 S */
    if (s_milli <= 0)
        return PK_GRBL_SPAN_ZERO;
    uint32_t sm = (uint32_t)s_milli, ovr = g->ovr_spindle;
    uint32_t s = sm / 100u * ovr + sm % 100u * ovr / 100u;
    uint32_t mx = (uint32_t)g->set.v[PK_GRBL_S_SPINDLE_MAX], mn = (uint32_t)g->set.v[PK_GRBL_S_SPINDLE_MIN];
    *s_out = s;
    if (s == 0)
        return PK_GRBL_SPAN_ZERO;
    if (mn >= mx || s >= mx)
        return PK_GRBL_SPAN_MAX;
    return s <= mn ? PK_GRBL_SPAN_MIN : PK_GRBL_SPAN_INSIDE;
}

int32_t pk_grbl_spindle_rpm_milli(const struct pk_grbl *g)
{
    if (g->gc.spindle == PK_GC_SPINDLE_OFF)
        return 0;
    uint32_t s = 0;
    switch (pk_grbl_spindle_span(g, g->gc.spindle_s, &s)) {
    case PK_GRBL_SPAN_ZERO: return 0;
    case PK_GRBL_SPAN_MAX: return g->set.v[PK_GRBL_S_SPINDLE_MAX];
    case PK_GRBL_SPAN_MIN: return g->set.v[PK_GRBL_S_SPINDLE_MIN];
    default: return (int32_t)s;
    }
}

int pk_grbl_state(const struct pk_grbl *g)
{
    int st = pk_grbl_mstate(g);
    if (g->mode == MODE_SLEEP)
        return PK_GRBL_SLEEP;
    if (g->mode == MODE_HOMING)
        return PK_GRBL_HOME;
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

/* Names packed in one string in program memory, NUL-separated (a table of
 * pointers, or a switch that gcc turns into one, would be writable data on
 * an AVR): the k-th of them, the last one for k past the end. */
static const char *rom_nth(const char *list, unsigned k, unsigned count)
{
    if (k >= count)
        k = count - 1u;
    while (k > 0u)
        if (pk_rom_u8(list++) == 0)
            k--;
    return list;
}

static const char state_names[] PK_ROM = "Idle\0Run\0Hold:0\0Hold:1\0Jog\0Alarm\0Check\0Sleep\0Home";
_Static_assert(PK_GRBL_IDLE == 0 && PK_GRBL_RUN == 1 && PK_GRBL_HOLD0 == 2 && PK_GRBL_HOLD1 == 3 &&
               PK_GRBL_JOG == 4 && PK_GRBL_ALARM == 5 && PK_GRBL_CHECK == 6 &&
               PK_GRBL_SLEEP == 7 && PK_GRBL_HOME == 8, "state_names follows enum pk_grbl_state");

static const char *state_name(struct pk_grbl *g, int *busy)
{
    int s = pk_grbl_state(g);
    /* Grbl's "busy" states refresh WCO/Ov more slowly */
    *busy = s == PK_GRBL_RUN || s == PK_GRBL_HOLD0 || s == PK_GRBL_HOLD1 || s == PK_GRBL_JOG ||
            s == PK_GRBL_HOME;
    return rom_nth(state_names, s < 0 || s > PK_GRBL_HOME ? 0u : (unsigned)s, 9u);
}

/* G0 .. G38.5 by enum pk_gc_motion, then G80 (PK_GC_MOT_NONE and anything after) */
static const char motion_words[] PK_ROM = "G0\0G1\0G2\0G3\0G5\0G5.1\0G38.2\0G38.3\0G38.4\0G38.5\0G80";
_Static_assert(PK_GC_MOT_RAPID == 0 && PK_GC_MOT_LINEAR == 1 && PK_GC_MOT_CW_ARC == 2 &&
               PK_GC_MOT_CCW_ARC == 3 && PK_GC_MOT_CUBIC == 4 && PK_GC_MOT_QUAD == 5 &&
               PK_GC_MOT_PROBE_TOWARD == 6 && PK_GC_MOT_PROBE_TOWARD_NO_ERROR == 7 &&
               PK_GC_MOT_PROBE_AWAY == 8 && PK_GC_MOT_PROBE_AWAY_NO_ERROR == 9,
               "motion_words follows enum pk_gc_motion");

static const char *motion_word(uint8_t m) { return rom_nth(motion_words, m, 11u); }

void pk_grbl_status_report(struct pk_grbl *g)
{
    /* the state first: a machine that is stopped (Idle, Hold:0) when asked
     * is still stopped when its position is read after, so the two agree */
    int busy;
    const char *name = state_name(g, &busy);
    pk_um_t pos[PK_GC_AXES], wco[PK_GC_AXES];
    g->mo.position_um(g->m, pos);
    for (unsigned a = 0; a < PK_GC_AXES; a++)
        wco[a] = pk_gcode_wco(&g->gc, a);
    PK_GRBL_PUTS(g, "<");
    pk_grbl_puts_rom(g, name);
    int32_t mask = g->set.v[PK_GRBL_S_REPORT_MASK];
    if (mask & 1) {
        PK_GRBL_PUTS(g, "|MPos:");
    } else {
        PK_GRBL_PUTS(g, "|WPos:");
        for (unsigned a = 0; a < PK_GC_AXES; a++)
            pos[a] -= wco[a];
    }
    pk_grbl_put_axes(g, pos);
    if (mask & 2) {
        PK_GRBL_PUTS(g, "|Bf:");
        pk_grbl_put_u32(g, g->mo.blocks_free(g->m));
        PK_GRBL_PUTS(g, ",");
        size_t used = g->io.rx_used ? g->io.rx_used(g->io.ctx) : 0;
        pk_grbl_put_u32(g, used >= PK_GRBL_RX_ADVERTISED ? 0u : (uint32_t)(PK_GRBL_RX_ADVERTISED - used));
    }
    PK_GRBL_PUTS(g, "|FS:");
    pk_grbl_put_rate(g, g->mo.speed_umpm(g->m));
    PK_GRBL_PUTS(g, ",");
    pk_grbl_put_fixed(g, pk_grbl_spindle_rpm_milli(g), 3, 0);
    if (PK_GRBL_INPUTS && g->mo.inputs) {
        /* Grbl's Pn: the active inputs, in its order P X Y Z D R H S */
        uint32_t lv = g->mo.inputs(g->m, PK_GRBL_IN_LEVELS);
        if (lv != 0u) {
            /* input bit of each letter, one nibble each: P=4 X=0 Y=1 Z=2 D=5 R=8 H=6 S=7 */
            const uint32_t order = 0x76852104u;
            const char *letters = PK_ROM_STR("PXYZDRHS");
            PK_GRBL_PUTS(g, "|Pn:");
            for (unsigned i = 0; i < 8u; i++) {
                unsigned b = (order >> (4u * i)) & 0xFu;
                if ((lv & (1u << b)) == 0u || (b < 4u && b >= PK_GC_AXES))
                    continue;
                char ch = (char)pk_rom_u8(letters + i);
                pk_grbl_put(g, &ch, 1);
            }
        }
    }
    /* Grbl's schedule (report.c): WCO when its counter runs out, then Ov on
     * the next report; both at once after a change (counter set to 0). */
    if (g->wco_counter > 0) {
        g->wco_counter--;
    } else {
        g->wco_counter = (uint8_t)((busy ? WCO_BUSY : WCO_IDLE) - 1u);
        if (g->ovr_counter == 0)
            g->ovr_counter = 1;
        PK_GRBL_PUTS(g, "|WCO:");
        pk_grbl_put_axes(g, wco);
    }
    if (g->ovr_counter > 0) {
        g->ovr_counter--;
    } else {
        g->ovr_counter = (uint8_t)((busy ? OVR_BUSY : OVR_IDLE) - 1u);
        PK_GRBL_PUTS(g, "|Ov:");
        pk_grbl_put_u32(g, g->ovr_feed);
        PK_GRBL_PUTS(g, ",");
        pk_grbl_put_u32(g, g->ovr_rapid);
        PK_GRBL_PUTS(g, ",");
        pk_grbl_put_u32(g, g->ovr_spindle);
        /* the output, as Grbl reads its pin: in laser mode it is off while
         * the last value sent (G0, or S0) is 0 */
        int sp = g->gc.spindle != PK_GC_SPINDLE_OFF &&
                 !(g->set.v[PK_GRBL_S_LASER] && g->laser_sent <= 0);
        if (sp || g->gc.coolant) {
            PK_GRBL_PUTS(g, "|A:");
            if (sp)
                pk_grbl_puts_rom(g, g->gc.spindle == PK_GC_SPINDLE_CCW ? PK_ROM_STR("C") : PK_ROM_STR("S"));
            if (g->gc.coolant & PK_GC_COOLANT_FLOOD)
                PK_GRBL_PUTS(g, "F");
            if (g->gc.coolant & PK_GC_COOLANT_MIST)
                PK_GRBL_PUTS(g, "M");
        }
    }
    PK_GRBL_PUTS(g, ">\r\n");
}

/* ---- multi-line reports ---------------------------------------------------------- */

static void gstate(struct pk_grbl *g)
{
    const struct pk_gc_state *s = &g->gc;
    PK_GRBL_PUTS(g, "[GC:");
    pk_grbl_puts_rom(g, motion_word(s->motion));
    PK_GRBL_PUTS(g, " G");
    pk_grbl_put_u32(g, 54u + s->wcs);
    PK_GRBL_PUTS(g, " G");
    pk_grbl_put_u32(g, 17u + s->plane);
    pk_grbl_puts_rom(g, s->units == PK_GC_INCH ? PK_ROM_STR(" G20") : PK_ROM_STR(" G21"));
    pk_grbl_puts_rom(g, s->distance == PK_GC_INCREMENTAL ? PK_ROM_STR(" G91") : PK_ROM_STR(" G90"));
    pk_grbl_puts_rom(g, s->feedmode == PK_GC_INVERSE_TIME ? PK_ROM_STR(" G93") : PK_ROM_STR(" G94"));
    pk_grbl_puts_rom(g, s->path == PK_GC_PATH_EXACT ? PK_ROM_STR(" G61") : PK_ROM_STR(" G64"));
    pk_grbl_puts_rom(g, s->spindle == PK_GC_SPINDLE_CW    ? PK_ROM_STR(" M3")
                        : s->spindle == PK_GC_SPINDLE_CCW ? PK_ROM_STR(" M4")
                                                          : PK_ROM_STR(" M5"));
    if (s->coolant) {
        if (s->coolant & PK_GC_COOLANT_MIST)
            PK_GRBL_PUTS(g, " M7");
        if (s->coolant & PK_GC_COOLANT_FLOOD)
            PK_GRBL_PUTS(g, " M8");
    } else {
        PK_GRBL_PUTS(g, " M9");
    }
    PK_GRBL_PUTS(g, " T");
    pk_grbl_put_u32(g, s->tool);
    PK_GRBL_PUTS(g, " F");
    if (s->feedmode == PK_GC_INVERSE_TIME)
        pk_grbl_put_fixed(g, div_round(s->feed, 1000), 0, 0);
    else
        pk_grbl_put_rate(g, s->feed);
    PK_GRBL_PUTS(g, " S");
    pk_grbl_put_fixed(g, div_round(s->spindle_s, 1000), 0, 0);
    PK_GRBL_PUTS(g, "]\r\n");
}

/* One piece of a report; returns 1 when the report is complete. */
static int report_piece(struct pk_grbl *g)
{
    switch (g->report) {
    case R_SETTINGS: {
        if (g->report_i >= PK_GRBL_S_COUNT)
            return 1;
        struct pk_grbl_setting_def d;
        (void)pk_grbl_setting_def(g->report_i, &d);
        PK_GRBL_PUTS(g, "$");
        pk_grbl_put_u32(g, d.num);
        PK_GRBL_PUTS(g, "=");
        pk_grbl_put_fixed(g, g->set.v[g->report_i], d.dec, d.pdec);
        PK_GRBL_PUTS(g, "\r\n");
        g->report_i++;
        return 0;
    }
    case R_OFFSETS: {
        unsigned i = g->report_i++;
        pk_um_t v[PK_GC_AXES];
        if (i < PK_GC_COORD_COUNT) {
            (void)pk_grbl_nvm_coord_read(g, i, v);
            PK_GRBL_PUTS(g, "[G");
            pk_grbl_put_u32(g, i == PK_GC_COORD_G28 ? 28u : i == PK_GC_COORD_G30 ? 30u : 54u + i);
            PK_GRBL_PUTS(g, ":");
            pk_grbl_put_axes(g, v);
            PK_GRBL_PUTS(g, "]\r\n");
        } else if (i == PK_GC_COORD_COUNT) {
            PK_GRBL_PUTS(g, "[G92:");
            pk_grbl_put_axes(g, g->gc.g92_um);
            PK_GRBL_PUTS(g, "]\r\n[TLO:");
            pk_grbl_put_len(g, g->gc.tlo_um);
            PK_GRBL_PUTS(g, "]\r\n");
        } else {
            PK_GRBL_PUTS(g, "[PRB:");
            pk_grbl_put_axes(g, g->prb_um);
            pk_grbl_puts_rom(g, g->probe_ok ? PK_ROM_STR(":1]\r\n") : PK_ROM_STR(":0]\r\n"));
            return 1;
        }
        return 0;
    }
    case R_INFO: {
        uint8_t buf[PK_GRBL_LINE_MAX];
        if (g->report_i++ == 0) {
            unsigned n = pk_grbl_nvm_line_read(g, PK_GRBL_N_STARTUP, buf);
            PK_GRBL_PUTS(g, "[VER:1.1h.plotkin-0.1:");
            pk_grbl_put(g, (const char *)buf, n);
            PK_GRBL_PUTS(g, "]\r\n");
            return 0;
        }
        PK_GRBL_PUTS(g, "[OPT:VM,");
        pk_grbl_put_u32(g, g->mo.blocks_total(g->m));
        PK_GRBL_PUTS(g, ",");
        pk_grbl_put_u32(g, PK_GRBL_RX_ADVERTISED);
        PK_GRBL_PUTS(g, "]\r\n");
        return 1;
    }
    case R_STARTUP: {
        uint8_t buf[PK_GRBL_LINE_MAX];
        unsigned k = g->report_i++;
        unsigned n = pk_grbl_nvm_line_read(g, k, buf);
        PK_GRBL_PUTS(g, "$N");
        pk_grbl_put_u32(g, k);
        PK_GRBL_PUTS(g, "=");
        pk_grbl_put(g, (const char *)buf, n);
        PK_GRBL_PUTS(g, "\r\n");
        return g->report_i >= PK_GRBL_N_STARTUP;
    }
    case R_GSTATE:
        gstate(g);
        return 1;
    case R_HELP:
        PK_GRBL_PUTS(g, "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]\r\n");
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
