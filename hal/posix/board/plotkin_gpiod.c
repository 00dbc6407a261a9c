/*
 * plotkin_gpiod.c — the firmware on a Linux board: `plotkin-gpiod`.
 *
 * The motion core on real GPIO lines through libgpiod (hal/gpiod/, linked
 * with -lgpiod) and on real time (hal/posix/), in one of two ways:
 *   - FILE: play a G-code (or polyline) file through the same job code as
 *     `plotkin sim`;
 *   - serve: the Grbl 1.1 engine (hal/pk_app.h: the controller every board
 *     image runs, the same engine as `plotkin serve`) on a serial line, so
 *     a G-code sender (cncjs, UGS, stream.py; over the network through
 *     socat/ser2net) streams to the plotter: a pseudo-terminal with a stable
 *     symlink (--link), or a serial device such as /dev/ttyAMA0 at 115200 8N1
 *     raw (--device). The serial side is hal/posix/pk_serve_port.h, shared
 *     with the simulator's serve: Grbl greeting, character counting against
 *     the 128-byte receive ring, realtime bytes ? ! ~ Ctrl-X claimed on
 *     arrival, a client that vanishes (pty closed) loses nothing accepted.
 * Built by `make board-gpiod`; this file is outside the wildcard source
 * lists so the simulator never links it, and the board never links the
 * libgpiod mock. Compiled with -DPLOTKIN_GPIOD_MOCK it is the test variant
 * build/plotkin-gpiod-mock instead (board_mock.h: an in-memory chip that
 * records every edge on the real clock, --mock-trace FILE).
 *
 *   plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime|--no-realtime] FILE
 *   plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime|--no-realtime]
 *                 serve (--link PATH | --device PATH [--baud N])
 *
 * Real time: by default the process asks for SCHED_FIFO and locked memory
 * and, where that is refused (no root / CAP_SYS_NICE, CAP_IPC_LOCK, as in a
 * container), says so in one line and runs with ordinary scheduling (step
 * timing then jitters with the load). --realtime makes it a requirement (a
 * refusal is an error, exit 1); --no-realtime does not ask.
 * BOARD.conf is the wiring (hal/gpiod/pk_gpiod.h, e.g.
 * hal/gpiod/rpi-plotter.conf); MACHINE.conf the `$N=value` settings.
 * SIGINT/SIGTERM stop the motion at once (like Grbl's reset) and release the
 * lines.
 */
#include <errno.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "gpiod/pk_gpiod.h"
#include "pk_app.h"
#include "posix/pk_posix_timer.h"
#include "posix/pk_serve_port.h"
#include "sim_job.h"
#ifdef PLOTKIN_GPIOD_MOCK
#include "board_mock.h"
#endif

static volatile sig_atomic_t stop_requested; /* set by the signal handler only */

static void on_signal(int sig)
{
    (void)sig;
    stop_requested = 1;
}

/* pk_posix_run polls an int; the handler writes a sig_atomic_t: copy. */
static volatile int run_stop;

static const char usage_text[] =
    "usage: plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime|--no-realtime] FILE\n"
    "       plotkin-gpiod --board BOARD.conf [--config MACHINE.conf] [--realtime|--no-realtime]\n"
    "                     serve (--link PATH | --device PATH [--baud N])\n"
#ifdef PLOTKIN_GPIOD_MOCK
    "       (test build: --mock-trace FILE writes every edge of the mock chip)\n"
#endif
    ;

/* The loop's edge source: the input lines' events (limit switches, probe).
 * A failing event read leaves the inputs unwatched: stop the run. */
static int edges_failed;
static void edge_poll(void *arg)
{
    struct pk_gpiod *g = arg;
    if (!edges_failed && pk_gpiod_input_service(g) < 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", pk_gpiod_error_text(g));
        edges_failed = 1;
        run_stop = 1;
    }
    if (stop_requested)
        run_stop = 1;
}

static char *slurp(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL)
        return NULL;
    size_t cap = 4096, n = 0;
    char *b = malloc(cap + 1);
    for (;;) {
        if (b == NULL)
            break;
        n += fread(b + n, 1, cap - n, f);
        if (n < cap)
            break;
        char *nb = realloc(b, cap * 2 + 1);
        if (nb == NULL) {
            free(b);
            b = NULL;
            break;
        }
        b = nb;
        cap *= 2;
    }
    fclose(f);
    if (b != NULL)
        b[n] = '\0';
    return b;
}

/* ---- options ---------------------------------------------------------------- */

enum rt_mode { RT_OFF, RT_TRY, RT_REQUIRE };

struct opts {
    const char *board, *config, *file;
    int serve;
    const char *link, *device;
    long baud;
    enum rt_mode rt;
    const char *mock_trace;
};

static int parse_opts(int argc, char **argv, struct opts *o)
{
    memset(o, 0, sizeof *o);
    o->rt = RT_TRY;
    o->baud = 115200;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        int more = i + 1 < argc;
        if (!strcmp(a, "--board") && more)
            o->board = argv[++i];
        else if (!strcmp(a, "--config") && more)
            o->config = argv[++i];
        else if (!strcmp(a, "--realtime"))
            o->rt = RT_REQUIRE;
        else if (!strcmp(a, "--no-realtime"))
            o->rt = RT_OFF;
        else if (o->serve && !strcmp(a, "--link") && more)
            o->link = argv[++i];
        else if (o->serve && !strcmp(a, "--device") && more)
            o->device = argv[++i];
        else if (o->serve && !strcmp(a, "--baud") && more) {
            char *end;
            o->baud = strtol(argv[++i], &end, 10);
            if (*end != '\0' || o->baud < 1) {
                fprintf(stderr, "plotkin-gpiod: bad value for --baud: '%s'\n", argv[i]);
                return -1;
            }
        }
#ifdef PLOTKIN_GPIOD_MOCK
        else if (!strcmp(a, "--mock-trace") && more)
            o->mock_trace = argv[++i];
#endif
        else if (!strcmp(a, "serve") && !o->serve && o->file == NULL)
            o->serve = 1;
        else if (a[0] != '-' && !o->serve && o->file == NULL)
            o->file = a;
        else {
            fprintf(stderr, "plotkin-gpiod: unexpected '%s'\n", a);
            return -1;
        }
    }
    if (o->board == NULL || (!o->serve && o->file == NULL) ||
        (o->serve && (o->link != NULL) == (o->device != NULL))) {
        if (o->serve && o->link != NULL && o->device != NULL)
            fprintf(stderr, "plotkin-gpiod: serve takes --link or --device, not both\n");
        return -1;
    }
    return 0;
}

/* SCHED_FIFO + mlockall as o->rt asks. 0 to go on, -1 to refuse. */
static int realtime_setup(enum rt_mode rt)
{
    if (rt == RT_OFF)
        return 0;
    int se = 0, le = 0;
    if (pk_posix_realtime(&se, &le) == 0) {
        fprintf(stderr, "plotkin-gpiod: real time: SCHED_FIFO, memory locked\n");
        return 0;
    }
    char why[160];
    snprintf(why, sizeof why, "%s%s%s%s%s", se ? "SCHED_FIFO: " : "", se ? strerror(se) : "",
             se && le ? "; " : "", le ? "mlockall: " : "", le ? strerror(le) : "");
    if (rt == RT_REQUIRE) {
        fprintf(stderr, "plotkin-gpiod: --realtime: refused (%s); run as root or grant "
                        "CAP_SYS_NICE and CAP_IPC_LOCK\n", why);
        return -1;
    }
    fprintf(stderr, "plotkin-gpiod: note: no real-time %s (%s): step timing will jitter with the "
                    "system's load (root or CAP_SYS_NICE/CAP_IPC_LOCK fixes it; --realtime makes "
                    "it required, --no-realtime silences this)\n",
            se ? "scheduling" : "memory locking", why);
    return 0;
}

/* ---- the two modes ------------------------------------------------------------ */

/* Two callbacks never closer than the machine's step pulse ($0) or direction
 * set-up ($206), whichever is longer, plus one tick for the clock's
 * resolution, however late one ran (pk_posix_timer.h). Follows the machine's
 * configuration as it is now (a `$0=` applies from the next turn). */
static void edge_gap_follow(struct pk_posix_timer *timer, const struct pk_machine *m)
{
    uint32_t gap = m->cfg.step_pulse_ticks > m->cfg.dir_setup_ticks ? m->cfg.step_pulse_ticks
                                                                    : m->cfg.dir_setup_ticks;
    timer->min_gap_ticks = (uint64_t)gap + 1u;
}

/* The job's main-loop turn, busy only when it made progress (read input,
 * answered a line): pk_sim_job_main says "busy" all along a job, which would
 * keep the loop spinning (a SCHED_FIFO loop that never sleeps is throttled
 * by the kernel); idle, the loop still comes back within a millisecond. */
static int job_turn(void *arg, uint64_t now)
{
    struct pk_sim_job *j = arg;
    size_t pos0 = j->pos;
    unsigned long lines0 = j->lines;
    int r = pk_sim_job_main(arg, now);
    return r < 0 ? r : j->pos != pos0 || j->lines != lines0 ? 1 : 0;
}

/* Play a file (the job code of `plotkin sim`). Returns the exit status. */
static int play_file(struct pk_posix_timer *timer, const struct pk_hal *hal, struct pk_sim_cfg *mcfg,
                     const struct pk_motion_cfg *motion, char *prog, enum rt_mode rt)
{
    static struct pk_machine m;
    static struct pk_sim_job job;
    if (pk_machine_init(&m, motion, hal) != PK_MOTION_OK) {
        fprintf(stderr, "plotkin-gpiod: machine init failed: %s\n", pk_hal_error_text(hal));
        return 1;
    }
    if (realtime_setup(rt) != 0)
        return 1;
    edge_gap_follow(timer, &m);
    pk_sim_job_init(&job, &m, mcfg, prog, strlen(prog));
    int stopped = pk_posix_run(timer, job_turn, &job, &run_stop);
    if (stopped)
        (void)pk_machine_reset(&m);
    pk_steps_t pos[PK_AXES];
    pk_machine_position_steps(&m, pos);
    printf("plotkin-gpiod: %s: %lu lines, %lu errors, %lu alarms%s%s; position",
           stopped ? "stopped" : "done", job.lines, job.errors, job.alarms,
           job.alarms ? ": " : "", job.alarm_text);
    for (unsigned a = 0; a < mcfg->axes; a++)
        printf(" %ld", (long)pos[a]);
    printf(" steps; %u late step events; latest timer callback %llu ticks late; longest main "
           "turn %llu ticks\n",
           (unsigned)m.sg.late, (unsigned long long)timer->late_max,
           (unsigned long long)timer->main_max);
    int status = stopped || job.alarms || job.errors ? 1 : 0;
    pk_sim_job_free(&job);
    return status;
}

struct serve {
    struct pk_app app;
    struct pk_serve_port port;
    struct pk_posix_timer *timer;
    int io_errno;          /* the serial line failed (stops the server) */
    uint8_t in_alarm;      /* the machine's alarm was reported on stderr */
};

/* One turn of the board's main loop: the receive/transmit "interrupts"
 * (the serial pump), the engine and the machine (pk_app_poll). */
static int serve_main(void *arg, uint64_t now)
{
    struct serve *s = arg;
    (void)now;
    if (stop_requested)
        run_stop = 1;
    int rc = pk_serve_port_pump(&s->port, &s->app.uart);
    if (rc < 0) {
        s->io_errno = -rc;
        run_stop = 1;
        return 0;
    }
    if (rc & PK_SERVE_PORT_LEFT)
        pk_grbl_drop_partial_line(&s->app.g); /* before a byte of the next client */
    int woke = rc & PK_SERVE_PORT_RX;
    uint32_t lines0 = s->app.g.stats.lines;
    pk_app_poll(&s->app);
    edge_gap_follow(s->timer, &s->app.m);
    /* The sender sees Grbl's ALARM:N; the operator sees why (a GPIO failure,
     * a move on an axis with no lines, a limit switch). */
    int alarm = pk_machine_state(&s->app.m) == PK_STATE_ALARM;
    if (alarm && !s->in_alarm)
        fprintf(stderr, "plotkin-gpiod: alarm: %s\n", pk_hal_error_text(s->app.gm.hal));
    s->in_alarm = (uint8_t)alarm;
    if ((rc = pk_serial_pump(&s->port.ser, &s->app.uart)) < 0) {
        s->io_errno = -rc;
        run_stop = 1;
        return 0;
    }
    /* Busy (call again at once) while bytes arrive or lines are answered;
     * otherwise the loop comes back within a millisecond. */
    return woke || s->app.g.stats.lines != lines0 ? 1 : 0;
}

static const char *state_name(enum pk_machine_state st)
{
    switch (st) {
    case PK_STATE_RUN: return "Run";
    case PK_STATE_HOLDING: return "Hold:1";
    case PK_STATE_HOLD: return "Hold:0";
    case PK_STATE_ALARM: return "Alarm";
    default: return "Idle";
    }
}

static int serve(struct pk_posix_timer *timer, const struct pk_hal *hal, const struct pk_sim_cfg *mcfg,
                 const struct opts *o)
{
    static struct serve s;
    struct pk_grbl_settings set;
    char err[200];
    s.timer = timer;
    if (pk_sim_cfg_to_grbl(mcfg, &set, err, sizeof err) != 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", err);
        return 2;
    }
    if (pk_app_init_settings(&s.app, hal, &set) != 0) {
        fprintf(stderr, "plotkin-gpiod: the Grbl engine could not configure the machine: %s\n",
                pk_hal_error_text(hal));
        return 1;
    }
    int rc = pk_serve_port_open(&s.port, o->device, (uint32_t)o->baud, o->link, stderr);
    if (rc != 0) {
        fprintf(stderr, "plotkin-gpiod: %s: %s\n", o->device ? o->device : "pty", strerror(-rc));
        return 1;
    }
    if (realtime_setup(o->rt) != 0) {
        pk_serve_port_close(&s.port);
        return 1;
    }
    if (o->device)
        printf("plotkin-gpiod: Grbl 1.1 on %s at %ld baud\n", s.port.ser.path, o->baud);
    else
        printf("plotkin-gpiod: Grbl 1.1 on %s (link %s)\n", s.port.ser.path, o->link);
    fflush(stdout);
    edge_gap_follow(timer, &s.app.m);
    (void)pk_posix_run(timer, serve_main, &s, &run_stop);
    (void)pk_machine_reset(&s.app.m); /* stop the motion now, keep the position */
    pk_um_t um[PK_AXES];
    pk_steps_t st[PK_AXES];
    pk_machine_position_um(&s.app.m, um);
    pk_machine_position_steps(&s.app.m, st);
    const struct pk_grbl_stats *gs = &s.app.g.stats;
    printf("plotkin-gpiod: stopped%s%s\n", s.io_errno ? " (I/O error on the serial line: " : "",
           s.io_errno ? strerror(s.io_errno) : "");
    if (s.io_errno)
        printf(")\n");
    printf("  lines %u: %u ok, %u error; moves %u; soft resets %u\n", gs->lines, gs->ok, gs->errors,
           gs->moves, gs->resets);
    printf("  serial: %llu bytes in, %llu bytes out, %u bytes lost to overflow, %lu client "
           "connections\n",
           (unsigned long long)s.port.ser.rx_bytes, (unsigned long long)s.port.ser.tx_bytes,
           (unsigned)pk_uart_rx_dropped(&s.app.uart), s.port.connections);
    printf("  state %s, position", state_name(pk_machine_state(&s.app.m)));
    for (unsigned a = 0; a < PK_AXES; a++)
        printf(" %c%.3f", "XYZA"[a], um[a] / 1000.0);
    printf(" mm, steps");
    for (unsigned a = 0; a < PK_AXES; a++)
        printf(" %ld", (long)st[a]);
    /* late: step events the generator found a whole interval overdue (the
     * loop fell behind; the schedule moved instead of bunching steps). */
    printf("\n  timer: %u starts, %llu callbacks, %u late step events, latest callback %llu "
           "ticks late, longest main turn %llu ticks\n",
           timer->starts, (unsigned long long)timer->callbacks, (unsigned)s.app.m.sg.late,
           (unsigned long long)timer->late_max, (unsigned long long)timer->main_max);
    fflush(stdout);
    pk_serve_port_close(&s.port);
    return s.io_errno ? 1 : 0;
}

int main(int argc, char **argv)
{
    struct opts o;
    if (argc == 2 && (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h"))) {
        fputs(usage_text, stdout);
        return 0;
    }
    if (parse_opts(argc, argv, &o) != 0) {
        fputs(usage_text, stderr);
        return 2;
    }
    char err[200];
    static struct pk_gpiod_cfg bcfg;
    static struct pk_sim_cfg mcfg;
    pk_gpiod_cfg_init(&bcfg);
    pk_sim_cfg_default(&mcfg);
    char *text = slurp(o.board);
    if (text == NULL || pk_gpiod_cfg_parse(&bcfg, text, err, sizeof err) != PK_HAL_OK) {
        fprintf(stderr, "plotkin-gpiod: %s: %s\n", o.board, text ? err : strerror(errno));
        free(text);
        return 2;
    }
    free(text);
    if (o.config != NULL) {
        text = slurp(o.config);
        if (text == NULL || pk_sim_cfg_parse(&mcfg, text, err, sizeof err, stderr) != 0) {
            fprintf(stderr, "plotkin-gpiod: %s: %s\n", o.config, text ? err : strerror(errno));
            free(text);
            return 2;
        }
        free(text);
    }
    /* The machine drives the axes the board wires (a plotter: X Y + pen). */
    mcfg.axes = bcfg.axes < PK_AXES ? bcfg.axes : PK_AXES;
    if (mcfg.axes < 2u) {
        fprintf(stderr, "plotkin-gpiod: the board wires %u axis; plotkin needs 2 or more\n",
                (unsigned)bcfg.axes);
        return 2;
    }
    static struct pk_motion_cfg motion;
    if (pk_sim_cfg_motion(&mcfg, &motion, err, sizeof err) != 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", err);
        return 2;
    }
    char *prog = NULL;
    if (!o.serve) {
        prog = slurp(o.file);
        if (prog == NULL) {
            fprintf(stderr, "plotkin-gpiod: %s: %s\n", o.file, strerror(errno));
            return 2;
        }
        int is_poly = 0;
        char *g = pk_sim_polyline_to_gcode(prog, mcfg.polyline_feed, &is_poly);
        if (g != NULL) {
            free(prog);
            prog = g;
        }
    }

    static struct pk_posix_timer timer;
    static struct pk_gpiod gpio;
    struct pk_hal base, hal;
    pk_posix_timer_init(&timer, mcfg.tick_hz);
    pk_posix_timer_hal(&timer, &base);
#ifdef PLOTKIN_GPIOD_MOCK
    static struct pk_board_mock mock;
    if (pk_board_mock_attach(&mock, &bcfg, &timer, err, sizeof err) != 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", err);
        free(prog);
        return 1;
    }
    fprintf(stderr, "plotkin-gpiod: TEST BUILD: mock GPIO chip '%s' in memory, no pin is driven\n",
            bcfg.chip);
#endif
    pk_serve_port_signals(on_signal);
    int status;
    if (pk_gpiod_open(&gpio, &bcfg, &base, &hal) != PK_HAL_OK) {
        fprintf(stderr, "plotkin-gpiod: %s\n", pk_gpiod_error_text(&gpio));
        status = 1;
    } else {
        timer.irq_poll = edge_poll;
        timer.irq_arg = &gpio;
        status = o.serve ? serve(&timer, &hal, &mcfg, &o)
                         : play_file(&timer, &hal, &mcfg, &motion, prog, o.rt);
        if (edges_failed && status == 0)
            status = 1;
    }
    pk_gpiod_close(&gpio);
#ifdef PLOTKIN_GPIOD_MOCK
    if (pk_board_mock_finish(&mock, o.mock_trace, err, sizeof err) != 0) {
        fprintf(stderr, "plotkin-gpiod: %s\n", err);
        status = 1;
    }
#endif
    free(prog);
    return status;
}
