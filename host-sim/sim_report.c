/*
 * sim_report.c — the summary of a simulated run, as `plotkin sim` prints it
 * and `plotkin serve` prints it on exit (see sim_report.h).
 */
#include <math.h>
#include "sim_report.h"

static const char axis_name[] = "XYZA";

const char *pk_sim_alarm_name(int a)
{
    switch (a) {
    case PK_ALARM_STEP_WRITE: return "step write failed";
    case PK_ALARM_DIR_WRITE: return "direction write failed";
    case PK_ALARM_TOOL_WRITE: return "pen write failed";
    case PK_ALARM_TIMER: return "timer start failed";
    case PK_ALARM_INTERNAL: return "internal error";
    case PK_ALARM_SPINDLE_WRITE: return "spindle write failed";
    case PK_ALARM_HARD_LIMIT: return "hard limit";
    case PK_ALARM_INPUT_READ: return "input read failed";
    default: return "none";
    }
}

const char *pk_sim_run_status_name(int s)
{
    if (s < 0)
        return "stopped (session ended, the machine was still live)";
    switch (s) {
    case PK_SIM_RUN_FINISHED: return "finished";
    case PK_SIM_RUN_TIME_LIMIT: return "simulated time limit reached";
    case PK_SIM_RUN_STUCK: return "stuck: the firmware stopped making progress";
    case PK_SIM_RUN_RUNAWAY: return "timer callback never advances";
    default: return "critical section left open";
    }
}

/* "X 67.4 mm/s (>= 66.9)  Y ..." for one figure of every axis. */
static void per_axis(FILE *f, const struct pk_sim_result *r, unsigned axes, int which, const char *fmt,
                     const char *unit)
{
    for (unsigned a = 0; a < axes && a < PK_AXES; a++) {
        const struct pk_rate *e = &r->rate[a];
        double v, lo;
        if (which == 0) {
            v = e->speed16.vmax.v;
            lo = e->speed16.lo_max;
        } else if (which == 1) {
            v = e->speed2.vmax.v;
            lo = e->speed2.lo_max;
        } else if (which == 2) {
            v = fabs(e->accel.amax.a);
            lo = e->accel.lo_abs_max;
        } else {
            v = e->accel_proven.lo_abs_max;
            lo = -1.0;
        }
        fprintf(f, "%c ", axis_name[a]);
        if (lo < 0.0)
            fputs(">= ", f);
        fprintf(f, fmt, v);
        fprintf(f, " %s", unit);
        if (lo >= 0.0) {
            fputs(" (>= ", f);
            fprintf(f, fmt, lo);
            fputc(')', f);
        }
        fputs("  ", f);
    }
}

/* Axes whose motion provably broke a limit (beyond the step quantisation). */
static void limits_line(FILE *f, const struct pk_sim_result *r, unsigned axes)
{
    int any = 0;
    fprintf(f, "  limits            ");
    for (unsigned a = 0; a < axes && a < PK_AXES; a++) {
        const struct pk_rate *e = &r->rate[a];
        double vl = e->cfg.v_limit, al = e->cfg.a_limit;
        double v = fmax(e->speed16.lo_max, e->speed2.lo_max);
        if (pk_rate_over_speed(e)) {
            fprintf(f, "%s%c over its max rate %.1f mm/s by at least %.0f%%", any ? "; " : "", axis_name[a], vl,
                    100.0 * (v / vl - 1.0));
            any = 1;
        }
        if (pk_rate_over_accel(e)) {
            fprintf(f, "%s%c over its acceleration %.0f mm/s^2 by at least %.0f%% over 20 ms", any ? "; " : "",
                    axis_name[a], al, 100.0 * (e->accel.lo_abs_max / al - 1.0));
            any = 1;
        }
        if (pk_rate_speed_jumps(e)) {
            fprintf(f, "%s%c speed jumps: %.0f%% over its acceleration in windows of 2-64 steps", any ? "; " : "",
                    axis_name[a], 100.0 * (e->accel_proven.lo_abs_max / al - 1.0));
            any = 1;
        }
    }
    if (!any)
        fprintf(f, "every axis within its max rate and acceleration (allowing for step quantisation)");
    fputc('\n', f);
}

static void deviation_line(FILE *f, const char *label, const struct pk_path *p, double tick_hz)
{
    const struct pk_path_stats *s = &p->st;
    char lines[48];
    if (s->max_line_last > s->max_line)
        snprintf(lines, sizeof lines, "lines %u-%u", (unsigned)s->max_line, (unsigned)s->max_line_last);
    else
        snprintf(lines, sizeof lines, "line %u", (unsigned)s->max_line);
    fprintf(f, "  %-17s max %.4f mm at X%.3f Y%.3f Z%.3f (t=%.3f s, %s, %s); 95%% within %.4f mm\n", label,
            s->max_um / 1000.0, s->max_at_um[0] / 1000.0, s->max_at_um[1] / 1000.0, s->max_at_um[2] / 1000.0,
            (double)s->max_tick / tick_hz, lines, s->max_drawn ? "stroke" : "travel",
            pk_path_quantile(p, 0.95) / 1000.0);
    if (s->approx_um > 0.0)
        fprintf(f, "                    (the window ran short of room: straight runs were held within %.4f mm, "
                   "so are these figures)\n",
                s->approx_um / 1000.0);
    if (s->forced_drops > 0u)
        fprintf(f, "                    (%llu primitives left the window before the machine was past them: "
                   "these are upper bounds)\n",
                (unsigned long long)s->forced_drops);
}

void pk_sim_print_summary(FILE *f, const struct pk_sim_result *r, unsigned axes,
                          const struct pk_sim_cfg *c, const char *driver)
{
    const double hz = (double)r->hw.sched.tick_hz;
    if (c->smooth_mode == PK_SMOOTH_OFF)
        fprintf(f, "  smoothing         off (exact path)\n");
    else if (c->smooth_mode == PK_SMOOTH_TOLERANCE)
        fprintf(f, "  smoothing         within %.3f mm, corners over %u deg kept sharp\n", c->tolerance,
                c->sharp_deg);
    else
        fprintf(f, "  smoothing         fixed: degree %u, depth %u\n", c->degree, c->depth);
    fprintf(f, "  run               %s\n", pk_sim_run_status_name(r->run_status));
    fprintf(f, "  lines             %lu\n", r->job.lines);
    fprintf(f, "  moves             %lu requested, %lu segments executed\n", r->job.move_requests,
            r->job.segments);
    fprintf(f, "  steps             ");
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%c %llu  ", axis_name[a], (unsigned long long)r->dec.steps[a]);
    fprintf(f, "\n  final position    ");
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%c %lld steps = %.4f mm  ", axis_name[a], (long long)r->dec.pos[a],
                pk_sim_steps_to_um(r, a, r->dec.pos[a]) / 1000.0);
    fprintf(f, "\n  simulated time    %.3f s\n", (double)r->ticks / hz);
    if (r->opts.lower_bound && r->lower_bound_s > 0.0)
        fprintf(f, "  lower bound       %.3f s (any path within the tolerance; this run %.3fx)\n",
                r->lower_bound_s, (double)r->ticks / hz / r->lower_bound_s);
    else if (r->opts.lower_bound)
        fprintf(f, "  lower bound       not computed (%s)\n", r->lower_bound_s < 0.0 ? "out of memory" : "no motion");
    fprintf(f, "  max speed         ");
    per_axis(f, r, axes, 0, "%.1f", "mm/s");
    fprintf(f, "over any 16 steps\n  max step rate     ");
    per_axis(f, r, axes, 1, "%.1f", "mm/s");
    fprintf(f, "over any 2 steps\n  max acceleration  ");
    per_axis(f, r, axes, 2, "%.0f", "mm/s^2");
    fprintf(f, "between windows of >= 16 steps and >= 20 ms\n  peak acceleration ");
    per_axis(f, r, axes, 3, "%.0f", "mm/s^2");
    fprintf(f, "proven by windows of 2 to 64 steps\n");
    fprintf(f, "                    (>= : the least the motion behind the steps can have reached, given "
               "their quantisation; a junction's speed jump counts as acceleration)\n");
    limits_line(f, r, axes);
    if (r->prog.st.points > 0u) {
        deviation_line(f, "path deviation", &r->prog, hz);
        fprintf(f, "                    (each decoded step position vs the programmed path; lines, arcs "
                   "and G5 curves exact: with smoothing on, this includes the rounding of corners)\n");
    }
    if (r->ref_on && r->ref.st.points > 0u)
        deviation_line(f, "vs smoothed curve", &r->ref, hz);
    fprintf(f, "  timing violations %zu (%s limits)\n", r->dec.n_viol, driver);
    size_t kept = r->dec.n_viol < PK_VIOL_KEEP ? r->dec.n_viol : PK_VIOL_KEEP;
    size_t show = kept < 20u ? kept : 20u;
    for (size_t i = 0; i < show; i++) {
        const struct pk_violation *v = &r->dec.viol[i];
        fprintf(f, "    t=%.6f s %c %s: %llu ns < %u ns\n", (double)v->t / hz, axis_name[v->axis & 3u],
                pk_violation_name((enum pk_violation_kind)v->kind), (unsigned long long)v->got_ns,
                (unsigned)v->limit_ns);
    }
    if (r->dec.n_viol > show)
        fprintf(f, "    ... and %zu more (--json lists the first %u)\n", r->dec.n_viol - show, PK_VIOL_KEEP);
    fprintf(f, "  errors            %lu\n", r->job.errors);
    size_t ne = r->job.errors < 32u ? r->job.errors : 32u;
    for (size_t i = 0; i < ne; i++)
        fprintf(f, "    line %u: error:%d\n", r->job.err[i].line, r->job.err[i].code);
    fprintf(f, "  alarms            %lu", r->job.alarms);
    if (r->job.alarms)
        fprintf(f, " (%s%s%s)", pk_sim_alarm_name(r->job.alarm), r->job.alarm_text[0] ? ": " : "",
                r->job.alarm_text);
    fputc('\n', f);
}
