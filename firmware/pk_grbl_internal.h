/*
 * pk_grbl_internal.h — what the Grbl engine's three files share (private to
 * firmware/pk_grbl*.c): output formatting (pk_grbl_report.c), the
 * non-volatile store layout (pk_grbl_settings.c) and the engine's own state
 * constants (pk_grbl.c). Not a public API.
 */
#ifndef PLOTKIN_PK_GRBL_INTERNAL_H
#define PLOTKIN_PK_GRBL_INTERNAL_H

#include "pk_grbl.h"
#include "pk_rom.h"

/* engine modes (pk_grbl.mode) */
enum {
    MODE_RUN = 0,     /* normal */
    MODE_IDLE_HOLD,   /* '!' while idle, or M0: Hold:0 until '~' */
    MODE_SOFTLIMIT,   /* soft limit hit: stopping, then ALARM:2 */
    MODE_CRITICAL,    /* after ALARM:2: only '?' and reset */
    MODE_SLEEP_REQ,   /* $SLP: stopping */
    MODE_SLEEP,       /* Sleep: only reset */
    MODE_HOMING       /* $H running: only '?', reset (ALARM:6) and the door (ALARM:7) */
};

/* one-line messages (pk_grbl.msg_due) */
enum {
    MSG_NONE = 0, MSG_RESTORING, MSG_NO_SPINDLE_STOP, MSG_DOOR_HOLD, MSG_DOOR_OPEN
};

/* multi-line reports (pk_grbl.report) */
enum { R_NONE = 0, R_SETTINGS, R_OFFSETS, R_INFO, R_GSTATE, R_HELP, R_STARTUP };

/* ---- output (pk_grbl_report.c) ---- */
size_t pk_grbl_out_room(const struct pk_grbl *g);
void pk_grbl_put(struct pk_grbl *g, const char *s, size_t n);
void pk_grbl_puts(struct pk_grbl *g, const char *s);
/** A string in program memory (pk_rom.h); PK_GRBL_PUTS for literals. */
void pk_grbl_puts_rom(struct pk_grbl *g, const char *rom_s);
#define PK_GRBL_PUTS(g, lit) pk_grbl_puts_rom((g), PK_ROM_STR(lit))
void pk_grbl_put_u32(struct pk_grbl *g, uint32_t v);
/** v * 10^-dec printed with at least pdec and at most dec decimals (trailing
 *  zeros beyond pdec dropped), rounded half away when dec > pdec is cut. */
void pk_grbl_put_fixed(struct pk_grbl *g, int32_t v, unsigned dec, unsigned pdec);
/** µm as mm (3 decimals) or, with $13, inches (4 decimals). */
void pk_grbl_put_len(struct pk_grbl *g, int32_t um);
void pk_grbl_put_axes(struct pk_grbl *g, const pk_um_t v[PK_GC_AXES]);
/** µm/min as mm/min (0 decimals) or, with $13, in/min (1 decimal). */
void pk_grbl_put_rate(struct pk_grbl *g, int32_t um_min);
void pk_grbl_status_report(struct pk_grbl *g);
/** Emit report lines while room allows; 1 when the report is complete. */
int pk_grbl_report_step(struct pk_grbl *g);
/** The spindle speed in force for FS: (S * override) clamped to $31..$30, 0 if off. */
/* S (thousandths) after the spindle override, against the range $31..$30:
 * SPAN_ZERO (S <= 0, or 0 after the override), SPAN_MAX (at or above $30,
 * or an empty range), SPAN_MIN (at or below $31), SPAN_INSIDE; *s_out: the
 * value after the override (not set for S <= 0). */
enum { PK_GRBL_SPAN_ZERO = 0, PK_GRBL_SPAN_MAX, PK_GRBL_SPAN_MIN, PK_GRBL_SPAN_INSIDE };
int pk_grbl_spindle_span(const struct pk_grbl *g, int32_t s_milli, uint32_t *s_out);
int32_t pk_grbl_spindle_rpm_milli(const struct pk_grbl *g);

/* ---- state queries (pk_grbl.c) ---- */
int pk_grbl_mstate(const struct pk_grbl *g);

/* ---- non-volatile store (pk_grbl_settings.c) ---- */
/** 0 if the store holds valid settings (copied to g->set). */
int pk_grbl_nvm_load_settings(struct pk_grbl *g);
int pk_grbl_nvm_save_settings(struct pk_grbl *g);
/** Coordinate data idx (0..7): 0, or -1 (unreadable: zeroed, rewritten). */
int pk_grbl_nvm_coord_read(struct pk_grbl *g, unsigned idx, pk_um_t out[PK_GC_AXES]);
int pk_grbl_nvm_coord_write(struct pk_grbl *g, unsigned idx, const pk_um_t in[PK_GC_AXES]);
/** Startup line k (0..1) or build info (k = PK_GRBL_N_STARTUP) into buf
 *  (PK_GRBL_LINE_MAX bytes); returns its length (0: empty or unreadable). */
unsigned pk_grbl_nvm_line_read(struct pk_grbl *g, unsigned k, uint8_t *buf);
int pk_grbl_nvm_line_write(struct pk_grbl *g, unsigned k, const uint8_t *buf, unsigned len);
/** $RST=: 1 settings, 2 coordinate data, 4 startup lines, 8 build info. */
void pk_grbl_nvm_restore(struct pk_grbl *g, unsigned what);

#endif
