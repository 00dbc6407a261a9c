/*
 * sim_job.c — G-code / polyline programs streamed through the firmware's
 * Grbl engine (see sim_job.h).
 */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "sim_job.h"

static int failf(char *err, size_t errlen, const char *fmt, ...);

/* ---- settings: Grbl's `$N` table of the firmware (pk_grbl.h) ------------ */

static double pow10d(unsigned d)
{
    double p = 1.0;
    while (d--)
        p *= 10.0;
    return p;
}

/* The double member of c that mirrors setting idx, or NULL. */
static double *cfg_double(struct pk_sim_cfg *c, int idx)
{
    switch (idx) {
    case PK_GRBL_S_STEP_PULSE_US: return &c->step_pulse_us;
    case PK_GRBL_S_JUNCTION_MM: return &c->junction_dev;
    case PK_GRBL_S_TOLERANCE_MM: return &c->tolerance;
    case PK_GRBL_S_DIR_SETUP_US: return &c->dir_setup_us;
    default: break;
    }
    if (idx >= PK_GRBL_S_STEPS_X && idx < PK_GRBL_S_STEPS_X + PK_GC_AXES)
        return &c->steps_per_mm[idx - PK_GRBL_S_STEPS_X];
    if (idx >= PK_GRBL_S_RATE_X && idx < PK_GRBL_S_RATE_X + PK_GC_AXES)
        return &c->max_rate[idx - PK_GRBL_S_RATE_X];
    if (idx >= PK_GRBL_S_ACCEL_X && idx < PK_GRBL_S_ACCEL_X + PK_GC_AXES)
        return &c->accel[idx - PK_GRBL_S_ACCEL_X];
    if (idx >= PK_GRBL_S_TRAVEL_X && idx < PK_GRBL_S_TRAVEL_X + PK_GC_AXES)
        return &c->travel[idx - PK_GRBL_S_TRAVEL_X];
    return NULL;
}

static unsigned *cfg_uint(struct pk_sim_cfg *c, int idx)
{
    switch (idx) {
    case PK_GRBL_S_SMOOTH_MODE: return &c->smooth_mode;
    case PK_GRBL_S_SCHEME: return &c->scheme;
    case PK_GRBL_S_DEGREE: return &c->degree;
    case PK_GRBL_S_DEPTH: return &c->depth;
    case PK_GRBL_S_CORNER_DEG: return &c->sharp_deg;
    case PK_GRBL_S_PEN_SETTLE_MS: return &c->pen_settle_ms;
    case PK_GRBL_S_LASER: return &c->laser_mode;
    default: return NULL;
    }
}

void pk_sim_cfg_from_grbl(struct pk_sim_cfg *c, const struct pk_grbl_settings *s)
{
    c->set = *s;
    for (int i = 0; i < PK_GRBL_S_COUNT; i++) {
        struct pk_grbl_setting_def dd, *d = &dd;
        (void)pk_grbl_setting_def(i, &dd);
        double *dv = cfg_double(c, i);
        unsigned *uv = cfg_uint(c, i);
        if (dv != NULL)
            *dv = (double)s->v[i] / pow10d(d->dec);
        else if (uv != NULL)
            *uv = (unsigned)(s->v[i] / (int32_t)pow10d(d->dec));
    }
}

int pk_sim_cfg_to_grbl(const struct pk_sim_cfg *cc, struct pk_grbl_settings *s, char *err,
                       size_t errlen)
{
    struct pk_sim_cfg *c = (struct pk_sim_cfg *)cc; /* only read through the accessors */
    *s = c->set;
    for (int i = 0; i < PK_GRBL_S_COUNT; i++) {
        struct pk_grbl_setting_def dd, *d = &dd;
        (void)pk_grbl_setting_def(i, &dd);
        const double *dv = cfg_double(c, i);
        const unsigned *uv = cfg_uint(c, i);
        if (dv == NULL && uv == NULL)
            continue;
        double v = dv != NULL ? *dv * pow10d(d->dec) : (double)*uv * pow10d(d->dec);
        if (!(v >= (double)d->min - 0.5 && v <= (double)d->max + 0.5))
            return failf(err, errlen, "$%u out of range (%g..%g)", (unsigned)d->num,
                         (double)d->min / pow10d(d->dec), (double)d->max / pow10d(d->dec));
        s->v[i] = (int32_t)llround(v);
    }
    if (s->v[PK_GRBL_S_SOFT_LIMITS] && !s->v[PK_GRBL_S_HOMING])
        return failf(err, errlen, "$20=1 needs $22=1 (error:10)");
    return 0;
}

void pk_sim_cfg_default(struct pk_sim_cfg *c)
{
    struct pk_grbl_settings s;
    memset(c, 0, sizeof *c);
    pk_grbl_settings_default(&s);
    pk_sim_cfg_from_grbl(c, &s);
    c->axes = PK_AXES;
    c->polyline_feed = 3000.0;
    c->pen_z_on = 0;
    c->tick_hz = 1000000u;
}

void pk_sim_cfg_pen(const struct pk_sim_cfg *c, struct pk_pen_cfg *out)
{
    out->mode = c->laser_mode ? PK_PEN_LASER : c->pen_z_on ? PK_PEN_Z : PK_PEN_TOOL;
    out->z_down_um = c->pen_z_mm * 1000.0;
}

/* $208 (pen-down height): how the simulator reads a drawing; not a firmware
 * setting. Returns 1 if handled (*rc: 0 or the failure). */
static int sim_only_setting(struct pk_sim_cfg *c, unsigned long num, const char *val, char *err,
                            size_t errlen, unsigned lineno, int *rc);

static int failf(char *err, size_t errlen, const char *fmt, ...)
{
    if (err != NULL && errlen > 0u) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -1;
}

static int sim_only_setting(struct pk_sim_cfg *c, unsigned long num, const char *val, char *err,
                            size_t errlen, unsigned lineno, int *rc)
{
    if (num != 208u)
        return 0;
    char *end;
    double v = strtod(val, &end);
    if (end == val || *end != '\0' || !isfinite(v)) {
        *rc = failf(err, errlen, "line %u: $%lu: bad number", lineno, num);
        return 1;
    }
    c->pen_z_on = 1;
    c->pen_z_mm = v;
    *rc = 0;
    return 1;
}

static const char *grbl_error_text(int code)
{
    switch (code) {
    case 2: return "bad number";
    case 3: return "not a setting plotkin has, or out of its range";
    case 4: return "negative value";
    case 6: return "step pulse below 3 us";
    case 10: return "soft limits need homing enabled ($22=1)";
    default: return "refused";
    }
}

/* Settings the firmware stores and reports but that change nothing in a
 * simulated run (the inputs phase, drivers, reports). */
static const char *stored_only(int idx)
{
    switch (idx) {
    case PK_GRBL_S_IDLE_DELAY_MS: return "stored: the drivers stay enabled";
    case PK_GRBL_S_LIMIT_INVERT: case PK_GRBL_S_PROBE_INVERT: case PK_GRBL_S_HARD_LIMITS:
    case PK_GRBL_S_HOMING_DIR: case PK_GRBL_S_HOMING_FEED: case PK_GRBL_S_HOMING_SEEK:
    case PK_GRBL_S_HOMING_DEBOUNCE: case PK_GRBL_S_HOMING_PULLOFF:
        return "acts only with --switch/--input inputs ($21: use --hard-limits)";
    case PK_GRBL_S_REPORT_MASK: case PK_GRBL_S_REPORT_INCHES:
        return "status reports only";
    default: return NULL;
    }
}

int pk_sim_cfg_parse(struct pk_sim_cfg *c, const char *text, char *err, size_t errlen, FILE *warn)
{
    unsigned lineno = 0;
    const char *p = text;
    while (*p) {
        char buf[128];
        size_t n = strcspn(p, "\r\n");
        lineno++;
        if (n >= sizeof buf)
            return failf(err, errlen, "line %u: too long", lineno);
        memcpy(buf, p, n);
        buf[n] = '\0';
        p += n;
        if (*p == '\r')
            p++;
        if (*p == '\n')
            p++;
        char *s = buf;
        char *cm = strpbrk(s, ";#(");
        if (cm)
            *cm = '\0';
        /* Grbl's line assembly: blanks out, letters up */
        size_t k = 0;
        for (char *q = s; *q; q++)
            if (!isspace((unsigned char)*q))
                s[k++] = (char)toupper((unsigned char)*q);
        s[k] = '\0';
        if (k == 0)
            continue;
        if (*s != '$' || !isdigit((unsigned char)s[1]))
            return failf(err, errlen, "line %u: expected $N=value", lineno);
        {
            char *eq = NULL;
            unsigned long num = strtoul(s + 1, &eq, 10);
            int src;
            if (eq != NULL && *eq == '=' && sim_only_setting(c, num, eq + 1, err, errlen, lineno, &src)) {
                if (src != 0)
                    return src;
                continue;
            }
        }
        /* The firmware's own parser, table and rules: the same numbers,
         * ranges and number syntax as `$N=value` sent to the Grbl engine. */
        struct pk_grbl_settings set;
        if (pk_sim_cfg_to_grbl(c, &set, NULL, 0) != 0)
            set = c->set;
        int rc = pk_grbl_settings_apply(&set, s);
        if (rc != 0) {
            unsigned long num = strtoul(s + 1, NULL, 10);
            int idx = pk_grbl_setting_index((uint32_t)num);
            struct pk_grbl_setting_def dd, *d = pk_grbl_setting_def(idx, &dd) == 0 ? &dd : NULL;
            if (d == NULL)
                return failf(err, errlen, "line %u: unknown setting $%lu (error:%d)", lineno, num, rc);
            return failf(err, errlen, "line %u: $%lu: error:%d (%s; range %g..%g%s)", lineno, num, rc,
                         grbl_error_text(rc), (double)d->min / pow10d(d->dec),
                         (double)d->max / pow10d(d->dec), d->dec == 0 ? ", whole numbers" : "");
        }
        pk_sim_cfg_from_grbl(c, &set);
        int idx = pk_grbl_setting_index((uint32_t)strtoul(s + 1, NULL, 10));
        if (warn && stored_only(idx))
            fprintf(warn, "plotkin sim: note: $%u has no effect in plotkin sim (%s)\n",
                    (unsigned)strtoul(s + 1, NULL, 10), stored_only(idx));
    }
    return 0;
}

int pk_sim_cfg_motion(const struct pk_sim_cfg *c, struct pk_motion_cfg *o, char *err, size_t errlen)
{
    struct pk_grbl_settings set;
    memset(o, 0, sizeof *o);
    if (c->axes < 2u || c->axes > PK_AXES)
        return failf(err, errlen, "axes must be 2..%d", PK_AXES);
    if (pk_sim_cfg_to_grbl(c, &set, err, errlen) != 0)
        return -1;
    /* The firmware's conversion, as the Grbl engine configures the machine. */
    pk_grbl_motion_cfg(&set, c->tick_hz, o);
    o->axes = (uint8_t)c->axes;
    return 0;
}

/* ---- polyline files ------------------------------------------------------ */

/* One polyline line: 1 with x, y if it is "x y" (or "x, y"), 0 if blank or a
 * comment, -1 otherwise. */
static int poly_line(const char *line, size_t n, double *x, double *y)
{
    char b[256];
    if (n >= sizeof b)
        return -1;
    memcpy(b, line, n);
    b[n] = '\0';
    char *h = strchr(b, '#');
    if (h)
        *h = '\0';
    char *s = b;
    while (isspace((unsigned char)*s))
        s++;
    if (*s == '\0')
        return 0;
    char *e1, *e2;
    *x = strtod(s, &e1);
    if (e1 == s)
        return -1;
    *y = strtod(e1, &e2);
    if (e2 == e1)
        return -1;
    while (isspace((unsigned char)*e2) || *e2 == ',')
        e2++;
    return *e2 == '\0' && isfinite(*x) && isfinite(*y) ? 1 : -1;
}

struct sbuf { char *p; size_t n, cap; int oom; };

static void sb_printf(struct sbuf *b, const char *fmt, ...)
{
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        int k = vsnprintf(b->p ? b->p + b->n : NULL, b->p ? b->cap - b->n : 0, fmt, ap);
        va_end(ap);
        if (k < 0) {
            b->oom = 1;
            return;
        }
        if (b->p && b->n + (size_t)k < b->cap) {
            b->n += (size_t)k;
            return;
        }
        size_t cap = (b->cap ? b->cap * 2u : 4096u) + (size_t)k;
        char *q = realloc(b->p, cap);
        if (q == NULL) {
            b->oom = 1;
            return;
        }
        b->p = q;
        b->cap = cap;
    }
}

char *pk_sim_polyline_to_gcode(const char *text, double feed, int *is_polyline)
{
    struct sbuf b = { 0 };
    int in_stroke = 0, any = 0;
    *is_polyline = 0;
    sb_printf(&b, "G21 G90\n");
    for (const char *p = text; *p;) {
        size_t n = strcspn(p, "\n");
        double x, y;
        int r = poly_line(p, n, &x, &y);
        p += n + (p[n] == '\n');
        if (r < 0) {
            free(b.p);
            return NULL;
        }
        if (r == 0) {
            if (in_stroke)
                sb_printf(&b, "M5\n");
            in_stroke = 0;
            continue;
        }
        any = 1;
        if (!in_stroke) {
            sb_printf(&b, "G0 X%.3f Y%.3f\nM3\n", x, y);
            in_stroke = 1;
        } else {
            sb_printf(&b, "G1 X%.3f Y%.3f F%.0f\n", x, y, feed);
        }
    }
    if (in_stroke)
        sb_printf(&b, "M5\n");
    sb_printf(&b, "M2\n");
    if (b.oom || !any) {
        free(b.p);
        return NULL;
    }
    *is_polyline = 1;
    return b.p;
}

/* ---- the program source: text or a file, streamed ---------------------------- */

/* Next raw byte of the source, or -1 at its end. */
static int src_byte(struct pk_sim_job *j)
{
    if (j->pos >= j->len)
        return -1;
    j->bytes_in++;
    return (unsigned char)j->text[j->pos++];
}

static void fifo_push(struct pk_sim_job *j, unsigned line)
{
    /* the engine numbers the lines it receives (1, 2, ...): remember the
     * source line of the latest ones, for the observer */
    j->lmap[j->eng_lines % (sizeof j->lmap / sizeof j->lmap[0])] = line;
    j->eng_lines++;
    if (j->fifo_n < sizeof j->fifo / sizeof j->fifo[0]) {
        j->fifo[(j->fifo_head + j->fifo_n) % (sizeof j->fifo / sizeof j->fifo[0])] = line;
        j->fifo_n++;
    }
}

static unsigned fifo_pop(struct pk_sim_job *j)
{
    if (j->fifo_n == 0)
        return 0;
    unsigned v = j->fifo[j->fifo_head];
    j->fifo_head = (j->fifo_head + 1u) % (sizeof j->fifo / sizeof j->fifo[0]);
    j->fifo_n--;
    return v;
}

/* Queue generated engine lines (s holds one or more lines separated by
 * '\n', without the last terminator) for source line `line`. */
static void give(struct pk_sim_job *j, const char *s, size_t n, unsigned line)
{
    if (j->lbuf_i >= j->lbuf_n)
        j->lbuf_i = j->lbuf_n = 0;
    if (n > sizeof j->lbuf - 1u - j->lbuf_n)
        n = sizeof j->lbuf - 1u - j->lbuf_n;
    memcpy(j->lbuf + j->lbuf_n, s, n);
    j->lbuf_n += n;
    j->lbuf[j->lbuf_n++] = '\n';
    fifo_push(j, line);
    for (size_t i = 0; i < n; i++)
        if (s[i] == '\n')
            fifo_push(j, line);
}

/* A polyline file: the next source line converted into lbuf; 0 at the end. */
static int next_poly_line(struct pk_sim_job *j)
{
    while (!j->tail_done) {
        char raw[256];
        size_t n = 0;
        int c, got = 0, over = 0;
        while ((c = src_byte(j)) >= 0) {
            got = 1;
            if (c == '\n')
                break;
            if (n < sizeof raw)
                raw[n++] = (char)c;
            else
                over = 1;
        }
        if (!got) {
            j->eof = 1;
            j->tail_done = 1;
            give(j, j->in_stroke ? "M5\nM2" : "M2", j->in_stroke ? 5u : 2u, j->src_line);
            j->in_stroke = 0;
            return 1;
        }
        j->src_line++;
        j->lines++;
        double x, y;
        int r = over ? -1 : poly_line(raw, n, &x, &y);
        char g[160];
        int k;
        if (r <= 0) { /* blank (a detected polyline has no bad lines) */
            if (!j->in_stroke)
                continue;
            j->in_stroke = 0;
            give(j, "M5", 2, j->src_line);
            return 1;
        }
        if (!j->in_stroke) {
            k = snprintf(g, sizeof g, "G0 X%.3f Y%.3f\nM3", x, y);
            j->in_stroke = 1;
        } else {
            k = snprintf(g, sizeof g, "G1 X%.3f Y%.3f F%.0f", x, y, j->cfg->polyline_feed);
        }
        give(j, g, (size_t)k, j->src_line);
        return 1;
    }
    return 0;
}

/* ---- the engine's stream ----------------------------------------------------- */

/* The engine asks for bytes: queued generated lines first, then the program,
 * streamed as a sender does (the engine assembles lines itself), minus what a
 * sender must not send as text: bytes >= 0x80 and the realtime characters.
 * Line ends are counted as the engine counts them (LF, CR, CR LF), so the
 * k-th answer belongs to the k-th line. */
static int job_read(void *ctx, uint8_t *buf, size_t len)
{
    struct pk_sim_job *j = ctx;
    if (len == 0)
        return 0;
    /* a new line only while the programmed path's observer has room (the
     * engine reads one byte at a time; a line ends at LF or CR) */
    int line_start = !j->midline && (j->lbuf_i >= j->lbuf_n || j->lbuf_i == 0 ||
                                     j->lbuf[j->lbuf_i - 1] == '\n');
    if (line_start && j->obs.room != NULL && j->obs.room(j->obs.arg) == 0u)
        return 0;
    if (j->lbuf_i < j->lbuf_n)
        len = 1; /* generated lines go out a byte at a time too */
    if (j->lbuf_i >= j->lbuf_n && !j->input_done && j->polyline)
        (void)next_poly_line(j);
    if (j->lbuf_i < j->lbuf_n) {
        size_t k = j->lbuf_n - j->lbuf_i;
        if (k > len)
            k = len;
        memcpy(buf, j->lbuf + j->lbuf_i, k);
        j->lbuf_i += k;
        return (int)k;
    }
    if (j->input_done || j->polyline || j->eof)
        return 0;
    for (;;) {
        int c = src_byte(j);
        if (c < 0) {
            j->eof = 1;
            if (!j->midline)
                return 0;
            c = '\n'; /* the last line had no line end */
        }
        if (c >= 0x80 || c == '?' || c == '!' || c == '~' || c == 0x18) {
            j->rt_skipped++;
            continue;
        }
        if (c == '\n' && j->last_cr) {
            j->last_cr = 0; /* CR LF: the engine ends the line at the CR */
        } else if (c == '\n' || c == '\r') {
            j->last_cr = c == '\r';
            j->src_line++;
            j->lines++;
            j->midline = 0;
            fifo_push(j, j->src_line);
        } else {
            j->last_cr = 0;
            j->midline = 1;
        }
        buf[0] = (uint8_t)c;
        return 1;
    }
}

/* The number after a "error:"/"ALARM:" prefix of a (n bytes, not NUL-terminated). */
static int code_after(const char *a, size_t n)
{
    int v = 0;
    for (size_t i = 6; i < n && a[i] >= '0' && a[i] <= '9' && v < 1000; i++)
        v = v * 10 + (a[i] - '0');
    return v;
}

static void answer_line(struct pk_sim_job *j, const char *a, size_t n)
{
    if (n == 2 && !memcmp(a, "ok", 2)) {
        (void)fifo_pop(j);
    } else if (n > 6 && !memcmp(a, "error:", 6)) {
        pk_sim_job_note_error(j, fifo_pop(j), code_after(a, n));
    } else if (n > 6 && !memcmp(a, "ALARM:", 6)) {
        if (j->alarms == 0u) {
            j->alarm = -code_after(a, n);
            snprintf(j->alarm_text, sizeof j->alarm_text, "Grbl ALARM:%d", code_after(a, n));
        }
        j->alarms++;
    } else if (n == 13 && !memcmp(a, "[MSG:Pgm End]", 13)) {
        j->input_done = 1; /* M2/M30: the rest of the file is not run */
    }
}

static int job_write(void *ctx, const uint8_t *buf, size_t len)
{
    struct pk_sim_job *j = ctx;
    for (size_t i = 0; i < len; i++) {
        char c = (char)buf[i];
        if (c == '\r' || c == '\n') {
            if (j->ans_n)
                answer_line(j, j->ans, j->ans_n < sizeof j->ans ? j->ans_n : sizeof j->ans);
            j->ans_n = 0;
        } else if (j->ans_n < sizeof j->ans) {
            j->ans[j->ans_n++] = c;
        } else {
            j->ans_n = sizeof j->ans + 1u; /* too long: not an answer */
        }
    }
    return (int)len;
}

/* ---- the job's machine ops: the adapter, recording the commanded path ----------- */

/* A move the machine took: the job's idea of where the tool is. */
static void took_move(struct pk_sim_job *j, const pk_um_t to[PK_AXES])
{
    memcpy(j->cur, to, sizeof j->cur);
    j->move_requests++;
}

static struct pk_sim_job *job_of(void *ctx)
{
    return (struct pk_sim_job *)((char *)ctx - offsetof(struct pk_sim_job, gm));
}

static int jm_move(void *ctx, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, int rapid)
{
    struct pk_grbl_machine_ops o;
    pk_grbl_motion_ops(&o);
    int rc = o.move(ctx, t, feed, rapid);
    if (rc == PK_GRBL_M_OK) {
        pk_um_t p[PK_AXES];
        memset(p, 0, sizeof p);
        memcpy(p, t, sizeof(pk_um_t) * (PK_AXES < PK_GC_AXES ? PK_AXES : PK_GC_AXES));
        took_move(job_of(ctx), p);
    }
    return rc;
}

static int jm_move_chord(void *ctx, const pk_um_t t[PK_GC_AXES], pk_gc_umpm_t feed, pk_um_t err)
{
    struct pk_grbl_machine_ops o;
    pk_grbl_motion_ops(&o);
    int rc = o.move_chord(ctx, t, feed, err);
    if (rc == PK_GRBL_M_OK) {
        pk_um_t p[PK_AXES];
        memset(p, 0, sizeof p);
        memcpy(p, t, sizeof(pk_um_t) * (PK_AXES < PK_GC_AXES ? PK_AXES : PK_GC_AXES));
        took_move(job_of(ctx), p);
    }
    return rc;
}

static int jm_pen(void *ctx, int down)
{
    struct pk_grbl_machine_ops o;
    pk_grbl_motion_ops(&o);
    int rc = o.pen(ctx, down);
    if (rc == PK_GRBL_M_OK)
        job_of(ctx)->pen = down != 0;
    return rc;
}

static int jm_smoothing(void *ctx, int exact, pk_um_t tol)
{
    if (job_of(ctx)->cfg->force_smoothing)
        return PK_GRBL_M_OK; /* --exact / --tolerance: the settings' policy stays */
    struct pk_grbl_machine_ops o;
    pk_grbl_motion_ops(&o);
    return o.smoothing(ctx, exact, tol);
}

static int jm_reset(void *ctx)
{
    struct pk_sim_job *j = job_of(ctx);
    struct pk_grbl_machine_ops o;
    pk_grbl_motion_ops(&o);
    int cut = o.reset(ctx);
    pk_machine_position_um(j->m, j->cur);
    return cut;
}

static void job_ops(struct pk_grbl_machine_ops *o)
{
    pk_grbl_motion_ops(o);
    o->move = jm_move;
    o->move_chord = jm_move_chord;
    o->pen = jm_pen;
    o->smoothing = jm_smoothing;
    o->reset = jm_reset;
}

/* ---- the programmed path: the engine's primitives as exact ones ---------------------- */

void pk_sim_prim_from_grbl(const struct pk_grbl_prim *g, const struct pk_pen_cfg *pen,
                           struct pk_path_prim *out)
{
    double a[3] = { 0, 0, 0 }, b[3] = { 0, 0, 0 };
    for (int i = 0; i < PK_GC_AXES && i < 3; i++) {
        a[i] = (double)g->start[i];
        b[i] = (double)g->end[i];
    }
    pk_path_line(out, a, b);
    if (g->kind == PK_GRBL_PRIM_ARC) {
        enum pk_path_plane pl = g->a0 == 2 ? PK_PLANE_ZX : g->a0 == 1 ? PK_PLANE_YZ : PK_PLANE_XY;
        double centre[2] = { g->centre_q8[0] / 256.0, g->centre_q8[1] / 256.0 };
        struct pk_path_prim arc;
        if (pk_path_arc(&arc, a, b, centre, pl, g->cw, 0) == 0) {
            /* the sweep the firmware flattens (binary angle: 2^32 a turn) */
            double sw = (double)g->sweep * (6.283185307179586 / 4294967296.0);
            arc.sweep = g->cw ? -sw : sw;
            *out = arc;
        }
    } else if (g->kind == PK_GRBL_PRIM_CUBIC || g->kind == PK_GRBL_PRIM_QUAD) {
        int n = g->kind == PK_GRBL_PRIM_QUAD ? 1 : 2;
        out->kind = n == 1 ? PK_PATH_QUAD : PK_PATH_CUBIC;
        for (int k = 0; k < n; k++) {
            out->c[k][0] = (double)g->ctrl[k][0];
            out->c[k][1] = (double)g->ctrl[k][1];
            out->c[k][2] = a[2]; /* G5/G5.1 are XY curves */
        }
    }
    int rapid = g->kind == PK_GRBL_PRIM_RAPID;
    out->rapid = (uint8_t)rapid;
    out->drawn = (uint8_t)pk_pen_prog_drawn(pen, g->tool_on, (double)g->spindle_s / 1000.0, rapid,
                                            a[2], b[2]);
}

/* The engine's observer, with the source line of the engine's line. */
static void job_observe(void *ctx, const struct pk_grbl_prim *g)
{
    struct pk_sim_job *j = ctx;
    if (j->obs.on_prim != NULL) {
        struct pk_path_prim p;
        pk_sim_prim_from_grbl(g, &j->pen_cfg, &p);
        uint32_t k = g->line; /* the engine's line number: 1 = the first one given */
        size_t cap = sizeof j->lmap / sizeof j->lmap[0];
        p.line = k > 0u && k <= j->eng_lines && j->eng_lines - (k - 1u) <= cap ? j->lmap[(k - 1u) % cap]
                                                                                 : j->src_line;
        j->obs.on_prim(j->obs.arg, &p);
    }
    if (j->raw_obs != NULL)
        j->raw_obs(j->raw_obs_ctx, g);
}

/* ---- the job --------------------------------------------------------------------- */

static void job_common(struct pk_sim_job *j, struct pk_machine *m, const struct pk_sim_cfg *cfg)
{
    memset(j, 0, sizeof *j);
    j->m = m;
    j->cfg = cfg;
    pk_machine_position_um(m, j->cur);
    pk_sim_cfg_pen(cfg, &j->pen_cfg);
}

static void job_start_engine(struct pk_sim_job *j)
{
    j->gm.m = j->m;
    j->gm.hal = j->m->hal;
    j->gm.ready = 1; /* the caller initialised the machine */
    struct pk_grbl_settings set;
    if (pk_sim_cfg_to_grbl(j->cfg, &set, NULL, 0) != 0)
        pk_grbl_settings_default(&set);
    if (j->m->hard_limits)
        set.v[PK_GRBL_S_HARD_LIMITS] = 1; /* the machine was given hard limits: Grbl's $21=1 */
    j->gm.set = set;
    memset(j->nvm_buf, 0xff, sizeof j->nvm_buf);
    j->ram.buf = j->nvm_buf;
    j->ram.size = sizeof j->nvm_buf;
    struct pk_grbl_nvm nvm;
    pk_grbl_ram_nvm(&j->ram, &nvm);
    struct pk_grbl_stream io = { job_read, job_write, NULL, j };
    struct pk_grbl_machine_ops ops;
    job_ops(&ops);
    if (pk_grbl_init(&j->g, &io, &ops, &j->gm, &set, &nvm) != 0) {
        j->alarms = 1;
        j->alarm = PK_ALARM_INTERNAL;
        snprintf(j->alarm_text, sizeof j->alarm_text, "the settings were refused by the machine");
        j->finished = 1;
    }
    pk_grbl_set_observer(&j->g, job_observe, j);
    if (pk_grbl_state(&j->g) == PK_GRBL_ALARM) {
        /* $22=1 locks at power-on: the operator unlocks it */
        give(j, "$X", 2, 0);
    }
}

/* Polyline detection: every non-blank line "x y" (at least one). */
static int text_is_polyline(const char *t, size_t len)
{
    int any = 0;
    for (size_t p = 0; p < len;) {
        size_t n = 0;
        while (p + n < len && t[p + n] != '\n')
            n++;
        double x, y;
        int r = poly_line(t + p, n, &x, &y);
        if (r < 0)
            return 0;
        any |= r;
        p += n + 1u;
    }
    return any;
}

void pk_sim_job_init(struct pk_sim_job *j, struct pk_machine *m, const struct pk_sim_cfg *cfg,
                     const char *text, size_t len)
{
    job_common(j, m, cfg);
    j->text = text;
    j->len = len;
    j->file_size = len;
    j->polyline = text_is_polyline(text, len);
    if (j->polyline)
        give(j, "G21 G90", 7, 0);
    job_start_engine(j);
}

void pk_sim_job_set_observer(struct pk_sim_job *j, pk_grbl_observer_fn fn, void *ctx)
{
    j->raw_obs = fn;
    j->raw_obs_ctx = ctx;
}

void pk_sim_job_free(struct pk_sim_job *j)
{
    (void)j; /* nothing on the heap: the path goes to the observer */
}

void pk_sim_job_poll_machine(struct pk_sim_job *j)
{
    struct pk_machine *m = j->m;
    /* Host-side peek into the machine's motion queue (read only; the
     * firmware API has no block counter): count the blocks this poll queues: they are appended at the ring's
     * head, so the new ones sit between the old head and the new head. */
    uint32_t head0 = (uint32_t)(m->mq.tail + m->mq.count) % PK_MQ_CAP;
    uint32_t tail0 = m->mq.tail, count0 = m->mq.count;
    pk_machine_poll(m);
    uint32_t popped = (m->mq.tail + PK_MQ_CAP - tail0) % PK_MQ_CAP;
    uint32_t pushed = m->mq.count + popped - count0;
    for (uint32_t i = 0; i < pushed && i < PK_MQ_CAP; i++) {
        const struct pk_block *bl = &m->mq.b[(head0 + i) % PK_MQ_CAP];
        if (bl->type == PK_BLK_LINE)
            j->segments++;
        else if (bl->type == PK_BLK_PEN)
            j->pen_blocks++;
    }
}

void pk_sim_job_note_error(struct pk_sim_job *j, unsigned line, int code)
{
    if (j->errors < sizeof j->err / sizeof j->err[0])
        j->err[j->errors] = (struct pk_sim_gc_error){ line, code };
    j->errors++;
}

int pk_sim_job_main(void *arg, uint64_t now)
{
    struct pk_sim_job *j = arg;
    struct pk_machine *m = j->m;

    if (j->finished)
        return -1;
    if (pk_machine_state(m) == PK_STATE_ALARM) {
        if (j->alarms == 0u || j->alarm < 0) {
            j->alarm = (int)pk_machine_alarm(m);
            snprintf(j->alarm_text, sizeof j->alarm_text, "%s", pk_hal_error_text(m->hal));
        }
        if (j->alarms == 0u)
            j->alarms = 1;
        j->finished = 1;
        return -1;
    }
    pk_grbl_poll(&j->g);
    int gs = pk_grbl_state(&j->g);
    if (gs == PK_GRBL_HOLD0 && j->g.todo) {
        /* M0: the operator presses cycle start */
        (void)pk_grbl_rt_filter(&j->g, '~');
        j->pauses++;
    }
    pk_sim_job_poll_machine(j);
    j->move_requests = j->g.stats.moves;
    if (j->progress != NULL && now >= j->next_progress_tick) {
        j->next_progress_tick = now + (uint64_t)j->cfg->tick_hz * 2u;
        fprintf(j->progress, "\rplotkin sim: line %lu (%.0f%% of the file read), %.1f s simulated ",
                j->lines, j->file_size ? 100.0 * (double)j->bytes_in / (double)j->file_size : 100.0,
                (double)now / (double)j->cfg->tick_hz);
        fflush(j->progress);
    }
    if (pk_machine_state(m) == PK_STATE_ALARM)
        return pk_sim_job_main(arg, now);
    if (j->alarms && gs == PK_GRBL_ALARM && pk_grbl_idle(&j->g) &&
        pk_machine_state(m) == PK_STATE_IDLE) {
        j->finished = 1; /* ALARM:2 / ALARM:3: locked until a reset nobody sends */
        return -1;
    }
    int fed_all = (j->input_done || (j->eof && j->lbuf_i >= j->lbuf_n && (!j->polyline || j->tail_done)));
    if (fed_all && pk_grbl_idle(&j->g) && j->fifo_n == 0) {
        if (!j->end_sent && pk_machine_room(m) > 0u && pk_machine_end(m) == PK_MOTION_OK)
            j->end_sent = 1;
        if (j->end_sent && pk_machine_state(m) == PK_STATE_IDLE && pk_machine_queue_fill(m) == 0u) {
            j->finished = 1;
            return -1;
        }
    }
    return 1;
}
