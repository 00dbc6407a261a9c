/*
 * cmd_sim.c — `plotkin sim FILE`: run a G-code program or a plain polyline
 * through the whole firmware in the simulator and report what the machine
 * did (see `plotkin sim --help`).
 */
#define _DEFAULT_SOURCE 1 /* madvise */
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include "commands.h"
#include "sim_inputs.h"
#include "sim_report.h"
#include "sim_run.h"

static const char sim_usage[] =
    "usage: plotkin sim FILE [--json] [--svg OUT.svg] [--trace OUT.csv] [--config FILE]\n"
    "                        [--exact | --tolerance MM] [--driver NAME] [--feed MM_PER_MIN]\n"
    "\n"
    "Runs FILE through the firmware (G-code parser, smoothing kernel, planner, step\n"
    "generator, libgpiod backend on a mock GPIO chip) on a simulated clock, decodes\n"
    "the step/dir pins and prints what the machine did.\n"
    "\n"
    "  FILE             G-code, or a plain polyline: one `x y` (mm) per line, a blank\n"
    "                   line between strokes (pen up between them); '-' reads stdin\n"
    "  --json           print the summary as one JSON object\n"
    "  --svg OUT        draw the programmed path (wide, light) and the executed path\n"
    "                   decoded from the step pulses (thin, dark); travels dashed\n"
    "  --svg-tolerance MM  the drawing is thinned within MM of each path (default 0.01)\n"
    "  --trace OUT.csv  write every pin edge (tick, time, signal, raw level)\n"
    "  --config FILE    machine settings, Grbl-style `$N=value` lines (as `$$` prints):\n"
    "                   $0 step pulse us, $11 junction deviation mm, $12 tolerance mm,\n"
    "                   $100-102 steps/mm, $110-112 max rate mm/min, $120-122 accel mm/s^2,\n"
    "                   $130-132 travel mm, $200 smoothing 0 off/1 fixed/2 tolerance,\n"
    "                   $201 scheme 0 B-spline/1 DLG, $202 degree, $203 depth,\n"
    "                   $204 sharp corner deg, $205 pen settle ms, $206 dir set-up us;\n"
    "                   read by the simulator only: $32=1 laser mode, $208=H pen-down height\n"
    "  --pen-z H        the pen is down at Z <= H mm ($208; M3/M5 then do not draw)\n"
    "  --laser          laser mode ($32=1): G1 moves with M3/M4 and S > 0 burn, G0 never\n"
    "  --axes N         axes driven, 2 or 3 (default 3)\n"
    "  --exact          no smoothing; --tolerance MM: smoothing within MM; either\n"
    "                   overrides the smoothing of G61/G64 in the program (arcs keep\n"
    "                   the chords of the program's path mode: 2 um in G61, P/4 in G64)\n"
    "  --lower-bound    also print a lower bound on the motion time of any path within\n"
    "                   the tolerance (host-sim/sim_bound.h: the model; dwells excluded)\n"
    "  --driver NAME    timing limits checked: drv8825 (default), a4988, tmc2209\n"
    "  --feed F         feed for polyline files, mm/min (default 3000)\n"
    "  --inject FAULT   make the mock GPIO chip fail: open, request:N (the Nth line\n"
    "                   request), set:N (the Nth write) - to see how the firmware copes\n"
    "%s"
    "\n"
    "Speeds are measured per axis from the decoded step times over any 16 and any 2\n"
    "consecutive steps, accelerations between windows of >= 16 steps and >= 20 ms,\n"
    "each with the least value the step quantisation allows (>=). The deviation is\n"
    "the distance from each decoded step position to the programmed path (lines,\n"
    "arcs and G5 curves evaluated exactly): its maximum, where, and 95th percentile.\n"
    "Soft limits ($20=1, which needs $22=1) keep moves within [-$13x, 0] as Grbl after\n"
    "homing; without them (the default) any target within +-2097 mm runs.\n"
    "\n"
    "Exit status: 0 ran cleanly; 1 alarm, G-code errors, timing violations or a\n"
    "setup failure; 2 bad usage.\n";

static char *read_all(const char *path, size_t *len)
{
    FILE *f = strcmp(path, "-") == 0 ? stdin : fopen(path, "rb");
    if (f == NULL)
        return NULL;
    size_t cap = 65536, n = 0;
    char *buf = malloc(cap + 1);
    while (buf != NULL) {
        size_t k = fread(buf + n, 1, cap - n, f);
        n += k;
        if (n < cap)
            break;
        char *nb = realloc(buf, cap * 2 + 1);
        if (nb == NULL) {
            free(buf);
            buf = NULL;
            break;
        }
        buf = nb;
        cap *= 2;
    }
    int bad = ferror(f);
    if (f != stdin)
        fclose(f);
    if (buf == NULL || bad) {
        free(buf);
        return NULL;
    }
    buf[n] = '\0';
    *len = n;
    return buf;
}

static void json_str(FILE *f, const char *s)
{
    fputc('"', f);
    for (; *s; s++) {
        unsigned char ch = (unsigned char)*s;
        if (ch == '"' || ch == '\\')
            fprintf(f, "\\%c", ch);
        else if (ch < 0x20)
            fprintf(f, "\\u%04x", ch);
        else
            fputc(ch, f);
    }
    fputc('"', f);
}

static void json_arr_d(FILE *f, const double *v, unsigned n, const char *fmt)
{
    fputc('[', f);
    for (unsigned i = 0; i < n; i++) {
        if (i)
            fputs(", ", f);
        fprintf(f, fmt, v[i]);
    }
    fputc(']', f);
}

static void json_rate(FILE *f, const char *key, const struct pk_sim_result *r, unsigned axes, int which,
                      int proven)
{
    fprintf(f, ",\n  \"%s\": [", key);
    for (unsigned a = 0; a < axes; a++) {
        const struct pk_rate *e = &r->rate[a];
        double v = which == 0 ? (proven ? e->speed16.lo_max : e->speed16.vmax.v)
                 : which == 1 ? (proven ? e->speed2.lo_max : e->speed2.vmax.v)
                              : (proven ? e->accel_proven.lo_abs_max : fabs(e->accel.amax.a));
        fprintf(f, which == 2 ? "%s%.1f" : "%s%.3f", a ? ", " : "", v);
    }
    fputc(']', f);
}

static void json_path(FILE *f, const char *prefix, const struct pk_path *p, double hz)
{
    const struct pk_path_stats *s = &p->st;
    fprintf(f, ",\n  \"%smax_deviation_mm\": %.4f,\n  \"%sdeviation_p95_mm\": %.4f,\n", prefix,
            s->max_um / 1000.0, prefix, pk_path_quantile(p, 0.95) / 1000.0);
    fprintf(f, "  \"%sdeviation_line_last\": %u,\n  \"%sdeviation_within_mm\": %.4f,\n", prefix,
            (unsigned)s->max_line_last, prefix, s->approx_um / 1000.0);
    fprintf(f, "  \"%sdeviation_at_mm\": [%.4f, %.4f, %.4f],\n  \"%sdeviation_line\": %u,\n"
               "  \"%sdeviation_t_s\": %.6f,\n  \"%sdeviation_points\": %llu,\n  \"%spath_forced_drops\": %llu",
            prefix, s->max_at_um[0] / 1000.0, s->max_at_um[1] / 1000.0, s->max_at_um[2] / 1000.0, prefix,
            (unsigned)s->max_line, prefix, (double)s->max_tick / hz, prefix, (unsigned long long)s->points,
            prefix, (unsigned long long)s->forced_drops);
}

/* Peak resident memory of this process so far (Linux VmHWM), kB; -1 if unknown. */
static long vm_hwm_kb(void)
{
    FILE *f = fopen("/proc/self/status", "r");
    char line[256];
    long kb = -1;
    if (f == NULL)
        return -1;
    while (fgets(line, sizeof line, f) != NULL)
        if (strncmp(line, "VmHWM:", 6) == 0)
            kb = strtol(line + 6, NULL, 10);
    fclose(f);
    return kb;
}

static void print_json(FILE *f, const char *file, const struct pk_sim_result *r, unsigned axes)
{
    double fmm[PK_AXES];
    const double hz = (double)r->hw.sched.tick_hz;
    fputs("{\n  \"file\": ", f);
    json_str(f, file);
    fprintf(f, ",\n  \"axes\": %u,\n  \"status\": ", axes);
    json_str(f, pk_sim_run_status_name(r->run_status));
    fprintf(f, ",\n  \"lines\": %lu,\n  \"moves\": %lu,\n  \"segments\": %lu,\n", r->job.lines,
            r->job.move_requests, r->job.segments);
    fputs("  \"steps\": [", f);
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%s%llu", a ? ", " : "", (unsigned long long)r->dec.steps[a]);
    fputs("],\n  \"final_steps\": [", f);
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%s%lld", a ? ", " : "", (long long)r->dec.pos[a]);
    fputs("],\n  \"firmware_steps\": [", f);
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%s%ld", a ? ", " : "", (long)r->fw_steps[a]);
    for (unsigned a = 0; a < axes; a++)
        fmm[a] = pk_sim_steps_to_um(r, a, r->dec.pos[a]) / 1000.0;
    fputs("],\n  \"final_mm\": ", f);
    json_arr_d(f, fmm, axes, "%.4f");
    fprintf(f, ",\n  \"sim_time_s\": %.6f", (double)r->ticks / hz);
    if (r->opts.lower_bound) {
        if (r->lower_bound_s >= 0.0)
            fprintf(f, ",\n  \"lower_bound_s\": %.6f", r->lower_bound_s);
        else
            fputs(",\n  \"lower_bound_s\": null", f);
    }
    json_rate(f, "max_speed_mm_s", r, axes, 0, 0);
    json_rate(f, "max_speed_proven_mm_s", r, axes, 0, 1);
    json_rate(f, "max_speed2_mm_s", r, axes, 1, 0);
    json_rate(f, "max_speed2_proven_mm_s", r, axes, 1, 1);
    json_rate(f, "max_accel_mm_s2", r, axes, 2, 0);
    json_rate(f, "max_accel_proven_mm_s2", r, axes, 2, 1);
    /* over_limits: the axis provably ran over its max rate (any 2 or 16
     * steps) or over its acceleration between windows of >= 20 ms, what the
     * text's "over its max rate" / "over its acceleration" say. speed_jumps:
     * windows of 2-64 steps prove more than the acceleration, as the
     * velocity jump of Grbl's junction model at a programmed corner does (by
     * design, reproduced) and the bounded jump the kink cap allows at a
     * smoothed vertex; the text's "speed jumps". Kept apart so that a CI
     * check on over_limits is not set off by every corner. */
    fputs(",\n  \"over_limits\": [", f);
    for (unsigned a = 0; a < axes; a++) {
        const struct pk_rate *e = &r->rate[a];
        int over = pk_rate_over_speed(e) || pk_rate_over_accel(e);
        fprintf(f, "%s%s", a ? ", " : "", over ? "true" : "false");
    }
    fputs("],\n  \"speed_jumps\": [", f);
    for (unsigned a = 0; a < axes; a++) {
        const struct pk_rate *e = &r->rate[a];
        int jump = pk_rate_speed_jumps(e);
        fprintf(f, "%s%s", a ? ", " : "", jump ? "true" : "false");
    }
    fputc(']', f);
    if (r->prog.st.points > 0u)
        json_path(f, "", &r->prog, hz);
    else
        fputs(",\n  \"max_deviation_mm\": null", f);
    if (r->ref_on && r->ref.st.points > 0u)
        json_path(f, "ref_", &r->ref, hz);
    fprintf(f, ",\n  \"path_primitives\": %llu,\n", (unsigned long long)r->prog.st.prims);
    size_t kept = r->dec.n_viol < PK_VIOL_KEEP ? r->dec.n_viol : PK_VIOL_KEEP;
    fprintf(f, "  \"timing_violations\": %zu,\n  \"violations\": [", r->dec.n_viol);
    for (size_t i = 0; i < kept; i++) {
        const struct pk_violation *vi = &r->dec.viol[i];
        fprintf(f, "%s\n    {\"tick\": %llu, \"axis\": \"%c\", \"kind\": \"%s\", \"got_ns\": %llu, \"min_ns\": %u}",
                i ? "," : "", (unsigned long long)vi->t, "XYZA"[vi->axis & 3u],
                pk_violation_name((enum pk_violation_kind)vi->kind), (unsigned long long)vi->got_ns,
                (unsigned)vi->limit_ns);
    }
    fprintf(f, "%s],\n  \"errors\": %lu,\n  \"error_lines\": [", kept ? "\n  " : "", r->job.errors);
    size_t ne = r->job.errors < 32u ? r->job.errors : 32u;
    for (size_t i = 0; i < ne; i++)
        fprintf(f, "%s{\"line\": %u, \"error\": %d}", i ? ", " : "", r->job.err[i].line, r->job.err[i].code);
    fprintf(f, "],\n  \"alarms\": %lu,\n  \"alarm\": ", r->job.alarms);
    json_str(f, r->job.alarms ? pk_sim_alarm_name(r->job.alarm) : "");
    fputs(",\n  \"alarm_text\": ", f);
    json_str(f, r->job.alarm_text);
    fprintf(f, ",\n  \"pin_edges\": %zu,\n  \"vm_hwm_kb\": %ld\n}\n", r->hw.trace.n, vm_hwm_kb());
}

/* ---- the program: a G-code file is mapped and its pages let go as the job
 * reads on, so memory stays flat whatever its size; a polyline file (small,
 * hand-made) or stdin is read whole --------------------------------------- */
struct input {
    char *heap;          /* read into memory (stdin, polyline files), or NULL */
    char *map;           /* mapped file, or NULL */
    size_t len, released;
};

#define INPUT_RELEASE_BYTES ((size_t)4 << 20)

static void input_read(void *arg, size_t pos)
{
    struct input *in = arg;
    if (in->map == NULL || pos < in->released + INPUT_RELEASE_BYTES)
        return;
    size_t page = (size_t)sysconf(_SC_PAGESIZE);
    size_t upto = pos / page * page;
    if (upto > in->released) {
        (void)madvise(in->map + in->released, upto - in->released, MADV_DONTNEED);
        in->released = upto;
    }
}

/* Is the first line that says anything two numbers (a polyline file)? */
static int looks_like_polyline(const char *p, size_t n)
{
    size_t i = 0;
    while (i < n) {
        size_t e = i;
        while (e < n && p[e] != '\n')
            e++;
        size_t k = i;
        while (k < e && (p[k] == ' ' || p[k] == '\t' || p[k] == '\r'))
            k++;
        if (k < e && p[k] != '#') {
            char buf[128];
            size_t m = e - k < sizeof buf - 1 ? e - k : sizeof buf - 1;
            memcpy(buf, p + k, m);
            buf[m] = '\0';
            char *e1, *e2;
            (void)strtod(buf, &e1);
            if (e1 == buf)
                return 0;
            (void)strtod(e1, &e2);
            return e2 != e1;
        }
        i = e + 1;
    }
    return 0;
}

static int input_open(struct input *in, const char *path)
{
    memset(in, 0, sizeof *in);
    if (strcmp(path, "-") != 0) {
        int fd = open(path, O_RDONLY);
        struct stat sb;
        if (fd < 0)
            return -1;
        if (fstat(fd, &sb) == 0 && S_ISREG(sb.st_mode) && sb.st_size > 0) {
            void *m = mmap(NULL, (size_t)sb.st_size, PROT_READ, MAP_PRIVATE, fd, 0);
            if (m != MAP_FAILED) {
                in->map = m;
                in->len = (size_t)sb.st_size;
                (void)madvise(m, in->len, MADV_SEQUENTIAL);
                close(fd);
                if (!looks_like_polyline(in->map, in->len))
                    return 0;
                munmap(in->map, in->len);
                in->map = NULL;
            } else {
                close(fd);
            }
        } else {
            close(fd);
        }
    }
    in->heap = read_all(path, &in->len);
    return in->heap != NULL ? 0 : -1;
}

static void input_close(struct input *in)
{
    if (in->map != NULL)
        munmap(in->map, in->len);
    free(in->heap);
    memset(in, 0, sizeof *in);
}

int cmd_sim(int argc, char **argv)
{
    const char *file = NULL, *svg = NULL, *trace = NULL, *config = NULL, *driver = "drv8825";
    int json = 0, exact = 0, laser = 0;
    double tol = -1.0, feed = -1.0, svg_tol = 0.01, pen_z = NAN;
    int axes_opt = 0, use_fault = 0, hard_limits = 0, lower_bound = 0;
    static struct pk_sim_inputs inputs;
    static struct pk_gpiod_mock fault;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            printf(sim_usage, pk_sim_inputs_usage);
            return 0;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--exact")) {
            exact = 1;
        } else if (!strcmp(a, "--lower-bound")) {
            lower_bound = 1;
        } else if (!strcmp(a, "--svg") && more) {
            svg = argv[++i];
        } else if (!strcmp(a, "--trace") && more) {
            trace = argv[++i];
        } else if (!strcmp(a, "--config") && more) {
            config = argv[++i];
        } else if (!strcmp(a, "--driver") && more) {
            driver = argv[++i];
        } else if (!strcmp(a, "--tolerance") && more) {
            tol = strtod(argv[++i], NULL);
        } else if (!strcmp(a, "--feed") && more) {
            feed = strtod(argv[++i], NULL);
        } else if (!strcmp(a, "--svg-tolerance") && more) {
            svg_tol = strtod(argv[++i], NULL);
            if (!(svg_tol > 0.0)) {
                fprintf(stderr, "plotkin sim: --svg-tolerance takes a positive number of mm\n");
                return 2;
            }
        } else if (!strcmp(a, "--pen-z") && more) {
            char *end;
            pen_z = strtod(argv[++i], &end);
            if (*end != '\0' || !isfinite(pen_z)) {
                fprintf(stderr, "plotkin sim: --pen-z takes a height in mm\n");
                return 2;
            }
        } else if (!strcmp(a, "--laser")) {
            laser = 1;
        } else if (!strcmp(a, "--inject") && more) {
            const char *v = argv[++i];
            if (!strcmp(v, "open"))
                fault.fail_open_errno = ENODEV;
            else if (!strncmp(v, "request:", 8) && atoi(v + 8) > 0)
                fault.fail_request_nth = (uint32_t)atoi(v + 8);
            else if (!strncmp(v, "set:", 4) && atoi(v + 4) > 0)
                fault.fail_set_nth = (uint32_t)atoi(v + 4);
            else {
                fprintf(stderr, "plotkin sim: --inject takes open, request:N or set:N\n");
                return 2;
            }
            use_fault = 1;
        } else if ((!strcmp(a, "--input") || !strcmp(a, "--switch")) && more) {
            char ierr[160];
            if (pk_sim_inputs_add(&inputs, a, argv[++i], ierr, sizeof ierr) != 0) {
                fprintf(stderr, "plotkin sim: %s\n", ierr);
                return 2;
            }
        } else if (!strcmp(a, "--hard-limits")) {
            hard_limits = 1;
        } else if (!strcmp(a, "--axes") && more) {
            axes_opt = atoi(argv[++i]);
        } else if (a[0] == '-' && a[1] != '\0') {
            fprintf(stderr, "plotkin sim: unknown or incomplete option '%s'\n\n", a);
            fprintf(stderr, sim_usage, pk_sim_inputs_usage);
            return 2;
        } else if (file == NULL) {
            file = a;
        } else {
            fprintf(stderr, "plotkin sim: one FILE only\n");
            return 2;
        }
    }
    if (file == NULL) {
        fprintf(stderr, sim_usage, pk_sim_inputs_usage);
        return 2;
    }
    struct pk_timing_limits lim;
    if (!strcmp(driver, "drv8825"))
        lim = (struct pk_timing_limits)PK_TIMING_DRV8825;
    else if (!strcmp(driver, "a4988"))
        lim = (struct pk_timing_limits){ 1000u, 1000u, 200u, 200u };
    else if (!strcmp(driver, "tmc2209"))
        lim = (struct pk_timing_limits){ 100u, 100u, 20u, 20u };
    else {
        fprintf(stderr, "plotkin sim: unknown driver '%s' (drv8825, a4988, tmc2209)\n", driver);
        return 2;
    }

    static struct pk_sim_cfg cfg;
    char err[200];
    pk_sim_cfg_default(&cfg);
    if (config != NULL) {
        size_t n;
        char *text = read_all(config, &n);
        if (text == NULL) {
            fprintf(stderr, "plotkin sim: %s: %s\n", config, strerror(errno));
            return 2;
        }
        int rc = pk_sim_cfg_parse(&cfg, text, err, sizeof err, stderr);
        free(text);
        if (rc != 0) {
            fprintf(stderr, "plotkin sim: %s: %s\n", config, err);
            return 2;
        }
    }
    if (exact) {
        cfg.smooth_mode = PK_SMOOTH_OFF;
        cfg.force_smoothing = 1;
    }
    if (tol >= 0.0) {
        cfg.force_smoothing = 1;
        cfg.smooth_mode = tol > 0.0 ? PK_SMOOTH_TOLERANCE : PK_SMOOTH_OFF;
        if (tol > 0.0)
            cfg.tolerance = tol;
    }
    if (feed > 0.0)
        cfg.polyline_feed = feed;
    if (axes_opt != 0)
        cfg.axes = (unsigned)axes_opt;
    if (laser)
        cfg.laser_mode = 1;
    if (!isnan(pen_z)) {
        cfg.pen_z_on = 1;
        cfg.pen_z_mm = pen_z;
    }

    static struct input in;
    if (input_open(&in, file) != 0) {
        fprintf(stderr, "plotkin sim: %s: %s\n", file, strerror(errno ? errno : EIO));
        return 2;
    }
    const char *text = in.map != NULL ? in.map : in.heap;
    size_t len = in.len;
    char *gcode = NULL;
    if (in.heap != NULL) {
        int is_poly = 0;
        gcode = pk_sim_polyline_to_gcode(in.heap, cfg.polyline_feed, &is_poly);
        if (gcode != NULL) {
            text = gcode;
            len = strlen(text);
        }
    }

    static struct pk_sim_result r;
    static struct pk_svg drawing;
    struct pk_sim_opts o = { .chip = "plotkin-sim0", .cfg = &cfg, .program = text, .len = len,
                             .lim = lim, .progress = isatty(2) ? stderr : NULL,
                             .input_read = input_read, .input_arg = &in };
    if (svg != NULL) {
        if (pk_svg_open(&drawing, svg_tol * 1000.0) != 0) {
            fprintf(stderr, "plotkin sim: no temporary file for the drawing: %s\n", strerror(errno));
            input_close(&in);
            free(gcode);
            return 2;
        }
        o.svg = &drawing;
    }
    if (use_fault)
        o.fault = &fault;
    pk_sim_inputs_resolve(&inputs, cfg.tick_hz, cfg.steps_per_mm);
    o.inputs = inputs.in;
    o.n_inputs = inputs.n;
    o.hard_limits = hard_limits;
    o.lower_bound = lower_bound;
    FILE *tf = NULL;
    if (trace != NULL) {
        tf = fopen(trace, "w");
        if (tf == NULL) {
            fprintf(stderr, "plotkin sim: cannot write %s: %s\n", trace, strerror(errno));
            if (svg != NULL)
                pk_svg_discard(&drawing);
            input_close(&in);
            free(gcode);
            return 2;
        }
        o.trace_csv = tf;
    }
    int rc = pk_sim_run(&o, &r);
    int status = 0;
    if (rc != 0) {
        fprintf(stderr, "plotkin sim: %s\n", r.err);
        status = 1;
    } else {
        unsigned axes = cfg.axes;
        if (json)
            print_json(stdout, file, &r, axes);
        else
        {
            printf("plotkin sim: %s\n", file);
            pk_sim_print_summary(stdout, &r, axes, &cfg, driver);
        }
        const char *base = strrchr(file, '/') ? strrchr(file, '/') + 1 : file;
        if (svg != NULL && pk_svg_close(&drawing, svg, base) != 0) {
            fprintf(stderr, "plotkin sim: cannot write %s: %s\n", svg, strerror(errno));
            status = 1;
        }
        svg = NULL;
        if (tf != NULL && (ferror(tf) || fclose(tf) != 0)) {
            fprintf(stderr, "plotkin sim: cannot write %s: %s\n", trace, strerror(errno));
            status = 1;
        }
        tf = NULL;
        if (r.job.alarms || r.job.errors || r.dec.n_viol || r.run_status != PK_SIM_RUN_FINISHED)
            status = status ? status : 1;
    }
    if (tf != NULL)
        fclose(tf);
    if (svg != NULL)
        pk_svg_discard(&drawing);
    pk_sim_result_free(&r);
    input_close(&in);
    free(gcode);
    return status;
}
