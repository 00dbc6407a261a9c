/*
 * sim_job.c — G-code / polyline programs through the firmware (see sim_job.h).
 */
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "sim_job.h"
#include "pk_grbl.h"
#include "pk_grbl_motion.h"

/* Requests one G-code line can need: pen + dwell + path + move + end. */
#define ROOM_PER_LINE 5u

static int failf(char *err, size_t errlen, const char *fmt, ...);

/* ---- settings: Grbl's `$N` table of the firmware (pk_grbl.h) ------------ */

/* The double member of c that holds setting idx (enum pk_grbl_setting) as
 * the user writes it, or NULL for the whole-number ones (see cfg_uint). */
static double *cfg_double(struct pk_sim_cfg *c, int idx)
{
    switch (idx) {
    case PK_GRBL_S_STEP_PULSE_US: return &c->step_pulse_us;
    case PK_GRBL_S_JUNCTION_MM: return &c->junction_dev;
    case PK_GRBL_S_TOLERANCE_MM: return &c->tolerance;
    case PK_GRBL_S_DIR_SETUP_US: return &c->dir_setup_us;
    default: break;
    }
    if (idx >= PK_GRBL_S_STEPS_X && idx <= PK_GRBL_S_STEPS_Z)
        return &c->steps_per_mm[idx - PK_GRBL_S_STEPS_X];
    if (idx >= PK_GRBL_S_RATE_X && idx <= PK_GRBL_S_RATE_Z)
        return &c->max_rate[idx - PK_GRBL_S_RATE_X];
    if (idx >= PK_GRBL_S_ACCEL_X && idx <= PK_GRBL_S_ACCEL_Z)
        return &c->accel[idx - PK_GRBL_S_ACCEL_X];
    if (idx >= PK_GRBL_S_TRAVEL_X && idx <= PK_GRBL_S_TRAVEL_Z)
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
    default: return NULL;
    }
}

void pk_sim_cfg_from_grbl(struct pk_sim_cfg *c, const struct pk_grbl_settings *s)
{
    for (int i = 0; i < PK_GRBL_S_COUNT; i++) {
        double *d = cfg_double(c, i);
        unsigned *u = cfg_uint(c, i);
        if (d != NULL)
            *d = (double)s->v[i] / 1e6;
        else if (u != NULL)
            *u = (unsigned)(s->v[i] / 1000000);
    }
}

int pk_sim_cfg_to_grbl(const struct pk_sim_cfg *cc, struct pk_grbl_settings *s, char *err,
                       size_t errlen)
{
    struct pk_sim_cfg *c = (struct pk_sim_cfg *)cc; /* only read through the accessors */
    for (int i = 0; i < PK_GRBL_S_COUNT; i++) {
        const struct pk_grbl_setting_def *d = pk_grbl_setting_def(i);
        const double *dv = cfg_double(c, i);
        const unsigned *uv = cfg_uint(c, i);
        double v = dv != NULL ? *dv * 1e6 : (double)*uv * 1e6;
        if (!(v >= (double)d->min - 0.5 && v <= (double)d->max + 0.5))
            return failf(err, errlen, "$%u out of range (%g..%g)", (unsigned)d->num,
                         (double)d->min / 1e6, (double)d->max / 1e6);
        s->v[i] = (pk_gc_u6_t)llround(v);
        if (d->integer && s->v[i] % 1000000 != 0)
            return failf(err, errlen, "$%u must be a whole number", (unsigned)d->num);
    }
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
    c->laser_mode = 0;
    c->pen_z_on = 0;
    c->tick_hz = 1000000u;
}

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

void pk_sim_cfg_pen(const struct pk_sim_cfg *c, struct pk_pen_cfg *out)
{
    out->mode = c->laser_mode ? PK_PEN_LASER : c->pen_z_on ? PK_PEN_Z : PK_PEN_TOOL;
    out->z_down_um = c->pen_z_mm * 1000.0;
}

/* $32 (laser mode) and $208 (pen-down height): how the simulator reads a
 * drawing; not in the firmware's table yet. Returns 1 if handled. */
static int sim_only_setting(struct pk_sim_cfg *c, unsigned long num, const char *val, char *err,
                            size_t errlen, unsigned lineno, int *rc)
{
    if (num != 32u && num != 208u)
        return 0;
    char *end;
    double v = strtod(val, &end);
    while (isspace((unsigned char)*end))
        end++;
    if (end == val || *end != '\0' || !isfinite(v)) {
        *rc = failf(err, errlen, "line %u: $%lu: bad number", lineno, num);
        return 1;
    }
    if (num == 32u) {
        if (v != 0.0 && v != 1.0) {
            *rc = failf(err, errlen, "line %u: $32 must be 0 or 1", lineno);
            return 1;
        }
        c->laser_mode = (unsigned)v;
    } else {
        c->pen_z_on = 1;
        c->pen_z_mm = v;
    }
    *rc = 0;
    return 1;
}

/* Grbl 1.1 settings plotkin has no use for: accepted, ignored. */
static int grbl_ignored(unsigned long n)
{
    static const unsigned ign[] = { 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 24, 25, 26, 27,
                                    30, 31 };
    for (size_t i = 0; i < sizeof ign / sizeof ign[0]; i++)
        if (ign[i] == n)
            return 1;
    return 0;
}

static const char *grbl_error_text(int code)
{
    switch (code) {
    case 3: return "not a setting plotkin has, or out of its range";
    case 4: return "negative value";
    default: return "bad number";
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
        while (isspace((unsigned char)*s))
            s++;
        size_t k = strlen(s);
        while (k > 0 && isspace((unsigned char)s[k - 1]))
            s[--k] = '\0';
        if (*s == '\0')
            continue;
        if (*s != '$' || !isdigit((unsigned char)s[1]))
            return failf(err, errlen, "line %u: expected $N=value", lineno);
        char *end;
        unsigned long num = strtoul(s + 1, &end, 10);
        while (isspace((unsigned char)*end))
            end++;
        if (*end != '=')
            return failf(err, errlen, "line %u: expected '=' after $%lu", lineno, num);
        int src;
        if (sim_only_setting(c, num, end + 1, err, errlen, lineno, &src)) {
            if (src != 0)
                return src;
            continue;
        }
        if (num > 65535ul || pk_grbl_setting_index((uint32_t)num) < 0) {
            if (!grbl_ignored(num))
                return failf(err, errlen, "line %u: unknown setting $%lu", lineno, num);
            if (warn)
                fprintf(warn, "plotkin sim: note: $%lu has no effect in plotkin\n", num);
            continue;
        }
        /* The firmware's own parser and table: the same numbers, ranges and
         * number syntax as `$N=value` sent to the Grbl engine. */
        int idx;
        pk_gc_u6_t val;
        int rc = pk_grbl_setting_parse((const uint8_t *)s + 1, k - 1u, &idx, &val);
        if (rc != 0) {
            const struct pk_grbl_setting_def *d = pk_grbl_setting_def(pk_grbl_setting_index((uint32_t)num));
            return failf(err, errlen, "line %u: $%lu: error:%d (%s; range %g..%g%s)", lineno, num, rc,
                         grbl_error_text(rc), (double)d->min / 1e6, (double)d->max / 1e6,
                         d->integer ? ", whole numbers" : "");
        }
        struct pk_grbl_settings set;
        if (pk_sim_cfg_to_grbl(c, &set, NULL, 0) != 0)
            pk_grbl_settings_default(&set); /* c was edited out of range: start clean */
        set.v[idx] = val;
        pk_sim_cfg_from_grbl(c, &set);
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
    int in_stroke = 0;
    *is_polyline = 0;
    sb_printf(&b, "G21 G90\n");
    for (const char *p = text; *p;) {
        size_t n = strcspn(p, "\n");
        char line[256];
        if (n >= sizeof line) {
            free(b.p);
            return NULL;
        }
        memcpy(line, p, n);
        line[n] = '\0';
        p += n + (p[n] == '\n');
        char *h = strchr(line, '#');
        if (h)
            *h = '\0';
        char *s = line;
        while (isspace((unsigned char)*s))
            s++;
        if (*s == '\0') {
            if (in_stroke)
                sb_printf(&b, "M5\n");
            in_stroke = 0;
            continue;
        }
        char *e1, *e2;
        double x = strtod(s, &e1);
        double y = e1 == s ? 0.0 : strtod(e1, &e2);
        if (e1 == s || e2 == e1) {
            free(b.p);
            return NULL;
        }
        while (isspace((unsigned char)*e2) || *e2 == ',')
            e2++;
        if (*e2 != '\0' || !isfinite(x) || !isfinite(y)) {
            free(b.p);
            return NULL;
        }
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
    if (b.oom) {
        free(b.p);
        return NULL;
    }
    *is_polyline = 1;
    return b.p;
}

/* ---- the job ------------------------------------------------------------- */
void pk_sim_job_init(struct pk_sim_job *j, struct pk_machine *m, const struct pk_sim_cfg *cfg,
                     const char *text, size_t len)
{
    struct pk_gc_limits lim;
    pk_um_t zero[PK_GC_AXES] = { 0 };
    memset(j, 0, sizeof *j);
    j->m = m;
    j->cfg = cfg;
    j->text = text;
    j->len = len;
    for (int i = 0; i < PK_GC_AXES; i++) {
        double t = cfg->travel[i] * 1000.0;
        pk_um_t tu = t > PK_UM_MAX ? PK_UM_MAX : (pk_um_t)llround(t);
        lim.min_um[i] = i < 2 ? 0 : -tu; /* as the Grbl engine: X, Y in [0, $13x] */
        lim.max_um[i] = tu;
    }
    pk_gcode_state_init(&j->gc, &lim, zero);
    pk_sim_cfg_pen(cfg, &j->pen_cfg);
}

void pk_sim_job_free(struct pk_sim_job *j) { (void)j; }

/* The observer's primitive for a move from j->cur (µm) to `to` (at least
 * PK_AXES coordinates; axes beyond PK_AXES stay 0). */
static void observe_move(struct pk_sim_job *j, const pk_um_t *to, int rapid, const pk_um_t (*ctrl)[2],
                         int nctrl)
{
    struct pk_path_prim p;
    double a[3] = { 0, 0, 0 }, b[3] = { 0, 0, 0 };
    if (j->obs.on_prim == NULL)
        return;
    for (int i = 0; i < PK_GC_AXES && i < PK_AXES; i++) {
        a[i] = (double)j->cur[i];
        b[i] = (double)to[i];
    }
    pk_path_line(&p, a, b);
    if (nctrl > 0) {
        p.kind = nctrl == 1 ? PK_PATH_QUAD : PK_PATH_CUBIC;
        for (int k = 0; k < nctrl; k++) {
            p.c[k][0] = (double)ctrl[k][0];
            p.c[k][1] = (double)ctrl[k][1];
            p.c[k][2] = a[2]; /* G5/G5.1 are XY curves */
        }
    }
    p.rapid = (uint8_t)rapid;
    p.line = j->lineno;
    p.drawn = (uint8_t)pk_pen_prog_drawn(&j->pen_cfg, j->pen, j->s_power, rapid, a[2], b[2]);
    j->obs.on_prim(j->obs.arg, &p);
}

static void gc_error(struct pk_sim_job *j, int code) { pk_sim_job_note_error(j, j->lineno, code); }

static int request_move(struct pk_sim_job *j, const pk_um_t to[PK_AXES], pk_gc_umpm_t feed, int rapid)
{
    pk_um_t tgt[PK_AXES];
    for (int i = 0; i < PK_AXES; i++)
        tgt[i] = to[i];
    pk_um_min_t f = feed <= 0 ? 1u : (pk_um_min_t)feed;
    if (f > PK_UM_MIN_MAX)
        f = PK_UM_MIN_MAX;
    int rc = pk_machine_move(j->m, tgt, f, rapid ? PK_MOVE_RAPID : PK_MOVE_FEED);
    if (rc == PK_MOTION_OK) {
        for (int i = 0; i < PK_AXES; i++)
            j->cur[i] = tgt[i];
        j->move_requests++;
    }
    return rc;
}

/* Next line of the program into buf (without terminator); 0 at the end. */
static int next_line(struct pk_sim_job *j, const uint8_t **line, size_t *n)
{
    if (j->pos >= j->len)
        return 0;
    size_t s = j->pos, e = s;
    while (e < j->len && j->text[e] != '\n' && j->text[e] != '\r')
        e++;
    *line = (const uint8_t *)j->text + s;
    *n = e - s;
    j->pos = e;
    if (j->pos < j->len && j->text[j->pos] == '\r')
        j->pos++;
    if (j->pos < j->len && j->text[j->pos] == '\n')
        j->pos++;
    j->lineno++;
    return 1;
}

static void execute(struct pk_sim_job *j, const struct pk_gc_cmd *c)
{
    if (c->what & PK_GC_DO_PEN) {
        (void)pk_machine_pen(j->m, c->pen == PK_GC_PEN_DOWN);
        j->pen = c->pen == PK_GC_PEN_DOWN;
    }
    if (c->what & PK_GC_DO_DWELL)
        (void)pk_machine_dwell(j->m, c->dwell_ms > PK_DWELL_MS_MAX ? PK_DWELL_MS_MAX : c->dwell_ms);
    if ((c->what & PK_GC_DO_PATH) && !j->cfg->force_smoothing) {
        struct pk_smooth_cfg s = j->m->cfg.smooth;
        if (c->path == PK_GC_PATH_EXACT) {
            s.mode = PK_SMOOTH_OFF;
        } else {
            s.mode = PK_SMOOTH_TOLERANCE;
            if (c->tol_um > 0)
                s.tolerance_um = c->tol_um;
            else if (s.tolerance_um <= 0)
                s.tolerance_um = 20;
            if (s.degree < 2u || s.degree > 3u)
                s.degree = 3;
        }
        if (pk_machine_set_smoothing(j->m, &s) == PK_MOTION_EINVAL)
            gc_error(j, PK_GC_E_UNSUPPORTED);
    }
    if (c->what & PK_GC_DO_MOVE) {
        if (c->motion == PK_GC_MOT_CUBIC || c->motion == PK_GC_MOT_QUAD) {
            pk_um_t p[4][2] = { { c->start_um[0], c->start_um[1] },
                                { c->ctrl_um[0][0], c->ctrl_um[0][1] },
                                { c->ctrl_um[1][0], c->ctrl_um[1][1] },
                                { c->target_um[0], c->target_um[1] } };
            int quad = c->motion == PK_GC_MOT_QUAD;
            if (quad) {
                p[2][0] = c->target_um[0];
                p[2][1] = c->target_um[1];
            }
            pk_um_t tol = j->m->cfg.smooth.tolerance_um > 0 ? j->m->cfg.smooth.tolerance_um : 10;
            pk_bez_init(&j->bez, (const pk_um_t(*)[2])p, quad, tol);
            observe_move(j, c->target_um, 0, (const pk_um_t(*)[2])&p[1], quad ? 1 : 2);
            j->bez_active = 1;
            j->bez_feed = c->feed_umpm;
        } else {
            int rapid = c->motion == PK_GC_MOT_RAPID;
            pk_um_t from[PK_AXES];
            memcpy(from, j->cur, sizeof from);
            if (request_move(j, c->target_um, c->feed_umpm, rapid) == PK_MOTION_OK) {
                pk_um_t to[PK_AXES];
                memcpy(to, j->cur, sizeof to);
                memcpy(j->cur, from, sizeof from);
                observe_move(j, to, rapid, NULL, 0);
                memcpy(j->cur, to, sizeof to);
            }
        }
    }
    if (c->what & PK_GC_DO_STOP) {
        j->input_done = 1; /* M2/M30: the rest of the file is not run */
    }
}

static void feed(struct pk_sim_job *j)
{
    for (;;) {
        if (j->bez_active) {
            if (pk_machine_room(j->m) == 0u)
                return;
            pk_um_t q[2], to[PK_AXES];
            if (!pk_bez_next(&j->bez, q)) {
                j->bez_active = 0;
                continue;
            }
            for (int i = 0; i < PK_AXES; i++)
                to[i] = j->cur[i];
            to[0] = q[0];
            to[1] = q[1];
            (void)request_move(j, to, j->bez_feed, 0);
            continue;
        }
        if (j->input_done) {
            if (!j->end_sent && pk_machine_room(j->m) > 0u && pk_machine_end(j->m) == PK_MOTION_OK)
                j->end_sent = 1;
            return;
        }
        if (pk_machine_room(j->m) < ROOM_PER_LINE)
            return;
        if (j->obs.room != NULL && j->obs.room(j->obs.arg) == 0u)
            return; /* the observer is full: let the machine catch up */
        const uint8_t *line;
        size_t n;
        if (!next_line(j, &line, &n)) {
            j->input_done = 1;
            continue;
        }
        j->lines++;
        struct pk_gc_block b;
        struct pk_gc_cmd c;
        int rc = pk_gcode_parse(line, n, &b);
        if (rc == PK_GC_OK)
            rc = pk_gcode_interp(&j->gc, &b, &c);
        if (rc != PK_GC_OK) {
            gc_error(j, rc);
            continue;
        }
        if (b.words & PK_GC_WBIT(PK_GC_W_S))
            j->s_power = (double)b.v[PK_GC_W_S] / 1e6;
        execute(j, &c);
    }
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

    if (pk_machine_state(m) == PK_STATE_ALARM) {
        if (j->alarms == 0u) {
            j->alarms = 1;
            j->alarm = (int)pk_machine_alarm(m);
            snprintf(j->alarm_text, sizeof j->alarm_text, "%s", pk_hal_error_text(m->hal));
        }
        j->finished = 1;
        return -1;
    }
    feed(j);
    pk_sim_job_poll_machine(j);
    if (j->progress != NULL && now >= j->next_progress_tick) {
        j->next_progress_tick = now + (uint64_t)j->cfg->tick_hz * 2u;
        fprintf(j->progress, "\rplotkin sim: line %lu (%.0f%% of the file read), %.1f s simulated ",
                j->lines, j->len ? 100.0 * (double)j->pos / (double)j->len : 100.0,
                (double)now / (double)j->cfg->tick_hz);
        fflush(j->progress);
    }
    if (pk_machine_state(m) == PK_STATE_ALARM)
        return pk_sim_job_main(arg, now);
    if (j->end_sent && !j->bez_active && pk_machine_state(m) == PK_STATE_IDLE &&
        pk_machine_queue_fill(m) == 0u) {
        j->finished = 1;
        return -1;
    }
    return 1;
}
