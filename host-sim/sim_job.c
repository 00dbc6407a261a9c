/*
 * sim_job.c — G-code / polyline programs through the firmware (see sim_job.h).
 */
#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include "sim_job.h"

/* Requests one G-code line can need: pen + dwell + path + move + end. */
#define ROOM_PER_LINE 5u

void pk_sim_cfg_default(struct pk_sim_cfg *c)
{
    memset(c, 0, sizeof *c);
    c->axes = PK_AXES;
    for (int i = 0; i < 3; i++) {
        c->steps_per_mm[i] = 80.0;
        c->max_rate[i] = i < 2 ? 6000.0 : 1500.0;
        c->accel[i] = i < 2 ? 1000.0 : 500.0;
        c->travel[i] = i < 2 ? 300.0 : 50.0;
    }
    c->junction_dev = 0.01;
    c->step_pulse_us = 10.0;
    c->dir_setup_us = 1.0;
    c->smooth_mode = PK_SMOOTH_TOLERANCE;
    c->tolerance = 0.02;
    c->sharp_deg = 60;
    c->degree = 3;
    c->depth = 3;
    c->pen_settle_ms = 50;
    c->polyline_feed = 3000.0;
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

/* Grbl 1.1 settings plotkin has no use for: accepted, ignored. */
static int grbl_ignored(unsigned n)
{
    static const unsigned ign[] = { 1, 2, 3, 4, 5, 6, 10, 13, 20, 21, 22, 23, 24, 25, 26, 27,
                                    30, 31, 32 };
    for (size_t i = 0; i < sizeof ign / sizeof ign[0]; i++)
        if (ign[i] == n)
            return 1;
    return 0;
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
        if (*s == '\0')
            continue;
        char *end;
        if (*s != '$' || !isdigit((unsigned char)s[1]))
            return failf(err, errlen, "line %u: expected $N=value", lineno);
        unsigned long num = strtoul(s + 1, &end, 10);
        while (isspace((unsigned char)*end))
            end++;
        if (*end != '=')
            return failf(err, errlen, "line %u: expected '=' after $%lu", lineno, num);
        const char *vs = end + 1;
        double v = strtod(vs, &end);
        while (isspace((unsigned char)*end))
            end++;
        if (end == vs || *end != '\0' || !isfinite(v) || v < 0.0)
            return failf(err, errlen, "line %u: $%lu needs a non-negative number", lineno, num);
        switch (num) {
        case 0: c->step_pulse_us = v; break;
        case 11: c->junction_dev = v; break;
        case 12: c->tolerance = v; break;
        case 100: case 101: case 102: c->steps_per_mm[num - 100] = v; break;
        case 110: case 111: case 112: c->max_rate[num - 110] = v; break;
        case 120: case 121: case 122: c->accel[num - 120] = v; break;
        case 130: case 131: case 132: c->travel[num - 130] = v; break;
        case 200: c->smooth_mode = (unsigned)v; break;
        case 201: c->scheme = (unsigned)v; break;
        case 202: c->degree = (unsigned)v; break;
        case 203: c->depth = (unsigned)v; break;
        case 204: c->sharp_deg = (unsigned)v; break;
        case 205: c->pen_settle_ms = (unsigned)v; break;
        case 206: c->dir_setup_us = v; break;
        default:
            if (!grbl_ignored((unsigned)num))
                return failf(err, errlen, "line %u: unknown setting $%lu", lineno, num);
            if (warn)
                fprintf(warn, "plotkin sim: note: $%lu has no effect in plotkin\n", num);
            break;
        }
    }
    return 0;
}

int pk_sim_cfg_motion(const struct pk_sim_cfg *c, struct pk_motion_cfg *o, char *err, size_t errlen)
{
    memset(o, 0, sizeof *o);
    if (c->axes < 2u || c->axes > PK_AXES)
        return failf(err, errlen, "axes must be 2..%d", PK_AXES);
    o->axes = (uint8_t)c->axes;
    for (unsigned i = 0; i < PK_AXES && i < 3u; i++) {
        double spmm = c->steps_per_mm[i] * 65536.0;
        if (!(spmm >= PK_SPMM_Q16_MIN && spmm <= PK_SPMM_Q16_MAX))
            return failf(err, errlen, "$%u steps/mm out of range (1/16..10000)", 100u + i);
        o->steps_per_mm_q16[i] = (pk_spmm_q16_t)llround(spmm);
        double rate = c->max_rate[i] * 1000.0;
        if (!(rate >= 1.0 && rate <= PK_UM_MIN_MAX))
            return failf(err, errlen, "$%u max rate out of range (0.001..60000 mm/min)", 110u + i);
        o->max_rate[i] = (pk_um_min_t)llround(rate);
        double acc = c->accel[i] * 1000.0;
        if (!(acc >= 1.0 && acc <= PK_UM_S2_MAX))
            return failf(err, errlen, "$%u acceleration out of range (0.001..100000 mm/s^2)", 120u + i);
        o->accel[i] = (pk_um_s2_t)llround(acc);
    }
    o->junction_dev_um = (pk_um_t)llround(c->junction_dev * 1000.0);
    double pulse = ceil(c->step_pulse_us * (double)c->tick_hz / 1e6 - 1e-9);
    double setup = ceil(c->dir_setup_us * (double)c->tick_hz / 1e6 - 1e-9);
    o->step_pulse_ticks = pulse < 1.0 ? 1u : (uint32_t)pulse;
    o->dir_setup_ticks = (uint32_t)setup;
    o->pen_settle_ms = c->pen_settle_ms;
    o->pen_down_level = 1;
    o->smooth.mode = (uint8_t)c->smooth_mode;
    o->smooth.scheme = (uint8_t)c->scheme;
    o->smooth.degree = (uint8_t)c->degree;
    o->smooth.depth = (uint8_t)c->depth;
    o->smooth.tolerance_um = (pk_um_t)llround(c->tolerance * 1000.0);
    o->smooth.sharp_turn_deg = (uint16_t)c->sharp_deg;
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
}

void pk_sim_job_free(struct pk_sim_job *j)
{
    free(j->moves);
    j->moves = NULL;
    j->n_moves = j->cap_moves = 0;
}

static void record_move(struct pk_sim_job *j, const pk_um_t to[PK_AXES], int rapid)
{
    if (j->n_moves == j->cap_moves) {
        size_t cap = j->cap_moves ? j->cap_moves * 2u : 1024u;
        struct pk_sim_move *p = realloc(j->moves, cap * sizeof *p);
        if (p == NULL)
            return;
        j->moves = p;
        j->cap_moves = cap;
    }
    struct pk_sim_move *mv = &j->moves[j->n_moves++];
    mv->a[0] = j->cur[0];
    mv->a[1] = j->cur[1];
    mv->b[0] = to[0];
    mv->b[1] = to[1];
    mv->rapid = (uint8_t)rapid;
    mv->pen = j->pen;
}

static void gc_error(struct pk_sim_job *j, int code)
{
    if (j->errors < sizeof j->err / sizeof j->err[0])
        j->err[j->errors] = (struct pk_sim_gc_error){ j->lineno, code };
    j->errors++;
}

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
        record_move(j, tgt, rapid);
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
    if (c->what & PK_GC_DO_PATH) {
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
            j->bez_active = 1;
            j->bez_feed = c->feed_umpm;
        } else {
            (void)request_move(j, c->target_um, c->feed_umpm, c->motion == PK_GC_MOT_RAPID);
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
        execute(j, &c);
    }
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

/* Distance from (px, py) to the segment of move k, µm. */
static double seg_dist(const struct pk_sim_move *mv, double px, double py)
{
    double ax = mv->a[0], ay = mv->a[1], bx = mv->b[0], by = mv->b[1];
    double dx = bx - ax, dy = by - ay, l2 = dx * dx + dy * dy;
    double t = l2 > 0.0 ? ((px - ax) * dx + (py - ay) * dy) / l2 : 0.0;
    t = t < 0.0 ? 0.0 : t > 1.0 ? 1.0 : t;
    double ex = ax + t * dx - px, ey = ay + t * dy - py;
    return sqrt(ex * ex + ey * ey);
}

double pk_sim_job_point_deviation(const struct pk_sim_job *j, size_t *k, double x, double y)
{
    if (j->n_moves == 0u)
        return -1.0;
    size_t c = *k < j->n_moves ? *k : j->n_moves - 1u;
    size_t lo = c >= 64u ? c - 64u : 0u, hi = c + 64u < j->n_moves ? c + 64u : j->n_moves;
    double best = INFINITY;
    size_t bk = c;
    for (size_t q = lo; q < hi; q++) {
        double d = seg_dist(&j->moves[q], x, y);
        if (d < best) {
            best = d;
            bk = q;
        }
    }
    if (best > 2.0 && j->n_moves > hi) {
        /* The move executing is never far behind the newest one requested
         * (the request FIFO, the kernel and the motion queue hold a bounded
         * number of moves): look there too, in case the window was lured
         * away by a crossing move. */
        size_t q0 = j->n_moves > 256u ? j->n_moves - 256u : 0u;
        for (size_t q = q0 > hi ? q0 : hi; q < j->n_moves; q++) {
            double d = seg_dist(&j->moves[q], x, y);
            if (d < best) {
                best = d;
                bk = q;
            }
        }
    }
    *k = bk;
    return best;
}

double pk_sim_job_deviation_um(const struct pk_sim_job *j, const double *x, const double *y, size_t n)
{
    if (j->n_moves == 0u)
        return -1.0;
    size_t k = 0;
    double worst = 0.0;
    for (size_t i = 0; i < n; i++) {
        double d = pk_sim_job_point_deviation(j, &k, x[i], y[i]);
        if (d > worst)
            worst = d;
    }
    return worst;
}
