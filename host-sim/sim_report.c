/*
 * sim_report.c — the summary of a simulated run, as `plotkin sim` prints it
 * and `plotkin serve` prints it on exit (see sim_report.h).
 */
#include "sim_report.h"

const char *pk_sim_alarm_name(int a)
{
    switch (a) {
    case PK_ALARM_STEP_WRITE: return "step write failed";
    case PK_ALARM_DIR_WRITE: return "direction write failed";
    case PK_ALARM_TOOL_WRITE: return "pen write failed";
    case PK_ALARM_TIMER: return "timer start failed";
    case PK_ALARM_INTERNAL: return "internal error";
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

void pk_sim_print_summary(FILE *f, const struct pk_sim_result *r, unsigned axes,
                          const struct pk_sim_cfg *c, const char *driver)
{
    static const char an[] = "XYZA";
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
        fprintf(f, "%c %llu  ", an[a], (unsigned long long)r->dec.steps[a]);
    fprintf(f, "\n  final position    ");
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%c %lld steps = %.4f mm  ", an[a], (long long)r->dec.pos[a],
                pk_sim_steps_to_um(r, a, r->dec.pos[a]) / 1000.0);
    fprintf(f, "\n  simulated time    %.3f s\n", (double)r->ticks / (double)r->hw.sched.tick_hz);
    fprintf(f, "  max speed         ");
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%c %.1f mm/s  ", an[a], r->max_speed_mm_s[a]);
    fprintf(f, "\n  max acceleration  ");
    for (unsigned a = 0; a < axes; a++)
        fprintf(f, "%c %.0f mm/s^2  ", an[a], r->max_accel_mm_s2[a]);
    fprintf(f, "(per axis over 16 steps: junction speed jumps count too)");
    if (r->deviation_um >= 0.0)
        fprintf(f, "\n  path deviation    %.4f mm (executed steps vs the programmed polyline: with "
                   "smoothing on, this includes the intended rounding of corners)",
                r->deviation_um / 1000.0);
    fprintf(f, "\n  timing violations %zu (%s limits)\n", r->dec.n_viol, driver);
    size_t show = r->dec.n_viol < 20u ? r->dec.n_viol : 20u;
    for (size_t i = 0; i < show; i++) {
        const struct pk_violation *v = &r->dec.viol[i];
        fprintf(f, "    t=%.6f s %c %s: %llu ns < %u ns\n", (double)v->t / (double)r->hw.sched.tick_hz,
                an[v->axis & 3u], pk_violation_name((enum pk_violation_kind)v->kind),
                (unsigned long long)v->got_ns, (unsigned)v->limit_ns);
    }
    if (r->dec.n_viol > show)
        fprintf(f, "    ... and %zu more (--json lists them all)\n", r->dec.n_viol - show);
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

