/*
 * pk_grbl_settings.c — the Grbl engine's `$N` settings table, their parsing
 * and cross rules (Grbl's settings_store_global_setting), and the layout of
 * the non-volatile store (Grbl's EEPROM scheme: records with a rotating
 * checksum byte; a record that fails its checksum is restored to its
 * default, as Grbl does).
 *
 * Store layout (little-endian, this build's sizes):
 *   0     header: 0xA5, layout version, settings count, axes, line size
 *   5     settings: PK_GRBL_S_COUNT int32, checksum
 *   ..    coordinate data G54..G59, G28, G30: PK_GC_AXES int32 (µm), checksum
 *   ..    startup lines $N0 $N1, build info $I=: length, PK_GRBL_LINE_MAX
 *         bytes, checksum
 * A header that does not match this build restores everything.
 */
#include "pk_grbl_internal.h"
#include "pk_rom.h"

#include <string.h>

#define NVM_MAGIC 0xA5u
#define NVM_VERSION 1u
#define HDR_BYTES 5u
#define OFF_SETTINGS HDR_BYTES
#define SETTINGS_BYTES (4u * PK_GRBL_S_COUNT + 1u)
#define OFF_COORD (OFF_SETTINGS + SETTINGS_BYTES)
#define COORD_BYTES (4u * PK_GC_AXES + 1u)
#define OFF_LINES (OFF_COORD + PK_GC_COORD_COUNT * COORD_BYTES)
#define LINE_BYTES (PK_GRBL_LINE_MAX + 2u)
#define NVM_TOTAL (OFF_LINES + (PK_GRBL_N_STARTUP + 1u) * LINE_BYTES)

/* ---- the table ------------------------------------------------------------- */

#if PK_GC_AXES >= 3
#define AXIS_ROWS(base, num, dec, pdec, dx, dy, dz, mn, mx)                         \
    [base] = { num, dec, pdec, dx, mn, mx }, [base + 1] = { num + 1, dec, pdec, dy, mn, mx }, \
    [base + 2] = { num + 2, dec, pdec, dz, mn, mx }
#else
#define AXIS_ROWS(base, num, dec, pdec, dx, dy, dz, mn, mx)                         \
    [base] = { num, dec, pdec, dx, mn, mx }, [base + 1] = { num + 1, dec, pdec, dy, mn, mx }
#endif

static const struct pk_grbl_setting_def table[PK_GRBL_S_COUNT] PK_ROM = {
    /*                         $   dec pdec default   min        max */
    [PK_GRBL_S_STEP_PULSE_US] = { 0, 0, 0, 10, 1, 1000 },
    [PK_GRBL_S_IDLE_DELAY_MS] = { 1, 0, 0, 25, 0, 255 },
    [PK_GRBL_S_STEP_INVERT] = { 2, 0, 0, 0, 0, 0 },
    [PK_GRBL_S_DIR_INVERT] = { 3, 0, 0, 0, 0, 0 },
    [PK_GRBL_S_ENABLE_INVERT] = { 4, 0, 0, 0, 0, 0 },
    [PK_GRBL_S_LIMIT_INVERT] = { 5, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_PROBE_INVERT] = { 6, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_REPORT_MASK] = { 10, 0, 0, 1, 0, 3 },
    [PK_GRBL_S_JUNCTION_MM] = { 11, 3, 3, 10, 0, 10000 },
    [PK_GRBL_S_TOLERANCE_MM] = { 12, 3, 3, 20, 1, 10000 },
    [PK_GRBL_S_REPORT_INCHES] = { 13, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_SOFT_LIMITS] = { 20, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_HARD_LIMITS] = { 21, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_HOMING] = { 22, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_HOMING_DIR] = { 23, 0, 0, 0, 0, (1 << PK_GC_AXES) - 1 },
    [PK_GRBL_S_HOMING_FEED] = { 24, 3, 3, 25000, 1000, 60000000 },
    [PK_GRBL_S_HOMING_SEEK] = { 25, 3, 3, 500000, 1000, 60000000 },
    [PK_GRBL_S_HOMING_DEBOUNCE] = { 26, 0, 0, 250, 0, 65535 },
    [PK_GRBL_S_HOMING_PULLOFF] = { 27, 3, 3, 1000, 0, 100000 },
    [PK_GRBL_S_SPINDLE_MAX] = { 30, 3, 0, 1000000, 0, 1000000000 },
    [PK_GRBL_S_SPINDLE_MIN] = { 31, 3, 0, 0, 0, 1000000000 },
    [PK_GRBL_S_LASER] = { 32, 0, 0, 0, 0, 1 },
    AXIS_ROWS(PK_GRBL_S_STEPS_X, 100, 4, 3, 800000, 800000, 800000, 10000, 100000000),
    AXIS_ROWS(PK_GRBL_S_RATE_X, 110, 3, 3, 6000000, 6000000, 1500000, 1000, 60000000),
    AXIS_ROWS(PK_GRBL_S_ACCEL_X, 120, 3, 3, 1000000, 1000000, 500000, 1000, 100000000),
    AXIS_ROWS(PK_GRBL_S_TRAVEL_X, 130, 3, 3, 300000, 300000, 50000, 1000, 2000000),
    [PK_GRBL_S_SMOOTH_MODE] = { 200, 0, 0, 2, 0, 2 },
    [PK_GRBL_S_SCHEME] = { 201, 0, 0, 0, 0, 1 },
    [PK_GRBL_S_DEGREE] = { 202, 0, 0, 3, 1, 7 },
    [PK_GRBL_S_DEPTH] = { 203, 0, 0, 3, 0, 8 },
    [PK_GRBL_S_CORNER_DEG] = { 204, 0, 0, 60, 1, 180 },
    [PK_GRBL_S_PEN_SETTLE_MS] = { 205, 0, 0, 50, 0, 60000 },
    [PK_GRBL_S_DIR_SETUP_US] = { 206, 0, 0, 1, 0, 1000 },
    [PK_GRBL_S_LOOKAHEAD_MS] = { 207, 0, 0, 0, 0, 60000 },
};

/* The table lives in program memory (pk_rom.h): entries are copied out. */
static struct pk_grbl_setting_def def_of(int idx)
{
    struct pk_grbl_setting_def d;
    pk_rom_copy(&d, &table[idx], sizeof d);
    return d;
}

int pk_grbl_setting_def(int idx, struct pk_grbl_setting_def *out)
{
    if (idx < 0 || idx >= PK_GRBL_S_COUNT)
        return -1;
    *out = def_of(idx);
    return 0;
}

int pk_grbl_setting_index(uint32_t num)
{
    for (int i = 0; i < PK_GRBL_S_COUNT; i++)
        if (pk_rom_u8(&table[i].num) == num)
            return i;
    return -1;
}

void pk_grbl_settings_default(struct pk_grbl_settings *s)
{
    for (int i = 0; i < PK_GRBL_S_COUNT; i++)
        s->v[i] = def_of(i).def;
}

int32_t pk_grbl_setting_scaled(const struct pk_grbl_settings *s, int idx, unsigned k)
{
    int32_t out = 0;
    (void)pk_gcode_scaled(s->v[idx], pk_rom_u8(&table[idx].dec), (uint8_t)k, &out);
    return out;
}

int pk_grbl_setting_parse(const uint8_t *s, size_t n, int *idx_out, int32_t *val_out)
{
    size_t eq = 0;
    while (eq < n && s[eq] != '=')
        eq++;
    int32_t pm, vm;
    uint8_t pd, vd;
    /* Grbl: the parameter number, '=', the value, nothing after it */
    int rc = pk_gcode_parse_number(s, eq, &pm, &pd);
    if (rc == PK_GC_E_EXPECTED_LETTER)
        return 3;
    if (rc != PK_GC_OK)
        return PK_GC_E_BAD_NUMBER;
    if (eq == n)
        return 3;
    rc = pk_gcode_parse_number(s + eq + 1, n - eq - 1, &vm, &vd);
    if (rc == PK_GC_E_EXPECTED_LETTER)
        return 3;
    if (rc != PK_GC_OK)
        return rc;
    uint32_t num = pm < 0 ? 0xffffffffu : (uint32_t)pm;
    for (uint8_t d = pd; d > 0; d--)
        num /= 10u; /* Grbl truncates the parameter */
    if (pm < 0 || num > 255u)
        return 3;
    if (vm < 0)
        return PK_GC_E_NEGATIVE;
    int idx = pk_grbl_setting_index(num);
    if (idx < 0)
        return 3;
    const struct pk_grbl_setting_def dd = def_of(idx), *d = &dd;
    int32_t v;
    if (d->dec == 0) {
        int32_t t = vm;
        for (uint8_t k = vd; k > 0; k--)
            t /= 10; /* Grbl: int_value = trunc(value) */
        v = t;
    } else if (pk_gcode_scaled(vm, vd, d->dec, &v) != PK_GC_OK) {
        return 3;
    }
    if (idx == PK_GRBL_S_STEP_PULSE_US && v < 1)
        return 6; /* Grbl: below 3 µs (its ISR); plotkin times pulses in ticks */
    if (v < d->min || v > d->max)
        return 3;
    *idx_out = idx;
    *val_out = v;
    return 0;
}

int pk_grbl_setting_store(struct pk_grbl_settings *s, int idx, int32_t val)
{
    if (idx < 0 || idx >= PK_GRBL_S_COUNT)
        return 3;
    if (idx == PK_GRBL_S_SOFT_LIMITS && val && !s->v[PK_GRBL_S_HOMING])
        return 10;
    s->v[idx] = val;
    if (idx == PK_GRBL_S_HOMING && !val)
        s->v[PK_GRBL_S_SOFT_LIMITS] = 0;
    return 0;
}

int pk_grbl_settings_apply(struct pk_grbl_settings *s, const char *a)
{
    if (*a == '$')
        a++;
    size_t n = strlen(a);
    int idx;
    int32_t v;
    int rc = pk_grbl_setting_parse((const uint8_t *)a, n, &idx, &v);
    return rc != 0 ? rc : pk_grbl_setting_store(s, idx, v);
}

/* ---- the store ---------------------------------------------------------------- */

uint32_t pk_grbl_nvm_bytes(void) { return NVM_TOTAL; }

_Static_assert(NVM_TOTAL == PK_GRBL_NVM_BYTES, "PK_GRBL_NVM_BYTES matches the layout");

static uint8_t sum_step(uint8_t c, uint8_t b) { return (uint8_t)(((c << 1) | (c >> 7)) + b); }

static int have_nvm(const struct pk_grbl *g) { return g->nvm.size >= NVM_TOTAL && g->nvm.read; }

static int rd(struct pk_grbl *g, uint32_t off, uint8_t *b, size_t n)
{
    return have_nvm(g) && g->nvm.read(g->nvm.ctx, off, b, n) == 0 ? 0 : -1;
}

static int wr(struct pk_grbl *g, uint32_t off, const uint8_t *b, size_t n)
{
    return have_nvm(g) && g->nvm.write && g->nvm.write(g->nvm.ctx, off, b, n) == 0 ? 0 : -1;
}

/* A record: n payload bytes then the checksum. */
static int rec_read(struct pk_grbl *g, uint32_t off, uint8_t *b, size_t n)
{
    uint8_t c;
    if (rd(g, off, b, n) != 0 || rd(g, off + (uint32_t)n, &c, 1) != 0)
        return -1;
    uint8_t s = 0;
    for (size_t i = 0; i < n; i++)
        s = sum_step(s, b[i]);
    return s == c ? 0 : -1;
}

static int rec_write(struct pk_grbl *g, uint32_t off, const uint8_t *b, size_t n)
{
    uint8_t s = 0;
    for (size_t i = 0; i < n; i++)
        s = sum_step(s, b[i]);
    if (wr(g, off, b, n) != 0)
        return -1;
    return wr(g, off + (uint32_t)n, &s, 1);
}

static void put32(uint8_t *b, int32_t v)
{
    uint32_t u = (uint32_t)v;
    for (int i = 0; i < 4; i++)
        b[i] = (uint8_t)(u >> (8 * i));
}

static int32_t get32(const uint8_t *b)
{
    uint32_t u = 0;
    for (int i = 0; i < 4; i++)
        u |= (uint32_t)b[i] << (8 * i);
    return (int32_t)u;
}

static const uint8_t header[HDR_BYTES] = { NVM_MAGIC, NVM_VERSION, PK_GRBL_S_COUNT, PK_GC_AXES,
                                           PK_GRBL_LINE_MAX };

int pk_grbl_nvm_load_settings(struct pk_grbl *g)
{
    uint8_t h[HDR_BYTES];
    if (rd(g, 0, h, sizeof h) != 0 || memcmp(h, header, sizeof h) != 0)
        return -1;
    uint8_t b[4u * PK_GRBL_S_COUNT];
    if (rec_read(g, OFF_SETTINGS, b, sizeof b) != 0)
        return -1;
    struct pk_grbl_settings s;
    for (int i = 0; i < PK_GRBL_S_COUNT; i++) {
        s.v[i] = get32(b + 4 * i);
        struct pk_grbl_setting_def d = def_of(i);
        if (s.v[i] < d.min || s.v[i] > d.max)
            return -1;
    }
    g->set = s;
    return 0;
}

/* The whole record in one write (a file store syncs once per write). */
int pk_grbl_nvm_save_settings(struct pk_grbl *g)
{
    if (!have_nvm(g))
        return 0;
    uint8_t b[4u * PK_GRBL_S_COUNT + 1u], sum = 0;
    for (int i = 0; i < PK_GRBL_S_COUNT; i++)
        put32(b + 4 * i, g->set.v[i]);
    for (size_t i = 0; i + 1u < sizeof b; i++)
        sum = sum_step(sum, b[i]);
    b[sizeof b - 1u] = sum;
    if (wr(g, 0, header, sizeof header) != 0)
        return -1;
    return wr(g, OFF_SETTINGS, b, sizeof b);
}

int pk_grbl_nvm_coord_write(struct pk_grbl *g, unsigned idx, const pk_um_t in[PK_GC_AXES])
{
    if (!have_nvm(g))
        return -1;
    uint8_t b[4 * PK_GC_AXES];
    for (unsigned a = 0; a < PK_GC_AXES; a++)
        put32(b + 4 * a, in[a]);
    return rec_write(g, OFF_COORD + idx * COORD_BYTES, b, sizeof b);
}

int pk_grbl_nvm_coord_read(struct pk_grbl *g, unsigned idx, pk_um_t out[PK_GC_AXES])
{
    uint8_t b[4 * PK_GC_AXES];
    if (!have_nvm(g)) {
        /* no store: G54 is the machine frame; nothing else exists (error 7) */
        memset(out, 0, sizeof(pk_um_t) * PK_GC_AXES);
        return idx == 0 ? 0 : -1;
    }
    int ok = idx < PK_GC_COORD_COUNT && rec_read(g, OFF_COORD + idx * COORD_BYTES, b, sizeof b) == 0;
    for (unsigned a = 0; a < PK_GC_AXES; a++) {
        out[a] = ok ? get32(b + 4 * a) : 0;
        if (out[a] < -PK_UM_MAX || out[a] > PK_UM_MAX)
            ok = 0;
    }
    if (ok)
        return 0;
    /* Grbl: an unreadable record is zeroed and rewritten (and reported) */
    memset(out, 0, sizeof(pk_um_t) * PK_GC_AXES);
    if (idx < PK_GC_COORD_COUNT)
        (void)pk_grbl_nvm_coord_write(g, idx, out);
    return -1;
}

unsigned pk_grbl_nvm_line_read(struct pk_grbl *g, unsigned k, uint8_t *buf)
{
    uint8_t tmp[PK_GRBL_LINE_MAX + 1u];
    if (rec_read(g, OFF_LINES + k * LINE_BYTES, tmp, sizeof tmp) != 0)
        return 0;
    unsigned n = tmp[0];
    if (n > PK_GRBL_LINE_MAX)
        return 0;
    memcpy(buf, tmp + 1, n);
    return n;
}

int pk_grbl_nvm_line_write(struct pk_grbl *g, unsigned k, const uint8_t *buf, unsigned len)
{
    uint8_t tmp[PK_GRBL_LINE_MAX + 1u];
    if (len > PK_GRBL_LINE_MAX)
        return -1;
    memset(tmp, 0, sizeof tmp);
    tmp[0] = (uint8_t)len;
    if (len)
        memcpy(tmp + 1, buf, len);
    return rec_write(g, OFF_LINES + k * LINE_BYTES, tmp, sizeof tmp);
}

void pk_grbl_nvm_restore(struct pk_grbl *g, unsigned what)
{
    if (what & 1u) {
        pk_grbl_settings_default(&g->set);
        (void)pk_grbl_nvm_save_settings(g);
    }
    if (what & 2u) {
        const pk_um_t zero[PK_GC_AXES] = { 0 }; /* a local: a zeroed const lands in .bss on AVR */
        for (unsigned i = 0; i < PK_GC_COORD_COUNT; i++)
            (void)pk_grbl_nvm_coord_write(g, i, zero);
    }
    for (unsigned k = 0; k <= PK_GRBL_N_STARTUP; k++)
        if (what & (k < PK_GRBL_N_STARTUP ? 4u : 8u))
            (void)pk_grbl_nvm_line_write(g, k, NULL, 0);
}

/* ---- RAM store ------------------------------------------------------------------ */

static int ram_read(void *ctx, uint32_t off, uint8_t *buf, size_t len)
{
    struct pk_grbl_ram_nvm *r = ctx;
    if (off > r->size || len > r->size - off)
        return -1;
    memcpy(buf, r->buf + off, len);
    return 0;
}

static int ram_write(void *ctx, uint32_t off, const uint8_t *buf, size_t len)
{
    struct pk_grbl_ram_nvm *r = ctx;
    if (off > r->size || len > r->size - off)
        return -1;
    if (len)
        memcpy(r->buf + off, buf, len);
    return 0;
}

void pk_grbl_ram_nvm(struct pk_grbl_ram_nvm *r, struct pk_grbl_nvm *nvm)
{
    nvm->read = ram_read;
    nvm->write = ram_write;
    nvm->ctx = r;
    nvm->size = r->size;
}
