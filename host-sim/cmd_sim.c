/*
 * cmd_sim.c — `plotkin sim FILE`: run a G-code program or a plain polyline
 * through the whole firmware in the simulator and report what the machine
 * did (see `plotkin sim --help`).
 */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>
#include "commands.h"
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
    "  --svg OUT        draw the commanded path (wide, light) and the executed path\n"
    "                   decoded from the step pulses (thin, dark); pen-up moves dashed\n"
    "  --trace OUT.csv  write every pin edge (tick, time, signal, raw level)\n"
    "  --config FILE    machine settings, Grbl-style `$N=value` lines (as `$$` prints):\n"
    "                   $0 step pulse us, $11 junction deviation mm, $12 tolerance mm,\n"
    "                   $100-102 steps/mm, $110-112 max rate mm/min, $120-122 accel mm/s^2,\n"
    "                   $130-132 travel mm, $200 smoothing 0 off/1 fixed/2 tolerance,\n"
    "                   $201 scheme 0 B-spline/1 DLG, $202 degree, $203 depth,\n"
    "                   $204 sharp corner deg, $205 pen settle ms, $206 dir set-up us\n"
    "  --axes N         axes driven, 2 or 3 (default 3)\n"
    "  --exact          no smoothing (like G61); --tolerance MM: smoothing within MM;\n"
    "                   either overrides G61/G64 in the program\n"
    "  --driver NAME    timing limits checked: drv8825 (default), a4988, tmc2209\n"
    "  --feed F         feed for polyline files, mm/min (default 3000)\n"
    "  --inject FAULT   make the mock GPIO chip fail: open, request:N (the Nth line\n"
    "                   request), set:N (the Nth write) - to see how the firmware copes\n"
    "\n"
    "Speeds and accelerations are estimated per axis from the decoded step times\n"
    "over runs of 16 steps (cornering shows as acceleration, as on the machine).\n"
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

static void print_json(FILE *f, const char *file, const struct pk_sim_result *r, unsigned axes)
{
    double fmm[PK_AXES], v[PK_AXES];
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
    fprintf(f, ",\n  \"sim_time_s\": %.6f,\n", (double)r->ticks / (double)r->hw.sched.tick_hz);
    fputs("  \"max_speed_mm_s\": ", f);
    json_arr_d(f, r->max_speed_mm_s, axes, "%.3f");
    fputs(",\n  \"max_accel_mm_s2\": ", f);
    json_arr_d(f, r->max_accel_mm_s2, axes, "%.1f");
    fprintf(f, ",\n  \"max_deviation_mm\": %.4f,\n", r->deviation_um / 1000.0);
    fprintf(f, "  \"timing_violations\": %zu,\n  \"violations\": [", r->dec.n_viol);
    for (size_t i = 0; i < r->dec.n_viol; i++) {
        const struct pk_violation *vi = &r->dec.viol[i];
        fprintf(f, "%s\n    {\"tick\": %llu, \"axis\": \"%c\", \"kind\": \"%s\", \"got_ns\": %llu, \"min_ns\": %u}",
                i ? "," : "", (unsigned long long)vi->t, "XYZA"[vi->axis & 3u],
                pk_violation_name((enum pk_violation_kind)vi->kind), (unsigned long long)vi->got_ns,
                (unsigned)vi->limit_ns);
    }
    fprintf(f, "%s],\n  \"errors\": %lu,\n  \"error_lines\": [", r->dec.n_viol ? "\n  " : "", r->job.errors);
    size_t ne = r->job.errors < 32u ? r->job.errors : 32u;
    for (size_t i = 0; i < ne; i++)
        fprintf(f, "%s{\"line\": %u, \"error\": %d}", i ? ", " : "", r->job.err[i].line, r->job.err[i].code);
    fprintf(f, "],\n  \"alarms\": %lu,\n  \"alarm\": ", r->job.alarms);
    json_str(f, r->job.alarms ? pk_sim_alarm_name(r->job.alarm) : "");
    fputs(",\n  \"alarm_text\": ", f);
    json_str(f, r->job.alarm_text);
    fprintf(f, ",\n  \"pin_edges\": %zu\n}\n", r->hw.trace.n);
    (void)v;
}

/* ---- SVG ------------------------------------------------------------------ */
struct bbox { double x0, y0, x1, y1; };

static void bb_add(struct bbox *b, double x, double y)
{
    if (x < b->x0) b->x0 = x;
    if (y < b->y0) b->y0 = y;
    if (x > b->x1) b->x1 = x;
    if (y > b->y1) b->y1 = y;
}

static int write_svg(const char *path, const struct pk_sim_result *r, const char *title)
{
    FILE *f = fopen(path, "w");
    if (f == NULL)
        return -1;
    const struct pk_sim_job *j = &r->job;
    struct bbox b = { INFINITY, INFINITY, -INFINITY, -INFINITY };
    for (size_t i = 0; i < j->n_moves; i++) {
        bb_add(&b, j->moves[i].a[0] / 1000.0, j->moves[i].a[1] / 1000.0);
        bb_add(&b, j->moves[i].b[0] / 1000.0, j->moves[i].b[1] / 1000.0);
    }
    if (!isfinite(b.x0)) {
        b = (struct bbox){ 0, 0, 10, 10 };
    }
    double m = 0.05 * fmax(b.x1 - b.x0, b.y1 - b.y0) + 2.0;
    double w = b.x1 - b.x0 + 2 * m, h = b.y1 - b.y0 + 2 * m;
    double sw = fmax(w, h) / 400.0; /* stroke width scale */
    fprintf(f, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0fmm\" height=\"%.0fmm\" "
               "viewBox=\"%.3f %.3f %.3f %.3f\">\n",
            fmin(w, 300.0), fmin(w, 300.0) * h / w, b.x0 - m, -(b.y1 + m), w, h + 3 * sw * 6);
    fprintf(f, "<title>%s</title>\n<rect x=\"%.3f\" y=\"%.3f\" width=\"%.3f\" height=\"%.3f\" fill=\"white\"/>\n",
            title, b.x0 - m, -(b.y1 + m), w, h + 3 * sw * 6);
    /* commanded path: pen-up moves dashed (drawn first, underneath), pen-down solid */
    fprintf(f, "<g fill=\"none\" stroke=\"#8ab4f8\" stroke-width=\"%.3f\" stroke-linecap=\"round\" "
               "stroke-linejoin=\"round\">\n", 3 * sw);
    for (int pass = 0; pass < 2; pass++) {
        int open = 0;
        for (size_t i = 0; i < j->n_moves; i++) {
            const struct pk_sim_move *mv = &j->moves[i];
            int down = mv->pen && !mv->rapid;
            if (down != (pass == 1)) {
                if (open)
                    fputs("\"/>\n", f);
                open = 0;
                continue;
            }
            if (!open) {
                fprintf(f, "<path %sd=\"M%.3f %.3f",
                        pass ? "" : "stroke=\"#c6dafc\" stroke-dasharray=\"4 3\" stroke-width=\"1\" ",
                        mv->a[0] / 1000.0, -mv->a[1] / 1000.0);
                open = 1;
            }
            fprintf(f, " L%.3f %.3f", mv->b[0] / 1000.0, -mv->b[1] / 1000.0);
        }
        if (open)
            fputs("\"/>\n", f);
    }
    fputs("</g>\n", f);
    /* executed path from the decoded steps (thinned to 0.1 mm): pen up
     * dotted and underneath, then pen down */
    fprintf(f, "<g fill=\"none\" stroke=\"#202124\" stroke-width=\"%.3f\" stroke-linejoin=\"round\">\n", sw);
    for (int pass = 0; pass < 2; pass++) {
        int open = 0;
        for (size_t i = 0; i < r->n_path; i++) {
            const struct pk_sim_path_pt *pt = &r->path[i];
            if (pt->pen != pass) {
                if (open)
                    fputs("\"/>\n", f);
                open = 0;
                continue;
            }
            if (!open)
                fprintf(f, "<path %sd=\"M%.3f %.3f",
                        pass ? "" : "stroke=\"#9aa0a6\" stroke-dasharray=\"1 1.5\" ",
                        pt->x_um / 1000.0, -pt->y_um / 1000.0);
            else
                fprintf(f, " L%.3f %.3f", pt->x_um / 1000.0, -pt->y_um / 1000.0);
            open = 1;
        }
        if (open)
            fputs("\"/>\n", f);
    }
    fputs("</g>\n", f);
    fprintf(f, "<text x=\"%.3f\" y=\"%.3f\" font-family=\"sans-serif\" font-size=\"%.3f\" fill=\"#5f6368\">"
               "%s: commanded (light, pen-up dashed) vs executed from decoded steps (dark)</text>\n",
            b.x0 - m + sw * 4, -(b.y0 - m) + sw * 12, sw * 9, title);
    fputs("</svg>\n", f);
    return fclose(f) == 0 ? 0 : -1;
}

int cmd_sim(int argc, char **argv)
{
    const char *file = NULL, *svg = NULL, *trace = NULL, *config = NULL, *driver = "drv8825";
    int json = 0, exact = 0;
    double tol = -1.0, feed = -1.0;
    int axes_opt = 0, use_fault = 0;
    static struct pk_gpiod_mock fault;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            fputs(sim_usage, stdout);
            return 0;
        } else if (!strcmp(a, "--json")) {
            json = 1;
        } else if (!strcmp(a, "--exact")) {
            exact = 1;
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
        } else if (!strcmp(a, "--axes") && more) {
            axes_opt = atoi(argv[++i]);
        } else if (a[0] == '-' && a[1] != '\0') {
            fprintf(stderr, "plotkin sim: unknown or incomplete option '%s'\n\n%s", a, sim_usage);
            return 2;
        } else if (file == NULL) {
            file = a;
        } else {
            fprintf(stderr, "plotkin sim: one FILE only\n");
            return 2;
        }
    }
    if (file == NULL) {
        fputs(sim_usage, stderr);
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

    /* The program is streamed (a file of any size runs in bounded memory);
     * the job detects a polyline file itself. */
    FILE *pf = strcmp(file, "-") == 0 ? stdin : fopen(file, "rb");
    if (pf == NULL) {
        fprintf(stderr, "plotkin sim: %s: %s\n", file, strerror(errno ? errno : EIO));
        return 2;
    }

    static struct pk_sim_result r;
    struct pk_sim_opts o = { .chip = "plotkin-sim0", .cfg = &cfg, .program_file = pf,
                             .lim = lim, .progress = isatty(2) ? stderr : NULL };
    if (use_fault)
        o.fault = &fault;
    FILE *tf = NULL;
    if (trace != NULL) {
        tf = fopen(trace, "w");
        if (tf == NULL) {
            fprintf(stderr, "plotkin sim: cannot write %s: %s\n", trace, strerror(errno));
            if (pf != stdin)
                fclose(pf);
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
        if (svg != NULL && write_svg(svg, &r, base) != 0) {
            fprintf(stderr, "plotkin sim: cannot write %s: %s\n", svg, strerror(errno));
            status = 1;
        }
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
    pk_sim_result_free(&r);
    if (pf != stdin)
        fclose(pf);
    return status;
}
